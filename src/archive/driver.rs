//! The driver of an archive run: the lake read, OUT claimed and locked, the state loaded; then
//! rounds of tasks (run here by `CALL trajdb_archive`, or handed to a host by
//! `trajdb_archive_next`), each result committed; then the summary.

use super::state::{append_run, load_state, save_state, STATE_EVERY_S};
use super::task::{failed_row, list_sql, run_task, Register, TaskResult, TaskSpec};
use crate::app::archive::change::{self, Change, Changes};
use crate::app::archive::fingerprint;
use crate::app::archive::folder;
use crate::app::archive::index;
use crate::app::archive::layout::{self, Layout, Partition};
use crate::app::archive::plan::{self as aplan, Day, StateRow};
use crate::app::archive::ArchiveError;
use crate::app::plan::{self, Part, Request};
use crate::app::sql::sql_string;
use crate::runner::Settings;
use duckdb::Connection;
use serde::Serialize;
use std::collections::{HashMap, HashSet};
use std::error::Error;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;


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

/// A private database that may read exactly `files` (the lake's, each checked against the
/// caller's sandbox before): the site column's values are read there, never elsewhere.
fn reader(files: &[String]) -> Result<Connection, Box<dyn Error>> {
    let con = Connection::open_in_memory()?;
    con.execute_batch(&format!("SET allowed_paths = {}; SET enable_external_access = false; SET lock_configuration = true", list_sql(files)))?;
    Ok(con)
}

fn scan_sql(files: &[String]) -> String {
    let reader = if files.iter().all(|f| f.to_ascii_lowercase().ends_with(".parquet")) { "read_parquet" } else { "read_csv" };
    format!("{reader}({}, hive_partitioning = false, union_by_name = true)", list_sql(files))
}

/// The site values of some files (a date=D/ lake with a site column).
fn site_values(con: &Connection, files: &[PathBuf]) -> Vec<String> {
    if files.is_empty() {
        return Vec::new();
    }
    let list: Vec<String> = files.iter().map(|f| f.to_string_lossy().into_owned()).collect();
    let q = format!("SELECT DISTINCT site::VARCHAR AS s FROM {} WHERE site IS NOT NULL ORDER BY s", scan_sql(&list));
    con.prepare(&q).and_then(|mut st| st.query_map([], |r| r.get::<_, String>(0))?.collect()).unwrap_or_default()
}

fn has_site_column(con: &Connection, file: &Path) -> bool {
    let f = vec![file.to_string_lossy().into_owned()];
    let q = format!("SELECT count(*) FROM (DESCRIBE SELECT * FROM {}) WHERE lower(column_name) = 'site'", scan_sql(&f));
    con.query_row(&q, [], |r| r.get::<_, i64>(0)).map(|n| n > 0).unwrap_or(false)
}

/// The lake's partitions, named and sorted (crates/app/src/archive/layout.rs); `check` is
/// asked for every data file before any is read (the caller's sandbox). `site`: the name of a
/// one-site date=D/ lake, or the one site to take of a lake of several.
pub fn partitions(lake: &Path, site: Option<&str>, check: &dyn Fn(&Path) -> Result<(), String>) -> Result<Vec<Partition>, Box<dyn Error>> {
    let layout = layout::discover(lake)?;
    let all: Vec<PathBuf> = match &layout {
        Layout::Sites(p) | Layout::Dates(p) => p.iter().flat_map(|q| q.files.iter().cloned()).collect(),
    };
    for f in &all {
        check(f)?;
    }
    let parts = match layout {
        Layout::Sites(p) => match site {
            Some(s) => layout::only_site(p, s)?,
            None => p,
        },
        Layout::Dates(p) => {
            let files: Vec<String> = all.iter().map(|f| f.to_string_lossy().into_owned()).collect();
            let con = reader(&files)?;
            let with: Vec<bool> = all.iter().map(|f| has_site_column(&con, f)).collect();
            let any = with.iter().any(|b| *b);
            let every = with.iter().all(|b| *b);
            if any && !every && site.is_none() {
                return Err(ArchiveError(format!(
                    "trajdb archive: some files of {:?} have a site column and some do not (or cannot be read); give every file one (or none, and name the site with site := ...)",
                    lake.display().to_string()
                ))
                .into());
            }
            if any && every {
                let values: Vec<Vec<String>> = p.iter().map(|q| site_values(&con, &q.files)).collect();
                let split = layout::split_by_site(p, &values);
                match site {
                    Some(s) => layout::only_site(split, s)?,
                    None => split,
                }
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
        let lake = folder::resolve(&req.lake)?;
        // (the host checked every file against its caller's sandbox before: trajdb_archive's bind)
        let parts = partitions(&lake, req.site.as_deref(), &|_| Ok(()))?;
        // unknown names and bad values fail before any work
        plan::plan(&Request { input: "archive_input".into(), out: None, part: Part::Site, params: req.params.clone() })?;
        if let Some(m) = &req.task_memory {
            let con = Connection::open_in_memory()?;
            con.execute_batch(&format!("SET memory_limit = {}", sql_string(m)))
                .map_err(|e| format!("task_memory {m:?} is not a memory size DuckDB takes (give e.g. '2GB'): {e}"))?;
        }
        let out = folder::claim(&req.out, &lake)?;
        folder::no_links(&out, &out.join("_state").join("lock"))?;
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
