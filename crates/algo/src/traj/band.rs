//! The time band, written once: for every time `a_i` of a sorted series A, the half-open index
//! window `[lo_i, hi_i)` of the points of a sorted series B within `T` of it,
//!
//! ```text
//! open:   { j : |a_i − b_j| <  T }  = [lo_i, hi_i)      (LCSS, thesis eq. 2.9: |t_a − t_b| < T)
//! closed: { j : |a_i − b_j| <= T }  = [lo_i, hi_i)      (TimeCPD's E-step cutoff κτ, eq. 2.7)
//! ```
//!
//! Both series sorted ascending makes every window contiguous and both ends non-decreasing in
//! `i`, so two pointers find all of them in O(n + m) time and O(1) memory (each pointer only
//! moves right). The windows are the band of the banded LCSS ([`crate::lcss::band`]) and the
//! sparse E-step of [`crate::align::cpd`]; [`TimeBand::cells`] is the band's size, which the
//! work limits are checked against before the work.
//!
//! Contract: both series NaN-free and non-decreasing (equal times allowed), `T` not NaN (it may
//! be `+inf`: every window is all of B). [`TimeBand::checked`] verifies it (O(n + m));
//! [`TimeBand::new`] is for callers that validated or sorted their input already (checked in
//! debug builds).

use std::fmt;

/// Whether a distance of exactly `T` is inside the window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bound {
    /// `|a − b| < T`.
    Open,
    /// `|a − b| <= T`.
    Closed,
}

/// A series that breaks the contract of [`TimeBand`].
#[derive(Clone, Debug, PartialEq)]
pub enum BandError {
    /// `which[index]` (0-based) is NaN.
    NaN { which: &'static str, index: usize },
    /// `which[index]` (0-based) is smaller than the time before it.
    Unsorted { which: &'static str, index: usize },
    /// The half-width is NaN.
    Width,
}

impl fmt::Display for BandError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BandError::NaN { which, index } => write!(f, "{which}[{}] is NaN", index + 1),
            BandError::Unsorted { which, index } => write!(f, "{which}[{}] is earlier than the time before it (sort by t)", index + 1),
            BandError::Width => write!(f, "the time window is NaN"),
        }
    }
}
impl std::error::Error for BandError {}

/// The windows `[lo_i, hi_i)` of B for every time of A, in order (an exact-size iterator of
/// `a.len()` items). See the module docs.
#[derive(Clone, Debug)]
pub struct TimeBand<'a> {
    a: &'a [f64],
    b: &'a [f64],
    half: f64,
    bound: Bound,
    i: usize,
    lo: usize,
    hi: usize,
}

fn check(which: &'static str, t: &[f64]) -> Result<(), BandError> {
    for (k, v) in t.iter().enumerate() {
        if v.is_nan() {
            return Err(BandError::NaN { which, index: k });
        }
        if k > 0 && *v < t[k - 1] {
            return Err(BandError::Unsorted { which, index: k });
        }
    }
    Ok(())
}

impl<'a> TimeBand<'a> {
    /// The band of sorted, NaN-free `a` against sorted, NaN-free `b` with half-width `half`.
    pub fn new(a: &'a [f64], b: &'a [f64], half: f64, bound: Bound) -> Self {
        debug_assert!(check("a", a).is_ok() && check("b", b).is_ok() && !half.is_nan(), "TimeBand contract");
        TimeBand { a, b, half, bound, i: 0, lo: 0, hi: 0 }
    }

    /// [`TimeBand::new`] after checking the contract.
    pub fn checked(a: &'a [f64], b: &'a [f64], half: f64, bound: Bound) -> Result<Self, BandError> {
        check("a", a)?;
        check("b", b)?;
        if half.is_nan() {
            return Err(BandError::Width);
        }
        Ok(Self::new(a, b, half, bound))
    }

    /// The number of pairs in the band, `Σ_i (hi_i − lo_i)`, of the windows not yet visited.
    pub fn cells(self) -> u128 {
        self.map(|(lo, hi)| (hi - lo) as u128).sum()
    }
}

impl Iterator for TimeBand<'_> {
    type Item = (usize, usize);

    #[inline]
    fn next(&mut self) -> Option<(usize, usize)> {
        let t = *self.a.get(self.i)?;
        self.i += 1;
        let b = self.b;
        match self.bound {
            Bound::Open => {
                while self.lo < b.len() && !(b[self.lo] > t - self.half) {
                    self.lo += 1;
                }
                self.hi = self.hi.max(self.lo);
                while self.hi < b.len() && b[self.hi] < t + self.half {
                    self.hi += 1;
                }
            }
            Bound::Closed => {
                while self.lo < b.len() && b[self.lo] < t - self.half {
                    self.lo += 1;
                }
                self.hi = self.hi.max(self.lo);
                while self.hi < b.len() && b[self.hi] <= t + self.half {
                    self.hi += 1;
                }
            }
        }
        Some((self.lo, self.hi))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.a.len() - self.i;
        (n, Some(n))
    }
}

impl ExactSizeIterator for TimeBand<'_> {}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The obvious O(n·m) version: every pair tested; the window is the first and one past the
    /// last index inside (empty windows are placed where the two-pointer version puts them:
    /// at the first index not before the window).
    fn naive(a: &[f64], b: &[f64], half: f64, bound: Bound) -> Vec<(usize, usize)> {
        let inside = |x: f64, y: f64| match bound {
            Bound::Open => (x - y).abs() < half,
            Bound::Closed => (x - y).abs() <= half,
        };
        a.iter()
            .map(|&x| {
                let js: Vec<usize> = (0..b.len()).filter(|&j| inside(x, b[j])).collect();
                match (js.first(), js.last()) {
                    (Some(&lo), Some(&hi)) => {
                        assert_eq!(hi + 1 - lo, js.len(), "a window of sorted times is contiguous");
                        (lo, hi + 1)
                    }
                    _ => {
                        let before = b.iter().filter(|&&y| !inside(x, y) && y < x).count();
                        (before, before)
                    }
                }
            })
            .collect()
    }

    /// Sorted times on a coarse grid: equal times and exact distances of T are common.
    fn times(max: usize) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec(0u8..16, 0..max).prop_map(|mut v| {
            v.sort();
            v.into_iter().map(|k| k as f64 * 0.5).collect()
        })
    }

    proptest! {
        #[test]
        fn two_pointers_equal_all_pairs(a in times(14), b in times(14),
                                        half in prop::sample::select(vec![0.25, 0.5, 1.0, 2.5, f64::INFINITY]),
                                        closed in any::<bool>()) {
            let bound = if closed { Bound::Closed } else { Bound::Open };
            let got: Vec<(usize, usize)> = TimeBand::checked(&a, &b, half, bound).unwrap().collect();
            let want = naive(&a, &b, half, bound);
            prop_assert_eq!(&got, &want);
            let cells: u128 = want.iter().map(|&(l, h)| (h - l) as u128).sum();
            prop_assert_eq!(TimeBand::new(&a, &b, half, bound).cells(), cells);
            prop_assert_eq!(TimeBand::new(&a, &b, half, bound).len(), a.len());
            for w in got.windows(2) { prop_assert!(w[0].0 <= w[1].0 && w[0].1 <= w[1].1, "monotone"); }
        }
    }

    #[test]
    fn edges_empty_and_rejections() {
        let (a, b) = ([1.0, 2.0, 2.0, 3.0], [1.0, 2.0, 3.0]);
        // exactly T apart: in the closed band, not in the open one
        assert_eq!(TimeBand::new(&a, &b, 1.0, Bound::Closed).collect::<Vec<_>>(), [(0, 2), (0, 3), (0, 3), (1, 3)]);
        assert_eq!(TimeBand::new(&a, &b, 1.0, Bound::Open).collect::<Vec<_>>(), [(0, 1), (1, 2), (1, 2), (2, 3)]);
        assert_eq!(TimeBand::new(&[], &b, 1.0, Bound::Open).count(), 0);
        assert_eq!(TimeBand::new(&a, &[], 1.0, Bound::Open).collect::<Vec<_>>(), [(0, 0); 4]);
        assert_eq!(TimeBand::checked(&[2.0, 1.0], &b, 1.0, Bound::Open).unwrap_err(), BandError::Unsorted { which: "a", index: 1 });
        assert_eq!(TimeBand::checked(&a, &[0.0, f64::NAN], 1.0, Bound::Open).unwrap_err(), BandError::NaN { which: "b", index: 1 });
        assert_eq!(TimeBand::checked(&a, &b, f64::NAN, Bound::Open).unwrap_err(), BandError::Width);
        assert_eq!(BandError::Unsorted { which: "a", index: 1 }.to_string(), "a[2] is earlier than the time before it (sort by t)");
    }
}
