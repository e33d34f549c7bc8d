//! Translation-invariant similarity `S2_2D` of Buzan (2004), definition 4.3, eq. 4.6:
//! `S2 = max over translations (c_x, c_y) of S1(A, B + (c_x, c_y))`.
//!
//! Because `S1` is computed per axis, the maximum splits into one search per axis. On one
//! axis, translating B by `c` lets `b_j` match `a_i` (with `|i − j| ≤ δ`) exactly when
//! `c ∈ (a_i − b_j − ε, a_i − b_j + ε)`: one open interval per pair in the band, O(δ·(n+m))
//! of them (lemma 4.2). The set of matchable pairs only changes at interval endpoints, so
//! one representative per cell between consecutive distinct endpoints (its midpoint) covers
//! every distinct LCSS problem.
//!
//! Improvement over the plain method (theorem 4.1, O(δ²·(n+m)²)): the number of intervals
//! covering a cell is an upper bound on the LCSS for any translation in that cell. Cells are
//! evaluated in decreasing order of that bound, and the search stops once the bound cannot
//! beat the best length found (branch and bound). The answer is identical; the worst case
//! is unchanged, the typical case evaluates a handful of cells.
//!
//! Ties between translations with equal LCSS go to the first cell in (bound desc, c asc)
//! order, which makes the result deterministic.
//!
//! # Complexity
//! O(K log K) to sort the K = O(δ·(n+m)) endpoints, then O(δ·(n+m)) per evaluated cell;
//! O(K) memory. Inputs of [`PARALLEL_MIN_POINTS`] points or more evaluate cells on all cores;
//! more than [`MAX_CANDIDATES`] candidates is an error ([`check_size`]).

use super::LcssError;
use super::index::{axis_length, IndexParams};
use crate::traj::Traj;

/// Result of [`s2`]: per-axis similarity and the translation of B that achieves it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct S2 {
    pub lx: usize,
    pub ly: usize,
    pub sx: f64,
    pub sy: f64,
    /// Add `(cx, cy)` to every point of B to obtain the best match against A.
    pub cx: f64,
    pub cy: f64,
}

/// Candidate cells on one axis: `(bound, representative translation)`, with bound > 0.
///
/// The bound of a cell is `min(#distinct i, #distinct j)` over the intervals covering it: an
/// LCSS uses each point at most once, so this is an upper bound on the LCSS of any translation
/// in the cell, and far tighter than the raw number of covering intervals (which counts up to
/// 2δ+1 intervals per point).
pub(crate) fn candidate_cells(a: &[f64], b: &[f64], delta: usize, epsilon: f64) -> Vec<(u32, f64)> {
    let m = b.len();
    // (position, +1 start / -1 end, i, j)
    let mut ev: Vec<(f64, i8, u32, u32)> = Vec::new();
    for (i, &ai) in a.iter().enumerate() {
        let lo = i.saturating_sub(delta).min(m);
        let hi = i.saturating_add(delta).saturating_add(1).min(m);
        for (j, &bj) in b.iter().enumerate().take(hi).skip(lo) {
            let d = ai - bj;
            ev.push((d - epsilon, 1, i as u32, j as u32));
            ev.push((d + epsilon, -1, i as u32, j as u32));
        }
    }
    // Open intervals: at equal positions process ends (-1) before starts (+1).
    ev.sort_unstable_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
    let mut cnt_i = vec![0u32; a.len()];
    let mut cnt_j = vec![0u32; m];
    let (mut di, mut dj) = (0u32, 0u32);
    let mut cells = Vec::new();
    let mut k = 0;
    while k < ev.len() {
        let x = ev[k].0;
        while k < ev.len() && ev[k].0 == x {
            let (_, s, i, j) = ev[k];
            let (ci, cj) = (&mut cnt_i[i as usize], &mut cnt_j[j as usize]);
            if s > 0 {
                di += (*ci == 0) as u32;
                dj += (*cj == 0) as u32;
                *ci += 1;
                *cj += 1;
            } else {
                *ci -= 1;
                *cj -= 1;
                di -= (*ci == 0) as u32;
                dj -= (*cj == 0) as u32;
            }
            k += 1;
        }
        let bound = di.min(dj);
        if bound > 0 && k < ev.len() {
            let next = ev[k].0;
            cells.push((bound, x + (next - x) / 2.0));
        }
    }
    cells
}

/// Best translation on one axis: `(length, c)`. With ε = ∞ every translation is optimal and
/// `c = 0` is returned.
pub fn best_axis_translation(a: &[f64], b: &[f64], delta: usize, epsilon: f64) -> Result<(usize, f64), LcssError> {
    if a.is_empty() || b.is_empty() {
        return Ok((0, 0.0));
    }
    if !epsilon.is_finite() {
        return Ok((axis_length(a, b, delta, epsilon, 0.0)?, 0.0));
    }
    let mut cells = candidate_cells(a, b, delta, epsilon);
    cells.sort_by(|p, q| q.0.cmp(&p.0).then(p.1.total_cmp(&q.1)));
    let (mut best, mut best_c) = (0usize, 0.0);
    // Small inputs: one cell at a time. Large inputs: evaluate the next batch of cells on all
    // cores; the batch is taken in the same order and ties resolve to the earliest cell, so
    // the answer is the same as the sequential one.
    let batch = if a.len() + b.len() >= PARALLEL_MIN_POINTS { rayon::current_num_threads().max(1) * 2 } else { 1 };
    let mut k = 0;
    while k < cells.len() && (cells[k].0 as usize) > best {
        let end = (k + batch).min(cells.len());
        let todo: Vec<(u32, f64)> = cells[k..end].iter().copied().filter(|c| c.0 as usize > best).collect();
        let lens: Vec<usize> = if batch > 1 {
            use rayon::prelude::*;
            // the workers check the work limit of the caller's scope
            let scope = crate::limits::current();
            let len = |c: f64| crate::limits::within(&scope, || axis_length(a, b, delta, epsilon, c));
            todo.par_iter().map(|&(_, c)| len(c)).collect::<Result<_, _>>()?
        } else {
            todo.iter().map(|&(_, c)| axis_length(a, b, delta, epsilon, c)).collect::<Result<_, _>>()?
        };
        for (&(_, c), l) in todo.iter().zip(lens) {
            if l > best {
                best = l;
                best_c = c;
            }
        }
        k = end;
    }
    Ok((best, best_c))
}

/// Inputs with at least this many points (n + m) search translations on all cores.
pub const PARALLEL_MIN_POINTS: usize = 4096;

/// Upper limit on the candidate translations of one axis (2 per banded pair), about 800 MB
/// of work space; larger inputs are rejected with [`LcssError::TooLarge`] rather than
/// exhausting memory.
pub const MAX_CANDIDATES: usize = 50_000_000;

/// Checks the size of the candidate set before [`s2`] allocates it.
pub fn check_size(n: usize, m: usize, p: &IndexParams) -> Result<(), LcssError> {
    let per_row = (2 * p.delta() + 1).min(m);
    let k = n.saturating_mul(per_row).saturating_mul(2);
    if k > MAX_CANDIDATES {
        Err(LcssError::TooLarge { candidates: k, limit: MAX_CANDIDATES })
    } else {
        Ok(())
    }
}

/// [`s2`] after [`check_size`]: the form for untrusted input sizes.
pub fn s2_checked(a: Traj<'_>, b: Traj<'_>, p: &IndexParams) -> Result<S2, LcssError> {
    check_size(a.len(), b.len(), p)?;
    s2(a, b, p)
}

/// `S2_2D(δ, ε, A, B)` with the ρ test of definition 4.1.
pub fn s2(a: Traj<'_>, b: Traj<'_>, p: &IndexParams) -> Result<S2, LcssError> {
    if p.rejects(a.len(), b.len()) {
        return Ok(S2 { lx: 0, ly: 0, sx: 0.0, sy: 0.0, cx: 0.0, cy: 0.0 });
    }
    let (lx, cx) = best_axis_translation(a.x, b.x, p.delta(), p.epsilon())?;
    let (ly, cy) = best_axis_translation(a.y, b.y, p.delta(), p.epsilon())?;
    let k = a.len().min(b.len()) as f64;
    Ok(S2 { lx, ly, sx: lx as f64 / k, sy: ly as f64 / k, cx, cy })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn vals(max: usize) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec((0u8..8).prop_map(|k| k as f64 * 0.5), 0..max)
    }

    proptest! {
        #[test]
        fn pruned_search_equals_exhaustive(a in vals(9), b in vals(9), d in 0usize..4,
                                           eps in prop::sample::select(vec![0.25, 0.5, 1.0]),
                                           shifts in prop::collection::vec(-5.0f64..5.0, 8)) {
            let (got, c) = best_axis_translation(&a, &b, d, eps).unwrap();
            let len = |c: f64| axis_length(&a, &b, d, eps, c).unwrap();
            // Exhaustive: every cell representative, no pruning.
            let exhaustive = candidate_cells(&a, &b, d, eps).iter()
                .map(|&(_, c)| len(c)).max().unwrap_or(0);
            prop_assert_eq!(got, exhaustive);
            // The returned translation achieves it.
            prop_assert_eq!(len(c), got);
            // No random translation beats it.
            for s in shifts { prop_assert!(len(s) <= got); }
            prop_assert!(len(0.0) <= got);
        }
    }

    #[test]
    fn large_inputs_use_the_parallel_path_and_agree() {
        let n = PARALLEL_MIN_POINTS;
        let a: Vec<f64> = (0..n).map(|k| ((k * 7919) % 101) as f64 * 0.1).collect();
        let b: Vec<f64> = (0..n).map(|k| ((k * 104729) % 97) as f64 * 0.1 + 3.0).collect();
        let (l, c) = best_axis_translation(&a, &b, 1, 0.05).unwrap();
        // Sequential evaluation of the same ordered cells gives the same answer.
        let mut cells = candidate_cells(&a, &b, 1, 0.05);
        cells.sort_by(|p, q| q.0.cmp(&p.0).then(p.1.total_cmp(&q.1)));
        let mut best = (0, 0.0);
        for (bound, cc) in cells {
            if bound as usize <= best.0 { break; }
            let v = axis_length(&a, &b, 1, 0.05, cc).unwrap();
            if v > best.0 { best = (v, cc); }
        }
        assert_eq!((l, c), best);
        let p = IndexParams::new(100_000, 1.0, None).unwrap();
        assert!(check_size(10_000, 10_000, &p).is_err());
        assert!(check_size(100, 100, &p).is_ok());
    }

    #[test]
    fn recovers_a_shift() {
        let ax: Vec<f64> = (0..20).map(|k| (k as f64 * 0.3).sin() * 5.0).collect();
        let ay: Vec<f64> = (0..20).map(|k| k as f64).collect();
        let bx: Vec<f64> = ax.iter().map(|v| v - 100.0).collect();
        let by: Vec<f64> = ay.iter().map(|v| v + 7.5).collect();
        let t = vec![0.0; 20];
        let p = IndexParams::new(2, 0.1, None).unwrap();
        let r = s2(Traj::new(&t, &ax, &ay), Traj::new(&t, &bx, &by), &p).unwrap();
        assert_eq!((r.lx, r.ly), (20, 20));
        assert!((r.cx - 100.0).abs() < 0.1 && (r.cy + 7.5).abs() < 0.1, "{r:?}");
        assert_eq!(r.sx, 1.0);
    }
}
