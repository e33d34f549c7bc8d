//! `trajdb score`: a pipeline output directory against a scenario's ground truth. The SQL is
//! `sql/score.sql`; this prints its tables.

use super::sql;
use duckdb::Connection;
use std::error::Error;
use std::path::Path;

/// Prints the road-user identity table (IDF1, exactly reconstructed objects, within-camera
/// links) and the clock offsets of the scenario.
fn identity(con: &Connection) -> Result<(), Box<dyn Error>> {
    println!("road users (from merged.parquet; IDF1 over real points, exact = all of an object's real tracks and nothing else in one road user):");
    println!("  {:<14} {:>6} {:>7} {:>8} {:>11} {:>12} {:>11} {:>8}", "class", "IDF1", "exact", "objects", "link prec.", "break recall", "true breaks", "links");
    let mut st = con.prepare(
        "SELECT class, idf1, exact_share, objects, links_correct::DOUBLE / greatest(links, 1), breaks_found::DOUBLE / greatest(true_breaks, 1),
                true_breaks, links FROM s_identity ORDER BY class = '*', class",
    )?;
    let mut q = st.query([])?;
    while let Some(r) = q.next()? {
        let (c, idf1, exact, n, lp, br, nb, nl): (String, f64, Option<f64>, i64, f64, f64, i64, i64) =
            (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?, r.get(6)?, r.get(7)?);
        let class = if c == "*" { "all" } else { c.as_str() };
        println!("  {class:<14} {idf1:>6.3} {:>7.3} {n:>8} {lp:>11.3} {br:>12.3} {nb:>11} {nl:>8}", exact.unwrap_or(0.0));
    }
    let offsets: Vec<f64> = con.prepare("SELECT DISTINCT clock_offset_s FROM s_cameras WHERE clock_offset_s IS NOT NULL ORDER BY 1")?.query_map([], |r| r.get(0))?.collect::<Result<_, _>>()?;
    if offsets.iter().any(|&o| o != 0.0) {
        println!("clock offsets: the scenario's cameras are off by {offsets:?} s; the pipeline does not estimate clock offsets yet (it assumes synchronised clocks)");
    }
    Ok(())
}

/// Scores `results` (transforms.csv, matches.csv, links.csv) against `scenario` (points.parquet,
/// cameras.csv, truth.csv): rotation / translation error per camera pair, and match precision /
/// recall / F1 overall and per class. Prints the tables; returns (worst rotation error in
/// degrees, worst translation error in metres, overall F1).
pub fn score(con: &Connection, scenario: &Path, results: &Path) -> Result<(f64, f64, f64), Box<dyn Error>> {
    con.execute_batch(&format!(
        "SET VARIABLE score_scenario = {}; SET VARIABLE score_results = {};",
        sql::sql_string(&scenario.to_string_lossy()),
        sql::sql_string(&results.to_string_lossy())
    ))?;
    con.execute_batch(sql::file("sql/score.sql").expect("sql/score.sql"))?;
    let (rot, trans): (f64, f64) = con.query_row("SELECT max(rot_deg), max(trans_m) FROM s_pair_err WHERE cam_from < cam_to", [], |r| Ok((r.get(0)?, r.get(1)?)))?;
    println!("camera pairs: worst rotation error {rot:.3} deg, worst translation error {trans:.3} m");
    let mut pe = con.prepare("SELECT cam_from, cam_to, rot_deg, trans_m FROM s_pair_err WHERE cam_from < cam_to ORDER BY 1, 2")?;
    let mut q = pe.query([])?;
    while let Some(r) = q.next()? {
        let (a, b, rd, tm): (i64, i64, f64, f64) = (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?);
        println!("  {a} -> {b}: rotation {rd:.3} deg, translation {tm:.3} m");
    }
    identity(con)?;
    println!("matches (a true pair: same object, >= 1 s together, >= 3 points each in the true overlap):");
    println!("  {:<14} {:>9} {:>7} {:>6} {:>10} {:>10}", "class", "precision", "recall", "F1", "true pairs", "predicted");
    let mut all_f1 = 0.0;
    let mut rows = con.prepare("SELECT class, precision, recall, true_pairs, predicted FROM s_class_scores ORDER BY class = '*', class")?;
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
