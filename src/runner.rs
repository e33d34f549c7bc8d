//! The pipeline runner of `CALL trajdb_pipeline(...)`: executes the statements of
//! [`trajdb_app::plan`] in a private in-memory database opened for the call.
//!
//! # Why a private database, and why it is safe
//! DuckDB's C API (v1, the one this extension targets) gives a function no way to run SQL on
//! the connection that called it (a C++ extension would use its `ClientContext`), and the
//! database handle an extension receives at LOAD is valid only during the load. A connection
//! opened then and kept would hold the caller's database open until the process ends: a
//! database FILE would stay locked against every other process after the user closed it
//! (tests/test_sandbox_python.py checks that it does not). So each call opens its own
//! in-memory DuckDB in this process, registers trajdb's functions there, runs the manifest,
//! writes the result files and closes it:
//! - **Sandbox, by construction.** The private database may touch exactly the files the
//!   caller's own file system let the bind open: the bind opens the input (the pattern, and
//!   each file it matches) for reading and the results folder for writing through the calling
//!   connection's file system (src/bindings/vector/fs.rs), where every sandbox setting DuckDB
//!   has applies (`enable_external_access`, `allowed_directories`, `allowed_paths`,
//!   `disabled_filesystems`, and any later one), and refuses when it refuses. Before any
//!   statement the private database gets `allowed_paths` = those input paths,
//!   `allowed_directories` = the results folder, `enable_external_access = false` and
//!   `lock_configuration = true`: no statement of the run can read or write anything else, nor
//!   lift the restriction. So a file the caller may not read is never opened, and no error
//!   message can quote its rows. It also takes the caller's `threads` and `memory_limit`.
//!   Work limits (`trajdb_limit`) are the caller's database's.
//! - **Catalog.** The private database reads files (Parquet, CSV, JSON, globs), not the
//!   caller's tables: a table or DataFrame input goes through `trajdb_stages` on the caller's
//!   own connection (Python's `trajdb.pipeline` does that), or is written to Parquet first.
//! - **Transactions and state.** Nothing of the run touches the caller's database: a caller's
//!   open transaction, its TEMP tables and variables are unaffected; the private database and
//!   all its memory are gone when the call returns.
//! - **Concurrent calls** each have their own private database.
//! - **Interrupts.** DuckDB's C API tells no extension about Ctrl-C, but it stops asking a
//!   table function for rows: the run goes one stage per call ([`Run::next_stage`]), so an
//!   interrupt stops it after the current stage and the unfinished run is undone (its staging
//!   folder removed, the earlier results kept). Within a stage every function is bounded by the
//!   work limits. The Python runner (statement by statement) stops at the next statement.
//! - **Extensions.** The private database installs or autoloads extensions only where the
//!   caller's settings allow it.

use duckdb::Connection;
use std::error::Error;
use std::time::Instant;
use trajdb_app::plan::Step;

/// The caller's settings the private database takes over (see the module doc).
#[derive(Clone, Debug, Default)]
pub struct Settings {
    /// The paths the run may read (the input pattern and the files it matched), each opened
    /// through the caller's file system at bind.
    pub read_paths: Vec<String>,
    /// The folders the run may write into (the results folder, resolved), each checked through
    /// the caller's file system at bind.
    pub write_dirs: Vec<String>,
    pub threads: Option<String>,
    pub memory_limit: Option<String>,
    /// `autoinstall_known_extensions` / `autoload_known_extensions`; `None` (unreadable): off.
    pub autoinstall: Option<bool>,
    pub autoload: Option<bool>,
    /// Where DuckDB spills (an archive's task: its scratch folder); `None`: DuckDB's default.
    pub temp_directory: Option<String>,
}

/// What a run did, one row per stage (in order), then one per warning, then the total.
#[derive(Clone, Debug)]
pub struct Log {
    pub stage: String,
    pub seconds: f64,
    pub statements: i64,
    pub note: String,
}

fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "''"))
}

/// One run in its private database: the next stage at a time ([`Run::next_stage`]), so that a
/// caller's interrupt (DuckDB stops asking for rows) stops it between stages; dropping an
/// unfinished run undoes what it did (the staging folder goes, earlier results stay).
pub struct Run {
    con: Connection,
    steps: Vec<Step>,
    next: usize,
    undo: Vec<String>,
    started: Instant,
    finished: bool,
}

/// Opens a run of `steps` in a private in-memory database with `settings`; `register`
/// registers trajdb's functions there (the bindings, which sit above this module).
pub fn open(settings: &Settings, steps: Vec<Step>, register: impl FnOnce(&Connection) -> duckdb::Result<()>) -> Result<Run, Box<dyn Error>> {
    let con = private(settings, register)?;
    Ok(Run { con, steps, next: 0, undo: Vec::new(), started: Instant::now(), finished: false })
}

/// A private in-memory database with `settings` (the sandbox locked) and trajdb's functions.
pub fn private(settings: &Settings, register: impl FnOnce(&Connection) -> duckdb::Result<()>) -> Result<Connection, Box<dyn Error>> {
    let con = Connection::open_in_memory()?;
    // the sandbox first, in the order DuckDB allows (directories before access is closed);
    // extensions are never installed or loaded behind the caller's back
    for (name, on) in [("autoinstall_known_extensions", settings.autoinstall), ("autoload_known_extensions", settings.autoload)] {
        con.execute_batch(&format!("SET {name} = {}", on == Some(true)))?;
    }
    if let Some(t) = settings.threads.as_deref().and_then(|t| t.trim().parse::<i64>().ok()).filter(|t| *t > 0) {
        con.execute_batch(&format!("SET threads = {t}"))?;
    }
    if let Some(m) = settings.memory_limit.as_deref().filter(|m| !m.trim().is_empty()) {
        con.execute_batch(&format!("SET memory_limit = {}", quote(m)))?;
    }
    if let Some(d) = settings.temp_directory.as_deref() {
        con.execute_batch(&format!("SET temp_directory = {}", quote(d)))?;
    }
    // only what the caller's file system allowed at bind (module doc); then locked
    let list = |v: &[String]| v.iter().map(|d| quote(d)).collect::<Vec<_>>().join(", ");
    if !settings.read_paths.is_empty() {
        con.execute_batch(&format!("SET allowed_paths = [{}]", list(&settings.read_paths)))?;
    }
    if !settings.write_dirs.is_empty() {
        con.execute_batch(&format!("SET allowed_directories = [{}]", list(&settings.write_dirs)))?;
    }
    con.execute_batch("SET enable_external_access = false")?;
    con.execute_batch("SET lock_configuration = true")?;
    register(&con)?;
    Ok(con)
}

/// Runs `steps` on `con` in order (a host's whole run, as Python's `execute_steps`): after a
/// step succeeds its undo is remembered; when one fails the remembered undos run last-first and
/// the error names the stage, its file and the statement.
pub fn execute_all(con: &Connection, steps: &[Step]) -> Result<(), Box<dyn Error>> {
    let mut undo: Vec<&str> = Vec::new();
    for s in steps {
        if let Err(e) = con.execute_batch(&s.sql) {
            for u in undo.iter().rev() {
                let _ = con.execute_batch(u);
            }
            let head: String = s.sql.split_whitespace().collect::<Vec<_>>().join(" ").chars().take(90).collect();
            return Err(format!("stage '{}' ({}) failed: {e}\n  in statement: {head} ...", s.stage, s.file).into());
        }
        if let Some(u) = &s.undo {
            undo.push(u);
        }
    }
    Ok(())
}

impl Run {
    fn abort(&mut self) {
        self.finished = true;
        for u in self.undo.drain(..).rev() {
            let _ = self.con.execute_batch(&u);
        }
    }

    /// Runs the statements of the next stage and returns its row; after the last stage, the
    /// warnings and the total; `None` when the run is over. A failure undoes the run and names
    /// the stage, its file and the statement.
    pub fn next_stage(&mut self) -> Result<Option<Vec<Log>>, Box<dyn Error>> {
        if self.finished {
            return Ok(None);
        }
        if self.next >= self.steps.len() {
            self.finished = true;
            return Ok(Some(self.closing()?));
        }
        let stage = self.steps[self.next].stage.clone();
        let (file, t) = (self.steps[self.next].file.clone(), Instant::now());
        let first = self.next;
        let mut n = 0;
        while self.next < self.steps.len() && self.steps[self.next].stage == stage {
            let k = self.next;
            if let Err(e) = self.con.execute_batch(&self.steps[k].sql) {
                self.abort();
                let of_stage = self.steps.iter().filter(|s| s.stage == stage).count();
                let nth = k - first + 1;
                let head: String = self.steps[k].sql.split_whitespace().collect::<Vec<_>>().join(" ").chars().take(90).collect();
                let mut msg = format!("stage '{stage}' ({}) failed: {e}\n  in statement {nth} of {of_stage}: {head} ...", self.steps[k].file);
                if stage == "load" && msg.contains("neither a table or view") {
                    msg.push_str("\n  (trajdb_pipeline runs in a private database and reads files; for a table or a DataFrame run the rows of trajdb_stages on your connection, as Python's trajdb.pipeline does, or COPY the table to Parquet first)");
                }
                return Err(msg.into());
            }
            if let Some(u) = &self.steps[k].undo {
                self.undo.push(u.clone());
            }
            self.next += 1;
            n += 1;
        }
        if self.next >= self.steps.len() {
            self.undo.clear(); // committed: nothing left to undo
        }
        Ok(Some(vec![Log { stage, seconds: t.elapsed().as_secs_f64(), statements: n, note: file }]))
    }

    /// The warnings (sql/warnings.sql, when the plan made them) and the total.
    fn closing(&self) -> Result<Vec<Log>, Box<dyn Error>> {
        let mut log = Vec::new();
        if self.steps.iter().any(|s| s.makes.as_deref() == Some("pipeline_warnings")) {
            let mut st = self.con.prepare("SELECT message FROM pipeline_warnings ORDER BY k")?;
            let rows = st.query_map([], |r| r.get::<_, String>(0))?;
            for m in rows {
                log.push(Log { stage: "warning".into(), seconds: 0.0, statements: 0, note: m? });
            }
        }
        log.push(Log { stage: "total".into(), seconds: self.started.elapsed().as_secs_f64(), statements: self.steps.len() as i64, note: String::new() });
        Ok(log)
    }
}

impl Drop for Run {
    /// An unfinished run (the caller interrupted it, or stopped reading its rows) is undone.
    fn drop(&mut self) {
        if !self.finished {
            self.abort();
        }
    }
}
