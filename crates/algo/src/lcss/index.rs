//! Index-window LCSS of Buzan (2004), definitions 4.1 and 4.2, after Vlachos et al. (2002).
//!
//! `LCSS_{δ,ε}(A_x, B_x)` matches `a_{x,i}` with `b_{x,j}` when `|a_{x,i} − b_{x,j}| < ε` and
//! `|i − j| ≤ δ`. `LCSS_2D` is the pair of per-axis lengths; it is 0 when
//! `min(n, m) < ρ · max(n, m)` (ρ, the length aspect ratio, in (0, 1]). `S1_2D` divides each
//! axis by `min(n, m)` (eq. 4.3). Buzan's distance is `D1 = 1 / S1` (eq. 4.7), in [1, ∞];
//! trajdb's `lcss_distance` uses `1 − S` instead, which stays finite and lies in [0, 1].
//!
//! [`joint_length`] is the same banded recurrence with one 2-D match `‖a_i − b_j‖ < ε`: the
//! form tslearn's `lcss(…, eps, global_constraint="sakoe_chiba", sakoe_chiba_radius=δ)`
//! computes (tslearn tests `≤ ε`; on real-valued data the two differ only on exact ties).
//! One exception: for δ = 0 tslearn 0.10.0 returns only the trailing run of diagonal matches
//! (its out-of-band cells stay 0, so a non-match resets the count); we return the true LCSS.
//!
//! Notes on the source: definition 4.1 writes `|n − m| ≤ δ` while appendix eq. A.1 writes
//! `|i − j| < δ`. We follow definition 4.1 and Vlachos et al.: `|i − j| ≤ δ`, so δ = 0 means
//! "same index only".
//!
//! # Complexity
//! O(δ · (n + m)) time (lemma 4.1) and O(m) memory per axis.

use super::band::lcss_len;
use super::{LcssError, Within};
use crate::traj::Traj;

/// Checked parameters of the index-window form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IndexParams {
    delta: usize,
    epsilon: f64,
    /// 0 means "no length-aspect-ratio test".
    rho: f64,
}

impl IndexParams {
    /// `rho = None` disables the length-aspect-ratio test.
    pub fn new(delta: i64, epsilon: f64, rho: Option<f64>) -> Result<Self, LcssError> {
        if delta < 0 {
            return Err(LcssError::Delta(delta));
        }
        if !(epsilon > 0.0) {
            return Err(LcssError::Epsilon(epsilon));
        }
        let rho = match rho {
            None => 0.0,
            Some(r) if r > 0.0 && r <= 1.0 => r,
            Some(r) => return Err(LcssError::Rho(r)),
        };
        Ok(Self { delta: delta as usize, epsilon, rho })
    }
    pub fn delta(&self) -> usize {
        self.delta
    }
    pub fn epsilon(&self) -> f64 {
        self.epsilon
    }
    /// True when the pair fails the length-aspect-ratio test (or a side is empty).
    pub fn rejects(&self, n: usize, m: usize) -> bool {
        n == 0 || m == 0 || (n.min(m) as f64) < self.rho * n.max(m) as f64
    }
}

/// The index band `|i − j| ≤ δ` of `n` rows against `m` columns.
pub(crate) fn index_band(n: usize, m: usize, delta: usize) -> impl Iterator<Item = (usize, usize)> + Clone {
    (0..n).map(move |i| (i.saturating_sub(delta).min(m), i.saturating_add(delta).saturating_add(1).min(m)))
}

/// One axis: `LCSS_{δ,ε}(a, b)` of eq. 4.2, with `b` shifted by `shift` (0 for S1); `Err`
/// over the limit `lcss_cells` (checked by the engine before the work).
pub fn axis_length(a: &[f64], b: &[f64], delta: usize, epsilon: f64, shift: f64) -> Result<usize, LcssError> {
    lcss_len(a.len(), b.len(), index_band(a.len(), b.len(), delta), |i, j| (a[i] - (b[j] + shift)).abs() < epsilon)
}

/// Per-axis result of definition 4.1/4.2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct S1 {
    pub lx: usize,
    pub ly: usize,
    pub sx: f64,
    pub sy: f64,
}

/// The cells of an index-band LCSS table (|i − j| ≤ δ) against the work limit `lcss_cells`.
/// O(1).
pub fn check_work(n: usize, m: usize, p: &IndexParams) -> Result<(), LcssError> {
    let d = p.delta() as u128;
    let (n, m) = (n as u128, m as u128);
    // Σ_i |{j : |i − j| ≤ δ}| ≤ n · min(m, 2δ + 1)
    let cells = n * m.min(2 * d + 1);
    crate::limits::LCSS_CELLS.check(cells).map_err(LcssError::Work)
}

/// `LCSS_2D` and `S1_2D` (eq. 4.1, 4.3). Only x and y are used; t plays no part here.
pub fn s1(a: Traj<'_>, b: Traj<'_>, p: &IndexParams) -> Result<S1, LcssError> {
    if p.rejects(a.len(), b.len()) {
        return Ok(S1 { lx: 0, ly: 0, sx: 0.0, sy: 0.0 });
    }
    let lx = axis_length(a.x, b.x, p.delta, p.epsilon, 0.0)?;
    let ly = axis_length(a.y, b.y, p.delta, p.epsilon, 0.0)?;
    let k = a.len().min(b.len()) as f64;
    Ok(S1 { lx, ly, sx: lx as f64 / k, sy: ly as f64 / k })
}

/// Banded LCSS with a joint Euclidean match `‖a_i − b_j‖ < ε` and `|i − j| ≤ δ`.
pub fn joint_length(a: Traj<'_>, b: Traj<'_>, p: &IndexParams) -> Result<usize, LcssError> {
    if p.rejects(a.len(), b.len()) || !boxes_within(a, b, p.epsilon) {
        return Ok(0);
    }
    let w = Within::new(p.epsilon);
    lcss_len(a.len(), b.len(), index_band(a.len(), b.len(), p.delta), |i, j| w.test(a.x[i] - b.x[j], a.y[i] - b.y[j]))
}

/// Exact O(n + m) pre-check: the ε-inflated bounding boxes of the two point sets intersect.
fn boxes_within(a: Traj<'_>, b: Traj<'_>, eps: f64) -> bool {
    let bb = |x: &[f64], y: &[f64]| {
        let f = |v: &[f64]| v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &q| (lo.min(q), hi.max(q)));
        (f(x), f(y))
    };
    let ((ax0, ax1), (ay0, ay1)) = bb(a.x, a.y);
    let ((bx0, bx1), (by0, by1)) = bb(b.x, b.y);
    // (eps = inf: no spatial constraint, also where a difference overflows to inf)
    eps == f64::INFINITY || !(ax0 - bx1 >= eps || bx0 - ax1 >= eps || ay0 - by1 >= eps || by0 - ay1 >= eps)
}

/// `joint_length / min(n, m)`.
pub fn joint_similarity(a: Traj<'_>, b: Traj<'_>, p: &IndexParams) -> Result<f64, LcssError> {
    Ok(super::time_window::ratio(joint_length(a, b, p)?, a.len(), b.len()))
}

#[cfg(test)]
mod tests {
    use crate::lcss::band::naive;
    use super::*;
    use proptest::prelude::*;

    fn vals(max: usize) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec((0u8..6).prop_map(|k| k as f64 * 0.5), 0..max)
    }

    proptest! {
        #[test]
        fn index_forms_match_naive(ax in vals(10), bx in vals(10), d in 0i64..5,
                                   eps in prop::sample::select(vec![0.25, 0.5, 1.0, 2.0]),
                                   rho in prop::option::of(prop::sample::select(vec![0.3, 0.5, 1.0]))) {
            // y is a reversed copy so the two axes differ.
            let ay: Vec<f64> = ax.iter().rev().cloned().collect();
            let by: Vec<f64> = bx.iter().rev().cloned().collect();
            let at = vec![0.0; ax.len()];
            let bt = vec![0.0; bx.len()];
            let (n, m) = (ax.len(), bx.len());
            let p = IndexParams::new(d, eps, rho).unwrap();
            let du = d as usize;
            let nx = naive::table(n, m, |i, j| i.abs_diff(j) <= du && (ax[i] - bx[j]).abs() < eps)[n][m] as usize;
            let ny = naive::table(n, m, |i, j| i.abs_diff(j) <= du && (ay[i] - by[j]).abs() < eps)[n][m] as usize;
            let nj = naive::table(n, m, |i, j| i.abs_diff(j) <= du && (ax[i] - bx[j]).hypot(ay[i] - by[j]) < eps)[n][m] as usize;
            let rejected = n == 0 || m == 0 || (n.min(m) as f64) < rho.unwrap_or(0.0) * n.max(m) as f64;
            let r = s1(Traj::new(&at, &ax, &ay), Traj::new(&bt, &bx, &by), &p).unwrap();
            if rejected {
                prop_assert_eq!((r.lx, r.ly), (0, 0));
            } else {
                prop_assert_eq!((r.lx, r.ly), (nx, ny));
                prop_assert_eq!(joint_length(Traj::new(&at, &ax, &ay), Traj::new(&bt, &bx, &by), &p), Ok(nj));
            }
        }
    }

    /// Expected values from tslearn 0.10.0:
    /// `tslearn.metrics.lcss(a, b, eps=e, global_constraint="sakoe_chiba", sakoe_chiba_radius=d)`
    /// with `a[k] = (3 sin(0.7k), 0.5k)`, `b[k] = (3 sin(0.7k + 0.4), 0.5k + 0.3)`, k = 0..12.
    #[test]
    fn pinned_against_tslearn_0_10_0() {
        let ax: Vec<f64> = (0..12).map(|k| (k as f64 * 0.7).sin() * 3.0).collect();
        let ay: Vec<f64> = (0..12).map(|k| k as f64 * 0.5).collect();
        let bx: Vec<f64> = (0..12).map(|k| (k as f64 * 0.7 + 0.4).sin() * 3.0).collect();
        let by: Vec<f64> = (0..12).map(|k| k as f64 * 0.5 + 0.3).collect();
        let t = vec![0.0; 12];
        let (a, b) = (Traj::new(&t, &ax, &ay), Traj::new(&t, &bx, &by));
        // δ = 0 is the one place we differ on purpose: tslearn gives 1/12 (0.0833) there,
        // because it leaves cells outside the band at 0 instead of carrying C[i-1][j], so with
        // a one-cell band a non-match resets the count. The true banded LCSS counts the 3
        // diagonal matches: 3/12 (checked against the full table in the property test above).
        let p0 = IndexParams::new(0, 0.5, None).unwrap();
        assert_eq!(joint_similarity(a, b, &p0), Ok(0.25));
        for (d, e, want) in [
            (1, 0.5, 0.3333333333333333),
            (2, 1.0, 0.9166666666666666),
            (3, 0.25, 0.08333333333333333),
        ] {
            let p = IndexParams::new(d, e, None).unwrap();
            assert_eq!(joint_similarity(a, b, &p), Ok(want), "delta {d} eps {e}");
        }
    }

    #[test]
    fn params() {
        assert_eq!(IndexParams::new(-1, 1.0, None).unwrap_err().to_string(), "delta must be >= 0, got -1");
        assert_eq!(IndexParams::new(1, 1.0, Some(1.5)).unwrap_err().to_string(), "rho must be in (0, 1], got 1.5");
        assert!(IndexParams::new(1, 1.0, Some(0.0)).is_err());
        let p = IndexParams::new(2, 1.0, Some(0.5)).unwrap();
        assert!(p.rejects(2, 5));
        assert!(!p.rejects(3, 5));
    }
}
