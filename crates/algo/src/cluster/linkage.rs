//! Agglomerative (hierarchical) clustering of trajectories on pairwise distances, with
//! cannot-link pairs (Buzan et al., sections 4.3–4.5 and 5.2: trajectories whose LCSS distance is
//! "infinite" must not share a cluster).
//!
//! # Input
//! Pairs `(a, b, distance)`. Items are the ids that appear; they are indexed in increasing id
//! order (index k = the k-th smallest id), which is the order of the dendrogram's leaves.
//! * a pair absent from the list, or with distance `+inf`, is infinitely far apart;
//! * NaN or negative distances and self pairs `(a, a)` are errors; a duplicated pair keeps
//!   its smallest distance (the closest evidence).
//!
//! # Methods and cannot-link
//! The linkage is `kodama` (a port of fastcluster, the algorithms scipy uses): MST for single,
//! nearest-neighbour chain for complete, average, weighted and ward. Infinite distances are
//! passed as `+inf` itself (no sentinel value that could leak into averages): the
//! Lance–Williams updates of complete (max), average and weighted (weighted means with
//! positive weights) keep `+inf` infinite, so two items at `+inf` can only meet in a merge at
//! height `+inf`, which no threshold cut applies: **under complete, average and weighted
//! linkage, cannot-link items never share a cluster** (Buzan's first requirement).
//! **Single linkage** is the minimum over all pairs, so it *does* join two cannot-link items
//! when a chain of finite links connects them (e.g. a–c and c–b close, a–b infinite): that is
//! what single linkage means (connected components of the pairs below the threshold), and the
//! result is reported as such rather than silently changed.
//! **Ward** assumes squared Euclidean geometry (items are points, the distances Euclidean
//! distances between them) and needs every pair: it is rejected when a pair is missing or
//! infinite. LCSS distances are not Euclidean, so Ward on them is a heuristic; prefer average.
//!
//! # Flat clusters (scipy's `fcluster`)
//! * threshold `t` (criterion 'distance'): apply every merge of height `<= t`;
//! * k clusters (criterion 'maxclust'): the smallest merge height `h` that leaves at most `k`
//!   clusters is found and every merge of height `<= h` applied (with tied heights this can give
//!   fewer than `k` clusters, as in scipy); infinite merges are never applied, so more than `k`
//!   clusters come back when cannot-link pairs require it.
//!
//! Clusters are numbered 1, 2, … in the order of their smallest id (scipy numbers them by its
//! own traversal; the partition is the same, the numbers are not).
//!
//! # Ties
//! Equal distances are resolved by kodama in the same way as fastcluster/scipy for single
//! linkage (MST order); for the chain methods the merge order among exact ties can differ from
//! scipy's, and then so can the dendrogram (not the partition at a threshold that does not
//! fall on a tie). The pinned fixtures use distances without ties.
//!
//! # Complexity
//! O(n²) memory: one condensed matrix of n(n−1)/2 `f64`; 24 GiB holds n ≈ 80,000 (the cap
//! [`MAX_ITEMS`]). Through SQL the list of pairs is the larger cost (24 bytes per pair in the
//! list, plus DuckDB's own copy), so about n ≈ 25,000 with all pairs fits in 24 GiB; sparse pair
//! lists (cannot-links left out) reach further. Time O(n²) for single (MST) and the chain
//! methods (NN-chain, O(n²) for these reducible methods), plus O(P) to read P pairs (parallel).

use crate::graph::UnionFind;
use std::collections::HashMap;
use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub enum ClusterError {
    UnknownMethod(String),
    /// 1-based index and value.
    Distance { index: usize, value: f64 },
    SelfPair { index: usize, id: i64 },
    /// Ward needs every pair, finite (1-based ids of a missing or infinite pair).
    WardIncomplete { a: i64, b: i64 },
    Threshold(f64),
    K(i64),
    /// More items than the condensed matrix can index or memory can hold.
    TooMany(usize),
    /// The condensed matrix could not be allocated (bytes needed).
    Memory { items: usize, bytes: usize },
    /// The condensed matrix would take more bytes than the limit `memory_bytes`.
    Limit(crate::limits::Exceeded),
}

impl fmt::Display for ClusterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClusterError::UnknownMethod(m) => {
                write!(f, "method must be 'single', 'complete', 'average', 'weighted' or 'ward', got '{m}'")
            }
            ClusterError::Distance { index, value } => {
                write!(f, "pairs[{index}].distance must be >= 0 and not NaN, got {value}")
            }
            ClusterError::SelfPair { index, id } => write!(f, "pairs[{index}] pairs id {id} with itself"),
            ClusterError::WardIncomplete { a, b } => write!(
                f,
                "ward needs a finite distance for every pair (Euclidean distances), but ({a}, {b}) is missing or infinite; use average"
            ),
            ClusterError::Threshold(t) => write!(f, "threshold must not be NaN, got {t}"),
            ClusterError::K(k) => write!(f, "k must be >= 1, got {k}"),
            ClusterError::TooMany(n) => write!(f, "{n} items need a {n}x{n} distance matrix, more than this machine can hold"),
            ClusterError::Memory { items, bytes } => write!(
                f,
                "{items} items need a {:.1} GiB distance matrix, which could not be allocated; cluster fewer at once (e.g. per class or hour)",
                *bytes as f64 / (1u64 << 30) as f64
            ),
            ClusterError::Limit(e) => write!(f, "{e}, or cluster fewer items at once (e.g. per class or hour): n items need n(n-1)/2 x 8 bytes"),
        }
    }
}
impl std::error::Error for ClusterError {}

/// Linkage method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Linkage {
    Single,
    Complete,
    Average,
    Weighted,
    Ward,
}

impl Linkage {
    pub fn parse(s: &str) -> Result<Self, ClusterError> {
        Ok(match s.trim().to_ascii_lowercase().as_str() {
            "single" => Linkage::Single,
            "complete" => Linkage::Complete,
            "average" => Linkage::Average,
            "weighted" => Linkage::Weighted,
            "ward" => Linkage::Ward,
            _ => return Err(ClusterError::UnknownMethod(s.to_string())),
        })
    }
    fn kodama(self) -> kodama::Method {
        match self {
            Linkage::Single => kodama::Method::Single,
            Linkage::Complete => kodama::Method::Complete,
            Linkage::Average => kodama::Method::Average,
            Linkage::Weighted => kodama::Method::Weighted,
            Linkage::Ward => kodama::Method::Ward,
        }
    }
}

/// One merge in scipy's linkage format: clusters `left < right` (leaves 0..n, merge i creates
/// n + i), their distance, and the size of the new cluster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Merge {
    pub left: usize,
    pub right: usize,
    pub distance: f64,
    pub size: usize,
}

/// The items (sorted ids) and their dendrogram.
#[derive(Clone, Debug, PartialEq)]
pub struct Dendrogram {
    pub ids: Vec<i64>,
    pub merges: Vec<Merge>,
}

/// Largest n whose condensed matrix we agree to allocate (n(n−1)/2 f64 ≤ 24 GiB).
pub const MAX_ITEMS: usize = 80_000;

/// Builds the dendrogram of `pairs` with `method` (see module docs).
pub fn dendrogram(pairs: &[(i64, i64, f64)], method: Linkage) -> Result<Dendrogram, ClusterError> {
    for (k, &(a, b, d)) in pairs.iter().enumerate() {
        if d.is_nan() || d < 0.0 {
            return Err(ClusterError::Distance { index: k + 1, value: d });
        }
        if a == b {
            return Err(ClusterError::SelfPair { index: k + 1, id: a });
        }
    }
    // Item ids -> dense indices: a lookup table when the ids span a small range (row numbers,
    // track ids), otherwise a sorted, deduplicated copy and a hash map.
    let (lo, hi) = pairs.iter().fold((i64::MAX, i64::MIN), |(l, h), p| (l.min(p.0.min(p.1)), h.max(p.0.max(p.1))));
    let span = if pairs.is_empty() { 0u128 } else { (hi as i128 - lo as i128) as u128 + 1 };
    if span <= 4 * pairs.len() as u128 + 1024 {
        let mut slot = vec![u32::MAX; span as usize];
        for p in pairs {
            slot[(p.0 - lo) as usize] = 0;
            slot[(p.1 - lo) as usize] = 0;
        }
        let mut ids = Vec::new();
        for (k, s) in slot.iter_mut().enumerate() {
            if *s == 0 {
                *s = ids.len() as u32;
                ids.push(lo + k as i64);
            }
        }
        finish(pairs, ids, |id| slot[(id - lo) as usize] as usize, method)
    } else {
        let mut ids: Vec<i64> = pairs.iter().flat_map(|p| [p.0, p.1]).collect();
        ids.sort_unstable();
        ids.dedup();
        let index: HashMap<i64, usize> = ids.iter().enumerate().map(|(k, &id)| (id, k)).collect();
        finish(pairs, ids, |id| index[&id], method)
    }
}

/// Fills the condensed matrix (in parallel: non-negative f64 order equals their bit order, so
/// duplicates keep the minimum with an atomic `fetch_min`) and runs the linkage.
fn finish(pairs: &[(i64, i64, f64)], ids: Vec<i64>, lookup: impl Fn(i64) -> usize + Sync, method: Linkage) -> Result<Dendrogram, ClusterError> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicU64, Ordering};
    let n = ids.len();
    if n > MAX_ITEMS {
        return Err(ClusterError::TooMany(n));
    }
    if n < 2 {
        return Ok(Dendrogram { ids, merges: vec![] });
    }
    // Condensed upper triangle, row-major: (i, j), i < j at i*n - i(i+1)/2 + j - i - 1.
    let len = n * (n - 1) / 2;
    let inf = f64::INFINITY.to_bits();
    // bounded by the limit, and fallible: too little memory is an error, never an abort of the host
    crate::limits::MEMORY_BYTES.check(len as u128 * 8).map_err(ClusterError::Limit)?;
    let mut cells: Vec<AtomicU64> = Vec::new();
    cells.try_reserve_exact(len).map_err(|_| ClusterError::Memory { items: n, bytes: len * 8 })?;
    cells.resize_with(len, || AtomicU64::new(inf));
    let at = |i: usize, j: usize| i * n - i * (i + 1) / 2 + j - i - 1;
    pairs.par_chunks(1 << 16).for_each(|chunk| {
        for &(a, b, d) in chunk {
            let (i, j) = (lookup(a), lookup(b));
            let (i, j) = (i.min(j), i.max(j));
            cells[at(i, j)].fetch_min(d.to_bits(), Ordering::Relaxed);
        }
    });
    // Same size and alignment: the standard library reuses the allocation for this collect.
    let m: Vec<f64> = cells.into_iter().map(|c| f64::from_bits(c.into_inner())).collect();
    linkage_condensed(ids, m, method)
}

/// The linkage of a ready condensed matrix `m` (row-major upper triangle, n(n−1)/2 entries,
/// `+inf` = cannot-link) over `ids` (increasing; the leaves). Used by [`dendrogram`] and by
/// [`super::traj_cluster`], which computes the matrix itself.
pub fn linkage_condensed(ids: Vec<i64>, mut m: Vec<f64>, method: Linkage) -> Result<Dendrogram, ClusterError> {
    let n = ids.len();
    if n > MAX_ITEMS {
        return Err(ClusterError::TooMany(n));
    }
    if n < 2 {
        return Ok(Dendrogram { ids, merges: vec![] });
    }
    debug_assert_eq!(m.len(), n * (n - 1) / 2);
    if method == Linkage::Ward {
        if let Some(k) = m.iter().position(|d| d.is_infinite()) {
            // Recover (i, j) of condensed index k.
            let mut i = 0;
            let mut row_start = 0;
            while row_start + (n - i - 1) <= k {
                row_start += n - i - 1;
                i += 1;
            }
            let j = k - row_start + i + 1;
            return Err(ClusterError::WardIncomplete { a: ids[i], b: ids[j] });
        }
    }
    // The Lance–Williams updates square distances (ward) and multiply them by cluster sizes
    // (average, weighted): near f64::MAX they overflow to inf and then NaN, on which kodama
    // panics. Every method is scale-equivariant, so very large (or very small) finite distances
    // are scaled by a power of two, which is exact, and the merge heights scaled back.
    let top = m.iter().copied().filter(|d| d.is_finite()).fold(0.0f64, f64::max);
    let shift = if top > 1e150 || (top > 0.0 && top < 1e-150) { (-(top.log2().floor() as i32)).clamp(-1000, 1000) } else { 0 };
    if shift != 0 {
        m.iter_mut().for_each(|d| *d *= 2f64.powi(shift));
    }
    let d = kodama::linkage(&mut m, n, method.kodama());
    let back = 2f64.powi(-shift);
    let merges = d
        .steps()
        .iter()
        .map(|s| Merge { left: s.cluster1.min(s.cluster2), right: s.cluster1.max(s.cluster2), distance: s.dissimilarity * back, size: s.size })
        .collect();
    Ok(Dendrogram { ids, merges })
}

/// Which merges a flat cut applies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cut {
    /// Every merge of height `<= t`.
    Threshold(f64),
    /// At most k clusters where finite merges allow (see module docs).
    K(usize),
}

impl Cut {
    /// A threshold cut; NaN is an error (`+-inf` cut everything / nothing).
    pub fn threshold(t: f64) -> Result<Cut, ClusterError> {
        if t.is_nan() {
            Err(ClusterError::Threshold(t))
        } else {
            Ok(Cut::Threshold(t))
        }
    }
    /// A cut at `k >= 1` clusters.
    pub fn k(k: i64) -> Result<Cut, ClusterError> {
        if k < 1 {
            Err(ClusterError::K(k))
        } else {
            Ok(Cut::K(k as usize))
        }
    }
}

/// Flat clusters of a dendrogram: for every item (in `ids` order) its cluster number 1..K,
/// numbered by smallest id.
pub fn flat(d: &Dendrogram, cut: Cut) -> Vec<u32> {
    let n = d.ids.len();
    let heights: Vec<f64> = d.merges.iter().map(|m| m.distance).collect();
    let limit = match cut {
        Cut::Threshold(t) => t,
        Cut::K(k) => {
            if k >= n || heights.is_empty() {
                f64::NEG_INFINITY
            } else {
                // merges are sorted by height (monotone methods): n - k merges leave k clusters
                heights[n - k - 1]
            }
        }
    };
    // Union–find over the leaves; cluster label n + i is merge i.
    let mut uf = UnionFind::new(2 * n.max(1));
    for (i, m) in d.merges.iter().enumerate() {
        if m.distance <= limit && m.distance.is_finite() {
            let new = n + i;
            let (a, b) = (uf.find(m.left), uf.find(m.right));
            uf.attach(a, new);
            uf.attach(b, new);
        }
    }
    let mut number: HashMap<usize, u32> = HashMap::new();
    (0..n)
        .map(|k| {
            let r = uf.find(k);
            let next = number.len() as u32 + 1;
            *number.entry(r).or_insert(next)
        })
        .collect()
}

#[cfg(test)]
// The slow references index like the textbook definitions they transcribe.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    /// Issue 19: a condensed matrix above `memory_bytes` (40k items: 6.4 GB) is refused
    /// before it is allocated.
    #[test]
    fn a_matrix_above_the_memory_limit_is_refused_first() {
        let pairs: Vec<(i64, i64, f64)> = (0..40_000).map(|k| (k, k + 1, 1.0)).collect();
        let e = dendrogram(&pairs, Linkage::Single).unwrap_err();
        let len = 40_001u128 * 40_000 / 2;
        assert_eq!(e, ClusterError::Limit(crate::limits::MEMORY_BYTES.check(len * 8).unwrap_err()));
        assert!(e.to_string().contains("cluster fewer items at once"), "{e}");
    }
    use proptest::prelude::*;

    /// Naive O(n³) agglomerative clustering with the textbook cluster distances (no
    /// Lance–Williams), cutting at `t`: merges the closest pair while its distance is <= t.
    fn naive(n: usize, dist: &[Vec<f64>], method: Linkage, t: f64) -> Vec<Vec<usize>> {
        let mut clusters: Vec<Vec<usize>> = (0..n).map(|k| vec![k]).collect();
        let cd = |a: &[usize], b: &[usize]| -> f64 {
            let all = a.iter().flat_map(|&i| b.iter().map(move |&j| dist[i][j]));
            match method {
                Linkage::Single => all.fold(f64::INFINITY, f64::min),
                Linkage::Complete => all.fold(0.0, f64::max),
                Linkage::Average => all.sum::<f64>() / (a.len() * b.len()) as f64,
                _ => unreachable!(),
            }
        };
        loop {
            let mut best = (f64::INFINITY, 0, 0);
            for i in 0..clusters.len() {
                for j in i + 1..clusters.len() {
                    let d = cd(&clusters[i], &clusters[j]);
                    if d < best.0 {
                        best = (d, i, j);
                    }
                }
            }
            if !(best.0 <= t) {
                break;
            }
            let b = clusters.remove(best.2);
            clusters[best.1].extend(b);
        }
        clusters
    }

    fn partition(labels: &[u32]) -> Vec<Vec<usize>> {
        let mut m: HashMap<u32, Vec<usize>> = HashMap::new();
        for (k, &l) in labels.iter().enumerate() {
            m.entry(l).or_default().push(k);
        }
        let mut v: Vec<Vec<usize>> = m.into_values().collect();
        v.sort();
        v
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// Threshold cuts equal the naive definition, with missing pairs (+inf) included.
        #[test]
        fn equals_naive(n in 2usize..9, raw in prop::collection::vec(0u32..1000, 36), holes in prop::collection::vec(any::<bool>(), 36), t in 0u32..1000, m in 0usize..3) {
            let method = [Linkage::Single, Linkage::Complete, Linkage::Average][m];
            let mut dist = vec![vec![0.0; n]; n];
            let mut pairs = Vec::new();
            let mut k = 0;
            for i in 0..n {
                for j in i + 1..n {
                    // distinct values (no ties): value + tiny index-based offset
                    let d = if holes[k % 36] && k % 3 == 0 { f64::INFINITY } else { raw[k % 36] as f64 + k as f64 * 1e-3 };
                    dist[i][j] = d; dist[j][i] = d;
                    if d.is_finite() { pairs.push((i as i64 * 10, j as i64 * 10, d)); }
                    k += 1;
                }
            }
            // items that have no finite pair would vanish from the input; keep all with a far pair
            for i in 0..n { if (0..n).all(|j| j == i || dist[i][j].is_infinite()) {
                let j = (i + 1) % n; pairs.push((i.min(j) as i64 * 10, i.max(j) as i64 * 10, f64::INFINITY)); } }
            let d = dendrogram(&pairs, method).unwrap();
            prop_assert_eq!(d.ids.len(), n);
            let got = partition(&flat(&d, Cut::Threshold(t as f64)));
            let mut want = naive(n, &dist, method, t as f64);
            for c in want.iter_mut() { c.sort(); }
            want.sort();
            prop_assert_eq!(got, want);
        }
    }

    #[test]
    fn cannot_link_under_complete_and_average_but_not_single() {
        // a-c and c-b close, a-b cannot-link
        let pairs = [(1, 3, 1.0), (3, 2, 1.0)];
        for m in [Linkage::Complete, Linkage::Average, Linkage::Weighted] {
            let d = dendrogram(&pairs, m).unwrap();
            assert!(d.merges.last().unwrap().distance.is_infinite(), "{m:?}");
            let f = flat(&d, Cut::Threshold(1e300));
            assert_ne!(f[0], f[1], "{m:?}: 1 and 2 must stay apart");
            // even asking for one cluster
            let f = flat(&d, Cut::K(1));
            assert_ne!(f[0], f[1]);
        }
        let s = flat(&dendrogram(&pairs, Linkage::Single).unwrap(), Cut::Threshold(1.0));
        assert_eq!(s, vec![1, 1, 1], "single linkage chains through 3");
    }

    /// Distances near f64::MAX (ward squares them, average multiplies them by sizes) or near
    /// the smallest doubles give the same dendrogram as the same distances at unit scale.
    #[test]
    fn extreme_magnitudes_scale_exactly() {
        let unit = [(1, 2, 1.0), (2, 3, 1.7), (1, 3, 1.0e-8 + 0.5)];
        for method in [Linkage::Ward, Linkage::Average, Linkage::Weighted, Linkage::Complete, Linkage::Single] {
            let base = dendrogram(&unit, method).unwrap();
            for scale in [2f64.powi(1000), 2f64.powi(-1000), 2f64.powi(-1020)] {
                let pairs: Vec<_> = unit.iter().map(|&(a, b, d)| (a, b, d * scale)).collect();
                let d = dendrogram(&pairs, method).unwrap();
                assert_eq!(d.merges.len(), base.merges.len());
                for (x, y) in d.merges.iter().zip(&base.merges) {
                    assert_eq!((x.left, x.right, x.size), (y.left, y.right, y.size), "{method:?} at {scale:e}");
                    assert!((x.distance / scale - y.distance).abs() <= 1e-12 * y.distance, "{method:?} at {scale:e}: {} vs {}", x.distance / scale, y.distance);
                }
            }
        }
        // the case: ward on 1e308 / 1.7e308 / 1e300 used to panic inside kodama
        let d = dendrogram(&[(1, 2, 1e308), (2, 3, 1.7e308), (1, 3, 1e300)], Linkage::Ward).unwrap();
        assert!(d.merges.iter().all(|m| m.distance.is_finite() || m.distance == f64::INFINITY));
        assert_eq!(d.merges[0].distance, 1e300);
        // subnormal distances: a result, not a panic
        let d = dendrogram(&[(1, 2, 5e-324), (2, 3, 1e-320), (1, 3, 2e-322)], Linkage::Ward).unwrap();
        assert!(d.merges.iter().all(|m| m.distance.is_finite()));
    }

    #[test]
    fn rules_and_errors() {
        assert_eq!(dendrogram(&[], Linkage::Average).unwrap().ids.len(), 0);
        assert_eq!(flat(&dendrogram(&[], Linkage::Average).unwrap(), Cut::K(3)), Vec::<u32>::new());
        assert!(matches!(dendrogram(&[(1, 2, f64::NAN)], Linkage::Single), Err(ClusterError::Distance { index: 1, .. })));
        assert!(matches!(dendrogram(&[(1, 2, -1.0)], Linkage::Single), Err(ClusterError::Distance { .. })));
        assert_eq!(dendrogram(&[(1, 1, 0.0)], Linkage::Single).unwrap_err(), ClusterError::SelfPair { index: 1, id: 1 });
        assert_eq!(
            dendrogram(&[(1, 2, 1.0), (2, 3, 1.0)], Linkage::Ward).unwrap_err(),
            ClusterError::WardIncomplete { a: 1, b: 3 }
        );
        assert!(Linkage::parse("centroid").is_err());
        // duplicates keep the smallest distance
        let d = dendrogram(&[(1, 2, 5.0), (2, 1, 2.0)], Linkage::Complete).unwrap();
        assert_eq!(d.merges[0].distance, 2.0);
        // numbering by smallest id; k cut
        let pairs = [(10, 20, 1.0), (30, 40, 1.0), (10, 30, 9.0), (10, 40, 9.0), (20, 30, 9.0), (20, 40, 9.0)];
        let d = dendrogram(&pairs, Linkage::Average).unwrap();
        assert_eq!(flat(&d, Cut::K(2)), vec![1, 1, 2, 2]);
        assert_eq!(flat(&d, Cut::K(1)), vec![1, 1, 1, 1]);
        assert_eq!(flat(&d, Cut::K(10)), vec![1, 2, 3, 4]);
        assert_eq!(flat(&d, Cut::Threshold(0.5)), vec![1, 2, 3, 4]);
    }

    /// scipy 1.17.1 `linkage(condensed, method)` and `fcluster(Z, t, 'distance')` on random
    /// inputs (benches/peers_cluster.py --pin writes `testdata/cluster_scipy.json`).
    #[test]
    fn pinned_against_scipy() {
        #[derive(serde::Deserialize)]
        struct Case {
            method: String,
            ids: Vec<i64>,
            condensed: Vec<f64>,
            linkage: Vec<[f64; 4]>,
            t: f64,
            fcluster: Vec<u32>,
            k: usize,
            maxclust: Vec<u32>,
        }
        #[derive(serde::Deserialize)]
        struct Pins {
            scipy: String,
            cases: Vec<Case>,
        }
        let pins: Pins = serde_json::from_str(include_str!("testdata/cluster_scipy.json")).unwrap();
        assert!(pins.scipy.starts_with('1') && pins.cases.len() >= 10);
        for (c, case) in pins.cases.iter().enumerate() {
            let n = case.ids.len();
            let mut pairs = Vec::new();
            let mut k = 0;
            for i in 0..n {
                for j in i + 1..n {
                    pairs.push((case.ids[i], case.ids[j], case.condensed[k]));
                    k += 1;
                }
            }
            let d = dendrogram(&pairs, Linkage::parse(&case.method).unwrap()).unwrap();
            for (s, z) in d.merges.iter().zip(&case.linkage) {
                assert_eq!((s.left as f64, s.right as f64, s.size as f64), (z[0], z[1], z[3]), "case {c} {}", case.method);
                assert!((s.distance - z[2]).abs() < 1e-9 * z[2].max(1.0), "case {c}");
            }
            assert_eq!(partition(&flat(&d, Cut::Threshold(case.t))), partition(&case.fcluster), "case {c} fcluster");
            assert_eq!(partition(&flat(&d, Cut::K(case.k))), partition(&case.maxclust), "case {c} maxclust");
        }
    }
}
