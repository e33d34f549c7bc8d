//! A road user that never moved (issue 39; docs/analysis.md, "Stationary road users").
//!
//! Parked cars are tracked all day: on the DUT intersection 18 car road users (15 in the truth)
//! never leave a spot of 0.2 m, and their speeds pulled the cars' 15th-percentile speed to
//! 0.3 km/h. A speed study leaves them out; a count keeps them, marked.
//!
//! **The rule** ([`stationary`]): the path's extent (the diagonal of its bounding box) is under
//! the class's length ([`Kind::still_extent_m`]: it never left a spot of its own size; a pedestrian's
//! for a class that says nothing, such as `unknown`) and that extent
//! over its duration is under [`STILL_SPEED_MS`] (so a 0.5 s fragment of a walking pedestrian,
//! 0.7 m in 0.5 s, is not stationary, while a pedestrian waiting at the kerb for the whole track
//! is). Measured on the DUT intersection: the parked cars' extents are 0.1-0.2 m (one 0.9 m), the
//! next car's 7.6 m.
//!
//! # Complexity
//! O(n) for n points.

use crate::associate::Kind;
use crate::traj::Traj;

/// Below this extent per second (m/s) a road user did not travel: a fifth of the slowest
/// pedestrians' walking speed (about 0.5 m/s for the old and impaired; HCM 2010's design value
/// 1.2 m/s) and under any vehicle's creep.
pub const STILL_SPEED_MS: f64 = 0.1;

/// The extent of a path: the diagonal of its bounding box (m); 0 for one point.
pub fn extent_m(tr: Traj<'_>) -> f64 {
    let fold = |v: &[f64]| v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &z| (l.min(z), h.max(z)));
    let ((x0, x1), (y0, y1)) = (fold(tr.x), fold(tr.y));
    if tr.len() == 0 {
        0.0
    } else {
        (x1 - x0).hypot(y1 - y0)
    }
}

/// Did a road user of `class` on path `tr` never move (module docs)? A path of one point, or of
/// no duration, is stationary when its extent is under the class's length.
pub fn stationary(tr: Traj<'_>, class: &str) -> bool {
    let e = extent_m(tr);
    if !(e < Kind::of(class).still_extent_m()) {
        return false;
    }
    let d = if tr.len() >= 2 { tr.t[tr.len() - 1] - tr.t[0] } else { 0.0 };
    d <= 0.0 || e / d < STILL_SPEED_MS
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traj::OwnedTraj;

    fn path(n: usize, dt: f64, v: f64, jitter: f64) -> OwnedTraj {
        let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let x: Vec<f64> = t.iter().enumerate().map(|(k, t)| v * t + if k % 2 == 0 { jitter } else { -jitter }).collect();
        OwnedTraj { y: vec![0.0; n], x, t }
    }

    #[test]
    fn parked_waiting_walking_and_a_fragment() {
        // a car parked for 10 minutes, 0.1 m of jitter
        assert!(stationary(path(6000, 0.1, 0.0, 0.05).view(), "car"));
        // a car creeping 4 m in a queue over a minute: 0.07 m/s, stationary
        assert!(stationary(path(600, 0.1, 4.0 / 60.0, 0.05).view(), "car"));
        // a car driving: not
        assert!(!stationary(path(100, 0.1, 10.0, 0.05).view(), "car"));
        // a pedestrian waiting 30 s at the kerb, swaying 0.2 m: stationary
        assert!(stationary(path(300, 0.1, 0.0, 0.1).view(), "pedestrian"));
        // half a second of a walking pedestrian (0.7 m): not (it moves at 1.4 m/s)
        assert!(!stationary(path(6, 0.1, 1.4, 0.0).view(), "pedestrian"));
        // a car's 0.7 m of jitter is under its length, but a pedestrian's 2 m walk is not
        assert!(!stationary(path(20, 0.1, 1.0, 0.0).view(), "pedestrian"));
        // one point: stationary
        assert!(stationary(path(1, 0.1, 0.0, 0.0).view(), "car"));
        assert_eq!(extent_m(path(0, 0.1, 0.0, 0.0).view()), 0.0);
        // a class that says nothing is sized as a pedestrian here: 2 m of swaying is not still
        assert!(!stationary(path(600, 0.1, 0.0, 1.0).view(), "unknown"));
        assert!(stationary(path(600, 0.1, 0.0, 1.0).view(), "car"));
    }
}
