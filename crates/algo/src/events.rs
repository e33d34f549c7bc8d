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
//! O(n log n) to sort the starts by time and bucket them on a grid of the search radius, plus
//! O(c) for c (end, start) pairs tested: those inside the time window and in the grid cells an
//! end's predicted position can reach ([`events`]). [`labels`]: O(Σ k²) for splits and merges
//! into k tracks, bounded by the work limit `label_pairs`.

use crate::geometry::region::Region;
use crate::limits::{self, Limit};
use std::collections::HashMap;
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
    /// More near (end, start) pairs than `cap`, which the limit `limit` (now `value`) sets.
    TooManyPairs { cap: u64, limit: &'static str, value: u64 },
    /// [`labels`] would compare more child pairs than the limit `label_pairs`.
    Work(limits::Exceeded),
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
            EventError::TooManyPairs { cap, limit, value } => write!(
                f,
                "more than {cap} (end, start) pairs of these tracks are near each other (each is an event row of {PAIR_BYTES} bytes), \
                 above the limit {limit} = {value}: the tracks crowd together in time and space; reduce max_gap or max_dist, pass fewer \
                 tracks per call (one camera and class), or raise it with CALL trajdb_set_limit('{limit}', {})",
                value.saturating_mul(4)
            ),
            EventError::Work(e) => e.fmt(f),
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

/// The bytes one near (end, start) pair takes: the pair itself and up to two event rows.
const PAIR_BYTES: u64 = (std::mem::size_of::<(usize, usize, f64, f64)>() + 2 * std::mem::size_of::<Event>()) as u64;

/// The most near (end, start) pairs one call may keep: each is at least one output row
/// (`output_points`) and takes [`PAIR_BYTES`] (`memory_bytes`). Returns the cap and the limit
/// that sets it.
fn pair_cap() -> (u64, &'static Limit) {
    let rows = &limits::OUTPUT_POINTS;
    let mem = &limits::MEMORY_BYTES;
    if rows.get() <= mem.get() / PAIR_BYTES {
        (rows.get(), rows)
    } else {
        (mem.get() / PAIR_BYTES, mem)
    }
}

/// The starts, bucketed on a square grid: `order` lists start indices cell by cell, each
/// cell's run sorted by (t0, id) with its times in `t`.
struct StartGrid {
    cell: f64,
    x0: f64,
    y0: f64,
    order: Vec<usize>,
    t: Vec<f64>,
    runs: HashMap<(i64, i64), (usize, usize)>,
}

impl StartGrid {
    fn new(tracks: &[Endpoints], starts: &[usize], radius: f64) -> Self {
        let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for &k in starts {
            x0 = x0.min(tracks[k].x0);
            x1 = x1.max(tracks[k].x0);
            y0 = y0.min(tracks[k].y0);
            y1 = y1.max(tracks[k].y0);
        }
        // cells of the search radius; coarser when the starts are sparse (about 4 a cell, fewer
        // cells to visit and a smaller table), and never finer than a millionth of the extent
        let spread = (x1 - x0).max(y1 - y0);
        let sparse = 2.0 * ((x1 - x0) * (y1 - y0) / starts.len().max(1) as f64).sqrt();
        let mut cell = radius.max(spread * 1e-6).max(if sparse.is_finite() { sparse } else { 0.0 });
        if !(cell > 0.0 && cell.is_finite()) {
            cell = if spread.is_finite() && spread > 0.0 { spread } else { 1.0 };
        }
        let mut g = StartGrid { cell, x0, y0, order: Vec::new(), t: Vec::new(), runs: HashMap::new() };
        let mut keyed: Vec<((i64, i64), f64, i64, usize)> =
            starts.iter().map(|&k| (g.key(tracks[k].x0, tracks[k].y0), tracks[k].t0, tracks[k].id, k)).collect();
        keyed.sort_by(|p, q| p.0.cmp(&q.0).then(p.1.total_cmp(&q.1)).then(p.2.cmp(&q.2)));
        let mut i = 0;
        while i < keyed.len() {
            let j = i + keyed[i..].iter().take_while(|e| e.0 == keyed[i].0).count();
            g.runs.insert(keyed[i].0, (i, j));
            i = j;
        }
        g.order = keyed.iter().map(|e| e.3).collect();
        g.t = keyed.iter().map(|e| e.1).collect();
        g
    }

    /// The cell of a coordinate: monotone in it (a floor, then a saturating cast).
    fn ix(&self, v: f64, o: f64) -> i64 {
        ((v - o) / self.cell).floor() as i64
    }

    fn key(&self, x: f64, y: f64) -> (i64, i64) {
        (self.ix(x, self.x0), self.ix(y, self.y0))
    }
}

/// The search around one end: the gap range `[0, max_gap]` cut into pieces over which the
/// predicted position moves at most one cell; per piece the start times and the box of cells
/// that can hold a near start. `None` when these boxes hold more cells than `budget` (then
/// scanning the time window is cheaper).
#[allow(clippy::type_complexity)]
fn search_boxes(a: &Endpoints, p: &EventParams, g: &StartGrid, budget: usize) -> Option<Vec<(f64, f64, (i64, i64), (i64, i64))>> {
    let speed = a.vx1.hypot(a.vy1);
    let pieces = (speed * p.max_gap / g.cell).ceil().max(1.0);
    if !(pieces <= budget as f64) {
        return None;
    }
    let pieces = pieces as usize;
    let mut out = Vec::with_capacity(pieces);
    let mut cells: u128 = 0;
    for k in 0..pieces {
        // start times [tau0, tau1): gaps fl(t0 - a.t1) in [g0, g1] (subtraction is monotone)
        let tau0 = a.t1 + p.max_gap * (k as f64 / pieces as f64);
        let tau1 = if k + 1 == pieces { f64::INFINITY } else { a.t1 + p.max_gap * ((k + 1) as f64 / pieces as f64) };
        let (g0, g1) = ((tau0 - a.t1).max(0.0), (tau1 - a.t1).min(p.max_gap));
        // the prediction a.p1 + v·gap is monotone in gap; a near start lies within radius(g1)
        // of it (with a margin for the rounding of the distance, and its underflow)
        let r = p.radius(g1);
        let m = r * (1.0 + 1e-12) + 1e-150;
        let (xa, xb) = (a.x1 + a.vx1 * g0, a.x1 + a.vx1 * g1);
        let (ya, yb) = (a.y1 + a.vy1 * g0, a.y1 + a.vy1 * g1);
        if !(xa.is_finite() && xb.is_finite() && ya.is_finite() && yb.is_finite() && m.is_finite()) {
            return None;
        }
        let lo = g.key(xa.min(xb) - m, ya.min(yb) - m);
        let hi = g.key(xa.max(xb) + m, ya.max(yb) + m);
        cells += (hi.0 as i128 - lo.0 as i128 + 1) as u128 * (hi.1 as i128 - lo.1 as i128 + 1) as u128;
        if cells > budget as u128 {
            return None;
        }
        out.push((tau0, tau1, lo, hi));
    }
    Some(out)
}

/// The events among `tracks` (see module docs). `interior` is the view polygon already shrunk
/// by the inset (`None`: every endpoint counts as interior). Sorted by (from, to, kind).
///
/// The starts near an end are found on a grid of the search radius: per end, only the cells
/// its predicted position can reach within `max_gap` are searched, each cell's starts sorted by
/// time (or, when that is more cells than the time window holds starts, the window itself).
/// So the work is O(n log n) plus the pairs tested, which are few unless tracks crowd together
/// in both time and space. Every near pair is an output row and takes memory: more than the
/// limits `output_points` and `memory_bytes` allow is an error ([`EventError::TooManyPairs`]),
/// raised as soon as the count passes them.
pub fn events(tracks: &[Endpoints], interior: Option<&Region>, p: &EventParams) -> Result<Vec<Event>, EventError> {
    let (cap, limit) = pair_cap();
    events_capped(tracks, interior, p, cap, limit)
}

/// [`events`] keeping at most `cap` near pairs (`limit` names the limit behind it).
fn events_capped(tracks: &[Endpoints], interior: Option<&Region>, p: &EventParams, cap: u64, limit: &'static Limit) -> Result<Vec<Event>, EventError> {
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
    starts.sort_unstable_by(|&a, &b| tracks[a].t0.total_cmp(&tracks[b].t0).then(tracks[a].id.cmp(&tracks[b].id)));  // ids are distinct: a total order, no merge buffer
    let start_t: Vec<f64> = starts.iter().map(|&k| tracks[k].t0).collect();
    let grid = StartGrid::new(tracks, &starts, p.radius(p.max_gap));
    // (end index, start index, gap, dist)
    let mut near: Vec<(usize, usize, f64, f64)> = Vec::new();
    let test = |ka: usize, kb: usize, near: &mut Vec<(usize, usize, f64, f64)>| -> Result<(), EventError> {
        let (a, b) = (&tracks[ka], &tracks[kb]);
        let gap = b.t0 - a.t1;
        if kb == ka || gap > p.max_gap {
            return Ok(());
        }
        let (px, py) = (a.x1 + a.vx1 * gap, a.y1 + a.vy1 * gap);
        let dist = ((b.x0 - px).powi(2) + (b.y0 - py).powi(2)).sqrt();
        if dist <= p.radius(gap) {
            if near.len() as u64 >= cap {
                return Err(EventError::TooManyPairs { cap, limit: limit.name, value: limit.get() });
            }
            if near.len() == near.capacity() {
                // doubling, but never past the cap
                near.try_reserve(near.len().max(1024).min((cap - near.len() as u64) as usize)).map_err(|_| EventError::TooManyPairs { cap: near.len() as u64, limit: limits::MEMORY_BYTES.name, value: limits::MEMORY_BYTES.get() })?;
            }
            near.push((ka, kb, gap, dist));
        }
        Ok(())
    };
    // the ends in time order, so that the time window of the starts only moves forward (two
    // pointers instead of two binary searches, which missed the cache on every end)
    let mut ends: Vec<usize> = (0..tracks.len()).filter(|&k| inside(tracks[k].x1, tracks[k].y1)).collect();
    ends.sort_unstable_by(|&a, &b| tracks[a].t1.total_cmp(&tracks[b].t1).then(tracks[a].id.cmp(&tracks[b].id)));  // ids are distinct: a total order, no merge buffer
    let (mut lo, mut hi) = (0usize, 0usize);
    for &ka in &ends {
        let a = &tracks[ka];
        // the time window: starts with t0 >= a.t1 and fl(t0 - a.t1) <= max_gap; both bounds are
        // monotone in t0 and only grow with a.t1
        while lo < start_t.len() && start_t[lo] < a.t1 {
            lo += 1;
        }
        hi = hi.max(lo);
        while hi < start_t.len() && start_t[hi] - a.t1 <= p.max_gap {
            hi += 1;
        }
        if hi - lo <= 16 {
            for &kb in &starts[lo..hi] {
                test(ka, kb, &mut near)?;
            }
            continue;
        }
        match search_boxes(a, p, &grid, hi - lo) {
            None => {
                for &kb in &starts[lo..hi] {
                    test(ka, kb, &mut near)?;
                }
            }
            Some(boxes) => {
                for (tau0, tau1, c0, c1) in boxes {
                    for cx in c0.0..=c1.0 {
                        for cy in c0.1..=c1.1 {
                            let Some(&(r0, r1)) = grid.runs.get(&(cx, cy)) else { continue };
                            let ts = &grid.t[r0..r1];
                            let (s, e) = (ts.partition_point(|&t| t < tau0), ts.partition_point(|&t| t < tau1));
                            for &kb in &grid.order[r0 + s..r0 + e] {
                                test(ka, kb, &mut near)?;
                            }
                        }
                    }
                }
            }
        }
    }
    let mut n_starts_near_end = vec![0usize; tracks.len()];
    let mut n_ends_near_start = vec![0usize; tracks.len()];
    for &(a, b, _, _) in &near {
        n_starts_near_end[a] += 1;
        n_ends_near_start[b] += 1;
    }
    let kinds = |a: usize, b: usize| {
        let (sa, eb) = (n_starts_near_end[a], n_ends_near_start[b]);
        [(sa == 1 && eb == 1, EventKind::Broken), (sa >= 2, EventKind::Split), (eb >= 2, EventKind::Merge)]
    };
    let rows: usize = near.iter().map(|&(a, b, _, _)| kinds(a, b).iter().filter(|k| k.0).count()).sum();
    let mut out = Vec::new();
    out.try_reserve_exact(rows).map_err(|_| EventError::TooManyPairs { cap: near.len() as u64, limit: limits::MEMORY_BYTES.name, value: limits::MEMORY_BYTES.get() })?;
    for &(a, b, gap, dist) in &near {
        for (yes, kind) in kinds(a, b) {
            if yes {
                out.push(Event { kind, from: tracks[a].id, to: tracks[b].id, gap, dist });
            }
        }
    }
    // (from, to, kind) is unique (one near pair per (end, start), each kind once): the in-place
    // unstable sort gives the one order there is and allocates nothing (sort_by's merge buffer
    // of half the rows was an infallible allocation: the abort of issue 37)
    out.sort_unstable_by(|p, q| p.from.cmp(&q.from).then(p.to.cmp(&q.to)).then((p.kind as u8).cmp(&(q.kind as u8))));
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
    let l = labels(&motion, &ev, lp)?;
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
/// none) in `tracks` order. The pairwise comparisons (Σ k(k−1)/2 over parents with k
/// children) are checked against the work limit `label_pairs` before they start.
pub fn labels(tracks: &[Motion], events: &[Event], p: &LabelParams) -> Result<Vec<(Label, f64)>, EventError> {
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
    let pairs: u128 = kids.values().map(|(c, _)| c.len() as u128 * (c.len() as u128).saturating_sub(1) / 2).sum();
    limits::LABEL_PAIRS.check(pairs).map_err(EventError::Work)?;
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
    Ok((0..tracks.len())
        .map(|k| {
            let l = match label[k] {
                Some(Label::Fragment) if !is_child[k] => Label::Object, // a root fragment is an object
                Some(l) => l,
                None => Label::Object,
            };
            (l, coh[k])
        })
        .collect())
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
        let l = labels(&t, &[ev(EventKind::Split, 1, 2), ev(EventKind::Split, 1, 3)], &p).unwrap();
        assert_eq!(l.iter().map(|x| x.0).collect::<Vec<_>>(), vec![Label::Object, Label::Fragment, Label::Fragment]);
        assert!(l[1].1 > 0.9);
        // 4 splits into 5 and 6 going different ways: a group of two objects
        let t = [m(4, 1.2, 0.0), m(5, 1.3, 1.2), m(6, 1.1, -1.3)];
        let l = labels(&t, &[ev(EventKind::Split, 4, 5), ev(EventKind::Split, 4, 6)], &p).unwrap();
        assert_eq!(l.iter().map(|x| x.0).collect::<Vec<_>>(), vec![Label::Group, Label::Object, Label::Object]);
        // merge: 7 and 8 (different speeds) merge into 9 -> 9 is a group
        let t = [m(7, 1.0, 0.0), m(8, 6.0, 0.0), m(9, 3.0, 0.0), m(10, 2.0, 2.0)];
        let l = labels(&t, &[ev(EventKind::Merge, 7, 9), ev(EventKind::Merge, 8, 9)], &p).unwrap();
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

    /// The O(n²) definition: every (end, start) pair tested, in any order.
    fn events_slow(tracks: &[Endpoints], interior: Option<&Region>, p: &EventParams) -> Vec<Event> {
        let inside = |x: f64, y: f64| interior.is_none_or(|r| r.contains(x, y));
        let mut near = vec![];
        for (ka, a) in tracks.iter().enumerate() {
            for (kb, b) in tracks.iter().enumerate() {
                let gap = b.t0 - a.t1;
                if ka == kb || !inside(a.x1, a.y1) || !inside(b.x0, b.y0) || b.t0 < a.t1 || gap > p.max_gap {
                    continue;
                }
                let (px, py) = (a.x1 + a.vx1 * gap, a.y1 + a.vy1 * gap);
                let dist = ((b.x0 - px).powi(2) + (b.y0 - py).powi(2)).sqrt();
                if dist <= p.radius(gap) {
                    near.push((ka, kb, gap, dist));
                }
            }
        }
        let mut out = vec![];
        for &(a, b, gap, dist) in &near {
            let sa = near.iter().filter(|x| x.0 == a).count();
            let eb = near.iter().filter(|x| x.1 == b).count();
            for (yes, kind) in [(sa == 1 && eb == 1, EventKind::Broken), (sa >= 2, EventKind::Split), (eb >= 2, EventKind::Merge)] {
                if yes {
                    out.push(Event { kind, from: tracks[a].id, to: tracks[b].id, gap, dist });
                }
            }
        }
        // (from, to, kind) is unique (one near pair per (end, start), each kind once): the in-place
    // unstable sort gives the one order there is and allocates nothing (sort_by's merge buffer
    // of half the rows was an infallible allocation: the abort of issue 37)
    out.sort_unstable_by(|p, q| p.from.cmp(&q.from).then(p.to.cmp(&q.to)).then((p.kind as u8).cmp(&(q.kind as u8))));
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// Issue 19: the grid search (many starts in one time window, so the grid is used, and
        /// fast ends, so some ends fall back to the window) equals the definition, events,
        /// gaps and distances alike; also with a view polygon and with max_dist 0.
        #[test]
        fn grid_search_equals_the_definition(
            raw in prop::collection::vec((0u32..40, 0u32..6, -30i32..30, -30i32..30, -60i32..60, -60i32..60, 0u32..8), 17..140),
            gap in prop::sample::select(vec![0.0, 0.5, 2.0, 5.0]),
            dist in prop::sample::select(vec![0.0, 0.3, 1.5, 6.0]),
            acc in prop::sample::select(vec![0.0, 1.0, 4.0]),
            spread in prop::sample::select(vec![1.0, 10.0, 1e6]),
            polygon in any::<bool>(),
        ) {
            let tracks: Vec<Endpoints> = raw.iter().enumerate().map(|(k, &(t0, dur, x0, y0, vx, vy, fast))| {
                let (x0, y0) = (x0 as f64 * 0.25 * spread, y0 as f64 * 0.25);
                let v = if fast == 0 { 500.0 } else { 0.25 };
                Endpoints {
                    id: 1000 - k as i64, t0: t0 as f64 * 0.125, x0, y0,
                    t1: (t0 + dur) as f64 * 0.125, x1: x0 + vx as f64 * 0.1, y1: y0 - vy as f64 * 0.1,
                    vx1: vx as f64 * v, vy1: vy as f64 * v * 0.5,
                }
            }).collect();
            let p = EventParams::new(gap, dist).unwrap().with_accel(acc).unwrap();
            let r = Region::from_wkt("POLYGON ((-4 -6, 6 -6, 6 6, -4 6, -4 -6))").unwrap();
            let reg = polygon.then_some(&r);
            prop_assert_eq!(events(&tracks, reg, &p).unwrap(), events_slow(&tracks, reg, &p));
        }
    }

    /// Issue 19: 64k tracks crowded into one place and time used to allocate their near pairs
    /// until the host died; past the cap (output_points, memory_bytes) it is an error that
    /// names the limit and what to reduce, before the pairs are stored.
    #[test]
    fn crowded_tracks_stop_at_the_pair_cap() {
        let tracks: Vec<Endpoints> = (0..400).map(|k| Endpoints { id: k, t0: 1.0, x0: 0.0, y0: 0.0, t1: 1.0, x1: 0.0, y1: 0.0, vx1: 0.0, vy1: 0.0 }).collect();
        let p = EventParams::new(1.0, 1.0).unwrap();
        let e = events_capped(&tracks, None, &p, 1000, &limits::OUTPUT_POINTS).unwrap_err();
        assert_eq!(e, EventError::TooManyPairs { cap: 1000, limit: "output_points", value: limits::OUTPUT_POINTS.get() });
        let msg = e.to_string();
        assert!(msg.starts_with("more than 1000 (end, start) pairs") && msg.contains("reduce max_gap or max_dist") && msg.contains("trajdb_set_limit('output_points'"), "{msg}");
        // 400 x 399 pairs fit the default cap
        assert_eq!(events(&tracks, None, &p).unwrap().len(), 400 * 399 * 2);
        // the cap from the limits: the smaller of the rows and the bytes
        let (cap, l) = pair_cap();
        assert_eq!(cap, (limits::OUTPUT_POINTS.get()).min(limits::MEMORY_BYTES.get() / PAIR_BYTES));
        assert!(l.name == "output_points" || l.name == "memory_bytes");
    }

    /// Issue 19: 300k one-point tracks in one minute over 10 km used to test every pair in
    /// the 2 s window (45 s a call); the grid finds the same few events at once.
    #[test]
    fn many_spread_tracks_are_fast_and_exact() {
        let mut st = 42u64;
        let mut rnd = || {
            st = st.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (st >> 11) as f64 / (1u64 << 53) as f64
        };
        let tracks: Vec<Endpoints> = (0..300_000)
            .map(|k| {
                let (t, x, y) = (rnd() * 60.0, rnd() * 10_000.0, rnd() * 10_000.0);
                Endpoints { id: k, t0: t, x0: x, y0: y, t1: t, x1: x, y1: y, vx1: 0.0, vy1: 0.0 }
            })
            .collect();
        let p = EventParams::new(2.5, 2.0).unwrap();
        let ev = events(&tracks, None, &p).unwrap();
        assert!(!ev.is_empty() && ev.len() < 5000, "{}", ev.len());
        // every 1000th end against all 300k starts by the definition
        for ka in (0..tracks.len()).step_by(1000) {
            let a = &tracks[ka];
            let mut want: Vec<i64> = tracks
                .iter()
                .filter(|b| b.id != a.id && b.t0 >= a.t1 && b.t0 - a.t1 <= 2.5 && (b.x0 - a.x1).hypot(b.y0 - a.y1) <= 2.0)
                .map(|b| b.id)
                .collect();
            let mut got: Vec<i64> = ev.iter().filter(|e| e.from == a.id).map(|e| e.to).collect();
            want.sort_unstable();
            got.sort_unstable();
            got.dedup();
            assert_eq!(got, want, "end {ka}");
        }
    }

    #[test]
    fn label_pairs_are_limited_before_the_work() {
        let k = 50_000usize;
        let m = |id| Motion { id, v0: 1.0, h0: 0.0, v1: 1.0, h1: 0.0 };
        let tracks: Vec<Motion> = (0..=k as i64).map(m).collect();
        let ev: Vec<Event> = (1..=k as i64).map(|to| Event { kind: EventKind::Split, from: 0, to, gap: 0.1, dist: 0.1 }).collect();
        let e = labels(&tracks, &ev, &LabelParams::default()).unwrap_err();
        let needed = (k * (k - 1) / 2) as u128;
        assert_eq!(e, EventError::Work(limits::LABEL_PAIRS.check(needed).unwrap_err()));
        assert!(e.to_string().contains("raise it with CALL trajdb_set_limit('label_pairs', 1249975000)"), "{e}");
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
