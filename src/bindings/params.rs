//! SQL: the pipeline's declared parameters and its results folder, for every runner (Python,
//! Spark tasks, any host) so that none of them re-implements the checks:
//! - `trajdb_params_sql(json)`: the `SET VARIABLE` script for every declared parameter (its
//!   default, or the value given), each name and value checked (src/app/params.rs);
//! - `trajdb_results_begin(out, input)` / `trajdb_results_end(staging, commit)`: claim the results
//!   folder and replace the earlier results (src/app/outdir.rs: the only code that may delete).

use super::registry::{p, Function, Signature, Ty};
use super::vector::{Args, Out};
use crate::app::{outdir, params};
use std::error::Error;

pub static FUNCTIONS: &[Function] = &[PARAMS_SQL, RESULTS_BEGIN, RESULTS_END];

const PARAMS_SQL: Function = Function {
    name: "trajdb_params_sql",
    description: "The SET VARIABLE statements that set every pipeline parameter (`trajdb params`) for one run: the values of the JSON object \
                  `values` ({\"merge_eta\": 0.6}, numbers, booleans or text; \"auto\" where the parameter is measured), every other parameter \
                  back to its default, so that nothing leaks from an earlier run. An unknown name, a value of the wrong type or outside the \
                  parameter's range is an error that names it. Runners execute the returned script before sql/pipeline.sql.",
    example: "SELECT trajdb_params_sql('{\"merge_eta\": 0.6}') LIKE '%SET VARIABLE merge_eta = 0.6::DOUBLE;%'; -- true",
    maths: "src/app/params.rs",
    binding: file!(),
    signatures: &[Signature { params: &[p("values", Ty::Varchar)], arities: &[], returns: Ty::Varchar, kernel: params_sql }],
    table: None,
};

fn params_sql(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
    let json = a.text(0);
    let vals = a.map(|r| {
        let Some(text) = json.get(r) else { return Ok(None) };
        let obj: serde_json::Map<String, serde_json::Value> = serde_json::from_str(if text.trim().is_empty() { "{}" } else { &text })
            .map_err(|e| format!("values must be a JSON object of parameter names and values, e.g. '{{\"merge_eta\": 0.6}}' ({e})"))?;
        let mut overrides = Vec::with_capacity(obj.len());
        for (k, v) in obj {
            let text = match v {
                serde_json::Value::String(s) => s,
                serde_json::Value::Number(n) => n.to_string(),
                serde_json::Value::Bool(b) => b.to_string(),
                other => return Err(format!("parameter {k} must be a number, a boolean or text, got {other}").into()),
            };
            overrides.push((k, text));
        }
        Ok(Some(params::set_sql(&params::resolve(&overrides)?)))
    })?;
    out.text(&vals);
    Ok(())
}

const RESULTS_BEGIN: Function = Function {
    name: "trajdb_results_begin",
    description: "Claims the results folder `out` for one pipeline run and returns the staging folder to write the result files into \
                  (inside `out`). Refused before any work: '' or NULL, '/', a file, a folder holding files that trajdb did not write, a \
                  folder that is or contains `input`, a folder another run is writing into. A new folder is created with normal \
                  permissions. End the run with trajdb_results_end.",
    example: "SELECT trajdb_results_end(trajdb_results_begin('/tmp/trajdb-example-results', 'points.parquet'), false); -- ",
    maths: "src/app/outdir.rs",
    binding: file!(),
    signatures: &[Signature { params: &[p("out", Ty::Varchar), p("input", Ty::Varchar)], arities: &[], returns: Ty::Varchar, kernel: results_begin }],
    table: None,
};

fn results_begin(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
    let (dir, input) = (a.text(0), a.text(1));
    let vals = a.map(|r| {
        let d = dir.get(r).ok_or("out is NULL: name a results folder")?;
        sandbox_check(&d)?;
        let i = input.get(r).unwrap_or_default();
        Ok(Some(outdir::open::begin(&d, &[&i])?.to_string_lossy().into_owned()))
    })?;
    out.text(&vals);
    Ok(())
}

const RESULTS_END: Function = Function {
    name: "trajdb_results_end",
    description: "Ends a run that trajdb_results_begin started. With commit true, the files in the staging folder replace the earlier \
                  results (file by file; earlier result files this run did not write are removed, files that trajdb did not write are \
                  never touched) and their names are returned, comma-separated; with false the staging folder is removed and the \
                  earlier results stay as they were.",
    example: "SELECT trajdb_results_end(trajdb_results_begin('/tmp/trajdb-example-results', 'points.parquet'), true); -- ",
    maths: "src/app/outdir.rs",
    binding: file!(),
    signatures: &[Signature { params: &[p("staging", Ty::Varchar), p("commit", Ty::Boolean)], arities: &[], returns: Ty::Varchar, kernel: results_end }],
    table: None,
};

fn results_end(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
    let (staging, commit) = (a.text(0), a.opt_boolean(1));
    let vals = a.map(|r| {
        let s = staging.get(r).ok_or("staging is NULL")?;
        let c = commit.or(r, false).ok_or("commit is NULL: true or false")?;
        Ok(Some(outdir::open::end(&s, c)?.join(",")))
    })?;
    out.text(&vals);
    Ok(())
}

/// The file-system rule of every function of ours that writes: DuckDB's enable_external_access.
// TODO(h3's sandbox module): replace by the shared check once it lands.
fn sandbox_check(_path: &str) -> Result<(), Box<dyn Error>> {
    Ok(())
}
