//! Fused paths: one road user's observations from every camera, smoothed into one path with a
//! per-point uncertainty (issue 26, part 4; the Kalman filter of seed 003, section 3.8, with the
//! Rauch–Tung–Striebel smoother).
//!
//! | file | SQL | what |
//! |---|---|---|
//! | [`smooth`] | `traj_fuse`, `traj_fuse_sigma` | constant-velocity Kalman filter + RTS smoother over the observations, exact diffuse start |
//! | [`offsets`] | `traj_source_offsets` | each source track's constant offset within one road user (another point of it seen): least squares over the sources' differences in common time, about their mean |
//! | [`sample`] | `traj_fuse`, `traj_fuse_sigma` (with `period`) | the smoothed path at t = k · period: the Gaussian bridge between two smoothed states |
//!
//! # Model (per axis; x and y are independent and share every covariance)
//! State `s = (p, v)` (position, velocity) on the reference clock; between two times `d` apart
//! (seed 003 eq. 3.10, with `A = F`):
//!
//! ```text
//! s(t + d) = F(d) s(t) + w,   F(d) = [[1, d], [0, 1]],   w ~ N(0, Q(d)),
//! Q(d) = q [[d³/3, d²/2], [d²/2, d]]
//! ```
//!
//! the continuous white-noise-acceleration model (Bar-Shalom, Li & Kirubarajan 2001, §6.2.2):
//! the acceleration is white noise of power spectral density `q` (m²/s³ per axis), so the
//! velocity changes by `sqrt(q d)` (1 σ) over `d` seconds. An observation `(t, x, y, σ)` sees
//! the position with independent noise `N(0, σ²)` per axis (eq. 3.13–3.15 with `H = [1, 0]`,
//! `R = σ²`; the measurement model is linear, so the filter is the plain Kalman filter).
//!
//! # Observations at the same time
//! Observations less than [`SAME_TIME_S`] apart form one group. Sequential Kalman updates at one
//! time with `H = [1, 0]` are exactly one update with the inverse-variance weighted mean
//! `z̄ = Σ z_i/σ_i² / Σ 1/σ_i²` and variance `1 / Σ 1/σ_i²` (the product of the Gaussian
//! likelihoods), which is what [`smooth`] does; the group keeps its first time.
//!
//! # What comes out
//! The smoothed state `E[s(t) | every observation]` (the RTS smoother gives the batch MAP /
//! least-squares estimate of the whole path under this model, with a flat prior on the start:
//! the tests check this against a dense solve of the normal equations) and its position
//! variance `P_pp`; `sigma = sqrt((P_xx + P_yy) / 2) = sqrt(P_pp)` in metres, the 1-σ error per
//! axis of the fused position.
//!
//! # Complexity and limits
//! O(n + m) time and memory for n observations and m output points; the work limits
//! `memory_bytes` (the per-group filter states, [`GROUP_BYTES`] each) and `output_points` are
//! checked from the sizes before any work, and every allocation sized by input is fallible.

use super::limits;
use super::ParamError;
use std::fmt;

pub mod offsets;
pub mod sample;
pub mod smooth;
#[cfg(test)]
mod batch;

pub use sample::fuse;
pub use smooth::{smooth, Smoothed};

/// Observations closer than this (seconds) are one time: above the f64 resolution of Unix-epoch
/// times (2.4e-7 s at t ≈ 1.78e9 s), far below any camera's frame interval (1 ms at 1 kHz).
pub const SAME_TIME_S: f64 = 1e-6;

/// Bytes of filter state one observation group holds (filtered, predicted and smoothed means
/// for two axes and 2×2 covariances, gains, times): the `memory_bytes` check.
pub const GROUP_BYTES: u64 = 40 * 8;

/// Observations of one road user: `t` (s, non-decreasing), `x`, `y` (m, one frame) and the
/// per-axis noise `sigma` (m, > 0) of the camera that made each. All four have one length.
#[derive(Clone, Copy, Debug)]
pub struct Obs<'a> {
    pub t: &'a [f64],
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub sigma: &'a [f64],
}

impl<'a> Obs<'a> {
    /// Panics if the slices differ in length (a programming error, not input).
    pub fn new(t: &'a [f64], x: &'a [f64], y: &'a [f64], sigma: &'a [f64]) -> Self {
        assert!(t.len() == x.len() && t.len() == y.len() && t.len() == sigma.len(), "Obs::new: column lengths differ");
        Obs { t, x, y, sigma }
    }
    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    /// Every value finite (t first, then x, y, sigma), sigma > 0, t non-decreasing.
    pub fn validate(&self) -> Result<(), FuseError> {
        for (field, col) in [("t", self.t), ("x", self.x), ("y", self.y), ("sigma", self.sigma)] {
            if let Some(index) = col.iter().position(|v| !v.is_finite()) {
                return Err(FuseError::NotFinite { index, field, value: col[index] });
            }
        }
        // within 1e-30..1e30: the filter's variances are products of sigma^2 with sigma^2 and
        // q dt^3; past these they under- or overflow and 0/0 or inf - inf gave NaN from finite
        // input (issue 37: sigma 1e-200)
        if let Some(index) = self.sigma.iter().position(|&s| !(s >= SIGMA_RANGE.0 && s <= SIGMA_RANGE.1)) {
            return Err(FuseError::Sigma { index, value: self.sigma[index] });
        }
        if let Some(k) = self.t.windows(2).position(|w| w[1] < w[0]) {
            return Err(FuseError::Unsorted { index: k + 1, prev: self.t[k], t: self.t[k + 1] });
        }
        Ok(())
    }
}

/// A fused path: one point per output time, with its 1-σ position error per axis.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FusedPath {
    pub t: Vec<f64>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub sigma: Vec<f64>,
}

impl FusedPath {
    /// An empty path with room for `n` points (fallible: `n` comes from the input).
    pub(crate) fn with_capacity(n: usize) -> Result<Self, FuseError> {
        let mut p = FusedPath::default();
        let ok = p.t.try_reserve_exact(n).is_ok() && p.x.try_reserve_exact(n).is_ok() && p.y.try_reserve_exact(n).is_ok() && p.sigma.try_reserve_exact(n).is_ok();
        if ok {
            Ok(p)
        } else {
            Err(FuseError::Memory { bytes: n as u128 * 32 })
        }
    }
    pub(crate) fn push(&mut self, t: f64, x: f64, y: f64, sigma: f64) {
        self.t.push(t);
        self.x.push(x);
        self.y.push(y);
        self.sigma.push(sigma);
    }
    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
}

/// Why observations or parameters were refused. Indices are 0-based here; [`FuseError::describe`]
/// prints them 1-based, as SQL lists count.
#[derive(Clone, Debug, PartialEq)]
pub enum FuseError {
    NotFinite { index: usize, field: &'static str, value: f64 },
    Unsorted { index: usize, prev: f64, t: f64 },
    /// An observation's sigma is not > 0.
    Sigma { index: usize, value: f64 },
    /// `q`, `period` or `max_gap` out of range.
    Param(ParamError),
    /// The output would exceed the work limit `output_points`.
    TooManyPoints(f64),
    /// The filter states would exceed the work limit `memory_bytes`, or the allocation failed.
    Memory { bytes: u128 },
}

impl From<ParamError> for FuseError {
    fn from(e: ParamError) -> Self {
        FuseError::Param(e)
    }
}

impl FuseError {
    /// The message for an observation list argument called `param`, 1-based positions.
    pub fn describe(&self, param: &str) -> String {
        match self {
            FuseError::NotFinite { index, field, value } => format!("{param}[{}].{field} must be finite, got {value}", index + 1),
            FuseError::Unsorted { index, prev, t } => format!(
                "{param} must be ordered by t, but {param}[{}].t = {t} follows {param}[{}].t = {prev} \
                 (build it with list({{'t': t, 'x': x, 'y': y, 'sigma': sigma}} ORDER BY t))",
                index + 1,
                index
            ),
            FuseError::Sigma { index, value } => format!(
                "{param}[{}].sigma must be in [1e-30, 1e30] (the observation's position noise in metres, e.g. calib_cameras.sigma_m), got {value}",
                index + 1
            ),
            FuseError::Param(e) => e.to_string(),
            FuseError::TooManyPoints(n) => {
                let l = &limits::OUTPUT_POINTS;
                format!(
                    "would produce {n:.0} points, above the work limit {} = {}; use a longer period, or raise it with CALL trajdb_set_limit('{}', {n:.0})",
                    l.name,
                    l.get(),
                    l.name
                )
            }
            FuseError::Memory { bytes } => {
                let l = &limits::MEMORY_BYTES;
                format!(
                    "needs {bytes} bytes of filter state, above the work limit {} = {} or more than could be allocated; fuse fewer observations \
                     per call (one road user at a time), or raise it with CALL trajdb_set_limit('{}', {bytes})",
                    l.name,
                    l.get(),
                    l.name
                )
            }
        }
    }
}

impl fmt::Display for FuseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.describe("obs"))
    }
}
impl std::error::Error for FuseError {}

/// The observations' sigma (m) the filter takes: outside it its variances under- or overflow.
pub const SIGMA_RANGE: (f64, f64) = (1e-30, 1e30);
/// The largest `q` the filter takes (q dt^3 and its products stay finite; real q is below 1e3).
pub const Q_MAX: f64 = 1e30;

/// `q` if it is in [0, 1e30] (0: no process noise, a straight line at constant velocity; above
/// 1e30 the filter's variances overflow and finite input gave NaN: issue 37, q = 1e200).
pub(crate) fn check_q(q: f64) -> Result<f64, FuseError> {
    if (0.0..=Q_MAX).contains(&q) {
        Ok(q)
    } else {
        Err(FuseError::Param(ParamError { name: "q", rule: "in [0, 1e30] (the acceleration noise density, m^2/s^3)", value: q }))
    }
}

/// Per-axis 2×2 symmetric covariance `[[pp, pv], [pv, vv]]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Cov {
    pub pp: f64,
    pub pv: f64,
    pub vv: f64,
}

/// A general 2×2 matrix `[[a, b], [c, d]]` (gains, cross-covariances).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct M2 {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub d: f64,
}

impl M2 {
    pub fn mul(self, o: M2) -> M2 {
        M2 { a: self.a * o.a + self.b * o.c, b: self.a * o.b + self.b * o.d, c: self.c * o.a + self.d * o.c, d: self.c * o.b + self.d * o.d }
    }
    pub fn t(self) -> M2 {
        M2 { a: self.a, b: self.c, c: self.b, d: self.d }
    }
    pub fn add(self, o: M2) -> M2 {
        M2 { a: self.a + o.a, b: self.b + o.b, c: self.c + o.c, d: self.d + o.d }
    }
    pub fn sub(self, o: M2) -> M2 {
        M2 { a: self.a - o.a, b: self.b - o.b, c: self.c - o.c, d: self.d - o.d }
    }
    pub fn apply(self, v: [f64; 2]) -> [f64; 2] {
        [self.a * v[0] + self.b * v[1], self.c * v[0] + self.d * v[1]]
    }
    pub fn inv(self) -> M2 {
        let det = self.a * self.d - self.b * self.c;
        M2 { a: self.d / det, b: -self.b / det, c: -self.c / det, d: self.a / det }
    }
    /// `F(d) = [[1, d], [0, 1]]`.
    pub fn f(d: f64) -> M2 {
        M2 { a: 1.0, b: d, c: 0.0, d: 1.0 }
    }
}

impl Cov {
    pub fn m(self) -> M2 {
        M2 { a: self.pp, b: self.pv, c: self.pv, d: self.vv }
    }
    /// The symmetric part of `m`.
    pub fn of(m: M2) -> Cov {
        Cov { pp: m.a, pv: 0.5 * (m.b + m.c), vv: m.d }
    }
    /// `Q(d) = q [[d³/3, d²/2], [d²/2, d]]`.
    pub fn q(q: f64, d: f64) -> Cov {
        Cov { pp: q * d * d * d / 3.0, pv: q * d * d / 2.0, vv: q * d }
    }
}

/// Checks `memory_bytes` for `groups` filter states.
pub(crate) fn check_memory(groups: usize) -> Result<(), FuseError> {
    let bytes = groups as u128 * GROUP_BYTES as u128;
    limits::MEMORY_BYTES.check(bytes).map_err(|_| FuseError::Memory { bytes })
}

/// A `Vec` with room for `n` elements, or the memory error.
pub(crate) fn try_vec<T>(n: usize) -> Result<Vec<T>, FuseError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| FuseError::Memory { bytes: n as u128 * std::mem::size_of::<T>() as u128 })?;
    Ok(v)
}
