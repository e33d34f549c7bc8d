//! Time-to-collision (TTC) at constant velocity (Hayward 1972, "Near-miss determination through
//! use of a scale of danger", HRR 384; SSAM's TTC, FHWA-HRT-08-051 §2; TrafficIntelligence's
//! `computeTTC` with constant-velocity motion prediction): at time s, extrapolate both road
//! users along their current velocities; TTC(s) is the first τ >= 0 at which their centres are
//! `radius` metres apart (radius = the sum of the two road users' radii):
//!
//! ```text
//! |Δp(s) + Δv(s) τ| = radius,  Δp = p_b - p_a,  Δv = v_b - v_a   (smallest root τ >= 0)
//! ```
//!
//! 0 while they are within `radius` of each other; undefined (no collision course) when the
//! relative motion never brings them that close. Returned: the minimum of TTC(s) over their
//! common period, the time s where it occurs, and the predicted collision point (the midpoint
//! of the two extrapolated centres at s + TTC).
//!
//! Both paths are piecewise linear, so on each interval between consecutive sample times of
//! either road user Δv is constant and TTC(s) = σ - (s - u) falls at slope -1 (σ: the root at
//! the interval's start u): the minimum over the interval is at its end (a left limit, exact,
//! not sampled), or 0 where the interval itself reaches the collision distance. Only the
//! samples inside the common period are read (binary searches for its ends):
//! O(log(n + m) + k), k the samples of both inside it (two sorted runs merged).

use super::{validate, ConflictError};
use crate::non_negative;
use crate::traj::Traj;

/// The smallest TTC over the common period: `ttc` (s) at time `t`, collision point `x`, `y`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ttc {
    pub ttc: f64,
    pub t: f64,
    pub x: f64,
    pub y: f64,
}

/// Position and velocity of `tr` on the interval (u, v): of the segment holding its midpoint.
/// `k` walks forward (both callers advance in time).
fn state(tr: Traj<'_>, k: &mut usize, u: f64, v: f64) -> ([f64; 2], [f64; 2]) {
    let m = 0.5 * (u + v);
    while *k + 2 < tr.len() && tr.t[*k + 1] <= m {
        *k += 1;
    }
    let j = *k;
    let dt = tr.t[j + 1] - tr.t[j];
    let vel = [(tr.x[j + 1] - tr.x[j]) / dt, (tr.y[j + 1] - tr.y[j]) / dt];
    ([tr.x[j] + vel[0] * (u - tr.t[j]), tr.y[j] + vel[1] * (u - tr.t[j])], vel)
}

/// The minimum TTC of `a` and `b` over their common period, or `None` when they share less
/// than an interval of time or are never on a collision course. Errors: a trajectory outside
/// the input policy, `radius` < 0 or not finite.
pub fn ttc(a: Traj<'_>, b: Traj<'_>, radius: f64) -> Result<Option<Ttc>, ConflictError> {
    validate(a, b)?;
    let r = non_negative("radius", radius)?;
    Ok(ttc_checked(a, b, r))
}

/// The sample times of `tr` strictly inside (lo, hi) (a slice: `t` is sorted), and the segment
/// index [`state`] starts from: the last `k` with `t[k + 1] <= lo` it would walk to from 0.
fn window(tr: Traj<'_>, lo: f64, hi: f64) -> (&[f64], usize) {
    let (p, q) = (tr.t.partition_point(|&t| t <= lo), tr.t.partition_point(|&t| t < hi));
    (&tr.t[p..q.max(p)], p.saturating_sub(1).min(tr.len() - 2))
}

/// [`ttc`] of trajectories already validated, `radius` already checked (>= 0, finite): what
/// [`super::conflicts`] calls per pair after validating each path once.
pub(crate) fn ttc_checked(a: Traj<'_>, b: Traj<'_>, r: f64) -> Option<Ttc> {
    if a.len() < 2 || b.len() < 2 {
        return None;
    }
    let (lo, hi) = (a.t[0].max(b.t[0]), a.t[a.len() - 1].min(b.t[b.len() - 1]));
    if !(hi > lo) {
        return None;
    }
    // every sample time of either inside the common period, in order, once (binary searches:
    // the points outside the common period are never read)
    let ((wa, mut ka), (wb, mut kb)) = (window(a, lo, hi), window(b, lo, hi));
    let mut times: Vec<f64> = Vec::with_capacity(wa.len() + wb.len() + 2);
    times.push(lo);
    if wa.iter().chain(wb).any(|&t| t == 0.0) {
        // -0.0 and 0.0: sorted by `<` is not sorted by total_cmp; sort as a whole (values equal
        // under total_cmp are the same bits, so the unstable sort gives the one order there is)
        times.extend_from_slice(wa);
        times.extend_from_slice(wb);
        times.sort_unstable_by(f64::total_cmp);
    } else {
        // both windows are sorted, all inside (lo, hi): merge them
        let (mut i, mut j) = (0, 0);
        while i < wa.len() && j < wb.len() {
            if wa[i].total_cmp(&wb[j]).is_le() {
                times.push(wa[i]);
                i += 1;
            } else {
                times.push(wb[j]);
                j += 1;
            }
        }
        times.extend_from_slice(&wa[i..]);
        times.extend_from_slice(&wb[j..]);
    }
    times.push(hi);
    times.dedup();
    let mut best: Option<Ttc> = None;
    for w in times.windows(2) {
        let (u, v) = (w[0], w[1]);
        let (pa, va) = state(a, &mut ka, u, v);
        let (pb, vb) = state(b, &mut kb, u, v);
        let (dx, dy, wx, wy) = (pb[0] - pa[0], pb[1] - pa[1], vb[0] - va[0], vb[1] - va[1]);
        // σ solves |Δp + Δv σ| = r, which scaling Δp, Δv and r together leaves alone: past 1e60
        // or below 1e-60 (coordinates of a broken frame, or a unit a billion times off) they are
        // scaled by a power of 2 (exact), so the squares below neither overflow to inf - inf =
        // NaN nor underflow to contact; the common case is untouched
        let m = dx.abs().max(dy.abs()).max(wx.abs()).max(wy.abs()).max(r);
        let (dx, dy, wx, wy, r) = if m.is_finite() && m > 0.0 && !(1e-60..=1e60).contains(&m) {
            // to [0.5, 1]: the squares and products below (up to the 4th power) neither overflow
            // nor underflow; in two factors, as 2^1074 or 2^-1074 alone is not a normal number
            let k = -(m.log2().ceil() as i32);
            let (f, g) = (pow2(k / 2), pow2(k - k / 2));
            (dx * f * g, dy * f * g, wx * f * g, wy * f * g, r * f * g)
        } else {
            (dx, dy, wx, wy, r)
        };
        let c = dx * dx + dy * dy - r * r;
        let at = |sigma: f64| ((pa[0] + va[0] * sigma + pb[0] + vb[0] * sigma) / 2.0, (pa[1] + va[1] * sigma + pb[1] + vb[1] * sigma) / 2.0);
        if c <= 0.0 {
            let (x, y) = at(0.0);
            return Some(Ttc { ttc: 0.0, t: u, x, y }); // in contact: TTC 0, the earliest time
        }
        let (qa, qb) = (wx * wx + wy * wy, 2.0 * (dx * wx + dy * wy));
        let disc = qb * qb - 4.0 * qa * c;
        if qb >= 0.0 || disc < 0.0 || qa == 0.0 {
            continue; // moving apart, or passing wide
        }
        // the smaller root, stable form: c / q with q = (-qb + sqrt(disc)) / 2
        let sigma = c / ((-qb + disc.sqrt()) / 2.0);
        let (x, y) = at(sigma);
        if sigma <= v - u {
            return Some(Ttc { ttc: 0.0, t: u + sigma, x, y }); // they reach the collision distance here
        }
        let cand = Ttc { ttc: sigma - (v - u), t: v, x, y };
        if best.is_none_or(|b| cand.ttc < b.ttc) {
            best = Some(cand);
        }
    }
    best
}

/// 2^k for |k| <= 1022 (a normal number, exact).
fn pow2(k: i32) -> f64 {
    f64::from_bits(((k.clamp(-1022, 1023) + 1023) as u64) << 52)
}

#[cfg(test)]
mod tests {
    /// A head-on pair along x: at t = 0 at -5k and 5k, at t = 1 at -4k and 4k.
    fn head_on(k: f64) -> (OwnedTraj, OwnedTraj) {
        (tr(&[(0.0, -5.0 * k, 0.0), (1.0, -4.0 * k, 0.0)]), tr(&[(0.0, 5.0 * k, 0.0), (1.0, 4.0 * k, 0.0)]))
    }

    #[test]
    fn the_kinematic_ttc_holds_at_every_scale() {
        // a head-on pair 10 apart closing at 2 per second, radius 2: TTC 3 at t = 1 (8 apart),
        // with positions, speeds and the radius scaled together by 1e-300 .. 1e300; and two
        // standing 9e307 apart are not in contact
        for e in [-300, -200, -170, -150, -100, -80, -60, -10, 0, 10, 60, 80, 100, 150, 200, 300] {
            let k = 10f64.powi(e);
            let (a, b) = head_on(k);
            let c = super::ttc(a.view(), b.view(), 2.0 * k).unwrap().unwrap();
            assert!((c.ttc - 3.0).abs() < 1e-9 && c.t == 1.0, "1e{e}: {c:?}");
        }
        // at 1e299 with a radius of 2 m: 8e299 apart at t = 1, closing at 2e299 per second: TTC 4
        let (a, b) = head_on(1e299);
        let c = super::ttc(a.view(), b.view(), 2.0).unwrap().unwrap();
        assert!((c.ttc - 4.0).abs() < 1e-9 && c.t == 1.0 && c.x.abs() < 1e-293, "{c:?}");
        let (a, b) = (tr(&[(0.0, -4.5e307, 0.0), (1.0, -4.5e307, 0.0)]), tr(&[(0.0, 4.5e307, 0.0), (1.0, 4.5e307, 0.0)]));
        assert_eq!(super::ttc(a.view(), b.view(), 2.0).unwrap(), None);
    }

    use super::*;
    use crate::traj::OwnedTraj;
    use proptest::prelude::*;

    fn tr(pts: &[(f64, f64, f64)]) -> OwnedTraj {
        let mut o = OwnedTraj::default();
        for &(t, x, y) in pts {
            o.push(t, x, y);
        }
        o
    }

    #[test]
    fn head_on_at_constant_speed_collides_at_the_kinematic_time() {
        // 100 m apart closing at 20 m/s, radius 2: contact at t = 4.9 at the origin
        let a = tr(&[(0.0, -50.0, 0.0), (10.0, 50.0, 0.0)]);
        let b = tr(&[(0.0, 50.0, 0.0), (10.0, -50.0, 0.0)]);
        let c = ttc(a.view(), b.view(), 2.0).unwrap().unwrap();
        assert!(c.ttc == 0.0 && (c.t - 4.9).abs() < 1e-12 && c.x.abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn both_stopping_gives_the_ttc_at_the_stop() {
        // as above, but both stop at t = 2 (30 m apart each side): TTC(s) = 4.9 - s, min 2.9 at t = 2
        let a = tr(&[(0.0, -50.0, 0.0), (1.0, -40.0, 0.0), (2.0, -30.0, 0.0), (5.0, -30.0, 0.0)]);
        let b = tr(&[(0.0, 50.0, 0.0), (0.5, 45.0, 0.0), (2.0, 30.0, 0.0), (5.0, 30.0, 0.0)]);
        let c = ttc(a.view(), b.view(), 2.0).unwrap().unwrap();
        assert!((c.ttc - 2.9).abs() < 1e-12 && (c.t - 2.0).abs() < 1e-12 && c.x.abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn passing_wide_diverging_and_disjoint_give_none() {
        let a = tr(&[(0.0, -50.0, 0.0), (10.0, 50.0, 0.0)]);
        let wide = tr(&[(0.0, 50.0, 3.0), (10.0, -50.0, 3.0)]);
        assert_eq!(ttc(a.view(), wide.view(), 2.0).unwrap(), None);
        let away = tr(&[(0.0, 60.0, 0.0), (10.0, 160.0, 0.0)]);
        assert_eq!(ttc(a.view(), away.view(), 2.0).unwrap(), None);
        let later = tr(&[(11.0, 0.0, 0.0), (12.0, 1.0, 0.0)]);
        assert_eq!(ttc(a.view(), later.view(), 2.0).unwrap(), None);
        assert_eq!(ttc(a.view(), OwnedTraj::default().view(), 2.0).unwrap(), None);
        // a radius above the 3 m offset makes the wide pass a contact
        let c = ttc(a.view(), wide.view(), 3.5).unwrap().unwrap();
        assert_eq!(c.ttc, 0.0);
    }

    #[test]
    fn a_rear_end_approach_has_gap_over_speed_difference() {
        // a follows b: a at 15 m/s, b at 10 m/s, 30 m ahead; radius 5 (two car lengths' halves)
        let a = tr(&[(0.0, 0.0, 0.0), (1.0, 15.0, 0.0)]);
        let b = tr(&[(0.0, 30.0, 0.0), (1.0, 40.0, 0.0)]);
        let c = ttc(a.view(), b.view(), 5.0).unwrap().unwrap();
        // at t = 1 the gap is 25 m closing at 5 m/s: (25 - 5) / 5 = 4 s
        assert!((c.ttc - 4.0).abs() < 1e-12 && c.t == 1.0 && (c.x - 77.5).abs() < 1e-12, "{c:?}"); // contact at t = 5: a at 75, b at 80
    }

    #[test]
    fn bad_radius_and_trajectories_are_errors() {
        let a = tr(&[(0.0, 0.0, 0.0), (1.0, 1.0, 0.0)]);
        assert_eq!(ttc(a.view(), a.view(), -1.0).unwrap_err().describe(), "radius must be >= 0, got -1");
        let bad = tr(&[(0.0, f64::NAN, 0.0)]);
        assert!(ttc(bad.view(), a.view(), 1.0).unwrap_err().describe().starts_with("a[1].x must be finite"));
    }

    /// The unwindowed form: every sample time filtered and sorted, segments walked from 0.
    fn ttc_reference(a: Traj<'_>, b: Traj<'_>, r: f64) -> Option<Ttc> {
        let (lo, hi) = (a.t[0].max(b.t[0]), a.t[a.len() - 1].min(b.t[b.len() - 1]));
        if !(hi > lo) {
            return None;
        }
        let mut times: Vec<f64> = a.t.iter().chain(b.t.iter()).copied().filter(|&t| t > lo && t < hi).collect();
        times.push(lo);
        times.push(hi);
        times.sort_by(f64::total_cmp);
        times.dedup();
        let (mut ka, mut kb) = (0usize, 0usize);
        let mut best: Option<Ttc> = None;
        for w in times.windows(2) {
            let (u, v) = (w[0], w[1]);
            let (pa, va) = state(a, &mut ka, u, v);
            let (pb, vb) = state(b, &mut kb, u, v);
            let (dx, dy, wx, wy) = (pb[0] - pa[0], pb[1] - pa[1], vb[0] - va[0], vb[1] - va[1]);
            let c = dx * dx + dy * dy - r * r;
            let at = |sigma: f64| ((pa[0] + va[0] * sigma + pb[0] + vb[0] * sigma) / 2.0, (pa[1] + va[1] * sigma + pb[1] + vb[1] * sigma) / 2.0);
            if c <= 0.0 {
                let (x, y) = at(0.0);
                return Some(Ttc { ttc: 0.0, t: u, x, y });
            }
            let (qa, qb) = (wx * wx + wy * wy, 2.0 * (dx * wx + dy * wy));
            let disc = qb * qb - 4.0 * qa * c;
            if qb >= 0.0 || disc < 0.0 || qa == 0.0 {
                continue;
            }
            let sigma = c / ((-qb + disc.sqrt()) / 2.0);
            let (x, y) = at(sigma);
            if sigma <= v - u {
                return Some(Ttc { ttc: 0.0, t: u + sigma, x, y });
            }
            let cand = Ttc { ttc: sigma - (v - u), t: v, x, y };
            if best.is_none_or(|b| cand.ttc < b.ttc) {
                best = Some(cand);
            }
        }
        best
    }

    proptest! {
        /// Reading only the common period (binary searches) gives exactly what reading every
        /// sample gives, for random walks shifted in time (partly, fully or not overlapping).
        #[test]
        fn the_window_agrees_with_every_sample(seed in 0u64..1_000_000, shift in -6.0f64..6.0, r in 0.0f64..3.0, na in 2usize..60, nb in 2usize..60) {
            let mut s = seed;
            let mut rnd = || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
            };
            let (mut a, mut b) = (OwnedTraj::default(), OwnedTraj::default());
            let (mut xa, mut ya, mut xb, mut yb) = (-10.0, 0.0, 10.0, 0.0);
            for k in 0..na {
                xa += rnd() + 0.5;
                ya += rnd();
                a.push(k as f64 * 0.1, xa, ya);
            }
            for k in 0..nb {
                xb += rnd() - 0.5;
                yb += rnd();
                b.push(k as f64 * 0.13 + shift, xb, yb);
            }
            prop_assert_eq!(ttc(a.view(), b.view(), r).unwrap(), ttc_reference(a.view(), b.view(), r));
            prop_assert_eq!(ttc(b.view(), a.view(), r).unwrap(), ttc_reference(b.view(), a.view(), r));
        }

        /// Constant-velocity pairs on a collision course: the sampled TTC at the first common time
        /// matches the closed form, and the minimum is 0 exactly when they reach `radius` in time.
        #[test]
        fn constant_velocity_matches_the_closed_form(gap in 10.0f64..80.0, closing in 1.0f64..30.0, r in 0.5f64..4.0, dt in 0.05f64..1.0) {
            let n = 40usize;
            let a: Vec<_> = (0..n).map(|k| (k as f64 * dt, closing * k as f64 * dt, 0.0)).collect();
            let b: Vec<_> = (0..n).map(|k| (k as f64 * dt, gap, 0.0)).collect();
            let (a, b) = (tr(&a), tr(&b));
            let end = (n - 1) as f64 * dt;
            let c = ttc(a.view(), b.view(), r).unwrap().unwrap();
            let contact = (gap - r) / closing;
            if contact <= end {
                prop_assert!(c.ttc == 0.0 && (c.t - contact).abs() < 1e-9, "{:?}", c);
            } else {
                prop_assert!((c.ttc - (contact - end)).abs() < 1e-9 && (c.t - end).abs() < 1e-12, "{:?}", c);
            }
            prop_assert!((c.x - (gap - r + gap) / 2.0).abs() < 1e-6);
        }
    }
}
