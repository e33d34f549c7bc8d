//! `trajdb pipeline`: one stage runner over `sql/pipeline.sql` (parameters, load, and the stage
//! list of `sql/stages.sql`), then the result files (`sql/export.sql`) and `report.html`.
//!
//! Parameters come from the one declared table in [`super::params`]: every value (default or
//! `--param name=value`, checked against its type) is set with `SET VARIABLE` before the SQL
//! runs, and `sql/params.sql` keeps values that are already set.

use super::{params, sql};
use duckdb::Connection;
use std::error::Error;
use std::io::IsTerminal;
use std::path::Path;
use std::time::Instant;

/// Sets the parameters (defaults and `overrides`); sql/params.sql records them in `pipeline_params`.
pub fn set_params(con: &Connection, overrides: &[(String, String)]) -> Result<(), Box<dyn Error>> {
    con.execute_batch(&params::set_sql(&params::resolve(overrides)?))?;
    Ok(())
}

/// Runs the embedded SQL file `path` (its `.read` includes expanded), printing the time of each
/// stage on stderr; returns `(part, seconds)` in order.
pub fn run_sql_file(con: &Connection, path: &str) -> Result<Vec<(String, f64)>, Box<dyn Error>> {
    let mut timings = Vec::new();
    for (name, text) in sql::parts(path)? {
        let label = if name == "setup" { "load" } else { name.as_str() };
        eprint!("[trajdb] {label:<8} ");
        let t = Instant::now();
        // statement by statement: progress within a long stage (on a terminal), and an error
        // that says which statement failed
        let statements = sql::split_statements(&text);
        let tty = std::io::stderr().is_terminal();
        for (k, stmt) in statements.iter().enumerate() {
            if tty {
                eprint!("\r[trajdb] {label:<8} statement {}/{}", k + 1, statements.len());
            }
            con.execute_batch(stmt).map_err(|e| {
                let head: String = stmt.split_whitespace().collect::<Vec<_>>().join(" ").chars().take(90).collect();
                stage_error(label, &format!("{e}\n  in statement {} of {}: {head} ...", k + 1, statements.len()))
            })?;
        }
        if tty {
            eprint!("\r[trajdb] {label:<8} {:<20}\r[trajdb] {label:<8} ", "");
        }
        let s = t.elapsed().as_secs_f64();
        if name == "setup" && con.prepare("SELECT 1 FROM duckdb_tables() WHERE table_name = 'points'")?.exists([])? {
            let n: i64 = con.query_row("SELECT count(*) FROM points", [], |r| r.get(0))?;
            eprintln!("{s:>7.2} s  {n} points");
            timings.push(("load".to_string(), s));
        } else {
            eprintln!("{s:>7.2} s");
            timings.push((name, s));
        }
    }
    Ok(timings)
}

/// A stage's error, naming the stage, its file and, where one is known, the fix.
fn stage_error(stage: &str, err: &str) -> Box<dyn Error> {
    eprintln!("failed");
    let file = match stage {
        "load" => "sql/pipeline.sql".to_string(),
        "export" | "report" => format!("sql/{stage}.sql"),
        _ => format!("sql/stages/{stage}.sql"),
    };
    let fix = if stage == "load" {
        "\nfix: the input needs the columns camera, track_id, class, t, x, y (t in seconds or a TIMESTAMP; estimated \
         optional). Map your own names with --param \"input_columns=camera=cam_id, t=time\" (in SQL: SET VARIABLE \
         input_columns = 'camera=cam_id, t=time')."
    } else if err.contains("INTERVAL") || err.contains("TIMESTAMP") {
        "\nfix: t must be seconds (a number) or a TIMESTAMP; load the input through sql/pipeline.sql, which converts it."
    } else {
        ""
    };
    format!("pipeline stage '{stage}' ({file}) failed: {err}{fix}").into()
}

/// report.html in `out_dir`: the stage times go to `pipeline_timings`, then `sql/report.sql`
/// gathers the data and `trajdb_report_html()` draws it (the same SQL as in stock DuckDB).
fn write_report(con: &Connection, timings: &[(String, f64)]) -> Result<(), Box<dyn Error>> {
    con.execute_batch("CREATE OR REPLACE TEMP TABLE pipeline_timings (stage VARCHAR, seconds DOUBLE)")?;
    {
        let mut st = con.prepare("INSERT INTO pipeline_timings VALUES (?, ?)")?;
        for (stage, s) in timings {
            st.execute(duckdb::params![stage, s])?;
        }
    }
    con.execute_batch(sql::file("sql/report.sql").expect("sql/report.sql")).map_err(|e| stage_error("report", &e.to_string()))?;
    Ok(())
}

/// Runs the pipeline on `input` (Parquet or CSV with camera, track_id, class, t, x, y,
/// estimated) and writes the result files into `out`. Progress goes to stderr.
pub fn run(con: &Connection, input: &str, out: &Path, overrides: &[(String, String)]) -> Result<(), Box<dyn Error>> {
    set_params(con, overrides)?;
    let t_all = Instant::now();
    con.execute_batch(&format!("SET VARIABLE pipeline_input = {};", sql::sql_string(input)))?;
    // the results folder is checked (and claimed) before any work: a folder with the user's
    // own files, '', '/', or the input's folder is refused here (src/app/outdir.rs)
    let claim = super::outdir::claim(&out.to_string_lossy(), &[input])?;
    let mut timings = run_sql_file(con, "sql/pipeline.sql")?;
    // The result files go to the claim's staging folder first and replace the earlier results
    // file by file only when all are written: a failed run leaves no half-written output, and
    // the earlier results in `out` stay as they were (outdir.rs).
    let partial = claim.partial.clone();
    let written = (|| -> Result<(), Box<dyn Error>> {
        let t = Instant::now();
        con.execute_batch(&format!("SET VARIABLE out_dir = {};", sql::sql_string(&partial.to_string_lossy())))?;
        con.execute_batch(&sql::expand_reads(sql::file("sql/export.sql").expect("sql/export.sql"))?).map_err(|e| stage_error("export", &e.to_string()))?;
        eprintln!("[trajdb] write    {:>7.2} s  -> {}", t.elapsed().as_secs_f64(), out.display());
        timings.push(("write".into(), t.elapsed().as_secs_f64()));
        let t = Instant::now();
        write_report(con, &timings)?;
        eprintln!("[trajdb] report   {:>7.2} s  -> {}", t.elapsed().as_secs_f64(), out.join("report.html").display());
        Ok(())
    })();
    if let Err(e) = written {
        claim.abort();
        return Err(e);
    }
    claim.commit()?;
    eprintln!("[trajdb] total    {:>7.2} s", t_all.elapsed().as_secs_f64());
    summary(con, out)?;
    Ok(())
}

/// What was found, in a few lines (stderr): road users per class, cross-camera links,
/// within-camera links, the cameras aligned and their worst residual.
fn summary(con: &Connection, out: &Path) -> Result<(), Box<dyn Error>> {
    let (users, multi, cams, aligned): (i64, i64, i64, i64) = con.query_row(
        "SELECT (SELECT count(*) FROM merged), (SELECT count(*) FROM merged WHERE n_tracks > 1),
                (SELECT count(DISTINCT camera) FROM points), (SELECT count(*) FROM align_frames)",
        [],
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
    )?;
    let per_class: String = con.query_row(
        "SELECT coalesce(string_agg(class || ' ' || n, ', ' ORDER BY n DESC, class), '') FROM (SELECT class, count(*) AS n FROM merged GROUP BY class)",
        [],
        |r| r.get(0),
    )?;
    let (links, chains): (i64, i64) = con.query_row(
        "SELECT (SELECT count(*) FROM merge_links m JOIN merge_groups a ON a.uid = m.uid_a JOIN merge_groups b ON b.uid = m.uid_b
                 WHERE a.road_user = b.road_user AND m.kind <> 'reach'),
                (SELECT count(*) FROM merge_chains WHERE track_id <> linked_id)",
        [],
        |r| Ok((r.get(0)?, r.get(1)?)),
    )?;
    eprintln!("[trajdb] found    {users} road users ({per_class}); {multi} seen by more than one track");
    eprintln!("[trajdb]          {aligned} of {cams} cameras in one frame; {links} cross-camera links; {chains} tracks joined to an earlier piece in their camera");
    eprintln!("[trajdb]          results in {}, open {} for the report", out.display(), out.join("report.html").display());
    for w in warnings(con)? {
        eprintln!("[trajdb] warning: {w}");
    }
    Ok(())
}

/// What a finished run should tell its user: the rows of sql/warnings.sql's pipeline_warnings
/// (the same table every runner reads).
pub fn warnings(con: &Connection) -> Result<Vec<String>, Box<dyn Error>> {
    con.execute_batch(sql::file("sql/warnings.sql").expect("sql/warnings.sql"))?;
    let rows = con.prepare("SELECT message FROM pipeline_warnings ORDER BY k")?.query_map([], |r| r.get(0))?.collect::<Result<_, _>>()?;
    Ok(rows)
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

    /// The quality stage's second pass: a car braking at 3 m/s^2 through a 1.5 s gap resumes
    /// 3.4 m short of its constant-velocity prediction, out of pass 1's 2 m but inside
    /// 2 + 3 * 1.5^2 / 2 m; a pair pass 1 linked stays linked and is not offered again. With
    /// quality_max_accel = 0 the second pass adds nothing.
    #[test]
    fn quality_second_pass_links_a_braking_car() {
        let points = "CREATE OR REPLACE TEMP TABLE points AS
             SELECT 1 AS camera, track_id, 'car' AS class, t, x, y, 0 AS estimated FROM (
               -- the view: a long drive around a 200 x 100 m rectangle (its ends on the hull)
               SELECT 9 AS track_id, k * 0.1 AS t,
                      CASE WHEN k < 200 THEN -50 + k ELSE 150 END AS x,
                      CASE WHEN k < 200 THEN -50 ELSE -50 + (k - 200) END AS y FROM range(300) r(k)
               UNION ALL SELECT 1, k * 0.1, 10 * k * 0.1, 0 FROM range(51) r(k)                 -- ends at 50 m, 10 m/s, t 5
               UNION ALL SELECT 2, 6.5 + k * 0.1, 61.625 + 5.5 * k * 0.1, 0 FROM range(31) r(k) -- braked: 3.4 m short
               UNION ALL SELECT 3, k * 0.1, 10 * k * 0.1, 20 FROM range(51) r(k)                -- a break at constant speed
               UNION ALL SELECT 4, 6.0 + k * 0.1, 60 + 10 * k * 0.1, 20 FROM range(31) r(k))";
        let run = |accel: &str| -> (Vec<(i64, i64)>, Vec<(i64, i64)>) {
            let con = crate::open(None).unwrap();
            set_params(&con, &[("quality_max_accel".into(), accel.into())]).unwrap();
            con.execute_batch(points).unwrap();
            for f in ["calibrate", "clean", "quality"] {
                con.execute_batch(sql::file(&format!("sql/stages/{f}.sql")).unwrap()).unwrap();
            }
            let pairs = |q: &str| -> Vec<(i64, i64)> {
                con.prepare(q).unwrap().query_map([], |r| Ok((r.get(0)?, r.get(1)?))).unwrap().collect::<Result<_, _>>().unwrap()
            };
            (
                pairs("SELECT track_id, linked_id FROM quality_links WHERE track_id <> linked_id ORDER BY 1"),
                pairs("SELECT from_id, to_id FROM quality_reach_links ORDER BY 1"),
            )
        };
        let (links, reach) = run("3.0");
        assert_eq!(links, vec![(4, 3)]);
        assert_eq!(reach, vec![(1, 2)]);
        let (links, reach) = run("0.0");
        assert_eq!(links, vec![(4, 3)]);
        assert!(reach.is_empty());
    }
}
