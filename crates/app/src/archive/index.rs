//! `reports/site=S/index.html`: a site's days, their counts, failures and camera changes.

use super::change::{describe, who, Changes};
use super::plan::StateRow;

/// `s` safe in HTML text and attributes (as Python's `html.escape`).
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&#x27;")
}

/// The page of site `site` from its state rows (in date order).
pub fn site_page(site: &str, rows: &[&StateRow]) -> String {
    let failed = rows.iter().filter(|r| r.status != "ok").count();
    let made = rows.iter().filter(|r| r.calibration_made.unwrap_or(false)).count();
    let mut lines = vec![
        format!("<!doctype html><meta charset=utf-8><title>trajdb archive: site {}</title>", escape(site)),
        "<style>body{font-family:sans-serif;margin:2em}td,th{padding:2px 8px;text-align:right}td.l,th.l{text-align:left}</style>".to_string(),
        format!("<h1>Site {}</h1><p>{} days; {failed} failed; {made} calibrations.</p>", escape(site), rows.len()),
        "<table><tr><th class=l>date</th><th class=l>status</th><th>cameras</th><th>points</th><th>road users</th><th>matches</th>\
         <th class=l>calibration</th><th class=l>camera changes and errors</th></tr>"
            .to_string(),
    ];
    let n = |v: Option<i64>| v.filter(|x| *x != 0).map(|x| x.to_string()).unwrap_or_default();
    for r in rows {
        let mut note = String::new();
        if let Some(ch) = r.changes.as_deref().filter(|c| *c != "[]").and_then(|c| serde_json::from_str::<Changes>(c).ok()) {
            note = format!("{}: {}", who(ch.camera.as_deref(), &ch.pairs), ch.pairs.iter().map(describe).collect::<Vec<_>>().join("; "));
        }
        if let Some(e) = r.error.as_deref().filter(|e| !e.is_empty()) {
            note = e.to_string();
        }
        let d = escape(&r.date);
        let link = if r.status == "ok" { format!("<a href='date={d}/report.html'>{d}</a>") } else { d };
        lines.push(format!(
            "<tr><td class=l>{link}</td><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=l>{}{}</td><td class=l>{}</td></tr>",
            escape(&r.status),
            n(r.cameras),
            n(r.points),
            n(r.road_users),
            n(r.matches),
            escape(r.calibration_out.as_deref().unwrap_or("")),
            if r.calibration_made.unwrap_or(false) { " (made)" } else { "" },
            escape(&note)
        ));
    }
    lines.push("</table>".into());
    lines.join("\n")
}
