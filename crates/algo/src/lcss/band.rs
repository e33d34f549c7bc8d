//! The banded LCSS engine shared by every LCSS form in trajdb.
//!
//! All LCSS variants here are the classical recurrence (Cormen et al.; thesis eq. 2.9;
//! Buzan eq. 4.2 / A.1)
//!
//! ```text
//! C[i][j] = 0                               if i = 0 or j = 0
//!         = C[i-1][j-1] + 1                 if a_i matches b_j
//!         = max(C[i-1][j], C[i][j-1])       otherwise
//! ```
//!
//! where a match is only possible inside a *band*: for row `i` the candidate columns form
//! one contiguous range `lo_i..hi_i`, and both `lo_i` and `hi_i` are non-decreasing in `i`.
//! The time-window form (|t_a - t_b| < T, both sides sorted by t) and the index-window form
//! (|i - j| <= δ) both have this shape.
//!
//! # Why cells outside the band need no work
//! Buzan's appendix proves this for the diagonal band; the argument holds for any monotone
//! band. For `j < lo_i`, `a_i` can match nothing in `B[..j]`, so `C[i][j] = C[i-1][j]`.
//! For `j > hi_i`, `C[i][j] = max(C[i-1][j], C[i][hi_i]) = C[i][hi_i]`, because by induction
//! `C[i-1][j]` equals a value of an earlier row at a column `<= hi_i`, which is bounded by
//! `C[i][hi_i]` (rows and columns are monotone). So one row array updated only inside the
//! band, plus a "tail" value for the columns right of the last band, is the whole table.
//!
//! # Complexity
//! [`lcss_len`]: O(n + m + Σ_i w_i) time, where `w_i = hi_i - lo_i`, and O(m) memory.
//! [`BandTable`] (for backtracking): same time, O(n + Σ w_i) memory (4 bytes a cell of the rows
//! that hold a match, allocated fallibly; [`table_bytes`] bounds it before the work), and
//! O((n + m) log n) for the backtrack itself.
//!
//! # The work limit
//! Both entry points count the band's cells `Σ_i w_i` first (one pass over the band, O(n)
//! and no match test) and refuse a table over the limit `lcss_cells` with
//! [`LcssError::Work`], before any work: every LCSS in trajdb (the SQL functions, the
//! merge of [`crate::merge`], the clustering) obeys the limit because the engine checks it.
//! The check reads the limit of the calling thread's scope ([`crate::limits::with_scope`]);
//! a caller that runs LCSS on rayon workers enters its scope there.

use super::LcssError;

/// Checks, in debug builds, the band contract: ranges inside `0..=m` and monotone.
#[inline]
fn debug_check(prev: &mut (usize, usize), lo: usize, hi: usize, m: usize) {
    debug_assert!(hi <= m, "band hi {hi} > m {m}");
    debug_assert!(lo >= prev.0 && hi >= prev.1, "band not monotone: {prev:?} then {:?}", (lo, hi));
    *prev = (lo, hi);
}

/// The band's cells against the work limit `lcss_cells`, before the work.
fn check_cells<B: Iterator<Item = (usize, usize)> + Clone>(band: &B) -> Result<(), LcssError> {
    let cells: u128 = band.clone().map(|(lo, hi)| hi.saturating_sub(lo) as u128).sum();
    crate::limits::LCSS_CELLS.check(cells).map_err(LcssError::Work)
}

/// The working rows of [`run_rows`]: kept per thread and reused, so a call allocates nothing
/// once its thread has seen a trajectory as long (an LCSS of two road users of a few hundred
/// points each is a few hundred nanoseconds of work; two allocations were a good part of it).
#[derive(Default)]
pub(crate) struct Scratch {
    row: Vec<u32>,
    hits: Vec<bool>,
}

/// Buffers above this many columns are not kept after the call (a rare long trajectory does
/// not pin its buffers on every worker thread).
const KEEP_COLUMNS: usize = 1 << 16;

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// Runs `f` with this thread's [`Scratch`], its row sized for `m` columns (a fresh one if the
/// thread's is in use). The row is allocated fallibly: [`LcssError::Alloc`] when it fails.
pub(crate) fn with_scratch<R>(m: usize, f: impl FnOnce(&mut Scratch) -> R) -> Result<R, LcssError> {
    let prepare = |s: &mut Scratch| -> Result<(), LcssError> {
        s.row.clear();
        s.hits.clear();
        if s.row.try_reserve(m + 1).is_err() || s.hits.try_reserve(m).is_err() {
            return Err(LcssError::Alloc { bytes: (m as u128 + 1) * 5 });
        }
        s.row.resize(m + 1, 0);
        Ok(())
    };
    SCRATCH.with(|cell| match cell.try_borrow_mut() {
        Ok(mut s) => {
            prepare(&mut s)?;
            let r = f(&mut s);
            if m > KEEP_COLUMNS {
                *s = Scratch::default();
            }
            Ok(r)
        }
        Err(_) => {
            let mut s = Scratch::default();
            prepare(&mut s)?;
            Ok(f(&mut s))
        }
    })
}

/// Runs the banded recurrence row by row. For every row `i`, `visit(i, lo, hi, cells)` gets the
/// row's effective band and, when it is non-empty, the new values of columns `lo+1..=hi`
/// (1-based). Rows whose band holds no match are reported with `hi = lo`: they leave the
/// table unchanged (C[i][j] = C[i-1][j] for all j), so they are skipped. Returns `C[n][m]`,
/// or `None` as soon as `visit` returns false.
/// `scratch` comes from [`with_scratch`] (`row` is `m + 1` zeros).
/// `row_match(i, lo, hi, hits)` appends the match tests of row `i` against columns `lo..hi` to
/// `hits` (one bool a column, in order; [`cell_tests`] makes one from an `is_match(i, j)`).
fn run_rows<B, R, V>(scratch: &mut Scratch, n: usize, m: usize, mut band: B, mut row_match: R, mut visit: V) -> Option<usize>
where
    B: Iterator<Item = (usize, usize)>,
    R: FnMut(usize, usize, usize, &mut Vec<bool>),
    V: FnMut(usize, usize, usize, &[u32]) -> bool,
{
    // row[c] = C[i][c] for c <= filled (1-based columns); C[i][c] = row[filled] for c > filled.
    let Scratch { row, hits } = scratch;
    debug_assert!(row.len() == m + 1);
    let mut filled = 0usize;
    let mut prev = (0, 0);
    for i in 0..n {
        let (lo, hi) = match band.next() {
            Some(b) if m > 0 => b,
            _ => (0, 0),
        };
        debug_check(&mut prev, lo, hi, m);
        // Match tests first, branch-free (vectorisable); on real data most rows of most pairs
        // have none and are skipped here.
        hits.clear();
        if lo < hi {
            row_match(i, lo, hi, hits);
            debug_assert_eq!(hits.len(), hi - lo);
        }
        if !hits.iter().fold(false, |any, &h| any | h) {
            if !visit(i, lo, lo, &[]) {
                return None;
            }
            continue;
        }
        if filled < hi {
            let tail = row[filled];
            row[filled + 1..=hi].fill(tail);
            filled = hi;
        }
        let mut diag = row[lo];
        let mut left = row[lo];
        for (c, &h) in (lo + 1..=hi).zip(hits.iter()) {
            let up = row[c];
            let v = if h { diag + 1 } else { up.max(left) };
            diag = up;
            row[c] = v;
            left = v;
        }
        if !visit(i, lo, hi, &row[lo + 1..=hi]) {
            return None;
        }
    }
    Some(row[filled] as usize)
}

/// Length of the banded LCSS of `n` rows against `m` columns.
///
/// `band` yields the half-open, 0-based column range of every row in order (`n` items) and
/// must be monotone. `is_match(i, j)` is only called inside the band. `Err` when the band has
/// more cells than the limit `lcss_cells` (checked before the work).
pub fn lcss_len<B, M>(n: usize, m: usize, band: B, is_match: M) -> Result<usize, LcssError>
where
    B: IntoIterator<Item = (usize, usize)>,
    B::IntoIter: Clone,
    M: FnMut(usize, usize) -> bool,
{
    lcss_len_rows(n, m, band, cell_tests(is_match))
}

/// A row matcher for [`lcss_len_rows`] from a per-cell `is_match(i, j)`.
fn cell_tests<M: FnMut(usize, usize) -> bool>(mut is_match: M) -> impl FnMut(usize, usize, usize, &mut Vec<bool>) {
    move |i, lo, hi, hits| hits.extend((lo..hi).map(|j| is_match(i, j)))
}

/// [`lcss_len`] with the match tests made a row at a time: `row_match(i, lo, hi, hits)`
/// appends to `hits` whether `a_i` matches `b_j` for every `j` in `lo..hi`, in order (a caller
/// with columns as slices tests a whole row in one vectorised loop). Same contract, limit and
/// result.
pub fn lcss_len_rows<B, R>(n: usize, m: usize, band: B, row_match: R) -> Result<usize, LcssError>
where
    B: IntoIterator<Item = (usize, usize)>,
    B::IntoIter: Clone,
    R: FnMut(usize, usize, usize, &mut Vec<bool>),
{
    if n == 0 || m == 0 {
        return Ok(0);
    }
    let band = band.into_iter();
    check_cells(&band)?;
    Ok(with_scratch(m, |s| run_rows(s, n, m, band, row_match, |_, _, _, _| true))?.unwrap_or(0))
}

/// The most bytes a [`BandTable`] of `n` rows and `cells` band cells can take: 4 bytes a cell
/// (rows without a match take none) and 32 bytes a row.
pub fn table_bytes(n: usize, cells: u128) -> u128 {
    cells * 4 + (n as u128 + 1) * 32
}

/// The band cells of the LCSS table, kept for backtracking.
#[derive(Debug)]
pub struct BandTable {
    lo: Vec<usize>,
    hi: Vec<usize>,
    off: Vec<usize>,
    vals: Vec<u32>,
    /// `ne[r]` = nearest row `<= r` (1-based) whose band is non-empty, 0 if none.
    ne: Vec<usize>,
}

impl BandTable {
    /// Fills the band cells; same contract (and work limit) as [`lcss_len`]. Rows without a
    /// match are stored as empty bands, which is exact (see [`run_rows`]). Every allocation is
    /// fallible: when one fails, the work stops with [`LcssError::Alloc`] and the bytes the
    /// table had reached.
    pub fn build<B, M>(n: usize, m: usize, band: B, is_match: M) -> Result<Self, LcssError>
    where
        B: IntoIterator<Item = (usize, usize)>,
        B::IntoIter: Clone,
        M: FnMut(usize, usize) -> bool,
    {
        let band = band.into_iter();
        check_cells(&band)?;
        let mut t = BandTable { lo: Vec::new(), hi: Vec::new(), off: Vec::new(), vals: Vec::new(), ne: Vec::new() };
        let rows_ok = t.lo.try_reserve_exact(n).is_ok()
            && t.hi.try_reserve_exact(n).is_ok()
            && t.off.try_reserve_exact(n).is_ok()
            && t.ne.try_reserve_exact(n + 1).is_ok();
        if !rows_ok {
            return Err(LcssError::Alloc { bytes: table_bytes(n, 0) });
        }
        t.ne.resize(n + 1, 0);
        let done = with_scratch(m, |s| run_rows(s, n, m, band, cell_tests(is_match), |i, lo, hi, cells| {
            if t.vals.try_reserve(cells.len()).is_err() {
                return false;
            }
            t.lo.push(lo);
            t.hi.push(hi);
            t.off.push(t.vals.len());
            t.ne[i + 1] = if lo < hi { i + 1 } else { t.ne[i] };
            t.vals.extend_from_slice(cells);
            true
        }))?;
        match done {
            Some(_) => Ok(t),
            None => Err(LcssError::Alloc { bytes: table_bytes(n, t.vals.len() as u128 * 2) }),
        }
    }

    /// `C[i][j]` for 1-based `i`, `j` (0 when either is 0). O(log n).
    pub fn get(&self, i: usize, j: usize) -> u32 {
        if i == 0 || j == 0 {
            return 0;
        }
        // Rows whose band starts left of column j form a prefix (lo is monotone); rows below
        // that prefix have C[r][j] = C[r-1][j].
        let p = self.lo.partition_point(|&l| l < j);
        let r = self.ne[i.min(p)];
        if r == 0 {
            return 0;
        }
        let (lo, hi) = (self.lo[r - 1], self.hi[r - 1]);
        let c = j.min(hi);
        self.vals[self.off[r - 1] + (c - lo - 1)]
    }

    /// Backtracks one longest common subsequence from `C[n][m]`, returning 0-based pairs
    /// `(i, j)` in increasing order. Ties prefer the latest diagonal match, then moving up.
    pub fn backtrack<M>(&self, m: usize, mut is_match: M) -> Vec<(usize, usize)>
    where
        M: FnMut(usize, usize) -> bool,
    {
        let n = self.lo.len();
        let mut out = Vec::new();
        let (mut i, mut j) = (n, m);
        while i > 0 && j > 0 {
            let c = self.get(i, j);
            if c == 0 {
                break;
            }
            let in_band = self.lo[i - 1] < j && j <= self.hi[i - 1];
            if in_band && is_match(i - 1, j - 1) && self.get(i - 1, j - 1) + 1 == c {
                out.push((i - 1, j - 1));
                i -= 1;
                j -= 1;
            } else if self.get(i - 1, j) == c {
                i -= 1;
            } else {
                j -= 1;
            }
        }
        out.reverse();
        out
    }
}

#[cfg(test)]
pub(crate) mod naive {
    //! Slow, obviously correct references used by the property tests of every LCSS form.

    /// Full O(n·m) table of the recurrence, with `allowed(i, j)` gating matches.
    pub fn table<F: Fn(usize, usize) -> bool>(n: usize, m: usize, matches: F) -> Vec<Vec<u32>> {
        let mut c = vec![vec![0u32; m + 1]; n + 1];
        for i in 1..=n {
            for j in 1..=m {
                c[i][j] = if matches(i - 1, j - 1) {
                    c[i - 1][j - 1] + 1
                } else {
                    c[i - 1][j].max(c[i][j - 1])
                };
            }
        }
        c
    }

    /// The textbook recursion of eq. 2.9, memo-free: exponential, only for tiny inputs.
    pub fn recursive<F: Fn(usize, usize) -> bool + Copy>(n: usize, m: usize, matches: F) -> u32 {
        if n == 0 || m == 0 {
            return 0;
        }
        if matches(n - 1, m - 1) {
            1 + recursive(n - 1, m - 1, matches)
        } else {
            recursive(n - 1, m, matches).max(recursive(n, m - 1, matches))
        }
    }
}

#[cfg(test)]
// The slow references index like the textbook definitions they transcribe.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn index_band(n: usize, m: usize, d: usize) -> impl Iterator<Item = (usize, usize)> + Clone {
        (0..n).map(move |i| (i.saturating_sub(d).min(m), (i + d + 1).min(m)))
    }

    proptest! {
        #[test]
        fn banded_equals_full_table(a in prop::collection::vec(0u8..4, 0..12),
                                    b in prop::collection::vec(0u8..4, 0..12),
                                    d in 0usize..6) {
            let allowed = |i: usize, j: usize| i.abs_diff(j) <= d && a[i] == b[j];
            let full = naive::table(a.len(), b.len(), allowed);
            let want = full[a.len()][b.len()];
            let got = lcss_len(a.len(), b.len(), index_band(a.len(), b.len(), d), allowed).unwrap();
            prop_assert_eq!(got as u32, want);
            if a.len() <= 7 && b.len() <= 7 {
                prop_assert_eq!(naive::recursive(a.len(), b.len(), allowed), want);
            }
            let t = BandTable::build(a.len(), b.len(), index_band(a.len(), b.len(), d), allowed).unwrap();
            for i in 0..=a.len() { for j in 0..=b.len() {
                prop_assert_eq!(t.get(i, j), full[i][j], "cell {} {}", i, j);
            }}
            let path = t.backtrack(b.len(), allowed);
            prop_assert_eq!(path.len() as u32, want);
            for w in path.windows(2) { prop_assert!(w[0].0 < w[1].0 && w[0].1 < w[1].1); }
            for &(i, j) in &path { prop_assert!(allowed(i, j)); }
        }
    }

    #[test]
    fn empty_inputs() {
        assert_eq!(lcss_len(0, 5, [], |_, _| true), Ok(0));
        assert_eq!(lcss_len(5, 0, [(0, 0); 5], |_, _| true), Ok(0));
        let t = BandTable::build(3, 0, [(0, 0); 3], |_, _| true).unwrap();
        assert!(t.backtrack(0, |_, _| true).is_empty());
    }

    /// The engine refuses a band over `lcss_cells` before the work (no match test runs).
    #[test]
    fn the_work_limit_is_checked_before_the_work() {
        use crate::limits::{with_scope, Limits};
        let l = std::sync::Arc::new(Limits::default());
        l.set("lcss_cells", 99).unwrap();
        let band = index_band(10, 10, 10); // 100 cells
        let mut tests = 0;
        let e = with_scope(&l, || lcss_len(10, 10, band.clone(), |_, _| { tests += 1; true })).unwrap_err();
        assert!(matches!(&e, LcssError::Work(x) if x.needed == 100 && x.limit == 99), "{e}");
        assert!(e.to_string().contains("trajdb_set_limit('lcss_cells', 100)"), "{e}");
        assert_eq!(tests, 0, "no work before the check");
        assert!(matches!(with_scope(&l, || BandTable::build(10, 10, band.clone(), |_, _| true)), Err(LcssError::Work(_))));
        l.set("lcss_cells", 100).unwrap();
        assert_eq!(with_scope(&l, || lcss_len(10, 10, band, |i, j| i == j)), Ok(10));
    }
}
