//! Post-encroachment time (PET): where two paths cross, the time between the first road user
//! leaving the crossing point and the second arriving at it (Allen, Shin & Cooper 1978,
//! "Analysis of traffic conflicts and collisions", TRR 667; SSAM's PET, FHWA-HRT-08-051 §2;
//! TrafficIntelligence's `computePET`). With road users as points on their paths:
//!
//! ```text
//! PET = |t_b(P) - t_a(P)|,  P = a crossing of path a and path b,  t_k(P) = when road user k is at P
//! ```
//!
//! `t_k(P)` is interpolated linearly along the crossing segment. Of every crossing, the one
//! with the smallest PET is returned (ties: the earliest). Collinear overlapping segments have
//! no single crossing point and are not crossings (two road users following one another in one
//! lane: their noisy paths still cross at small angles, with PET = the time headway; `angle`
//! tells these apart, SSAM's rule: rear-end below 30°, lane change 30-85°, crossing above 85°).
//!
//! Prefilters: a sweep over the axis with the larger extent keeps only segment pairs whose
//! intervals on that axis overlap, then their extents on the other axis, and pairs whose time
//! intervals are more than `max_pet` apart are skipped before any intersection is computed.
//! Before the sweep, each path keeps only its segments within `max_pet` of the other path's time
//! span (two binary searches), narrowed to the first and last meeting the box of the other's
//! window (the sweep would never compare the rest), so two road users that meet for a few
//! seconds cost the points of those seconds near each other, not of their whole paths. Where
//! the two still share more than 4 `max_pet` seconds (a queue, following in one lane), the
//! sweep runs over time instead: a merge of the two paths' segments, already in time order.
//! O(log(n + m) + (n' + m') log(n' + m') + K), n', m' the segments inside those time windows, K
//! the segment pairs overlapping on the sweep axis (O(n m) only for paths that overlap along
//! their whole length on both axes); over time O(n' + m' + K_t), K_t the segment pairs within
//! `max_pet` in time.
//!
//! # Work limit
//! K (or K_t) is known only as the sweep proceeds: two long paths standing and jittering in one
//! place, or zigzagging over each other, overlap everywhere (K = n m). Each sweep counts the
//! segment pairs it examines (K, K_t, before the box and time prefilters) and stops with the
//! `pet_segment_pairs` error ([`crate::limits::PET_SEGMENT_PAIRS`], default 5e7: about a second)
//! once the count passes it, so that one call is bounded whatever the input (DuckDB's C API
//! gives a scalar function no way to see an interrupt inside a call: its work limit is what
//! bounds it). [`super::conflicts`] and `conflicts_top` give each pair of road users its own
//! count (a day holds 10^5 candidate pairs, themselves bounded by `memory_bytes`). The segment and event lists
//! are fallible allocations (the `memory_bytes` error, never an abort).

use super::candidates::alloc_error;
use super::{validate, ConflictError};
use crate::limits::{Exceeded, PET_SEGMENT_PAIRS};
use crate::positive_or_inf;
use crate::traj::Traj;

/// One crossing: the PET, the crossing point, when each road user was there, and the angle
/// between their directions of travel there (degrees, 0 = same direction, 180 = opposite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pet {
    pub pet: f64,
    pub x: f64,
    pub y: f64,
    /// When `a` was at the crossing point.
    pub t_a: f64,
    /// When `b` was at the crossing point.
    pub t_b: f64,
    pub angle: f64,
}

impl Pet {
    pub fn t_first(&self) -> f64 {
        self.t_a.min(self.t_b)
    }
    pub fn t_second(&self) -> f64 {
        self.t_a.max(self.t_b)
    }
}

#[derive(Clone, Copy)]
struct Seg {
    /// start point, direction (end - start), start time, time span
    px: f64,
    py: f64,
    dx: f64,
    dy: f64,
    t0: f64,
    dt: f64,
    /// extent on the sweep axis and the other axis
    lo: f64,
    hi: f64,
    olo: f64,
    ohi: f64,
}

#[cfg(test)]
fn segments(tr: Traj<'_>, sweep_x: bool) -> Vec<Seg> {
    segments_of(tr, sweep_x, window(tr, f64::NEG_INFINITY, f64::INFINITY)).unwrap()
}

/// The work budget of one search: segment pairs examined (shareable across threads), against the `pet_segment_pairs` limit read once by the caller (in its own thread: the limits'
/// scope is per thread).
pub(crate) struct Budget {
    done: std::sync::atomic::AtomicU64,
    limit: u64,
}

impl Budget {
    /// The budget of the current scope's `pet_segment_pairs`.
    pub(crate) fn from_limit() -> Budget {
        Budget::new(PET_SEGMENT_PAIRS.get())
    }
    pub(crate) fn new(limit: u64) -> Budget {
        Budget { done: std::sync::atomic::AtomicU64::new(0), limit }
    }
}

/// One sweep's count, added to its [`Budget`] every 2^16 pairs and at the end.
struct Work<'b> {
    local: u64,
    budget: &'b Budget,
}

impl Work<'_> {
    fn new(budget: &Budget) -> Work<'_> {
        Work { local: 0, budget }
    }
    /// Counts `n` more pairs; the `pet_segment_pairs` error once the call is past the limit.
    #[inline]
    fn add(&mut self, n: usize) -> Result<(), ConflictError> {
        self.local = self.local.saturating_add(n as u64);
        if self.local >= 1 << 16 {
            self.flush()?;
        }
        Ok(())
    }
    fn flush(&mut self) -> Result<(), ConflictError> {
        let done = self.budget.done.fetch_add(self.local, std::sync::atomic::Ordering::Relaxed).saturating_add(self.local);
        self.local = 0;
        if done > self.budget.limit {
            // the count so far: the whole search would need at least this many
            return Err(ConflictError::Work(Exceeded { name: PET_SEGMENT_PAIRS.name, counts: PET_SEGMENT_PAIRS.counts, needed: done as u128, limit: self.budget.limit }));
        }
        Ok(())
    }
}

/// The segments (k - 1, k) of `tr` whose time interval meets [lo, hi], as the range of k
/// (binary search: `t` is sorted).
fn window(tr: Traj<'_>, lo: f64, hi: f64) -> std::ops::Range<usize> {
    let first = tr.t.partition_point(|&t| t < lo).max(1);
    let end = (tr.t.partition_point(|&t| t <= hi) + 1).min(tr.len());
    first..end.max(first)
}

/// Segment (k - 1, k) of `tr`, or `None` standing still (no direction, and no crossing another
/// segment could not find).
#[inline]
fn segment(tr: Traj<'_>, k: usize, sweep_x: bool) -> Option<Seg> {
    let (px, py, dx, dy) = (tr.x[k - 1], tr.y[k - 1], tr.x[k] - tr.x[k - 1], tr.y[k] - tr.y[k - 1]);
    if dx == 0.0 && dy == 0.0 {
        return None;
    }
    let (xs, ys) = ((px.min(px + dx), px.max(px + dx)), (py.min(py + dy), py.max(py + dy)));
    let ((lo, hi), (olo, ohi)) = if sweep_x { (xs, ys) } else { (ys, xs) };
    Some(Seg { px, py, dx, dy, t0: tr.t[k - 1], dt: tr.t[k] - tr.t[k - 1], lo, hi, olo, ohi })
}

/// The box (x0, x1, y0, y1) of the points of segments `ks` of `tr` (empty: an empty box).
fn window_box(tr: Traj<'_>, ks: &std::ops::Range<usize>) -> [f64; 4] {
    if ks.is_empty() {
        return [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
    }
    (ks.start - 1..ks.end).fold([f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY], |[a, b, c, d], k| {
        [a.min(tr.x[k]), b.max(tr.x[k]), c.min(tr.y[k]), d.max(tr.y[k])]
    })
}

/// `ks` narrowed to its first and last segment whose box meets `bx` (closed intervals).
fn narrow(tr: Traj<'_>, ks: std::ops::Range<usize>, bx: &[f64; 4]) -> std::ops::Range<usize> {
    let meets = |k: usize| {
        let (x0, x1, y0, y1) = (tr.x[k - 1], tr.x[k], tr.y[k - 1], tr.y[k]);
        x0.max(x1) >= bx[0] && x0.min(x1) <= bx[1] && y0.max(y1) >= bx[2] && y0.min(y1) <= bx[3]
    };
    let Some(first) = ks.clone().find(|&k| meets(k)) else { return ks.start..ks.start };
    let last = ks.clone().rev().find(|&k| meets(k)).unwrap_or(first);
    first..last + 1
}

/// The segments (k - 1, k) of `tr` for k in `ks`, but those standing still (a fallible
/// allocation).
fn segments_of(tr: Traj<'_>, sweep_x: bool, ks: std::ops::Range<usize>) -> Result<Vec<Seg>, ConflictError> {
    let mut v = Vec::new();
    v.try_reserve_exact(ks.len()).map_err(|_| alloc_error((ks.len() * std::mem::size_of::<Seg>()) as u128))?;
    v.extend(ks.filter_map(|k| segment(tr, k, sweep_x)));
    Ok(v)
}

/// Keeps the segments of `ss` whose boxes meet the box around all of `other` (closed
/// intervals, as the sweep compares them). Keeps the order.
fn clip(ss: &mut Vec<Seg>, other: &[Seg]) {
    let inf = f64::INFINITY;
    let (lo, hi, olo, ohi) = other.iter().fold((inf, -inf, inf, -inf), |(a, b, c, d), s| (a.min(s.lo), b.max(s.hi), c.min(s.olo), d.max(s.ohi)));
    ss.retain(|s| s.hi >= lo && s.lo <= hi && s.ohi >= olo && s.olo <= ohi);
}

/// The crossing of segments `a` and `b`, if they cross at one point.
fn cross(a: &Seg, b: &Seg) -> Option<Pet> {
    let den = a.dx * b.dy - a.dy * b.dx;
    let (la, lb) = (a.dx.hypot(a.dy), b.dx.hypot(b.dy));
    let (qx, qy) = (b.px - a.px, b.py - a.py);
    let (s, u, cos) = if la * lb > 1e-250 && den.is_finite() && (la * lb).is_finite() && (qx * b.dy).is_finite() && (qx * a.dy).is_finite() && (qy * b.dx).is_finite() && (qy * a.dx).is_finite() {
        if den.abs() <= 1e-12 * la * lb {
            return None; // parallel or collinear
        }
        ((qx * b.dy - qy * b.dx) / den, (qx * a.dy - qy * a.dx) / den, (a.dx * b.dx + a.dy * b.dy) / (la * lb))
    } else {
        // products past f64::MAX or below 1e-250 (coordinates near 1e300 or 1e-150: a hostile
        // or broken frame): the same test on unit directions, where every product is at most |q|
        // and nothing underflows to "parallel" (the common case above keeps its arithmetic)
        let (ux, uy, vx, vy) = (a.dx / la, a.dy / la, b.dx / lb, b.dy / lb);
        let sin = ux * vy - uy * vx;
        if !(sin.abs() > 1e-12) {
            return None;
        }
        (((qx * vy - qy * vx) / sin) / la, ((qx * uy - qy * ux) / sin) / lb, ux * vx + uy * vy)
    };
    if !(0.0..=1.0).contains(&s) || !(0.0..=1.0).contains(&u) {
        return None;
    }
    let (t_a, t_b) = (a.t0 + s * a.dt, b.t0 + u * b.dt);
    let cos = cos.clamp(-1.0, 1.0);
    Some(Pet { pet: (t_a - t_b).abs(), x: a.px + s * a.dx, y: a.py + s * a.dy, t_a, t_b, angle: cos.acos().to_degrees() })
}

/// The crossing of paths `a` and `b` with the smallest PET (at most `max_pet` seconds; `+inf`:
/// no limit), or `None` when the paths do not cross (within `max_pet`). Errors: a trajectory
/// outside the input policy, `max_pet` <= 0 or NaN.
pub fn pet(a: Traj<'_>, b: Traj<'_>, max_pet: f64) -> Result<Option<Pet>, ConflictError> {
    validate(a, b)?;
    let max_pet = positive_or_inf("max_pet", max_pet)?;
    pet_checked(a, b, max_pet, &Budget::from_limit())
}

/// [`pet`] of trajectories already validated, `max_pet` already checked (> 0), examining at
/// most what is left of `budget` (the call's `pet_segment_pairs`, shared by all its pairs): what
/// [`super::conflicts`] calls per pair after validating each path once.
pub(crate) fn pet_checked(a: Traj<'_>, b: Traj<'_>, max_pet: f64, budget: &Budget) -> Result<Option<Pet>, ConflictError> {
    let mut work = Work::new(budget);
    let found = sweep(a, b, max_pet, &mut work)?;
    work.flush()?;
    Ok(found)
}

fn sweep(a: Traj<'_>, b: Traj<'_>, max_pet: f64, work: &mut Work<'_>) -> Result<Option<Pet>, ConflictError> {
    if a.len() < 2 || b.len() < 2 {
        return Ok(None);
    }
    // only segments within max_pet of the other path's time span can hold a crossing with
    // PET <= max_pet (t_a < b.t_0 - max_pet <= t_b - max_pet otherwise): the rest are never read
    let (ta, tb) = ((a.t[0], a.t[a.len() - 1]), (b.t[0], b.t[b.len() - 1]));
    // the prefilters compare with `reach`, max_pet widened by a few units of rounding of the
    // times involved: `tb.0 - max_pet` rounds, and a pair whose PET is exactly max_pet must not
    // be filtered out by it (the final test, `pet <= max_pet`, is exact)
    let scale = ta.0.abs().max(ta.1.abs()).max(tb.0.abs()).max(tb.1.abs());
    let reach = max_pet + 16.0 * f64::EPSILON * (scale + max_pet);
    let (wa, wb) = (window(a, tb.0 - reach, tb.1 + reach), window(b, ta.0 - reach, ta.1 + reach));
    // and only segments meeting the box of the other's window can cross it: each window narrowed
    // to the first and last such segment (one pass, nothing allocated; a road user standing for
    // minutes beside another's path costs the seconds where they come near)
    let (ba, bb) = (window_box(a, &wa), window_box(b, &wb));
    let (wa, wb) = (narrow(a, wa, &bb), narrow(b, wb, &ba));
    if wa.is_empty() || wb.is_empty() {
        return Ok(None);
    }
    // long shared times (a queue, road users following each other): sweep over time, where a
    // segment meets only 2 max_pet seconds of the other path; short encounters (the usual
    // crossing) stay with the space sweep, which there compares fewer pairs. Either compares
    // every segment pair the other would find a crossing in, so the result is the same.
    let t_lo = a.t[wa.start - 1].min(b.t[wb.start - 1]);
    let t_hi = a.t[wa.end - 1].max(b.t[wb.end - 1]);
    if max_pet.is_finite() && t_hi - t_lo > 4.0 * max_pet {
        return time_sweep([a, b], [wa, wb], max_pet, reach, work);
    }
    // sweep along the axis on which the two windows' points spread more (fewer overlapping
    // intervals; either axis finds the same crossing, `better` being a total order)
    // (the boxes of the windows before narrowing: the axis only sets the cost)
    let sweep_x = ba[1].max(bb[1]) - ba[0].min(bb[0]) >= ba[3].max(bb[3]) - ba[2].min(bb[2]);
    let (mut sa, mut sb) = (segments_of(a, sweep_x, wa)?, segments_of(b, sweep_x, wb)?);
    // and only segments meeting the other's bounding box: the sweep compares a pair only when
    // their boxes meet (closed intervals on both axes), so the others are never compared
    clip(&mut sa, &sb);
    clip(&mut sb, &sa);
    let segs = [sa, sb];
    let n_events = segs[0].len() + segs[1].len();
    let mut events: Vec<(f64, usize, usize)> = Vec::new();
    events.try_reserve_exact(n_events).map_err(|_| alloc_error((n_events * std::mem::size_of::<(f64, usize, usize)>()) as u128))?;
    events.extend(segs.iter().enumerate().flat_map(|(side, ss)| ss.iter().enumerate().map(move |(i, s)| (s.lo, side, i))));
    // the active lists hold at most every segment of their side: reserved once, never grown
    let mut active: [Vec<usize>; 2] = [Vec::new(), Vec::new()];
    for (side, act) in active.iter_mut().enumerate() {
        act.try_reserve_exact(segs[side].len()).map_err(|_| alloc_error((segs[side].len() * std::mem::size_of::<usize>()) as u128))?;
    }
    // (side, i) is unique: the unstable sort gives the one order there is
    events.sort_unstable_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)).then(p.2.cmp(&q.2)));
    let mut best: Option<Pet> = None;
    for (lo, side, i) in events {
        let other = 1 - side;
        // every active segment of the other side is examined (retain, then the loop below)
        work.add(active[other].len())?;
        active[other].retain(|&j| segs[other][j].hi >= lo);
        let s = &segs[side][i];
        for &j in &active[other] {
            let o = &segs[other][j];
            if o.ohi < s.olo || s.ohi < o.olo {
                continue;
            }
            let (sa, sb) = if side == 0 { (s, o) } else { (o, s) };
            // temporal prefilter: the two segments' times can be at most max_pet apart
            if sa.t0 > sb.t0 + sb.dt + reach || sb.t0 > sa.t0 + sa.dt + reach {
                continue;
            }
            if let Some(c) = cross(sa, sb) {
                if c.pet <= max_pet && better(&c, &best) {
                    best = Some(c);
                }
            }
        }
        active[side].push(i);
    }
    Ok(best)
}

/// The better of two crossings: the smaller PET, then the earlier first passage, then (two
/// crossings at the same PET and time: rare, but a grid of times makes them) the smaller x, y,
/// angle and `t_a`: a total order, so the crossing returned does not depend on the order the
/// sweep met them in (space or time sweep, any `max_pet` that holds it).
fn better(c: &Pet, best: &Option<Pet>) -> bool {
    match best {
        None => true,
        Some(b) => {
            let key = |p: &Pet| [p.pet, p.t_first(), p.x, p.y, p.angle, p.t_a];
            let (k, l) = (key(c), key(b));
            k.iter().zip(l.iter()).map(|(u, v)| u.total_cmp(v)).find(|o| o.is_ne()) == Some(std::cmp::Ordering::Less)
        }
    }
}

/// [`pet_checked`]'s search with a finite `max_pet`, as a sweep over time instead of space:
/// a segment is compared with the other path's segments whose time intervals come within
/// `max_pet` of its own (the pairs the temporal prefilter would keep), then their boxes. Two
/// road users following each other in one lane overlap along their whole paths on both axes
/// (a space sweep compares every segment pair: O(n m), what made conflicts grow as n^1.5 with
/// congestion); in time each segment meets only the others' segments of 2 max_pet seconds.
/// Both paths' segments are in time order already: the sweep is a merge of the two windows
/// `ks` (segments k - 1..k), and a side's active segments are a range of it (their ends are in
/// order too), so nothing is sorted or allocated: O(n' + m' + K_t), K_t the segment pairs within
/// max_pet in time. The same crossings are compared as by the space sweep, so the same one is
/// returned (ties: the earlier first passage).
fn time_sweep(tr: [Traj<'_>; 2], ks: [std::ops::Range<usize>; 2], max_pet: f64, reach: f64, work: &mut Work<'_>) -> Result<Option<Pet>, ConflictError> {
    let mut best: Option<Pet> = None;
    let (mut next, mut lo) = ([ks[0].start, ks[1].start], [ks[0].start, ks[1].start]);
    while next[0] < ks[0].end || next[1] < ks[1].end {
        // events in (start time, side, k) order
        let side = if next[1] >= ks[1].end || (next[0] < ks[0].end && tr[0].t[next[0] - 1].total_cmp(&tr[1].t[next[1] - 1]).is_le()) { 0 } else { 1 };
        let k = next[side];
        next[side] += 1;
        let Some(s) = segment(tr[side], k, true) else { continue };
        let other = 1 - side;
        // the other's segments that started before s (merged in order) and ended more than
        // max_pet before it starts are done with for good (the temporal prefilter)
        while lo[other] < next[other] && s.t0 > tr[other].t[lo[other]] + reach {
            lo[other] += 1;
        }
        work.add(next[other] - lo[other])?;
        for j in lo[other]..next[other] {
            let Some(o) = segment(tr[other], j, true) else { continue };
            if o.hi < s.lo || s.hi < o.lo || o.ohi < s.olo || s.ohi < o.olo {
                continue;
            }
            let (sa, sb) = if side == 0 { (&s, &o) } else { (&o, &s) };
            if let Some(c) = cross(sa, sb) {
                if c.pet <= max_pet && better(&c, &best) {
                    best = Some(c);
                }
            }
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traj::OwnedTraj;
    use proptest::prelude::*;

    use super::super::test_line as line;

    /// Two road users standing and jittering in one place for `n` points each (every segment
    /// pair overlaps on both axes: K = n m, what took 36 s at n = 40,000).
    fn jitter(n: usize, seed: u64) -> OwnedTraj {
        let mut s = seed;
        let mut r = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
        let x: Vec<f64> = (0..n).map(|_| r()).collect();
        let y: Vec<f64> = (0..n).map(|_| r()).collect();
        OwnedTraj { t, x, y }
    }

    #[test]
    fn the_sweeps_stop_at_the_segment_pair_limit() {
        use crate::limits::{with_scope, Limits};
        use std::sync::Arc;
        let (a, b) = (jitter(3000, 1), jitter(3000, 2));
        let low = Arc::new(Limits::default());
        low.set("pet_segment_pairs", 100_000).unwrap();
        // the space sweep (no max_pet) and the time sweep (a long shared time) both stop
        for max_pet in [f64::INFINITY, 5.0] {
            let e = with_scope(&low, || pet(a.view(), b.view(), max_pet)).unwrap_err();
            let ConflictError::Work(w) = &e else { panic!("{e:?}") };
            assert_eq!((w.name, w.limit), ("pet_segment_pairs", 100_000));
            assert!(w.needed > 100_000, "{w:?}");
            assert!(e.describe().contains("segment pairs examined, above the work limit pet_segment_pairs = 100000; raise it with CALL trajdb_set_limit('pet_segment_pairs'"), "{e}");
        }
        // within the default: the same paths give their crossing, as with no limit at all
        let full = pet_checked(a.view(), b.view(), f64::INFINITY, &Budget::new(u64::MAX)).unwrap();
        assert!(full.is_some());
        assert_eq!(pet(a.view(), b.view(), f64::INFINITY).unwrap(), full);
        // a path crossing another once costs far below the limit
        let c = OwnedTraj { t: vec![0.0, 1.0], x: vec![-5.0, 5.0], y: vec![0.5, 0.5] };
        let d = OwnedTraj { t: vec![0.0, 1.0], x: vec![0.5, 0.5], y: vec![-5.0, 5.0] };
        assert!(with_scope(&low, || pet(c.view(), d.view(), f64::INFINITY)).unwrap().is_some());
    }

    #[test]
    fn a_right_angle_crossing_has_the_kinematic_pet() {
        // a: along x at 10 m/s, at the origin at t = 5; b: along y at 5 m/s, at the origin at t = 6.5
        let a = line(0.0, -50.0, 0.0, 10.0, 0.0, 101, 0.1);
        let b = line(0.0, 0.0, -32.5, 0.0, 5.0, 131, 0.1);
        let p = pet(a.view(), b.view(), f64::INFINITY).unwrap().unwrap();
        assert!((p.pet - 1.5).abs() < 1e-9, "{p:?}");
        assert!(p.x.abs() < 1e-9 && p.y.abs() < 1e-9);
        assert!((p.t_a - 5.0).abs() < 1e-9 && (p.t_b - 6.5).abs() < 1e-9);
        assert!((p.angle - 90.0).abs() < 1e-9);
        // symmetric, and max_pet filters
        let q = pet(b.view(), a.view(), f64::INFINITY).unwrap().unwrap();
        assert!((q.pet - p.pet).abs() < 1e-12 && q.t_a == p.t_b);
        assert_eq!(pet(a.view(), b.view(), 1.0).unwrap(), None);
    }

    #[test]
    fn no_crossing_parallel_short_and_empty_give_none() {
        let a = line(0.0, 0.0, 0.0, 1.0, 0.0, 10, 1.0);
        let b = line(0.0, 0.0, 1.0, 1.0, 0.0, 10, 1.0);
        assert_eq!(pet(a.view(), b.view(), f64::INFINITY).unwrap(), None);
        // collinear overlap is not a crossing
        assert_eq!(pet(a.view(), a.view(), f64::INFINITY).unwrap(), None);
        let e = OwnedTraj::default();
        assert_eq!(pet(a.view(), e.view(), f64::INFINITY).unwrap(), None);
        let one = line(0.0, 0.0, 0.0, 1.0, 0.0, 1, 1.0);
        assert_eq!(pet(one.view(), a.view(), f64::INFINITY).unwrap(), None);
    }

    #[test]
    fn of_several_crossings_the_smallest_pet_wins() {
        // b zig-zags across a's line y = 0 (a: x = t): crossings at x = 1 (t_b = 1) and x = 3 (t_b = 7)
        let a = line(0.0, 0.0, 0.0, 1.0, 0.0, 11, 1.0);
        let mut b = OwnedTraj::default();
        b.push(0.0, 1.0, -1.0);
        b.push(2.0, 1.0, 1.0);
        b.push(6.0, 3.0, 1.0);
        b.push(8.0, 3.0, -1.0);
        let p = pet(a.view(), b.view(), f64::INFINITY).unwrap().unwrap();
        // at x = 1 both are there at t = 1 (PET 0); at x = 3, a at t = 3 and b at t = 7 (PET 4)
        assert!((p.x - 1.0).abs() < 1e-12 && p.pet.abs() < 1e-12, "{p:?}");
        let q = pet(a.view(), b.view(), f64::INFINITY).unwrap().unwrap();
        assert_eq!(p, q);
    }

    #[test]
    fn bad_input_is_an_error_naming_the_argument() {
        let a = line(0.0, 0.0, 0.0, 1.0, 0.0, 3, 1.0);
        let mut b = a.clone();
        b.t[2] = 0.5;
        assert!(pet(a.view(), b.view(), 1.0).unwrap_err().describe().starts_with("b must be ordered by t"));
        assert_eq!(pet(a.view(), a.view(), 0.0).unwrap_err().describe(), "max_pet must be > 0, got 0");
    }

    proptest! {
        /// Two straight crossings at random angles and speeds: PET = |t_a - t_b| at the true crossing,
        /// whatever the sampling, and the sweep finds what the all-pairs search finds.
        #[test]
        fn crossing_lines_have_the_exact_pet(ha in 0.0f64..6.28, hb in 0.0f64..6.28, va in 1.0f64..20.0, vb in 1.0f64..20.0,
                                             ta in 2.0f64..8.0, tb in 2.0f64..8.0, dt in 0.05f64..0.5) {
            let sep = ((ha - hb).sin()).abs();
            prop_assume!(sep > 0.1);
            let n = (12.0 / dt) as usize;
            let a = line(0.0, -va * ta * ha.cos(), -va * ta * ha.sin(), va * ha.cos(), va * ha.sin(), n, dt);
            let b = line(0.0, -vb * tb * hb.cos(), -vb * tb * hb.sin(), vb * hb.cos(), vb * hb.sin(), n, dt);
            let p = pet(a.view(), b.view(), f64::INFINITY).unwrap().unwrap();
            prop_assert!((p.pet - (ta - tb).abs()).abs() < 1e-6, "{:?}", p);
            prop_assert!(p.x.abs() < 1e-6 && p.y.abs() < 1e-6);
        }
    }

    #[test]
    fn the_sweep_agrees_with_all_pairs_on_wiggly_paths() {
        // deterministic pseudo-random walks
        let mut s = 12345u64;
        let mut rnd = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
        };
        for _ in 0..50 {
            let (mut a, mut b) = (OwnedTraj::default(), OwnedTraj::default());
            let (mut xa, mut ya, mut xb, mut yb) = (0.0, 0.0, 3.0, -3.0);
            for k in 0..60 {
                xa += rnd() * 2.0 + 0.3;
                ya += rnd() * 2.0;
                xb += rnd() * 2.0;
                yb += rnd() * 2.0 + 0.3;
                a.push(k as f64 * 0.1, xa, ya);
                b.push(k as f64 * 0.1 + 0.05, xb, yb);
            }
            let got = pet(a.view(), b.view(), f64::INFINITY).unwrap();
            let (sa, sb) = (segments(a.view(), true), segments(b.view(), true));
            let mut best: Option<Pet> = None;
            for x in &sa {
                for y in &sb {
                    if let Some(c) = cross(x, y) {
                        if best.is_none_or(|b| c.pet < b.pet || (c.pet == b.pet && c.t_first() < b.t_first())) {
                            best = Some(c);
                        }
                    }
                }
            }
            assert_eq!(got.map(|p| p.pet), best.map(|p| p.pet));
        }
    }

    #[test]
    fn a_crossing_at_every_scale_is_found() {
        // the right-angle crossing scaled by 1e-300 .. 1e298: products of coordinates underflow
        // or overflow
        for k in [1e-300, 1e-200, 1e-170, 1e-100, 1.0, 1e100, 1e200, 1e298] {
            let mut a = OwnedTraj::default();
            a.push(0.0, -10.0 * k, 0.0);
            a.push(2.0, 10.0 * k, 0.0);
            let mut b = OwnedTraj::default();
            b.push(0.0, 0.0, -10.0 * k);
            b.push(4.0, 0.0, 10.0 * k);
            let p = pet(a.view(), b.view(), f64::INFINITY).unwrap().unwrap();
            assert!((p.pet - 1.0).abs() < 1e-9 && p.x.abs() < 1e-6 * k && (p.angle - 90.0).abs() < 1e-9, "{k}: {p:?}");
        }
    }

    #[test]
    fn a_pet_of_exactly_max_pet_is_found() {
        // the probe's case: a ends at the origin at t = 0.1, b starts there at 1.35; PET 1.25,
        // and 1.35 - 1.25 rounds to just above 0.1
        let mut a = OwnedTraj::default();
        a.push(-0.9, 1.0, 1.0);
        a.push(0.1, 0.0, 0.0);
        let mut b = OwnedTraj::default();
        b.push(1.35, 0.0, 0.0);
        b.push(2.35, -1.0, 1.0);
        assert_eq!(pet(a.view(), b.view(), 1.25).unwrap().map(|p| p.pet), Some(1.25));
    }

    proptest! {
        /// With a finite max_pet, the time windows (segments within max_pet of the other path's
        /// span) change nothing: the same crossing as all segment pairs, for paths shifted in time
        /// so that they meet for part of their spans or not at all (a long shared time: the time
        /// sweep; a short one: the space sweep).
        #[test]
        fn the_time_windows_agree_with_all_pairs(seed in 0u64..1_000_000, shift in -8.0f64..8.0, max_pet in 0.2f64..4.0) {
            let mut s = seed;
            let mut rnd = || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
            };
            let (mut a, mut b) = (OwnedTraj::default(), OwnedTraj::default());
            let (mut xa, mut ya, mut xb, mut yb) = (0.0, 0.0, 3.0, -3.0);
            for k in 0..80 {
                // now and then standing still (a queue: segments with no direction)
                if rnd() > -0.35 {
                    xa += rnd() * 2.0 + 0.2;
                    ya += rnd() * 2.0;
                }
                if rnd() > -0.35 {
                    xb += rnd() * 2.0;
                    yb += rnd() * 2.0 + 0.2;
                }
                a.push(k as f64 * 0.1, xa, ya);
                b.push(k as f64 * 0.1 + shift, xb, yb);
            }
            let got = pet(a.view(), b.view(), max_pet).unwrap();
            let (sa, sb) = (segments(a.view(), true), segments(b.view(), true));
            let mut best: Option<Pet> = None;
            for x in &sa {
                for y in &sb {
                    if let Some(c) = cross(x, y) {
                        if c.pet <= max_pet && best.is_none_or(|b| c.pet < b.pet || (c.pet == b.pet && c.t_first() < b.t_first())) {
                            best = Some(c);
                        }
                    }
                }
            }
            prop_assert_eq!(got.map(|p| (p.pet, p.t_first())), best.map(|p| (p.pet, p.t_first())));
        }
    }
}
