//! One-to-one assignment on a sparse bipartite graph (thesis Alg. 3–4's Hungarian step).
//!
//! Input: weighted candidate edges `(a, b, w)` (e.g. track pairs and their LCSS similarity).
//! Output: a set of edges, no two sharing an `a` or a `b`, with the largest total weight.
//!
//! The graph is split into connected components ([`crate::graph`]); each component is solved as a
//! dense rectangular linear sum assignment with the `lsap` crate (a port of scipy's
//! `linear_sum_assignment`, the shortest-augmenting-path Jonker–Volgenant variant). Missing
//! edges get weight 0 and are never reported. Candidate graphs of tracks are sparse (a track
//! only overlaps a few others in time), so components are small.
//!
//! # Complexity
//! O(E α(V)) for the components, then O(k³) per component of k nodes instead of O(V³), and
//! O(k²) memory (24 bytes a cell), checked against the limit `memory_bytes` before the work and
//! allocated fallibly; the solver's O(k³) steps are checked against `assign_steps`.

use crate::graph;
use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub enum AssignError {
    Weight { index: usize, value: f64 },
    Solver,
    /// A component's dense matrix (24 bytes a cell) would take more than the limit `memory_bytes`.
    Memory(crate::limits::Exceeded),
    /// The dense solves would take more than the limit `assign_steps`.
    Steps(crate::limits::Exceeded),
    /// A component's dense matrix could not be allocated (rows, columns).
    Alloc { rows: usize, cols: usize },
}

impl fmt::Display for AssignError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AssignError::Weight { index, value } => write!(f, "weight [{}] must be finite and >= 0, got {value}", index + 1),
            AssignError::Solver => write!(f, "the assignment solver failed"),
            AssignError::Memory(e) => write!(
                f,
                "{e}: a connected component of the candidate pairs is solved as a dense matrix (24 bytes a cell); pass fewer candidate pairs \
                 (a stricter threshold), or use hungarian_match, which keeps them sparse"
            ),
            AssignError::Steps(e) => write!(
                f,
                "{e}: the connected components of the candidate pairs are solved densely in O(k^3); pass fewer candidate pairs \
                 (a stricter threshold), or use hungarian_match, which keeps them sparse"
            ),
            AssignError::Alloc { rows, cols } => write!(
                f,
                "a connected component of {rows} x {cols} candidates needs a dense matrix that could not be allocated; pass fewer candidate pairs, \
                 or use hungarian_match, which keeps them sparse"
            ),
        }
    }
}
impl std::error::Error for AssignError {}

/// Indices into `edges` of a maximum-weight one-to-one matching. Edges with weight 0 are
/// never chosen; for duplicate `(a, b)` edges the heaviest counts.
pub fn assign_max(edges: &[(i64, i64, f64)]) -> Result<Vec<usize>, AssignError> {
    let a: Vec<i64> = edges.iter().map(|e| e.0).collect();
    let b: Vec<i64> = edges.iter().map(|e| e.1).collect();
    let w: Vec<f64> = edges.iter().map(|e| e.2).collect();
    assign_max_columns(&a, &b, &w)
}

/// [`assign_max`] on the edges given as three columns of equal length (the SQL list's struct
/// fields, read in place).
pub fn assign_max_columns(a: &[i64], b: &[i64], w: &[f64]) -> Result<Vec<usize>, AssignError> {
    assert!(a.len() == b.len() && b.len() == w.len(), "columns of equal length");
    for (k, &x) in w.iter().enumerate() {
        if !(x.is_finite() && x >= 0.0) {
            return Err(AssignError::Weight { index: k, value: x });
        }
    }
    let ((na, a_of), (nb, b_of)) = (graph::dense_ids(a), graph::dense_ids(b));
    let g = graph::bipartite_components(&a_of, na, &b_of, nb);
    // the largest component's dense matrix, against the limit, before any solving
    let cells = (0..g.len()).map(|c| g.n_a[c] as u128 * g.n_b[c] as u128).max().unwrap_or(0);
    let cell_bytes = (std::mem::size_of::<f64>() + std::mem::size_of::<Option<usize>>()) as u128;
    crate::limits::MEMORY_BYTES.check(cells * cell_bytes).map_err(AssignError::Memory)?;
    // and the solver's time: O(rows x columns x min(rows, columns)) per component
    let steps: u128 = (0..g.len()).map(|c| g.n_a[c] as u128 * g.n_b[c] as u128 * (g.n_a[c].min(g.n_b[c]) as u128)).sum();
    crate::limits::ASSIGN_STEPS.check(steps).map_err(AssignError::Steps)?;
    let mut chosen = Vec::new();
    for c in 0..g.len() {
        let (nr, nc) = (g.n_a[c] as usize, g.n_b[c] as usize);
        let alloc = AssignError::Alloc { rows: nr, cols: nc };
        let mut cost: Vec<f64> = Vec::new();
        let mut best: Vec<Option<usize>> = Vec::new();
        cost.try_reserve_exact(nr * nc).map_err(|_| alloc.clone())?;
        best.try_reserve_exact(nr * nc).map_err(|_| alloc)?;
        cost.resize(nr * nc, 0.0);
        best.resize(nr * nc, None);
        for &k in g.edges_of(c) {
            let k = k as usize;
            let cell = g.loc_a[k] as usize * nc + g.loc_b[k] as usize;
            if best[cell].is_none_or(|b| w[k] > w[b]) {
                best[cell] = Some(k);
                cost[cell] = w[k];
            }
        }
        let (rows, cols) = lsap::solve(nr, nc, &cost, true).map_err(|_| AssignError::Solver)?;
        for (i, j) in rows.into_iter().zip(cols) {
            if let Some(k) = best[i * nc + j] {
                if w[k] > 0.0 {
                    chosen.push(k);
                }
            }
        }
    }
    chosen.sort_unstable();
    Ok(chosen)
}

#[cfg(test)]
// The slow references index like the textbook definitions they transcribe.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute force: best total weight over all matchings (subsets of edges, tiny inputs).
    fn brute(edges: &[(i64, i64, f64)]) -> f64 {
        let n = edges.len();
        let mut best = 0.0f64;
        for mask in 0u32..(1 << n) {
            let mut used_a = vec![];
            let mut used_b = vec![];
            let mut ok = true;
            let mut s = 0.0;
            for k in 0..n {
                if mask >> k & 1 == 1 {
                    let e = edges[k];
                    if used_a.contains(&e.0) || used_b.contains(&e.1) {
                        ok = false;
                        break;
                    }
                    used_a.push(e.0);
                    used_b.push(e.1);
                    s += e.2;
                }
            }
            if ok {
                best = best.max(s);
            }
        }
        best
    }

    proptest! {
        #[test]
        fn equals_brute_force(edges in prop::collection::vec((0i64..5, 0i64..5, (0u8..10).prop_map(|v| v as f64 / 10.0)), 0..11)) {
            let got = assign_max(&edges).unwrap();
            let total: f64 = got.iter().map(|&k| edges[k].2).sum();
            prop_assert!((total - brute(&edges)).abs() < 1e-9, "{} vs {}", total, brute(&edges));
            let mut a: Vec<i64> = got.iter().map(|&k| edges[k].0).collect();
            let mut b: Vec<i64> = got.iter().map(|&k| edges[k].1).collect();
            a.sort(); b.sort();
            let (la, lb) = (a.len(), b.len());
            a.dedup(); b.dedup();
            prop_assert_eq!((a.len(), b.len()), (la, lb), "one to one");
        }
    }

    /// Issue 19: one long chain of candidates is one component, solved densely: 15k x 15k
    /// cells (5.4 GB) are refused before anything is allocated.
    #[test]
    fn a_component_above_the_memory_limit_is_refused_first() {
        let n = 15_000i64;
        let edges: Vec<(i64, i64, f64)> = (0..n).flat_map(|k| [(k, k, 0.5), (k, k + 1, 0.4)]).collect();
        let e = assign_max(&edges).unwrap_err();
        let cells = n as u128 * (n as u128 + 1);
        assert_eq!(e, AssignError::Memory(crate::limits::MEMORY_BYTES.check(cells * 24).unwrap_err()));
        assert!(e.to_string().contains("use hungarian_match"), "{e}");
    }

    #[test]
    fn picks_the_global_best_not_the_greedy() {
        // Greedy takes (1, 10, 0.9) and then only (2, 20, 0.1); the optimum is 0.8 + 0.8.
        let e = [(1, 10, 0.9), (1, 20, 0.8), (2, 10, 0.8), (2, 20, 0.1)];
        assert_eq!(assign_max(&e).unwrap(), vec![1, 2]);
        assert!(assign_max(&[(1, 1, f64::NAN)]).is_err());
        assert!(assign_max(&[(1, 1, -1.0)]).is_err());
        assert!(assign_max(&[]).unwrap().is_empty());
        assert!(assign_max(&[(1, 1, 0.0)]).unwrap().is_empty());
    }
}
