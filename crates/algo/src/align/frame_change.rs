//! Has a camera's frame or clock changed since its calibration (issue 40: an archive's
//! calibration is kept across days and checked every day)?
//!
//! The archive (python/trajdb/archives.py, sql/archive_check.sql) registers each camera pair on
//! the day's matched tracks under the kept calibration (`register_pair`, with the moving
//! camera's points centred on an anchor fixed on the calibration day, so that the translation
//! is where the anchor lands, not a lever arm from a far origin), and the same on the
//! calibration day itself. The differences between the two (rotation, the anchor's position,
//! the clock) and their standard errors (the two fits' jackknife errors, in quadrature) come
//! here. The test is
//!
//! ```text
//! z_theta = |d_theta| / se_theta,  z_pos = sqrt((d_x / se_x)^2 + (d_y / se_y)^2),  z_clock = |d_dt| / se_dt
//! changed = max(z_theta, z_pos, z_clock) > z_crit
//! ```
//!
//! z_pos is the square root of a chi-square with 2 degrees of freedom under no change; above 5 it
//! is exceeded with probability exp(-12.5) = 3.7e-6, |z| > 5 of one normal 5.7e-7: either is a
//! false alarm in about a thousand years of daily checks of a few camera pairs. A part whose
//! difference or standard error is missing (NULL, not finite, or a standard error of 0) is not
//! tested; with none left the result is NULL. O(1).
//!
//! **Estimated errors.** Those tails hold when the standard errors are known. They are estimated:
//! register_pair's block jackknife over min(pairs, 16) blocks of track pairs
//! ([`jackknife_dof`](super::register::jackknife_dof): ν = 15 at most, 7 for a quiet pair's 8
//! matches), so a ratio is Student's t with ν degrees of freedom, whose tail is far heavier:
//! P(|t_7| > 5) = 1.6e-3, a false alarm every 600 pair-days, P(|t_15| > 5) = 1.6e-4 (the hostile
//! review's finding). So with `pairs` given (the track pairs of the smaller of the two
//! registrations: ν from it, a conservative bound on Welch's ν for the two fits together, which
//! lies between that and twice it), each ratio is first turned into the normal (or, for z_pos,
//! the chi-square(2)) value with the same tail:
//!
//! ```text
//! z_theta, z_clock:  z = (8ν + 1) / (8ν + 3) · sqrt(ν ln(1 + t² / ν))     (Wallace 1959, Ann. Math.
//!                    Stat. 30: within 0.05 of the exact normal equivalent for ν ≥ 3,
//!                    t ≤ 8, low where it errs, by up to 0.05: tested)
//! z_pos:             z = sqrt(ν ln(1 + z_pos² / ν))   (z_pos² / 2 taken as F(2, ν), whose tail
//!                    (1 + 2F/ν)^(-ν/2) equals chi-square(2)'s exp(-z²/2) exactly at this z)
//! ```
//!
//! Both tend to the ratio itself as ν grows; with ν = 15 a t of 5 becomes 3.77 and a change
//! must show a t of about 8.3 to pass z_crit = 5; with ν = 7 a t of 5 becomes 3.15 (its tail,
//! 1.6e-3, is a normal's at 3.15) and it takes about 17.7. Fewer than 8 pairs (no jackknife) leave
//! nothing tested.

/// What [`frame_change`] decided, with the statistics behind it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameChange {
    pub changed: bool,
    /// The largest of the three (the tested ones).
    pub z: f64,
    pub z_theta: Option<f64>,
    pub z_pos: Option<f64>,
    pub z_clock: Option<f64>,
}

/// The error of [`frame_change`].
#[derive(Debug, Clone, PartialEq)]
pub enum FrameChangeError {
    /// z_crit is not a finite number > 0.
    BadThreshold(f64),
}

impl std::fmt::Display for FrameChangeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FrameChangeError::BadThreshold(z) => write!(f, "frame_change: z_crit must be a finite number > 0 (standard errors), got {z}; give e.g. 5"),
        }
    }
}

impl std::error::Error for FrameChangeError {}

fn ratio(d: Option<f64>, se: Option<f64>) -> Option<f64> {
    match (d, se) {
        (Some(d), Some(se)) if d.is_finite() && se.is_finite() && se > 0.0 => Some(d.abs() / se),
        _ => None,
    }
}

/// The normal value with the tail of Student's t = `t` at `nu` degrees of freedom (Wallace's
/// approximation, module doc); `nu` infinite: `t` itself.
pub fn t_as_normal(t: f64, nu: f64) -> f64 {
    if nu.is_infinite() {
        return t;
    }
    (8.0 * nu + 1.0) / (8.0 * nu + 3.0) * (nu * (t * t / nu).ln_1p()).sqrt()
}

/// The chi-square(2) root with the tail of sqrt(2 F(2, ν)) = `z` (exact, module doc).
pub fn f2_as_chi2(z: f64, nu: f64) -> f64 {
    if nu.is_infinite() {
        return z;
    }
    (nu * (z * z / nu).ln_1p()).sqrt()
}

/// The test above. `d_*` are the day's differences from the calibration day (rad, m, m, s) and
/// `se_*` their standard errors; `z_crit` the threshold in standard errors; `pairs` the track
/// pairs of the smaller registration, whose jackknife gives the errors' degrees of freedom (None:
/// known errors, the normal limit; NaN, negative or fewer than 8: nothing tested).
#[allow(clippy::too_many_arguments)]
pub fn frame_change(
    d_theta: Option<f64>,
    se_theta: Option<f64>,
    d_x: Option<f64>,
    se_x: Option<f64>,
    d_y: Option<f64>,
    se_y: Option<f64>,
    d_dt: Option<f64>,
    se_dt: Option<f64>,
    z_crit: f64,
    pairs: Option<f64>,
) -> Result<Option<FrameChange>, FrameChangeError> {
    if !(z_crit.is_finite() && z_crit > 0.0) {
        return Err(FrameChangeError::BadThreshold(z_crit));
    }
    let nu = match pairs {
        None => f64::INFINITY,
        Some(n) if n.is_finite() && n >= 0.0 => match super::register::jackknife_dof(n as usize) {
            0 => return Ok(None), // no jackknife: the errors say nothing
            nu => nu as f64,
        },
        Some(_) => return Ok(None),
    };
    let z_theta = ratio(d_theta, se_theta).map(|t| t_as_normal(t, nu));
    let z_pos = match (ratio(d_x, se_x), ratio(d_y, se_y)) {
        (Some(a), Some(b)) => Some(f2_as_chi2(a.hypot(b), nu)),
        _ => None,
    };
    let z_clock = ratio(d_dt, se_dt).map(|t| t_as_normal(t, nu));
    let Some(z) = [z_theta, z_pos, z_clock].into_iter().flatten().reduce(f64::max) else { return Ok(None) };
    Ok(Some(FrameChange { changed: z > z_crit, z, z_theta, z_pos, z_clock }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_metre_at_ten_centimetres_is_a_change_and_noise_is_not() {
        let moved = frame_change(Some(0.0), Some(1e-3), Some(1.0), Some(0.1), Some(0.0), Some(0.1), Some(0.0), Some(0.01), 5.0, None).unwrap().unwrap();
        assert!(moved.changed && (moved.z - 10.0).abs() < 1e-12 && moved.z_pos == Some(10.0));
        let still = frame_change(Some(1e-3), Some(1e-3), Some(0.1), Some(0.1), Some(-0.1), Some(0.1), Some(0.01), Some(0.01), 5.0, None).unwrap().unwrap();
        assert!(!still.changed && (still.z - 2f64.sqrt()).abs() < 1e-12);
        // a degree at 0.1 degree of error
        let turned = frame_change(Some(1f64.to_radians()), Some(0.1f64.to_radians()), None, None, None, None, None, None, 5.0, None).unwrap().unwrap();
        assert!(turned.changed && turned.z_pos.is_none() && turned.z_clock.is_none());
    }

    #[test]
    fn missing_parts_are_not_tested_and_a_bad_threshold_is_an_error() {
        assert_eq!(frame_change(None, None, None, None, None, None, None, None, 5.0, None).unwrap(), None);
        assert_eq!(frame_change(Some(1.0), Some(0.0), Some(f64::NAN), Some(1.0), Some(0.0), Some(1.0), None, None, 5.0, None).unwrap(), None);
        assert!(frame_change(None, None, None, None, None, None, None, None, 0.0, None).unwrap_err().to_string().contains("z_crit"));
        assert!(frame_change(None, None, None, None, None, None, None, None, f64::NAN, None).is_err());
    }

    /// Property: the test equals its definition written out, for any signs and scales.
    #[test]
    fn equals_the_definition() {
        let mut s = 12345u64;
        let mut u = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..1000 {
            let v: Vec<f64> = (0..8).map(|k| if k % 2 == 0 { (u() - 0.5) * 4.0 } else { u() + 1e-3 }).collect();
            let zc = 0.5 + u() * 5.0;
            let r = frame_change(Some(v[0]), Some(v[1]), Some(v[2]), Some(v[3]), Some(v[4]), Some(v[5]), Some(v[6]), Some(v[7]), zc, None).unwrap().unwrap();
            let slow = [v[0].abs() / v[1], ((v[2] / v[3]).powi(2) + (v[4] / v[5]).powi(2)).sqrt(), v[6].abs() / v[7]];
            let z = slow.iter().cloned().fold(f64::MIN, f64::max);
            assert!((r.z - z).abs() < 1e-12 && r.changed == (z > zc));
        }
    }

    /// The small-sample conversion against exact tails: Student's t and the normal tails by
    /// numerical integration of their densities; Wallace's z must have the
    /// t's tail within 0.05 in z for ν >= 3, never more than 0.005 above it.
    #[test]
    fn few_pairs_are_judged_by_the_t_tail() {
        fn ln_gamma(x: f64) -> f64 {
            // Lanczos (g = 7, n = 9), accurate to ~1e-15 for x > 0.5
            const C: [f64; 9] = [0.999_999_999_999_809_9, 676.520_368_121_885_1, -1_259.139_216_722_402_8, 771.323_428_777_653_1,
                -176.615_029_162_140_6, 12.507_343_278_686_905, -0.138_571_095_265_720_12, 9.984_369_578_019_572e-6, 1.505_632_735_149_311_6e-7];
            let x = x - 1.0;
            let mut a = C[0];
            let t = x + 7.5;
            for (k, c) in C.iter().enumerate().skip(1) {
                a += c / (x + k as f64);
            }
            0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
        }
        // P(|X| > x0) of a symmetric density f: twice its integral from x0, by Simpson in s with
        // x = x0 + s / (1 - s), s in [0, 1) (dx = ds / (1 - s)^2)
        fn two_sided_tail(f: impl Fn(f64) -> f64, x0: f64) -> f64 {
            let n = 20000;
            let h = 1.0 / n as f64;
            let g = |s: f64| if s >= 1.0 { 0.0 } else { f(x0 + s / (1.0 - s)) / (1.0 - s).powi(2) };
            let mut sum = g(0.0) + g(1.0);
            for k in 1..n {
                sum += g(k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
            }
            2.0 * sum * h / 3.0
        }
        let t_tail = |t: f64, nu: f64| {
            let c = (ln_gamma((nu + 1.0) / 2.0) - ln_gamma(nu / 2.0) - 0.5 * (nu * std::f64::consts::PI).ln()).exp();
            two_sided_tail(|x| c * (1.0 + x * x / nu).powf(-(nu + 1.0) / 2.0), t)
        };
        let normal_tail = |z: f64| two_sided_tail(|x| (-x * x / 2.0).exp() / (2.0 * std::f64::consts::PI).sqrt(), z);
        for nu in [3.0, 7.0, 20.0, 49.0, 399.0] {
            for t in [1.0, 3.0, 5.0, 8.0] {
                let z = t_as_normal(t, nu);
                let p = t_tail(t, nu);
                // the normal z with tail p, by bisection
                let (mut lo, mut hi) = (0.0, 40.0);
                for _ in 0..200 {
                    let m = 0.5 * (lo + hi);
                    if normal_tail(m) > p { lo = m } else { hi = m }
                }
                // within 0.05 (low at large t: fewer alarms)
                assert!((z - lo).abs() < 0.05 && z < lo + 5e-3, "nu {nu} t {t}: Wallace {z}, exact {lo}");
            }
        }
        // F(2, nu): the tail of z_pos is (1 + z^2 / nu)^(-nu/2), chi-square(2)'s at the result
        for nu in [3.0, 7.0, 50.0] {
            let z = f2_as_chi2(5.0, nu);
            assert!(((-z * z / 2.0).exp() - (1.0 + 25.0 / nu).powf(-nu / 2.0)).abs() < 1e-15);
        }
        // 8 pairs (7 degrees of freedom): t = 5 is no change at z_crit 5; t = 20 is
        let quiet = frame_change(Some(5e-3), Some(1e-3), None, None, None, None, None, None, 5.0, Some(8.0)).unwrap().unwrap();
        assert!(!quiet.changed && (quiet.z - 3.15).abs() < 0.05, "{quiet:?}");
        let moved = frame_change(Some(20e-3), Some(1e-3), None, None, None, None, None, None, 5.0, Some(8.0)).unwrap().unwrap();
        assert!(moved.changed);
        // 400 pairs: 16 blocks, 15 degrees of freedom (t = 5 -> 3.77, 9 -> 5.2)
        let many = frame_change(Some(5e-3), Some(1e-3), None, None, None, None, None, None, 5.0, Some(400.0)).unwrap().unwrap();
        assert!(!many.changed && (many.z - 3.77).abs() < 0.01, "{many:?}");
        let nine = frame_change(Some(9e-3), Some(1e-3), None, None, None, None, None, None, 5.0, Some(400.0)).unwrap().unwrap();
        assert!(nine.changed && (nine.z - 5.2).abs() < 0.05, "{nine:?}");
        // fewer than 8 pairs (no jackknife), NaN, negative: nothing tested
        for bad in [7.0, f64::NAN, -1.0] {
            assert_eq!(frame_change(Some(1.0), Some(1e-3), None, None, None, None, None, None, 5.0, Some(bad)).unwrap(), None);
        }
    }
}
