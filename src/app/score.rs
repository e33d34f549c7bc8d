//! `trajdb score`: a pipeline output directory against a scenario's ground truth. The SQL is
//! `sql/score.sql`; this prints its tables.

use super::sql;
use duckdb::Connection;
use std::error::Error;
use std::path::Path;

/// Prints the road-user identity table (IDF1, exactly reconstructed objects, within-camera
/// links, HOTA with its DetA and AssA; docs/scoring.md). New columns go at the end of the row:
/// benches/identity_grid.sh and tests/cli.rs read the first ones by position.
fn identity(con: &Connection) -> Result<(), Box<dyn Error>> {
    crate::outln!("road users (from merged.parquet; IDF1 and HOTA over real points, exact = all of an object's real tracks and nothing else in one road user):");
    crate::outln!(
        "  {:<14} {:>6} {:>7} {:>8} {:>11} {:>12} {:>11} {:>8} {:>6} {:>6} {:>6}",
        "class",
        "IDF1",
        "exact",
        "objects",
        "link prec.",
        "break recall",
        "true breaks",
        "links",
        "HOTA",
        "DetA",
        "AssA"
    );
    let mut st = con.prepare(
        "SELECT class, idf1, exact_share, objects, links_correct::DOUBLE / greatest(links, 1), breaks_found::DOUBLE / greatest(true_breaks, 1),
                true_breaks, links, coalesce(hota, 0), coalesce(deta, 0), coalesce(assa, 0) FROM s_identity ORDER BY class = '*', class",
    )?;
    let mut q = st.query([])?;
    while let Some(r) = q.next()? {
        let (c, idf1, exact, n, lp, br, nb, nl): (String, f64, Option<f64>, i64, f64, f64, i64, i64) =
            (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?, r.get(6)?, r.get(7)?);
        let (hota, deta, assa): (f64, f64, f64) = (r.get(8)?, r.get(9)?, r.get(10)?);
        let class = if c == "*" { "all" } else { c.as_str() };
        crate::outln!(
            "  {class:<14} {idf1:>6.3} {:>7.3} {n:>8} {lp:>11.3} {br:>12.3} {nb:>11} {nl:>8} {hota:>6.3} {deta:>6.3} {assa:>6.3}",
            exact.unwrap_or(0.0)
        );
    }
    Ok(())
}

/// Prints how far the merged trajectories lie from the true paths (world.csv), per class
/// (`sql/score_path.sql`).
fn paths(con: &Connection) -> Result<(), Box<dyn Error>> {
    con.execute_batch(sql::file("sql/score_path.sql").expect("sql/score_path.sql"))?;
    let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
    let name = |c: &str| if c == "*" { "all".to_string() } else { c.to_string() };
    crate::outln!("merged paths against world.csv (each road user's mapped object, at the same time):");
    crate::outln!("  {:<14} {:>9} {:>9} {:>9} {:>9} {:>18}", "class", "points", "median m", "p95 m", "max m", "road users > 1 m");
    let mut st = con.prepare("SELECT class, points, median_m, p95_m, max_m, off_1m FROM s_path_summary ORDER BY class = '*', class")?;
    let mut q = st.query([])?;
    while let Some(r) = q.next()? {
        let (c, n, med, p95, max, off): (String, i64, Option<f64>, Option<f64>, Option<f64>, i64) =
            (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?);
        crate::outln!("  {:<14} {n:>9} {:>9} {:>9} {:>9} {off:>18}", name(&c), f(med), f(p95), f(max));
    }
    crate::outln!("fused vs the best single camera (road users seen by >= 2 cameras; each camera mapped by the pipeline's transforms.csv,");
    crate::outln!("the best = lowest median error, over its time span; ratio = fused / best, target <= 0.6):");
    crate::outln!("  {:<14} {:>11} {:>12} {:>9} {:>11} {:>9} {:>13} {:>10}", "class", "road users", "fused med m", "p95 m", "best med m", "p95 m", "ratio median", "ratio p95");
    let mut st = con.prepare(
        "SELECT class, road_users, fused_median_m, fused_p95_m, best_median_m, best_p95_m FROM s_fuse_vs_best ORDER BY class = '*', class",
    )?;
    let mut q = st.query([])?;
    while let Some(r) = q.next()? {
        let (c, n, fm, fp, bm, bp): (String, i64, Option<f64>, Option<f64>, Option<f64>, Option<f64>) =
            (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?);
        let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) if b > 0.0 => format!("{:.2}", a / b),
            _ => "-".to_string(),
        };
        crate::outln!("  {:<14} {n:>11} {:>12} {:>9} {:>11} {:>9} {:>13} {:>10}", name(&c), f(fm), f(fp), f(bm), f(bp), ratio(fm, bm), ratio(fp, bp));
    }
    crate::outln!("fused path steps (jump: consecutive points whose errors differ by > 1 m; mean speed = length_m / duration_s against the");
    crate::outln!("true path's over the same time, road users seen >= 1 s, as over- (+) or understatement):");
    crate::outln!("  {:<14} {:>9} {:>10} {:>12} {:>14} {:>17} {:>14}", "class", "jumps>1m", "max jump m", "min step s", "max speed m/s", "mean speed median", "mean speed p95");
    let mut st = con.prepare(
        "SELECT class, jumps_1m, max_jump_m, min_step_s, max_speed, speed_over_median, speed_over_p95 FROM s_path_quality ORDER BY class = '*', class",
    )?;
    let mut q = st.query([])?;
    while let Some(r) = q.next()? {
        let (c, j, mj, ms, mv, om, op): (String, i64, Option<f64>, Option<f64>, Option<f64>, Option<f64>, Option<f64>) =
            (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?, r.get(6)?);
        let pct = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:+.1}%", v * 100.0));
        let g = |v: Option<f64>| v.map_or("-".to_string(), |v| if v.abs() < 1e-3 { format!("{v:.2e}") } else { format!("{v:.4}") });
        crate::outln!("  {:<14} {j:>9} {:>10} {:>12} {:>14} {:>17} {:>14}", name(&c), f(mj), g(ms), f(mv), pct(om), pct(op));
    }
    Ok(())
}

/// Scores `results` (transforms.csv, matches.csv, links.csv, merged.parquet, calibration.csv)
/// against `scenario` (points.parquet, cameras.csv, truth.csv, world.csv when present): rotation /
/// translation / clock error per camera pair, road-user identity, merged path error, and match precision /
/// recall / F1 overall and per class. Prints the tables; returns (worst rotation error in
/// degrees, worst translation error in metres, overall F1); the errors are infinite when no
/// camera pair was placed.
pub fn score(con: &Connection, scenario: &Path, results: &Path) -> Result<(f64, f64, f64), Box<dyn Error>> {
    con.execute_batch(&format!(
        "SET VARIABLE score_scenario = {}; SET VARIABLE score_results = {};",
        sql::sql_string(&scenario.to_string_lossy()),
        sql::sql_string(&results.to_string_lossy())
    ))?;
    con.execute_batch(sql::file("sql/score.sql").expect("sql/score.sql"))?;
    let (rot, trans, clock, drift): (Option<f64>, Option<f64>, Option<f64>, Option<f64>) = con.query_row(
        "SELECT max(rot_deg), max(trans_m), max(clock_err_s), max(drift_err_ppm) FROM s_pair_err WHERE cam_from < cam_to",
        [],
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
    )?;
    match (rot, trans, clock, drift) {
        // the line ends with the clock error in ms: tests/cli.rs and benches/identity_grid.sh read it there
        (Some(rot), Some(trans), Some(clock), Some(drift)) => crate::outln!(
            "camera pairs: worst rotation error {rot:.3} deg, worst translation error {trans:.3} m, worst clock drift error {drift:.1} ppm, worst clock offset error {:.1} ms",
            clock * 1e3
        ),
        // a run that placed no camera pair (transforms.csv without values): a score, not an error
        _ => crate::outln!("camera pairs: none placed (transforms.csv has no transform)"),
    }
    let mut pe = con.prepare("SELECT cam_from, cam_to, rot_deg, trans_m, clock_err_s, drift_err_ppm FROM s_pair_err WHERE cam_from < cam_to ORDER BY 1, 2")?;
    let mut q = pe.query([])?;
    while let Some(r) = q.next()? {
        let (a, b, rd, tm, ce, de): (i64, i64, Option<f64>, Option<f64>, Option<f64>, Option<f64>) =
            (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?);
        match (rd, tm, ce, de) {
            (Some(rd), Some(tm), Some(ce), Some(de)) => crate::outln!(
                "  {a} -> {b}: rotation {rd:.3} deg, translation {tm:.3} m, clock offset {:.1} ms (worst over camera {b}'s recording), clock drift {de:.1} ppm",
                ce * 1e3
            ),
            _ => crate::outln!("  {a} -> {b}: not placed"),
        }
    }
    identity(con)?;
    if scenario.join("world.csv").exists() {
        paths(con)?;
    }
    crate::outln!("matches (a true pair: same object, >= 1 s together, >= 3 points each in the true overlap; a predicted pair of one");
    crate::outln!("object that misses that rule is neutral: right, so not against precision, but not a true pair either):");
    crate::outln!("  {:<14} {:>9} {:>7} {:>6} {:>10} {:>10} {:>8}", "class", "precision", "recall", "F1", "true pairs", "predicted", "neutral");
    let mut all_f1 = 0.0;
    let mut rows = con.prepare("SELECT class, precision, recall, true_pairs, predicted, neutral FROM s_class_scores ORDER BY class = '*', class")?;
    let mut q = rows.query([])?;
    while let Some(r) = q.next()? {
        let (c, p, rc, nt, np, nn): (String, f64, f64, i64, i64, i64) = (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?);
        let f1 = if p + rc > 0.0 { 2.0 * p * rc / (p + rc) } else { 0.0 };
        if c == "*" {
            all_f1 = f1;
        }
        crate::outln!("  {:<14} {p:>9.3} {rc:>7.3} {f1:>6.3} {nt:>10} {np:>10} {nn:>8}", if c == "*" { "all" } else { &c });
    }
    // no camera pair placed: infinitely far from any target
    Ok((rot.unwrap_or(f64::INFINITY), trans.unwrap_or(f64::INFINITY), all_f1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Camera 0 sees object A as tracks 1 (10 points) and 3 (5 points, after a break) and
    /// object B as track 2 (10 points); camera 1 sees A as track 7 (10 points).
    fn scenario(dir: &Path, road_users: &str, links: &str) -> Connection {
        let con = crate::open(None).unwrap();
        std::fs::create_dir_all(dir.join("r")).unwrap();
        let f = |n: &str| sql::sql_string(&dir.join(n).to_string_lossy());
        con.execute_batch(&format!(
            "COPY (SELECT camera::INTEGER AS camera, track_id::BIGINT AS track_id, class, t0 + k * 0.1 AS t, k::DOUBLE AS x, y, 0 AS estimated
                   FROM (VALUES (0, 1, 'car', 0.0, 0.0, 10), (0, 2, 'car', 0.0, 5.0, 10), (0, 3, 'car', 2.0, 0.0, 5), (1, 7, 'car', 0.0, 0.0, 10))
                        v(camera, track_id, class, t0, y, n), range(10) r(k) WHERE k < n) TO {pts} (FORMAT parquet);
             COPY (SELECT * FROM (VALUES (0, 0.0, 0.0, 0.0, 'POLYGON ((-9 -9, 99 -9, 99 99, -9 99, -9 -9))', 0.0),
                                         (1, 0.0, 0.0, 0.0, 'POLYGON ((-9 -9, 99 -9, 99 99, -9 99, -9 -9))', 0.0))
                   v(camera, theta_rad, tx, ty, view_wkt_world, clock_offset_s)) TO {cams} (HEADER);
             COPY (SELECT * FROM (VALUES (0, 1, 100, 0), (0, 2, 200, 0), (0, 3, 100, 0), (1, 7, 100, 0)) v(camera, track_id, object_id, is_noise)) TO {truth} (HEADER);
             COPY (SELECT 0 AS cam_from, 1 AS cam_to, 0.0 AS theta_rad, 0.0 AS tx, 0.0 AS ty, 0.0 AS clock_offset_s) TO {tf} (HEADER);
             COPY (SELECT 0 AS camera_a, 1 AS track_a, 1 AS camera_b, 7 AS track_b, 1.0 AS score, 'hungarian' AS kind) TO {m} (HEADER);
             COPY (SELECT * FROM (VALUES {links}) v(camera, track_id, linked_id)) TO {l} (HEADER);
             COPY (SELECT road_user, 'car' AS class, list({{'camera': c, 'track_id': t}}) AS sources
                   FROM (VALUES {road_users}) v(road_user, c, t) GROUP BY road_user) TO {mp} (FORMAT parquet);",
            pts = f("points.parquet"),
            cams = f("cameras.csv"),
            truth = f("truth.csv"),
            tf = f("r/transforms.csv"),
            m = f("r/matches.csv"),
            l = f("r/links.csv"),
            mp = f("r/merged.parquet"),
        ))
        .unwrap();
        score(&con, dir, &dir.join("r")).unwrap();
        con
    }

    fn identity_row(con: &Connection) -> (f64, f64, i64, i64, i64, i64) {
        con.query_row("SELECT idf1, exact_share, true_breaks, breaks_found, links, links_correct FROM s_identity WHERE class = '*'", [], |r| {
            Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?))
        })
        .unwrap()
    }

    #[test]
    fn identity_measures_by_hand() {
        let base = std::env::temp_dir().join(format!("trajdb-score-unit-{}", std::process::id()));
        // perfect: A = {0:1, 0:3, 1:7}, B = {0:2}; the break 1 -> 3 linked
        let con = scenario(&base.join("a"), "(1, 0, 1), (1, 0, 3), (1, 1, 7), (2, 0, 2)", "(0, 1, 1), (0, 3, 1), (0, 2, 2), (1, 7, 7)");
        let (idf1, exact, tb, bf, nl, lc) = identity_row(&con);
        assert!((idf1 - 1.0).abs() < 1e-12 && exact == 1.0, "{idf1} {exact}");
        assert_eq!((tb, bf, nl, lc), (1, 1, 1, 1));
        // files without clock_drift_ppm (cameras.csv, transforms.csv): drift 0 on both sides
        let (ce, de): (f64, f64) = con.query_row("SELECT clock_err_s, drift_err_ppm FROM s_pair_err", [], |r| Ok((r.get(0)?, r.get(1)?))).unwrap();
        assert_eq!((ce, de), (0.0, 0.0));
        // every observation in its object's one road user: HOTA 1
        let h: f64 = con.query_row("SELECT hota FROM s_identity WHERE class = '*'", [], |r| r.get(0)).unwrap();
        assert!((h - 1.0).abs() < 1e-12, "{h}");
        // A's second piece merged into B's road user, and wrongly linked to track 2:
        // shared A-RU1 = 20, B-RU2 = 10 of 35 + 35 points: IDF1 = 2 * 30 / 70; nothing exact
        let con = scenario(&base.join("b"), "(1, 0, 1), (1, 1, 7), (2, 0, 2), (2, 0, 3)", "(0, 1, 1), (0, 3, 2), (0, 2, 2), (1, 7, 7)");
        let (idf1, exact, tb, bf, nl, lc) = identity_row(&con);
        assert!((idf1 - 60.0 / 70.0).abs() < 1e-12, "{idf1}");
        assert_eq!(exact, 0.0);
        assert_eq!((tb, bf, nl, lc), (1, 0, 1, 0));
        std::fs::remove_dir_all(&base).ok();
    }

    /// HOTA and the clock model with drift, by hand. Two cameras at identity transforms, clocks
    /// t_cam = (1 + D 1e-6) w + o at Unix-epoch size (camera 0: o = 1 780 000 000 s, D = +100 ppm;
    /// camera 1: o = 1 780 003 600 s (an hour later), D = -50 ppm).
    ///
    /// Tracks (real points; w = world time of the first point, one point per second):
    ///   camera 0: 1 = A car (10 points, w 0..9), 2 = B pedestrian (10), 3 = A car (5),
    ///             9 = noise (car, is_noise = 1, object -1; 4 points);
    ///   camera 1: 7 = A car (10 points, w 0..9, plus one ESTIMATED point at w = 2000 that counts
    ///             nowhere), 8 = B pedestrian (6 points, w 995..1000).
    /// Road users: RU1 = {0:1, 1:7}, RU2 = {0:2, 0:3, 0:9}; track 1:8 in none.
    ///
    /// HOTA over all classes: n_A = 10 + 5 + 10 = 25, n_B = 10 + 6 = 16; TP = 20 (A in RU1) + 5 (A in
    /// RU2) + 10 (B in RU2) = 35, FN = 6 (track 1:8), FP = 4 (noise in RU2); n_RU1 = 20, n_RU2 = 19.
    ///   DetA = 35 / 45 = 7/9
    ///   AssA = [20²/(25+20-20) + 5²/(25+19-5) + 10²/(16+19-10)] / 35 = (16 + 25/39 + 4) / 35 = 23/39
    ///   HOTA = sqrt(7/9 · 23/39) = sqrt(161/351) = 0.67726...
    /// car only (A and the noise): TP 25, FN 0, FP 4, n_RU1 = 20, n_RU2 = 9:
    ///   DetA = 25/29, AssA = (16 + 25/29) / 25 = 489/725, HOTA = sqrt(489/841) = sqrt(489)/29
    /// pedestrian only (B): TP 10, FN 6, FP 0, n_RU2 = 10: DetA = 10/16, AssA = (100/16)/10 = 5/8, HOTA = 5/8.
    ///
    /// Clock of the pair 0 -> 1 (t_0 = (1 + e) t_1 + C): true pairwise drift (100 + 50) / (1 - 50e-6)
    /// = 150.0075004 ppm; estimated e = 150 ppm: drift error 0.0075004 ppm. C is set so that the
    /// error is -2 ms at w = 0; it changes by w (e + d_1 + e d_1 - d_0) = w · (-7.5e-9), so at the end
    /// of camera 1's real span (w = 1000; the estimated point at w = 2000 is not real) it is
    /// -2.0075 ms: clock error 2.0075 ms.
    #[test]
    fn hota_and_drifting_epoch_clocks_by_hand() {
        let dir = std::env::temp_dir().join(format!("trajdb-score-hota-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("r")).unwrap();
        let f = |n: &str| sql::sql_string(&dir.join(n).to_string_lossy());
        let con = crate::open(None).unwrap();
        let (o0, o1, d0, d1, e) = (1_780_000_000.0_f64, 1_780_003_600.0_f64, 100e-6_f64, -50e-6_f64, 150e-6_f64);
        // est - true at w = 0 is (C - (o0 - o1)) + e o1 = -0.002
        let c = -0.002 + (o0 - o1) - e * o1;
        con.execute_batch(&format!(
            "COPY (SELECT v.camera::INTEGER AS camera, track_id::BIGINT AS track_id, class,
                          c.o + (1 + c.d) * (w0 + k) AS t, k::DOUBLE AS x, y, est AS estimated
                   FROM (VALUES (0, 1, 'car', 0.0, 0.0, 10, 0), (0, 2, 'pedestrian', 0.0, 5.0, 10, 0), (0, 3, 'car', 20.0, 0.0, 5, 0),
                                (0, 9, 'car', 0.0, 9.0, 4, 0), (1, 7, 'car', 0.0, 0.0, 10, 0), (1, 7, 'car', 2000.0, 0.0, 1, 1),
                                (1, 8, 'pedestrian', 995.0, 5.0, 6, 0)) v(camera, track_id, class, w0, y, n, est)
                   JOIN (VALUES (0, {o0}, {d0}), (1, {o1}, {d1})) c(camera, o, d) ON c.camera = v.camera,
                   range(10) r(k) WHERE k < n) TO {pts} (FORMAT parquet);
             COPY (SELECT * FROM (VALUES (0, 0.0, 0.0, 0.0, 'POLYGON ((-9 -9, 99 -9, 99 99, -9 99, -9 -9))', {o0}, 100.0),
                                         (1, 0.0, 0.0, 0.0, 'POLYGON ((-9 -9, 99 -9, 99 99, -9 99, -9 -9))', {o1}, -50.0))
                   v(camera, theta_rad, tx, ty, view_wkt_world, clock_offset_s, clock_drift_ppm)) TO {cams} (HEADER);
             COPY (SELECT * FROM (VALUES (0, 1, 100, 0), (0, 2, 200, 0), (0, 3, 100, 0), (0, 9, -1, 1), (1, 7, 100, 0), (1, 8, 200, 0))
                   v(camera, track_id, object_id, is_noise)) TO {truth} (HEADER);
             COPY (SELECT 0 AS cam_from, 1 AS cam_to, 0.0 AS theta_rad, 0.0 AS tx, 0.0 AS ty, {c} AS clock_offset_s, 150.0 AS clock_drift_ppm) TO {tf} (HEADER);
             COPY (SELECT 0 AS camera_a, 1 AS track_a, 1 AS camera_b, 7 AS track_b, 1.0 AS score, 'hungarian' AS kind) TO {m} (HEADER);
             COPY (SELECT * FROM (VALUES (0, 1, 1), (0, 2, 2), (0, 3, 2), (0, 9, 2), (1, 7, 7), (1, 8, 8)) v(camera, track_id, linked_id)) TO {l} (HEADER);
             COPY (SELECT road_user, 'car' AS class, list({{'camera': c, 'track_id': t}}) AS sources
                   FROM (VALUES (1, 0, 1), (1, 1, 7), (2, 0, 2), (2, 0, 3), (2, 0, 9)) v(road_user, c, t) GROUP BY road_user) TO {mp} (FORMAT parquet);",
            c = format!("{c:?}"),
            pts = f("points.parquet"),
            cams = f("cameras.csv"),
            truth = f("truth.csv"),
            tf = f("r/transforms.csv"),
            m = f("r/matches.csv"),
            l = f("r/links.csv"),
            mp = f("r/merged.parquet"),
        ))
        .unwrap();
        score(&con, &dir, &dir.join("r")).unwrap();
        let hota = |class: &str| -> (f64, f64, f64) {
            con.query_row(&format!("SELECT hota, deta, assa FROM s_identity WHERE class = '{class}'"), [], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
                .unwrap()
        };
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        let (h, d, a) = hota("*");
        assert!(close(d, 7.0 / 9.0) && close(a, 23.0 / 39.0) && close(h, (161.0_f64 / 351.0).sqrt()), "{h} {d} {a}");
        let (h, d, a) = hota("car");
        assert!(close(d, 25.0 / 29.0) && close(a, 489.0 / 725.0) && close(h, 489.0_f64.sqrt() / 29.0), "{h} {d} {a}");
        let (h, d, a) = hota("pedestrian");
        assert!(close(d, 0.625) && close(a, 0.625) && close(h, 0.625), "{h} {d} {a}");
        let (tp, fn_, fp): (f64, f64, f64) =
            con.query_row("SELECT tp, fn, fp FROM s_hota WHERE class = '*'", [], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?))).unwrap();
        assert_eq!((tp, fn_, fp), (35.0, 6.0, 4.0));
        let (ce, de): (f64, f64) = con.query_row("SELECT clock_err_s, drift_err_ppm FROM s_pair_err", [], |r| Ok((r.get(0)?, r.get(1)?))).unwrap();
        let true_drift = (100.0 - -50.0) / (1.0 - 50e-6);
        assert!((de - (true_drift - 150.0)).abs() < 1e-9, "{de}");
        // -0.002 + 1000 (e + d1 + e d1 - d0)
        let want = (-0.002 + 1000.0 * (e + d1 + e * d1 - d0)).abs();
        assert!((ce - want).abs() < 1e-7 && (ce - 0.0020075).abs() < 1e-7, "{ce} {want}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
