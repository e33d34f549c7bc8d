//! One axis of a uniform grid (space or time), for the space-time grids that find the pairs
//! near each other ([`crate::lcss::sparse`], [`crate::conflict::candidates`]), and the common
//! clock's ticks `t = k · period` that every resampled path shares ([`clock_ticks`]:
//! [`crate::traj::resample`] and the fused paths of [`crate::fuse`]).

/// Cells of `size` along one axis; a size that is not finite and > 0 is one cell (index 0).
#[derive(Clone, Copy, Debug)]
pub struct CellAxis(pub f64);

impl CellAxis {
    /// The index of the cell holding `v`. `as` saturates: values past ±2^63 cells share the end
    /// cells, which only adds candidates, never loses one (floor and division are monotone).
    pub fn cell(&self, v: f64) -> i64 {
        if self.0.is_finite() && self.0 > 0.0 {
            (v / self.0).floor() as i64
        } else {
            0
        }
    }
}

/// The common clock's ticks within `[first, last]`: `t = k · period` for integer k, increasing,
/// each computed as `k as f64 * period` (never by adding steps, which drifts), so every path
/// resampled with the same period lands on the same instants to the last bit. O(1) per tick.
/// The caller checks that `first / period` and `last / period` are below 2^53 (k exact) and
/// `period > 0`; a tick `k · period` that rounds below `first` is skipped.
pub fn clock_ticks(first: f64, last: f64, period: f64) -> impl Iterator<Item = f64> {
    let mut k = (first / period).ceil() as i64;
    std::iter::from_fn(move || loop {
        let t = k as f64 * period;
        if !(t <= last) {
            return None;
        }
        k += 1;
        if t >= first {
            return Some(t);
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_multiples_of_the_period_within_the_span() {
        let t: Vec<f64> = clock_ticks(0.25, 1.0, 0.1).collect();
        assert_eq!(t, (3..=10).map(|k| k as f64 * 0.1).collect::<Vec<_>>());
        assert_eq!(clock_ticks(-0.31, -0.1, 0.1).collect::<Vec<_>>(), vec![-3.0 * 0.1, -2.0 * 0.1, -1.0 * 0.1]);
        // -3 · 0.1 rounds to -0.30000000000000004, below -0.3: not a tick of [-0.3, -0.1]
        assert_eq!(clock_ticks(-0.3, -0.1, 0.1).count(), 2);
        assert_eq!(clock_ticks(1.0, 0.5, 0.1).count(), 0);
        assert_eq!(clock_ticks(0.0, 0.0, 0.1).collect::<Vec<_>>(), vec![0.0]);
    }
}
