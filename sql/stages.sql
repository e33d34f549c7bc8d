-- trajdb: the pipeline's stages, in order: THE one list. `trajdb pipeline`, `trajdb demo` and
-- sql/pipeline.sql (the DuckDB CLI) all run exactly these files. Each reads `points` and the
-- tables of the stages before it; see the header of each file.
.read sql/stages/calibrate.sql
.read sql/stages/clean.sql
.read sql/stages/quality.sql
.read sql/stages/align.sql
.read sql/stages/overlap.sql
.read sql/stages/merge.sql
.read sql/stages/fuse.sql
.read sql/stages/cluster.sql
