//! Sparse time-window LCSS between two sets of trajectories: η of eq. 2.10 for every pair
//! `(a_i, b_j)` with η > 0, without visiting the pairs that cannot match.
//!
//! η > 0 needs at least one match (eq. 2.9): a point of `a_i` and a point of `b_j`, both
//! inside the region when there is one, with `‖a − b‖ < ε` and `|t_a − t_b| < T`. Two road
//! users seen at the same time on opposite sides of a site can never match, yet a join on
//! time overlap scores them: in a crowd, or with 4 times the road users at once, that is 16
//! times the pairs, each pair's LCSS longer too (the pipeline's merge stage grew as n^1.6 in
//! road users per window). Here the candidates come from a space-time grid:
//!
//! 1. with a region, every trajectory is restricted to it once (not once per pair);
//! 2. the points of every `b_j` go into cells of `2ε × 2ε` metres by `2T` seconds (one entry
//!    per cell a trajectory visits: consecutive points in one cell are one entry);
//! 3. every point of `a_i` looks up the cells its box `(x ± ε, y ± ε, t ± T)` touches: at
//!    most 2 a dimension (8 cells), each visited once per `a_i`;
//! 4. the pairs found get the banded LCSS of [`super::time_window`] (its `may_match` pre-check
//!    first); those with η > 0 are kept.
//!
//! Exact, not approximate: every matching point pair lies in one of the looked-up cells
//! (division and `floor` are monotone, so `|x_b − x_a| < ε` puts `⌊x_b / 2ε⌋` between
//! `⌊(x_a − ε) / 2ε⌋` and `⌊(x_a + ε) / 2ε⌋`; likewise in t), so the result is every pair of
//! [`similarity_in`](super::time_window::similarity_in) with η > 0, with that η; a pair not
//! returned has η = 0. The cell size only decides the speed. With `ε` or `T` infinite that
//! dimension has one cell (every pair of the other dimensions is a candidate).
//!
//! # Complexity
//! O(P log P) for the grid (P the points of the b side), O(Σ_a points · 8) lookups, and the
//! banded LCSS of the candidate pairs: pairs that come within 2ε (up to 3ε diagonally) of each
//! other within 2T seconds. For a given density of road users in space that is linear in the
//! road users of a day and in the road users per window (a pair must be near in space *and*
//! time), never every pair that merely overlaps in time. Memory O(P) for the grid plus the
//! restricted copies. The a side runs in parallel (rayon); each pair's LCSS obeys
//! `lcss_cells`, the grid and the output obey `memory_bytes` and are allocated fallibly.

use super::time_window::{similarity, TimeWindowParams};
use super::LcssError;
use crate::geometry::region::{clip, Region};
use crate::limits::{self, MEMORY_BYTES};
use crate::traj::grid::CellAxis;
use crate::traj::{OwnedTraj, Traj};
use rayon::prelude::*;
use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

/// One pair with η > 0: positions in the `a` and `b` inputs, and η.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    pub a: usize,
    pub b: usize,
    pub eta: f64,
}

/// The most cells one point's query box may cover (2 a dimension, 3 with rounding: 27).
const MAX_QUERY_CELLS: u128 = 64;

/// A grid cell: (time, x, y) indices.
type Cell = (i64, i64, i64);

/// A multiplicative hash for cell keys (std's SipHash costs more than the lookups it guards;
/// the keys are not attacker-chosen in a way that matters: the worst case is a slower call).
#[derive(Default)]
struct CellHasher(u64);
impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(23) ^ v).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}
type CellMap<V> = HashMap<Cell, V, BuildHasherDefault<CellHasher>>;
type CellSet = HashSet<Cell, BuildHasherDefault<CellHasher>>;

/// One dimension of the grid: cells of `2 · reach` (infinite: one cell), queried `± reach`.
#[derive(Clone, Copy)]
struct Axis {
    cells: CellAxis,
    reach: f64,
}

impl Axis {
    fn new(reach: f64) -> Self {
        Axis { cells: CellAxis(2.0 * reach), reach }
    }
    fn cell(&self, v: f64) -> i64 {
        self.cells.cell(v)
    }
    /// The cells a point at `v` can match in: those of `v − reach` to `v + reach`.
    fn range(&self, v: f64) -> (i64, i64) {
        (self.cell(v - self.reach), self.cell(v + self.reach))
    }
}

fn alloc_err(bytes: usize) -> LcssError {
    LcssError::Alloc { bytes: bytes as u128 }
}

/// η of every pair of `a` × `b` with η > 0 (eq. 2.10, inside `region` when given, as
/// [`similarity_in`](super::time_window::similarity_in)), sorted by (a, b). Inputs must satisfy
/// [`Traj::validate`]. Errors: a pair over `lcss_cells`; the grid or the result over
/// `memory_bytes` or not allocatable.
pub fn similarity_sparse(a: &[Traj<'_>], b: &[Traj<'_>], p: &TimeWindowParams, region: Option<&Region>) -> Result<Vec<Pair>, LcssError> {
    // 1. the restriction to the region, once per trajectory
    let restrict = |side: &[Traj<'_>]| -> Option<Vec<OwnedTraj>> { region.map(|r| side.par_iter().map(|&t| clip(t, r).0).collect()) };
    let (ca, cb) = (restrict(a), restrict(b));
    let va: Vec<Traj<'_>> = match &ca {
        Some(c) => c.iter().map(OwnedTraj::view).collect(),
        None => a.to_vec(),
    };
    let vb: Vec<Traj<'_>> = match &cb {
        Some(c) => c.iter().map(OwnedTraj::view).collect(),
        None => b.to_vec(),
    };
    let short = |n: usize| n == 0 || n < p.min_points();
    let (tx, sx) = (Axis::new(p.time_window()), Axis::new(p.epsilon()));

    // 2. the grid of b: (cell, j) entries, one per run of consecutive points in a cell
    let points: usize = vb.iter().map(Traj::len).sum();
    let entry_bytes = std::mem::size_of::<(Cell, u32)>();
    MEMORY_BYTES.check((points as u128) * (entry_bytes as u128 * 2)).map_err(LcssError::Memory)?;
    let mut entries: Vec<(Cell, u32)> = Vec::new();
    entries.try_reserve(points).map_err(|_| alloc_err(points * entry_bytes))?;
    for (j, t) in vb.iter().enumerate() {
        if short(t.len()) {
            continue;
        }
        let mut last = None;
        for k in 0..t.len() {
            let c = (tx.cell(t.t[k]), sx.cell(t.x[k]), sx.cell(t.y[k]));
            if last != Some(c) {
                entries.push((c, j as u32));
                last = Some(c);
            }
        }
    }
    entries.par_sort_unstable();
    entries.dedup();
    let mut grid: CellMap<(u32, u32)> = CellMap::default();
    grid.try_reserve(entries.len() / 2 + 1).map_err(|_| alloc_err(entries.len() * 32))?;
    let mut s = 0;
    while s < entries.len() {
        let c = entries[s].0;
        let mut e = s + 1;
        while e < entries.len() && entries[e].0 == c {
            e += 1;
        }
        grid.insert(c, (s as u32, e as u32));
        s = e;
    }
    let entries: Vec<u32> = entries.into_iter().map(|(_, j)| j).collect();

    // 3-4. candidates of every a_i, then their LCSS; a_i in parallel
    let scope = limits::current();
    let rows: Vec<Result<Vec<Pair>, LcssError>> = (0..va.len())
        .into_par_iter()
        .map_init(
            || (vec![u32::MAX; vb.len()], CellSet::default(), Vec::<u32>::new()),
            |(seen, visited, cand), i| {
                limits::within(&scope, || {
                    let t = va[i];
                    if short(t.len()) {
                        return Ok(Vec::new());
                    }
                    visited.clear();
                    cand.clear();
                    let mut last = None;
                    for k in 0..t.len() {
                        let q = (tx.range(t.t[k]), sx.range(t.x[k]), sx.range(t.y[k]));
                        if last == Some(q) {
                            continue;
                        }
                        last = Some(q);
                        let ((t0, t1), (x0, x1), (y0, y1)) = q;
                        let w = |a: i64, b: i64| (b as i128 - a as i128 + 1) as u128;
                        if w(t0, t1).saturating_mul(w(x0, x1)).saturating_mul(w(y0, y1)) > MAX_QUERY_CELLS {
                            // a box of 2 cells a side spans more only where v ± reach overflowed
                            // (|v| near f64::MAX): every trajectory of b is a candidate instead
                            cand.clear();
                            cand.extend((0..vb.len() as u32).filter(|&j| !short(vb[j as usize].len())));
                            break;
                        }
                        for ct in t0..=t1 {
                            for cx in x0..=x1 {
                                for cy in y0..=y1 {
                                    if !visited.insert((ct, cx, cy)) {
                                        continue;
                                    }
                                    if let Some(&(s, e)) = grid.get(&(ct, cx, cy)) {
                                        for &j in &entries[s as usize..e as usize] {
                                            if seen[j as usize] != i as u32 {
                                                seen[j as usize] = i as u32;
                                                cand.push(j);
                                            }
                                        }
                                    }
                                }
                            }
                        }
                    }
                    cand.sort_unstable();
                    let mut out = Vec::new();
                    for &j in cand.iter() {
                        let eta = similarity(t, vb[j as usize], p)?;
                        if eta > 0.0 {
                            out.try_reserve(1).map_err(|_| alloc_err(out.len() * std::mem::size_of::<Pair>()))?;
                            out.push(Pair { a: i, b: j as usize, eta });
                        }
                    }
                    Ok(out)
                })
            },
        )
        .collect();
    let n: usize = rows.iter().map(|r| r.as_ref().map_or(0, Vec::len)).sum();
    MEMORY_BYTES.check((n * std::mem::size_of::<Pair>()) as u128).map_err(LcssError::Memory)?;
    let mut out = Vec::new();
    out.try_reserve(n).map_err(|_| alloc_err(n * std::mem::size_of::<Pair>()))?;
    for r in rows {
        out.extend(r?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lcss::time_window::similarity_in;
    use proptest::prelude::*;

    fn owned(pts: &[(f64, f64, f64)]) -> OwnedTraj {
        let mut o = OwnedTraj::default();
        for &(t, x, y) in pts {
            o.push(t, x, y);
        }
        o
    }

    /// The obviously right version: every pair, η > 0 kept.
    fn dense(a: &[Traj<'_>], b: &[Traj<'_>], p: &TimeWindowParams, r: Option<&Region>) -> Vec<Pair> {
        let mut v = Vec::new();
        for (i, x) in a.iter().enumerate() {
            for (j, y) in b.iter().enumerate() {
                let eta = similarity_in(*x, *y, p, r).unwrap();
                if eta > 0.0 {
                    v.push(Pair { a: i, b: j, eta });
                }
            }
        }
        v
    }

    /// Random walks: `n` trajectories of up to 30 points in a `size`-metre square.
    fn walks(seed: u64, n: usize, size: f64) -> Vec<OwnedTraj> {
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut rnd = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64) / ((1u64 << 53) as f64)
        };
        (0..n)
            .map(|_| {
                let len = (rnd() * 30.0) as usize;
                let (mut t, mut x, mut y) = (rnd() * 20.0, rnd() * size, rnd() * size);
                let mut pts = Vec::new();
                for _ in 0..len {
                    pts.push((t, x, y));
                    t += 0.05 + rnd() * 0.4;
                    x += rnd() * 2.0 - 1.0;
                    y += rnd() * 2.0 - 1.0;
                }
                owned(&pts)
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn equals_every_pair(seed in 0u64..1_000_000, na in 0usize..12, nb in 0usize..12, size in 1.0f64..40.0,
                             eps in prop::sample::select(vec![0.3, 1.0, 2.5, f64::INFINITY]),
                             tw in prop::sample::select(vec![0.1, 0.5, 3.0, f64::INFINITY]),
                             xi in 0i64..4, with_region in any::<bool>()) {
            let (oa, ob) = (walks(seed, na, size), walks(seed ^ 0xABCD, nb, size));
            let a: Vec<Traj<'_>> = oa.iter().map(OwnedTraj::view).collect();
            let b: Vec<Traj<'_>> = ob.iter().map(OwnedTraj::view).collect();
            let p = TimeWindowParams::new(eps, tw, xi).unwrap();
            let region = Region::from_wkt(&format!("POLYGON((0 0, {s} 0, {s} {s}, 0 0))", s = size)).unwrap();
            let r = with_region.then_some(&region);
            prop_assert_eq!(similarity_sparse(&a, &b, &p, r).unwrap(), dense(&a, &b, &p, r));
        }
    }

    #[test]
    fn pairs_on_cell_edges_are_found() {
        // points exactly on cell boundaries, just inside ε and T of each other
        let eps = 1.0;
        let a = owned(&[(0.0, 2.0, 2.0)]);
        let b = owned(&[(0.49, 2.7, 1.3), (5.0, 0.0, 0.0)]);
        let c = owned(&[(-0.49, 1.3, 2.7)]);
        let p = TimeWindowParams::new(eps, 0.5, 0).unwrap();
        let got = similarity_sparse(&[a.view()], &[b.view(), c.view()], &p, None).unwrap();
        assert_eq!(got, vec![Pair { a: 0, b: 0, eta: 1.0 }, Pair { a: 0, b: 1, eta: 1.0 }]);
    }

    #[test]
    fn a_query_box_past_f64_max_does_not_walk_the_cells() {
        // x - eps overflows to -inf: the box would span 2^63 cells; every b is a candidate instead
        let a = owned(&[(0.0, -1.7e308, 0.0)]);
        let b = owned(&[(0.0, 0.0, 0.0)]);
        let p = TimeWindowParams::new(8e307, 1.0, 0).unwrap();
        assert_eq!(similarity_sparse(&[a.view()], &[b.view()], &p, None).unwrap(), dense(&[a.view()], &[b.view()], &p, None));
        let a = owned(&[(1e308, 0.0, 0.0)]);
        let p = TimeWindowParams::new(1.0, 8e307, 0).unwrap();
        assert_eq!(similarity_sparse(&[a.view()], &[b.view()], &p, None).unwrap(), dense(&[a.view()], &[b.view()], &p, None));
    }

    #[test]
    fn empty_sides_and_far_coordinates() {
        let p = TimeWindowParams::new(1.0, 0.5, 0).unwrap();
        assert!(similarity_sparse(&[], &[], &p, None).unwrap().is_empty());
        let far = owned(&[(0.0, 1e300, -1e300), (1.0, 1e300, -1e300)]);
        let got = similarity_sparse(&[far.view()], &[far.view()], &p, None).unwrap();
        assert_eq!(got, vec![Pair { a: 0, b: 0, eta: 1.0 }]);
    }
}
