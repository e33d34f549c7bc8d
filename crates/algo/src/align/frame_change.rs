//! Has a camera's frame or clock changed since its calibration (issue 40: an archive's
//! calibration is kept across days and checked every day)?
//!
//! The archive (python/trajdb/archive.py, sql/archive_check.sql) registers each camera pair on
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

/// The test above. `d_*` are the day's differences from the calibration day (rad, m, m, s) and
/// `se_*` their standard errors; `z_crit` the threshold in standard errors.
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
) -> Result<Option<FrameChange>, FrameChangeError> {
    if !(z_crit.is_finite() && z_crit > 0.0) {
        return Err(FrameChangeError::BadThreshold(z_crit));
    }
    let z_theta = ratio(d_theta, se_theta);
    let z_pos = match (ratio(d_x, se_x), ratio(d_y, se_y)) {
        (Some(a), Some(b)) => Some(a.hypot(b)),
        _ => None,
    };
    let z_clock = ratio(d_dt, se_dt);
    let Some(z) = [z_theta, z_pos, z_clock].into_iter().flatten().reduce(f64::max) else { return Ok(None) };
    Ok(Some(FrameChange { changed: z > z_crit, z, z_theta, z_pos, z_clock }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_metre_at_ten_centimetres_is_a_change_and_noise_is_not() {
        let moved = frame_change(Some(0.0), Some(1e-3), Some(1.0), Some(0.1), Some(0.0), Some(0.1), Some(0.0), Some(0.01), 5.0).unwrap().unwrap();
        assert!(moved.changed && (moved.z - 10.0).abs() < 1e-12 && moved.z_pos == Some(10.0));
        let still = frame_change(Some(1e-3), Some(1e-3), Some(0.1), Some(0.1), Some(-0.1), Some(0.1), Some(0.01), Some(0.01), 5.0).unwrap().unwrap();
        assert!(!still.changed && (still.z - 2f64.sqrt()).abs() < 1e-12);
        // a degree at 0.1 degree of error
        let turned = frame_change(Some(1f64.to_radians()), Some(0.1f64.to_radians()), None, None, None, None, None, None, 5.0).unwrap().unwrap();
        assert!(turned.changed && turned.z_pos.is_none() && turned.z_clock.is_none());
    }

    #[test]
    fn missing_parts_are_not_tested_and_a_bad_threshold_is_an_error() {
        assert_eq!(frame_change(None, None, None, None, None, None, None, None, 5.0).unwrap(), None);
        assert_eq!(frame_change(Some(1.0), Some(0.0), Some(f64::NAN), Some(1.0), Some(0.0), Some(1.0), None, None, 5.0).unwrap(), None);
        assert!(frame_change(None, None, None, None, None, None, None, None, 0.0).unwrap_err().to_string().contains("z_crit"));
        assert!(frame_change(None, None, None, None, None, None, None, None, f64::NAN).is_err());
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
            let r = frame_change(Some(v[0]), Some(v[1]), Some(v[2]), Some(v[3]), Some(v[4]), Some(v[5]), Some(v[6]), Some(v[7]), zc).unwrap().unwrap();
            let slow = [v[0].abs() / v[1], ((v[2] / v[3]).powi(2) + (v[4] / v[5]).powi(2)).sqrt(), v[6].abs() / v[7]];
            let z = slow.iter().cloned().fold(f64::MIN, f64::max);
            assert!((r.z - z).abs() < 1e-12 && r.changed == (z > zc));
        }
    }
}
