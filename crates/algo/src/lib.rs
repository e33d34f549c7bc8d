//! Pure-Rust algorithms behind trajdb. Nothing in this module imports DuckDB: it builds and
//! tests with `cargo test --release --no-default-features --lib`.
//!
//! One operation per file, grouped by family; each SQL function's descriptor in
//! `src/bindings/<family>.rs` names the file that holds its maths (`trajdb_functions()`
//! column `maths`, and docs/functions.md). Every range check lives in a parameter type or a
//! checking constructor here; the bindings never test a value.
//!
//! | module | what |
//! |---|---|
//! | [`traj`] | trajectory views ([`traj::Traj`], [`traj::Traj3`], series), the input policy, speeds, turn rates, WKT/WKB, resampling |
//! | [`lcss`] | the LCSS family: banded engine, time-window form (thesis eq. 2.9/2.10), index-window S1 and translation-invariant S2 (Buzan) |
//! | [`align`] | 2-D transforms and the Umeyama fit, time-interpolated correspondences, rigid TimeCPD in 2-D and 3-D |
//! | [`geometry`] | polygon regions (WKT/WKB, prepared point-in-polygon), view polygons P^k, overlaps and unions |
//! | [`matching`] | one-to-one assignment: `hungarian_match` (scipy semantics, sparse JV) and `assign_pairs` (lsap) |
//! | [`cluster`] | agglomerative clustering with cannot-links, and trajectories clustered in one call |
//! | [`merge`] | Θ(A, B) of eq. 2.11 for N cameras, and consistent road-user groups |
//! | [`fuse`] | fused paths: constant-velocity Kalman filter + RTS smoother over every camera's observations of one road user (seed 003 §3.8) |
//! | [`events`] | broken / split / merge events within one camera, object / fragment / group labels |
//! | [`break_link`] | the evidence that a start continues an end in one camera (a mixture of constant velocity and acceleration) |
//! | [`stats`] | small robust statistics shared by the modules (the median) |
//! | [`graph`] | union–find and the connected components of a bipartite edge list (shared) |
//! | [`limits`] | work limits per call (LCSS cells, CPD pair visits, output points), raised with `CALL trajdb_set_limit` (refused under `lock_configuration`) |

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::fmt;

pub mod align;
pub mod associate;
pub mod break_link;
pub mod cluster;
pub mod conflict;
pub mod events;
pub mod fuse;
pub mod geometry;
pub mod graph;
pub mod lcss;
pub mod limits;
pub mod matching;
pub mod merge;
pub mod noise;
pub mod peak_hour;
pub mod stats;
pub mod traj;

/// A scalar parameter outside its range: `"<name> must be <rule>, got <value>"`. Modules whose
/// parameters are single numbers use it directly or wrap it in their own error type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamError {
    pub name: &'static str,
    pub rule: &'static str,
    pub value: f64,
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // huge or tiny values in exponent form (1e-320, not 320 digits)
        let v = self.value;
        if v.is_finite() && v != 0.0 && !(1e-6..1e16).contains(&v.abs()) {
            write!(f, "{} must be {}, got {v:e}", self.name, self.rule)
        } else {
            write!(f, "{} must be {}, got {v}", self.name, self.rule)
        }
    }
}
impl std::error::Error for ParamError {}

/// `value` if it is > 0 and finite, else an error saying "must be > 0".
pub fn positive(name: &'static str, value: f64) -> Result<f64, ParamError> {
    if value > 0.0 && value.is_finite() {
        Ok(value)
    } else {
        Err(ParamError { name, rule: "> 0", value })
    }
}

/// `value` if it is > 0 (`+inf` allowed: "no limit"), else an error.
pub fn positive_or_inf(name: &'static str, value: f64) -> Result<f64, ParamError> {
    if value > 0.0 {
        Ok(value)
    } else {
        Err(ParamError { name, rule: "> 0", value })
    }
}

/// `value` if it is >= 0 and finite, else an error.
pub fn non_negative(name: &'static str, value: f64) -> Result<f64, ParamError> {
    if value >= 0.0 && value.is_finite() {
        Ok(value)
    } else {
        Err(ParamError { name, rule: ">= 0", value })
    }
}

/// `value` if it is finite, else an error.
pub fn finite(name: &'static str, value: f64) -> Result<f64, ParamError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ParamError { name, rule: "finite", value })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn param_checks_name_the_parameter_and_the_value() {
        assert_eq!(positive("period", 0.0).unwrap_err().to_string(), "period must be > 0, got 0");
        assert!(positive("period", f64::INFINITY).is_err() && positive("period", f64::NAN).is_err());
        assert_eq!(positive_or_inf("max_gap", f64::INFINITY), Ok(f64::INFINITY));
        assert_eq!(finite("x", f64::NAN).unwrap_err().to_string(), "x must be finite, got NaN");
        assert_eq!(finite("x", -2.5), Ok(-2.5));
    }
}
