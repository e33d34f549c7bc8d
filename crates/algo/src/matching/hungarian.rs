//! Optimal one-to-one assignment on a sparse, rectangular candidate list: the Hungarian step
//! of thesis Alg. 2–4 (`hungarian_match` in SQL).
//!
//! # Problem
//! Given candidate pairs `(a, b, score)`, choose pairs, no two sharing an `a` or a `b`, such that
//! (1) as many pairs as possible are chosen (maximum cardinality), and (2) among those, the
//! total score is largest (`maximize`) or smallest (costs). Pairs absent from the list can
//! never be chosen. This is exactly `scipy.optimize.linear_sum_assignment` on the dense matrix
//! with absent pairs forbidden (±inf) whenever scipy finds that matrix feasible, and the natural
//! extension when it does not (scipy raises "cost matrix is infeasible"; we leave the rows that
//! cannot be matched unmatched).
//!
//! The thesis instead runs Hungarian on a dense matrix with 0 for non-candidates and drops the
//! zero pairs afterwards, which maximises the total without the cardinality rule; that variant
//! is `assign_pairs` ([`crate::matching::assign`]). The `min_score` threshold is applied *before*
//! solving (pairs that fail it are not candidates): applied afterwards, a forced larger
//! matching could pick two weak pairs over one strong one and then drop both.
//!
//! # Rules
//! * a NaN or infinite score is an error; a duplicated `(a, b)` keeps its best score (the max
//!   when maximising, the min for costs);
//! * ties are broken deterministically: the solvers see the pairs in canonical `(a, b)` order
//!   (ids numbered in increasing order of value), so the same set of pairs gives the same
//!   answer in any list order.
//!
//! # Algorithm and complexity
//! For `m` pairs with `na` distinct `a` and `nb` distinct `b` ([`hungarian_match_columns`]
//! reads the three columns in place):
//! * ids are numbered by a lookup table when they span a small range (row numbers; O(m)),
//!   otherwise by a sort of the distinct values (O(m log m));
//! * a complete list (every `(a, b)` present, duplicates allowed) is scattered straight into a
//!   flat `rows × columns` matrix, rows the smaller side, and solved by the classic dense LAPJV
//!   ([`solve_complete`]: column reduction, reduction transfer, two passes of augmenting row
//!   reduction, shortest augmenting paths with the column-list scan; O(n³) worst case);
//! * any other list is put in canonical order by two counting sorts on the ids (O(m + na + nb),
//!   skipped when already in order), deduplicated, and split into connected components
//!   (union–find, O(m α)); components are solved independently (in parallel for large inputs),
//!   complete ones by the dense LAPJV, the others by Jonker–Volgenant in sparse form
//!   ([`solve_sparse`]): a square component first as LAPJVsp (scipy's
//!   `min_weight_full_bipartite_matching`) does, from the column reduction and reduction
//!   transfer; then augmenting row reduction (4 passes) places most rows cheaply, and every row
//!   still free gets a Dijkstra over reduced costs `c - u - v >= 0`, stopping at the first free
//!   column (labels at or above the best free column are never queued), followed by the dual
//!   update and augmentation. Sparse components run Dijkstra on a 4-ary heap, dense ones
//!   (≥ 25 % of cells) with JV's linear scans. O(R · E log V) worst case for R rows left
//!   after the reductions;
//! * `lsap` (scipy's LSAP port) is the reference in the property tests. The hand-written
//!   solvers are used because a dense solver cannot hold a 50,000 × 50,000 sparse problem, and
//!   LAPJV's reductions leave few rows for the augmenting phase (`benches/peers_hungarian.py`
//!   times both shapes against scipy and lap; `cargo run --release -p trajdb-algo --example
//!   hungarian_sparse` without DuckDB).
//!
//! Maximum cardinality is obtained by giving every row a private "unmatched" column of cost
//! `M = range · (rows + 1) + 1` (`range` = spread of the costs): any matching with one more real
//! pair is cheaper than any with one fewer, so the result is the best among the largest
//! matchings; the private columns are dropped from the output. (For lsap the absent cells
//! carry the same `M`.) A square component whose rows can all be matched needs no private
//! columns: it is solved without them first, and again with them only when some row finds no
//! augmenting path.

use crate::graph::{self, Components};
use rayon::prelude::*;
use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub enum MatchError {
    /// 0-based index of a NaN or infinite score.
    Score { index: usize, value: f64 },
    /// `min_score` is NaN.
    Threshold(f64),
    /// lsap reported a failure (cannot happen with finite costs).
    Solver,
    /// A working array of this many elements could not be allocated.
    Alloc(usize),
}

impl fmt::Display for MatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MatchError::Score { index, value } => write!(f, "pairs[{}].score must be finite and within ±1e150, got {value:?}", index + 1),
            MatchError::Threshold(v) => write!(f, "min_score must not be NaN, got {v}"),
            MatchError::Solver => write!(f, "the assignment solver failed"),
            MatchError::Alloc(n) => write!(f, "a working array of {n} elements could not be allocated; pass fewer candidate pairs (a stricter min_score)"),
        }
    }
}
impl std::error::Error for MatchError {}

/// Validated options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatchParams {
    pub maximize: bool,
    /// Candidates must score `>= min_score` (maximize) or `<= min_score` (costs).
    pub min_score: Option<f64>,
}

impl MatchParams {
    pub fn new(maximize: bool, min_score: Option<f64>) -> Result<Self, MatchError> {
        if let Some(t) = min_score {
            if t.is_nan() {
                return Err(MatchError::Threshold(t));
            }
        }
        Ok(MatchParams { maximize, min_score })
    }
}

const NONE: u32 = u32::MAX;
/// Passes of augmenting row reduction (JV use 2; passes after the second run only while more
/// than 1/64 of the rows are free). On the 50k × 50k bench the square start (column reduction)
/// leaves 405 of 50,000 rows for the Dijkstra phase after 2 passes; from zero prices (the
/// private-column solve) 4 passes leave 712 (8 measured no better).
const ARR_PASSES: usize = 4;

/// The state of one column, packed so that relaxing an edge touches one cache line (the
/// columns of a large sparse component are visited in random order).
#[derive(Clone, Copy)]
struct Col {
    /// Dual (price).
    v: f64,
    /// Tentative distance of the current search (∞ when unlabelled).
    dist: f64,
    /// The row assigned to the column (`NONE` = free).
    row: u32,
    /// The row the current search reached it from.
    pred: u32,
    /// Settled by the current search.
    done: bool,
}

/// A min-heap of `(dist, column)` labels with lazy deletion (a column may be in it several
/// times; stale labels are skipped when popped). Keys are inline, so sifting touches only the
/// heap. Ties go to the lower column index.
#[derive(Default)]
struct Heap(Vec<(f64, u32)>);

impl Heap {
    #[inline]
    fn less(a: (f64, u32), b: (f64, u32)) -> bool {
        a.0 < b.0 || (a.0 == b.0 && a.1 < b.1)
    }
    fn push(&mut self, x: (f64, u32)) {
        let h = &mut self.0;
        let mut k = h.len();
        h.push(x);
        while k > 0 {
            let p = (k - 1) / 4;
            if !Self::less(x, h[p]) {
                break;
            }
            h[k] = h[p];
            k = p;
        }
        h[k] = x;
    }
    fn peek(&self) -> Option<(f64, u32)> {
        self.0.first().copied()
    }
    fn pop(&mut self) -> Option<(f64, u32)> {
        let h = &mut self.0;
        let top = *h.first()?;
        let last = h.pop().expect("non-empty");
        let n = h.len();
        if n > 0 {
            let mut k = 0;
            loop {
                let c0 = 4 * k + 1;
                if c0 >= n {
                    break;
                }
                let mut m = c0;
                for c in c0 + 1..(c0 + 4).min(n) {
                    if Self::less(h[c], h[m]) {
                        m = c;
                    }
                }
                if !Self::less(h[m], last) {
                    break;
                }
                h[k] = h[m];
                k = m;
            }
            h[k] = last;
        }
        Some(top)
    }
    fn clear(&mut self) {
        self.0.clear();
    }
}

/// Min-cost maximum-cardinality assignment of a component with `nr <= nc`, edges in CSR
/// (`start[i]..start[i+1]` into `adj`, columns increasing). Returns `col4row` (`NONE` =
/// unmatched).
///
/// A square component is first solved as LAPJVsp does (scipy's
/// `min_weight_full_bipartite_matching`): without private columns, starting from the column
/// reduction and reduction transfer ([`column_reduction`]); that is exact when every row can be
/// matched (a perfect matching has maximum cardinality). When a row finds no augmenting path
/// there is no perfect matching, and the component is solved again with the private columns.
/// Those make the problem rectangular, where the column reduction is not valid (a column left
/// free must keep the largest price), so that solve starts from zero prices.
pub(crate) fn solve_sparse(nr: usize, nc: usize, start: &[usize], adj: &[(u32, f64)], scan: bool) -> Vec<u32> {
    if nr == nc {
        if let Some(x) = solve_jv(nr, nc, start, adj, scan, false) {
            return x;
        }
    }
    solve_jv(nr, nc, start, adj, scan, true).expect("a private column is always free")
}

/// Jonker & Volgenant (1987), sparse form: [`column_reduction`] (without private columns) or
/// zero prices, augmenting row reduction, then one Dijkstra per row still free. With
/// `private`, every row `i` has an extra column `nc + i` of cost `big`; without, `None` when
/// some row cannot be matched. `scan` picks the next column by a linear scan of the labelled
/// columns instead of a heap (JV's dense variant): cheaper when rows are long.
fn solve_jv(nr: usize, nc: usize, start: &[usize], adj: &[(u32, f64)], scan: bool, private: bool) -> Option<Vec<u32>> {
    let (mut cmin, mut cmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for &(_, c) in adj {
        cmin = cmin.min(c);
        cmax = cmax.max(c);
    }
    let big = (cmax - cmin) * (nr as f64 + 1.0) + 1.0;
    let cost = |c: f64| c - cmin;
    // real columns, then one private column per row
    let ncol = nc + if private { nr } else { 0 };
    let own = |i: usize| std::iter::once(((nc + i) as u32, big)).take(private as usize);
    let mut u = vec![0.0f64; nr];
    let mut cols = vec![Col { v: 0.0, dist: f64::INFINITY, row: NONE, pred: NONE, done: false }; ncol];
    let mut col4row = vec![NONE; nr];
    let mut free = if private { (0..nr as u32).collect() } else { column_reduction(nr, nc, start, adj, cmin, &mut cols, &mut col4row) };
    // Jonker–Volgenant augmenting row reduction: each free row takes the column of its smallest
    // reduced cost h = c - v and lowers that column's v by the gap to its second smallest,
    // displacing the previous owner (re-processed at once when the gap was positive). v only
    // ever decreases, so every assigned row keeps a minimal-h column: with u = min_j h the
    // duals are feasible and the matched edges tight, as Dijkstra needs.
    for pass in 0..ARR_PASSES {
        if pass >= 2 && free.len() * 64 < nr {
            break;
        }
        let prev = std::mem::take(&mut free);
        let mut stack: Vec<u32> = prev.into_iter().rev().collect();
        let mut steps = 0usize;
        while let Some(i) = stack.pop() {
            let iu = i as usize;
            let (mut h1, mut j1, mut h2, mut j2) = (f64::INFINITY, NONE, f64::INFINITY, NONE);
            for (j, c) in adj[start[iu]..start[iu + 1]].iter().map(|&(j, c)| (j, cost(c))).chain(own(iu)) {
                let h = c - cols[j as usize].v;
                if h < h2 {
                    if h < h1 {
                        (h2, j2) = (h1, j1);
                        (h1, j1) = (h, j);
                    } else {
                        (h2, j2) = (h, j);
                    }
                }
            }
            let mut i0 = cols[j1 as usize].row;
            // (a row with one edge and no private column has no second column: no price change)
            let strict = h1 < h2 && h2 < f64::INFINITY;
            if strict {
                cols[j1 as usize].v -= h2 - h1;
            } else if i0 != NONE && j2 != NONE {
                j1 = j2;
                i0 = cols[j2 as usize].row;
            }
            if i0 != NONE {
                col4row[i0 as usize] = NONE;
            }
            cols[j1 as usize].row = i;
            col4row[iu] = j1;
            if i0 != NONE {
                steps += 1;
                // Bounded like the paper's loop: a displaced row is retried at once only while
                // the work stays linear in the number of rows; otherwise it waits for Dijkstra.
                if strict && steps < 4 * nr {
                    stack.push(i0);
                } else {
                    free.push(i0);
                }
            }
        }
    }
    for i in 0..nr {
        u[i] = adj[start[i]..start[i + 1]].iter().map(|&(j, c)| (j, cost(c))).chain(own(i)).map(|(j, c)| c - cols[j as usize].v).fold(f64::INFINITY, f64::min);
    }
    let mut touched: Vec<u32> = Vec::new();
    let mut finished: Vec<u32> = Vec::new();
    let mut heap = Heap::default();
    // Rows still free, in increasing order (the displaced rows of the ARR come last there).
    free.sort_unstable();
    for &s in &free {
        let s = s as usize;
        // Dijkstra from row s over reduced costs. `bound` is the best tentative distance of a
        // free column seen so far: the search ends there, so no label at or above it is kept.
        let mut bound = (f64::INFINITY, NONE);
        let relax = |i: usize, base: f64, cols: &mut [Col], heap: &mut Heap, bound: &mut (f64, u32), touched: &mut Vec<u32>| {
            let ui = u[i];
            for (j, c) in adj[start[i]..start[i + 1]].iter().map(|&(j, c)| (j, cost(c))).chain(own(i)) {
                let col = &mut cols[j as usize];
                let nd = base + (c - ui - col.v).max(0.0);
                if nd < col.dist && nd < bound.0 {
                    if col.dist == f64::INFINITY {
                        touched.push(j);
                    }
                    col.dist = nd;
                    col.pred = i as u32;
                    if col.row == NONE {
                        *bound = (nd, j);
                    } else if !scan {
                        heap.push((nd, j));
                    }
                }
            }
        };
        relax(s, 0.0, &mut cols, &mut heap, &mut bound, &mut touched);
        let (sink, delta) = loop {
            let next = if scan {
                // The closest labelled, unfinished, matched column (ties: lowest index).
                let mut best = (f64::INFINITY, NONE);
                for &j in &touched {
                    let c = &cols[j as usize];
                    if !c.done && c.row != NONE && (c.dist < best.0 || (c.dist == best.0 && j < best.1)) {
                        best = (c.dist, j);
                    }
                }
                (best.1 != NONE).then_some(best)
            } else {
                heap.peek()
            };
            let Some((d, j)) = next.filter(|&(d, _)| d < bound.0) else {
                // The best free column is the closest remaining node: the path ends there.
                let j = bound.1;
                if j == NONE {
                    return None; // no augmenting path from s: no perfect matching
                }
                cols[j as usize].done = true;
                finished.push(j);
                break (j as usize, bound.0);
            };
            if !scan {
                heap.pop();
            }
            let c = &mut cols[j as usize];
            if c.done || d > c.dist {
                continue; // a stale label
            }
            c.done = true;
            finished.push(j);
            let i2 = c.row as usize;
            relax(i2, d, &mut cols, &mut heap, &mut bound, &mut touched);
        };
        // Dual update: rows u += delta - d(row), columns v -= delta - d(col) over the finished set.
        u[s] += delta;
        for &j in &finished {
            let ju = j as usize;
            let c = &mut cols[ju];
            let slack = delta - c.dist;
            c.v -= slack;
            if ju != sink {
                u[c.row as usize] += slack;
            }
        }
        // Augment along the predecessor chain.
        let mut j = sink;
        loop {
            let i = cols[j].pred as usize;
            let next = col4row[i];
            col4row[i] = j as u32;
            cols[j].row = i as u32;
            if i == s {
                break;
            }
            j = next as usize;
        }
        for &j in &touched {
            let c = &mut cols[j as usize];
            c.dist = f64::INFINITY;
            c.done = false;
        }
        touched.clear();
        finished.clear();
        heap.clear();
    }
    Some(col4row.into_iter().map(|j| if j != NONE && (j as usize) < nc { j } else { NONE }).collect())
}

/// Column reduction and reduction transfer of JV's LAPJVsp (square, no private columns):
/// every column's v is its smallest cost, and the row of that cost claims it (last column
/// first; a row keeps its first claim); a row claimed once then lowers its column's v by the
/// gap to its second-best reduced cost (reduction transfer). Returns the rows left free,
/// increasing. Afterwards every assigned row holds a column of minimal h = c - v, as the
/// augmenting row reduction requires.
fn column_reduction(nr: usize, nc: usize, start: &[usize], adj: &[(u32, f64)], cmin: f64, cols: &mut [Col], col4row: &mut [u32]) -> Vec<u32> {
    for c in cols[..nc].iter_mut() {
        c.v = f64::INFINITY;
    }
    for i in 0..nr {
        for &(j, c) in &adj[start[i]..start[i + 1]] {
            let (c, col) = (c - cmin, &mut cols[j as usize]);
            if c < col.v {
                col.v = c;
                col.row = i as u32;
            }
        }
    }
    let mut unique = vec![true; nr];
    for j in (0..nc).rev() {
        let i = cols[j].row;
        if i == NONE {
            cols[j].v = 0.0; // no edge (cannot happen inside a component)
        } else if col4row[i as usize] == NONE {
            col4row[i as usize] = j as u32;
        } else {
            cols[j].row = NONE;
            unique[i as usize] = false;
        }
    }
    let mut free = Vec::new();
    for i in 0..nr {
        let j1 = col4row[i];
        if j1 == NONE {
            free.push(i as u32);
        } else if unique[i] {
            let (mut second, mut c1) = (f64::INFINITY, 0.0);
            for &(j, c) in &adj[start[i]..start[i + 1]] {
                if j == j1 {
                    c1 = c - cmin;
                } else {
                    second = second.min(c - cmin - cols[j as usize].v);
                }
            }
            if second < f64::INFINITY {
                cols[j1 as usize].v = c1 - second;
            }
        }
    }
    free
}

/// Complete bipartite component (every row–column pair is a candidate) as a flat `nr × nc`
/// cost matrix, `nr <= nc`: classic dense LAPJV (Jonker & Volgenant 1987: column reduction,
/// reduction transfer, two passes of augmenting row reduction, then shortest augmenting paths
/// with the column-list scan). Rows `nr..nc` are virtual zero-cost rows that absorb the spare
/// columns. Returns `col4row` for the real rows. O(n³) worst case, far less in practice.
// The index loops follow the paper's pseudocode line by line (and `for k in up..n` reads `up`
// once on purpose, as LAPJV's scan does), which is easier to check against it than iterators.
#[allow(clippy::needless_range_loop, clippy::mut_range_bound)]
pub(crate) fn solve_complete(nr: usize, nc: usize, cost: &[f64]) -> Vec<u32> {
    let n = nc;
    // Row i of the matrix (rows nr.. are the virtual zero rows), taken once per row scan.
    let zeros = vec![0.0f64; if nr < n { n } else { 0 }];
    let row = |i: usize| if i < nr { &cost[i * nc..(i + 1) * nc] } else { &zeros[..] };
    let mut v = vec![0.0f64; n];
    let mut rowsol = vec![NONE; n];
    let mut colsol = vec![NONE; n];
    let mut matches = vec![0u32; n];
    // Column reduction (last column first, as in the paper). The column minima are found in
    // one row-major pass (cache-friendly; same first-minimum rows as a column-wise scan).
    let mut colmin = vec![f64::INFINITY; n];
    let mut argmin = vec![0usize; n];
    for i in 0..n {
        for (j, &h) in row(i).iter().enumerate() {
            if h < colmin[j] {
                colmin[j] = h;
                argmin[j] = i;
            }
        }
    }
    for j in (0..n).rev() {
        let (min, imin) = (colmin[j], argmin[j]);
        v[j] = min;
        matches[imin] += 1;
        if matches[imin] == 1 {
            rowsol[imin] = j as u32;
            colsol[j] = imin as u32;
        } else if v[j] < v[rowsol[imin] as usize] {
            let j1 = rowsol[imin] as usize;
            rowsol[imin] = j as u32;
            colsol[j] = imin as u32;
            colsol[j1] = NONE;
        } else {
            colsol[j] = NONE;
        }
    }
    // Reduction transfer.
    let mut free: Vec<usize> = Vec::new();
    for i in 0..n {
        if matches[i] == 0 {
            free.push(i);
        } else if matches[i] == 1 {
            let j1 = rowsol[i] as usize;
            let mut min = f64::INFINITY;
            for (j, (&h, &vj)) in row(i).iter().zip(&v).enumerate() {
                if j != j1 {
                    min = min.min(h - vj);
                }
            }
            if min.is_finite() {
                v[j1] -= min;
            }
        }
    }
    // Augmenting row reduction, two passes.
    for _ in 0..2 {
        let prev = std::mem::take(&mut free);
        let mut k = 0usize;
        let mut list = prev;
        let mut steps = 0usize;
        while k < list.len() {
            let i = list[k];
            k += 1;
            let r = row(i);
            let (mut u1, mut j1) = (r[0] - v[0], 0usize);
            let (mut u2, mut j2) = (f64::INFINITY, NONE as usize);
            for j in 1..n {
                let h = r[j] - v[j];
                if h < u2 {
                    if h >= u1 {
                        u2 = h;
                        j2 = j;
                    } else {
                        u2 = u1;
                        u1 = h;
                        j2 = j1;
                        j1 = j;
                    }
                }
            }
            let mut i0 = colsol[j1];
            if u1 < u2 {
                v[j1] -= u2 - u1;
            } else if i0 != NONE && j2 != NONE as usize {
                j1 = j2;
                i0 = colsol[j2];
            }
            rowsol[i] = j1 as u32;
            colsol[j1] = i as u32;
            if i0 != NONE {
                rowsol[i0 as usize] = NONE;
                steps += 1;
                // Retried at once only while the work stays linear (floating-point ties can
                // make the paper's loop creep by tiny price steps); otherwise it waits for
                // the augmentation phase.
                if u1 < u2 && steps < 4 * n {
                    k -= 1;
                    list[k] = i0 as usize;
                } else {
                    free.push(i0 as usize);
                }
            }
        }
    }
    // Shortest augmenting paths.
    let mut d = vec![0.0f64; n];
    let mut pred = vec![0usize; n];
    let mut collist: Vec<usize> = (0..n).collect();
    for &freerow in &free {
        let r = row(freerow);
        for j in 0..n {
            d[j] = r[j] - v[j];
            pred[j] = freerow;
            collist[j] = j;
        }
        let (mut low, mut up) = (0usize, 0usize);
        let mut last = 0usize;
        let mut min = 0.0f64;
        let endofpath = 'search: loop {
            if up == low {
                last = low;
                min = d[collist[up]];
                up += 1;
                for k in up..n {
                    let j = collist[k];
                    let h = d[j];
                    if h <= min {
                        if h < min {
                            up = low;
                            min = h;
                        }
                        collist[k] = collist[up];
                        collist[up] = j;
                        up += 1;
                    }
                }
                for &j in &collist[low..up] {
                    if colsol[j] == NONE {
                        break 'search j;
                    }
                }
            }
            let j1 = collist[low];
            low += 1;
            let i = colsol[j1] as usize;
            let r = row(i);
            let h = r[j1] - v[j1] - min;
            let mut k = up;
            while k < n {
                let j = collist[k];
                let v2 = r[j] - v[j] - h;
                if v2 < d[j] {
                    pred[j] = i;
                    if v2 == min {
                        if colsol[j] == NONE {
                            break 'search j;
                        }
                        collist[k] = collist[up];
                        collist[up] = j;
                        up += 1;
                    }
                    d[j] = v2;
                }
                k += 1;
            }
        };
        // Update the prices of the columns scanned before the last minimum.
        for &j1 in &collist[..last] {
            v[j1] += d[j1] - min;
        }
        let mut j = endofpath;
        loop {
            let i = pred[j];
            colsol[j] = i as u32;
            let next = rowsol[i];
            rowsol[i] = j as u32;
            if i == freerow {
                break;
            }
            j = next as usize;
        }
    }
    rowsol.truncate(nr);
    rowsol
}

/// Dense component through `lsap` (absent cells cost `M`, see module docs): the reference the
/// JV solver is tested against (the JV solver with array scans was faster on the benches).
#[cfg(test)]
fn solve_dense(nr: usize, nc: usize, start: &[usize], adj: &[(u32, f64)]) -> Result<Vec<u32>, MatchError> {
    let (mut cmin, mut cmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for &(_, c) in adj {
        cmin = cmin.min(c);
        cmax = cmax.max(c);
    }
    let big = (cmax - cmin) * (nr.min(nc) as f64 + 1.0) + 1.0 + (cmax - cmin);
    let mut w = vec![big; nr * nc];
    let mut present = vec![false; nr * nc];
    for i in 0..nr {
        for &(j, c) in &adj[start[i]..start[i + 1]] {
            w[i * nc + j as usize] = c - cmin;
            present[i * nc + j as usize] = true;
        }
    }
    let (rows, cols) = lsap::solve(nr, nc, &w, false).map_err(|_| MatchError::Solver)?;
    let mut col4row = vec![NONE; nr];
    for (i, j) in rows.into_iter().zip(cols) {
        if present[i * nc + j] {
            col4row[i] = j as u32;
        }
    }
    Ok(col4row)
}

/// Dense ids `0..n` for the distinct values of one id column, in increasing order of value:
/// a lookup table when the values span a small range (row numbers), otherwise the sorted
/// distinct values and a binary search.
struct IdMap {
    /// The distinct values, increasing: id `k` is `values[k]`.
    values: Vec<i64>,
    /// `Some((lo, table))`: the id of `v` is `table[v - lo]`.
    table: Option<(i64, Vec<u32>)>,
}

impl IdMap {
    fn new(x: &[i64]) -> Result<IdMap, MatchError> {
        let m = x.len();
        let (lo, hi) = x.iter().fold((i64::MAX, i64::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        let span = (hi as i128 - lo as i128) as u128;
        if span < 4 * m as u128 + 1024 {
            let mut table = try_vec(NONE, span as usize + 1)?;
            for &v in x {
                table[(v - lo) as usize] = 0;
            }
            let mut values = Vec::new();
            for (k, t) in table.iter_mut().enumerate() {
                if *t == 0 {
                    *t = values.len() as u32;
                    values.push(lo + k as i64);
                }
            }
            Ok(IdMap { values, table: Some((lo, table)) })
        } else {
            let mut values = Vec::new();
            values.try_reserve_exact(m).map_err(|_| MatchError::Alloc(m))?;
            values.extend_from_slice(x);
            if m >= PAR_SORT {
                values.par_sort_unstable();
            } else {
                values.sort_unstable();
            }
            values.dedup();
            Ok(IdMap { values, table: None })
        }
    }
    fn len(&self) -> usize {
        self.values.len()
    }
    #[inline]
    fn id(&self, v: i64) -> u32 {
        match &self.table {
            Some((lo, t)) => t[(v - lo) as usize],
            None => self.values.binary_search(&v).expect("id present") as u32,
        }
    }
    /// The ids of every element (in parallel for long columns).
    fn ids(&self, x: &[i64]) -> Result<Vec<u32>, MatchError> {
        let mut out = Vec::new();
        out.try_reserve_exact(x.len()).map_err(|_| MatchError::Alloc(x.len()))?;
        if x.len() >= PAR_SORT {
            x.par_iter().map(|&v| self.id(v)).collect_into_vec(&mut out);
        } else {
            out.extend(x.iter().map(|&v| self.id(v)));
        }
        Ok(out)
    }
}

/// Chosen pairs `(a, b, score)`.
type Pairs = Vec<(i64, i64, f64)>;

/// Lists of at least this many pairs are mapped and sorted in parallel.
const PAR_SORT: usize = 100_000;
/// Complete candidate lists up to this many cells (max(rows, columns)²) go to the flat LAPJV.
const DENSE_CELLS: usize = 16_000_000;

/// `vec![x; n]`, allocated fallibly.
fn try_vec<T: Clone>(x: T, n: usize) -> Result<Vec<T>, MatchError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| MatchError::Alloc(n))?;
    v.resize(n, x);
    Ok(v)
}

/// Components of the canonical pairs (ids `ca`, `cb`, sorted by `(a, b)`, no duplicates)
/// ([`graph::bipartite_components`]); a complete bipartite candidate list is one component
/// without the union–find.
fn components(ca: &[u32], na: usize, cb: &[u32], nb: usize) -> Components {
    let m = ca.len();
    if na * nb == m {
        // Complete bipartite (deduplicated, so every pair is present once): one component, and
        // the global ids are already local.
        return Components { start: vec![0, m], edges: (0..m as u32).collect(), loc_a: ca.to_vec(), loc_b: cb.to_vec(), n_a: vec![na as u32], n_b: vec![nb as u32] };
    }
    graph::bipartite_components(ca, na, cb, nb)
}

/// Solves component `c` of the canonical pairs (scores `cs`); returns canonical indices of the
/// chosen edges.
fn solve_component(cs: &[f64], g: &Components, c: usize, maximize: bool) -> Result<Vec<usize>, MatchError> {
    let edges = g.edges_of(c);
    // Rows are the smaller side.
    let transpose = g.n_b[c] < g.n_a[c];
    let (nr, nc) = if transpose { (g.n_b[c] as usize, g.n_a[c] as usize) } else { (g.n_a[c] as usize, g.n_b[c] as usize) };
    let rc = |k: usize| if transpose { (g.loc_b[k], g.loc_a[k]) } else { (g.loc_a[k], g.loc_b[k]) };
    let mut start = try_vec(0usize, nr + 1)?;
    for &k in edges {
        start[rc(k as usize).0 as usize + 1] += 1;
    }
    for i in 0..nr {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut adj = try_vec((0u32, 0.0f64), edges.len())?;
    let mut edge_of = try_vec(0u32, edges.len())?;
    for &k in edges {
        let (r, col) = rc(k as usize);
        let s = cs[k as usize];
        let slot = fill[r as usize];
        adj[slot] = (col, if maximize { -s } else { s });
        edge_of[slot] = k;
        fill[r as usize] += 1;
    }
    // Complete components: dense LAPJV on a flat matrix; other dense ones: JV with array
    // scans; sparse ones: JV with a heap (see examples/hungarian_sparse.rs for the timings).
    let col4row = if edges.len() == nr * nc && nc * nc <= DENSE_CELLS {
        let mut m = try_vec(0.0f64, nr * nc)?;
        for i in 0..nr {
            for &(j, c) in &adj[start[i]..start[i + 1]] {
                m[i * nc + j as usize] = c;
            }
        }
        solve_complete(nr, nc, &m)
    } else {
        solve_sparse(nr, nc, &start, &adj, edges.len() * 4 >= nr * nc)
    };
    let mut out = Vec::new();
    for (i, &j) in col4row.iter().enumerate() {
        if j == NONE {
            continue;
        }
        let slot = (start[i]..start[i + 1]).find(|&x| adj[x].0 == j).expect("assigned edge exists");
        out.push(edge_of[slot] as usize);
    }
    Ok(out)
}

/// The optimal assignment (see module docs); returns the chosen pairs sorted by `(a, b)`.
pub fn hungarian_match(pairs: &[(i64, i64, f64)], params: &MatchParams) -> Result<Vec<(i64, i64, f64)>, MatchError> {
    let a: Vec<i64> = pairs.iter().map(|p| p.0).collect();
    let b: Vec<i64> = pairs.iter().map(|p| p.1).collect();
    let s: Vec<f64> = pairs.iter().map(|p| p.2).collect();
    hungarian_match_columns(&a, &b, &s, params)
}

/// [`hungarian_match`] on the pairs given as three columns of equal length (the SQL list's
/// struct fields, read in place: no copy of the pairs is made unless `min_score` drops some).
///
/// Work before the solver, for `m` pairs with `na` distinct `a` and `nb` distinct `b`: the ids
/// are numbered by a lookup table (O(m), ids spanning a small range) or a sort (O(m log m));
/// a complete list (`m >= na·nb` and every cell present) is scattered straight into the flat
/// matrix of [`solve_complete`]; any other list is put in canonical `(a, b)` order by two
/// counting sorts on the ids (O(m + na + nb), skipped when already in order) and split into
/// components.
pub fn hungarian_match_columns(a: &[i64], b: &[i64], s: &[f64], params: &MatchParams) -> Result<Vec<(i64, i64, f64)>, MatchError> {
    assert!(a.len() == b.len() && b.len() == s.len(), "columns of equal length");
    let keep = |s: f64| match params.min_score {
        None => true,
        Some(t) if params.maximize => s >= t,
        Some(t) => s <= t,
    };
    let mut kept = 0usize;
    for (k, &x) in s.iter().enumerate() {
        // finite and within ±1e150: the solver adds and subtracts scores (potentials), and
        // -1.7e308 next to 9.2e18 overflowed into an index out of bounds (found by the fuzz run)
        if !(x.is_finite() && x.abs() <= 1e150) {
            return Err(MatchError::Score { index: k, value: x });
        }
        kept += keep(x) as usize;
    }
    if kept < s.len() {
        // min_score drops candidates before anything else
        let mut cols = (Vec::new(), Vec::new(), Vec::new());
        cols.0.try_reserve_exact(kept).map_err(|_| MatchError::Alloc(kept))?;
        cols.1.try_reserve_exact(kept).map_err(|_| MatchError::Alloc(kept))?;
        cols.2.try_reserve_exact(kept).map_err(|_| MatchError::Alloc(kept))?;
        for k in 0..s.len() {
            if keep(s[k]) {
                cols.0.push(a[k]);
                cols.1.push(b[k]);
                cols.2.push(s[k]);
            }
        }
        return solve_pairs(&cols.0, &cols.1, &cols.2, params.maximize);
    }
    solve_pairs(a, b, s, params.maximize)
}

/// The candidates after the threshold: ids, then the complete fast path or the general one.
fn solve_pairs(a: &[i64], b: &[i64], s: &[f64], maximize: bool) -> Result<Vec<(i64, i64, f64)>, MatchError> {
    let m = s.len();
    if m == 0 {
        return Ok(vec![]);
    }
    let (ia, ib) = if m >= PAR_SORT { rayon::join(|| IdMap::new(a), || IdMap::new(b)) } else { (IdMap::new(a), IdMap::new(b)) };
    let (ia, ib) = (ia?, ib?);
    let (na, nb) = (ia.len(), ib.len());
    let big = na.max(nb);
    if (na as u128) * (nb as u128) <= m as u128 && big * big <= DENSE_CELLS {
        if let Some(out) = solve_full(a, b, s, &ia, &ib, maximize)? {
            return Ok(out);
        }
    }
    let (a_of, b_of) = if m >= PAR_SORT { rayon::join(|| ia.ids(a), || ib.ids(b)) } else { (ia.ids(a), ib.ids(b)) };
    let (a_of, b_of) = (a_of?, b_of?);
    // Canonical order (a, b) of the ids, which is the order of the values; duplicates keep the
    // best score.
    let sorted = (1..m).all(|k| (a_of[k - 1], b_of[k - 1]) < (a_of[k], b_of[k]));
    let (ca, cb, cs) = if sorted {
        (a_of, b_of, s.to_vec())
    } else {
        let order = canonical_order(&a_of, na, &b_of, nb)?;
        let (mut ca, mut cb, mut cs) = (Vec::new(), Vec::new(), Vec::new());
        ca.try_reserve_exact(m).map_err(|_| MatchError::Alloc(m))?;
        cb.try_reserve_exact(m).map_err(|_| MatchError::Alloc(m))?;
        cs.try_reserve_exact(m).map_err(|_| MatchError::Alloc(m))?;
        for &k in &order {
            let (x, y, z) = (a_of[k as usize], b_of[k as usize], s[k as usize]);
            if let (Some(&px), Some(&py)) = (ca.last(), cb.last()) {
                if px == x && py == y {
                    let last: &mut f64 = cs.last_mut().expect("same length");
                    if (maximize && z > *last) || (!maximize && z < *last) {
                        *last = z;
                    }
                    continue;
                }
            }
            ca.push(x);
            cb.push(y);
            cs.push(z);
        }
        (ca, cb, cs)
    };
    let g = components(&ca, na, &cb, nb);
    let ncomp = g.len();
    let solve = |c: usize| solve_component(&cs, &g, c, maximize);
    let chosen: Vec<Vec<usize>> = if cs.len() >= 20_000 && ncomp > 1 {
        (0..ncomp).into_par_iter().map(solve).collect::<Result<_, _>>()?
    } else {
        (0..ncomp).map(solve).collect::<Result<_, _>>()?
    };
    let mut idx: Vec<usize> = chosen.into_iter().flatten().collect();
    idx.sort_unstable();
    Ok(idx.into_iter().map(|k| (ia.values[ca[k] as usize], ib.values[cb[k] as usize], cs[k])).collect())
}

/// The permutation that sorts the pairs by `(a_of, b_of)` (stable): a counting sort by `b`,
/// then a stable counting sort by `a`. O(m + na + nb).
fn canonical_order(a_of: &[u32], na: usize, b_of: &[u32], nb: usize) -> Result<Vec<u32>, MatchError> {
    let m = a_of.len();
    let counting = |key: &[u32], n: usize, input: &mut dyn Iterator<Item = u32>| -> Result<Vec<u32>, MatchError> {
        let mut pos = try_vec(0usize, n + 1)?;
        for &x in key {
            pos[x as usize + 1] += 1;
        }
        for i in 0..n {
            pos[i + 1] += pos[i];
        }
        let mut out = try_vec(0u32, m)?;
        for k in input {
            let p = &mut pos[key[k as usize] as usize];
            out[*p] = k;
            *p += 1;
        }
        Ok(out)
    };
    let by_b = counting(b_of, nb, &mut (0..m as u32))?;
    counting(a_of, na, &mut by_b.into_iter())
}

/// The complete case: every `(a, b)` cell present (duplicates keep the best), scattered straight
/// into the flat cost matrix of [`solve_complete`] with the smaller side as rows. `None` when a
/// cell is missing (the general path takes over).
fn solve_full(a: &[i64], b: &[i64], s: &[f64], ia: &IdMap, ib: &IdMap, maximize: bool) -> Result<Option<Pairs>, MatchError> {
    let (na, nb) = (ia.len(), ib.len());
    let transpose = nb < na;
    let (nr, nc) = if transpose { (nb, na) } else { (na, nb) };
    let mut cost = try_vec(f64::NAN, nr * nc)?;
    let mut filled = 0usize;
    for k in 0..s.len() {
        let (x, y) = (ia.id(a[k]) as usize, ib.id(b[k]) as usize);
        let cell = if transpose { y * nc + x } else { x * nc + y };
        let c = if maximize { -s[k] } else { s[k] };
        let w = &mut cost[cell];
        if w.is_nan() {
            *w = c;
            filled += 1;
        } else if c < *w {
            *w = c;
        }
    }
    if filled < nr * nc {
        return Ok(None);
    }
    let col4row = solve_complete(nr, nc, &cost);
    let mut out: Vec<(i64, i64, f64)> = col4row
        .iter()
        .enumerate()
        .map(|(i, &j)| {
            let c = cost[i * nc + j as usize];
            let score = if maximize { -c } else { c };
            let (x, y) = if transpose { (j as usize, i) } else { (i, j as usize) };
            (ia.values[x], ib.values[y], score)
        })
        .collect();
    if transpose {
        out.sort_unstable_by_key(|p| (p.0, p.1));
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute force: among all matchings of maximum size, the best total.
    fn brute(pairs: &[(i64, i64, f64)], maximize: bool) -> (usize, f64) {
        let n = pairs.len();
        let mut best: (usize, f64) = (0, 0.0);
        for mask in 0u32..(1 << n) {
            let sel: Vec<&(i64, i64, f64)> = (0..n).filter(|k| mask >> k & 1 == 1).map(|k| &pairs[k]).collect();
            let ok = sel.iter().enumerate().all(|(x, p)| sel[x + 1..].iter().all(|q| p.0 != q.0 && p.1 != q.1));
            if !ok {
                continue;
            }
            let total: f64 = sel.iter().map(|p| p.2).sum();
            let improves = sel.len() > best.0
                || (sel.len() == best.0 && if maximize { total > best.1 + 1e-12 } else { total < best.1 - 1e-12 });
            if improves {
                best = (sel.len(), total);
            }
        }
        best
    }

    fn total(m: &[(i64, i64, f64)]) -> f64 {
        m.iter().map(|p| p.2).sum()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        /// Exact against brute force on up to 12 candidate pairs among up to 7 ids a side.
        #[test]
        fn equals_brute_force(raw in prop::collection::vec((0i64..7, 0i64..7, -50i32..100), 0..12), maximize in any::<bool>()) {
            let mut pairs: Vec<(i64, i64, f64)> = raw.iter().map(|&(a, b, s)| (a, b, s as f64 / 10.0)).collect();
            // brute force needs unique (a, b): dedup keeping the best, as the solver does
            pairs.sort_by(|p, q| p.0.cmp(&q.0).then(p.1.cmp(&q.1)).then(if maximize { q.2.total_cmp(&p.2) } else { p.2.total_cmp(&q.2) }));
            pairs.dedup_by(|q, p| p.0 == q.0 && p.1 == q.1);
            let got = hungarian_match(&pairs, &MatchParams::new(maximize, None).unwrap()).unwrap();
            let (n, t) = brute(&pairs, maximize);
            prop_assert_eq!(got.len(), n);
            prop_assert!((total(&got) - t).abs() < 1e-9, "got {} want {}", total(&got), t);
        }

        /// The sparse solver equals lsap on the same components (dense path).
        #[test]
        fn sparse_equals_dense(raw in prop::collection::vec((0u32..9, 0u32..12, 0i32..1000), 1..60)) {
            let mut e: Vec<(u32, u32, f64)> = raw.iter().map(|&(i, j, c)| (i, j, c as f64 / 7.0)).collect();
            e.sort_by(|p, q| p.0.cmp(&q.0).then(p.1.cmp(&q.1)));
            e.dedup_by(|q, p| p.0 == q.0 && p.1 == q.1);
            let nr = 9; let nc = 12;
            let mut start = vec![0usize; nr + 1];
            for x in &e { start[x.0 as usize + 1] += 1; }
            for i in 0..nr { start[i + 1] += start[i]; }
            let adj: Vec<(u32, f64)> = e.iter().map(|x| (x.1, x.2)).collect();
            let cost = |c4r: &[u32]| -> (usize, f64) {
                let mut n = 0; let mut t = 0.0;
                for (i, &j) in c4r.iter().enumerate() {
                    if j != NONE { n += 1; t += adj[start[i]..start[i + 1]].iter().find(|x| x.0 == j).unwrap().1; }
                }
                (n, t)
            };
            let s = cost(&solve_sparse(nr, nc, &start, &adj, false));
            // complete instances through the dense LAPJV
            let full: Vec<f64> = (0..nr * nc).map(|k| ((k * 7919 + raw.len() * 31) % 1000) as f64 / 7.0).collect();
            let fstart: Vec<usize> = (0..=nr).map(|i| i * nc).collect();
            let fadj: Vec<(u32, f64)> = (0..nr * nc).map(|k| ((k % nc) as u32, full[k])).collect();
            let fc = |c4r: &[u32]| -> f64 { c4r.iter().enumerate().map(|(i, &j)| full[i * nc + j as usize]).sum() };
            let jv = solve_complete(nr, nc, &full);
            prop_assert!(jv.iter().all(|&j| j != NONE));
            let mut seen = jv.clone(); seen.sort_unstable(); seen.dedup();
            prop_assert_eq!(seen.len(), nr);
            prop_assert!((fc(&jv) - fc(&solve_dense(nr, nc, &fstart, &fadj).unwrap())).abs() < 1e-9);
            let s2 = cost(&solve_sparse(nr, nc, &start, &adj, true));
            prop_assert_eq!(s.0, s2.0);
            prop_assert!((s.1 - s2.1).abs() < 1e-9);
            let d = cost(&solve_dense(nr, nc, &start, &adj).unwrap());
            prop_assert_eq!(s.0, d.0);
            prop_assert!((s.1 - d.1).abs() < 1e-9, "sparse {} dense {}", s.1, d.1);
        }

        /// Square components take the LAPJVsp start without private columns; without a
        /// perfect matching they fall back to the private columns. Both equal lsap.
        #[test]
        fn square_equals_lsap(n in 1usize..9, raw in prop::collection::vec((0usize..64, 0i32..1000), 0..40), perfect in any::<bool>(), seed in 0usize..1000) {
            let mut e: Vec<(u32, u32, f64)> = raw.iter().map(|&(k, c)| ((k / 8 % n) as u32, (k % 8 % n) as u32, c as f64 / 7.0)).collect();
            if perfect {
                // a hidden permutation: a perfect matching exists
                e.extend((0..n).map(|i| (i as u32, ((i * 5 + seed) % n) as u32, ((i * 31 + seed) % 97) as f64)));
            }
            e.sort_by(|p, q| p.0.cmp(&q.0).then(p.1.cmp(&q.1)));
            e.dedup_by(|q, p| p.0 == q.0 && p.1 == q.1);
            // rows without edges are not part of a component: give each row one edge at least
            for i in 0..n as u32 {
                if !e.iter().any(|x| x.0 == i) { e.push((i, 0, 50.0)); }
            }
            e.sort_by(|p, q| p.0.cmp(&q.0).then(p.1.cmp(&q.1)));
            let mut start = vec![0usize; n + 1];
            for x in &e { start[x.0 as usize + 1] += 1; }
            for i in 0..n { start[i + 1] += start[i]; }
            let adj: Vec<(u32, f64)> = e.iter().map(|x| (x.1, x.2)).collect();
            let cost = |c4r: &[u32]| -> (usize, f64) {
                let mut k = 0; let mut t = 0.0;
                for (i, &j) in c4r.iter().enumerate() {
                    if j != NONE { k += 1; t += adj[start[i]..start[i + 1]].iter().find(|x| x.0 == j).unwrap().1; }
                }
                (k, t)
            };
            let d = cost(&solve_dense(n, n, &start, &adj).unwrap());
            for scan in [false, true] {
                let got = solve_sparse(n, n, &start, &adj, scan);
                let mut used: Vec<u32> = got.iter().copied().filter(|&j| j != NONE).collect();
                used.sort_unstable();
                let k = used.len();
                used.dedup();
                prop_assert_eq!(used.len(), k, "one to one");
                let s = cost(&got);
                prop_assert_eq!(s.0, d.0);
                prop_assert!((s.1 - d.1).abs() < 1e-9, "scan {} sparse {} lsap {}", scan, s.1, d.1);
            }
        }

        /// Through the public entry: complete lists (the flat LAPJV path) and partial ones (the
        /// canonical order and components), with duplicates, any order and wide ids, against
        /// lsap on the deduplicated matrix; and the same answer for a shuffled copy.
        #[test]
        fn lists_equal_lsap(na in 1usize..7, nb in 1usize..7, cells in prop::collection::vec((any::<bool>(), 0i32..50, 0u8..3), 36), maximize in any::<bool>(), wide in any::<bool>(), complete in any::<bool>(), seed in any::<u64>()) {
            let ida = |i: usize| if wide { i as i64 * 1_000_000_007 - 3_000_000_000 } else { i as i64 + 10 };
            let idb = |j: usize| if wide { i64::MAX - j as i64 * 999_999_937 } else { 100 - j as i64 };
            let mut pairs = Vec::new();
            for i in 0..na {
                for j in 0..nb {
                    let (present, score, dups) = cells[i * 6 + j];
                    if complete || present {
                        for k in 0..=dups as i32 {
                            pairs.push((ida(i), idb(j), (score - 7 * k) as f64 / 4.0));
                        }
                    }
                }
            }
            let mut st = seed | 1;
            for k in (1..pairs.len()).rev() {
                st ^= st << 13; st ^= st >> 7; st ^= st << 17;
                pairs.swap(k, (st % (k as u64 + 1)) as usize);
            }
            let p = MatchParams::new(maximize, None).unwrap();
            let got = hungarian_match(&pairs, &p).unwrap();
            // reference: best score per cell, lsap with absent cells forbidden
            let mut canon = pairs.clone();
            canon.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.cmp(&y.1)).then(if maximize { y.2.total_cmp(&x.2) } else { x.2.total_cmp(&y.2) }));
            canon.dedup_by(|q, p| p.0 == q.0 && p.1 == q.1);
            if canon.is_empty() {
                prop_assert!(got.is_empty());
                return Ok(());
            }
            let a: Vec<i64> = canon.iter().map(|x| x.0).collect();
            let b: Vec<i64> = canon.iter().map(|x| x.1).collect();
            let (ma, a_of) = graph::dense_ids(&a);
            let (mb, b_of) = graph::dense_ids(&b);
            let mut start = vec![0usize; ma + 1];
            for &x in &a_of { start[x as usize + 1] += 1; }
            for i in 0..ma { start[i + 1] += start[i]; }
            let adj: Vec<(u32, f64)> = (0..canon.len()).map(|k| (b_of[k], if maximize { -canon[k].2 } else { canon[k].2 })).collect();
            let (rows, cols, adj2, start2) = if ma <= mb {
                (ma, mb, adj, start)
            } else {
                // lsap wants rows <= columns: transpose
                let mut t: Vec<(u32, u32, f64)> = (0..canon.len()).map(|k| (b_of[k], a_of[k], adj[k].1)).collect();
                t.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.cmp(&y.1)));
                let mut st2 = vec![0usize; mb + 1];
                for x in &t { st2[x.0 as usize + 1] += 1; }
                for i in 0..mb { st2[i + 1] += st2[i]; }
                (mb, ma, t.iter().map(|x| (x.1, x.2)).collect(), st2)
            };
            let want = solve_dense(rows, cols, &start2, &adj2).unwrap();
            let mut n_want = 0; let mut t_want = 0.0;
            for (i, &j) in want.iter().enumerate() {
                if j != NONE { n_want += 1; t_want += adj2[start2[i]..start2[i + 1]].iter().find(|x| x.0 == j).unwrap().1; }
            }
            if maximize { t_want = -t_want; }
            prop_assert_eq!(got.len(), n_want);
            prop_assert!((total(&got) - t_want).abs() < 1e-9, "got {} want {}", total(&got), t_want);
            // the chosen pairs are candidates with their best score, sorted by (a, b), one to one
            for m in &got { prop_assert!(canon.contains(m), "{:?} not a best candidate", m); }
            prop_assert!(got.windows(2).all(|w| (w[0].0, w[0].1) < (w[1].0, w[1].1)));
            let mut bs: Vec<i64> = got.iter().map(|m| m.1).collect();
            bs.sort_unstable(); bs.dedup();
            prop_assert_eq!(bs.len(), got.len());
            // any order, the same answer
            let mut rev = pairs.clone();
            rev.reverse();
            prop_assert_eq!(hungarian_match(&rev, &p).unwrap(), got);
        }

        /// The answer does not depend on the list order.
        #[test]
        fn order_independent(raw in prop::collection::vec((0i64..6, 0i64..6, 0i32..4), 0..20), seed in any::<u64>()) {
            let pairs: Vec<(i64, i64, f64)> = raw.iter().map(|&(a, b, s)| (a, b, s as f64)).collect();
            let mut shuffled = pairs.clone();
            let mut st = seed | 1;
            for k in (1..shuffled.len()).rev() {
                st ^= st << 13; st ^= st >> 7; st ^= st << 17;
                shuffled.swap(k, (st % (k as u64 + 1)) as usize);
            }
            let p = MatchParams::new(true, None).unwrap();
            prop_assert_eq!(hungarian_match(&pairs, &p).unwrap(), hungarian_match(&shuffled, &p).unwrap());
        }
    }

    #[test]
    fn rules() {
        let p = MatchParams::new(true, None).unwrap();
        // cardinality first: two 0.6 pairs beat one 0.95 pair (scipy semantics)
        let m = hungarian_match(&[(1, 10, 0.95), (1, 20, 0.6), (2, 10, 0.6)], &p).unwrap();
        assert_eq!(m, vec![(1, 20, 0.6), (2, 10, 0.6)]);
        // the threshold removes candidates before solving
        let t = MatchParams::new(true, Some(0.7)).unwrap();
        assert_eq!(hungarian_match(&[(1, 10, 0.95), (1, 20, 0.6), (2, 10, 0.6)], &t).unwrap(), vec![(1, 10, 0.95)]);
        // duplicates keep the best; costs keep the min
        assert_eq!(hungarian_match(&[(1, 1, 0.2), (1, 1, 0.9)], &p).unwrap(), vec![(1, 1, 0.9)]);
        let c = MatchParams::new(false, None).unwrap();
        assert_eq!(hungarian_match(&[(1, 1, 0.2), (1, 1, 0.9)], &c).unwrap(), vec![(1, 1, 0.2)]);
        // costs with a ceiling
        let cc = MatchParams::new(false, Some(1.0)).unwrap();
        assert_eq!(hungarian_match(&[(1, 1, 3.0), (1, 2, 0.5), (2, 2, 0.1)], &cc).unwrap(), vec![(2, 2, 0.1)]);
        assert!(hungarian_match(&[], &p).unwrap().is_empty());
        assert_eq!(
            hungarian_match(&[(1, 1, f64::NAN)], &p).unwrap_err().to_string(),
            "pairs[1].score must be finite and within ±1e150, got NaN"
        );
        // found by the fuzz harness: -1.7e308 beside 9.2e18 overflowed the solver's potentials
        let big = [(1, 2, -127.1), (1, 8, 123.5), (1, 58, -1.7e308), (48, 2, -104.4), (9, 2, 9.2e18)];
        assert!(matches!(hungarian_match(&big, &MatchParams::new(true, None).unwrap()), Err(MatchError::Score { index: 2, .. })));
        assert!(MatchParams::new(true, Some(f64::NAN)).is_err());
        // negative and huge ids, rectangular
        let r = hungarian_match(&[(-5, i64::MAX, 1.0), (-5, 0, 2.0), (7, 0, 1.5)], &p).unwrap();
        assert_eq!(r, vec![(-5, i64::MAX, 1.0), (7, 0, 1.5)]);
    }

    /// Reference totals from scipy 1.17.1 `linear_sum_assignment` on the dense matrix with
    /// absent pairs forbidden (see `hungarian_scipy.json`, generated by
    /// `benches/peers_hungarian.py --pin`).
    #[test]
    fn pinned_against_scipy() {
        #[derive(serde::Deserialize)]
        struct Case {
            maximize: bool,
            pairs: Vec<(i64, i64, f64)>,
            count: usize,
            total: f64,
        }
        #[derive(serde::Deserialize)]
        struct Pins {
            scipy: String,
            cases: Vec<Case>,
        }
        let pins: Pins = serde_json::from_str(include_str!("testdata/hungarian_scipy.json")).unwrap();
        assert!(pins.scipy.starts_with('1'));
        assert!(pins.cases.len() >= 10);
        for (k, c) in pins.cases.iter().enumerate() {
            let got = hungarian_match(&c.pairs, &MatchParams::new(c.maximize, None).unwrap()).unwrap();
            assert_eq!(got.len(), c.count, "case {k}");
            assert!((total(&got) - c.total).abs() < 1e-9 * c.total.abs().max(1.0), "case {k}: {} vs {}", total(&got), c.total);
        }
    }
}
