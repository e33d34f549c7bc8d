//! The QA report of the pipeline (`report.html`, one self-contained file with inline SVG):
//! each camera's points before alignment (its own frame) and after (the common frame), the view
//! polygons and overlaps per class, sample merges, count tables in the style of the thesis's
//! tables 4.1–4.6, and the parameters used.
//!
//! `sql/report.sql` gathers the data from the pipeline's tables (the same SQL in the `trajdb`
//! binary and in stock DuckDB); [`render`] (SQL: `trajdb_report_html(data)`) only draws it: one
//! function per section, the data from [`data`], the markup from [`html`] and [`svg`]. No DuckDB
//! here, so the loadable extension renders the same page as the binary.

mod data;
mod html;
mod svg;

pub use data::DataError;
use data::{Data, R};
use html::table;
use std::fmt::Write as _;
use svg::{color, Frame};

/// The HTML page from the data text of `sql/report.sql`. O(size of the data).
pub fn render(text: &str) -> Result<String, DataError> {
    let d = Data::parse(text);
    let c = Ctx::load(&d)?;
    let mut h = html::page_start(d.meta("input").unwrap_or("?"));
    stage_times(&d, &mut h)?;
    transforms(&d, &c, &mut h)?;
    calibration(&d, &c, &mut h)?;
    points(&d, &c, &mut h)?;
    view_polygons(&d, &c, &mut h)?;
    track_counts(&d, &c, &mut h)?;
    matches(&d, &c, &mut h)?;
    sample_merges(&d, &c, &mut h)?;
    clusters(&d, &c, &mut h)?;
    parameters(&d, &c, &mut h)?;
    h.push_str(html::GLOSSARY);
    h.push_str(html::page_end());
    Ok(h)
}

/// What every section needs: the cameras, the classes, ξ (merge_min_points), η̄, the clustered
/// camera and the sampling step of the point plots.
struct Ctx {
    cameras: Vec<i64>,
    classes: Vec<String>,
    xi: i64,
    eta: String,
    cluster_camera: String,
    step: i64,
    /// (camera, class, WKT)
    views: Vec<(i64, String, String)>,
}

impl Ctx {
    fn load(d: &Data) -> R<Ctx> {
        let meta = |k: &str| d.meta(k).map(str::to_string).ok_or_else(|| DataError(format!("no meta row '{k}'")));
        let int = |k: &str| meta(k)?.parse::<i64>().map_err(|_| DataError(format!("meta '{k}' is not an integer")));
        Ok(Ctx {
            cameras: d.rows("camera").iter().map(|r| r.i(0)).collect::<R<_>>()?,
            classes: d.rows("class").iter().map(|r| r.s(0)).collect::<R<_>>()?,
            xi: int("xi")?,
            eta: meta("eta")?,
            cluster_camera: meta("cluster_camera")?,
            step: int("step")?,
            views: d.rows("view").iter().map(|r| Ok((r.i(0)?, r.s(1)?, r.s(2)?))).collect::<R<_>>()?,
        })
    }
}

/// Stage times.
fn stage_times(d: &Data, h: &mut String) -> R<()> {
    let rows = d.rows("stage").iter().map(|r| Ok(vec![r.s(0)?, format!("{:.2}", r.f(1)?)])).collect::<R<Vec<_>>>()?;
    let _ = write!(h, "<h2>Stages</h2>{}", table(&["stage".into(), "seconds".into()], &rows));
    Ok(())
}

/// Each camera's transform into the reference frame.
fn transforms(d: &Data, _: &Ctx, h: &mut String) -> R<()> {
    let tf = d
        .rows("transform")
        .iter()
        .map(|r| {
            Ok(vec![
                r.i(0)?.to_string(),
                r.i(1)?.to_string(),
                format!("{:.3}", r.f(2)?),
                format!("{:.3}", r.f(3)?),
                format!("{:.3}", r.f(4)?),
                r.i(5)?.to_string(),
                r.opt_f(6)?.map_or("-".into(), |v| format!("{v:.0}")),
                format!("{:+.1}", r.f(7)?),
            ])
        })
        .collect::<R<Vec<_>>>()?;
    let unaligned = d.rows("unaligned").iter().map(|r| r.i(0)).collect::<R<Vec<i64>>>()?;
    let _ = write!(
        h,
        "<h2>Camera alignment</h2><p>Each camera's transform into the reference camera's frame (sql/stages/align.sql).{}</p>{}",
        if unaligned.is_empty() { String::new() } else { format!(" <b>Not aligned (no consistent track pairs): cameras {unaligned:?}.</b>") },
        table(&["camera", "reference", "rotation °", "tx m", "ty m", "hops", "support (pairs)", "clock offset ms"].map(String::from), &tf)
    );
    Ok(())
}

/// What the pipeline measured from the data and the parameters it derived (calibration.csv).
fn calibration(d: &Data, _: &Ctx, h: &mut String) -> R<()> {
    let rows = d
        .rows("calibration")
        .iter()
        .map(|r| Ok(vec![r.s(0)?, r.s(1)?, r.opt_f(2)?.map_or("-".into(), |v| format!("{v:.4}")), r.s(3)?, r.s(4)?]))
        .collect::<R<Vec<_>>>()?;
    let _ = write!(
        h,
        "<h2>Calibration</h2><p>Measured from the tracks alone (sql/stages/calibrate.sql, sql/stages/align.sql) and the parameters derived from it; \
         <code>--param name=value</code> overrides any of them (shown as <i>given</i>). The same table is calibration.csv.</p>{}",
        table(&["scope", "quantity", "value", "unit", "how"].map(String::from), &rows)
    );
    Ok(())
}

/// Every camera's points before (own frame) and after alignment.
fn points(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    let step = c.step;
    // (camera, local x, local y, aligned x, aligned y)
    type Pt = (i64, f64, f64, Option<f64>, Option<f64>);
    let pts = d.rows("point").iter().map(|r| Ok((r.i(0)?, r.f(1)?, r.f(2)?, r.opt_f(3)?, r.opt_f(4)?))).collect::<R<Vec<Pt>>>()?;
    h.push_str("<h2>Points before and after alignment</h2><p>");
    let _ = write!(h, "{}Before: each camera in its own frame. After: all cameras in the reference frame, with the view polygons (all classes) outlined.</p>{}",
        if step > 1 { format!("One real point in {step}. ") } else { String::new() }, svg::legend(&c.cameras));
    for &cam in &c.cameras {
        let mine: Vec<(f64, f64)> = pts.iter().filter(|p| p.0 == cam).map(|p| (p.1, p.2)).collect();
        let fr = Frame::fit(mine.iter().copied(), svg::PLOT_W);
        h.push_str(&fr.open(&format!("camera {cam}, local frame")));
        h.push_str(&fr.dots(&mine, color(cam), 1.6));
        h.push_str(&fr.close(&format!("camera {cam} before alignment (its own frame)")));
    }
    let aligned: Vec<(i64, f64, f64)> = pts.iter().filter_map(|p| Some((p.0, p.3?, p.4?))).collect();
    let fr = Frame::fit(aligned.iter().map(|p| (p.1, p.2)), 620.0);
    h.push_str(&fr.open("all cameras, common frame"));
    for &cam in &c.cameras {
        let mine: Vec<(f64, f64)> = aligned.iter().filter(|p| p.0 == cam).map(|p| (p.1, p.2)).collect();
        h.push_str(&fr.dots(&mine, color(cam), 1.6));
    }
    for (cam, _, w) in c.views.iter().filter(|v| v.1 == "*") {
        h.push_str(&fr.polygon(w, color(*cam), "none", 0.0));
    }
    h.push_str(&fr.close("all cameras after alignment"));
    Ok(())
}

/// View polygons and overlaps per class.
fn view_polygons(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    let overlaps = d.rows("overlap").iter().map(|r| Ok((r.s(0)?, r.i(1)?, r.i(2)?, r.s(3)?, r.f(4)?))).collect::<R<Vec<(String, i64, i64, String, f64)>>>()?;
    let views = &c.views;
    h.push_str("<h2>View polygons and overlaps per class</h2><p>P<sup>k</sup> per camera (outline, camera colour) and the pairwise overlaps P<sup>k∩l</sup> (grey fill), in the common frame.</p>");
    h.push_str(&svg::legend(&c.cameras));
    let all_view_pts = views.iter().flat_map(|v| svg::rings(&v.2).into_iter().flatten());
    let frv = Frame::fit(all_view_pts, svg::PLOT_W);
    for class in c.classes.iter().map(String::as_str).chain(std::iter::once("*")) {
        h.push_str(&frv.open(class));
        for (_, _, _, w, _) in overlaps.iter().filter(|o| o.0 == class) {
            h.push_str(&frv.polygon(w, "#555", "#888", 0.35));
        }
        for (cam, _, w) in views.iter().filter(|v| v.1 == class) {
            h.push_str(&frv.polygon(w, color(*cam), "none", 0.0));
        }
        let areas: Vec<String> = overlaps.iter().filter(|o| o.0 == class).map(|o| format!("{}∩{} {:.0} m²", o.1, o.2, o.4)).collect();
        h.push_str(&frv.close(&format!("{}: {}", if class == "*" { "all classes" } else { class }, areas.join(", "))));
    }
    Ok(())
}

/// Tracks per class and camera (table 4.1/4.3) and Cayley tables (4.4/4.5).
fn track_counts(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    let xi = c.xi;
    // Table 4.1 style: tracks per class and camera, (*) with >= xi points in an overlap
    let counts = d.rows("count").iter().map(|r| Ok((r.s(0)?, r.i(1)?, r.i(2)?, r.i(3)?))).collect::<R<Vec<(String, i64, i64, i64)>>>()?;
    let mut rows = Vec::new();
    for class in &c.classes {
        let mut row = vec![class.clone()];
        let (mut a, mut b) = (0, 0);
        for &cam in &c.cameras {
            let x = counts.iter().find(|q| &q.0 == class && q.1 == cam).map_or((0, 0), |q| (q.2, q.3));
            row.push(format!("{} ({})", x.0, x.1));
            a += x.0;
            b += x.1;
        }
        row.push(format!("{a} ({b})"));
        rows.push(row);
    }
    let mut total = vec!["Total".to_string()];
    for &cam in c.cameras.iter() {
        let x: (i64, i64) = counts.iter().filter(|q| q.1 == cam).fold((0, 0), |s, q| (s.0 + q.2, s.1 + q.3));
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
    let cay = d.rows("cayley").iter().map(|r| Ok((r.s(0)?, r.i(1)?, r.i(2)?, r.i(3)?))).collect::<R<Vec<(String, i64, i64, i64)>>>()?;
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
fn matches(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    let triple = |section: &str| d.rows(section).iter().map(|r| Ok((r.s(0)?, r.s(1)?, r.i(2)?))).collect::<R<Vec<(String, String, i64)>>>();
    let (links, sets) = (triple("link")?, triple("set")?);
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
    let _ = write!(
        h,
        "<h2>Matches and merged road users (cf. [PA20] tables 4.2/4.6)</h2><p>Accepted links (LCSS similarity ≥ η̄ = {}, one-to-one per camera pair, consistent road users) per camera pair:</p>{}<p>Road users after merging, by the set of cameras that saw them (no duplicates: every track belongs to exactly one road user):</p>{}",
        c.eta,
        pivot(&links, "camera pair"),
        pivot(&sets, "cameras")
    );
    Ok(())
}

/// Up to six merged road users with their sources, chosen for variety (class, cameras, length).
fn sample_merges(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    let samples = d.rows("sample").iter().map(|r| Ok((r.i(0)?, r.s(1)?))).collect::<R<Vec<(i64, String)>>>()?;
    // (road user, camera, track, points)
    type Source = (i64, i64, i64, Vec<(f64, f64)>);
    let sources = d.rows("sample_source").iter().map(|r| Ok((r.i(0)?, r.i(1)?, r.i(2)?, r.xy(3)?))).collect::<R<Vec<Source>>>()?;
    let merged = d.rows("sample_merged").iter().map(|r| Ok((r.i(0)?, r.xy(1)?))).collect::<R<Vec<(i64, Vec<(f64, f64)>)>>>()?;
    h.push_str("<h2>Sample merges</h2><p>Source tracks in the common frame (camera colours, dashed) and the merged trajectory (black): the longest road user of each class and number of cameras.</p>");
    h.push_str(&svg::legend(&c.cameras));
    for (ru, class) in samples {
        let src: Vec<&Source> = sources.iter().filter(|s| s.0 == ru).collect();
        let merged: &[(f64, f64)] = merged.iter().find(|m| m.0 == ru).map_or(&[], |m| &m.1);
        let fr = Frame::fit(src.iter().flat_map(|s| s.3.iter().copied()).chain(merged.iter().copied()), svg::PLOT_W);
        h.push_str(&fr.open(&format!("road user {ru}")));
        for (_, cam, _, pts) in &src {
            h.push_str(&fr.line(pts, color(*cam), 2.5, true));
        }
        h.push_str(&fr.line(merged, "#000", 1.0, false));
        let names: Vec<String> = src.iter().map(|s| format!("{}:{}", s.1, s.2)).collect();
        h.push_str(&fr.close(&format!("road user {ru} ({class}) from camera:track {}", names.join(", "))));
    }
    Ok(())
}

/// Route patterns.
fn clusters(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    let cl = d
        .rows("cluster")
        .iter()
        .map(|r| Ok(vec![r.s(0)?, r.i(1)?.to_string(), r.i(2)?.to_string(), r.i(3)?.to_string()]))
        .collect::<R<Vec<_>>>()?;
    let cam = &c.cluster_camera;
    let _ = write!(
        h,
        "<h2>Route patterns</h2><p>Agglomerative clustering (average linkage on 1 − LCSS S1, [Buz04]) of camera {cam}'s tracks \
         (sql/stages/cluster.sql), in that camera's frame. Each plot: the tracks of the eight largest clusters of a class, one colour per cluster \
         (grey: tracks in smaller clusters or none).</p>{}",
        table(&["class", "clusters", "tracks in a cluster", "tracks"].map(String::from), &cl)
    );
    // (class, rank of its cluster by size (0: not among the 8 largest), points)
    type Routed = (String, i64, Vec<(f64, f64)>);
    let tracks = d.rows("route").iter().map(|r| Ok((r.s(0)?, r.i(1)?, r.xy(2)?))).collect::<R<Vec<Routed>>>()?;
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
fn parameters(d: &Data, _: &Ctx, h: &mut String) -> R<()> {
    let rows = d.rows("param").iter().map(|r| Ok(vec![r.s(0)?, r.s(1)?, r.s(2)?, r.s(3)?])).collect::<R<Vec<_>>>()?;
    let _ = write!(h, "<h2>Parameters</h2><p>Declared in src/app/params.rs; set with <code>--param name=value</code>.</p>{}", table(&["name", "value", "stage", "description"].map(String::from), &rows));
    Ok(())
}
