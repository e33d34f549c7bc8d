-- trajdb simulate: the points.csv that trajdb_simulate wrote, as points.parquet typed as the shared
-- scenarios (../shared/data/README.md: camera INTEGER, track_id BIGINT, class VARCHAR, t, x, y,
-- speed DOUBLE, estimated INTEGER). Set the variables trajdb_sim_csv and trajdb_sim_parquet (the
-- two paths) first; trajdb.simulate (python/trajdb/__init__.py) does, inside its claim of the folder.
-- reads: trajdb_sim_csv, trajdb_sim_parquet (variables)   writes: points.parquet
COPY (SELECT camera::INTEGER AS camera, track_id::BIGINT AS track_id, class::VARCHAR AS class, t::DOUBLE AS t,
             x::DOUBLE AS x, y::DOUBLE AS y, speed::DOUBLE AS speed, estimated::INTEGER AS estimated
      FROM read_csv(getvariable('trajdb_sim_csv'), header = true))
TO (getvariable('trajdb_sim_parquet')) (FORMAT parquet);
