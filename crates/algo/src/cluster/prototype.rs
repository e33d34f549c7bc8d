//! Prototype clustering of trajectories: linear in the trajectories for a fixed number of route
//! patterns, where [`super::traj_cluster`] compares all n(n−1)/2 pairs.
//!
//! # Method
//! TrafficIntelligence's prototype (leader) clustering with LCSS (Saunier & Morency; `ml.py
//! prototypeCluster`), followed by the exact linkage over the prototypes:
//! 1. **Prototypes.** The trajectories are visited longest first (ties: the earliest start time,
//!    then the id: an order that moving or rotating the frame, shifting the clock, relabelling
//!    the ids or reordering the rows leaves as it is, unless two tracks of one length start at
//!    the same instant). Each is compared with the prototypes so far by Buzan's distance
//!    `d = 1 − min(S_x, S_y)` (S1 or S2, with δ, ε, ρ: [`super::traj_cluster::similarity`]). When
//!    the nearest prototype is within `radius` (ties: the earliest prototype) the trajectory
//!    becomes its member; otherwise it becomes a new prototype. Longest first because a long
//!    trajectory covers the shorter ones of its route (S is normalised by the shorter length), as
//!    TrafficIntelligence orders them.
//! 2. **Linkage.** The prototypes' condensed distance matrix ([`super::traj_cluster::distances`],
//!    exact, cannot-links `+inf`) goes through [`super::linkage::linkage_condensed`] with `method`
//!    and is cut at `threshold`; every member takes its prototype's cluster. A prototype with no
//!    member and no finite distance to any other prototype is isolated: cluster 0, as in
//!    `traj_cluster`. Clusters are numbered 1.. by their smallest id.
//!
//! # Against the exact clustering
//! Each prototype stands for its members: two members of one prototype share a cluster even if
//! their own distance is above the threshold or infinite (a cannot-link between members of the
//! same prototype, or of two prototypes that merge, is not seen), and the linkage weighs each
//! prototype once, not by its member count. With `radius` at half the threshold the members of a
//! prototype are close to each other in the sense of the cut. The agreement with `traj_cluster`
//! on the shared scenes and a simulated day is measured in docs/clustering.md (adjusted Rand
//! index and cluster counts), not assumed.
//!
//! # Complexity
//! Step 1: O(n · P) similarity evaluations for P prototypes (each O(L · δ) for S1 with the
//! bounding-box pre-filter; S2 times its translations), in parallel over blocks of 256
//! trajectories against the prototypes known before the block, then sequentially against the
//! prototypes the block itself made: the result equals the one-at-a-time visit. Step 2:
//! O(P²) distances and memory, the linkage's O(P²). P is the number of route patterns at the
//! radius (tens to a few thousand), not the number of trajectories; when every trajectory is its
//! own prototype (nothing alike) the cost is the exact method's.

use super::linkage::{self as cluster, ClusterError, Cut, Linkage};
use super::traj_cluster::{self as tc, Similarity, TrajClusterError};
use crate::lcss::index::IndexParams;
use crate::traj::Traj;
use rayon::prelude::*;

/// Trajectories compared in parallel against the prototypes known before them.
const BLOCK: usize = 256;

/// The result: ids in increasing order, with each id's cluster (0 = isolated) and prototype id.
#[derive(Clone, Debug, PartialEq)]
pub struct Prototypes {
    pub ids: Vec<i64>,
    pub cluster: Vec<u32>,
    pub prototype: Vec<i64>,
}

/// Clusters `trajs` (one per id in `ids`, any order) by prototypes within `radius` (a distance
/// in [0, 1]), then `method` over the prototypes cut at `threshold`.
pub fn cluster_prototypes(
    ids: &[i64],
    trajs: &[Traj<'_>],
    p: &IndexParams,
    sim: Similarity,
    method: Linkage,
    threshold: f64,
    radius: f64,
) -> Result<Prototypes, TrajClusterError> {
    let by_id = tc::id_order(ids, trajs.len())?;
    if !(0.0..=1.0).contains(&radius) {
        return Err(TrajClusterError::Radius(radius));
    }
    let cut = Cut::threshold(threshold).map_err(TrajClusterError::Cluster)?;
    let n = ids.len();
    // S2: the worst case, every pair compared (each trajectory its own prototype)
    tc::check_s2(trajs, p, sim)?;
    let boxes: Vec<[f64; 4]> = trajs.iter().map(tc::bbox).collect();
    // the visit: longest first, then the earliest start, then the id
    let mut visit: Vec<usize> = (0..n).collect();
    let start = |k: usize| trajs[k].t.first().copied().unwrap_or(0.0);
    visit.sort_by(|&a, &b| trajs[b].len().cmp(&trajs[a].len()).then(start(a).total_cmp(&start(b))).then(ids[a].cmp(&ids[b])));
    // nearest prototype among protos[from..to] of item k: (distance, position), ties to the earliest
    let nearest = |k: usize, protos: &[usize], from: usize| -> Result<Option<(f64, usize)>, TrajClusterError> {
        let mut best: Option<(f64, usize)> = None;
        for (pos, &q) in protos.iter().enumerate().skip(from) {
            let s = tc::similarity(trajs[k], trajs[q], &boxes[k], &boxes[q], p, sim)?;
            if s > 0.0 {
                let d = 1.0 - s;
                if best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, pos));
                }
            }
        }
        Ok(best)
    };
    let scope = crate::limits::current();
    let mut protos: Vec<usize> = Vec::new();
    let mut owner = vec![usize::MAX; n]; // item -> prototype position
    for block in visit.chunks(BLOCK) {
        let known = protos.len();
        let found: Vec<Option<(f64, usize)>> = block
            .par_iter()
            .map(|&k| crate::limits::within(&scope, || nearest(k, &protos[..known], 0)))
            .collect::<Result<_, _>>()?;
        for (&k, old) in block.iter().zip(found) {
            let new = nearest(k, &protos, known)?;
            let best = match (old, new) {
                (Some(o), Some(w)) => Some(if w.0 < o.0 { w } else { o }),
                (o, w) => o.or(w),
            };
            match best {
                Some((d, pos)) if d <= radius => owner[k] = pos,
                _ => {
                    owner[k] = protos.len();
                    protos.push(k);
                }
            }
        }
    }
    // the prototypes' exact linkage, leaves in prototype order
    let pt: Vec<Traj<'_>> = protos.iter().map(|&k| trajs[k]).collect();
    let m = tc::distances(&pt, p, sim)?;
    let linked = tc::linked_items(&m, protos.len());
    // leaves are prototype positions: an error naming two of them names their trajectories' ids
    let d = cluster::linkage_condensed((0..protos.len() as i64).collect(), m, method).map_err(|e| {
        TrajClusterError::Cluster(match e {
            ClusterError::WardIncomplete { a, b } => ClusterError::WardIncomplete { a: ids[protos[a as usize]], b: ids[protos[b as usize]] },
            e => e,
        })
    })?;
    let flat = cluster::flat(&d, cut);
    let mut members = vec![0usize; protos.len()];
    for &o in &owner {
        members[o] += 1;
    }
    let cluster = tc::renumber(by_id.iter().map(|&k| {
        let o = owner[k];
        (flat[o], linked[o] || members[o] > 1)
    }));
    Ok(Prototypes {
        ids: by_id.iter().map(|&k| ids[k]).collect(),
        cluster,
        prototype: by_id.iter().map(|&k| ids[protos[owner[k]]]).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lane(y: f64, n: usize, wiggle: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..n).map(|k| k as f64).collect();
        let x: Vec<f64> = (0..n).map(|k| k as f64).collect();
        let yy: Vec<f64> = (0..n).map(|k| y + ((k * 13 + wiggle * 7) % 11) as f64 * 0.05).collect();
        (t, x, yy)
    }

    fn data(k: usize) -> Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        (0..k).map(|i| lane((i % 3) as f64 * 10.0, 10 + i % 4, i)).collect()
    }

    /// Three clear lanes: the same partition as the exact clustering, one prototype per lane.
    #[test]
    fn clear_lanes_match_the_exact_clustering() {
        let d = data(30);
        let trajs: Vec<Traj<'_>> = d.iter().map(|(t, x, y)| Traj::new(t, x, y)).collect();
        let ids: Vec<i64> = (0..30).map(|k| 1000 - 7 * k).collect();
        let p = IndexParams::new(2, 2.0, Some(0.5)).unwrap();
        let got = cluster_prototypes(&ids, &trajs, &p, Similarity::S1, Linkage::Average, 0.5, 0.25).unwrap();
        let (eids, exact) = tc::cluster_trajectories(&ids, &trajs, &p, Similarity::S1, Linkage::Average, Cut::Threshold(0.5)).unwrap();
        assert_eq!(got.ids, eids);
        assert_eq!(got.cluster, exact);
        let mut protos = got.prototype.clone();
        protos.sort();
        protos.dedup();
        assert_eq!(protos.len(), 3);
    }

    /// Relabelled ids and a shuffled input order give the same partition (the visit is by
    /// length and first point); isolated trajectories get 0.
    #[test]
    fn invariant_to_ids_and_order_and_isolated_zero() {
        let mut d = data(24);
        d.push((vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0], vec![500.0; 6], vec![500.0, 501.0, 502.0, 503.0, 504.0, 505.0]));
        let trajs: Vec<Traj<'_>> = d.iter().map(|(t, x, y)| Traj::new(t, x, y)).collect();
        let p = IndexParams::new(2, 2.0, Some(0.5)).unwrap();
        let ids: Vec<i64> = (0..25).collect();
        let a = cluster_prototypes(&ids, &trajs, &p, Similarity::S1, Linkage::Average, 0.5, 0.25).unwrap();
        assert_eq!(a.cluster[24], 0);
        assert_eq!(a.prototype[24], 24);
        // reverse the order and relabel ids descending
        let rev: Vec<Traj<'_>> = trajs.iter().rev().copied().collect();
        let ids2: Vec<i64> = (0..25).map(|k| 100 + k).collect(); // rev[k] is trajs[24 - k]
        let b = cluster_prototypes(&ids2, &rev, &p, Similarity::S1, Linkage::Average, 0.5, 0.25).unwrap();
        // same partition: map b's ids back to original positions
        let orig = |id: i64| 24 - (id - 100) as usize;
        let mut pa: Vec<Vec<usize>> = Vec::new();
        let mut pb: Vec<Vec<usize>> = Vec::new();
        for (res, map) in [(&a, &(|id: i64| id as usize) as &dyn Fn(i64) -> usize), (&b, &orig as &dyn Fn(i64) -> usize)] {
            let mut groups: std::collections::BTreeMap<u32, Vec<usize>> = Default::default();
            for (id, c) in res.ids.iter().zip(&res.cluster) {
                groups.entry(*c).or_default().push(map(*id));
            }
            let mut g: Vec<Vec<usize>> = groups.into_values().map(|mut v| {
                v.sort();
                v
            }).collect();
            g.sort();
            if pa.is_empty() { pa = g } else { pb = g }
        }
        assert_eq!(pa, pb);
    }

    /// The block-parallel visit equals the one-at-a-time visit (more than one block of items).
    #[test]
    fn blocks_equal_the_sequential_visit() {
        let d: Vec<_> = (0..700).map(|i| lane((i % 37) as f64 * 3.0, 8 + i % 5, i)).collect();
        let trajs: Vec<Traj<'_>> = d.iter().map(|(t, x, y)| Traj::new(t, x, y)).collect();
        let ids: Vec<i64> = (0..700).collect();
        let p = IndexParams::new(2, 2.0, Some(0.5)).unwrap();
        let got = cluster_prototypes(&ids, &trajs, &p, Similarity::S1, Linkage::Average, 0.5, 0.25).unwrap();
        // the slow obvious visit
        let mut visit: Vec<usize> = (0..700).collect();
        visit.sort_by(|&a, &b| trajs[b].len().cmp(&trajs[a].len()).then(trajs[a].t[0].total_cmp(&trajs[b].t[0])).then(a.cmp(&b)));
        let mut protos: Vec<usize> = Vec::new();
        let mut owner = vec![0usize; 700];
        for &k in &visit {
            let mut best: Option<(f64, usize)> = None;
            for (pos, &q) in protos.iter().enumerate() {
                let r = crate::lcss::index::s1(trajs[k], trajs[q], &p).unwrap();
                let s = if p.rejects(trajs[k].len(), trajs[q].len()) { 0.0 } else { r.sx.min(r.sy) };
                if s > 0.0 && best.is_none_or(|(bd, _)| 1.0 - s < bd) {
                    best = Some((1.0 - s, pos));
                }
            }
            match best {
                Some((d, pos)) if d <= 0.25 => owner[k] = protos[pos],
                _ => {
                    owner[k] = k;
                    protos.push(k);
                }
            }
        }
        assert_eq!(got.prototype, owner.iter().map(|&o| o as i64).collect::<Vec<_>>());
    }

    #[test]
    fn bad_radius_and_lengths_are_errors() {
        let d = data(3);
        let trajs: Vec<Traj<'_>> = d.iter().map(|(t, x, y)| Traj::new(t, x, y)).collect();
        let p = IndexParams::new(2, 2.0, None).unwrap();
        for r in [f64::NAN, -0.1, 1.5] {
            let e = cluster_prototypes(&[1, 2, 3], &trajs, &p, Similarity::S1, Linkage::Average, 0.5, r).unwrap_err();
            assert!(e.to_string().contains("radius"), "{e}");
        }
        assert!(matches!(cluster_prototypes(&[1, 2], &trajs, &p, Similarity::S1, Linkage::Average, 0.5, 0.2), Err(TrajClusterError::Lengths { .. })));
        assert!(matches!(cluster_prototypes(&[1, 1, 2], &trajs, &p, Similarity::S1, Linkage::Average, 0.5, 0.2), Err(TrajClusterError::DuplicateId(1))));
        let e = cluster_prototypes(&[], &[], &p, Similarity::S1, Linkage::Average, 0.5, 0.2).unwrap();
        assert!(e.ids.is_empty());
    }
}
