//! The clock offset of ONE track pair under a KNOWN transform: the shift dt (moving clock minus
//! fixed clock) that minimises the mean squared residual
//!
//! ```text
//! f(dt) = 1/n sum_i | p_fixed(t_i) - T(p_moving(t_i + dt)) |^2
//! ```
//!
//! over the grid `centre + k step` (the moving track interpolated linearly, as
//! [`correspond`](super::correspond)), refined by a parabola through the best shift's
//! neighbours. With the transform known, even a straight track pins its offset: a shift slides
//! the moving road user along the road, away from the fixed one, by speed x shift. align.sql
//! measures clock drift from these per-pair offsets over the recording (a camera clock running
//! 200 ppm fast moves the offset by 0.36 s in 30 minutes).
//!
//! The standard error of the offset is estimated from the curvature of `f` at its minimum: for
//! residuals of variance s^2 = f(dt*) (both axes), f'' ~ 2 v^2 and se(dt) ~ sqrt(2 f(dt*) / (n f'')).
//!
//! Complexity: O(S (n + m)) for S shifts, bounded by the `shift_pair_fits` work limit.

use super::correspond::Pairs;
use super::rigid::Transform2;
use super::shift::{correspond_at, ShiftError, ShiftGrid};
use crate::limits;
use crate::traj::Traj;

/// The best shift of one pair under a known transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftUnder {
    /// Moving clock minus fixed clock (s), refined between grid points.
    pub dt: f64,
    /// RMS distance (m) at the best grid shift.
    pub rms: f64,
    /// Point pairs at the best grid shift.
    pub n: usize,
    /// Standard error of `dt` (s) from the curvature; infinite when the minimum is flat.
    pub se: f64,
    /// The minimum lies on the first or last grid shift (the true one may lie beyond).
    pub at_edge: bool,
}

fn mean_sq(p: &Pairs, tf: &Transform2) -> f64 {
    let map = tf.mapper();
    let s: f64 = (0..p.fx.len())
        .map(|i| {
            let (x, y) = map(p.mx[i], p.my[i]);
            (p.fx[i] - x).powi(2) + (p.fy[i] - y).powi(2)
        })
        .sum();
    s / p.fx.len() as f64
}

/// See the module docs. `None` when no shift of the grid pairs at least `min_pairs` points
/// (every shift of the grid must pair that many, so that f is compared over like sets).
pub fn best_shift_under(fixed: Traj<'_>, moving: Traj<'_>, tf: &Transform2, grid: &ShiftGrid, max_gap: f64, min_pairs: usize) -> Result<Option<ShiftUnder>, ShiftError> {
    tf.validate()?;
    limits::SHIFT_PAIR_FITS
        .check((2 * grid.k as u128 + 1) * (fixed.len() + moving.len()) as u128)
        .map_err(ShiftError::Work)?;
    let shifts: Vec<f64> = grid.shifts().collect();
    let mut f = Vec::with_capacity(shifts.len());
    let mut ns = Vec::with_capacity(shifts.len());
    for &dt in &shifts {
        let p = correspond_at(fixed, moving, dt, max_gap)?;
        if p.fx.len() >= min_pairs.max(2) {
            f.push(mean_sq(&p, tf));
        } else {
            f.push(f64::INFINITY);
        }
        ns.push(p.fx.len());
    }
    let Some((k, &f0)) = f.iter().enumerate().filter(|(_, v)| v.is_finite()).min_by(|a, b| a.1.total_cmp(b.1).then(a.0.cmp(&b.0))) else {
        return Ok(None);
    };
    let at_edge = k == 0 || k + 1 == f.len();
    let (mut dt, mut se) = (shifts[k], f64::INFINITY);
    if !at_edge && f[k - 1].is_finite() && f[k + 1].is_finite() {
        let h = grid.step;
        let curv = (f[k - 1] - 2.0 * f0 + f[k + 1]) / (h * h);
        if curv > 0.0 {
            dt += (0.5 * h * (f[k - 1] - f[k + 1]) / (f[k - 1] - 2.0 * f0 + f[k + 1])).clamp(-0.5 * h, 0.5 * h);
            se = (2.0 * f0.max(0.0) / (ns[k] as f64 * curv)).sqrt();
        }
    }
    Ok(Some(ShiftUnder { dt, rms: f0.max(0.0).sqrt(), n: ns[k], se, at_edge }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(t0: f64, n: usize, v: f64, tf: Option<&Transform2>) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let mut o = (vec![], vec![], vec![]);
        for i in 0..n {
            let t = t0 + i as f64 * 0.1;
            let (x, y) = (v * t + 0.3 * (t * 0.7).sin(), 2.0 + 0.1 * t);
            let (x, y) = tf.map_or((x, y), |tf| tf.apply(x, y));
            o.0.push(t);
            o.1.push(x);
            o.2.push(y);
        }
        o
    }

    #[test]
    fn recovers_the_shift_of_a_straight_track_under_the_transform() {
        let tf = Transform2::new(0.7, 12.0, -3.0, 1.0);
        let inv = tf.invert();
        for true_dt in [0.0, 0.237, -0.61, 3600.02] {
            let f = line(0.0, 200, 8.0, None);
            // the moving camera sees the same road user in its frame, its clock true_dt ahead
            let m0 = line(0.0, 200, 8.0, Some(&inv));
            let mt: Vec<f64> = m0.0.iter().map(|t| t + true_dt).collect();
            let grid = ShiftGrid::new(true_dt.round(), 1.0, 0.01).unwrap();
            let r = best_shift_under(Traj::new(&f.0, &f.1, &f.2), Traj::new(&mt, &m0.1, &m0.2), &tf, &grid, 0.5, 10).unwrap().unwrap();
            assert!((r.dt - true_dt).abs() < 2e-3, "{true_dt}: {r:?}");
            assert!(!r.at_edge && r.rms < 0.05);
        }
    }

    #[test]
    fn none_without_pairs_and_edge_flag() {
        let f = line(0.0, 50, 8.0, None);
        let g = line(100.0, 50, 8.0, None);
        let tf = Transform2::new(0.0, 0.0, 0.0, 1.0);
        let grid = ShiftGrid::new(0.0, 1.0, 0.1).unwrap();
        assert_eq!(best_shift_under(Traj::new(&f.0, &f.1, &f.2), Traj::new(&g.0, &g.1, &g.2), &tf, &grid, 0.5, 10).unwrap(), None);
        let mt: Vec<f64> = f.0.iter().map(|t| t + 3.0).collect();
        let r = best_shift_under(Traj::new(&f.0, &f.1, &f.2), Traj::new(&mt, &f.1, &f.2), &tf, &grid, 0.5, 10).unwrap().unwrap();
        assert!(r.at_edge);
        let bad = Transform2::new(f64::NAN, 0.0, 0.0, 1.0);
        assert!(best_shift_under(Traj::new(&f.0, &f.1, &f.2), Traj::new(&f.0, &f.1, &f.2), &bad, &grid, 0.5, 10).is_err());
    }
}
