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

use super::rigid::{wrap_angle, Transform2};
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

/// A point set in struct-of-arrays form, sorted by `t` internally.
struct Set {
    x: Vec<f64>,
    y: Vec<f64>,
    t: Vec<f64>,
}

fn prepare(which: &'static str, x: &[f64], y: &[f64], t: &[f64]) -> Result<Set, CpdError> {
    if x.len() < 2 {
        return Err(CpdError::TooFew { which, got: x.len() });
    }
    for k in 0..x.len() {
        if !(x[k].is_finite() && y[k].is_finite() && t[k].is_finite()) {
            return Err(CpdError::NotFinite { which, index: k });
        }
        if x[k].abs().max(y[k].abs()).max(t[k].abs()) > MAX_MAGNITUDE {
            return Err(CpdError::Magnitude { which, index: k });
        }
    }
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| t[a].total_cmp(&t[b]));
    Ok(Set { x: idx.iter().map(|&k| x[k]).collect(), y: idx.iter().map(|&k| y[k]).collect(), t: idx.iter().map(|&k| t[k]).collect() })
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

/// [`exp_neg`] for the 3-D module.
#[inline(always)]
pub(crate) fn exp_neg_pub(x: f64) -> f64 {
    exp_neg(x)
}

/// Unnormalised posteriors of one fixed point against its band: `buf[k] = exp(−arg_k)`;
/// returns their sum. Exponent, then exp, in branch-free passes the compiler vectorises.
#[inline(always)]
fn row_weights_generic(p: (f64, f64, f64), band: (&[f64], &[f64], &[f64]), inv: (f64, f64), buf: &mut [f64]) -> f64 {
    let (bx, by, bt) = band;
    let n = buf.len().min(bx.len()).min(by.len()).min(bt.len());
    for k in 0..n {
        let (dx, dy, dt) = (p.0 - bx[k], p.1 - by[k], p.2 - bt[k]);
        buf[k] = (dx * dx + dy * dy) * inv.0 + dt * dt * inv.1;
    }
    for v in buf.iter_mut() {
        *v = exp_neg(*v);
    }
    sum(buf)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn row_weights_avx2(p: (f64, f64, f64), band: (&[f64], &[f64], &[f64]), inv: (f64, f64), buf: &mut [f64]) -> f64 {
    row_weights_generic(p, band, inv, buf)
}

/// Dispatches to an AVX2/FMA build of the same code when the CPU has it (checked once).
#[inline]
fn row_weights(p: (f64, f64, f64), band: (&[f64], &[f64], &[f64]), inv: (f64, f64), buf: &mut [f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        if has_avx2() {
            // SAFETY: the CPU supports AVX2 and FMA (checked in `has_avx2`).
            return unsafe { row_weights_avx2(p, band, inv, buf) };
        }
    }
    row_weights_generic(p, band, inv, buf)
}

/// P-weighted moments of one fixed point over its band, with `p_k = buf[k] · inv`:
/// `(Σ p, Σ p·y_x, Σ p·y_y, Σ p‖y‖², Σ p‖x − T y‖²)`. Four-lane accumulators, no branches.
#[inline(always)]
fn row_moments_generic(x: (f64, f64), inv: f64, buf: &[f64], y: (&[f64], &[f64]), ty: (&[f64], &[f64])) -> (f64, f64, f64, f64, f64) {
    let n = buf.len().min(y.0.len()).min(y.1.len()).min(ty.0.len()).min(ty.1.len());
    let mut acc = [[0.0f64; 4]; 5];
    let mut k = 0;
    while k + 4 <= n {
        for l in 0..4 {
            let p = buf[k + l] * inv;
            let (mx, my) = (y.0[k + l], y.1[k + l]);
            let (dx, dy) = (x.0 - ty.0[k + l], x.1 - ty.1[k + l]);
            acc[0][l] += p;
            acc[1][l] += p * mx;
            acc[2][l] += p * my;
            acc[3][l] += p * (mx * mx + my * my);
            acc[4][l] += p * (dx * dx + dy * dy);
        }
        k += 4;
    }
    while k < n {
        let p = buf[k] * inv;
        let (mx, my) = (y.0[k], y.1[k]);
        let (dx, dy) = (x.0 - ty.0[k], x.1 - ty.1[k]);
        acc[0][0] += p;
        acc[1][0] += p * mx;
        acc[2][0] += p * my;
        acc[3][0] += p * (mx * mx + my * my);
        acc[4][0] += p * (dx * dx + dy * dy);
        k += 1;
    }
    let r = |a: [f64; 4]| (a[0] + a[1]) + (a[2] + a[3]);
    (r(acc[0]), r(acc[1]), r(acc[2]), r(acc[3]), r(acc[4]))
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn row_moments_avx2(x: (f64, f64), inv: f64, buf: &[f64], y: (&[f64], &[f64]), ty: (&[f64], &[f64])) -> (f64, f64, f64, f64, f64) {
    row_moments_generic(x, inv, buf, y, ty)
}

#[inline]
fn row_moments(x: (f64, f64), inv: f64, buf: &[f64], y: (&[f64], &[f64]), ty: (&[f64], &[f64])) -> (f64, f64, f64, f64, f64) {
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
#[derive(Clone, Copy, Default, Debug)]
struct Stats {
    np: f64,
    sx: [f64; 2],
    sy: [f64; 2],
    /// Σ P x yᵀ, row-major (x index, y index).
    sxy: [[f64; 2]; 2],
    sxx: f64,
    syy: f64,
    /// Σ_n log(den_n)
    log_den: f64,
    /// Σ P‖x − T y‖²
    resid: f64,
    inliers: usize,
}

impl Stats {
    fn add(mut self, o: Stats) -> Stats {
        self.np += o.np;
        for d in 0..2 {
            self.sx[d] += o.sx[d];
            self.sy[d] += o.sy[d];
            for e in 0..2 {
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
}

struct Problem<'a> {
    fx: &'a Set,
    mv: &'a Set,
    /// moving-index band `[lo, hi)` of every fixed point
    band: Vec<(u32, u32)>,
    inv_2tau2: f64,
    log_tau_norm: f64,
}

impl Problem<'_> {
    fn e_step(&self, tf: &Transform2, sigma2: f64, w: f64) -> Stats {
        let (n, m) = (self.fx.x.len() as f64, self.mv.x.len() as f64);
        let d = 2.0;
        let c = (2.0 * std::f64::consts::PI * sigma2).powf(d / 2.0) * self.log_tau_norm.exp() * w / (1.0 - w) * m / n;
        let inv_2s2 = 1.0 / (2.0 * sigma2);
        let mat = tf.matrix();
        // Transformed moving points, once per iteration (struct of arrays, for vectorisation).
        let (tyx, tyy): (Vec<f64>, Vec<f64>) = (0..self.mv.x.len())
            .map(|k| {
                let (x, y) = (self.mv.x[k], self.mv.y[k]);
                (mat[0][0] * x + mat[0][1] * y + tf.tx, mat[1][0] * x + mat[1][1] * y + tf.ty)
            })
            .unzip();
        if self.inv_2tau2 == 0.0 {
            if let Some(st) = self.e_step_grid(&tyx, &tyy, inv_2s2, c) {
                return st;
            }
        }
        const CHUNK: usize = 512;
        (0..self.fx.x.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .fold(
                || (Stats::default(), Vec::<f64>::new()),
                |(mut st, mut buf), i| {
                    let (xi, yi, ti) = (self.fx.x[i], self.fx.y[i], self.fx.t[i]);
                    let (lo, hi) = (self.band[i].0 as usize, self.band[i].1 as usize);
                    buf.clear();
                    buf.resize(hi - lo, 0.0);
                    let den = row_weights(
                        (xi, yi, ti),
                        (&tyx[lo..hi], &tyy[lo..hi], &self.mv.t[lo..hi]),
                        (inv_2s2, self.inv_2tau2),
                        &mut buf,
                    );
                    // pycpd clips the column sum at machine epsilon before adding c.
                    let den = den.max(f64::EPSILON) + c;
                    st.log_den += den.ln();
                    let inv = 1.0 / den;
                    let (pt1, sy0, sy1, syy, resid) = row_moments(
                        (xi, yi),
                        inv,
                        &buf,
                        (&self.mv.x[lo..hi], &self.mv.y[lo..hi]),
                        (&tyx[lo..hi], &tyy[lo..hi]),
                    );
                    st.resid += resid;
                    accumulate(&mut st, xi, yi, pt1, sy0, sy1, syy);
                    (st, buf)
                },
            )
            .map(|(s, _)| s)
            .reduce(Stats::default, Stats::add)
    }
}

impl Problem<'_> {
    /// Plain CPD (no time term) once σ is small: pairs farther apart than
    /// `r = sqrt(2σ² · EXP_ZERO)` have `exp(−d²/2σ²) = 0` exactly in [`exp_neg`], so only the
    /// transformed moving points in the 3×3 grid cells (side ≥ r) around each fixed point are
    /// visited. The posteriors are the same; only the order of the sums differs. Returns `None`
    /// when the grid would not save work (r large against the extent of the points).
    fn e_step_grid(&self, tyx: &[f64], tyy: &[f64], inv_2s2: f64, c: f64) -> Option<Stats> {
        const EXP_ZERO: f64 = 708.0;
        let r = (EXP_ZERO / inv_2s2).sqrt();
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
        let (gx, gy, gmx, gmy) = (g(tyx), g(tyy), g(&self.mv.x), g(&self.mv.y));
        let zeros = vec![0.0; gx.len()];
        let st = (0..self.fx.x.len())
            .into_par_iter()
            .with_min_len(512)
            .fold(
                || (Stats::default(), Vec::<f64>::new(), Vec::<(usize, usize)>::new()),
                |(mut st, mut buf, mut runs), i| {
                    let (xi, yi) = (self.fx.x[i], self.fx.y[i]);
                    let cx = ((xi - x0) / r).floor();
                    let cy = ((yi - y0) / r).floor();
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
                        den += row_weights((xi, yi, 0.0), (&gx[a..b], &gy[a..b], &zeros[a..b]), (inv_2s2, 0.0), &mut buf[off..off + b - a]);
                        off += b - a;
                    }
                    let den = den.max(f64::EPSILON) + c;
                    st.log_den += den.ln();
                    let inv = 1.0 / den;
                    let (mut pt1, mut sy0, mut sy1, mut syy) = (0.0, 0.0, 0.0, 0.0);
                    let mut off = 0;
                    for &(a, b) in &runs {
                        let mm = row_moments((xi, yi), inv, &buf[off..off + b - a], (&gmx[a..b], &gmy[a..b]), (&gx[a..b], &gy[a..b]));
                        pt1 += mm.0;
                        sy0 += mm.1;
                        sy1 += mm.2;
                        syy += mm.3;
                        st.resid += mm.4;
                        off += b - a;
                    }
                    accumulate(&mut st, xi, yi, pt1, sy0, sy1, syy);
                    (st, buf, runs)
                },
            )
            .map(|(s, _, _)| s)
            .reduce(Stats::default, Stats::add);
        Some(st)
    }
}

/// Adds one fixed point's P-weighted sums to the E-step statistics.
#[inline]
fn accumulate(st: &mut Stats, xi: f64, yi: f64, pt1: f64, sy0: f64, sy1: f64, syy: f64) {
    st.np += pt1;
    st.sx[0] += pt1 * xi;
    st.sx[1] += pt1 * yi;
    st.sy[0] += sy0;
    st.sy[1] += sy1;
    st.sxy[0][0] += xi * sy0;
    st.sxy[0][1] += xi * sy1;
    st.sxy[1][0] += yi * sy0;
    st.sxy[1][1] += yi * sy1;
    st.sxx += pt1 * (xi * xi + yi * yi);
    st.syy += syy;
    st.inliers += (pt1 > 0.5) as usize;
}

/// One EM run from `init`. Returns the result and whether it converged.
fn run(pb: &Problem<'_>, init: Transform2, p: &CpdParams, max_iter: usize, sigma2_init: f64) -> CpdResult {
    let mut tf = init;
    let mut sigma2 = sigma2_init;
    let (mut q, mut diff) = (f64::INFINITY, f64::INFINITY);
    let mut it = 0;
    let mut last = Stats::default();
    let d = 2.0;
    while it < max_iter && diff > p.tol {
        let st = pb.e_step(&tf, sigma2, p.w);
        last = st;
        if !(st.np > 0.0) {
            break; // every point is an outlier: keep the current estimate
        }
        let mux = [st.sx[0] / st.np, st.sx[1] / st.np];
        let muy = [st.sy[0] / st.np, st.sy[1] / st.np];
        // A = Σ P x̂ ŷᵀ
        let a = [
            [st.sxy[0][0] - st.np * mux[0] * muy[0], st.sxy[0][1] - st.np * mux[0] * muy[1]],
            [st.sxy[1][0] - st.np * mux[1] * muy[0], st.sxy[1][1] - st.np * mux[1] * muy[1]],
        ];
        let ypy = st.syy - st.np * (muy[0] * muy[0] + muy[1] * muy[1]);
        let xpx = st.sxx - st.np * (mux[0] * mux[0] + mux[1] * mux[1]);
        // argmax_R tr(AᵀR) over rotations (Umeyama), closed form in 2-D.
        let (dot, cross) = (a[0][0] + a[1][1], a[1][0] - a[0][1]);
        let theta = cross.atan2(dot);
        let tr_ar = dot.hypot(cross);
        let s = if p.with_scale && ypy > 0.0 { tr_ar / ypy } else { 1.0 };
        let mut next = Transform2 { theta, tx: 0.0, ty: 0.0, scale: s };
        let (rx, ry) = next.apply(muy[0], muy[1]);
        next.tx = mux[0] - rx;
        next.ty = mux[1] - ry;
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
    let (n, m) = (pb.fx.x.len() as f64, pb.mv.x.len() as f64);
    let ll = last.log_den - n * (d / 2.0 * (2.0 * std::f64::consts::PI * sigma2).ln() + pb.log_tau_norm)
        + n * ((1.0 - p.w) / m).ln();
    CpdResult {
        transform: Transform2 { theta: wrap_angle(tf.theta), ..tf },
        sigma2,
        iterations: it,
        converged: diff <= p.tol,
        q,
        log_likelihood: ll,
        inlier_fraction: last.inliers as f64 / n,
        rms: if last.np > 0.0 { (last.resid / last.np).sqrt() } else { f64::NAN },
        start_theta: init.theta,
        pairs_in_band: pb.band.iter().map(|&(a, b)| (b - a) as usize).sum(),
    }
}

/// Builds the time bands of a problem (sets sorted by time). See the module docs.
fn make_problem<'a>(fxc: &'a Set, mvc: &'a Set, tau: Option<f64>) -> Problem<'a> {
    let (inv_2tau2, log_tau_norm, cutoff) = match tau {
        None => (0.0, 0.0, f64::INFINITY),
        Some(t) => (1.0 / (2.0 * t * t), 0.5 * (2.0 * std::f64::consts::PI * t * t).ln(), TIME_CUTOFF_TAUS * t),
    };
    let mut band = Vec::with_capacity(fxc.x.len());
    let (mut lo, mut hi) = (0usize, 0usize);
    for &t in &fxc.t {
        while lo < mvc.t.len() && mvc.t[lo] < t - cutoff {
            lo += 1;
        }
        hi = hi.max(lo);
        while hi < mvc.t.len() && mvc.t[hi] <= t + cutoff {
            hi += 1;
        }
        band.push((lo as u32, hi as u32));
    }
    Problem { fx: fxc, mv: mvc, band, inv_2tau2, log_tau_norm }
}

/// Initial σ² of pycpd: Σ_nm ‖x_n − T y_m‖² / (D N M), in O(N + M) by moments.
fn sigma2_init(fx: &Set, mv: &Set, tf: &Transform2) -> f64 {
    let (n, m) = (fx.x.len() as f64, mv.x.len() as f64);
    let (mut sx, mut sy, mut sxx) = ([0.0; 2], [0.0; 2], 0.0);
    let mut syy = 0.0;
    for k in 0..fx.x.len() {
        sx[0] += fx.x[k];
        sx[1] += fx.y[k];
        sxx += fx.x[k] * fx.x[k] + fx.y[k] * fx.y[k];
    }
    for k in 0..mv.x.len() {
        let (x, y) = tf.apply(mv.x[k], mv.y[k]);
        sy[0] += x;
        sy[1] += y;
        syy += x * x + y * y;
    }
    let s = m * sxx + n * syy - 2.0 * (sx[0] * sy[0] + sx[1] * sy[1]);
    (s / (2.0 * n * m)).max(f64::MIN_POSITIVE)
}

/// Aligns `moving` onto `fixed` (each given as x, y, t columns of equal length).
pub fn align(
    fixed: (&[f64], &[f64], &[f64]),
    moving: (&[f64], &[f64], &[f64]),
    p: &CpdParams,
) -> Result<CpdResult, CpdError> {
    let fx = prepare("fixed", fixed.0, fixed.1, fixed.2)?;
    let mv = prepare("moving", moving.0, moving.1, moving.2)?;
    // Centre both sets (exact: the translation absorbs it) so the raw-moment sums of the
    // M-step do not lose digits to large coordinates.
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (cfx, cfy, cmx, cmy) = (mean(&fx.x), mean(&fx.y), mean(&mv.x), mean(&mv.y));
    let fxc = Set { x: fx.x.iter().map(|v| v - cfx).collect(), y: fx.y.iter().map(|v| v - cfy).collect(), t: fx.t };
    let mvc = Set { x: mv.x.iter().map(|v| v - cmx).collect(), y: mv.y.iter().map(|v| v - cmy).collect(), t: mv.t };
    let pb = make_problem(&fxc, &mvc, p.tau);
    if pb.band.iter().all(|&(a, b)| a == b) {
        return Err(CpdError::NoTimeOverlap { tau: p.tau.unwrap_or(f64::INFINITY) });
    }
    let pairs: u128 = pb.band.iter().map(|&(a, b)| (b - a) as u128).sum();
    crate::limits::CPD_PAIR_VISITS.check(pairs * p.max_iter as u128).map_err(CpdError::Work)?;
    // Start k: rotation 2πk/starts about the centroids (the centred sets share their origin).
    // With one start we reproduce pycpd exactly: R = I and t = 0 in the caller's frames,
    // i.e. t' = c_m − c_f in the centred frames.
    let start = |k: usize| {
        if p.starts == 1 {
            Transform2 { tx: cmx - cfx, ty: cmy - cfy, ..Transform2::default() }
        } else {
            Transform2 { theta: 2.0 * std::f64::consts::PI * k as f64 / p.starts as f64, ..Transform2::default() }
        }
    };
    let best = if p.starts == 1 {
        let s0 = start(0);
        run(&pb, s0, p, p.max_iter, sigma2_init(&fxc, &mvc, &s0))
    } else {
        // Probe every start on an evenly strided subsample of at most PROBE_POINTS points
        // per set (the probes only rank the starts), then continue the winner on all points.
        let probe = PROBE_ITERATIONS.min(p.max_iter);
        let stride = |n: usize| n.div_ceil(PROBE_POINTS).max(1);
        let sub = |s: &Set, k: usize| Set {
            x: s.x.iter().step_by(k).copied().collect(),
            y: s.y.iter().step_by(k).copied().collect(),
            t: s.t.iter().step_by(k).copied().collect(),
        };
        let (fs, ms) = (sub(&fxc, stride(fxc.x.len())), sub(&mvc, stride(mvc.x.len())));
        let pbs = make_problem(&fs, &ms, p.tau);
        let mut best: Option<CpdResult> = None;
        for k in 0..p.starts {
            let s0 = start(k);
            let r = run(&pbs, s0, p, probe, sigma2_init(&fs, &ms, &s0));
            if best.as_ref().is_none_or(|b| r.log_likelihood > b.log_likelihood) {
                best = Some(r);
            }
        }
        let b = best.expect("starts >= 1");
        let mut r = run(&pb, b.transform, p, p.max_iter.saturating_sub(b.iterations).max(1), b.sigma2);
        r.iterations += b.iterations;
        r.start_theta = b.start_theta;
        r
    };
    if !(best.rms.is_finite()) {
        return Err(CpdError::AllOutliers { w: p.w });
    }
    // Undo the centring: p_f − c_f = T'(p_m − c_m)  ⇒  t = t' + c_f − sR c_m.
    let mut out = best;
    let t = out.transform;
    let (rx, ry) = Transform2 { tx: 0.0, ty: 0.0, ..t }.apply(cmx, cmy);
    out.transform.tx = t.tx + cfx - rx;
    out.transform.ty = t.ty + cfy - ry;
    Ok(out)
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
        let fx = prepare("fixed", &f.0, &f.1, &f.2).unwrap();
        let mv = prepare("moving", &f.1, &f.0, &f.2).unwrap();
        let pb = make_problem(&fx, &mv, None);
        let tf = Transform2::new(0.3, 1.0, -2.0, 1.0);
        let mat = tf.matrix();
        let (tyx, tyy): (Vec<f64>, Vec<f64>) =
            (0..mv.x.len()).map(|k| (mat[0][0] * mv.x[k] + mat[0][1] * mv.y[k] + tf.tx, mat[1][0] * mv.x[k] + mat[1][1] * mv.y[k] + tf.ty)).unzip();
        for sigma2 in [0.01, 0.1] {
            let inv = 1.0 / (2.0 * sigma2);
            let g = pb.e_step_grid(&tyx, &tyy, inv, 1e-3).expect("grid applies at small sigma");
            // dense reference: every pair, with std's exp
            let dense = {
                let mut st = Stats::default();
                for i in 0..fx.x.len() {
                    let w: Vec<f64> = (0..mv.x.len()).map(|j| (-(((fx.x[i] - tyx[j]).powi(2) + (fx.y[i] - tyy[j]).powi(2)) * inv)).exp()).collect();
                    let den = w.iter().sum::<f64>().max(f64::EPSILON) + 1e-3;
                    let pt1: f64 = w.iter().sum::<f64>() / den;
                    st.np += pt1;
                    st.sxx += pt1 * (fx.x[i] * fx.x[i] + fx.y[i] * fx.y[i]);
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
