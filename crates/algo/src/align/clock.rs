//! The clock model, written once: a camera's clock against a reference clock is
//! `t_camera = (1 + D) · t_reference + O` (offset O in seconds, drift D a fraction: 200 ppm is
//! 2e-4). align.sql fits O and D per camera pair (steps 3, 3b), composes them along the spanning
//! tree (step 4), puts every point on the reference clock (step 5), and writes each camera
//! pair's relative clock to transforms.csv; the score reads cameras.csv in the same model. Every
//! one of those steps calls a function of this file (SQL: `clock_to_reference`,
//! `clock_compose`, `clock_invert`, `clock_between`, `clock_from_relative`).
//!
//! Without drift (D = 0) every formula reduces to sums of offsets to the last bit: `(t − O) / 1`
//! is `t − O` and `(1 + 0) · a + b` is `a + b` in IEEE arithmetic, so a recording without drift
//! gets exactly the numbers of the offset-only model. Each function is O(1).

use std::fmt;

/// A clock that is not one: an input that is not finite, a drift that is not finite and above
/// −1 (a clock must run forwards), or a result that overflowed (finite inputs near 1e308, or a
/// drift rounded to −1).
#[derive(Clone, Debug, PartialEq)]
pub enum ClockError {
    /// An argument (`offset`, `t`, `c`, `origin_moving`, ...) that is not finite.
    NotFinite { field: &'static str, value: f64 },
    /// A drift that is not finite and > −1.
    Drift(f64),
    /// A computed clock that is not one.
    NotAClock(Box<ClockError>),
    /// A computed time that is not finite.
    TimeOverflow(f64),
}

impl fmt::Display for ClockError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClockError::NotFinite { field, value } => write!(f, "{field} must be finite, got {value}"),
            ClockError::Drift(v) => write!(f, "drift must be finite and > -1 (a fraction: 2e-4 is 200 ppm), got {v}"),
            ClockError::NotAClock(e) => write!(f, "the result is not a clock: {e}; the inputs are too large or too close to -1"),
            ClockError::TimeOverflow(r) => write!(f, "the result ({r}) is not finite: t and offset are too large"),
        }
    }
}
impl std::error::Error for ClockError {}

fn finite(field: &'static str, value: f64) -> Result<f64, ClockError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ClockError::NotFinite { field, value })
    }
}

/// A clock against a reference: `t = (1 + drift) · t_reference + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clock {
    /// O (s): the camera's time when the reference reads 0.
    pub offset: f64,
    /// D: the rate error (1e-6 is 1 ppm); > −1.
    pub drift: f64,
}

impl Clock {
    /// The reference clock itself.
    pub const IDENTITY: Clock = Clock { offset: 0.0, drift: 0.0 };

    pub fn new(offset: f64, drift: f64) -> Clock {
        Clock { offset, drift }
    }

    /// A clock, checked: the offset finite, the drift finite and > −1.
    pub fn checked(offset: f64, drift: f64) -> Result<Clock, ClockError> {
        finite("offset", offset)?;
        if !(drift.is_finite() && drift > -1.0) {
            return Err(ClockError::Drift(drift));
        }
        Ok(Clock { offset, drift })
    }

    /// This clock as the result of a computation, checked like an argument: finite inputs can
    /// still overflow or round a drift to −1, and that is an error, never a clock that the next
    /// call refuses.
    pub fn result(self) -> Result<Clock, ClockError> {
        Clock::checked(self.offset, self.drift).map_err(|e| ClockError::NotAClock(Box::new(e)))
    }

    /// [`Clock::to_reference`] of a finite `t`, its result checked to be finite.
    pub fn to_reference_checked(&self, t: f64) -> Result<f64, ClockError> {
        let r = self.to_reference(finite("t", t)?);
        if r.is_finite() {
            Ok(r)
        } else {
            Err(ClockError::TimeOverflow(r))
        }
    }

    /// [`Clock::from_relative`] of checked inputs, its result checked.
    pub fn from_relative_checked(c: f64, drift: f64, origin_moving: f64, origin_fixed: f64) -> Result<Clock, ClockError> {
        Clock::checked(0.0, drift)?;
        finite("c", c)?;
        finite("origin_moving", origin_moving)?;
        finite("origin_fixed", origin_fixed)?;
        Clock::from_relative(c, drift, origin_moving, origin_fixed).result()
    }

    /// A time of this clock on the reference clock: `(t − O) / (1 + D)`.
    pub fn to_reference(&self, t: f64) -> f64 {
        (t - self.offset) / (1.0 + self.drift)
    }

    /// `self` after `inner`: with `self` the clock of A against B (`t_A = (1 + D₁) t_B + O₁`)
    /// and `inner` the clock of B against C (`t_B = (1 + D₂) t_C + O₂`), the clock of A against
    /// C: `t_A = (1 + D₁)(1 + D₂) t_C + (1 + D₁) O₂ + O₁`, its drift written
    /// `D₁ + D₂ + D₁D₂` (exactly 0 when both are 0).
    pub fn compose(&self, inner: &Clock) -> Clock {
        Clock { offset: (1.0 + self.drift) * inner.offset + self.offset, drift: self.drift + inner.drift + self.drift * inner.drift }
    }

    /// The reference against this clock: `t_ref = (1 + D') t + O'` with `D' = −D / (1 + D)` and
    /// `O' = −O / (1 + D)`.
    pub fn invert(&self) -> Clock {
        Clock { offset: -self.offset / (1.0 + self.drift), drift: -self.drift / (1.0 + self.drift) }
    }

    /// The clock of camera `a` against camera `b`, both given against one reference:
    /// `t_a = (1 + D_a)/(1 + D_b) · t_b + O_a − (1 + D_a)/(1 + D_b) · O_b` (transforms.csv's
    /// `t_from = (1 + drift) t_to + offset`). Equal to `a.compose(&b.invert())` in exact
    /// arithmetic; written with one ratio so that without drift it is `O_a − O_b` exactly.
    pub fn between(a: &Clock, b: &Clock) -> Clock {
        let ratio = (1.0 + a.drift) / (1.0 + b.drift);
        Clock { offset: a.offset - ratio * b.offset, drift: ratio - 1.0 }
    }

    /// A camera pair's clock on the cameras' own clocks from a fit on relative clocks (align.sql
    /// times every camera from its own first time, its origin `o`): the fit says
    /// `t_m − o_m = (1 + D)(t_f − o_f + c)` (c: the offset of the refit, on the fixed camera's
    /// rate), so `O = c (1 + D) + (o_m − o_f) − D · o_f`; without drift `c + (o_m − o_f)`.
    pub fn from_relative(c: f64, drift: f64, origin_moving: f64, origin_fixed: f64) -> Clock {
        let offset = if drift == 0.0 { c + (origin_moving - origin_fixed) } else { c * (1.0 + drift) + (origin_moving - origin_fixed) - drift * origin_fixed };
        Clock { offset, drift }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
    }

    #[test]
    fn bad_clocks_are_refused() {
        assert_eq!(Clock::checked(f64::NAN, 0.0).unwrap_err().to_string(), "offset must be finite, got NaN");
        assert!(Clock::checked(0.0, -1.0).unwrap_err().to_string().starts_with("drift must be finite and > -1"));
        assert!(Clock::checked(0.0, f64::INFINITY).is_err());
        assert_eq!(Clock::checked(1.0, -0.5).unwrap(), Clock::new(1.0, -0.5));
        assert_eq!(Clock::new(0.0, 1e200).compose(&Clock::new(0.0, 1e200)).result().unwrap_err().to_string(),
                   "the result is not a clock: drift must be finite and > -1 (a fraction: 2e-4 is 200 ppm), got inf; the inputs are too large or too close to -1");
        assert_eq!(Clock::new(-1e308, 0.0).to_reference_checked(1e308).unwrap_err(), ClockError::TimeOverflow(f64::INFINITY));
        assert_eq!(Clock::IDENTITY.to_reference_checked(f64::NAN).unwrap_err().to_string(), "t must be finite, got NaN");
        assert_eq!(Clock::from_relative_checked(0.0, 0.0, 1.0, f64::NAN).unwrap_err().to_string(), "origin_fixed must be finite, got NaN");
    }

    #[test]
    fn the_model_by_hand() {
        // 200 ppm fast, 3 s ahead: at reference time 100 the camera reads 100.02 + 3
        let c = Clock::new(3.0, 2e-4);
        assert!(close(c.to_reference(103.02), 100.0));
        assert_eq!(Clock::IDENTITY.to_reference(5.5), 5.5);
        // no drift: plain offsets, bit for bit
        let (a, b) = (Clock::new(0.1, 0.0), Clock::new(0.2, 0.0));
        assert_eq!(a.compose(&b), Clock::new(0.2 + 0.1, 0.0));
        assert_eq!(Clock::between(&a, &b), Clock::new(0.1 - 0.2, 0.0));
        assert_eq!(a.invert(), Clock::new(-0.1, -0.0));
        assert_eq!(Clock::from_relative(0.25, 0.0, 10.0, 4.0).offset, 0.25 + 6.0);
    }

    #[test]
    fn compose_invert_and_between_agree_with_mapping_times() {
        let (a, b, c) = (Clock::new(1.5, 1e-4), Clock::new(-0.7, -3e-4), Clock::new(3600.0, 5e-5));
        for t in [-50.0, 0.0, 12.5, 1800.0] {
            // a after b maps a time of the inner reference C: B reads it, A reads B's reading
            let tb = (1.0 + b.drift) * t + b.offset;
            let ta = (1.0 + a.drift) * tb + a.offset;
            let ab = a.compose(&b);
            assert!(close((1.0 + ab.drift) * t + ab.offset, ta));
            // invert: back to the reference
            let inv = c.invert();
            let tc = (1.0 + c.drift) * t + c.offset;
            assert!(close((1.0 + inv.drift) * tc + inv.offset, t));
            assert!(close(c.to_reference(tc), t));
            // between: b's reading to a's reading of the same instant
            let (ra, rb) = ((1.0 + a.drift) * t + a.offset, (1.0 + b.drift) * t + b.offset);
            let r = Clock::between(&a, &b);
            assert!(close((1.0 + r.drift) * rb + r.offset, ra));
            let slow = a.compose(&b.invert());
            assert!(close(slow.offset, r.offset) && close(slow.drift, r.drift));
        }
        // from_relative: a refit offset c on the relative clocks, origins o_m and o_f
        let (cc, d, om, of) = (0.3, 2e-4, 1000.0, 400.0);
        let k = Clock::from_relative(cc, d, om, of);
        let tf = 700.0;
        let tm = om + (1.0 + d) * (tf - of + cc);
        assert!(close((1.0 + k.drift) * tf + k.offset, tm));
    }
}
