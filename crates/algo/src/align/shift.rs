//! Clock offsets between two cameras, found together with the rigid transform.
//!
//! Roadside units are rarely synchronised: a camera's clock may be off by tenths of a second.
//! Write `dt` for the moving camera's clock minus the fixed camera's clock, so that a road user
//! seen at fixed time `t` is seen at moving time `t + dt`. [`correspond`](super::correspond) at
//! `dt = 0` then pairs points that are `v·dt` apart along the track, and the fitted translation
//! is off by about `v̄·dt` (0.3 s at 10 m/s: 3 m, different for every direction of travel, so
//! the consensus vote of the align stage scatters).
//!
//! * [`scan`]: one track pair, fitted in closed form ([`rigid::fit`]) at every shift
//!   `dt = -max, -max + step, …, max`, with the moving times mapped to the fixed clock as
//!   `t − dt`. This is a Hough line per hypothesis: a straight track fits well at every `dt`,
//!   with a translation that slides along the track as `dt` changes; a track that turns or
//!   changes speed fits well only near the true `dt`. Voting over `(θ, tx, ty, dt)` bins finds
//!   the one bin where the track pairs of a camera pair agree, whatever their directions.
//! * [`joint`]: the agreeing track pairs of one camera pair, fitted together (least trimmed
//!   squares, [`rigid::fit_trimmed`]) at every shift of a fine grid; the shift with the least
//!   trimmed RMS, refined by the vertex of the parabola through it and its two neighbours, and
//!   the transform fitted at that shift. Straight tracks in one direction cannot separate `dt`
//!   from a translation along the road (the least-squares valley is flat); tracks in two or
//!   more directions, or turning tracks, can, and the joint fit uses all of them at once.
//!
//! # Complexity
//! [`scan`]: O(S·K·log m) for S = 2·⌊max/step⌋ + 1 shifts and K ≤ [`SCAN_PAIRS`] pairs per shift. [`joint`]: O(W·S·I·P) for P point
//! pairs over all track pairs, I ≤ 50 trimming rounds (each O(P): a selection, not a sort) and
//! W ≤ 1 + [`MAX_WALKS`] grid passes; W·S·(points) is bounded by the work limit `shift_pair_fits`.

use super::correspond::{correspond_into, interpolation_weight, Pairs};
use super::rigid::{self, RigidError, Transform2};
use crate::limits;
use crate::traj::Traj;
use crate::{finite, non_negative, positive, positive_or_inf, ParamError};
use rayon::prelude::*;
use std::fmt;

/// Errors of this module.
#[derive(Clone, Debug, PartialEq)]
pub enum ShiftError {
    Param(ParamError),
    Rigid(RigidError),
    /// `max / step` would give more than [`MAX_SHIFTS`] shifts.
    TooManyShifts { max: f64, step: f64 },
    /// `joint` was given different numbers of fixed and moving tracks.
    Lengths { fixed: usize, moving: usize },
    /// `joint` would fit more point pairs than the work limit `shift_pair_fits`.
    Work(limits::Exceeded),
    /// `register::register` would fit more point pairs than the work limit `shift_pair_fits`.
    RegisterWork(limits::Exceeded),
}

impl fmt::Display for ShiftError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShiftError::Param(e) => e.fmt(f),
            ShiftError::Rigid(e) => e.fmt(f),
            ShiftError::TooManyShifts { max, step } => {
                write!(f, "max_shift / step must give at most {MAX_SHIFTS} shifts, got max_shift {max} and step {step}")
            }
            ShiftError::Lengths { fixed, moving } => write!(f, "fixed and moving must list as many tracks, got {fixed} and {moving}"),
            ShiftError::Work(e) => write!(f, "{e}, or search fewer shifts (a larger step or a smaller half_width) or fewer points"),
            ShiftError::RegisterWork(e) => write!(f, "{e}, or register fewer track pairs or shorter tracks"),
        }
    }
}
impl std::error::Error for ShiftError {}
impl From<ParamError> for ShiftError {
    fn from(e: ParamError) -> Self {
        ShiftError::Param(e)
    }
}
impl From<RigidError> for ShiftError {
    fn from(e: RigidError) -> Self {
        ShiftError::Rigid(e)
    }
}

/// [`joint`] moves its grid at most this many times, and never farther than [`WALK_LIMIT`]
/// seconds from where it started.
pub const MAX_WALKS: usize = 20;
pub const WALK_LIMIT: f64 = 1.0;

/// The most shifts one scan or joint fit evaluates (bounds the work of one call).
pub const MAX_SHIFTS: usize = 100_001;

/// The shift grid `centre + k·step`, |k·step| ≤ `half_width`, validated once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftGrid {
    pub centre: f64,
    pub half_width: f64,
    pub step: f64,
    /// Number of shifts on each side of the centre.
    pub k: usize,
}

impl ShiftGrid {
    /// `half_width >= 0` and `step > 0`, all finite, and at most [`MAX_SHIFTS`] shifts.
    pub fn new(centre: f64, half_width: f64, step: f64) -> Result<Self, ShiftError> {
        let centre = finite("centre", centre)?;
        let half_width = non_negative("max_shift", half_width)?;
        let step = positive("step", step)?;
        let k = (half_width / step + 1e-9).floor();
        if 2.0 * k + 1.0 > MAX_SHIFTS as f64 {
            return Err(ShiftError::TooManyShifts { max: half_width, step });
        }
        Ok(ShiftGrid { centre, half_width, step, k: k as usize })
    }

    /// The shifts, in ascending order.
    pub fn shifts(&self) -> impl Iterator<Item = f64> + '_ {
        let k = self.k as i64;
        (-k..=k).map(move |i| self.centre + i as f64 * self.step)
    }
}

/// One fit at one shift.
#[derive(Clone, Debug, PartialEq)]
pub struct ShiftFit {
    /// Moving clock minus fixed clock (s).
    pub dt: f64,
    pub transform: Transform2,
    /// RMS residual ([`joint`]: of the kept pairs, each squared residual weighted by
    /// [`interpolation_weight`]).
    pub rms: f64,
    /// Point pairs used.
    pub n: usize,
    /// The larger side of the bounding box of the moving points paired (m): how much of the
    /// track the fit saw.
    pub span: f64,
}

/// [`correspond`](super::correspond::correspond) with the moving times read as `t − dt` (`dt` finite).
pub fn correspond_at(fixed: Traj<'_>, moving: Traj<'_>, dt: f64, max_gap: f64) -> Result<Pairs, ParamError> {
    let dt = finite("shift", dt)?;
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    let mut out = Pairs::default();
    correspond_into(fixed, moving, dt, max_gap, &mut out);
    Ok(out)
}

/// `(fixed[i], moving[i])` pairs for [`joint`]; the two lists must be as long.
pub fn zip_tracks<'a>(fixed: &[Traj<'a>], moving: &[Traj<'a>]) -> Result<Vec<(Traj<'a>, Traj<'a>)>, ShiftError> {
    if fixed.len() != moving.len() {
        return Err(ShiftError::Lengths { fixed: fixed.len(), moving: moving.len() });
    }
    Ok(fixed.iter().copied().zip(moving.iter().copied()).collect())
}

fn span(p: &Pairs) -> f64 {
    let ext = |v: &[f64]| v.iter().fold(f64::INFINITY, |a, &b| a.min(b)) - v.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    if p.mx.is_empty() {
        0.0
    } else {
        (-ext(&p.mx)).max(-ext(&p.my))
    }
}

/// The most point pairs one [`scan`] fit uses: longer overlaps are subsampled evenly (a vote
/// needs a hypothesis, not its last digit), so a scan costs O(S · SCAN_PAIRS · log m).
pub const SCAN_PAIRS: usize = 48;

/// See the module docs: the closed-form fit of one track pair at every shift of `grid`. Shifts
/// that leave fewer than 2 point pairs, or pairs all at one point, give no fit. Both tracks
/// must satisfy [`Traj::validate`]; `max_gap` as in [`correspond`]. At most [`SCAN_PAIRS`]
/// evenly spread fixed points are paired per shift; `n` counts every fixed point inside the
/// moving track's shifted time span.
pub fn scan(fixed: Traj<'_>, moving: Traj<'_>, grid: &ShiftGrid, max_gap: f64) -> Result<Vec<ShiftFit>, ShiftError> {
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    let mut out = Vec::new();
    let (n, m) = (fixed.len(), moving.len());
    if n == 0 || m == 0 {
        return Ok(out);
    }
    let mut p = Pairs::default();
    for dt in grid.shifts() {
        // fixed points inside the moving span [moving.t0 - dt, moving.t1 - dt]
        let (lo_t, hi_t) = (moving.t[0] - dt, moving.t[m - 1] - dt);
        let lo = fixed.t.partition_point(|&t| t < lo_t);
        let hi = fixed.t.partition_point(|&t| t <= hi_t);
        if hi <= lo + 1 {
            continue;
        }
        let inside = hi - lo;
        let stride = inside.div_ceil(SCAN_PAIRS).max(1);
        p.t.clear();
        p.u.clear();
        p.fx.clear();
        p.fy.clear();
        p.mx.clear();
        p.my.clear();
        for i in (lo..hi).step_by(stride) {
            let tm = fixed.t[i] + dt; // on the moving clock
            let j = moving.t.partition_point(|&t| t <= tm).saturating_sub(1); // moving.t[j] <= tm
            let (x, y) = if moving.t[j] == tm || j + 1 == m {
                (moving.x[j], moving.y[j])
            } else {
                let (t0, t1) = (moving.t[j], moving.t[j + 1]);
                if t1 - t0 > max_gap {
                    continue;
                }
                let u = (tm - t0) / (t1 - t0);
                (moving.x[j] + u * (moving.x[j + 1] - moving.x[j]), moving.y[j] + u * (moving.y[j + 1] - moving.y[j]))
            };
            p.t.push(fixed.t[i]);
            p.fx.push(fixed.x[i]);
            p.fy.push(fixed.y[i]);
            p.mx.push(x);
            p.my.push(y);
        }
        match rigid::fit(&p.fx, &p.fy, &p.mx, &p.my, &[], false) {
            Ok((transform, rms)) => {
                let used = p.t.len();
                out.push(ShiftFit { dt, transform, rms, n: if stride == 1 { used } else { inside.min(used * stride) }, span: span(&p) })
            }
            Err(RigidError::TooFew { .. } | RigidError::Degenerate) => {}
            Err(e) => return Err(e.into()),
        }
    }
    Ok(out)
}

/// All track pairs' point pairs at one shift, concatenated (`max_gap` already checked).
fn joint_pairs(tracks: &[(Traj<'_>, Traj<'_>)], dt: f64, max_gap: f64) -> Result<Pairs, ParamError> {
    let dt = finite("shift", dt)?;
    let mut all = Pairs::default();
    for &(f, m) in tracks {
        correspond_into(f, m, dt, max_gap, &mut all);
    }
    Ok(all)
}

/// Position noise of the two cameras (per axis, m), for [`interpolation_weight`]; both 0: equal.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Noise {
    pub fixed: f64,
    pub moving: f64,
}

impl Noise {
    /// Both finite and >= 0.
    pub fn new(fixed: f64, moving: f64) -> Result<Self, ShiftError> {
        Ok(Noise { fixed: non_negative("sigma_fixed", fixed)?, moving: non_negative("sigma_moving", moving)? })
    }
}

fn joint_at(tracks: &[(Traj<'_>, Traj<'_>)], dt: f64, max_gap: f64, trim: f64, noise: Noise) -> Result<Option<ShiftFit>, ShiftError> {
    let p = joint_pairs(tracks, dt, max_gap)?;
    match rigid::fit_trimmed(&p.fx, &p.fy, &p.mx, &p.my, trim, false) {
        Ok(f) => {
            // the objective compared across shifts: the mean interpolation-weighted squared
            // residual of the kept pairs (see correspond::interpolation_weight)
            let (mut s, mut k) = (0.0, 0usize);
            let map = f.transform.mapper();
            for i in (0..p.t.len()).filter(|&i| f.inliers[i]) {
                let (x, y) = map(p.mx[i], p.my[i]);
                s += interpolation_weight(p.u[i], noise.fixed, noise.moving) * ((p.fx[i] - x).powi(2) + (p.fy[i] - y).powi(2));
                k += 1;
            }
            let rms = if k > 0 { (s / k as f64).sqrt() } else { f.rms };
            Ok(Some(ShiftFit { dt, transform: f.transform, rms, n: p.t.len(), span: span(&p) }))
        }
        Err(RigidError::TooFew { .. } | RigidError::Degenerate) => Ok(None),
        Err(e) => Err(e.into()),
    }
}

/// The work of `passes` grid passes of [`joint`]: every pass fits the point pairs of every
/// shift, at most one pair per point of the fixed and moving tracks. Checked against the limit
/// `shift_pair_fits` before each pass (the first pass and every walk of the grid), so the
/// whole call stays within it.
pub fn check_joint_work(tracks: &[(Traj<'_>, Traj<'_>)], grid: &ShiftGrid, passes: u128) -> Result<(), ShiftError> {
    let points: u128 = tracks.iter().map(|(f, m)| (f.len() + m.len()) as u128).sum();
    let needed = passes * (2 * grid.k as u128 + 1) * points;
    limits::SHIFT_PAIR_FITS.check(needed).map_err(ShiftError::Work)
}

/// See the module docs: the shift of `grid` (refined between grid points) and the transform
/// that fit all `(fixed, moving)` track pairs best together, trimming `trim` of the point pairs;
/// `noise` weighs the residuals of interpolated pairs ([`interpolation_weight`]).
/// `None` when no shift gives a fit (fewer than 2 point pairs). The work (shifts × points, per
/// grid pass) is checked against the limit `shift_pair_fits` before each pass
/// ([`check_joint_work`]); the shifts of a pass are fitted in parallel.
pub fn joint(tracks: &[(Traj<'_>, Traj<'_>)], grid: &ShiftGrid, max_gap: f64, trim: f64, noise: Noise) -> Result<Option<ShiftFit>, ShiftError> {
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    let centre0 = grid.centre;
    if !(0.0..1.0).contains(&trim) {
        return Err(RigidError::Trim(trim).into());
    }
    // Search the grid; while the best shift is at its edge, move the grid there and search on
    // (the vote's bin can sit off the minimum where offset and rotation trade off, e.g. on a
    // roundabout, where circling at constant speed looks the same shifted in time and rotated),
    // at most `MAX_WALKS` times and never beyond `WALK_LIMIT` from the first centre.
    let mut grid = *grid;
    let mut walks = 0;
    let (fits, i) = loop {
        check_joint_work(tracks, &grid, walks as u128 + 1)?;
        // the shifts are independent: fitted in parallel, the first error in grid order wins
        let shifts: Vec<f64> = grid.shifts().collect();
        let fits: Vec<Result<Option<ShiftFit>, ShiftError>> = shifts.par_iter().map(|&dt| joint_at(tracks, dt, max_gap, trim, noise)).collect();
        let fits: Vec<Option<ShiftFit>> = fits.into_iter().collect::<Result<_, _>>()?;
        let Some(i) = fits.iter().enumerate().filter_map(|(i, f)| f.as_ref().map(|f| (i, f))).min_by(|a, b| a.1.rms.total_cmp(&b.1.rms)).map(|x| x.0)
        else {
            return Ok(None);
        };
        let at_edge = grid.k > 0 && (i == 0 || i + 1 == fits.len());
        if !at_edge || walks >= MAX_WALKS || (fits[i].as_ref().unwrap().dt - centre0).abs() + grid.half_width > WALK_LIMIT {
            break (fits, i);
        }
        grid.centre = fits[i].as_ref().unwrap().dt;
        walks += 1;
    };
    let best = fits[i].as_ref().unwrap();
    // Parabola through the best shift and its neighbours (same number of pairs or close: the
    // vertex is only taken inside the bracket, where the objective is locally smooth).
    if i == 0 || i + 1 == fits.len() {
        return Ok(Some(best.clone()));
    }
    let (Some(l), Some(r)) = (&fits[i - 1], &fits[i + 1]) else { return Ok(Some(best.clone())) };
    let (f0, f1, f2) = (l.rms * l.rms, best.rms * best.rms, r.rms * r.rms);
    let curv = f0 - 2.0 * f1 + f2;
    if !(curv > 0.0) {
        return Ok(Some(best.clone()));
    }
    let u = (0.5 * (f0 - f2) / curv).clamp(-0.5, 0.5);
    let dt = best.dt + u * grid.step;
    match joint_at(tracks, dt, max_gap, trim, noise)? {
        Some(f) if f.rms <= best.rms => Ok(Some(f)),
        _ => Ok(Some(best.clone())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traj::OwnedTraj;

    /// A road user on a curve, sampled at `rate` with phase `phase`, in world coordinates.
    fn curve(t0: f64, t1: f64, rate: f64, phase: f64, f: impl Fn(f64) -> (f64, f64)) -> OwnedTraj {
        let mut tr = OwnedTraj { t: vec![], x: vec![], y: vec![] };
        let mut t = t0 + phase;
        while t <= t1 {
            let (x, y) = f(t);
            tr.t.push(t);
            tr.x.push(x);
            tr.y.push(y);
            t += 1.0 / rate;
        }
        tr
    }

    /// The moving camera's view: world -> local by the inverse of `tf`, clock + `dt`.
    fn observe(w: &OwnedTraj, tf: &Transform2, dt: f64) -> OwnedTraj {
        let inv = tf.invert();
        let mut o = w.clone();
        for k in 0..o.t.len() {
            let (x, y) = inv.apply(w.x[k], w.y[k]);
            o.x[k] = x;
            o.y[k] = y;
            o.t[k] += dt;
        }
        o
    }

    fn turning(t: f64) -> (f64, f64) {
        // straight east at 8 m/s for 2 s, then a left turn on a 12 m radius (an arc alone would
        // not do: constant-speed motion on a circle is a rotation of itself in time, so a
        // rotation absorbs any clock offset)
        if t < 2.0 {
            return (8.0 * (t - 2.0), 0.0);
        }
        let a = (t - 2.0) * 8.0 / 12.0;
        (12.0 * a.sin(), 12.0 * (1.0 - a.cos()))
    }

    #[test]
    fn grid_checks_and_lists_shifts() {
        let g = ShiftGrid::new(0.1, 0.25, 0.1).unwrap();
        let s: Vec<f64> = g.shifts().collect();
        assert_eq!(s.len(), 5);
        assert!((s[0] + 0.1).abs() < 1e-12 && (s[4] - 0.3).abs() < 1e-12);
        assert_eq!(ShiftGrid::new(0.0, 0.0, 0.1).unwrap().shifts().count(), 1);
        assert_eq!(ShiftGrid::new(0.0, -1.0, 0.1).unwrap_err().to_string(), "max_shift must be >= 0, got -1");
        assert_eq!(ShiftGrid::new(0.0, 1.0, 0.0).unwrap_err().to_string(), "step must be > 0, got 0");
        assert!(matches!(ShiftGrid::new(0.0, 1e9, 1e-3).unwrap_err(), ShiftError::TooManyShifts { .. }));
        assert!(ShiftGrid::new(f64::NAN, 1.0, 0.1).is_err());
    }

    #[test]
    fn scan_finds_the_clock_offset_of_a_turning_track() {
        let tf = Transform2::new(0.7, 5.0, -3.0, 1.0);
        let w = curve(0.0, 6.0, 10.0, 0.0, turning);
        let m = observe(&curve(0.0, 6.0, 10.0, 0.03, turning), &tf, 0.3);
        let g = ShiftGrid::new(0.0, 1.0, 0.05).unwrap();
        let fits = scan(w.view(), m.view(), &g, 0.5).unwrap();
        let best = fits.iter().min_by(|a, b| a.rms.total_cmp(&b.rms)).unwrap();
        assert!((best.dt - 0.3).abs() < 1e-9, "{best:?}");
        assert!(best.rms < 0.05 && (best.transform.tx - 5.0).abs() < 0.1, "{best:?}");
        assert!(best.span > 5.0);
        // at dt = 0 the same pair fits badly
        let at0 = fits.iter().find(|f| f.dt.abs() < 1e-9).unwrap();
        assert!(at0.rms > 0.5, "{at0:?}");
    }

    #[test]
    fn joint_separates_offset_from_translation_with_two_straight_directions() {
        // Two straight tracks at constant speed, one east, one north: each alone cannot tell dt
        // from a translation along its road, together they can.
        let tf = Transform2::new(-1.2, -20.0, 7.0, 1.0);
        let dt = -0.23;
        let east = |t: f64| (10.0 * t, 2.0);
        let north = |t: f64| (30.0, -5.0 + 1.4 * t);
        let (we, wn) = (curve(0.0, 8.0, 10.0, 0.0, east), curve(0.0, 8.0, 10.0, 0.0, north));
        let (me, mn) = (observe(&curve(0.0, 8.0, 10.0, 0.04, east), &tf, dt), observe(&curve(0.0, 8.0, 10.0, 0.04, north), &tf, dt));
        let g = ShiftGrid::new(-0.2, 0.1, 0.01).unwrap();
        let f = joint(&[(we.view(), me.view()), (wn.view(), mn.view())], &g, 0.5, 0.0, Noise::default()).unwrap().unwrap();
        assert!((f.dt - dt).abs() < 0.005, "{f:?}");
        assert!((f.transform.tx - tf.tx).abs() < 0.05 && (f.transform.ty - tf.ty).abs() < 0.05, "{f:?}");
        assert!(rigid::wrap_angle(f.transform.theta - tf.theta).abs() < 1e-3);
        // a grid that does not hold the minimum walks to it
        let far = ShiftGrid::new(-0.1, 0.05, 0.01).unwrap();
        let w = joint(&[(we.view(), me.view()), (wn.view(), mn.view())], &far, 0.5, 0.0, Noise::default()).unwrap().unwrap();
        assert!((w.dt - dt).abs() < 0.005, "{w:?}");
        // one direction alone leaves the offset to the translation: the fit is still exact
        let one = joint(&[(we.view(), me.view())], &g, 0.5, 0.0, Noise::default()).unwrap().unwrap();
        assert!(one.rms < 1e-6);
    }

    /// The slow, obviously right version of [`scan`]: `correspond` on a shifted copy, every pair.
    fn scan_slow(fixed: Traj<'_>, moving: Traj<'_>, grid: &ShiftGrid, max_gap: f64) -> Vec<ShiftFit> {
        grid.shifts()
            .filter_map(|dt| {
                let p = correspond_at(fixed, moving, dt, max_gap).unwrap();
                rigid::fit(&p.fx, &p.fy, &p.mx, &p.my, &[], false).ok().map(|(transform, rms)| ShiftFit { dt, transform, rms, n: p.t.len(), span: span(&p) })
            })
            .collect()
    }

    proptest::proptest! {
        #[test]
        fn scan_equals_correspond_at_every_shift(phase in 0.0f64..0.1, dt in -0.4f64..0.4, theta in -3.0f64..3.0, len in 1.0f64..4.0, gap_at in 0.0f64..4.0) {
            // short tracks (<= 41 fixed points: no subsampling), one with a 0.6 s gap
            let tf = Transform2::new(theta, 3.0, -2.0, 1.0);
            let w = curve(0.0, len, 10.0, 0.0, turning);
            let mut m = observe(&curve(0.0, len, 10.0, phase, turning), &tf, dt);
            let keep: Vec<bool> = m.t.iter().map(|&t| !(t > gap_at + dt && t < gap_at + dt + 0.6)).collect();
            let pick = |v: &[f64]| v.iter().zip(&keep).filter(|(_, &k)| k).map(|(x, _)| *x).collect::<Vec<f64>>();
            m = OwnedTraj { t: pick(&m.t), x: pick(&m.x), y: pick(&m.y) };
            let g = ShiftGrid::new(0.0, 0.5, 0.05).unwrap();
            let fast = scan(w.view(), m.view(), &g, 0.5).unwrap();
            let slow = scan_slow(w.view(), m.view(), &g, 0.5);
            proptest::prop_assert_eq!(fast.len(), slow.len());
            for (a, b) in fast.iter().zip(&slow) {
                proptest::prop_assert!((a.dt - b.dt).abs() < 1e-12 && a.n == b.n);
                proptest::prop_assert!((a.rms - b.rms).abs() < 1e-9 && (a.transform.tx - b.transform.tx).abs() < 1e-9);
            }
        }
    }

    /// Deterministic Gaussian noise (an LCG and Box-Muller): the test needs no RNG crate.
    fn gauss(state: &mut u64) -> f64 {
        let mut next = || {
            *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((*state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (next(), next());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }

    #[test]
    fn interpolation_weights_remove_the_phase_bias_of_synchronised_noisy_cameras() {
        // Synchronised clocks, different phases and noise: the unweighted residual prefers the
        // shift that puts fixed samples half-way between moving ones; the weighted one does not.
        let tf = Transform2::new(0.4, 2.0, 1.0, 1.0);
        let (sf, sm) = (0.08, 0.13);
        let mut st = 7u64;
        let mut tracks = Vec::new();
        for k in 0..40 {
            let dir = k as f64 * 0.7;
            let v = if k % 3 == 0 { 9.0 } else { 1.4 };
            let f = move |t: f64| (v * t * dir.cos() + k as f64, v * t * dir.sin() - k as f64);
            let mut a = curve(0.0, 10.0, 10.0, 0.0, f);
            let mut b = observe(&curve(0.0, 10.0, 10.0, 0.04, f), &tf, 0.0);
            for i in 0..a.t.len() {
                a.x[i] += sf * gauss(&mut st);
                a.y[i] += sf * gauss(&mut st);
            }
            for i in 0..b.t.len() {
                b.x[i] += sm * gauss(&mut st);
                b.y[i] += sm * gauss(&mut st);
            }
            tracks.push((a, b));
        }
        let views: Vec<_> = tracks.iter().map(|(a, b)| (a.view(), b.view())).collect();
        let g = ShiftGrid::new(0.0, 0.06, 0.005).unwrap();
        let w = joint(&views, &g, 0.5, 0.1, Noise::new(sf, sm).unwrap()).unwrap().unwrap();
        assert!(w.dt.abs() <= 0.01, "{w:?}");
        assert!(Noise::new(-1.0, 0.0).is_err());
    }

    /// Issue 19: 20k points × 20,001 shifts took 78 s and could not be interrupted; it is
    /// refused before any work, naming the limit and what to reduce.
    #[test]
    fn joint_work_is_limited_before_the_work() {
        let a = curve(0.0, 1000.0, 10.0, 0.0, turning);
        let b = observe(&curve(0.0, 1000.0, 10.0, 0.03, turning), &Transform2::new(0.3, 1.0, 2.0, 1.0), 0.2);
        let points = (a.t.len() + b.t.len()) as u128;
        assert_eq!(points, 20_000);
        let g = ShiftGrid::new(0.0, 1.0, 1e-4).unwrap();
        assert_eq!(g.shifts().count(), 20_001);
        let e = joint(&[(a.view(), b.view())], &g, 0.5, 0.1, Noise::default()).unwrap_err();
        assert_eq!(e, ShiftError::Work(limits::SHIFT_PAIR_FITS.check(20_001 * points).unwrap_err()));
        let msg = e.to_string();
        assert!(msg.contains("trajdb_set_limit('shift_pair_fits', 400020000)") && msg.contains("search fewer shifts"), "{msg}");
        // a usual grid on the same tracks is within the limit
        assert!(check_joint_work(&[(a.view(), b.view())], &ShiftGrid::new(0.2, 0.2, 0.005).unwrap(), 1 + MAX_WALKS as u128).is_ok());
    }

    proptest::proptest! {
        /// correspond_at reads the shifted times in place: the same pairs, bit for bit, as
        /// `correspond` on a shifted copy (the code before issue 19).
        #[test]
        fn correspond_at_equals_a_shifted_copy(phase in 0.0f64..0.1, dt in -3.0f64..3.0, len in 0.5f64..4.0, gap in proptest::sample::select(vec![0.05, 0.5, f64::INFINITY])) {
            let w = curve(0.0, len, 10.0, 0.0, turning);
            let m = curve(0.0, len, 7.0, phase, turning);
            let copy = OwnedTraj { t: m.t.iter().map(|t| t - dt).collect(), x: m.x.clone(), y: m.y.clone() };
            let want = super::super::correspond::correspond(w.view(), copy.view(), gap).unwrap();
            proptest::prop_assert_eq!(correspond_at(w.view(), m.view(), dt, gap).unwrap(), want);
        }
    }

    #[test]
    fn degenerate_inputs_give_no_fit_not_an_error() {
        let g = ShiftGrid::new(0.0, 0.2, 0.1).unwrap();
        let a = curve(0.0, 2.0, 10.0, 0.0, turning);
        let e = OwnedTraj { t: vec![], x: vec![], y: vec![] };
        assert!(scan(a.view(), e.view(), &g, 0.5).unwrap().is_empty());
        let far = curve(100.0, 102.0, 10.0, 0.0, turning);
        assert!(scan(a.view(), far.view(), &g, 0.5).unwrap().is_empty());
        assert_eq!(joint(&[(a.view(), far.view())], &g, 0.5, 0.1, Noise::default()).unwrap(), None);
        assert_eq!(joint(&[], &g, 0.5, 0.1, Noise::default()).unwrap(), None);
        assert!(joint(&[], &g, 0.5, 1.0, Noise::default()).is_err());
        assert!(scan(a.view(), a.view(), &g, 0.0).is_err());
    }
}
