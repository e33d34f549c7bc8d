//! SQL bindings of the noise model's conversions (crates/algo/src/noise.rs): what the stages
//! measure (medians and percentiles of distances) to the model's parameters, each once.

use super::registry::{pd, Function, Param, Section, Signature, Ty};
use super::vector::{Args, Out};
use crate::algo::noise;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;

/// A DOUBLE function of DOUBLE arguments, NULL in NULL out; an argument outside its domain is an
/// error naming it.
fn doubles<const N: usize>(a: &Args<'_>, out: &mut Out<'_>, f: impl Fn([f64; N]) -> Result<f64, noise::NoiseError>) -> R {
    let row = a.doubles::<N>();
    let vals = a.map(|r| {
        let Some(v) = row(r) else { return Ok(None) };
        Ok(Some(f(v)?))
    })?;
    out.flat(&vals);
    Ok(())
}

const SIGMA_PAIR: Param = pd("sigma_pair_m", Ty::Double, "the camera pair's per-axis noise sqrt(sigma_a² + sigma_b²) (m), >= 0");

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "recording_gap_s",
        description: "How long the road can be empty before the recording, not the traffic, has stopped (s): 10 x p99_interarrival_s (the \
                      99th percentile of the gaps between consecutive road users' first sightings), at least 60 s (under Poisson arrivals \
                      a gap of 10 x p99 comes by chance with probability 0.01^10; a recording in sessions shows hours). The report cuts \
                      the recording into sessions at longer gaps: quarter hours inside a gap are not recorded, those a gap cuts are \
                      partial, and neither takes part in the peak hour (crates/algo/src/peak_hour.rs). NULL for NULL; NaN or negative: 60. \
                      O(1).",
        example: "SELECT recording_gap_s(30); -- 300.0",
        maths: "crates/algo/src/peak_hour.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["noise_reappear_radius_95"],
        signatures: &[Signature {
            params: &[
                pd("p99_interarrival_s", Ty::Double, "the 99th percentile of the gaps between consecutive road users' first sightings (s); NaN or negative gives 60"),
            ],
            arities: &[],
            returns: Ty::Double,
            kernel: recording_gap_s,
        }],
        table: None,
    },
    Function {
        name: "noise_sigma_from_second_differences",
        description: "A camera's per-axis position noise sigma (m) from the median of |p(t+1) - 2 p(t) + p(t-1)|² (m²) over evenly spaced triples of its tracks (calibrate.sql): the second difference of noisy positions is 6 sigma² per axis, its squared length 6 sigma² chi2(2) with median 12 ln 2 sigma², so sigma = sqrt(median_sq / (12 ln 2)). NULL for NULL; a negative or non-finite argument is an error naming it. O(1).",
        example: "SELECT round(noise_sigma_from_second_differences(12 * ln(2) * 0.01), 6); -- 0.1",
        maths: "crates/algo/src/noise.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["noise_sigma_from_rayleigh_median", "noise_match_epsilon"],
        signatures: &[Signature {
            params: &[
                pd("median_sq", Ty::Double, "the median of |p(t+1) - 2 p(t) + p(t-1)|² over evenly spaced triples of a camera's tracks (m²), >= 0"),
            ],
            arities: &[],
            returns: Ty::Double,
            kernel: noise_sigma_from_second_differences,
        }],
        table: None,
    },
    Function {
        name: "noise_sigma_from_rayleigh_median",
        description: "Per-axis sigma (m) from the median length of 2-D Gaussian residuals (align.sql's matched residuals): median / sqrt(2 ln 2), the Rayleigh median. NULL for NULL; a negative or non-finite argument is an error naming it. O(1).",
        example: "SELECT round(noise_sigma_from_rayleigh_median(sqrt(2 * ln(2))), 6); -- 1.0",
        maths: "crates/algo/src/noise.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["noise_sigma_from_second_differences", "noise_sigma_from_rayleigh_p95"],
        signatures: &[Signature {
            params: &[pd("median_m", Ty::Double, "the median length of the 2-D residuals (m), >= 0")],
            arities: &[],
            returns: Ty::Double,
            kernel: noise_sigma_from_rayleigh_median,
        }],
        table: None,
    },
    Function {
        name: "noise_sigma_from_rayleigh_p95",
        description: "Per-axis sigma from the 95th percentile length of a 2-D Gaussian quantity (a class's acceleration, accel_p95): p95 / sqrt(2 ln 20) (= p95 / 2.45). NULL for NULL; a negative or non-finite argument is an error naming it. O(1).",
        example: "SELECT round(noise_sigma_from_rayleigh_p95(sqrt(2 * ln(20))), 6); -- 1.0",
        maths: "crates/algo/src/noise.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["noise_sigma_from_rayleigh_median", "noise_process_q"],
        signatures: &[Signature {
            params: &[pd("p95", Ty::Double, "the 95th percentile length of the 2-D quantity (its unit, e.g. m/s² for accel_p95), >= 0")],
            arities: &[],
            returns: Ty::Double,
            kernel: noise_sigma_from_rayleigh_p95,
        }],
        table: None,
    },
    Function {
        name: "noise_align_vote_rms",
        description: "align.sql's first gate (m): a clock and frame hypothesis of a track pair votes when the RMS of its point pairs about its own fit is within 0.1 + 3 sigma_pair, sigma_pair = sqrt(sigma_a² + sigma_b²) the camera pair's per-axis noise (calibrate.sql's align_max_rms_m, 'auto'); 0.1 m covers a hypothesis's clock-grid and interpolation error. NULL for NULL; a negative or non-finite argument is an error naming it. O(1).",
        example: "SELECT round(noise_align_vote_rms(0.1), 6); -- 0.4",
        maths: "crates/algo/src/noise.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["noise_align_refine_rms", "rigid_fit_scan"],
        signatures: &[Signature {
            params: &[SIGMA_PAIR],
            arities: &[],
            returns: Ty::Double,
            kernel: noise_align_vote_rms,
        }],
        table: None,
    },
    Function {
        name: "noise_align_refine_rms",
        description: "align.sql's second gate (m, align_clean): a track pair is kept in the refit when the RMS about its own mean offset is within 0.05 + 2 sigma_pair (calibrate.sql's align_refine_rms_m, 'auto'): road users walking side by side 0.7 m apart stay out while sigma_pair is under ~0.3 m. NULL for NULL; a negative or non-finite argument is an error naming it. O(1).",
        example: "SELECT round(noise_align_refine_rms(0.1), 6); -- 0.25",
        maths: "crates/algo/src/noise.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["noise_align_vote_rms"],
        signatures: &[Signature {
            params: &[SIGMA_PAIR],
            arities: &[],
            returns: Ty::Double,
            kernel: noise_align_refine_rms,
        }],
        table: None,
    },
    Function {
        name: "noise_match_epsilon",
        description: "LCSS's matching radius epsilon (m) for a camera pair whose residuals have per-axis sigma_m (align.sql's merge_epsilon): 99 % of a true pair's points fall within sqrt(2 ln 100) sigma (3.03 sigma); at least 1 mm (noise-free input measures sigma 0, and LCSS needs epsilon > 0). NULL for NULL; a negative or non-finite argument is an error naming it. O(1).",
        example: "SELECT round(noise_match_epsilon(0.1), 4); -- 0.3035",
        maths: "crates/algo/src/noise.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["lcss_similarity_pairs", "noise_sigma_from_rayleigh_median"],
        signatures: &[Signature {
            params: &[pd("sigma_m", Ty::Double, "the per-axis sigma of the camera pair's residuals (m), >= 0")],
            arities: &[],
            returns: Ty::Double,
            kernel: noise_match_epsilon,
        }],
        table: None,
    },
    Function {
        name: "noise_process_q",
        description: "The white-noise-acceleration density q (m²/s³) of a class for the fusion's Kalman smoother (fuse.sql), from its accel_p95 (m/s²: second differences on tracks resampled to 1 s) and the cameras' mean position variance noise_var (m²): q = 1.5 max((accel_p95 / sqrt(2 ln 20))² - 6 noise_var, 0.1 (accel_p95 / sqrt(2 ln 20))²). NULL for NULL; a negative or non-finite argument is an error naming it. O(1).",
        example: "SELECT round(noise_process_q(2.0, 0.0), 4); -- 1.0014",
        maths: "crates/algo/src/noise.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["traj_fuse", "noise_sigma_from_rayleigh_p95"],
        signatures: &[Signature {
            params: &[
                pd("accel_p95", Ty::Double, "the class's 95th percentile acceleration (m/s²; second differences on tracks resampled to 1 s), >= 0"),
                pd("noise_var", Ty::Double, "the cameras' mean position variance (m²), >= 0"),
            ],
            arities: &[],
            returns: Ty::Double,
            kernel: noise_process_q,
        }],
        table: None,
    },
    Function {
        name: "noise_reappear_radius_95",
        description: "The radius (m) holding 95 % of where a road user reappears after a gap of gap_s (quality.sql's local density of starts): position noise sigma_m plus the acceleration allowance sigma_acc gap²/2 per axis, sqrt(5.99 (sigma_m² + (sigma_acc gap_s² / 2)²)) (chi2(2) at 0.95), at least min_radius_m. NULL for NULL; a negative or non-finite argument is an error naming it. O(1).",
        example: "SELECT round(noise_reappear_radius_95(1.0, 0.0, 1.0, 0.0), 4); -- 2.4477",
        maths: "crates/algo/src/noise.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["break_evidence", "noise_velocity_window_s"],
        signatures: &[Signature {
            params: &[
                pd("sigma_m", Ty::Double, "the position noise per axis (m), >= 0"),
                pd("sigma_acc", Ty::Double, "the road user's acceleration per axis (m/s²), >= 0"),
                pd("gap_s", Ty::Double, "the gap (s), >= 0"),
                pd("min_radius_m", Ty::Double, "the least radius returned (m), >= 0"),
            ],
            arities: &[],
            returns: Ty::Double,
            kernel: noise_reappear_radius_95,
        }],
        table: None,
    },
    Function {
        name: "noise_velocity_window_s",
        description: "The window W (s) of the least-squares line that gives a track end's velocity (calibrate.sql's calib_fit_window, used by quality.sql's break links): the line's velocity variance 12 sigma_m² period_s / W³ per axis plus the bias sigma_acc W / 2 of a road user accelerating at sigma_acc (m/s², per axis) is least at W⁵ = 72 sigma_m² period_s / sigma_acc²; at least 3 periods; sigma_m and sigma_acc at least 1e-3. NULL for NULL; a negative or non-finite argument is an error naming it. O(1).",
        example: "SELECT round(noise_velocity_window_s(0.3, 0.1, 1.5 / sqrt(2 * ln(20))), 2); -- 1.12",
        maths: "crates/algo/src/noise.rs",
        binding: file!(),
        section: Section::Noise,
        see_also: &["break_evidence", "noise_reappear_radius_95"],
        signatures: &[Signature {
            params: &[
                pd("sigma_m", Ty::Double, "the position noise per axis (m), >= 0 (at least 1e-3 is used)"),
                pd("period_s", Ty::Double, "the sampling period (s), >= 0"),
                pd("sigma_acc", Ty::Double, "the road user's acceleration per axis (m/s²), >= 0 (at least 1e-3 is used)"),
            ],
            arities: &[],
            returns: Ty::Double,
            kernel: noise_velocity_window_s,
        }],
        table: None,
    },
];

fn noise_velocity_window_s(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<3>(a, out, |v| noise::velocity_window_s(v[0], v[1], v[2]))
}

fn noise_sigma_from_second_differences(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<1>(a, out, |v| noise::sigma_from_second_differences(v[0]))
}

fn noise_sigma_from_rayleigh_median(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<1>(a, out, |v| noise::sigma_from_rayleigh_median(v[0]))
}

fn noise_sigma_from_rayleigh_p95(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<1>(a, out, |v| noise::sigma_from_rayleigh_p95(v[0]))
}

fn noise_match_epsilon(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<1>(a, out, |v| noise::match_epsilon(v[0]))
}

fn noise_process_q(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<2>(a, out, |v| noise::process_noise_q(v[0], v[1]))
}

fn noise_reappear_radius_95(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<4>(a, out, |v| noise::reappear_radius_95(v[0], v[1], v[2], v[3]))
}

fn noise_align_vote_rms(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<1>(a, out, |[s]| noise::align_vote_rms(s))
}

fn noise_align_refine_rms(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<1>(a, out, |[s]| noise::align_refine_rms(s))
}

fn recording_gap_s(a: &Args<'_>, out: &mut Out<'_>) -> R {
    doubles::<1>(a, out, |[p]| Ok(crate::algo::peak_hour::recording_gap_s(p)))
}
