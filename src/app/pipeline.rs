//! `trajdb pipeline`: one stage runner over `sql/pipeline.sql` (parameters, load, and the stage
//! list of `sql/stages.sql`), then the result files (`sql/export.sql`) and `report.html`.
//!
//! Parameters come from the one declared table in [`super::params`]: every value (default or
//! `--param name=value`, checked against its type) is set with `SET VARIABLE` before the SQL
//! runs, and `sql/params.sql` keeps values that are already set.

use super::{params, report, sql};
use duckdb::Connection;
use std::error::Error;
use std::path::Path;
use std::time::Instant;

/// Sets the parameters (defaults and `overrides`) and records them in `pipeline_params`.
pub fn set_params(con: &Connection, overrides: &[(String, String)]) -> Result<(), Box<dyn Error>> {
    con.execute_batch(&params::set_sql(&params::resolve(overrides)?))?;
    Ok(())
}

/// Runs the embedded SQL file `path` (its `.read` includes expanded), printing the time of each
/// stage on stderr; returns `(part, seconds)` in order.
pub fn run_sql_file(con: &Connection, path: &str) -> Result<Vec<(String, f64)>, Box<dyn Error>> {
    let mut timings = Vec::new();
    for (name, text) in sql::parts(path)? {
        let t = Instant::now();
        con.execute_batch(&text)?;
        let s = t.elapsed().as_secs_f64();
        if name == "setup" && con.prepare("SELECT 1 FROM duckdb_tables() WHERE table_name = 'points'")?.exists([])? {
            let n: i64 = con.query_row("SELECT count(*) FROM points", [], |r| r.get(0))?;
            eprintln!("[trajdb] load     {s:>7.2} s  {n} points");
            timings.push(("load".to_string(), s));
        } else {
            eprintln!("[trajdb] {name:<8} {s:>7.2} s");
            timings.push((name, s));
        }
    }
    Ok(timings)
}

/// Runs the pipeline on `input` (Parquet or CSV with camera, track_id, class, t, x, y,
/// estimated) and writes the result files into `out`. Progress goes to stderr.
pub fn run(con: &Connection, input: &str, out: &Path, overrides: &[(String, String)]) -> Result<(), Box<dyn Error>> {
    set_params(con, overrides)?;
    std::fs::create_dir_all(out)?;
    let t_all = Instant::now();
    con.execute_batch(&format!("SET VARIABLE pipeline_input = {};", sql::sql_string(input)))?;
    let mut timings = run_sql_file(con, "sql/pipeline.sql")?;
    let t = Instant::now();
    con.execute_batch(&format!("SET VARIABLE out_dir = {};", sql::sql_string(&out.to_string_lossy())))?;
    con.execute_batch(sql::file("sql/export.sql").expect("sql/export.sql"))?;
    eprintln!("[trajdb] write    {:>7.2} s  -> {}", t.elapsed().as_secs_f64(), out.display());
    timings.push(("write".into(), t.elapsed().as_secs_f64()));
    let t = Instant::now();
    report::write(con, out, input, &timings)?;
    eprintln!("[trajdb] report   {:>7.2} s  -> {}", t.elapsed().as_secs_f64(), out.join("report.html").display());
    eprintln!("[trajdb] total    {:>7.2} s", t_all.elapsed().as_secs_f64());
    Ok(())
}
