//! Draws the route patterns of `sql/stages/cluster.sql` as an SVG: one panel per class, every track a
//! polyline coloured by its cluster (grey: tracks in no pattern of 5 or more).
//!
//! `cargo run --release --example cluster_svg -- ../shared/data/dut_intersection_3cam/points.parquet clusters.svg [camera]`

use std::collections::BTreeMap;
use std::fmt::Write as _;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: cluster_svg POINTS.parquet OUT.svg [camera]");
        std::process::exit(2);
    }
    let camera: i64 = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(1);
    let con = trajdb::open(None)?;
    con.execute_batch(&format!("CREATE TABLE points AS SELECT * FROM read_parquet('{}')", args[1].replace('\'', "''")))?;
    trajdb::app::pipeline::set_params(&con, &[("cluster_camera".to_string(), camera.to_string())])?;
    con.execute_batch(trajdb::app::sql::file("sql/stages/cluster.sql").expect("embedded"))?;
    // (class, cluster, track) -> points
    let mut tracks: BTreeMap<(String, i64, i64), Vec<(f64, f64)>> = BTreeMap::new();
    let mut sizes: BTreeMap<(String, i64), i64> = BTreeMap::new();
    let mut stmt = con.prepare(
        "SELECT a.class, a.cluster, a.track_id, p.x, p.y, s.n_tracks, p.t
         FROM cluster_assign a JOIN cluster_tracks t USING (class, track_id)
         JOIN cluster_summary s USING (class, cluster), unnest(t.traj) AS u(p)
         ORDER BY a.class, a.cluster, a.track_id, p.t",
    )?;
    let mut rows = stmt.query([])?;
    while let Some(r) = rows.next()? {
        let (class, cluster, track): (String, i64, i64) = (r.get(0)?, r.get(1)?, r.get(2)?);
        sizes.insert((class.clone(), cluster), r.get(5)?);
        tracks.entry((class, cluster, track)).or_default().push((r.get(3)?, r.get(4)?));
    }
    let classes: Vec<String> = {
        let mut c: Vec<String> = tracks.keys().map(|k| k.0.clone()).collect();
        c.dedup();
        c
    };
    let (w, h) = (520.0, 520.0);
    let mut svg = String::new();
    writeln!(svg, r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{h}" font-family="sans-serif">"#, w * classes.len() as f64)?;
    for (panel, class) in classes.iter().enumerate() {
        let pts = tracks.iter().filter(|(k, _)| &k.0 == class).flat_map(|(_, v)| v.iter());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in pts {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        let scale = (w - 40.0) / (x1 - x0).max(y1 - y0).max(1e-9);
        let ox = panel as f64 * w + 20.0;
        writeln!(svg, r#"<text x="{}" y="16">{class} (camera {camera})</text>"#, ox)?;
        for ((c, cluster, _), v) in tracks.iter().filter(|(k, _)| &k.0 == class) {
            let big = sizes.get(&(c.clone(), *cluster)).copied().unwrap_or(0) >= 5 && *cluster > 0;
            let colour = if big { format!("hsl({}, 70%, 45%)", (*cluster * 137) % 360) } else { "#bbb".to_string() };
            let path: Vec<String> = v.iter().map(|&(x, y)| format!("{:.1},{:.1}", ox + (x - x0) * scale, h - 20.0 - (y - y0) * scale)).collect();
            writeln!(svg, r#"<polyline fill="none" stroke="{colour}" stroke-width="1" stroke-opacity="0.7" points="{}"/>"#, path.join(" "))?;
        }
    }
    svg.push_str("</svg>\n");
    std::fs::write(&args[2], svg)?;
    println!("wrote {} ({} tracks, {} classes)", args[2], tracks.len(), classes.len());
    Ok(())
}
