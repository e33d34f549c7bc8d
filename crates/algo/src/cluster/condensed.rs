//! The vocabulary the linkage algorithms share, a leaf that imports nothing of theirs: the
//! [`Linkage`] method, a merge as an algorithm finds it ([`RawMerge`]), the condensed matrix
//! ([`Condensed`]) and how far its column scans prefetch ([`AHEAD`]). [`super::linkage`]
//! dispatches to [`super::mst`] (single) and [`super::nn_chain`] (the others); both read and
//! write through these types, so no algorithm file imports another.

/// Linkage method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Linkage {
    Single,
    Complete,
    Average,
    Weighted,
    Ward,
}

/// How many items ahead the column scans prefetch (at n = 5,000, best of 3 in CPU time on a
/// shared machine, `examples/condensed_timing`: none 0.124 s single / 0.126 s average, 16 ahead
/// 0.078 / 0.101, 32 0.058 / 0.085, 64 0.047 / 0.081, 96 0.044 / 0.075).
pub const AHEAD: usize = 64;

/// One merge as an algorithm finds it: the two clusters by their item index (the cluster that
/// item stands for at that time) and the height. `linkage::label` turns them into [`Merge`](super::linkage::Merge)s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct RawMerge {
    pub x: u32,
    pub y: u32,
    pub distance: f64,
}

/// Read (and, by the NN-chain's updates, written) access to a condensed matrix: row-major upper
/// triangle, `(i, j)`, `i < j`, at `i·n − i(i+1)/2 + j − i − 1`.
pub(super) struct Condensed<'a> {
    ptr: *mut f64,
    len: usize,
    n: usize,
    /// Index of `(i, i + 1)` for every row `i`.
    start: Vec<usize>,
    _m: std::marker::PhantomData<&'a mut [f64]>,
}

// SAFETY: the matrix is shared by the parallel scans (reads) and updates (writes to cells that
// no other task touches, see `set`).
unsafe impl Sync for Condensed<'_> {}

impl<'a> Condensed<'a> {
    pub(super) fn new(m: &'a mut [f64], n: usize) -> Result<Self, std::collections::TryReserveError> {
        assert_eq!(m.len(), n * n.saturating_sub(1) / 2);
        let mut start = Vec::new();
        start.try_reserve_exact(n)?;
        start.extend((0..n).map(|i| i * n - i * (i + 1) / 2));
        Ok(Condensed { ptr: m.as_mut_ptr(), len: m.len(), n, start, _m: std::marker::PhantomData })
    }
    /// A matrix that is only read: for [`super::mst`], which never calls [`Condensed::set`].
    pub(super) fn read_only(m: &'a [f64], n: usize) -> Result<Self, std::collections::TryReserveError> {
        assert_eq!(m.len(), n * n.saturating_sub(1) / 2);
        let mut start = Vec::new();
        start.try_reserve_exact(n)?;
        start.extend((0..n).map(|i| i * n - i * (i + 1) / 2));
        // the pointer is never written through (see above)
        Ok(Condensed { ptr: m.as_ptr() as *mut f64, len: m.len(), n, start, _m: std::marker::PhantomData })
    }
    pub(super) fn n(&self) -> usize {
        self.n
    }
    #[inline(always)]
    fn at(&self, i: usize, j: usize) -> usize {
        debug_assert!(i < j && j < self.n);
        let k = self.start[i] + j - i - 1;
        assert!(k < self.len);
        k
    }
    /// `d(i, j)` for `i < j`.
    #[inline(always)]
    pub(super) fn get_lower(&self, i: usize, j: usize) -> f64 {
        let k = self.at(i, j);
        // SAFETY: k < len (checked in `at`); no write to this cell runs concurrently (`set`).
        unsafe { *self.ptr.add(k) }
    }
    /// A hint to the processor to load `d(i, j)` (`i < j`) into the cache: the column scans
    /// read one cache line per row, and the loads the out-of-order core overlaps by itself
    /// are too few to hide the memory's latency.
    #[inline(always)]
    pub(super) fn prefetch_lower(&self, i: usize, j: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            let k = self.at(i, j);
            // SAFETY: a prefetch neither faults nor changes memory; the address is in the matrix.
            unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(self.ptr.add(k) as *const i8) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (i, j);
    }
    /// `d(i, j)` for `i != j`.
    #[inline(always)]
    pub(super) fn get(&self, i: usize, j: usize) -> f64 {
        if i < j {
            self.get_lower(i, j)
        } else {
            self.get_lower(j, i)
        }
    }
    /// Row `x`: `d(x, x + 1 + k)` at `k`.
    #[inline(always)]
    pub(super) fn row(&self, x: usize) -> &[f64] {
        let s = if x + 1 < self.n { self.start[x] } else { 0 };
        // SAFETY: the row lies within the matrix; `set` is never called while a row is borrowed.
        unsafe { std::slice::from_raw_parts(self.ptr.add(s), self.n - x - 1) }
    }
    /// Sets `d(i, j) = v` (`i != j`).
    ///
    /// # Safety
    /// No other thread reads or writes this cell meanwhile, and no slice from [`Condensed::row`]
    /// is alive.
    #[inline(always)]
    pub(super) unsafe fn set(&self, i: usize, j: usize, v: f64) {
        let k = if i < j { self.at(i, j) } else { self.at(j, i) };
        unsafe { *self.ptr.add(k) = v };
    }
}

