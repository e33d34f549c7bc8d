#!/usr/bin/env python3
"""Every trajdb function under an address-space cap, and every long kernel under an interrupt
(issue 37): a clean SQL error or a result passes; a child killed by a signal (SIGABRT from a
failed allocation, SIGSEGV), or a return long after con.interrupt(), fails.

1. RLIMIT_AS: for every function trajdb registers (the names from trajdb_functions(), the
   overloads and their types from duckdb_functions(): nothing hand-listed), a CHILD Python
   sets resource.RLIMIT_AS to 3.5 GB, loads the extension and calls each overload with inputs
   built to need more than that when a kernel allocates by input (lists of 10^6 elements, tracks
   of 10^6 points, struct lists of 2.5 x 10^5 elements, pairs over 5,000 ids, a polygon of 10^5 vertices, tiny periods and huge
   windows), twice: at the default limits, and with the memory limits lifted
   (CALL trajdb_set_limit('memory_bytes' / 'output_points', 9e18)), where only the kernels' own
   fallible allocations stand between the input and an abort.
2. Interrupts: each long kernel runs over many rows (or one long call) in a thread;
   con.interrupt() after 1 s; the query must return within BOUND seconds (one call's worth of
   work: DuckDB's C API shows no interrupt inside a call, so the work limits bound it).

usage: python3 tests/test_rlimit_python.py path/to/trajdb.duckdb_extension
"""
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time

import duckdb

CAP = int(3.5 * 1024 ** 3)
BOUND = 20.0  # seconds from con.interrupt() to the query's return
N = 1_000_000  # elements of a big list
CHILD_TIMEOUT = 45  # a child still running then is reported as slow (no abort seen), not failed

# the big inputs live in one database file the parent builds once (INPUTS, plus a table per
# struct-list type in STRUCT_TABLES); each child attaches it read-only as `inp`
TRAJ = "(SELECT v FROM inp.big_traj)"
INPUTS = f"""
CREATE TABLE big_traj AS SELECT list({{'t': i * 0.01, 'x': (i % 2) * 0.5 + (i * 7919 % 100) / 1000.0, 'y': ((i // 2) % 2) * 0.5}} ORDER BY i) AS v FROM range({N}) r(i);
CREATE TABLE trajs AS SELECT list(k ORDER BY k) AS ids, list(tr ORDER BY k) AS v FROM (
  SELECT k, list({{'t': i * 0.1, 'x': (k % 50) * 1.0 + sin(i * 0.3 + k), 'y': (k // 50) * 1.0 + cos(i * 0.2 + k)}} ORDER BY i) AS tr
  FROM range(300) a(k), range(500) b(i) GROUP BY k);
CREATE TABLE doubles AS SELECT list(i * 0.001 ORDER BY i)::DOUBLE[] AS v FROM range({N}) r(i);
CREATE TABLE texts AS SELECT string_agg('x', '') AS v FROM range({N});
CREATE TABLE polys AS SELECT list(CASE WHEN i % 2 = 0 THEN 'POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))' ELSE 'POLYGON ((0 0, ' || i || ' 0, ' || i || ' 1, 0 1, 0 0))' END) AS v FROM range(200000) r(i);
"""
STRUCT_TABLES = {}
# reproducers of the issue, besides the generic inputs: close endpoints whose 2e7 near pairs fit
# but whose event rows did not (traj_events aborted the host on 64,000 such endpoints under a 4 GB
# cap: "memory allocation of 1096319880 bytes failed")
CLOSE_ENDS = ("(SELECT list({'id': i, 't0': (i % 2) * 1.0 + (i % 1000) * 0.0001, 'x0': (i % 10) * 0.01, 'y0': 0.0, 't1': (i % 2) * 1.0 + 0.5 + (i % 1000) * 0.0001, "
              "'x1': (i % 7) * 0.01, 'y1': 0.0, 'vx1': 0.0, 'vy1': 0.0}) FROM range(9000) r(i))")
EXTRA = {
    "traj_events": [f"SELECT (traj_events({CLOSE_ENDS}, 10.0, 10.0)) IS NULL"],
    "traj_resample": ["SELECT (traj_resample([{'t': 0, 'x': 0, 'y': 0}, {'t': 1e6, 'x': 1, 'y': 0}], 1e-6)) IS NULL"],
}

def polygon_wkt(n):
    import math
    pts = [(50 * math.cos(2 * math.pi * k / n) * (1 + 0.01 * (k * 7919 % 13)), 50 * math.sin(2 * math.pi * k / n)) for k in range(n)]
    pts.append(pts[0])
    return "POLYGON ((" + ", ".join(f"{x:.6f} {y:.6f}" for x, y in pts) + "))"


def split_top(s):
    """Top-level comma split (STRUCT(...) types hold commas)."""
    out, depth, cur = [], 0, ""
    for ch in s:
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        if ch == "," and depth == 0:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    if cur.strip():
        out.append(cur)
    return out


def param_names(signatures):
    """Parameter names in order, from trajdb_functions()' signature lines (brackets dropped)."""
    names = []
    for line in signatures.splitlines():
        inner = line[line.index("(") + 1: line.rindex(") ->")]
        flat = inner.replace("[, ", ", ").replace(" [", ", ")
        flat = re.sub(r"\](?=[\],)]|$)", "", flat)
        got = [p.strip().split(" ")[0] for p in split_top(flat) if p.strip()]
        if len(got) > len(names):
            names = got
    return names


def struct_fields(ty):
    m = re.fullmatch(r"STRUCT\((.*)\)(\[\])?", ty)
    fields = []
    for f in split_top(m.group(1)):
        name, t = f.strip().split(" ", 1)
        fields.append((name.strip('"'), t.strip()))
    return fields, bool(m.group(2))


def value(fn, name, ty, variant):
    """An SQL expression of type `ty` for parameter `name` of `fn`: 'big' makes the work large,
    'small' makes windows tiny and periods short (outputs large)."""
    big = variant == "big"
    if ty == "STRUCT(t DOUBLE, x DOUBLE, y DOUBLE)[]":
        return TRAJ
    if ty == "STRUCT(t DOUBLE, x DOUBLE, y DOUBLE)[][]":
        return "(SELECT v FROM inp.trajs)"
    if ty == "BIGINT[]":
        return "(SELECT ids FROM inp.trajs)"
    if ty == "DOUBLE[]":
        return "(SELECT v FROM inp.doubles)"
    if ty in ("VARCHAR[]", "BLOB[]", "GEOMETRY[]"):
        return "(SELECT v FROM inp.polys)" if ty == "VARCHAR[]" else None
    if ty.startswith("STRUCT("):
        fields, is_list = struct_fields(ty)
        if not is_list:
            if [f for f, _ in fields] == ["theta", "tx", "ty", "scale"]:
                return "{'theta': 0.1, 'tx': 1.0, 'ty': 2.0, 'scale': 1.0}"
            if [f for f, _ in fields][:5] == ["theta", "tx", "ty", "scale", "lonlat"]:  # a map fit (map_apply, ...)
                return ("{'theta': 0.1, 'tx': 1.0, 'ty': 2.0, 'scale': 1.0, 'lonlat': true, 'lon0': 11.97, 'lat0': 57.7, "
                        "'rms_m': 0.0, 'max_residual_m': 0.0, 'points': 2}")
            if [f for f, _ in fields] == ["offset", "drift"]:  # a clock (clock_compose, ...)
                return "{'offset': 0.5, 'drift': 1e-4}"
            if [f for f, _ in fields] == ["mx", "my", "sxx", "sxy", "syy", "n"]:  # a bias state (pair_evidence)
                return "{'mx': 0.5, 'my': 0.0, 'sxx': 0.04, 'sxy': 0.0, 'syy': 0.04, 'n': 10}"
            return None
        parts = []
        for k, (f, t) in enumerate(fields):
            if t in ("BIGINT", "INTEGER"):
                e = "i % 5000" if f in ("a", "id") and k == 0 else ("(i * 7919) % 5000" if f in ("b",) else "i")
            elif t == "DOUBLE":
                e = {"t": "i * 0.01", "t0": "i * 0.01", "t1": "i * 0.01 + 1.0", "sigma": "1.0"}.get(f, f"((i * 7919) % 1000) / 100.0 + {k}")
            else:
                return None
            parts.append(f"'{f}': {e}")
        table = STRUCT_TABLES.setdefault(ty, (f"s{len(STRUCT_TABLES)}", f"SELECT list({{{', '.join(parts)}}} ORDER BY i)::{ty} AS v FROM range({N // 4}) r(i)"))[0]
        return f"(SELECT v FROM inp.{table})"
    if ty == "DOUBLE":
        return "1e6" if big else "1e-6"
    if ty in ("BIGINT", "INTEGER"):
        return "1000000" if big else "1"
    if ty == "BOOLEAN":
        return "true"
    if ty == "VARCHAR":
        if name == "method":
            return "'concave'" if fn == "view_polygon" else "'average'"
        if name in ("p", "a", "b", "interior", "region"):
            return "(SELECT big FROM inp.poly)" if fn == "polygon_buffer" else "(SELECT small FROM inp.poly)"
        if name == "name":
            return "'output_points'"
        if name == "format":
            return "'markdown'"
        return "(SELECT v FROM inp.texts)"
    return None  # BLOB / GEOMETRY overloads: the same kernels as VARCHAR, after parsing


CHILD = r"""
import os, resource, sys, json, time, duckdb
cap, ext, calls_file, db, scratch = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5]
calls = json.load(open(calls_file))
resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
con = duckdb.connect(config={'allow_unsigned_extensions': 'true', 'threads': '2'})
con.execute("SET enable_progress_bar = false")
con.execute(f"LOAD '{ext}'")
con.execute(f"ATTACH '{db}' AS inp (READ_ONLY)")
os.chdir(scratch)
for mode, sql in calls:
    if mode == 'lifted':
        con.execute("CALL trajdb_set_limit('memory_bytes', 9000000000000000000)")
        con.execute("CALL trajdb_set_limit('output_points', 9000000000000000000)")
    t = time.perf_counter()
    try:
        r = con.execute(sql).fetchall()
        out = 'result'
    except duckdb.Error as e:
        out = 'error ' + str(e)[:160].replace(chr(10), ' ')
    print(f"{mode:6} {time.perf_counter() - t:6.2f}s {out}", flush=True)
print('ALIVE', con.execute('SELECT 42').fetchall()[0][0], flush=True)
"""


def overloads(con):
    names = dict(con.execute("SELECT name, signatures FROM trajdb_functions()").fetchall())
    rows = con.execute(
        "SELECT function_name, function_type, parameter_types FROM duckdb_functions() WHERE function_name IN (SELECT name FROM trajdb_functions())"
    ).fetchall()
    seen = {}
    for fn, kind, types in rows:
        seen.setdefault(fn, []).append((kind, [str(t) for t in types]))
    assert set(seen) == set(names), set(names) ^ set(seen)
    return names, seen


def table_call(fn, scratch):
    """Table functions: each with inputs that would be large; file writers into scratch."""
    d = os.path.join(scratch, fn)
    lake = os.path.join(scratch, fn + "-lake")
    if fn.startswith("trajdb_archive"):
        os.makedirs(os.path.join(lake, "site=a", "date=2026-05-04"), exist_ok=True)
    task = {"site": "a", "date": "d", "files": [], "inputs": "[]", "fingerprint": "x", "cal_id": None, "cal_dir": None,
            "scratch": d + "/task-1", "params_json": "{}", "build": "b"}
    return {
        "trajdb_simulate": f"FROM trajdb_simulate('{d}', minutes := 1440, traffic := 50, pedestrians := 50, rate_hz := 30)",
        "trajdb_pipeline": f"FROM trajdb_pipeline('nope_missing_table', out_dir := '{d}')",
        "trajdb_results_begin": f"FROM trajdb_results_begin('{d}', 'x')",
        "trajdb_results_end": f"FROM trajdb_results_end('{d}', false)",
        "trajdb_script": "FROM trajdb_script('sql/pipeline.sql')",
        "trajdb_stages": "FROM trajdb_stages('scene')",
        "trajdb_functions": "FROM trajdb_functions()",
        "trajdb_params": "FROM trajdb_params()",
        "trajdb_set_limit": "FROM trajdb_set_limit('lcss_cells', 10000000000)",
        # (a lake of one empty partition: the call runs, the day fails for want of files)
        "trajdb_archive": f"FROM trajdb_archive('{lake}', out_dir := '{d}')",
        "trajdb_archive_open": f"FROM trajdb_archive_open('{lake}', out_dir := '{d}')",
        "trajdb_archive_task": "FROM trajdb_archive_task('" + json.dumps(task) + "')",
        "trajdb_archive_next": "FROM trajdb_archive_next(1)",
        "trajdb_archive_commit": "FROM trajdb_archive_commit(1, '" + json.dumps({"task": task, "error": "x"}) + "')",
        "trajdb_archive_close": "FROM trajdb_archive_close(1)",
    }.get(fn, f"FROM {fn}()")


def rlimit_cases(ext, con, scratch):
    names, seen = overloads(con)
    failures, total = [], 0
    plan = []
    for fn in sorted(seen):
        calls = []
        for kind, types in seen[fn]:
            if kind == "table":
                sql = table_call(fn, scratch)
                calls += [("default", sql), ("lifted", sql)]
                continue
            pnames = param_names(names[fn])
            for variant in ("big", "small"):
                args = [value(fn, pnames[k] if k < len(pnames) else "", t, variant) for k, t in enumerate(types)]
                if any(a is None for a in args):
                    break
                args = [f"{a}::{t}" for a, t in zip(args, types)]
                sql = f"SELECT ({fn}({', '.join(args)})) IS NULL"
                calls += [("default", sql)]
        calls += [("default", q) for q in EXTRA.get(fn, [])]
        # the lifted run of each scalar call after its default runs
        calls += [("lifted", s) for m, s in list(calls) if m == "default" and not s.startswith("FROM")]
        if not calls:
            failures.append(f"{fn}: no overload could be given inputs")
            continue
        plan.append((fn, calls))
    # the inputs, once
    t = time.perf_counter()
    db = os.path.join(scratch, "inputs.duckdb")
    build = duckdb.connect(db)
    build.execute("SET enable_progress_bar = false")
    build.execute(INPUTS)
    build.execute("CREATE TABLE poly AS SELECT ? AS small, ? AS big", [polygon_wkt(20_000), polygon_wkt(100_000)])
    for table, sql in STRUCT_TABLES.values():
        build.execute(f"CREATE TABLE {table} AS {sql}")
    build.close()
    print(f"-- inputs built in {time.perf_counter() - t:.1f} s")
    def run_child(k, fn, calls):
        calls_file = os.path.join(scratch, f"calls{k}.json")
        json.dump(calls, open(calls_file, "w"))
        t = time.perf_counter()
        try:
            p = subprocess.run([sys.executable, "-c", CHILD, str(CAP), ext, calls_file, db, scratch],
                               capture_output=True, text=True, timeout=CHILD_TIMEOUT)
        except subprocess.TimeoutExpired:
            # no abort and no signal within the bound: slow, which the interrupt part and the work
            # limits judge; reported, not failed
            return None, f"SLOW {fn}: still running after {CHILD_TIMEOUT} s under the cap (no abort); stopped"
        took = time.perf_counter() - t
        lines = p.stdout.strip().splitlines()
        if p.returncode < 0 or "ALIVE 42" not in p.stdout:
            sig = signal.Signals(-p.returncode).name if p.returncode < 0 else f"exit {p.returncode}"
            nxt = calls[len(lines)] if len(lines) < len(calls) else ("?", "?")
            return f"{fn}: {sig} after {len(lines)} of {len(calls)} calls; the call: [{nxt[0]}] {nxt[1][:200]}; {p.stderr.strip()[-300:]}", None
        bad = [line for line in lines if any(w in line for w in ("INTERNAL", "panicked", "Binder Error", "Conversion Error"))]
        if bad:
            return f"{fn}: {bad[0]}", None
        return None, f"ok   {fn}: {len(calls)} calls under RLIMIT_AS {CAP / 1024 ** 3:.1f} GB in {took:.1f} s; " + "; ".join(line[:90] for line in lines[:4])

    from concurrent.futures import ThreadPoolExecutor
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = [pool.submit(run_child, k, fn, calls) for k, (fn, calls) in enumerate(plan)]
        for (fn, calls), fut in zip(plan, futures):
            total += len(calls)
            fail, ok = fut.result()
            if fail:
                failures.append(fail)
                print("FAIL " + fail)
            else:
                print(ok)
    return failures, total


# long kernels under con.interrupt(): (name, query). Each row is a call of moderate size (DuckDB
# checks the interrupt between chunks of up to 2048 rows, so a chunk must fit in BOUND); the
# query has far more rows than it could run in BOUND seconds. "(one call)": a single call,
# bounded by its work limit alone.
LONG = {
    "traj_pet": "SELECT count(traj_pet(a, b)) FROM zig_small, range(1000000) r(i)",
    "traj_pet (one call)": "SELECT traj_pet(a, b) FROM (SELECT a, b FROM zig_long)",
    "traj_events": "SELECT count(traj_events(CASE WHEN i >= 0 THEN ev END, 1e6, 1e6)) FROM evs, range(1000000) r(i)",
    "traj_labels": "SELECT count(traj_labels(CASE WHEN i >= 0 THEN lb END, 1e6, 1e6)) FROM evs, range(1000000) r(i)",
    "lcss_similarity": "SELECT sum(lcss_similarity(a, b, 1.0 + 0 * i, 1e9)) FROM zig_tiny, range(1000000) r(i)",
    "lcss_matches": "SELECT count(lcss_matches(a, b, 1.0 + 0 * i, 1e9)) FROM zig_tiny, range(1000000) r(i)",
    "lcss_index_similarity": "SELECT sum(lcss_index_similarity(a, b, 100000, 1.0 + 0 * i)) FROM zig_tiny, range(1000000) r(i)",
    "lcss_s2": "SELECT count(lcss_s2(a, b, 100000, 1.0 + 0 * i)) FROM zig_tiny, range(1000000) r(i)",
    "cpd_align": "SELECT count(cpd_align(a, b, 0.1 + 0 * i)) FROM zig_tiny, range(1000000) r(i)",
    "traj_conflicts": "SELECT count(traj_conflicts(ids, v, 1e6 + 0 * i, 1.0, 5.0)) FROM few, range(1000000) r(i)",
    "traj_conflicts_top": "SELECT count(traj_conflicts_top(ids, v, 10, 1e6 + 0 * i, 1.0)) FROM few, range(1000000) r(i)",
    "polygon_buffer": "SELECT count(polygon_buffer(p, 2.0 + 0 * i)) FROM poly, range(1000000) r(i)",
    "traj_cluster": "SELECT count(traj_cluster(ids, v, 'average', 0.5 + 0 * i, 5, 1.0)) FROM few, range(1000000) r(i)",
    "agglomerative_cluster": "SELECT count(agglomerative_cluster(CASE WHEN i >= 0 THEN pairs END, 'average', 0.5)) FROM prs, range(1000000) r(i)",
    "agglomerative_dendrogram": "SELECT count(agglomerative_dendrogram(CASE WHEN i >= 0 THEN pairs END, 'single')) FROM prs, range(1000000) r(i)",
    "assign_pairs": "SELECT count(assign_pairs(CASE WHEN i >= 0 THEN edges END)) FROM prs, range(1000000) r(i)",
    "hungarian_match": "SELECT count(hungarian_match(CASE WHEN i >= 0 THEN sc END)) FROM prs, range(1000000) r(i)",
    "traj_fuse": "SELECT count(traj_fuse(CASE WHEN i >= 0 THEN obs END, 1.0, 0.01)) FROM fz, range(1000000) r(i)",
    "traj_resample": "SELECT count(traj_resample(a, 0.001 + 0 * i)) FROM zig_tiny, range(1000000) r(i)",
    "rigid_fit_shifted": "SELECT count(rigid_fit_shifted([a], [b], 0.0, 5.0 + 0 * i, 0.05)) FROM zig_tiny, range(1000000) r(i)",
    "view_polygon": "SELECT count(view_polygon(a, 'concave', 0.3 + 0 * i)) FROM zig_tiny, range(1000000) r(i)",
    "trajectory_merge": "SELECT count(trajectory_merge(a, b, 1.0 + 0 * i, 1e9)) FROM zig_tiny, range(1000000) r(i)",
}

def zig_table(name, n):
    """Two zig-zag tracks of n points each, 0.05 s apart (the interrupt cases' per-row input)."""
    return f"""CREATE TEMP TABLE {name} AS SELECT
  list({{'t': i * 0.1, 'x': (i % 2) * 1.0 + (i * 7919 % 100) / 1000.0, 'y': ((i // 2) % 2) * 1.0}} ORDER BY i) AS a,
  list({{'t': i * 0.1 + 0.05, 'x': ((i + 1) % 2) * 1.0, 'y': ((i // 3) % 2) * 1.0 + (i * 104729 % 100) / 1000.0}} ORDER BY i) AS b
  FROM range({n}) r(i);
"""


INTERRUPT_SETUP = "SET threads = 2;\n" + "".join(zig_table(t, n) for t, n in [("zig", 3000), ("zig_small", 300), ("zig_tiny", 40), ("zig_long", 200000)]) + f"""
CREATE TEMP TABLE few AS SELECT list(k ORDER BY k) AS ids, list(tr ORDER BY k) AS v FROM (
  SELECT k, list({{'t': i * 0.1, 'x': (k % 10) * 1.0 + sin(i * 0.3 + k), 'y': (k // 10) * 1.0 + cos(i * 0.2 + k)}} ORDER BY i) AS tr
  FROM range(60) a(k), range(300) b(i) GROUP BY k);
CREATE TEMP TABLE evs AS SELECT list({{'id': i, 't0': (i % 50) * 0.1, 'x0': (i % 7) * 0.1, 'y0': 0.0, 't1': (i % 50) * 0.1 + 1.0, 'x1': (i % 5) * 0.1, 'y1': 0.0, 'vx1': 1.0, 'vy1': 0.0}}) AS ev,
  list({{'id': i, 't0': (i % 50) * 0.1, 'x0': (i % 7) * 0.1, 'y0': 0.0, 't1': (i % 50) * 0.1 + 1.0, 'x1': (i % 5) * 0.1, 'y1': 0.0, 'vx1': 1.0, 'vy1': 0.0, 'vx0': 1.0, 'vy0': 0.0}}) AS lb
  FROM range(50) r(i);
CREATE TEMP TABLE prs AS SELECT list({{'a': i, 'b': j, 'distance': abs(sin(i) - sin(j))}}) AS pairs,
  list({{'a': i, 'b': j, 'w': abs(sin(i * j))}}) AS edges, list({{'a': i, 'b': j, 'score': abs(cos(i * j))}}) AS sc
  FROM range(120) a(i), range(120) b(j) WHERE i < j;
CREATE TEMP TABLE fz AS SELECT list({{'t': i * 0.01, 'x': sin(i * 0.01), 'y': cos(i * 0.01), 'sigma': 0.1}} ORDER BY i) AS obs FROM range(20000) r(i);
CREATE TEMP TABLE poly AS SELECT '{polygon_wkt(20000)}' AS p;
"""


def interrupt_cases(ext):
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    con.execute("SET enable_progress_bar = false")
    con.execute(INTERRUPT_SETUP)
    failures = []
    for name, q in LONG.items():
        box = {}

        def run():
            try:
                con.execute(q).fetchall()
                box["outcome"] = "finished"
            except duckdb.InterruptException:
                box["outcome"] = "interrupted"
            except duckdb.Error as e:
                box["outcome"] = "error " + str(e)[:120]
            box["end"] = time.perf_counter()

        th = threading.Thread(target=run)
        th.start()
        time.sleep(1.0)
        t_int = time.perf_counter()
        con.interrupt()
        th.join(timeout=BOUND + 60)
        if th.is_alive():
            failures.append(f"{name}: still running {BOUND + 60:.0f} s after con.interrupt()")
            print(f"FAIL {name}: still running; the harness cannot continue")
            return failures
        took = box["end"] - t_int
        if took > BOUND:
            failures.append(f"{name}: returned {took:.1f} s after con.interrupt() ({box['outcome']})")
            print(f"FAIL {name}: {took:.1f} s after the interrupt ({box['outcome']})")
        else:
            print(f"ok   {name}: {box['outcome'][:100]}, {max(took, 0) * 1000:.0f} ms after con.interrupt()")
        assert con.execute("SELECT 42").fetchall() == [(42,)]
    return failures


def main():
    ext = os.path.abspath(sys.argv[1])
    only = sys.argv[2] if len(sys.argv) > 2 else ""
    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    t0 = time.perf_counter()
    failures = []
    with tempfile.TemporaryDirectory(prefix="trajdb-rlimit-") as scratch:
        if only != "interrupt":
            f, total = rlimit_cases(ext, con, scratch)
            failures += f
            print(f"-- RLIMIT_AS: {total} calls in {time.perf_counter() - t0:.0f} s")
    if only != "rlimit":
        t1 = time.perf_counter()
        failures += interrupt_cases(ext)
        print(f"-- interrupts: {len(LONG)} kernels in {time.perf_counter() - t1:.0f} s")
    if failures:
        print("\n".join(["FAILURES:"] + failures))
        sys.exit(1)
    print(f"test_rlimit_python: OK (duckdb {duckdb.__version__}, {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
