//! 2-D similarity transforms and their least-squares fit.
//!
//! A [`Transform2`] maps a point of the *moving* frame into the *fixed* frame:
//! `p_fixed = scale · R(theta) · p_moving + (tx, ty)`, with `R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]]`.
//!
//! Composition order: [`Transform2::compose`]`(a, b)` is "apply `b`, then `a`", i.e.
//! `compose(a, b).apply(p) == a.apply(b.apply(p))`, the usual `a ∘ b`. To chain camera frames
//! `k → l → ref`, use `compose(l_to_ref, k_to_l)`.
//!
//! [`fit`] is the weighted Umeyama (1991) / Kabsch solution. In 2-D the optimal rotation has a
//! closed form, `θ = atan2(Σ w (x̂ × ŷ), Σ w (x̂ · ŷ))`, which is what the SVD of the 2×2
//! cross-covariance gives (with the reflection excluded), so no SVD is needed. O(n).
//! [`fit_trimmed`] refits on the best `(1 − trim)` share of the pairs until the inlier set is
//! stable (least trimmed squares by concentration steps), O(n log n) per step.

use crate::traj::{OwnedTraj, Traj};
use crate::{finite, ParamError};
use std::fmt;

/// `p_fixed = scale · R(theta) · p_moving + (tx, ty)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform2 {
    pub theta: f64,
    pub tx: f64,
    pub ty: f64,
    pub scale: f64,
}

impl Default for Transform2 {
    fn default() -> Self {
        Transform2::IDENTITY
    }
}

/// Wraps an angle to (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let mut r = a.rem_euclid(2.0 * std::f64::consts::PI);
    if r > std::f64::consts::PI {
        r -= 2.0 * std::f64::consts::PI;
    }
    r
}

/// An angle (or the difference of two) in degrees, wrapped to [−180, 180):
/// `((a + 540) mod 360) − 180` with C's `fmod` (SQL's `%` on doubles), so that align.sql's
/// agreement tests and the score's rotation error get the same doubles as the formula written in
/// SQL; an `a` below −540 (where `fmod` turns negative) is brought up by one more turn. O(1).
/// The largest |angle| (degrees) [`wrap_deg`] takes: beyond it `a + 540` loses the degrees
/// that decide the wrap (at 1e19 the result was 180 degrees off). Callers refuse larger values.
pub const MAX_WRAP_DEG: f64 = 1e15;

/// [`wrap_deg`] of an angle that is finite and within ±[`MAX_WRAP_DEG`]; an error naming the
/// argument otherwise.
pub fn wrap_deg_checked(a: f64) -> Result<f64, RigidError> {
    if !(a.abs() <= MAX_WRAP_DEG) {
        return Err(RigidError::Angle(a));
    }
    Ok(wrap_deg(a))
}

pub fn wrap_deg(a: f64) -> f64 {
    let r = ((a + 540.0) % 360.0) - 180.0;
    if r < -180.0 {
        r + 360.0
    } else {
        r
    }
}

impl Transform2 {
    /// The identity: no rotation, no translation, scale 1.
    pub const IDENTITY: Transform2 = Transform2 { theta: 0.0, tx: 0.0, ty: 0.0, scale: 1.0 };

    pub fn new(theta: f64, tx: f64, ty: f64, scale: f64) -> Self {
        Transform2 { theta, tx, ty, scale }
    }
    /// Rejects non-finite fields and a non-positive scale.
    pub fn validate(&self) -> Result<(), RigidError> {
        if !(self.theta.is_finite() && self.tx.is_finite() && self.ty.is_finite() && self.scale.is_finite()) {
            return Err(RigidError::NotFinite);
        }
        // within these bounds the inverse and every composition stay finite
        if !(1e-150..=1e150).contains(&self.scale) {
            return Err(RigidError::Scale(self.scale));
        }
        if self.tx.abs().max(self.ty.abs()) > 1e150 {
            return Err(RigidError::NotFinite);
        }
        Ok(())
    }
    /// The 2×2 matrix `scale · R(theta)`, row-major.
    pub fn matrix(&self) -> [[f64; 2]; 2] {
        let (s, c) = self.theta.sin_cos();
        [[self.scale * c, -self.scale * s], [self.scale * s, self.scale * c]]
    }
    #[inline]
    pub fn apply(&self, x: f64, y: f64) -> (f64, f64) {
        self.mapper()(x, y)
    }
    /// [`Transform2::apply`] with the matrix (a `sin_cos`) computed once, for loops over many
    /// points: the same operations, so the same results.
    #[inline]
    pub fn mapper(&self) -> impl Fn(f64, f64) -> (f64, f64) + Copy {
        let m = self.matrix();
        let (tx, ty) = (self.tx, self.ty);
        move |x, y| (m[0][0] * x + m[0][1] * y + tx, m[1][0] * x + m[1][1] * y + ty)
    }
    /// Every point of `tr` mapped (`transform_apply`); t unchanged. O(n).
    pub fn apply_traj(&self, tr: Traj<'_>) -> OwnedTraj {
        let mut o = OwnedTraj::default();
        let map = self.mapper();
        for k in 0..tr.len() {
            let (x, y) = map(tr.x[k], tr.y[k]);
            o.push(tr.t[k], x, y);
        }
        o
    }
    /// [`Transform2::apply`] on a point that must be finite (`transform_point`).
    pub fn apply_checked(&self, x: f64, y: f64) -> Result<(f64, f64), ParamError> {
        Ok(self.apply(finite("x", x)?, finite("y", y)?))
    }
    /// `a ∘ b`: apply `b` first, then `self`.
    pub fn compose(&self, b: &Transform2) -> Transform2 {
        let (tx, ty) = self.apply(b.tx, b.ty);
        Transform2 { theta: wrap_angle(self.theta + b.theta), tx, ty, scale: self.scale * b.scale }
    }
    /// The inverse: maps the fixed frame back to the moving frame.
    pub fn invert(&self) -> Transform2 {
        let inv = Transform2 { theta: wrap_angle(-self.theta), tx: 0.0, ty: 0.0, scale: 1.0 / self.scale };
        let (tx, ty) = inv.apply(-self.tx, -self.ty);
        Transform2 { tx, ty, ..inv }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum RigidError {
    /// Fewer usable pairs than the fit needs (2 for a rotation).
    TooFew { got: usize, need: usize },
    /// All moving points coincide: the rotation is undetermined.
    Degenerate,
    NotFinite,
    Scale(f64),
    Trim(f64),
    /// A pair holds NaN or infinity (1-based pair, field name, value).
    PairNotFinite { index: usize, field: &'static str, value: f64 },
    /// An angle (degrees) to wrap that is not finite or beyond ±[`MAX_WRAP_DEG`].
    Angle(f64),
}

impl fmt::Display for RigidError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RigidError::TooFew { got, need } => write!(f, "needs at least {need} point pairs, got {got}"),
            RigidError::Degenerate => write!(f, "all points coincide, so the rotation is undetermined"),
            RigidError::NotFinite => write!(f, "a value is NaN or infinite (or a translation beyond ±1e150)"),
            RigidError::Scale(s) => write!(f, "scale must be between 1e-150 and 1e150, got {s:?}"),
            RigidError::Trim(t) => write!(f, "trim must be in [0, 1), got {t}"),
            RigidError::PairNotFinite { index, field, value } => write!(f, "pairs[{index}].{field} must be finite, got {value}"),
            RigidError::Angle(a) => {
                write!(f, "a must be finite and within +-{MAX_WRAP_DEG:e} degrees (beyond it a double no longer resolves the turn), got {a}")
            }
        }
    }
}
impl std::error::Error for RigidError {}

/// Weighted 2-D Umeyama fit of `fixed ≈ s·R·moving + t` (s = 1 unless `with_scale`).
/// `w` may be empty (all ones). Returns the transform and the weighted RMS residual.
pub fn fit(fx: &[f64], fy: &[f64], mx: &[f64], my: &[f64], w: &[f64], with_scale: bool) -> Result<(Transform2, f64), RigidError> {
    let t = fit_transform(fx, fy, mx, my, w, with_scale)?;
    let rms = residual_rms(&t, fx, fy, mx, my, w);
    Ok((t, rms))
}

/// [`fit`] without the residual.
fn fit_transform(fx: &[f64], fy: &[f64], mx: &[f64], my: &[f64], w: &[f64], with_scale: bool) -> Result<Transform2, RigidError> {
    let n = fx.len();
    let wt = |k: usize| if w.is_empty() { 1.0 } else { w[k] };
    let sw: f64 = (0..n).map(wt).sum();
    if n < 2 || !(sw > 0.0) {
        return Err(RigidError::TooFew { got: n, need: 2 });
    }
    let (mut cfx, mut cfy, mut cmx, mut cmy) = (0.0, 0.0, 0.0, 0.0);
    for k in 0..n {
        let q = wt(k);
        cfx += q * fx[k];
        cfy += q * fy[k];
        cmx += q * mx[k];
        cmy += q * my[k];
    }
    cfx /= sw;
    cfy /= sw;
    cmx /= sw;
    cmy /= sw;
    let (mut dot, mut cross, mut var_m) = (0.0, 0.0, 0.0);
    for k in 0..n {
        let q = wt(k);
        let (ax, ay) = (mx[k] - cmx, my[k] - cmy);
        let (bx, by) = (fx[k] - cfx, fy[k] - cfy);
        dot += q * (ax * bx + ay * by);
        cross += q * (ax * by - ay * bx);
        var_m += q * (ax * ax + ay * ay);
    }
    if !(var_m > 0.0) || !dot.is_finite() || !cross.is_finite() {
        return Err(if dot.is_finite() { RigidError::Degenerate } else { RigidError::NotFinite });
    }
    let theta = cross.atan2(dot);
    let scale = if with_scale { dot.hypot(cross) / var_m } else { 1.0 };
    let mut t = Transform2 { theta, tx: 0.0, ty: 0.0, scale };
    let (px, py) = t.apply(cmx, cmy);
    t.tx = cfx - px;
    t.ty = cfy - py;
    Ok(t)
}

/// Checks that every pair `(fx, fy) <- (mx, my)` is finite (the input rule of [`fit_trimmed`]
/// and [`residual_rms`] in SQL).
pub fn check_pairs(fx: &[f64], fy: &[f64], mx: &[f64], my: &[f64]) -> Result<(), RigidError> {
    for (field, c) in [("fx", fx), ("fy", fy), ("mx", mx), ("my", my)] {
        if let Some(i) = c.iter().position(|v| !v.is_finite()) {
            return Err(RigidError::PairNotFinite { index: i + 1, field, value: c[i] });
        }
    }
    Ok(())
}

/// Weighted RMS of `|fixed − T(moving)|`.
pub fn residual_rms(t: &Transform2, fx: &[f64], fy: &[f64], mx: &[f64], my: &[f64], w: &[f64]) -> f64 {
    let (mut s, mut sw) = (0.0, 0.0);
    let map = t.mapper();
    for k in 0..fx.len() {
        let q = if w.is_empty() { 1.0 } else { w[k] };
        let (px, py) = map(mx[k], my[k]);
        s += q * ((fx[k] - px).powi(2) + (fy[k] - py).powi(2));
        sw += q;
    }
    if sw > 0.0 {
        (s / sw).sqrt()
    } else {
        f64::NAN
    }
}

/// Result of [`fit_trimmed`].
#[derive(Clone, Debug, PartialEq)]
pub struct TrimmedFit {
    pub transform: Transform2,
    /// RMS residual over the kept pairs.
    pub rms: f64,
    /// Which pairs were kept.
    pub inliers: Vec<bool>,
}

/// Least trimmed squares: fit on all pairs, keep the `ceil((1 − trim)·n)` smallest residuals,
/// refit, until the kept set stops changing (at most 50 steps). `trim = 0` is [`fit`].
pub fn fit_trimmed(fx: &[f64], fy: &[f64], mx: &[f64], my: &[f64], trim: f64, with_scale: bool) -> Result<TrimmedFit, RigidError> {
    if !(0.0..1.0).contains(&trim) {
        return Err(RigidError::Trim(trim));
    }
    let n = fx.len();
    let keep = ((1.0 - trim) * n as f64).ceil() as usize;
    let mut t = fit_transform(fx, fy, mx, my, &[], with_scale)?;
    let mut inliers = vec![true; n];
    // buffers reused by every step
    let mut next = vec![false; n];
    let mut w = vec![0.0; n];
    let mut r: Vec<(f64, usize)> = Vec::with_capacity(n);
    for _ in 0..50 {
        let map = t.mapper();
        r.clear();
        r.extend((0..n).map(|k| {
            let (px, py) = map(mx[k], my[k]);
            ((fx[k] - px).powi(2) + (fy[k] - py).powi(2), k)
        }));
        // the keep smallest residuals (ties by index, so the set is deterministic): O(n)
        let kk = keep.max(2).min(n);
        if kk < n {
            r.select_nth_unstable_by(kk - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        }
        next.fill(false);
        for &(_, k) in &r[..kk] {
            next[k] = true;
        }
        for (wk, &b) in w.iter_mut().zip(&next) {
            *wk = b as u8 as f64;
        }
        t = fit_transform(fx, fy, mx, my, &w, with_scale)?;
        if next == inliers {
            break;
        }
        std::mem::swap(&mut inliers, &mut next);
    }
    let w: Vec<f64> = inliers.iter().map(|&b| b as u8 as f64).collect();
    let rms = residual_rms(&t, fx, fy, mx, my, &w);
    Ok(TrimmedFit { transform: t, rms, inliers })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_deg_is_the_sql_formula_and_stays_in_range() {
        for a in [-359.5, -180.0, -0.1, 0.0, 0.1, 179.9, 180.0, 359.99] {
            let sql = ((a + 540.0f64) % 360.0) - 180.0;
            assert_eq!(wrap_deg(a).to_bits(), sql.to_bits(), "{a}");
        }
        for a in [-1e6, -900.0, -541.0, 725.0, 1e6] {
            let w = wrap_deg(a);
            assert!((-180.0..180.0).contains(&w), "{a} -> {w}");
            assert!(((a - w) / 360.0 - ((a - w) / 360.0).round()).abs() < 1e-9, "{a} -> {w}");
        }
    }
    use proptest::prelude::*;

    fn close(a: &Transform2, b: &Transform2) -> bool {
        wrap_angle(a.theta - b.theta).abs() < 1e-9
            && (a.tx - b.tx).abs() < 1e-7
            && (a.ty - b.ty).abs() < 1e-7
            && (a.scale - b.scale).abs() < 1e-9
    }

    proptest! {
        #[test]
        fn compose_invert_and_fit_recover(th in -3.2f64..3.2, tx in -100.0f64..100.0, ty in -100.0f64..100.0,
                                          s in 0.5f64..2.0, th2 in -3.2f64..3.2, px in -50.0f64..50.0, py in -50.0f64..50.0,
                                          pts in prop::collection::vec((-30.0f64..30.0, -30.0f64..30.0), 3..20)) {
            let a = Transform2::new(th, tx, ty, s);
            let b = Transform2::new(th2, ty, tx, 1.0);
            // compose(a, b)(p) = a(b(p))
            let (q1x, q1y) = a.compose(&b).apply(px, py);
            let (bx, by) = b.apply(px, py);
            let (q2x, q2y) = a.apply(bx, by);
            prop_assert!((q1x - q2x).abs() < 1e-8 && (q1y - q2y).abs() < 1e-8);
            // invert
            prop_assert!(close(&a.compose(&a.invert()), &Transform2::default()));
            // exact correspondences give the transform back
            let (mx, my): (Vec<f64>, Vec<f64>) = pts.iter().cloned().unzip();
            let (fx, fy): (Vec<f64>, Vec<f64>) = pts.iter().map(|&(x, y)| a.apply(x, y)).unzip();
            let spread = mx.iter().zip(&my).any(|(x, y)| (x - mx[0]).abs() + (y - my[0]).abs() > 1e-3);
            if spread {
                let (t, rms) = fit(&fx, &fy, &mx, &my, &[], true).unwrap();
                prop_assert!(close(&t, &Transform2 { theta: wrap_angle(th), ..a }), "{:?} vs {:?}", t, a);
                prop_assert!(rms < 1e-6);
            }
        }
    }

    #[test]
    fn trimmed_fit_ignores_outliers() {
        let truth = Transform2::new(2.5, 10.0, -4.0, 1.0);
        let mx: Vec<f64> = (0..40).map(|k| (k as f64 * 1.3).sin() * 20.0).collect();
        let my: Vec<f64> = (0..40).map(|k| (k as f64 * 0.7).cos() * 15.0).collect();
        let (mut fx, mut fy): (Vec<f64>, Vec<f64>) = mx.iter().zip(&my).map(|(&x, &y)| truth.apply(x, y)).unzip();
        for k in 0..8 {
            fx[k * 5] += 50.0;
            fy[k * 5] -= 30.0;
        }
        assert!(!close(&fit(&fx, &fy, &mx, &my, &[], false).unwrap().0, &truth));
        let r = fit_trimmed(&fx, &fy, &mx, &my, 0.25, false).unwrap();
        assert!(close(&r.transform, &truth), "{:?}", r.transform);
        assert_eq!(r.inliers.iter().filter(|&&b| !b).count(), 10);
        assert!(r.rms < 1e-9);
    }

    #[test]
    fn degenerate_inputs() {
        assert_eq!(fit(&[1.0], &[1.0], &[0.0], &[0.0], &[], false).unwrap_err(), RigidError::TooFew { got: 1, need: 2 });
        assert_eq!(fit(&[1.0, 2.0], &[1.0, 2.0], &[0.0, 0.0], &[0.0, 0.0], &[], false).unwrap_err(), RigidError::Degenerate);
        assert!(fit_trimmed(&[1.0, 2.0], &[1.0, 2.0], &[0.0, 1.0], &[0.0, 0.0], 1.0, false).is_err());
        assert!(Transform2::new(0.0, 0.0, 0.0, 0.0).validate().is_err());
        assert!(Transform2::new(f64::NAN, 0.0, 0.0, 1.0).validate().is_err());
    }
}
