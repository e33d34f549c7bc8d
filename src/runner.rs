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
//! - **Sandbox.** Before any statement the private database gets the caller's file-access
//!   settings (`enable_external_access`, `allowed_directories`, `disabled_filesystems`) as read
//!   through the bind's client context, and its `threads` and `memory_limit`: it may read and
//!   write exactly what the caller's SQL may. A setting that cannot be read closes access.
//!   Work limits (`trajdb_limit`) are the caller's database's.
//! - **Catalog.** The private database reads files (Parquet, CSV, JSON, globs), not the
//!   caller's tables: a table or DataFrame input goes through `trajdb_stages` on the caller's
//!   own connection (Python's `trajdb.pipeline` does that), or is written to Parquet first.
//! - **Transactions and state.** Nothing of the run touches the caller's database: a caller's
//!   open transaction, its TEMP tables and variables are unaffected; the private database and
//!   all its memory are gone when the call returns.
//! - **Concurrent calls** each have their own private database.
//! - **Interrupts.** DuckDB's C API tells no extension about Ctrl-C; every function the
//!   pipeline calls is bounded by the work limits, and the Python runner (statement by
//!   statement on the caller's connection) stops at the next statement.

use duckdb::Connection;
use std::error::Error;
use std::time::Instant;
use trajdb_app::plan::Step;

/// The caller's settings the private database takes over (see the module doc).
#[derive(Clone, Debug, Default)]
pub struct Settings {
    /// `enable_external_access`; `None` (unreadable) closes access.
    pub external: Option<bool>,
    pub allowed_directories: Vec<String>,
    /// `disabled_filesystems` names `LocalFileSystem`.
    pub local_disabled: bool,
    pub threads: Option<String>,
    pub memory_limit: Option<String>,
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

/// Runs `steps` in a private in-memory database with `settings`; `register` registers trajdb's
/// functions there (the bindings, which sit above this module). When a step fails, the undos
/// of the steps that succeeded run last-first and the error names the stage, its file and the
/// statement.
pub fn run(settings: &Settings, steps: &[Step], register: impl FnOnce(&Connection) -> duckdb::Result<()>) -> Result<Vec<Log>, Box<dyn Error>> {
    let con = Connection::open_in_memory()?;
    // the sandbox first, in the order DuckDB allows (directories before access is closed)
    if let Some(t) = settings.threads.as_deref().and_then(|t| t.trim().parse::<i64>().ok()).filter(|t| *t > 0) {
        con.execute_batch(&format!("SET threads = {t}"))?;
    }
    if let Some(m) = settings.memory_limit.as_deref().filter(|m| !m.trim().is_empty()) {
        con.execute_batch(&format!("SET memory_limit = {}", quote(m)))?;
    }
    if !settings.allowed_directories.is_empty() {
        let list: Vec<String> = settings.allowed_directories.iter().map(|d| quote(d)).collect();
        con.execute_batch(&format!("SET allowed_directories = [{}]", list.join(", ")))?;
    }
    if settings.local_disabled {
        con.execute_batch("SET disabled_filesystems = 'LocalFileSystem'")?;
    }
    if settings.external != Some(true) {
        con.execute_batch("SET enable_external_access = false")?;
    }
    register(&con)?;
    execute(&con, steps)
}

fn execute(con: &Connection, steps: &[Step]) -> Result<Vec<Log>, Box<dyn Error>> {
    let mut log: Vec<Log> = Vec::new();
    let mut undo: Vec<&str> = Vec::new();
    let total = Instant::now();
    for (k, step) in steps.iter().enumerate() {
        let t = Instant::now();
        if let Err(e) = con.execute_batch(&step.sql) {
            for u in undo.iter().rev() {
                let _ = con.execute_batch(u);
            }
            let of_stage: Vec<&Step> = steps.iter().filter(|s| s.stage == step.stage).collect();
            let nth = steps[..=k].iter().filter(|s| s.stage == step.stage).count();
            let head: String = step.sql.split_whitespace().collect::<Vec<_>>().join(" ").chars().take(90).collect();
            return Err(format!("stage '{}' ({}) failed: {e}\n  in statement {nth} of {}: {head} ...", step.stage, step.file, of_stage.len()).into());
        }
        if let Some(u) = &step.undo {
            undo.push(u);
        }
        let s = t.elapsed().as_secs_f64();
        match log.last_mut() {
            Some(l) if l.stage == step.stage => {
                l.seconds += s;
                l.statements += 1;
            }
            _ => log.push(Log { stage: step.stage.clone(), seconds: s, statements: 1, note: step.file.clone() }),
        }
    }
    // what the run should tell its user (sql/warnings.sql, when the plan made them)
    let has_warnings = steps.iter().any(|s| s.makes.as_deref() == Some("pipeline_warnings"));
    if has_warnings {
        let mut st = con.prepare("SELECT message FROM pipeline_warnings ORDER BY k")?;
        let rows = st.query_map([], |r| r.get::<_, String>(0))?;
        for m in rows {
            log.push(Log { stage: "warning".into(), seconds: 0.0, statements: 0, note: m? });
        }
    }
    log.push(Log { stage: "total".into(), seconds: total.elapsed().as_secs_f64(), statements: steps.len() as i64, note: String::new() });
    Ok(log)
}
