//! `trajdb score`: a pipeline output directory against a scenario's ground truth. The SQL is
//! `sql/score.sql`; this prints its tables.

use super::sql;
use duckdb::Connection;
use std::error::Error;
use std::path::Path;

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
