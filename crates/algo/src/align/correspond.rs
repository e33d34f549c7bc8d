//! Point correspondences between two tracks of the same road user seen by two cameras with
//! synchronised clocks but different sampling phases.
//!
//! For every point `a_i` of the fixed track whose time lies inside the moving track's time
//! span, the moving track is interpolated linearly at `t_i` between its two neighbouring
//! samples, provided they are at most `max_gap` seconds apart (no interpolation across track
//! breaks). The pairs `(a_i, b(t_i))` feed [`crate::align::rigid::fit`]: one pair of tracks of
//! the same object is a hypothesis for the camera-to-camera transform, which needs no initial
//! rotation at all (it is found in closed form).
//!
//! # Complexity
//! O(n + m) (two pointers over time-sorted tracks).

use crate::traj::Traj;
use crate::{positive_or_inf, ParamError};

/// Correspondence columns: fixed (fx, fy) and interpolated moving (mx, my), plus time t and
/// the interpolation fraction u in [0, 1) between the two moving samples (0: a moving sample).
/// Interpolating two samples with independent noise σ leaves noise σ·sqrt(u² + (1 − u)²), so
/// the residual of a pair depends on u: [`interpolation_weight`] undoes that.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pairs {
    pub t: Vec<f64>,
    pub u: Vec<f64>,
    pub fx: Vec<f64>,
    pub fy: Vec<f64>,
    pub mx: Vec<f64>,
    pub my: Vec<f64>,
}

impl Pairs {
    /// Empties every column, keeping the allocations (a buffer reused per track pair).
    pub fn clear(&mut self) {
        for v in [&mut self.t, &mut self.u, &mut self.fx, &mut self.fy, &mut self.mx, &mut self.my] {
            v.clear();
        }
    }
}

/// See the module docs. Both tracks must satisfy [`Traj::validate`]; `max_gap` must be > 0
/// (`+inf`: interpolate across any gap).
pub fn correspond(fixed: Traj<'_>, moving: Traj<'_>, max_gap: f64) -> Result<Pairs, ParamError> {
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    let mut out = Pairs::default();
    correspond_into(fixed, moving, 0.0, max_gap, &mut out);
    Ok(out)
}

/// [`correspond`] with the moving times read as `t − dt`, appended to `out`: the moving track
/// is not copied (the shifted times are computed where they are read, by the same subtraction,
/// so the pairs are those of `correspond` on a shifted copy). `max_gap` already checked.
pub(crate) fn correspond_into(fixed: Traj<'_>, moving: Traj<'_>, dt: f64, max_gap: f64, out: &mut Pairs) {
    each_pair(fixed, moving, dt, max_gap, |t, u, fx, fy, mx, my| {
        out.t.push(t);
        out.u.push(u);
        out.fx.push(fx);
        out.fy.push(fy);
        out.mx.push(mx);
        out.my.push(my);
    });
}

/// The pairs of [`correspond_into`] handed to `f(t, u, fx, fy, mx, my)` in time order, without
/// building them (the one walk both use).
pub(crate) fn each_pair(fixed: Traj<'_>, moving: Traj<'_>, dt: f64, max_gap: f64, mut f: impl FnMut(f64, f64, f64, f64, f64, f64)) {
    let m = moving.len();
    if m == 0 {
        return;
    }
    let mt = |j: usize| moving.t[j] - dt;
    let (first, last) = (mt(0), mt(m - 1));
    let mut j = 0usize; // mt(j) <= t < mt(j + 1)
    for i in 0..fixed.len() {
        let t = fixed.t[i];
        if t < first || t > last {
            continue;
        }
        while j + 1 < m && mt(j + 1) <= t {
            j += 1;
        }
        let (x, y, u) = if mt(j) == t || j + 1 == m {
            (moving.x[j], moving.y[j], 0.0)
        } else {
            let (t0, t1) = (mt(j), mt(j + 1));
            if t1 - t0 > max_gap {
                continue;
            }
            let u = (t - t0) / (t1 - t0);
            (moving.x[j] + u * (moving.x[j + 1] - moving.x[j]), moving.y[j] + u * (moving.y[j + 1] - moving.y[j]), u)
        };
        f(t, u, fixed.x[i], fixed.y[i], x, y);
    }
}

/// `(σf² + σm²) / (σf² + σm²·(u² + (1 − u)²))`: the squared residual of a pair whose moving
/// point is interpolated at fraction `u` between two samples has expectation
/// `2(σf² + σm²·(u² + (1 − u)²))` (fixed noise σf, moving noise σm, per axis), so
/// `weight · r²` has the same expectation, 2(σf² + σm²), at every `u`. Without it, a residual
/// summed over pairs is smallest when the fixed samples fall half-way between moving ones
/// (u = 0.5 averages two noisy samples), and a clock offset search is pulled towards that
/// phase (measured: 25-37 ms on synchronised 10 Hz cameras). Equal σ when both are 0.
pub fn interpolation_weight(u: f64, sigma_fixed: f64, sigma_moving: f64) -> f64 {
    let (f, m) = if sigma_fixed > 0.0 || sigma_moving > 0.0 { (sigma_fixed * sigma_fixed, sigma_moving * sigma_moving) } else { (1.0, 1.0) };
    (f + m) / (f + m * (u * u + (1.0 - u) * (1.0 - u)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_inside_and_skips_gaps_and_outside() {
        let (at, ax, ay) = (vec![0.0, 0.5, 1.0, 2.5, 4.0], vec![0.0; 5], vec![0.0; 5]);
        let (bt, bx, by) = (vec![0.2, 1.2, 1.4, 3.9], vec![2.0, 12.0, 14.0, 39.0], vec![0.0, 1.0, 1.0, 1.0]);
        let p = correspond(Traj::new(&at, &ax, &ay), Traj::new(&bt, &bx, &by), 1.0).unwrap();
        // 0.0 is before b starts, 2.5 falls in the 2.5 s gap 1.4..3.9, 4.0 is after b ends.
        assert_eq!(p.t, vec![0.5, 1.0]);
        assert!((p.mx[0] - 5.0).abs() < 1e-12 && (p.mx[1] - 10.0).abs() < 1e-12);
        assert!((p.my[0] - 0.3).abs() < 1e-12);
        // exact sample times and a single-point moving track
        let q = correspond(Traj::new(&[3.9], &[0.0], &[0.0]), Traj::new(&bt, &bx, &by), 1.0).unwrap();
        assert_eq!(q.mx, vec![39.0]);
        let r = correspond(Traj::new(&at, &ax, &ay), Traj::new(&[1.0], &[7.0], &[8.0]), 1.0).unwrap();
        assert_eq!((r.t.clone(), r.mx.clone()), (vec![1.0], vec![7.0]));
        assert!(correspond(Traj::new(&at, &ax, &ay), Traj::new(&[], &[], &[]), 1.0).unwrap().t.is_empty());
        assert_eq!(correspond(Traj::new(&[], &[], &[]), Traj::new(&[], &[], &[]), 0.0).unwrap_err().to_string(), "max_gap must be > 0, got 0");
    }
}
