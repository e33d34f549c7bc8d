-- trajdb: the report's gates (parameter report_gates; issue 39), checked once, before any stage.
-- In:  report_gates_in, the rows as given (the runner reads the parameter's file or table into it
--      first, so that a bad one fails in seconds, not after the pipeline; by hand: CREATE TEMP
--      TABLE report_gates_in AS FROM 'gates.csv' before .read sql/report.sql; none: no gates).
-- Out: report_gates(approach, x1, y1, x2, y2), read by sql/report.sql: the approaches the report
--      counts movements by (none: approaches found in the data).
CREATE TEMP TABLE IF NOT EXISTS report_gates_in AS SELECT NULL::VARCHAR AS approach, NULL::DOUBLE AS x1, NULL::DOUBLE AS y1, NULL::DOUBLE AS x2, NULL::DOUBLE AS y2 WHERE false;
-- the columns: approach and x1, y1, x2, y2, or approach and wkt
SET VARIABLE report_gates_checked = (
    SELECT CASE WHEN NOT list_contains(c, 'approach') OR NOT (list_has_all(c, ['x1', 'y1', 'x2', 'y2']) OR list_contains(c, 'wkt'))
                THEN error('report_gates: the gates need the columns approach, x1, y1, x2, y2 (metres in the results'' frame) or approach, wkt '
                           || '(LINESTRING (x1 y1, x2 y2)); ' || coalesce(nullif(getvariable('report_gates'), ''), 'report_gates_in')
                           || ' has ' || array_to_string(c, ', '))
                ELSE true END
    FROM (SELECT coalesce(list(lower(column_name)), []) AS c FROM duckdb_columns() WHERE database_name = 'temp' AND table_name = 'report_gates_in'));
CREATE OR REPLACE TEMP TABLE report_gates AS
WITH j AS (SELECT to_json(g) AS j FROM report_gates_in g),
v AS (SELECT j->>'approach' AS approach, TRY_CAST(j->>'x1' AS DOUBLE) AS x1, TRY_CAST(j->>'y1' AS DOUBLE) AS y1,
             TRY_CAST(j->>'x2' AS DOUBLE) AS x2, TRY_CAST(j->>'y2' AS DOUBLE) AS y2, j->>'wkt' AS wkt, left(j::VARCHAR, 200) AS row_text FROM j),
w AS (SELECT *, CASE WHEN regexp_matches(coalesce(wkt, ''), '^\s*LINESTRING\s*\(', 'i')
                     THEN list_transform(regexp_extract_all(wkt, '[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?'), lambda s: s::DOUBLE) END AS nums FROM v),
c AS (SELECT approach, row_text, coalesce(x1, CASE WHEN len(nums) = 4 THEN nums[1] END) AS x1, coalesce(y1, CASE WHEN len(nums) = 4 THEN nums[2] END) AS y1,
             coalesce(x2, CASE WHEN len(nums) = 4 THEN nums[3] END) AS x2, coalesce(y2, CASE WHEN len(nums) = 4 THEN nums[4] END) AS y2 FROM w)
SELECT CASE WHEN coalesce(trim(approach), '') = ''
            THEN error('report_gates: every gate needs an approach name (column approach); got ' || row_text)
            WHEN x1 IS NULL OR y1 IS NULL OR x2 IS NULL OR y2 IS NULL OR NOT (isfinite(x1) AND isfinite(y1) AND isfinite(x2) AND isfinite(y2))
            THEN error('report_gates: gate ' || approach || ' needs finite numbers x1, y1, x2, y2 (metres in the results'' frame) or a wkt '
                       || 'LINESTRING (x1 y1, x2 y2) with two points; got ' || row_text)
            ELSE approach END AS approach, x1, y1, x2, y2
FROM c;
-- a gates parameter that names no gates is a mistake, not a request for approaches from the data
SET VARIABLE report_gates_checked = (
    SELECT CASE WHEN coalesce(getvariable('report_gates'), '') <> '' AND count(*) = 0
                THEN error('report_gates: ' || getvariable('report_gates') || ' holds no gates (no rows); give one row per gate, or leave '
                           || 'report_gates out for approaches found in the data')
                ELSE true END
    FROM report_gates);
