//! A camera change as people read it: which camera (the one every changed pair shares), and a
//! sentence per changed pair, for the day's warning, the state and the site's index page.

use serde::{Deserialize, Serialize};

/// One changed camera pair of a day's check (sql/archive_check.sql), or a camera the
/// calibration never saw (`kind` "new camera", `camera_moving` its name).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Change {
    pub kind: String,
    pub camera_fixed: Option<String>,
    pub camera_moving: Option<String>,
    #[serde(default)]
    pub pairs: Option<i64>,
    #[serde(default)]
    pub expected_pairs: Option<f64>,
    #[serde(default)]
    pub turned_deg: Option<f64>,
    #[serde(default)]
    pub moved_m: Option<f64>,
    #[serde(default)]
    pub clock_s: Option<f64>,
    #[serde(default)]
    pub z: Option<f64>,
}

/// What the state's `changes` holds for a day with changes: the camera they are put on, and each pair.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Changes {
    pub camera: Option<String>,
    pub pairs: Vec<Change>,
}

/// A number as Python prints it (1.0, 0.25, None): the messages read the same whichever host wrote them.
pub fn num(v: Option<f64>) -> String {
    match v {
        None => "None".into(),
        Some(x) if x.is_finite() && x.fract() == 0.0 && x.abs() < 1e16 => format!("{x:.1}"),
        Some(x) => format!("{x}"),
    }
}

/// The camera every moved or lost pair has in common, when only one does (with two cameras the
/// pair says which two; with three or more, the unchanged pairs `cleared` clear the others).
pub fn which_camera(changes: &[Change], cleared: &[(String, String)]) -> Option<String> {
    let moved: Vec<&Change> = changes.iter().filter(|c| c.kind == "moved" || c.kind == "lost").collect();
    let first = moved.first()?;
    let mut common: Vec<String> = [&first.camera_fixed, &first.camera_moving].iter().filter_map(|c| c.as_ref().cloned()).collect();
    common.dedup();
    common.retain(|c| moved.iter().all(|m| m.camera_fixed.as_ref() == Some(c) || m.camera_moving.as_ref() == Some(c)));
    if common.len() == 1 {
        return common.pop();
    }
    let rest: Vec<String> = common.into_iter().filter(|c| !cleared.iter().any(|(a, b)| a == c || b == c)).collect();
    (rest.len() == 1).then(|| rest[0].clone())
}

/// "camera X", or the pair's two, or "a camera".
pub fn who(camera: Option<&str>, changes: &[Change]) -> String {
    if let Some(c) = camera {
        return format!("camera {c}");
    }
    let mut pairs: Vec<(String, String)> = changes
        .iter()
        .filter(|c| c.kind == "moved" || c.kind == "lost")
        .map(|c| (c.camera_fixed.clone().unwrap_or_default(), c.camera_moving.clone().unwrap_or_default()))
        .collect();
    pairs.sort();
    pairs.dedup();
    if pairs.len() == 1 {
        format!("camera {} or {}", pairs[0].0, pairs[0].1)
    } else {
        "a camera".into()
    }
}

/// One pair's change in words.
pub fn describe(c: &Change) -> String {
    let f = c.camera_fixed.as_deref().unwrap_or("None");
    let m = c.camera_moving.as_deref().unwrap_or("None");
    match c.kind.as_str() {
        "new camera" => format!("camera {m} is new"),
        "lost" => format!(
            "cameras {f}-{m}: {} matches where {} were expected",
            c.pairs.map(|p| p.to_string()).unwrap_or("None".into()),
            num(c.expected_pairs)
        ),
        _ => format!(
            "cameras {f}-{m}: moved {} m, turned {} deg, clock {} s ({} standard errors)",
            num(c.moved_m),
            num(c.turned_deg),
            num(c.clock_s),
            num(c.z)
        ),
    }
}

/// The day's warning of a camera change (in its warnings and report.html).
pub fn note(site: &str, date: &str, camera: Option<&str>, changes: &[Change]) -> String {
    let summary: Vec<String> = changes.iter().map(describe).collect();
    format!("camera change on {date} at site {site}: {} ({}); registered again from this day", who(camera, changes), summary.join("; "))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn moved(a: &str, b: &str) -> Change {
        Change { kind: "moved".into(), camera_fixed: Some(a.into()), camera_moving: Some(b.into()), moved_m: Some(1.0), z: Some(5.7), ..Default::default() }
    }

    #[test]
    fn the_camera_is_the_common_one() {
        assert_eq!(which_camera(&[moved("1", "2"), moved("2", "3")], &[]), Some("2".into()));
        assert_eq!(which_camera(&[moved("1", "2")], &[("1".into(), "3".into())]), Some("2".into()));
        assert_eq!(which_camera(&[moved("1", "2")], &[]), None);
        assert_eq!(who(None, &[moved("1", "2")]), "camera 1 or 2");
        assert_eq!(describe(&moved("1", "2")), "cameras 1-2: moved 1.0 m, turned None deg, clock None s (5.7 standard errors)");
    }
}
