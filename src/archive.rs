//! An archive's site-days run in private databases (issue 40; docs/archive.md): one day's task
//! ([`run_task`], the same on every host: `CALL trajdb_archive`, a Python worker through
//! `trajdb_archive_task`, a Spark task) and the one-machine driver of `CALL trajdb_archive`
//! ([`Driver`]). The decisions (partitions, fingerprints, the incremental rule, the calibration
//! chain, names, commits) are crates/app/src/archive; this module runs the statements.
//!
//! # One day ([`run_task`])
//! 1. The site's calibration in effect (a folder of Parquet files made from an earlier day) is
//!    loaded instead of measured, or, when the site has none, measured from this day (the
//!    manifest's part 'site': crates/app/src/plan.rs).
//! 2. The day runs on it (part 'day', its results folder in the task's scratch), then
//!    sql/archive_check.sql re-registers every camera pair on the day's matches. A camera change
//!    (a pair moved beyond `archive_change_z` standard errors, a pair whose matches collapsed, a
//!    camera the calibration never saw) calibrates the site again from this day and runs the day
//!    again on it, with a warning that says which camera and by how much.
//! 3. The result files go to the task's scratch folder; the driver moves them into place.
//!
//! Each database has one thread (a day's bytes do not depend on what runs beside it), the
//! task's memory limit, DuckDB's spill folder in the scratch, and a sandbox that allows
//! exactly the partition's files and the calibration's (read) and the scratch (write), locked.

use crate::app::archive::change::{self, Change, Changes};
use crate::app::archive::fingerprint;
use crate::app::archive::folder;
use crate::app::archive::index;
use crate::app::archive::layout::{self, Layout, Partition};
use crate::app::archive::plan::{self as aplan, Day, StateRow, STATE_COLUMNS};
use crate::app::archive::{ArchiveError, TASK_MEMORY};
use crate::app::plan::{self, Part, Request, SITE_TABLES};
use crate::app::sql::sql_string;
use crate::runner::{self, Settings};
use duckdb::Connection;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::error::Error;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Registers trajdb's functions on a private database (the bindings, above this module).
pub type Register<'a> = &'a (dyn Fn(&Connection) -> duckdb::Result<()> + Sync);

/// One site-day to run: its partition, the calibration it starts from, and the run's build and
/// parameters (what Python's driver and Spark send as JSON to `trajdb_archive_task`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TaskSpec {
    pub site: String,
    pub date: String,
    pub files: Vec<String>,
    #[serde(default)]
    pub site_column: bool,
    pub inputs: String,
    pub fingerprint: String,
    pub cal_id: Option<String>,
    pub cal_dir: Option<String>,
    /// The scratch folder's prefix: each attempt writes to `<scratch>-<pid>-<ns>` of its own.
    pub scratch: String,
    /// The pipeline parameters, a JSON object (checked by crates/app/src/params.rs).
    #[serde(default)]
    pub params: serde_json::Value,
    pub params_json: String,
    pub build: String,
    #[serde(default)]
    pub memory_limit: Option<String>,
}

/// What a task returns: the partition's state row, its scratch folder (the files to commit) and
/// the folder of a calibration it made.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TaskResult {
    pub row: StateRow,
    pub scratch: Option<String>,
    pub calibration: Option<String>,
    pub seconds: f64,
    /// The task's peak memory, when its host measured it (a worker process: VmHWM).
    #[serde(default)]
    pub peak_rss_mb: Option<f64>,
}

impl TaskResult {
    /// The result of a task that could not report one itself (its process died, its Spark task
    /// failed every attempt): the partition failed with `error`, nothing to commit.
    pub fn failed(t: &TaskSpec, error: &str) -> TaskResult {
        TaskResult { row: failed_row(t, Some(error.chars().take(2000).collect())), scratch: None, calibration: None, seconds: 0.0, peak_rss_mb: None }
    }
}

/// The partition's state row before (or without) its run: failed with `error`.
pub fn failed_row(t: &TaskSpec, error: Option<String>) -> StateRow {
    StateRow {
        site: t.site.clone(),
        date: t.date.clone(),
        status: "failed".into(),
        inputs: Some(t.inputs.clone()),
        fingerprint: Some(t.fingerprint.clone()),
        trajdb_version: Some(t.build.clone()),
        params: Some(t.params_json.clone()),
        calibration_in: t.cal_id.clone(),
        calibration_out: t.cal_id.clone(),
        calibration_made: Some(false),
        changes: Some("[]".into()),
        checks: Some("[]".into()),
        warnings: Some("[]".into()),
        error,
        ..Default::default()
    }
}

/// A kept calibration: the folder of its site tables, the camera numbers, and whether it has
/// a baseline (a calibration made today gets its baseline after the day's check).
struct Calibration {
    dir: PathBuf,
    numbers: Vec<(String, i32)>,
}

fn params_of(t: &TaskSpec) -> Result<Vec<(String, String)>, Box<dyn Error>> {
    let text = if t.params.is_null() { "{}".to_string() } else { t.params.to_string() };
    crate::app::params::from_json(&text)
}

fn list_sql(v: &[String]) -> String {
    format!("[{}]::VARCHAR[]", v.iter().map(|s| sql_string(s)).collect::<Vec<_>>().join(", "))
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir).into_iter().flatten().flatten().map(|e| e.path().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// A private database for one task (module doc): reads the partition's files and `reads`,
/// writes into `scratch`.
fn connect(t: &TaskSpec, scratch: &Path, reads: &[String], base: &Settings, register: Register<'_>) -> Result<Connection, Box<dyn Error>> {
    let mut read_paths = t.files.clone();
    read_paths.extend_from_slice(reads);
    let settings = Settings {
        read_paths,
        write_dirs: vec![scratch.to_string_lossy().into_owned()],
        threads: Some("1".into()),
        memory_limit: Some(t.memory_limit.clone().unwrap_or_else(|| TASK_MEMORY.into())),
        temp_directory: Some(scratch.join("spill").to_string_lossy().into_owned()),
        ..base.clone()
    };
    let con = runner::private(&settings, register)?;
    // the partition's rows: its files, and of a file holding several sites only this one's
    let reader = if t.files.iter().all(|f| f.to_ascii_lowercase().ends_with(".parquet")) { "read_parquet" } else { "read_csv" };
    con.execute_batch(&format!("SET VARIABLE archive_files = {}", list_sql(&t.files)))?;
    con.execute_batch(&format!("SET VARIABLE archive_site = {}", sql_string(&t.site)))?;
    let filter = if t.site_column { " WHERE site::VARCHAR = getvariable('archive_site')" } else { "" };
    con.execute_batch(&format!(
        "CREATE TEMP VIEW archive_input AS FROM {reader}(getvariable('archive_files'), hive_partitioning = false, union_by_name = true){filter}"
    ))?;
    Ok(con)
}

fn set_numbers(con: &Connection, numbers: &[(String, i32)]) -> Result<(), Box<dyn Error>> {
    let names: Vec<String> = numbers.iter().map(|(n, _)| n.clone()).collect();
    let nums: Vec<String> = numbers.iter().map(|(_, k)| k.to_string()).collect();
    con.execute_batch(&format!("SET VARIABLE load_camera_numbers = MAP({}, [{}]::INTEGER[])", list_sql(&names), nums.join(", ")))?;
    Ok(())
}

/// The site's calibration measured from this day, written into `dir` (its site tables and
/// camera numbers; `known` numbers kept).
fn calibrate(t: &TaskSpec, scratch: &Path, dir: &Path, known: &[(String, i32)], base: &Settings, register: Register<'_>) -> Result<Calibration, Box<dyn Error>> {
    let con = connect(t, scratch, &[], base, register)?;
    set_numbers(&con, known)?;
    let steps = plan::plan(&Request { input: "archive_input".into(), out: None, part: Part::Site, params: params_of(t)? })?;
    runner::execute_all(&con, &steps)?;
    fs::create_dir_all(dir)?;
    for name in SITE_TABLES {
        let exists: i64 = con.query_row("SELECT count(*) FROM duckdb_tables() WHERE table_name = ? AND temporary", [name], |r| r.get(0))?;
        if exists > 0 {
            con.execute(&format!("COPY {name} TO {} (FORMAT parquet)", sql_string(&dir.join(format!("{name}.parquet")).to_string_lossy())), [])?;
        }
    }
    let mut numbers: Vec<(String, i32)> = known.to_vec();
    let mut st = con.prepare("SELECT DISTINCT camera_in::VARCHAR, camera FROM load_ids ORDER BY camera")?;
    for r in st.query_map([], |r| Ok((r.get::<_, String>(0)?, r.get::<_, i32>(1)?)))? {
        let (name, num) = r?;
        if !numbers.iter().any(|(n, _)| *n == name) {
            numbers.push((name, num));
        }
    }
    numbers.sort_by_key(|(_, k)| *k);
    write_cameras(&con, dir, &numbers)?;
    Ok(Calibration { dir: dir.to_path_buf(), numbers })
}

fn write_cameras(con: &Connection, dir: &Path, numbers: &[(String, i32)]) -> Result<(), Box<dyn Error>> {
    let names: Vec<String> = numbers.iter().map(|(n, _)| n.clone()).collect();
    let nums: Vec<String> = numbers.iter().map(|(_, k)| k.to_string()).collect();
    con.execute_batch(&format!(
        "COPY (SELECT unnest({}) AS camera_in, unnest([{}]::INTEGER[]) AS camera) TO {} (FORMAT parquet)",
        list_sql(&names),
        nums.join(", "),
        sql_string(&dir.join("cameras.parquet").to_string_lossy())
    ))?;
    Ok(())
}

const BASELINE_SQL: &str = "cam_fixed INTEGER, cam_moving INTEGER, ax DOUBLE, ay DOUBLE, d_theta DOUBLE, d_x DOUBLE, d_y DOUBLE, d_dt DOUBLE, \
     se_theta DOUBLE, se_x DOUBLE, se_y DOUBLE, se_dt DOUBLE, pairs_per_user DOUBLE, fit_pairs BIGINT";

/// A kept calibration's folder: its site tables (only trajdb's names), camera numbers and baseline.
fn load_calibration(dir: &Path) -> Result<Calibration, Box<dyn Error>> {
    let cams = dir.join("cameras.parquet");
    let con = Connection::open_in_memory()?;
    let mut numbers = Vec::new();
    let mut st = con.prepare("SELECT camera_in::VARCHAR, camera::INTEGER FROM read_parquet(?, hive_partitioning = false) ORDER BY camera")?;
    for r in st.query_map([cams.to_string_lossy().as_ref()], |r| Ok((r.get::<_, String>(0)?, r.get::<_, i32>(1)?)))? {
        numbers.push(r?);
    }
    Ok(Calibration { dir: dir.to_path_buf(), numbers })
}

/// The day on calibration `cal`, its results in `results` (`note`: the archive's warning for the
/// day's warnings and report); returns the open database (archive_check run).
fn run_day(
    t: &TaskSpec, scratch: &Path, cal: &Calibration, results: &Path, note: Option<&str>, base: &Settings, register: Register<'_>,
) -> Result<Connection, Box<dyn Error>> {
    let con = connect(t, scratch, &files_in(&cal.dir), base, register)?;
    set_numbers(&con, &cal.numbers)?;
    con.execute_batch(&format!("SET VARIABLE archive_day_note = {}::VARCHAR", note.map(sql_string).unwrap_or_else(|| "NULL".into())))?;
    for f in files_in(&cal.dir) {
        let name = Path::new(&f).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let file = Path::new(&f).file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        if file.starts_with(['.', '_']) || !file.ends_with(".parquet") || name == "cameras" || name == "baseline" {
            continue;
        }
        let Some(known) = SITE_TABLES.iter().find(|s| **s == name) else {
            return Err(format!(
                "the kept calibration holds {name}.parquet, which is not a site table trajdb makes ({}); remove that file or the calibration folder (it is then made again)",
                SITE_TABLES.join(", ")
            )
            .into());
        };
        con.execute(&format!("CREATE OR REPLACE TEMP TABLE {known} AS FROM read_parquet(?, hive_partitioning = false)"), [&f])?;
    }
    let steps = plan::plan(&Request { input: "archive_input".into(), out: Some(results.to_string_lossy().into_owned()), part: Part::Day, params: params_of(t)? })?;
    runner::execute_all(&con, &steps)?;
    // the calibration day's check (empty on that day), a baseline of an earlier version filled
    con.execute_batch(&format!("CREATE OR REPLACE TEMP TABLE archive_baseline ({BASELINE_SQL})"))?;
    let bl = cal.dir.join("baseline.parquet");
    if bl.exists() {
        con.execute("INSERT INTO archive_baseline BY NAME FROM read_parquet(?, hive_partitioning = false)", [bl.to_string_lossy().as_ref()])?;
    }
    runner::execute_all(&con, &plan::script("sql/archive_check.sql")?)?;
    Ok(con)
}

fn read_changes(con: &Connection) -> Result<Vec<Change>, Box<dyn Error>> {
    let mut st = con.prepare("SELECT kind, camera_fixed, camera_moving, pairs, expected_pairs, turned_deg, moved_m, clock_s, z FROM archive_changes")?;
    let rows = st.query_map([], |r| {
        Ok(Change {
            kind: r.get(0)?,
            camera_fixed: r.get(1)?,
            camera_moving: r.get(2)?,
            pairs: r.get(3)?,
            expected_pairs: r.get(4)?,
            turned_deg: r.get(5)?,
            moved_m: r.get(6)?,
            clock_s: r.get(7)?,
            z: r.get(8)?,
        })
    })?;
    Ok(rows.collect::<Result<_, _>>()?)
}

#[derive(Serialize)]
struct Check {
    cameras: String,
    pairs: Option<i64>,
    z: Option<f64>,
    z_theta: Option<f64>,
    z_pos: Option<f64>,
    z_clock: Option<f64>,
    lost: Option<bool>,
}

fn read_checks(con: &Connection) -> Result<Vec<Check>, Box<dyn Error>> {
    let mut st = con.prepare("SELECT cameras, pairs, z, z_theta, z_pos, z_clock, lost FROM archive_checks")?;
    let rows = st.query_map([], |r| {
        Ok(Check { cameras: r.get(0)?, pairs: r.get(1)?, z: r.get(2)?, z_theta: r.get(3)?, z_pos: r.get(4)?, z_clock: r.get(5)?, lost: r.get(6)? })
    })?;
    Ok(rows.collect::<Result<_, _>>()?)
}

fn save_baseline(con: &Connection, dir: &Path) -> Result<(), Box<dyn Error>> {
    con.execute_batch(&format!("COPY (FROM archive_baseline_out) TO {} (FORMAT parquet)", sql_string(&dir.join("baseline.parquet").to_string_lossy())))?;
    Ok(())
}

/// The day's result files in the scratch folder (moved into place by the driver).
fn write_outputs(con: &Connection, results: &Path, scratch: &Path) -> Result<(), Box<dyn Error>> {
    fs::rename(results.join("merged.parquet"), scratch.join("road_users.parquet"))?;
    fs::rename(results.join("report.html"), scratch.join("report.html"))?;
    for (mac, name, order) in [
        ("result_matches()", "matches", "camera_a, track_a, camera_b, track_b"),
        ("result_links()", "links", "camera, track_id"),
        ("result_transforms()", "transforms", "cam_from, cam_to"),
        ("result_calibration()", "calibration", "scope, quantity"),
    ] {
        con.execute_batch(&format!(
            "COPY (FROM {mac} ORDER BY {order}) TO {} (FORMAT parquet)",
            sql_string(&scratch.join(format!("{name}.parquet")).to_string_lossy())
        ))?;
    }
    Ok(())
}

static SEQ: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// One site-day (module doc). Never fails: a failure is the row's error.
pub fn run_task(t: &TaskSpec, base: &Settings, register: Register<'_>) -> TaskResult {
    let t0 = Instant::now();
    // this attempt's own folder (a Spark retry, or a speculative copy still running, never
    // shares one); the driver removes it after the commit, the next run any a kill left
    let ns = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let seq = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let scratch = PathBuf::from(format!("{}-{}-{ns}{}", t.scratch, std::process::id(), if seq > 0 { format!("-{seq}") } else { String::new() }));
    let mut row = failed_row(t, None);
    let mut made = false;
    let r = (|| -> Result<(), Box<dyn Error>> {
        fs::create_dir_all(&scratch)?;
        if t.files.is_empty() {
            return Err(format!("site {} date {}: the partition has no data files (.parquet or .csv)", t.site, t.date).into());
        }
        let parquet = t.files.iter().filter(|f| f.to_ascii_lowercase().ends_with(".parquet")).count();
        if parquet != 0 && parquet != t.files.len() {
            return Err(format!("site {} date {}: the partition mixes Parquet and CSV files; give one format per partition", t.site, t.date).into());
        }
        // the parameters checked, and the files there, before any database (a file that vanished
        // since the plan would read as a refused glob)
        plan::plan(&Request { input: "archive_input".into(), out: None, part: Part::Site, params: params_of(t)? })?;
        if let Some(f) = t.files.iter().find(|f| !Path::new(f).is_file()) {
            return Err(format!("site {} date {}: the input file {f} is not there (removed since the run began?)", t.site, t.date).into());
        }
        let results = scratch.join("results");
        let (mut cal, mut first) = match &t.cal_dir {
            Some(d) => (load_calibration(Path::new(d))?, false),
            None => (calibrate(t, &scratch, &scratch.join("cal-1"), &[], base, register)?, true),
        };
        let mut con = run_day(t, &scratch, &cal, &results, None, base, register)?;
        let mut changes = Vec::new();
        let mut camera = None;
        let mut checks = Vec::new();
        if first {
            save_baseline(&con, &cal.dir)?;
        } else {
            changes = read_changes(&con)?;
            checks = read_checks(&con)?;
            if !changes.is_empty() {
                let mut st = con.prepare("SELECT camera_fixed, camera_moving FROM archive_cleared")?;
                let cleared: Vec<(String, String)> = st.query_map([], |r| Ok((r.get(0)?, r.get(1)?)))?.collect::<Result<_, _>>()?;
                drop(st);
                camera = change::which_camera(&changes, &cleared);
                // re-register the site from this day, and run the day again on it (its warnings
                // and report say so)
                drop(con);
                fs::remove_dir_all(&results)?;
                cal = calibrate(t, &scratch, &scratch.join("cal-2"), &cal.numbers, base, register)?;
                let note = change::note(&t.site, &t.date, camera.as_deref(), &changes);
                con = run_day(t, &scratch, &cal, &results, Some(&note), base, register)?;
                save_baseline(&con, &cal.dir)?;
                first = true;
            }
        }
        write_outputs(&con, &results, &scratch)?;
        let mut st = con.prepare("SELECT message FROM pipeline_warnings ORDER BY k")?;
        let warnings: Vec<String> = st.query_map([], |r| r.get(0))?.collect::<Result<_, _>>()?;
        drop(st);
        let stats: (i64, i64, i64, i64) = con.query_row(
            "SELECT (SELECT count(DISTINCT camera) FROM points), (SELECT count(*) FROM points), (SELECT count(*) FROM merged), (SELECT count(*) FROM result_matches())",
            [],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
        )?;
        drop(con);
        if first {
            fs::rename(&cal.dir, scratch.join("calibration"))?;
            row.calibration_out = Some(fingerprint::calibration_id(&t.date, &t.fingerprint, &t.build, &t.params_json));
            row.calibration_made = Some(true);
            made = true;
        }
        row.status = "ok".into();
        row.changes = Some(if changes.is_empty() { "[]".into() } else { serde_json::to_string(&Changes { camera, pairs: changes })? });
        row.checks = Some(serde_json::to_string(&checks)?);
        row.warnings = Some(serde_json::to_string(&warnings)?);
        (row.cameras, row.points, row.road_users, row.matches) = (Some(stats.0), Some(stats.1), Some(stats.2), Some(stats.3));
        Ok(())
    })();
    if let Err(e) = r {
        let msg: String = e.to_string().chars().take(2000).collect();
        row = failed_row(t, Some(msg));
        made = false;
    }
    TaskResult {
        row,
        scratch: Some(scratch.to_string_lossy().into_owned()),
        calibration: made.then(|| scratch.join("calibration").to_string_lossy().into_owned()),
        seconds: t0.elapsed().as_secs_f64(),
        peak_rss_mb: None,
    }
}

// --- the one-machine driver of CALL trajdb_archive ------------------------------------------------

/// What `CALL trajdb_archive` was asked.
#[derive(Clone, Debug)]
pub struct ArchiveRequest {
    pub lake: PathBuf,
    pub out: PathBuf,
    /// The site of a date=D/ lake without a site column.
    pub site: Option<String>,
    pub params: Vec<(String, String)>,
    pub task_memory: Option<String>,
    /// Site-days run at once (each in its own database, one thread each).
    pub workers: usize,
    /// The build id (crates/app/src/archive/fingerprint.rs `build`).
    pub build: String,
}

/// One partition's row of `CALL trajdb_archive`'s result.
#[derive(Clone, Debug, Serialize)]
pub struct PartitionRow {
    pub row: StateRow,
    /// Run by this call (else done by an earlier run, or failed before it and not tried again).
    pub ran: bool,
}

/// The driver: opened (the lake read, OUT claimed and locked, the state loaded), then a round of
/// tasks at a time ([`Driver::step`]), then [`Driver::finish`].
pub struct Driver {
    req: ArchiveRequest,
    base: Settings,
    out: PathBuf,
    _lock: fs::File,
    parts: Vec<Partition>,
    inputs: Vec<(String, String)>,
    state: HashMap<(String, String), StateRow>,
    params_json: String,
    attempted: HashSet<(String, String, Option<String>)>,
    ran: HashSet<(String, String)>,
    pending: Vec<TaskSpec>,
    /// The tasks handed out and not committed yet, by partition.
    handed: HashMap<(String, String), TaskSpec>,
    round: usize,
    runs: usize,
    total: usize,
    saved: Instant,
    dirty: bool,
}

/// One camera change of a run, as the state holds it, with its sentence.
#[derive(Clone, Debug, Serialize)]
pub struct ChangeNote {
    pub site: String,
    pub date: String,
    pub camera: Option<String>,
    pub pairs: Vec<Change>,
    pub message: String,
}

/// What a run did ([`Driver::finish`]).
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub out: String,
    pub partitions: usize,
    /// Partitions run by this call (a day run twice counts once).
    pub done: usize,
    /// Day runs (a day run again after an earlier day's camera change counts twice).
    pub runs: usize,
    pub skipped: usize,
    pub failed: usize,
    pub failed_partitions: Vec<String>,
    pub changes: Vec<ChangeNote>,
    pub rounds: usize,
    /// Partitions of the archive no longer in the lake (their results are kept).
    pub orphaned: Vec<String>,
    /// Every partition of the lake: its state row and whether this call ran it.
    pub rows: Vec<PartitionRow>,
}

/// The state is rewritten whole (one Parquet file) at most this often, and at each round's end.
const STATE_EVERY_S: f64 = 2.0;

fn state_path(out: &Path) -> PathBuf {
    out.join("_state").join("partitions.parquet")
}

/// The archive's state, as any host wrote it.
pub fn load_state(out: &Path) -> Result<HashMap<(String, String), StateRow>, Box<dyn Error>> {
    let p = state_path(out);
    let mut state = HashMap::new();
    if !p.exists() {
        return Ok(state);
    }
    let con = Connection::open_in_memory()?;
    let cols: Vec<String> = STATE_COLUMNS.iter().map(|(c, t)| format!("\"{c}\"::{t}")).collect();
    let mut st = con.prepare(&format!("SELECT {} FROM read_parquet(?, hive_partitioning = false)", cols.join(", ")))?;
    let rows = st.query_map([p.to_string_lossy().as_ref()], |r| {
        Ok(StateRow {
            site: r.get(0)?,
            date: r.get(1)?,
            status: r.get(2)?,
            inputs: r.get(3)?,
            fingerprint: r.get(4)?,
            trajdb_version: r.get(5)?,
            params: r.get(6)?,
            calibration_in: r.get(7)?,
            calibration_out: r.get(8)?,
            calibration_made: r.get(9)?,
            changes: r.get(10)?,
            cameras: r.get(11)?,
            points: r.get(12)?,
            road_users: r.get(13)?,
            matches: r.get(14)?,
            checks: r.get(15)?,
            warnings: r.get(16)?,
            error: r.get(17)?,
        })
    })?;
    for r in rows {
        let r = r?;
        state.insert((r.site.clone(), r.date.clone()), r);
    }
    Ok(state)
}

/// Writes the state whole (sorted by site and date) and renames it into place.
pub fn save_state(out: &Path, state: &HashMap<(String, String), StateRow>) -> Result<(), Box<dyn Error>> {
    let con = Connection::open_in_memory()?;
    let cols: Vec<String> = STATE_COLUMNS.iter().map(|(c, t)| format!("\"{c}\" {t}")).collect();
    con.execute_batch(&format!("CREATE TABLE s ({})", cols.join(", ")))?;
    {
        let mut app = con.appender("s")?;
        let mut keys: Vec<&(String, String)> = state.keys().collect();
        keys.sort();
        for k in keys {
            let r = &state[k];
            app.append_row(duckdb::params![
                r.site, r.date, r.status, r.inputs, r.fingerprint, r.trajdb_version, r.params, r.calibration_in, r.calibration_out,
                r.calibration_made, r.changes, r.cameras, r.points, r.road_users, r.matches, r.checks, r.warnings, r.error
            ])?;
        }
    }
    let ns = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let tmp = out.join("_work").join(format!("task-tmp-{}-{ns}.parquet", std::process::id()));
    con.execute_batch(&format!("COPY s TO {} (FORMAT parquet)", sql_string(&tmp.to_string_lossy())))?;
    fs::rename(&tmp, state_path(out))?;
    Ok(())
}

/// Now as 2026-11-28T21:29:41Z.
fn utc_now() -> String {
    let s = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0) as i64;
    let (days, rem) = (s.div_euclid(86400), s.rem_euclid(86400));
    // civil from days (H. Hinnant)
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60)
}

fn append_run(out: &Path, r: &TaskResult) {
    use std::io::Write;
    let p = out.join("_state").join("runs.csv");
    let new = !p.exists();
    if let Ok(mut f) = fs::OpenOptions::new().create(true).append(true).open(&p) {
        if new {
            let _ = f.write_all(b"finished_utc,site,date,status,seconds,peak_rss_mb,points\n");
        }
        let pts = r.row.points.map(|p| p.to_string()).unwrap_or_default();
        let rss = r.peak_rss_mb.map(|m| format!("{m:.1}")).unwrap_or_default();
        let secs = if r.seconds > 0.0 { format!("{:.2}", r.seconds) } else { String::new() };
        let _ = writeln!(f, "{},{},{},{},{secs},{rss},{pts}", utc_now(), r.row.site, r.row.date, r.row.status);
    }
}

/// The site values of some files (a date=D/ lake with a site column).
fn site_values(con: &Connection, files: &[PathBuf]) -> Vec<String> {
    if files.is_empty() {
        return Vec::new();
    }
    let list: Vec<String> = files.iter().map(|f| f.to_string_lossy().into_owned()).collect();
    let reader = if list.iter().all(|f| f.to_ascii_lowercase().ends_with(".parquet")) { "read_parquet" } else { "read_csv" };
    let q = format!(
        "SELECT DISTINCT site::VARCHAR AS s FROM {reader}({}, hive_partitioning = false, union_by_name = true) WHERE site IS NOT NULL ORDER BY s",
        list_sql(&list)
    );
    con.prepare(&q).and_then(|mut st| st.query_map([], |r| r.get::<_, String>(0))?.collect()).unwrap_or_default()
}

fn has_site_column(con: &Connection, file: &Path) -> bool {
    let f = file.to_string_lossy().into_owned();
    let reader = if f.to_ascii_lowercase().ends_with(".parquet") { "read_parquet" } else { "read_csv" };
    let q = format!("SELECT count(*) FROM (DESCRIBE SELECT * FROM {reader}({}, hive_partitioning = false)) WHERE lower(column_name) = 'site'", sql_string(&f));
    con.query_row(&q, [], |r| r.get::<_, i64>(0)).map(|n| n > 0).unwrap_or(false)
}

/// The lake's partitions, named and sorted (crates/app/src/archive/layout.rs).
pub fn partitions(lake: &Path, site: Option<&str>) -> Result<Vec<Partition>, Box<dyn Error>> {
    let parts = match layout::discover(lake)? {
        Layout::Sites(p) => p,
        Layout::Dates(p) => {
            let con = Connection::open_in_memory()?;
            let with: Vec<bool> = p.iter().flat_map(|q| q.files.iter()).map(|f| has_site_column(&con, f)).collect();
            let any = with.iter().any(|b| *b);
            if any && !with.iter().all(|b| *b) && site.is_none() {
                return Err(ArchiveError(format!(
                    "trajdb archive: some files of {:?} have a site column and some do not; give every file one (or none, and name the site with site := ...)",
                    lake.display().to_string()
                ))
                .into());
            }
            if any && site.is_none() {
                let values: Vec<Vec<String>> = p.iter().map(|q| site_values(&con, &q.files)).collect();
                layout::split_by_site(p, &values)
            } else {
                layout::name_single_site(p, site, lake)
            }
        }
    };
    Ok(layout::finish(parts)?)
}

impl Driver {
    /// Reads the lake, checks the parameters, claims and locks OUT, loads the state and each
    /// partition's fingerprint (the content is read only when names, sizes or times changed).
    pub fn open(req: ArchiveRequest, base: Settings) -> Result<Driver, Box<dyn Error>> {
        let lake = std::path::absolute(&req.lake)?;
        let parts = partitions(&lake, req.site.as_deref())?;
        // unknown names and bad values fail before any work
        plan::plan(&Request { input: "archive_input".into(), out: None, part: Part::Site, params: req.params.clone() })?;
        if let Some(m) = &req.task_memory {
            let con = Connection::open_in_memory()?;
            con.execute_batch(&format!("SET memory_limit = {}", sql_string(m)))
                .map_err(|e| format!("task_memory {m:?} is not a memory size DuckDB takes (give e.g. '2GB'): {e}"))?;
        }
        let out = folder::claim(&req.out, &lake)?;
        let lock = folder::lock(&out)?;
        folder::clean_work(&out);
        let state = load_state(&out)?;
        let mut inputs = Vec::with_capacity(parts.len());
        for p in &parts {
            let inp = fingerprint::inputs(&p.files, &lake)?;
            let fp = match state.get(&(p.site.clone(), p.date.clone())) {
                Some(st) if st.inputs.as_deref() == Some(inp.as_str()) && st.fingerprint.is_some() => st.fingerprint.clone().unwrap_or_default(),
                _ => fingerprint::content(&p.files, p.site_column.then_some(p.site.as_str()))?,
            };
            inputs.push((inp, fp));
        }
        let params_json = fingerprint::params_json(&req.params);
        Ok(Driver {
            req: ArchiveRequest { lake, ..req },
            base,
            out,
            _lock: lock,
            parts,
            inputs,
            state,
            params_json,
            attempted: HashSet::new(),
            ran: HashSet::new(),
            pending: Vec::new(),
            handed: HashMap::new(),
            round: 0,
            runs: 0,
            total: 0,
            saved: Instant::now(),
            dirty: false,
        }
        .counted())
    }

    fn counted(mut self) -> Driver {
        self.total = self.plan(false).len();
        self
    }

    /// The partitions of the lake, and those that need work (a progress bar's total: a round
    /// may add days a camera change made due again).
    pub fn counts(&self) -> (usize, usize) {
        (self.parts.len(), self.total)
    }

    /// The archive folder (absolute).
    pub fn out(&self) -> &Path {
        &self.out
    }

    /// The build this run names its results by.
    pub fn build(&self) -> &str {
        &self.req.build
    }

    fn plan(&self, wait: bool) -> Vec<aplan::Task> {
        let days: Vec<Day<'_>> =
            self.parts.iter().zip(&self.inputs).map(|(p, (_, fp))| Day { site: &p.site, date: &p.date, fingerprint: fp }).collect();
        let out = self.out.clone();
        let exists = move |site: &str, id: &str| folder::cal_dir(&out, site, id).is_dir();
        aplan::plan(&days, &self.state, &aplan::Run { build: &self.req.build, params_json: &self.params_json }, &exists, wait, &self.attempted)
    }

    /// The next round's tasks (the state saved and the scratch cleaned after the round before),
    /// or None when the archive is done: for hosts that run the tasks themselves (Python's
    /// worker processes, Spark), which hand each result to [`Driver::commit`].
    pub fn next_round(&mut self) -> Result<Option<Vec<TaskSpec>>, Box<dyn Error>> {
        if self.round > 0 {
            self.save()?;
            folder::clean_work(&self.out);
        }
        let tasks = self.plan(true);
        if tasks.is_empty() {
            return Ok(None);
        }
        self.round += 1;
        self.total = self.total.max(self.runs + tasks.len());
        let mut specs = Vec::with_capacity(tasks.len());
        for (k, t) in tasks.iter().enumerate() {
            let (p, (inp, fp)) = (&self.parts[t.index], &self.inputs[t.index]);
            self.attempted.insert((p.site.clone(), p.date.clone(), t.cal_id.clone()));
            let params: serde_json::Map<String, serde_json::Value> =
                self.req.params.iter().map(|(k, v)| (k.clone(), serde_json::Value::String(v.clone()))).collect();
            specs.push(TaskSpec {
                site: p.site.clone(),
                date: p.date.clone(),
                files: p.files.iter().map(|f| f.to_string_lossy().into_owned()).collect(),
                site_column: p.site_column,
                inputs: inp.clone(),
                fingerprint: fp.clone(),
                cal_id: t.cal_id.clone(),
                cal_dir: t.cal_id.as_deref().map(|c| folder::cal_dir(&self.out, &p.site, c).to_string_lossy().into_owned()),
                scratch: self.out.join("_work").join(format!("task-{}-{}-{k}", std::process::id(), self.round)).to_string_lossy().into_owned(),
                params: serde_json::Value::Object(params),
                params_json: self.params_json.clone(),
                build: self.req.build.clone(),
                memory_limit: self.req.task_memory.clone(),
            });
        }
        for t in &specs {
            self.handed.insert((t.site.clone(), t.date.clone()), t.clone());
        }
        Ok(Some(specs))
    }

    /// Runs the next batch of site-days in this process (at most `workers`, at once, each in
    /// its own database) and commits them; None when the archive is done. Between batches DuckDB
    /// may stop the call (an interrupt): what was committed is in the state.
    pub fn step(&mut self, register: Register<'_>) -> Result<Option<Vec<PartitionRow>>, Box<dyn Error>> {
        if self.pending.is_empty() {
            match self.next_round()? {
                None => return Ok(None),
                Some(mut tasks) => {
                    tasks.reverse();
                    self.pending = tasks;
                }
            }
        }
        let n = self.req.workers.max(1).min(self.pending.len());
        let batch: Vec<TaskSpec> = self.pending.split_off(self.pending.len() - n).into_iter().rev().collect();
        let base = &self.base;
        let results: Vec<TaskResult> = std::thread::scope(|s| {
            let hs: Vec<_> = batch.iter().map(|t| s.spawn(move || run_task(t, base, register))).collect();
            hs.into_iter()
                .zip(&batch)
                .map(|(h, t)| h.join().unwrap_or_else(|_| TaskResult::failed(t, "the task panicked (a bug: please report it)")))
                .collect()
        });
        let mut rows = Vec::with_capacity(results.len());
        for r in results {
            rows.push(PartitionRow { row: self.commit(r)?, ran: true });
        }
        Ok(Some(rows))
    }

    /// Moves a finished task's files into place and records it (the partition's commit point);
    /// returns its state row.
    pub fn commit(&mut self, r: TaskResult) -> Result<StateRow, Box<dyn Error>> {
        let (site, date) = (r.row.site.clone(), r.row.date.clone());
        // only a task this run handed out, once; its files only from its own scratch folder
        // under OUT/_work; what the state records of its input, build and parameters is the
        // driver's own (a result is a host's JSON: it never names a folder to move or remove)
        let Some(task) = self.handed.remove(&(site.clone(), date.clone())) else {
            return Err(format!("site {site:?} date {date:?} is no task of this run waiting for its result (trajdb_archive_next hands them out, once)").into());
        };
        let work = self.out.join("_work");
        let scratch = r.scratch.as_deref().map(Path::new);
        if let Some(sc) = scratch {
            let own = sc.parent() == Some(work.as_path())
                && sc.file_name().is_some_and(|n| n.to_string_lossy().starts_with(&format!("{}-", Path::new(&task.scratch).file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default())))
                && !sc.is_symlink();
            if !own {
                self.handed.insert((site.clone(), date.clone()), task);
                return Err(format!("the result's scratch {:?} is not its task's folder under {}", sc.display().to_string(), work.display()).into());
            }
        }
        let made_id = fingerprint::calibration_id(&task.date, &task.fingerprint, &task.build, &task.params_json);
        let calibration = match r.calibration.as_deref() {
            Some(c) if scratch.is_some_and(|sc| Path::new(c) == sc.join("calibration")) && r.row.calibration_out.as_deref() == Some(made_id.as_str()) => Some(Path::new(c)),
            Some(c) => {
                self.handed.insert((site.clone(), date.clone()), task);
                return Err(format!("the result's calibration {c:?} is not its scratch's calibration folder, or not named {made_id}").into());
            }
            None => None,
        };
        let ok = r.row.status == "ok";
        let mut row = StateRow {
            inputs: Some(task.inputs.clone()),
            fingerprint: Some(task.fingerprint.clone()),
            trajdb_version: Some(task.build.clone()),
            params: Some(task.params_json.clone()),
            calibration_in: task.cal_id.clone(),
            ..r.row.clone()
        };
        if ok && calibration.is_some() {
            row.calibration_made = Some(true);
            row.calibration_out = Some(made_id.clone());
        } else {
            row.calibration_made = Some(false);
            row.calibration_out = task.cal_id.clone();
        }
        if let Err(e) = folder::commit(&self.out, &site, &date, ok, scratch, calibration.zip(Some(made_id.as_str()))) {
            row = failed_row(&task, Some(e.to_string()));
        }
        self.state.insert((site.clone(), date.clone()), row.clone());
        append_run(&self.out, &r);
        self.ran.insert((site, date));
        self.runs += 1;
        self.dirty = true;
        if self.saved.elapsed().as_secs_f64() >= STATE_EVERY_S {
            self.save()?;
        }
        Ok(row)
    }

    fn save(&mut self) -> Result<(), Box<dyn Error>> {
        if self.dirty {
            save_state(&self.out, &self.state)?;
            self.dirty = false;
        }
        self.saved = Instant::now();
        Ok(())
    }

    /// The state saved, the site index pages written; what the run did.
    pub fn finish(&mut self) -> Result<Summary, Box<dyn Error>> {
        self.save()?;
        folder::clean_work(&self.out);
        let mut by_site: HashMap<&str, Vec<&StateRow>> = HashMap::new();
        for r in self.state.values() {
            by_site.entry(r.site.as_str()).or_default().push(r);
        }
        for (site, rows) in by_site.iter_mut() {
            rows.sort_by(|a, b| layout::date_order(&a.date, &b.date));
            let dest = self.out.join(folder::REPORT.0).join(format!("site={site}")).join("index.html");
            if let Some(d) = dest.parent() {
                fs::create_dir_all(d)?;
            }
            folder::write_atomic(&dest, index::site_page(site, rows).as_bytes(), Some(&self.out.join("_work")))?;
        }
        let key = |p: &Partition| (p.site.clone(), p.date.clone());
        let present: HashSet<(String, String)> = self.parts.iter().map(key).collect();
        let rows: Vec<PartitionRow> = self
            .parts
            .iter()
            .filter_map(|p| self.state.get(&key(p)).map(|r| PartitionRow { row: r.clone(), ran: self.ran.contains(&key(p)) }))
            .collect();
        let name = |s: &str, d: &str| format!("site={s}/date={d}");
        let failed_partitions: Vec<String> = rows.iter().filter(|r| r.row.status != "ok").map(|r| name(&r.row.site, &r.row.date)).collect();
        let mut orphaned: Vec<String> = self.state.keys().filter(|k| !present.contains(*k)).map(|(s, d)| name(s, d)).collect();
        orphaned.sort();
        let mut changes = Vec::new();
        for r in rows.iter().filter(|r| r.ran) {
            if let Some(ch) = r.row.changes.as_deref().filter(|c| *c != "[]").and_then(|c| serde_json::from_str::<Changes>(c).ok()) {
                let words: Vec<String> = ch.pairs.iter().map(change::describe).collect();
                changes.push(ChangeNote {
                    site: r.row.site.clone(),
                    date: r.row.date.clone(),
                    message: format!("{} ({})", change::who(ch.camera.as_deref(), &ch.pairs), words.join("; ")),
                    camera: ch.camera,
                    pairs: ch.pairs,
                });
            }
        }
        let done = rows.iter().filter(|r| r.ran).count();
        Ok(Summary {
            out: self.out.to_string_lossy().into_owned(),
            partitions: self.parts.len(),
            done,
            runs: self.runs,
            skipped: self.parts.len() - done,
            failed: failed_partitions.len(),
            failed_partitions,
            changes,
            rounds: self.round,
            orphaned,
            rows,
        })
    }
}

impl Drop for Driver {
    /// What was committed is recorded, also when the call stops early (an interrupt).
    fn drop(&mut self) {
        let _ = self.save();
    }
}
