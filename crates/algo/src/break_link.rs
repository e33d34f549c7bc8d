//! The evidence that a track's start continues an earlier track's end in one camera (a broken
//! track, sql/stages/quality.sql; docs/association.md, "Within-camera links").
//!
//! Both ends are extrapolated to the middle of the gap by least-squares lines; `d` is the
//! difference of the two predicted positions and `dv` of the two velocities. Under the
//! constant-velocity model (the road user kept its velocity through the gap) `d` and `dv` are
//! Gaussian with variances `var_cv` (per axis, from the two fits' noise) and `varv_cv`; if it
//! accelerated as its class may, with `var_cv + var_acc` and `varv_cv + varv_acc`
//! (`σ_acc gap² / 2` and `σ_acc gap`). The continuation is a mixture of the two:
//!
//! `L = π N(d; var_cv) N(dv; varv_cv) + (1 − π) N(d; var_cv + var_acc) N(dv; varv_cv + varv_acc)`
//!
//! with `π` the share of continuations that kept their velocity (quality.sql measures it per
//! camera and class on the unambiguous candidates of road users standing at both ends, and uses
//! the mixture only for those, where it has at least 10 of them; π → 0 is the acceleration model
//! alone). Why a mixture: with the acceleration model alone, a person who stood still in a
//! waiting group and reappeared where they stood had a predicted position spread of metres after
//! a 2–3 s gap, so a neighbour 0.6 m away was almost as likely and the ratio test refused the
//! link; under the mixture the standing person's constant-velocity density decides
//! (docs/association.md has the figures).
//!
//! `ll_bg` compares the position alone against an unrelated start at that place: the mixture's
//! position density minus `ln λ`, λ the density of starts (per m², over the gate's time window).
//!
//! O(1).

use std::fmt;

/// The candidate gate: chi-square with 4 degrees of freedom at 0.99 (position and velocity, two
/// axes each). A pair whose `z2` (acceleration model) exceeds it is not a candidate.
pub const GATE_Z2: f64 = 13.276704135987622;

/// A link is taken only when it is this many times likelier than every other candidate of its
/// end and of its start (the ratio test: one wrong link in 100 when two road users could both
/// have made the gap); a link taken on this camera's evidence alone ('broken') must also be this
/// many times likelier than an unrelated start.
pub const LINK_RATIO: f64 = 100.0;

/// A track end "stands" when its velocity is within its fit's noise of 0: `|v|² ≤ STANDING_Z2 ·
/// var_v` (chi-square with 2 degrees of freedom at 0.99, `2 ln 100`). quality.sql scores the
/// mixture only for candidates standing at both ends ([`standing`]).
pub const STANDING_Z2: f64 = 9.210340371976184;

/// Whether a track end with velocity² `v2` (m²/s²) and per-axis velocity variance `var_v` (its
/// fit's noise, m²/s²) stands ([`STANDING_Z2`]). False for a NaN, an infinity or a variance ≤ 0.
pub fn standing(v2: f64, var_v: f64) -> bool {
    v2.is_finite() && var_v.is_finite() && var_v > 0.0 && v2 <= STANDING_Z2 * var_v
}

/// The kind of a taken link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkKind {
    /// Taken on this camera's evidence alone: within the constant-velocity gate, and [`LINK_RATIO`]
    /// times likelier than an unrelated start about that place.
    Broken,
    /// Taken, but only by the acceleration allowance or with a weaker background test: another
    /// camera or the merge must confirm it (quality.sql).
    Reach,
}

impl LinkKind {
    pub fn as_str(self) -> &'static str {
        match self {
            LinkKind::Broken => "broken",
            LinkKind::Reach => "reach",
        }
    }
}

/// The link decision for a candidate that is the mutual best of its end and its start (the SQL
/// finds that: a join): with its evidence (`z2_cv`, `ll`, `ll_bg` of [`evidence`]) and the best
/// other candidates' `ll` of its end and of its start (−∞ when there is none), the ratio test
/// (`ll − ll_next ≥ ln LINK_RATIO` for both), and no link when it is less likely than an unrelated
/// start (`ll_bg < 0`); then [`LinkKind::Broken`] or [`LinkKind::Reach`]. A NaN anywhere is no link.
///
/// A negative `z2_cv` (a chi-square statistic) is an error.
pub fn link_kind(z2_cv: f64, ll: f64, ll_bg: f64, ll_next_end: f64, ll_next_start: f64) -> Result<Option<LinkKind>, BreakError> {
    if z2_cv < 0.0 {
        return Err(BreakError::Chi2(z2_cv));
    }
    if [z2_cv, ll, ll_bg, ll_next_end, ll_next_start].iter().any(|v| v.is_nan()) {
        return Ok(None);
    }
    let margin = LINK_RATIO.ln();
    let beats = |next: f64| next == f64::NEG_INFINITY || ll - next >= margin;
    if !(beats(ll_next_end) && beats(ll_next_start) && ll_bg >= 0.0) {
        return Ok(None);
    }
    Ok(Some(if z2_cv <= GATE_Z2 && ll_bg >= margin { LinkKind::Broken } else { LinkKind::Reach }))
}

/// Whether a pair is a candidate: its `z2` (acceleration model) within [`GATE_Z2`].
pub fn candidate(z2: f64) -> bool {
    z2 <= GATE_Z2
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BreakError {
    /// A variance (name, value) is not > 0 (var_acc, varv_acc: >= 0) and finite, or two add to infinity.
    Variance(&'static str, f64),
    /// pi is not in [0, 1).
    Pi(f64),
    /// A difference (name, value) is not finite.
    Difference(&'static str, f64),
    /// The start density is not > 0 and finite.
    Density(f64),
    /// A chi-square statistic (z2_cv) is negative.
    Chi2(f64),
}

impl fmt::Display for BreakError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BreakError::Variance(n, v) => write!(
                f,
                "{n} must be {} and finite (m² or m²/s², with its constant-velocity part a finite sum), got {v}",
                if n.ends_with("_acc") { ">= 0" } else { "> 0" }
            ),
            BreakError::Pi(v) => write!(f, "pi must be in [0, 1) (the share of continuations at constant velocity; 0: the acceleration model alone), got {v}"),
            BreakError::Difference(n, v) => write!(f, "{n} must be finite, got {v}"),
            BreakError::Chi2(v) => write!(f, "z2_cv must be >= 0 (a chi-square statistic, break_evidence's z2_cv), got {v:e}"),
            BreakError::Density(v) => write!(f, "start_density must be > 0 and finite (starts per m² in the gap's window), got {v}"),
        }
    }
}
impl std::error::Error for BreakError {}

/// The variances of one (end, start) pair, validated once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BreakModel {
    pub var_cv: f64,
    pub var_acc: f64,
    pub varv_cv: f64,
    pub varv_acc: f64,
    pub pi: f64,
}

impl BreakModel {
    pub fn new(var_cv: f64, var_acc: f64, varv_cv: f64, varv_acc: f64, pi: f64) -> Result<Self, BreakError> {
        for (n, v, zero_ok) in [("var_cv", var_cv, false), ("var_acc", var_acc, true), ("varv_cv", varv_cv, false), ("varv_acc", varv_acc, true)] {
            if !(v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0))) {
                return Err(BreakError::Variance(n, v));
            }
        }
        if !(pi >= 0.0 && pi < 1.0) {
            return Err(BreakError::Pi(pi));
        }
        if !(var_cv + var_acc).is_finite() {
            return Err(BreakError::Variance("var_acc", var_acc));
        }
        if !(varv_cv + varv_acc).is_finite() {
            return Err(BreakError::Variance("varv_acc", varv_acc));
        }
        Ok(BreakModel { var_cv, var_acc, varv_cv, varv_acc, pi })
    }
}

/// What [`evidence`] returns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evidence {
    /// `|d|²/var_cv + |dv|²/varv_cv`: chi2(4) for a continuation at constant velocity.
    pub z2_cv: f64,
    /// The same with the acceleration allowance: the candidate gate ([`GATE_Z2`]).
    pub z2: f64,
    /// ln L, the mixture's log-density (the constant −2 ln 2π left out): ranks the candidates.
    pub ll: f64,
    /// ln of the mixture's position density over the density of unrelated starts.
    pub ll_bg: f64,
}

/// ln(e^a + e^b) without overflow.
fn log_add(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + ((a - m).exp() + (b - m).exp()).ln()
}

/// The evidence of one (end, start) pair: `d2 = |d|²` (m²), `dv2 = |dv|²` (m²/s²), the model, and
/// the density of unrelated starts `start_density` (per m², over the gate's time window).
pub fn evidence(d2: f64, dv2: f64, m: &BreakModel, start_density: f64) -> Result<Evidence, BreakError> {
    if !(start_density > 0.0 && start_density.is_finite()) {
        return Err(BreakError::Density(start_density));
    }
    if !d2.is_finite() {
        return Err(BreakError::Difference("position difference (dx, dy)", d2));
    }
    if !dv2.is_finite() {
        return Err(BreakError::Difference("velocity difference (dvx, dvy)", dv2));
    }
    let (vp, vv) = (m.var_cv + m.var_acc, m.varv_cv + m.varv_acc);
    let z2_cv = d2 / m.var_cv + dv2 / m.varv_cv;
    let z2 = d2 / vp + dv2 / vv;
    // 2-D Gaussians: ln N(d; v I) = −|d|²/(2v) − ln(2π v)
    let l_cv = -z2_cv / 2.0 - m.var_cv.ln() - m.varv_cv.ln();
    let l_acc = -z2 / 2.0 - vp.ln() - vv.ln();
    let ll = log_add(m.pi.ln() + l_cv, (1.0 - m.pi).ln() + l_acc);
    let two_pi = 2.0 * std::f64::consts::PI;
    let lp_cv = -d2 / m.var_cv / 2.0 - (two_pi * m.var_cv).ln();
    let lp_acc = -d2 / vp / 2.0 - (two_pi * vp).ln();
    let ll_bg = log_add(m.pi.ln() + lp_cv, (1.0 - m.pi).ln() + lp_acc) - start_density.ln();
    Ok(Evidence { z2_cv, z2, ll, ll_bg })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(pi: f64) -> BreakModel {
        // a 10 Hz pedestrian track at sigma 0.1 m, a 2 s gap, accel p95 1 m/s²
        let sa2 = (1.0f64 / 2.45).powi(2);
        BreakModel::new(0.01, sa2 * (2.0f64 * 2.0 / 2.0).powi(2), 0.05, sa2 * 4.0, pi).unwrap()
    }

    /// The slow, obviously right version: the mixture density written out and integrated
    /// nowhere, just evaluated.
    fn slow_ll(d2: f64, dv2: f64, m: &BreakModel) -> f64 {
        let g = |x2: f64, v: f64| (-x2 / (2.0 * v)).exp() / v; // 2-D Gaussian times 2π
        (m.pi * g(d2, m.var_cv) * g(dv2, m.varv_cv) + (1.0 - m.pi) * g(d2, m.var_cv + m.var_acc) * g(dv2, m.varv_cv + m.varv_acc)).ln()
    }

    #[test]
    fn the_mixture_matches_its_definition() {
        let m = model(0.4);
        for (d2, dv2) in [(0.0, 0.0), (0.01, 0.02), (0.5, 0.1), (2.0, 1.0)] {
            let e = evidence(d2, dv2, &m, 1e-3).unwrap();
            assert!((e.ll - slow_ll(d2, dv2, &m)).abs() < 1e-9, "{d2} {dv2}: {} vs {}", e.ll, slow_ll(d2, dv2, &m));
        }
        // far in the tail the log-sum stays finite where the slow version underflows
        assert!(evidence(1e4, 1e4, &m, 1e-3).unwrap().ll.is_finite());
    }

    #[test]
    fn a_standing_person_is_told_from_a_neighbour_0_6_m_away() {
        // the true continuation reappears where it stood (d ~ noise), the neighbour 0.6 m off
        let m = model(0.5);
        let own = evidence(0.01, 0.01, &m, 1e-3).unwrap();
        let nb = evidence(0.36, 0.01, &m, 1e-3).unwrap();
        assert!(own.ll - nb.ll >= LINK_RATIO.ln(), "{} vs {}", own.ll, nb.ll);
        // the acceleration model alone could not: its variance is metres wide
        let acc = BreakModel { pi: 0.0, ..m };
        let (a, b) = (evidence(0.01, 0.01, &acc, 1e-3).unwrap(), evidence(0.36, 0.01, &acc, 1e-3).unwrap());
        assert!(a.ll - b.ll < LINK_RATIO.ln());
    }

    #[test]
    fn a_dense_place_weakens_the_background_test() {
        let m = model(0.5);
        let sparse = evidence(0.04, 0.0, &m, 1e-4).unwrap();
        let dense = evidence(0.04, 0.0, &m, 1e-1).unwrap();
        assert!((sparse.ll_bg - dense.ll_bg - 1e3f64.ln()).abs() < 1e-9);
    }

    #[test]
    fn the_link_decision_is_the_ratio_test_then_the_background_test() {
        let m = LINK_RATIO.ln();
        // no competitor, background passed, constant velocity: broken
        assert_eq!(link_kind(1.0, 0.0, m, f64::NEG_INFINITY, f64::NEG_INFINITY).unwrap(), Some(LinkKind::Broken));
        // a competitor within the ratio of the end or of the start: no link
        assert_eq!(link_kind(1.0, 0.0, m, -m + 0.01, f64::NEG_INFINITY).unwrap(), None);
        assert_eq!(link_kind(1.0, 0.0, m, f64::NEG_INFINITY, -m + 0.01).unwrap(), None);
        assert_eq!(link_kind(1.0, 0.0, m, -m, -m).unwrap(), Some(LinkKind::Broken));
        // beyond the constant-velocity gate, or a weaker background: reach
        assert_eq!(link_kind(GATE_Z2 + 0.1, 0.0, m, f64::NEG_INFINITY, f64::NEG_INFINITY).unwrap(), Some(LinkKind::Reach));
        assert_eq!(link_kind(1.0, 0.0, m - 0.1, f64::NEG_INFINITY, f64::NEG_INFINITY).unwrap(), Some(LinkKind::Reach));
        // less likely than an unrelated start: no link
        assert_eq!(link_kind(1.0, 0.0, -0.1, f64::NEG_INFINITY, f64::NEG_INFINITY).unwrap(), None);
        assert_eq!(link_kind(1.0, f64::NAN, m, f64::NEG_INFINITY, f64::NEG_INFINITY).unwrap(), None);
        assert_eq!(link_kind(-5.0, 0.0, m, f64::NEG_INFINITY, f64::NEG_INFINITY), Err(BreakError::Chi2(-5.0)));
    }

    #[test]
    fn standing_is_within_the_fits_noise_of_zero() {
        assert!(standing(0.0, 0.01) && standing(0.092, 0.01) && !standing(0.093, 0.01));
        assert!(!standing(0.0, 0.0) && !standing(f64::NAN, 1.0) && !standing(f64::INFINITY, f64::INFINITY));
        assert!((STANDING_Z2 - 2.0 * 100f64.ln()).abs() < 1e-12);
        assert!(candidate(GATE_Z2) && !candidate(GATE_Z2 + 1e-9));
    }

    #[test]
    fn bad_parameters_are_named() {
        assert_eq!(BreakModel::new(0.0, 0.0, 1.0, 0.0, 0.5), Err(BreakError::Variance("var_cv", 0.0)));
        assert_eq!(BreakModel::new(1.0, -1.0, 1.0, 0.0, 0.5), Err(BreakError::Variance("var_acc", -1.0)));
        assert_eq!(BreakModel::new(1.0, 0.0, 1.0, 0.0, 1.0), Err(BreakError::Pi(1.0)));
        assert!(BreakModel::new(1e308, 1e308, 1.0, 0.0, 0.5).is_err());
        assert!(evidence(f64::NAN, 0.0, &model(0.5), 1e-3).is_err());
        assert!(BreakModel::new(1.0, 0.0, 1.0, 0.0, f64::NAN).is_err());
        assert_eq!(evidence(0.0, 0.0, &model(0.5), 0.0), Err(BreakError::Density(0.0)));
        assert!(BreakError::Pi(2.0).to_string().contains("pi must be in [0, 1)"));
        assert!(BreakError::Variance("var_acc", -1.0).to_string().contains("var_acc must be >= 0"));
    }

    #[test]
    fn pi_0_is_the_acceleration_model_alone() {
        let m = BreakModel { pi: 0.0, ..model(0.5) };
        let e = evidence(0.09, 0.02, &m, 1e-3).unwrap();
        let l_acc = -e.z2 / 2.0 - (m.var_cv + m.var_acc).ln() - (m.varv_cv + m.varv_acc).ln();
        assert!((e.ll - l_acc).abs() < 1e-12);
    }

    #[test]
    fn z2_is_the_gate_statistic() {
        let m = BreakModel::new(1.0, 1.0, 1.0, 1.0, 0.5).unwrap();
        let e = evidence(2.0, 4.0, &m, 1.0).unwrap();
        assert_eq!(e.z2_cv, 6.0);
        assert_eq!(e.z2, 3.0);
    }
}
