#!/usr/bin/env python3
"""Scale benchmarks of issue 25 ("no host crash, no unbounded call"), run with the loadable
extension in Python DuckDB. Timing only: nothing here is a test.

Each case runs in a child process with a time limit and an address-space limit, so that an old
build that runs for minutes or allocates without bound cannot take the machine down; the case
then reports "> N s" or "died". Run it against two builds to compare:

    python3 benches/robust_scale.py --ext old/trajdb.duckdb_extension --timeout 300
    python3 benches/robust_scale.py --ext trajdb.duckdb_extension

Cases:
  rigid_fit_shifted  20,000 points (one 10k-point track pair) x 20,001 shifts
  merge_groups       a chain of 120,000 and of 1,000,000 links (one camera, disjoint pieces)
  quality            the functions of sql/stages/quality.sql on 300,000 and 1,000,000 one-point
                     tracks (one camera, 60 s, 10 km x 10 km): traj_events (pass 1),
                     quality_reach (traj_events pass 2), traj_labels, merge_groups (quality_links),
                     each statement timed
  refusals           calls that must stop at once with an error: lcss_matches(tr, tr, 1, 'inf')
                     on 100,000 points, traj_events on 64,000 crowded tracks, trajdb_simulate at
                     its largest parameters
"""
import argparse
import multiprocessing as mp
import os
import resource
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def connect(ext):
    import duckdb

    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute(f"LOAD '{ext}'")
    return con


def timed(con, sql):
    t = time.perf_counter()
    try:
        r = con.execute(sql).fetchall()
        return time.perf_counter() - t, r, None
    except Exception as e:  # an error is a result here (a refusal)
        return time.perf_counter() - t, None, f"{type(e).__name__}: {str(e)[:160]}"


def case_rigid(ext):
    con = connect(ext)
    con.execute("""CREATE TABLE a AS SELECT list({'t': k * 0.1, 'x': 10 * sin(k * 0.005) * k * 0.1, 'y': k * 0.3} ORDER BY k) AS f,
                   list({'t': k * 0.1 + 0.03 + 0.2, 'x': 10 * sin((k * 0.1 + 0.03) * 0.05) * (k * 0.1 + 0.03), 'y': (k * 0.1 + 0.03) * 3} ORDER BY k) AS m
                   FROM range(10000) r(k)""")
    q = "SELECT rigid_fit_shifted([f], [m], 0.2, 1.0, 0.0001) FROM a"
    s, r, e = timed(con, q)
    out = [("rigid_fit_shifted 20k points x 20,001 shifts", s, e or f"dt {r[0][0]['dt']:.4f}")]
    if e and "shift_pair_fits" in e:
        # the same work with the limit raised: how long the refused call would have taken
        con.execute("CALL trajdb_set_limit('shift_pair_fits', 1000000000)")
        s, r, e = timed(con, q)
        out.append(("rigid_fit_shifted 20k x 20,001, shift_pair_fits raised to 1e9", s, e or f"dt {r[0][0]['dt']:.4f}"))
    return out


def case_merge(ext, n):
    con = connect(ext)
    con.execute(f"""CREATE TABLE c AS SELECT list({{'id': i, 'camera': 1, 't0': i::DOUBLE, 't1': i + 0.5}}) AS t,
                    list({{'a': i - 1, 'b': i}} ORDER BY i) FILTER (WHERE i > 0) AS l FROM range({n} + 1) r(i)""")
    s, r, e = timed(con, "SELECT len(merge_groups(t, l)) FROM c")
    return [(f"merge_groups chain of {n:,} links", s, e or f"{r[0][0]:,} tracks")]


def quality_statements(con):
    """The quality stage's statements as the extension embeds them (trajdb_script)."""
    return [r[0] for r in con.execute("SELECT sql FROM trajdb_script('sql/stages/quality.sql') ORDER BY k").fetchall()]


def case_quality(ext, n):
    con = connect(ext)
    con.execute("SET VARIABLE quality_max_gap = 2.5; SET VARIABLE quality_max_dist = 2.0; SET VARIABLE quality_inset = 1.0; "
                "SET VARIABLE quality_max_accel = NULL::DOUBLE")
    con.execute("CREATE TEMP TABLE calib_classes AS SELECT 'car' AS class, 3.0 AS accel_p95, 1 AS n")
    # one-point tracks, one camera, 60 s, 10 km x 10 km (hashes of the row number: the same
    # input every run)
    con.execute(f"""CREATE TEMP TABLE points AS
        SELECT 1 AS camera, i AS track_id, 'car' AS class,
               (hash(i, 1) % 6000000) / 100000.0 AS t,
               (hash(i, 2) % 10000000) / 1000.0 AS x,
               (hash(i, 3) % 10000000) / 1000.0 AS y,
               0 AS estimated
        FROM range({n}) r(i)""")
    out = []
    for stmt in quality_statements(con):
        head = " ".join(stmt.split()[:6])
        name = head.split(" TABLE ")[1].split()[0] if " TABLE " in head else head[:40]
        s, r, e = timed(con, stmt)
        if e:
            out.append((f"quality {n:,}: {name}", s, e))
            break
        if name in ("quality_events_cv", "quality_reach", "quality_labels", "quality_links"):
            count = con.execute(f"SELECT count(*) FROM {name}").fetchone()[0]
            fn = {"quality_events_cv": "traj_events", "quality_reach": "traj_events pass 2",
                  "quality_labels": "traj_labels", "quality_links": "merge_groups"}[name]
            out.append((f"quality {n:,}: {name} ({fn})", s, f"{count:,} rows"))
        else:
            out.append((f"quality {n:,}: {name}", s, ""))
    return out


def case_refusal(ext, which):
    con = connect(ext)
    if which == "lcss":
        con.execute("CREATE TABLE a AS SELECT list({'t': k * 0.1, 'x': k * 1.0, 'y': 0} ORDER BY k) AS tr FROM range(100000) r(k)")
        s, r, e = timed(con, "SELECT len(lcss_matches(tr, tr, 1, 'inf')) FROM a")
        return [("lcss_matches 100k points, time_window inf", s, e or f"{r[0][0]} pairs")]
    if which == "events":
        con.execute("""CREATE TABLE crowd AS SELECT list({'id': i, 't0': 1 + (i % 100) * 0.01, 'x0': (i % 250) * 0.004, 'y0': (i // 250) * 0.004,
                       't1': 1 + (i % 100) * 0.01, 'x1': (i % 250) * 0.004, 'y1': (i // 250) * 0.004, 'vx1': 0, 'vy1': 0}) AS e FROM range(64000) r(i)""")
        s, r, e = timed(con, "SELECT len(traj_events(e, 2.5, 2.0)) FROM crowd")
        return [("traj_events 64k crowded tracks", s, e or f"{r[0][0]:,} events")]
    with tempfile.TemporaryDirectory() as d:
        s, r, e = timed(con, f"""SELECT * FROM trajdb_simulate('{d}/sim', cameras := 16, minutes := 1440, rate_hz := 100,
                                 traffic := 50, pedestrians := 50)""")
    return [("trajdb_simulate at its largest parameters", s, e or "done")]


def child(q, fn, args, mem_gb):
    # an old build that aborts prints a long Rust backtrace: keep the report readable
    os.environ["RUST_BACKTRACE"] = "0"
    if mem_gb:
        b = int(mem_gb * 1024 ** 3)
        resource.setrlimit(resource.RLIMIT_AS, (b, b))
    try:
        q.put(fn(*args))
    except Exception as e:
        q.put([(fn.__name__, float("nan"), f"{type(e).__name__}: {str(e)[:160]}")])


def run(fn, args, timeout, mem_gb, label):
    q = mp.Queue()
    p = mp.Process(target=child, args=(q, fn, args, mem_gb))
    t = time.perf_counter()
    p.start()
    p.join(timeout)
    if p.is_alive():
        p.kill()
        p.join()
        return [(label, None, f"> {timeout} s (stopped)")]
    if p.exitcode != 0:
        return [(label, time.perf_counter() - t, f"died (exit {p.exitcode}; the host process aborted)")]
    return q.get()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ext", default=os.path.join(ROOT, "trajdb.duckdb_extension"))
    ap.add_argument("--timeout", type=float, default=600, help="seconds per case (default 600)")
    ap.add_argument("--mem-gb", type=float, default=8, help="address-space limit of each case's process (default 8; 0: none)")
    ap.add_argument("--only", default="", help="comma-separated: rigid, merge, quality, refusals")
    a = ap.parse_args()
    ext = os.path.abspath(a.ext)
    cases = [
        ("rigid", case_rigid, (ext,), "rigid_fit_shifted 20k x 20,001"),
        ("merge", case_merge, (ext, 120_000), "merge_groups 120k"),
        ("merge", case_merge, (ext, 1_000_000), "merge_groups 1M"),
        ("quality", case_quality, (ext, 300_000), "quality 300k"),
        ("quality", case_quality, (ext, 1_000_000), "quality 1M"),
        ("refusals", case_refusal, (ext, "lcss"), "lcss_matches 100k inf"),
        ("refusals", case_refusal, (ext, "events"), "traj_events 64k crowded"),
        ("refusals", case_refusal, (ext, "simulate"), "trajdb_simulate largest"),
    ]
    only = {s for s in a.only.split(",") if s}
    print(f"extension {ext}\ntime limit {a.timeout:.0f} s per case, address space {a.mem_gb or 'unlimited'} GB", flush=True)
    for key, fn, args, label in cases:
        if only and key not in only:
            continue
        for name, secs, note in run(fn, args, a.timeout, a.mem_gb, label):
            t = "      -" if secs is None else f"{secs:7.2f}"
            print(f"{t} s  {name}  {note}", flush=True)


if __name__ == "__main__":
    main()
