//! The evidence of one candidate pair of tracks (two cameras, one class), over their whole
//! common time (docs/association.md).
//!
//! From the correspondences of the two tracks on the common clock ([`crate::align::msd`]): `n`
//! common steps, the mean offset `b = (dx, dy)` = mean of `p_a(t) − p_b(t)` and the mean squared
//! distance `msd`. With `n_eff` independent samples (one per period of the slower camera) and
//! the camera pair's per-axis noise `σ_d`:
//!
//! ```text
//! r_res = (msd − |b|²) / (2 σ_d²)                the residual after removing the constant offset:
//!                                                 2 n_eff r_res ~ χ²(2 n_eff − 2) for one road user
//! r_gate = χ²_{k}(0.999) / (2 n_eff) + 0.25      k = 2 n_eff − 2 (Wilson–Hilferty), + the
//!                                                 allowance for an offset that varies along the
//!                                                 common time by up to 0.71 σ_d RMS
//! se²   = σ_d² / n_eff                           the measurement variance of b, per axis
//! d²    = (b − μ)ᵀ (Σ + se² I)⁻¹ (b − μ)         b against the camera pair's bias state (μ, Σ)
//!                                                 ([`super::bias`]): χ²₂ for one road user
//! nll   = n_eff r_res + d² / 2                   the negative log-likelihood (up to terms equal
//!                                                 for every candidate of a camera pair and class)
//! ```
//!
//! A pair is a **candidate** when `r_res ≤ r_gate` and `d² ≤` the state's gate
//! ([`BiasState::gate`]: `χ²₂(0.999)` for a state given, Hotelling's predictive bound for one
//! estimated from few anchors).
//! Hungarian maximises `score = n_eff (r_gate − r_res) + (gate − d²) / 2` (both margins, in
//! log-likelihood units). A match is **clear** of a rival candidate of either track when it is
//! [`RATIO`] times likelier ([`clear_of`]).
//!
//! Before issue 38 the offset was part of the residual (`r = msd / (2 σ_d²)`, gate + 0.25): a
//! constant offset beyond 0.71 σ_d was refused, and with half a metre of viewpoint bias only
//! one in five cross-camera pairs of a car was matched. Where the data show no bias (a drone,
//! the shared scenes), the bias state is tight (Σ of a few cm²) and two neighbours a metre apart
//! are refused as firmly as before; where cameras see different points of a road user, Σ is as
//! wide as the measured offsets of unambiguous matches, and the residual and the rivals decide.
//!
//! O(1) per pair.

use super::bias::BiasState;
use super::Z_999;

/// The residual gate's allowance: an offset that varies along the common time (a car turning
/// before two cameras, a ground-plane error left by the registration) by up to 0.71 σ_d RMS.
/// (The gate of the shared scenes before issue 38 had the same 0.25, then for a constant
/// offset: their true pairs' residual stays below 1.21.)
pub const RESIDUAL_ALLOWANCE: f64 = 0.25;

/// A match must be this many times likelier than every rival candidate of either track (in
/// the same camera pair at the same time). 100 lost true pairs in waiting crowds at σ 0.3 m
/// (exact 0.979 against 1.000 with 10; docs/association.md).
pub const RATIO: f64 = 10.0;

/// The evidence of one candidate pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairEvidence {
    pub r_res: f64,
    pub r_gate: f64,
    pub d2: f64,
    pub nll: f64,
    pub score: f64,
    pub candidate: bool,
}

/// `χ²_k(0.999) / (2 n_eff) + RESIDUAL_ALLOWANCE`, k = 2 n_eff − 2 (at least 1), by
/// Wilson–Hilferty.
pub fn residual_gate(n_eff: f64) -> f64 {
    let n = if n_eff.is_finite() { n_eff.max(1.0) } else { 1.0 };
    let k = (2.0 * n - 2.0).max(1.0);
    let h = 2.0 / (9.0 * k);
    k * (1.0 - h + Z_999 * h.sqrt()).powi(3) / (2.0 * n) + RESIDUAL_ALLOWANCE
}

/// The evidence of a pair with `n_eff` independent samples, mean offset `(dx, dy)`, mean
/// squared distance `msd` (m²), noise `sigma_d` (m, per axis) and the camera pair's bias state.
pub fn pair_evidence(msd: f64, dx: f64, dy: f64, sigma_d: f64, n_eff: f64, state: &BiasState) -> PairEvidence {
    let n = if n_eff.is_finite() { n_eff.max(1.0) } else { 1.0 };
    let s2 = (sigma_d * sigma_d).max(1e-12);
    let r_res = ((msd - dx * dx - dy * dy).max(0.0)) / (2.0 * s2);
    let r_gate = residual_gate(n);
    let d2 = state.d2(dx, dy, s2 / n);
    let gate = state.gate();
    let nll = n * r_res + d2 / 2.0;
    // both margins in log-likelihood units (the offset's against the state's gate: every pair
    // of a camera pair and class shares the state, so the gate moves their weights alike)
    let score = n * (r_gate - r_res) + (gate - d2) / 2.0;
    let candidate = r_res.is_finite() && r_res <= r_gate && d2 <= gate;
    PairEvidence { r_res, r_gate, d2, nll, score, candidate }
}

/// Is the pair (`r_res`, `d2`, `n_eff`) [`RATIO`] times likelier than the rival (`ro`, `d2o`,
/// `no`)? The residuals compare per independent sample over the shorter of the two common
/// times, the offsets as they are: `(ro − r) min(n, no) + (d2o − d2) / 2 ≥ ln RATIO`.
pub fn clear_of(r_res: f64, d2: f64, n_eff: f64, ro: f64, d2o: f64, no: f64) -> bool {
    (ro - r_res) * n_eff.min(no).max(1.0) + (d2o - d2) / 2.0 >= RATIO.ln()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_gate_is_the_chi2_quantile() {
        // chi2(198) at 0.999 by Wilson-Hilferty: 198 (1 - h + 3.09 sqrt h)^3, h = 2 / (9 198), = 265.3
        // (between the normal approximation's 259.5 and that plus the skew's correction)
        assert!((residual_gate(100.0) - (265.30 / 200.0 + 0.25)).abs() < 0.001, "{}", residual_gate(100.0));
        assert!(residual_gate(1.0).is_finite() && residual_gate(f64::NAN).is_finite());
    }

    #[test]
    fn a_biased_pair_passes_and_a_neighbour_does_not() {
        // cameras see a car 1 m apart (a bias state learned from such pairs), noise 0.1 m
        let state = BiasState { mx: 1.0, my: 0.0, sxx: 0.09, sxy: 0.0, syy: 0.09, n: 40 };
        let sd = 0.1;
        let n = 100.0;
        // the true pair: offset (1.05, 0.1), residual pure noise (msd = |b|^2 + 2 sd^2)
        let t = pair_evidence(1.05f64.powi(2) + 0.01 + 2.0 * sd * sd, 1.05, 0.1, sd, n, &state);
        assert!(t.candidate, "{t:?}");
        // a car in the next lane 3.5 m over, same bias: offset (1, 3.5)
        let w = pair_evidence(1.0 + 12.25 + 2.0 * sd * sd, 1.0, 3.5, sd, n, &state);
        assert!(!w.candidate && w.d2 > 100.0, "{w:?}");
        // the old rule would have refused the true pair: r = msd / (2 sd^2) = 56
        assert!((1.05f64.powi(2) + 0.01 + 0.02) / 0.02 > 50.0);
        // a pair whose offset wanders (not one road user) fails the residual
        let v = pair_evidence(1.0 + 0.5, 1.0, 0.0, sd, n, &state);
        assert!(!v.candidate && v.r_res > v.r_gate, "{v:?}");
        assert!(clear_of(t.r_res, t.d2, n, w.r_res, w.d2, n));
        assert!(!clear_of(w.r_res, w.d2, n, t.r_res, t.d2, n));
    }

    #[test]
    fn without_bias_two_people_a_metre_apart_are_refused() {
        // a drone scene: the bias state is tight (2 cm)
        let state = BiasState { mx: 0.0, my: 0.0, sxx: 4e-4, sxy: 0.0, syy: 4e-4, n: 200 };
        let sd = 0.35;
        let e = pair_evidence(1.0 + 2.0 * sd * sd, 1.0, 0.0, sd, 300.0, &state);
        assert!(!e.candidate && e.d2 > 1000.0, "{e:?}");
    }

    proptest! {
        /// A true pair (constant offset drawn from the state, Gaussian noise) passes the bias
        /// gate and the residual gate, and nll is its negative log-likelihood up to constants.
        #[test]
        fn score_and_candidate_agree(msd in 0.0f64..10.0, dx in -3.0f64..3.0, dy in -3.0f64..3.0, sd in 0.01f64..1.0, n in 1.0f64..500.0) {
            let state = BiasState::none(0.5);
            let e = pair_evidence(msd.max(dx * dx + dy * dy), dx, dy, sd, n, &state);
            prop_assert!(e.r_res >= 0.0 && e.d2 >= 0.0);
            prop_assert!((e.nll - (n * e.r_res + e.d2 / 2.0)).abs() < 1e-9 * (1.0 + e.nll));
            // a candidate always has a positive score
            if e.candidate { prop_assert!(e.score > 0.0); }
        }
    }
}
