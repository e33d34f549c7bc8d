-- trajdb: the whole pipeline for the DuckDB CLI (extension loaded) or `trajdb run`, from the
-- repository root:
--
--   SET VARIABLE pipeline_input = 'points.parquet';   -- or a .csv file
--   SET VARIABLE merge_eta = 0.6;                      -- optional: any parameter of sql/params.sql
--   .read sql/pipeline.sql
--
-- 1 parameters (defaults for whatever you did not set), 2 load, 3 the stages of sql/stages.sql.
-- `trajdb pipeline --input FILE --out DIR` runs the same files and also writes the results
-- (sql/export.sql) and report.html.
.read sql/params.sql
CREATE OR REPLACE TEMP TABLE points AS
SELECT camera, track_id, class, t, x, y, estimated
FROM query_table(getvariable('pipeline_input'));
.read sql/stages.sql
