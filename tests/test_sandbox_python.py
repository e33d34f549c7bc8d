#!/usr/bin/env python3
"""Never lose a user's file, never abort the host: the table functions and trajdb_set_limit through
the loadable extension in PyPI DuckDB.

- NULL, '' and wrong types to every table function (found in trajdb_functions()): each call, in
  a child process, returns rows or raises a clear error; the child (the host) must survive
  (`FROM trajdb_simulate(NULL)` used to abort it: "Rust cannot catch foreign exceptions");
- the sandbox: with SET enable_external_access = false (which refuses COPY ... TO),
  trajdb_simulate writes nothing, except inside allowed_directories; '..' cannot leave them;
- overwrites: a folder holding a user's file is refused and the file is untouched; a rerun
  replaces trajdb's own earlier scenario; '' and a file in place of the folder are refused;
- limits per database: two databases in one process (two duckdb.connect()) do not see each
  other's trajdb_set_limit; the cursors of one database share its limits, also in worker threads;
- the caller's own file system (issue 37): `disabled_filesystems` (which DuckDB 2.0.1 reports as
  '' to an extension), with and without lock_configuration, refuses trajdb_pipeline,
  trajdb_simulate and trajdb_results_begin/end; an input the caller may not read is never read
  (its rows never quoted); NUL bytes in paths and parameters are refused, never cut;
- the extension keeps no connection of its own: a database file closed in this process opens
  in another process.

usage: python3 tests/test_sandbox_python.py path/to/trajdb.duckdb_extension
Exits non-zero when a check fails.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

import duckdb

FAILED = []


def check(name, cond, detail=""):
    print(f"{'ok  ' if cond else 'FAIL'} {name}" + (f": {detail}" if detail and not cond else ""))
    if not cond:
        FAILED.append(name)


def connect(ext, path=":memory:"):
    con = duckdb.connect(path, config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    return con


def error_of(con, sql, params=None):
    """The error message of `sql`, or None when it runs."""
    try:
        con.execute(sql, params or []).fetchall()
        return None
    except duckdb.Error as e:
        return str(e)


def listing(d):
    return sorted(os.listdir(d)) if os.path.isdir(d) else None


# ---------------------------------------------------------------- NULL / bad arguments
CHILD = r"""
import sys, duckdb
ext, calls = sys.argv[1], sys.argv[2:]
con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
con.execute(f"LOAD '{ext}'")
for sql in calls:
    print("CALL", sql, flush=True)
    try:
        n = len(con.execute(sql).fetchall())
        print("ROWS", n, flush=True)
    except duckdb.Error as e:
        print("ERROR", type(e).__name__, str(e).replace("\n", " "), flush=True)
    con.execute("SELECT 1").fetchall()  # the connection still works
print("DONE", flush=True)
"""


def parse_signature(sig):
    """'f(a VARCHAR, b := BIGINT) -> TABLE(...)' -> (name, [(a, VARCHAR)], [(b, BIGINT)])."""
    m = re.match(r"(\w+)\((.*?)\) -> TABLE\(", sig)
    name, inner = m.group(1), m.group(2)
    pos, named = [], []
    for part in [p.strip() for p in inner.split(",") if p.strip()]:
        if ":=" in part:
            n, t = [x.strip() for x in part.split(":=")]
            named.append((n, t))
        else:
            n, t = part.split(None, 1)
            pos.append((n, t))
    return name, pos, named


# seconds one child may take for all its calls (each valid call is small)
CALL_TIMEOUT = 60
# the children's address space: a call that allocates without bound fails there, not the machine
CHILD_MEMORY = 4 << 30


def limit_memory():
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (CHILD_MEMORY, CHILD_MEMORY))

# named arguments that keep the valid part of a call small
SMALL = {"trajdb_simulate": {"minutes": "0.1"}}


def bad_calls(name, pos, named, scratch):
    """Calls with NULL, '' and wrong types in every argument, the other arguments valid."""
    counter = iter(range(10**6))
    wrong = {"VARCHAR": "[1, 2]", "BIGINT": "'x'", "DOUBLE": "'x'", "BOOLEAN": "'x'"}

    def good(t):
        return {"VARCHAR": f"'{scratch}/{name}-{next(counter)}'", "BIGINT": "1", "DOUBLE": "0.1", "BOOLEAN": "true"}.get(t, "NULL")

    def call(args, tested=None):
        extra = [f"{n} := {v}" for n, v in SMALL.get(name, {}).items() if n != tested]
        return f"FROM {name}({', '.join(args + extra)})"

    calls = [f"FROM {name}(NULL)", f"FROM {name}(NULL, NULL)", f"FROM {name}('')"]
    for k, (_, t) in enumerate(pos):
        for v in ["NULL", f"NULL::{t}", "''", "'   '", wrong.get(t, "42")]:
            calls.append(call([good(u) for _, u in pos[:k]] + [v] + [good(u) for _, u in pos[k + 1:]]))
    for n, t in named:
        for v in ["NULL", f"NULL::{t}", "''", wrong.get(t, "42"), "'nan'::DOUBLE", "'inf'::DOUBLE", "-1", "0", "1e300"]:
            calls.append(call([good(u) for _, u in pos] + [f"{n} := {v}"], tested=n))
    return calls


def test_bad_arguments(ext, scratch):
    con = connect(ext)
    tables = [r[0] for r in con.execute("SELECT signatures FROM trajdb_functions() WHERE signatures LIKE '%-> TABLE(%'").fetchall()]
    check("table functions found", len(tables) >= 2, str(tables))
    for sig in tables:
        name, pos, named = parse_signature(sig)
        calls = bad_calls(name, pos, named, scratch)
        lines, died, hung, todo = [], [], [], list(calls)
        while todo:
            # one child runs the calls in turn; a call that kills it or does not come back is
            # recorded, and a new child goes on with the next one
            try:
                out = subprocess.run([sys.executable, "-c", CHILD, ext] + todo, capture_output=True, text=True, timeout=CALL_TIMEOUT,
                                     preexec_fn=limit_memory)
                got, rc, timed_out = out.stdout.splitlines(), out.returncode, False
            except subprocess.TimeoutExpired as e:
                got, rc, timed_out = (e.stdout or b"").decode(errors="replace").splitlines(), None, True
            lines += got
            if got and got[-1] == "DONE":
                break
            last = next((l[len("CALL "):] for l in reversed(got) if l.startswith("CALL ")), todo[0])
            (hung if timed_out else died).append(f"{last} (exit {rc})")
            todo = todo[todo.index(last) + 1:] if last in todo else todo[1:]
        check(f"{name}: {len(calls)} calls with NULL / '' / wrong / extreme values, the host survives", not died, "; ".join(died[:3]))
        check(f"{name}: every call comes back within {CALL_TIMEOUT} s", not hung, "; ".join(hung[:3]))
        errors = [l for l in lines if l.startswith("ERROR")]
        internal = [l for l in errors if "INTERNAL" in l.upper() or "panicked" in l]
        check(f"{name}: no INTERNAL error or panic", not internal, "; ".join(internal[:3]))
        # errors raised by trajdb name the function; DuckDB's own binder errors quote the call
        unclear = [l for l in errors if name not in l]
        check(f"{name}: every error names the function", not unclear, "; ".join(unclear[:3]))
    # the reported abort, explicitly, and the named NULL
    msg = error_of(con, "FROM trajdb_simulate(NULL)") or ""
    check("trajdb_simulate(NULL): dir is NULL", "trajdb_simulate: dir is NULL" in msg, msg)
    msg = error_of(con, f"FROM trajdb_simulate('{scratch}/named-null', cameras := NULL)") or ""
    check("cameras := NULL is an error naming it", "cameras := NULL" in msg and not os.path.exists(f"{scratch}/named-null"), msg)
    con.close()


# ---------------------------------------------------------------- sandbox
def test_sandbox(ext, scratch):
    con = connect(ext)
    ok_dir = os.path.join(scratch, "allowed")
    os.makedirs(ok_dir)
    con.execute("SET allowed_directories = [?]", [ok_dir])
    con.execute("SET enable_external_access = false")
    copy = error_of(con, f"COPY (SELECT 1) TO '{scratch}/copy.csv'")
    check("sandbox: COPY TO is refused (DuckDB's own rule)", copy is not None and not os.path.exists(f"{scratch}/copy.csv"), str(copy))
    target = os.path.join(scratch, "sandboxed")
    msg = error_of(con, "FROM trajdb_simulate(?, minutes := 0.1)", [target]) or ""
    check("sandbox: trajdb_simulate is refused and creates nothing",
          "enable_external_access is false" in msg and not os.path.exists(target), msg)
    for escape in [os.path.join(ok_dir, "..", "escaped"), os.path.join(ok_dir, "new", "..", "..", "escaped")]:
        msg = error_of(con, "FROM trajdb_simulate(?, minutes := 0.1)", [escape]) or ""
        check(f"sandbox: '..' out of allowed_directories is refused ({escape[len(scratch) + 1:]})",
              "trajdb_simulate: " in msg and not os.path.exists(os.path.join(scratch, "escaped")), msg)
    inside = os.path.join(ok_dir, "sim")
    msg = error_of(con, "FROM trajdb_simulate(?, minutes := 0.1)", [inside])
    check("sandbox: inside allowed_directories it writes", msg is None and os.path.exists(os.path.join(inside, "points.csv")), str(msg))
    # another connection (cursor) to the same database is sandboxed too: the setting is global
    msg = error_of(con.cursor(), "FROM trajdb_simulate(?, minutes := 0.1)", [target]) or ""
    check("sandbox: a second cursor of the database is refused as well", "enable_external_access is false" in msg, msg)
    con.close()
    # another database in the process is not sandboxed
    other = connect(ext)
    msg = error_of(other, "FROM trajdb_simulate(?, minutes := 0.1)", [os.path.join(scratch, "free")])
    check("sandbox: another database of the process still writes", msg is None, str(msg))
    other.close()


# ---------------------------------------------------------------- the caller's own file system
def test_caller_file_system(ext, scratch):
    """Issue 37 HIGH 1: settings DuckDB does not report (disabled_filesystems reads '' in 2.0.1)
    still bind trajdb, because every path goes through the caller's own file system first; the
    private database of trajdb_pipeline may then touch only what that file system allowed.
    And NUL bytes: a path is read whole, never cut at the NUL."""
    secret = os.path.join(scratch, "secret.csv")
    with open(secret, "w") as f:
        f.write("camera,track_id,class,t,x,y\n1,1,TOP-SECRET-KEY-123,0,0,0\n1,1,TOP-SECRET-KEY-123,1,1,1\n")
    for lock in (False, True):
        con = connect(ext)
        con.execute("SET disabled_filesystems = 'LocalFileSystem'")
        if lock:
            con.execute("SET lock_configuration = true")
        tag = " (lock_configuration)" if lock else ""
        out = os.path.join(scratch, f"out-{lock}")
        msg = error_of(con, "CALL trajdb_pipeline(?, out_dir := ?)", [secret, out]) or ""
        check("disabled_filesystems: trajdb_pipeline is refused, reads and writes nothing" + tag,
              "disabled by configuration" in msg and "TOP-SECRET" not in msg and not os.path.exists(out), msg)
        sim = os.path.join(scratch, f"sim-{lock}")
        msg = error_of(con, "FROM trajdb_simulate(?, minutes := 0.1)", [sim]) or ""
        check("disabled_filesystems: trajdb_simulate is refused and creates nothing" + tag,
              "disabled by configuration" in msg and not os.path.exists(sim), msg)
        rb = os.path.join(scratch, f"rb-{lock}")
        msg = error_of(con, "FROM trajdb_results_begin(?, 'points.parquet')", [rb]) or ""
        check("disabled_filesystems: trajdb_results_begin is refused and creates nothing" + tag,
              "disabled by configuration" in msg and not os.path.exists(rb), msg)
        msg = error_of(con, "FROM trajdb_results_end(?, false)", [rb]) or ""
        check("disabled_filesystems: trajdb_results_end is refused" + tag, "disabled by configuration" in msg, msg)
        con.close()
    # writing allowed, reading the input not: the input is never opened, its rows never quoted
    allowed = os.path.join(scratch, "allowed")
    os.makedirs(allowed)
    con = connect(ext)
    con.execute("SET allowed_directories = [?]", [allowed + "/"])
    con.execute("SET enable_external_access = false")
    out = os.path.join(allowed, "out")
    msg = error_of(con, "CALL trajdb_pipeline(?, out_dir := ?)", [secret, out]) or ""
    check("sandbox: an input outside allowed_directories is refused before it is read",
          "cannot read" in msg and "TOP-SECRET" not in msg and not os.path.exists(out), msg)
    # a glob reaching outside is refused before it is listed
    msg = error_of(con, "CALL trajdb_pipeline(?, out_dir := ?)", [os.path.join(scratch, "*.csv"), out]) or ""
    check("sandbox: a glob outside allowed_directories is refused", "cannot read" in msg and "TOP-SECRET" not in msg, msg)
    # inside: a scenario and a run, both in the allowed folder, work (the private database's
    # allow-list holds the input and the results folder)
    sim = os.path.join(allowed, "sim")
    msg = error_of(con, "FROM trajdb_simulate(?, minutes := 0.3)", [sim])
    check("sandbox: trajdb_simulate inside allowed_directories works", msg is None, str(msg))
    msg = error_of(con, "CALL trajdb_pipeline(?, out_dir := ?)", [os.path.join(sim, "poin*.csv"), out])
    check("sandbox: trajdb_pipeline from and into allowed_directories works (a glob input)",
          msg is None and os.path.exists(os.path.join(out, "merged.parquet")), str(msg))
    # the report's gates (issue 39) are a file the run reads: outside allowed_directories refused
    # before it is read; inside, read and drawn
    gates_out = os.path.join(scratch, "gates.csv")
    with open(gates_out, "w") as f:
        f.write("approach,x1,y1,x2,y2\nTOP-SECRET-GATE,0,0,1,1\n")
    out2 = os.path.join(allowed, "out2")
    msg = error_of(con, "CALL trajdb_pipeline(?, out_dir := ?, report_gates := ?)", [os.path.join(sim, "points.csv"), out2, gates_out]) or ""
    check("sandbox: report_gates outside allowed_directories is refused before it is read",
          "cannot read" in msg and "TOP-SECRET" not in msg and not os.path.exists(out2), msg)
    gates_in = os.path.join(allowed, "gates.csv")
    with open(gates_in, "w") as f:
        f.write("approach,x1,y1,x2,y2\nmy-gate,0,0,1,1\n")
    msg = error_of(con, "CALL trajdb_pipeline(?, out_dir := ?, report_gates := ?)", [os.path.join(sim, "points.csv"), out2, gates_in])
    check("sandbox: report_gates inside allowed_directories is read",
          msg is None and "the gates you drew" in open(os.path.join(out2, "report.html")).read(), str(msg))
    con.close()
    # NUL bytes: refused whole, nothing made at the cut-off name
    con = connect(ext)
    cwd = os.getcwd()
    os.chdir(scratch)
    try:
        for name, sql in [
            ("trajdb_pipeline input", "CALL trajdb_pipeline('in.csv' || chr(0) || 'zz', out_dir := 'nul-a')"),
            ("trajdb_pipeline out_dir", "CALL trajdb_pipeline('in.csv', out_dir := 'nul-b' || chr(0) || 'x')"),
            ("trajdb_pipeline parameter", "CALL trajdb_pipeline('in.csv', out_dir := 'nul-c', input_columns := 'camera=c' || chr(0) || 'x')"),
            ("trajdb_simulate dir", "FROM trajdb_simulate('nul-d' || chr(0) || 'x', minutes := 0.1)"),
            ("trajdb_results_begin out", "FROM trajdb_results_begin('nul-e' || chr(0) || 'x', 'in.csv')"),
            ("trajdb_stages params", "FROM trajdb_stages('in.csv', params := '{}' || chr(0) || 'x')"),
            ("trajdb_script path", "FROM trajdb_script('sql/score.sql' || chr(0) || 'x')"),
        ]:
            msg = error_of(con, sql) or ""
            made = [n for n in os.listdir(scratch) if n.startswith("nul-")]
            check(f"NUL byte: {name} is refused, nothing made", "NUL" in msg and not made, f"{msg} {made}")
    finally:
        os.chdir(cwd)
    con.close()


# ---------------------------------------------------------------- overwrites
def test_overwrite(ext, scratch):
    con = connect(ext)
    user = os.path.join(scratch, "user")
    os.makedirs(user)
    for n, text in [("README.txt", "my notes\n"), ("points.csv", "my,own,points\n")]:
        with open(os.path.join(user, n), "w") as f:
            f.write(text)
    before = {n: open(os.path.join(user, n), "rb").read() for n in os.listdir(user)}
    msg = error_of(con, "FROM trajdb_simulate(?, minutes := 0.1)", [user]) or ""
    after = {n: open(os.path.join(user, n), "rb").read() for n in os.listdir(user)}
    check("overwrite: a folder with the user's files is refused, naming the folder", "did not write" in msg and user in msg, msg)
    check("overwrite: the user's files are untouched and nothing is added", before == after, str(sorted(after)))
    sim = os.path.join(scratch, "sim")
    first = con.execute("SELECT points FROM trajdb_simulate(?, minutes := 0.1, seed := 1)", [sim]).fetchall()[0][0]
    files = listing(sim)
    check("overwrite: a new folder gets the scenario and its manifest",
          {"points.csv", "README.txt", ".trajdb-results"} <= set(files) and not any(n.startswith(".trajdb-partial") for n in files), str(files))
    second = con.execute("SELECT points FROM trajdb_simulate(?, minutes := 0.1, seed := 2, world_rate_hz := 0)", [sim]).fetchall()[0][0]
    rows = sum(1 for _ in open(os.path.join(sim, "points.csv"))) - 1
    check("overwrite: a rerun replaces trajdb's own earlier scenario whole",
          rows == second and first != second and not os.path.exists(os.path.join(sim, "world.csv")), f"{rows} rows, {second} expected")
    for bad, want in [("", "dir is '' (empty)"), ("   ", "dir is '' (empty)"), (os.path.join(sim, "points.csv"), "is a file")]:
        msg = error_of(con, "FROM trajdb_simulate(?, minutes := 0.1)", [bad]) or ""
        check(f"overwrite: dir {bad!r} is refused", want in msg, msg)
    con.close()


# ---------------------------------------------------------------- limits per database
RESAMPLE = "SELECT traj_resample([{'t': 0, 'x': 0, 'y': 0}, {'t': 2, 'x': 2, 'y': 0}], 0.1)"
MANY = "SELECT sum(len(traj_resample([{'t': 0, 'x': 0, 'y': 0}, {'t': 2 + i % 3, 'x': 2, 'y': 0}], 0.1))) FROM range(200000) r(i)"


def test_limits(ext, scratch):
    a, b = connect(ext), connect(ext)
    default = b.execute("SELECT trajdb_limit('output_points')").fetchall()[0][0]
    prev = a.execute("FROM trajdb_set_limit('output_points', 10)").fetchall()[0][1]
    check("limits: setting returns the previous value", prev == default, str(prev))
    got_a = a.execute("SELECT trajdb_limit('output_points')").fetchall()[0][0]
    got_b = b.execute("SELECT trajdb_limit('output_points')").fetchall()[0][0]
    check("limits: the other database keeps its own value", got_a == 10 and got_b == default, f"a {got_a}, b {got_b}")
    msg = error_of(a, RESAMPLE) or ""
    check("limits: database a enforces its lowered limit, naming its value", "above the work limit output_points = 10;" in msg, msg)
    check("limits: database b is not bound by a's limit", error_of(b, RESAMPLE) is None)
    check("limits: a cursor of a shares a's limits", a.cursor().execute("SELECT trajdb_limit('output_points')").fetchall()[0][0] == 10)
    a.execute("SET threads = 4")
    b.execute("SET threads = 4")
    msg = error_of(a, MANY) or ""
    check("limits: a's limit holds in DuckDB's worker threads", "output_points = 10" in msg, msg)
    check("limits: b runs the same multi-threaded query", error_of(b, MANY) is None)
    # b raises its limit: a stays at 10
    b.execute("CALL trajdb_set_limit('output_points', 123456789)").fetchall()
    check("limits: b's change does not reach a", a.execute("SELECT trajdb_limit('output_points')").fetchall()[0][0] == 10)
    # a locked, sandboxed connection cannot lift a limit (issue 37 HIGH 2): refused, unchanged
    b.execute("SET enable_external_access = false")
    b.execute("SET lock_configuration = true")
    msg = error_of(b, "CALL trajdb_set_limit('output_points', 9000000000000000000)") or ""
    check("limits: lock_configuration locks trajdb's limits", "lock_configuration is true" in msg
          and b.execute("SELECT trajdb_limit('output_points')").fetchall()[0][0] == 123456789, msg)
    a.close()
    b.close()
    # the extension holds no connection of its own: a closed database file opens elsewhere
    path = os.path.join(scratch, "file.duckdb")
    f = connect(ext, path)
    f.execute("CREATE TABLE t AS SELECT 1 AS x")
    f.execute("FROM trajdb_simulate(?, minutes := 0.1)", [os.path.join(scratch, "from-file")]).fetchall()
    f.close()
    out = subprocess.run([sys.executable, "-c", "import duckdb, sys; print(duckdb.connect(sys.argv[1]).execute('SELECT x FROM t').fetchall())", path],
                         capture_output=True, text=True, timeout=120)
    check("no connection kept: the closed database file opens in another process", out.returncode == 0 and "[(1,)]" in out.stdout, out.stderr.strip()[-300:])


def main():
    ext = os.path.abspath(sys.argv[1])
    print(f"duckdb {duckdb.__version__}")
    scratch = tempfile.mkdtemp(prefix="trajdb-sandbox-")
    try:
        for test in [test_bad_arguments, test_sandbox, test_caller_file_system, test_overwrite, test_limits]:
            sub = os.path.join(scratch, test.__name__)
            os.makedirs(sub)
            test(ext, sub)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    if FAILED:
        print(f"{len(FAILED)} check(s) failed: {FAILED}")
        sys.exit(1)
    print("all sandbox checks passed")


if __name__ == "__main__":
    main()
