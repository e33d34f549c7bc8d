//! Two road users that travel together, and when that means one road user counted twice
//! (issue 39; docs/analysis.md, "Probably one road user").
//!
//! Tracking errors inflate conflict counts (Liu, Saunier and Bilodeau 2025): a pedestrian split
//! into two road users (a track that no other camera's or the same camera's track was linked to)
//! crosses "itself" with a PET of about 0 and a TTC of 0, and tops the near-miss table. On the
//! DUT intersection 7 of the 10 smallest PETs were such pairs. Here every kept pair is measured
//! over its common time: at every sample time of either path inside the common span, both paths
//! are interpolated linearly and their distance taken; [`Together`] holds how many such times
//! and the median distance.
//!
//! **The decision** ([`probably_one`]): two road users of the same class whose centres stay,
//! at the median over their common time, closer than the least gap of two distinct bodies of the
//! class ([`Kind::min_gap_m`]: a pedestrian's torso depth, a car's width) cannot be two bodies:
//! they are one road user counted twice. Measured on both shared DUT scenes (trajdb pipeline,
//! then `probably_one()` against truth.csv): the pairs the truth calls one object are 0.03-0.14 m
//! apart; pedestrians walking in pairs 0.32 m and more (a bound of 0.45 m, a shoulder breadth,
//! took 30 such pairs for one); the bound for pedestrians is 0.25 m. Pairs that are not the same
//! class, or that share fewer than [`MIN_COMMON`] sample times, are never judged one.
//!
//! # Complexity
//! O(n + m) to walk both paths, O(k log k) for the median of the k common times.

use crate::associate::class_min_gap_m;
use crate::stats::median;
use crate::traj::Traj;

/// Sample times in the common span needed to judge a pair: one instant is a crossing, not
/// travelling together.
pub const MIN_COMMON: usize = 2;

/// Two paths over their common time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Together {
    /// Sample times (of either path) inside the common span.
    pub n: usize,
    /// The median distance between the two paths at those times (m).
    pub median_m: f64,
    /// The common span (s).
    pub span_s: f64,
}

/// `tr` at time `t` (inside its span), linearly between the samples around it; `i` is a cursor
/// that only moves forward (the times asked for increase).
fn at(tr: Traj<'_>, t: f64, i: &mut usize) -> (f64, f64) {
    let n = tr.len();
    while *i + 1 < n && tr.t[*i + 1] < t {
        *i += 1;
    }
    let j = (*i + 1).min(n - 1);
    let (t0, t1) = (tr.t[*i], tr.t[j]);
    if j == *i || t1 <= t0 {
        return (tr.x[*i], tr.y[*i]);
    }
    let u = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
    (tr.x[*i] + u * (tr.x[j] - tr.x[*i]), tr.y[*i] + u * (tr.y[j] - tr.y[*i]))
}

/// The two paths over their common time (module docs); `None` when they share no time. The
/// paths are valid trajectories (times strictly increasing, finite).
pub fn together(a: Traj<'_>, b: Traj<'_>) -> Option<Together> {
    if a.len() == 0 || b.len() == 0 {
        return None;
    }
    let lo = a.t[0].max(b.t[0]);
    let hi = a.t[a.len() - 1].min(b.t[b.len() - 1]);
    if lo > hi {
        return None;
    }
    let (mut i, mut j) = (a.t.partition_point(|&t| t < lo), b.t.partition_point(|&t| t < lo));
    let (mut ca, mut cb) = (0usize, 0usize);
    let mut d = Vec::new();
    loop {
        let ta = a.t.get(i).copied().filter(|&t| t <= hi);
        let tb = b.t.get(j).copied().filter(|&t| t <= hi);
        let t = match (ta, tb) {
            (None, None) => break,
            (Some(x), None) => {
                i += 1;
                x
            }
            (None, Some(y)) => {
                j += 1;
                y
            }
            (Some(x), Some(y)) => {
                // one time once: a shared clock gives both paths the same times
                if x <= y {
                    i += 1;
                    if x == y {
                        j += 1;
                    }
                    x
                } else {
                    j += 1;
                    y
                }
            }
        };
        let (pa, pb) = (at(a, t, &mut ca), at(b, t, &mut cb));
        d.push((pa.0 - pb.0).hypot(pa.1 - pb.1));
    }
    if d.is_empty() {
        return None;
    }
    let n = d.len();
    Some(Together { n, median_m: median(&mut d), span_s: hi - lo })
}

/// A road user as [`probably_one_body`] needs it: its class (any code: only equality counts)
/// and its class's least gap (m, [`class_min_gap_m`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    pub class: i64,
    pub min_gap_m: f64,
}

/// Are two road users of classes `class_a` and `class_b`, together as `t`, one road user counted
/// twice (module docs)? Same class, at least [`MIN_COMMON`] common sample times, and a median
/// distance under the class's least gap.
pub fn probably_one(class_a: &str, class_b: &str, t: Option<Together>) -> bool {
    // one class whatever its case ('Car' and 'CAR'), as the class's kind is read
    class_a.trim().eq_ignore_ascii_case(class_b.trim()) && probably_one_body(Body { class: 0, min_gap_m: class_min_gap_m(class_a) }, Body { class: 0, min_gap_m: class_min_gap_m(class_b) }, t)
}

/// [`probably_one`] for classes given as codes with their least gaps.
pub fn probably_one_body(a: Body, b: Body, t: Option<Together>) -> bool {
    a.class == b.class && t.is_some_and(|t| t.n >= MIN_COMMON && t.median_m < a.min_gap_m.min(b.min_gap_m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traj::OwnedTraj;

    fn line(t0: f64, n: usize, dt: f64, y: f64) -> OwnedTraj {
        let t: Vec<f64> = (0..n).map(|k| t0 + k as f64 * dt).collect();
        let x: Vec<f64> = t.iter().map(|t| 1.4 * t).collect();
        OwnedTraj { y: vec![y; n], x, t }
    }

    /// The obviously right version: a fine grid of times over the common span.
    fn slow(a: Traj<'_>, b: Traj<'_>) -> f64 {
        let lo = a.t[0].max(b.t[0]);
        let hi = a.t[a.len() - 1].min(b.t[b.len() - 1]);
        let (mut i, mut j) = (0, 0);
        let mut d: Vec<f64> = (0..=1000)
            .map(|k| {
                let t = lo + (hi - lo) * k as f64 / 1000.0;
                let (p, q) = (at(a, t, &mut i), at(b, t, &mut j));
                (p.0 - q.0).hypot(p.1 - q.1)
            })
            .collect();
        median(&mut d)
    }

    #[test]
    fn a_copy_a_neighbour_and_no_common_time() {
        let a = line(0.0, 50, 0.1, 0.0);
        let copy = line(1.0, 50, 0.1, 0.08);
        let t = together(a.view(), copy.view()).unwrap();
        // every sample time of either path in the common 3.9 s (the two grids' times differ by float rounding)
        assert!(t.n >= 40 && t.n <= 80, "{t:?}");
        assert!((t.median_m - 0.08).abs() < 1e-9 && (t.span_s - 3.9).abs() < 1e-9, "{t:?}");
        assert!(probably_one("pedestrian", "pedestrian", Some(t)));
        assert!(!probably_one("pedestrian", "cyclist", Some(t)));
        assert!(probably_one("Car", "CAR", Some(t)));
        // no class (the load's 'unknown'): the least gap of any road user, 0.25 m
        assert!(probably_one("unknown", "unknown", Some(t)));
        assert!(!probably_one("unknown", "unknown", together(a.view(), line(0.0, 50, 0.1, 0.32).view())));
        // a neighbour walking 0.32 m beside (the closest pair on the DUT scenes): two people
        let side = line(0.0, 50, 0.1, 0.32);
        assert!(!probably_one("pedestrian", "pedestrian", together(a.view(), side.view())));
        // but 0.32 m apart are one car
        assert!(probably_one("car", "car", together(a.view(), side.view())));
        // after one another: no common time
        assert_eq!(together(a.view(), line(10.0, 5, 0.1, 0.0).view()), None);
        // one common instant: a crossing, not together
        let touch = line(4.9, 5, 0.1, 0.0);
        let t1 = together(a.view(), touch.view()).unwrap();
        assert_eq!(t1.n, 1);
        assert!(!probably_one("pedestrian", "pedestrian", Some(t1)));
    }

    #[test]
    fn other_sampling_is_interpolated() {
        // b at 3 Hz with a phase, 0.2 m off: every time of either path, b interpolated on its line
        let a = line(0.0, 60, 0.1, 0.0);
        let b = line(0.05, 17, 1.0 / 3.0, 0.2);
        let t = together(a.view(), b.view()).unwrap();
        assert!((t.median_m - 0.2).abs() < 1e-9, "{t:?}");
        assert!((t.median_m - slow(a.view(), b.view())).abs() < 1e-9);
    }

    proptest::proptest! {
        /// On paths of random shape and sampling, the median over both paths' sample times stays
        /// near the fine-grid median (a different sample of the same distance function): equal
        /// for parallel paths, within the distance's range otherwise.
        #[test]
        fn within_the_distance_range(seed in 0u64..500) {
            let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            let mut r = || { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); ((s >> 11) as f64) / (1u64 << 53) as f64 };
            let mk = |r: &mut dyn FnMut() -> f64| {
                let n = 3 + (r() * 30.0) as usize;
                let mut t = vec![r() * 2.0];
                for _ in 1..n { let last = *t.last().unwrap(); t.push(last + 0.05 + r() * 0.4); }
                let x: Vec<f64> = t.iter().map(|_| r() * 5.0).collect();
                let y: Vec<f64> = t.iter().map(|_| r() * 5.0).collect();
                OwnedTraj { t, x, y }
            };
            let (a, b) = (mk(&mut r), mk(&mut r));
            if let Some(t) = together(a.view(), b.view()) {
                let lo = a.t[0].max(b.t[0]);
                let hi = a.t[a.t.len() - 1].min(b.t[b.t.len() - 1]);
                let (mut i, mut j) = (0, 0);
                let fine: Vec<f64> = (0..=2000).map(|k| { let tt = lo + (hi - lo) * k as f64 / 2000.0; let (p, q) = (at(a.view(), tt, &mut i), at(b.view(), tt, &mut j)); (p.0 - q.0).hypot(p.1 - q.1) }).collect();
                let (mn, mx) = fine.iter().fold((f64::INFINITY, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
                proptest::prop_assert!(t.median_m >= mn - 1e-9 && t.median_m <= mx + 1e-9);
                proptest::prop_assert!(t.n >= 1);
            }
        }
    }
}
