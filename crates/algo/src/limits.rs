//! Work limits: the most work one call may do, so that a call started by mistake stops at once
//! with an error instead of running for hours (DuckDB's C API gives an extension no way to see
//! the client's interrupt, so Ctrl-C and `con.interrupt()` only stop a query between chunks).
//!
//! Every limit has a documented default, and `CALL trajdb_set_limit('name', value)` raises (or
//! lowers) it for one database, unless its configuration is locked (`lock_configuration`:
//! src/bindings/meta.rs); `trajdb_limit('name')` reads it. The check runs before the work, from
//! sizes alone (O(n + m)), or, where only the work itself tells (`pet_segment_pairs`), as the
//! work proceeds, counted in the loop that does it.
//!
//! A limit bounds work and memory a call is *allowed*; it never makes an allocation safe. Every
//! allocation sized by input is fallible (`try_reserve` or a checked size first) and becomes a
//! typed error, whatever the limits say, so that a raised limit ends in an error, not an abort.
//!
//! # Whose limits
//! Each DuckDB database that loads trajdb gets its own [`Limits`] (made when its functions are
//! registered, kept in their state), so that one user's `trajdb_limit` cannot lift the bound of
//! another database in the same process. The bindings run every kernel inside
//! [`with_scope`]; [`Limit::get`] reads the values of the scope the current thread is in, and
//! outside any scope (pure `algo` tests, the maths called from Rust) the documented default.
//! Nothing sets a limit for the whole process.
//!
//! A scope is per thread: read (check) a limit in the calling thread, before parallel work
//! starts, as every check here does; a parallel closure that must check takes [`current`]
//! and enters it with [`with_scope`].
//!
//! | name | what one call may do | default |
//! |---|---|---|
//! | `lcss_cells` | cells of one LCSS table (inside the time or index band; traj_cluster S2: summed over pairs and candidate translations) | 1e10 (seconds) |
//! | `cpd_pair_visits` | point pairs visited by one `cpd_align`: pairs in the time band × max_iter | 2e10 |
//! | `output_points` | points (or rows) one call returns | 5e7 |
//! | `memory_bytes` | bytes of the working tables one call allocates beyond its input and output (LCSS traceback, `traj_events` pairs, distance matrices, `trajdb_simulate`) | 4e9 |
//! | `shift_pair_fits` | point pairs one `rigid_fit_shifted` fits: shifts × points of all track pairs, summed over its grid passes (checked before each) | 2e8 |
//! | `label_pairs` | child pairs `traj_labels` compares (eq. 5: k(k−1)/2 for a split or merge into k tracks, summed) | 1e9 |
//! | `assign_steps` | `assign_pairs`' dense solves: rows × columns × min(rows, columns) of each connected component, summed (the O(k³) bound of the shortest-augmenting-path solver) | 2e11 |
//! | `pet_segment_pairs` | segment pairs one `traj_pet` examines in its sweep (`traj_conflicts`, `traj_conflicts_top`: per pair of road users), counted as it goes | 5e7 |

use std::cell::RefCell;
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// One limit: its SQL name, what it counts, its default. Its value lives in a [`Limits`].
#[derive(Debug)]
pub struct Limit {
    pub name: &'static str,
    pub counts: &'static str,
    pub default: u64,
}

pub static LCSS_CELLS: Limit = Limit::new("lcss_cells", "LCSS table cells", 10_000_000_000);
pub static CPD_PAIR_VISITS: Limit = Limit::new("cpd_pair_visits", "point-pair visits (pairs in the time band x max_iter)", 20_000_000_000);
pub static OUTPUT_POINTS: Limit = Limit::new("output_points", "output points", 50_000_000);
pub static MEMORY_BYTES: Limit = Limit::new("memory_bytes", "bytes of working memory", 4_000_000_000);
pub static SHIFT_PAIR_FITS: Limit = Limit::new("shift_pair_fits", "point-pair fits (shifts x points)", 200_000_000);
pub static LABEL_PAIRS: Limit = Limit::new("label_pairs", "child pairs compared", 1_000_000_000);
pub static ASSIGN_STEPS: Limit = Limit::new("assign_steps", "dense assignment steps (rows x columns x min(rows, columns), summed over components)", 200_000_000_000);
pub static PET_SEGMENT_PAIRS: Limit = Limit::new("pet_segment_pairs", "segment pairs examined", 50_000_000);

/// Every limit, in the order of the table above.
pub static ALL: [&Limit; 8] = [&LCSS_CELLS, &CPD_PAIR_VISITS, &OUTPUT_POINTS, &MEMORY_BYTES, &SHIFT_PAIR_FITS, &LABEL_PAIRS, &ASSIGN_STEPS, &PET_SEGMENT_PAIRS];

impl Limit {
    const fn new(name: &'static str, counts: &'static str, default: u64) -> Limit {
        Limit { name, counts, default }
    }

    /// The value in the current thread's scope ([`with_scope`]), else the default.
    pub fn get(&self) -> u64 {
        SCOPE.with(|s| s.borrow().as_ref().map(|l| l.get(self))).unwrap_or(self.default)
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
            "this call needs {} {}, above the work limit {} = {}; raise it with CALL trajdb_set_limit('{}', {})",
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

/// The values of every limit ([`ALL`]) for one database; starts at the defaults.
#[derive(Debug)]
pub struct Limits {
    /// One value per entry of [`ALL`], same order.
    values: Vec<AtomicU64>,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { values: ALL.iter().map(|l| AtomicU64::new(l.default)).collect() }
    }
}

impl Limits {
    fn slot(&self, l: &Limit) -> Option<&AtomicU64> {
        ALL.iter().position(|x| std::ptr::eq(*x, l)).and_then(|k| self.values.get(k))
    }

    /// The value of `l` here (its default if `l` is not in [`ALL`]).
    pub fn get(&self, l: &Limit) -> u64 {
        self.slot(l).map(|v| v.load(Ordering::Relaxed)).unwrap_or(l.default)
    }

    /// Sets limit `name` in this set only; returns the previous value.
    pub fn set(&self, name: &str, value: i64) -> Result<u64, LimitError> {
        let l = find(name)?;
        if value < 1 {
            return Err(LimitError::Value(value));
        }
        let slot = self.slot(l).ok_or_else(|| LimitError::Unknown(name.to_string()))?;
        Ok(slot.swap(value as u64, Ordering::Relaxed))
    }
}

thread_local! {
    /// The limits of the database whose call this thread is running ([`with_scope`]).
    static SCOPE: RefCell<Option<Arc<Limits>>> = const { RefCell::new(None) };
}

/// Runs `f` with `limits` as the current thread's limits (nested scopes restore the outer one,
/// also when `f` panics).
pub fn with_scope<R>(limits: &Arc<Limits>, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<Arc<Limits>>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let prev = self.0.take();
            let _ = SCOPE.try_with(|s| *s.borrow_mut() = prev);
        }
    }
    let prev = SCOPE.with(|s| s.borrow_mut().replace(Arc::clone(limits)));
    let _restore = Restore(prev);
    f()
}

/// The limits of the current thread's scope, if any.
pub fn current() -> Option<Arc<Limits>> {
    SCOPE.with(|s| s.borrow().clone())
}

/// Runs `f` within `scope` (a caller's [`current`], carried to a worker thread), or as it is
/// when the caller had none: how rayon workers obey the limits of the call that spawned them.
pub fn within<R>(scope: &Option<Arc<Limits>>, f: impl FnOnce() -> R) -> R {
    match scope {
        Some(l) => with_scope(l, f),
        None => f(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_set_and_errors() {
        assert!(OUTPUT_POINTS.check(50_000_000).is_ok());
        let e = OUTPUT_POINTS.check(50_000_001).unwrap_err();
        assert!(e.to_string().contains("raise it with CALL trajdb_set_limit('output_points', 50000001)"), "{e}");
        assert_eq!(find("nope").unwrap_err().to_string(), "name must be one of lcss_cells, cpd_pair_visits, output_points, memory_bytes, shift_pair_fits, label_pairs, assign_steps, pet_segment_pairs, got 'nope'");
        let mine = Arc::new(Limits::default());
        assert_eq!(mine.set("lcss_cells", 0).unwrap_err(), LimitError::Value(0));
        assert_eq!(mine.set("CPD_PAIR_VISITS", 7).unwrap(), CPD_PAIR_VISITS.default);
        assert_eq!(mine.get(&CPD_PAIR_VISITS), 7);
    }

    #[test]
    fn a_set_of_limits_binds_only_inside_its_scope() {
        let (a, b) = (Arc::new(Limits::default()), Arc::new(Limits::default()));
        a.set("output_points", 10).unwrap();
        assert_eq!(OUTPUT_POINTS.get(), OUTPUT_POINTS.default, "no scope: the default");
        with_scope(&a, || {
            assert_eq!(OUTPUT_POINTS.get(), 10);
            assert!(OUTPUT_POINTS.check(11).is_err());
            // a nested scope (another database's call on this thread) sees its own values
            with_scope(&b, || assert_eq!(OUTPUT_POINTS.get(), OUTPUT_POINTS.default));
            assert_eq!(OUTPUT_POINTS.get(), 10);
            // another thread is in no scope
            std::thread::spawn(|| assert_eq!(OUTPUT_POINTS.get(), OUTPUT_POINTS.default)).join().unwrap();
        });
        assert_eq!(OUTPUT_POINTS.get(), OUTPUT_POINTS.default);
        // a panic inside a scope restores the outer one
        let r = std::panic::catch_unwind(|| with_scope(&a, || panic!("boom")));
        assert!(r.is_err());
        assert!(current().is_none());
        assert_eq!(b.get(&OUTPUT_POINTS), OUTPUT_POINTS.default);
    }
}
