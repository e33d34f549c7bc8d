//! Is one camera the other exported twice? The decision behind the pipeline's twin check
//! (sql/pipeline.sql, after the load; SQL `camera_twin`).
//!
//! # The evidence (counted by SQL, which does the joins)
//! For two cameras a and b, each point is put in a cell of 0.1 mm in its camera's own frame;
//! only the cells a camera fills once are used (a standing road user's repeated positions are
//! left out, so that no cell pairs many points with many), giving `points_a` and `points_b`.
//! A point of a and a point of b *coincide* when they fall in the same cell; `shared` is the
//! largest number of coincidences at ONE time difference t_b − t_a (rounded to the
//! microsecond): 0 µs for a plain copy, any constant for a copy whose clock was shifted.
//!
//! # The rule ([`camera_twin`])
//! `share = shared / min(points_a, points_b)`; the cameras are twins when
//! `share >= min_share` (default 0.5). The twin to drop ([`TwinVerdict::copy`]) is the camera
//! with fewer such points: its rows are (nearly) all in the other's. Equal counts: b (the
//! caller passes the camera to keep as a).
//!
//! # Why this rule separates twins from real cameras
//! Two real cameras never put a point in the same 0.1 mm cell at the same time difference as
//! each other's points over and over: their frames differ (each camera has its own origin and
//! rotation), their clocks and sampling phases differ, and even two cameras already registered
//! into one world frame with synchronised clocks carry their own detector noise (centimetres),
//! so a coincidence to 0.1 mm is a chance of about (1e-4 / σ)² per point pair. Measured on the
//! shared scenes (dut_intersection_3cam: cameras 0–1, 0–2, 1–2; dut_roundabout_2cam: 0–1),
//! every real camera pair has share = 0 (no coincident point at any time difference), and a
//! camera exported again under another id has share = 1 exactly. 0.5 sits in the middle of
//! that gap, so a twin that lost up to half its rows, or had half of them rounded into a
//! neighbouring cell (a float32 round trip), is still caught, and no real pair comes near it.
//!
//! # What is detected, and what is not
//! - detected: an identical copy under another id (share 1); a copy of a subset of the rows
//!   (a shorter export, dropped tracks or frames: share relative to the smaller camera, 1); a
//!   copy with its clock shifted by a constant (the coincidences all fall at one time
//!   difference); a copy with its track ids renumbered (tracks play no part).
//! - not detected: a copy whose frame was moved (rotated, translated or scaled: no cell
//!   coincides), or with noise added, or resampled at other times, or whose clock drifts
//!   against the original. Such a "copy" carries no information the alignment cannot treat
//!   as a second camera's; it is aligned as one (a zero-residual pair).
//!
//! # Complexity
//! O(1): the counts are the caller's (one hash join on the cells).

use crate::ParamError;

/// Which of the two cameras is the copy to drop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    A,
    B,
}

/// [`camera_twin`]'s answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwinVerdict {
    /// `shared / min(points_a, points_b)`, 0 when either camera has no point.
    pub share: f64,
    /// `share >= min_share`.
    pub twin: bool,
    /// The camera to drop when `twin` (the one with fewer points; b on a tie), else `None`.
    pub copy: Option<Side>,
}

/// The default `min_share` (see the module docs for why 0.5).
pub const DEFAULT_MIN_SHARE: f64 = 0.5;

/// Decides whether cameras a and b are one camera exported twice, from the counts of the
/// module docs. Errors: `min_share` outside (0, 1]; `shared` larger than the smaller camera's
/// count (each point coincides with at most one point of the other camera, so the counts
/// cannot come from the rule's join).
pub fn camera_twin(points_a: u64, points_b: u64, shared: u64, min_share: f64) -> Result<TwinVerdict, ParamError> {
    if !(min_share > 0.0 && min_share <= 1.0) {
        return Err(ParamError { name: "min_share", rule: "in (0, 1]", value: min_share });
    }
    let smaller = points_a.min(points_b);
    if shared > smaller {
        return Err(ParamError { name: "shared", rule: "<= the smaller of points_a and points_b", value: shared as f64 });
    }
    let share = if smaller == 0 { 0.0 } else { shared as f64 / smaller as f64 };
    let twin = smaller > 0 && share >= min_share;
    let copy = twin.then_some(if points_a < points_b { Side::A } else { Side::B });
    Ok(TwinVerdict { share, twin, copy })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_identical_copy_is_a_twin_and_b_is_dropped() {
        let v = camera_twin(1000, 1000, 1000, DEFAULT_MIN_SHARE).unwrap();
        assert_eq!(v, TwinVerdict { share: 1.0, twin: true, copy: Some(Side::B) });
    }

    #[test]
    fn a_subset_copy_is_dropped_whichever_side_it_is() {
        assert_eq!(camera_twin(300, 1000, 300, 0.5).unwrap().copy, Some(Side::A));
        assert_eq!(camera_twin(1000, 300, 300, 0.5).unwrap().copy, Some(Side::B));
    }

    #[test]
    fn real_cameras_share_nothing_and_are_not_twins() {
        let v = camera_twin(40_000, 30_000, 0, 0.5).unwrap();
        assert_eq!(v, TwinVerdict { share: 0.0, twin: false, copy: None });
        // a few chance coincidences are far from the threshold
        assert!(!camera_twin(40_000, 30_000, 3, 0.5).unwrap().twin);
    }

    #[test]
    fn the_threshold_is_inclusive() {
        assert!(camera_twin(100, 200, 50, 0.5).unwrap().twin);
        assert!(!camera_twin(100, 200, 49, 0.5).unwrap().twin);
        assert!(camera_twin(100, 200, 100, 1.0).unwrap().twin);
    }

    #[test]
    fn an_empty_camera_is_never_a_twin() {
        assert_eq!(camera_twin(0, 0, 0, 0.5).unwrap(), TwinVerdict { share: 0.0, twin: false, copy: None });
        assert_eq!(camera_twin(0, 10, 0, 0.5).unwrap().twin, false);
    }

    #[test]
    fn bad_parameters_are_typed_errors() {
        for m in [0.0, -0.5, 1.5, f64::NAN, f64::INFINITY] {
            let e = camera_twin(10, 10, 5, m).unwrap_err();
            assert_eq!(e.name, "min_share");
        }
        let e = camera_twin(10, 20, 11, 0.5).unwrap_err();
        assert_eq!(e.name, "shared");
        assert!(e.to_string().contains("got 11"));
    }

    #[test]
    fn the_verdict_does_not_depend_on_the_order_of_the_cameras_but_the_tie() {
        for (a, b, s) in [(100u64, 250u64, 90u64), (500, 80, 80), (7, 7, 7), (50, 60, 20)] {
            let x = camera_twin(a, b, s, 0.5).unwrap();
            let y = camera_twin(b, a, s, 0.5).unwrap();
            assert_eq!((x.share, x.twin), (y.share, y.twin));
            if a != b {
                assert_eq!(x.copy.map(|c| c == Side::A), y.copy.map(|c| c == Side::B));
            }
        }
    }
}
