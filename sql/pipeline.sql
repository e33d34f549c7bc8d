-- trajdb: the whole pipeline for the DuckDB CLI (extension loaded) or `trajdb run`, from the
-- repository root:
--
--   SET VARIABLE pipeline_input = 'points.parquet';   -- or a .csv file
--   SET VARIABLE merge_eta = 0.6;                      -- optional: any parameter of sql/params.sql
--   .read sql/pipeline.sql
--
-- 1 parameters (defaults for whatever you did not set), 2 load, 3 the stages of sql/stages.sql.
-- `trajdb pipeline --input FILE --out DIR` runs the same files and also writes the results
-- (sql/export.sql) and report.html (sql/report.sql); in the CLI afterwards:
--   SET VARIABLE out_dir = 'results'; .read sql/export.sql; .read sql/report.sql
.read sql/params.sql
-- load: the input's columns by name (input_columns maps yours: 'camera=cam_id, t=time'); t may
-- be seconds (any number) or a TIMESTAMP / TIMESTAMPTZ (then epoch seconds); estimated may be
-- absent (then every point is real).
-- the input: a file (Parquet, CSV, JSON; a path or glob) or a table name. query() with a FROM
-- string works in DuckDB 1.5 and 2.0 (query_table('file.parquet') is a table name in 1.5).
SET VARIABLE input_query = 'FROM ' || CASE
    WHEN regexp_matches(getvariable('pipeline_input'), '(\.(parquet|csv|tsv|txt|json|jsonl|ndjson|gz|zst)$)|[/\\*]')
    THEN '''' || replace(getvariable('pipeline_input'), '''', '''''') || ''''
    ELSE getvariable('pipeline_input') END;
SET VARIABLE input_map = map_from_entries(
    [(trim(split_part(kv, '=', 1)), trim(split_part(kv, '=', 2)))
     for kv in string_split(coalesce(getvariable('input_columns'), ''), ',') if trim(kv) <> '']);
SELECT CASE WHEN len(missing) > 0 THEN error('load: the input ' || getvariable('pipeline_input') || ' has no column '
                                               || array_to_string(missing, ', ') || ' (its columns: ' || array_to_string(cols, ', ') || ')') END
FROM (SELECT cols, [coalesce(getvariable('input_map')[n], n) for n in ['camera', 'track_id', 'class', 't', 'x', 'y']
                    if NOT list_contains(cols, coalesce(getvariable('input_map')[n], n))] AS missing
      FROM (SELECT list(column_name) AS cols FROM (DESCRIBE FROM query(getvariable('input_query')))));
CREATE OR REPLACE TEMP TABLE points AS
SELECT camera::INTEGER AS camera, track_id::BIGINT AS track_id, class::VARCHAR AS class,
       coalesce(try_cast(t AS DOUBLE), epoch(try_cast(t AS TIMESTAMP))) AS t,
       x::DOUBLE AS x, y::DOUBLE AS y, coalesce(estimated::INTEGER, 0) AS estimated
FROM (SELECT COLUMNS(lambda c: c = coalesce(getvariable('input_map')['camera'], 'camera')) AS camera,
             COLUMNS(lambda c: c = coalesce(getvariable('input_map')['track_id'], 'track_id')) AS track_id,
             COLUMNS(lambda c: c = coalesce(getvariable('input_map')['class'], 'class')) AS class,
             COLUMNS(lambda c: c = coalesce(getvariable('input_map')['t'], 't')) AS t,
             COLUMNS(lambda c: c = coalesce(getvariable('input_map')['x'], 'x')) AS x,
             COLUMNS(lambda c: c = coalesce(getvariable('input_map')['y'], 'y')) AS y,
             COLUMNS(lambda c: c = coalesce(getvariable('input_map')['estimated'], 'estimated')) AS estimated
      FROM (SELECT * FROM query(getvariable('input_query'))
            UNION ALL BY NAME SELECT NULL AS estimated WHERE false));
.read sql/stages.sql
