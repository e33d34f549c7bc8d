//! SQL: the pipeline's declared parameters and its results folder, for every runner (Python,
//! Spark tasks, any host) so that none of them re-implements the checks:
//! - `trajdb_params_sql(json)`: the `SET VARIABLE` script for every declared parameter (its
//!   default, or the value given), each name and value checked (crates/app/src/params.rs);
//! - `trajdb_results_begin(out, input)` / `trajdb_results_end(out, commit)`: claim the results
//!   folder and replace the earlier results (crates/app/src/outdir.rs: the only code that may delete).
//!   Table functions, not scalars: they run exactly once per statement (a scalar with side
//!   effects may be evaluated again by the optimizer), and their bind sees the connection's
//!   file system (every sandbox setting of the connection applies, as to its COPY ... TO:
//!   src/bindings/vector/fs.rs).

use super::registry::{pd, Function, Section, Signature, Table, Ty};
use super::common::may_write_into;
use super::vector::table::{self, BindArgs, Rows, TableFn};
use super::vector::{Args, Out};
use crate::app::{outdir, params};
use std::error::Error;
use std::sync::Mutex;

pub static FUNCTIONS: &[Function] = &[PARAMS_SQL, PIPELINE_SQL, RESULTS_BEGIN, RESULTS_END];

const PIPELINE_SQL: Function = Function {
    name: "trajdb_pipeline_sql",
    description: "The text of sql/trajdb_pipeline.sql as this build makes it: sql/pipeline.sql, sql/warnings.sql and sql/analysis.sql \
                  with every `.read` line replaced by the file it names (the extension's one `.read` expander), for the DuckDB CLI \
                  from any folder (`trajdb sql-file > sql/trajdb_pipeline.sql` writes it). O(size of the SQL files).",
    example: "SELECT trajdb_pipeline_sql() LIKE '%CREATE OR REPLACE TEMP TABLE align_frames%'; -- true",
    maths: "crates/app/src/sql.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_script", "trajdb_params_sql"],
    signatures: &[Signature { params: &[], arities: &[], returns: Ty::Varchar, kernel: pipeline_sql }],
    table: None,
};

fn pipeline_sql(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
    let text = crate::app::sql::single_file()?;
    out.text(&vec![Some(text.as_str()); a.rows()]);
    Ok(())
}

const PARAMS_SQL: Function = Function {
    name: "trajdb_params_sql",
    description: "The SET VARIABLE statements that set every pipeline parameter (`trajdb params`) for one run: the values of the JSON object \
                  `values` ({\"merge_eta\": 0.6}, numbers, booleans or text; \"auto\" where the parameter is measured), every other parameter \
                  back to its default, so that nothing leaks from an earlier run. An unknown name, a value of the wrong type or outside the \
                  parameter's range is an error that names it. Runners execute the returned script before sql/pipeline.sql.",
    example: "SELECT trajdb_params_sql('{\"merge_eta\": 0.6}') LIKE '%SET VARIABLE merge_eta = 0.6::DOUBLE;%'; -- true",
    maths: "crates/app/src/params.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_params", "trajdb_params_script"],
    signatures: &[Signature {
        params: &[
            pd("values", Ty::Varchar, "a JSON object of pipeline parameters and their values, e.g. '{\"merge_eta\": 0.6}' (numbers, booleans, text, or \"auto\" where measured)"),
        ],
        arities: &[],
        returns: Ty::Varchar,
        kernel: params_sql,
    }],
    table: None,
};

fn params_sql(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
    let json = a.text(0);
    let vals = a.map(|r| {
        let Some(text) = json.get(r) else { return Ok(None) };
        // the same reading as trajdb_stages' params (crates/app/src/params.rs)
        let overrides = params::from_json(&text).map_err(|e| e.to_string().replacen("params must be", "values must be", 1))?;
        Ok(Some(params::set_sql(&params::resolve(&overrides)?)))
    })?;
    out.text(&vals);
    Ok(())
}

const BEGIN_TABLE: Table = Table {
    params: &[
        pd("out", Ty::Varchar, "the results folder to claim"),
        pd("input", Ty::Varchar, "the run's input (a path, glob, file:// URL or view): out may neither be nor contain it"),
    ],
    named: &[
        pd("kind", Ty::Varchar, "'results' (the default) or 'scenario' (trajdb.simulate's folder)"),
        pd("views", Ty::Varchar, "the caller's views as a JSON list of duckdb_views()' database, schema, name, sql: a view input is followed to its files"),
    ],
    columns: &[("staging", Ty::Varchar)],
    register: table::register::<Begin>,
};

const RESULTS_BEGIN: Function = Function {
    name: "trajdb_results_begin",
    description: "Claims the results folder `out` for one pipeline run and returns (one row, column staging) the folder to write the result \
                  files into, inside `out`. Refused before any work: NULL or '', '/', a file, a folder holding files that trajdb did not \
                  write, a folder that is or contains `input` (a path, glob or file:// URL; a view is followed to the files its definition names \
                  when `views` gives the caller's views, as trajdb_stages does: the JSON list of duckdb_views()' database, schema, name, \
                  sql; a view input without them, or one that builds its paths at run time, is refused where `out` holds earlier files), \
                  a folder of the other kind (`kind` 'results', the default, or 'scenario' for trajdb.simulate: a pipeline never \
                  writes into a scenario's folder, nor a simulation into results), a folder another run is writing into, and any folder this connection's own file system refuses (every sandbox setting, as for COPY ... TO). A new \
                  folder is created with normal permissions. End the run with trajdb_results_end.",
    example: "SELECT count(*) FROM trajdb_results_begin('/tmp/trajdb-example-results', 'points.parquet'); -- 1",
    maths: "crates/app/src/outdir.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_results_end", "trajdb_stages"],
    signatures: &[],
    table: Some(BEGIN_TABLE),
};

/// What a statement's bind decided, done once by the scan.
pub struct Job {
    out: String,
    input: String,
    commit: bool,
    kind: outdir::Kind,
    /// The caller's views (JSON of duckdb_views()), to follow a view input to its files.
    views: Option<String>,
}

/// The rows to emit (the side effect runs once, on the first call).
pub struct Once(Mutex<Option<Vec<String>>>);

fn once(job: &Job, scan: &Once, out: &mut Rows<'_>, run: impl FnOnce(&Job) -> Result<Vec<String>, outdir::OutError>) -> Result<usize, Box<dyn Error>> {
    let mut state = scan.0.lock().unwrap_or_else(|e| e.into_inner());
    let rows = match state.as_mut() {
        Some(rows) => rows,
        None => state.insert(run(job)?),
    };
    let n = rows.len().min(Rows::CAPACITY);
    for (k, v) in rows.drain(..n).enumerate() {
        out.text(0, k, &v);
    }
    Ok(n)
}

struct Begin;

impl TableFn for Begin {
    const TABLE: &'static Table = &BEGIN_TABLE;
    type Bind = Job;
    type Scan = Once;

    fn bind(args: &BindArgs<'_>) -> Result<Job, Box<dyn Error>> {
        let out = args.text(0)?.ok_or("out is NULL; name a results folder, e.g. 'results'")?;
        if out.trim().is_empty() {
            return Err("out is '' (empty); name a results folder, e.g. 'results'".into());
        }
        let kind = outdir::Kind::parse(&args.named_text("kind")?.unwrap_or_default())?;
        let views = args.named_text("views")?;
        may_write_into(args, &out)?;
        Ok(Job { out, input: args.text(1)?.unwrap_or_default(), commit: true, kind, views })
    }
    fn init(_: &Job) -> Result<Once, Box<dyn Error>> {
        Ok(Once(Mutex::new(None)))
    }
    fn func(job: &Job, scan: &Once, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        let catalog = match &job.views {
            Some(v) => outdir::Catalog::Views(v),
            None => outdir::Catalog::Unknown,
        };
        once(job, scan, out, |j| Ok(vec![outdir::open::begin(&j.out, &[&j.input], catalog, j.kind)?.to_string_lossy().into_owned()]))
    }
}

const END_TABLE: Table = Table {
    params: &[
        pd("out", Ty::Varchar, "the folder given to trajdb_results_begin, or its staging folder"),
        pd("commit", Ty::Boolean, "true: the staged files replace the earlier results; false: the staging folder is removed"),
    ],
    named: &[],
    columns: &[("file", Ty::Varchar)],
    register: table::register::<End>,
};

const RESULTS_END: Function = Function {
    name: "trajdb_results_end",
    description: "Ends the run that trajdb_results_begin started on `out` (the same folder, or its staging folder). With commit true, the files \
                  in the staging folder replace the earlier results (all targets are checked first, then each file is renamed into place; \
                  earlier result files this run did not write are removed; files that trajdb did not write are never touched) and one row \
                  per file is returned; with false the staging folder is removed, the earlier results stay as they were, and no row is \
                  returned (also when no run was open). Obeys this connection's own file system (every sandbox setting) as COPY ... TO does.",
    example: "SELECT count(*) FROM trajdb_results_end('/tmp/trajdb-example-results', false); -- 0",
    maths: "crates/app/src/outdir.rs",
    binding: file!(),
    section: Section::Pipeline,
    see_also: &["trajdb_results_begin"],
    signatures: &[],
    table: Some(END_TABLE),
};

struct End;

impl TableFn for End {
    const TABLE: &'static Table = &END_TABLE;
    type Bind = Job;
    type Scan = Once;

    fn bind(args: &BindArgs<'_>) -> Result<Job, Box<dyn Error>> {
        let out = args.text(0)?.ok_or("out is NULL; the folder given to trajdb_results_begin")?;
        let commit = args.boolean(1)?.ok_or("commit is NULL; true (replace the results) or false (abort the run)")?;
        may_write_into(args, &out)?;
        Ok(Job { out, input: String::new(), commit, kind: outdir::Kind::Results, views: None })
    }
    fn init(_: &Job) -> Result<Once, Box<dyn Error>> {
        Ok(Once(Mutex::new(None)))
    }
    fn func(job: &Job, scan: &Once, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        once(job, scan, out, |j| outdir::open::end(&j.out, j.commit))
    }
}
