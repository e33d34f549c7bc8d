//! Complete, average, weighted and Ward linkage by the nearest-neighbour chain (Murtagh 1983;
//! Müllner 2011, fig. 5; scipy's `nn_chain`), in place on the condensed matrix.
//!
//! The chain starts at the first active cluster; its last element `x` looks up its nearest
//! active neighbour `y` (preferring the element before it in the chain when that is as close),
//! which is pushed; when `y` is the element before `x`, the two are reciprocal nearest
//! neighbours and merge. For *reducible* methods (`d(i, x ∪ y) >= min(d(i, x), d(i, y))`, true
//! of complete, average, weighted and Ward) a merge never makes a cluster closer to the rest of
//! the chain, so the chain stays valid and every reciprocal pair is a merge of the generic
//! algorithm. The merged cluster takes the larger index `y`; its distances come from the
//! Lance–Williams formulas, written as scipy writes them (same operations, same order, so the
//! same floating-point results):
//! * complete `max(d_xi, d_yi)`; weighted `(d_xi + d_yi) / 2`;
//! * average `(n_x d_xi + n_y d_yi) / (n_x + n_y)`;
//! * ward `sqrt(((n_i + n_x) t d_xi² + (n_i + n_y) t d_yi² − n_i t d_xy²))`, `t = 1 / (n_x + n_y + n_i)`
//!   (clamped at 0 against rounding: for reciprocal neighbours the exact value is `>= d_xy`).
//!
//! # Ties and cannot-links
//! The nearest neighbour of `x` is the smallest `(distance, index)` among the active clusters,
//! except that the previous chain element wins ties with it: scipy's rule, so the merges are
//! scipy's, ties included. `+inf` is an ordinary value: complete, average and weighted keep it
//! `+inf`, so clusters at `+inf` merge only at `+inf` (after every finite merge once sorted).
//!
//! # Complexity
//! O(n²) time: every merge updates one row and column of the active clusters (O(n)), and the
//! chain grows at most 3n times in all (each growth costs one O(n) scan). O(n) memory besides the
//! matrix (the sorted active list, sizes, the chain). Scans and updates over many active
//! clusters run in parallel chunks (rayon). Their column reads (one cache line per row) are
//! prefetched [`AHEAD`] items ahead, as in [`super::mst`].

use super::condensed::{Condensed, Linkage, RawMerge, AHEAD};
use rayon::prelude::*;

/// Below this many active clusters a scan or update runs on one thread (see mst.rs: at n = 5,000
/// the serial chain was faster on 2 cores).
const PAR_MIN: usize = 8192;
/// Clusters per parallel chunk.
const CHUNK: usize = 2048;

/// The smallest `(distance, cluster)` over `items` other than `x`; `None` when there is none.
#[inline]
fn nearest(m: &Condensed<'_>, x: u32, items: &[u32]) -> Option<(f64, u32)> {
    let split = items.partition_point(|&i| i < x);
    let xs = x as usize;
    let mut best_d = f64::INFINITY;
    let mut best = u32::MAX;
    let col = &items[..split];
    for (k, &i) in col.iter().enumerate() {
        if let Some(&f) = col.get(k + AHEAD) {
            m.prefetch_lower(f as usize, xs);
        }
        let d = m.get_lower(i as usize, xs);
        if d < best_d {
            best_d = d;
            best = i;
        }
    }
    let row = m.row(xs);
    let rest = if split < items.len() && items[split] == x { &items[split + 1..] } else { &items[split..] };
    for &i in rest {
        let d = row[i as usize - xs - 1];
        if d < best_d {
            best_d = d;
            best = i;
        }
    }
    if best == u32::MAX {
        // all at +inf: the first other cluster
        best = *items.iter().find(|&&i| i != x)?;
    }
    Some((best_d, best))
}

fn nearest_par(m: &Condensed<'_>, x: u32, items: &[u32]) -> Option<(f64, u32)> {
    if items.len() < PAR_MIN {
        return nearest(m, x, items);
    }
    items.par_chunks(CHUNK).map(|c| nearest(m, x, c)).reduce(
        || None,
        |a, b| match (a, b) {
            (Some(p), Some(q)) => Some(if q < p { q } else { p }),
            (p, None) => p,
            (None, q) => q,
        },
    )
}

/// Lance–Williams update of `d(i, x ∪ y)` (see module docs); `recip[s] = 1.0 / s` (ward's `t`,
/// the same value as the division, from a table: a division per update costs more than the
/// rest of it).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn update(method: Linkage, dxi: f64, dyi: f64, dxy: f64, nx: u32, ny: u32, ni: u32, recip: &[f64]) -> f64 {
    match method {
        Linkage::Complete => {
            if dxi > dyi {
                dxi
            } else {
                dyi
            }
        }
        Linkage::Average => (nx as f64 * dxi + ny as f64 * dyi) / (nx + ny) as f64,
        Linkage::Weighted => 0.5 * (dxi + dyi),
        Linkage::Ward => {
            let t = recip[(nx + ny + ni) as usize];
            let s = (ni + nx) as f64 * t * dxi * dxi + (ni + ny) as f64 * t * dyi * dyi - ni as f64 * t * dxy * dxy;
            if s > 0.0 {
                s.sqrt()
            } else {
                0.0
            }
        }
        Linkage::Single => dxi.min(dyi),
    }
}

/// Writes `d(i, y) <- update(d(i, x), d(i, y))` for the active `items` (x < y; x and y skipped).
/// The items below `y` read column `y` (one cache line per row, prefetched ahead), those below
/// `x` column `x` too; the rest read rows.
#[inline]
#[allow(clippy::too_many_arguments)]
fn update_all<M: MethodConst>(m: &Condensed<'_>, items: &[u32], sizes: &[u32], recip: &[f64], x: usize, y: usize, dxy: f64, nx: u32, ny: u32) {
    let below_y = &items[..items.partition_point(|&i| (i as usize) < y)];
    for (k, &i) in below_y.iter().enumerate() {
        if let Some(&f) = below_y.get(k + AHEAD) {
            let f = f as usize;
            if f < x {
                m.prefetch_lower(f, x);
            }
            m.prefetch_lower(f, y);
        }
        let i = i as usize;
        if i == x {
            continue;
        }
        let (dxi, dyi) = (m.get(i, x), m.get_lower(i, y));
        let v = update(M::METHOD, dxi, dyi, dxy, nx, ny, sizes[i], recip);
        // SAFETY: each active i writes only its own cell (i, y), which no other i reads or
        // writes during this update; nothing holds a slice of the matrix meanwhile.
        unsafe { m.set(i, y, v) };
    }
    for &i in &items[below_y.len()..] {
        let i = i as usize;
        if i == y {
            continue;
        }
        let (dxi, dyi) = (m.get_lower(x, i), m.get_lower(y, i));
        let v = update(M::METHOD, dxi, dyi, dxy, nx, ny, sizes[i], recip);
        // SAFETY: as above.
        unsafe { m.set(i, y, v) };
    }
}

/// The method as a type, so that [`update`]'s match is resolved at compile time.
trait MethodConst: Sync {
    const METHOD: Linkage;
}
macro_rules! method_const {
    ($t:ident, $m:expr) => {
        struct $t;
        impl MethodConst for $t {
            const METHOD: Linkage = $m;
        }
    };
}
method_const!(Complete, Linkage::Complete);
method_const!(Average, Linkage::Average);
method_const!(Weighted, Linkage::Weighted);
method_const!(Ward, Linkage::Ward);

/// The n − 1 merges `(x, y, height)` in the order they are found (unsorted). Overwrites `m`.
pub(super) fn nn_chain(m: &Condensed<'_>, method: Linkage) -> Result<Vec<RawMerge>, std::collections::TryReserveError> {
    match method {
        Linkage::Complete => run::<Complete>(m),
        Linkage::Average => run::<Average>(m),
        Linkage::Weighted => run::<Weighted>(m),
        Linkage::Ward => run::<Ward>(m),
        Linkage::Single => unreachable!("single linkage is mst"),
    }
}

fn run<M: MethodConst>(m: &Condensed<'_>) -> Result<Vec<RawMerge>, std::collections::TryReserveError> {
    let n = m.n();
    let mut steps = Vec::new();
    steps.try_reserve_exact(n.saturating_sub(1))?;
    if n < 2 {
        return Ok(steps);
    }
    let mut items: Vec<u32> = Vec::new();
    items.try_reserve_exact(n)?;
    items.extend(0..n as u32);
    let mut sizes: Vec<u32> = Vec::new();
    sizes.try_reserve_exact(n)?;
    sizes.resize(n, 1);
    let mut recip: Vec<f64> = Vec::new();
    if M::METHOD == Linkage::Ward {
        recip.try_reserve_exact(n + 1)?;
        recip.extend((0..=n).map(|s| 1.0 / s as f64));
    }
    let mut chain: Vec<u32> = Vec::new();
    chain.try_reserve_exact(n)?;
    for _ in 0..n - 1 {
        if chain.is_empty() {
            chain.push(items[0]);
        }
        let (x, y, dxy) = loop {
            let x = *chain.last().expect("chain not empty");
            let prev = if chain.len() > 1 { Some(chain[chain.len() - 2]) } else { None };
            let (d, nn) = nearest_par(m, x, &items).expect("two active clusters");
            let (d, y) = match prev {
                Some(p) => {
                    let dp = m.get(x as usize, p as usize);
                    if dp <= d {
                        (dp, p)
                    } else {
                        (d, nn)
                    }
                }
                None => (d, nn),
            };
            if Some(y) == prev {
                break (x, y, d);
            }
            chain.push(y);
        };
        chain.truncate(chain.len() - 2);
        let (x, y) = (x.min(y) as usize, x.max(y) as usize);
        let (nx, ny) = (sizes[x], sizes[y]);
        steps.push(RawMerge { x: x as u32, y: y as u32, distance: dxy });
        if items.len() >= PAR_MIN {
            let (s, r) = (&sizes, &recip);
            items.par_chunks(CHUNK).for_each(|c| update_all::<M>(m, c, s, r, x, y, dxy, nx, ny));
        } else {
            update_all::<M>(m, &items, &sizes, &recip, x, y, dxy, nx, ny);
        }
        sizes[x] = 0;
        sizes[y] = nx + ny;
        let k = items.binary_search(&(x as u32)).expect("x is active");
        items.remove(k);
    }
    Ok(steps)
}
