//! Rigid (Time)CPD in 3-D: the model, E-step, time band and starts of [`crate::align::cpd`]
//! (see there for the equations and the bound; the EM is written once there, generic over the
//! dimension), with the rotation of the M-step from the SVD of the 3×3 matrix
//! `A = Σ P x̂ ŷᵀ` (thesis lemma 1 / eq. 2.5: `R = U·diag(1, 1, det(UVᵀ))·Vᵀ`, via nalgebra).
//!
//! Starts: road cameras differ mostly by yaw, so the `starts` rotations are about the z axis
//! (`2πk/starts`); `starts = 1` is R = I, t = 0 (pycpd's start). The starts are probed on at
//! most [`super::cpd::PROBE_POINTS`] points per set, as in 2-D (until issue 27 the 3-D code
//! probed on all points).
//!
//! # Complexity
//! Per iteration O(N + M + K) time (K = pairs in the time band) and O(N + M) memory.

use super::cpd::{align_in, CpdError, CpdParams, Space};
use nalgebra::{Matrix3, Vector3};

/// `p_fixed = scale · R · p_moving + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform3 {
    pub r: [[f64; 3]; 3],
    pub t: [f64; 3],
    pub scale: f64,
}

/// Outcome of [`align3`]: the shared result type with a 3-D transform.
pub type Cpd3Result = super::cpd::CpdResult<Transform3>;

/// 3-D for the EM of [`crate::align::cpd`]: the transform is [`Transform3`], the rotation of
/// the M-step comes from the SVD of `A`.
pub(crate) struct Space3;

fn to_rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

impl Space<3> for Space3 {
    type Transform = Transform3;
    fn start(theta: f64, v: [f64; 3]) -> Transform3 {
        let (s, c) = theta.sin_cos();
        Transform3 { r: [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], t: v, scale: 1.0 }
    }
    fn matrix(tf: &Transform3) -> ([[f64; 3]; 3], [f64; 3]) {
        (tf.r.map(|row| row.map(|v| tf.scale * v)), tf.t)
    }
    fn m_step(a: &[[f64; 3]; 3], mux: &[f64; 3], muy: &[f64; 3], ypy: f64, with_scale: bool) -> (Transform3, f64, f64) {
        let am = Matrix3::from_fn(|i, j| a[i][j]);
        let svd = am.svd(true, true);
        // both are computed when asked for; R = I is the fallback that cannot be reached
        let r = match (svd.u, svd.v_t) {
            (Some(u), Some(vt)) => {
                let mut c = Matrix3::identity();
                c[(2, 2)] = (u * vt).determinant().signum();
                u * c * vt
            }
            _ => Matrix3::identity(),
        };
        let tr_ar = (am.transpose() * r).trace();
        let s = if with_scale && ypy > 0.0 { tr_ar / ypy } else { 1.0 };
        let tv = Vector3::from(*mux) - s * (r * Vector3::from(*muy));
        (Transform3 { r: to_rows(&r), t: [tv.x, tv.y, tv.z], scale: s }, tr_ar, s)
    }
    fn normalise(tf: Transform3) -> Transform3 {
        tf
    }
    fn uncentre(tf: Transform3, cf: &[f64; 3], cm: &[f64; 3]) -> Transform3 {
        let r = Matrix3::from_fn(|i, j| tf.r[i][j]);
        let t = Vector3::from(tf.t) + Vector3::from(*cf) - tf.scale * (r * Vector3::from(*cm));
        Transform3 { t: [t.x, t.y, t.z], ..tf }
    }
}

/// Aligns `moving` onto `fixed`, each given as (x, y, z, t) columns.
pub fn align3(
    fixed: (&[f64], &[f64], &[f64], &[f64]),
    moving: (&[f64], &[f64], &[f64], &[f64]),
    p: &CpdParams,
) -> Result<Cpd3Result, CpdError> {
    align_in::<Space3, 3>(([fixed.0, fixed.1, fixed.2], fixed.3), ([moving.0, moving.1, moving.2], moving.3), p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_3d_rigid_motion() {
        let n = 300;
        let (mut x, mut y, mut z, mut t) = (vec![], vec![], vec![], vec![]);
        for k in 0..n {
            let s = k as f64 * 0.1;
            x.push((s * 0.7).sin() * 10.0 + (k % 7) as f64);
            y.push((s * 0.3).cos() * 8.0 - (k % 5) as f64);
            z.push((s * 0.2).sin() * 2.0);
            t.push(s);
        }
        // moving = R⁻¹ (fixed − t) with R = yaw 100° then a small tilt
        let r = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)
            * Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.1f64.cos(), -0.1f64.sin(), 0.0, 0.1f64.sin(), 0.1f64.cos());
        let tv = Vector3::new(5.0, -3.0, 1.0);
        let p = CpdParams::new(0.0, Some(0.5), 200, 1e-10, false, 8).unwrap();
        recovers(&x, &y, &z, &t, r, tv, &p);
        let one = [1.0, 2.0];
        assert!(matches!(align3((&one, &one, &one, &one), (&one, &one, &one, &one), &p), Err(CpdError::TooFew { .. })));
    }

    /// Moves the fixed cloud by R⁻¹(p − t), aligns it back, and checks R and t; returns the fit.
    fn recovers(x: &[f64], y: &[f64], z: &[f64], t: &[f64], r: Matrix3<f64>, tv: Vector3<f64>, p: &CpdParams) -> Cpd3Result {
        let (mut mx, mut my, mut mz) = (vec![], vec![], vec![]);
        for k in 0..x.len() {
            let v = r.transpose() * (Vector3::new(x[k], y[k], z[k]) - tv);
            mx.push(v.x);
            my.push(v.y);
            mz.push(v.z);
        }
        let out = align3((x, y, z, t), (&mx, &my, &mz, t), p).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                assert!((out.transform.r[i][j] - r[(i, j)]).abs() < 1e-6, "{out:?}");
            }
            assert!((out.transform.t[i] - tv[i]).abs() < 1e-5, "{out:?}");
        }
        out
    }

    /// More than PROBE_POINTS points: the starts are probed on a strided subsample (the rule
    /// 3-D shares with 2-D since issue 27), and the winner, continued on all points, still
    /// recovers a yaw of 2.5 rad with a tilt and an offset.
    #[test]
    fn recovers_a_large_yaw_with_subsampled_probes() {
        let n = 2 * super::super::cpd::PROBE_POINTS + 500;
        let (mut x, mut y, mut z, mut t) = (vec![], vec![], vec![], vec![]);
        for k in 0..n {
            let (obj, s) = ((k % 9) as f64, (k / 9) as f64 * 0.05);
            let a = obj * 0.7;
            let along = (s * 6.0) % 40.0 - 20.0;
            x.push(a.cos() * along + obj);
            y.push(a.sin() * along - obj * 0.5);
            z.push((s * 0.4 + obj).sin());
            t.push(s);
        }
        let (c, sn) = (2.5f64.cos(), 2.5f64.sin());
        let r = Matrix3::new(c, -sn, 0.0, sn, c, 0.0, 0.0, 0.0, 1.0)
            * Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.05f64.cos(), -0.05f64.sin(), 0.0, 0.05f64.sin(), 0.05f64.cos());
        let tv = Vector3::new(-7.0, 4.0, 2.0);
        let p = CpdParams::new(0.0, Some(0.3), 200, 1e-10, false, 8).unwrap();
        let out = recovers(&x, &y, &z, &t, r, tv, &p);
        assert!((out.start_theta - 2.0 * std::f64::consts::PI * 3.0 / 8.0).abs() < 1e-12, "the start nearest 2.5 rad wins: {out:?}");
    }
}
