//! The noise model's conversions: from what calibrate.sql, align.sql, quality.sql and fuse.sql
//! measure (medians and percentiles of distances) to the model's parameters, each once, with
//! the distribution it assumes. Positions carry independent Gaussian noise σ per axis; a road
//! user's acceleration is white noise; a 2-D length of a zero-mean isotropic Gaussian with
//! per-axis variance s² is Rayleigh with scale s: its median is `s √(2 ln 2)`, its p-quantile
//! `s √(−2 ln(1 − p))`, and its square is `s² χ²₂` (median `2 ln 2 s²`).
//!
//! Every function is O(1). Each argument is a length, a variance, a percentile or a time, so it
//! must be finite and ≥ 0 (a period > 0); anything else is a [`NoiseError`] naming it (a NaN, a
//! negative σ or a negative period would otherwise come out as a plausible number). The SQL's
//! aggregates give NULL where there is nothing to measure, and the stages coalesce.

use std::fmt;

/// An argument outside its domain: (name, value, what it must be).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseError {
    pub param: &'static str,
    pub value: f64,
    pub want: &'static str,
}

impl fmt::Display for NoiseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} must be {}, got {:e}", self.param, self.want, self.value)
    }
}
impl std::error::Error for NoiseError {}

/// `v` finite and ≥ 0.
fn nonneg(param: &'static str, v: f64) -> Result<f64, NoiseError> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(NoiseError { param, value: v, want: "finite and >= 0" })
    }
}

/// `v` finite and > 0.
fn positive(param: &'static str, v: f64) -> Result<f64, NoiseError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(NoiseError { param, value: v, want: "finite and > 0" })
    }
}

/// `√(2 ln 2)`: the median of a Rayleigh distribution in units of its scale.
pub const RAYLEIGH_MEDIAN: f64 = 1.1774100225154747;
/// `√(2 ln 20)`: the 95th percentile of a Rayleigh distribution in units of its scale.
pub const RAYLEIGH_P95: f64 = 2.4477468306808166;
/// `√(2 ln 100)`: the radius holding 99 % of a 2-D isotropic Gaussian, in per-axis sigmas.
pub const RADIUS_99: f64 = 3.034854258770293;
/// The 95 % point of chi-square with 2 degrees of freedom, `2 ln 20`.
pub const CHI2_2_95: f64 = 5.991464547107982;
/// The smallest matching radius (m): noise-free input measures σ = 0, and LCSS needs ε > 0; 1 mm
/// is below any camera's noise.
pub const MIN_EPSILON_M: f64 = 1e-3;
/// The floor of the process noise, as a share of its value before the position noise is taken
/// out (where noise is nearly all of the measurement the difference is uncertain; docs/fusion.md
/// measured q × 0.1 to cost < 5 % of accuracy).
pub const Q_FLOOR_SHARE: f64 = 0.1;

/// A camera's per-axis position noise σ from the median of `|p(t+1) − 2 p(t) + p(t−1)|²` over
/// evenly spaced triples of its tracks (calibrate.sql): a second difference of noisy positions
/// has per-axis variance 6σ² (plus the motion's own, small at camera rates), so its squared
/// length is `6σ² χ²₂` with median `12 ln 2 σ²`: `σ = √(median / (12 ln 2))`.
pub fn sigma_from_second_differences(median_sq: f64) -> Result<f64, NoiseError> {
    Ok((nonneg("median_sq", median_sq)? / (12.0 * std::f64::consts::LN_2)).sqrt())
}

/// Per-axis σ from the median length of 2-D residuals (align.sql's matched residuals: Rayleigh,
/// robust to the few wrong pairs): `median / √(2 ln 2)`.
pub fn sigma_from_rayleigh_median(median: f64) -> Result<f64, NoiseError> {
    Ok(nonneg("median_m", median)? / RAYLEIGH_MEDIAN)
}

/// Per-axis σ from the 95th percentile length of a 2-D Gaussian quantity (a class's
/// acceleration, calibrate.sql's accel_p95): `p95 / √(2 ln 20)`.
pub fn sigma_from_rayleigh_p95(p95: f64) -> Result<f64, NoiseError> {
    Ok(nonneg("p95", p95)? / RAYLEIGH_P95)
}

/// LCSS's matching radius ε for a camera pair whose residuals have per-axis σ: 99 % of a true
/// pair's points fall within it, `√(2 ln 100) σ` (3.03 σ), at least [`MIN_EPSILON_M`].
pub fn match_epsilon(sigma: f64) -> Result<f64, NoiseError> {
    Ok((RADIUS_99 * nonneg("sigma_m", sigma)?).max(MIN_EPSILON_M))
}

/// The continuous white-noise-acceleration density q (m²/s³) of a class for the fusion's
/// Kalman smoother (fuse.sql), from its acceleration's 95th percentile `accel_p95` (second
/// differences on tracks resampled to 1 s) and the cameras' mean position variance `noise_var`
/// (σ², m²). Under the model that second difference is Gaussian per axis with variance
/// `q · 2τ³/3` (τ = 1 s) plus `6 σ²` of position noise, so
/// `q = 1.5 · max((accel_p95 / √(2 ln 20))² − 6 σ², Q_FLOOR_SHARE · (accel_p95 / √(2 ln 20))²)`.
pub fn process_noise_q(accel_p95: f64, noise_var: f64) -> Result<f64, NoiseError> {
    let s2 = sigma_from_rayleigh_p95(nonneg("accel_p95", accel_p95)?)?.powi(2);
    Ok(1.5 * (s2 - 6.0 * nonneg("noise_var", noise_var)?).max(Q_FLOOR_SHARE * s2))
}

/// The radius (m) holding 95 % of where a road user reappears after a gap `gap_s` (quality.sql's
/// local density of starts): position noise σ plus the acceleration allowance `σ_acc gap² / 2`
/// per axis, `√(5.99 (σ² + (σ_acc gap²/2)²))`, at least `min_radius_m`.
pub fn reappear_radius_95(sigma: f64, sigma_acc: f64, gap_s: f64, min_radius_m: f64) -> Result<f64, NoiseError> {
    let (sigma, sigma_acc) = (nonneg("sigma_m", sigma)?, nonneg("sigma_acc", sigma_acc)?);
    let (gap_s, min_radius_m) = (nonneg("gap_s", gap_s)?, nonneg("min_radius_m", min_radius_m)?);
    Ok((CHI2_2_95 * (sigma * sigma + (sigma_acc * gap_s * gap_s / 2.0).powi(2))).sqrt().max(min_radius_m))
}

/// The window W (s) of the least-squares line that gives a track end's velocity (quality.sql's
/// break links; calibrate.sql's calib_fit_window): over the last W seconds a line's velocity has
/// variance `12 σ² period / W³` per axis, and a road user accelerating at `σ_acc` biases it by
/// about `σ_acc W / 2`; the sum is least at `W⁵ = 72 σ² period / σ_acc²`. At least 3 periods (a
/// slope and its scatter need 3 points); σ and σ_acc at least 1 mm (/s²).
pub fn velocity_window_s(sigma: f64, period_s: f64, sigma_acc: f64) -> Result<f64, NoiseError> {
    let (s, a) = (nonneg("sigma_m", sigma)?.max(1e-3), nonneg("sigma_acc", sigma_acc)?.max(1e-3));
    let period_s = positive("period_s", period_s)?;
    Ok((3.0 * period_s).max((72.0 * s * s * period_s / (a * a)).powf(0.2)))
}

/// The hypothesis allowance of [`align_vote_rms`] (m): a clock hypothesis on align.sql's grid
/// is up to half a bin off, and interpolating the moving track at that time adds a few cm at a
/// road user's speed; 0.1 m covers both (the pre-issue-38 rule, kept: its reason still holds).
pub const VOTE_ALLOWANCE_M: f64 = 0.1;
/// Sigmas of [`align_vote_rms`]: a true hypothesis's RMS of n point pairs is about σ_pair per axis
/// and rarely above 3 σ_pair, where two road users side by side (0.7 m apart) are far above it.
pub const VOTE_SIGMAS: f64 = 3.0;
/// The allowance of [`align_refine_rms`] (m): the refit's pairs sit at the pooled clock, so half
/// the vote's allowance.
pub const REFINE_ALLOWANCE_M: f64 = 0.05;
/// Sigmas of [`align_refine_rms`]: tighter than the vote's, so that neighbours walking 0.7 m
/// apart stay out while σ_pair is under ~0.3 m.
pub const REFINE_SIGMAS: f64 = 2.0;

/// align.sql's first gate: a hypothesis (a track pair's own best fit) votes when the RMS of its
/// point pairs about that fit is within `VOTE_ALLOWANCE_M + VOTE_SIGMAS σ_pair` (m), `σ_pair` =
/// `√(σ_a² + σ_b²)` the camera pair's per-axis residual noise (calibrate.sql).
pub fn align_vote_rms(sigma_pair: f64) -> Result<f64, NoiseError> {
    Ok(VOTE_ALLOWANCE_M + VOTE_SIGMAS * nonneg("sigma_pair_m", sigma_pair)?)
}

/// align.sql's second gate (`align_clean`): a track pair is kept in the refit when the RMS about
/// its own mean offset is within `REFINE_ALLOWANCE_M + REFINE_SIGMAS σ_pair` (m).
pub fn align_refine_rms(sigma_pair: f64) -> Result<f64, NoiseError> {
    Ok(REFINE_ALLOWANCE_M + REFINE_SIGMAS * nonneg("sigma_pair_m", sigma_pair)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_align_gates() {
        assert_eq!(align_vote_rms(0.0).unwrap(), 0.1);
        assert!((align_vote_rms(0.1).unwrap() - 0.4).abs() < 1e-15);
        assert!((align_refine_rms(0.1).unwrap() - 0.25).abs() < 1e-15);
        // neighbours 0.7 m apart fail the refine gate while sigma_pair < 0.3 m: 0.05 + 2 * 0.3 = 0.65
        assert!(align_refine_rms(0.29).unwrap() < 0.7);
        assert!(align_vote_rms(-1.0).is_err() && align_refine_rms(f64::NAN).is_err());
        // the vote admits at least what the refit keeps
        for s in [0.0, 0.05, 0.2, 1.0] {
            assert!(align_vote_rms(s).unwrap() >= align_refine_rms(s).unwrap());
        }
    }

    #[test]
    fn the_constants_are_their_formulas() {
        assert!((RAYLEIGH_MEDIAN - (2.0 * 2f64.ln()).sqrt()).abs() < 1e-15);
        assert!((RAYLEIGH_P95 - (2.0 * 20f64.ln()).sqrt()).abs() < 1e-15);
        assert!((RADIUS_99 - (2.0 * 100f64.ln()).sqrt()).abs() < 1e-15);
        assert!((CHI2_2_95 - 2.0 * 20f64.ln()).abs() < 1e-12);
    }

    /// A deterministic standard normal stream (Box–Muller over an LCG).
    fn normals(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        let mut u = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        move || (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos()
    }

    fn median(mut v: Vec<f64>) -> f64 {
        crate::stats::median(&mut v)
    }

    #[test]
    fn property_sigma_is_recovered_from_simulated_noise() {
        let mut g = normals(7);
        let sigma = 0.13;
        // second differences of pure noise
        let p: Vec<(f64, f64)> = (0..40_001).map(|_| (sigma * g(), sigma * g())).collect();
        let sq: Vec<f64> = p.windows(3).map(|w| (w[2].0 - 2.0 * w[1].0 + w[0].0).powi(2) + (w[2].1 - 2.0 * w[1].1 + w[0].1).powi(2)).collect();
        let s = sigma_from_second_differences(median(sq)).unwrap();
        assert!((s / sigma - 1.0).abs() < 0.03, "{s}");
        // 2-D residual lengths
        let r: Vec<f64> = (0..40_000).map(|_| (sigma * g()).hypot(sigma * g())).collect();
        assert!((sigma_from_rayleigh_median(median(r.clone())).unwrap() / sigma - 1.0).abs() < 0.03);
        let mut r = r;
        r.sort_by(f64::total_cmp);
        assert!((sigma_from_rayleigh_p95(r[38_000]).unwrap() / sigma - 1.0).abs() < 0.03);
        // 99 % within the matching radius
        let inside = r.iter().filter(|&&d| d <= match_epsilon(sigma).unwrap()).count() as f64 / r.len() as f64;
        assert!((inside - 0.99).abs() < 0.003, "{inside}");
    }

    #[test]
    fn floors_hold() {
        assert_eq!(match_epsilon(0.0).unwrap(), MIN_EPSILON_M);
        assert!(match_epsilon(f64::NAN).is_err() && match_epsilon(-1.0).is_err());
        assert_eq!(velocity_window_s(0.3, -1.0, 1.0).unwrap_err().to_string(), "period_s must be finite and > 0, got -1e0");
        assert!(process_noise_q(2.0, f64::NAN).is_err() && process_noise_q(2.0, f64::INFINITY).is_err() && process_noise_q(2.0, -1.0).is_err());
        assert!(reappear_radius_95(0.1, f64::INFINITY, 0.0, 0.0).is_err() && reappear_radius_95(f64::NAN, 0.0, 1.0, 0.5).is_err());
        assert!(sigma_from_rayleigh_median(-1.0).is_err() && sigma_from_second_differences(-1.0).is_err());
        let s2 = sigma_from_rayleigh_p95(1.0).unwrap().powi(2);
        assert!((process_noise_q(1.0, 0.0).unwrap() - 1.5 * s2).abs() < 1e-15);
        assert!((process_noise_q(1.0, 10.0).unwrap() - 1.5 * Q_FLOOR_SHARE * s2).abs() < 1e-15);
        assert_eq!(reappear_radius_95(0.0, 0.0, 1.0, 1.0).unwrap(), 1.0);
        // pedestrians at 10 Hz, sigma 0.3 m, accel_p95 1.5 m/s²: about 1.1 s; never under 3 periods
        let w = velocity_window_s(0.3, 0.1, sigma_from_rayleigh_p95(1.5).unwrap()).unwrap();
        assert!((w - 1.1).abs() < 0.1, "{w}");
        assert_eq!(velocity_window_s(0.0, 0.5, 100.0).unwrap(), 1.5);
        assert!((reappear_radius_95(1.0, 0.0, 1.0, 0.0).unwrap() - CHI2_2_95.sqrt()).abs() < 1e-12);
    }
}
