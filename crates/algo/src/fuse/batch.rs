//! Tests only: the slow, obviously right version of [`super::smooth`] and [`super::sample`] for
//! one axis. The MAP estimate of every state under the model of [`super`] with a flat prior
//! minimises
//!
//! ```text
//! Σ_obs (z_i − p(t_i))² / σ_i²  +  Σ_k (s_{k+1} − F(d_k) s_k)ᵀ Q(d_k)⁻¹ (s_{k+1} − F(d_k) s_k)
//! ```
//!
//! a quadratic in all states at once: its normal equations `N s = b` are solved densely
//! (Gaussian elimination with partial pivoting, O(S³) for S states) and the posterior
//! covariance is `N⁻¹`. Needs q > 0 (Q invertible).

use super::SAME_TIME_S;

/// `obs` = (time, position, sigma), sorted by time; `extra` = times of states without an
/// observation. Returns the MAP (p, v) of every state, its position variance, and the states'
/// times (the observation groups' and `extra`, sorted).
pub fn map_axis_times(obs: &[(f64, f64, f64)], extra: &[f64], q: f64) -> (Vec<(f64, f64)>, Vec<f64>, Vec<f64>) {
    assert!(q > 0.0);
    // groups: the same rule as smooth()
    let mut times: Vec<f64> = Vec::new();
    let mut start = f64::NEG_INFINITY;
    let mut of_obs = Vec::new();
    for o in obs {
        if o.0 - start >= SAME_TIME_S {
            start = o.0;
            times.push(o.0);
        }
        of_obs.push(start);
    }
    for &e in extra {
        if !times.iter().any(|&t| (t - e).abs() < 1e-12) {
            times.push(e);
        }
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let s = times.len();
    let idx = |t: f64| times.iter().position(|&u| (u - t).abs() < 1e-12).unwrap();
    let n = 2 * s;
    let mut a = vec![vec![0.0; n]; n];
    let mut b = vec![0.0; n];
    for (o, &g) in obs.iter().zip(&of_obs) {
        let i = 2 * idx(g);
        a[i][i] += 1.0 / (o.2 * o.2);
        b[i] += o.1 / (o.2 * o.2);
    }
    for k in 0..s.saturating_sub(1) {
        let d = times[k + 1] - times[k];
        // Q(d)^-1
        let qi = [[12.0 / (q * d * d * d), -6.0 / (q * d * d)], [-6.0 / (q * d * d), 4.0 / (q * d)]];
        // residual = G [s_k; s_k+1], G = [-F, I]
        let g = [[-1.0, -d, 1.0, 0.0], [0.0, -1.0, 0.0, 1.0]];
        let base = 2 * k;
        for r in 0..4 {
            for c in 0..4 {
                let mut v = 0.0;
                for i in 0..2 {
                    for j in 0..2 {
                        v += g[i][r] * qi[i][j] * g[j][c];
                    }
                }
                a[base + r][base + c] += v;
            }
        }
    }
    let sol = solve(&a, &b);
    let mut var = Vec::new();
    for k in 0..s {
        let mut e = vec![0.0; n];
        e[2 * k] = 1.0;
        var.push(solve(&a, &e)[2 * k]);
    }
    ((0..s).map(|k| (sol[2 * k], sol[2 * k + 1])).collect(), var, times)
}

/// [`map_axis_times`] without the times.
pub fn map_axis(obs: &[(f64, f64, f64)], extra: &[f64], q: f64) -> (Vec<(f64, f64)>, Vec<f64>) {
    let (s, v, _) = map_axis_times(obs, extra, q);
    (s, v)
}

fn solve(a: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let n = b.len();
    let mut m: Vec<Vec<f64>> = a.iter().zip(b).map(|(r, &v)| r.iter().copied().chain([v]).collect()).collect();
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| m[i][c].abs().partial_cmp(&m[j][c].abs()).unwrap()).unwrap();
        m.swap(c, p);
        for r in 0..n {
            if r != c {
                let f = m[r][c] / m[c][c];
                if f != 0.0 {
                    for k in c..=n {
                        m[r][k] -= f * m[c][k];
                    }
                }
            }
        }
    }
    (0..n).map(|i| m[i][n] / m[i][i]).collect()
}
