//! A camera pair's clock drift from its candidate track pairs' own offsets (align.sql step 3b),
//! and the standard error of the pair's clock offset once the drift is known.
//!
//! Each candidate track pair k of a camera pair (its hypothesis agrees with the winning
//! transform) has its own clock offset `y_k` (`rigid_shift_under`) at the middle time `x_k` of
//! its fixed track, with a standard error `se_k`, so a weight `w_k = 1 / se_k²`. The clock model
//! of the pair is `y = a + D x` (t_moving = (1 + D) t_fixed + O, to first order in the ppm-sized
//! D). [`fit`]:
//!
//! 1. weighted least squares over every pair: `D̂ = (S_w S_wxy − S_wx S_wy) / (S_w S_wxx − S_wx²)`,
//!    `â = (S_wy − D̂ S_wx) / S_w`;
//! 2. the pairs whose standardised residual `z_k = (y_k − â − D̂ x_k) √w_k` lies beyond
//!    [`OUTLIER_Z`] robust standard deviations (`1.4826 · median |z|`, the MAD's normal
//!    consistency, [`MAD_TO_SD`]) are left out: a wrong pair of two people side by side;
//! 3. weighted least squares again over the kept pairs, with two standard errors of `D̂`, and
//!    the larger is the drift's: least squares' `√(S_w / Δ · max(χ² / (n − 2), 1e-12))`, and the
//!    delete-a-block jackknife over [`JACKKNIFE_BLOCKS`] blocks of the recording (the pairs in
//!    time order, cut as DuckDB's `ntile` cuts), infinite with fewer than
//!    [`MIN_JACKKNIFE_BLOCKS`] blocks that leave a fit. Why both: road users seen close in time
//!    share biases (one crowd, one interpolation at 2 Hz), which a 5-minute 2 Hz crowd without
//!    drift turned into a "134 ppm ± 17" drift under least squares alone.
//!
//! Whether the drift is then used is the camera network's decision (clock_network.rs: at least
//! [`MIN_DRIFT_PAIRS`] pairs per camera pair, and every camera's drift against 0 beyond the
//! 5-sigma level at once).
//!
//! [`offset_se`]: with the drift `D` removed (`y_k − D x_k`), the pair's clock offset is the
//! weighted mean of its pairs; its standard error is the larger of the mean's `1 / √S_w` and
//! the same block jackknife's, `None` with fewer than [`MIN_JACKKNIFE_BLOCKS`] blocks.
//!
//! Both are O(n log n) for n pairs (the median), and allocate O(n) fallibly. Sums run in the
//! order given, so a result does not depend on DuckDB's thread count (the SQL passes the pairs
//! ordered by time).

use std::fmt;

use crate::stats::median;

/// Pairs beyond this many robust standard deviations of the first fit are left out (step 2).
pub const OUTLIER_Z: f64 = 3.0;
/// `1 / Φ⁻¹(3/4)`: the median absolute deviation times this is the standard deviation of a
/// normal sample.
pub const MAD_TO_SD: f64 = 1.4826;
/// Blocks of the recording the jackknife leaves out in turn (a block is an eighth of the pairs in
/// time order: long enough to hold a crowd that shares its errors).
pub const JACKKNIFE_BLOCKS: usize = 8;
/// Fewest blocks, each leaving a fit when left out, for a jackknife standard error.
pub const MIN_JACKKNIFE_BLOCKS: usize = 4;
/// Fewest kept pairs for a camera pair's drift to enter the camera network (align.sql).
pub const MIN_DRIFT_PAIRS: i64 = 8;

/// One candidate track pair: middle time `x` of the fixed track, its own clock offset `y`, weight
/// `w = 1 / se²`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obs {
    pub x: f64,
    pub y: f64,
    pub w: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub enum DriftError {
    /// Observation `index` (1-based) has a non-finite x or y, or a weight that is not finite and > 0.
    Obs { index: usize, what: &'static str, value: f64 },
    /// The drift given to [`offset_se`] is not finite.
    Drift(f64),
    /// The observations' weighted mean of x or y, or y − drift · x, overflows.
    Range,
    /// The working vectors could not be allocated.
    Memory(usize),
}

impl fmt::Display for DriftError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DriftError::Obs { index, what, value } => {
                write!(f, "obs[{index}].{what} must be finite{}, got {value}", if *what == "w" { " and > 0" } else { "" })
            }
            DriftError::Drift(d) => write!(f, "drift must be finite, got {d}"),
            DriftError::Range => write!(f, "the observations' x or y (or y - drift * x) are too large to fit (their weighted mean overflows); pass times and offsets relative to the recording's start"),
            DriftError::Memory(n) => write!(f, "could not allocate the working vectors for {n} observations"),
        }
    }
}
impl std::error::Error for DriftError {}

/// The robust drift fit of one camera pair.
#[derive(Clone, Debug, PartialEq)]
pub struct DriftFit {
    /// Per observation, in the order given: kept by the outlier test of step 2.
    pub kept: Vec<bool>,
    /// Per observation: its standardised residual about the first fit.
    pub z: Vec<f64>,
    /// Kept pairs.
    pub n: usize,
    /// Time spanned by the kept pairs' x.
    pub x_span: f64,
    /// D̂ and â of the kept pairs' fit.
    pub slope: f64,
    pub intercept: f64,
    /// The drift's standard error: max(se_ls, se_jk).
    pub se: f64,
    pub se_ls: f64,
    /// Infinite with fewer than [`MIN_JACKKNIFE_BLOCKS`] blocks.
    pub se_jk: f64,
    /// The kept pairs' weighted sums S_w, S_wx, S_wy, the weights relative to the largest (for the
    /// intercept under another slope, (S_wy − D S_wx) / S_w).
    pub sw: f64,
    pub swx: f64,
    pub swy: f64,
    /// Whether the camera network may use this pair's drift: at least [`MIN_DRIFT_PAIRS`] kept
    /// pairs and a finite standard error > 0.
    pub usable: bool,
}

/// Weighted sums of a set of observations.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Sums {
    sw: f64,
    swx: f64,
    swy: f64,
    swxx: f64,
    swxy: f64,
}

impl Sums {
    fn of<'a>(obs: impl IntoIterator<Item = &'a Obs>) -> Sums {
        let mut s = Sums::default();
        for o in obs {
            s.add(o, 1.0);
        }
        s
    }
    fn add(&mut self, o: &Obs, sign: f64) {
        self.sw += sign * o.w;
        self.swx += sign * o.w * o.x;
        self.swy += sign * o.w * o.y;
        self.swxx += sign * o.w * o.x * o.x;
        self.swxy += sign * o.w * o.x * o.y;
    }
    fn minus(&self, b: &Sums) -> Sums {
        Sums { sw: self.sw - b.sw, swx: self.swx - b.swx, swy: self.swy - b.swy, swxx: self.swxx - b.swxx, swxy: self.swxy - b.swxy }
    }
    /// The normal equations' determinant Δ = S_w S_wxx − S_wx².
    fn det(&self) -> f64 {
        self.sw * self.swxx - self.swx * self.swx
    }
    /// The weighted least-squares slope; None when Δ = 0 (one time, or no weight).
    fn slope(&self) -> Option<f64> {
        let d = self.det();
        (d != 0.0 && d.is_finite()).then(|| (self.sw * self.swxy - self.swx * self.swy) / d)
    }
}

fn check(obs: &[Obs]) -> Result<(), DriftError> {
    for (i, o) in obs.iter().enumerate() {
        for (what, v) in [("x", o.x), ("y", o.y)] {
            if !v.is_finite() {
                return Err(DriftError::Obs { index: i + 1, what, value: v });
            }
        }
        if !(o.w.is_finite() && o.w > 0.0) {
            return Err(DriftError::Obs { index: i + 1, what: "w", value: o.w });
        }
    }
    Ok(())
}

fn try_vec<T: Clone>(n: usize, v: T) -> Result<Vec<T>, DriftError> {
    let mut out = Vec::new();
    out.try_reserve_exact(n).map_err(|_| DriftError::Memory(n))?;
    out.resize(n, v);
    Ok(out)
}

/// The block of each of `n` items in order, as DuckDB's `ntile(b)` numbers them (0-based):
/// sizes differ by at most one, the larger blocks first; fewer than `b` items are one block each.
fn ntile(i: usize, n: usize, b: usize) -> usize {
    let (q, r) = (n / b, n % b);
    if q == 0 {
        return i;
    }
    // the first r blocks hold q + 1 items
    if i < r * (q + 1) {
        i / (q + 1)
    } else {
        r + (i - r * (q + 1)) / q
    }
}

/// The delete-a-block jackknife standard error of `stat` over the blocks of `items` (in order):
/// `√((B − 1) / B · Σ (θ₋b − θ̄)²)` over the blocks whose leave-out `stat` is defined, `B` the
/// number of blocks; None with fewer than [`MIN_JACKKNIFE_BLOCKS`] defined.
fn jackknife(items: &[Obs], stat: impl Fn(&Sums) -> Option<f64>) -> Option<f64> {
    let n = items.len();
    let nb = n.min(JACKKNIFE_BLOCKS);
    if nb == 0 {
        return None;
    }
    let tot = Sums::of(items);
    let mut blocks = [Sums::default(); JACKKNIFE_BLOCKS];
    for (i, o) in items.iter().enumerate() {
        blocks[ntile(i, n, JACKKNIFE_BLOCKS)].add(o, 1.0);
    }
    let thetas: Vec<f64> = blocks[..nb].iter().filter_map(|b| stat(&tot.minus(b))).collect();
    if thetas.len() < MIN_JACKKNIFE_BLOCKS {
        return None;
    }
    let m = thetas.iter().sum::<f64>() / thetas.len() as f64;
    Some(((nb as f64 - 1.0) / nb as f64 * thetas.iter().map(|t| (t - m) * (t - m)).sum::<f64>()).sqrt())
}

/// The larger of two values, NaN when either is (`f64::max` drops a NaN).
fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Observations with weights relative to the largest (`w / c`) and x, y about their weighted
/// means (`mx`, `my`). Why: at epoch-second times (x ≈ 1.78e9) the raw sums `S_wxx`, `S_wx²`
/// cancel every digit of a ppm slope (a 2000 ppm line came out at 1066 ppm), and weights near
/// 1e308 overflow the sums. The slope, the outlier test and the jackknife do not depend on
/// either change; the intercept and the sums are shifted back.
struct Centred {
    obs: Vec<Obs>,
    c: f64,
    mx: f64,
    my: f64,
}

fn centre(obs: &[Obs]) -> Result<Centred, DriftError> {
    let c = obs.iter().fold(0.0f64, |m, o| m.max(o.w));
    let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for o in obs {
        let w = o.w / c;
        sw += w;
        sx += w * o.x;
        sy += w * o.y;
    }
    let (mx, my) = if obs.is_empty() { (0.0, 0.0) } else { (sx / sw, sy / sw) };
    if !(mx.is_finite() && my.is_finite()) {
        return Err(DriftError::Range);
    }
    let mut out = Vec::new();
    out.try_reserve_exact(obs.len()).map_err(|_| DriftError::Memory(obs.len()))?;
    for o in obs {
        let q = Obs { x: o.x - mx, y: o.y - my, w: o.w / c };
        if !(q.x.is_finite() && q.y.is_finite()) {
            return Err(DriftError::Range);
        }
        out.push(q);
    }
    Ok(Centred { obs: out, c, mx, my })
}

/// The robust drift fit of one camera pair's observations (module docs, steps 1–3). `obs` should
/// be in time order (the jackknife's blocks are consecutive). None when a fit is undefined (no
/// observation, all at one time, or no kept pair spans two times).
pub fn fit(obs: &[Obs]) -> Result<Option<DriftFit>, DriftError> {
    check(obs)?;
    let Centred { obs: cobs, c, mx, my } = centre(obs)?;
    let all = Sums::of(&cobs);
    let Some(b1) = all.slope() else { return Ok(None) };
    let a1 = (all.swy - b1 * all.swx) / all.sw;
    let mut z = try_vec(cobs.len(), 0.0)?;
    for (zk, o) in z.iter_mut().zip(&cobs) {
        *zk = (o.y - a1 - b1 * o.x) * o.w.sqrt();
    }
    let mut absz = try_vec(cobs.len(), 0.0)?;
    for (a, zk) in absz.iter_mut().zip(&z) {
        *a = zk.abs();
    }
    let s = MAD_TO_SD * median(&mut absz);
    let kept: Vec<bool> = z.iter().map(|zk| zk.abs() <= OUTLIER_Z * s).collect();
    // z in the weights given (the relative weights scale every z by 1 / sqrt(c))
    let sc = c.sqrt();
    for zk in z.iter_mut() {
        *zk *= sc;
    }
    let mut k_obs = Vec::new();
    k_obs.try_reserve_exact(cobs.len()).map_err(|_| DriftError::Memory(cobs.len()))?;
    k_obs.extend(cobs.iter().zip(&kept).filter(|(_, &k)| k).map(|(o, _)| *o));
    let sums = Sums::of(&k_obs);
    let Some(slope) = sums.slope() else { return Ok(None) };
    let a_c = (sums.swy - slope * sums.swx) / sums.sw;
    let n = k_obs.len();
    let chi2: f64 = k_obs.iter().map(|o| o.w * (o.y - a_c - slope * o.x).powi(2)).sum();
    // least squares' variance in the weights given: (S_w / Δ) / c · max(c χ² / (n − 2), 1e-12)
    let slope_var0 = sums.sw / sums.det();
    let dof = (n.saturating_sub(2).max(1)) as f64;
    let se_ls = nan_max(slope_var0 * chi2 / dof, slope_var0 * 1e-12 / c).sqrt();
    let se_jk = jackknife(&k_obs, Sums::slope).unwrap_or(f64::INFINITY);
    let (lo, hi) = k_obs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), o| (lo.min(o.x), hi.max(o.x)));
    let se = nan_max(se_ls, se_jk);
    Ok(Some(DriftFit {
        kept,
        z,
        n,
        x_span: hi - lo,
        slope,
        intercept: my + a_c - slope * mx,
        se,
        se_ls,
        se_jk,
        sw: sums.sw,
        swx: sums.sw * mx + sums.swx,
        swy: sums.sw * my + sums.swy,
        usable: n as i64 >= MIN_DRIFT_PAIRS && se.is_finite() && se > 0.0,
    }))
}

/// The clock offset's standard error of one camera pair, its drift `drift` removed (module docs):
/// (blocks, se), se None with fewer than [`MIN_JACKKNIFE_BLOCKS`] blocks. `obs` in time order
/// (the kept pairs of [`fit`]).
pub fn offset_se(obs: &[Obs], drift: f64) -> Result<(usize, Option<f64>), DriftError> {
    check(obs)?;
    if !drift.is_finite() {
        return Err(DriftError::Drift(drift));
    }
    let mut level = Vec::new();
    level.try_reserve_exact(obs.len()).map_err(|_| DriftError::Memory(obs.len()))?;
    for o in obs {
        let y = o.y - drift * o.x;
        if !y.is_finite() {
            return Err(DriftError::Range);
        }
        level.push(Obs { x: o.x, y, w: o.w });
    }
    let Centred { obs: cobs, c, .. } = centre(&level)?;
    let sw = Sums::of(&cobs).sw;
    // the weighted mean's se in the weights given: 1 / sqrt(c S_w)
    let se = jackknife(&cobs, |s| (s.sw > 0.0).then(|| s.swy / s.sw)).map(|jk| nan_max(jk, 1.0 / (c.sqrt() * sw.sqrt())));
    Ok((obs.len().min(JACKKNIFE_BLOCKS), se))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(n: usize, a: f64, d: f64, noise: impl Fn(usize) -> f64) -> Vec<Obs> {
        (0..n).map(|i| {
            let x = i as f64 * 3.0;
            Obs { x, y: a + d * x + noise(i), w: 1.0 / 0.01f64.powi(2) }
        }).collect()
    }

    /// A deterministic noise in [−1, 1).
    fn noise(i: usize) -> f64 {
        ((i as u64).wrapping_mul(2654435761) % 1000) as f64 / 500.0 - 1.0
    }

    #[test]
    fn ntile_cuts_as_the_sql_ntile_does() {
        // 10 rows in 8 tiles: 2, 2, 1, 1, 1, 1, 1, 1
        let b: Vec<usize> = (0..10).map(|i| ntile(i, 10, 8)).collect();
        assert_eq!(b, vec![0, 0, 1, 1, 2, 3, 4, 5, 6, 7]);
        // 5 rows: one each
        assert_eq!((0..5).map(|i| ntile(i, 5, 8)).collect::<Vec<_>>(), vec![0, 1, 2, 3, 4]);
        // 16 rows: 2 each
        assert_eq!((0..16).map(|i| ntile(i, 16, 8)).collect::<Vec<_>>(), (0..16).map(|i| i / 2).collect::<Vec<_>>());
    }

    #[test]
    fn a_clean_line_is_found_with_every_pair_kept() {
        let obs = line(200, 0.5, 200e-6, |i| 0.005 * noise(i));
        let f = fit(&obs).unwrap().unwrap();
        assert!((f.slope - 200e-6).abs() < 5e-6, "{}", f.slope);
        assert!((f.intercept - 0.5).abs() < 2e-3);
        assert_eq!(f.n, 200);
        assert!(f.kept.iter().all(|&k| k));
        assert!(f.se >= f.se_ls && f.se >= f.se_jk && f.se_jk.is_finite());
        assert_eq!(f.x_span, 199.0 * 3.0);
        assert!(f.usable);
    }

    #[test]
    fn a_wrong_pair_is_left_out_and_does_not_move_the_drift() {
        let mut obs = line(100, 0.0, 100e-6, |i| 0.004 * noise(i));
        obs[40].y += 1.5; // two people side by side: 1.5 s off
        let f = fit(&obs).unwrap().unwrap();
        assert!(!f.kept[40] && f.n == 99);
        assert!((f.slope - 100e-6).abs() < 5e-6, "{}", f.slope);
    }

    #[test]
    fn epoch_second_times_and_huge_weights_give_the_same_fit() {
        let base = line(200, 0.5, 2e-3, |i| 0.001 * noise(i));
        let f0 = fit(&base).unwrap().unwrap();
        // x shifted to epoch seconds (and y with it, as the offset's line moves along)
        let t0 = 1.78e9;
        let shifted: Vec<Obs> = base.iter().map(|o| Obs { x: o.x + t0, y: o.y + 2e-3 * t0, w: o.w }).collect();
        let f1 = fit(&shifted).unwrap().unwrap();
        assert!((f1.slope - f0.slope).abs() < 1e-9, "{} vs {}", f1.slope, f0.slope);
        assert!((f1.se / f0.se - 1.0).abs() < 1e-3, "{} vs {}", f1.se, f0.se);
        assert_eq!(f1.kept, f0.kept);
        // the intercept under another slope from the sums
        assert!(((f1.swy - f1.slope * f1.swx) / f1.sw - f1.intercept).abs() < 1e-3);
        // weights of any scale: the same slope, se and z (z in the weights given)
        let heavy: Vec<Obs> = base.iter().map(|o| Obs { w: o.w * 1e300, ..*o }).collect();
        let f2 = fit(&heavy).unwrap().unwrap();
        assert!((f2.slope - f0.slope).abs() < 1e-12 && (f2.se / f0.se - 1.0).abs() < 1e-9);
        assert!((f2.z[7] / f0.z[7] / 1e150 - 1.0).abs() < 1e-9);
        let (_, a) = offset_se(&base, 2e-3).unwrap();
        let (_, b) = offset_se(&heavy, 2e-3).unwrap();
        // (the jackknife does not depend on the weights' scale, the mean's 1 / sqrt(S_w) does)
        assert!(b.unwrap().is_finite() && b.unwrap() <= a.unwrap() * (1.0 + 1e-9));
        // overflow is an error, not a number
        assert_eq!(offset_se(&[Obs { x: 1e10, y: 2.0, w: 1.0 }], 1e300), Err(DriftError::Range));
    }

    #[test]
    fn one_time_or_no_pair_gives_none() {
        assert_eq!(fit(&[]).unwrap(), None);
        let same_t = vec![Obs { x: 5.0, y: 1.0, w: 1.0 }, Obs { x: 5.0, y: 1.1, w: 1.0 }];
        assert_eq!(fit(&same_t).unwrap(), None);
        assert_eq!(offset_se(&[], 0.0).unwrap(), (0, None));
    }

    #[test]
    fn few_blocks_leave_the_jackknife_infinite() {
        let f = fit(&line(3, 0.0, 0.0, |i| 0.01 * noise(i))).unwrap().unwrap();
        assert!(f.se_jk.is_infinite() && f.se.is_infinite() && !f.usable);
    }

    #[test]
    fn bad_values_are_errors_naming_the_observation() {
        let e = fit(&[Obs { x: 0.0, y: 0.0, w: 1.0 }, Obs { x: 1.0, y: f64::NAN, w: 1.0 }]).unwrap_err();
        assert!(matches!(e, DriftError::Obs { index: 2, what: "y", value } if value.is_nan()));
        assert!(e.to_string().contains("obs[2].y must be finite"));
        let e = fit(&[Obs { x: 0.0, y: 0.0, w: 0.0 }]).unwrap_err();
        assert!(e.to_string().contains("obs[1].w must be finite and > 0"), "{e}");
    }

    #[test]
    fn offset_se_is_at_least_the_weighted_means() {
        let obs = line(64, 2.0, 50e-6, |i| 0.003 * noise(i));
        let (blocks, se) = offset_se(&obs, 50e-6).unwrap();
        let se = se.unwrap();
        assert_eq!(blocks, 8);
        assert!(se >= 1.0 / Sums::of(&obs).sw.sqrt());
        // an offset that wanders over the recording (a crowd sharing its error) widens it
        let wander = line(64, 2.0, 0.0, |i| if i < 32 { 0.05 } else { -0.05 });
        assert!(offset_se(&wander, 0.0).unwrap().1.unwrap() > 10.0 * se);
    }

    /// The slow, obviously right version: refit by brute force (a 2×2 solve per subset).
    fn slow_slope(obs: &[Obs]) -> Option<f64> {
        let (mut a, mut b, mut c, mut d, mut e) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for o in obs {
            a += o.w;
            b += o.w * o.x;
            c += o.w * o.x * o.x;
            d += o.w * o.y;
            e += o.w * o.x * o.y;
        }
        let det = a * c - b * b;
        (det.abs() > 1e-300).then(|| (a * e - b * d) / det)
    }

    fn slow_blocks(n: usize) -> Vec<Vec<usize>> {
        // DuckDB's ntile: sizes n / B or n / B + 1, the larger first
        let b = n.min(JACKKNIFE_BLOCKS);
        let mut out = vec![Vec::new(); b];
        let mut i = 0;
        for k in 0..b {
            let size = n / b + usize::from(k < n % b);
            for _ in 0..size {
                out[k].push(i);
                i += 1;
            }
        }
        out
    }

    #[test]
    fn property_the_jackknife_equals_refitting_without_each_block() {
        let mut state = 12345u64;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for trial in 0..200 {
            let n = 4 + (rnd() * 60.0) as usize;
            let mut obs: Vec<Obs> = (0..n).map(|_| Obs { x: rnd() * 600.0, y: rnd() * 0.1, w: 1.0 + rnd() * 100.0 }).collect();
            obs.sort_by(|a, b| a.x.total_cmp(&b.x));
            let fast = jackknife(&obs, Sums::slope);
            let thetas: Vec<f64> = slow_blocks(n)
                .iter()
                .filter_map(|blk| slow_slope(&obs.iter().enumerate().filter(|(i, _)| !blk.contains(i)).map(|(_, o)| *o).collect::<Vec<_>>()))
                .collect();
            let nb = n.min(JACKKNIFE_BLOCKS) as f64;
            let slow = (thetas.len() >= MIN_JACKKNIFE_BLOCKS).then(|| {
                let m = thetas.iter().sum::<f64>() / thetas.len() as f64;
                ((nb - 1.0) / nb * thetas.iter().map(|t| (t - m).powi(2)).sum::<f64>()).sqrt()
            });
            match (fast, slow) {
                (Some(f), Some(s)) => assert!((f - s).abs() <= 1e-6 * s.abs().max(1e-12), "trial {trial}: {f} vs {s}"),
                (f, s) => assert_eq!(f.is_some(), s.is_some(), "trial {trial}"),
            }
        }
    }
}
