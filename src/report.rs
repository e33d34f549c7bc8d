//! The QA report of `trajdb pipeline` (`report.html`, one self-contained file with inline SVG):
//! each camera's points before alignment (its own frame) and after (the common frame), the view
//! polygons and overlaps per class, sample merges, and count tables in the style of the thesis's
//! tables 4.1–4.6 (tracks per class and camera with the number that has ≥ ξ points in an
//! overlap; Cayley tables per class; matched pairs and merged road users per camera set).
//!
//! It reads the pipeline's tables (points, align_frames, view_polygons, view_overlaps,
//! merge_tracks, merge_links, merge_groups, merged, cluster_assign) from the open connection.

use duckdb::Connection;
use std::error::Error;
use std::fmt::Write as _;
use std::path::Path;

type R<T> = Result<T, Box<dyn Error>>;

const PALETTE: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"];

fn color(camera: i64) -> &'static str {
    PALETTE[camera.rem_euclid(PALETTE.len() as i64) as usize]
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// World → SVG pixel mapping with equal scales, y up.
struct Frame {
    x0: f64,
    y1: f64,
    k: f64,
    w: f64,
    h: f64,
}

impl Frame {
    fn fit(xs: impl Iterator<Item = (f64, f64)>, w: f64) -> Frame {
        let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for (x, y) in xs.filter(|(x, y)| x.is_finite() && y.is_finite()) {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if !x0.is_finite() {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        let pad = 0.03 * (x1 - x0).max(y1 - y0).max(1.0);
        let (x0, x1, y0, y1) = (x0 - pad, x1 + pad, y0 - pad, y1 + pad);
        let k = w / (x1 - x0).max(y1 - y0);
        Frame { x0, y1, k, w: (x1 - x0) * k, h: (y1 - y0) * k }
    }
    fn p(&self, x: f64, y: f64) -> (f64, f64) {
        ((x - self.x0) * self.k, (self.y1 - y) * self.k)
    }
    fn open(&self, title: &str) -> String {
        format!(
            "<figure><svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{:.0}\" height=\"{:.0}\" viewBox=\"0 0 {:.1} {:.1}\" style=\"background:#fff;border:1px solid #ccc\">",
            self.w, self.h, self.w, self.h
        ) + &format!("<title>{}</title>", esc(title))
    }
    fn close(&self, caption: &str) -> String {
        // a 10 m scale bar
        let (bx, by) = (8.0, self.h - 8.0);
        format!(
            "<line x1=\"{bx}\" y1=\"{by}\" x2=\"{:.1}\" y2=\"{by}\" stroke=\"#000\" stroke-width=\"2\"/><text x=\"{bx}\" y=\"{:.1}\" font-size=\"10\">10 m</text></svg><figcaption>{}</figcaption></figure>",
            bx + 10.0 * self.k,
            by - 4.0,
            esc(caption)
        )
    }
    /// Points as one path of zero-length round-capped segments.
    fn dots(&self, pts: &[(f64, f64)], color: &str, r: f64) -> String {
        let mut d = String::with_capacity(pts.len() * 16);
        for &(x, y) in pts {
            let (u, v) = self.p(x, y);
            let _ = write!(d, "M{u:.1} {v:.1}h0");
        }
        format!("<path d=\"{d}\" stroke=\"{color}\" stroke-width=\"{r}\" stroke-linecap=\"round\" stroke-opacity=\"0.5\" fill=\"none\"/>")
    }
    fn line(&self, pts: &[(f64, f64)], color: &str, width: f64, dash: bool) -> String {
        let mut d = String::new();
        for (i, &(x, y)) in pts.iter().enumerate() {
            let (u, v) = self.p(x, y);
            let _ = write!(d, "{}{u:.1} {v:.1}", if i == 0 { "M" } else { "L" });
        }
        format!(
            "<path d=\"{d}\" stroke=\"{color}\" stroke-width=\"{width}\" fill=\"none\"{}/>",
            if dash { " stroke-dasharray=\"4 3\"" } else { "" }
        )
    }
    /// A (multi)polygon given as WKT.
    fn polygon(&self, wkt_text: &str, stroke: &str, fill: &str, fill_opacity: f64) -> String {
        let mut d = String::new();
        for ring in wkt_rings(wkt_text) {
            for (i, &(x, y)) in ring.iter().enumerate() {
                let (u, v) = self.p(x, y);
                let _ = write!(d, "{}{u:.1} {v:.1}", if i == 0 { "M" } else { "L" });
            }
            d.push('Z');
        }
        format!("<path d=\"{d}\" stroke=\"{stroke}\" stroke-width=\"1.5\" fill=\"{fill}\" fill-opacity=\"{fill_opacity}\" fill-rule=\"evenodd\"/>")
    }
}

/// The rings of a POLYGON / MULTIPOLYGON WKT (every parenthesised list of coordinates).
fn wkt_rings(s: &str) -> Vec<Vec<(f64, f64)>> {
    let mut rings = Vec::new();
    let mut depth_start = None;
    for (i, c) in s.char_indices() {
        match c {
            '(' => depth_start = Some(i + 1),
            ')' => {
                if let Some(st) = depth_start.take() {
                    let ring: Vec<(f64, f64)> = s[st..i]
                        .split(',')
                        .filter_map(|p| {
                            let mut it = p.split_whitespace().map(str::parse::<f64>);
                            match (it.next(), it.next()) {
                                (Some(Ok(x)), Some(Ok(y))) => Some((x, y)),
                                _ => None,
                            }
                        })
                        .collect();
                    if ring.len() >= 3 {
                        rings.push(ring);
                    }
                }
            }
            _ => {}
        }
    }
    rings
}

fn query_rows<T>(con: &Connection, sql: &str, f: impl FnMut(&duckdb::Row) -> duckdb::Result<T>) -> R<Vec<T>> {
    let mut st = con.prepare(sql)?;
    let rows = st.query_map([], f)?;
    Ok(rows.collect::<Result<Vec<T>, _>>()?)
}

/// An HTML table from a header and rows of cells.
fn table(head: &[String], rows: &[Vec<String>]) -> String {
    let mut s = String::from("<table><tr>");
    for h in head {
        let _ = write!(s, "<th>{}</th>", esc(h));
    }
    s.push_str("</tr>");
    for r in rows {
        s.push_str("<tr>");
        for (i, c) in r.iter().enumerate() {
            let _ = write!(s, "<{0}>{1}</{0}>", if i == 0 { "th" } else { "td" }, esc(c));
        }
        s.push_str("</tr>");
    }
    s.push_str("</table>");
    s
}

/// Writes `out/report.html`. `timings` are the stage times (s); `xi` the minimum number of
/// points inside an overlap (merge_min_points).
pub fn write(con: &Connection, out: &Path, input: &str, timings: &[(String, f64)]) -> R<()> {
    let mut h = String::new();
    h.push_str("<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>trajdb pipeline report</title><style>body{font-family:sans-serif;max-width:1300px;margin:1em auto;padding:0 1em}table{border-collapse:collapse;margin:.5em 0 1.2em}td,th{border:1px solid #bbb;padding:2px 8px;text-align:right}th{background:#f3f3f3}figure{display:inline-block;margin:.4em;vertical-align:top}figcaption{font-size:12px;max-width:420px}</style></head><body>");
    let _ = write!(h, "<h1>trajdb pipeline report</h1><p>Input: <code>{}</code>. Generated by trajdb {}.</p>", esc(input), env!("CARGO_PKG_VERSION"));

    // stage times
    let _ = write!(
        h,
        "<h2>Stages</h2>{}",
        table(&["stage".into(), "seconds".into()], &timings.iter().map(|(n, t)| vec![n.clone(), format!("{t:.2}")]).collect::<Vec<_>>())
    );

    let cameras: Vec<i64> = query_rows(con, "SELECT DISTINCT camera FROM points ORDER BY camera", |r| r.get(0))?;
    let classes: Vec<String> = query_rows(con, "SELECT DISTINCT class FROM points ORDER BY class", |r| r.get(0))?;
    let xi: i64 = con.query_row("SELECT getvariable('merge_min_points')::BIGINT", [], |r| r.get(0))?;

    // transforms
    let tf: Vec<Vec<String>> = query_rows(
        con,
        "SELECT camera, reference, degrees(to_reference.theta), to_reference.tx, to_reference.ty, hops, bottleneck_support FROM align_frames ORDER BY camera",
        |r| {
            Ok(vec![
                r.get::<_, i64>(0)?.to_string(),
                r.get::<_, i64>(1)?.to_string(),
                format!("{:.3}", r.get::<_, f64>(2)?),
                format!("{:.3}", r.get::<_, f64>(3)?),
                format!("{:.3}", r.get::<_, f64>(4)?),
                r.get::<_, i64>(5)?.to_string(),
                r.get::<_, Option<f64>>(6)?.map_or("-".into(), |v| format!("{v:.0}")),
            ])
        },
    )?;
    let unaligned: Vec<i64> = query_rows(con, "SELECT DISTINCT camera FROM points ANTI JOIN align_frames USING (camera) ORDER BY camera", |r| r.get(0))?;
    let _ = write!(
        h,
        "<h2>Camera alignment</h2><p>Each camera's transform into the reference camera's frame (sql/align.sql).{}</p>{}",
        if unaligned.is_empty() { String::new() } else { format!(" <b>Not aligned (no consistent track pairs): cameras {unaligned:?}.</b>") },
        table(&["camera", "reference", "rotation °", "tx m", "ty m", "hops", "support (pairs)"].map(String::from), &tf)
    );

    // points before / after
    let n_points: i64 = con.query_row("SELECT count(*) FROM points WHERE estimated = 0", [], |r| r.get(0))?;
    let step = (n_points / 12_000).max(1);
    let pts: Vec<(i64, f64, f64, Option<f64>, Option<f64>)> = query_rows(
        con,
        &format!(
            "SELECT p.camera, p.x, p.y,
                    f.to_reference.scale * (cos(f.to_reference.theta) * p.x - sin(f.to_reference.theta) * p.y) + f.to_reference.tx,
                    f.to_reference.scale * (sin(f.to_reference.theta) * p.x + cos(f.to_reference.theta) * p.y) + f.to_reference.ty
             FROM (SELECT *, row_number() OVER (ORDER BY camera, track_id, t) AS k FROM points WHERE estimated = 0) p
             LEFT JOIN align_frames f USING (camera) WHERE p.k % {step} = 0"
        ),
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?)),
    )?;
    h.push_str("<h2>Points before and after alignment</h2><p>Every ");
    let _ = write!(h, "{step}th real point. Before: each camera in its own frame. After: all cameras in the reference frame, with the view polygons (all classes) outlined.</p>");
    for &c in &cameras {
        let mine: Vec<(f64, f64)> = pts.iter().filter(|p| p.0 == c).map(|p| (p.1, p.2)).collect();
        let fr = Frame::fit(mine.iter().copied(), 300.0);
        h.push_str(&fr.open(&format!("camera {c}, local frame")));
        h.push_str(&fr.dots(&mine, color(c), 1.6));
        h.push_str(&fr.close(&format!("camera {c} before alignment (its own frame)")));
    }
    let aligned: Vec<(i64, f64, f64)> = pts.iter().filter_map(|p| Some((p.0, p.3?, p.4?))).collect();
    let views: Vec<(i64, String, String)> = query_rows(con, "SELECT camera, class, polygon_to_wkt(polygon) FROM view_polygons ORDER BY camera, class", |r| {
        Ok((r.get(0)?, r.get(1)?, r.get(2)?))
    })?;
    let fr = Frame::fit(aligned.iter().map(|p| (p.1, p.2)), 620.0);
    h.push_str(&fr.open("all cameras, common frame"));
    for &c in &cameras {
        let mine: Vec<(f64, f64)> = aligned.iter().filter(|p| p.0 == c).map(|p| (p.1, p.2)).collect();
        h.push_str(&fr.dots(&mine, color(c), 1.6));
    }
    for (c, _, w) in views.iter().filter(|v| v.1 == "*") {
        h.push_str(&fr.polygon(w, color(*c), "none", 0.0));
    }
    h.push_str(&fr.close(&format!(
        "after alignment; colours: {}",
        cameras.iter().map(|c| format!("camera {c} {}", color(*c))).collect::<Vec<_>>().join(", ")
    )));

    // view polygons and overlaps per class
    let overlaps: Vec<(String, i64, i64, String, f64)> =
        query_rows(con, "SELECT class, cam_a, cam_b, polygon_to_wkt(polygon), area_m2 FROM view_overlaps ORDER BY class, cam_a, cam_b", |r| {
            Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?))
        })?;
    h.push_str("<h2>View polygons and overlaps per class</h2><p>P<sup>k</sup> per camera (outline, camera colour) and the pairwise overlaps P<sup>k∩l</sup> (grey fill), in the common frame.</p>");
    let all_view_pts = views.iter().flat_map(|v| wkt_rings(&v.2).into_iter().flatten());
    let frv = Frame::fit(all_view_pts, 300.0);
    for class in classes.iter().map(String::as_str).chain(std::iter::once("*")) {
        h.push_str(&frv.open(class));
        for (_, _, _, w, _) in overlaps.iter().filter(|o| o.0 == class) {
            h.push_str(&frv.polygon(w, "#555", "#888", 0.35));
        }
        for (c, _, w) in views.iter().filter(|v| v.1 == class) {
            h.push_str(&frv.polygon(w, color(*c), "none", 0.0));
        }
        let areas: Vec<String> = overlaps.iter().filter(|o| o.0 == class).map(|o| format!("{}∩{} {:.0} m²", o.1, o.2, o.4)).collect();
        h.push_str(&frv.close(&format!("{}: {}", if class == "*" { "all classes" } else { class }, areas.join(", "))));
    }

    // Table 4.1 style: tracks per class and camera, (*) with >= xi points in an overlap
    let counts: Vec<(String, i64, i64, i64)> = query_rows(
        con,
        "WITH t AS (SELECT camera, track_id, class, traj FROM merge_tracks),
              inside AS (
                SELECT t.camera, t.track_id, t.class,
                       max(traj_points_inside(t.traj, o.polygon)) AS best
                FROM t LEFT JOIN view_overlaps o ON o.class = t.class AND (o.cam_a = t.camera OR o.cam_b = t.camera) AND o.area_m2 > 0
                GROUP BY ALL)
         SELECT class, camera, count(*), count(*) FILTER (WHERE best >= getvariable('merge_min_points'))
         FROM inside GROUP BY ALL ORDER BY class, camera",
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
    )?;
    let mut rows = Vec::new();
    for class in &classes {
        let mut row = vec![class.clone()];
        let (mut a, mut b) = (0, 0);
        for &c in &cameras {
            let x = counts.iter().find(|q| &q.0 == class && q.1 == c).map_or((0, 0), |q| (q.2, q.3));
            row.push(format!("{} ({})", x.0, x.1));
            a += x.0;
            b += x.1;
        }
        row.push(format!("{a} ({b})"));
        rows.push(row);
    }
    let mut total = vec!["Total".to_string()];
    for &c in cameras.iter() {
        let x: (i64, i64) = counts.iter().filter(|q| q.1 == c).fold((0, 0), |s, q| (s.0 + q.2, s.1 + q.3));
        total.push(format!("{} ({})", x.0, x.1));
    }
    let x: (i64, i64) = counts.iter().fold((0, 0), |s, q| (s.0 + q.2, s.1 + q.3));
    total.push(format!("{} ({})", x.0, x.1));
    rows.push(total);
    let mut head = vec!["class".to_string()];
    head.extend(cameras.iter().map(|c| format!("camera {c} (*)")));
    head.push("total (*)".into());
    let _ = write!(
        h,
        "<h2>Tracks per class and camera (cf. thesis table 4.1/4.3)</h2><p>Tracks after cleaning and linking of broken tracks; (*) tracks with at least ξ = {xi} points in an overlap with another camera (the most that can be matched).</p>{}",
        table(&head, &rows)
    );

    // Cayley tables per class (tables 4.4/4.5)
    let cay: Vec<(String, i64, i64, i64)> = query_rows(
        con,
        "SELECT t.class, t.camera, CASE WHEN o.cam_a = t.camera THEN o.cam_b ELSE o.cam_a END AS other,
                count(*) FILTER (WHERE traj_points_inside(t.traj, o.polygon) >= getvariable('merge_min_points'))
         FROM merge_tracks t JOIN view_overlaps o ON o.class = t.class AND (o.cam_a = t.camera OR o.cam_b = t.camera)
         GROUP BY ALL",
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
    )?;
    let _ = write!(h, "<h2>Cayley tables: tracks with at least ξ points in each overlap (cf. thesis tables 4.4/4.5)</h2><p>Row k, column l: camera k's tracks with ≥ {xi} points in P<sup>k∩l</sup>; the diagonal is all of camera k's tracks.</p>");
    for class in &classes {
        let mut rows = Vec::new();
        for &k in &cameras {
            let mut row = vec![format!("P{k}")];
            for &l in &cameras {
                let v = if k == l {
                    counts.iter().find(|q| &q.0 == class && q.1 == k).map_or(0, |q| q.2)
                } else {
                    cay.iter().find(|q| &q.0 == class && q.1 == k && q.2 == l).map_or(0, |q| q.3)
                };
                row.push(v.to_string());
            }
            rows.push(row);
        }
        let mut head = vec![class.clone()];
        head.extend(cameras.iter().map(|c| format!("P{c}")));
        h.push_str(&table(&head, &rows));
    }

    // matched pairs per camera pair and class (table 4.2 style), merged road users per camera set (4.6)
    let links: Vec<(String, String, i64)> = query_rows(
        con,
        "SELECT t.camera::VARCHAR || '–' || u.camera::VARCHAR AS pair, t.class, count(*)
         FROM merge_links m JOIN merge_groups ga ON ga.uid = m.uid_a JOIN merge_groups gb ON gb.uid = m.uid_b
         JOIN merge_tracks t ON t.uid = m.uid_a JOIN merge_tracks u ON u.uid = m.uid_b
         WHERE ga.road_user = gb.road_user GROUP BY ALL ORDER BY pair",
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
    )?;
    let sets: Vec<(String, String, i64)> = query_rows(
        con,
        "SELECT cams, class, count(*)
         FROM (SELECT array_to_string(list_sort(list_distinct([s.camera FOR s IN sources])), '+') AS cams, class FROM merged)
         GROUP BY cams, class ORDER BY length(cams), cams",
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
    )?;
    let pivot = |data: &[(String, String, i64)], label: &str| -> String {
        let mut keys: Vec<&String> = data.iter().map(|d| &d.0).collect();
        keys.dedup();
        let mut rows = Vec::new();
        let mut col_tot = vec![0i64; classes.len() + 1];
        for k in keys {
            let mut row = vec![k.clone()];
            let mut tot = 0;
            for (i, class) in classes.iter().enumerate() {
                let v = data.iter().find(|d| &d.0 == k && &d.1 == class).map_or(0, |d| d.2);
                row.push(v.to_string());
                tot += v;
                col_tot[i] += v;
            }
            col_tot[classes.len()] += tot;
            row.push(tot.to_string());
            rows.push(row);
        }
        let mut last = vec!["Total".to_string()];
        last.extend(col_tot.iter().map(|v| v.to_string()));
        rows.push(last);
        let mut head = vec![label.to_string()];
        head.extend(classes.iter().cloned());
        head.push("total".into());
        table(&head, &rows)
    };
    let eta: f64 = con.query_row("SELECT getvariable('merge_eta')::DOUBLE", [], |r| r.get(0))?;
    let _ = write!(
        h,
        "<h2>Matches and merged road users (cf. thesis tables 4.2/4.6)</h2><p>Accepted links (LCSS similarity ≥ η̄ = {eta}, one-to-one per camera pair, consistent road users) per camera pair:</p>{}<p>Road users after merging, by the set of cameras that saw them (no duplicates: every track belongs to exactly one road user):</p>{}",
        pivot(&links, "camera pair"),
        pivot(&sets, "cameras")
    );

    // sample merges
    let samples: Vec<(i64, String)> = query_rows(
        con,
        "SELECT road_user, class FROM merged
         ORDER BY len(list_distinct([s.camera FOR s IN sources])) DESC, n_tracks DESC, len(traj) DESC, road_user LIMIT 4",
        |r| Ok((r.get(0)?, r.get(1)?)),
    )?;
    h.push_str("<h2>Sample merges</h2><p>Source tracks in the common frame (camera colours, dashed) and the merged trajectory (black).</p>");
    for (ru, class) in samples {
        let src: Vec<(i64, i64, Vec<(f64, f64)>)> = query_rows(
            con,
            &format!(
                "SELECT t.camera, t.track_id, t.traj FROM merge_tracks t JOIN merge_groups g USING (uid) WHERE g.road_user = {ru} ORDER BY t.camera, t.t0"
            ),
            |r| {
                let l: duckdb::types::Value = r.get(2)?;
                Ok((r.get(0)?, r.get(1)?, value_xy(&l)))
            },
        )?;
        let merged: Vec<(f64, f64)> = con.query_row(
            &format!("SELECT traj FROM merged WHERE road_user = {ru}"),
            [],
            |r| Ok(value_xy(&r.get::<_, duckdb::types::Value>(0)?)),
        )?;
        let fr = Frame::fit(src.iter().flat_map(|s| s.2.iter().copied()).chain(merged.iter().copied()), 300.0);
        h.push_str(&fr.open(&format!("road user {ru}")));
        for (c, _, pts) in &src {
            h.push_str(&fr.line(pts, color(*c), 2.5, true));
        }
        h.push_str(&fr.line(&merged, "#000", 1.0, false));
        let names: Vec<String> = src.iter().map(|s| format!("{}:{}", s.0, s.1)).collect();
        h.push_str(&fr.close(&format!("road user {ru} ({class}) from tracks {}", names.join(", "))));
    }

    // clusters
    let cl: Vec<Vec<String>> = query_rows(
        con,
        "SELECT class, count(DISTINCT cluster) FILTER (WHERE cluster > 0), count(*) FILTER (WHERE cluster > 0), count(*)
         FROM cluster_assign GROUP BY class ORDER BY class",
        |r| Ok(vec![r.get::<_, String>(0)?, r.get::<_, i64>(1)?.to_string(), r.get::<_, i64>(2)?.to_string(), r.get::<_, i64>(3)?.to_string()]),
    )?;
    let cam: i64 = con.query_row("SELECT getvariable('cluster_camera')::BIGINT", [], |r| r.get(0))?;
    let _ = write!(
        h,
        "<h2>Route patterns</h2><p>Agglomerative clustering (average linkage on 1 − LCSS S1) of camera {cam}'s tracks (sql/cluster.sql).</p>{}",
        table(&["class", "clusters", "tracks in a cluster", "tracks"].map(String::from), &cl)
    );
    h.push_str("</body></html>\n");
    std::fs::write(out.join("report.html"), h)?;
    Ok(())
}

/// (x, y) pairs of a trajectory value (`STRUCT(t, x, y)[]`).
fn value_xy(v: &duckdb::types::Value) -> Vec<(f64, f64)> {
    use duckdb::types::Value;
    let f = |v: &Value| match v {
        Value::Double(d) => *d,
        _ => f64::NAN,
    };
    match v {
        Value::List(items) => items
            .iter()
            .filter_map(|it| match it {
                Value::Struct(m) => Some((f(m.get(&"x".to_string())?), f(m.get(&"y".to_string())?))),
                _ => None,
            })
            .collect(),
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::wkt_rings;

    #[test]
    fn rings_of_polygons_and_multipolygons() {
        assert_eq!(wkt_rings("POLYGON EMPTY").len(), 0);
        let r = wkt_rings("MULTIPOLYGON (((0 0, 1 0, 1 1, 0 0)), ((5 5, 6 5, 6 6, 5 5), (5.1 5.1, 5.2 5.1, 5.2 5.2, 5.1 5.1)))");
        assert_eq!(r.len(), 3);
        assert_eq!(r[1][2], (6.0, 6.0));
    }
}
