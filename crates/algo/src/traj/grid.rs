//! One axis of a uniform grid (space or time), for the space-time grids that find the pairs
//! near each other ([`crate::lcss::sparse`], [`crate::conflict::candidates`]), and the common
//! clock's ticks `t = k · period` that every resampled path shares ([`clock_ticks`]:
//! [`crate::traj::resample`] and the fused paths of [`crate::fuse`]), and the window of a time
//! ([`window_index`]: which `[k · width, (k + 1) · width)` holds it, as a host computes the bounds).

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

/// Why [`window_index`] has no answer.
#[derive(Clone, Debug, PartialEq)]
pub enum WindowError {
    Width(f64),
    Time(f64),
    /// `t / width` beyond ±2^53: k would not be exact.
    TooFar { t: f64, width: f64 },
}

impl std::fmt::Display for WindowError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WindowError::Width(w) => write!(f, "width must be finite and > 0 (seconds), got {w:?}"),
            WindowError::Time(t) => write!(f, "t must be finite, got {t:?}"),
            WindowError::TooFar { t, width } => write!(f, "t / width ({t:?} / {width:?}) must lie within +-2^53 windows: use a wider window"),
        }
    }
}
impl std::error::Error for WindowError {}

/// The k with `k as f64 * width <= t < (k + 1) as f64 * width`, each bound computed as a host
/// computes a window's start and end from k (one product, rounded once): the window
/// `[k · width, (k + 1) · width)` that holds `t`. `floor(t / width)` alone can be one off, as
/// `t / width` and `k · width` round apart; the products decide. The archive's Spark runner
/// assigns a road user's first observation to its window with this, and each window task keeps
/// the road users whose first observation lies in its `[start, end)` (sql/window.sql). O(1).
/// An error unless `t` is finite, `width` finite and > 0, and `|t / width| < 2^53` (k exact).
pub fn window_index(t: f64, width: f64) -> Result<i64, WindowError> {
    if !(width.is_finite() && width > 0.0) {
        return Err(WindowError::Width(width));
    }
    if !t.is_finite() {
        return Err(WindowError::Time(t));
    }
    let q = (t / width).floor();
    if !(q.abs() < 9_007_199_254_740_992.0) {
        return Err(WindowError::TooFar { t, width });
    }
    let k = q as i64;
    Ok(if t < k as f64 * width {
        k - 1
    } else if t >= (k + 1) as f64 * width {
        k + 1
    } else {
        k
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

    #[test]
    fn a_time_lies_in_the_window_of_its_index() {
        // the rule itself, against the products, over awkward widths and times near the bounds
        for &w in &[0.1, 0.3, 1.0 / 3.0, 3600.0, 86400.0, 1e-3, 7.7] {
            for k in -50i64..50 {
                for &t in &[k as f64 * w, (k as f64 * w).next_up(), (k as f64 * w).next_down(), (k as f64 + 0.5) * w] {
                    let i = window_index(t, w).unwrap();
                    assert!(i as f64 * w <= t && t < (i + 1) as f64 * w, "t {t} w {w} -> {i}");
                }
            }
        }
        // just below -36 · 0.1 (-3.6000000000000005): floor(t / 0.1) says -36, but -36 · 0.1 lies
        // above t, so window -37 holds it
        let t = (-36.0f64 * 0.1).next_down();
        assert_eq!((t / 0.1f64).floor(), -36.0);
        assert_eq!(window_index(t, 0.1), Ok(-37));
        // 3 · 0.1 is 0.30000000000000004: 0.3 lies in window 2
        assert_eq!(window_index(0.3, 0.1), Ok(2));
        assert_eq!(window_index(1.78e9 + 0.5, 3600.0), Ok(494_444));
        assert!(matches!(window_index(f64::NAN, 1.0), Err(WindowError::Time(_))));
        assert_eq!(window_index(1.0, 0.0), Err(WindowError::Width(0.0)));
        assert_eq!(window_index(1e300, 1e-300), Err(WindowError::TooFar { t: 1e300, width: 1e-300 }));
    }
}
