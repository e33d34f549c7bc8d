//! The QA report of `trajdb pipeline` (`report.html`, one self-contained file with inline SVG):
//! each camera's points before alignment (its own frame) and after (the common frame), the view
//! polygons and overlaps per class, sample merges, count tables in the style of the thesis's
//! tables 4.1–4.6, and the parameters used. One function per section; the data comes from the
//! pipeline's tables ([`queries`]), the markup from [`html`] and [`svg`].

mod html;
mod queries;
mod svg;

use duckdb::Connection;
use html::table;
use queries::{query_rows, value_xy, Ctx};
use std::error::Error;
use std::fmt::Write as _;
use std::path::Path;
use svg::{color, Frame};

type R<T> = Result<T, Box<dyn Error>>;

/// Writes `out/report.html`; `timings` are the stage times (s).
pub fn write(con: &Connection, out: &Path, input: &str, timings: &[(String, f64)]) -> R<()> {
    let mut h = html::page_start(input);
    stage_times(timings, &mut h);
    let c = Ctx::load(con)?;
    transforms(con, &c, &mut h)?;
    calibration(con, &c, &mut h)?;
    points(con, &c, &mut h)?;
    view_polygons(con, &c, &mut h)?;
    track_counts(con, &c, &mut h)?;
    matches(con, &c, &mut h)?;
    sample_merges(con, &c, &mut h)?;
    clusters(con, &c, &mut h)?;
    parameters(con, &c, &mut h)?;
    h.push_str(html::GLOSSARY);
    h.push_str(html::page_end());
    std::fs::write(out.join("report.html"), h)?;
    Ok(())
}

/// Stage times.
fn stage_times(timings: &[(String, f64)], h: &mut String) {
    // stage times
    let _ = write!(
        h,
        "<h2>Stages</h2>{}",
        table(&["stage".into(), "seconds".into()], &timings.iter().map(|(n, t)| vec![n.clone(), format!("{t:.2}")]).collect::<Vec<_>>())
    );

}

/// Each camera's transform into the reference frame.
fn transforms(con: &Connection, _: &Ctx, h: &mut String) -> R<()> {
    // transforms
    let tf: Vec<Vec<String>> = query_rows(
        con,
        "SELECT camera, reference, degrees(to_reference.theta), to_reference.tx, to_reference.ty, hops, bottleneck_support, clock_offset_s * 1000 FROM align_frames ORDER BY camera",
        |r| {
            Ok(vec![
                r.get::<_, i64>(0)?.to_string(),
                r.get::<_, i64>(1)?.to_string(),
                format!("{:.3}", r.get::<_, f64>(2)?),
                format!("{:.3}", r.get::<_, f64>(3)?),
                format!("{:.3}", r.get::<_, f64>(4)?),
                r.get::<_, i64>(5)?.to_string(),
                r.get::<_, Option<f64>>(6)?.map_or("-".into(), |v| format!("{v:.0}")),
                format!("{:+.1}", r.get::<_, f64>(7)?),
            ])
        },
    )?;
    let unaligned: Vec<i64> = query_rows(con, "SELECT DISTINCT camera FROM points ANTI JOIN align_frames USING (camera) ORDER BY camera", |r| r.get(0))?;
    let _ = write!(
        h,
        "<h2>Camera alignment</h2><p>Each camera's transform into the reference camera's frame (sql/stages/align.sql).{}</p>{}",
        if unaligned.is_empty() { String::new() } else { format!(" <b>Not aligned (no consistent track pairs): cameras {unaligned:?}.</b>") },
        table(&["camera", "reference", "rotation °", "tx m", "ty m", "hops", "support (pairs)", "clock offset ms"].map(String::from), &tf)
    );

    Ok(())
}

/// What the pipeline measured from the data and the parameters it derived (calibration.csv).
fn calibration(con: &Connection, _: &Ctx, h: &mut String) -> R<()> {
    let rows: Vec<Vec<String>> = query_rows(con, "SELECT scope, quantity, value, unit, how FROM calibration_summary ORDER BY scope, quantity", |r| {
        Ok(vec![
            r.get::<_, String>(0)?,
            r.get::<_, String>(1)?,
            r.get::<_, Option<f64>>(2)?.map_or("-".into(), |v| format!("{v:.4}")),
            r.get::<_, String>(3)?,
            r.get::<_, String>(4)?,
        ])
    })?;
    let _ = write!(
        h,
        "<h2>Calibration</h2><p>Measured from the tracks alone (sql/stages/calibrate.sql, sql/stages/align.sql) and the parameters derived from it; \
         <code>--param name=value</code> overrides any of them (shown as <i>given</i>). The same table is calibration.csv.</p>{}",
        table(&["scope", "quantity", "value", "unit", "how"].map(String::from), &rows)
    );
    Ok(())
}

/// Every camera's points before (own frame) and after alignment.
fn points(con: &Connection, c: &Ctx, h: &mut String) -> R<()> {
    // points before / after
    let n_points: i64 = con.query_row("SELECT count(*) FROM points WHERE estimated = 0", [], |r| r.get(0))?;
    let step = (n_points / 12_000).max(1);
    // (camera, local x, local y, aligned x, aligned y)
    type Pt = (i64, f64, f64, Option<f64>, Option<f64>);
    let pts: Vec<Pt> = query_rows(
        con,
        &format!(
            "SELECT p.camera, p.x, p.y,
                    transform_point(f.to_reference, p.x, p.y).x,
                    transform_point(f.to_reference, p.x, p.y).y
             FROM (SELECT *, row_number() OVER (ORDER BY camera, track_id, t) AS k FROM points WHERE estimated = 0) p
             LEFT JOIN align_frames f USING (camera) WHERE p.k % {step} = 0"
        ),
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?)),
    )?;
    h.push_str("<h2>Points before and after alignment</h2><p>");
    let _ = write!(h, "{}Before: each camera in its own frame. After: all cameras in the reference frame, with the view polygons (all classes) outlined.</p>{}",
        if step > 1 { format!("One real point in {step}. ") } else { String::new() }, svg::legend(&c.cameras));
    for &c in &c.cameras {
        let mine: Vec<(f64, f64)> = pts.iter().filter(|p| p.0 == c).map(|p| (p.1, p.2)).collect();
        let fr = Frame::fit(mine.iter().copied(), svg::PLOT_W);
        h.push_str(&fr.open(&format!("camera {c}, local frame")));
        h.push_str(&fr.dots(&mine, color(c), 1.6));
        h.push_str(&fr.close(&format!("camera {c} before alignment (its own frame)")));
    }
    let aligned: Vec<(i64, f64, f64)> = pts.iter().filter_map(|p| Some((p.0, p.3?, p.4?))).collect();
    let views = queries::views(con)?;
    let fr = Frame::fit(aligned.iter().map(|p| (p.1, p.2)), 620.0);
    h.push_str(&fr.open("all cameras, common frame"));
    for &c in &c.cameras {
        let mine: Vec<(f64, f64)> = aligned.iter().filter(|p| p.0 == c).map(|p| (p.1, p.2)).collect();
        h.push_str(&fr.dots(&mine, color(c), 1.6));
    }
    for (c, _, w) in views.iter().filter(|v| v.1 == "*") {
        h.push_str(&fr.polygon(w, color(*c), "none", 0.0));
    }
    h.push_str(&fr.close(&format!(
        "all cameras after alignment{}",
        ""
    )));

    Ok(())
}

/// View polygons and overlaps per class.
fn view_polygons(con: &Connection, c: &Ctx, h: &mut String) -> R<()> {
    // view polygons and overlaps per class
    let overlaps: Vec<(String, i64, i64, String, f64)> =
        query_rows(con, "SELECT class, cam_a, cam_b, polygon_to_wkt(polygon), area_m2 FROM view_overlaps ORDER BY class, cam_a, cam_b", |r| {
            Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?))
        })?;
    let views = queries::views(con)?;
    h.push_str("<h2>View polygons and overlaps per class</h2><p>P<sup>k</sup> per camera (outline, camera colour) and the pairwise overlaps P<sup>k∩l</sup> (grey fill), in the common frame.</p>");
    h.push_str(&svg::legend(&c.cameras));
    let all_view_pts = views.iter().flat_map(|v| svg::rings(&v.2).into_iter().flatten());
    let frv = Frame::fit(all_view_pts, svg::PLOT_W);
    for class in c.classes.iter().map(String::as_str).chain(std::iter::once("*")) {
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

    Ok(())
}

/// Tracks per class and camera (table 4.1/4.3) and Cayley tables (4.4/4.5).
fn track_counts(con: &Connection, c: &Ctx, h: &mut String) -> R<()> {
    let xi = c.xi;
    // Table 4.1 style: tracks per class and camera, (*) with >= xi points in an overlap
    let counts: Vec<(String, i64, i64, i64)> = query_rows(
        con,
        "WITH t AS (SELECT camera, track_id, class, traj FROM merge_tracks),
              inside AS (
                SELECT t.camera, t.track_id, t.class,
                       max(traj_points_inside(t.traj, o.polygon)) AS best
                FROM t LEFT JOIN view_overlaps o ON o.class = t.class AND (o.cam_a = t.camera OR o.cam_b = t.camera) AND o.area_m2 > 0
                GROUP BY ALL)
         SELECT class, camera, count(*), count(*) FILTER (WHERE best >= calibrated('merge_min_points'))
         FROM inside GROUP BY ALL ORDER BY class, camera",
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
    )?;
    let mut rows = Vec::new();
    for class in &c.classes {
        let mut row = vec![class.clone()];
        let (mut a, mut b) = (0, 0);
        for &c in &c.cameras {
            let x = counts.iter().find(|q| &q.0 == class && q.1 == c).map_or((0, 0), |q| (q.2, q.3));
            row.push(format!("{} ({})", x.0, x.1));
            a += x.0;
            b += x.1;
        }
        row.push(format!("{a} ({b})"));
        rows.push(row);
    }
    let mut total = vec!["Total".to_string()];
    for &c in c.cameras.iter() {
        let x: (i64, i64) = counts.iter().filter(|q| q.1 == c).fold((0, 0), |s, q| (s.0 + q.2, s.1 + q.3));
        total.push(format!("{} ({})", x.0, x.1));
    }
    let x: (i64, i64) = counts.iter().fold((0, 0), |s, q| (s.0 + q.2, s.1 + q.3));
    total.push(format!("{} ({})", x.0, x.1));
    rows.push(total);
    let mut head = vec!["class".to_string()];
    head.extend(c.cameras.iter().map(|c| format!("camera {c} (*)")));
    head.push("total (*)".into());
    let _ = write!(
        h,
        "<h2>Tracks per class and camera (cf. [PA20] tables 4.1/4.3)</h2><p>Tracks after cleaning and linking of broken tracks; (*) tracks with at least ξ = {xi} points in an overlap with another camera (the most that can be matched).</p>{}",
        table(&head, &rows)
    );

    // Cayley tables per class (tables 4.4/4.5)
    let cay: Vec<(String, i64, i64, i64)> = query_rows(
        con,
        "SELECT t.class, t.camera, CASE WHEN o.cam_a = t.camera THEN o.cam_b ELSE o.cam_a END AS other,
                count(*) FILTER (WHERE traj_points_inside(t.traj, o.polygon) >= calibrated('merge_min_points'))
         FROM merge_tracks t JOIN view_overlaps o ON o.class = t.class AND (o.cam_a = t.camera OR o.cam_b = t.camera)
         GROUP BY ALL",
        |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
    )?;
    let _ = write!(h, "<h2>Cayley tables: tracks with at least ξ points in each overlap (cf. [PA20] tables 4.4/4.5)</h2><p>Row k, column l: camera k's tracks with ≥ {xi} points in P<sup>k∩l</sup>; the diagonal is all of camera k's tracks.</p>");
    for class in &c.classes {
        let mut rows = Vec::new();
        for &k in &c.cameras {
            let mut row = vec![format!("P{k}")];
            for &l in &c.cameras {
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
        head.extend(c.cameras.iter().map(|c| format!("P{c}")));
        h.push_str(&table(&head, &rows));
    }

    Ok(())
}

/// Accepted links per camera pair (4.2) and road users per camera set (4.6).
fn matches(con: &Connection, c: &Ctx, h: &mut String) -> R<()> {
    // matched pairs per camera pair and class (table 4.2 style), merged road users per camera set (4.6)
    let links: Vec<(String, String, i64)> = query_rows(
        con,
        "SELECT t.camera::VARCHAR || '–' || u.camera::VARCHAR AS pair, t.class, count(*)
         FROM merge_links m JOIN merge_groups ga ON ga.uid = m.uid_a JOIN merge_groups gb ON gb.uid = m.uid_b
         JOIN merge_tracks t ON t.uid = m.uid_a JOIN merge_tracks u ON u.uid = m.uid_b
         WHERE ga.road_user = gb.road_user AND m.kind <> 'reach' GROUP BY ALL ORDER BY pair",
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
        let mut col_tot = vec![0i64; c.classes.len() + 1];
        for k in keys {
            let mut row = vec![k.clone()];
            let mut tot = 0;
            for (i, class) in c.classes.iter().enumerate() {
                let v = data.iter().find(|d| &d.0 == k && &d.1 == class).map_or(0, |d| d.2);
                row.push(v.to_string());
                tot += v;
                col_tot[i] += v;
            }
            col_tot[c.classes.len()] += tot;
            row.push(tot.to_string());
            rows.push(row);
        }
        let mut last = vec!["Total".to_string()];
        last.extend(col_tot.iter().map(|v| v.to_string()));
        rows.push(last);
        let mut head = vec![label.to_string()];
        head.extend(c.classes.iter().cloned());
        head.push("total".into());
        table(&head, &rows)
    };
    let eta: f64 = con.query_row("SELECT getvariable('merge_eta')::DOUBLE", [], |r| r.get(0))?;
    let _ = write!(
        h,
        "<h2>Matches and merged road users (cf. [PA20] tables 4.2/4.6)</h2><p>Accepted links (LCSS similarity ≥ η̄ = {eta}, one-to-one per camera pair, consistent road users) per camera pair:</p>{}<p>Road users after merging, by the set of cameras that saw them (no duplicates: every track belongs to exactly one road user):</p>{}",
        pivot(&links, "camera pair"),
        pivot(&sets, "cameras")
    );

    Ok(())
}

/// Up to six merged road users with their sources, chosen for variety (class, cameras, length).
fn sample_merges(con: &Connection, c: &Ctx, h: &mut String) -> R<()> {
    // sample merges
    let samples: Vec<(i64, String)> = query_rows(
        con,
        "WITH m AS (SELECT road_user, class, len(list_distinct([s.camera FOR s IN sources])) AS n_cams, traj_length_m(traj) AS len_m
                    FROM merged WHERE n_tracks > 1),
              -- variety: the longest road user of every (class, camera count), then round-robin over classes
              best AS (SELECT *, row_number() OVER (PARTITION BY class, n_cams ORDER BY len_m DESC, road_user) AS k FROM m QUALIFY k = 1)
         SELECT road_user, class FROM best
         QUALIFY row_number() OVER (PARTITION BY class ORDER BY n_cams DESC) <= 2
         ORDER BY row_number() OVER (PARTITION BY class ORDER BY n_cams DESC), class LIMIT 6",
        |r| Ok((r.get(0)?, r.get(1)?)),
    )?;
    h.push_str("<h2>Sample merges</h2><p>Source tracks in the common frame (camera colours, dashed) and the merged trajectory (black): the longest road user of each class and number of cameras.</p>");
    h.push_str(&svg::legend(&c.cameras));
    for (ru, class) in samples {
        // (camera, track, points)
        type Source = (i64, i64, Vec<(f64, f64)>);
        let src: Vec<Source> = query_rows(
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
        let fr = Frame::fit(src.iter().flat_map(|s| s.2.iter().copied()).chain(merged.iter().copied()), svg::PLOT_W);
        h.push_str(&fr.open(&format!("road user {ru}")));
        for (c, _, pts) in &src {
            h.push_str(&fr.line(pts, color(*c), 2.5, true));
        }
        h.push_str(&fr.line(&merged, "#000", 1.0, false));
        let names: Vec<String> = src.iter().map(|s| format!("{}:{}", s.0, s.1)).collect();
        h.push_str(&fr.close(&format!("road user {ru} ({class}) from camera:track {}", names.join(", "))));
    }

    Ok(())
}

/// Route patterns.
fn clusters(con: &Connection, _: &Ctx, h: &mut String) -> R<()> {
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
        "<h2>Route patterns</h2><p>Agglomerative clustering (average linkage on 1 − LCSS S1, [Buz04]) of camera {cam}'s tracks \
         (sql/stages/cluster.sql), in that camera's frame. Each plot: the tracks of the eight largest clusters of a class, one colour per cluster \
         (grey: tracks in smaller clusters or none).</p>{}",
        table(&["class", "clusters", "tracks in a cluster", "tracks"].map(String::from), &cl)
    );
    // (class, rank of its cluster by size (0: not among the 8 largest), points)
    type Routed = (String, i64, Vec<(f64, f64)>);
    let tracks: Vec<Routed> = query_rows(
        con,
        "WITH sizes AS (SELECT class, cluster, row_number() OVER (PARTITION BY class ORDER BY count(*) DESC, cluster) AS rank
                        FROM cluster_assign WHERE cluster > 0 GROUP BY class, cluster)
         SELECT t.class, CASE WHEN s.rank <= 8 THEN s.rank ELSE 0 END AS rank, t.traj
         FROM cluster_tracks t JOIN cluster_assign a USING (class, track_id) LEFT JOIN sizes s USING (class, cluster)
         QUALIFY row_number() OVER (PARTITION BY t.class ORDER BY hash(t.track_id)) <= 600
         ORDER BY t.class, rank = 0 DESC, rank DESC",
        |r| {
            let l: duckdb::types::Value = r.get(2)?;
            Ok((r.get(0)?, r.get(1)?, value_xy(&l)))
        },
    )?;
    let mut classes: Vec<&str> = tracks.iter().map(|t| t.0.as_str()).collect();
    classes.dedup();
    for class in classes {
        let mine: Vec<&Routed> = tracks.iter().filter(|t| t.0 == class).collect();
        let fr = Frame::fit(mine.iter().flat_map(|t| t.2.iter().copied()), svg::PLOT_W);
        h.push_str(&fr.open(&format!("route patterns, {class}")));
        for t in &mine {
            let (col, w) = if t.1 == 0 { ("#c8c8c8", 0.8) } else { (color(t.1 - 1), 1.2) };
            h.push_str(&fr.line(&t.2, col, w, false));
        }
        h.push_str(&fr.close(&format!("{class}: route patterns of camera {cam}")));
    }
    Ok(())
}

/// The parameters the run used (`pipeline_params`).
fn parameters(con: &Connection, _: &Ctx, h: &mut String) -> R<()> {
    let rows: Vec<Vec<String>> = query_rows(con, "SELECT name, value, stage, description FROM pipeline_params", |r| {
        Ok(vec![r.get::<_, String>(0)?, r.get::<_, String>(1)?, r.get::<_, String>(2)?, r.get::<_, String>(3)?])
    })?;
    let _ = write!(h, "<h2>Parameters</h2><p>Declared in src/app/params.rs; set with <code>--param name=value</code>.</p>{}", table(&["name", "value", "stage", "description"].map(String::from), &rows));
    Ok(())
}
