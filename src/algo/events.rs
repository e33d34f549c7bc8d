//! Track events within one camera: broken, split and merged tracks (Zhao et al., section III.A),
//! found from track endpoints.
//!
//! A track that starts or ends in the interior of the scene (farther than `inset` metres inside
//! the camera's view polygon, when one is given) is suspicious: objects enter and leave at the
//! margins. For an interior end of track `a` and an interior start of track `b` with
//! `0 <= gap = b.t0 - a.t1 <= max_gap`, `b` is *near* `a` when `b`'s first point lies within
//! `max_dist + accel·gap²/2` metres of where `a` would be after `gap` seconds at its final
//! velocity (a constant-velocity prediction, plus what an acceleration of `accel` adds over the
//! gap; the paper says only "near", and a moving object covers distance during the gap). Then, with S(a) the starts near a's end and E(b) the ends near b's
//! start (the paper's three rules):
//! * **broken** `a -> b`: S(a) = {b} and E(b) = {a} (one-to-one, no overlap in time);
//! * **split** `a -> b_i`: |S(a)| >= 2 (one track ends, several start near its end);
//! * **merge** `a_i -> b`: |E(b)| >= 2 (several end near where one starts).
//!
//! # Complexity
//! O(n log n) to sort the starts by time, plus O(c) for c (end, start) pairs inside the time
//! window.

use crate::algo::geometry::region::Region;
use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub enum EventError {
    Param(&'static str, f64),
    Positive(&'static str, f64),
    Threshold(f64),
    /// 1-based index, field name.
    NotFinite { index: usize, field: &'static str },
    Reversed { index: usize },
    /// The starting velocity of a track (1-based) is NaN or infinite.
    NotFiniteStart { index: usize },
    /// Two tracks share an id (it would link a track to itself: "broken 1→1").
    DuplicateId(i64),
}

impl fmt::Display for EventError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EventError::Param(name, v) => write!(f, "{name} must be >= 0 and finite, got {v}"),
            EventError::Positive(name, v) => write!(f, "{name} must be > 0 and finite, got {v}"),
            EventError::Threshold(v) => write!(f, "threshold must be in [0, 1], got {v}"),
            EventError::NotFinite { index, field } => write!(f, "tracks[{index}].{field} must be finite"),
            EventError::Reversed { index } => write!(f, "tracks[{index}] ends before it starts (t1 < t0)"),
            EventError::NotFiniteStart { index } => write!(f, "tracks[{index}].vx0/vy0 must be finite"),
            EventError::DuplicateId(id) => write!(f, "tracks lists id {id} twice (one row per track)"),
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
    /// The acceleration a road user may have had during the gap (m/s²): `b` is near `a` within
    /// `max_dist + accel · gap² / 2` (a car braking at 2 m/s² for a 2 s gap ends 4 m short of
    /// its constant-velocity prediction). 0: the constant-velocity rule alone.
    pub accel: f64,
}

impl EventParams {
    pub fn new(max_gap: f64, max_dist: f64) -> Result<Self, EventError> {
        if !(max_gap >= 0.0 && max_gap.is_finite()) {
            return Err(EventError::Param("max_gap", max_gap));
        }
        if !(max_dist >= 0.0 && max_dist.is_finite()) {
            return Err(EventError::Param("max_dist", max_dist));
        }
        Ok(EventParams { max_gap, max_dist, accel: 0.0 })
    }

    /// With an acceleration allowance (>= 0, finite; see [`EventParams::accel`]).
    pub fn with_accel(self, accel: f64) -> Result<Self, EventError> {
        if !(accel >= 0.0 && accel.is_finite()) {
            return Err(EventError::Param("accel", accel));
        }
        Ok(EventParams { accel, ..self })
    }

    /// The distance within which a start `gap` seconds after an end is near it.
    pub fn radius(&self, gap: f64) -> f64 {
        self.max_dist + 0.5 * self.accel * gap * gap
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
    let mut ids: Vec<i64> = tracks.iter().map(|t| t.id).collect();
    ids.sort_unstable();
    if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
        return Err(EventError::DuplicateId(w[0]));
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
            if dist <= p.radius(gap) {
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

/// Motion at a track's ends: speed (m/s) and heading (rad) at the start and at the end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    pub id: i64,
    pub v0: f64,
    pub h0: f64,
    pub v1: f64,
    pub h1: f64,
}

impl Motion {
    /// Speed and heading from a track's end velocity (`ends.vx1`, `ends.vy1`) and its start
    /// velocity `(vx0, vy0)`.
    pub fn of(ends: &Endpoints, vx0: f64, vy0: f64) -> Motion {
        Motion { id: ends.id, v0: vx0.hypot(vy0), h0: vy0.atan2(vx0), v1: ends.vx1.hypot(ends.vy1), h1: ends.vy1.atan2(ends.vx1) }
    }
}

/// One call for `traj_labels`: `tracks` are the endpoints with the start velocity `(vx0, vy0)`
/// of each track; finds the [`events`] and labels every track with [`labels`]. Returns
/// `(id, label, coherence)` in input order. Errors on NaN / infinite start velocities (checked
/// first) and on everything [`events`] rejects.
pub fn label_tracks(
    tracks: &[(Endpoints, f64, f64)],
    interior: Option<&Region>,
    p: &EventParams,
    lp: &LabelParams,
) -> Result<Vec<(i64, Label, f64)>, EventError> {
    if let Some(k) = tracks.iter().position(|(_, vx0, vy0)| !(vx0.is_finite() && vy0.is_finite())) {
        return Err(EventError::NotFiniteStart { index: k + 1 });
    }
    let ends: Vec<Endpoints> = tracks.iter().map(|t| t.0).collect();
    let ev = events(&ends, interior, p)?;
    let motion: Vec<Motion> = tracks.iter().map(|(e, vx0, vy0)| Motion::of(e, *vx0, *vy0)).collect();
    let l = labels(&motion, &ev, lp);
    Ok(motion.iter().zip(l).map(|(m, (lab, c))| (m.id, lab, c)).collect())
}

/// Motion-coherency parameters of eq. 3–5: the speed / heading differences of fragments of one
/// object are zero-mean Gaussian with σ_s, σ_d; those of different objects with τ_s, τ_d; a set
/// of tracks is coherent when the minimum pairwise posterior is at least `threshold`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelParams {
    pub sigma_speed: f64,
    pub sigma_heading: f64,
    pub tau_speed: f64,
    pub tau_heading: f64,
    pub threshold: f64,
}

impl Default for LabelParams {
    /// σ_s = 0.5 m/s, σ_d = 0.25 rad, τ_s = 3 m/s, τ_d = 1.5 rad, threshold 0.7 (the paper's).
    fn default() -> Self {
        LabelParams { sigma_speed: 0.5, sigma_heading: 0.25, tau_speed: 3.0, tau_heading: 1.5, threshold: 0.7 }
    }
}

impl LabelParams {
    pub fn new(sigma_speed: f64, sigma_heading: f64, tau_speed: f64, tau_heading: f64, threshold: f64) -> Result<Self, EventError> {
        for (name, v) in [("sigma_speed", sigma_speed), ("sigma_heading", sigma_heading), ("tau_speed", tau_speed), ("tau_heading", tau_heading)] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(EventError::Positive(name, v));
            }
        }
        if !(0.0..=1.0).contains(&threshold) {
            return Err(EventError::Threshold(threshold));
        }
        Ok(LabelParams { sigma_speed, sigma_heading, tau_speed, tau_heading, threshold })
    }

    /// Eq. 3 / (eq. 3 + eq. 4): posterior that two motions belong to one object (equal priors).
    pub fn coherence(&self, ds: f64, dh: f64) -> f64 {
        let n = |x: f64, s: f64| (-0.5 * (x / s).powi(2)).exp() / s;
        let yes = n(ds, self.sigma_speed) * n(dh, self.sigma_heading);
        let no = n(ds, self.tau_speed) * n(dh, self.tau_heading);
        if yes + no > 0.0 {
            yes / (yes + no)
        } else {
            0.0
        }
    }
}

/// Trajectory labels of section IV.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Label {
    Object,
    Fragment,
    Group,
}

impl Label {
    pub fn as_str(self) -> &'static str {
        match self {
            Label::Object => "object",
            Label::Fragment => "fragment",
            Label::Group => "group",
        }
    }
}

fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    (a + std::f64::consts::PI).rem_euclid(t) - std::f64::consts::PI
}

/// Labels every track (section IV, motion coherency only): the interaction graph has an edge
/// parent → child for every split (the splitting track → the new ones) and merge (the merged
/// track → the merging ones) event; broken events link pieces of one target and add no edge.
/// For a parent with children c_1..c_k the children are compared pairwise (eq. 5, the
/// minimum of eq. 3 normalised against eq. 4; split children by their starting motion, merging
/// tracks by their final motion): coherent children are fragments of one object (rule a),
/// incoherent ones are objects and the parent a group (rule b); a parent of an object or group
/// is a group (rule d); roots labelled fragment become objects, and every track in no event is
/// an object. Shape coherency (eq. 1–2) needs object extents, which these tracks do not carry,
/// so it is skipped. Returns (label, coherence of the children set the track belongs to, 1 if
/// none) in `tracks` order.
pub fn labels(tracks: &[Motion], events: &[Event], p: &LabelParams) -> Vec<(Label, f64)> {
    use std::collections::HashMap;
    let index: HashMap<i64, usize> = tracks.iter().enumerate().map(|(k, t)| (t.id, k)).collect();
    // parent -> (children, children use start motion?)
    let mut kids: HashMap<usize, (Vec<usize>, bool)> = HashMap::new();
    for e in events {
        let (Some(&a), Some(&b)) = (index.get(&e.from), index.get(&e.to)) else { continue };
        match e.kind {
            EventKind::Split => kids.entry(a).or_insert((Vec::new(), true)).0.push(b),
            EventKind::Merge => kids.entry(b).or_insert((Vec::new(), false)).0.push(a),
            EventKind::Broken => {}
        }
    }
    let mut label: Vec<Option<Label>> = vec![None; tracks.len()];
    let mut coh = vec![1.0f64; tracks.len()];
    let mut parents: Vec<usize> = kids.keys().copied().collect();
    parents.sort_unstable();
    let mut is_child = vec![false; tracks.len()];
    for &par in &parents {
        let (cs, at_start) = &kids[&par];
        let motion = |k: usize| if *at_start { (tracks[k].v0, tracks[k].h0) } else { (tracks[k].v1, tracks[k].h1) };
        let mut pmin = 1.0f64;
        for i in 0..cs.len() {
            for j in i + 1..cs.len() {
                let (a, b) = (motion(cs[i]), motion(cs[j]));
                pmin = pmin.min(p.coherence(a.0 - b.0, wrap(a.1 - b.1)));
            }
        }
        let coherent = pmin >= p.threshold;
        for &c in cs {
            is_child[c] = true;
            coh[c] = coh[c].min(pmin);
            let l = if coherent { Label::Fragment } else { Label::Object };
            // a track that is a group elsewhere stays a group
            if label[c] != Some(Label::Group) {
                label[c] = Some(l);
            }
        }
        if !coherent {
            label[par] = Some(Label::Group);
        }
    }
    // rule d: a parent of an object or group is a group
    for &par in &parents {
        if kids[&par].0.iter().any(|&c| matches!(label[c], Some(Label::Object) | Some(Label::Group))) && label[par] != Some(Label::Group) {
            label[par] = Some(Label::Group);
        }
    }
    (0..tracks.len())
        .map(|k| {
            let l = match label[k] {
                Some(Label::Fragment) if !is_child[k] => Label::Object, // a root fragment is an object
                Some(l) => l,
                None => Label::Object,
            };
            (l, coh[k])
        })
        .collect()
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
    fn labels_by_motion_coherency() {
        let m = |id, v, h| Motion { id, v0: v, h0: h, v1: v, h1: h };
        let ev = |kind, from, to| Event { kind, from, to, gap: 0.5, dist: 0.1 };
        let p = LabelParams::default();
        // 1 splits into 2 and 3 moving alike: fragments of one object
        let t = [m(1, 5.0, 0.0), m(2, 5.1, 0.05), m(3, 4.9, -0.05)];
        let l = labels(&t, &[ev(EventKind::Split, 1, 2), ev(EventKind::Split, 1, 3)], &p);
        assert_eq!(l.iter().map(|x| x.0).collect::<Vec<_>>(), vec![Label::Object, Label::Fragment, Label::Fragment]);
        assert!(l[1].1 > 0.9);
        // 4 splits into 5 and 6 going different ways: a group of two objects
        let t = [m(4, 1.2, 0.0), m(5, 1.3, 1.2), m(6, 1.1, -1.3)];
        let l = labels(&t, &[ev(EventKind::Split, 4, 5), ev(EventKind::Split, 4, 6)], &p);
        assert_eq!(l.iter().map(|x| x.0).collect::<Vec<_>>(), vec![Label::Group, Label::Object, Label::Object]);
        // merge: 7 and 8 (different speeds) merge into 9 -> 9 is a group
        let t = [m(7, 1.0, 0.0), m(8, 6.0, 0.0), m(9, 3.0, 0.0), m(10, 2.0, 2.0)];
        let l = labels(&t, &[ev(EventKind::Merge, 7, 9), ev(EventKind::Merge, 8, 9)], &p);
        assert_eq!(l.iter().map(|x| x.0).collect::<Vec<_>>(), vec![Label::Object, Label::Object, Label::Group, Label::Object]);
        // heading wraps around ±π
        assert!(p.coherence(0.0, wrap(3.1 - -3.1)) > 0.9);
        assert!(LabelParams::new(0.0, 1.0, 1.0, 1.0, 0.5).is_err());
        assert!(LabelParams::new(1.0, 1.0, 1.0, 1.0, 1.5).is_err());
    }

    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// The time-window search equals the O(n²) definition: every (end, start) pair tested.
        #[test]
        fn equals_brute_force(raw in prop::collection::vec((0u32..50, 0u32..20, 0u32..40, 0u32..40, -20i32..20), 0..25), acc in 0u32..4) {
            let tracks: Vec<Endpoints> = raw.iter().enumerate().map(|(k, &(t0, dur, x0, x1, v))| Endpoints {
                id: k as i64, t0: t0 as f64 * 0.5, x0: x0 as f64 * 0.5, y0: 0.0,
                t1: (t0 + dur) as f64 * 0.5, x1: x1 as f64 * 0.5, y1: 0.3, vx1: v as f64 * 0.1, vy1: 0.0,
            }).collect();
            let p = EventParams::new(2.0, 1.5).unwrap().with_accel(acc as f64 * 0.5).unwrap();
            let got = events(&tracks, None, &p).unwrap();
            let mut near = vec![];
            for (a, ta) in tracks.iter().enumerate() {
                for (b, tb) in tracks.iter().enumerate() {
                    let gap = tb.t0 - ta.t1;
                    if a == b || gap < 0.0 || gap > p.max_gap { continue; }
                    let d = ((tb.x0 - (ta.x1 + ta.vx1 * gap)).powi(2) + (tb.y0 - (ta.y1 + ta.vy1 * gap)).powi(2)).sqrt();
                    if d <= p.radius(gap) { near.push((a, b)); }
                }
            }
            let ns = |a: usize| near.iter().filter(|x| x.0 == a).count();
            let ne = |b: usize| near.iter().filter(|x| x.1 == b).count();
            let mut want = vec![];
            for &(a, b) in &near {
                if ns(a) == 1 && ne(b) == 1 { want.push((a as i64, b as i64, EventKind::Broken as u8)); }
                if ns(a) >= 2 { want.push((a as i64, b as i64, EventKind::Split as u8)); }
                if ne(b) >= 2 { want.push((a as i64, b as i64, EventKind::Merge as u8)); }
            }
            want.sort();
            let mut g: Vec<(i64, i64, u8)> = got.iter().map(|e| (e.from, e.to, e.kind as u8)).collect();
            g.sort();
            prop_assert_eq!(g, want);
        }
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
