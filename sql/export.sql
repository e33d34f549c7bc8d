-- trajdb: the pipeline's result files, written into the directory getvariable('out_dir')
-- (`trajdb pipeline --out DIR` sets it; after `.read sql/pipeline.sql` in the DuckDB CLI:
-- SET VARIABLE out_dir = 'results'; .read sql/export.sql  -- the directory must exist).
-- What each file holds is defined once, by the stage that makes it: the table macros result_*()
-- at the end of sql/stages/align.sql, merge.sql and cluster.sql.

COPY (FROM result_transforms() ORDER BY cam_from, cam_to)
TO (getvariable('out_dir') || '/transforms.csv') (HEADER, DELIMITER ',');

COPY (FROM result_calibration() ORDER BY scope, quantity)
TO (getvariable('out_dir') || '/calibration.csv') (HEADER, DELIMITER ',');

COPY (FROM result_matches() ORDER BY camera_a, track_a, camera_b, track_b)
TO (getvariable('out_dir') || '/matches.csv') (HEADER, DELIMITER ',');

-- merged.parquet: GeoParquet 1.1. The local metric frame has no CRS ("crs": null is
-- GeoParquet's "undefined"; QGIS and GDAL open it as a plain XY layer). Checked: geopandas 1.2 /
-- shapely 2.2 and DuckDB spatial (1.5.5) read M from this file. python/trajdb/spark.py writes
-- the same metadata (it reads it from this statement).
COPY (FROM result_road_users() ORDER BY road_user)
TO (getvariable('out_dir') || '/merged.parquet')
(FORMAT parquet, KV_METADATA {geo: '{"version":"1.1.0","primary_column":"geometry","columns":{"geometry":{"encoding":"WKB","geometry_types":["LineString M","Point M"],"crs":null,"edges":"planar"}}}'});

COPY (FROM result_clusters() ORDER BY class, cluster, track_id)
TO (getvariable('out_dir') || '/clusters.csv') (HEADER, DELIMITER ',');

COPY (FROM result_links() ORDER BY camera, track_id)
TO (getvariable('out_dir') || '/links.csv') (HEADER, DELIMITER ',');

-- analysis.sql: the analysis macros (sql/analysis.sql: movements(), speeds(), conflicts(), ...)
-- over this folder's merged.parquet, for a session that did not run the pipeline itself (the
-- DuckDB CLI after CALL trajdb_pipeline, which leaves nothing in the session): `.read
-- results/analysis.sql`, then `FROM movements()`. The view `results_merged` (the macros' default
-- table there) reads getvariable('trajdb_results') || '/merged.parquet', by default the folder as the run was given
-- it (relative paths: from the same working folder). Written from the extension's own copy of
-- sql/analysis.sql (trajdb_script), so it needs no file of the repository.
COPY (SELECT '-- trajdb: the analysis macros over the results in this folder (docs/analysis.md). In the DuckDB CLI,' || chr(10)
             || '-- with the extension loaded: .read <this folder>/analysis.sql, then FROM movements();' || chr(10)
             || '-- another folder: SET VARIABLE trajdb_results = ''path/to/results''; first.' || chr(10)
             || 'CREATE OR REPLACE TEMP VIEW results_merged AS FROM read_parquet(coalesce(getvariable(''trajdb_results''), '
             || '''' || replace(coalesce(getvariable('trajdb_results_dir'), getvariable('out_dir'), '.'), '''', '''''') || ''') || ''/merged.parquet'');' || chr(10)
             -- the macros read results_merged unless told otherwise (a `merged` of the session, a
             -- pipeline's own table, stays what it is)
             || string_agg(replace(sql, 'tbl := ''merged''', 'tbl := ''results_merged''') || ';', chr(10) ORDER BY k) || chr(10)
      FROM trajdb_script('sql/analysis.sql'))
TO (getvariable('out_dir') || '/analysis.sql') (FORMAT csv, HEADER false, QUOTE '', ESCAPE '', DELIMITER chr(1));
-- (the folder as the runner named it is this run's only: a later manual export must not take it)
SET VARIABLE trajdb_results_dir = NULL;
