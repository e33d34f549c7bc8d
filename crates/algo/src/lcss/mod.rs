//! The LCSS family: one banded dynamic-programming engine and three ways to use it.
//!
//! | file | SQL | what |
//! |---|---|---|
//! | [`band`] | (engine) | the banded LCSS table shared by every form, with naive references for the tests |
//! | [`time_window`] | `lcss_length`, `lcss_similarity`, `lcss_distance`, `lcss_matches`, `lcss_series_*` | thesis eq. 2.9/2.10, Alg. 1: match within ε metres and T seconds, optionally inside a region |
//! | [`index`] | `lcss_index_similarity`, `lcss_s1` | Buzan def. 4.1/4.2: match within ε and δ list positions |
//! | [`translate`] | `lcss_s2` | Buzan def. 4.3, lemma 4.2: the best S1 over all translations |
//! | [`sparse`] | `lcss_similarity_pairs` | η of eq. 2.10 for every pair of two sets with η > 0, candidates from a space-time grid |
//!
//! Every parameter is checked once, in [`time_window::TimeWindowParams`] or
//! [`index::IndexParams`]; a violation is an [`LcssError`].
//!
//! The work limit `lcss_cells` is checked by the engine ([`band::lcss_len`],
//! [`band::BandTable::build`]) from the band's cells before the work, so every form and every
//! caller (SQL functions, merge, clustering) obeys it: the forms return
//! `Result<_, LcssError>` and a table over the limit is [`LcssError::Work`].

use std::fmt;

pub mod band;
pub mod index;
pub mod sparse;
pub mod time_window;
pub mod translate;

/// The kernels' match test `‖(dx, dy)‖ < ε`. It compares squares, `dx² + dy² < ε²`, wherever ε²
/// is a normal number: there an overflowing square is a distance above ε and an underflowing one
/// a distance below it, so the squares decide as the distance does. Below ε ≈ 1.5e-154 or above
/// ε ≈ 1.3e154, ε² itself underflows or overflows (identical points scored 0 at ε = 1e-300), so
/// those use `hypot`; ε = +inf matches every pair (no spatial constraint).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Within {
    eps: f64,
    e2: f64,
    squared: bool,
}

impl Within {
    pub(crate) fn new(eps: f64) -> Self {
        let e2 = eps * eps;
        Within { eps, e2, squared: e2.is_normal() }
    }
    /// ε² when the squared test is exact for this ε (callers branch once, outside their loops).
    pub(crate) fn squared_bound(&self) -> Option<f64> {
        self.squared.then_some(self.e2)
    }
    #[inline]
    pub(crate) fn test(&self, dx: f64, dy: f64) -> bool {
        if self.squared {
            dx * dx + dy * dy < self.e2
        } else {
            self.eps == f64::INFINITY || dx.hypot(dy) < self.eps
        }
    }
}

/// A parameter was out of range. The message names the parameter and the value.
#[derive(Clone, Debug, PartialEq)]
pub enum LcssError {
    Epsilon(f64),
    TimeWindow(f64),
    MinPoints(i64),
    Delta(i64),
    Rho(f64),
    /// The translation search of S2 would need more candidates than the limit.
    TooLarge { candidates: usize, limit: usize },
    /// The LCSS table would have more cells than the work limit `lcss_cells`.
    Work(crate::limits::Exceeded),
    /// The traceback table of the matched pairs would take more bytes than `memory_bytes`.
    Memory(crate::limits::Exceeded),
    /// The traceback table could not be allocated (it had reached `bytes`).
    Alloc { bytes: u128 },
}

impl fmt::Display for LcssError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LcssError::Epsilon(v) => write!(f, "epsilon must be > 0, got {v}"),
            LcssError::TimeWindow(v) => write!(f, "time_window must be > 0, got {v}"),
            LcssError::MinPoints(v) => write!(f, "min_points must be >= 0, got {v}"),
            LcssError::Delta(v) => write!(f, "delta must be >= 0, got {v}"),
            LcssError::Rho(v) => write!(f, "rho must be in (0, 1], got {v}"),
            LcssError::TooLarge { candidates, limit } => write!(
                f,
                "delta is too large for these trajectories: {candidates} candidate translations (limit {limit}); reduce delta"
            ),
            LcssError::Work(e) => e.fmt(f),
            LcssError::Memory(e) => write!(
                f,
                "{e}, or shorten the trajectories or time_window: the matched pairs need the LCSS table inside the time band, 4 bytes a cell"
            ),
            LcssError::Alloc { bytes } => write!(
                f,
                "the LCSS table of the matched pairs could not be allocated (about {bytes} bytes); shorten the trajectories or time_window"
            ),
        }
    }
}
impl std::error::Error for LcssError {}
