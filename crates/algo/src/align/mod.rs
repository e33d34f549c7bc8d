//! Camera alignment: putting two cameras' points into one frame.
//!
//! | file | SQL | what |
//! |---|---|---|
//! | [`rigid`] | `rigid_fit`, `rigid_rms`, `transform_apply`, `transform_point`, `transform_compose`, `transform_invert` | 2-D similarity transforms; Umeyama/Kabsch fit from known pairs, trimmed (LTS) |
//! | [`correspond`] | `traj_correspond` | time-interpolated point pairs of two tracks (one transform hypothesis) |
//! | [`msd`] | `traj_msd_pairs` | mean squared distance of track pairs over their common time (merge evidence) |
//! | [`shift`] | `rigid_fit_scan`, `rigid_fit_shifted` | clock offsets: the fit of a track pair at every time shift (a Hough line), and the joint fit of many pairs with the best shift |
//! | [`xcorr`] | `activity_lag` | the coarse clock offset of two cameras over every lag: cross-correlation of their activity (FFT, [`fft`]) |
//! | [`register`] | `register_pair` | the final registration when cameras see different points of a road user: rotation and scale within each track pair, translation weighted by each class's offset spread, standard errors by the jackknife |
//! | [`perspective`] | `register_pair` (`perspective_*`) | the perspective term between two cameras' ground planes, measured within track pairs, with its jackknife error and a 5-sigma test (reported, not applied) |
//! | [`register_clock`] | `register_pair` (with `max_shift`) | the clock offset under that model: each class its own mean offset, a time shift seen within pairs (turns, speed changes) and in the classes whose offsets scatter little |
//! | [`clock`] | `clock_to_reference`, `clock_compose`, `clock_invert`, `clock_between`, `clock_from_relative` | the clock model t = (1 + D) t_ref + O, written once |
//! | [`clock_network`] | `clock_network` | one clock drift per camera from every camera pair's drift (weighted least squares over the pairs' graph), and whether the recording shows drift at all |
//! | [`shift_under`] | `rigid_shift_under` | the clock offset of one track pair under a known transform (align.sql's drift measurement) |
//! | [`speed_lag`] | `speed_lag` | the clock offset of one track pair from their speed profiles (frame-free): align.sql's second coarse offset where the activity peak was too far off |
//! | [`frame_change`] | `frame_change` | has a camera's frame or clock changed since its calibration: the day's registration against the calibration day's, in standard errors (an archive's daily check) |
//! | [`map`] | `map_fit`, `map_apply`, `map_residual_m` | results on a map: the similarity from the reference camera's frame to a map CRS fitted on control points, through the tangent plane for longitude/latitude |
//! | [`twin`] | `camera_twin` | is one camera the other exported twice (the load's twin check, sql/pipeline.sql) |
//! | [`cpd`] | `cpd_align` (2-D) | rigid TimeCPD, thesis eq. 2.7/2.8, Alg. 5–8, sparse time-windowed E-step |
//! | [`cpd3`] | `cpd_align` (3-D) | the same model in 3-D (rotation by SVD) |

pub mod clock;
pub mod clock_network;
pub mod drift_fit;
pub mod frame_change;
pub mod map;
pub mod correspond;
pub mod msd;
pub mod perspective;
pub mod register;
pub mod register_clock;
pub mod cpd;
pub mod fft;
pub mod cpd3;
#[cfg(test)]
mod cpd_pinned;
pub mod rigid;
pub mod shift;
pub mod shift_under;
pub mod speed_lag;
pub mod twin;
pub mod xcorr;

/// The scenes of the registration tests: a seeded uniform draw in (0, 1) (a 64-bit LCG's top 53
/// bits) and a normal one (Box-Muller), shared by register, register_clock and perspective.
#[cfg(test)]
pub(crate) mod test_rng {
    pub(crate) fn lcg(state: &mut u64) -> f64 {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    pub(crate) fn gauss(state: &mut u64) -> f64 {
        let (a, b) = (lcg(state), lcg(state));
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}
