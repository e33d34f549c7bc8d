//! The pipeline runner of `CALL trajdb_pipeline(...)`: executes the statements of
//! [`trajdb_app::plan`] on a connection of the caller's database.
//!
//! # Why a second connection, and why it is safe
//! DuckDB's C API (v1, the one this extension targets) gives a function no way to run SQL on
//! the connection that called it (a C++ extension would use its `ClientContext`). What it does
//! give, once, is the database at LOAD: [`Runner::open`] opens one connection on it then (the
//! database handle of the load is not valid afterwards), kept for the database's lifetime.
//! - **Catalog.** The runner's connection sees the caller's persistent tables and views and
//!   the files the caller may read; not the caller's TEMP objects or Python-registered
//!   DataFrames (per connection in DuckDB). `trajdb.pipeline` (Python) therefore runs the same
//!   statements on the caller's own connection (`trajdb_stages`), and `trajdb_pipeline` refuses
//!   nothing more than DuckDB would: an input it cannot see is "neither a table nor a file".
//! - **Settings.** `enable_external_access`, `allowed_directories`, threads and memory limits
//!   are database-wide: the runner obeys the caller's. Variables are per connection: the
//!   caller's `SET VARIABLE`s do not leak in (parameters come as named arguments, checked).
//! - **Transactions.** Every statement of a run commits on its own (autocommit), as in the
//!   DuckDB CLI; the work tables are TEMP on the runner's connection, so a caller's open
//!   transaction never sees half a run, and nothing of the run is left in the caller's
//!   database: after each run every TEMP object and variable of the runner's connection is
//!   dropped (its memory freed).
//! - **Concurrent calls** on one database take turns (a mutex): two runs never share the
//!   runner's TEMP tables. Calls in different databases have different runners.
//! - **Lifetime.** The kept connection holds the database open until the process ends (DuckDB
//!   has no weak handle): a file database stays locked against OTHER processes until then.
//! - **Interrupts.** DuckDB's C API tells no extension about Ctrl-C; every function the
//!   pipeline calls is bounded by the work limits (trajdb_limit), and the Python runner
//!   (statement by statement on the caller's connection) stops at the next statement.

use duckdb::Connection;
use std::error::Error;
use std::sync::Mutex;
use std::time::Instant;
use trajdb_app::plan::Step;

/// One database's runner (see the module doc).
pub struct Runner {
    con: Mutex<Option<Connection>>,
}

/// What a run did, one row per stage (in order), then one per warning, then the files written.
#[derive(Clone, Debug)]
pub struct Log {
    pub stage: String,
    pub seconds: f64,
    pub statements: i64,
    pub note: String,
}

impl Runner {
    /// Opens the runner's connection on `con`'s database: call at LOAD, while the database
    /// handle the entry point received is valid.
    pub fn open(con: &Connection) -> Runner {
        Runner { con: Mutex::new(con.try_clone().ok()) }
    }

    /// A runner with no connection (unit tests of the registry).
    pub fn none() -> Runner {
        Runner { con: Mutex::new(None) }
    }

    /// Executes `steps` in order; when one fails, the undos of the steps that succeeded run
    /// last-first and the error names the stage, its file and the statement. The runner's TEMP
    /// objects and variables are dropped afterwards either way.
    pub fn run(&self, steps: &[Step]) -> Result<Vec<Log>, Box<dyn Error>> {
        let mut guard = self.con.lock().unwrap_or_else(|e| e.into_inner());
        let con = guard.as_mut().ok_or("this database has no runner connection (the extension could not open one at LOAD)")?;
        let result = execute(con, steps);
        let cleaned = clean(con);
        let log = result?;
        cleaned?;
        Ok(log)
    }
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

/// Drops every TEMP table, view and macro of the runner's connection and resets its variables:
/// the next run starts clean and the memory of this one is freed.
fn clean(con: &Connection) -> Result<(), Box<dyn Error>> {
    let drops: Vec<String> = con
        .prepare(
            "SELECT 'DROP ' || kind || ' IF EXISTS temp.main.\"' || replace(name, '\"', '\"\"') || '\"' FROM (
                 SELECT 'VIEW' AS kind, view_name AS name FROM duckdb_views() WHERE temporary AND NOT internal
                 UNION ALL SELECT 'TABLE', table_name FROM duckdb_tables() WHERE temporary
                 UNION ALL SELECT DISTINCT CASE function_type WHEN 'table_macro' THEN 'MACRO TABLE' ELSE 'MACRO' END, function_name
                 FROM duckdb_functions() WHERE database_name = 'temp' AND function_type IN ('macro', 'table_macro'))
             UNION ALL SELECT 'RESET VARIABLE \"' || replace(name, '\"', '\"\"') || '\"' FROM duckdb_variables()",
        )?
        .query_map([], |r| r.get(0))?
        .collect::<Result<_, _>>()?;
    for d in drops {
        con.execute_batch(&d)?;
    }
    Ok(())
}
