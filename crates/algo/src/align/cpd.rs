//! Rigid coherent point drift with time (TimeCPD): thesis section 2.1, eq. 2.7 (E-step) and
//! 2.2/2.5/2.6/2.8 (M-step), Alg. 5–8; Myronenko & Song (2010) when `tau` is infinite.
//!
//! Model: every fixed point `(x_n, t_n)` comes from a Gaussian around a transformed moving
//! point `T(y_m) = s·R·y_m + v` with variance σ², times a Gaussian in time around `s_m` with
//! variance τ², or from a uniform outlier component with weight `w`:
//!
//! ```text
//! P(m | n) = exp(−‖x_n − T y_m‖²/2σ² − (t_n − s_m)²/2τ²) / (Σ_j exp(…) + c),
//! c = (2πσ²)^{D/2} (2πτ²)^{1/2} · w/(1−w) · M/N      ((2πτ²)^{1/2} is dropped when τ = ∞)
//! ```
//!
//! Notes on the source: eq. 2.7 prints `‖x − Ry − v‖` and `|t − s|` without the squares of the
//! density it is derived from (the φ_m above eq. 2.7); we use the squares. The text also swaps
//! the names "E step" and "M step" once; the algorithm is the standard EM.
//!
//! # Sparse, time-windowed E-step
//! Both sets are sorted by time. A pair with `|t − s| > κτ`, `κ = sqrt(2 ln 10¹²) ≈ 7.43`, has
//! time weight below `10⁻¹²` of a simultaneous pair, so it is skipped: each fixed point only
//! visits the moving points in its time band (found once, by two pointers; times never change).
//! Per iteration this is O(N + M + K) time, K = number of pairs in the band, and O(N + M)
//! memory: the M-step needs only P-weighted sums (Np, Σ P x, Σ P y, Σ P x yᵀ, Σ P‖x‖², Σ P‖y‖²),
//! which are reduced over fixed points in parallel (rayon) without an N×M matrix.
//! With τ = ∞ every pair is visited (plain CPD, O(N·M) per iteration, still O(N + M) memory).
//!
//! # Robust start
//! A camera may be rotated by any angle, and CPD from R = I converges to the nearest local
//! optimum. [`align`] runs `starts` EM runs from rotations `θ₀ = 2πk/starts` (each with the
//! translation that matches the centroids), [`PROBE_ITERATIONS`] iterations each on an evenly
//! strided subsample of at most [`PROBE_POINTS`] points per set, keeps the start with the
//! highest data log-likelihood, and continues it on all points to convergence. `starts = 1`
//! is the thesis's R = I start (and reproduces pycpd exactly).
//!
//! # Scale
//! With `with_scale`, s is estimated as in pycpd's `RigidRegistration`:
//! `s = tr(AᵀR) / Σ P‖ŷ‖²` and `σ² = (Σ P‖x̂‖² − s·tr(AᵀR)) / (D·Np)`; the update order and the
//! convergence test (`|q − q_prev| > tol`, at most `max_iter` iterations) follow pycpd 2.0.0,
//! so results agree with it. Without scale, `σ² = (Σ P‖x̂‖² − 2 tr(AᵀR) + Σ P‖ŷ‖²) / (D·Np)`,
//! the exact rigid update (pycpd's formula is only right when s is optimal).
//!
//! # One EM for 2-D and 3-D
//! The EM above is written once, over points `[f64; D]` (`align_in`); a dimension supplies
//! only its transform and the rotation of the M-step through the trait `Space`: `Plane`
//! here (closed form `θ = atan2(A₁₀ − A₀₁, A₀₀ + A₁₁)`), and `Space3` in
//! [`crate::align::cpd3`] (SVD of the 3×3 `A`, thesis lemma 1). Both probe their starts on
//! at most [`PROBE_POINTS`] points per set.
//!
//! # Complexity
//! Per iteration O(N + M + K) time and O(N + M) memory (above); the starts add
//! `starts · PROBE_ITERATIONS` iterations on at most `PROBE_POINTS` points per set.

use super::rigid::{wrap_angle, Transform2};
use crate::traj::band::{Bound, TimeBand};
use rayon::prelude::*;
use std::fmt;

/// Iterations each start runs before the best start is chosen.
pub const PROBE_ITERATIONS: usize = 15;
/// Largest subsample (points per set) the start probes run on.
pub const PROBE_POINTS: usize = 4000;
/// Time-weight cutoff in units of τ: pairs further apart weigh less than 1e-12.
pub const TIME_CUTOFF_TAUS: f64 = 7.43;

#[derive(Clone, Debug, PartialEq)]
pub enum CpdError {
    W(f64),
    Tau(f64),
    Tol(f64),
    MaxIter(i64),
    Starts(i64),
    TooFew { which: &'static str, got: usize },
    NotFinite { which: &'static str, index: usize },
    /// A coordinate or time beyond [`MAX_MAGNITUDE`] (squares would overflow).
    Magnitude { which: &'static str, index: usize },
    /// No fixed point has a moving point within the time band (|t − s| ≤ 7.43 τ).
    NoTimeOverlap { tau: f64 },
    /// Every fixed point ended as an outlier: there is no fit to report.
    AllOutliers { w: f64 },
    /// More pair visits than the work limit `cpd_pair_visits`.
    Work(crate::limits::Exceeded),
}

/// Largest `max_iter` (each iteration is one E-step over the band; pycpd's default is 100).
pub const MAX_ITER: i64 = 100_000;
/// Largest |coordinate| and |t| accepted: squared distances stay far from overflow.
pub const MAX_MAGNITUDE: f64 = 1e150;
/// τ outside [1e-100, 1e100] makes 1/(2τ²) or τ² overflow.
pub const TAU_RANGE: (f64, f64) = (1e-100, 1e100);
/// σ² below this share of its first value is the noise-free floor: the fit is exact, and the
/// run stops as converged (without it σ² → 0 and the EM oscillates on rounding until max_iter).
pub const SIGMA2_FLOOR: f64 = 1e-16;

impl fmt::Display for CpdError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CpdError::W(v) => write!(f, "w must be in [0, 1), got {v}"),
            CpdError::Tau(v) => write!(f, "tau must be between 1e-100 and 1e100 seconds (or 'inf' for plain CPD), got {v}"),
            CpdError::Tol(v) => write!(f, "tol must be in [0, 1), got {v:?}"),
            CpdError::MaxIter(v) => write!(f, "max_iter must be between 1 and {MAX_ITER}, got {v}"),
            CpdError::Starts(v) => write!(f, "starts must be between 1 and 360, got {v}"),
            CpdError::TooFew { which, got } => write!(f, "{which} has too few points: got {got}, needs 2 (3 in 3-D)"),
            CpdError::NotFinite { which, index } => write!(f, "{which}[{}] has a NaN or infinite value", index + 1),
            CpdError::Magnitude { which, index } => {
                write!(f, "{which}[{}] has a coordinate or time beyond ±{MAX_MAGNITUDE:e} (shift or rescale the data)", index + 1)
            }
            CpdError::NoTimeOverlap { tau } => write!(
                f,
                "no point of fixed has a point of moving within 7.43*tau = {} s of its time: the sets do not overlap in time (check the clocks, or raise tau)",
                7.43 * tau
            ),
            CpdError::Work(e) => e.fmt(f),
            CpdError::AllOutliers { w } => write!(f, "every fixed point is an outlier at w = {w}: no fit (lower w, or check that the sets show the same scene)"),
        }
    }
}
impl std::error::Error for CpdError {}

/// Checked parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpdParams {
    pub w: f64,
    /// `None`: plain rigid CPD (no time term).
    pub tau: Option<f64>,
    pub max_iter: usize,
    pub tol: f64,
    pub with_scale: bool,
    pub starts: usize,
}

impl CpdParams {
    pub fn new(w: f64, tau: Option<f64>, max_iter: i64, tol: f64, with_scale: bool, starts: i64) -> Result<Self, CpdError> {
        if !(0.0..1.0).contains(&w) {
            return Err(CpdError::W(w));
        }
        let tau = match tau {
            None => None,
            Some(t) if t == f64::INFINITY => None,
            Some(t) if (TAU_RANGE.0..=TAU_RANGE.1).contains(&t) => Some(t),
            Some(t) => return Err(CpdError::Tau(t)),
        };
        // |Δq| below tol stops the EM; a tol of 1 or more would stop it after one step with
        // converged = true on whatever angle it had reached
        if !(0.0..1.0).contains(&tol) {
            return Err(CpdError::Tol(tol));
        }
        if !(1..=MAX_ITER).contains(&max_iter) {
            return Err(CpdError::MaxIter(max_iter));
        }
        if !(1..=360).contains(&starts) {
            return Err(CpdError::Starts(starts));
        }
        Ok(CpdParams { w, tau, max_iter: max_iter as usize, tol, with_scale, starts: starts as usize })
    }
}

/// The outcome of [`align`] (and, with `T = Transform3`, of [`crate::align::cpd3::align3`]).
/// `transform` maps moving into fixed.
#[derive(Clone, Debug, PartialEq)]
pub struct CpdResult<T = Transform2> {
    pub transform: T,
    pub sigma2: f64,
    pub iterations: usize,
    pub converged: bool,
    /// pycpd's objective `q` (negative expected complete log-likelihood, up to constants).
    pub q: f64,
    /// Data log-likelihood of the mixture at the final parameters (used to rank starts).
    pub log_likelihood: f64,
    /// Share of fixed points whose posterior of being an inlier exceeds 1/2.
    pub inlier_fraction: f64,
    /// sqrt(Σ P‖x − T y‖² / Σ P).
    pub rms: f64,
    /// The start rotation that won (about z in 3-D).
    pub start_theta: f64,
    /// Pairs visited per E-step (N·M for plain CPD).
    pub pairs_in_band: usize,
}

/// What the EM needs to know about the dimension `D` (2 or 3): the transform's form, the
/// rotation of the M-step, and the start rotations. Everything else — the time band, the
/// E-step, σ², the objective, the starts and their probes — is written once, over `[f64; D]`.
pub(crate) trait Space<const D: usize> {
    /// `p_fixed = s·R·p_moving + v` in the dimension's own form.
    type Transform: Copy;
    /// Rotation `theta` about the z axis (the plane's rotation in 2-D), scale 1, translation `v`.
    fn start(theta: f64, v: [f64; D]) -> Self::Transform;
    /// `(s·R, v)`: the matrix (row-major) and translation that map moving points.
    fn matrix(tf: &Self::Transform) -> ([[f64; D]; D], [f64; D]);
    /// The M-step (eq. 2.5/2.6, Umeyama): `R = argmax tr(AᵀR)` over rotations for
    /// `A = Σ P x̂ ŷᵀ`, then `s` (`tr(AᵀR)/Σ P‖ŷ‖²` with scale, else 1) and `v = μx − s R μy`.
    /// Returns the transform, `tr(AᵀR)` and `s`.
    fn m_step(a: &[[f64; D]; D], mux: &[f64; D], muy: &[f64; D], ypy: f64, with_scale: bool) -> (Self::Transform, f64, f64);
    /// The canonical form of a run's result (2-D: θ wrapped to (−π, π]).
    fn normalise(tf: Self::Transform) -> Self::Transform;
    /// The transform in the callers' frames from the one of the centred sets:
    /// `p_f − c_f = T'(p_m − c_m)  ⇒  v = v' + c_f − s R c_m`.
    fn uncentre(tf: Self::Transform, cf: &[f64; D], cm: &[f64; D]) -> Self::Transform;
}

/// 2-D: the transform is [`Transform2`] (θ, tx, ty, scale); the rotation of the M-step is the
/// closed form `θ = atan2(A₁₀ − A₀₁, A₀₀ + A₁₁)`, `tr(AᵀR) = hypot(A₀₀ + A₁₁, A₁₀ − A₀₁)`.
pub(crate) struct Plane;

impl Space<2> for Plane {
    type Transform = Transform2;
    fn start(theta: f64, v: [f64; 2]) -> Transform2 {
        Transform2 { theta, tx: v[0], ty: v[1], scale: 1.0 }
    }
    fn matrix(tf: &Transform2) -> ([[f64; 2]; 2], [f64; 2]) {
        (tf.matrix(), [tf.tx, tf.ty])
    }
    fn m_step(a: &[[f64; 2]; 2], mux: &[f64; 2], muy: &[f64; 2], ypy: f64, with_scale: bool) -> (Transform2, f64, f64) {
        let (dot, cross) = (a[0][0] + a[1][1], a[1][0] - a[0][1]);
        let theta = cross.atan2(dot);
        let tr_ar = dot.hypot(cross);
        let s = if with_scale && ypy > 0.0 { tr_ar / ypy } else { 1.0 };
        let mut next = Transform2 { theta, tx: 0.0, ty: 0.0, scale: s };
        let (rx, ry) = next.apply(muy[0], muy[1]);
        next.tx = mux[0] - rx;
        next.ty = mux[1] - ry;
        (next, tr_ar, s)
    }
    fn normalise(tf: Transform2) -> Transform2 {
        Transform2 { theta: wrap_angle(tf.theta), ..tf }
    }
    fn uncentre(t: Transform2, cf: &[f64; 2], cm: &[f64; 2]) -> Transform2 {
        let (rx, ry) = Transform2 { tx: 0.0, ty: 0.0, ..t }.apply(cm[0], cm[1]);
        Transform2 { tx: t.tx + cf[0] - rx, ty: t.ty + cf[1] - ry, ..t }
    }
}

/// A point set in struct-of-arrays form (one column per coordinate), sorted by `t`.
struct Set<const D: usize> {
    c: [Vec<f64>; D],
    t: Vec<f64>,
}

impl<const D: usize> Set<D> {
    fn len(&self) -> usize {
        self.t.len()
    }
    /// The points `0, k, 2k, …`.
    fn strided(&self, k: usize) -> Set<D> {
        Set { c: std::array::from_fn(|d| self.c[d].iter().step_by(k).copied().collect()), t: self.t.iter().step_by(k).copied().collect() }
    }
}

/// Checks one input set (at least D points, finite, within [`MAX_MAGNITUDE`]) and sorts it by t.
fn prepare<const D: usize>(which: &'static str, c: [&[f64]; D], t: &[f64]) -> Result<Set<D>, CpdError> {
    if t.len() < D {
        return Err(CpdError::TooFew { which, got: t.len() });
    }
    for k in 0..t.len() {
        if !(c.iter().all(|col| col[k].is_finite()) && t[k].is_finite()) {
            return Err(CpdError::NotFinite { which, index: k });
        }
        if c.iter().fold(t[k].abs(), |m, col| m.max(col[k].abs())) > MAX_MAGNITUDE {
            return Err(CpdError::Magnitude { which, index: k });
        }
    }
    let mut idx: Vec<usize> = (0..t.len()).collect();
    idx.sort_by(|&a, &b| t[a].total_cmp(&t[b]));
    Ok(Set { c: std::array::from_fn(|d| idx.iter().map(|&k| c[d][k]).collect()), t: idx.iter().map(|&k| t[k]).collect() })
}

/// `Σ_d a_d·b_d`, summed from the first term (so that 2-D sums are `a₀b₀ + a₁b₁` to the bit).
#[inline(always)]
fn dot<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    let mut s = a[0] * b[0];
    for d in 1..D {
        s += a[d] * b[d];
    }
    s
}

/// `M·p + v`, each row summed from its first term.
#[inline(always)]
fn apply<const D: usize>(m: &[[f64; D]; D], v: &[f64; D], p: &[f64; D]) -> [f64; D] {
    std::array::from_fn(|d| dot(&m[d], p) + v[d])
}

/// `e^(−x)` for `x ≥ 0` (NaN-free inputs), branch-free so that loops over it vectorise.
///
/// Range reduction `x = k·ln 2 − r`, `|r| ≤ ln 2 / 2`, with `k` rounded by the 1.5·2⁵² trick,
/// then a degree-12 Taylor polynomial of `e^r` (truncation error < 2⁻⁵³ relative) and the
/// scaling by `2^(−k)` built from the exponent bits. The result is within a few ulp of `exp`;
/// for `x > 708` it returns 0 (the true value is below 1e-307, which changes no posterior
/// that has `den ≥ f64::EPSILON`).
#[inline(always)]
#[allow(clippy::excessive_precision)] // the ln 2 split constants are the standard fdlibm values
pub(crate) fn exp_neg(x: f64) -> f64 {
    const INV_LN2: f64 = std::f64::consts::LOG2_E;
    const LN2_HI: f64 = 6.931_471_803_691_238_164_9e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
    const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52
    let xc = x.min(708.0);
    let big = xc * INV_LN2 + MAGIC; // k = round(x / ln 2) sits in the low mantissa bits
    let kf = big - MAGIC;
    let k = big.to_bits() & 0x7ff; // 0 <= k <= 1022
    let r = (kf * LN2_HI - xc) + kf * LN2_LO; // e^(−x) = 2^(−k) e^r
    // Horner, 1/n! coefficients
    let mut p = 1.0 / 479_001_600.0;
    p = p * r + 1.0 / 39_916_800.0;
    p = p * r + 1.0 / 3_628_800.0;
    p = p * r + 1.0 / 362_880.0;
    p = p * r + 1.0 / 40_320.0;
    p = p * r + 1.0 / 5_040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    let scale = f64::from_bits(1023u64.wrapping_sub(k) << 52);
    let v = p * scale;
    if x > 708.0 {
        0.0
    } else {
        v
    }
}

/// A fixed point `(x, t)` against a band of (transformed) moving points: coordinate columns
/// and times, all of one length.
type Band<'b, const D: usize> = ([&'b [f64]; D], &'b [f64]);

/// Unnormalised posteriors of one fixed point against its band: `buf[k] = exp(−arg_k)` with
/// `arg_k = ‖x − y_k‖²·inv.0 + (t − s_k)²·inv.1`; returns their sum. Exponent, then exp, in
/// branch-free passes the compiler vectorises (every column cut to one length first, so that
/// the indexing needs no bounds checks).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // indexing by d, not zip: this form vectorises (zip cost 25 %)
fn row_weights_generic<const D: usize>(p: (&[f64; D], f64), band: Band<'_, D>, inv: (f64, f64), buf: &mut [f64]) -> f64 {
    let n = band.0.iter().fold(buf.len().min(band.1.len()), |n, col| n.min(col.len()));
    let (bc, bt): ([&[f64]; D], &[f64]) = (std::array::from_fn(|d| &band.0[d][..n]), &band.1[..n]);
    let w = &mut buf[..n];
    for k in 0..n {
        let d0 = p.0[0] - bc[0][k];
        let mut s = d0 * d0;
        for d in 1..D {
            let dd = p.0[d] - bc[d][k];
            s += dd * dd;
        }
        let dt = p.1 - bt[k];
        w[k] = s * inv.0 + dt * dt * inv.1;
    }
    for v in buf.iter_mut() {
        *v = exp_neg(*v);
    }
    sum(buf)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn row_weights_avx2<const D: usize>(p: (&[f64; D], f64), band: Band<'_, D>, inv: (f64, f64), buf: &mut [f64]) -> f64 {
    row_weights_generic(p, band, inv, buf)
}

/// Dispatches to an AVX2/FMA build of the same code when the CPU has it (checked once).
#[inline]
fn row_weights<const D: usize>(p: (&[f64; D], f64), band: Band<'_, D>, inv: (f64, f64), buf: &mut [f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        if has_avx2() {
            // SAFETY: the CPU supports AVX2 and FMA (checked in `has_avx2`).
            return unsafe { row_weights_avx2(p, band, inv, buf) };
        }
    }
    row_weights_generic(p, band, inv, buf)
}

/// The running sums of [`row_moments_generic`], four lanes each.
struct Lanes<const D: usize> {
    p: [f64; 4],
    y: [[f64; 4]; D],
    yy: [f64; 4],
    r: [f64; 4],
}

impl<const D: usize> Lanes<D> {
    /// Adds moving point `k` to lane `l`.
    #[inline(always)]
    fn add(&mut self, l: usize, k: usize, p: f64, x: &[f64; D], y: &[&[f64]; D], ty: &[&[f64]; D]) {
        let (m0, d0) = (y[0][k], x[0] - ty[0][k]);
        let (mut mm, mut dd) = (m0 * m0, d0 * d0);
        self.y[0][l] += p * m0;
        for d in 1..D {
            let (m, e) = (y[d][k], x[d] - ty[d][k]);
            mm += m * m;
            dd += e * e;
            self.y[d][l] += p * m;
        }
        self.p[l] += p;
        self.yy[l] += p * mm;
        self.r[l] += p * dd;
    }
}

/// P-weighted moments of one fixed point `x` over its band, with `p_k = buf[k] · inv`:
/// `(Σ p, Σ p·y, Σ p‖y‖², Σ p‖x − T y‖²)` for moving points `y` (columns) and their
/// transforms `ty`. Four-lane accumulators, no branches.
#[inline(always)]
fn row_moments_generic<const D: usize>(x: &[f64; D], inv: f64, buf: &[f64], y: &[&[f64]; D], ty: &[&[f64]; D]) -> (f64, [f64; D], f64, f64) {
    let n = y.iter().chain(ty.iter()).fold(buf.len(), |n, col| n.min(col.len()));
    // every column cut to n, so that the indexing below needs no bounds checks
    let (buf, y, ty): (&[f64], [&[f64]; D], [&[f64]; D]) = (&buf[..n], std::array::from_fn(|d| &y[d][..n]), std::array::from_fn(|d| &ty[d][..n]));
    let mut acc = Lanes { p: [0.0; 4], y: [[0.0; 4]; D], yy: [0.0; 4], r: [0.0; 4] };
    let mut k = 0;
    while k + 4 <= n {
        for l in 0..4 {
            acc.add(l, k + l, buf[k + l] * inv, x, &y, &ty);
        }
        k += 4;
    }
    while k < n {
        acc.add(0, k, buf[k] * inv, x, &y, &ty);
        k += 1;
    }
    let r = |a: [f64; 4]| (a[0] + a[1]) + (a[2] + a[3]);
    (r(acc.p), std::array::from_fn(|d| r(acc.y[d])), r(acc.yy), r(acc.r))
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn row_moments_avx2<const D: usize>(x: &[f64; D], inv: f64, buf: &[f64], y: &[&[f64]; D], ty: &[&[f64]; D]) -> (f64, [f64; D], f64, f64) {
    row_moments_generic(x, inv, buf, y, ty)
}

#[inline]
fn row_moments<const D: usize>(x: &[f64; D], inv: f64, buf: &[f64], y: &[&[f64]; D], ty: &[&[f64]; D]) -> (f64, [f64; D], f64, f64) {
    #[cfg(target_arch = "x86_64")]
    {
        if has_avx2() {
            // SAFETY: the CPU supports AVX2 and FMA (checked in `has_avx2`).
            return unsafe { row_moments_avx2(x, inv, buf, y, ty) };
        }
    }
    row_moments_generic(x, inv, buf, y, ty)
}

#[cfg(target_arch = "x86_64")]
fn has_avx2() -> bool {
    use std::sync::OnceLock;
    static AVX2: OnceLock<bool> = OnceLock::new();
    *AVX2.get_or_init(|| is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"))
}

/// Sum with four independent accumulators (breaks the add latency chain).
#[inline]
fn sum(v: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let chunks = v.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..4 {
            acc[k] += c[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + rest.iter().sum::<f64>()
}

/// P-weighted sums of one E-step.
#[derive(Clone, Copy, Debug)]
struct Stats<const D: usize> {
    np: f64,
    sx: [f64; D],
    sy: [f64; D],
    /// Σ P x yᵀ, row-major (x index, y index).
    sxy: [[f64; D]; D],
    sxx: f64,
    syy: f64,
    /// Σ_n log(den_n)
    log_den: f64,
    /// Σ P‖x − T y‖²
    resid: f64,
    inliers: usize,
}

impl<const D: usize> Stats<D> {
    fn zero() -> Self {
        Stats { np: 0.0, sx: [0.0; D], sy: [0.0; D], sxy: [[0.0; D]; D], sxx: 0.0, syy: 0.0, log_den: 0.0, resid: 0.0, inliers: 0 }
    }

    fn add(mut self, o: Self) -> Self {
        self.np += o.np;
        for d in 0..D {
            self.sx[d] += o.sx[d];
            self.sy[d] += o.sy[d];
            for e in 0..D {
                self.sxy[d][e] += o.sxy[d][e];
            }
        }
        self.sxx += o.sxx;
        self.syy += o.syy;
        self.log_den += o.log_den;
        self.resid += o.resid;
        self.inliers += o.inliers;
        self
    }

    /// Adds one fixed point `x`'s P-weighted sums: `pt1 = Σ_m P`, `sy = Σ_m P y_m`,
    /// `syy = Σ_m P‖y_m‖²`.
    #[inline]
    fn accumulate(&mut self, x: &[f64; D], pt1: f64, sy: &[f64; D], syy: f64) {
        self.np += pt1;
        for d in 0..D {
            self.sx[d] += pt1 * x[d];
            self.sy[d] += sy[d];
            for (v, se) in self.sxy[d].iter_mut().zip(sy) {
                *v += x[d] * se;
            }
        }
        self.sxx += pt1 * dot(x, x);
        self.syy += syy;
        self.inliers += (pt1 > 0.5) as usize;
    }
}

struct Problem<'a, const D: usize> {
    fx: &'a Set<D>,
    mv: &'a Set<D>,
    /// moving-index band `[lo, hi)` of every fixed point
    band: Vec<(u32, u32)>,
    inv_2tau2: f64,
    log_tau_norm: f64,
}

impl<const D: usize> Problem<'_, D> {
    /// One E-step (eq. 2.7) reduced to the M-step's sums.
    fn e_step<S: Space<D>>(&self, tf: &S::Transform, sigma2: f64, w: f64) -> Stats<D> {
        let (n, m) = (self.fx.len() as f64, self.mv.len() as f64);
        let d = D as f64;
        let c = (2.0 * std::f64::consts::PI * sigma2).powf(d / 2.0) * self.log_tau_norm.exp() * w / (1.0 - w) * m / n;
        let inv_2s2 = 1.0 / (2.0 * sigma2);
        let (mat, v) = S::matrix(tf);
        // Transformed moving points, once per iteration (struct of arrays, for vectorisation).
        let mut ty: [Vec<f64>; D] = std::array::from_fn(|_| Vec::with_capacity(self.mv.len()));
        for k in 0..self.mv.len() {
            let q = apply(&mat, &v, &std::array::from_fn(|d| self.mv.c[d][k]));
            for d in 0..D {
                ty[d].push(q[d]);
            }
        }
        if self.inv_2tau2 == 0.0 {
            if let Some(st) = self.e_step_grid(&ty, inv_2s2, c) {
                return st;
            }
        }
        const CHUNK: usize = 512;
        (0..self.fx.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .fold(
                || (Stats::zero(), Vec::<f64>::new()),
                |(mut st, mut buf), i| {
                    let xi: [f64; D] = std::array::from_fn(|d| self.fx.c[d][i]);
                    let (lo, hi) = (self.band[i].0 as usize, self.band[i].1 as usize);
                    buf.clear();
                    buf.resize(hi - lo, 0.0);
                    let tyb: [&[f64]; D] = std::array::from_fn(|d| &ty[d][lo..hi]);
                    let den = row_weights((&xi, self.fx.t[i]), (tyb, &self.mv.t[lo..hi]), (inv_2s2, self.inv_2tau2), &mut buf);
                    // pycpd clips the column sum at machine epsilon before adding c.
                    let den = den.max(f64::EPSILON) + c;
                    st.log_den += den.ln();
                    let inv = 1.0 / den;
                    let yb: [&[f64]; D] = std::array::from_fn(|d| &self.mv.c[d][lo..hi]);
                    let (pt1, sy, syy, resid) = row_moments(&xi, inv, &buf, &yb, &tyb);
                    st.resid += resid;
                    st.accumulate(&xi, pt1, &sy, syy);
                    (st, buf)
                },
            )
            .map(|(s, _)| s)
            .reduce(Stats::zero, Stats::add)
    }

    /// Plain CPD (no time term) once σ is small: pairs farther apart than
    /// `r = sqrt(2σ² · EXP_ZERO)` have `exp(−d²/2σ²) = 0` exactly in [`exp_neg`], so only the
    /// transformed moving points in the 3×3 grid cells (side ≥ r, over the first two
    /// coordinates: a pair farther than r apart there is farther in D dimensions) around each
    /// fixed point are visited. The posteriors are the same; only the order of the sums
    /// differs. Returns `None` when the grid would not save work (r large against the extent).
    fn e_step_grid(&self, ty: &[Vec<f64>; D], inv_2s2: f64, c: f64) -> Option<Stats<D>> {
        const EXP_ZERO: f64 = 708.0;
        let r = (EXP_ZERO / inv_2s2).sqrt();
        let (tyx, tyy) = (&ty[0], &ty[1]);
        let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..tyx.len() {
            x0 = x0.min(tyx[k]);
            x1 = x1.max(tyx[k]);
            y0 = y0.min(tyy[k]);
            y1 = y1.max(tyy[k]);
        }
        let (nx, ny) = (((x1 - x0) / r).floor() as usize + 1, ((y1 - y0) / r).floor() as usize + 1);
        if !(r > 0.0) || nx * ny < 16 || nx * ny > 4 * tyx.len() + 16 {
            return None;
        }
        let cell = |x: f64, y: f64| (((x - x0) / r) as usize).min(nx - 1) + nx * (((y - y0) / r) as usize).min(ny - 1);
        // Counting sort of the moving points by cell; cell-ordered copies keep each cell contiguous.
        let mut start = vec![0usize; nx * ny + 1];
        for k in 0..tyx.len() {
            start[cell(tyx[k], tyy[k]) + 1] += 1;
        }
        for k in 0..nx * ny {
            start[k + 1] += start[k];
        }
        let mut fill = start.clone();
        let mut order = vec![0usize; tyx.len()];
        for k in 0..tyx.len() {
            let cidx = cell(tyx[k], tyy[k]);
            order[fill[cidx]] = k;
            fill[cidx] += 1;
        }
        let g = |v: &[f64]| order.iter().map(|&k| v[k]).collect::<Vec<f64>>();
        let (gt, gm): ([Vec<f64>; D], [Vec<f64>; D]) = (std::array::from_fn(|d| g(&ty[d])), std::array::from_fn(|d| g(&self.mv.c[d])));
        let zeros = vec![0.0; tyx.len()];
        let st = (0..self.fx.len())
            .into_par_iter()
            .with_min_len(512)
            .fold(
                || (Stats::zero(), Vec::<f64>::new(), Vec::<(usize, usize)>::new()),
                |(mut st, mut buf, mut runs), i| {
                    let xi: [f64; D] = std::array::from_fn(|d| self.fx.c[d][i]);
                    let cx = ((xi[0] - x0) / r).floor();
                    let cy = ((xi[1] - y0) / r).floor();
                    runs.clear();
                    for dy in -1..=1 {
                        let yy = cy + dy as f64;
                        if yy < 0.0 || yy >= ny as f64 {
                            continue;
                        }
                        let (xa, xb) = ((cx - 1.0).max(0.0), (cx + 1.0).min(nx as f64 - 1.0));
                        if xa > xb {
                            continue;
                        }
                        let row = yy as usize * nx;
                        // the cells of one grid row are contiguous in the cell order
                        let (a, b) = (start[row + xa as usize], start[row + xb as usize + 1]);
                        if a < b {
                            runs.push((a, b));
                        }
                    }
                    let total: usize = runs.iter().map(|&(a, b)| b - a).sum();
                    buf.clear();
                    buf.resize(total, 0.0);
                    let mut den = 0.0;
                    let mut off = 0;
                    for &(a, b) in &runs {
                        let band: [&[f64]; D] = std::array::from_fn(|d| &gt[d][a..b]);
                        den += row_weights((&xi, 0.0), (band, &zeros[a..b]), (inv_2s2, 0.0), &mut buf[off..off + b - a]);
                        off += b - a;
                    }
                    let den = den.max(f64::EPSILON) + c;
                    st.log_den += den.ln();
                    let inv = 1.0 / den;
                    let (mut pt1, mut sy, mut syy) = (0.0, [0.0; D], 0.0);
                    let mut off = 0;
                    for &(a, b) in &runs {
                        let (yb, tyb): ([&[f64]; D], [&[f64]; D]) = (std::array::from_fn(|d| &gm[d][a..b]), std::array::from_fn(|d| &gt[d][a..b]));
                        let mm = row_moments(&xi, inv, &buf[off..off + b - a], &yb, &tyb);
                        pt1 += mm.0;
                        for (v, add) in sy.iter_mut().zip(mm.1) {
                            *v += add;
                        }
                        syy += mm.2;
                        st.resid += mm.3;
                        off += b - a;
                    }
                    st.accumulate(&xi, pt1, &sy, syy);
                    (st, buf, runs)
                },
            )
            .map(|(s, _, _)| s)
            .reduce(Stats::zero, Stats::add);
        Some(st)
    }
}

/// One EM run from `init` (at most `max_iter` iterations, from σ² = `sigma2_init`), reported
/// with `start_theta` as its start.
fn run<S: Space<D>, const D: usize>(pb: &Problem<'_, D>, init: S::Transform, start_theta: f64, p: &CpdParams, max_iter: usize, sigma2_init: f64) -> CpdResult<S::Transform> {
    let mut tf = init;
    let mut sigma2 = sigma2_init;
    let (mut q, mut diff) = (f64::INFINITY, f64::INFINITY);
    let mut it = 0;
    let mut last = Stats::zero();
    let d = D as f64;
    while it < max_iter && diff > p.tol {
        let st = pb.e_step::<S>(&tf, sigma2, p.w);
        last = st;
        if !(st.np > 0.0) {
            break; // every point is an outlier: keep the current estimate
        }
        let mux: [f64; D] = std::array::from_fn(|k| st.sx[k] / st.np);
        let muy: [f64; D] = std::array::from_fn(|k| st.sy[k] / st.np);
        // A = Σ P x̂ ŷᵀ
        let a: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|c| st.sxy[r][c] - st.np * mux[r] * muy[c]));
        let ypy = st.syy - st.np * dot(&muy, &muy);
        let xpx = st.sxx - st.np * dot(&mux, &mux);
        let (next, tr_ar, s) = S::m_step(&a, &mux, &muy, ypy, p.with_scale);
        tf = next;
        let qprev = q;
        q = (xpx - 2.0 * s * tr_ar + s * s * ypy) / (2.0 * sigma2) + d * st.np / 2.0 * sigma2.ln();
        diff = (q - qprev).abs();
        sigma2 = if p.with_scale { (xpx - s * tr_ar) / (st.np * d) } else { (xpx - 2.0 * tr_ar + ypy) / (st.np * d) };
        it += 1;
        let floor = (sigma2_init * SIGMA2_FLOOR).max(f64::MIN_POSITIVE);
        if !(sigma2 > floor) {
            // noise-free: the fit is exact to rounding
            sigma2 = floor;
            diff = 0.0;
        }
    }
    let (n, m) = (pb.fx.len() as f64, pb.mv.len() as f64);
    let ll = last.log_den - n * (d / 2.0 * (2.0 * std::f64::consts::PI * sigma2).ln() + pb.log_tau_norm)
        + n * ((1.0 - p.w) / m).ln();
    CpdResult {
        transform: S::normalise(tf),
        sigma2,
        iterations: it,
        converged: diff <= p.tol,
        q,
        log_likelihood: ll,
        inlier_fraction: last.inliers as f64 / n,
        rms: if last.np > 0.0 { (last.resid / last.np).sqrt() } else { f64::NAN },
        start_theta,
        pairs_in_band: pb.band.iter().map(|&(a, b)| (b - a) as usize).sum(),
    }
}

/// Builds the time bands of a problem (sets sorted by time): the closed band `|t − s| ≤ κτ`
/// of [`crate::traj::band`], every pair when τ = ∞. See the module docs.
fn make_problem<'a, const D: usize>(fxc: &'a Set<D>, mvc: &'a Set<D>, tau: Option<f64>) -> Problem<'a, D> {
    let (inv_2tau2, log_tau_norm, cutoff) = match tau {
        None => (0.0, 0.0, f64::INFINITY),
        Some(t) => (1.0 / (2.0 * t * t), 0.5 * (2.0 * std::f64::consts::PI * t * t).ln(), TIME_CUTOFF_TAUS * t),
    };
    let band = TimeBand::new(&fxc.t, &mvc.t, cutoff, Bound::Closed).map(|(lo, hi)| (lo as u32, hi as u32)).collect();
    Problem { fx: fxc, mv: mvc, band, inv_2tau2, log_tau_norm }
}

/// Initial σ² of pycpd: Σ_nm ‖x_n − T y_m‖² / (D N M), in O(N + M) by moments.
fn sigma2_init<S: Space<D>, const D: usize>(fx: &Set<D>, mv: &Set<D>, tf: &S::Transform) -> f64 {
    let (n, m) = (fx.len() as f64, mv.len() as f64);
    let (mut sx, mut sy, mut sxx, mut syy) = ([0.0; D], [0.0; D], 0.0, 0.0);
    for k in 0..fx.len() {
        let x: [f64; D] = std::array::from_fn(|d| fx.c[d][k]);
        for d in 0..D {
            sx[d] += x[d];
        }
        sxx += dot(&x, &x);
    }
    let (mat, v) = S::matrix(tf);
    for k in 0..mv.len() {
        let y = apply(&mat, &v, &std::array::from_fn(|d| mv.c[d][k]));
        for d in 0..D {
            sy[d] += y[d];
        }
        syy += dot(&y, &y);
    }
    let s = m * sxx + n * syy - 2.0 * dot(&sx, &sy);
    (s / (D as f64 * n * m)).max(f64::MIN_POSITIVE)
}

/// Aligns `moving` onto `fixed` in `D` dimensions (coordinate columns and times of each set):
/// the EM of the module docs for 2-D ([`align`]) and 3-D ([`crate::align::cpd3::align3`]).
pub(crate) fn align_in<S: Space<D>, const D: usize>(
    fixed: ([&[f64]; D], &[f64]),
    moving: ([&[f64]; D], &[f64]),
    p: &CpdParams,
) -> Result<CpdResult<S::Transform>, CpdError> {
    let fx = prepare("fixed", fixed.0, fixed.1)?;
    let mv = prepare("moving", moving.0, moving.1)?;
    // Centre both sets (exact: the translation absorbs it) so the raw-moment sums of the
    // M-step do not lose digits to large coordinates.
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (cf, cm): ([f64; D], [f64; D]) = (std::array::from_fn(|d| mean(&fx.c[d])), std::array::from_fn(|d| mean(&mv.c[d])));
    let centred = |s: Set<D>, c: &[f64; D]| Set { c: std::array::from_fn(|d| s.c[d].iter().map(|v| v - c[d]).collect()), t: s.t };
    let (fxc, mvc) = (centred(fx, &cf), centred(mv, &cm));
    let pb = make_problem(&fxc, &mvc, p.tau);
    if pb.band.iter().all(|&(a, b)| a == b) {
        return Err(CpdError::NoTimeOverlap { tau: p.tau.unwrap_or(f64::INFINITY) });
    }
    let pairs: u128 = pb.band.iter().map(|&(a, b)| (b - a) as u128).sum();
    crate::limits::CPD_PAIR_VISITS.check(pairs * p.max_iter as u128).map_err(CpdError::Work)?;
    // Start k: rotation 2πk/starts about the centroids (about z in 3-D; the centred sets share
    // their origin). With one start we reproduce pycpd exactly: R = I and t = 0 in the
    // caller's frames, i.e. t' = c_m − c_f in the centred frames.
    let theta = |k: usize| if p.starts == 1 { 0.0 } else { 2.0 * std::f64::consts::PI * k as f64 / p.starts as f64 };
    let start = |k: usize| {
        if p.starts == 1 {
            S::start(0.0, std::array::from_fn(|d| cm[d] - cf[d]))
        } else {
            S::start(theta(k), [0.0; D])
        }
    };
    let best = if p.starts == 1 {
        let s0 = start(0);
        run::<S, D>(&pb, s0, 0.0, p, p.max_iter, sigma2_init::<S, D>(&fxc, &mvc, &s0))
    } else {
        // Probe every start on an evenly strided subsample of at most PROBE_POINTS points
        // per set (the probes only rank the starts), then continue the winner on all points.
        // (Until issue 27 the 3-D code probed on all points; it follows this rule now.)
        let probe = PROBE_ITERATIONS.min(p.max_iter);
        let stride = |n: usize| n.div_ceil(PROBE_POINTS).max(1);
        let (fs, ms) = (fxc.strided(stride(fxc.len())), mvc.strided(stride(mvc.len())));
        let pbs = make_problem(&fs, &ms, p.tau);
        let mut best: Option<CpdResult<S::Transform>> = None;
        for k in 0..p.starts {
            let s0 = start(k);
            let r = run::<S, D>(&pbs, s0, theta(k), p, probe, sigma2_init::<S, D>(&fs, &ms, &s0));
            if best.as_ref().is_none_or(|b| r.log_likelihood > b.log_likelihood) {
                best = Some(r);
            }
        }
        let Some(b) = best else { unreachable!("starts >= 1 (CpdParams)") };
        let mut r = run::<S, D>(&pb, b.transform, b.start_theta, p, p.max_iter.saturating_sub(b.iterations).max(1), b.sigma2);
        r.iterations += b.iterations;
        r
    };
    if !(best.rms.is_finite()) {
        return Err(CpdError::AllOutliers { w: p.w });
    }
    Ok(CpdResult { transform: S::uncentre(best.transform, &cf, &cm), ..best })
}

/// Aligns `moving` onto `fixed` (each given as x, y, t columns of equal length).
pub fn align(
    fixed: (&[f64], &[f64], &[f64]),
    moving: (&[f64], &[f64], &[f64]),
    p: &CpdParams,
) -> Result<CpdResult, CpdError> {
    align_in::<Plane, 2>(([fixed.0, fixed.1], fixed.2), ([moving.0, moving.1], moving.2), p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic scene: a few tracks crossing, sampled at 10 Hz.
    fn scene(n_tracks: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let (mut x, mut y, mut t) = (vec![], vec![], vec![]);
        for k in 0..n_tracks {
            let a = k as f64 * 0.9;
            for s in 0..60 {
                let tt = k as f64 * 2.0 + s as f64 * 0.1;
                x.push(a.cos() * (s as f64 * 0.8 - 24.0) + (k % 3) as f64 * 3.0);
                y.push(a.sin() * (s as f64 * 0.8 - 24.0) - (k % 2) as f64 * 2.0);
                t.push(tt);
            }
        }
        (x, y, t)
    }

    fn moved(tf: &Transform2, s: &(Vec<f64>, Vec<f64>, Vec<f64>)) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let inv = tf.invert();
        let (x, y): (Vec<f64>, Vec<f64>) = s.0.iter().zip(&s.1).map(|(&a, &b)| inv.apply(a, b)).unzip();
        (x, y, s.2.clone())
    }

    #[test]
    fn recovers_large_rotation_with_starts_and_time() {
        let fixed = scene(12);
        let truth = Transform2::new(2.4, 15.0, -7.0, 1.0);
        let mv = moved(&truth, &fixed);
        let p = CpdParams::new(0.1, Some(0.5), 200, 1e-8, false, 8).unwrap();
        let r = align((&fixed.0, &fixed.1, &fixed.2), (&mv.0, &mv.1, &mv.2), &p).unwrap();
        assert!(wrap_angle(r.transform.theta - truth.theta).abs() < 1e-4, "{r:?}");
        assert!((r.transform.tx - truth.tx).abs() < 1e-3 && (r.transform.ty - truth.ty).abs() < 1e-3, "{r:?}");
        assert!(r.pairs_in_band < fixed.0.len() * mv.0.len() / 2, "the time band is sparse");
        // R = I alone does not find a 2.4 rad rotation without time.
        let p1 = CpdParams::new(0.1, None, 200, 1e-8, false, 1).unwrap();
        let r1 = align((&fixed.0, &fixed.1, &fixed.2), (&mv.0, &mv.1, &mv.2), &p1).unwrap();
        assert!(wrap_angle(r1.transform.theta - truth.theta).abs() > 0.1, "{r1:?}");
    }

    #[test]
    fn scale_is_estimated() {
        let fixed = scene(6);
        let truth = Transform2::new(0.3, 1.0, 2.0, 1.5);
        let mv = moved(&truth, &fixed);
        let p = CpdParams::new(0.0, None, 300, 1e-10, true, 1).unwrap();
        let r = align((&fixed.0, &fixed.1, &fixed.2), (&mv.0, &mv.1, &mv.2), &p).unwrap();
        assert!((r.transform.scale - 1.5).abs() < 1e-4 && wrap_angle(r.transform.theta - 0.3).abs() < 1e-4, "{r:?}");
    }

    #[test]
    fn grid_e_step_equals_the_dense_one() {
        let f = scene(10);
        let fx = prepare("fixed", [&f.0, &f.1], &f.2).unwrap();
        let mv = prepare("moving", [&f.1, &f.0], &f.2).unwrap();
        let pb = make_problem(&fx, &mv, None);
        let tf = Transform2::new(0.3, 1.0, -2.0, 1.0);
        let mat = tf.matrix();
        let ty: [Vec<f64>; 2] = [
            (0..mv.len()).map(|k| mat[0][0] * mv.c[0][k] + mat[0][1] * mv.c[1][k] + tf.tx).collect(),
            (0..mv.len()).map(|k| mat[1][0] * mv.c[0][k] + mat[1][1] * mv.c[1][k] + tf.ty).collect(),
        ];
        let (fxx, fxy, tyx, tyy) = (&fx.c[0], &fx.c[1], &ty[0], &ty[1]);
        for sigma2 in [0.01, 0.1] {
            let inv = 1.0 / (2.0 * sigma2);
            let g = pb.e_step_grid(&ty, inv, 1e-3).expect("grid applies at small sigma");
            // dense reference: every pair, with std's exp
            let dense = {
                let mut st = Stats::<2>::zero();
                for i in 0..fx.len() {
                    let w: Vec<f64> = (0..mv.len()).map(|j| (-(((fxx[i] - tyx[j]).powi(2) + (fxy[i] - tyy[j]).powi(2)) * inv)).exp()).collect();
                    let den = w.iter().sum::<f64>().max(f64::EPSILON) + 1e-3;
                    let pt1: f64 = w.iter().sum::<f64>() / den;
                    st.np += pt1;
                    st.sxx += pt1 * (fxx[i] * fxx[i] + fxy[i] * fxy[i]);
                    st.log_den += den.ln();
                }
                st
            };
            assert!((g.np - dense.np).abs() <= 1e-9 * dense.np.max(1.0), "{} {}", g.np, dense.np);
            assert!((g.sxx - dense.sxx).abs() <= 1e-9 * dense.sxx.max(1.0));
            assert!((g.log_den - dense.log_den).abs() <= 1e-9 * dense.log_den.abs().max(1.0));
        }
    }

    #[test]
    fn fast_exp_matches_std() {
        let mut worst = 0.0f64;
        let mut x = 0.0;
        while x < 708.0 {
            let (a, b) = (exp_neg(x), (-x).exp());
            worst = worst.max(((a - b) / b).abs());
            x += 0.0137;
        }
        assert!(worst < 4.0 * f64::EPSILON, "relative error {worst}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert_eq!(exp_neg(800.0), 0.0);
    }

    #[test]
    fn bad_inputs_are_errors_not_panics() {
        assert_eq!(CpdParams::new(1.0, None, 10, 1e-5, false, 1).unwrap_err().to_string(), "w must be in [0, 1), got 1");
        assert!(CpdParams::new(-0.1, None, 10, 1e-5, false, 1).is_err());
        assert!(CpdParams::new(0.1, Some(0.0), 10, 1e-5, false, 1).is_err());
        assert!(CpdParams::new(0.1, Some(f64::NAN), 10, 1e-5, false, 1).is_err());
        assert_eq!(CpdParams::new(0.1, Some(f64::INFINITY), 10, 1e-5, false, 1).unwrap().tau, None);
        let p = CpdParams::new(0.1, None, 10, 1e-5, false, 4).unwrap();
        let one = [1.0];
        assert!(matches!(align((&one, &one, &one), (&one, &one, &one), &p), Err(CpdError::TooFew { .. })));
        let nan = [1.0, f64::NAN];
        let two = [1.0, 2.0];
        assert!(matches!(align((&two, &nan, &two), (&two, &two, &two), &p), Err(CpdError::NotFinite { .. })));
        // identical points: no panic, a finite answer
        let same = [3.0, 3.0, 3.0];
        let r = align((&same, &same, &same), (&same, &same, &same), &p).unwrap();
        assert!(r.transform.tx.is_finite() && r.sigma2 > 0.0);
        // one iteration cannot converge: converged = false with the estimate
        let p1 = CpdParams::new(0.1, None, 1, 0.0, false, 1).unwrap();
        let s = scene(3);
        let r = align((&s.0, &s.1, &s.2), (&s.0, &s.1, &s.2), &p1).unwrap();
        assert!(!r.converged && r.iterations == 1);
    }

    /// Issue 17: the calls that never stopped or came back silently wrong.
    #[test]
    fn bounded_iterations_floor_overlap_and_magnitudes() {
        // max_iter has a ceiling; tau a range where tau² and 1/tau² stay finite
        assert_eq!(CpdParams::new(0.1, None, 9_000_000_000_000_000_000, 1e-5, false, 1).unwrap_err(), CpdError::MaxIter(9_000_000_000_000_000_000));
        assert!(CpdParams::new(0.1, None, MAX_ITER, 1e-5, false, 1).is_ok());
        for tau in [1e160, 1e-300] {
            assert_eq!(CpdParams::new(0.1, Some(tau), 10, 1e-5, false, 1).unwrap_err(), CpdError::Tau(tau));
        }
        // noise-free points with tol = 0 and the largest max_iter: sigma² reaches its floor,
        // which counts as converged, long before max_iter
        let s = scene(3);
        let (c, sn) = (0.3f64.cos(), 0.3f64.sin());
        let mx: Vec<f64> = s.0.iter().zip(&s.1).map(|(x, y)| c * x - sn * y + 5.0).collect();
        let my: Vec<f64> = s.0.iter().zip(&s.1).map(|(x, y)| sn * x + c * y - 2.0).collect();
        let p = CpdParams::new(0.0, Some(0.5), MAX_ITER, 0.0, false, 1).unwrap();
        let r = align((&mx, &my, &s.2), (&s.0, &s.1, &s.2), &p).unwrap();
        assert!(r.converged && r.iterations < 1000, "{} iterations", r.iterations);
        assert!((r.transform.theta - 0.3).abs() < 1e-9 && (r.transform.tx - 5.0).abs() < 1e-7 && r.rms < 1e-6, "{r:?}");
        // no time overlap: an error, not theta = 0 with rms NaN
        let late: Vec<f64> = s.2.iter().map(|t| t + 1000.0).collect();
        let p = CpdParams::new(0.1, Some(0.5), 100, 1e-5, false, 1).unwrap();
        let e = align((&s.0, &s.1, &late), (&s.0, &s.1, &s.2), &p).unwrap_err();
        assert_eq!(e, CpdError::NoTimeOverlap { tau: 0.5 });
        assert!(e.to_string().contains("do not overlap in time"));
        // 1e200 coordinates: an error naming the bound, not NaN
        let big: Vec<f64> = s.0.iter().map(|x| x * 1e200).collect();
        assert!(matches!(align((&big, &s.1, &s.2), (&s.0, &s.1, &s.2), &p), Err(CpdError::Magnitude { which: "fixed", index: 0 }) | Err(CpdError::Magnitude { which: "fixed", .. })));
        // 1e100 coordinates still fit
        let (bx, by): (Vec<f64>, Vec<f64>) = (s.0.iter().map(|x| x * 1e100).collect(), s.1.iter().map(|y| y * 1e100).collect());
        let r = align((&bx, &by, &s.2), (&bx, &by, &s.2), &CpdParams::new(0.1, Some(0.5), 100, 1e-5, false, 1).unwrap()).unwrap();
        assert!(r.transform.theta.abs() < 1e-9 && r.rms.is_finite());
    }
}
