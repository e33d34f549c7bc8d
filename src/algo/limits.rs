//! Work limits: the most work one call may do, so that a call started by mistake stops at once
//! with an error instead of running for hours (DuckDB's C API gives an extension no way to see
//! the client's interrupt, so Ctrl-C and `con.interrupt()` only stop a query between chunks).
//!
//! Every limit has a documented default, and `SELECT trajdb_limit('name', value)` raises (or
//! lowers) it for the process; `SELECT * FROM trajdb_limits()`-style reading is
//! `trajdb_limit('name')`. The check runs before the work, from sizes alone (O(n + m)).
//!
//! | name | what one call may do | default |
//! |---|---|---|
//! | `lcss_cells` | cells of one LCSS table (inside the time or index band; traj_cluster S2: summed over pairs and candidate translations) | 1e10 (seconds) |
//! | `cpd_pair_visits` | point pairs visited by one `cpd_align`: pairs in the time band × max_iter | 2e10 |
//! | `output_points` | points (or rows) one call returns | 5e7 |

use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};

/// One limit: its SQL name, what it counts, its default.
#[derive(Debug)]
pub struct Limit {
    pub name: &'static str,
    pub counts: &'static str,
    pub default: u64,
    value: AtomicU64,
}

pub static LCSS_CELLS: Limit = Limit::new("lcss_cells", "LCSS table cells", 10_000_000_000);
pub static CPD_PAIR_VISITS: Limit = Limit::new("cpd_pair_visits", "point-pair visits (pairs in the time band x max_iter)", 20_000_000_000);
pub static OUTPUT_POINTS: Limit = Limit::new("output_points", "output points", 50_000_000);
pub static MEMORY_BYTES: Limit = Limit::new("memory_bytes", "bytes of working memory", 4_000_000_000);
pub static SHIFT_PAIR_FITS: Limit = Limit::new("shift_pair_fits", "point-pair fits (shifts x points)", 2_000_000_000);
pub static LABEL_PAIRS: Limit = Limit::new("label_pairs", "child pairs compared", 1_000_000_000);

/// Every limit, in the order of the table above.
pub static ALL: [&Limit; 6] = [&LCSS_CELLS, &CPD_PAIR_VISITS, &OUTPUT_POINTS, &MEMORY_BYTES, &SHIFT_PAIR_FITS, &LABEL_PAIRS];

impl Limit {
    const fn new(name: &'static str, counts: &'static str, default: u64) -> Limit {
        Limit { name, counts, default, value: AtomicU64::new(default) }
    }

    pub fn get(&self) -> u64 {
        self.value.load(Ordering::Relaxed)
    }

    /// `Ok` when `needed` is within the limit; otherwise the error that says how to raise it.
    pub fn check(&self, needed: u128) -> Result<(), Exceeded> {
        let limit = self.get();
        if needed > limit as u128 {
            Err(Exceeded { name: self.name, counts: self.counts, needed, limit })
        } else {
            Ok(())
        }
    }
}

/// A call would do more work than a limit allows.
#[derive(Clone, Debug, PartialEq)]
pub struct Exceeded {
    pub name: &'static str,
    pub counts: &'static str,
    pub needed: u128,
    pub limit: u64,
}

impl fmt::Display for Exceeded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "this call needs {} {}, above the work limit {} = {}; raise it with SELECT trajdb_limit('{}', {})",
            self.needed,
            self.counts,
            self.name,
            self.limit,
            self.name,
            self.needed.min(u64::MAX as u128)
        )
    }
}
impl std::error::Error for Exceeded {}

/// An unknown limit name or a value below 1.
#[derive(Clone, Debug, PartialEq)]
pub enum LimitError {
    Unknown(String),
    Value(i64),
}

impl fmt::Display for LimitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LimitError::Unknown(n) => {
                write!(f, "name must be one of {}, got '{n}'", ALL.iter().map(|l| l.name).collect::<Vec<_>>().join(", "))
            }
            LimitError::Value(v) => write!(f, "value must be >= 1, got {v}"),
        }
    }
}
impl std::error::Error for LimitError {}

pub fn find(name: &str) -> Result<&'static Limit, LimitError> {
    ALL.iter().copied().find(|l| l.name.eq_ignore_ascii_case(name)).ok_or_else(|| LimitError::Unknown(name.to_string()))
}

/// Sets limit `name` for the whole process; returns the previous value.
pub fn set(name: &str, value: i64) -> Result<u64, LimitError> {
    let l = find(name)?;
    if value < 1 {
        return Err(LimitError::Value(value));
    }
    Ok(l.value.swap(value as u64, Ordering::Relaxed))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_set_and_errors() {
        assert!(OUTPUT_POINTS.check(50_000_000).is_ok());
        let e = OUTPUT_POINTS.check(50_000_001).unwrap_err();
        assert!(e.to_string().contains("raise it with SELECT trajdb_limit('output_points', 50000001)"), "{e}");
        assert_eq!(find("nope").unwrap_err().to_string(), "name must be one of lcss_cells, cpd_pair_visits, output_points, memory_bytes, shift_pair_fits, label_pairs, got 'nope'");
        assert_eq!(set("lcss_cells", 0).unwrap_err(), LimitError::Value(0));
        // tests share the process: set the value it already has
        let v = CPD_PAIR_VISITS.get();
        assert_eq!(set("CPD_PAIR_VISITS", v as i64).unwrap(), v);
    }
}
