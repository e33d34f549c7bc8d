//! SQL: the pipeline's one runner, for every host.
//! - `trajdb_pipeline(input, out_dir := ..., <parameter> := value, ...)`: the whole run in one
//!   statement (src/runner.rs executes the manifest in a private in-memory database with the caller's settings);
//! - `trajdb_stages(input, out, part, params)`: the manifest itself, one row per statement, for
//!   hosts that run the statements on their own connection (Python's `trajdb.pipeline`,
//!   `trajdb.windows`, Spark tasks): crates/app/src/plan.rs;
//! - `trajdb_script(path)`: the statements of one embedded SQL file (`.read` expanded);
//! - `trajdb_params()` and `trajdb_params_script()`: the declared parameter table and the text
//!   of sql/params.sql generated from it; `trajdb_reference(format)`: the function reference.
//!
//! Every parameter name and value is checked by crates/app/src/params.rs, once, whichever
//! host asks; no host splits SQL or resolves a parameter.

use super::common::{pipeline_param, N_PARAMS};
use super::registry::{pd, Function, Section, Signature, Table, Ty};
use super::types::Param;
use super::vector::table::{self, BindArgs, Rows, TableFn};
use super::vector::{Args, Out};
use crate::app::params::{self, PARAMS};
use crate::app::plan::{self, Part, Request, Step};
use crate::runner::{self, Settings};
use std::error::Error;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

pub static FUNCTIONS: &[Function] = &[PIPELINE, STAGES, SCRIPT, STATEMENT, PARAMS_TABLE, PARAMS_SCRIPT, REFERENCE];

const STATEMENT: Function = Function {
    name: "trajdb_statement",
    description: "What one SQL statement does to which table, view or macro, as the runner reads it (its undo, the manifest's `makes`): \
                  'ACTION NAME', ACTION one of table, view, macro (a CREATE), insert, delete, update and NAME the lower-case name \
                  without its schema (quoted names unquoted: temp.main.\"My T\" is my t); NULL for any other statement (SELECT, SET, \
                  ...). Comments (-- and /* */) are skipped, and a leading WITH clause: WITH x AS (...) INSERT INTO t is insert t. \
                  tests/check_stage_contracts.py reads every stage's statements with it. O(length of the statement).",
    example: "SELECT trajdb_statement('CREATE OR REPLACE TEMP MACRO m(x) AS x + 1'); -- macro m",
    maths: "crates/app/src/plan.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_script", "trajdb_stages"],
    signatures: &[Signature {
        params: &[pd("sql", Ty::Varchar, "one SQL statement (a row of trajdb_script or trajdb_stages)")],
        arities: &[],
        returns: Ty::Varchar,
        kernel: statement,
    }],
    table: None,
};

fn statement(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
    let sql = a.text(0);
    let vals = a.map(|r| {
        let Some(text) = sql.get(r) else { return Ok(None) };
        Ok(plan::statement_action(&text).map(|(action, name)| format!("{action} {name}")))
    })?;
    out.text(&vals);
    Ok(())
}

/// `out_dir` and every declared pipeline parameter, as named parameters of trajdb_pipeline.
static PIPELINE_NAMED: [Param; N_PARAMS + 1] = {
    let mut a = [pd("out_dir", Ty::Varchar, "the results folder, new or holding earlier results of trajdb (required)"); N_PARAMS + 1];
    let mut k = 0;
    while k < N_PARAMS {
        a[k + 1] = pipeline_param(k);
        k += 1;
    }
    a
};

const PIPELINE_TABLE: Table = Table {
    params: &[pd("input", Ty::Varchar, "the points: a file or a glob (never SQL), e.g. 'points.parquet'")],
    named: &PIPELINE_NAMED,
    columns: &[("stage", Ty::Varchar), ("seconds", Ty::Double), ("statements", Ty::Bigint), ("note", Ty::Varchar)],
    register: table::register::<PipelineFn>,
};

const PIPELINE: Function = Function {
    name: "trajdb_pipeline",
    description: "The whole pipeline in one statement: `CALL trajdb_pipeline('points.parquet', out_dir := 'results', merge_eta := 0.6)`. \
                  `input` is a file or a glob (never SQL); `out_dir` the results folder (transforms.csv, \
                  calibration.csv, matches.csv, merged.parquet, clusters.csv, links.csv, report.html), claimed before any work and \
                  replaced only when every file is written; every other named parameter is a pipeline parameter (`FROM trajdb_params()`; \
                  'auto' where measured), checked by name, type and range. Returns one row per stage as it finishes (seconds, statements, its file), one \
                  per warning and a total; an interrupt stops it after the current stage and undoes it (earlier results stay). It runs in a private in-memory database with this connection's threads, memory and work limits, allowed exactly the \
                  input files and results folder this connection's own file system let it open (every sandbox setting applies) (src/runner.rs): it reads files, not this database's tables (for a table or a DataFrame run \
                  trajdb_stages on your connection, as Python's trajdb.pipeline does), and leaves nothing in this database: read the \
                  results from `out_dir`.",
    example: "SELECT count(*) > 0 FROM trajdb_params(); -- true",
    maths: "crates/app/src/plan.rs, src/runner.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_stages", "trajdb_params", "trajdb_archive"],
    signatures: &[],
    table: Some(PIPELINE_TABLE),
};

struct PipelineFn;

/// The paths a run may read for `input` (a file, a glob or a URL): the input itself and, for a
/// glob, every file it matches now, each opened for reading through the caller's file system
/// (`fs`), which refuses what the caller's own SQL may not read. The pattern is checked before
/// it is listed, so a folder the caller may not read is never listed either. The list is
/// expanded in a throwaway database allowed exactly the pattern; a file that appears between
/// here and the run is not on the list, and the run's read of it is refused.
fn readable_inputs(fs: &super::vector::fs::CallerFs, input: &str) -> Result<Vec<String>, Box<dyn Error>> {
    fs.may_read(input)?;
    let mut paths = vec![input.to_string()];
    if input.contains(['*', '?', '[', '{']) {
        let con = duckdb::Connection::open_in_memory()?;
        con.execute_batch(&format!("SET allowed_paths = ['{}']", input.replace('\'', "''")))?;
        con.execute_batch("SET enable_external_access = false; SET lock_configuration = true")?;
        let mut st = con.prepare("SELECT file FROM glob(?) ORDER BY file")?;
        let files = st.query_map([input], |r| r.get::<_, String>(0))?;
        for f in files {
            let f = f?;
            fs.may_read(&f)?;
            paths.push(f);
        }
    }
    Ok(paths)
}

/// The run of one statement: opened on the first call, one stage per call after it; rows
/// waiting to be written; done.
pub struct PipelineScan(Mutex<(Option<runner::Run>, Vec<Log>, bool)>);

type Log = runner::Log;

impl TableFn for PipelineFn {
    const TABLE: &'static Table = &PIPELINE_TABLE;
    type Bind = (Vec<Step>, Settings, std::sync::Arc<crate::algo::limits::Limits>);
    type Scan = PipelineScan;

    fn bind(args: &BindArgs<'_>) -> Result<Self::Bind, Box<dyn Error>> {
        let input = args.text(0)?.ok_or("input is NULL; give a file or a glob, e.g. 'points.parquet'")?;
        let out = args.named_text("out_dir")?.ok_or(
            "out_dir is missing: name the results folder, e.g. out_dir := 'results' (the run is private: to keep its tables in your \
             session run `.read sql/pipeline.sql`, or trajdb.pipeline in Python)",
        )?;
        if out.trim().is_empty() {
            return Err("out_dir is '' (empty); name a results folder, e.g. out_dir := 'results'".into());
        }
        // the settings DuckDB lets us read, then the caller's own file system, which has the
        // last word (src/runner.rs, "Sandbox, by construction")
        super::common::may_write_into(args, &out)?;
        let out_dir = crate::app::outdir::absolute(&out)?;
        let fs = args.caller_fs()?;
        let mut read_paths = readable_inputs(&fs, &input)?;
        let params: Vec<(String, String)> = args.named_as_text()?.into_iter().filter(|(k, _)| k != "out_dir").collect();
        // the report's gates (issue 39): a file the run may read, as the input; the private
        // database has none of this connection's tables
        if let Some((_, g)) = params.iter().rev().find(|(k, _)| k == "report_gates") {
            let g = g.trim();
            let lower = g.to_ascii_lowercase();
            if lower.ends_with(".csv") || lower.ends_with(".csv.gz") || lower.ends_with(".parquet") {
                fs.may_read(g).map_err(|e| format!("report_gates: cannot read {g:?}: {e}"))?;
                read_paths.push(g.to_string());
            } else if !g.is_empty() {
                return Err(format!(
                    "report_gates = {g:?}: CALL trajdb_pipeline reads files, not this database's tables; give the gates as a .csv or .parquet \
                     file (approach, x1, y1, x2, y2 or approach, wkt), or run trajdb.pipeline in Python on your connection"
                )
                .into());
            }
        }
        let steps = plan::plan(&Request { input, out: Some(out), part: Part::All, params })?;
        let flag = |name: &str| args.setting(name).map(|v| v.eq_ignore_ascii_case("true"));
        let settings = Settings {
            read_paths,
            write_dirs: vec![out_dir.to_string_lossy().into_owned()],
            threads: args.setting("threads"),
            memory_limit: args.setting("memory_limit"),
            autoinstall: flag("autoinstall_known_extensions"),
            autoload: flag("autoload_known_extensions"),
            temp_directory: None,
        };
        Ok((steps, settings, std::sync::Arc::clone(args.limits())))
    }
    fn init(_: &Self::Bind) -> Result<Self::Scan, Box<dyn Error>> {
        Ok(PipelineScan(Mutex::new((None, Vec::new(), false))))
    }
    fn func(bind: &Self::Bind, scan: &Self::Scan, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        let mut guard = scan.0.lock().unwrap_or_else(|e| e.into_inner());
        let (run, pending, done) = &mut *guard;
        if pending.is_empty() && !*done {
            if run.is_none() {
                *run = Some(runner::open(&bind.1, bind.0.clone(), |con| super::register_all_with(con, std::sync::Arc::clone(&bind.2)))?);
            }
            match run.as_mut().expect("opened").next_stage() {
                Ok(Some(rows)) => pending.extend(rows),
                Ok(None) => *done = true,
                Err(e) => {
                    *done = true;
                    *run = None;
                    return Err(e);
                }
            }
        }
        let n = pending.len().min(Rows::CAPACITY);
        for (r, l) in pending.drain(..n).enumerate() {
            out.text(0, r, &l.stage);
            out.double(1, r, l.seconds);
            out.bigint(2, r, l.statements);
            out.text(3, r, &l.note);
        }
        if n == 0 {
            *run = None; // finished: the private database closes now
        }
        Ok(n)
    }
}

const STAGES_TABLE: Table = Table {
    params: &[pd("input", Ty::Varchar, "the points: a file, a glob or a table name, e.g. 'points.parquet'")],
    named: &[
        pd("out_dir", Ty::Varchar, "the results folder: adds the statements that write the result files and report.html; default: none"),
        pd("part", Ty::Varchar, "'all' (the default), 'site', 'window' or 'day'"),
        pd("params", Ty::Varchar, "a JSON object of pipeline parameters, e.g. '{\"merge_eta\": 0.6}'; default: every default"),
    ],
    columns: &[
        ("k", Ty::Bigint),
        ("stage", Ty::Varchar),
        ("file", Ty::Varchar),
        ("sql", Ty::Varchar),
        ("makes", Ty::Varchar),
        ("undo", Ty::Varchar),
        ("shared", Ty::Boolean),
        ("short_name", Ty::Varchar),
    ],
    register: table::register::<StagesFn>,
};

const STAGES: Function = Function {
    name: "trajdb_stages",
    description: "The pipeline's manifest: one row per statement of a run, in order (k), with its stage, its file, the statement, the table \
                  or macro it makes, the statement that undoes it when a later one fails (`undo`), and whether `makes` is a site table \
                  shared by the windows of a site (`shared`). A host runs the rows in order on its own connection; after a row succeeds \
                  it remembers its undo; when a row fails it runs the remembered undos last-first. `short_name` names the short name a row gives one \
                  of trajdb's macros (sql/analysis.sql: routes for trajdb_routes): a host skips that row when the name is already the user's. `out_dir` (optional) adds the result \
                  files and report.html, the results folder claimed first and committed last; `part` is 'all' (default), 'site' (the \
                  load and the calibration stages of a site) 'window' (one window that reuses a site's tables: sql/window.sql) or 'day' (an archive's day: the whole run, \
                  with out_dir, on a site's tables kept from an earlier day: src/archive/task.rs); \
                  `params` a JSON object of pipeline parameters ('{\"merge_eta\": 0.6}'), checked by name, type and range.",
    example: "SELECT count(DISTINCT stage) >= 9 FROM trajdb_stages('points.parquet'); -- true",
    maths: "crates/app/src/plan.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_pipeline", "trajdb_script", "trajdb_params_sql"],
    signatures: &[],
    table: Some(STAGES_TABLE),
};

/// Rows of statements, emitted a chunk at a time.
pub struct Cursor(AtomicUsize);

fn emit_steps(steps: &[Step], cursor: &Cursor, out: &mut Rows<'_>) -> usize {
    let start = cursor.0.fetch_add(Rows::CAPACITY, Ordering::SeqCst).min(steps.len());
    let rows = &steps[start..(start + Rows::CAPACITY).min(steps.len())];
    for (r, s) in rows.iter().enumerate() {
        out.bigint(0, r, (start + r + 1) as i64);
        out.text(1, r, &s.stage);
        out.text(2, r, &s.file);
        out.text(3, r, &s.sql);
        out.opt_text(4, r, s.makes.as_deref());
        out.opt_text(5, r, s.undo.as_deref());
        out.boolean(6, r, s.makes.as_deref().is_some_and(|m| plan::SITE_TABLES.contains(&m)));
        out.opt_text(7, r, plan::short_name(&s.sql).as_deref());
    }
    rows.len()
}

struct StagesFn;

impl TableFn for StagesFn {
    const TABLE: &'static Table = &STAGES_TABLE;
    type Bind = Vec<Step>;
    type Scan = Cursor;

    fn bind(args: &BindArgs<'_>) -> Result<Self::Bind, Box<dyn Error>> {
        let input = args.text(0)?.ok_or("input is NULL; give a file, a glob or a table name, e.g. 'points.parquet'")?;
        let out = args.named_text("out_dir")?;
        if let Some(o) = &out {
            if o.trim().is_empty() {
                return Err("out_dir is '' (empty); name a results folder, e.g. out_dir := 'results', or leave it out".into());
            }
        }
        let part = Part::parse(&args.named_text("part")?.unwrap_or_default())?;
        let params = params::from_json(&args.named_text("params")?.unwrap_or_default())?;
        plan::plan(&Request { input, out, part, params })
    }
    fn init(_: &Self::Bind) -> Result<Self::Scan, Box<dyn Error>> {
        Ok(Cursor(AtomicUsize::new(0)))
    }
    fn func(steps: &Self::Bind, cursor: &Self::Scan, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        Ok(emit_steps(steps, cursor, out))
    }
}

const SCRIPT_TABLE: Table = Table {
    params: &[pd("path", Ty::Varchar, "one of trajdb's embedded SQL files, e.g. 'sql/export.sql'")],
    named: &[],
    columns: STAGES_TABLE.columns,
    register: table::register::<ScriptFn>,
};

const SCRIPT: Function = Function {
    name: "trajdb_script",
    description: "The statements of one of trajdb's SQL files as this extension embeds them (`sql/score.sql`, `sql/export.sql`, \
                  `sql/report.sql`, `sql/warnings.sql`, `sql/demo.sql`, ...), its `.read` lines expanded, one row each in the columns of \
                  trajdb_stages: what `.read FILE` runs in the DuckDB CLI, for hosts without `.read`. An unknown path is an error listing \
                  the files.",
    example: "SELECT count(*) > 3 FROM trajdb_script('sql/export.sql'); -- true",
    maths: "crates/app/src/plan.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_stages"],
    signatures: &[],
    table: Some(SCRIPT_TABLE),
};

struct ScriptFn;

impl TableFn for ScriptFn {
    const TABLE: &'static Table = &SCRIPT_TABLE;
    type Bind = Vec<Step>;
    type Scan = Cursor;

    fn bind(args: &BindArgs<'_>) -> Result<Self::Bind, Box<dyn Error>> {
        let path = args.text(0)?.ok_or("path is NULL; e.g. 'sql/score.sql'")?;
        if path.contains('\0') || crate::app::sql::file(&path).is_none() {
            let files: Vec<&str> = crate::app::sql::SQL_FILES.iter().map(|(p, _)| *p).collect();
            return Err(format!("path {path:?} is not one of trajdb's SQL files ({})", files.join(", ")).into());
        }
        plan::script(&path)
    }
    fn init(_: &Self::Bind) -> Result<Self::Scan, Box<dyn Error>> {
        Ok(Cursor(AtomicUsize::new(0)))
    }
    fn func(steps: &Self::Bind, cursor: &Self::Scan, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        Ok(emit_steps(steps, cursor, out))
    }
}

const PARAMS_COLUMNS: &[(&str, Ty)] =
    &[("name", Ty::Varchar), ("type", Ty::Varchar), ("default", Ty::Varchar), ("stage", Ty::Varchar), ("description", Ty::Varchar), ("lo", Ty::Double), ("hi", Ty::Double)];

const PARAMS_TABLE_T: Table = Table { params: &[], named: &[], columns: PARAMS_COLUMNS, register: table::register::<ParamsFn> };

const PARAMS_TABLE: Function = Function {
    name: "trajdb_params",
    description: "The pipeline's parameters, declared once (crates/app/src/params.rs): name, SQL type, default ('auto': measured from the \
                  recording by the calibrate stage), the stage that reads it, what it does, and the closed range a number must lie in. \
                  trajdb_pipeline and trajdb_stages check every value against this table; sql/params.sql is generated from it.",
    example: "SELECT \"default\" FROM trajdb_params() WHERE name = 'merge_eta'; -- 0.5",
    maths: "crates/app/src/params.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_params_script", "trajdb_params_sql", "trajdb_pipeline"],
    signatures: &[],
    table: Some(PARAMS_TABLE_T),
};

struct ParamsFn;

impl TableFn for ParamsFn {
    const TABLE: &'static Table = &PARAMS_TABLE_T;
    type Bind = ();
    type Scan = AtomicUsize;

    fn bind(_: &BindArgs<'_>) -> Result<(), Box<dyn Error>> {
        Ok(())
    }
    fn init(_: &()) -> Result<AtomicUsize, Box<dyn Error>> {
        Ok(AtomicUsize::new(0))
    }
    fn func(_: &(), next: &AtomicUsize, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        if next.fetch_add(1, Ordering::SeqCst) > 0 {
            return Ok(0);
        }
        for (r, q) in PARAMS.iter().enumerate() {
            out.text(0, r, q.name);
            out.text(1, r, params::kind_sql(q.kind));
            out.text(2, r, q.default.trim_matches('\''));
            out.text(3, r, q.stage);
            out.text(4, r, q.description);
            out.double(5, r, q.lo);
            out.double(6, r, q.hi);
        }
        Ok(PARAMS.len())
    }
}

const PARAMS_SCRIPT: Function = Function {
    name: "trajdb_params_script",
    description: "The text of sql/params.sql, generated from the declared parameter table (`trajdb params --sql`): a default for every \
                  parameter that is not set yet.",
    example: "SELECT trajdb_params_script() LIKE '%merge_eta%'; -- true",
    maths: "crates/app/src/params.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_params", "trajdb_params_sql"],
    signatures: &[Signature { params: &[], arities: &[], returns: Ty::Varchar, kernel: params_script }],
    table: None,
};

fn params_script(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
    let text = params::params_sql();
    let vals = a.map(|_| Ok(Some(text.clone())))?;
    out.text(&vals);
    Ok(())
}

const REFERENCE: Function = Function {
    name: "trajdb_reference",
    description: "The function reference generated from the registered descriptions: format 'markdown' (docs/functions.md: the \
                  sections with an index, each function's overloads, description, arguments, example and related functions), 'text' \
                  (the same by section, as plain text), 'families' (per section, where its maths, bindings and functions live: the \
                  table of docs/development.md) or 'params' (the pipeline parameters with their type, default, range, stage and \
                  description, as `trajdb params` prints them).",
    example: "SELECT trajdb_reference('markdown') LIKE '# trajdb function reference%'; -- true",
    maths: "src/bindings/registry.rs",
    binding: file!(),
    section: Section::Reference,
    see_also: &["trajdb_functions", "trajdb_params"],
    signatures: &[Signature {
        params: &[pd("format", Ty::Varchar, "'markdown' (docs/functions.md), 'text', 'families' (the family table of docs/development.md) or 'params' (the parameter table)")],
        arities: &[],
        returns: Ty::Varchar,
        kernel: reference,
    }],
    table: None,
};

fn reference(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
    let format = a.text(0);
    let vals = a.map(|r| {
        let Some(f) = format.get(r) else { return Ok(None) };
        let docs = super::docs();
        Ok(Some(match f.trim().to_ascii_lowercase().as_str() {
            "markdown" => super::registry::markdown(&docs),
            "text" => super::registry::text(&docs),
            "families" => super::registry::families(&docs),
            "params" => params::table(),
            other => return Err(format!("format must be 'markdown', 'text', 'families' or 'params', got {other:?}").into()),
        }))
    })?;
    out.text(&vals);
    Ok(())
}
