//! The bias state of a class that has too few unambiguous matches of its own, from the states of
//! the camera pair's other classes (issue 38; docs/association.md, "A class without anchors").
//!
//! Each class of road user has its own mean offset between two cameras' views (a camera that
//! sees every car from behind on a one-way road offsets the cars by a metre and the pedestrians
//! by nothing), so the anchors of every class pooled are a mixture, and the robust state of the
//! mixture is its largest mode: on a simulated scene where camera 1 saw every car 1 m off, the
//! three heavy vehicles (too few for a state) took the cars' state and none was matched.
//!
//! Here the unknown class's offsets are drawn from the distribution of the classes' states
//! (a hierarchical model): the mean of the `C` class means, and the covariance
//! `Σ = mean_c Σ_c + S_μ`, `S_μ` the sample covariance of the class means (divisor `C − 1`):
//! where the classes agree (a drone's view) this is their common state, where they differ it is
//! as wide as their differences. `n` is the classes' anchors together (the gate of
//! [`BiasState::gate`] then tends to `χ²₂`; the width is in `Σ`). `None` with fewer than 2
//! states (one class's state says nothing of how classes differ; the caller falls back).
//!
//! Complexity: O(C).

use super::bias::{BiasState, MIN_BIAS_VAR_M2};

/// See the module docs. Non-finite states are skipped.
pub fn bias_state_between(states: &[BiasState]) -> Option<BiasState> {
    let ok: Vec<&BiasState> = states.iter().filter(|s| [s.mx, s.my, s.sxx, s.sxy, s.syy].iter().all(|v| v.is_finite())).collect();
    if ok.len() < 2 {
        return None;
    }
    let c = ok.len() as f64;
    let mx = ok.iter().map(|s| s.mx).sum::<f64>() / c;
    let my = ok.iter().map(|s| s.my).sum::<f64>() / c;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for s in &ok {
        sxx += s.sxx / c + (s.mx - mx).powi(2) / (c - 1.0);
        sxy += s.sxy / c + (s.mx - mx) * (s.my - my) / (c - 1.0);
        syy += s.syy / c + (s.my - my).powi(2) / (c - 1.0);
    }
    let (sxx, syy) = (sxx.max(MIN_BIAS_VAR_M2), syy.max(MIN_BIAS_VAR_M2));
    let lim = 0.999 * (sxx * syy).sqrt();
    Some(BiasState { mx, my, sxx, sxy: sxy.clamp(-lim, lim), syy, n: ok.iter().map(|s| s.n).sum() })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn st(mx: f64, my: f64, v: f64, n: usize) -> BiasState {
        BiasState { mx, my, sxx: v, sxy: 0.0, syy: v, n }
    }

    #[test]
    fn classes_that_differ_widen_the_state_to_cover_them() {
        // cars 1 m off (every car seen from behind), pedestrians and cyclists at 0
        let s = bias_state_between(&[st(1.0, 0.0, 0.01, 40), st(0.0, 0.0, 0.01, 15), st(0.0, 0.0, 0.01, 6)]).unwrap();
        assert!((s.mx - 1.0 / 3.0).abs() < 1e-12 && s.my == 0.0 && s.n == 61, "{s:?}");
        // every class's mean is within the gate, so a class without anchors near any passes
        for m in [0.0, 1.0] {
            assert!(s.d2(m, 0.0, 0.0) < s.gate(), "{m} {s:?}");
        }
        // a neighbour 3 m away does not
        assert!(s.d2(3.0, 0.0, 0.0) > s.gate(), "{s:?}");
    }

    #[test]
    fn classes_that_agree_give_their_common_state() {
        let s = bias_state_between(&[st(0.2, 0.1, 0.04, 10), st(0.2, 0.1, 0.04, 10)]).unwrap();
        assert!((s.mx - 0.2).abs() < 1e-12 && (s.sxx - 0.04).abs() < 1e-12 && s.sxy == 0.0, "{s:?}");
    }

    #[test]
    fn fewer_than_two_states_give_none() {
        assert_eq!(bias_state_between(&[]), None);
        assert_eq!(bias_state_between(&[st(0.0, 0.0, 0.01, 5)]), None);
        assert_eq!(bias_state_between(&[st(0.0, 0.0, 0.01, 5), st(f64::NAN, 0.0, 0.01, 5)]), None);
    }
}
