//! The clock offset of one track pair from their SPEED profiles alone: speed does not depend on
//! either camera's frame, so a road user accelerating, braking or starting from a wait shows
//! the same profile in both cameras, shifted by their clock offset. For each lag L on the grid
//! `centre + k step`, the Pearson correlation
//!
//! ```text
//! r(L) = corr_i( v_a(t_i), v_b(t_i + L) ),   v(t) = |p(t + h) - p(t - h)| / 2h,  h = 0.5 s
//! ```
//!
//! over a's times t_i (every 0.25 s) where both speeds exist, and the lag with the largest r is
//! the pair's vote. Positions are interpolated linearly; the central difference over 1 s keeps
//! position noise small against speed (sigma 0.3 m gives 0.42 m/s). Each track's speed profile
//! is computed once on its own 0.25 s grid, and b's is read between grid points by linear
//! interpolation, so one lag costs O(n). A pair whose speed hardly changes (a constant cruise,
//! or people standing) has no peak: its r is low or its lag random, and align.sql's vote over
//! many pairs sees it as background.
//!
//! align.sql uses the votes where the activity cross-correlation's coarse offset
//! ([`super::xcorr`]) was too far off for the first exact search: crowds waiting at a crossing
//! pull it 10 s or more away.
//!
//! Complexity: O(n + m + S n / 8) for S lags (coarse to fine); bounded by `shift_pair_fits` (S x n).

use super::shift::{ShiftError, ShiftGrid};
use crate::limits;
use crate::traj::Traj;

/// Half the speed difference baseline (s).
const H: f64 = 0.5;
/// Sampling step of the speed profiles (s).
const STEP_T: f64 = 0.25;

/// The best lag of one pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedLag {
    /// b's clock minus a's clock (s).
    pub lag: f64,
    /// Pearson correlation of the speed profiles at that lag.
    pub corr: f64,
    /// Speed samples compared at that lag.
    pub n: usize,
}

/// Position of `tr` at `t` by linear interpolation; `None` outside its span.
fn at(tr: &Traj<'_>, t: f64) -> Option<(f64, f64)> {
    let m = tr.len();
    if m == 0 || t < tr.t[0] || t > tr.t[m - 1] {
        return None;
    }
    let j = tr.t.partition_point(|&s| s <= t).saturating_sub(1);
    if j + 1 >= m || tr.t[j] == t {
        return Some((tr.x[j], tr.y[j]));
    }
    let u = (t - tr.t[j]) / (tr.t[j + 1] - tr.t[j]);
    Some((tr.x[j] + u * (tr.x[j + 1] - tr.x[j]), tr.y[j] + u * (tr.y[j + 1] - tr.y[j])))
}

/// The speed profile on the track's own grid t0 + h + k step; empty when shorter than 2h.
fn profile(tr: &Traj<'_>) -> (f64, Vec<f64>) {
    let m = tr.len();
    if m < 2 {
        return (0.0, Vec::new());
    }
    let (t0, span) = (tr.t[0] + H, tr.t[m - 1] - tr.t[0] - 2.0 * H);
    if span < 0.0 {
        return (t0, Vec::new());
    }
    let n = (span / STEP_T).floor() as usize + 1;
    let v = (0..n)
        .map(|k| {
            let t = t0 + k as f64 * STEP_T;
            match (at(tr, t - H), at(tr, t + H)) {
                (Some(a), Some(b)) => ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt() / (2.0 * H),
                _ => f64::NAN,
            }
        })
        .collect();
    (t0, v)
}

/// See the module docs. `None` when no lag compares at least `min_samples` speeds with
/// non-zero variance on both sides. Both tracks must satisfy [`Traj::validate`] (the bindings
/// check it).
pub fn speed_lag(a: Traj<'_>, b: Traj<'_>, grid: &ShiftGrid, min_samples: usize) -> Result<Option<SpeedLag>, ShiftError> {
    let (ta0, va) = profile(&a);
    let (tb0, vb) = profile(&b);
    if va.is_empty() || vb.is_empty() {
        return Ok(None);
    }
    limits::SHIFT_PAIR_FITS.check((2 * grid.k as u128 + 1) * (va.len() + vb.len()) as u128).map_err(ShiftError::Work)?;
    let last = (vb.len() - 1) as f64;
    let vb_at = |t: f64| -> Option<f64> {
        let u = (t - tb0) / STEP_T;
        if !(0.0..=last).contains(&u) {
            return None;
        }
        let k = (u.floor() as usize).min(vb.len() - 1);
        let f = u - k as f64;
        let v = if k + 1 < vb.len() { vb[k] + f * (vb[k + 1] - vb[k]) } else { vb[k] };
        v.is_finite().then_some(v)
    };
    // Pearson r of a's samples (every `stride`-th) against b at t + lag
    let corr = |lag: f64, stride: usize| -> Option<SpeedLag> {
        let (mut k, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0usize, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (i, &x) in va.iter().enumerate().step_by(stride) {
            if !x.is_finite() {
                continue;
            }
            let Some(y) = vb_at(ta0 + i as f64 * STEP_T + lag) else { continue };
            k += 1;
            sx += x;
            sy += y;
            sxx += x * x;
            syy += y * y;
            sxy += x * y;
        }
        if k * stride < min_samples.max(3) {
            return None;
        }
        let kf = k as f64;
        let (vx, vy) = (sxx - sx * sx / kf, syy - sy * sy / kf);
        if vx <= 1e-9 * kf || vy <= 1e-9 * kf {
            return None;
        }
        Some(SpeedLag { lag, corr: (sxy - sx * sy / kf) / (vx * vy).sqrt(), n: k })
    };
    let better = |b: Option<SpeedLag>, c: Option<SpeedLag>| match (b, c) {
        (Some(b), Some(c)) if c.corr > b.corr => Some(c),
        (None, c) => c,
        (b, _) => b,
    };
    // coarse to fine: speed profiles change over seconds, so the correlation is smooth in the lag;
    // lags 4 steps apart on every other sample first, then every step within 4 steps of the best
    // (a quarter to an eighth of the work of the full grid)
    let coarse = ShiftGrid::new(grid.centre, grid.half_width, 4.0 * grid.step)?;
    let Some(c) = coarse.shifts().fold(None, |b, lag| better(b, corr(lag, 2))) else { return Ok(None) };
    let (lo, hi) = (grid.centre - grid.k as f64 * grid.step, grid.centre + grid.k as f64 * grid.step);
    let fine = ShiftGrid::new(c.lag, 4.0 * grid.step, grid.step)?;
    let best = fine.shifts().filter(|&l| l >= lo - 1e-9 && l <= hi + 1e-9).fold(None, |b, lag| better(b, corr(lag, 1)));
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A road user that waits, then accelerates and walks on, seen by a camera in another frame.
    fn walker(clock: f64, rot: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let (mut t, mut x, mut y) = (vec![], vec![], vec![]);
        let mut s = 0.0;
        for i in 0..300 {
            let tt = i as f64 * 0.1;
            let v = if tt < 10.0 { 0.0 } else if tt < 14.0 { 0.35 * (tt - 10.0) } else { 1.4 + 0.3 * ((tt - 14.0) * 0.9).sin() };
            s += v * 0.1;
            let (px, py) = (s, 0.2 * s);
            t.push(tt + clock);
            x.push(px * rot.cos() - py * rot.sin() + 500.0);
            y.push(px * rot.sin() + py * rot.cos() - 40.0);
        }
        (t, x, y)
    }

    #[test]
    fn finds_the_offset_from_speed_alone_in_any_frame() {
        let a = walker(0.0, 0.0);
        for off in [0.0, 3.25, -11.5, 3600.75] {
            let b = walker(off, 2.1);
            let grid = ShiftGrid::new((off / 20.0).round() * 20.0, 20.0, 0.25).unwrap();
            let r = speed_lag(Traj::new(&a.0, &a.1, &a.2), Traj::new(&b.0, &b.1, &b.2), &grid, 8).unwrap().unwrap();
            assert!((r.lag - off).abs() < 0.26, "{off}: {r:?}");
            assert!(r.corr > 0.95);
        }
    }

    #[test]
    fn flat_or_short_tracks_give_none() {
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let x = vec![1.0; 50];
        let g = ShiftGrid::new(0.0, 2.0, 0.25).unwrap();
        assert_eq!(speed_lag(Traj::new(&t, &x, &x), Traj::new(&t, &x, &x), &g, 8).unwrap(), None);
        assert_eq!(speed_lag(Traj::new(&t[..1], &x[..1], &x[..1]), Traj::new(&t, &x, &x), &g, 8).unwrap(), None);
    }
}
