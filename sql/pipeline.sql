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
-- the input's types, before anything is read: numbers where numbers are needed
SELECT CASE WHEN count(*) > 0 THEN error('load: ' || string_agg('column ' || d.column_name || ' is ' || d.column_type || ', not ' || w.want, '; ' ORDER BY w.k)
    || ' (fix: cast it when you read the file, e.g. read_csv(''points.csv'', types = {''t'': ''DOUBLE''}), or map another column with input_columns'
    || '; camera and track ids that are text can be numbered with dense_rank() OVER (ORDER BY id))') END
FROM (DESCRIBE FROM query(getvariable('input_query'))) d
JOIN (VALUES (1, 'camera', 'an integer'), (2, 'track_id', 'an integer'), (3, 't', 'a number (seconds) or a TIMESTAMP'),
             (4, 'x', 'a number'), (5, 'y', 'a number'), (6, 'estimated', 'an integer or a BOOLEAN')) w(k, name, want)
  ON d.column_name = coalesce(getvariable('input_map')[w.name], w.name)
WHERE NOT (d.column_type IN ('TINYINT', 'SMALLINT', 'INTEGER', 'BIGINT', 'HUGEINT', 'UTINYINT', 'USMALLINT', 'UINTEGER', 'UBIGINT', 'UHUGEINT')
        OR (w.name IN ('t', 'x', 'y') AND (d.column_type IN ('FLOAT', 'DOUBLE') OR d.column_type LIKE 'DECIMAL%'))
        OR (w.name = 't' AND (d.column_type LIKE 'TIMESTAMP%' OR d.column_type = 'DATE'))
        OR (w.name = 'estimated' AND d.column_type = 'BOOLEAN'));
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
-- no rows, or rows the stages cannot use: a clear error, not an empty result
SELECT CASE WHEN n = 0 THEN error('load: the input ' || getvariable('pipeline_input') || ' has no rows')
            WHEN bad > 0 THEN error('load: ' || bad || ' of ' || n || ' rows have a NULL, NaN or infinite camera, track_id, class, t, x or y (the first: '
                                    || coalesce(first_bad, '?') || '); drop or fill them before the pipeline') END
FROM (SELECT count(*) AS n,
             count(*) FILTER (WHERE NOT coalesce(camera IS NOT NULL AND track_id IS NOT NULL AND class IS NOT NULL AND isfinite(t) AND isfinite(x) AND isfinite(y), false)) AS bad,
             first(format('camera {}, track_id {}, class {}, t {}, x {}, y {}', coalesce(camera::VARCHAR, 'NULL'), coalesce(track_id::VARCHAR, 'NULL'),
                        coalesce(class, 'NULL'), coalesce(t::VARCHAR, 'NULL'), coalesce(x::VARCHAR, 'NULL'), coalesce(y::VARCHAR, 'NULL')) ORDER BY camera, track_id, t)
                 FILTER (WHERE NOT coalesce(camera IS NOT NULL AND track_id IS NOT NULL AND class IS NOT NULL AND isfinite(t) AND isfinite(x) AND isfinite(y), false)) AS first_bad
      FROM points);
-- a track is (camera, track_id) whatever its class does: a classifier that flickers between
-- classes gets the track's majority class (ties: the first class name), and the flicker is
-- listed in load_class_flicker (camera, track_id, class kept, classes with their point counts)
CREATE OR REPLACE TEMP TABLE load_class_flicker AS
SELECT camera, track_id, first(class ORDER BY n DESC, class) AS class, list(class || ' ' || n ORDER BY n DESC, class) AS classes
FROM (SELECT camera, track_id, class, count(*) AS n FROM points GROUP BY ALL)
GROUP BY ALL HAVING count(*) > 1;
UPDATE points SET class = f.class FROM load_class_flicker f
WHERE points.camera = f.camera AND points.track_id = f.track_id AND points.class <> f.class;
.read sql/stages.sql
