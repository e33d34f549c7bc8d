"""The real pipeline, up to a stage, for the benches (benches/accuracy_*.py).

The statements are the extension's manifest, `trajdb_stages(input, params := '{...}')` (the one
`CALL trajdb_pipeline` and python/trajdb's `pipeline` run): rows (k, stage, file, sql, makes,
undo, shared), stages params, load, calibrate, clean, quality, align, overlap, merge, fuse,
cluster, warnings, analysis. No SQL file is read from disk and no SQL text is edited here: a
parameter (`overlap_method='concave'`, `quality_max_gap=0.0`; `SELECT * FROM trajdb_params()`
lists them) goes to the manifest, which checks its name and value.

    from stages import run_stages
    seconds = run_stages(con, "points.parquet", "align")           # {'params': .., 'load': .., ..., 'align': ..}
    seconds = run_stages(con, "points.parquet", "overlap", overlap_method="concave")
"""
import json
import os
import time

import duckdb


def manifest(con, input, **params):
    """Every statement of one pipeline run, in order: [(k, stage, file, sql)] (fetched whole
    before anything runs). `input` as `trajdb pipeline` takes it (a Parquet / CSV path, a table
    name); a path is made absolute."""
    if isinstance(input, (str, os.PathLike)) and os.path.exists(input):
        input = os.path.abspath(input)
    for k, v in params.items():
        if hasattr(v, "item") and not isinstance(v, (str, bytes)):
            params[k] = v.item()  # a numpy scalar
    return con.execute("SELECT k, stage, file, sql FROM trajdb_stages(?, params := ?) ORDER BY k",
                       [os.fspath(input), json.dumps(params, allow_nan=False)]).fetchall()


def stage_order(rows):
    """The stages of a manifest in their order."""
    order = []
    for _, stage, _, _ in rows:
        if stage not in order:
            order.append(stage)
    return order


def run_stages(con, input, upto, **params):
    """Runs on `con`, in order of k, every statement of the manifest whose stage is 'params',
    'load' or any stage up to and including `upto` (manifest order), each result fetched so that
    DuckDB finishes it. Returns {stage: seconds} in the order the stages ran."""
    rows = manifest(con, input, **params)
    order = stage_order(rows)
    if upto not in order:
        raise ValueError(f"run_stages: no stage {upto!r}; the manifest's stages: {', '.join(order)}")
    wanted = {"params", "load"} | set(order[: order.index(upto) + 1])
    seconds = {}
    for k, stage, file, sql in rows:
        if stage not in wanted:
            continue
        t = time.perf_counter()
        try:
            con.execute(sql).fetchall()
        except duckdb.Error as e:
            if hasattr(e, "add_note"):
                head = " ".join(" ".join(l for l in sql.splitlines() if not l.lstrip().startswith("--")).split())[:160]
                e.add_note(f"run_stages: statement {k} of stage '{stage}' ({file}): {head} ...")
            raise
        seconds[stage] = seconds.get(stage, 0.0) + time.perf_counter() - t
    return seconds
