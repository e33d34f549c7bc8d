//! Trajectory clustering in one call (Buzan et al. 4.3–4.5, 5.2): every pairwise distance
//! 1 − min(S_x, S_y) of Buzan's S1 (def. 4.1/4.2, eq. 4.3) or the translation-invariant S2
//! (def. 4.3) is computed in parallel straight into the condensed matrix, and the linkage of
//! [`super::linkage`] runs on it.
//!
//! Why not pairs through SQL: all-pairs S1 of 5,813 tracks is 16.9 M pairs; built as a join and
//! passed as a list of pairs, DuckDB materialises two trajectories per pair row (single-threaded
//! hash-join probe on the class key), which took 86 s of the 95 s cluster stage on a simulated
//! Mellingen-sized day. Here the same matrix costs O(n²) distance evaluations on all cores with no
//! intermediate rows.
//!
//! Cannot-links: a pair with no common subsequence (min(S_x, S_y) = 0, or rejected by the
//! length-aspect-ratio ρ) is at distance `+inf`, exactly like a pair left out of the list given to
//! `agglomerative_cluster`. Items at `+inf` from every other item ("isolated", no similar
//! trajectory at all) get cluster 0; the others are numbered 1.. by their smallest id.
//!
//! Pruning (exact, S1 only): S_x > 0 needs some |a.x_i − b.x_j| < ε, so the x ranges must come
//! within ε (likewise y); other pairs are `+inf` without running the LCSS. S2 translates, so it
//! cannot prune this way.
//!
//! Complexity: O(n² · L · δ) time for n trajectories of length ≤ L (S2: times the candidate
//! translations, see [`crate::lcss::translate`]), O(n²) memory (the condensed f64 matrix; the
//! cap is [`super::linkage::MAX_ITEMS`]).

use super::linkage::{self as cluster, ClusterError, Cut, Linkage};
use crate::lcss::index::{self as lcss_index, IndexParams};
use crate::lcss::LcssError;
use crate::lcss::translate as lcss_translate;
use crate::traj::Traj;
use rayon::prelude::*;
use std::fmt;

/// Which Buzan similarity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Similarity {
    /// S1: positions compared where they are (route patterns).
    S1,
    /// S2: the best translation per axis first (shape patterns anywhere).
    S2,
}

/// Errors of [`cluster_trajectories`].
#[derive(Debug, PartialEq)]
pub enum TrajClusterError {
    /// ids and trajectories differ in length.
    Lengths { ids: usize, trajs: usize },
    /// The same id twice.
    DuplicateId(i64),
    /// S2 on a pair too large for its exact search.
    TooLarge(String),
    Cluster(ClusterError),
    /// More work than the limit `lcss_cells` (S2: every pair's candidate translations).
    Work(crate::limits::Exceeded),
    /// The condensed distance matrix could not be allocated.
    Memory { items: usize, bytes: usize },
    /// The condensed distance matrix would take more bytes than the limit `memory_bytes`.
    MemoryLimit(crate::limits::Exceeded),
    /// A prototype radius outside [0, 1] or NaN ([`super::prototype`]).
    Radius(f64),
}

impl fmt::Display for TrajClusterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TrajClusterError::Lengths { ids, trajs } => write!(f, "ids and trajs must have the same length, got {ids} and {trajs}"),
            TrajClusterError::DuplicateId(id) => write!(f, "ids must be distinct, got {id} twice"),
            TrajClusterError::TooLarge(s) => write!(f, "{s}"),
            TrajClusterError::Cluster(e) => write!(f, "{e}"),
            TrajClusterError::Work(e) => write!(f, "{e}"),
            TrajClusterError::Memory { items, bytes } => write!(
                f,
                "{items} trajectories need a {:.1} GiB distance matrix, which could not be allocated; cluster fewer at once (e.g. per class or hour)",
                *bytes as f64 / (1u64 << 30) as f64
            ),
            TrajClusterError::Radius(r) => write!(f, "radius must be a distance in [0, 1] (1 - similarity), got {r}; e.g. half the threshold"),
            TrajClusterError::MemoryLimit(e) => {
                write!(f, "{e}, or cluster fewer trajectories at once (e.g. per class or hour): n need n(n-1)/2 x 8 bytes")
            }
        }
    }
}
impl std::error::Error for TrajClusterError {}

/// The bounding box `[x0, x1, y0, y1]` of a trajectory (the S1 pre-filter's key).
pub(crate) fn bbox(t: &Traj<'_>) -> [f64; 4] {
    let f = |v: &[f64]| v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &q| (lo.min(q), hi.max(q)));
    let ((x0, x1), (y0, y1)) = (f(t.x), f(t.y));
    [x0, x1, y0, y1]
}

/// The Buzan similarity min(S_x, S_y) of `a` and `b` (0: no common subsequence, or rejected
/// by ρ), given their bounding boxes: the one pair rule of [`distances`] and
/// [`super::prototype`]. S1 returns 0 without an LCSS when the boxes are more than ε apart.
pub(crate) fn similarity(a: Traj<'_>, b: Traj<'_>, ba: &[f64; 4], bb: &[f64; 4], p: &IndexParams, sim: Similarity) -> Result<f64, TrajClusterError> {
    let lcss_err = |e: LcssError| match e {
        LcssError::Work(x) => TrajClusterError::Work(x),
        e => TrajClusterError::TooLarge(e.to_string()),
    };
    if p.rejects(a.len(), b.len()) {
        return Ok(0.0);
    }
    Ok(match sim {
        Similarity::S1 => {
            let eps = p.epsilon();
            if ba[0] - bb[1] >= eps || bb[0] - ba[1] >= eps || ba[2] - bb[3] >= eps || bb[2] - ba[3] >= eps {
                return Ok(0.0);
            }
            let r = lcss_index::s1(a, b, p).map_err(lcss_err)?;
            r.sx.min(r.sy)
        }
        Similarity::S2 => {
            let r = lcss_translate::s2(a, b, p).map_err(lcss_err)?;
            r.sx.min(r.sy)
        }
    })
}

/// The condensed distance matrix (row-major upper triangle) of `trajs`, in parallel. Its
/// allocation is fallible: too little memory is an error, never an abort of the host process.
pub fn distances(trajs: &[Traj<'_>], p: &IndexParams, sim: Similarity) -> Result<Vec<f64>, TrajClusterError> {
    let n = trajs.len();
    if n < 2 {
        return Ok(Vec::new());
    }
    let bbox: Vec<[f64; 4]> = trajs.iter().map(bbox).collect();
    let len = n * (n - 1) / 2;
    crate::limits::MEMORY_BYTES.check(len as u128 * 8).map_err(TrajClusterError::MemoryLimit)?;
    let mut m: Vec<f64> = Vec::new();
    m.try_reserve_exact(len).map_err(|_| TrajClusterError::Memory { items: n, bytes: len * 8 })?;
    m.resize(len, f64::INFINITY);
    let mut rows: Vec<&mut [f64]> = Vec::with_capacity(n - 1);
    let mut rest = &mut m[..];
    for i in 0..n - 1 {
        let (row, tail) = rest.split_at_mut(n - 1 - i);
        rows.push(row);
        rest = tail;
    }
    // the workers check the LCSS work limit of the caller's scope
    let scope = crate::limits::current();
    rows.into_par_iter().enumerate().try_for_each(|(i, row)| {
        let fill = || -> Result<(), TrajClusterError> {
            for (k, cell) in row.iter_mut().enumerate() {
                let j = i + 1 + k;
                let s = similarity(trajs[i], trajs[j], &bbox[i], &bbox[j], p, sim)?;
                if s > 0.0 {
                    *cell = 1.0 - s;
                }
            }
            Ok(())
        };
        crate::limits::within(&scope, fill)
    })?;
    Ok(m)
}

/// The items in increasing id order; lengths must agree and ids be distinct.
pub(crate) fn id_order(ids: &[i64], n_trajs: usize) -> Result<Vec<usize>, TrajClusterError> {
    if ids.len() != n_trajs {
        return Err(TrajClusterError::Lengths { ids: ids.len(), trajs: n_trajs });
    }
    if ids.len() > cluster::MAX_ITEMS {
        return Err(TrajClusterError::Cluster(ClusterError::TooMany(ids.len())));
    }
    let mut order: Vec<usize> = (0..ids.len()).collect();
    order.sort_by_key(|&k| ids[k]);
    if let Some(w) = order.windows(2).find(|w| ids[w[0]] == ids[w[1]]) {
        return Err(TrajClusterError::DuplicateId(ids[w[0]]));
    }
    Ok(order)
}

/// The work of S2 (nothing to check for S1): it tries every candidate translation of every
/// pair, LCSS cells x candidates per pair, summed over all pairs (by distinct lengths, O(L²)),
/// against the work limit `lcss_cells`; the pair sizes against S2's exact search first. All pairs
/// is the exact clustering's work and the prototype clustering's worst case.
pub(crate) fn check_s2(trajs: &[Traj<'_>], p: &IndexParams, sim: Similarity) -> Result<(), TrajClusterError> {
    if sim != Similarity::S2 {
        return Ok(());
    }
    let longest = trajs.iter().map(|t| t.len()).max().unwrap_or(0);
    lcss_translate::check_size(longest, longest, p).map_err(|e| TrajClusterError::TooLarge(e.to_string()))?;
    let mut by_len: std::collections::BTreeMap<usize, u128> = std::collections::BTreeMap::new();
    for t in trajs {
        *by_len.entry(t.len()).or_default() += 1;
    }
    let band = 2 * p.delta() as u128 + 1;
    let pair = |a: u128, b: u128| a * b.min(band) * 2 * a * b.min(band);
    let lens: Vec<(u128, u128)> = by_len.into_iter().map(|(l, c)| (l as u128, c)).collect();
    let mut work: u128 = 0;
    for (i, &(la, ca)) in lens.iter().enumerate() {
        work = work.saturating_add((ca * ca.saturating_sub(1) / 2).saturating_mul(pair(la, la)));
        for &(lb, cb) in &lens[i + 1..] {
            work = work.saturating_add(ca.saturating_mul(cb).saturating_mul(pair(la, lb)));
        }
    }
    crate::limits::LCSS_CELLS.check(work).map_err(TrajClusterError::Work)
}

/// Clusters the trajectories `trajs` (one per id in `ids`, any order) with `method` and `cut`.
/// Returns `(ids in increasing order, cluster per id)`, cluster 0 for isolated items.
pub fn cluster_trajectories(
    ids: &[i64],
    trajs: &[Traj<'_>],
    p: &IndexParams,
    sim: Similarity,
    method: Linkage,
    cut: Cut,
) -> Result<(Vec<i64>, Vec<u32>), TrajClusterError> {
    let order = id_order(ids, trajs.len())?;
    let n = ids.len();
    check_s2(trajs, p, sim)?;
    let sorted_ids: Vec<i64> = order.iter().map(|&k| ids[k]).collect();
    let sorted: Vec<Traj<'_>> = order.iter().map(|&k| trajs[k]).collect();
    let m = distances(&sorted, p, sim)?;
    let linked = linked_items(&m, n);
    let d = cluster::linkage_condensed(sorted_ids, m, method).map_err(TrajClusterError::Cluster)?;
    let flat = cluster::flat(&d, cut);
    let labels = renumber(flat.iter().zip(&linked).map(|(&c, &l)| (c, l)));
    Ok((d.ids, labels))
}

/// Which of the `n` items of the condensed matrix `m` have a finite distance to some other
/// item (the others are isolated: cluster 0).
pub(crate) fn linked_items(m: &[f64], n: usize) -> Vec<bool> {
    let mut linked = vec![false; n];
    let mut off = 0;
    for i in 0..n.saturating_sub(1) {
        for (k, d) in m[off..off + n - 1 - i].iter().enumerate() {
            if d.is_finite() {
                linked[i] = true;
                linked[i + 1 + k] = true;
            }
        }
        off += n - 1 - i;
    }
    linked
}

/// Cluster numbers from `(flat label, linked)` per item in increasing id order: isolated items
/// 0, the rest 1, 2, … in the order of their smallest id.
pub(crate) fn renumber(items: impl Iterator<Item = (u32, bool)>) -> Vec<u32> {
    let mut map = std::collections::HashMap::new();
    items
        .map(|(c, l)| {
            if !l {
                0
            } else {
                let next = map.len() as u32 + 1;
                *map.entry(c).or_insert(next)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 19: a matrix above `memory_bytes` (here 40k trajectories, 6.4 GB) is refused
    /// before it is allocated, naming the limit and what to reduce.
    #[test]
    fn a_matrix_above_the_memory_limit_is_refused_first() {
        let n = 40_000;
        let (t, x, y) = (vec![0.0], vec![0.0], vec![0.0]);
        let trajs: Vec<Traj<'_>> = (0..n).map(|_| Traj::new(&t, &x, &y)).collect();
        let p = IndexParams::new(1, 1.0, None).unwrap();
        let e = distances(&trajs, &p, Similarity::S1).unwrap_err();
        let len = (n * (n - 1) / 2) as u128;
        assert_eq!(e, TrajClusterError::MemoryLimit(crate::limits::MEMORY_BYTES.check(len * 8).unwrap_err()));
        assert!(e.to_string().contains("cluster fewer trajectories at once"), "{e}");
    }

    fn line(y: f64, n: usize, dx: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        ((0..n).map(|k| k as f64).collect(), (0..n).map(|k| k as f64 * dx).collect(), vec![y; n])
    }

    /// Issue 27: the LCSS engine checks lcss_cells on the rayon workers too, against the
    /// limit of the caller's scope (not the default).
    #[test]
    fn the_workers_obey_the_callers_cell_limit() {
        use crate::limits::{with_scope, Limits};
        let data: Vec<_> = (0..6).map(|k| line(k as f64 * 0.1, 20, 1.0)).collect();
        let trajs: Vec<Traj<'_>> = data.iter().map(|(t, x, y)| Traj::new(t, x, y)).collect();
        let p = IndexParams::new(100, 1.0, None).unwrap(); // 20 x 20 = 400 cells an axis
        let l = std::sync::Arc::new(Limits::default());
        l.set("lcss_cells", 399).unwrap();
        let e = with_scope(&l, || distances(&trajs, &p, Similarity::S1)).unwrap_err();
        assert!(matches!(&e, TrajClusterError::Work(x) if x.needed == 400 && x.limit == 399), "{e}");
        l.set("lcss_cells", 400).unwrap();
        assert_eq!(with_scope(&l, || distances(&trajs, &p, Similarity::S1)).unwrap(), distances(&trajs, &p, Similarity::S1).unwrap());
    }

    /// The matrix equals the pairwise lcss_s1 distances a SQL self-join would give.
    #[test]
    fn matrix_equals_pairwise_s1_and_s2() {
        let mut data = Vec::new();
        for k in 0..12 {
            let (t, x, mut y) = line((k % 4) as f64 * 1.5, 8 + k % 5, 1.0 + 0.1 * k as f64);
            for (i, v) in y.iter_mut().enumerate() {
                *v += ((i * 7 + k * 3) % 5) as f64 * 0.3;
            }
            data.push((t, x, y));
        }
        let trajs: Vec<Traj<'_>> = data.iter().map(|(t, x, y)| Traj::new(t, x, y)).collect();
        let p = IndexParams::new(2, 1.0, Some(0.5)).unwrap();
        for sim in [Similarity::S1, Similarity::S2] {
            let m = distances(&trajs, &p, sim).unwrap();
            let mut k = 0;
            for i in 0..trajs.len() {
                for j in i + 1..trajs.len() {
                    let s = match sim {
                        Similarity::S1 => {
                            let r = lcss_index::s1(trajs[i], trajs[j], &p).unwrap();
                            r.sx.min(r.sy)
                        }
                        Similarity::S2 => {
                            let r = lcss_translate::s2(trajs[i], trajs[j], &p).unwrap();
                            r.sx.min(r.sy)
                        }
                    };
                    let want = if s > 0.0 { 1.0 - s } else { f64::INFINITY };
                    assert_eq!(m[k], want, "{sim:?} {i} {j}");
                    k += 1;
                }
            }
        }
    }

    #[test]
    fn same_partition_as_the_pair_list_route() {
        let mut data = Vec::new();
        for k in 0..30 {
            let lane = (k % 3) as f64 * 10.0;
            let (t, x, mut y) = line(lane, 10, 1.0);
            for (i, v) in y.iter_mut().enumerate() {
                *v += ((i * 13 + k * 7) % 11) as f64 * 0.05;
            }
            data.push((t, x, y));
        }
        let trajs: Vec<Traj<'_>> = data.iter().map(|(t, x, y)| Traj::new(t, x, y)).collect();
        let ids: Vec<i64> = (0..30).map(|k| 1000 - 7 * k).collect();
        let p = IndexParams::new(2, 2.0, Some(0.5)).unwrap();
        let (got_ids, got) = cluster_trajectories(&ids, &trajs, &p, Similarity::S1, Linkage::Average, Cut::Threshold(0.5)).unwrap();
        let mut pairs = Vec::new();
        for i in 0..30 {
            for j in i + 1..30 {
                let r = lcss_index::s1(trajs[i], trajs[j], &p).unwrap();
                if r.sx.min(r.sy) > 0.0 {
                    pairs.push((ids[i], ids[j], 1.0 - r.sx.min(r.sy)));
                }
            }
        }
        let d = cluster::dendrogram(&pairs, Linkage::Average).unwrap();
        let want = cluster::flat(&d, Cut::Threshold(0.5));
        assert_eq!(got_ids, d.ids);
        assert_eq!(got, want);
        // three lanes, ten tracks each
        let mut sizes = std::collections::HashMap::new();
        for c in &got {
            *sizes.entry(*c).or_insert(0) += 1;
        }
        assert_eq!(sizes.len(), 3);
        assert!(sizes.values().all(|&v| v == 10));
    }

    #[test]
    fn isolated_items_get_cluster_zero_and_errors() {
        let (t, x, y) = line(0.0, 6, 1.0);
        let (t2, x2, y2) = line(100.0, 6, 1.0);
        let trajs = [Traj::new(&t, &x, &y), Traj::new(&t, &x, &y), Traj::new(&t2, &x2, &y2)];
        let p = IndexParams::new(1, 0.5, None).unwrap();
        let (ids, c) = cluster_trajectories(&[5, 3, 9], &trajs, &p, Similarity::S1, Linkage::Complete, Cut::Threshold(0.1)).unwrap();
        assert_eq!(ids, vec![3, 5, 9]);
        assert_eq!(c, vec![1, 1, 0]);
        assert_eq!(
            cluster_trajectories(&[1, 1, 2], &trajs, &p, Similarity::S1, Linkage::Average, Cut::K(1)).unwrap_err(),
            TrajClusterError::DuplicateId(1)
        );
        assert!(matches!(
            cluster_trajectories(&[1], &trajs, &p, Similarity::S1, Linkage::Average, Cut::K(1)),
            Err(TrajClusterError::Lengths { .. })
        ));
        assert!(matches!(
            cluster_trajectories(&[1, 2, 3], &trajs, &p, Similarity::S1, Linkage::Ward, Cut::K(1)),
            Err(TrajClusterError::Cluster(_))
        ));
        let (ids, c) = cluster_trajectories(&[], &[], &p, Similarity::S1, Linkage::Average, Cut::K(1)).unwrap();
        assert!(ids.is_empty() && c.is_empty());
        let (_, c) = cluster_trajectories(&[4], &trajs[..1], &p, Similarity::S1, Linkage::Average, Cut::K(1)).unwrap();
        assert_eq!(c, vec![0]);
    }
}
