"""trajdb on an archive: site=S/date=D partitions in, partitioned results out, incremental and
resumable (issue 40; docs/archive.md has the layout, the state and the rules).

    trajdb archive --input LAKE --out OUT          # the command line
    trajdb.archive(con, LAKE, out=OUT)             # Python (trajdb.archives.run(LAKE, OUT) without a connection)
    trajdb.spark.archive(spark, LAKE, OUT)         # the same work as Spark tasks
    FROM trajdb_archive('LAKE', out_dir := 'OUT')  # the same in one SQL call

Every decision is the extension's, written once for every host: the lake's partitions, the
fingerprints, the incremental rule and the calibration chain, the names, the commits
(crates/app/src/archive), and a day's run with its camera-change check (trajdb_archive_task,
src/archive/). This module is only what a Python host adds: worker processes (a day per
process, a dead worker replaced, workers that die with their driver), Spark's executor hook,
progress on a terminal or in a log. The driver asks trajdb_archive_open / _next / _commit /
_close on a connection of its own; each worker runs trajdb_archive_task.
"""
import json
import os
import shutil
import sys
import time

import duckdb

from . import _literal, _params_json, check_duckdb
from . import windows as W


class ArchiveError(Exception):
    """A refusal before any work (the folders, the lake's layout): names what and how to fix it."""


# --- one site-day (runs in a worker process or a Spark task) --------------------------------------


def _reset_peak_rss():
    """Starts a task's peak memory afresh (a worker runs many tasks): Linux resets the process's
    high-water mark VmHWM on `5` written to /proc/self/clear_refs; elsewhere the peak stays the
    process's own since it started."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def _peak_rss_mb():
    """The task's peak resident memory in MB (VmHWM since _reset_peak_rss; else the process's)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return round(int(line.split()[1]) / 1024.0, 1)
    except (OSError, ValueError, IndexError):
        pass
    try:
        import resource

        return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)
    except Exception:  # noqa: BLE001 - not on every platform
        return None


def run_task(task):
    """One site-day: returns trajdb_archive_task's result {row (the state row), scratch,
    calibration (the folder of a calibration made today, or None)} with this process's `run`
    (seconds, peak memory), or failed_result's. Never raises: a failure is the row's error.
    The day itself is the extension's (`trajdb_archive_task`, src/archive/: the same function
    `CALL trajdb_archive` runs), in a private database of one thread; this process measures it."""
    t0 = time.perf_counter()
    _reset_peak_rss()
    try:
        check_duckdb()
        con = W.connect(task["extension"], threads=1)
        try:
            spec = {k: task.get(k) for k in ("site", "date", "files", "site_column", "inputs", "fingerprint", "cal_id", "cal_dir", "scratch",
                                             "params", "params_json", "build", "memory_limit")}
            res = json.loads(con.execute("FROM trajdb_archive_task(?)", [json.dumps(spec)]).fetchone()[0])
        finally:
            con.close()
    except Exception as e:  # noqa: BLE001 - a partition's failure is reported, the others go on
        return failed_result(task, f"{type(e).__name__}: {e}".strip())
    res["run"] = {"seconds": round(time.perf_counter() - t0, 2), "peak_rss_mb": _peak_rss_mb()}
    return res


class Progress:
    """partitions done / total, points/s, time left: one line rewritten on a terminal, plain
    lines in a log."""

    def __init__(self, total, stream=None, enabled=True):
        self.total, self.done, self.points, self.failed, self.t0 = total, 0, 0, 0, time.perf_counter()
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.tty = enabled and hasattr(self.stream, "isatty") and self.stream.isatty()

    def update(self, res):
        self.done += 1
        row = res["row"]
        self.points += row.get("points") or 0
        self.failed += row["status"] != "ok"
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        rate = self.points / el if el > 0 else 0.0
        left = el / self.done * (self.total - self.done)
        what = f"site {row['site']} {row['date']} {row['status']}"
        if row["status"] != "ok":
            what += f": {row['error'][:160]}"
        self.total = max(self.total, self.done)
        line = (f"[trajdb] archive {self.done}/{self.total} partitions, {rate:,.0f} points/s, "
                f"{_eta(left)} left ({what})")
        if self.tty:
            self.stream.write("\r\033[K" + line)
            if self.done >= self.total:
                self.stream.write("\n")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


def _eta(s):
    s = int(round(s))
    return f"{s // 3600} h {s % 3600 // 60:02d} min" if s >= 3600 else (f"{s // 60} min {s % 60:02d} s" if s >= 60 else f"{s} s")


def _local_executor(workers):
    """Tasks in `workers` worker processes, one thread each: `python -m trajdb.archives --worker`,
    one task per line of JSON in; per task the worker answers `took` (it has the task) and then
    its result, one line each. Subprocesses, not multiprocessing: a caller's script without
    `if __name__ == "__main__":` is not run again in each worker, and DuckDB is never forked.
    A worker that ended before it took a task (killed between tasks) is replaced and the task
    sent again; one that ended while running it fails that partition alone. When the driver
    stops (an interrupt, an error), no worker takes another task and the running ones are
    killed: nothing goes on behind a stopped run."""
    import queue
    import subprocess
    import threading

    def run(tasks, on_done):
        if not tasks:
            return
        todo = queue.Queue()
        for t in tasks:
            todo.put(t)
        results = queue.Queue()
        stop = threading.Event()
        procs, procs_lock = set(), threading.Lock()
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
                                                          + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])}

        def spawn():
            p = subprocess.Popen([sys.executable, "-m", "trajdb.archives", "--worker"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                 env=env, text=True, bufsize=1)
            with procs_lock:
                procs.add(p)
            return p

        def end(p):
            with procs_lock:
                procs.discard(p)
            try:
                p.stdin.close()
                p.wait(timeout=30)
            except Exception:  # noqa: BLE001 - a worker that will not stop is killed
                p.kill()

        def send(p, t):
            """(worker, its result line): "" when it died while running the task. A worker that
            ended before it took the task (no `took`) is replaced and the task sent again, once."""
            for attempt in range(2):
                try:
                    p.stdin.write(json.dumps(t) + "\n")
                    p.stdin.flush()
                    took = p.stdout.readline()
                except OSError:  # BrokenPipeError: it had ended
                    took = ""
                if took.strip() == "took":
                    return p, p.stdout.readline()
                if took:  # not the protocol: a result-shaped line or garbage, as the result
                    return p, took
                end(p)
                if attempt or stop.is_set():
                    return None, ""
                p = spawn()
            return None, ""

        def worker():
            p, t = None, None
            try:
                p = spawn()
                while not stop.is_set():
                    try:
                        t = todo.get_nowait()
                    except queue.Empty:
                        return
                    q, line = send(p, t)
                    if not line:  # the worker died (killed, out of memory): the task failed, a new worker goes on
                        status = (q or p).poll()
                        results.put(_died(t, status))
                        t = None
                        if q is not None:
                            end(q)
                        p = None
                        if stop.is_set():
                            return
                        p = spawn()
                        continue
                    p = q
                    try:
                        results.put(json.loads(line))
                    except ValueError:
                        results.put(_died(t, f"(it wrote {line[:200]!r})"))
                    t = None
            except BaseException as e:  # noqa: BLE001 - never leave the driver waiting for a result
                if t is not None:
                    results.put(failed_result(t, f"the archive's worker thread failed on this partition: {type(e).__name__}: {e}"))
            finally:
                if p is not None:
                    end(p)

        threads = [threading.Thread(target=worker, daemon=True) for _ in range(max(1, min(workers, len(tasks))))]
        for th in threads:
            th.start()
        got = 0
        try:
            while got < len(tasks):
                try:
                    res = results.get(timeout=1.0)
                except queue.Empty:
                    if any(th.is_alive() for th in threads):
                        continue
                    # every worker thread ended: what is still queued never ran
                    while True:
                        try:
                            t = todo.get_nowait()
                        except queue.Empty:
                            break
                        results.put(failed_result(t, "no archive worker was left to run this partition"))
                    if results.empty():
                        raise ArchiveError(f"trajdb archive: {len(tasks) - got} partitions were lost by the worker threads (a bug: please report it)")
                    continue
                got += 1
                on_done(res)
        except BaseException:
            # the driver stops (Ctrl-C in a notebook, an error committing): no new task, and the
            # running workers killed (their scratch is removed by the next run)
            stop.set()
            with procs_lock:
                running = list(procs)
            for p in running:
                try:
                    p.kill()
                except OSError:
                    pass
            raise
        for th in threads:
            th.join()

    return run


def failed_result(task, error):
    """The result of a task that could not report one itself (its process died, its Spark task
    failed every attempt): trajdb_archive_commit records the partition failed with `error`."""
    return {"task": {k: v for k, v in task.items() if k != "extension"}, "error": str(error)[:2000]}


def _died(task, status):
    return failed_result(task, f"the worker process ended with status {status} while running this partition (killed, or out of memory?)")


def _die_with_driver():
    """A worker ends when its driver does (kill -9 included): Linux sends it SIGKILL when the
    thread that started it ends (PR_SET_PDEATHSIG); elsewhere it ends at its next task (stdin
    closed). Without this a killed run's workers went on computing days no one would commit."""
    try:
        import ctypes
        import signal

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG = 1
    except Exception:  # noqa: BLE001 - not Linux
        pass


def _worker_main():
    _die_with_driver()  # (a driver that died before this line: stdin's end ends the worker)
    # the protocol owns the original stdout; anything else printed (by Python or C code) goes to stderr
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    # (tests: TRAJDB_ARCHIVE_WORKER_TASKS=n makes a worker end after n tasks, as one killed
    # between tasks would: tests/test_archive_python.py)
    quit_after = int(os.environ.get("TRAJDB_ARCHIVE_WORKER_TASKS") or 0)
    n = 0
    for line in sys.stdin:
        if line.strip():
            task = json.loads(line)
            proto.write("took\n")  # the task is this worker's now (a worker that dies before this is replaced)
            proto.flush()
            proto.write(json.dumps(run_task(task)) + "\n")
            proto.flush()
            n += 1
            if quit_after and n >= quit_after:
                os._exit(0)


def _refusal(e, fn):
    """DuckDB's error of one of the extension's archive functions, as the archive's own."""
    msg = str(e).split("\n\nLINE ")[0].strip()
    if f"{fn}: " in msg:
        msg = msg.split(f"{fn}: ", 1)[1]
    return ArchiveError(msg)


def run(lake, out, params=None, site=None, workers=None, extension=None, progress=True, executor=None, stream=None, max_rounds=None,
        task_memory=None):
    """The archive run (module docstring). The decisions are the extension's (trajdb_archive_open,
    _next, _commit, _close: crates/app/src/archive, src/archive/); this function runs each
    round's tasks with `executor(tasks, on_done)` (default: local worker processes; trajdb.spark
    gives Spark's) and shows progress. Returns a summary dict: partitions, done (partitions run
    this run), runs (day runs: a day run again after an earlier day's camera change counts
    twice), skipped, failed (in the state after the run), failed_partitions, changes (camera
    changes found this run, each with its message), rounds, seconds, out, orphaned."""
    import threading

    check_duckdb()
    t0 = time.perf_counter()
    from . import extension_path

    extension = extension or extension_path()
    con = W.connect(extension, threads=1)
    try:
        try:
            named = {"out_dir": os.path.abspath(os.fspath(out)), "site": site, "task_memory": task_memory,
                     "params": _params_json(params or {}, "trajdb.archive")}
            named = {k: v for k, v in named.items() if v is not None}  # (the names are these four, never a caller's)
            sql = "FROM trajdb_archive_open(?" + "".join(f", {k} := ?" for k in named) + ")"
            h, _, due, out, _ = con.execute(sql, [os.path.abspath(os.fspath(lake)), *named.values()]).fetchone()
        except duckdb.Error as e:
            raise _refusal(e, "trajdb_archive_open") from None
        closed = False
        try:
            executor = executor or _local_executor(workers or os.cpu_count() or 1)
            prog = Progress(due, stream=stream, enabled=progress)
            lock = threading.Lock()
            rounds = 0
            while True:
                tasks = [json.loads(r[0]) for r in con.execute("FROM trajdb_archive_next(?)", [h]).fetchall()]
                if not tasks:
                    break
                rounds += 1
                if max_rounds is not None and rounds > max_rounds:
                    break
                prog.total = max(prog.total, prog.done + len(tasks))
                for t in tasks:
                    t["extension"] = extension

                def on_done(res):
                    with lock:  # (one connection: one commit at a time)
                        run = res.pop("run", None) or {}
                        if "task" not in res and run:  # as the host measured it (the process's own time and peak)
                            res["peak_rss_mb"] = run.get("peak_rss_mb")
                            res["seconds"] = run.get("seconds") or res.get("seconds") or 0.0
                        row = json.loads(con.execute("FROM trajdb_archive_commit(?, ?)", [h, json.dumps(res)]).fetchone()[0])
                        prog.update({"row": row})

                executor(tasks, on_done)
            summary = json.loads(con.execute("FROM trajdb_archive_close(?)", [h]).fetchone()[0])
            closed = True
        finally:
            if not closed:
                # what was committed is recorded, also when the run stops here (an interrupt)
                try:
                    con.execute("FROM trajdb_archive_close(?)", [h]).fetchall()
                except duckdb.Error:
                    pass
    finally:
        con.close()
    changes = [{"site": c["site"], "date": c["date"], "camera": c["camera"], "pairs": c["pairs"], "message": c["message"]} for c in summary["changes"]]
    return {"partitions": summary["partitions"], "done": summary["done"], "runs": summary["runs"], "skipped": summary["skipped"],
            "failed": summary["failed"], "failed_partitions": summary["failed_partitions"], "changes": changes, "rounds": rounds,
            "seconds": round(time.perf_counter() - t0, 2), "out": out, "orphaned": summary["orphaned"]}


def export_day(out, site, date, dest, con=None):
    """One partition of an archive as a `trajdb pipeline` results folder `dest` (a new folder):
    merged.parquet, matches.csv, links.csv, transforms.csv, calibration.csv and report.html, for
    the tools that read one (trajdb score, analysis.sql)."""
    dest = os.path.abspath(dest)
    if os.path.lexists(dest) and not (os.path.isdir(dest) and not os.path.islink(dest) and not os.listdir(dest)):
        raise ArchiveError(f"trajdb archive: {dest!r} exists and is not an empty folder; name a new folder")
    part = lambda folder, name: os.path.join(out, folder, f"site={site}", f"date={date}", name)  # noqa: E731
    if not os.path.exists(part("road_users", "part-0.parquet")):
        raise ArchiveError(f"trajdb archive: {out!r} has no partition site={site}/date={date}")
    # written whole beside dest, then renamed onto it: a failure leaves no half-written folder
    stage = f"{dest}.trajdb-tmp-{os.getpid()}-{time.time_ns()}"
    os.makedirs(stage)
    own = con is None
    con = con or duckdb.connect()
    try:
        shutil.copyfile(part("road_users", "part-0.parquet"), os.path.join(stage, "merged.parquet"))
        shutil.copyfile(part("reports", "report.html"), os.path.join(stage, "report.html"))
        for folder in ("matches", "links", "transforms", "calibration"):
            name = folder + ".csv"
            # the file's own columns only (no site and date guessed from its path)
            con.execute(f"COPY (FROM read_parquet(?, hive_partitioning = false)) TO {_literal(os.path.join(stage, name))} (HEADER, DELIMITER ',')",
                        [part(folder, "part-0.parquet")])
        if os.path.isdir(dest):
            os.rmdir(dest)  # empty (checked above); fails, keeping the stage for no one, if a file appeared since
        os.replace(stage, dest)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    finally:
        if own:
            con.close()
    return dest


if __name__ == "__main__" and sys.argv[1:] == ["--worker"]:
    _worker_main()
