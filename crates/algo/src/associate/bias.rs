//! A camera pair's bias state for one class: the distribution of the constant offsets `b`
//! between its two cameras' views of one road user (issue 38), estimated from the offsets of
//! its unambiguous matches.
//!
//! Model: `b_i ~ N(μ, Σ + se_i² I)`, `se_i²` the measurement variance of pair i's mean offset
//! (`σ_d² / n_eff` per axis, [`super::pair`]). A few anchors may be wrong (neighbours), so the
//! estimate is robust: start at the coordinate-wise median with the MAD as scale, then
//! concentration steps: keep the offsets within `χ²₂(0.99)` of the current estimate, take their
//! mean and covariance, and correct the covariance for the truncation (a Gaussian cut at
//! `d² ≤ q` keeps the share `F₂(q)` of its mass and shrinks its covariance by
//! `F₄(q) / F₂(q)`, `F_k` the chi-square CDF; Croux & Haesbroeck 1999). The covariance
//! estimated so contains the measurement spread; the mean of `se_i²` is taken out of its
//! diagonal (at least [`MIN_BIAS_VAR_M2`] stays), so that [`BiasState::d2`] can add each
//! candidate's own `se²` back.
//!
//! Fewer than [`MIN_ANCHORS`] offsets: no state (`None`); the caller falls back (merge.sql:
//! the camera pair's anchors of every class, then "no bias": `Σ = σ_d² I`, the tolerance the
//! association had before issue 38).
//!
//! Complexity: O(n log n) (the medians) + O(n) per concentration step, at most
//! [`MAX_STEPS`] steps.

/// Fewest anchors for a bias state: five offsets pin a 2-D mean and covariance only roughly,
/// and the fallback (all classes of the camera pair) is broader, not wronger.
pub const MIN_ANCHORS: usize = 5;
/// The concentration steps keep the offsets within this squared Mahalanobis distance
/// (`χ²₂(0.99)`).
pub const TRIM_D2: f64 = 9.210340371976182;
/// At most this many concentration steps (they usually settle in 3-5).
pub const MAX_STEPS: usize = 20;
/// The least variance per axis a bias state keeps (m²: 1 cm²), so that a noise-free
/// recording (simulated exact points) still has an invertible covariance.
pub const MIN_BIAS_VAR_M2: f64 = 1e-4;

/// One anchor: its mean offset (m) and that mean's measurement variance per axis (m²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Offset {
    pub dx: f64,
    pub dy: f64,
    pub se2: f64,
}

/// Mean and covariance of the offsets of one camera pair (and class); `n` anchors kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasState {
    pub mx: f64,
    pub my: f64,
    pub sxx: f64,
    pub sxy: f64,
    pub syy: f64,
    pub n: usize,
}

impl BiasState {
    /// "No bias": mean 0 and `σ_d² I` (the tolerance of a constant offset before issue 38).
    pub fn none(sigma_d: f64) -> BiasState {
        let v = (sigma_d * sigma_d).max(MIN_BIAS_VAR_M2);
        BiasState { mx: 0.0, my: 0.0, sxx: v, sxy: 0.0, syy: v, n: 0 }
    }

    /// Squared Mahalanobis distance of offset `(dx, dy)`, measured with variance `se2` per
    /// axis, from this state: `(b − μ)ᵀ (Σ + se2 I)⁻¹ (b − μ)`. `χ²₂` for a true pair.
    pub fn d2(&self, dx: f64, dy: f64, se2: f64) -> f64 {
        let se2 = if se2.is_finite() && se2 > 0.0 { se2 } else { 0.0 };
        let (a, b, d) = (self.sxx + se2, self.sxy, self.syy + se2);
        let det = a * d - b * b;
        let (ex, ey) = (dx - self.mx, dy - self.my);
        if !(det > 0.0) || !det.is_finite() {
            return f64::INFINITY;
        }
        (d * ex * ex - 2.0 * b * ex * ey + a * ey * ey) / det
    }

    /// The 0.999 gate of [`d2`](Self::d2) for a new pair under this state. For [`none`](Self::none)
    /// (`n = 0`, Σ given, not estimated) `χ²₂(0.999)` ([`super::BIAS_GATE_D2`]). For a state
    /// estimated from `n` anchors the mean and Σ are themselves uncertain, and a new offset's
    /// distance follows the predictive Hotelling law:
    /// `d² · n/(n+1) ~ T²(2, n−1) = 2(n−1)/(n−2) · F(2, n−2)`, with `F(2, ν)` at q in closed form,
    /// `(ν/2)((1−q)^(−2/ν) − 1)`. So the gate is `(n+1)/n · 2(n−1)/(n−2) · F(2, n−2; 0.999)`:
    /// 70.9 for 8 anchors, 17.0 for 100, → 13.8. With the χ² gate, 8 pedestrian anchors whose
    /// offsets spread 1.3 cm refused two true pairs 0.16 m from their mean (d² 23 and 50;
    /// `trajdb simulate --viewpoint-bias 0.5,0.1`, seed 1). Fewer than 3 anchors: no gate
    /// (infinite).
    pub fn gate(&self) -> f64 {
        if self.n == 0 {
            return super::BIAS_GATE_D2;
        }
        if self.n < 3 {
            return f64::INFINITY;
        }
        let n = self.n as f64;
        let nu = n - 2.0;
        let f = nu / 2.0 * ((1.0 - GATE_Q).powf(-2.0 / nu) - 1.0);
        (n + 1.0) / n * 2.0 * (n - 1.0) / nu * f
    }

    /// The 0.999 bound of `|b|` under this state (m): how far the search for candidates
    /// must reach, `|μ| + sqrt(gate · λ_max)`.
    pub fn reach(&self) -> f64 {
        let tr = self.sxx + self.syy;
        let det = self.sxx * self.syy - self.sxy * self.sxy;
        let lmax = tr / 2.0 + ((tr * tr / 4.0 - det).max(0.0)).sqrt();
        self.mx.hypot(self.my) + (self.gate() * lmax).sqrt()
    }
}

/// The level of [`BiasState::gate`] (one wrong refusal in a thousand true pairs).
pub const GATE_Q: f64 = 0.999;

use crate::stats::median;

/// Chi-square CDF with 2 and 4 degrees of freedom.
fn f2(q: f64) -> f64 {
    1.0 - (-q / 2.0).exp()
}
fn f4(q: f64) -> f64 {
    1.0 - (-q / 2.0).exp() * (1.0 + q / 2.0)
}

/// The bias state of `offsets` (see the module docs); `None` with fewer than [`MIN_ANCHORS`]
/// finite offsets.
pub fn bias_state(offsets: &[Offset]) -> Option<BiasState> {
    let pts: Vec<Offset> = offsets.iter().copied().filter(|o| o.dx.is_finite() && o.dy.is_finite() && o.se2.is_finite() && o.se2 >= 0.0).collect();
    if pts.len() < MIN_ANCHORS {
        return None;
    }
    // start: coordinate-wise median, MAD scale (1.4826 MAD is sigma for a Gaussian)
    let mut xs: Vec<f64> = pts.iter().map(|o| o.dx).collect();
    let mut ys: Vec<f64> = pts.iter().map(|o| o.dy).collect();
    let (mx, my) = (median(&mut xs), median(&mut ys));
    let mut ax: Vec<f64> = pts.iter().map(|o| (o.dx - mx).abs()).collect();
    let mut ay: Vec<f64> = pts.iter().map(|o| (o.dy - my).abs()).collect();
    let floor = MIN_BIAS_VAR_M2;
    let (vx, vy) = ((1.4826 * median(&mut ax)).powi(2).max(floor), (1.4826 * median(&mut ay)).powi(2).max(floor));
    let mut s = BiasState { mx, my, sxx: vx, sxy: 0.0, syy: vy, n: pts.len() };
    let shrink = f2(TRIM_D2) / f4(TRIM_D2);
    let mut kept_prev = usize::MAX;
    for _ in 0..MAX_STEPS {
        let kept: Vec<&Offset> = pts.iter().filter(|o| s.d2(o.dx, o.dy, 0.0) <= TRIM_D2).collect();
        if kept.len() < MIN_ANCHORS {
            break;
        }
        let n = kept.len() as f64;
        let mx = kept.iter().map(|o| o.dx).sum::<f64>() / n;
        let my = kept.iter().map(|o| o.dy).sum::<f64>() / n;
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for o in &kept {
            sxx += (o.dx - mx) * (o.dx - mx);
            sxy += (o.dx - mx) * (o.dy - my);
            syy += (o.dy - my) * (o.dy - my);
        }
        let k = shrink / (n - 1.0).max(1.0);
        let next = BiasState { mx, my, sxx: (sxx * k).max(floor), sxy: sxy * k, syy: (syy * k).max(floor), n: kept.len() };
        let done = kept.len() == kept_prev && (next.mx - s.mx).abs() < 1e-9 && (next.my - s.my).abs() < 1e-9;
        kept_prev = kept.len();
        s = next;
        if done {
            break;
        }
    }
    // the measurement spread out of the diagonal: the mean se² of the kept anchors
    let kept: Vec<&Offset> = pts.iter().filter(|o| s.d2(o.dx, o.dy, 0.0) <= TRIM_D2).collect();
    let se2 = if kept.is_empty() { 0.0 } else { kept.iter().map(|o| o.se2).sum::<f64>() / kept.len() as f64 };
    let (sxx, syy) = ((s.sxx - se2).max(floor), (s.syy - se2).max(floor));
    // keep the correlation a covariance can carry
    let lim = 0.999 * (sxx * syy).sqrt();
    Some(BiasState { sxx, syy, sxy: s.sxy.clamp(-lim, lim), ..s })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gauss(seed: &mut u64) -> f64 {
        // Box-Muller on a small LCG: deterministic, no dependency
        let mut u = || {
            *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (((*seed >> 11) as f64) + 0.5) / ((1u64 << 53) as f64)
        };
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }

    #[test]
    fn recovers_mean_and_covariance_despite_wrong_anchors() {
        let mut seed = 7u64;
        let mut v = Vec::new();
        for _ in 0..400 {
            let (g1, g2) = (gauss(&mut seed), gauss(&mut seed));
            // mean (0.8, -0.3), sd 0.3 and 0.1, correlation 0.5
            v.push(Offset { dx: 0.8 + 0.3 * g1, dy: -0.3 + 0.1 * (0.5 * g1 + 0.75f64.sqrt() * g2), se2: 0.0 });
        }
        // 10 % wrong anchors: neighbours 3 m away
        for k in 0..40 {
            v.push(Offset { dx: 3.5 + 0.01 * k as f64, dy: 2.0, se2: 0.0 });
        }
        let s = bias_state(&v).unwrap();
        assert!((s.mx - 0.8).abs() < 0.05 && (s.my + 0.3).abs() < 0.03, "{s:?}");
        assert!((s.sxx.sqrt() - 0.3).abs() < 0.04 && (s.syy.sqrt() - 0.1).abs() < 0.015, "{s:?}");
        assert!((s.sxy / (s.sxx * s.syy).sqrt() - 0.5).abs() < 0.12, "{s:?}");
        assert!(s.n < 420);
        // a true offset passes, a neighbour's does not
        assert!(s.d2(0.9, -0.25, 0.0) < super::super::BIAS_GATE_D2);
        assert!(s.d2(3.5, 2.0, 0.0) > 100.0);
    }

    #[test]
    fn measurement_spread_is_taken_out_and_added_back() {
        let mut seed = 3u64;
        // no true spread: every offset is 0.5 m in x, measured with se 0.1 m
        let v: Vec<Offset> = (0..500).map(|_| Offset { dx: 0.5 + 0.1 * gauss(&mut seed), dy: 0.1 * gauss(&mut seed), se2: 0.01 }).collect();
        let s = bias_state(&v).unwrap();
        assert!(s.sxx < 0.002 && s.syy < 0.002, "{s:?}");
        // the d2 of an offset measured that well is chi2(2): mean about 2
        let m: f64 = v.iter().map(|o| s.d2(o.dx, o.dy, o.se2)).sum::<f64>() / v.len() as f64;
        assert!((m - 2.0).abs() < 0.3, "{m}");
    }

    #[test]
    fn too_few_or_degenerate_anchors() {
        let o = Offset { dx: 1.0, dy: 1.0, se2: 0.0 };
        assert_eq!(bias_state(&[o; 4]), None);
        assert_eq!(bias_state(&[Offset { dx: f64::NAN, ..o }; 9]), None);
        // identical offsets: the variance floor keeps it invertible
        let s = bias_state(&[o; 9]).unwrap();
        assert_eq!((s.mx, s.my, s.sxx, s.syy), (1.0, 1.0, MIN_BIAS_VAR_M2, MIN_BIAS_VAR_M2));
        assert!(s.d2(1.0, 1.0, 0.0) == 0.0 && s.d2(1.5, 1.0, 0.0) > 100.0);
        let none = BiasState::none(0.2);
        assert!((none.d2(0.2, 0.0, 0.0) - 1.0).abs() < 1e-12);
        assert!((none.reach() - (BIAS_GATE_D2_TEST * 0.04f64).sqrt()).abs() < 1e-9);
    }
    const BIAS_GATE_D2_TEST: f64 = super::super::BIAS_GATE_D2;

    #[test]
    fn the_gate_widens_for_few_anchors_and_tends_to_chi2() {
        let st = |n| BiasState { mx: 0.0, my: 0.0, sxx: 1e-2, sxy: 0.0, syy: 1e-2, n };
        assert_eq!(BiasState::none(0.1).gate(), BIAS_GATE_D2_TEST);
        // n = 8: F(2, 6; 0.999) = 3 (0.001^(-1/3) - 1) = 27; 9/8 * 14/6 * 27 = 70.875
        assert!((st(8).gate() - 70.875).abs() < 1e-9, "{}", st(8).gate());
        assert!(st(2).gate().is_infinite());
        assert!((st(1_000_000).gate() - BIAS_GATE_D2_TEST).abs() < 1e-3);
        let mut prev = f64::INFINITY;
        for n in 3..500 {
            let g = st(n).gate();
            assert!(g < prev && g > BIAS_GATE_D2_TEST);
            prev = g;
        }
    }

}
