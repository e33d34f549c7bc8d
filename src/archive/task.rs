//! One site-day of an archive (the module doc of [`super`]): the same function on every host.

use crate::app::archive::change::{self, Change, Changes};
use crate::app::archive::fingerprint;
use crate::app::archive::plan::StateRow;
use crate::app::archive::TASK_MEMORY;
use crate::app::plan::{self, Part, Request, SITE_TABLES};
use crate::app::sql::sql_string;
use crate::runner::{self, Settings};
use duckdb::Connection;
use serde::{Deserialize, Serialize};
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

pub(super) fn list_sql(v: &[String]) -> String {
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
    // a database allowed exactly this file
    let con = Connection::open_in_memory()?;
    con.execute_batch(&format!(
        "SET allowed_paths = [{}]; SET enable_external_access = false; SET lock_configuration = true",
        sql_string(&cams.to_string_lossy())
    ))?;
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

