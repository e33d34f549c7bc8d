//! Single linkage by Prim's minimum spanning tree on the condensed matrix (Müllner 2011,
//! "Modern hierarchical, agglomerative clustering algorithms", fig. 6; scipy's
//! `mst_single_linkage`, fastcluster's `MST_linkage_core`).
//!
//! Starting from item 0, every step adds the item `y` outside the tree whose distance to the
//! tree, `D[y] = min over tree items t of d(t, y)`, is smallest, after updating `D` with the
//! item `x` added last: `D[i] <- min(D[i], d(x, i))`. The step is recorded as `(x, y, D[y])`;
//! sorted by height (stably) and relabelled by union–find ([`super::linkage`]) these n − 1
//! edges are the single-linkage dendrogram (Müllner, theorem 3: every item added between the
//! tree end of `y`'s edge and `x` joined at a height `<= D[y]`).
//!
//! # Ties and cannot-links
//! `y` is the item with the smallest `(D[y], y)`: among equal distances the smallest index,
//! which is scipy's choice (its scan keeps the first strict minimum in index order), so the
//! steps are scipy's, ties included. `+inf` (cannot-link) is an ordinary value here: when every
//! item outside the tree is at `+inf`, the smallest index is added at height `+inf`.
//!
//! # Complexity
//! O(n²) time (every entry of the matrix is read once), O(n) memory besides the matrix (the
//! items outside the tree with their `D`, in index order, finished items marked NaN and
//! squeezed out when they are a quarter). For large n each step's scan runs in parallel chunks
//! (rayon), each returning its own minimum. The items below `x` read column `x`, one cache line
//! (and, without huge pages, one page) per row: those loads are prefetched [`AHEAD`] items ahead,
//! which at n = 5,000 more than halves the time (the loads the core overlaps by itself are too
//! few to hide the memory's latency). The same pass checks every entry (NaN, negative) for
//! [`super::linkage::dendrogram_condensed`], which so needs no pass of its own.

use super::linkage::{Condensed, RawMerge};
use rayon::prelude::*;

/// Below this many items outside the tree a step is scanned on one thread: a rayon split costs a
/// few microseconds a step; at n = 5,000 on 2 cores the serial steps were as fast for single
/// linkage (0.095 s vs 0.093 s) and faster for the chain methods (0.112-0.142 s vs 0.132-0.155 s,
/// `examples/cluster_timing`; measured before the prefetch).
const PAR_MIN: usize = 8192;
/// Items per parallel chunk.
const CHUNK: usize = 2048;
/// How many items ahead the column scans prefetch (at n = 5,000, best of 3 in CPU time on a
/// shared machine, `examples/condensed_timing`: none 0.124 s single / 0.126 s average, 16 ahead
/// 0.078 / 0.101, 32 0.058 / 0.085, 64 0.047 / 0.081, 96 0.044 / 0.075).
pub(super) const AHEAD: usize = 64;

/// The smallest `(D, index)` of a chunk: `(distance, item, position)`; `None` if every item of
/// the chunk is finished.
type Best = Option<(f64, u32, usize)>;

fn better(a: Best, b: Best) -> Best {
    match (a, b) {
        (Some(x), Some(y)) => Some(if (y.0, y.1) < (x.0, x.1) { y } else { x }),
        (x, None) => x,
        (None, y) => y,
    }
}

/// Updates `dmin` with the distances to `x` and returns the chunk's best, and whether every
/// distance read was `>= 0` (not NaN); `base` is the position of the chunk's first item.
/// Finished items have `dmin` NaN and are never chosen.
#[inline]
fn scan(m: &Condensed<'_>, x: u32, items: &[u32], dmin: &mut [f64], base: usize) -> (Best, bool) {
    // items are increasing: those below x read column x (one per row), the others row x
    let split = items.partition_point(|&i| i < x);
    let mut best_d = f64::INFINITY;
    let mut best_k = usize::MAX;
    let xs = x as usize;
    let mut valid = true;
    // one item's step, the same on both sides of x: its distance to x lowers its dmin
    let mut step = |k: usize, d: f64| {
        valid &= d >= 0.0;
        let v = &mut dmin[k];
        if d < *v {
            *v = d;
        }
        if *v < best_d {
            best_d = *v;
            best_k = k;
        }
    };
    for k in 0..split {
        if let Some(&f) = items[..split].get(k + AHEAD) {
            m.prefetch_lower(f as usize, xs);
        }
        step(k, m.get_lower(items[k] as usize, xs));
    }
    let row = m.row(xs);
    // x itself may still be listed (finished, NaN) until the next squeeze
    let from = if split < items.len() && items[split] == x { split + 1 } else { split };
    for k in from..items.len() {
        step(k, row[items[k] as usize - xs - 1]);
    }
    if best_k == usize::MAX {
        // every live item at +inf (or none live): the first live one
        match dmin.iter().position(|v| !v.is_nan()) {
            Some(k) => best_k = k,
            None => return (None, valid),
        }
    }
    (Some((best_d, items[best_k], base + best_k)), valid)
}

/// The n − 1 Prim steps `(x, y, height)` in the order they are taken (unsorted), and whether
/// every entry of the matrix was `>= 0` and not NaN (each is read exactly once: the pair of `x`
/// and `i` when the first of them joins the tree; a NaN is never chosen).
pub(super) fn mst(m: &Condensed<'_>) -> Result<(Vec<RawMerge>, bool), std::collections::TryReserveError> {
    let n = m.n();
    let mut steps = Vec::new();
    steps.try_reserve_exact(n.saturating_sub(1))?;
    if n < 2 {
        return Ok((steps, true));
    }
    let mut items: Vec<u32> = Vec::new();
    items.try_reserve_exact(n - 1)?;
    items.extend(1..n as u32);
    let mut dmin: Vec<f64> = Vec::new();
    dmin.try_reserve_exact(n - 1)?;
    dmin.resize(n - 1, f64::INFINITY);
    let mut finished = 0usize;
    let mut x = 0u32;
    let mut valid = true;
    for _ in 0..n - 1 {
        let (best, ok) = if items.len() >= PAR_MIN {
            items
                .par_chunks(CHUNK)
                .zip(dmin.par_chunks_mut(CHUNK))
                .enumerate()
                .map(|(c, (it, dm))| scan(m, x, it, dm, c * CHUNK))
                .reduce(|| (None, true), |a, b| (better(a.0, b.0), a.1 && b.1))
        } else {
            scan(m, x, &items, &mut dmin, 0)
        };
        valid &= ok;
        let (d, y, k) = best.expect("an item outside the tree remains");
        steps.push(RawMerge { x, y, distance: d });
        dmin[k] = f64::NAN;
        finished += 1;
        x = y;
        if finished * 4 > items.len() {
            let mut w = 0;
            for r in 0..items.len() {
                if !dmin[r].is_nan() {
                    items[w] = items[r];
                    dmin[w] = dmin[r];
                    w += 1;
                }
            }
            items.truncate(w);
            dmin.truncate(w);
            finished = 0;
        }
    }
    Ok((steps, valid))
}
