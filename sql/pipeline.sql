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
-- the input: a table or view of this database, or a file (Parquet, CSV, JSON; a path or glob).
-- It is resolved as exactly one of those and QUOTED, never pasted into SQL: a name that is a
-- table or view (as name, schema.name or catalog.schema.name, case-insensitive) becomes a
-- quoted identifier; anything else is a file path, a quoted string literal. A name is looked up
-- as DuckDB does (TEMP first, then the current catalog and schema), except that the pipeline's
-- own working table temp.points comes last (a second run on `points` reads the user's
-- main.points); a name found in two catalogs or schemas at the same rank is an error. query() with a
-- FROM string works in DuckDB 1.5 and 2.0 (query_table('file.parquet') is a table name in 1.5).
SET VARIABLE load_check = (SELECT CASE WHEN getvariable('pipeline_input') IS NULL OR trim(getvariable('pipeline_input')) = ''
            THEN error('load: the input is empty; SET VARIABLE pipeline_input = ''points.parquet'' (a file, a glob or a table name)') END);
SET VARIABLE input_query = (
    WITH relations AS (
        SELECT database_name, schema_name, table_name AS name, temporary FROM duckdb_tables()
        UNION ALL SELECT database_name, schema_name, view_name, temporary FROM duckdb_views() WHERE NOT internal),
    hits AS (
        -- DuckDB's own order for a name: a TEMP table or view (a registered DataFrame) first,
        -- then the current catalog and schema, then the rest; the pipeline's working table
        -- temp.points last (a user's points elsewhere wins over it)
        SELECT *, CASE WHEN temporary AND lower(name) = 'points' THEN 3
                       WHEN temporary THEN 0
                       WHEN database_name = current_database() AND schema_name = current_schema() THEN 1
                       ELSE 2 END AS rank
        FROM relations
        WHERE lower(getvariable('pipeline_input')) IN (lower(name), lower(schema_name || '.' || name), lower(database_name || '.' || name),
                                                       lower(database_name || '.' || schema_name || '.' || name))),
    hit AS (
        SELECT *, count(*) OVER (PARTITION BY rank) AS tied FROM hits QUALIFY rank = min(rank) OVER () ORDER BY database_name, schema_name LIMIT 1)
    SELECT 'FROM ' || coalesce(
        (SELECT CASE WHEN temporary AND lower(name) = 'points'
                     THEN error('load: the input ' || getvariable('pipeline_input') || ' is the pipeline''s own working table (temp.points); '
                                || 'give your table another name (the pipeline works in temp.points)')
                     WHEN tied > 1
                     THEN error('load: the input ' || getvariable('pipeline_input') || ' names ' || tied || ' tables or views in different catalogs or schemas; '
                                || 'write it as catalog.schema.name')
                     ELSE '"' || replace(database_name, '"', '""') || '"."' || replace(schema_name, '"', '""') || '"."' || replace(name, '"', '""') || '"' END
         FROM hit),
        '''' || replace(getvariable('pipeline_input'), '''', '''''') || ''''));
-- not a table: it must name at least one file (glob() reads no file and obeys enable_external_access)
-- (a table input globs nothing: a sandboxed connection, enable_external_access = false, still reads tables)
SET VARIABLE load_check = (SELECT CASE WHEN getvariable('input_query') LIKE 'FROM ''%'
             AND NOT EXISTS (FROM glob(CASE WHEN getvariable('input_query') LIKE 'FROM ''%' THEN [getvariable('pipeline_input')] ELSE []::VARCHAR[] END))
            THEN error('load: the input ' || getvariable('pipeline_input') || ' is neither a table or view of this database nor an existing file '
                       || '(fix: the path of a Parquet, CSV or JSON file, a glob such as ''data/*.parquet'', or a table name)') END);
-- the input's columns and types, described once (a CSV is sniffed once, not once per check)
CREATE OR REPLACE TEMP TABLE load_columns AS SELECT column_name, column_type FROM (DESCRIBE FROM query(getvariable('input_query')));
-- input_columns: 'role=column, ...' with roles camera, track_id, class, t, x, y, estimated, each
-- at most once and each onto its own column (names compared case-insensitively, as DuckDB does)
SET VARIABLE load_check = (SELECT CASE
    WHEN len(unknown) > 0 THEN error('load: input_columns names ' || array_to_string(unknown, ', ') || ', which is not a role; the roles are camera, track_id, class, t, x, y, estimated (e.g. ''camera=cam_id, t=time'')')
    WHEN len(roles) <> len(list_distinct(roles)) THEN error('load: input_columns gives a role twice: ' || getvariable('input_columns'))
    WHEN len(cols) <> len(list_distinct(cols)) THEN error('load: input_columns reads two roles from one column: ' || getvariable('input_columns'))
    WHEN list_contains(roles, '') OR list_contains(cols, '') THEN error('load: input_columns must be ''role=column, ...'', got ''' || getvariable('input_columns') || '''') END
FROM (SELECT [r for r in roles if NOT list_contains(['camera', 'track_id', 'class', 't', 'x', 'y', 'estimated'], r)] AS unknown, roles, cols
      FROM (SELECT [lower(trim(split_part(kv, '=', 1))) for kv in kvs] AS roles, [lower(trim(split_part(kv, '=', 2))) for kv in kvs] AS cols
            FROM (SELECT [kv for kv in string_split(coalesce(getvariable('input_columns'), ''), ',') if trim(kv) <> ''] AS kvs))));
SET VARIABLE input_map = map_from_entries(
    [(lower(trim(split_part(kv, '=', 1))), lower(trim(split_part(kv, '=', 2))))
     for kv in string_split(coalesce(getvariable('input_columns'), ''), ',') if trim(kv) <> '']);
SET VARIABLE load_check = (SELECT CASE WHEN len(eff) <> len(list_distinct(eff))
            THEN error('load: input_columns ''' || getvariable('input_columns') || ''' reads two roles from one column (roles read as: '
                       || array_to_string([r || '=' || coalesce(getvariable('input_map')[r], r) for r in ['camera', 'track_id', 'class', 't', 'x', 'y', 'estimated']], ', ') || ')') END
FROM (SELECT [coalesce(getvariable('input_map')[r], r) for r in ['camera', 'track_id', 'class', 't', 'x', 'y', 'estimated']] AS eff));
SET VARIABLE load_check = (SELECT CASE WHEN len(missing) > 0 THEN error('load: the input ' || getvariable('pipeline_input') || ' has no column '
                                               || array_to_string(missing, ', ') || ' (its columns: ' || array_to_string(cols, ', ') || '). '
                                               || 'Fix: map your own names with input_columns, e.g. input_columns = ''camera=cam_id, t=time'' '
                                               || '(trajdb pipeline --param "input_columns=camera=cam_id, t=time"; in SQL: SET VARIABLE input_columns = ''camera=cam_id, t=time'' '
                                               || 'or trajdb_pipeline(..., input_columns := ''camera=cam_id, t=time''))') END
FROM (SELECT cols, [coalesce(getvariable('input_map')[n], n) for n in ['camera', 'track_id', 'class', 't', 'x', 'y']
                    if NOT list_contains([lower(c) for c in cols], coalesce(getvariable('input_map')[n], n))
                       -- no class column: one class (below); a class that input_columns names must be there
                       AND (n <> 'class' OR getvariable('input_map')['class'] IS NOT NULL)] AS missing
      FROM (SELECT list(column_name) AS cols FROM load_columns)));
-- the input's types, before anything is read: numbers where numbers are needed; camera and
-- track ids may be integers or text ('north', 'trk-1738': VARCHAR, ENUM or UUID)
SET VARIABLE load_check = (SELECT CASE WHEN count(*) > 0 THEN error('load: ' || string_agg('column ' || d.column_name || ' is ' || d.column_type || ', not ' || w.want, '; ' ORDER BY w.k)
    || ' (fix: cast it when you read the file, e.g. read_csv(''points.csv'', types = {''t'': ''DOUBLE''}), or map another column with input_columns)') END
FROM load_columns d
JOIN (VALUES (1, 'camera', 'an integer or text'), (2, 'track_id', 'an integer or text'), (3, 't', 'a number (seconds) or a TIMESTAMP'),
             (4, 'x', 'a number'), (5, 'y', 'a number'), (6, 'estimated', 'an integer or a BOOLEAN')) w(k, name, want)
  ON lower(d.column_name) = coalesce(getvariable('input_map')[w.name], w.name)
WHERE NOT (d.column_type IN ('TINYINT', 'SMALLINT', 'INTEGER', 'BIGINT', 'HUGEINT', 'UTINYINT', 'USMALLINT', 'UINTEGER', 'UBIGINT', 'UHUGEINT')
        OR (w.name IN ('t', 'x', 'y') AND (d.column_type IN ('FLOAT', 'DOUBLE') OR d.column_type LIKE 'DECIMAL%'))
        OR (w.name = 't' AND d.column_type LIKE 'TIMESTAMP%')
        OR (w.name = 'estimated' AND d.column_type = 'BOOLEAN')
        OR (w.name IN ('camera', 'track_id') AND (d.column_type LIKE 'VARCHAR%' OR d.column_type LIKE 'ENUM(%' OR d.column_type = 'UUID'))));
-- what the input gave: text ids (numbered below, and given back as they came in every result:
-- table load_ids), no class column (then one class, 'unknown', and a note in pipeline_warnings)
SET VARIABLE load_id_types = (
    SELECT map_from_entries(list((w, d.column_type)))
    FROM load_columns d, (VALUES ('camera'), ('track_id')) v(w)
    WHERE lower(d.column_name) = coalesce(getvariable('input_map')[w], w));
SET VARIABLE load_text_ids = (SELECT coalesce(bool_or(NOT (v IN ('TINYINT', 'SMALLINT', 'INTEGER', 'BIGINT', 'HUGEINT', 'UTINYINT', 'USMALLINT', 'UINTEGER', 'UBIGINT', 'UHUGEINT'))), false)
                              FROM (SELECT unnest(map_values(getvariable('load_id_types'))) AS v));
SET VARIABLE load_no_class = NOT EXISTS (SELECT 1 FROM load_columns WHERE lower(column_name) = coalesce(getvariable('input_map')['class'], 'class'));
-- t: a TIMESTAMPTZ is an instant: its epoch seconds, whatever the session's TimeZone (a cast to
-- TIMESTAMP would go through it: 5 h early in New York, and an hour jump at a daylight-saving
-- change). The input is read through epoch() of that column (its name quoted as an
-- identifier), so that no other input type ever meets a TIMESTAMPTZ cast (DuckDB without ICU
-- has none). A TIMESTAMP without time zone is read as UTC.
-- Ids are read the same way: an integer id as INTEGER (camera) / BIGINT (track_id), a text id as
-- VARCHAR, so that `points` holds them as they came until they are numbered (end of the load).
SET VARIABLE input_t_type = (SELECT any_value(d.column_type) FROM load_columns d
                             WHERE lower(d.column_name) = coalesce(getvariable('input_map')['t'], 't'));
SET VARIABLE input_query = (
    SELECT 'SELECT * REPLACE (' || string_agg(CASE
               WHEN w = 't' THEN 'epoch(' || q || ') AS ' || q
               WHEN d.column_type IN ('TINYINT', 'SMALLINT', 'INTEGER', 'BIGINT', 'HUGEINT', 'UTINYINT', 'USMALLINT', 'UINTEGER', 'UBIGINT', 'UHUGEINT')
               THEN 'try_cast(' || q || ' AS ' || CASE WHEN w = 'camera' THEN 'INTEGER' ELSE 'BIGINT' END || ') AS ' || q
               ELSE q || '::VARCHAR AS ' || q END, ', ' ORDER BY w) || ') ' || getvariable('input_query')
    FROM (SELECT *, '"' || replace(column_name, '"', '""') || '"' AS q FROM load_columns) d, (VALUES ('camera'), ('track_id'), ('t')) v(w)
    WHERE lower(d.column_name) = coalesce(getvariable('input_map')[w], w)
      AND (w <> 't' OR getvariable('input_t_type') = 'TIMESTAMP WITH TIME ZONE'));
-- the input's columns by role (a table macro: the text-id numbering below reads the ids first)
CREATE OR REPLACE TEMP MACRO load_input() AS TABLE
SELECT COLUMNS(lambda c: lower(c) = coalesce(getvariable('input_map')['camera'], 'camera')) AS camera,
       COLUMNS(lambda c: lower(c) = coalesce(getvariable('input_map')['track_id'], 'track_id')) AS track_id,
       COLUMNS(lambda c: lower(c) = coalesce(getvariable('input_map')['class'], 'class')) AS class,
       COLUMNS(lambda c: lower(c) = coalesce(getvariable('input_map')['t'], 't')) AS t,
       COLUMNS(lambda c: lower(c) = coalesce(getvariable('input_map')['x'], 'x')) AS x,
       COLUMNS(lambda c: lower(c) = coalesce(getvariable('input_map')['y'], 'y')) AS y,
       COLUMNS(lambda c: lower(c) = coalesce(getvariable('input_map')['estimated'], 'estimated')) AS estimated
FROM (SELECT * FROM query(getvariable('input_query'))
      UNION ALL BY NAME SELECT NULL AS estimated, NULL AS class WHERE false);
-- ids: the stages work on integer ids. load_ids maps every track's ids as they came (camera_in,
-- track_in: INTEGER / BIGINT, or VARCHAR when the input's were text) to the ids of the stages
-- (camera INTEGER, track_id BIGINT), and the results map them back (the result_*() macros of the
-- stages), so 'north' / 'trk-1738' come back unchanged in every result file. Integer ids are
-- kept as they are; text ids are numbered 1, 2, ... in the order of the text (dense_rank; an
-- archive's days keep their site's camera numbers, load_camera_numbers), so
-- the numbering, and with it every result, does not depend on the order of the input's rows, and
-- ordering by the number is ordering by the text. Text ids: their distinct values are read
-- first (a second pass over the input's two id columns); integer ids: nothing is read here
-- (the filter is constant), and load_ids is filled from points below.
CREATE OR REPLACE TEMP TABLE load_ids AS
SELECT camera AS camera_in,
       CASE WHEN getvariable('load_id_types')['camera'] IN ('TINYINT', 'SMALLINT', 'INTEGER', 'BIGINT', 'HUGEINT', 'UTINYINT', 'USMALLINT', 'UINTEGER', 'UBIGINT', 'UHUGEINT')
            THEN try_cast(camera AS INTEGER)
            -- an archive's day: the site's numbers first (load_camera_numbers, set by the runner:
            -- crates/app/src/plan.rs), a camera the site has not seen after them
            ELSE coalesce(getvariable('load_camera_numbers')[camera::VARCHAR],
                          coalesce(list_max(map_values(getvariable('load_camera_numbers'))), 0)
                          + dense_rank() OVER (PARTITION BY getvariable('load_camera_numbers')[camera::VARCHAR] IS NULL ORDER BY camera))::INTEGER END AS camera,
       track_id AS track_in,
       CASE WHEN getvariable('load_id_types')['track_id'] IN ('TINYINT', 'SMALLINT', 'INTEGER', 'BIGINT', 'HUGEINT', 'UTINYINT', 'USMALLINT', 'UINTEGER', 'UBIGINT', 'UHUGEINT')
            THEN try_cast(track_id AS BIGINT) ELSE dense_rank() OVER (ORDER BY track_id) END AS track_id
FROM (SELECT DISTINCT camera, track_id FROM load_input()
      WHERE getvariable('load_text_ids') AND camera IS NOT NULL AND track_id IS NOT NULL);
-- the points; a text id is replaced by its number (a NULL id stays NULL: refused below)
CREATE OR REPLACE TEMP TABLE points AS
SELECT camera, track_id, CASE WHEN getvariable('load_no_class') THEN 'unknown' ELSE class::VARCHAR END AS class,
       coalesce(try_cast(t AS DOUBLE), epoch(try_cast(t AS TIMESTAMP))) AS t,
       x::DOUBLE AS x, y::DOUBLE AS y, coalesce(estimated::INTEGER, 0) AS estimated
FROM (SELECT try_cast(camera AS INTEGER) AS camera, try_cast(track_id AS BIGINT) AS track_id, class, t, x, y, estimated
      FROM load_input() WHERE NOT getvariable('load_text_ids')
      UNION ALL
      SELECT i.camera, i.track_id, p.class, p.t, p.x, p.y, p.estimated
      FROM load_input() p LEFT JOIN load_ids i ON i.camera_in = p.camera AND i.track_in = p.track_id
      WHERE getvariable('load_text_ids'));
-- no rows, or rows the stages cannot use: a clear error, not an empty result
-- (the first bad row is looked up only when there is one: a format() per row costs a second a day)
SET VARIABLE load_check = (SELECT CASE WHEN n = 0 THEN error('load: the input ' || getvariable('pipeline_input') || ' has no rows')
            WHEN bad > 0 THEN error('load: ' || bad || ' of ' || n || ' rows have a NULL, NaN or infinite camera, track_id, class, t, x or y, '
                                    || 'or a camera id beyond a 32-bit INTEGER or a track_id beyond BIGINT (shown as NULL; the first: '
                                    || coalesce((SELECT format('camera {}, track_id {}, class {}, t {}, x {}, y {}', coalesce(camera::VARCHAR, 'NULL'),
                                                               coalesce(track_id::VARCHAR, 'NULL'), coalesce(class, 'NULL'), coalesce(t::VARCHAR, 'NULL'),
                                                               coalesce(x::VARCHAR, 'NULL'), coalesce(y::VARCHAR, 'NULL'))
                                                 FROM points
                                                 WHERE NOT coalesce(camera IS NOT NULL AND track_id IS NOT NULL AND class IS NOT NULL AND isfinite(t) AND isfinite(x) AND isfinite(y), false)
                                                 ORDER BY camera, track_id, t LIMIT 1), '?')
                                    || '); drop or fill them before the pipeline, and renumber ids that do not fit '
                                    || 'with dense_rank() OVER (ORDER BY id)') END
FROM (SELECT count(*) AS n,
             count(*) FILTER (WHERE NOT coalesce(camera IS NOT NULL AND track_id IS NOT NULL AND class IS NOT NULL AND isfinite(t) AND isfinite(x) AND isfinite(y), false)) AS bad
      FROM points));
-- the class '*' names every class at once in the stages' per-class tables (view_polygons,
-- view_overlaps): a class of that name would be mixed with all the others
SET VARIABLE load_check = (SELECT CASE WHEN count(*) > 0
            THEN error('load: ' || count(*) || ' rows of the input ' || getvariable('pipeline_input') || ' have the class ''*'', which trajdb keeps for "every class" '
                       || '(fix: rename it when you read the input, e.g. SELECT * REPLACE (CASE WHEN class = ''*'' THEN ''any'' ELSE class END AS class) FROM ...)') END
FROM points WHERE class = '*');
-- only estimated points: nothing was observed (estimated <> 0 on every row)
SET VARIABLE load_check = (SELECT CASE WHEN count(*) FILTER (WHERE estimated = 0) = 0
            THEN error('load: every one of the ' || count(*) || ' rows of the input ' || getvariable('pipeline_input') || ' is estimated (estimated <> 0); '
                       || 'trajdb needs observed points (estimated = 0). If your column means something else, map another with input_columns, e.g. ''estimated=is_predicted''') END
FROM points);
-- exact repeats of (camera, track_id, t): a file loaded twice, a camera exported twice. Each
-- (camera, track_id, t) is kept once (the first by estimated, x, y, class), and the repeats are
-- counted in load_duplicates (the run's warnings say how many). Without this, a repeated
-- camera aligned nothing and a repeated input failed deep inside a stage.
CREATE OR REPLACE TEMP TABLE load_duplicates AS
-- (more than one distinct (x, y) is: x or y differ; min/max is a fraction of a DISTINCT aggregate's cost)
SELECT camera, track_id, t, count(*) - 1 AS repeats, min(x) <> max(x) OR min(y) <> max(y) AS conflicting
FROM points GROUP BY camera, track_id, t HAVING count(*) > 1;
DELETE FROM points WHERE rowid IN (
    SELECT rowid FROM points SEMI JOIN load_duplicates USING (camera, track_id, t)
    QUALIFY row_number() OVER (PARTITION BY camera, track_id, t ORDER BY estimated, x, y, class, rowid) > 1);
-- a 32-bit FLOAT t far from 0 has lost its sub-seconds (epoch seconds step by 128 s)
SET VARIABLE load_check = (SELECT CASE WHEN getvariable('input_t_type') = 'FLOAT' AND max(abs(t)) > 1e5
            THEN error(format('load: column t is FLOAT (32-bit): at {} its steps are {} s, too coarse for time stamps. Fix: store t as DOUBLE or a TIMESTAMP',
                              max(abs(t)), 2.0 ** (floor(log2(max(abs(t)))) - 23))) END
FROM points);
-- 32-bit FLOAT coordinates far from 0 have lost their centimetres (UTM y ~ 5.7e6 steps by 0.5 m)
SET VARIABLE input_float_xy = (SELECT coalesce(list(w ORDER BY w), []) FROM load_columns d, (VALUES ('x'), ('y')) v(w)
                               WHERE lower(d.column_name) = coalesce(getvariable('input_map')[w], w) AND d.column_type = 'FLOAT');
SET VARIABLE load_check = (SELECT CASE WHEN len(getvariable('input_float_xy')) > 0 AND greatest(max(abs(x)), max(abs(y))) > 1e4
            THEN error(format('load: columns x, y are FLOAT (32-bit): at {} their steps are {} m, too coarse for positions. Fix: store x, y as DOUBLE',
                              greatest(max(abs(x)), max(abs(y))), 2.0 ** (floor(log2(greatest(max(abs(x)), max(abs(y))))) - 23))) END
FROM points);
-- units: the sampling period and the speeds of road users are known to within a factor of a
-- few; times in milliseconds (1.7e12) or coordinates in millimetres give implausible ones (and,
-- left alone, 0 road users): a clear error naming the column and the unit it seems to be in.
-- Measured per track on the observed points of whole tracks (at most 2,000, drawn by a hash of
-- their ids: lag() over a row sample would measure the gaps between sampled rows, not between
-- samples): each track's median period and median speed of moving points; the input's are the
-- medians OVER TRACKS, so each track weighs the same whatever its length: a few absurd tracks
-- (three 30-hour tracks of a million points each) cannot move them, while a wrong unit (t in
-- milliseconds for every track) moves every track and is still refused. Tracks whose own values
-- are implausible are listed in load_unit_outliers (kept; the run's warnings name them).
CREATE OR REPLACE TEMP TABLE load_unit_tracks AS
SELECT camera, track_id, count(*) AS points, max(t) - min(t) AS span_s,
       median(dt) FILTER (WHERE dt > 0) AS period,
       median(sqrt(dx * dx + dy * dy) / dt) FILTER (WHERE dt > 0 AND sqrt(dx * dx + dy * dy) > 0) AS speed
FROM (SELECT camera, track_id, t, t - lag(t) OVER w AS dt, x - lag(x) OVER w AS dx, y - lag(y) OVER w AS dy
      FROM points WHERE estimated = 0 AND hash(camera, track_id) % greatest(1, (SELECT count(DISTINCT (camera, track_id)) FROM points) // 2000) = 0
      WINDOW w AS (PARTITION BY camera, track_id ORDER BY t))
GROUP BY camera, track_id;
SET VARIABLE load_check = (SELECT CASE
    WHEN period > 20 THEN error(format('load: column t looks like {} rather than seconds: the median time between a track''s points is {} '
        || '(road-user cameras sample every 0.01-2 s). Fix: give t in seconds, e.g. a view with t / {} AS t, or a TIMESTAMP',
        CASE WHEN period > 2e4 THEN 'microseconds' ELSE 'milliseconds' END, round(period, 3), CASE WHEN period > 2e4 THEN '1e6' ELSE '1000' END))
    WHEN speed > 150 THEN error(format('load: columns x, y do not look like metres: the median speed of moving points is {} units/s, and road '
        || 'users move at 0.5-40 m/s. In millimetres, x / 1000 gives {} m/s; in centimetres, x / 100 gives {} m/s. Fix: give x, y in metres '
        || '(e.g. a view with x / 1000 AS x, y / 1000 AS y)', round(speed, 1), round(speed / 1000, 2), round(speed / 100, 2)))
    WHEN speed < 0.02 THEN error(format('load: the median speed of moving points is {} m/s, too slow for road users (0.5-40 m/s): t may be in '
        || 'milliseconds (median period {} units) or x, y in kilometres. Fix: give t in seconds and x, y in metres', speed, round(period, 4)))
    END
FROM (SELECT median(period) AS period, median(speed) AS speed FROM load_unit_tracks));
-- the tracks measured above whose own period or speed is outside what the check accepts for
-- the input (kept: a parked car may crawl, a track may be sparse; named in the warnings)
CREATE OR REPLACE TEMP TABLE load_unit_outliers AS
SELECT camera, track_id, points, span_s, period, speed,
       CASE WHEN period > 20 THEN 'median period ' || round(period, 1) || ' s'
            WHEN speed > 150 THEN 'median speed ' || round(speed, 1) || ' m/s'
            ELSE 'median speed ' || round(speed, 4) || ' m/s' END AS why
FROM load_unit_tracks WHERE period > 20 OR speed > 150 OR speed < 0.02;
-- a track is (camera, track_id) whatever its class does: a classifier that flickers between
-- classes gets the track's majority class (ties: the first class name), and the flicker is
-- listed in load_class_flicker (camera, track_id, class kept, classes with their point counts)
CREATE OR REPLACE TEMP TABLE load_class_flicker AS
SELECT camera, track_id, first(class ORDER BY n DESC, class) AS class, list(class || ' ' || n ORDER BY n DESC, class) AS classes
FROM (SELECT camera, track_id, class, count(*) AS n FROM points GROUP BY ALL)
GROUP BY ALL HAVING count(*) > 1;
UPDATE points SET class = f.class FROM load_class_flicker f
WHERE points.camera = f.camera AND points.track_id = f.track_id AND points.class <> f.class;
-- integer ids: load_ids maps each track's ids to themselves
INSERT INTO load_ids SELECT DISTINCT camera, camera, track_id, track_id FROM points WHERE NOT getvariable('load_text_ids');
-- a camera exported twice under another id: its twin aligned with it at 0 deg, 0 m, 0 s, pulled
-- the other cameras' calibration and doubled every road user it saw. Evidence (SQL's join): each
-- camera's points in cells of 0.1 mm of its own frame (cells a camera fills once: a standing road
-- user's repeats are left out, so no cell pairs many points with many); for each camera pair the
-- most cells both fill at ONE time difference (rounded to the microsecond: 0 for a plain copy, a
-- constant for a copy with a shifted clock). The decision is camera_twin's (crates/algo/src/align/
-- twin.rs: share of the smaller camera's points >= 0.5; real camera pairs measure 0, a copy 1).
-- Detected: identical, subset and clock-shifted copies, whatever their track ids; not: a copy with
-- its frame moved, noise added or other sample times (it is aligned as a camera of its own).
-- Each pair is oriented by the data (more points first; the camera id only between two cameras of
-- equal counts, i.e. identical copies, where either choice gives the same road users), and the
-- copy's points are left out of everything after the load (alignment, matching, merging), so no
-- road user is doubled; load_twins lists them and the run warns, naming both cameras.
CREATE OR REPLACE TEMP TABLE load_twins AS
WITH cells AS (
    SELECT camera, round(x * 1e4) AS cx, round(y * 1e4) AS cy, any_value(t) AS t
    FROM points GROUP BY camera, cx, cy HAVING count(*) = 1
),
n AS (SELECT camera, count(*) AS n FROM cells GROUP BY camera),
pairs AS (
    SELECT a.camera AS cam_a, b.camera AS cam_b, a.n AS n_a, b.n AS n_b
    FROM n a JOIN n b ON a.n > b.n OR (a.n = b.n AND a.camera < b.camera)
),
co AS (
    SELECT cam_a, cam_b, max(shared) AS shared, arg_min(dt_us, (-shared, abs(dt_us), dt_us)) / 1e6 AS dt_s
    FROM (SELECT p.cam_a, p.cam_b, round((b.t - a.t) * 1e6) AS dt_us, count(*) AS shared
          FROM pairs p JOIN cells a ON a.camera = p.cam_a JOIN cells b ON b.camera = p.cam_b AND b.cx = a.cx AND b.cy = a.cy
          GROUP BY ALL)
    GROUP BY ALL
)
SELECT CASE WHEN v.copy = 2 THEN p.cam_a ELSE p.cam_b END AS camera_kept, CASE WHEN v.copy = 2 THEN p.cam_b ELSE p.cam_a END AS camera_dropped,
       v.share, co.dt_s AS time_difference_s, p.n_a, p.n_b
FROM pairs p JOIN co USING (cam_a, cam_b), LATERAL (SELECT camera_twin(p.n_a, p.n_b, co.shared) AS v) x
WHERE v.twin;
DELETE FROM points WHERE camera IN (SELECT camera_dropped FROM load_twins);
.read sql/stages.sql
