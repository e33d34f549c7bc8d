-- trajdb: the whole pipeline for the DuckDB CLI (or `trajdb run sql/pipeline.sql`), from the
-- repository root:
--
--   SET VARIABLE pipeline_input = 'points.parquet';   -- or a .csv file
--   .read sql/pipeline.sql
--
-- Stages (each file holds its parameters as SET VARIABLE defaults at the top; set your own
-- values after the .read of a stage file to override, or use `trajdb pipeline --param`):
--   1 load, 2 clean, 3 tracks + quality (broken tracks linked), 4 align, 5 overlap,
--   6 match + 7 merge (merge.sql), 8 cluster.
CREATE OR REPLACE TEMP TABLE points AS
SELECT camera, track_id, class, t, x, y, estimated
FROM query_table(getvariable('pipeline_input'));
.read sql/clean.sql
.read sql/quality.sql
CREATE OR REPLACE TEMP TABLE points AS SELECT * FROM points_linked;
.read sql/align.sql
.read sql/overlap.sql
.read sql/merge.sql
.read sql/cluster.sql
