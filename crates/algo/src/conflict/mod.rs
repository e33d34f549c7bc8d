//! Surrogate safety measures between two road users' paths (the conflict indicators of
//! traffic-conflict studies): post-encroachment time ([`pet`]) and time-to-collision at
//! constant velocity ([`ttc`]).
//!
//! Both are the measures SSAM (Gettman, Pu, Sayed, Shelby: *Surrogate Safety Assessment Model
//! and Validation*, FHWA-HRT-08-051, 2008) and TrafficIntelligence (Saunier & Sayed 2008,
//! "Probabilistic framework for automated analysis of exposure to road collisions", TRB;
//! `trafficintelligence/moving.py`, `prediction.py`) compute from trajectories. Road users are
//! points on their paths (PET) or discs whose centres must come within `radius` (TTC); each is
//! piecewise linear between its samples, as `traj_resample` and `traj_fuse` give them.
//!
//! One operation per file: [`pet`] (path crossings by segment intersection, with a sweep over
//! one axis as the spatial prefilter and a time window as the temporal one), [`ttc`] (one pass
//! over the merged sample times of the common period), [`pairs`] (both for every pair of a set
//! near each other in time and space: a sweep over start times, never all N² pairs; what
//! sql/analysis.sql `conflicts` calls through `traj_conflicts`), [`top`] (the pairs with the k
//! smallest PETs, searching the PET bound upward: `top_conflicts`, `traj_conflicts_top`) and
//! [`together`] (how close two road users stay over their common time, and when that makes
//! them one road user counted twice: not a near miss) and [`kind`] (SSAM's kinds, only between
//! vehicles).

pub mod candidates;
pub mod kind;
pub mod pairs;
pub mod pet;
pub mod together;
pub mod top;
pub mod ttc;

pub use kind::conflict_kind;
pub use pairs::{conflicts, Conflict};
pub use pet::{pet, Pet};
pub use together::{probably_one, probably_one_body, together, Body, Together};
pub use top::top_conflicts;
pub use ttc::{ttc, Ttc};

use crate::traj::{Traj, TrajError};
use crate::ParamError;

/// Why a conflict measure was refused: a bad trajectory (`a` or `b`, or the k-th of a list),
/// a bad parameter, lists of different lengths, or a work limit.
#[derive(Clone, Debug, PartialEq)]
pub enum ConflictError {
    Traj(&'static str, TrajError),
    /// `trajs[k]` (0-based here, 1-based in the message) of [`conflicts`]
    TrajAt(usize, TrajError),
    Param(ParamError),
    /// `ids` and `trajs` of [`conflicts`] differ in length
    Lengths { ids: usize, trajs: usize },
    /// the same id twice in `ids` of [`conflicts`] (a road user's pairs would be lost or doubled)
    DuplicateId(i64),
    /// `classes` of [`top_conflicts`] is not one per road user
    ClassesLength { ids: usize, classes: usize },
    /// `radii` or `walkers` (named) is not one per road user
    PerRoadUser { what: &'static str, ids: usize, got: usize },
    Work(crate::limits::Exceeded),
}

impl From<ParamError> for ConflictError {
    fn from(e: ParamError) -> Self {
        ConflictError::Param(e)
    }
}

impl ConflictError {
    /// The message for SQL (trajectory arguments named `a` / `b`, 1-based indices).
    pub fn describe(&self) -> String {
        match self {
            ConflictError::Traj(name, e) => e.describe(name),
            ConflictError::TrajAt(k, e) => e.describe(&format!("trajs[{}]", k + 1)),
            ConflictError::Param(e) => e.to_string(),
            ConflictError::Lengths { ids, trajs } => {
                format!("ids and trajs must have the same length, got {ids} ids and {trajs} trajectories (list(id ORDER BY id), list(traj ORDER BY id) over the same rows)")
            }
            ConflictError::DuplicateId(id) => {
                format!("ids must be distinct (one path per road user), got {id} twice; aggregate one row per road user first")
            }
            ConflictError::ClassesLength { ids, classes } => {
                format!("class_codes must list one code per road user, got {classes} codes for {ids} ids (list(code ORDER BY id) over the same rows)")
            }
            ConflictError::PerRoadUser { what, ids, got } => {
                format!("{what} must list one value per road user, got {got} for {ids} ids (list(value ORDER BY id) over the same rows)")
            }
            ConflictError::Work(e) => e.to_string(),
        }
    }
}

impl std::fmt::Display for ConflictError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.describe())
    }
}
impl std::error::Error for ConflictError {}

/// Both trajectories checked against the input policy of [`crate::traj`].
fn validate(a: Traj<'_>, b: Traj<'_>) -> Result<(), ConflictError> {
    a.validate().map_err(|e| ConflictError::Traj("a", e))?;
    b.validate().map_err(|e| ConflictError::Traj("b", e))
}

/// Test paths of the conflict tests: n points from (x0, y0) at t0, velocity (vx, vy), every dt.
#[cfg(test)]
pub(crate) fn test_line(t0: f64, x0: f64, y0: f64, vx: f64, vy: f64, n: usize, dt: f64) -> crate::traj::OwnedTraj {
    let mut o = crate::traj::OwnedTraj::default();
    for k in 0..n {
        let t = k as f64 * dt;
        o.push(t0 + t, x0 + vx * t, y0 + vy * t);
    }
    o
}
