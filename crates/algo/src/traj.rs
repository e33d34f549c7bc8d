//! Trajectories: borrowed column views, validation and simple derived values.
//!
//! A trajectory is a time-ordered sequence of points `(t, x, y)` with `t` in
//! seconds. In SQL it is `STRUCT(t DOUBLE, x DOUBLE, y DOUBLE)[]`; here it is a
//! struct-of-arrays view ([`Traj`]) so that DuckDB's column buffers can be
//! borrowed without copying.
//!
//! # Input policy (decided once, used by every function)
//! - every `t`, `x`, `y` must be finite: NaN or ±inf is an error ([`TrajError::NotFinite`]);
//! - `t` must be non-decreasing ([`TrajError::Unsorted`]); duplicate timestamps are allowed;
//! - an empty trajectory is valid.

pub mod band;
pub mod grid;
pub mod stationary;

use super::{positive, positive_or_inf, ParamError};
use std::fmt;

/// A borrowed 2-D trajectory in struct-of-arrays form. All three slices have the same length.
#[derive(Clone, Copy, Debug)]
pub struct Traj<'a> {
    pub t: &'a [f64],
    pub x: &'a [f64],
    pub y: &'a [f64],
}

/// A borrowed 1-D series `(t, v)`, for example speeds from [`speeds`].
#[derive(Clone, Copy, Debug)]
pub struct Series<'a> {
    pub t: &'a [f64],
    pub v: &'a [f64],
}

/// An owned trajectory, used where points are filtered or produced.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OwnedTraj {
    pub t: Vec<f64>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

impl OwnedTraj {
    pub fn view(&self) -> Traj<'_> {
        Traj { t: &self.t, x: &self.x, y: &self.y }
    }
    pub fn push(&mut self, t: f64, x: f64, y: f64) {
        self.t.push(t);
        self.x.push(x);
        self.y.push(y);
    }
}

impl<'a> Traj<'a> {
    /// The points at `idx` (in that order), e.g. the points inside a region. O(|idx|).
    pub fn select(&self, idx: &[usize]) -> OwnedTraj {
        OwnedTraj {
            t: idx.iter().map(|&k| self.t[k]).collect(),
            x: idx.iter().map(|&k| self.x[k]).collect(),
            y: idx.iter().map(|&k| self.y[k]).collect(),
        }
    }
    /// Builds a view; panics if the slices differ in length (a programming error, not input).
    pub fn new(t: &'a [f64], x: &'a [f64], y: &'a [f64]) -> Self {
        assert!(t.len() == x.len() && t.len() == y.len(), "Traj::new: column lengths differ");
        Traj { t, x, y }
    }
    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    /// Checks the input policy of this module.
    pub fn validate(&self) -> Result<(), TrajError> {
        self.validate_bounds().map(|_| ())
    }
    /// [`Traj::validate`] and the bounding box of the points, in one pass over the columns
    /// (the readers of the SQL functions call it for every trajectory argument; the LCSS
    /// bindings use the box to answer pairs that are more than ε apart without another pass).
    /// O(n); an empty trajectory has the empty box [`Bounds::EMPTY`].
    pub fn validate_bounds(&self) -> Result<Bounds, TrajError> {
        match scan(*self) {
            Some(b) => Ok(b),
            None => check(self.t, &[("x", self.x), ("y", self.y)]).map(|_| bounds_slow(*self)),
        }
    }
}

/// Axis-aligned bounding box of a trajectory's points (`min > max` for no points).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min_x: f64,
    pub max_x: f64,
    pub min_y: f64,
    pub max_y: f64,
}

impl Bounds {
    /// The box of no points: every gap to it is infinite.
    pub const EMPTY: Bounds = Bounds { min_x: f64::INFINITY, max_x: f64::NEG_INFINITY, min_y: f64::INFINITY, max_y: f64::NEG_INFINITY };

    /// Whether some point of `self` and some point of `other` could be less than `eps` apart:
    /// false when the boxes are at least `eps` apart on one axis (then so is every pair of
    /// points, `‖a − b‖ >= |a_x − b_x|`) or when one is empty.
    pub fn within(&self, other: &Bounds, eps: f64) -> bool {
        if self.min_x > self.max_x || other.min_x > other.max_x {
            return false;
        }
        // (eps = inf: no spatial constraint, also where a difference overflows to inf)
        eps == f64::INFINITY
            || !(self.min_x - other.max_x >= eps
                || other.min_x - self.max_x >= eps
                || self.min_y - other.max_y >= eps
                || other.min_y - self.max_y >= eps)
    }
}

#[inline(always)]
fn lo(a: f64, b: f64) -> f64 {
    if b < a { b } else { a }
}
#[inline(always)]
fn hi(a: f64, b: f64) -> f64 {
    if b > a { b } else { a }
}

/// One branch-free pass over `t`, `x`, `y` in two lanes (one SSE2 register each; it
/// vectorises): the bounding box when every value is finite and `t` is non-decreasing, else
/// `None` (then the scans of [`check`] find the first offending position, and the box is
/// computed again). A sum of finite values is finite unless it overflows, and NaN or ±inf when
/// one is not, so a finite sum proves every value finite (an overflow only takes the slow
/// path); `t_k − t_{k−1}` of finite times is negative exactly when they are out of order.
fn scan(tr: Traj<'_>) -> Option<Bounds> {
    let n = tr.len();
    if n == 0 {
        return Some(Bounds::EMPTY);
    }
    let (t0, x0, y0) = (tr.t[0], tr.x[0], tr.y[0]);
    let mut sum = [t0 + x0 + y0, 0.0];
    let mut step = [0.0f64; 2];
    let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) = ([x0; 2], [x0; 2], [y0; 2], [y0; 2]);
    let (prev, t, x, y) = (&tr.t[..n - 1], &tr.t[1..], &tr.x[1..], &tr.y[1..]);
    let (pc, tc, xc, yc) = (prev.chunks_exact(2), t.chunks_exact(2), x.chunks_exact(2), y.chunks_exact(2));
    let rest = (pc.remainder(), tc.remainder(), xc.remainder(), yc.remainder());
    let lo2 = |a: [f64; 2], b: &[f64]| [lo(a[0], b[0]), lo(a[1], b[1])];
    let hi2 = |a: [f64; 2], b: &[f64]| [hi(a[0], b[0]), hi(a[1], b[1])];
    for (((p, t), x), y) in pc.zip(tc).zip(xc).zip(yc) {
        sum = [sum[0] + (t[0] + x[0] + y[0]), sum[1] + (t[1] + x[1] + y[1])];
        step = [lo(step[0], t[0] - p[0]), lo(step[1], t[1] - p[1])];
        x_lo = lo2(x_lo, x);
        x_hi = hi2(x_hi, x);
        y_lo = lo2(y_lo, y);
        y_hi = hi2(y_hi, y);
    }
    if let (Some(&p), Some(&t), Some(&x), Some(&y)) = (rest.0.first(), rest.1.first(), rest.2.first(), rest.3.first()) {
        sum[1] += t + x + y;
        step[1] = lo(step[1], t - p);
        x_lo[1] = lo(x_lo[1], x);
        x_hi[1] = hi(x_hi[1], x);
        y_lo[1] = lo(y_lo[1], y);
        y_hi[1] = hi(y_hi[1], y);
    }
    let total = sum[0] + sum[1];
    let ok = total - total == 0.0 && step[0] >= 0.0 && step[1] >= 0.0;
    ok.then(|| Bounds { min_x: lo(x_lo[0], x_lo[1]), max_x: hi(x_hi[0], x_hi[1]), min_y: lo(y_lo[0], y_lo[1]), max_y: hi(y_hi[0], y_hi[1]) })
}

/// The bounding box by plain folds (the slow path of [`Traj::validate_bounds`]; finite input).
fn bounds_slow(tr: Traj<'_>) -> Bounds {
    let fold = |s: &[f64], f: fn(f64, f64) -> f64, z: f64| s.iter().copied().fold(z, f);
    Bounds {
        min_x: fold(tr.x, lo, f64::INFINITY),
        max_x: fold(tr.x, hi, f64::NEG_INFINITY),
        min_y: fold(tr.y, lo, f64::INFINITY),
        max_y: fold(tr.y, hi, f64::NEG_INFINITY),
    }
}

impl<'a> Series<'a> {
    pub fn new(t: &'a [f64], v: &'a [f64]) -> Self {
        assert!(t.len() == v.len(), "Series::new: column lengths differ");
        Series { t, v }
    }
    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    pub fn validate(&self) -> Result<(), TrajError> {
        check(self.t, &[("v", self.v)])
    }
}

/// A borrowed 3-D trajectory `(t, x, y, z)` (`STRUCT(t, x, y, z)[]` in SQL), same input policy.
#[derive(Clone, Copy, Debug)]
pub struct Traj3<'a> {
    pub t: &'a [f64],
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub z: &'a [f64],
}

impl<'a> Traj3<'a> {
    pub fn new(t: &'a [f64], x: &'a [f64], y: &'a [f64], z: &'a [f64]) -> Self {
        assert!(t.len() == x.len() && t.len() == y.len() && t.len() == z.len(), "Traj3::new: column lengths differ");
        Traj3 { t, x, y, z }
    }
    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    pub fn validate(&self) -> Result<(), TrajError> {
        check(self.t, &[("x", self.x), ("y", self.y), ("z", self.z)])
    }
}

/// Why a trajectory was rejected. Indices are 0-based here; the SQL layer prints them 1-based.
#[derive(Clone, Debug, PartialEq)]
pub enum TrajError {
    NotFinite { index: usize, field: &'static str, value: f64 },
    Unsorted { index: usize, prev: f64, t: f64 },
    /// A parameter (`period`, `max_gap`, `min_step`) out of range.
    Param(ParamError),
    /// [`resample`] would produce more points than the work limit `output_points`.
    TooManyPoints(f64),
    /// [`resample`]'s output of this many points could not be allocated (whatever the limit).
    OutOfMemory(f64),
}

impl From<ParamError> for TrajError {
    fn from(e: ParamError) -> Self {
        TrajError::Param(e)
    }
}

impl TrajError {
    /// Formats the error for a trajectory argument called `param`, with 1-based SQL indices.
    pub fn describe(&self, param: &str) -> String {
        match self {
            TrajError::NotFinite { index, field, value } => {
                format!("{param}[{}].{field} must be finite, got {value}", index + 1)
            }
            TrajError::Unsorted { index, prev, t } => format!(
                "{param} must be ordered by t, but {param}[{}].t = {t} follows {param}[{}].t = {prev} \
                 (build it with list({{'t': t, 'x': x, 'y': y}} ORDER BY t))",
                index + 1,
                index
            ),
            TrajError::Param(e) => e.to_string(),
            TrajError::OutOfMemory(n) => format!(
                "would produce {n:.0} points ({:.0} bytes), which could not be allocated; use a longer period, or resample a shorter piece per call",
                n * 24.0
            ),
            TrajError::TooManyPoints(n) => {
                let l = &crate::limits::OUTPUT_POINTS;
                format!(
                    "would produce {n:.0} points, above the work limit {} = {}; use a longer period, or raise it with CALL trajdb_set_limit('{}', {n:.0})",
                    l.name,
                    l.get(),
                    l.name
                )
            }
        }
    }
}

impl fmt::Display for TrajError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.describe("trajectory"))
    }
}
impl std::error::Error for TrajError {}

/// The input policy: every column finite (t first), then t non-decreasing.
/// The input policy, O(n): a branch-free pass over the columns first (every value finite,
/// `t` non-decreasing; it vectorises, and it runs once per row of every SQL call), and only
/// when it fails the scans below that find the first offending position for the error.
fn check(t: &[f64], cols: &[(&'static str, &[f64])]) -> Result<(), TrajError> {
    if all_finite(t) && cols.iter().all(|(_, c)| all_finite(c)) && all_sorted(t) {
        return Ok(());
    }
    check_finite("t", t)?;
    for (name, c) in cols {
        check_finite(name, c)?;
    }
    check_sorted(t)
}

/// Whether every value is finite, without early exit (`|v| < inf` is false for NaN and ±inf).
fn all_finite(v: &[f64]) -> bool {
    let mut ok = [true; 4];
    let chunks = v.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..4 {
            ok[k] &= c[k].abs() < f64::INFINITY;
        }
    }
    rest.iter().all(|a| a.abs() < f64::INFINITY) && ok.iter().all(|&b| b)
}

/// Whether `t` is non-decreasing, without early exit (NaN-free input: [`all_finite`] first).
fn all_sorted(t: &[f64]) -> bool {
    if t.len() < 2 {
        return true;
    }
    let (prev, next) = (&t[..t.len() - 1], &t[1..]);
    let mut ok = [true; 4];
    let (pc, nc) = (prev.chunks_exact(4), next.chunks_exact(4));
    let (pr, nr) = (pc.remainder(), nc.remainder());
    for (p, n) in pc.zip(nc) {
        for k in 0..4 {
            ok[k] &= n[k] >= p[k];
        }
    }
    pr.iter().zip(nr).all(|(p, n)| n >= p) && ok.iter().all(|&b| b)
}

fn check_finite(field: &'static str, v: &[f64]) -> Result<(), TrajError> {
    match v.iter().position(|a| !a.is_finite()) {
        None => Ok(()),
        Some(index) => Err(TrajError::NotFinite { index, field, value: v[index] }),
    }
}

fn check_sorted(t: &[f64]) -> Result<(), TrajError> {
    match t.windows(2).position(|w| w[1] < w[0]) {
        None => Ok(()),
        Some(k) => Err(TrajError::Unsorted { index: k + 1, prev: t[k], t: t[k + 1] }),
    }
}

/// `last.t - first.t`; `None` for an empty trajectory, `0` for one point. O(1).
pub fn duration(t: &[f64]) -> Option<f64> {
    Some(t.last()? - t.first()?)
}

/// `(first.t, last.t)`; `None` for an empty trajectory. O(1).
pub fn time_range(t: &[f64]) -> Option<(f64, f64)> {
    Some((*t.first()?, *t.last()?))
}

/// Speeds by forward finite differences: for consecutive points `p_k, p_{k+1}` with
/// `dt = t_{k+1} - t_k > 0`, emits `(t_{k+1}, |p_{k+1} - p_k| / dt)`.
///
/// The sample is stamped at the later point, so the output has `n - 1` samples for `n`
/// points with distinct timestamps. Pairs with `dt == 0` (duplicate timestamps) are
/// skipped: a speed over zero time is undefined. O(n).
pub fn speeds(tr: Traj<'_>) -> (Vec<f64>, Vec<f64>) {
    let n = tr.len();
    let mut ts = Vec::with_capacity(n.saturating_sub(1));
    let mut vs = Vec::with_capacity(n.saturating_sub(1));
    let mut k = 0;
    for j in 1..n {
        let dt = tr.t[j] - tr.t[k];
        if dt > 0.0 {
            let d = (tr.x[j] - tr.x[k]).hypot(tr.y[j] - tr.y[k]);
            ts.push(tr.t[j]);
            vs.push(d / dt);
            k = j;
        }
    }
    (ts, vs)
}

/// Turn rate (rad/s), a rotation- and translation-invariant signature of a track.
///
/// The track is cut into displacement segments of at least `min_step` metres (consecutive
/// points are accumulated until the chord reaches it, which keeps position noise from
/// dominating the heading of slow road users). The heading of each segment is the direction
/// of its chord; the turn rate between two consecutive segments is the wrapped heading change
/// divided by the time between their ends, stamped at the later end. Fewer than two segments
/// give no samples. O(n). `min_step` must be > 0 and finite.
pub fn turn_rates(tr: Traj<'_>, min_step: f64) -> Result<(Vec<f64>, Vec<f64>), TrajError> {
    let min_step = positive("min_step", min_step)?;
    let mut ends: Vec<(f64, f64)> = Vec::new(); // (t, heading)
    let mut k = 0;
    for j in 1..tr.len() {
        let (dx, dy) = (tr.x[j] - tr.x[k], tr.y[j] - tr.y[k]);
        if dx.hypot(dy) >= min_step && tr.t[j] > tr.t[k] {
            ends.push((tr.t[j], dy.atan2(dx)));
            k = j;
        }
    }
    let mut ts = Vec::with_capacity(ends.len().saturating_sub(1));
    let mut vs = Vec::with_capacity(ends.len().saturating_sub(1));
    for w in ends.windows(2) {
        let mut d = w[1].1 - w[0].1;
        d = (d + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI;
        ts.push(w[1].0);
        vs.push(d / (w[1].0 - w[0].0));
    }
    Ok((ts, vs))
}

/// WKT for GIS tools: `LINESTRING (x y, ...)` for two or more points, `POINT (x y)` for one,
/// `LINESTRING EMPTY` for none. Coordinates use Rust's shortest round-trip formatting. O(n).
pub fn to_wkt(tr: Traj<'_>) -> String {
    use std::fmt::Write;
    match tr.len() {
        0 => "LINESTRING EMPTY".to_string(),
        1 => format!("POINT ({} {})", tr.x[0], tr.y[0]),
        n => {
            let mut s = String::with_capacity(16 + n * 24);
            s.push_str("LINESTRING (");
            for k in 0..n {
                if k > 0 {
                    s.push_str(", ");
                }
                let _ = write!(s, "{} {}", tr.x[k], tr.y[k]);
            }
            s.push(')');
            s
        }
    }
}

/// Little-endian ISO WKB of the same geometry as [`to_wkt`]: LINESTRING (type 2) for two or
/// more points, POINT (type 1) for one, LINESTRING EMPTY (zero points) for none. O(n).
pub fn to_wkb(tr: Traj<'_>) -> Vec<u8> {
    wkb_of(tr, false)
}

/// [`to_wkb`] with time as the M coordinate: ISO LINESTRING M (type 2002) / POINT M (2001),
/// each point (x, y, t). O(n).
pub fn to_wkb_m(tr: Traj<'_>) -> Vec<u8> {
    wkb_of(tr, true)
}

fn wkb_of(tr: Traj<'_>, m: bool) -> Vec<u8> {
    let n = tr.len();
    let base = if m { 2000u32 } else { 0 };
    let mut out = Vec::with_capacity(9 + if m { 24 } else { 16 } * n);
    out.push(1u8);
    if n == 1 {
        out.extend_from_slice(&(base + 1).to_le_bytes());
    } else {
        out.extend_from_slice(&(base + 2).to_le_bytes());
        out.extend_from_slice(&(n as u32).to_le_bytes());
    }
    for k in 0..n {
        out.extend_from_slice(&tr.x[k].to_le_bytes());
        out.extend_from_slice(&tr.y[k].to_le_bytes());
        if m {
            out.extend_from_slice(&tr.t[k].to_le_bytes());
        }
    }
    out
}

/// Path length in metres: the sum of |p[k+1] - p[k]| over consecutive points; 0 for one point,
/// `None` for none. O(n).
pub fn path_length(tr: Traj<'_>) -> Option<f64> {
    if tr.is_empty() {
        return None;
    }
    // fold from +0.0: `sum()` of no floats is -0.0
    Some((1..tr.len()).fold(0.0, |acc, k| acc + (tr.x[k] - tr.x[k - 1]).hypot(tr.y[k] - tr.y[k - 1])))
}


/// Resamples a validated trajectory onto the global clock t = k · `period` (k integer), by linear
/// interpolation between consecutive points; never extrapolates, and never interpolates across
/// a gap longer than `max_gap` seconds (a track break stays a break). Equal timestamps are a
/// zero-length segment and are skipped. Every camera resampled with the same period shares one
/// clock, so LCSS compares positions at the same instant instead of up to half a sample period
/// apart (at 12 m/s and 5 Hz that is 1.2 m, more than the matching ε).
/// O(n + m) for n input and m output points. Errors when m would exceed the work limit
/// [`crate::limits::OUTPUT_POINTS`], when `period` is not > 0 and finite, or `max_gap` not > 0
/// (`+inf`: no limit).
pub fn resample(tr: Traj<'_>, period: f64, max_gap: f64) -> Result<OwnedTraj, TrajError> {
    let period = positive("period", period)?;
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    let n = tr.len();
    let mut out = OwnedTraj::default();
    if n == 0 {
        return Ok(out);
    }
    let (t0, t1) = (tr.t[0], tr.t[n - 1]);
    let estimate = ((t1 - t0) / period).floor() + 1.0;
    if estimate > crate::limits::OUTPUT_POINTS.get() as f64 {
        return Err(TrajError::TooManyPoints(estimate));
    }
    // the clock index k = t / period must be an exact integer in f64 (|k| < 2^53), or the grid
    // cannot be walked (a period of 1e-320 made k saturate and the walk never end)
    const EXACT: f64 = 9_007_199_254_740_992.0;
    if !((t0 / period).abs() < EXACT && (t1 / period).abs() < EXACT) {
        return Err(TrajError::Param(ParamError {
            name: "period",
            rule: "large enough that t / period stays below 2^53 for every t of the trajectory",
            value: period,
        }));
    }
    // the output, reserved for the estimate (an upper bound, give or take rounding) fallibly:
    // a limit raised past what memory holds is an error, never an abort
    let want = (estimate as usize).saturating_add(2);
    if out.t.try_reserve_exact(want).is_err() || out.x.try_reserve_exact(want).is_err() || out.y.try_reserve_exact(want).is_err() {
        return Err(TrajError::OutOfMemory(estimate));
    }
    let mut j = 0usize;
    for t in grid::clock_ticks(t0, t1, period) {
        while j + 1 < n && tr.t[j + 1] < t {
            j += 1;
        }
        if j + 1 == n || tr.t[j] >= t {
            // exactly on a sample (or the last one)
            if tr.t[j] == t {
                out.push(t, tr.x[j], tr.y[j]);
            } else if j + 1 < n && tr.t[j + 1] == t {
                out.push(t, tr.x[j + 1], tr.y[j + 1]);
            }
            continue;
        }
        // tr.t[j] < t <= tr.t[j + 1]
        let (ta, tb) = (tr.t[j], tr.t[j + 1]);
        if tb == t {
            out.push(t, tr.x[j + 1], tr.y[j + 1]);
            continue;
        }
        if tb - ta > max_gap {
            continue;
        }
        let f = (t - ta) / (tb - ta);
        out.push(t, tr.x[j] + f * (tr.x[j + 1] - tr.x[j]), tr.y[j] + f * (tr.y[j + 1] - tr.y[j]));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 17 (found by the fuzz harness): equal times and a period of 1e-320 walked the
    /// clock forever; the clock index must stay an exact f64 integer.
    /// Issue 37: with output_points lifted, a resample into 1e12 points is an error (its output
    /// is reserved fallibly first), not an abort of the host.
    #[test]
    fn resample_past_memory_is_an_error_whatever_the_limit() {
        let lifted = std::sync::Arc::new(crate::limits::Limits::default());
        lifted.set("output_points", i64::MAX).unwrap();
        let tr = OwnedTraj { t: vec![0.0, 1e6], x: vec![0.0, 1.0], y: vec![0.0, 0.0] };
        let e = crate::limits::with_scope(&lifted, || resample(tr.view(), 1e-6, f64::INFINITY)).unwrap_err();
        assert!(matches!(e, TrajError::OutOfMemory(_)), "{e}");
        assert!(e.describe("traj").contains("could not be allocated"), "{e}");
    }

    #[test]
    fn resample_refuses_a_period_below_the_clock_resolution() {
        let (t, x, y) = ([1.0, 1.0], [0.0, 1.0], [0.0, 0.0]);
        let e = resample(Traj::new(&t, &x, &y), 1e-320, f64::INFINITY).unwrap_err();
        assert!(e.to_string().contains("period must be large enough that t / period stays below 2^53"), "{e}");
        assert_eq!(resample(Traj::new(&t, &x, &y), 0.5, f64::INFINITY).unwrap().t, vec![1.0]);
    }

    #[test]
    fn resample_on_the_global_clock() {
        let (t, x, y) = ([0.03, 0.23, 0.43, 3.0, 3.2], [0.0, 2.0, 4.0, 10.0, 12.0], [1.0; 5]);
        let r = resample(Traj::new(&t, &x, &y), 0.1, 1.0).unwrap();
        // 0.1 .. 0.4, then the 2.57 s gap is not bridged, then 3.0 .. 3.2
        let want_t = [0.1, 0.2, 0.3, 0.4, 3.0, 3.1, 3.2];
        assert_eq!(r.t.len(), want_t.len(), "{:?}", r.t);
        for (a, b) in r.t.iter().zip(want_t) {
            assert!((a - b).abs() < 1e-12);
        }
        assert!((r.x[0] - 0.7).abs() < 1e-9 && (r.x[3] - 3.7).abs() < 1e-9 && r.x[4] == 10.0 && (r.x[5] - 11.0).abs() < 1e-9);
        // bridging allowed: the gap is interpolated
        assert_eq!(resample(Traj::new(&t, &x, &y), 0.1, f64::INFINITY).unwrap().t.len(), 32);
        // one point on / off the grid, empty, duplicate timestamps
        assert_eq!(resample(Traj::new(&[0.5], &[1.0], &[2.0]), 0.1, 1.0).unwrap().t, vec![0.5]);
        assert!(resample(Traj::new(&[0.55], &[1.0], &[2.0]), 0.1, 1.0).unwrap().t.is_empty());
        assert!(resample(Traj::new(&[], &[], &[]), 0.1, 1.0).unwrap().t.is_empty());
        let r = resample(Traj::new(&[0.0, 0.0, 1.0], &[5.0, 7.0, 8.0], &[0.0; 3]), 0.5, 2.0).unwrap();
        assert_eq!(r.t, vec![0.0, 0.5, 1.0]);
        assert_eq!(r.x, vec![5.0, 7.5, 8.0]);
        assert!(resample(Traj::new(&[0.0, 1e9], &[0.0, 1.0], &[0.0; 2]), 1e-3, f64::INFINITY).is_err());
        let e = |p, g| resample(Traj::new(&[], &[], &[]), p, g).unwrap_err().to_string();
        assert_eq!(e(0.0, 1.0), "period must be > 0, got 0");
        assert_eq!(e(f64::INFINITY, 1.0), "period must be > 0, got inf");
        assert_eq!(e(0.1, -1.0), "max_gap must be > 0, got -1");
    }

    proptest::proptest! {
        #[test]
        fn resample_matches_a_naive_interpolation(steps in proptest::collection::vec((0.0f64..0.4, -3.0f64..3.0), 1..40), period in 0.05f64..0.5) {
            let mut t = vec![0.37];
            let mut x = vec![0.0];
            for (dt, dx) in &steps {
                t.push(t.last().unwrap() + dt);
                x.push(x.last().unwrap() + dx);
            }
            let y: Vec<f64> = x.iter().map(|v| -2.0 * v).collect();
            let r = resample(Traj::new(&t, &x, &y), period, 0.3).unwrap();
            // naive: for every grid time, find any segment containing it with length <= max_gap
            let mut want = Vec::new();
            let mut k = (t[0] / period).ceil() as i64;
            while (k as f64) * period <= *t.last().unwrap() {
                let tk = k as f64 * period;
                k += 1;
                let mut v = None;
                for i in 0..t.len() {
                    if t[i] == tk { v = Some(x[i]); break; }
                    if i + 1 < t.len() && t[i] < tk && tk < t[i + 1] {
                        if t[i + 1] - t[i] <= 0.3 { v = Some(x[i] + (tk - t[i]) / (t[i + 1] - t[i]) * (x[i + 1] - x[i])); }
                        break;
                    }
                }
                if let Some(v) = v { want.push((tk, v)); }
            }
            proptest::prop_assert_eq!(r.t.len(), want.len());
            for (k, (tk, v)) in want.iter().enumerate() {
                proptest::prop_assert!((r.t[k] - tk).abs() < 1e-12 && (r.x[k] - v).abs() < 1e-9 && (r.y[k] + 2.0 * v).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn path_length_sums_segments() {
        let (t, x, y) = ([0.0, 1.0, 2.0], [0.0, 3.0, 3.0], [0.0, 4.0, 6.0]);
        assert_eq!(path_length(Traj::new(&t, &x, &y)), Some(7.0));
        let one = path_length(Traj::new(&t[..1], &x[..1], &y[..1])).unwrap();
        assert!(one == 0.0 && one.is_sign_positive());
        assert_eq!(path_length(Traj::new(&[], &[], &[])), None);
    }

    #[test]
    fn wkb_m_carries_time() {
        let (t, x, y) = ([10.0, 11.5], [1.0, 2.0], [3.0, 4.0]);
        let b = to_wkb_m(Traj::new(&t, &x, &y));
        assert_eq!(u32::from_le_bytes(b[1..5].try_into().unwrap()), 2002);
        assert_eq!(b.len(), 9 + 2 * 24);
        assert_eq!(f64::from_le_bytes(b[9 + 24 + 16..9 + 48].try_into().unwrap()), 11.5);
        let p = to_wkb_m(Traj::new(&t[..1], &x[..1], &y[..1]));
        assert_eq!(u32::from_le_bytes(p[1..5].try_into().unwrap()), 2001);
    }

    #[test]
    fn wkb_reads_back_as_the_wkt_geometry() {
        use geo_traits::{CoordTrait, GeometryTrait, GeometryType, LineStringTrait, PointTrait};
        let (t, x, y) = ([0.0, 1.0, 2.0], [0.5, -1.25, 3.0], [2.0, 4.5, -7.0]);
        let b = to_wkb(Traj::new(&t, &x, &y));
        let g = wkb::reader::read_wkb(&b).unwrap();
        match g.as_type() {
            GeometryType::LineString(l) => {
                assert_eq!(l.num_coords(), 3);
                let c = l.coord(1).unwrap();
                assert_eq!((c.x(), c.y()), (-1.25, 4.5));
            }
            _ => panic!("not a linestring"),
        }
        let b = to_wkb(Traj::new(&t[..1], &x[..1], &y[..1]));
        match wkb::reader::read_wkb(&b).unwrap().as_type() {
            GeometryType::Point(p) => assert_eq!(p.coord().unwrap().x(), 0.5),
            _ => panic!("not a point"),
        }
        let b = to_wkb(Traj::new(&[], &[], &[]));
        assert_eq!(b, [1, 2, 0, 0, 0, 0, 0, 0, 0]);
    }

    #[test]
    fn validate_rejects_nan_inf_and_unsorted() {
        let t = [0.0, 1.0, 2.0];
        let x = [0.0, f64::NAN, 1.0];
        let y = [0.0; 3];
        let e = Traj::new(&t, &x, &y).validate().unwrap_err();
        assert_eq!(e.describe("a"), "a[2].x must be finite, got NaN");
        let t2 = [0.0, 2.0, 1.0];
        let e = Traj::new(&t2, &y, &y).validate().unwrap_err();
        assert!(e.describe("b").starts_with("b must be ordered by t, but b[3].t = 1 follows b[2].t = 2"));
        let t3 = [0.0, f64::INFINITY, 1.0];
        assert!(Traj::new(&t3, &y, &y).validate().is_err());
    }

    #[test]
    fn traj3_and_select() {
        let (t, x) = ([0.0, 1.0, 0.5], [1.0, 2.0, 3.0]);
        let e = Traj3::new(&t, &x, &x, &x).validate().unwrap_err();
        assert!(e.describe("fixed").starts_with("fixed must be ordered by t, but fixed[3].t = 0.5 follows fixed[2].t = 1"));
        let z = [0.0, f64::NAN, 0.0];
        assert_eq!(Traj3::new(&x, &x, &x, &z).validate().unwrap_err().describe("a"), "a[2].z must be finite, got NaN");
        let s = Traj::new(&t, &x, &x).select(&[2, 0]);
        assert_eq!((s.t, s.x), (vec![0.5, 0.0], vec![3.0, 1.0]));
    }

    proptest::proptest! {
        /// The branch-free pass of `check` agrees with the obviously-right early-exit scans
        /// (lengths around the 4-lane chunks, NaN / ±inf and unsorted times anywhere).
        #[test]
        fn fast_validation_agrees_with_the_scans(
            v in proptest::collection::vec(proptest::prop_oneof![
                8 => proptest::strategy::Strategy::prop_map(0u8..6, |k| k as f64),
                1 => proptest::sample::select(vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY]),
            ], 0..14),
            sort in proptest::bool::ANY,
        ) {
            use proptest::prelude::*;
            let mut t = v.clone();
            if sort {
                t.sort_by(|a, b| a.total_cmp(b));
            }
            let slow = check_finite("t", &t).is_ok() && check_finite("x", &v).is_ok() && check_sorted(&t).is_ok();
            prop_assert_eq!(all_finite(&t) && all_finite(&v) && all_sorted(&t), slow);
            prop_assert_eq!(Traj::new(&t, &v, &v).validate().is_ok(), slow);
            // the fused pass: same verdict (same error), and the box of the points
            let y: Vec<f64> = v.iter().rev().copied().collect();
            let tr = Traj::new(&t, &v, &y);
            let want = check(&t, &[("x", &v), ("y", &y)]);
            match tr.validate_bounds() {
                Ok(b) => {
                    prop_assert!(want.is_ok());
                    let min = |s: &[f64]| s.iter().copied().fold(f64::INFINITY, f64::min);
                    let max = |s: &[f64]| s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    prop_assert_eq!(b, Bounds { min_x: min(&v), max_x: max(&v), min_y: min(&y), max_y: max(&y) });
                }
                // (compared as messages: the errors hold the offending value, maybe NaN)
                Err(e) => prop_assert_eq!(Some(e.describe("a")), want.err().map(|w| w.describe("a"))),
            }
        }
    }

    #[test]
    fn duplicates_and_empty_are_valid() {
        let t = [0.0, 0.0, 1.0];
        let z = [0.0; 3];
        assert!(Traj::new(&t, &z, &z).validate().is_ok());
        assert!(Traj::new(&[], &[], &[]).validate().is_ok());
    }

    #[test]
    fn speeds_skip_zero_dt() {
        let t = [0.0, 1.0, 1.0, 3.0];
        let x = [0.0, 3.0, 9.0, 3.0];
        let y = [0.0, 4.0, 9.0, 8.0];
        let (ts, vs) = speeds(Traj::new(&t, &x, &y));
        assert_eq!(ts, vec![1.0, 3.0]);
        assert_eq!(vs, vec![5.0, 2.0]);
        assert_eq!(speeds(Traj::new(&[1.0], &[1.0], &[1.0])).0.len(), 0);
    }

    #[test]
    fn turn_rates_are_rotation_invariant() {
        // A quarter circle of radius 10 m in 10 s: 0.157 rad/s everywhere.
        let t: Vec<f64> = (0..=100).map(|k| k as f64 * 0.1).collect();
        let x: Vec<f64> = t.iter().map(|t| 10.0 * (t * 0.157).cos()).collect();
        let y: Vec<f64> = t.iter().map(|t| 10.0 * (t * 0.157).sin()).collect();
        let (rx, ry): (Vec<f64>, Vec<f64>) = x.iter().zip(&y).map(|(&a, &b)| (a * 0.3f64.cos() - b * 0.3f64.sin() + 5.0, a * 0.3f64.sin() + b * 0.3f64.cos())).unzip();
        let (t1, v1) = turn_rates(Traj::new(&t, &x, &y), 1.0).unwrap();
        let (t2, v2) = turn_rates(Traj::new(&t, &rx, &ry), 1.0).unwrap();
        assert_eq!(t1, t2);
        assert!(v1.iter().zip(&v2).all(|(a, b)| (a - b).abs() < 1e-9));
        assert!(v1.iter().all(|v| (v - 0.157).abs() < 0.01), "{v1:?}");
        assert!(turn_rates(Traj::new(&[0.0], &[0.0], &[0.0]), 1.0).unwrap().0.is_empty());
        assert_eq!(turn_rates(Traj::new(&[], &[], &[]), 0.0).unwrap_err().to_string(), "min_step must be > 0, got 0");
    }

    #[test]
    fn wkt_forms() {
        assert_eq!(to_wkt(Traj::new(&[], &[], &[])), "LINESTRING EMPTY");
        assert_eq!(to_wkt(Traj::new(&[0.0], &[1.5], &[2.0])), "POINT (1.5 2)");
        assert_eq!(
            to_wkt(Traj::new(&[0.0, 1.0], &[1.0, 3.0], &[2.0, -4.25])),
            "LINESTRING (1 2, 3 -4.25)"
        );
        assert_eq!(duration(&[1.0, 4.5]), Some(3.5));
        assert_eq!(duration(&[]), None);
        assert_eq!(time_range(&[1.0, 4.5]), Some((1.0, 4.5)));
    }
}
