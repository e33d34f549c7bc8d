//! The `k` most severe crossings of a set of road users: the pairs with the smallest PET, without
//! scoring every pair that has one (sql/analysis.sql `top_conflicts`, the report's near misses).
//!
//! [`super::conflicts`] returns every pair with a PET of at most `max_pet` (or a TTC of at most
//! `max_ttc`). That table is output-bound: in congestion every road user in a queue crosses the
//! paths of the ones ahead within seconds, so at 4 times the road users per minute the pairs with
//! a PET under 3 s grew 57 times (benches/scale_series.py, density). A report that shows the 15
//! smallest PETs needs none of the others. Here the PET bound is searched upward:
//!
//! ```text
//! g_0 = max_pet / 16,  g_{i+1} = min(2 g_i, max_pet)   (g_5 = max_pet)
//! round i: P_i = { pairs with PET <= g_i }  (candidates with spans widened by g_i / 2, pet(a, b, g_i))
//! stop at the first i with |P_i| >= k, or g_i = max_pet
//! ```
//!
//! Exact: a pair's PET below `g` is its smallest crossing, found with the bound `g` as with any
//! larger one (the same crossing, ties the earlier first passage: [`super::pet`]), and the
//! candidates at `g` hold every pair with a PET of at most `g` ([`super::candidates`]). When
//! `|P_i| >= k`, the k-th smallest PET is `v <= g_i`, and every pair with a PET of at most `v` is
//! in `P_i`. Kept: the first k pairs by (PET, id_a, id_b), the rows `ORDER BY pet, a, b LIMIT k`
//! of the full table would give (ties at the k-th broken by the ids, so the answer does not
//! depend on the order of the input, and a crowd at one point does not return a million rows
//! for k = 15), with their TTC at `radius` as [`super::conflicts`] gives it. A pair with a TTC but no PET is not a crossing and is not here.
//! With `max_pet` infinite, the search stops once `g` passes the whole recording's time span
//! (every PET is below it). After 5 doublings the next round takes the last bound at once
//! (`max_pet`, or the span: at most 6 rounds).
//!
//! Within a round the workers share the k-th smallest PET found so far: a pair is searched up to
//! it, not up to `g` (it only falls, and the answer's k-th is at most it, so no kept pair is
//! missed; in a jam the first few hundred pairs bring it to microseconds).
//!
//! The starting bound only sets how many rounds run, never the answer. Cost: the rounds' sum,
//! at most about twice the last round (each round's candidates grow with `g`), and each round
//! scores only pairs whose paths cross within `g` seconds: O(P log P + K_g) per round for P path
//! pieces and K_g the piece pairs within `g` of each other, instead of all pairs within
//! `max_pet`.

use super::candidates::alloc_error;
use super::pairs::{check_set, ordered_candidates, Conflict};
use super::pet::pet_checked;
use super::ttc::ttc_checked;
use super::ConflictError;
use crate::traj::Traj;
use crate::{non_negative, positive_or_inf, ParamError};
use rayon::prelude::*;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// The pairs (`a` has the smaller id) with the `k` smallest PETs of at most `max_pet` (ties
/// broken by (id_a, id_b): the first k of the PET order), each with its TTC at `radius`, sorted by
/// (id_a, id_b). `k = 0`: none. With `bodies` (one per road user), a pair that is
/// [`probably_one_body`](super::probably_one_body) road user counted twice is not a near miss: it is left
/// out and does not count towards `k` (issue 39: they were 7 of the 10 smallest PETs of the DUT
/// intersection). With `radii` (one per road user, m: `class_radius_m`), a pair's TTC is at the
/// sum of its two radii instead of `radius`. With `walkers` (one per road user), a pair of two
/// walkers is left out too: two pedestrians passing close by are no traffic conflict, and on
/// both DUT scenes they were every one of the 10 smallest PETs (the report ranks the encounters
/// with a vehicle).
/// Errors: those of [`super::conflicts`], `k` < 0, and `bodies`, `radii` or `walkers` of another
/// length than `ids`, a radius < 0 or not finite.
pub fn top_conflicts(
    ids: &[i64],
    trajs: &[Traj<'_>],
    k: i64,
    max_pet: f64,
    radius: f64,
    bodies: Option<&[super::Body]>,
    radii: Option<&[f64]>,
    walkers: Option<&[bool]>,
) -> Result<Vec<Conflict>, ConflictError> {
    let max_pet = positive_or_inf("max_pet", max_pet)?;
    let radius = non_negative("radius", radius)?;
    if k < 0 {
        return Err(ParamError { name: "k", value: k as f64, rule: ">= 0" }.into());
    }
    check_set(ids, trajs)?;
    if let Some(c) = bodies {
        if c.len() != ids.len() {
            return Err(ConflictError::ClassesLength { ids: ids.len(), classes: c.len() });
        }
    }
    for (what, n) in [("radii", radii.map(<[_]>::len)), ("walkers", walkers.map(<[_]>::len))] {
        if let Some(n) = n.filter(|n| *n != ids.len()) {
            return Err(ConflictError::PerRoadUser { what, ids: ids.len(), got: n });
        }
    }
    if let Some(r) = radii {
        for &v in r {
            non_negative("radii", v)?;
        }
    }
    let pair_radius = |a: usize, b: usize| radii.map_or(radius, |r| r[a] + r[b]);
    let one = |a: usize, b: usize| {
        walkers.is_some_and(|w| w[a] && w[b]) || bodies.is_some_and(|c| super::probably_one_body(c[a], c[b], super::together(trajs[a], trajs[b])))
    };
    let k = k as usize;
    if k == 0 {
        return Ok(Vec::new());
    }
    // the recording's span: no PET exceeds it, so a bound past it finds every crossing
    let (t0, t1) = trajs.iter().filter(|t| t.len() >= 2).fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), t| (l.min(t.t[0]), h.max(t.t[t.len() - 1])));
    if t0 > t1 {
        return Ok(Vec::new());
    }
    let whole = (t1 - t0) * 2.0 + 1.0;
    let last = max_pet.min(whole);
    let mut g = if max_pet.is_finite() { max_pet / 16.0 } else { 1.0f64.min(last) };
    let mut rounds = 0;
    // PET's work limit per pair of road users, read in this thread (the limits' scope)
    let limit = crate::limits::PET_SEGMENT_PAIRS.get();
    let mut found = loop {
        rounds += 1;
        let cand = ordered_candidates(ids, trajs, 0.0, 0.0, g / 2.0)?;
        // within a round, the k-th smallest PET found so far bounds the rest (it only falls, and
        // the answer's k-th is at most it): a pair is searched up to it, not up to g
        let bound = Bound::new(k, g);
        let found: Vec<(usize, usize, super::Pet)> = cand
            .par_iter()
            .filter_map(|&(a, b)| match pet_checked(trajs[a], trajs[b], bound.get(), &super::pet::Budget::new(limit)) {
                Ok(Some(_)) if one(a, b) => None,
                Ok(Some(p)) => {
                    bound.offer(p.pet);
                    Some(Ok((a, b, p)))
                }
                Ok(None) => None,
                Err(e) => Some(Err(e)),
            })
            .collect::<Result<_, ConflictError>>()?;
        if found.len() >= k || g >= last {
            break found;
        }
        // at most 5 doublings, then the last bound: with no max_pet and a span of 1e300 seconds
        // the doubling alone would take a thousand rounds
        g = if rounds >= 5 { last } else { (g * 2.0).min(last) };
    };
    if found.is_empty() {
        return Ok(Vec::new());
    }
    // the first k by (PET, id_a, id_b): pairs are distinct, so that is one order, whatever the
    // order of the input
    let key = |f: &(usize, usize, super::Pet)| (f.2.pet, ids[f.0], ids[f.1]);
    let by_key = |x: &(usize, usize, super::Pet), y: &(usize, usize, super::Pet)| {
        let (p, q) = (key(x), key(y));
        p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)).then(p.2.cmp(&q.2))
    };
    if found.len() > k {
        found.select_nth_unstable_by(k - 1, by_key);
        found.truncate(k);
    }
    found.sort_unstable_by(|x, y| (ids[x.0], ids[x.1]).cmp(&(ids[y.0], ids[y.1])));
    let kept: Vec<Conflict> = found
        .into_par_iter()
        .map(|(a, b, p)| Conflict { a, b, pet: Some(p), ttc: ttc_checked(trajs[a], trajs[b], pair_radius(a, b)), together: super::together(trajs[a], trajs[b]) })
        .collect();
    let mut out = Vec::new();
    out.try_reserve(kept.len()).map_err(|_| alloc_error((kept.len() * std::mem::size_of::<Conflict>()) as u128))?;
    out.extend(kept);
    Ok(out)
}

/// The k-th smallest PET found so far in a round (or the round's bound `g` while fewer than k
/// are found), shared by the workers: read without a lock, updated under one only when a PET
/// below it is found (after the first few pairs, rarely).
struct Bound {
    k: usize,
    bits: AtomicU64,
    heap: Mutex<BinaryHeap<OrdF64>>,
}

/// A PET (finite, >= 0) ordered for the max-heap.
struct OrdF64(f64);
impl PartialEq for OrdF64 {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o).is_eq()
    }
}
impl Eq for OrdF64 {}
impl PartialOrd for OrdF64 {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for OrdF64 {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

impl Bound {
    fn new(k: usize, g: f64) -> Bound {
        Bound { k, bits: AtomicU64::new(g.to_bits()), heap: Mutex::new(BinaryHeap::new()) }
    }
    fn get(&self) -> f64 {
        f64::from_bits(self.bits.load(Ordering::Relaxed))
    }
    fn offer(&self, pet: f64) {
        if pet >= self.get() {
            return; // changes nothing (the k-th stays), and at the bound ties are kept anyway
        }
        // a poisoned lock (a panic elsewhere) only loses the pruning, never a pair
        let Ok(mut h) = self.heap.lock() else { return };
        h.push(OrdF64(pet));
        if h.len() > self.k {
            h.pop();
        }
        if h.len() == self.k {
            if let Some(top) = h.peek() {
                self.bits.fetch_min(top.0.to_bits(), Ordering::Relaxed);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::conflicts;
    use super::super::test_line as line;
    use super::*;
    use proptest::prelude::*;

    /// The obviously right version: every conflict with a PET, ordered by (PET, id_a, id_b), the
    /// first k, back in (id_a, id_b) order.
    fn slow(ids: &[i64], trajs: &[Traj<'_>], k: usize, max_pet: f64, radius: f64) -> Vec<Conflict> {
        let mut all: Vec<Conflict> = conflicts(ids, trajs, max_pet, radius, 0.0, None).unwrap().into_iter().filter(|c| c.pet.is_some()).collect();
        all.sort_by(|x, y| x.pet.unwrap().pet.total_cmp(&y.pet.unwrap().pet).then(ids[x.a].cmp(&ids[y.a])).then(ids[x.b].cmp(&ids[y.b])));
        all.truncate(k);
        all.sort_by_key(|c| (ids[c.a], ids[c.b]));
        all
    }

    #[test]
    fn the_smallest_pets_and_their_ties() {
        // 1 crosses 2 (PET 1.5) and 3 (PET 0.5); 4 crosses 1 with PET 0.5 as well (a tie)
        let a = line(0.0, -50.0, 0.0, 10.0, 0.0, 101, 0.1);
        let b = line(0.0, 0.0, -32.5, 0.0, 5.0, 131, 0.1);
        let c = line(-1.0, 0.0, -27.5, 0.0, 5.0, 131, 0.1);
        let d = line(-1.0, 0.0, 27.5, 0.0, -5.0, 131, 0.1);
        let trajs = [a.view(), b.view(), c.view(), d.view()];
        let ids = [1, 2, 3, 4];
        let all = conflicts(&ids, &trajs, 5.0, 2.0, 3.0, None).unwrap();
        // k = 1: of the two tied at 0.5 s, the first by ids; k = 2: both
        let one = top_conflicts(&ids, &trajs, 1, 5.0, 2.0, None, None, None).unwrap();
        assert_eq!(one.iter().map(|c| (c.a, c.b)).collect::<Vec<_>>(), vec![(0, 2)], "{one:?}");
        let two = top_conflicts(&ids, &trajs, 2, 5.0, 2.0, None, None, None).unwrap();
        assert_eq!(two.iter().map(|c| (c.a, c.b)).collect::<Vec<_>>(), vec![(0, 2), (0, 3)], "{two:?}");
        assert!(two.iter().all(|c| (c.pet.unwrap().pet - 0.5).abs() < 1e-9));
        // the same rows (TTC included) as the full table
        for c in &two {
            assert!(all.contains(c), "{c:?}");
        }
        assert_eq!(top_conflicts(&ids, &trajs, 10, 5.0, 2.0, None, None, None).unwrap(), slow(&ids, &trajs, 10, 5.0, 2.0));
        assert_eq!(top_conflicts(&ids, &trajs, 10, f64::INFINITY, 2.0, None, None, None).unwrap(), slow(&ids, &trajs, 10, f64::INFINITY, 2.0));
        assert_eq!(top_conflicts(&ids, &trajs, 0, 5.0, 2.0, None, None, None).unwrap(), vec![]);
        assert_eq!(top_conflicts(&[], &[], 3, 5.0, 2.0, None, None, None).unwrap(), vec![]);
    }

    #[test]
    fn bad_parameters_are_errors_naming_them() {
        let a = line(0.0, 0.0, 0.0, 1.0, 0.0, 3, 1.0);
        assert_eq!(top_conflicts(&[1], &[a.view()], -1, 5.0, 2.0, None, None, None).unwrap_err().describe(), "k must be >= 0, got -1");
        assert_eq!(top_conflicts(&[1], &[a.view()], 1, 0.0, 2.0, None, None, None).unwrap_err().describe(), "max_pet must be > 0, got 0");
        assert_eq!(top_conflicts(&[1], &[a.view()], 1, 1.0, f64::NAN, None, None, None).unwrap_err().describe(), "radius must be >= 0, got NaN");
        assert!(matches!(top_conflicts(&[1, 1], &[a.view(), a.view()], 1, 1.0, 2.0, None, None, None), Err(ConflictError::DuplicateId(1))));
    }

    #[test]
    fn a_road_user_counted_twice_is_not_a_near_miss() {
        // 1 and 2 are one pedestrian (0.06 m apart, the same times): PET about 0 to each other; 3 crosses
        // them with PET 0.5 s and 4 with 1.5 s
        let a = line(0.0, -20.0, 0.0, 1.4, 0.0, 301, 0.1);
        // (the copy zigzags about the path, as noise does: the two paths cross all the time)
        let mut b = line(0.0, -20.0, 0.0, 1.4, 0.0, 301, 0.1);
        for (i, y) in b.y.iter_mut().enumerate() {
            *y = if i % 2 == 0 { 0.06 } else { -0.06 };
        }
        let c = line(8.12, 0.0, -10.0, 0.0, 1.5, 141, 0.1);
        let d = line(9.12, 0.0, -10.0, 0.0, 1.5, 141, 0.1);
        let trajs = [a.view(), b.view(), c.view(), d.view()];
        let ids = [1, 2, 3, 4];
        let plain = top_conflicts(&ids, &trajs, 1, 5.0, 2.0, None, None, None).unwrap();
        assert_eq!(plain.iter().map(|c| (c.a, c.b)).collect::<Vec<_>>(), vec![(0, 1)], "{plain:?}");
        let ped = super::super::Body { class: 1, min_gap_m: 0.45 };
        let cls = [ped; 4];
        let top = top_conflicts(&ids, &trajs, 2, 5.0, 2.0, Some(&cls), None, None).unwrap();
        // k = 2 without the pair (1, 2): both crossings of 3 with the pedestrian
        assert!(top.iter().all(|c| (c.a, c.b) != (0, 1)), "{top:?}");
        assert_eq!(top.len(), 2);
        assert!(top.iter().all(|c| c.b == 2 && (c.pet.unwrap().pet - 0.5).abs() < 0.2), "{top:?}");
        // the same pair as two classes: a near miss again
        let mixed = [ped, super::super::Body { class: 2, min_gap_m: 0.6 }, ped, ped];
        assert_eq!(top_conflicts(&ids, &trajs, 1, 5.0, 2.0, Some(&mixed), None, None).unwrap().iter().map(|c| (c.a, c.b)).collect::<Vec<_>>(), vec![(0, 1)]);
        assert!(matches!(top_conflicts(&ids, &trajs, 1, 5.0, 2.0, Some(&cls[..3]), None, None), Err(ConflictError::ClassesLength { ids: 4, classes: 3 })));
    }

    #[test]
    fn walker_pairs_left_out_and_radii_per_road_user() {
        // pedestrians 1 and 2 walk side by side 1.5 m apart; car 3 crosses them with PET 0.5 s
        let a = line(0.0, -20.0, 0.0, 1.4, 0.0, 301, 0.1);
        let b = line(0.3, -20.0, 1.5, 1.4, 0.0, 301, 0.1);
        let c = line(8.12, 0.0, -10.0, 0.0, 5.0, 61, 0.1);
        let trajs = [a.view(), b.view(), c.view()];
        let ids = [1, 2, 3];
        // the pedestrian pair crosses nowhere (parallel), so the closest is the car with a pedestrian
        let walkers = [true, true, false];
        let all = top_conflicts(&ids, &trajs, 3, 5.0, 2.0, None, None, None).unwrap();
        let some = top_conflicts(&ids, &trajs, 3, 5.0, 2.0, None, None, Some(&walkers)).unwrap();
        assert!(some.iter().all(|c| !(walkers[c.a] && walkers[c.b])));
        assert_eq!(all.iter().filter(|c| !(walkers[c.a] && walkers[c.b])).count(), some.len());
        // TTC at the pair's radii: a 2 m disc puts the two pedestrians in contact, 0.25 m each does not
        // (two pedestrians crossing at right angles 1 s apart: at least 0.99 m apart)
        let (d, e) = (line(0.0, -10.0, 0.0, 1.4, 0.0, 201, 0.1), line(1.0, 0.0, -10.0, 0.0, 1.4, 201, 0.1));
        let pair = [d.view(), e.view()];
        let wide = top_conflicts(&[1, 2], &pair, 1, 5.0, 2.0, None, None, None).unwrap();
        let narrow = top_conflicts(&[1, 2], &pair, 1, 5.0, 2.0, None, Some(&[0.25, 0.25]), None).unwrap();
        assert!(wide[0].ttc.is_some() && narrow[0].ttc.is_none(), "{wide:?} {narrow:?}");
        assert!((wide[0].pet.unwrap().pet - 1.0).abs() < 1e-9 && narrow[0].pet == wide[0].pet);
        assert!(matches!(top_conflicts(&[1, 2], &pair, 1, 5.0, 2.0, None, Some(&[0.25]), None), Err(ConflictError::PerRoadUser { what: "radii", ids: 2, got: 1 })));
        assert_eq!(top_conflicts(&[1, 2], &pair, 1, 5.0, 2.0, None, Some(&[0.25, -1.0]), None).unwrap_err().describe(), "radii must be >= 0, got -1");
    }

    proptest! {
        /// Random crossings and queues (road users following one lane): the same rows as the
        /// first k of the full table by (PET, ids), for any k and max_pet.
        #[test]
        fn the_search_agrees_with_the_full_table(seed in 0u64..1_000_000, n in 0usize..40, k in 0usize..30, max_pet in 0.2f64..8.0, inf in any::<bool>()) {
            let mut s = seed;
            let mut rnd = || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 11) as f64) / ((1u64 << 53) as f64)
            };
            let mut trajs = Vec::new();
            for _ in 0..n {
                // half of them in two lanes with small angles (queues, rear-end crossings)
                let h = if rnd() < 0.5 { (rnd() - 0.5) * 0.2 + if rnd() < 0.5 { 0.0 } else { 1.5 } } else { rnd() * std::f64::consts::TAU };
                let v = if rnd() < 0.1 { 0.0 } else { 1.0 + rnd() * 15.0 };
                let len = if rnd() < 0.05 { 1 } else { 5 + (rnd() * 60.0) as usize };
                let (x0, y0) = (-40.0 * h.cos() + rnd() * 3.0, -40.0 * h.sin() + rnd() * 3.0);
                // times on a 0.1 s grid: exact PET ties happen
                trajs.push(line((rnd() * 300.0).round() / 10.0, x0, y0, v * h.cos(), v * h.sin(), len, 0.1 + (rnd() * 4.0).round() / 10.0));
            }
            let ids: Vec<i64> = (0..n as i64).map(|k| k * 5 - 7).collect();
            let views: Vec<Traj<'_>> = trajs.iter().map(|t| t.view()).collect();
            let m = if inf { f64::INFINITY } else { max_pet };
            prop_assert_eq!(top_conflicts(&ids, &views, k as i64, m, 2.0, None, None, None).unwrap(), slow(&ids, &views, k, m, 2.0));
        }
    }
}
