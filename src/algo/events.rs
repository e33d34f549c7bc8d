//! Track events within one camera: broken, split and merged tracks (Zhao et al., section III.A),
//! found from track endpoints.
//!
//! A track that starts or ends in the interior of the scene (farther than `inset` metres inside
//! the camera's view polygon, when one is given) is suspicious: objects enter and leave at the
//! margins. For an interior end of track `a` and an interior start of track `b` with
//! `0 <= gap = b.t0 - a.t1 <= max_gap`, `b` is *near* `a` when `b`'s first point lies within
//! `max_dist` metres of where `a` would be after `gap` seconds at its final velocity (a
//! constant-velocity prediction; the paper says only "near", and a moving object covers
//! distance during the gap). Then, with S(a) the starts near a's end and E(b) the ends near b's
//! start (the paper's three rules):
//! * **broken** `a -> b`: S(a) = {b} and E(b) = {a} (one-to-one, no overlap in time);
//! * **split** `a -> b_i`: |S(a)| >= 2 (one track ends, several start near its end);
//! * **merge** `a_i -> b`: |E(b)| >= 2 (several end near where one starts).
//!
//! # Complexity
//! O(n log n) to sort the starts by time, plus O(c) for c (end, start) pairs inside the time
//! window.

use crate::algo::region::Region;
use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub enum EventError {
    Param(&'static str, f64),
    /// 1-based index, field name.
    NotFinite { index: usize, field: &'static str },
    Reversed { index: usize },
}

impl fmt::Display for EventError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EventError::Param(name, v) => write!(f, "{name} must be >= 0 and finite, got {v}"),
            EventError::NotFinite { index, field } => write!(f, "tracks[{index}].{field} must be finite"),
            EventError::Reversed { index } => write!(f, "tracks[{index}] ends before it starts (t1 < t0)"),
        }
    }
}
impl std::error::Error for EventError {}

/// A track reduced to its two endpoints and the velocity at each.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Endpoints {
    pub id: i64,
    pub t0: f64,
    pub x0: f64,
    pub y0: f64,
    pub t1: f64,
    pub x1: f64,
    pub y1: f64,
    pub vx1: f64,
    pub vy1: f64,
}

/// Validated thresholds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventParams {
    pub max_gap: f64,
    pub max_dist: f64,
}

impl EventParams {
    pub fn new(max_gap: f64, max_dist: f64) -> Result<Self, EventError> {
        if !(max_gap >= 0.0 && max_gap.is_finite()) {
            return Err(EventError::Param("max_gap", max_gap));
        }
        if !(max_dist >= 0.0 && max_dist.is_finite()) {
            return Err(EventError::Param("max_dist", max_dist));
        }
        Ok(EventParams { max_gap, max_dist })
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventKind {
    Broken,
    Split,
    Merge,
}

impl EventKind {
    pub fn as_str(self) -> &'static str {
        match self {
            EventKind::Broken => "broken",
            EventKind::Split => "split",
            EventKind::Merge => "merge",
        }
    }
}

/// One event edge `from -> to` (the earlier track to the later one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    pub kind: EventKind,
    pub from: i64,
    pub to: i64,
    pub gap: f64,
    pub dist: f64,
}

/// The events among `tracks` (see module docs). `interior` is the view polygon already shrunk
/// by the inset (`None`: every endpoint counts as interior). Sorted by (from, to, kind).
pub fn events(tracks: &[Endpoints], interior: Option<&Region>, p: &EventParams) -> Result<Vec<Event>, EventError> {
    for (k, t) in tracks.iter().enumerate() {
        for (name, v) in [("t0", t.t0), ("x0", t.x0), ("y0", t.y0), ("t1", t.t1), ("x1", t.x1), ("y1", t.y1), ("vx1", t.vx1), ("vy1", t.vy1)] {
            if !v.is_finite() {
                return Err(EventError::NotFinite { index: k + 1, field: name });
            }
        }
        if t.t1 < t.t0 {
            return Err(EventError::Reversed { index: k + 1 });
        }
    }
    let inside = |x: f64, y: f64| interior.is_none_or(|r| r.contains(x, y));
    let mut starts: Vec<usize> = (0..tracks.len()).filter(|&k| inside(tracks[k].x0, tracks[k].y0)).collect();
    starts.sort_by(|&a, &b| tracks[a].t0.total_cmp(&tracks[b].t0).then(tracks[a].id.cmp(&tracks[b].id)));
    let start_t: Vec<f64> = starts.iter().map(|&k| tracks[k].t0).collect();
    // (end index, start index, gap, dist)
    let mut near: Vec<(usize, usize, f64, f64)> = Vec::new();
    for (ka, a) in tracks.iter().enumerate() {
        if !inside(a.x1, a.y1) {
            continue;
        }
        let lo = start_t.partition_point(|&t| t < a.t1);
        for &kb in &starts[lo..] {
            let b = &tracks[kb];
            let gap = b.t0 - a.t1;
            if gap > p.max_gap {
                break;
            }
            if kb == ka {
                continue;
            }
            let (px, py) = (a.x1 + a.vx1 * gap, a.y1 + a.vy1 * gap);
            let dist = ((b.x0 - px).powi(2) + (b.y0 - py).powi(2)).sqrt();
            if dist <= p.max_dist {
                near.push((ka, kb, gap, dist));
            }
        }
    }
    let mut n_starts_near_end = vec![0usize; tracks.len()];
    let mut n_ends_near_start = vec![0usize; tracks.len()];
    for &(a, b, _, _) in &near {
        n_starts_near_end[a] += 1;
        n_ends_near_start[b] += 1;
    }
    let mut out = Vec::new();
    for &(a, b, gap, dist) in &near {
        let (sa, eb) = (n_starts_near_end[a], n_ends_near_start[b]);
        let mut push = |kind| out.push(Event { kind, from: tracks[a].id, to: tracks[b].id, gap, dist });
        if sa == 1 && eb == 1 {
            push(EventKind::Broken);
        }
        if sa >= 2 {
            push(EventKind::Split);
        }
        if eb >= 2 {
            push(EventKind::Merge);
        }
    }
    out.sort_by(|p, q| p.from.cmp(&q.from).then(p.to.cmp(&q.to)).then((p.kind as u8).cmp(&(q.kind as u8))));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tr(id: i64, t0: f64, x0: f64, t1: f64, x1: f64, y: f64) -> Endpoints {
        let v = (x1 - x0) / (t1 - t0).max(1e-9);
        Endpoints { id, t0, x0, y0: y, t1, x1, y1: y, vx1: v, vy1: 0.0 }
    }

    #[test]
    fn broken_split_merge() {
        let p = EventParams::new(2.0, 1.0).unwrap();
        // 1 runs x 0..10 (t 0..10, 1 m/s) and is broken; 2 resumes at t 11.5, x 11.6
        let a = tr(1, 0.0, 0.0, 10.0, 10.0, 0.0);
        let b = tr(2, 11.5, 11.6, 20.0, 20.0, 0.0);
        let ev = events(&[a, b], None, &p).unwrap();
        assert_eq!(ev.len(), 1);
        assert_eq!((ev[0].kind, ev[0].from, ev[0].to), (EventKind::Broken, 1, 2));
        assert!((ev[0].dist - 0.1).abs() < 1e-9);
        // a split: 3 and 4 start near 1's end
        let c = tr(3, 10.5, 10.4, 20.0, 20.0, 0.3);
        let d = tr(4, 10.2, 10.3, 20.0, 20.0, -0.3);
        let ev = events(&[a, c, d], None, &p).unwrap();
        assert_eq!(ev.iter().map(|e| (e.kind, e.to)).collect::<Vec<_>>(), vec![(EventKind::Split, 3), (EventKind::Split, 4)]);
        // a merge: 5 and 6 end near where 7 starts
        let e5 = tr(5, 0.0, 0.0, 10.0, 10.0, 0.3);
        let e6 = tr(6, 0.0, 0.0, 10.0, 10.0, -0.3);
        let g7 = tr(7, 10.5, 10.5, 20.0, 20.0, 0.0);
        let ev = events(&[e5, e6, g7], None, &p).unwrap();
        assert_eq!(ev.iter().map(|e| (e.kind, e.from)).collect::<Vec<_>>(), vec![(EventKind::Merge, 5), (EventKind::Merge, 6)]);
        // too far in time or space: nothing
        assert!(events(&[a, tr(8, 13.0, 13.0, 20.0, 20.0, 0.0)], None, &p).unwrap().is_empty());
        assert!(events(&[a, tr(9, 10.5, 10.5, 20.0, 20.0, 5.0)], None, &p).unwrap().is_empty());
    }

    #[test]
    fn margins_are_not_events() {
        let p = EventParams::new(2.0, 1.0).unwrap();
        let a = tr(1, 0.0, 0.0, 10.0, 10.0, 0.0);
        let b = tr(2, 11.0, 11.0, 20.0, 20.0, 0.0);
        // interior = x in [2, 8]: a ends at x 10, on the margin
        let r = Region::from_wkt("POLYGON ((2 -5, 8 -5, 8 5, 2 5, 2 -5))").unwrap();
        assert!(events(&[a, b], Some(&r), &p).unwrap().is_empty());
        let r2 = Region::from_wkt("POLYGON ((2 -5, 18 -5, 18 5, 2 5, 2 -5))").unwrap();
        assert_eq!(events(&[a, b], Some(&r2), &p).unwrap().len(), 1);
    }

    #[test]
    fn bad_input() {
        assert!(EventParams::new(-1.0, 1.0).is_err());
        assert!(EventParams::new(1.0, f64::NAN).is_err());
        let p = EventParams::new(1.0, 1.0).unwrap();
        let mut a = tr(1, 0.0, 0.0, 1.0, 1.0, 0.0);
        a.vx1 = f64::NAN;
        assert_eq!(events(&[a], None, &p).unwrap_err(), EventError::NotFinite { index: 1, field: "vx1" });
        let b = Endpoints { t1: -1.0, ..tr(2, 0.0, 0.0, 1.0, 1.0, 0.0) };
        assert_eq!(events(&[b], None, &p).unwrap_err(), EventError::Reversed { index: 1 });
        assert!(events(&[], None, &p).unwrap().is_empty());
    }
}
