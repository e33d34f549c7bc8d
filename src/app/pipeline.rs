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

#[cfg(test)]
mod tests {
    use super::*;

    /// The clean stage, with its `auto` thresholds measured by the calibrate stage (period
    /// 0.1 s here): keeps a 2 Hz track of 3 points (1 s of a real road user) and a 10 Hz track
    /// of 4 points (0.3 s), drops a single point and an estimated-only track.
    #[test]
    fn clean_drops_short_tracks_by_points_and_duration() {
        let con = crate::open(None).unwrap();
        set_params(&con, &[]).unwrap();
        con.execute_batch(
            "CREATE TEMP TABLE points AS
             SELECT 1 AS camera, track_id, 'pedestrian' AS class, k * dt AS t, k::DOUBLE AS x, 0.0 AS y, est AS estimated
             FROM (VALUES (1, 0.5, 3, 0), (2, 0.1, 4, 0), (3, 0.1, 1, 0), (4, 0.1, 8, 1), (5, 0.1, 5, 0)) v(track_id, dt, n, est),
                  range(10) r(k) WHERE k < n;",
        )
        .unwrap();
        con.execute_batch(sql::file("sql/stages/calibrate.sql").unwrap()).unwrap();
        con.execute_batch(sql::file("sql/stages/clean.sql").unwrap()).unwrap();
        let kept: Vec<i64> = con.prepare("SELECT DISTINCT track_id FROM points ORDER BY 1").unwrap().query_map([], |r| r.get(0)).unwrap().collect::<Result<_, _>>().unwrap();
        assert_eq!(kept, vec![1, 2, 5]);
        let reasons: Vec<String> = con.prepare("SELECT reason FROM clean_dropped ORDER BY track_id").unwrap().query_map([], |r| r.get(0)).unwrap().collect::<Result<_, _>>().unwrap();
        assert_eq!(reasons, vec!["too short", "estimated only"]);
        // a given value wins over the measured one: 5 points needed, 0.35 s
        set_params(&con, &[("clean_min_points".into(), "5".into()), ("clean_min_duration_s".into(), "0.35".into())]).unwrap();
        con.execute_batch(sql::file("sql/stages/calibrate.sql").unwrap()).unwrap();
        con.execute_batch(sql::file("sql/stages/clean.sql").unwrap()).unwrap();
        let kept: Vec<i64> = con.prepare("SELECT DISTINCT track_id FROM points ORDER BY 1").unwrap().query_map([], |r| r.get(0)).unwrap().collect::<Result<_, _>>().unwrap();
        assert_eq!(kept, vec![1, 5]);
    }
}
