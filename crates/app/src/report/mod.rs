//! The QA report of the pipeline (`report.html`, one self-contained file with inline SVG). It
//! opens with the headline (road users per class over time, the cameras' alignment in plain
//! words, warnings and what needs a look), speeds per class and per-camera quality; then
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
mod study;
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
    // the headline first (issue 29 §5): what was found and how far to trust it
    summary(&d, &c, &mut h)?;
    // the study (issue 39 §8): the site, movements, counts with the peak hour, speeds, near misses
    study::site_map(&d, &c, &mut h)?;
    study::movements(&d, &c, &mut h)?;
    study::counts(&d, &c, &mut h)?;
    speeds(&d, &mut h)?;
    study::speed_movements(&d, &c, &mut h)?;
    study::near_misses(&d, &c, &mut h)?;
    camera_quality(&d, &mut h)?;
    transforms(&d, &c, &mut h)?;
    calibration(&d, &c, &mut h)?;
    points(&d, &c, &mut h)?;
    view_polygons(&d, &c, &mut h)?;
    track_counts(&d, &c, &mut h)?;
    matches(&d, &c, &mut h)?;
    sample_merges(&d, &c, &mut h)?;
    clusters(&d, &c, &mut h)?;
    stage_times(&d, &mut h)?;
    parameters(&d, &c, &mut h)?;
    h.push_str(html::GLOSSARY);
    h.push_str(html::page_end());
    Ok(h)
}

/// What every section needs: the cameras, the classes, ξ (merge_min_points), η̄, the clustered
/// camera and the sampling step of the point plots.
struct Ctx {
    cameras: Vec<i64>,
    /// (the stages' number, the input's camera id as text): every camera is written by its name
    names: Vec<(i64, String)>,
    classes: Vec<String>,
    xi: i64,
    eta: String,
    cluster_camera: String,
    step: i64,
    /// (camera, class, WKT)
    views: Vec<(i64, String, String)>,
}

impl Ctx {
    /// A camera's name: the input's id (the number when the data has no name for it).
    fn name(&self, cam: i64) -> String {
        self.names.iter().find(|n| n.0 == cam).map_or_else(|| cam.to_string(), |n| n.1.clone())
    }

    fn load(d: &Data) -> R<Ctx> {
        let meta = |k: &str| d.meta(k).map(str::to_string).ok_or_else(|| DataError(format!("no meta row '{k}'")));
        let int = |k: &str| meta(k)?.parse::<i64>().map_err(|_| DataError(format!("meta '{k}' is not an integer")));
        Ok(Ctx {
            cameras: d.rows("camera").iter().map(|r| r.i(0)).collect::<R<_>>()?,
            names: d.rows("camera").iter().map(|r| Ok((r.i(0)?, r.s(1)?))).collect::<R<_>>()?,
            classes: d.rows("class").iter().map(|r| r.s(0)).collect::<R<_>>()?,
            xi: int("xi")?,
            eta: meta("eta")?,
            cluster_camera: meta("cluster_camera")?,
            step: int("step")?,
            views: d.rows("view").iter().map(|r| Ok((r.i(0)?, r.s(1)?, r.s(2)?))).collect::<R<_>>()?,
        })
    }
}

/// A number of seconds as minutes:seconds from the start of the recording (`+m:ss`), or hours.
fn clock(s: f64) -> String {
    let s = s.max(0.0).round() as i64;
    if s >= 3600 {
        format!("+{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("+{}:{:02}", s / 60, s % 60)
    }
}

/// The headline: road users per class and over time, the alignment in plain words, warnings and
/// what needs a look.
fn summary(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    // (class, road users, seen by more than one camera, median duration s)
    let users = d
        .rows("users")
        .iter()
        .map(|r| Ok((r.s(0)?, r.i(1)?, r.i(2)?, r.opt_f(3)?)))
        .collect::<R<Vec<_>>>()?;
    let total: i64 = users.iter().map(|u| u.1).sum();
    let multi: i64 = users.iter().map(|u| u.2).sum();
    let span = d.meta("span_s").and_then(|v| v.parse::<f64>().ok());
    let per_class: Vec<String> = users.iter().map(|u| format!("{} {}", u.1, u.0)).collect();
    h.push_str("<h2>Summary</h2>");
    let _ = write!(
        h,
        "<p><b>{total} road users</b>{}{} ({multi} seen by more than one camera), from {} camera{}.</p>",
        if per_class.is_empty() {
            String::new()
        } else {
            format!(": {}", per_class.join(", "))
        },
        span.map_or(String::new(), |s| format!(" in {:.1} minutes of recording", s / 60.0)),
        c.cameras.len(),
        if c.cameras.len() == 1 { "" } else { "s" }
    );
    // road users per class and time bin (by the time each was first seen)
    let bins = d
        .rows("users_bin")
        .iter()
        .map(|r| Ok((r.i(0)?, r.s(1)?, r.i(2)?)))
        .collect::<R<Vec<(i64, String, i64)>>>()?;
    if let (Some(bin_s), false) = (d.meta("bin_s").and_then(|v| v.parse::<f64>().ok()), bins.is_empty()) {
        let classes: Vec<&String> = users.iter().map(|u| &u.0).collect();
        let last = bins.iter().map(|b| b.0).max().unwrap_or(0);
        let mut rows = Vec::new();
        for b in 0..=last {
            let mut row = vec![format!("{} – {}", clock(b as f64 * bin_s), clock((b + 1) as f64 * bin_s))];
            let mut tot = 0;
            for class in &classes {
                let v = bins.iter().find(|x| x.0 == b && &&x.1 == class).map_or(0, |x| x.2);
                tot += v;
                row.push(v.to_string());
            }
            row.push(tot.to_string());
            rows.push(row);
        }
        let mut head = vec!["first seen (from the start)".to_string()];
        head.extend(classes.iter().map(|c| c.to_string()));
        head.push("all".into());
        let _ = write!(
            h,
            "<p>Road users per class by the time they were first seen ({:.0}-minute bins, the reference camera's clock):</p>{}",
            bin_s / 60.0,
            table(&head, &rows)
        );
    }

    // the alignment in plain words
    let tf = d
        .rows("transform")
        .iter()
        .map(|r| Ok((r.s(0)?, r.s(1)?, r.f(2)?, r.f(3)?, r.f(4)?, r.f(7)?)))
        .collect::<R<Vec<_>>>()?;
    let pairs = d.rows("pair").iter().map(|r| Ok((r.s(0)?, r.s(1)?, r.f(2)?, r.s(4)?))).collect::<R<Vec<_>>>()?;
    let unaligned = d.rows("unaligned").iter().map(|r| r.s(0)).collect::<R<Vec<String>>>()?;
    let mut items = Vec::new();
    if c.cameras.len() > 1 {
        let reference = tf.iter().find(|t| t.0 == t.1).map(|t| t.0.clone());
        items.push(format!(
            "<b>{} of {} cameras in one frame</b>{}.",
            tf.len(),
            c.cameras.len(),
            // (the names are the input's: escaped, as these lines carry markup)
            reference.as_ref().map_or(String::new(), |r| format!(
                ": camera {}'s frame and clock are the reference of every output",
                html::esc(r)
            ))
        ));
        for (cam, reference, theta, tx, ty, off_ms) in tf.iter().filter(|t| t.0 != t.1) {
            let resid = pairs.iter().find(|p| (&p.0 == cam && &p.1 == reference) || (&p.1 == cam && &p.0 == reference));
            let (cam, reference) = (html::esc(cam), html::esc(reference));
            items.push(format!(
                "Camera {cam}: turned {theta:.1}° and shifted {:.1} m onto camera {reference}; its clock runs {} camera {reference}'s{}.",
                tx.hypot(*ty),
                if off_ms.abs() < 0.05 {
                    "with".to_string()
                } else {
                    format!("{:.1} ms {}", off_ms.abs(), if *off_ms > 0.0 { "ahead of" } else { "behind" })
                },
                resid.map_or(String::new(), |p| format!(
                    "; the same road user seen by both lies {:.2} m apart (1 σ per axis, both cameras' noise included; from {})",
                    p.2, p.3
                ))
            ));
        }
    }
    let warnings = d.rows("warning").iter().map(|r| r.s(0)).collect::<R<Vec<String>>>()?;
    // what needs a look: unaligned cameras, a camera pair whose matched road users lie more
    // than half a metre apart, a camera none of whose tracks was matched while others were
    let mut look: Vec<String> = Vec::new();
    if !unaligned.is_empty() {
        look.push(format!(
            "cameras {} are not aligned with the others: their road users are their own",
            unaligned.join(", ")
        ));
    }
    for p in pairs.iter().filter(|p| p.2 > 0.5) {
        look.push(format!(
            "cameras {} and {}: the same road user lies {:.2} m apart (1 σ per axis); check the alignment below",
            p.0, p.1, p.2
        ));
    }
    // approaches found in the data that cannot be right: most vehicles in and out by one (issue 39)
    if let Some(share) = d.meta("same_approach_share").and_then(|v| v.parse::<f64>().ok()).filter(|v| *v > 0.5) {
        look.push(format!(
            "{:.0}% of the vehicles with a known movement enter and leave by the same approach: the approaches found in the data are \
             probably wrong for this site; draw gates (movements(gates := ...), docs/analysis.md)",
            100.0 * share
        ));
    }
    // road users that are probably one counted twice (issue 39): not near misses
    let dups = d.rows("dup").len();
    if dups > 0 {
        look.push(format!(
            "{dups} pair{} of road users {} probably one road user counted twice (same class, closer than two bodies can be over their common time): \
             not counted as near misses; listed under Movements and near misses",
            if dups == 1 { "" } else { "s" },
            if dups == 1 { "is" } else { "are" }
        ));
    }
    let camq = d.rows("camq").iter().map(|r| Ok((r.s(0)?, r.i(1)?, r.i(6)?))).collect::<R<Vec<_>>>()?;
    if camq.iter().any(|q| q.2 > 0) {
        for q in camq.iter().filter(|q| q.2 == 0 && q.1 > 0) {
            look.push(format!("camera {}: none of its {} tracks was matched to another camera", q.0, q.1));
        }
    }
    if !items.is_empty() {
        h.push_str("<p>Cameras:</p><ul>");
        for i in &items {
            let _ = write!(h, "<li>{i}</li>");
        }
        h.push_str("</ul>");
    }
    let _ = write!(h, "<p>Warnings: {}</p>", if warnings.is_empty() { "none.".to_string() } else { String::new() });
    if !warnings.is_empty() {
        h.push_str("<ul>");
        for w in &warnings {
            let _ = write!(h, "<li>{}</li>", html::esc(w));
        }
        h.push_str("</ul>");
    }
    let _ = write!(
        h,
        "<p>Needs a look: {}</p>",
        if look.is_empty() { "nothing found.".to_string() } else { String::new() }
    );
    if !look.is_empty() {
        h.push_str("<ul>");
        for w in &look {
            let _ = write!(h, "<li>{}</li>", html::esc(w));
        }
        h.push_str("</ul>");
    }
    Ok(())
}

/// Speeds per class: the road users' mean speeds and the spot speeds of the fused paths.
fn speeds(d: &Data, h: &mut String) -> R<()> {
    let kmh = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.1}", v * 3.6));
    let rows = d
        .rows("speed")
        .iter()
        .map(|r| {
            Ok(vec![
                r.s(0)?,
                r.i(1)?.to_string(),
                kmh(r.opt_f(2)?),
                kmh(r.opt_f(3)?),
                kmh(r.opt_f(4)?),
                kmh(r.opt_f(5)?),
                kmh(r.opt_f(6)?),
                kmh(r.opt_f(7)?),
                kmh(r.opt_f(8)?),
                r.i(9)?.to_string(),
            ])
        })
        .collect::<R<Vec<_>>>()?;
    let _ = write!(
        h,
        "<h2>Speeds per class</h2><p>In km/h. Mean speed: each road user's length_m / duration_s (those seen for at least 1 s), its 15th, 50th and 85th percentiles over the road users. \
         Spot speed: every point of the fused paths (traj_speeds, one per 0.1 s step), its percentiles and maximum. Stationary road users (they never moved: parked cars, \
         traj_stationary) are left out of both and counted apart.</p>{}",
        table(&["class", "road users", "mean p15 km/h", "mean p50 km/h", "mean p85 km/h", "spot p50 km/h", "spot p85 km/h", "spot p95 km/h", "spot max km/h", "stationary (left out)"].map(String::from), &rows)
    );
    Ok(())
}

/// Per-camera quality: tracks, breaks linked, matches, noise, alignment.
fn camera_quality(d: &Data, h: &mut String) -> R<()> {
    let rows = d
        .rows("camq")
        .iter()
        .map(|r| {
            Ok(vec![
                r.s(0)?,
                r.i(1)?.to_string(),
                r.i(2)?.to_string(),
                r.opt_f(3)?.map_or("-".into(), |v| format!("{v:.3}")),
                r.opt_f(4)?.map_or("-".into(), |v| format!("{v:.3}")),
                r.i(5)?.to_string(),
                r.i(6)?.to_string(),
                r.i(7)?.to_string(),
                r.opt_s(8)?.unwrap_or_else(|| "not aligned".into()),
                r.opt_f(9)?.map_or("-".into(), |v| format!("{v:+.1}")),
                r.opt_f(10)?.map_or("-".into(), |v| format!("{v:+.1}")),
            ])
        })
        .collect::<R<Vec<_>>>()?;
    let pairs = d
        .rows("pair")
        .iter()
        .map(|r| Ok(vec![format!("{}–{}", r.s(0)?, r.s(1)?), format!("{:.3}", r.f(2)?), r.s(3)?, r.s(4)?]))
        .collect::<R<Vec<_>>>()?;
    let _ = write!(
        h,
        "<h2>Per-camera quality</h2><p>Tracks: the camera's original track ids (links.csv); breaks linked: tracks joined to an earlier piece of the same road user within the camera; \
         matched: tracks linked to another camera's (matches.csv); period and noise σ (per axis) as calibration measured them; clock offset and drift against the reference camera.</p>{}\
         <p>Residuals per camera pair: how far apart the matched tracks of the two cameras lie under the final alignment (1 σ per axis, both cameras' noise included), over how many point pairs.</p>{}",
        table(
            &["camera", "tracks", "real points", "period s", "noise σ m", "breaks linked", "matched", "road users", "reference", "clock offset ms", "drift ppm"].map(String::from),
            &rows
        ),
        table(&["cameras", "residual σ m", "point pairs", "from"].map(String::from), &pairs)
    );
    Ok(())
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
                r.s(0)?,
                r.s(1)?,
                format!("{:.3}", r.f(2)?),
                format!("{:.3}", r.f(3)?),
                format!("{:.3}", r.f(4)?),
                r.i(5)?.to_string(),
                r.opt_f(6)?.map_or("-".into(), |v| format!("{v:.0}")),
                format!("{:+.1}", r.f(7)?),
            ])
        })
        .collect::<R<Vec<_>>>()?;
    let unaligned = d.rows("unaligned").iter().map(|r| r.s(0)).collect::<R<Vec<String>>>()?;
    let _ = write!(
        h,
        "<h2>Camera alignment</h2><p>Each camera's transform into the reference camera's frame (sql/stages/align.sql).{}</p>{}",
        if unaligned.is_empty() { String::new() } else { format!(" <b>Not aligned (no consistent track pairs): cameras {}.</b>", unaligned.join(", ")) },
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
        if step > 1 { format!("One real point in {step}. ") } else { String::new() }, svg::legend(&c.names));
    for &cam in &c.cameras {
        let mine: Vec<(f64, f64)> = pts.iter().filter(|p| p.0 == cam).map(|p| (p.1, p.2)).collect();
        let fr = Frame::fit(mine.iter().copied(), svg::PLOT_W);
        let name = c.name(cam);
        h.push_str(&fr.open(&format!("camera {name}, local frame")));
        h.push_str(&fr.dots(&mine, color(cam), 1.6));
        h.push_str(&fr.close(&format!("camera {name} before alignment (its own frame)")));
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
    h.push_str(&svg::legend(&c.names));
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
        let areas: Vec<String> = overlaps.iter().filter(|o| o.0 == class).map(|o| format!("{}∩{} {:.0} m²", c.name(o.1), c.name(o.2), o.4)).collect();
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
    head.extend(c.cameras.iter().map(|&k| format!("camera {} (*)", c.name(k))));
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
            let mut row = vec![format!("P {}", c.name(k))];
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
        head.extend(c.cameras.iter().map(|&k| format!("P {}", c.name(k))));
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
    // (road user, camera, "camera:track" in the input's ids, points)
    type Source = (i64, i64, String, Vec<(f64, f64)>);
    let sources = d.rows("sample_source").iter().map(|r| Ok((r.i(0)?, r.i(1)?, r.s(2)?, r.xy(3)?))).collect::<R<Vec<Source>>>()?;
    let merged = d.rows("sample_merged").iter().map(|r| Ok((r.i(0)?, r.xy(1)?))).collect::<R<Vec<(i64, Vec<(f64, f64)>)>>>()?;
    h.push_str("<h2>Sample merges</h2><p>Source tracks in the common frame (camera colours, dashed) and the merged trajectory (black): the longest road user of each class and number of cameras.</p>");
    h.push_str(&svg::legend(&c.names));
    for (ru, class) in samples {
        let src: Vec<&Source> = sources.iter().filter(|s| s.0 == ru).collect();
        let merged: &[(f64, f64)] = merged.iter().find(|m| m.0 == ru).map_or(&[], |m| &m.1);
        let fr = Frame::fit(src.iter().flat_map(|s| s.3.iter().copied()).chain(merged.iter().copied()), svg::PLOT_W);
        h.push_str(&fr.open(&format!("road user {ru}")));
        for (_, cam, _, pts) in &src {
            h.push_str(&fr.line(pts, color(*cam), 2.5, true));
        }
        h.push_str(&fr.line(merged, "#000", 1.0, false));
        let names: Vec<String> = src.iter().map(|s| s.2.clone()).collect();
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
    let cam = &html::esc(&c.cluster_camera);
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
        h.push_str(&fr.close(&format!("{class}: route patterns of camera {}", c.cluster_camera)));
    }
    Ok(())
}

/// The parameters the run used (`pipeline_params`).
fn parameters(d: &Data, _: &Ctx, h: &mut String) -> R<()> {
    let rows = d.rows("param").iter().map(|r| Ok(vec![r.s(0)?, r.s(1)?, r.s(2)?, r.s(3)?])).collect::<R<Vec<_>>>()?;
    let _ = write!(h, "<h2>Parameters</h2><p>Declared in crates/app/src/params.rs; set with <code>--param name=value</code>.</p>{}", table(&["name", "value", "stage", "description"].map(String::from), &rows));
    Ok(())
}
