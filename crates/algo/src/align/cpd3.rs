//! Rigid (Time)CPD in 3-D: the same model, E-step and time band as [`crate::align::cpd`]
//! (see there for the equations and the bound), with the rotation of the M-step from the SVD
//! of the 3×3 matrix `A = Σ P x̂ ŷᵀ` (thesis lemma 1 / eq. 2.5: `R = U·diag(1, 1, det(UVᵀ))·Vᵀ`,
//! via nalgebra).
//!
//! Starts: road cameras differ mostly by yaw, so the `starts` rotations are about the z axis
//! (`2πk/starts`); `starts = 1` is R = I, t = 0 (pycpd's start).
//!
//! # Complexity
//! Per iteration O(N + M + K) time (K = pairs in the time band) and O(N + M) memory.

use super::cpd::{exp_neg_pub as exp_neg, CpdError, CpdParams, MAX_MAGNITUDE, PROBE_ITERATIONS, SIGMA2_FLOOR, TIME_CUTOFF_TAUS};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

/// `p_fixed = scale · R · p_moving + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform3 {
    pub r: [[f64; 3]; 3],
    pub t: [f64; 3],
    pub scale: f64,
}

/// Outcome of [`align3`]: the shared result type with a 3-D transform.
pub type Cpd3Result = super::cpd::CpdResult<Transform3>;

type P3 = (Vec<Vector3<f64>>, Vec<f64>);
/// One EM run's outcome: R, t, s, σ², iterations, converged, q, log-likelihood, last sums.
type Run3 = (Matrix3<f64>, Vector3<f64>, f64, f64, usize, bool, f64, f64, St);

fn prepare(which: &'static str, c: (&[f64], &[f64], &[f64], &[f64])) -> Result<P3, CpdError> {
    let (x, y, z, t) = c;
    if x.len() < 3 {
        return Err(CpdError::TooFew { which, got: x.len() });
    }
    for k in 0..x.len() {
        if !(x[k].is_finite() && y[k].is_finite() && z[k].is_finite() && t[k].is_finite()) {
            return Err(CpdError::NotFinite { which, index: k });
        }
        if x[k].abs().max(y[k].abs()).max(z[k].abs()).max(t[k].abs()) > MAX_MAGNITUDE {
            return Err(CpdError::Magnitude { which, index: k });
        }
    }
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| t[a].total_cmp(&t[b]));
    Ok((idx.iter().map(|&k| Vector3::new(x[k], y[k], z[k])).collect(), idx.iter().map(|&k| t[k]).collect()))
}

#[derive(Clone, Copy, Default)]
struct St {
    np: f64,
    sx: Vector3<f64>,
    sy: Vector3<f64>,
    sxy: Matrix3<f64>,
    sxx: f64,
    syy: f64,
    log_den: f64,
    resid: f64,
    inliers: usize,
}

fn add(a: St, b: St) -> St {
    St {
        np: a.np + b.np,
        sx: a.sx + b.sx,
        sy: a.sy + b.sy,
        sxy: a.sxy + b.sxy,
        sxx: a.sxx + b.sxx,
        syy: a.syy + b.syy,
        log_den: a.log_den + b.log_den,
        resid: a.resid + b.resid,
        inliers: a.inliers + b.inliers,
    }
}

/// Aligns `moving` onto `fixed`, each given as (x, y, z, t) columns.
pub fn align3(
    fixed: (&[f64], &[f64], &[f64], &[f64]),
    moving: (&[f64], &[f64], &[f64], &[f64]),
    p: &CpdParams,
) -> Result<Cpd3Result, CpdError> {
    let (mut fx, ft) = prepare("fixed", fixed)?;
    let (mut my, mt) = prepare("moving", moving)?;
    let cf = fx.iter().sum::<Vector3<f64>>() / fx.len() as f64;
    let cm = my.iter().sum::<Vector3<f64>>() / my.len() as f64;
    fx.iter_mut().for_each(|v| *v -= cf);
    my.iter_mut().for_each(|v| *v -= cm);
    let (n, m, d) = (fx.len() as f64, my.len() as f64, 3.0);
    let (inv_2tau2, log_tau_norm, cutoff) = match p.tau {
        None => (0.0, 0.0, f64::INFINITY),
        Some(t) => (1.0 / (2.0 * t * t), 0.5 * (2.0 * std::f64::consts::PI * t * t).ln(), TIME_CUTOFF_TAUS * t),
    };
    let mut band = Vec::with_capacity(fx.len());
    let (mut lo, mut hi) = (0usize, 0usize);
    for &t in &ft {
        while lo < mt.len() && mt[lo] < t - cutoff {
            lo += 1;
        }
        hi = hi.max(lo);
        while hi < mt.len() && mt[hi] <= t + cutoff {
            hi += 1;
        }
        band.push((lo, hi));
    }
    if band.iter().all(|&(a, b)| a == b) {
        return Err(CpdError::NoTimeOverlap { tau: p.tau.unwrap_or(f64::INFINITY) });
    }
    let pairs: u128 = band.iter().map(|&(a, b)| (b - a) as u128).sum();
    crate::limits::CPD_PAIR_VISITS.check(pairs * p.max_iter as u128).map_err(CpdError::Work)?;
    let e_step = |r: &Matrix3<f64>, tv: &Vector3<f64>, s: f64, sigma2: f64| -> St {
        let ty: Vec<Vector3<f64>> = my.iter().map(|y| s * (r * y) + tv).collect();
        let c = (2.0 * std::f64::consts::PI * sigma2).powf(d / 2.0) * log_tau_norm.exp() * p.w / (1.0 - p.w) * m / n;
        let inv_2s2 = 1.0 / (2.0 * sigma2);
        (0..fx.len())
            .into_par_iter()
            .with_min_len(256)
            .fold(
                || (St::default(), Vec::<f64>::new()),
                |(mut st, mut buf), i| {
                    let (lo, hi) = band[i];
                    buf.clear();
                    for j in lo..hi {
                        let dt = ft[i] - mt[j];
                        buf.push(exp_neg((fx[i] - ty[j]).norm_squared() * inv_2s2 + dt * dt * inv_2tau2));
                    }
                    let den = buf.iter().sum::<f64>().max(f64::EPSILON) + c;
                    st.log_den += den.ln();
                    let (mut pt1, mut sy, mut syy) = (0.0, Vector3::zeros(), 0.0);
                    for (k, j) in (lo..hi).enumerate() {
                        let pk = buf[k] / den;
                        pt1 += pk;
                        sy += pk * my[j];
                        syy += pk * my[j].norm_squared();
                        st.resid += pk * (fx[i] - ty[j]).norm_squared();
                    }
                    st.np += pt1;
                    st.sx += pt1 * fx[i];
                    st.sy += sy;
                    st.sxy += fx[i] * sy.transpose();
                    st.sxx += pt1 * fx[i].norm_squared();
                    st.syy += syy;
                    st.inliers += (pt1 > 0.5) as usize;
                    (st, buf)
                },
            )
            .map(|(s, _)| s)
            .reduce(St::default, add)
    };
    let run = |r0: Matrix3<f64>, t0: Vector3<f64>, max_iter: usize, sigma2_0: Option<f64>| {
        let (mut r, mut tv, mut s) = (r0, t0, 1.0);
        let mut sigma2 = sigma2_0.unwrap_or_else(|| {
            let ty: Vec<Vector3<f64>> = my.iter().map(|y| r * y + tv).collect();
            let (sx, sxx) = (fx.iter().sum::<Vector3<f64>>(), fx.iter().map(|v| v.norm_squared()).sum::<f64>());
            let (sy, syy) = (ty.iter().sum::<Vector3<f64>>(), ty.iter().map(|v| v.norm_squared()).sum::<f64>());
            ((m * sxx + n * syy - 2.0 * sx.dot(&sy)) / (d * n * m)).max(f64::MIN_POSITIVE)
        });
        let sigma2_first = sigma2;
        let (mut q, mut diff, mut it) = (f64::INFINITY, f64::INFINITY, 0);
        let mut last = St::default();
        while it < max_iter && diff > p.tol {
            let st = e_step(&r, &tv, s, sigma2);
            last = st;
            if !(st.np > 0.0) {
                break;
            }
            let (mux, muy) = (st.sx / st.np, st.sy / st.np);
            let a = st.sxy - st.np * mux * muy.transpose();
            let ypy = st.syy - st.np * muy.norm_squared();
            let xpx = st.sxx - st.np * mux.norm_squared();
            let svd = a.svd(true, true);
            let (u, vt) = (svd.u.expect("u"), svd.v_t.expect("v_t"));
            let mut c = Matrix3::identity();
            c[(2, 2)] = (u * vt).determinant().signum();
            r = u * c * vt;
            let tr_ar = (a.transpose() * r).trace();
            s = if p.with_scale && ypy > 0.0 { tr_ar / ypy } else { 1.0 };
            tv = mux - s * (r * muy);
            let qprev = q;
            q = (xpx - 2.0 * s * tr_ar + s * s * ypy) / (2.0 * sigma2) + d * st.np / 2.0 * sigma2.ln();
            diff = (q - qprev).abs();
            sigma2 = if p.with_scale { (xpx - s * tr_ar) / (st.np * d) } else { (xpx - 2.0 * tr_ar + ypy) / (st.np * d) };
            it += 1;
            let floor = (sigma2_first * SIGMA2_FLOOR).max(f64::MIN_POSITIVE);
            if !(sigma2 > floor) {
                // noise-free: the fit is exact to rounding
                sigma2 = floor;
                diff = 0.0;
            }
        }
        let ll = last.log_den - n * (d / 2.0 * (2.0 * std::f64::consts::PI * sigma2).ln() + log_tau_norm) + n * ((1.0 - p.w) / m).ln();
        (r, tv, s, sigma2, it, diff <= p.tol, q, ll, last)
    };
    let zrot = |a: f64| Matrix3::new(a.cos(), -a.sin(), 0.0, a.sin(), a.cos(), 0.0, 0.0, 0.0, 1.0);
    let mut start_theta = 0.0;
    let res = if p.starts == 1 {
        run(Matrix3::identity(), cm - cf, p.max_iter, None)
    } else {
        let probe = PROBE_ITERATIONS.min(p.max_iter);
        let mut best: Option<(f64, Run3)> = None;
        for k in 0..p.starts {
            let yaw = 2.0 * std::f64::consts::PI * k as f64 / p.starts as f64;
            let out = run(zrot(yaw), Vector3::zeros(), probe, None);
            if best.as_ref().is_none_or(|b| out.7 > b.1 .7) {
                best = Some((yaw, out));
            }
        }
        let (yaw, b) = best.expect("starts >= 1");
        start_theta = yaw;
        let mut out = run(b.0, b.1, p.max_iter.saturating_sub(b.4).max(1), Some(b.3));
        out.4 += b.4;
        out
    };
    let (r, tv, s, sigma2, it, converged, q, ll, last) = res;
    if !(last.np > 0.0) {
        return Err(CpdError::AllOutliers { w: p.w });
    }
    // Undo the centring: t = t' + c_f − s R c_m.
    let t = tv + cf - s * (r * cm);
    let mut rr = [[0.0; 3]; 3];
    for (i, row) in rr.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = r[(i, j)];
        }
    }
    Ok(Cpd3Result {
        transform: Transform3 { r: rr, t: [t.x, t.y, t.z], scale: s },
        sigma2,
        iterations: it,
        converged,
        q,
        log_likelihood: ll,
        inlier_fraction: last.inliers as f64 / n,
        rms: if last.np > 0.0 { (last.resid / last.np).sqrt() } else { f64::NAN },
        start_theta,
        pairs_in_band: band.iter().map(|&(a, b)| b - a).sum(),
    })
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
        let (mut mx, mut my, mut mz) = (vec![], vec![], vec![]);
        for k in 0..n {
            let v = r.transpose() * (Vector3::new(x[k], y[k], z[k]) - tv);
            mx.push(v.x);
            my.push(v.y);
            mz.push(v.z);
        }
        let p = CpdParams::new(0.0, Some(0.5), 200, 1e-10, false, 8).unwrap();
        let out = align3((&x, &y, &z, &t), (&mx, &my, &mz, &t), &p).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                assert!((out.transform.r[i][j] - r[(i, j)]).abs() < 1e-6, "{out:?}");
            }
            assert!((out.transform.t[i] - tv[i]).abs() < 1e-5, "{out:?}");
        }
        let one = [1.0, 2.0];
        assert!(matches!(align3((&one, &one, &one, &one), (&one, &one, &one, &one), &p), Err(CpdError::TooFew { .. })));
    }
}
