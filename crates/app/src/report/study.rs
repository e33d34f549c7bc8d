//! The study's sections of the report (issue 39 §8): what a client reads first. The site map
//! (merged paths by class, the cameras' views, the approaches), the movement diagram and table,
//! counts per 15 minutes with the peak hour and its factor, speeds per movement, and the conflict
//! map with the PET / TTC distributions. Every number comes with a confidence line: how many of
//! its road users were matched across cameras, joined across a break, or flagged.
//!
//! The data are sql/report.sql's rows `site_path`, `approach`, `movement`, `flow`, `conf`,
//! `speed_mov`, `near`, `conflict`, `dup` and the `meta` keys `flow_t0`, `flow_t1`, `clock`.

use super::data::{Data, R};
use super::html::{esc, table};
use super::svg::{self, color, Frame};
use super::{clock, Ctx};
use std::fmt::Write as _;
use trajdb_algo::associate::Kind;
use trajdb_algo::peak_hour::{peak_hour, PeakHour};

/// Class colours (the camera colours are the other palette).
const CLASS_PALETTE: [&str; 8] = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"];

fn class_color(c: &Ctx, class: &str) -> &'static str {
    let i = c.classes.iter().position(|k| k == class).unwrap_or(c.classes.len());
    CLASS_PALETTE[i % CLASS_PALETTE.len()]
}

fn class_legend(c: &Ctx, classes: &[&str]) -> String {
    let items: Vec<String> = classes
        .iter()
        .map(|k| format!("<span class=\"key\"><span class=\"sw\" style=\"background:{}\"></span>{}</span>", class_color(c, k), esc(k)))
        .collect();
    format!("<p class=\"legend\">{}</p>", items.join(" "))
}

fn is_vehicle(class: &str) -> bool {
    !matches!(Kind::of(class), Kind::Pedestrian)
}

/// The confidence line of a number (rows `conf`: topic, road users, seen by more than one
/// camera, joined across a break within a camera, flagged as probably one counted twice).
fn confidence(d: &Data, topic: &str, what: &str) -> R<String> {
    let Some(r) = d.rows("conf").iter().find(|r| r.s(0).ok().as_deref() == Some(topic)) else {
        return Ok(String::new());
    };
    let (n, multi, joined, flagged) = (r.i(1)?, r.i(2)?, r.i(3)?, r.i(4)?);
    if n == 0 {
        return Ok(String::new());
    }
    let pct = |k: i64| format!("{:.0} %", 100.0 * k as f64 / n as f64);
    Ok(format!(
        "<p class=\"conf\"><b>Confidence</b> ({what}: {n}): {multi} ({}) seen by more than one camera and matched across them; \
         {joined} ({}) joined across a break within one camera; {flagged} flagged as probably one road user counted twice{}.</p>",
        pct(multi),
        pct(joined),
        if flagged > 0 { " (see Needs a look)" } else { "" }
    ))
}

/// An approach found in the data: name, mean bearing, sector, centre, least radius.
struct Approach {
    name: String,
    bearing: f64,
    lo: f64,
    hi: f64,
    cx: f64,
    cy: f64,
    r_min: f64,
    n_in: i64,
    n_out: i64,
}

fn approaches(d: &Data) -> R<Vec<Approach>> {
    d.rows("approach")
        .iter()
        .map(|r| {
            Ok(Approach {
                name: r.s(0)?,
                bearing: r.f(1)?,
                lo: r.f(2)?,
                hi: r.f(3)?,
                cx: r.f(4)?,
                cy: r.f(5)?,
                r_min: r.f(6)?,
                n_in: r.i(7)?,
                n_out: r.i(8)?,
            })
        })
        .collect()
}

/// A gate drawn by the analyst (parameter report_gates): approach, x1, y1, x2, y2.
type Gate = (String, f64, f64, f64, f64);

fn gates(d: &Data) -> R<Vec<Gate>> {
    d.rows("gate").iter().map(|r| Ok((r.s(0)?, r.f(1)?, r.f(2)?, r.f(3)?, r.f(4)?))).collect()
}

/// Were the approaches drawn (gates), not found in the data?
fn drawn(d: &Data) -> bool {
    d.meta("approaches_from") == Some("gates")
}

/// Every approach's name and bearing (degrees) for the movement diagram: the approaches found
/// in the data, or the gates' midpoints seen from the centroid of all of them.
fn bearings(d: &Data) -> R<Vec<(String, f64)>> {
    if !drawn(d) {
        return Ok(approaches(d)?.into_iter().map(|a| (a.name, a.bearing)).collect());
    }
    let g = gates(d)?;
    let mut names: Vec<&String> = g.iter().map(|x| &x.0).collect();
    names.sort();
    names.dedup();
    let mid = |name: &str| -> (f64, f64) {
        let mine: Vec<&Gate> = g.iter().filter(|x| x.0 == name).collect();
        let n = mine.len().max(1) as f64;
        (mine.iter().map(|x| (x.1 + x.3) / 2.0).sum::<f64>() / n, mine.iter().map(|x| (x.2 + x.4) / 2.0).sum::<f64>() / n)
    };
    let mids: Vec<(f64, f64)> = names.iter().map(|n| mid(n)).collect();
    let k = mids.len().max(1) as f64;
    let (cx, cy) = (mids.iter().map(|m| m.0).sum::<f64>() / k, mids.iter().map(|m| m.1).sum::<f64>() / k);
    Ok(names.iter().zip(&mids).map(|(n, m)| ((*n).clone(), (m.1 - cy).atan2(m.0 - cx).to_degrees())).collect())
}

/// (class, stationary, path) of the site map's sample of road users.
type SitePath = (String, bool, Vec<(f64, f64)>);

fn site_paths(d: &Data) -> R<Vec<SitePath>> {
    d.rows("site_path").iter().map(|r| Ok((r.s(0)?, r.s(1)? == "true", r.xy(2)?))).collect()
}

/// The map's frame: the views (all classes), the paths and the gates drawn.
fn site_frame(c: &Ctx, paths: &[SitePath], gates: &[Gate], w: f64) -> Frame {
    let views = c.views.iter().filter(|v| v.1 == "*").flat_map(|v| svg::rings(&v.2).into_iter().flatten());
    let ends = gates.iter().flat_map(|g| [(g.1, g.2), (g.3, g.4)]);
    Frame::fit(views.chain(paths.iter().flat_map(|p| p.2.iter().copied())).chain(ends), w)
}

/// The views (outlined, camera colours) and the paths (class colours, thin), for both maps.
fn site_background(c: &Ctx, fr: &Frame, paths: &[SitePath], grey: bool) -> String {
    let mut s = String::new();
    // dashed: the views are the cameras', not a class's
    s.push_str("<g stroke-dasharray=\"6 4\">");
    for (cam, _, w) in c.views.iter().filter(|v| v.1 == "*") {
        s.push_str(&fr.polygon(w, color(*cam), color(*cam), 0.04));
    }
    s.push_str("</g>");
    s.push_str(&format!("<g stroke-opacity=\"{}\">", if grey { 0.25 } else { 0.45 }));
    for (class, still, p) in paths {
        if !*still && p.len() >= 2 {
            s.push_str(&fr.line(p, if grey { "#888" } else { class_color(c, class) }, 0.8, false));
        }
    }
    s.push_str("</g>");
    let still: Vec<(f64, f64)> = paths.iter().filter(|p| p.1).filter_map(|p| p.2.first().copied()).collect();
    if !still.is_empty() && !grey {
        s.push_str(&fr.dots(&still, "#222", 4.0));
    }
    s
}

/// The site map: the merged paths on the site, coloured by class, with the cameras' views and
/// the approaches found in the data (their sectors from the site's centre).
pub fn site_map(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    let paths = site_paths(d)?;
    let ap = approaches(d)?;
    h.push_str("<h2>Site map</h2>");
    if paths.is_empty() {
        h.push_str("<p>No road users.</p>");
        return Ok(());
    }
    let mut classes: Vec<&str> = c.classes.iter().map(String::as_str).filter(|k| paths.iter().any(|p| p.0 == *k)).collect();
    classes.dedup();
    let _ = write!(
        h,
        "<p>The merged paths of {} road users{} in the common frame (metres, the reference camera's axes), coloured by class; parked road users \
         (stationary) as black dots; the cameras' views outlined in their colours; the approaches found in the data (approaches(): where \
         vehicles enter and leave, named by compass point in the frame's axes) as grey sectors from the site's centre (+), or the gates \
         you drew (report_gates) as black lines. The views are dashed.</p>{}{}",
        paths.len(),
        if paths.len() >= 1500 { " (a sample)" } else { "" },
        class_legend(c, &classes),
        svg::legend(&c.names)
    );
    let g = gates(d)?;
    let fr = site_frame(c, &paths, &g, 760.0);
    h.push_str("<div id=\"site-map\">");
    h.push_str(&fr.open("site map"));
    h.push_str(&site_background(c, &fr, &paths, false));
    if let Some(a0) = ap.first() {
        let (x0, x1, y0, y1) = fr.bounds();
        // how far the frame reaches from the centre along a bearing (the sectors stay inside it)
        let edge = |b: f64| -> f64 {
            let (s, c) = b.sin_cos();
            let tx = if c > 1e-9 { (x1 - a0.cx) / c } else if c < -1e-9 { (x0 - a0.cx) / c } else { f64::INFINITY };
            let ty = if s > 1e-9 { (y1 - a0.cy) / s } else if s < -1e-9 { (y0 - a0.cy) / s } else { f64::INFINITY };
            tx.min(ty).max(0.0)
        };
        for a in &ap {
            let reach = 0.97 * edge(a.bearing.to_radians()).min(edge(a.lo.to_radians())).min(edge(a.hi.to_radians()));
            let span = (a.hi - a.lo).rem_euclid(360.0);
            let pts: Vec<(f64, f64)> = (0..=16)
                .map(|i| (a.lo + span * i as f64 / 16.0).to_radians())
                .map(|b| (a.cx + reach * b.cos(), a.cy + reach * b.sin()))
                .collect();
            let mut ring = vec![(a.cx + a.r_min * a.lo.to_radians().cos(), a.cy + a.r_min * a.lo.to_radians().sin())];
            ring.extend(pts);
            ring.push((a.cx + a.r_min * a.hi.to_radians().cos(), a.cy + a.r_min * a.hi.to_radians().sin()));
            let wkt = format!(
                "POLYGON (({}, {} {}))",
                ring.iter().map(|p| format!("{} {}", p.0, p.1)).collect::<Vec<_>>().join(", "),
                ring[0].0,
                ring[0].1
            );
            h.push_str(&fr.polygon(&wkt, "#555", "#999", 0.12));
            let b = a.bearing.to_radians();
            let r = 0.85 * reach;
            // anchored towards the centre, so that the label stays inside the frame
            let anchor = if b.cos() > 0.3 { "end" } else if b.cos() < -0.3 { "start" } else { "middle" };
            h.push_str(&fr.text(a.cx + r * b.cos(), a.cy + r * b.sin(), &format!("{} (in {}, out {})", a.name, a.n_in, a.n_out), anchor, 13.0));
        }
        h.push_str(&fr.text(a0.cx, a0.cy, "+", "middle", 16.0));
    }
    for (name, x1, y1, x2, y2) in &g {
        h.push_str(&fr.line(&[(*x1, *y1), (*x2, *y2)], "#000", 3.5, false));
        h.push_str(&fr.text((x1 + x2) / 2.0, (y1 + y2) / 2.0, name, "middle", 14.0));
    }
    h.push_str(&fr.close(&if drawn(d) {
        format!("Site map: {} road users, {} gates drawn by the analyst (report_gates)", paths.len(), g.len())
    } else {
        format!(
            "Site map: {} road users, {} approaches found in the data{}",
            paths.len(),
            ap.len(),
            if ap.is_empty() { " (none: draw gates, docs/analysis.md)" } else { "" }
        )
    }));
    h.push_str("</div>");
    Ok(())
}

/// A point of the movement diagram (pixels, y down): on the circle of radius `r` at the
/// approach's bearing, moved `w` to the right of the direction of travel (in: towards the
/// centre, out: away from it; right-hand traffic).
fn lane_point(bearing_deg: f64, r: f64, w: f64, inbound: bool) -> (f64, f64) {
    let (uy, ux) = bearing_deg.to_radians().sin_cos();
    // world (y up): right of d = (dy, -dx); d = -u inbound, u outbound
    let (nx, ny) = if inbound { (-uy, ux) } else { (uy, -ux) };
    let (x, y) = (r * ux + w * nx, r * uy + w * ny);
    (DIAGRAM_CX + x, 170.0 - y)
}

/// The movement diagram's centre (pixels): room either side for the approaches' names.
const DIAGRAM_CX: f64 = 230.0;

/// An approach's name for the diagram: at most 14 characters (the full name is in the table
/// and the arrows' titles).
fn short_name(name: &str) -> String {
    if name.chars().count() <= 14 {
        name.to_string()
    } else {
        name.chars().take(13).collect::<String>() + "…"
    }
}

/// The movement diagram and table: arrows from the entry approach to the exit approach, width by
/// the count, one diagram per class (the four largest), then the table.
pub fn movements(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    let ap = bearings(d)?;
    // (from, to, movement, class, n)
    let all = d.rows("movement").iter().map(|r| Ok((r.s(0)?, r.s(1)?, r.s(2)?, r.s(3)?, r.i(4)?))).collect::<R<Vec<_>>>()?;
    // turning movements are the vehicles': a pedestrian crossing one arm enters and leaves by it
    // (no "u-turn"); pedestrians are counted by the counts below and by crossings()
    let mv: Vec<_> = all.iter().filter(|m| is_vehicle(&m.3)).cloned().collect();
    let peds: i64 = all.iter().filter(|m| !is_vehicle(&m.3)).map(|m| m.4).sum();
    h.push_str("<h2>Turning movements</h2>");
    if mv.is_empty() {
        h.push_str(if drawn(d) {
            "<p>No vehicle crossed two of your gates (report_gates).</p>"
        } else if ap.is_empty() {
            "<p>No vehicle crosses the site from one approach to another (no approaches found: draw gates, parameter report_gates).</p>"
        } else {
            "<p>No vehicle crosses the site from one approach to another (the approaches on the site map are where road users enter and \
             leave; without vehicles they are every road user's).</p>"
        });
        return Ok(());
    }
    let _ = write!(
        h,
        "<p>Vehicles per movement over the whole recording, from the entry approach to the exit approach. {} Arrows drive on the right; the \
         width is the count.</p>{}",
        if drawn(d) {
            format!(
                "The approaches are <b>the gates you drew</b> (parameter report_gates{}): the entry is the gate crossed first, the exit the \
                 gate crossed last.",
                d.meta("gates_source").filter(|g| !g.is_empty()).map_or(String::new(), |g| format!(" = {}", esc(g)))
            )
        } else {
            "The approaches were <b>found in the data</b> (approaches(): the site's centre from where vehicles head, and the bearings at \
             which they enter and leave); to count by your own lines, give gates (parameter report_gates, or movements(gates := ...) in \
             SQL; docs/analysis.md)."
                .to_string()
        },
        confidence(d, "movement", "vehicles with a known movement")?
    );
    let mut classes: Vec<(String, i64)> = Vec::new();
    for m in &mv {
        match classes.iter_mut().find(|k| k.0 == m.3) {
            Some(k) => k.1 += m.4,
            None => classes.push((m.3.clone(), m.4)),
        }
    }
    classes.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let bearing = |name: &str| ap.iter().find(|a| a.0 == name).map(|a| a.1);
    h.push_str("<div id=\"movement-diagram\">");
    for (k, (class, total)) in classes.iter().take(4).enumerate() {
        let col = class_color(c, class);
        let mine: Vec<_> = mv.iter().filter(|m| &m.3 == class).collect();
        let top = mine.iter().map(|m| m.4).max().unwrap_or(1).max(1) as f64;
        let _ = write!(
            h,
            "<figure style=\"max-width:460px\"><svg xmlns=\"http://www.w3.org/2000/svg\" width=\"460\" height=\"340\" viewBox=\"0 0 460 340\" style=\"background:#fff\">\
             <title>movements: {}</title><defs><marker id=\"arrow{k}\" viewBox=\"0 0 10 10\" refX=\"6\" refY=\"5\" markerWidth=\"9\" markerHeight=\"9\" \
             markerUnits=\"userSpaceOnUse\" orient=\"auto\"><path d=\"M0 0L10 5L0 10z\" fill=\"{col}\"/></marker></defs>\
             <circle cx=\"230\" cy=\"170\" r=\"118\" fill=\"none\" stroke=\"#ddd\"/>",
            esc(class)
        );
        for (name, b) in &ap {
            let (u, v) = lane_point(*b, 128.0, 0.0, true);
            // anchored away from the circle, so that a long name runs outward
            let c = b.to_radians().cos();
            let (anchor, u) = if c > 0.35 { ("start", u + 4.0) } else if c < -0.35 { ("end", u - 4.0) } else { ("middle", u) };
            let v = v - 12.0 * b.to_radians().sin().signum() * (c.abs() <= 0.35) as i32 as f64;
            let _ = write!(
                h,
                "<text x=\"{u:.1}\" y=\"{v:.1}\" font-size=\"13\" font-weight=\"bold\" text-anchor=\"{anchor}\" dominant-baseline=\"middle\"><title>{}</title>{}</text>",
                esc(name),
                esc(&short_name(name))
            );
        }
        let mut drawn = 0;
        for m in &mine {
            let (Some(bi), Some(bo)) = (bearing(&m.0), bearing(&m.1)) else { continue };
            let w = 1.0 + 11.0 * m.4 as f64 / top;
            let p0 = lane_point(bi, 118.0, 9.0, true);
            let p1 = lane_point(bo, 118.0, 9.0, false);
            // through the centre for turns and through movements, a loop for a u-turn
            let ctrl = if m.0 == m.1 { lane_point(bi, 50.0, 0.0, true) } else { (DIAGRAM_CX, 170.0) };
            let _ = write!(
                h,
                "<path d=\"M{:.1} {:.1}Q{:.1} {:.1} {:.1} {:.1}\" stroke=\"{col}\" stroke-width=\"{w:.1}\" stroke-opacity=\"0.7\" fill=\"none\" marker-end=\"url(#arrow{k})\"><title>{} → {} {}: {}</title></path>",
                p0.0,
                p0.1,
                ctrl.0,
                ctrl.1,
                p1.0,
                p1.1,
                esc(&m.0),
                esc(&m.1),
                esc(&m.2),
                m.4
            );
            // the count at the arrow's end
            let q = (0.2 * p0.0 + 0.32 * ctrl.0 + 0.48 * p1.0, 0.2 * p0.1 + 0.32 * ctrl.1 + 0.48 * p1.1);
            let _ = write!(
                h,
                "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\" text-anchor=\"middle\" paint-order=\"stroke\" stroke=\"#fff\" stroke-width=\"3\">{}</text>",
                q.0,
                q.1,
                m.4
            );
            drawn += 1;
        }
        let _ = write!(
            h,
            "</svg><figcaption>{}: {total} road users, {drawn} movements</figcaption></figure>",
            esc(class)
        );
    }
    h.push_str("</div>");
    let rows: Vec<Vec<String>> = mv.iter().map(|m| vec![m.0.clone(), m.1.clone(), m.2.clone(), m.3.clone(), m.4.to_string()]).collect();
    h.push_str(&table(&["from", "to", "movement", "class", "road users"].map(String::from), &rows));
    if classes.len() > 4 {
        let _ = write!(h, "<p>The diagrams show the four classes with the most road users; the table has them all.</p>");
    }
    if peds > 0 {
        let _ = write!(
            h,
            "<p>{peds} pedestrians also entered and left by an approach; they are not in this table, since walking across one arm is no turning              movement (movements() in SQL lists them; count them per crosswalk with gates).</p>"
        );
    }
    Ok(())
}

/// A bin's time as the clock reads it: hh:mm on a wall clock (the input's TIMESTAMPs), else
/// +m:ss from the start of the recording.
fn bin_label(b: f64, t0: f64, wall: bool) -> String {
    if wall {
        let s = b.rem_euclid(86400.0).round() as i64;
        format!("{:02}:{:02}", s / 3600, s / 60 % 60)
    } else {
        clock(b - t0)
    }
}

/// Counts per 15 minutes, the peak hour and its factor (AM and PM on a wall clock).
pub fn counts(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    let flow = d.rows("flow").iter().map(|r| Ok((r.f(0)?, r.s(1)?, r.i(2)?))).collect::<R<Vec<(f64, String, i64)>>>()?;
    let num = |k: &str| d.meta(k).and_then(|v| v.parse::<f64>().ok());
    h.push_str("<h2>Counts per 15 minutes and the peak hour</h2>");
    let (Some(t0), Some(t1), Some(b0)) = (num("flow_t0"), num("flow_t1"), flow.iter().map(|f| f.0).reduce(f64::min)) else {
        h.push_str("<p>No road user moved.</p>");
        return Ok(());
    };
    let clock_kind = d.meta("clock").unwrap_or("relative");
    let wall = clock_kind != "relative";
    let last = flow.iter().map(|f| f.0).fold(b0, f64::max);
    let nb = ((last - b0) / 900.0).round() as usize + 1;
    let mut classes: Vec<&str> = c.classes.iter().map(String::as_str).filter(|k| flow.iter().any(|f| f.1 == *k)).collect();
    classes.dedup();
    let vehicles: Vec<&str> = classes.iter().copied().filter(|k| is_vehicle(k)).collect();
    // the peak is of vehicles when there are any (a traffic count), else of every road user
    let counted: Vec<&str> = if vehicles.is_empty() { classes.clone() } else { vehicles.clone() };
    let what = if vehicles.is_empty() { "road users" } else { "vehicles" };
    let cell = |b: usize, class: &str| flow.iter().find(|f| ((f.0 - b0) / 900.0).round() as usize == b && f.1 == class).map_or(0, |f| f.2);
    // a bin is whole when one session of the recording covers it from start to end, but for
    // the session's slack (its ends are known to within the gaps between road users: the 99th
    // percentile gap, at most 90 s), not recorded when none touches it (the recording stopped:
    // recording_gap_s)
    let sessions = d.rows("session").iter().map(|r| Ok((r.f(0)?, r.f(1)?, r.opt_f(2)?.unwrap_or(1.0)))).collect::<R<Vec<(f64, f64, f64)>>>()?;
    let sessions = if sessions.is_empty() { vec![(t0, t1, 1.0)] } else { sessions };
    let span = |b: usize| (b0 + 900.0 * b as f64, b0 + 900.0 * (b + 1) as f64);
    let whole: Vec<bool> = (0..nb).map(|b| sessions.iter().any(|s| span(b).0 >= s.0 - s.2.max(1.0) && span(b).1 <= s.1 + s.2.max(1.0))).collect();
    let recorded: Vec<bool> = (0..nb).map(|b| sessions.iter().any(|s| span(b).0 < s.1 && span(b).1 > s.0)).collect();
    let volume: Vec<f64> = (0..nb).map(|b| counted.iter().map(|k| cell(b, k)).sum::<i64>() as f64).collect();
    let label = |b: usize| bin_label(b0 + 900.0 * b as f64, t0, wall);
    // the peak hours: of the whole day, or of the morning and the afternoon on a wall clock
    let mut peaks: Vec<(&str, PeakHour)> = Vec::new();
    let masked = |keep: &dyn Fn(usize) -> bool| -> Vec<Option<f64>> { (0..nb).map(|b| (whole[b] && keep(b)).then_some(volume[b])).collect() };
    let hour_of = |b: usize| ((b0 + 900.0 * b as f64).rem_euclid(86400.0) / 3600.0) as i64;
    if wall && (0..nb).any(|b| hour_of(b) < 12) && (0..nb).any(|b| hour_of(b) >= 12) {
        // an hour belongs to the half of the day its first bin starts in
        for (name, am) in [("AM", true), ("PM", false)] {
            let v = masked(&|b| (hour_of(b) < 12) == am || (b >= 3 && (hour_of(b - 3) < 12) == am));
            if let Some(p) = peak_hour(&v).filter(|p| (hour_of(p.first) < 12) == am) {
                peaks.push((name, p));
            }
        }
    } else if let Some(p) = peak_hour(&masked(&|_| true)) {
        peaks.push(("", p));
    }
    let _ = write!(
        h,
        "<p>{} that moved, by the quarter hour in which they were first seen ({}). A quarter the recording does not cover whole is marked \
         partial and left out of the peak hour. Peak hour factor PHF = V / (4 · V15): V the peak hour's volume, V15 its busiest quarter \
         (HCM 6th ed., eq. 4-4).</p>",
        if vehicles.is_empty() { "Road users" } else { "Road users (the peak hour: vehicles)" },
        match clock_kind {
            "utc" => "the input's clock, UTC",
            "wall" => "the input's clock",
            _ => "minutes from the start of the recording; the input has no wall clock",
        }
    );
    h.push_str("<div id=\"peak-hour\">");
    if peaks.is_empty() {
        let n_whole = whole.iter().filter(|w| **w).count();
        let _ = write!(
            h,
            "<p><b>No peak hour</b>: the recording covers {n_whole} whole quarter hour{} ({:.0} minutes recorded); a peak hour needs 4 in a row.{}</p>",
            if n_whole == 1 { "" } else { "s" },
            sessions.iter().map(|s| s.1 - s.0).sum::<f64>() / 60.0,
            volume
                .iter()
                .enumerate()
                .filter(|(b, _)| whole[*b])
                // the first of the busiest
                .fold(None, |best: Option<(usize, &f64)>, x| if best.is_none_or(|b| x.1 > b.1) { Some(x) } else { best })
                .map_or(String::new(), |(b, v)| format!(" The busiest whole quarter: {} – {}, {v:.0} {what}.", label(b), label(b + 1)))
        );
    }
    for (name, p) in &peaks {
        let _ = write!(
            h,
            "<p><b>{}Peak hour {} – {}</b>: V = {:.0} {what}, busiest quarter V15 = {:.0}, <b>PHF = {:.0} / (4 × {:.0}) = {:.2}</b>.</p>",
            if name.is_empty() { String::new() } else { format!("{name} ") },
            label(p.first),
            label(p.first + 4),
            p.volume,
            p.max_15,
            p.volume,
            p.max_15,
            p.phf
        );
    }
    let in_peak = |b: usize| peaks.iter().any(|(_, p)| b >= p.first && b < p.first + 4);
    let labels: Vec<String> = (0..nb).map(label).collect();
    let colors: Vec<&str> = (0..nb).map(|b| if !whole[b] { "#c7c7c7" } else if in_peak(b) { "#d62728" } else { "#1f77b4" }).collect();
    if sessions.len() > 1 {
        let _ = write!(
            h,
            "<p>The recording has {} sessions (it stopped for longer than the road is ever empty: recording_gap_s); the quarters between them \
             were not recorded and are left out.</p>",
            sessions.len()
        );
    }
    let every = (50.0 / (560.0 / nb.max(1) as f64).clamp(3.0, 40.0)).ceil() as usize;
    h.push_str(&svg::bars(
        &format!("{what} per 15 minutes (red: the peak hour; grey: a partial quarter)"),
        &labels,
        &volume,
        &colors,
        what,
        every.max(1),
    ));
    h.push_str("</div>");
    h.push_str(&confidence(d, "count", "road users that moved")?);
    // the table: every quarter, per class
    if nb <= 200 {
        let mut head = vec!["quarter from".to_string()];
        head.extend(classes.iter().map(|k| k.to_string()));
        if !vehicles.is_empty() {
            head.push("vehicles".into());
        }
        head.push("all".into());
        let rows: Vec<Vec<String>> = (0..nb)
            .filter(|&b| recorded[b])
            .map(|b| {
                let mut row = vec![format!(
                    "{}{}{}",
                    labels[b],
                    if whole[b] { "" } else { " (partial)" },
                    if in_peak(b) { " (peak)" } else { "" }
                )];
                row.extend(classes.iter().map(|k| cell(b, k).to_string()));
                if !vehicles.is_empty() {
                    row.push(vehicles.iter().map(|k| cell(b, k)).sum::<i64>().to_string());
                }
                row.push(classes.iter().map(|k| cell(b, k)).sum::<i64>().to_string());
                row
            })
            .collect();
        h.push_str(&table(&head, &rows));
    }
    Ok(())
}

/// Speeds per movement: the road users' mean speeds, their 15th, 50th and 85th percentiles and
/// range, as a table and a chart.
pub fn speed_movements(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    // (from, to, movement, class, n, p15, p50, p85, min, max) in m/s
    type Row = (String, String, String, String, i64, f64, f64, f64, f64, f64);
    let rows = d
        .rows("speed_mov")
        .iter()
        .map(|r| Ok((r.s(0)?, r.s(1)?, r.s(2)?, r.s(3)?, r.i(4)?, r.f(5)?, r.f(6)?, r.f(7)?, r.f(8)?, r.f(9)?)))
        .collect::<R<Vec<Row>>>()?;
    // vehicles: a pedestrian's "movement" is the arms it walked by, not a turn
    let rows: Vec<Row> = rows.into_iter().filter(|r| is_vehicle(&r.3)).collect();
    if rows.is_empty() {
        return Ok(());
    }
    let shown: Vec<&Row> = rows.iter().take(24).collect();
    let top = shown.iter().map(|r| r.9 * 3.6).fold(10.0, f64::max);
    let step = if top > 60.0 { 20.0 } else { 10.0 };
    let top = (top / step).ceil() * step;
    let (lw, pw, rh) = (190.0, 420.0, 18.0);
    let ht = 30.0 + rh * shown.len() as f64;
    let x = |kmh: f64| lw + pw * kmh / top;
    let _ = write!(
        h,
        "<h3>Speeds per movement</h3><p>Each vehicle's mean speed (length / duration, km/h; stationary road users left out), per movement \
         and class: the bar spans the 15th to the 85th percentile, the tick is the median, the line the range.</p><div id=\"speed-movements\"><figure style=\"max-width:{:.0}px\">\
         <svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{:.0}\" height=\"{ht:.0}\" viewBox=\"0 0 {:.0} {ht:.0}\" style=\"background:#fff\"><title>speeds per movement</title>",
        lw + pw + 20.0,
        lw + pw + 20.0,
        lw + pw + 20.0
    );
    let mut t = 0.0;
    while t <= top + 1e-9 {
        let _ = write!(
            h,
            "<line x1=\"{0:.1}\" y1=\"4\" x2=\"{0:.1}\" y2=\"{1:.1}\" stroke=\"#eee\"/><text x=\"{0:.1}\" y=\"{2:.1}\" font-size=\"10\" text-anchor=\"middle\">{3}</text>",
            x(t),
            ht - 22.0,
            ht - 10.0,
            t
        );
        t += step;
    }
    for (i, r) in shown.iter().enumerate() {
        let y = 12.0 + rh * i as f64;
        let col = class_color(c, &r.3);
        let _ = write!(
            h,
            "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\" text-anchor=\"end\">{} → {} {}, {} ({})</text>\
             <line x1=\"{:.1}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"{col}\"/>\
             <rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"10\" fill=\"{col}\" fill-opacity=\"0.6\"/>\
             <line x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"#000\" stroke-width=\"2\"/>",
            lw - 6.0,
            y + 4.0,
            esc(&r.0),
            esc(&r.1),
            esc(&r.2),
            esc(&r.3),
            r.4,
            x(r.8 * 3.6),
            x(r.9 * 3.6),
            x(r.5 * 3.6),
            y - 5.0,
            (x(r.7 * 3.6) - x(r.5 * 3.6)).max(1.0),
            x(r.6 * 3.6),
            y - 6.0,
            x(r.6 * 3.6),
            y + 6.0
        );
    }
    let _ = write!(h, "</svg><figcaption>Mean speeds per movement and class, km/h</figcaption></figure></div>");
    let kmh = |v: f64| format!("{:.1}", v * 3.6);
    let cells: Vec<Vec<String>> = rows
        .iter()
        .map(|r| vec![format!("{} → {}", r.0, r.1), r.2.clone(), r.3.clone(), r.4.to_string(), kmh(r.5), kmh(r.6), kmh(r.7)])
        .collect();
    h.push_str(&table(&["movement", "turn", "class", "road users", "p15 km/h", "p50 km/h", "p85 km/h"].map(String::from), &cells));
    Ok(())
}

/// The conflict map (where the closest encounters happened, coloured by kind), the PET and TTC
/// distributions, the table of the closest, and the road users that are probably one.
pub fn near_misses(d: &Data, c: &Ctx, h: &mut String) -> R<()> {
    // (pet, ttc, kind, x, y, class a, class b)
    type Near = (f64, Option<f64>, Option<String>, f64, f64, String, String);
    let near = d
        .rows("near")
        .iter()
        .map(|r| Ok((r.f(0)?, r.opt_f(1)?, r.opt_s(2)?, r.f(3)?, r.f(4)?, r.s(5)?, r.s(6)?)))
        .collect::<R<Vec<Near>>>()?;
    let cells = |section: &str, n: usize| -> R<Vec<Vec<String>>> { d.rows(section).iter().map(|r| (0..n).map(|k| r.opt_s(k).map(Option::unwrap_or_default)).collect::<R<Vec<_>>>()).collect() };
    h.push_str("<h2>Near misses</h2>");
    let _ = write!(
        h,
        "<p>The closest encounters between road users: post-encroachment time (PET, s: how long after the first road user left the point where \
         the paths cross the second arrived) under 3 s, and the time to collision at constant velocity (TTC, s) where they converged \
         (conflicts(), top_conflicts()). Kinds: SSAM's rear-end, lane change and crossing between vehicles only; a pair with a pedestrian is \
         vehicle–pedestrian or pedestrian–pedestrian (conflict_kind). Pairs that are probably one road user counted twice are left out.</p>{}",
        confidence(d, "conflict", "road users in the table below")?
    );
    if near.is_empty() {
        h.push_str("<p>No pair of road users crossed within 3 s.</p>");
    } else {
        const KINDS: [(&str, &str); 6] = [
            ("crossing", "#d62728"),
            ("rear-end", "#ff7f0e"),
            ("lane-change", "#9467bd"),
            ("vehicle-pedestrian", "#1f77b4"),
            ("pedestrian-pedestrian", "#7f7f7f"),
            ("", "#bbbbbb"),
        ];
        let kcol = |k: &Option<String>| KINDS.iter().find(|x| x.0 == k.as_deref().unwrap_or("")).map_or("#bbbbbb", |x| x.1);
        let paths = site_paths(d)?;
        let fr = site_frame(c, &paths, &gates(d)?, 760.0);
        let legend: Vec<String> = KINDS
            .iter()
            .filter_map(|(k, col)| {
                let n = near.iter().filter(|x| x.2.as_deref().unwrap_or("") == *k).count();
                (n > 0).then(|| format!("<span class=\"key\"><span class=\"sw\" style=\"background:{col}\"></span>{} ({n})</span>", if k.is_empty() { "no kind" } else { k }))
            })
            .collect();
        let _ = write!(h, "<p class=\"legend\">{}</p><div id=\"conflict-map\">", legend.join(" "));
        h.push_str(&fr.open("conflict map"));
        h.push_str(&site_background(c, &fr, &paths, true));
        // the most severe drawn last, on top
        for n in near.iter().rev() {
            let r = 2.5 + 5.0 * (1.0 - n.0 / 3.0).clamp(0.0, 1.0);
            let title = format!(
                "{} – {}: PET {:.2} s{}{}",
                n.5,
                n.6,
                n.0,
                n.1.map_or(String::new(), |t| format!(", TTC {t:.2} s")),
                n.2.as_ref().map_or(String::new(), |k| format!(", {k}"))
            );
            h.push_str(&fr.circle(n.3, n.4, r, kcol(&n.2), &title));
        }
        h.push_str(&fr.close(&format!(
            "Conflict map: the {} closest encounters (PET under 3 s), larger for a smaller PET, coloured by kind",
            near.len()
        )));
        h.push_str("</div><div id=\"conflict-distributions\">");
        // PET and TTC in 0.25 s bins over 0-3 s
        for (name, vals) in [
            ("PET", near.iter().map(|n| n.0).collect::<Vec<f64>>()),
            ("TTC", near.iter().filter_map(|n| n.1).filter(|t| *t <= 3.0).collect::<Vec<f64>>()),
        ] {
            let mut hist = [0.0f64; 12];
            for v in &vals {
                hist[((v / 0.25).floor().max(0.0) as usize).min(11)] += 1.0;
            }
            let labels: Vec<String> = (0..12).map(|i| format!("{:.2}", i as f64 * 0.25)).collect();
            h.push_str(&svg::bars(
                &format!("{name} of the {} closest encounters{} (s, 0.25 s bins)", near.len(), if name == "TTC" { " with a TTC under 3 s" } else { "" }),
                &labels,
                &hist,
                &[if name == "PET" { "#d62728" } else { "#ff7f0e" }; 12],
                "pairs",
                2,
            ));
        }
        h.push_str("</div>");
        let conflicts = cells("conflict", 9)?;
        h.push_str(&table(&["road user", "class", "road user", "class", "PET", "kind", "x", "y", "TTC"].map(String::from), &conflicts));
    }
    let count = |k: &str| d.meta(k).and_then(|v| v.parse::<i64>().ok());
    if let (Some(top), Some(same)) = (count("tracks_top_near_misses"), count("tracks_top_same_road_user")) {
        let _ = write!(
            h,
            "<p>Before merging (every camera's track a road user of its own), {same} of the {top} closest encounters (PET under 3 s) were two \
             tracks of one road user (seen by two cameras, or broken in one); merging removed them from this table.</p>"
        );
    }
    let dups = cells("dup", 5)?;
    if !dups.is_empty() {
        h.push_str("<p><b>Probably one road user counted twice</b> (not near misses): two road users of one class whose centres stay closer \
                    over their common time than two bodies can (conflict_probably_one: a pedestrian 0.25 m, a car 1.8 m), the median distance \
                    in m; probably_one() in SQL.</p>");
        h.push_str(&table(&["road user", "road user", "class", "apart (m)", "PET"].map(String::from), &dups));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::data::Data;
    use super::super::Ctx;
    use super::{bin_label, counts, lane_point};

    fn ctx(classes: &[&str]) -> Ctx {
        Ctx {
            cameras: vec![0],
            names: vec![(0, "0".into())],
            classes: classes.iter().map(|c| c.to_string()).collect(),
            xi: 3,
            eta: "0.5".into(),
            cluster_camera: "0".into(),
            step: 1,
            views: Vec::new(),
        }
    }

    /// A day on a wall clock from 07:00 to 19:00: the AM and the PM peak hour, each with its
    /// PHF; pedestrians are counted but not in the vehicles' peak.
    #[test]
    fn am_and_pm_peaks_on_a_wall_clock() {
        let day = 1_700_006_400.0 - 1_700_006_400.0 % 86400.0;
        let mut text = format!("meta\x1fflow_t0\x1f{}\x1emeta\x1fflow_t1\x1f{}\x1emeta\x1fclock\x1fwall", day + 7.0 * 3600.0, day + 19.0 * 3600.0);
        for q in 0..48 {
            let b = day + 7.0 * 3600.0 + 900.0 * q as f64;
            // cars: 10 a quarter; 40, 40, 40, 60 in 07:30-08:30; 30 a quarter in 16:00-17:00
            let cars = match q {
                2..=4 => 40,
                5 => 60,
                36..=39 => 30,
                _ => 10,
            };
            text.push_str(&format!("\x1eflow\x1f{b}\x1fcar\x1f{cars}\x1eflow\x1f{b}\x1fpedestrian\x1f{}", if q == 20 { 500 } else { 1 }));
        }
        let mut h = String::new();
        counts(&Data::parse(&text), &ctx(&["car", "pedestrian"]), &mut h).unwrap();
        assert!(h.contains("<b>AM Peak hour 07:30 – 08:30</b>: V = 180 vehicles, busiest quarter V15 = 60, <b>PHF = 180 / (4 × 60) = 0.75</b>"), "{h}");
        assert!(h.contains("<b>PM Peak hour 16:00 – 17:00</b>: V = 120 vehicles, busiest quarter V15 = 30, <b>PHF = 120 / (4 × 30) = 1.00</b>"), "{h}");
    }

    /// (issue 39, review F1) Two sessions of the same traffic, 07:00:05-08:05:56 and
    /// 16:00:05-17:05:56: three whole quarters each, so no peak hour, and the hours between are
    /// not listed as counted zeros.
    #[test]
    fn sessions_have_no_whole_hour_and_the_gap_is_not_counted() {
        let day = 1_700_006_400.0 - 1_700_006_400.0 % 86400.0;
        let (a0, a1, p0, p1) = (day + 7.0 * 3600.0 + 5.0, day + 8.0 * 3600.0 + 356.0, day + 16.0 * 3600.0 + 5.0, day + 17.0 * 3600.0 + 356.0);
        let mut text = format!("meta\x1fflow_t0\x1f{a0}\x1emeta\x1fflow_t1\x1f{p1}\x1emeta\x1fclock\x1fwall\x1esession\x1f{a0}\x1f{a1}\x1f1\x1esession\x1f{p0}\x1f{p1}\x1f1");
        for start in [day + 7.0 * 3600.0, day + 16.0 * 3600.0] {
            for (q, n) in [200, 190, 200, 200, 60].iter().enumerate() {
                text.push_str(&format!("\x1eflow\x1f{}\x1fcar\x1f{n}", start + 900.0 * q as f64));
            }
        }
        let mut h = String::new();
        counts(&Data::parse(&text), &ctx(&["car"]), &mut h).unwrap();
        assert!(h.contains("<b>No peak hour</b>: the recording covers 6 whole quarter hours"), "{h}");
        assert!(h.contains("The recording has 2 sessions"), "{h}");
        assert!(!h.contains("<th>12:00") && h.contains("<th>16:00 (partial)<") && h.contains("<th>08:00 (partial)<"), "{h}");
        assert!(h.contains("(132 minutes recorded)") && h.contains("The busiest whole quarter: 07:30 – 07:45, 200 vehicles."), "{h}");
        // with the sessions' slack of 10 s (road users a few seconds apart), the quarters 5 s
        // short are whole: the same peak hour and PHF in both sessions
        let mut h = String::new();
        counts(&Data::parse(&text.replace("\x1f1\x1esession", "\x1f10\x1esession").replacen(&format!("{p1}\x1f1"), &format!("{p1}\x1f10"), 1)), &ctx(&["car"]), &mut h).unwrap();
        assert!(h.contains("<b>AM Peak hour 07:00 – 08:00</b>: V = 790 vehicles, busiest quarter V15 = 200, <b>PHF = 790 / (4 × 200) = 0.99</b>"), "{h}");
        assert!(h.contains("<b>PM Peak hour 16:00 – 17:00</b>: V = 790 vehicles, busiest quarter V15 = 200, <b>PHF = 790 / (4 × 200) = 0.99</b>"), "{h}");
    }

    /// A recording shorter than an hour has no peak hour, and says why.
    #[test]
    fn no_peak_hour_in_40_minutes() {
        let text = "meta\x1fflow_t0\x1f100\x1emeta\x1fflow_t1\x1f2500\x1emeta\x1fclock\x1frelative\x1eflow\x1f100\x1fcar\x1f5\x1eflow\x1f1000\x1fcar\x1f7\x1eflow\x1f1900\x1fcar\x1f2";
        let mut h = String::new();
        counts(&Data::parse(text), &ctx(&["car"]), &mut h).unwrap();
        assert!(h.contains("<b>No peak hour</b>: the recording covers 2 whole quarter hours (40 minutes recorded)"), "{h}");
        assert!(h.contains("The busiest whole quarter: +15:00 – +30:00, 7 vehicles."), "{h}");
    }

    #[test]
    fn lanes_keep_to_the_right() {
        // the east approach (bearing 0): entering westward, the right-hand lane is north (up: a
        // smaller pixel y); leaving eastward, south
        let (_, y_in) = lane_point(0.0, 100.0, 10.0, true);
        let (_, y_out) = lane_point(0.0, 100.0, 10.0, false);
        assert!(y_in < 170.0 && y_out > 170.0);
        assert_eq!(super::short_name("East arm (Bahnhofstrasse)"), "East arm (Bah…");
    }

    #[test]
    fn wall_and_relative_labels() {
        assert_eq!(bin_label(1_700_000_100.0 - 1_700_000_100.0 % 900.0, 0.0, true), "22:15");
        assert_eq!(bin_label(900.0, 0.0, false), "+15:00");
    }
}
