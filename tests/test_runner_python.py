#!/usr/bin/env python3
"""The in-extension runner as a careless or hostile user meets it (issue 27): CALL trajdb_pipeline
interrupted mid-run keeps the earlier results and leaves no staging folder (the run goes one stage
per scan call); a manifest planted by hand never makes trajdb delete a file it did not write; a
result file the user replaced is never overwritten; the run leaves nothing in the caller's session.

usage: python3 tests/test_runner_python.py path/to/trajdb.duckdb_extension
"""
import os
import shutil
import sys
import tempfile
import threading
import time

import duckdb

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HEAD = "# trajdb results: the files below were written by trajdb and may be replaced by its next run into this folder\n"


def connect(ext):
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{os.path.abspath(ext)}'")
    return con


def results(out):
    return {f: (os.path.getmtime(os.path.join(out, f)), os.path.getsize(os.path.join(out, f))) for f in os.listdir(out) if not f.startswith(".")}


def main():
    ext = sys.argv[1]
    w = tempfile.mkdtemp(prefix="trajdb-runner-")
    con = connect(ext)
    inp = os.path.join(w, "points.parquet")
    # a scene long enough that an interrupt lands mid-run
    con.execute("FROM trajdb_simulate(?, cameras := 3, minutes := 4, seed := 5)", [os.path.join(w, "sim")]).fetchall()
    con.execute(f"COPY (FROM read_csv('{w}/sim/points.csv')) TO '{inp}' (FORMAT parquet)")
    out = os.path.join(w, "res")
    rows = con.execute("SELECT stage FROM trajdb_pipeline(?, out_dir := ?)", [inp, out]).fetchall()
    assert [r[0] for r in rows][-1] == "total" and os.path.exists(os.path.join(out, "merged.parquet")), rows
    assert con.execute("SELECT count(*) FROM duckdb_tables() WHERE table_name IN ('merged', 'points')").fetchall() == [(0,)]
    print("ok   CALL trajdb_pipeline: results written, nothing left in the session")

    t0 = time.time()
    con.execute("SELECT seconds FROM trajdb_pipeline(?, out_dir := ?) WHERE stage = 'total'", [inp, out]).fetchall()
    whole = time.time() - t0
    before = results(out)
    threading.Timer(min(0.5, whole / 4), con.interrupt).start()
    try:
        con.execute("FROM trajdb_pipeline(?, out_dir := ?)", [inp, out]).fetchall()
        interrupted = False
    except duckdb.InterruptException:
        interrupted = True
    if interrupted:
        after = results(out)
        assert after == before, (before, after)  # the same files, untouched (time and size)
        assert not [f for f in os.listdir(out) if f.startswith(".trajdb-partial")], os.listdir(out)
        con.execute("FROM trajdb_pipeline(?, out_dir := ?)", [inp, out]).fetchall()  # the folder is free again
        print(f"ok   an interrupted CALL (run of {whole:.1f} s) keeps the earlier results, leaves no staging folder, frees the folder")
    else:
        print(f"skip interrupt: the run ({whole:.1f} s) ended before the interrupt")

    # a planted manifest naming a file trajdb never writes deletes nothing
    planted = os.path.join(w, "planted")
    os.makedirs(planted)
    open(os.path.join(planted, "thesis.docx"), "w").write("mine")
    open(os.path.join(planted, ".trajdb-results"), "w").write(HEAD + "thesis.docx\n")
    try:
        con.execute("FROM trajdb_pipeline(?, out_dir := ?)", [inp, planted]).fetchall()
        raise SystemExit("FAIL: a planted manifest was trusted")
    except duckdb.Error as e:
        assert "earlier trajdb" in str(e), e  # an old-form manifest (no fingerprints) is never trusted
    assert open(os.path.join(planted, "thesis.docx")).read() == "mine"
    print("ok   a planted manifest naming thesis.docx is refused; the file stays")

    # a result file the user replaced is never overwritten
    time.sleep(0.05)
    open(os.path.join(out, "report.html"), "w").write("my own notes, saved over the report")
    try:
        con.execute("FROM trajdb_pipeline(?, out_dir := ?)", [inp, out]).fetchall()
        raise SystemExit("FAIL: a changed result file was overwritten")
    except duckdb.Error as e:
        assert "changed since trajdb wrote it" in str(e), e
    assert open(os.path.join(out, "report.html")).read() == "my own notes, saved over the report"
    print("ok   a result file the user changed is never replaced")

    # a table of the caller's database is not the private run's input: the error says what to do
    con.execute(f"CREATE TABLE my_points AS FROM '{inp}'")
    try:
        con.execute("FROM trajdb_pipeline('my_points', out_dir := ?)", [os.path.join(w, "t")]).fetchall()
        raise SystemExit("FAIL: a table input ran")
    except duckdb.Error as e:
        assert "reads files" in str(e) and "trajdb_stages" in str(e), e
    print("ok   a table input: the error says how to run it (trajdb_stages / trajdb.pipeline)")
    shutil.rmtree(w, ignore_errors=True)
    print("test_runner_python: OK (duckdb %s)" % duckdb.__version__)


if __name__ == "__main__":
    main()
