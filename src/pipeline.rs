//! The whole pipeline as SQL stages, run embedded (`trajdb pipeline`): load → clean → quality
//! (broken tracks linked) → align → overlap → merge → cluster, then the result files; and the
//! scorer (`trajdb score`) that compares those files with a scenario's ground truth.
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

/// GeoParquet 1.1 file metadata of merged.parquet: `geometry` is WKB (LINESTRING, or POINT for a
/// one-point road user) in the reference camera's local metric frame, which has no CRS
/// (`"crs": null` is GeoParquet's "undefined"; QGIS and GDAL open it as a plain XY layer).
pub const GEOPARQUET_META: &str = r#"{"version":"1.1.0","primary_column":"geometry","columns":{"geometry":{"encoding":"WKB","geometry_types":["LineString","Point"],"crs":null,"edges":"planar"}}}"#;

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

/// A SQL string literal (single quotes doubled).
pub fn sql_string(s: &str) -> String {
    format!("'{}'", s.replace('\'', "''"))
}

/// Runs the pipeline on `input` (Parquet or CSV with camera, track_id, class, t, x, y,
/// estimated) and writes the result files into `out`. Progress goes to stderr.
pub fn run(con: &Connection, input: &str, out: &Path, params: &[(String, String)]) -> Result<(), Box<dyn Error>> {
    let mut timings: Vec<(String, f64)> = Vec::new();
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
    timings.push(("load".into(), t.elapsed().as_secs_f64()));
    for (name, sql) in &stages {
        let t = Instant::now();
        con.execute_batch(sql)?;
        if *name == "quality" {
            con.execute_batch("CREATE OR REPLACE TEMP TABLE points AS SELECT * FROM points_linked")?;
        }
        eprintln!("[trajdb] {name:<8} {:>7.2} s", t.elapsed().as_secs_f64());
        timings.push((name.to_string(), t.elapsed().as_secs_f64()));
    }
    let t = Instant::now();
    let path = |f: &str| sql_string(&out.join(f).to_string_lossy());
    con.execute_batch(&format!(
        "COPY (SELECT a.camera AS cam_from, b.camera AS cam_to, tf.theta AS theta_rad, tf.tx, tf.ty
               FROM align_frames a, align_frames b,
                    LATERAL (SELECT transform_compose(transform_invert(b.to_reference), a.to_reference) AS tf)
               WHERE a.camera <> b.camera ORDER BY cam_from, cam_to) TO {} (HEADER, DELIMITER ',');
         COPY (SELECT ta.camera AS camera_a, ta.track_id AS track_a,
                      tb.camera AS camera_b, tb.track_id AS track_b, m.eta AS score, m.kind
               FROM merge_links m
               JOIN merge_tracks ta ON ta.uid = m.uid_a JOIN merge_tracks tb ON tb.uid = m.uid_b
               -- only the links merge_groups() kept (a refused link contradicts its road user)
               JOIN merge_groups ga ON ga.uid = m.uid_a JOIN merge_groups gb ON gb.uid = m.uid_b
               WHERE ga.road_user = gb.road_user
               ORDER BY camera_a, track_a, camera_b, track_b) TO {} (HEADER, DELIMITER ',');
         COPY (SELECT road_user, class, n_tracks, sources, traj_to_wkb(traj) AS geometry, traj
               FROM merged ORDER BY road_user) TO {} (FORMAT parquet, KV_METADATA {{geo: {}}});
         COPY (SELECT getvariable('cluster_camera') AS camera, class, track_id, cluster FROM cluster_assign
               ORDER BY class, cluster, track_id) TO {} (HEADER, DELIMITER ',');
         COPY (SELECT camera, track_id, linked_id FROM quality_links ORDER BY camera, track_id) TO {} (HEADER, DELIMITER ',');",
        path("transforms.csv"),
        path("matches.csv"),
        path("merged.parquet"),
        sql_string(GEOPARQUET_META),
        path("clusters.csv"),
        path("links.csv"),
    ))?;
    eprintln!("[trajdb] write    {:>7.2} s  -> {}", t.elapsed().as_secs_f64(), out.display());
    timings.push(("write".into(), t.elapsed().as_secs_f64()));
    let t = Instant::now();
    crate::report::write(con, out, input, &timings)?;
    eprintln!("[trajdb] report   {:>7.2} s  -> {}", t.elapsed().as_secs_f64(), out.join("report.html").display());
    eprintln!("[trajdb] total    {:>7.2} s", t_all.elapsed().as_secs_f64());
    Ok(())
}

/// Scores a pipeline output directory `results` against the ground truth of `scenario`
/// (points.parquet, cameras.csv, truth.csv in the format of the shared DUT scenarios):
/// rotation / translation error per camera pair, and match precision / recall / F1 overall and
/// per class. A true pair is the same object seen by two cameras at the same time for at least
/// `min_overlap_s` seconds, with at least 3 points of each track inside the true overlap of the
/// two views. Prints the tables; returns (worst rotation error in degrees, worst translation
/// error in metres, overall F1).
pub fn score(con: &Connection, scenario: &Path, results: &Path) -> Result<(f64, f64, f64), Box<dyn Error>> {
    let f = |d: &Path, n: &str| sql_string(&d.join(n).to_string_lossy());
    con.execute_batch(&format!(
        "CREATE OR REPLACE TEMP TABLE s_points AS SELECT * FROM read_parquet({pts});
         CREATE OR REPLACE TEMP TABLE s_cameras AS SELECT * FROM read_csv({cams});
         CREATE OR REPLACE TEMP TABLE s_truth AS SELECT * FROM read_csv({truth});
         CREATE OR REPLACE TEMP TABLE s_tf AS SELECT * FROM read_csv({tf});
         CREATE OR REPLACE TEMP TABLE s_matches AS SELECT * FROM read_csv({matches});
         CREATE OR REPLACE TEMP TABLE s_links AS SELECT * FROM read_csv({links});
         -- true local -> world transforms: world = R(theta) p + t
         CREATE OR REPLACE TEMP TABLE s_true AS
         SELECT camera, {{'theta': theta_rad, 'tx': tx, 'ty': ty, 'scale': 1.0}} AS tf, view_wkt_world FROM s_cameras;
         CREATE OR REPLACE TEMP TABLE s_pair_err AS
         WITH c AS (SELECT camera, avg(x) AS mx, avg(y) AS my FROM s_points GROUP BY camera)
         SELECT e.cam_from, e.cam_to,
                abs(((degrees(e.theta_rad - tt.theta) + 540) % 360) - 180) AS rot_deg,
                sqrt((cos(e.theta_rad) * c.mx - sin(e.theta_rad) * c.my + e.tx
                      - (cos(tt.theta) * c.mx - sin(tt.theta) * c.my + tt.tx)) ** 2
                   + (sin(e.theta_rad) * c.mx + cos(e.theta_rad) * c.my + e.ty
                      - (sin(tt.theta) * c.mx + cos(tt.theta) * c.my + tt.ty)) ** 2) AS trans_m
         FROM s_tf e
         JOIN s_true a ON a.camera = e.cam_from JOIN s_true b ON b.camera = e.cam_to
         JOIN c ON c.camera = e.cam_from,
         LATERAL (SELECT transform_compose(transform_invert(b.tf), a.tf) AS tt);
         -- world positions of the real points, with the object of each track
         CREATE OR REPLACE TEMP TABLE s_world AS
         SELECT p.camera, p.track_id, p.class, p.t, tr.object_id,
                cos(c.tf.theta) * p.x - sin(c.tf.theta) * p.y + c.tf.tx AS wx,
                sin(c.tf.theta) * p.x + cos(c.tf.theta) * p.y + c.tf.ty AS wy
         FROM s_points p JOIN s_true c USING (camera) JOIN s_truth tr USING (camera, track_id)
         WHERE p.estimated = 0 AND tr.is_noise = 0;
         CREATE OR REPLACE TEMP TABLE s_true_pairs AS
         WITH tracks AS (SELECT camera, track_id, any_value(class) AS class, any_value(object_id) AS object_id, min(t) AS t0, max(t) AS t1
                         FROM s_world GROUP BY camera, track_id),
              cand AS (SELECT a.camera AS ca, a.track_id AS ta, b.camera AS cb, b.track_id AS tb, a.class
                       FROM tracks a JOIN tracks b ON a.object_id = b.object_id AND a.camera < b.camera
                       WHERE least(a.t1, b.t1) - greatest(a.t0, b.t0) >= 1.0)
         SELECT cand.* FROM cand
         JOIN s_true va ON va.camera = cand.ca JOIN s_true vb ON vb.camera = cand.cb
         WHERE (SELECT count(*) FROM s_world w WHERE w.camera = cand.ca AND w.track_id = cand.ta
                  AND polygon_contains(va.view_wkt_world, w.wx, w.wy) AND polygon_contains(vb.view_wkt_world, w.wx, w.wy)) >= 3
           AND (SELECT count(*) FROM s_world w WHERE w.camera = cand.cb AND w.track_id = cand.tb
                  AND polygon_contains(va.view_wkt_world, w.wx, w.wy) AND polygon_contains(vb.view_wkt_world, w.wx, w.wy)) >= 3;
         -- predicted pairs are between linked tracks: expand them to the original tracks
         CREATE OR REPLACE TEMP TABLE s_pred AS
         SELECT DISTINCT la.camera AS ca, la.track_id AS ta, lb.camera AS cb, lb.track_id AS tb
         FROM s_matches m
         JOIN s_links la ON la.camera = m.camera_a AND la.linked_id = m.track_a
         JOIN s_links lb ON lb.camera = m.camera_b AND lb.linked_id = m.track_b;
         CREATE OR REPLACE TEMP TABLE s_obj AS SELECT camera, track_id, object_id, is_noise FROM s_truth;",
        pts = f(scenario, "points.parquet"),
        cams = f(scenario, "cameras.csv"),
        truth = f(scenario, "truth.csv"),
        tf = f(results, "transforms.csv"),
        matches = f(results, "matches.csv"),
        links = f(results, "links.csv"),
    ))?;
    let (rot, trans): (f64, f64) = con.query_row("SELECT max(rot_deg), max(trans_m) FROM s_pair_err WHERE cam_from < cam_to", [], |r| Ok((r.get(0)?, r.get(1)?)))?;
    // Precision: predicted pairs whose two tracks are one object; recall: true pairs found.
    let mut rows = con.prepare(
        "WITH p AS (SELECT s.*, oa.object_id = ob.object_id AND oa.is_noise = 0 AS correct,
                           (SELECT any_value(class) FROM s_points q WHERE q.camera = s.ca AND q.track_id = s.ta) AS class
                    FROM s_pred s JOIN s_obj oa ON oa.camera = s.ca AND oa.track_id = s.ta
                    JOIN s_obj ob ON ob.camera = s.cb AND ob.track_id = s.tb),
              t AS (SELECT tp.*, EXISTS (SELECT 1 FROM s_pred s WHERE s.ca = tp.ca AND s.ta = tp.ta AND s.cb = tp.cb AND s.tb = tp.tb) AS found
                    FROM s_true_pairs tp),
              cls AS (SELECT DISTINCT class FROM s_true_pairs UNION SELECT '*')
         SELECT cls.class,
                (SELECT count(*) FILTER (WHERE correct)::DOUBLE / greatest(count(*), 1) FROM p WHERE cls.class = '*' OR p.class = cls.class),
                (SELECT count(*) FILTER (WHERE found)::DOUBLE / greatest(count(*), 1) FROM t WHERE cls.class = '*' OR t.class = cls.class),
                (SELECT count(*) FROM t WHERE cls.class = '*' OR t.class = cls.class),
                (SELECT count(*) FROM p WHERE cls.class = '*' OR p.class = cls.class)
         FROM cls ORDER BY cls.class = '*', cls.class",
    )?;
    println!("camera pairs: worst rotation error {rot:.3} deg, worst translation error {trans:.3} m");
    let mut pe = con.prepare("SELECT cam_from, cam_to, rot_deg, trans_m FROM s_pair_err WHERE cam_from < cam_to ORDER BY 1, 2")?;
    let mut q = pe.query([])?;
    while let Some(r) = q.next()? {
        let (a, b, rd, tm): (i64, i64, f64, f64) = (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?);
        println!("  {a} -> {b}: rotation {rd:.3} deg, translation {tm:.3} m");
    }
    println!("matches (a true pair: same object, >= 1 s together, >= 3 points each in the true overlap):");
    println!("  {:<14} {:>9} {:>7} {:>6} {:>10} {:>10}", "class", "precision", "recall", "F1", "true pairs", "predicted");
    let mut all_f1 = 0.0;
    let mut q = rows.query([])?;
    while let Some(r) = q.next()? {
        let (c, p, rc, nt, np): (String, f64, f64, i64, i64) = (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?);
        let f1 = if p + rc > 0.0 { 2.0 * p * rc / (p + rc) } else { 0.0 };
        if c == "*" {
            all_f1 = f1;
        }
        println!("  {:<14} {p:>9.3} {rc:>7.3} {f1:>6.3} {nt:>10} {np:>10}", if c == "*" { "all" } else { &c });
    }
    Ok((rot, trans, all_f1))
}
