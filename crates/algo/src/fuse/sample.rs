//! The fused path as points: at the observation groups' times, or on the common clock
//! `t = k · period` (the clock `traj_resample` and merge.sql use).
//!
//! # Between two smoothed states (the Gaussian bridge)
//! For `τ` strictly between groups `k` and `k+1` (`d₁ = τ − τ_k`, `d₂ = τ_{k+1} − τ`,
//! `d = d₁ + d₂`), the model gives `s(τ) = F(d₁) s_k + w₁` and `s_{k+1} = F(d₂) s(τ) + w₂`;
//! `s(τ)` given both neighbours is Gaussian with
//!
//! ```text
//! K = Q(d₁) F(d₂)ᵀ Q(d)⁻¹          (F(d₂) Q(d₁) F(d₂)ᵀ + Q(d₂) = Q(d); q cancels)
//! E[s(τ) | s_k, s_{k+1}] = A s_k + B s_{k+1},   A = F(d₁) − K F(d),  B = K
//! Var[s(τ) | s_k, s_{k+1}] = Q(d₁) − K F(d₂) Q(d₁)
//! ```
//!
//! and, by the Markov property, given every observation (with the smoothed `ŝ_k`, `ŝ_{k+1}`,
//! their covariances and `X = Cov(ŝ_k, ŝ_{k+1})` from [`super::smooth`]):
//! `ŝ(τ) = A ŝ_k + B ŝ_{k+1}`,
//! `P̂(τ) = Var[s(τ) | s_k, s_{k+1}] + A P̂_k Aᵀ + B P̂_{k+1} Bᵀ + A X Bᵀ + B Xᵀ Aᵀ`.
//! This is exactly what the smoother would give with `τ` as an extra state without an
//! observation (the tests compare with the batch solve); with `q = 0`, `K = 0` and the path is
//! the straight line through `ŝ_k`. For `q > 0` the mean is the cubic Hermite interpolation of the
//! smoothed positions and velocities.
//!
//! # Which clock points are made
//! `t = k · period` for every integer k with `t_first <= t <= t_last`, except those inside a
//! gap longer than `max_gap` seconds between two consecutive observation groups (a path is not
//! invented where no camera saw the road user, as `traj_resample` does not bridge such gaps).
//! A path shorter than one period may get no clock point at all (an empty result, as with
//! `traj_resample`); call without `period` to get the groups' times instead.
//!
//! Complexity: O(n + m) for n observations and m clock points; `output_points` is checked from
//! the time span before any work.

use super::smooth::{smooth, Smoothed};
use super::{check_q, Cov, FuseError, FusedPath, Obs, M2};
use crate::limits;
use crate::{positive, positive_or_inf, ParamError};

/// The fused path of `obs` with acceleration noise density `q` (m²/s³): at the observation
/// groups' times when `clock` is `None`, else at `t = k · period` (`clock = (period, max_gap)`).
pub fn fuse(obs: Obs<'_>, q: f64, clock: Option<(f64, f64)>) -> Result<FusedPath, FuseError> {
    check_q(q)?;
    let clock = match clock {
        None => None,
        Some((p, g)) => Some((positive("period", p)?, positive_or_inf("max_gap", g)?)),
    };
    obs.validate()?;
    if let Some((period, _)) = clock {
        if let (Some(&a), Some(&b)) = (obs.t.first(), obs.t.last()) {
            // the clock index k = t / period must be an exact integer in f64 (as in traj_resample)
            const EXACT: f64 = 9_007_199_254_740_992.0;
            if !((a / period).abs() < EXACT && (b / period).abs() < EXACT) {
                return Err(FuseError::Param(ParamError {
                    name: "period",
                    rule: "large enough that t / period stays below 2^53 for every t of the observations",
                    value: period,
                }));
            }
            let estimate = ((b - a) / period).floor() + 1.0;
            if estimate > limits::OUTPUT_POINTS.get() as f64 {
                return Err(FuseError::TooManyPoints(estimate));
            }
        }
    } else {
        limits::OUTPUT_POINTS.check(obs.len() as u128).map_err(|_| FuseError::TooManyPoints(obs.len() as f64))?;
    }
    let s = smooth(obs, q)?;
    match clock {
        None => {
            let mut out = FusedPath::with_capacity(s.len())?;
            for g in 0..s.len() {
                out.push(s.t0 + s.tau[g], s.x0 + s.sx[g][0], s.y0 + s.sy[g][0], s.sigma(g));
            }
            Ok(out)
        }
        Some((period, max_gap)) => on_clock(&s, period, max_gap),
    }
}

/// The smoothed path at `t = k · period` (see the module docs).
fn on_clock(s: &Smoothed, period: f64, max_gap: f64) -> Result<FusedPath, FuseError> {
    let m = s.len();
    if m == 0 {
        return Ok(FusedPath::default());
    }
    let (first, last) = (s.t0 + s.tau[0], s.t0 + s.tau[m - 1]);
    let estimate = ((last - first) / period).floor() + 1.0;
    let mut out = FusedPath::with_capacity(estimate.max(0.0) as usize)?;
    let mut g = 0usize;
    for t in crate::traj::grid::clock_ticks(first, last, period) {
        let tau = t - s.t0;
        while g + 1 < m && s.tau[g + 1] <= tau {
            g += 1;
        }
        if s.tau[g] == tau || g + 1 == m {
            // on a group's time (the last group: t == last)
            if s.tau[g] == tau {
                out.push(t, s.x0 + s.sx[g][0], s.y0 + s.sy[g][0], s.sigma(g));
            }
            continue;
        }
        let (d1, d2) = (tau - s.tau[g], s.tau[g + 1] - tau);
        if s.tau[g + 1] - s.tau[g] > max_gap {
            continue;
        }
        let (px, py, var) = bridge(s, g, d1, d2);
        out.push(t, s.x0 + px, s.y0 + py, var.max(0.0).sqrt());
    }
    Ok(out)
}

/// `Q(d)` with q = 1 and its inverse `[[12/d³, −6/d²], [−6/d², 4/d]]`.
fn q1(d: f64) -> M2 {
    Cov::q(1.0, d).m()
}
fn q1_inv(d: f64) -> M2 {
    M2 { a: 12.0 / (d * d * d), b: -6.0 / (d * d), c: -6.0 / (d * d), d: 4.0 / d }
}

/// The smoothed positions (x, y, relative) and position variance at `τ_g + d₁`, `d₁, d₂ > 0`.
fn bridge(s: &Smoothed, g: usize, d1: f64, d2: f64) -> (f64, f64, f64) {
    let d = d1 + d2;
    let (f1, f2, f) = (M2::f(d1), M2::f(d2), M2::f(d));
    let k = if s.q > 0.0 { q1(d1).mul(f2.t()).mul(q1_inv(d)) } else { M2::default() };
    let a = f1.sub(k.mul(f));
    let b = k;
    let var_b = if s.q > 0.0 { Cov::of(q1(d1).sub(k.mul(f2).mul(q1(d1)))).pp * s.q } else { 0.0 };
    let (pk, pn, x) = (s.cov[g].m(), s.cov[g + 1].m(), s.cross[g]);
    let p = a.mul(pk).mul(a.t()).add(b.mul(pn).mul(b.t())).add(a.mul(x).mul(b.t())).add(b.mul(x.t()).mul(a.t()));
    let mx = a.apply(s.sx[g]);
    let nx = b.apply(s.sx[g + 1]);
    let my = a.apply(s.sy[g]);
    let ny = b.apply(s.sy[g + 1]);
    (mx[0] + nx[0], my[0] + ny[0], var_b + p.a)
}

#[cfg(test)]
mod tests {
    use super::super::batch;
    use super::*;
    use proptest::prelude::*;

    fn cols(v: &[(f64, f64, f64, f64)]) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        (v.iter().map(|o| o.0).collect(), v.iter().map(|o| o.1).collect(), v.iter().map(|o| o.2).collect(), v.iter().map(|o| o.3).collect())
    }

    #[test]
    fn groups_or_clock() {
        // two cameras 37 ms apart: one point per distinct time, or one per 0.1 s clock tick
        let mut v = Vec::new();
        for k in 0..10 {
            let t = 100.0 + 0.1 * k as f64 + 0.004;
            v.push((t, 2.0 * t, 0.0, 0.1));
            v.push((t + 0.037, 2.0 * (t + 0.037), 0.0, 0.2));
        }
        let (t, x, y, s) = cols(&v);
        let o = Obs::new(&t, &x, &y, &s);
        let a = fuse(o, 0.5, None).unwrap();
        assert_eq!(a.len(), 20);
        let b = fuse(o, 0.5, Some((0.1, 1.0))).unwrap();
        assert_eq!(b.len(), 9, "{:?}", b.t);
        for k in 0..b.len() {
            assert!((b.t[k] - (100.1 + 0.1 * k as f64)).abs() < 1e-9);
            assert!((b.x[k] - 2.0 * b.t[k]).abs() < 1e-9, "{} {}", b.x[k], b.t[k]);
            assert!(b.sigma[k] > 0.0 && b.sigma[k] < 0.1);
        }
        // steps are the clock's: never under a microsecond
        assert!(b.t.windows(2).all(|w| w[1] - w[0] > 0.099));
    }

    #[test]
    fn gaps_are_not_bridged_and_bad_parameters_refused() {
        let v = [(0.0, 0.0, 0.0, 0.1), (0.1, 0.1, 0.0, 0.1), (3.0, 3.0, 0.0, 0.1), (3.1, 3.1, 0.0, 0.1)];
        let (t, x, y, s) = cols(&v);
        let o = Obs::new(&t, &x, &y, &s);
        assert_eq!(fuse(o, 1.0, Some((0.5, 1.0))).unwrap().t, vec![0.0, 3.0]);
        assert_eq!(fuse(o, 1.0, Some((0.5, f64::INFINITY))).unwrap().t, vec![0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0]);
        for (p, g, msg) in [(0.0, 1.0, "period must be > 0"), (f64::NAN, 1.0, "period must be > 0"), (0.1, 0.0, "max_gap must be > 0"), (1e-320, 1.0, "period must be large enough")] {
            let e = fuse(o, 1.0, Some((p, g))).unwrap_err();
            assert!(e.to_string().starts_with(msg), "{e}");
        }
        let e = fuse(o, 1.0, Some((1e-9, 1.0))).unwrap_err();
        assert!(matches!(e, FuseError::TooManyPoints(_)), "{e}");
        // a path shorter than a period: no clock point
        let (t, x, y, s) = cols(&[(0.01, 0.0, 0.0, 0.1), (0.02, 0.0, 0.0, 0.1)]);
        assert!(fuse(Obs::new(&t, &x, &y, &s), 1.0, Some((0.1, 1.0))).unwrap().is_empty());
        assert!(fuse(Obs::new(&[], &[], &[], &[]), 1.0, Some((0.1, 1.0))).unwrap().is_empty());
    }

    /// q = 0: no acceleration at all, the fused path is one straight line at one velocity.
    #[test]
    fn zero_q_is_a_straight_line() {
        let v: Vec<_> = (0..20).map(|k| (0.13 * k as f64, (k as f64).sin(), (k as f64 * 0.3).cos(), 0.1 + 0.05 * (k % 2) as f64)).collect();
        let (t, x, y, s) = cols(&v);
        let f = fuse(Obs::new(&t, &x, &y, &s), 0.0, Some((0.1, f64::INFINITY))).unwrap();
        let vx = (f.x[1] - f.x[0]) / (f.t[1] - f.t[0]);
        let vy = (f.y[1] - f.y[0]) / (f.t[1] - f.t[0]);
        for k in 0..f.len() {
            assert!((f.x[k] - f.x[0] - vx * (f.t[k] - f.t[0])).abs() < 1e-9 && (f.y[k] - f.y[0] - vy * (f.t[k] - f.t[0])).abs() < 1e-9);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// A clock point between two groups equals the batch MAP with that time as an extra
        /// state that has no observation.
        #[test]
        fn bridge_equals_the_batch_map(
            steps in prop::collection::vec((0.06f64..0.5, -3.0f64..3.0, 0.02f64..1.0), 2..12),
            q in prop::sample::select(vec![0.01, 0.3, 5.0]),
            period in 0.05f64..0.4,
        ) {
            let mut v = Vec::new();
            let mut t = 0.0;
            for (dt, x, s) in steps {
                t += dt;
                v.push((t, x, -x, s));
            }
            let (tt, x, y, s) = cols(&v);
            let f = fuse(Obs::new(&tt, &x, &y, &s), q, Some((period, f64::INFINITY))).unwrap();
            let obs: Vec<(f64, f64, f64)> = v.iter().map(|o| (o.0 - v[0].0, o.1 - v[0].1, o.3)).collect();
            for (k, &tk) in f.t.iter().enumerate() {
                // the dense solve is ill-conditioned for a state very close to another one
                // (Q(d)^-1 grows as 1/d^3): those points are compared with the smoother instead
                let tau = tk - v[0].0;
                if obs.iter().any(|o| (o.0 - tau).abs() < 0.01 && o.0 != tau) {
                    continue;
                }
                let (states, var, times) = batch::map_axis_times(&obs, &[tau], q);
                let i = times.iter().position(|&b| (b - tau).abs() < 1e-12).unwrap();
                let scale = 1.0 + states[i].0.abs();
                prop_assert!((f.x[k] - v[0].1 - states[i].0).abs() < 1e-6 * scale, "t {} x {} vs {}", tk, f.x[k] - v[0].1, states[i].0);
                prop_assert!((f.sigma[k].powi(2) - var[i]).abs() < 1e-6 * (1.0 + var[i]), "t {} var {} vs {}", tk, f.sigma[k].powi(2), var[i]);
            }
        }
    }
}
