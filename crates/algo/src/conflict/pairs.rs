//! Conflicts of a whole set of road users in one call: every pair near each other in time and
//! space, with its [`pet`](super::pet()) and [`ttc`](super::ttc()) (sql/analysis.sql `conflicts`).
//!
//! The kept pairs: road users `a`, `b` with `id_a < id_b` that have a PET of at most `max_pet`
//! or a TTC of at most `max_ttc`. Such a pair always meets the rule the SQL macro had as a range
//! join: time spans that meet within `max_pet`,
//!
//! ```text
//! t0_a <= t1_b + max_pet  and  t0_b <= t1_a + max_pet
//! ```
//!
//! and bounding boxes that overlap once each is widened by its reach,
//! `reach = radius / 2 + v_max * max_ttc` (`v_max`: the top of [`crate::traj::speeds`], 0 when
//! none): how far a constant-velocity prediction can take it within `max_ttc`. That rule is what
//! the property test's all-pairs version applies.
//!
//! Candidates come from a space-time grid of path pieces ([`super::candidates`]): a finer form of
//! the same rule, piece by piece, so a pair is scored only when pieces of both paths come near
//! each other near the same time. The work is O(P log P + K_near + Σ pair cost), P the pieces,
//! K_near the pairs near each other: linear in the road users of a day and in the road users
//! per window at a given density in space (a sweep over start times, the rule before, scored
//! every pair that met in time: 16 times the pairs at 4 times the road users at once). The
//! pairs' PET and TTC run in parallel (rayon); the paths are read in place, never copied per
//! pair (what made the SQL join slow: it copied both lists into every pair row).

use super::candidates::{alloc_error, candidates};
use super::pet::pet_checked;
use super::ttc::ttc_checked;
use super::{ConflictError, Pet, Ttc};
#[cfg(test)]
use crate::traj::speeds;
use crate::traj::Traj;
use crate::{non_negative, positive_or_inf};
use rayon::prelude::*;

/// One kept pair: indices into the input (`a` has the smaller id), its PET and TTC, and how the
/// two travel over their common time ([`super::together`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conflict {
    pub a: usize,
    pub b: usize,
    pub pet: Option<Pet>,
    pub ttc: Option<Ttc>,
    pub together: Option<super::Together>,
}

/// Time span, bounding box and reach of one road user.
#[cfg(test)]
#[derive(Clone, Copy)]
struct Extent {
    t0: f64,
    t1: f64,
    xmin: f64,
    xmax: f64,
    ymin: f64,
    ymax: f64,
    reach: f64,
}

#[cfg(test)]
fn extent(tr: Traj<'_>, radius: f64, max_ttc: f64) -> Extent {
    let fold = |v: &[f64]| v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &z| (l.min(z), h.max(z)));
    let ((xmin, xmax), (ymin, ymax)) = (fold(tr.x), fold(tr.y));
    let vmax = speeds(tr).1.into_iter().reduce(f64::max).unwrap_or(0.0);
    Extent { t0: tr.t[0], t1: tr.t[tr.len() - 1], xmin, xmax, ymin, ymax, reach: radius / 2.0 + vmax * max_ttc }
}

/// The candidate rule in space (the time rule is the sweep's).
#[cfg(test)]
fn boxes_meet(a: &Extent, b: &Extent) -> bool {
    a.xmin - a.reach <= b.xmax + b.reach
        && b.xmin - b.reach <= a.xmax + a.reach
        && a.ymin - a.reach <= b.ymax + b.reach
        && b.ymin - b.reach <= a.ymax + a.reach
}

/// The conflicts among `trajs` (ids in `ids`, same length; road users with fewer than 2 points
/// take no part), sorted by (id_a, id_b) and then input position. Errors: lists of different
/// lengths, a trajectory outside the input policy (named `trajs[k]`, 1-based), `max_pet` <= 0 or
/// NaN, `radius` or `max_ttc` < 0 or not finite, more candidate pairs than the `memory_bytes`
/// limit holds, `radii` not one per road user or a radius < 0 or not finite.
///
/// With `radii` (one per road user, m: `class_radius_m`, issue 39), a pair's TTC is at the sum of
/// its two radii instead of `radius` (a 2 m disc put two pedestrians 1.9 m apart in contact), and
/// the candidates are searched at twice the largest radius (a superset).
pub fn conflicts(ids: &[i64], trajs: &[Traj<'_>], max_pet: f64, radius: f64, max_ttc: f64, radii: Option<&[f64]>) -> Result<Vec<Conflict>, ConflictError> {
    let max_pet = positive_or_inf("max_pet", max_pet)?;
    let radius = non_negative("radius", radius)?;
    let max_ttc = non_negative("max_ttc", max_ttc)?;
    check_set(ids, trajs)?;
    if let Some(r) = radii {
        if r.len() != ids.len() {
            return Err(ConflictError::PerRoadUser { what: "radii", ids: ids.len(), got: r.len() });
        }
        for &v in r {
            non_negative("radii", v)?;
        }
    }
    let pair_radius = |a: usize, b: usize| radii.map_or(radius, |r| r[a] + r[b]);
    let search = radii.map_or(radius, |r| 2.0 * r.iter().copied().fold(0.0, f64::max));
    // candidates on a space-time grid of path pieces (candidates.rs): a superset of the pairs
    // the whole-path rule above keeps, never every pair that meets in time
    let cand = ordered_candidates(ids, trajs, search, max_ttc, max_pet / 2.0)?;
    // PET's work limit, read here (the limits' scope is this thread's) and carried into the
    // rayon workers as a value: each pair of road users may examine that many segment pairs (a
    // real day's call holds 10^5 pairs; the candidates themselves are bounded by memory_bytes)
    let limit = crate::limits::PET_SEGMENT_PAIRS.get();
    let found: Vec<Option<Conflict>> = cand
        .par_iter()
        .map(|&(a, b)| {
            // every path was validated above, and the parameters checked
            let p = pet_checked(trajs[a], trajs[b], max_pet, &super::pet::Budget::new(limit))?;
            let c = ttc_checked(trajs[a], trajs[b], pair_radius(a, b));
            let keep = p.is_some() || c.is_some_and(|c| c.ttc <= max_ttc);
            Ok(keep.then(|| Conflict { a, b, pet: p, ttc: c, together: super::together(trajs[a], trajs[b]) }))
        })
        .collect::<Result<_, ConflictError>>()?;
    let mut out = Vec::new();
    out.try_reserve(found.len()).map_err(|_| alloc_error((found.len() * std::mem::size_of::<Conflict>()) as u128))?;
    out.extend(found.into_iter().flatten());
    Ok(out)
}

/// The checks of a set of road users (shared with [`super::top`]): lists of the same length,
/// distinct ids, every path inside the input policy (named `trajs[k]`, 1-based).
pub(super) fn check_set(ids: &[i64], trajs: &[Traj<'_>]) -> Result<(), ConflictError> {
    if ids.len() != trajs.len() {
        return Err(ConflictError::Lengths { ids: ids.len(), trajs: trajs.len() });
    }
    let mut sorted = ids.to_vec();
    sorted.sort_unstable();
    if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
        return Err(ConflictError::DuplicateId(w[0]));
    }
    for (k, tr) in trajs.iter().enumerate() {
        tr.validate().map_err(|e| ConflictError::TrajAt(k, e))?;
    }
    Ok(())
}

/// The candidate pairs as positions `(a, b)` with `ids[a] < ids[b]`, sorted by the ids.
pub(super) fn ordered_candidates(ids: &[i64], trajs: &[Traj<'_>], radius: f64, max_ttc: f64, half_pet: f64) -> Result<Vec<(usize, usize)>, ConflictError> {
    let mut cand: Vec<(usize, usize)> = candidates(trajs, radius, max_ttc, half_pet)?
        .into_iter()
        .map(|(p, q)| {
            let (p, q) = (p as usize, q as usize);
            if ids[q] < ids[p] {
                (q, p)
            } else {
                (p, q)
            }
        })
        .collect();
    cand.sort_unstable_by(|&(a, b), &(c, d)| ids[a].cmp(&ids[c]).then(ids[b].cmp(&ids[d])).then(a.cmp(&c)).then(b.cmp(&d)));
    Ok(cand)
}

#[cfg(test)]
mod tests {
    use super::super::{pet, ttc};
    use super::*;
    use proptest::prelude::*;

    use super::super::test_line as line;

    /// The obviously right version: every pair, the rule as the SQL macro spelled it.
    fn all_pairs(ids: &[i64], trajs: &[Traj<'_>], max_pet: f64, radius: f64, max_ttc: f64) -> Vec<Conflict> {
        let mut out = Vec::new();
        for a in 0..trajs.len() {
            for b in 0..trajs.len() {
                if ids[a] >= ids[b] || trajs[a].len() < 2 || trajs[b].len() < 2 {
                    continue;
                }
                let (ea, eb) = (extent(trajs[a], radius, max_ttc), extent(trajs[b], radius, max_ttc));
                if !(ea.t0 <= eb.t1 + max_pet && eb.t0 <= ea.t1 + max_pet && boxes_meet(&ea, &eb)) {
                    continue;
                }
                let p = pet(trajs[a], trajs[b], max_pet).unwrap();
                let c = ttc(trajs[a], trajs[b], radius).unwrap();
                if p.is_some() || c.is_some_and(|c| c.ttc <= max_ttc) {
                    out.push(Conflict { a, b, pet: p, ttc: c, together: crate::conflict::together(trajs[a], trajs[b]) });
                }
            }
        }
        out.sort_by(|x, y| ids[x.a].cmp(&ids[y.a]).then(ids[x.b].cmp(&ids[y.b])).then(x.a.cmp(&y.a)).then(x.b.cmp(&y.b)));
        out
    }

    #[test]
    fn a_crossing_pair_is_found_and_far_or_late_ones_are_not() {
        // 1 and 2 cross at the origin (PET 1.5); 3 is there 60 s later; 4 is 500 m away
        let a = line(0.0, -50.0, 0.0, 10.0, 0.0, 101, 0.1);
        let b = line(0.0, 0.0, -32.5, 0.0, 5.0, 131, 0.1);
        let late = line(60.0, 0.0, -32.5, 0.0, 5.0, 131, 0.1);
        let far = line(0.0, 500.0, -32.5, 0.0, 5.0, 131, 0.1);
        let trajs = [a.view(), b.view(), late.view(), far.view()];
        let got = conflicts(&[1, 2, 3, 4], &trajs, 5.0, 2.0, 3.0, None).unwrap();
        assert_eq!(got.len(), 1, "{got:?}");
        assert_eq!((got[0].a, got[0].b), (0, 1));
        assert!((got[0].pet.unwrap().pet - 1.5).abs() < 1e-9);
        // ids decide a and b, not positions
        let got = conflicts(&[9, 2, 3, 4], &trajs, 5.0, 2.0, 3.0, None).unwrap();
        assert_eq!((got[0].a, got[0].b), (1, 0));
        assert_eq!(got[0].pet.unwrap().t_a, got[0].pet.unwrap().t_a);
    }

    #[test]
    fn bad_input_is_an_error_naming_the_argument() {
        let a = line(0.0, 0.0, 0.0, 1.0, 0.0, 3, 1.0);
        let mut bad = a.clone();
        bad.t[2] = 0.5;
        let e = conflicts(&[1, 2], &[a.view(), bad.view()], 5.0, 2.0, 3.0, None).unwrap_err().describe();
        assert!(e.starts_with("trajs[2] must be ordered by t"), "{e}");
        let e = conflicts(&[1], &[a.view(), a.view()], 5.0, 2.0, 3.0, None).unwrap_err().describe();
        assert!(e.starts_with("ids and trajs must have the same length, got 1 ids and 2 trajectories"), "{e}");
        assert_eq!(conflicts(&[1], &[a.view()], 0.0, 2.0, 3.0, None).unwrap_err().describe(), "max_pet must be > 0, got 0");
        assert_eq!(conflicts(&[1], &[a.view()], 1.0, -2.0, 3.0, None).unwrap_err().describe(), "radius must be >= 0, got -2");
        assert_eq!(conflicts(&[1], &[a.view()], 1.0, 2.0, f64::NAN, None).unwrap_err().describe(), "max_ttc must be >= 0, got NaN");
        assert_eq!(conflicts(&[], &[], 1.0, 2.0, 3.0, None).unwrap(), vec![]);
    }

    proptest! {
        /// Random road users crossing a site at random times, directions and speeds (one-point
        /// paths and standing road users included; duplicated ids are an error): the sweep finds
        /// exactly the pairs, PETs and TTCs of the all-pairs version.
        #[test]
        fn the_sweep_agrees_with_all_pairs(seed in 0u64..1_000_000, n in 0usize..40, max_pet in 0.5f64..6.0, max_ttc in 0.0f64..4.0) {
            let mut s = seed;
            let mut rnd = || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 11) as f64) / ((1u64 << 53) as f64)
            };
            let mut trajs = Vec::new();
            let mut ids = Vec::new();
            for _ in 0..n {
                let h = rnd() * std::f64::consts::TAU;
                let v = if rnd() < 0.1 { 0.0 } else { 1.0 + rnd() * 15.0 };
                let len = if rnd() < 0.05 { 1 } else { 5 + (rnd() * 60.0) as usize };
                let (x0, y0) = (-40.0 * h.cos() + rnd() * 6.0, -40.0 * h.sin() + rnd() * 6.0);
                trajs.push(line(rnd() * 60.0, x0, y0, v * h.cos(), v * h.sin(), len, 0.1 + rnd() * 0.4));
                ids.push((rnd() * n as f64 * 1.2) as i64);
            }
            let views: Vec<Traj<'_>> = trajs.iter().map(|t| t.view()).collect();
            let mut distinct = ids.clone();
            distinct.sort_unstable();
            distinct.dedup();
            if distinct.len() < ids.len() {
                prop_assert!(matches!(conflicts(&ids, &views, max_pet, 2.0, max_ttc, None), Err(ConflictError::DuplicateId(_))));
                ids = (0..n as i64).map(|k| k * 7 - 3).collect();
            }
            let got = conflicts(&ids, &views, max_pet, 2.0, max_ttc, None).unwrap();
            // radii of 1 m each are the 2 m disc of the pair, whatever `radius` says
            let by_radii = conflicts(&ids, &views, max_pet, 9.0, max_ttc, Some(&vec![1.0; ids.len()])).unwrap();
            prop_assert_eq!(&by_radii, &got);
            prop_assert_eq!(got, all_pairs(&ids, &views, max_pet, 2.0, max_ttc));
        }
    }
}
