//! The whole pipeline as SQL stages, run embedded (`trajdb pipeline`): load → clean → quality
//! (broken tracks linked) → align → overlap → merge → cluster, then the result files.
//!
//! Every parameter is a `SET VARIABLE name = value;` at the top of its stage file in `sql/`;
//! `--param name=value` replaces that default (an unknown name is an error).

use duckdb::Connection;
use std::error::Error;
use std::path::Path;
use std::time::Instant;

/// The stages, in order: (name, SQL).
pub const STAGES: &[(&str, &str)] = &[
    ("clean", include_str!("../sql/clean.sql")),
    ("quality", include_str!("../sql/quality.sql")),
    ("align", include_str!("../sql/align.sql")),
    ("overlap", include_str!("../sql/overlap.sql")),
    ("merge", include_str!("../sql/merge.sql")),
    ("cluster", include_str!("../sql/cluster.sql")),
];

/// Replaces the default of every `(name, value)` in the stage files; errors on unknown names.
pub fn with_params(params: &[(String, String)]) -> Result<Vec<(&'static str, String)>, Box<dyn Error>> {
    let mut stages: Vec<(&'static str, String)> = STAGES.iter().map(|(n, s)| (*n, s.to_string())).collect();
    for (name, value) in params {
        let key = format!("SET VARIABLE {name} = ");
        let mut found = false;
        for (_, sql) in stages.iter_mut() {
            if let Some(start) = sql.find(&key) {
                let end = start + sql[start..].find(';').ok_or("malformed SET VARIABLE")?;
                sql.replace_range(start..end, &format!("{key}{value}"));
                found = true;
            }
        }
        if !found {
            let known: Vec<String> = STAGES
                .iter()
                .flat_map(|(_, s)| s.lines().filter_map(|l| l.strip_prefix("SET VARIABLE ")).map(|l| l.split(' ').next().unwrap_or("").to_string()))
                .collect();
            return Err(format!("pipeline: unknown parameter {name:?}; known: {}", known.join(", ")).into());
        }
    }
    Ok(stages)
}

fn sql_string(s: &str) -> String {
    format!("'{}'", s.replace('\'', "''"))
}

/// Runs the pipeline on `input` (Parquet or CSV with camera, track_id, class, t, x, y,
/// estimated) and writes the result files into `out`. Progress goes to stderr.
pub fn run(con: &Connection, input: &str, out: &Path, params: &[(String, String)]) -> Result<(), Box<dyn Error>> {
    let stages = with_params(params)?;
    std::fs::create_dir_all(out)?;
    let t_all = Instant::now();
    let reader = if input.to_ascii_lowercase().ends_with(".csv") { "read_csv_auto" } else { "read_parquet" };
    let t = Instant::now();
    con.execute_batch(&format!(
        "CREATE OR REPLACE TEMP TABLE points AS SELECT camera, track_id, class, t, x, y, estimated FROM {reader}({})",
        sql_string(input)
    ))?;
    let n: i64 = con.query_row("SELECT count(*) FROM points", [], |r| r.get(0))?;
    eprintln!("[trajdb] load     {:>7.2} s  {n} points", t.elapsed().as_secs_f64());
    for (name, sql) in &stages {
        let t = Instant::now();
        con.execute_batch(sql)?;
        if *name == "quality" {
            con.execute_batch("CREATE OR REPLACE TEMP TABLE points AS SELECT * FROM points_linked")?;
        }
        eprintln!("[trajdb] {name:<8} {:>7.2} s", t.elapsed().as_secs_f64());
    }
    let t = Instant::now();
    let path = |f: &str| sql_string(&out.join(f).to_string_lossy());
    con.execute_batch(&format!(
        "COPY (SELECT a.camera AS cam_from, b.camera AS cam_to, tf.theta AS theta_rad, tf.tx, tf.ty
               FROM align_frames a, align_frames b,
                    LATERAL (SELECT transform_compose(transform_invert(b.to_reference), a.to_reference) AS tf)
               WHERE a.camera <> b.camera ORDER BY cam_from, cam_to) TO {} (HEADER, DELIMITER ',');
         COPY (SELECT m.uid_a // 1000000000 AS camera_a, m.uid_a % 1000000000 AS track_a,
                      m.uid_b // 1000000000 AS camera_b, m.uid_b % 1000000000 AS track_b, m.eta AS score, m.kind
               FROM merge_links m ORDER BY camera_a, track_a, camera_b, track_b) TO {} (HEADER, DELIMITER ',');
         COPY (SELECT road_user, class, n_tracks, sources, traj_to_wkt(traj) AS geometry_wkt, traj
               FROM merged ORDER BY road_user) TO {} (FORMAT parquet);
         COPY (SELECT getvariable('cluster_camera') AS camera, class, track_id, cluster FROM cluster_assign
               ORDER BY class, cluster, track_id) TO {} (HEADER, DELIMITER ',');",
        path("transforms.csv"),
        path("matches.csv"),
        path("merged.parquet"),
        path("clusters.csv"),
    ))?;
    eprintln!("[trajdb] write    {:>7.2} s  -> {}", t.elapsed().as_secs_f64(), out.display());
    eprintln!("[trajdb] total    {:>7.2} s", t_all.elapsed().as_secs_f64());
    Ok(())
}
