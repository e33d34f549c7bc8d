//! Agglomerative (hierarchical) clustering of trajectories on pairwise distances, with
//! cannot-link pairs (Buzan et al., sections 4.3–4.5 and 5.2: trajectories whose LCSS distance is
//! "infinite" must not share a cluster).
//!
//! # Input
//! Pairs `(a, b, distance)` ([`dendrogram_pairs`], three columns read in place). Items are the ids
//! that appear; they are indexed in increasing id order (index k = the k-th smallest id), which
//! is the order of the dendrogram's leaves. Or a scipy-style condensed matrix
//! ([`dendrogram_condensed`], `pdist`'s layout) over the items 0..n−1.
//! * a pair absent from the list, or with distance `+inf`, is infinitely far apart;
//! * NaN or negative distances and self pairs `(a, a)` are errors; a duplicated pair keeps
//!   its smallest distance (the closest evidence).
//!
//! # Methods and cannot-link
//! The algorithms are scipy's (`scipy.cluster.hierarchy.linkage`, Müllner 2011): Prim's minimum
//! spanning tree for single ([`super::mst`]), the nearest-neighbour chain for complete, average,
//! weighted and ward ([`super::nn_chain`]); all five methods are reducible, so the generic
//! algorithm (O(n³) worst case) is never needed, and it only lives in the tests as the slow,
//! obviously right reference. Infinite distances are
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
//! # Ties: scipy's merges, bit for bit
//! The merges are those of scipy 1.17's `linkage`, equal heights included (pinned:
//! `testdata/cluster_scipy_ties.json`, 60 matrices of small integers; property test against a
//! transcription of scipy's loops):
//! * single: Prim from item 0 adds the outside item with the smallest `(distance to the tree,
//!   index)`;
//! * the chain methods: the chain starts at the smallest active index; the nearest neighbour of
//!   the chain's end is the smallest `(distance, index)`, except that the element before it in
//!   the chain wins a tie; the merged cluster keeps the larger index; the Lance–Williams updates
//!   are computed with scipy's operations in scipy's order (ward: `sqrt` of the update, not
//!   fastcluster's squared distances), so heights are the same doubles;
//! * the merges are then sorted by height, **stably** (equal heights keep the order in which the
//!   algorithm found them) and numbered by union–find (`left < right`), as scipy's `label`.
//!
//! Where scipy would meet `+inf` (which it never gets: it rejects non-finite input) the same
//! rules apply with `+inf` as a value: a chain end whose every neighbour is at `+inf` takes the
//! smallest active index. Merges at `+inf` come last; which groups they join is this rule's
//! choice and has no meaning (no cut applies them).
//!
//! # Complexity
//! O(n²) memory: one condensed matrix of n(n−1)/2 `f64` (asked for in transparent huge pages on
//! Linux: the column scans touch one cache line per row), within the `memory_bytes` limit;
//! 24 GiB holds n ≈ 80,000 (the cap [`MAX_ITEMS`]). Besides it O(n): Prim and the chain keep
//! lists of the active items, sizes and the chain; [`dendrogram_condensed`] with single linkage
//! reads the caller's list in place and checks its entries inside Prim's scan, the other
//! methods copy it in one pass that checks it (no pass of its own for the checks). Through SQL the list of pairs is the larger cost (24 bytes
//! per pair in the list, plus DuckDB's own copy), so about n ≈ 25,000 with all pairs fits in
//! 24 GiB; sparse pair lists (cannot-links left out) reach further. Time O(n²) for every
//! method (Prim; the NN-chain on reducible methods), plus O(P) to read P pairs: three parallel
//! passes over the columns (id range, id marks, fill without locks) and a fourth only when the
//! list holds duplicates.

pub use super::condensed::Linkage;
use super::condensed::{Condensed, RawMerge};
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
    /// A condensed list whose length is not n(n−1)/2 for any n.
    CondensedLength(usize),
    /// 1-based index and value of a NaN or negative entry of a condensed list.
    CondensedValue { index: usize, value: f64 },
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
            ClusterError::CondensedLength(len) => write!(
                f,
                "condensed has {len} entries, which is n(n-1)/2 for no n: pass the upper triangle of an n x n distance matrix row by row (scipy's pdist / squareform layout)"
            ),
            ClusterError::CondensedValue { index, value } => write!(f, "condensed[{index}] must be >= 0 (or 'inf' for a cannot-link) and not NaN, got {value}"),
        }
    }
}
impl std::error::Error for ClusterError {}

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

/// The pairs as three columns of equal length (DuckDB's struct fields, read in place).
#[derive(Clone, Copy, Debug)]
pub struct Pairs<'a> {
    pub a: &'a [i64],
    pub b: &'a [i64],
    pub distance: &'a [f64],
}

impl Pairs<'_> {
    pub fn len(&self) -> usize {
        self.distance.len()
    }
    pub fn is_empty(&self) -> bool {
        self.distance.is_empty()
    }
}

/// [`dendrogram_pairs`] of pairs written as tuples (a copy into columns first).
pub fn dendrogram(pairs: &[(i64, i64, f64)], method: Linkage) -> Result<Dendrogram, ClusterError> {
    let a: Vec<i64> = pairs.iter().map(|p| p.0).collect();
    let b: Vec<i64> = pairs.iter().map(|p| p.1).collect();
    let d: Vec<f64> = pairs.iter().map(|p| p.2).collect();
    dendrogram_pairs(Pairs { a: &a, b: &b, distance: &d }, method)
}

/// Builds the dendrogram of `pairs` with `method` (see module docs).
///
/// The pair columns are read three times (the id range, the id marks, the matrix fill), each
/// pass in parallel chunks; a fourth pass runs only when the pairs hold duplicates.
pub fn dendrogram_pairs(pairs: Pairs<'_>, method: Linkage) -> Result<Dendrogram, ClusterError> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicU32, Ordering};
    let Pairs { a, b, distance } = pairs;
    assert!(a.len() == distance.len() && b.len() == distance.len(), "pair columns of different lengths");
    if pairs.is_empty() {
        return Ok(Dendrogram { ids: vec![], merges: vec![] });
    }
    let range = |s: &[i64]| {
        s.par_chunks(CHUNK)
            .map(|c| (c.iter().fold(i64::MAX, |l, &v| l.min(v)), c.iter().fold(i64::MIN, |h, &v| h.max(v))))
            .reduce(|| (i64::MAX, i64::MIN), |x, y| (x.0.min(y.0), x.1.max(y.1)))
    };
    let ((la, ha), (lb, hb)) = (range(a), range(b));
    let (lo, hi) = (la.min(lb), ha.max(hb));
    let span = (hi as i128 - lo as i128) as u128 + 1;
    let memory = |len: usize| ClusterError::Memory { items: len, bytes: len * 8 };
    // Item ids -> dense indices: a lookup table when the ids span a small range (row numbers,
    // track ids), otherwise a sorted, deduplicated copy and a hash map.
    if span <= 4 * pairs.len() as u128 + 1024 {
        let span = span as usize;
        let mut slot: Vec<AtomicU32> = Vec::new();
        slot.try_reserve_exact(span).map_err(|_| memory(span))?;
        slot.resize_with(span, || AtomicU32::new(u32::MAX));
        a.par_chunks(CHUNK).zip(b.par_chunks(CHUNK)).for_each(|(a, b)| {
            for (&x, &y) in a.iter().zip(b) {
                slot[(x - lo) as usize].store(0, Ordering::Relaxed);
                slot[(y - lo) as usize].store(0, Ordering::Relaxed);
            }
        });
        let mut slot: Vec<u32> = slot.into_iter().map(AtomicU32::into_inner).collect();
        let mut ids = Vec::new();
        for (k, s) in slot.iter_mut().enumerate() {
            if *s == 0 {
                *s = ids.len() as u32;
                ids.push(lo + k as i64);
            }
        }
        finish(pairs, ids, |id| slot[(id - lo) as usize] as usize, method)
    } else {
        let mut ids: Vec<i64> = Vec::new();
        ids.try_reserve_exact(2 * pairs.len()).map_err(|_| memory(2 * pairs.len()))?;
        ids.extend_from_slice(a);
        ids.extend_from_slice(b);
        ids.par_sort_unstable();
        ids.dedup();
        let index: HashMap<i64, usize> = ids.iter().enumerate().map(|(k, &id)| (id, k)).collect();
        finish(pairs, ids, |id| index[&id], method)
    }
}

/// Pairs per parallel chunk.
const CHUNK: usize = 1 << 16;

/// Fills the condensed matrix from the pairs, checking them on the way, and runs the linkage.
fn finish(pairs: Pairs<'_>, ids: Vec<i64>, lookup: impl Fn(i64) -> usize + Sync, method: Linkage) -> Result<Dendrogram, ClusterError> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicU64, Ordering};
    let n = ids.len();
    let Pairs { a, b, distance } = pairs;
    // self pairs are the only way to have a single item
    if !(2..=MAX_ITEMS).contains(&n) {
        if let Some(e) = first_bad(pairs, 0..pairs.len()) {
            return Err(e);
        }
        if n > MAX_ITEMS {
            return Err(ClusterError::TooMany(n));
        }
        return Ok(Dendrogram { ids, merges: vec![] });
    }
    let len = n * (n - 1) / 2;
    let mut m = alloc_condensed(n, f64::INFINITY)?;
    const _: () = assert!(std::mem::align_of::<AtomicU64>() == std::mem::align_of::<f64>() && std::mem::size_of::<AtomicU64>() == 8);
    // SAFETY: AtomicU64 has the size and alignment of f64 (checked above) and any bit pattern
    // is valid for both; `m` is not used otherwise while `cells` lives.
    let cells: &[AtomicU64] = unsafe { std::slice::from_raw_parts(m.as_mut_ptr() as *const AtomicU64, len) };
    let start = |i: usize| i * n - i * (i + 1) / 2;
    let cell = |k: usize| {
        let (i, j) = (lookup(a[k]), lookup(b[k]));
        let (i, j) = (i.min(j), i.max(j));
        &cells[start(i) + j - i - 1]
    };
    // Non-negative f64 order equals their bit order. The fill stores without a lock (a relaxed
    // load and store), so two duplicates of a pair written at the same moment by two threads can
    // lose the smaller. Without duplicates every finite pair has its own cell: when the cells
    // below +inf are as many as the finite pairs, nothing was lost. Otherwise a second pass
    // re-applies every pair with an atomic fetch_min where its cell is still above it: cells only
    // decrease in that pass and each pair leaves its cell <= its distance, so every cell ends at
    // the minimum of its pairs (duplicates keep the smallest distance).
    let finite = (0..pairs.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let r = c * CHUNK..((c + 1) * CHUNK).min(pairs.len());
            let (mut finite, mut top) = (0usize, 0.0f64);
            for k in r.clone() {
                let d = distance[k];
                if !(d >= 0.0) || a[k] == b[k] {
                    return Err(first_bad(pairs, r).expect("a bad pair in this chunk"));
                }
                // + 0.0 turns -0.0 into 0.0
                let bits = (d + 0.0).to_bits();
                let c = cell(k);
                if bits < c.load(Ordering::Relaxed) {
                    c.store(bits, Ordering::Relaxed);
                }
                if d.is_finite() {
                    finite += 1;
                    top = top.max(d);
                }
            }
            Ok((finite, top))
        })
        .try_reduce(|| (0, 0.0), |x, y| Ok((x.0 + y.0, x.1.max(y.1))));
    let (finite, top) = match finite {
        Ok(f) => f,
        // the first bad pair in list order (the reduction stops at any)
        Err(_) => return Err(first_bad(pairs, 0..pairs.len()).expect("a bad pair")),
    };
    let filled = cells.par_chunks(CHUNK).map(|c| c.iter().filter(|v| v.load(Ordering::Relaxed) != f64::INFINITY.to_bits()).count()).sum::<usize>();
    if filled < finite {
        (0..pairs.len()).into_par_iter().with_min_len(CHUNK).for_each(|k| {
            let bits = (distance[k] + 0.0).to_bits();
            let c = cell(k);
            if bits < c.load(Ordering::Relaxed) {
                c.fetch_min(bits, Ordering::Relaxed);
            }
        });
    }
    // without duplicates the largest finite pair is the largest finite entry
    let known = Known { complete: filled == len, top: (filled == finite).then_some(top) };
    linkage_known(ids, m, method, known)
}

/// The first pair of `r` (in list order) with a NaN or negative distance or a self pair.
fn first_bad(pairs: Pairs<'_>, r: std::ops::Range<usize>) -> Option<ClusterError> {
    let Pairs { a, b, distance } = pairs;
    let k = r.into_iter().find(|&k| !(distance[k] >= 0.0) || a[k] == b[k])?;
    let d = distance[k];
    Some(if !(d >= 0.0) { ClusterError::Distance { index: k + 1, value: d } } else { ClusterError::SelfPair { index: k + 1, id: a[k] } })
}

/// What the caller already knows of a matrix (saves passes over it).
#[derive(Clone, Copy, Debug)]
struct Known {
    /// No entry is `+inf`.
    complete: bool,
    /// The largest finite entry, if known.
    top: Option<f64>,
}

/// The dendrogram of a scipy-style condensed distance matrix (`pdist`'s layout: the upper
/// triangle row by row, n(n−1)/2 entries, `+inf` = cannot-link) over the items 0..n−1. Single
/// linkage reads `condensed` in place (no copy: O(n) memory); the other methods work on a copy.
pub fn dendrogram_condensed(condensed: &[f64], method: Linkage) -> Result<Dendrogram, ClusterError> {
    use rayon::prelude::*;
    let len = condensed.len();
    if len == 0 {
        return Ok(Dendrogram { ids: vec![], merges: vec![] });
    }
    // n(n-1)/2 = len: n = (1 + sqrt(1 + 8 len)) / 2, checked exactly
    let n = ((1.0 + (1.0 + 8.0 * len as f64).sqrt()) / 2.0).round() as usize;
    if n * (n - 1) / 2 != len {
        return Err(ClusterError::CondensedLength(len));
    }
    if n > MAX_ITEMS {
        return Err(ClusterError::TooMany(n));
    }
    let first_bad = || {
        let k = condensed.par_chunks(CHUNK).enumerate().filter_map(|(c, s)| s.iter().position(|d| !(*d >= 0.0)).map(|k| c * CHUNK + k)).min()?;
        Some(ClusterError::CondensedValue { index: k + 1, value: condensed[k] })
    };
    let ids: Vec<i64> = (0..n as i64).collect();
    let oom = |_| ClusterError::Memory { items: n, bytes: n * 16 };
    if method == Linkage::Single {
        // Prim reads every entry once and reports whether one was NaN or negative: the check
        // costs no pass of its own (the error, rare, then finds the first bad entry)
        let (raw, valid) = super::mst::mst(&Condensed::read_only(condensed, n).map_err(oom)?).map_err(oom)?;
        if !valid {
            return Err(first_bad().expect("a NaN or negative entry"));
        }
        let merges = label(n, raw, 1.0)?;
        return Ok(Dendrogram { ids, merges });
    }
    // One pass copies the list into the working matrix and checks it on the way: NaN or
    // negative entries, the largest finite entry and whether one is +inf (ward's check).
    let mut m = alloc_condensed_uninit(n)?;
    let (valid, top, complete) = m.spare_capacity_mut()[..len]
        .par_chunks_mut(CHUNK)
        .zip(condensed.par_chunks(CHUNK))
        .map(|(dst, src)| {
            let (mut valid, mut top, mut complete) = (true, 0.0f64, true);
            for (w, &d) in dst.iter_mut().zip(src) {
                w.write(d);
                valid &= d >= 0.0;
                if d.is_finite() {
                    top = top.max(d);
                } else {
                    complete = false;
                }
            }
            (valid, top, complete)
        })
        .reduce(|| (true, 0.0, true), |a, b| (a.0 && b.0, a.1.max(b.1), a.2 && b.2));
    if !valid {
        return Err(first_bad().expect("a NaN or negative entry"));
    }
    // SAFETY: the pass above wrote each of the `len` elements (the chunks of `dst` cover them).
    unsafe { m.set_len(len) };
    linkage_known(ids, m, method, Known { complete, top: Some(top) })
}

/// A condensed matrix for `n` items, allocated (within the memory limit, fallibly, in huge
/// pages) but not written: capacity n(n−1)/2, length 0.
fn alloc_condensed_uninit(n: usize) -> Result<Vec<f64>, ClusterError> {
    let len = n * n.saturating_sub(1) / 2;
    // bounded by the limit, and fallible: too little memory is an error, never an abort of the host
    crate::limits::MEMORY_BYTES.check(len as u128 * 8).map_err(ClusterError::Limit)?;
    let mut m: Vec<f64> = Vec::new();
    m.try_reserve_exact(len).map_err(|_| ClusterError::Memory { items: n, bytes: len * 8 })?;
    huge_pages(&mut m, len);
    Ok(m)
}

/// A condensed matrix for `n` items filled with `value`, within the memory limit and fallibly.
pub fn alloc_condensed(n: usize, value: f64) -> Result<Vec<f64>, ClusterError> {
    use rayon::prelude::*;
    let len = n * n.saturating_sub(1) / 2;
    let mut m = alloc_condensed_uninit(n)?;
    m.spare_capacity_mut()[..len].par_chunks_mut(1 << 16).for_each(|c| c.iter_mut().for_each(|w| {
        w.write(value);
    }));
    // SAFETY: every one of the `len` elements was written above.
    unsafe { m.set_len(len) };
    Ok(m)
}

/// Asks Linux for transparent huge pages on a fresh allocation of `len` elements (the column
/// scans of the linkage touch one cache line per row: with 4 KiB pages, one TLB miss each). A
/// hint only: without it (other systems, THP off) nothing changes but speed.
pub fn huge_pages<T>(v: &mut Vec<T>, len: usize) {
    #[cfg(target_os = "linux")]
    {
        let bytes = len * std::mem::size_of::<T>();
        if bytes >= 4 << 20 {
            let p = v.as_mut_ptr() as usize;
            let start = (p + 4095) & !4095;
            let end = (p + bytes) & !4095;
            if end > start {
                // SAFETY: [start, end) lies within the allocation owned by `v`; MADV_HUGEPAGE
                // changes no contents.
                unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) };
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (v, len);
}

/// scipy's `label` after a stable sort by height: cluster numbers by union–find (leaves 0..n,
/// merge i creates n + i), `left < right`, sizes; heights multiplied by `back`.
fn label(n: usize, mut raw: Vec<RawMerge>, back: f64) -> Result<Vec<Merge>, ClusterError> {
    let oom = |_| ClusterError::Memory { items: n, bytes: n * 16 };
    // stable: equal heights keep the order the algorithm found them in (scipy's mergesort)
    raw.sort_by(|p, q| p.distance.partial_cmp(&q.distance).unwrap_or(std::cmp::Ordering::Equal));
    let mut parent: Vec<u32> = Vec::new();
    parent.try_reserve_exact(2 * n).map_err(oom)?;
    parent.extend(0..2 * n as u32);
    let mut size: Vec<usize> = Vec::new();
    size.try_reserve_exact(2 * n).map_err(oom)?;
    size.resize(2 * n, 1);
    let find = |parent: &mut Vec<u32>, mut x: u32| {
        let mut p = x;
        while parent[x as usize] != x {
            x = parent[x as usize];
        }
        while parent[p as usize] != x {
            let q = parent[p as usize];
            parent[p as usize] = x;
            p = q;
        }
        x
    };
    let mut merges = Vec::new();
    merges.try_reserve_exact(raw.len()).map_err(oom)?;
    for (k, r) in raw.iter().enumerate() {
        let (a, b) = (find(&mut parent, r.x), find(&mut parent, r.y));
        let new = n + k;
        parent[a as usize] = new as u32;
        parent[b as usize] = new as u32;
        size[new] = size[a as usize] + size[b as usize];
        merges.push(Merge { left: a.min(b) as usize, right: a.max(b) as usize, distance: r.distance * back, size: size[new] });
    }
    Ok(merges)
}

/// The linkage of a ready condensed matrix `m` (row-major upper triangle, n(n−1)/2 entries,
/// `+inf` = cannot-link) over `ids` (increasing; the leaves). Used by [`dendrogram`] and by
/// [`super::traj_cluster`], which computes the matrix itself. `m` is consumed (overwritten).
pub fn linkage_condensed(ids: Vec<i64>, m: Vec<f64>, method: Linkage) -> Result<Dendrogram, ClusterError> {
    linkage_known(ids, m, method, Known { complete: false, top: None })
}

fn linkage_known(ids: Vec<i64>, mut m: Vec<f64>, method: Linkage, known: Known) -> Result<Dendrogram, ClusterError> {
    use rayon::prelude::*;
    let n = ids.len();
    if n > MAX_ITEMS {
        return Err(ClusterError::TooMany(n));
    }
    if n < 2 {
        return Ok(Dendrogram { ids, merges: vec![] });
    }
    assert_eq!(m.len(), n * (n - 1) / 2, "linkage_condensed: a matrix of n(n-1)/2 entries");
    if method == Linkage::Ward && !known.complete {
        let first_inf = m.par_chunks(CHUNK).enumerate().filter_map(|(c, s)| s.iter().position(|d| d.is_infinite()).map(|k| c * CHUNK + k)).min();
        if let Some(k) = first_inf {
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
    // The Lance–Williams updates square distances (ward), multiply them by cluster sizes
    // (average) or add them (weighted): near f64::MAX they would overflow to inf (and ward's
    // inf − inf to NaN), near the smallest doubles ward's squares underflow. Every method is
    // scale-equivariant, so very large (or very small) finite distances are scaled by a power
    // of two, which is exact, and the merge heights scaled back. Single and complete only
    // compare distances and need no scaling.
    let mut shift = 0;
    if !matches!(method, Linkage::Single | Linkage::Complete) {
        let top = known.top.unwrap_or_else(|| m.par_chunks(CHUNK).map(|c| c.iter().fold(0.0f64, |t, &d| if d.is_finite() { t.max(d) } else { t })).reduce(|| 0.0, f64::max));
        if top > 1e150 || (top > 0.0 && top < 1e-150) {
            shift = (-(top.log2().floor() as i32)).clamp(-1000, 1000);
            let f = 2f64.powi(shift);
            m.par_chunks_mut(CHUNK).for_each(|c| c.iter_mut().for_each(|d| *d *= f));
        }
    }
    let oom = |_| ClusterError::Memory { items: n, bytes: n * 16 };
    let raw = {
        let c = Condensed::new(&mut m, n).map_err(oom)?;
        match method {
            Linkage::Single => super::mst::mst(&c).map(|(raw, _)| raw),
            _ => super::nn_chain::nn_chain(&c, method),
        }
        .map_err(oom)?
    };
    drop(m);
    let merges = label(n, raw, 2f64.powi(-shift))?;
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
        // the case: ward on 1e308 / 1.7e308 / 1e300 used to panic inside kodama (the former linkage crate)
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

    /// scipy 1.17.1 `linkage` on condensed matrices of small integers (most heights tied;
    /// benches/peers_cluster.py --pin writes `testdata/cluster_scipy_ties.json`): the same merges,
    /// in the same order, through both entry points.
    #[test]
    fn pinned_ties_against_scipy() {
        #[derive(serde::Deserialize)]
        struct Case {
            method: String,
            condensed: Vec<f64>,
            /// left, right, size
            merges: Vec<[usize; 3]>,
            /// decimal strings (parsed exactly here)
            heights: Vec<String>,
        }
        #[derive(serde::Deserialize)]
        struct Pins {
            scipy: String,
            cases: Vec<Case>,
        }
        let pins: Pins = serde_json::from_str(include_str!("testdata/cluster_scipy_ties.json")).unwrap();
        assert!(pins.scipy.starts_with('1') && pins.cases.len() >= 50);
        for (c, case) in pins.cases.iter().enumerate() {
            let method = Linkage::parse(&case.method).unwrap();
            let d = dendrogram_condensed(&case.condensed, method).unwrap();
            let n = d.ids.len();
            let mut pairs = Vec::new();
            let mut k = 0;
            for i in 0..n {
                for j in i + 1..n {
                    pairs.push((i as i64, j as i64, case.condensed[k]));
                    k += 1;
                }
            }
            assert_eq!(dendrogram(&pairs, method).unwrap(), d, "case {c}");
            assert_eq!(d.merges.len(), case.merges.len());
            for ((s, z), h) in d.merges.iter().zip(&case.merges).zip(&case.heights) {
                assert_eq!([s.left, s.right, s.size], *z, "case {c} {}", case.method);
                assert_eq!(s.distance, h.parse::<f64>().unwrap(), "case {c} {}", case.method);
            }
        }
    }

    #[test]
    fn condensed_rules() {
        assert_eq!(dendrogram_condensed(&[], Linkage::Single).unwrap().ids.len(), 0);
        assert_eq!(dendrogram_condensed(&[1.0, 2.0], Linkage::Single).unwrap_err(), ClusterError::CondensedLength(2));
        assert_eq!(dendrogram_condensed(&[1.0, -1.0, 2.0], Linkage::Average).unwrap_err(), ClusterError::CondensedValue { index: 2, value: -1.0 });
        assert!(matches!(dendrogram_condensed(&[1.0, f64::INFINITY, 2.0], Linkage::Ward), Err(ClusterError::WardIncomplete { a: 0, b: 2 })));
        let d = dendrogram_condensed(&[4.0], Linkage::Ward).unwrap();
        assert_eq!(d.merges, vec![Merge { left: 0, right: 1, distance: 4.0, size: 2 }]);
    }

    /// The five methods' Lance–Williams updates in their textbook form (not the algorithms'
    /// operation order).
    fn lance_williams(method: Linkage, dxi: f64, dyi: f64, dxy: f64, nx: f64, ny: f64, ni: f64) -> f64 {
        match method {
            Linkage::Single => dxi.min(dyi),
            Linkage::Complete => dxi.max(dyi),
            Linkage::Average => (nx * dxi + ny * dyi) / (nx + ny),
            Linkage::Weighted => (dxi + dyi) / 2.0,
            Linkage::Ward => (((ni + nx) * dxi * dxi + (ni + ny) * dyi * dyi - ni * dxy * dxy) / (ni + nx + ny)).max(0.0).sqrt(),
        }
    }

    /// Slow, obviously right generic agglomerative clustering, O(n³): every step merges the two
    /// closest clusters (the smallest `(d, i, j)`) of a full matrix. Returns the merges as
    /// (height, leaves of one side, leaves of the other), sides sorted.
    fn generic(dist: &[Vec<f64>], method: Linkage) -> Vec<(f64, Vec<usize>, Vec<usize>)> {
        let n = dist.len();
        let mut d = dist.to_vec();
        let mut members: Vec<Vec<usize>> = (0..n).map(|k| vec![k]).collect();
        let mut active: Vec<bool> = vec![true; n];
        let mut out = Vec::new();
        for _ in 0..n.saturating_sub(1) {
            let mut best = (f64::INFINITY, usize::MAX, usize::MAX);
            for i in 0..n {
                for j in i + 1..n {
                    if active[i] && active[j] && (best.1 == usize::MAX || d[i][j] < best.0) {
                        best = (d[i][j], i, j);
                    }
                }
            }
            let (h, x, y) = best;
            let (nx, ny) = (members[x].len() as f64, members[y].len() as f64);
            for i in 0..n {
                if active[i] && i != x && i != y {
                    let v = lance_williams(method, d[x][i], d[y][i], h, nx, ny, members[i].len() as f64);
                    d[y][i] = v;
                    d[i][y] = v;
                }
            }
            active[x] = false;
            let (mut l, mut r) = (members[x].clone(), members[y].clone());
            l.sort();
            r.sort();
            out.push((h, l.clone().min(r.clone()), l.max(r)));
            let mx = std::mem::take(&mut members[x]);
            members[y].extend(mx);
        }
        out
    }

    /// A dendrogram's merges as (height, leaves of one side, leaves of the other).
    fn as_leaf_sets(d: &Dendrogram) -> Vec<(f64, Vec<usize>, Vec<usize>)> {
        let n = d.ids.len();
        let mut leaves: Vec<Vec<usize>> = (0..n).map(|k| vec![k]).collect();
        let mut out = Vec::new();
        for m in &d.merges {
            let (mut l, mut r) = (leaves[m.left].clone(), leaves[m.right].clone());
            assert_eq!(l.len() + r.len(), m.size);
            let mut all = l.clone();
            all.extend(&r);
            l.sort();
            r.sort();
            out.push((m.distance, l.clone().min(r.clone()), l.max(r)));
            leaves.push(all);
        }
        out
    }

    /// Random symmetric matrices: `ties` draws distances from 0..4 (many equal values), else from
    /// a continuous range (no ties with probability 1); `inf` makes about a third of the pairs
    /// cannot-links.
    fn matrix(n: usize, vals: &[f64], holes: &[bool], ties: bool, inf: bool) -> Vec<Vec<f64>> {
        let mut dist = vec![vec![0.0; n]; n];
        let mut k = 0;
        for i in 0..n {
            for j in i + 1..n {
                let v = vals[k % vals.len()];
                let v = if ties { (v * 5.0).floor() } else { v * 100.0 + k as f64 * 1e-7 };
                let d = if inf && holes[k % holes.len()] { f64::INFINITY } else { v };
                dist[i][j] = d;
                dist[j][i] = d;
                k += 1;
            }
        }
        dist
    }

    /// Our dendrogram of a full matrix (every pair listed, the infinite ones as `inf`).
    fn ours(dist: &[Vec<f64>], method: Linkage) -> Dendrogram {
        let n = dist.len();
        let mut pairs = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                pairs.push((i as i64 * 3 + 7, j as i64 * 3 + 7, dist[i][j]));
            }
        }
        dendrogram(&pairs, method).unwrap()
    }

    const METHODS: [Linkage; 5] = [Linkage::Single, Linkage::Complete, Linkage::Average, Linkage::Weighted, Linkage::Ward];

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        /// Without ties: the same merges as the generic algorithm, for all five methods, with
        /// cannot-links (not for ward, which refuses them): the finite merges one by one, then
        /// as many merges at +inf.
        #[test]
        fn equals_generic_without_ties(n in 2usize..14, vals in prop::collection::vec(0.0f64..1.0, 91), holes in prop::collection::vec(prop::bool::weighted(0.3), 91), m in 0usize..5, inf in any::<bool>()) {
            let method = METHODS[m];
            let inf = inf && method != Linkage::Ward;
            let dist = matrix(n, &vals, &holes, false, inf);
            let got = as_leaf_sets(&ours(&dist, method));
            let want = generic(&dist, method);
            prop_assert_eq!(got.len(), want.len());
            for (g, w) in got.iter().zip(&want) {
                if w.0.is_infinite() {
                    prop_assert!(g.0.is_infinite(), "{:?}: {:?} vs {:?}", method, got, want);
                    continue;
                }
                prop_assert_eq!((&g.1, &g.2), (&w.1, &w.2), "{:?}", method);
                prop_assert!((g.0 - w.0).abs() <= 1e-9 * w.0.max(1e-300), "{:?}: {} vs {}", method, g.0, w.0);
            }
        }

        /// With ties and cannot-links, single linkage still has one answer: the same heights as
        /// the generic algorithm and the same partition at every threshold.
        #[test]
        fn single_with_ties_equals_generic(n in 2usize..14, vals in prop::collection::vec(0.0f64..1.0, 91), holes in prop::collection::vec(prop::bool::weighted(0.3), 91), inf in any::<bool>()) {
            let dist = matrix(n, &vals, &holes, true, inf);
            let d = ours(&dist, Linkage::Single);
            let want = generic(&dist, Linkage::Single);
            let hs: Vec<f64> = d.merges.iter().map(|m| m.distance).collect();
            let ws: Vec<f64> = want.iter().map(|w| w.0).collect();
            prop_assert_eq!(hs, ws);
            for t in [0.0, 1.0, 2.0, 3.0, 4.0] {
                let got = partition(&flat(&d, Cut::Threshold(t)));
                let mut want = naive(n, &dist, Linkage::Single, t);
                for c in want.iter_mut() { c.sort(); }
                want.sort();
                prop_assert_eq!(got, want);
            }
        }

        /// With ties and cannot-links, every method gives exactly scipy's procedure
        /// ([`scipy_transcription`]): same merges, same heights to the bit.
        #[test]
        fn ties_follow_scipy(n in 2usize..30, vals in prop::collection::vec(0.0f64..1.0, 97), holes in prop::collection::vec(prop::bool::weighted(0.3), 97), m in 0usize..5, inf in any::<bool>()) {
            let method = METHODS[m];
            let inf = inf && method != Linkage::Ward;
            let dist = matrix(n, &vals, &holes, true, inf);
            let got = ours(&dist, method);
            prop_assert_eq!(got.merges, scipy_transcription(&dist, method));
        }

        /// The condensed form checks its entries inside the linkage's own passes (single: in
        /// Prim's scan; the others: in the copy): the same dendrogram as the pairs, the first NaN
        /// or negative entry as the error, and ward's missing pairs, also for distances scaled
        /// near the ends of the f64 range.
        #[test]
        fn condensed_equals_pairs(n in 2usize..40, vals in prop::collection::vec(0.0f64..1.0, 97), holes in prop::collection::vec(prop::bool::weighted(0.2), 97), m in 0usize..5, inf in any::<bool>(), scale in 0usize..3, bad in prop::collection::vec((0usize..800, 0usize..3), 0..3)) {
            let method = METHODS[m];
            let f = [1.0, 1e300, 1e-300][scale];
            let dist = matrix(n, &vals, &holes, scale == 0, inf);
            let mut cond = Vec::new();
            let mut pairs = Vec::new();
            for i in 0..n {
                for j in i + 1..n {
                    cond.push(dist[i][j] * f);
                    pairs.push((i as i64, j as i64, dist[i][j] * f));
                }
            }
            for &(k, v) in &bad {
                let k = k % cond.len();
                let v = [f64::NAN, -1.0, -0.5 * f][v];
                cond[k] = v;
                pairs[k].2 = v;
            }
            let got = dendrogram_condensed(&cond, method);
            match dendrogram(&pairs, method) {
                Ok(want) => prop_assert_eq!(got.unwrap(), want),
                Err(ClusterError::Distance { index, value }) => {
                    let e = got.unwrap_err();
                    prop_assert!(matches!(e, ClusterError::CondensedValue { index: i, value: v } if i == index && v.to_bits() == value.to_bits()), "{:?} vs {} {}", e, index, value);
                }
                Err(e) => prop_assert_eq!(got.unwrap_err(), e),
            }
        }
    }

    /// scipy 1.17's `mst_single_linkage` and `nn_chain` (scipy/cluster/_hierarchy.pyx), their
    /// stable sort by height and `label`, transcribed loop for loop on a full matrix (scanning
    /// every index, inactive ones skipped), without the chunks, lists and squeezes of
    /// [`super::super::mst`] and [`super::super::nn_chain`]. Where scipy leaves `y` unset (every
    /// distance `+inf`, which scipy never meets) the first candidate index is taken.
    fn scipy_transcription(dist: &[Vec<f64>], method: Linkage) -> Vec<Merge> {
        let n = dist.len();
        let mut d = dist.to_vec();
        let mut z: Vec<(usize, usize, f64)> = Vec::new();
        if n < 2 {
            return vec![];
        }
        if method == Linkage::Single {
            let mut merged = vec![false; n];
            let mut dm = vec![f64::INFINITY; n];
            let mut x = 0;
            for _ in 0..n - 1 {
                let mut current_min = f64::INFINITY;
                let mut y = usize::MAX;
                merged[x] = true;
                for i in 0..n {
                    if merged[i] {
                        continue;
                    }
                    if dm[i] > d[x][i] {
                        dm[i] = d[x][i];
                    }
                    if y == usize::MAX && dm[i] == f64::INFINITY {
                        y = i; // scipy: unset
                    }
                    if dm[i] < current_min {
                        y = i;
                        current_min = dm[i];
                    }
                }
                z.push((x, y, current_min));
                x = y;
            }
        } else {
            let mut size = vec![1usize; n];
            let mut chain: Vec<usize> = Vec::new();
            for _ in 0..n - 1 {
                if chain.is_empty() {
                    chain.push((0..n).find(|&i| size[i] > 0).unwrap());
                }
                let (x, y, current_min) = loop {
                    let x = *chain.last().unwrap();
                    let (mut y, mut current_min) = if chain.len() > 1 { (chain[chain.len() - 2], d[x][chain[chain.len() - 2]]) } else { (usize::MAX, f64::INFINITY) };
                    for i in 0..n {
                        if size[i] == 0 || x == i {
                            continue;
                        }
                        if y == usize::MAX {
                            y = i; // scipy: unset
                        }
                        if d[x][i] < current_min {
                            current_min = d[x][i];
                            y = i;
                        }
                    }
                    if chain.len() > 1 && y == chain[chain.len() - 2] {
                        break (x, y, current_min);
                    }
                    chain.push(y);
                };
                chain.truncate(chain.len() - 2);
                let (x, y) = (x.min(y), x.max(y));
                let (nx, ny) = (size[x], size[y]);
                z.push((x, y, current_min));
                size[x] = 0;
                size[y] = nx + ny;
                for i in 0..n {
                    let ni = size[i];
                    if ni == 0 || i == y {
                        continue;
                    }
                    let (dxi, dyi) = (d[i][x], d[i][y]);
                    // _hierarchy_distance_update.pxi
                    let v = match method {
                        Linkage::Complete => if dxi > dyi { dxi } else { dyi },
                        Linkage::Average => (nx as f64 * dxi + ny as f64 * dyi) / (nx + ny) as f64,
                        Linkage::Weighted => 0.5 * (dxi + dyi),
                        Linkage::Ward => {
                            let t = 1.0 / (nx + ny + ni) as f64;
                            ((ni + nx) as f64 * t * dxi * dxi + (ni + ny) as f64 * t * dyi * dyi - ni as f64 * t * current_min * current_min).sqrt()
                        }
                        Linkage::Single => unreachable!(),
                    };
                    d[i][y] = v;
                    d[y][i] = v;
                }
            }
        }
        // np.argsort(kind='mergesort') is stable
        z.sort_by(|p, q| p.2.partial_cmp(&q.2).unwrap());
        let mut parent: Vec<usize> = (0..2 * n - 1).collect();
        let mut size = vec![1usize; 2 * n - 1];
        fn find(parent: &mut [usize], mut x: usize) -> usize {
            while parent[x] != x {
                x = parent[x];
            }
            x
        }
        z.iter()
            .enumerate()
            .map(|(k, &(x, y, h))| {
                let (a, b) = (find(&mut parent, x), find(&mut parent, y));
                parent[a] = n + k;
                parent[b] = n + k;
                size[n + k] = size[a] + size[b];
                Merge { left: a.min(b), right: a.max(b), distance: h, size: size[n + k] }
            })
            .collect()
    }

    /// Large enough for the parallel chunks (more than 4,096 active items), with many ties and
    /// cannot-links: still scipy's procedure exactly.
    #[test]
    fn parallel_chunks_follow_scipy() {
        let n = 4_700;
        let mut s = 11u64;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let mut dist = vec![vec![0.0; n]; n];
        let mut dist_full = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in i + 1..n {
                let r = rnd();
                let v = (r % 40) as f64;
                dist_full[i][j] = v;
                dist_full[j][i] = v;
                let v = if r % 7 == 0 { f64::INFINITY } else { v };
                dist[i][j] = v;
                dist[j][i] = v;
            }
        }
        for method in METHODS {
            let dist = if method == Linkage::Ward { &dist_full } else { &dist };
            assert_eq!(ours(dist, method).merges, scipy_transcription(dist, method), "{method:?}");
        }
    }
}
