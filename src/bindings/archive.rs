//! SQL: an archive of site-days in one call (issue 40; docs/archive.md).
//! - `trajdb_archive(lake, out_dir := ..., <parameter> := value, ...)`: the whole archive run
//!   (src/archive/: the due site-days, each in a private database of one thread);
//! - `trajdb_archive_task(task)`: one site-day, for hosts that run the days in processes of
//!   their own (Python's workers, Spark tasks): the same function, so every host writes the
//!   same bytes.

use super::common::{pipeline_param, N_PARAMS};
use super::registry::{pd, Function, Section, Table, Ty};
use super::types::Param;
use super::vector::table::{self, BindArgs, Rows, TableFn};
use crate::archive::{self, ArchiveRequest, Driver, PartitionRow, TaskSpec};
use crate::runner::Settings;
use std::error::Error;
use std::sync::{Arc, Mutex};

pub static FUNCTIONS: &[Function] = &[ARCHIVE, TASK, OPEN, NEXT, COMMIT, CLOSE];

/// The call's own named parameters.
const OWN: [Param; 4] = [
    pd("out_dir", Ty::Varchar, "the archive folder: new, empty or an archive of this lake (required)"),
    pd("site", Ty::Varchar, "the site's name for a lake of date=D/ folders without a site column (default: the lake folder's name)"),
    pd("task_memory", Ty::Varchar, "the memory limit of each site-day's private database, as DuckDB's memory_limit (default '1.5GB')"),
    pd("workers", Ty::Bigint, "site-days run at once, 1 to 256 (default: this connection's threads)"),
];

/// The call's own named parameters, then every declared pipeline parameter.
static ARCHIVE_NAMED: [Param; N_PARAMS + 4] = {
    let mut a = [OWN[0]; N_PARAMS + 4];
    let mut k = 0;
    while k < 4 {
        a[k] = OWN[k];
        k += 1;
    }
    while k < N_PARAMS + 4 {
        a[k] = pipeline_param(k - 4);
        k += 1;
    }
    a
};

const ARCHIVE_COLUMNS: &[(&str, Ty)] = &[
    ("site", Ty::Varchar),
    ("date", Ty::Varchar),
    ("status", Ty::Varchar),
    ("ran", Ty::Boolean),
    ("cameras", Ty::Bigint),
    ("points", Ty::Bigint),
    ("road_users", Ty::Bigint),
    ("matches", Ty::Bigint),
    ("calibration", Ty::Varchar),
    ("calibration_made", Ty::Boolean),
    ("changes", Ty::Varchar),
    ("warnings", Ty::Varchar),
    ("error", Ty::Varchar),
];

const LAKE: Param = pd("lake", Ty::Varchar, "the lake's folder: Parquet or CSV files under site=S/date=D/, or date=D/ of one site");

const ARCHIVE_TABLE: Table = Table { params: &[LAKE], named: &ARCHIVE_NAMED, columns: ARCHIVE_COLUMNS, register: table::register::<ArchiveFn> };

const ARCHIVE: Function = Function {
    name: "trajdb_archive",
    description: "An archive in one statement: `CALL trajdb_archive('lake', out_dir := 'archive')`. `lake` is a folder of Parquet or CSV \
                  files under site=S/date=D/ (hive style), or date=D/ of one site (`site := 'name'`, else the folder's name), or date=D/ \
                  whose files have a site column. `out_dir` receives road_users/, matches/, links/, transforms/, calibration/ and \
                  reports/ as site=S/date=D/ partitions, the sites' kept calibrations and the state (_state/partitions.parquet): it \
                  must be new, empty or an archive of this lake. Incremental: a second call runs only new or changed partitions (and \
                  days whose site calibration changed); a killed call is resumed by the next, to the same bytes. Each site's calibration \
                  is made from its first day, kept, and checked on every later day; a camera that moved or whose clock jumped is \
                  registered again from that day and reported (changes, warnings, the day's report). `workers` site-days run at once \
                  (default: this connection's threads), each in a private database of one thread with `task_memory` (default 1.5GB); \
                  every other named parameter is a pipeline parameter (`FROM trajdb_params()`). The same work and bytes as \
                  `trajdb archive` and trajdb.spark.archive. Returns one row per site-day run, as it is committed (`ran` true: its \
                  status, counts, the calibration in effect, its camera changes as JSON, warnings and error; a day run again after an \
                  earlier day's camera change has a second row), then one row per partition of the lake this call did not run (`ran` \
                  false: its state). A failed partition does not stop the others. An interrupt stops the call between batches of \
                  site-days; what was committed is kept, and the next call goes on from there.",
    example: "SELECT count(*) = 1 FROM duckdb_functions() WHERE function_name = 'trajdb_archive'; -- true",
    maths: "crates/app/src/archive/, src/archive/",
    binding: file!(),
    section: Section::Archive,
    see_also: &["trajdb_archive_open", "trajdb_archive_task", "trajdb_pipeline", "frame_change"],
    signatures: &[],
    table: Some(ARCHIVE_TABLE),
};

/// The build id of this extension (crates/app/src/archive/fingerprint.rs `build`), and the
/// DuckDB that runs it: another DuckDB writes other Parquet bytes and may round a last digit
/// otherwise, so an archive made by one is not taken as done by another.
fn build_id() -> Result<String, Box<dyn Error>> {
    let file = super::vector::extension_file().ok_or("cannot find the file this extension was loaded from (its bytes name the build)")?;
    let build = crate::app::archive::fingerprint::build(env!("CARGO_PKG_VERSION"), &file)
        .map_err(|e| format!("cannot read the extension file {} to name the build: {e}", file.display()))?;
    let con = duckdb::Connection::open_in_memory()?;
    let version: String = con.query_row("SELECT library_version FROM pragma_version()", [], |r| r.get(0))?;
    Ok(format!("{build}+duckdb-{version}"))
}

fn base_settings(args: &BindArgs<'_>) -> Settings {
    let flag = |name: &str| args.setting(name).map(|v| v.eq_ignore_ascii_case("true"));
    Settings { autoinstall: flag("autoinstall_known_extensions"), autoload: flag("autoload_known_extensions"), ..Settings::default() }
}

/// The request of trajdb_archive or trajdb_archive_open, its folders checked against this
/// connection's sandbox: it must be allowed to write the archive and to read every file of the
/// lake (its own file system has the last word: src/bindings/vector/fs.rs).
fn request(args: &BindArgs<'_>, params: Vec<(String, String)>, workers: usize) -> Result<ArchiveRequest, Box<dyn Error>> {
    let lake = args.text(0)?.ok_or("lake is NULL; give the lake's folder (site=S/date=D/ partitions), e.g. 'lake'")?;
    if lake.trim().is_empty() || lake.contains('\0') {
        return Err(format!("lake is {lake:?}; give the lake's folder (site=S/date=D/ partitions), e.g. 'lake'").into());
    }
    let out = args.named_text("out_dir")?.ok_or("out_dir is missing: name the archive folder, e.g. out_dir := 'archive'")?;
    if out.trim().is_empty() || out.contains('\0') {
        return Err(format!("out_dir is {out:?}; name the archive folder, e.g. out_dir := 'archive'").into());
    }
    let site = args.named_text("site")?;
    let task_memory = args.named_text("task_memory")?;
    // the paths as the sandbox check resolves them (`~`, `..`, links) are the paths written to
    super::common::may_write_into(args, &out)?;
    let out = crate::app::archive::folder::resolve(std::path::Path::new(&out))?;
    let lake = crate::app::archive::folder::resolve(std::path::Path::new(&lake))?;
    // every file of the lake checked before any is read (a site column is read to split a
    // date=D/ lake: only through a database allowed exactly these files)
    let fs = args.caller_fs()?;
    archive::partitions(&lake, site.as_deref(), &|f| fs.may_read(&f.to_string_lossy()))?;
    Ok(ArchiveRequest { lake, out, site, params, task_memory, workers, build: build_id()? })
}

struct ArchiveFn;

pub struct ArchiveBind {
    req: ArchiveRequest,
    base: Settings,
    limits: Arc<crate::algo::limits::Limits>,
}

/// The call's driver (opened on the first call), then its rows.
pub struct ArchiveScan(Mutex<(Option<Driver>, Vec<PartitionRow>, bool)>);

impl TableFn for ArchiveFn {
    const TABLE: &'static Table = &ARCHIVE_TABLE;
    type Bind = ArchiveBind;
    type Scan = ArchiveScan;

    fn bind(args: &BindArgs<'_>) -> Result<ArchiveBind, Box<dyn Error>> {
        let workers = match args.named_bigint("workers")? {
            Some(w) if !(1..=256).contains(&w) => return Err(format!("workers = {w}: give 1 to 256 site-days at once").into()),
            Some(w) => w as usize,
            None => args.setting("threads").and_then(|t| t.trim().parse::<usize>().ok()).unwrap_or(1).clamp(1, 256),
        };
        let params: Vec<(String, String)> =
            args.named_as_text()?.into_iter().filter(|(k, _)| !OWN.iter().any(|o| o.name == k.as_str())).collect();
        let req = request(args, params, workers)?;
        Ok(ArchiveBind { req, base: base_settings(args), limits: Arc::clone(args.limits()) })
    }
    fn init(_: &ArchiveBind) -> Result<ArchiveScan, Box<dyn Error>> {
        Ok(ArchiveScan(Mutex::new((None, Vec::new(), false))))
    }
    fn func(bind: &ArchiveBind, scan: &ArchiveScan, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        let mut g = scan.0.lock().unwrap_or_else(|e| e.into_inner());
        let (driver, pending, finished) = &mut *g;
        // one batch of site-days per call, its rows returned as they are committed: an interrupt
        // stops the call between batches (what was committed stays in the state)
        while pending.is_empty() && !*finished {
            if driver.is_none() {
                *driver = Some(Driver::open(bind.req.clone(), bind.base.clone())?);
            }
            let d = driver.as_mut().expect("opened");
            let limits = Arc::clone(&bind.limits);
            let register = move |con: &duckdb::Connection| super::register_all_with(con, Arc::clone(&limits));
            match d.step(&register)? {
                Some(rows) => pending.extend(rows),
                None => {
                    pending.extend(d.finish()?.rows.into_iter().filter(|r| !r.ran));
                    *finished = true;
                    *driver = None; // the lock released
                }
            }
        }
        let n = pending.len().min(Rows::CAPACITY);
        for (r, pr) in pending.drain(..n).enumerate() {
            let s = &pr.row;
            out.text(0, r, &s.site);
            out.text(1, r, &s.date);
            out.text(2, r, &s.status);
            out.boolean(3, r, pr.ran);
            out.opt_bigint(4, r, s.cameras);
            out.opt_bigint(5, r, s.points);
            out.opt_bigint(6, r, s.road_users);
            out.opt_bigint(7, r, s.matches);
            out.opt_text(8, r, s.calibration_out.as_deref());
            out.opt_boolean(9, r, s.calibration_made);
            out.opt_text(10, r, s.changes.as_deref());
            out.opt_text(11, r, s.warnings.as_deref());
            out.opt_text(12, r, s.error.as_deref());
        }
        Ok(n)
    }
}

const TASK_TABLE: Table = Table {
    params: &[pd("task", Ty::Varchar, "one site-day as the driver plans it: the JSON of a trajdb_archive_next row")],
    named: &[],
    columns: &[("result", Ty::Varchar)],
    register: table::register::<TaskFn>,
};

const TASK: Function = Function {
    name: "trajdb_archive_task",
    description: "One site-day of an archive, for hosts that run the days in processes of their own (python/trajdb/archives.py's workers, \
                  trajdb.spark tasks): `task` is the JSON the driver plans (site, date, files, inputs, fingerprint, cal_id, cal_dir, \
                  scratch, params, params_json, build, memory_limit); returns one row, `result`: JSON of the partition's state row, \
                  its scratch folder and the calibration it made. The day runs in a private database of one thread (src/archive/), \
                  allowed to read the partition's and the calibration's files and to write the scratch folder. A failed day is a \
                  row with status 'failed' and its error, never an error of the call (bad JSON is one).",
    example: "SELECT count(*) = 1 FROM duckdb_functions() WHERE function_name = 'trajdb_archive_task'; -- true",
    maths: "src/archive/",
    binding: file!(),
    section: Section::Archive,
    see_also: &["trajdb_archive_open", "trajdb_archive_commit"],
    signatures: &[],
    table: Some(TASK_TABLE),
};

struct TaskFn;

impl TableFn for TaskFn {
    const TABLE: &'static Table = &TASK_TABLE;
    type Bind = (TaskSpec, Settings, Arc<crate::algo::limits::Limits>);
    type Scan = Mutex<bool>;

    fn bind(args: &BindArgs<'_>) -> Result<Self::Bind, Box<dyn Error>> {
        let text = args.text(0)?.ok_or("task is NULL; give the JSON of one site-day (python/trajdb/archives.py plans it)")?;
        let mut task: TaskSpec = serde_json::from_str(&text).map_err(|e| format!("task is not the JSON of a site-day: {e}"))?;
        // every path as the sandbox check resolves it (`~`, `..`, links) is the path used
        let abs = |p: &str| crate::app::outdir::absolute(p).map(|p| p.to_string_lossy().into_owned());
        let fs = args.caller_fs()?;
        for f in task.files.iter_mut() {
            fs.may_read(f)?;
            *f = abs(f)?;
        }
        if let Some(d) = task.cal_dir.as_mut() {
            *d = abs(d)?;
            for e in std::fs::read_dir(&*d).map_err(|e| format!("task.cal_dir {d:?}: {e}"))?.flatten() {
                fs.may_read(&e.path().to_string_lossy())?;
            }
        }
        let scratch = std::path::PathBuf::from(abs(&task.scratch)?);
        let parent = scratch.parent().ok_or("task.scratch has no folder")?;
        super::common::may_write_into(args, &parent.to_string_lossy())?;
        task.scratch = scratch.to_string_lossy().into_owned();
        Ok((task, base_settings(args), Arc::clone(args.limits())))
    }
    fn init(_: &Self::Bind) -> Result<Self::Scan, Box<dyn Error>> {
        Ok(Mutex::new(false))
    }
    fn func(bind: &Self::Bind, done: &Self::Scan, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        let mut d = done.lock().unwrap_or_else(|e| e.into_inner());
        if *d {
            return Ok(0);
        }
        *d = true;
        let limits = Arc::clone(&bind.2);
        let register = move |con: &duckdb::Connection| super::register_all_with(con, Arc::clone(&limits));
        let r = archive::run_task(&bind.0, &bind.1, &register);
        out.text(0, 0, &serde_json::to_string(&r)?);
        Ok(1)
    }
}

// --- a driver step by step, for hosts that run the site-days themselves -------------------------

/// The drivers opened by trajdb_archive_open in this process, by handle (each holds its
/// archive's lock until trajdb_archive_close, or until the process ends).
static DRIVERS: Mutex<Vec<(i64, Driver)>> = Mutex::new(Vec::new());
/// A handle no other connection can guess (a connection that was not given it cannot drive,
/// commit into or close another's run): 62 random bits.
fn new_handle() -> i64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0));
    h.write_u32(std::process::id());
    (h.finish() >> 2) as i64
}

fn with_driver<T>(h: i64, f: impl FnOnce(&mut Driver) -> Result<T, Box<dyn Error>>) -> Result<T, Box<dyn Error>> {
    let mut g = DRIVERS.lock().unwrap_or_else(|e| e.into_inner());
    let d = g.iter_mut().find(|(k, _)| *k == h).map(|(_, d)| d).ok_or_else(|| format!("handle {h} is no open archive run (trajdb_archive_open gives one; trajdb_archive_close ends it)"))?;
    f(d)
}

fn handle_arg(args: &BindArgs<'_>) -> Result<i64, Box<dyn Error>> {
    Ok(args.bigint(0)?.ok_or("handle is NULL; give the handle trajdb_archive_open returned")?)
}

type Action = Box<dyn FnOnce() -> Result<Vec<Vec<Option<String>>>, Box<dyn Error>> + Send + Sync>;

/// What a step does, decided at bind (the arguments read and checked) and done once, at the
/// first call of the scan (a bind may run again; the work must not).
pub struct Once(Mutex<Option<Action>>);

fn emit(once: &Once, out: &mut Rows<'_>, kinds: &[Ty]) -> Result<usize, Box<dyn Error>> {
    let Some(action) = once.0.lock().unwrap_or_else(|e| e.into_inner()).take() else { return Ok(0) };
    let rows = action()?;
    if rows.len() > Rows::CAPACITY {
        return Err(format!("{} rows for one chunk of {} (a bug: please report it)", rows.len(), Rows::CAPACITY).into());
    }
    for (r, row) in rows.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            match (kinds[c], v) {
                (Ty::Bigint, Some(v)) => out.bigint(c, r, v.parse()?),
                (_, v) => out.opt_text(c, r, v.as_deref()),
            }
        }
    }
    Ok(rows.len())
}

macro_rules! step_fn {
    ($t:ident, $table:ident, $kinds:expr, |$args:ident| $body:block) => {
        struct $t;
        impl TableFn for $t {
            const TABLE: &'static Table = &$table;
            type Bind = Mutex<Option<Action>>;
            type Scan = Once;
            fn bind($args: &BindArgs<'_>) -> Result<Self::Bind, Box<dyn Error>> {
                let action: Action = $body;
                Ok(Mutex::new(Some(action)))
            }
            fn init(b: &Self::Bind) -> Result<Once, Box<dyn Error>> {
                Ok(Once(Mutex::new(b.lock().unwrap_or_else(|e| e.into_inner()).take())))
            }
            fn func(_: &Self::Bind, once: &Once, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
                emit(once, out, $kinds)
            }
        }
    };
}

/// The run a step belongs to.
const HANDLE: Param = pd("handle", Ty::Bigint, "the run's handle, from trajdb_archive_open");

const OPEN_TABLE: Table = Table {
    params: &[LAKE],
    named: &[OWN[0], OWN[1], OWN[2], pd("params", Ty::Varchar, "a JSON object of pipeline parameters, e.g. '{\"merge_eta\": 0.6}'; default: every default")],
    columns: &[("handle", Ty::Bigint), ("partitions", Ty::Bigint), ("due", Ty::Bigint), ("out_dir", Ty::Varchar), ("build", Ty::Varchar)],
    register: table::register::<OpenFn>,
};

const OPEN: Function = Function {
    name: "trajdb_archive_open",
    description: "Opens an archive run for a host that runs the site-days itself (python/trajdb/archives.py's worker processes, \
                  trajdb.spark): the lake read, `out_dir` claimed and locked, the state loaded, as trajdb_archive does; `params` a JSON \
                  object of pipeline parameters. Returns one row: the run's handle, the lake's partitions, how many need work now, the \
                  archive folder and the build. Then trajdb_archive_next(handle) gives each round's tasks, the host runs each with \
                  trajdb_archive_task and hands its result to trajdb_archive_commit(handle, result), and trajdb_archive_close(handle) \
                  ends the run (the lock is held until then, or until the process ends).",
    example: "SELECT count(*) = 1 FROM duckdb_functions() WHERE function_name = 'trajdb_archive_open'; -- true",
    maths: "crates/app/src/archive/, src/archive/",
    binding: file!(),
    section: Section::Archive,
    see_also: &["trajdb_archive_next", "trajdb_archive_task", "trajdb_archive_commit", "trajdb_archive_close"],
    signatures: &[],
    table: Some(OPEN_TABLE),
};

step_fn!(OpenFn, OPEN_TABLE, &[Ty::Bigint, Ty::Bigint, Ty::Bigint, Ty::Varchar, Ty::Varchar], |args| {
    let params = crate::app::params::from_json(&args.named_text("params")?.unwrap_or_default())?;
    let req = request(args, params, 1)?;
    let base = base_settings(args);
    Box::new(move || {
        let d = Driver::open(req, base).map_err(|e| {
            let open_here = DRIVERS.lock().map(|g| !g.is_empty()).unwrap_or(false);
            if open_here && e.to_string().contains("another trajdb archive is writing") {
                format!("{e} (a run opened in this process with trajdb_archive_open and not closed holds it: trajdb_archive_close(handle) ends it)").into()
            } else {
                e
            }
        })?;
        let h = new_handle();
        let (parts, due) = d.counts();
        let row = vec![Some(h.to_string()), Some(parts.to_string()), Some(due.to_string()), Some(d.out().to_string_lossy().into_owned()), Some(d.build().to_string())];
        DRIVERS.lock().unwrap_or_else(|e| e.into_inner()).push((h, d));
        Ok(vec![row])
    })
});

const NEXT_TABLE: Table =
    Table { params: &[HANDLE], named: &[], columns: &[("task", Ty::Varchar)], register: table::register::<NextFn> };

const NEXT: Function = Function {
    name: "trajdb_archive_next",
    description: "The next round's site-days of an open archive run (trajdb_archive_open): one row per task, the JSON that \
                  trajdb_archive_task takes; no row when the archive is done. The state of the round before is saved first.",
    example: "SELECT count(*) = 1 FROM duckdb_functions() WHERE function_name = 'trajdb_archive_next'; -- true",
    maths: "crates/app/src/archive/plan.rs, src/archive/",
    binding: file!(),
    section: Section::Archive,
    see_also: &["trajdb_archive_open", "trajdb_archive_task"],
    signatures: &[],
    table: Some(NEXT_TABLE),
};

step_fn!(NextFn, NEXT_TABLE, &[Ty::Varchar], |args| {
    let h = handle_arg(args)?;
    Box::new(move || {
        let tasks = with_driver(h, |d| d.next_round())?.unwrap_or_default();
        let mut rows = Vec::with_capacity(tasks.len());
        for t in tasks {
            rows.push(vec![Some(serde_json::to_string(&t)?)]);
        }
        Ok(rows)
    })
});

const COMMIT_TABLE: Table = Table {
    params: &[
        HANDLE,
        pd("result", Ty::Varchar, "trajdb_archive_task's result JSON, or {\"task\": <the task's JSON>, \"error\": \"...\"} for a task that reported none"),
    ],
    named: &[],
    columns: &[("row", Ty::Varchar)],
    register: table::register::<CommitFn>,
};

const COMMIT: Function = Function {
    name: "trajdb_archive_commit",
    description: "Commits one site-day of an open archive run: `result` is trajdb_archive_task's JSON (with `peak_rss_mb` when the host \
                  measured it), or {\"task\": <the task's JSON>, \"error\": \"...\"} for a task that could not report one (its process \
                  died, its Spark task failed every attempt). Its files are moved into place, then it is recorded in the state; \
                  returns the partition's state row as JSON.",
    example: "SELECT count(*) = 1 FROM duckdb_functions() WHERE function_name = 'trajdb_archive_commit'; -- true",
    maths: "crates/app/src/archive/folder.rs, src/archive/",
    binding: file!(),
    section: Section::Archive,
    see_also: &["trajdb_archive_task", "trajdb_archive_close"],
    signatures: &[],
    table: Some(COMMIT_TABLE),
};

#[derive(serde::Deserialize)]
struct Unreported {
    task: TaskSpec,
    error: String,
}

step_fn!(CommitFn, COMMIT_TABLE, &[Ty::Varchar], |args| {
    let h = handle_arg(args)?;
    let text = args.text(1)?.ok_or("result is NULL; give trajdb_archive_task's result")?;
    let res = match serde_json::from_str::<archive::TaskResult>(&text) {
        Ok(r) => r,
        Err(e) => match serde_json::from_str::<Unreported>(&text) {
            Ok(u) => archive::TaskResult::failed(&u.task, &u.error),
            Err(_) => return Err(format!("result is not trajdb_archive_task's JSON (nor {{\"task\", \"error\"}}): {e}").into()),
        },
    };
    Box::new(move || {
        let row = with_driver(h, |d| d.commit(res))?;
        Ok(vec![vec![Some(serde_json::to_string(&row)?)]])
    })
});

const CLOSE_TABLE: Table =
    Table { params: &[HANDLE], named: &[], columns: &[("summary", Ty::Varchar)], register: table::register::<CloseFn> };

const CLOSE: Function = Function {
    name: "trajdb_archive_close",
    description: "Ends an open archive run: the state saved, the sites' index pages written, the lock released. Returns one row, \
                  the run's summary as JSON (partitions, done, runs, skipped, failed, failed_partitions, changes with their sentences, \
                  rounds, orphaned, and every partition's state row with `ran`).",
    example: "SELECT count(*) = 1 FROM duckdb_functions() WHERE function_name = 'trajdb_archive_close'; -- true",
    maths: "src/archive/",
    binding: file!(),
    section: Section::Archive,
    see_also: &["trajdb_archive_open"],
    signatures: &[],
    table: Some(CLOSE_TABLE),
};

step_fn!(CloseFn, CLOSE_TABLE, &[Ty::Varchar], |args| {
    let h = handle_arg(args)?;
    Box::new(move || {
        let mut d = {
            let mut g = DRIVERS.lock().unwrap_or_else(|e| e.into_inner());
            let k = g.iter().position(|(k, _)| *k == h).ok_or_else(|| format!("handle {h} is no open archive run (trajdb_archive_open gives one)"))?;
            g.remove(k).1
        };
        let summary = d.finish()?;
        Ok(vec![vec![Some(serde_json::to_string(&summary)?)]])
    })
});
