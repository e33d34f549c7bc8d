//! The final registration of a camera pair when the cameras do not see the same point of a road
//! user (issue 38; docs/alignment.md, "Registration with a bias per track pair").
//!
//! Two cameras see different points of a car (front, back, side: 0.5–2 m apart, constant while
//! both see it) and each has a ground-plane scale error of about 1 %. The pooled fit of
//! [`shift::joint`](super::shift::joint) treats every point pair as `fixed = T(moving) + noise`,
//! so a constant offset `b_k` of track pair `k` pulls the translation (towards the class that
//! biases most), and an offset that points towards the moving camera everywhere (a line-of-sight
//! bias) looks like a rotation and a scale about that camera. Here the model is
//!
//! `f_ki = s R m_ki + T + b_k + e_ki`, with `b_k ~ N(0, τ²_c)` per class `c` and `e` the noise,
//!
//! and the parameters come from the parts of the data that `b_k` cannot touch:
//! * **rotation and scale from within each track pair** (fixed effects): every pair's points are
//!   centred on the pair's own means, so a constant `b_k` drops out; the kept points are those
//!   within [`KEEP_SIGMAS`] of the least-trimmed-squares fit ([`rigid::fit_trimmed`]), `θ = arg Σ f·conj(m)` and `s` is Deming's
//!   (errors in both views, their variance ratio from the cameras' measured noise: plain least
//!   squares was 1.7 % low on a simulated pedestrian-heavy pair). A scale error shows as a
//!   track that is longer in one view than in the other, whatever its offset;
//! * **scale only where the data show it**: its standard error is the block jackknife over
//!   [`BLOCKS`] consecutive blocks of track pairs (pairs seen close in time share the crowd and
//!   the interpolation, so they are left out together: a cluster-robust error), and `s` is used
//!   only when `|ln s| > `[`SCALE_Z`]` · se` (5, not 3: a site has many camera pairs, as the clock
//!   drift's test); otherwise `s = 1` and `R` is the rigid fit of the same centred points;
//! * **translation from the pairs' offsets, weighted by how much each class's offsets scatter**
//!   (random effects): `d_k = f̄_k − s R m̄_k` estimates `T + b_k`; `τ²_c` is the robust spread of
//!   the class's `d_k` (MAD, per axis) less the noise of a mean; `T` is the mean of the `d_k`
//!   weighted by `1 / (τ²_c + v_k)` (`v_k` the variance of the pair's mean), refitted once
//!   without the pairs beyond `χ²₂(0.999)` ([`OUTLIER_D2`]). Pedestrians (bias ≤ 0.3 m) then
//!   fix the translation, cars (≤ 2 m) barely move it. The common part of the biases (the mean
//!   over classes of where each camera sees a road user) cannot be told from `T`: it is the
//!   registration's reference point, and stays in `T`.
//!
//! Every parameter has a standard error from the same jackknife (the translation's is the larger
//! of the jackknife's and `1/sqrt(Σ w)`).
//!
//! The clock offset `dt` is not fitted here: a per-pair offset absorbs a time shift along a
//! straight road, so within pairs it cannot be seen. It is the pooled fit's (which several
//! directions of flow pin), passed in.
//!
//! # Complexity
//! O(P) to build the P point pairs, O(I·P) for the trimmed fit (I ≤ 50 rounds), O(B·P) for the
//! jackknife (B = [`BLOCKS`]) and O(K log K) for the K track pairs' offsets; the point pairs are
//! counted against the work limit `shift_pair_fits` (as `(B + 2)·P` fits) before any work.

use super::correspond::{correspond_into, Pairs};
use super::perspective::{self, Perspective};
use super::rigid::{self, wrap_angle, Transform2};
use super::shift::{Noise, ShiftError};
use crate::limits;
use crate::traj::Traj;
use crate::{finite, positive_or_inf};

/// The jackknife's blocks of consecutive track pairs.
pub const BLOCKS: usize = 16;
/// Fewer non-empty blocks than this: no standard error (infinite), so no scale.
pub const MIN_BLOCKS: usize = 8;

/// The degrees of freedom of a standard error of [`register`] (and of register_clock's se_dt)
/// over `pairs` track pairs: a block jackknife over min(pairs, [`BLOCKS`]) non-empty blocks has
/// one less. 0 when it has no standard error (fewer than [`MIN_BLOCKS`] blocks).
pub fn jackknife_dof(pairs: usize) -> usize {
    let b = pairs.min(BLOCKS);
    if b < MIN_BLOCKS { 0 } else { b - 1 }
}
/// A track pair needs this many point pairs to have a mean offset.
pub const MIN_PAIR_POINTS: usize = 3;
/// The scale is used when `|ln s|` exceeds this many standard errors (unitless; the clock
/// drift's rule in align.sql, for the same reason: many camera pairs are tested).
pub const SCALE_Z: f64 = 5.0;
/// χ²₂ at 0.999: a track pair whose offset is this far from the translation (in its own
/// standard deviations, squared) is left out of the translation's second fit.
pub const OUTLIER_D2: f64 = 13.815510557964274;
/// Rounds of the random-effects fit after the pooled start (each: offsets, τ², weights, fit).
pub const GLS_ROUNDS: usize = 3;
/// Point pairs farther than this many noise sigmas (per axis; the residuals' median / sqrt(2 ln 2))
/// from the trimmed fit are left out: 0.03 % of Gaussian noise, every gross error.
pub const KEEP_SIGMAS: f64 = 4.0;
/// The smallest variance of a pair's mean (m²): 1 mm², so that noise-free input has weights.
pub const MIN_VAR_M2: f64 = 1e-6;

/// The registration of one camera pair (module docs): `fixed = transform(moving)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Registration {
    /// The transform used: scale 1 unless [`scale_significant`](Self::scale_significant).
    pub transform: Transform2,
    /// The scale the centred points show, before the test.
    pub scale_fit: f64,
    /// Standard errors (jackknife): rotation (rad), translation (m), scale (unitless).
    pub se_theta: f64,
    pub se_tx: f64,
    pub se_ty: f64,
    pub se_scale: f64,
    /// `|ln scale_fit| > SCALE_Z · se(ln s)`.
    pub scale_significant: bool,
    /// Track pairs in the translation (after the outlier step) and in the fit.
    pub pairs_used: usize,
    pub pairs: usize,
    /// RMS residual about each pair's own offset (m, both axes), over the kept point pairs.
    pub rms: f64,
    /// The largest spread of a class's offsets, τ (m, per axis).
    pub tau_max: f64,
    /// τ² per class (m², per axis; index = the class label's rank among the labels given).
    pub tau2: Vec<f64>,
    /// The perspective term the kept point pairs show ([`perspective`](super::perspective)),
    /// measured, tested, and not applied; `None` when the points do not fix it.
    pub perspective: Option<Perspective>,
}

struct PairPoints {
    /// point pairs, centred per track pair
    c: Pairs,
    /// which track pair each point pair belongs to (index into `means`)
    k: Vec<usize>,
    /// per track pair: its means (fx, fy, mx, my) and class
    means: Vec<([f64; 4], u32)>,
    /// its block (consecutive pairs)
    block: Vec<usize>,
}

fn build(tracks: &[(Traj<'_>, Traj<'_>)], classes: &[u32], dt: f64, max_gap: f64) -> PairPoints {
    let mut c = Pairs::default();
    let mut k = Vec::new();
    let mut means = Vec::new();
    let mut tmp = Pairs::default();
    for (&(f, m), &cls) in tracks.iter().zip(classes) {
        tmp.clear();
        correspond_into(f, m, dt, max_gap, &mut tmp);
        let n = tmp.fx.len();
        if n < MIN_PAIR_POINTS {
            continue;
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / n as f64;
        let mu = [mean(&tmp.fx), mean(&tmp.fy), mean(&tmp.mx), mean(&tmp.my)];
        let id = means.len();
        means.push((mu, cls));
        for i in 0..n {
            c.t.push(tmp.t[i]);
            c.u.push(tmp.u[i]);
            c.fx.push(tmp.fx[i] - mu[0]);
            c.fy.push(tmp.fy[i] - mu[1]);
            c.mx.push(tmp.mx[i] - mu[2]);
            c.my.push(tmp.my[i] - mu[3]);
            k.push(id);
        }
    }
    let kk = means.len();
    let block = (0..kk).map(|i| i * BLOCKS / kk.max(1)).collect();
    PairPoints { c, k, means, block }
}

/// Rotation and scale of the centred points with the mask `keep`: θ = arg Σ f·conj(m) (writing
/// points as complex numbers), and the scale by Deming regression (errors in both views) with
/// `lambda` = the fixed view's noise variance over the moving view's: the least-squares scale
/// `|Σ f·conj(m)| / Σ|m|²` is diluted by the moving view's noise, 1 % low when that noise's
/// variance is 1 % of the centred points' spread (a pedestrian walking 8 m in a view with 0.13 m
/// of noise: measured on `trajdb simulate`, 0.9905 for a true 1.0073). With `s0 R` the truth,
/// Deming's estimate is exact without noise and unbiased under it when `lambda` is right.
/// `None` when the points do not fix a rotation.
///
/// `between`: the pairs' own means, centred on their weighted mean, with their weights (in
/// units of one point pair's): the part of the random-effects fit that the offsets `b_k` blur
/// ([`between_part`]).
fn fit_masked(p: &Pairs, keep: &[bool], with_scale: bool, lambda: f64, between: &[([f64; 2], [f64; 2], f64)]) -> Option<(f64, f64)> {
    let (mut sff, mut smm, mut re, mut im) = (0.0, 0.0, 0.0, 0.0);
    let points = (0..p.fx.len()).filter(|&i| keep[i]).map(|i| (p.fx[i], p.fy[i], p.mx[i], p.my[i], 1.0));
    let means = between.iter().map(|(f, m, w)| (f[0], f[1], m[0], m[1], *w));
    for (fx, fy, mx, my, w) in points.chain(means) {
        sff += w * (fx * fx + fy * fy);
        smm += w * (mx * mx + my * my);
        re += w * (fx * mx + fy * my);
        im += w * (fy * mx - fx * my);
    }
    let sfm = re.hypot(im);
    if !(sfm > 0.0 && smm > 0.0) || !sfm.is_finite() {
        return None;
    }
    let theta = im.atan2(re);
    if !with_scale {
        return Some((theta, 1.0));
    }
    let s = if lambda.is_infinite() {
        sfm / smm // the moving view is exact: ordinary least squares
    } else {
        // Deming: s = (d + sqrt(d² + 4 λ |Sfm|²)) / (2 |Sfm|), d = Sff − λ Smm; in the form that
        // does not cancel when d < 0
        let d = sff - lambda * smm;
        let r = (d * d + 4.0 * lambda * sfm * sfm).sqrt();
        if d >= 0.0 {
            (d + r) / (2.0 * sfm)
        } else {
            2.0 * lambda * sfm / (r - d)
        }
    };
    (s.is_finite() && s > 0.0).then_some((theta, s))
}

/// Deming's variance ratio: the fixed view's noise variance over the interpolated moving view's
/// (a point interpolated at fraction u between two samples has (1 − u)² + u² of a sample's
/// variance); both noises 0 (not measured): 1, the symmetric fit.
fn noise_ratio(p: &Pairs, keep: &[bool], noise: Noise) -> f64 {
    let (vf, vm) = (noise.fixed * noise.fixed, noise.moving * noise.moving);
    if vf == 0.0 && vm == 0.0 {
        return 1.0;
    }
    let (mut s, mut n) = (0.0, 0usize);
    for i in (0..p.u.len()).filter(|&i| keep[i]) {
        let u = p.u[i].clamp(0.0, 1.0);
        s += (1.0 - u).powi(2) + u * u;
        n += 1;
    }
    let vm = vm * if n > 0 { s / n as f64 } else { 1.0 };
    if vm == 0.0 {
        f64::INFINITY
    } else {
        vf / vm
    }
}

/// The jackknife standard error of values `v_b` (one per left-out block).
pub(super) fn jackknife(v: &[f64]) -> f64 {
    let b = v.len();
    if b < MIN_BLOCKS {
        return f64::INFINITY;
    }
    let m = v.iter().sum::<f64>() / b as f64;
    ((b - 1) as f64 / b as f64 * v.iter().map(|x| (x - m).powi(2)).sum::<f64>()).sqrt()
}

use crate::stats::median;

/// Per track pair: its offset `d_k` under `(theta, s)`, the variance of its mean, its class and
/// block; over the kept point pairs.
struct Offset {
    d: [f64; 2],
    v: f64,
    cls: u32,
    block: usize,
    /// the pair's means over its kept points, and their number
    f: [f64; 2],
    m: [f64; 2],
    n: f64,
    /// the track pair (index into `PairPoints::means`)
    id: usize,
}

fn offsets(pp: &PairPoints, keep: &[bool], theta: f64, s: f64) -> Vec<Offset> {
    let kk = pp.means.len();
    let rot = Transform2::new(theta, 0.0, 0.0, s);
    // per pair: kept points' sums of centred values and squared residuals
    let mut acc = vec![[0.0f64; 8]; kk];
    for i in 0..pp.c.fx.len() {
        if !keep[i] {
            continue;
        }
        let a = &mut acc[pp.k[i]];
        let (qx, qy) = rot.apply(pp.c.mx[i], pp.c.my[i]);
        let (rx, ry) = (pp.c.fx[i] - qx, pp.c.fy[i] - qy);
        a[0] += 1.0;
        a[1] += rx;
        a[2] += ry;
        a[3] += rx * rx + ry * ry;
        a[4] += pp.c.fx[i];
        a[5] += pp.c.fy[i];
        a[6] += pp.c.mx[i];
        a[7] += pp.c.my[i];
    }
    let mut out = Vec::with_capacity(kk);
    for (id, (mu, cls)) in pp.means.iter().enumerate() {
        let a = acc[id];
        let n = a[0];
        if n < MIN_PAIR_POINTS as f64 {
            continue;
        }
        // d_k = mean(f) - s R mean(m), over the kept points: the centred parts' mean residual
        // plus the pair's means
        let (qx, qy) = rot.apply(mu[2], mu[3]);
        let (ex, ey) = (a[1] / n, a[2] / n);
        let d = [mu[0] - qx + ex, mu[1] - qy + ey];
        let var_axis = ((a[3] / n - ex * ex - ey * ey) / 2.0).max(0.0) * n / (n - 1.0);
        let f = [mu[0] + a[4] / n, mu[1] + a[5] / n];
        let m = [mu[2] + a[6] / n, mu[3] + a[7] / n];
        out.push(Offset { d, v: (var_axis / n).max(MIN_VAR_M2), cls: *cls, block: pp.block[id], f, m, n, id });
    }
    out
}

/// τ² per class (the index is the class): the robust spread of its offsets per axis less the
/// mean variance of a pair's mean; a class with fewer than 3 pairs takes the largest of the
/// others (0 when none has 3).
fn class_tau2(off: &[Offset]) -> Vec<f64> {
    let spread = |mine: &[&Offset]| {
        let mut mad2 = 0.0;
        for ax in 0..2 {
            let mut v: Vec<f64> = mine.iter().map(|o| o.d[ax]).collect();
            let med = median(&mut v);
            let mut dev: Vec<f64> = mine.iter().map(|o| (o.d[ax] - med).abs()).collect();
            mad2 += (1.4826 * median(&mut dev)).powi(2) / 2.0;
        }
        let noise = mine.iter().map(|o| o.v).sum::<f64>() / mine.len() as f64;
        (mad2 - noise).max(0.0)
    };
    let ncls = off.iter().map(|o| o.cls as usize + 1).max().unwrap_or(0);
    let mut tau = vec![f64::NAN; ncls];
    for (c, slot) in tau.iter_mut().enumerate() {
        let mine: Vec<&Offset> = off.iter().filter(|o| o.cls as usize == c).collect();
        if mine.len() >= 3 {
            *slot = spread(&mine);
        }
    }
    // a class with fewer than 3 pairs: the largest of the measured classes and of all pairs
    // together (the hostile probe: 40 pairs of 40 classes had τ = 0 each, every pair was an
    // outlier and the call returned NULL)
    let all: Vec<&Offset> = off.iter().collect();
    let pooled = if all.len() >= 2 { spread(&all) } else { 0.0 };
    let fill = tau.iter().copied().filter(|v| v.is_finite()).fold(pooled, f64::max);
    tau.iter().map(|v| if v.is_finite() { *v } else { fill }).collect()
}

/// The random-effects weight of each pair's mean, in units of one point pair's (noise σ² per
/// axis pooled over the pairs): `σ² / (τ²_c + v_k)`, which is `n_k` (the pooled fit) when the
/// class's offsets do not scatter and → 0 when they scatter much more than the noise.
fn pair_weights(off: &[Offset], tau2: &[f64]) -> Vec<f64> {
    let (mut s, mut d) = (0.0, 0.0);
    for o in off {
        s += o.v * o.n * (o.n - 1.0);
        d += o.n - 1.0;
    }
    let sigma2 = if d > 0.0 { (s / d).max(MIN_VAR_M2) } else { MIN_VAR_M2 };
    off.iter().map(|o| sigma2 / (tau2[o.cls as usize] + o.v)).collect()
}

/// Each class's mean offset `μ_c` (index = class; `None` for a class without pairs), over the
/// pairs not in block `skip`: weighted by `w`, then again without the pairs beyond
/// [`OUTLIER_D2`] of the first mean in their own spread (`τ²_c + v_k`). A class of road users
/// that one camera sees all from one side (every car from behind on a one-way road) has its own
/// mean; judged against one mean of all classes, every pair of it was an outlier (or, when it
/// weighed most, every pedestrian was) and the fit was left with no pairs.
fn class_means(off: &[Offset], w: &[f64], tau2: &[f64], skip: Option<usize>) -> Vec<Option<[f64; 2]>> {
    let ncls = off.iter().map(|o| o.cls as usize + 1).max().unwrap_or(0);
    let means = |keep: &dyn Fn(&Offset) -> bool| {
        let mut acc = vec![[0.0f64; 3]; ncls];
        for (o, &q) in off.iter().zip(w).filter(|(o, _)| Some(o.block) != skip && keep(o)) {
            let a = &mut acc[o.cls as usize];
            a[0] += q;
            a[1] += q * o.d[0];
            a[2] += q * o.d[1];
        }
        acc.iter().map(|a| (a[0] > 0.0).then(|| [a[1] / a[0], a[2] / a[0]])).collect::<Vec<_>>()
    };
    let first = means(&|_| true);
    let second = means(&|o| d2_class(o, &first, tau2) <= OUTLIER_D2);
    second.iter().zip(&first).map(|(a, b)| a.or(*b)).collect()
}

/// A pair's squared distance from its class's mean offset, in its own spread `τ²_c + v_k`.
fn d2_class(o: &Offset, mu: &[Option<[f64; 2]>], tau2: &[f64]) -> f64 {
    let spread = tau2.get(o.cls as usize).copied().unwrap_or(0.0) + o.v;
    mu.get(o.cls as usize).copied().flatten().map_or(0.0, |m| ((o.d[0] - m[0]).powi(2) + (o.d[1] - m[1]).powi(2)) / spread)
}

/// The points of the fit: `keep`, without the pairs whose offset lies beyond [`OUTLIER_D2`] of
/// their class's mean offset in their own spread (`τ²_c + v_k`): a pair offset that much more
/// than its class's pairs is two road users (neighbours walking side by side), not two views of
/// one, and its points would bend the rotation (0.11 deg on the shared intersection).
fn without_outliers(pp: &PairPoints, keep: &[bool], off: &[Offset], w: &[f64], tau2: &[f64]) -> Vec<bool> {
    let mu = class_means(off, w, tau2, None);
    let mut bad = vec![false; pp.means.len()];
    for o in off {
        bad[o.id] = d2_class(o, &mu, tau2) > OUTLIER_D2;
    }
    keep.iter().zip(&pp.k).map(|(&k, &id)| k && !bad[id]).collect()
}

/// The between-pairs part of the fit ([`fit_masked`]): every pair's kept means, without the
/// block `skip` and without the pairs beyond [`OUTLIER_D2`] of their class's mean offset (in
/// the pair's own spread), centred on their class's weighted means (each class its own
/// offset, [`class_means`]; the spatial spread of a class's pairs is what pins the rotation).
fn between_part(off: &[Offset], w: &[f64], tau2: &[f64], skip: Option<usize>) -> Vec<([f64; 2], [f64; 2], f64)> {
    let mu = class_means(off, w, tau2, skip);
    let ok = |o: &Offset| Some(o.block) != skip && d2_class(o, &mu, tau2) <= OUTLIER_D2;
    let ncls = mu.len();
    let mut acc = vec![[0.0f64; 5]; ncls];
    for (o, &q) in off.iter().zip(w).filter(|(o, _)| ok(o)) {
        let a = &mut acc[o.cls as usize];
        a[0] += q;
        a[1] += q * o.f[0];
        a[2] += q * o.f[1];
        a[3] += q * o.m[0];
        a[4] += q * o.m[1];
    }
    off.iter()
        .zip(w)
        .filter(|(o, _)| ok(o) && acc[o.cls as usize][0] > 0.0)
        .map(|(o, &q)| {
            let a = acc[o.cls as usize];
            ([o.f[0] - a[1] / a[0], o.f[1] - a[2] / a[0]], [o.m[0] - a[3] / a[0], o.m[1] - a[4] / a[0]], q)
        })
        .collect()
}

/// The translation: each class's mean offset `μ_c` ([`class_means`], weights `1 / (τ²_c + v_k)`,
/// variance `V_c = 1 / Σ w` per axis), combined as a random-effects meta-analysis: the classes'
/// means scatter about `T` (where each camera sees a car against where it sees a pedestrian) with
/// a variance `κ² e_c²`, `e_c` half the class's length (`extents`, m: a detector's ground point
/// lies on the road user's outline, so a car's can be metres from its centre and a pedestrian's
/// decimetres; all 1 when not given). κ² is Paule–Mandel's: `Q(κ²) = Σ |μ_c − T|² / (V_c + κ² e_c²)`
/// equal to its degrees of freedom `2(C − 1)` (0 when `Q(0)` is already below them), and
/// `T = Σ μ_c / (V_c + κ² e_c²) / Σ 1 / (V_c + κ² e_c²)`. Classes that agree (a drone's view)
/// weigh by their precision, as one pooled mean; classes that do not weigh by their extent, so that
/// no class's systematic offset (every car of one camera seen from behind, all offsets equal,
/// τ ≈ 0) moves the translation: with equal weights (DerSimonian–Laird before) half of one
/// camera's 1 m car offset went into its translation, and the 0.9 m overlap strip of the shared
/// intersection's cameras 0 and 2 moved by half a metre (3 % of its road users split). Returns `T`,
/// `Σ 1 / (V_c + κ² e_c²)` and the pairs used; `None` when no pair.
fn translation(off: &[Offset], tau2: &[f64], extents: &[f64], skip_block: Option<usize>) -> Option<([f64; 2], f64, usize)> {
    let w: Vec<f64> = off.iter().map(|o| 1.0 / (tau2[o.cls as usize] + o.v)).collect();
    let mu = class_means(off, &w, tau2, skip_block);
    let mut per = vec![(0.0f64, 0usize); mu.len()];
    for (o, &q) in off.iter().zip(&w).filter(|(o, _)| Some(o.block) != skip_block && d2_class(o, &mu, tau2) <= OUTLIER_D2) {
        per[o.cls as usize].0 += q;
        per[o.cls as usize].1 += 1;
    }
    let e2 = |c: usize| extents.get(c).map_or(1.0, |e| if e.is_finite() && *e > 0.0 { (e / 2.0).powi(2) } else { 1.0 });
    // (mean, V, pairs, e²)
    let classes: Vec<([f64; 2], f64, usize, f64)> = mu
        .iter()
        .zip(&per)
        .enumerate()
        .filter_map(|(c, (m, &(sw, n)))| m.filter(|_| sw > 0.0).map(|m| (m, 1.0 / sw, n, e2(c))))
        .collect();
    if classes.is_empty() {
        return None;
    }
    let combine = |k2: f64| -> ([f64; 2], f64, f64) {
        let sw: f64 = classes.iter().map(|c| 1.0 / (c.1 + k2 * c.3)).sum();
        let t = [0, 1].map(|ax| classes.iter().map(|c| c.0[ax] / (c.1 + k2 * c.3)).sum::<f64>() / sw);
        let q: f64 = classes.iter().map(|c| ((c.0[0] - t[0]).powi(2) + (c.0[1] - t[1]).powi(2)) / (c.1 + k2 * c.3)).sum();
        (t, sw, q)
    };
    let df = 2.0 * (classes.len() as f64 - 1.0);
    let mut k2 = 0.0;
    if classes.len() > 1 && combine(0.0).2 > df {
        // Q falls as κ² grows: bracket the root, then bisect (on a log scale)
        let mut hi = 1e-6;
        while combine(hi).2 > df && hi < 1e12 {
            hi *= 10.0;
        }
        let mut lo = hi / 10.0;
        if combine(lo).2 <= df {
            lo = 0.0;
        }
        for _ in 0..100 {
            let mid = if lo > 0.0 { (lo * hi).sqrt() } else { hi / 2.0 };
            if combine(mid).2 > df {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        k2 = hi;
    }
    let (t, sw_re, _) = combine(k2);
    Some((t, sw_re, classes.iter().map(|c| c.2).sum()))
}

/// See the module docs. `tracks[k]` is a (fixed, moving) track pair of class `classes[k]` (any
/// labels: only equality counts), in the order of the recording (the jackknife's blocks are
/// consecutive pairs); `dt` the clock offset (moving − fixed), `max_gap` the interpolation gap,
/// `trim` the share of point pairs least trimmed squares leaves out; `extents[c]` the length of
/// class `c`'s road users (m; the class labels' ranks index it; empty: all alike), which weighs
/// the classes' disagreement in [`translation`]. `None` when fewer than 2
/// track pairs have [`MIN_PAIR_POINTS`] point pairs, or their points do not fix a rotation.
pub fn register(tracks: &[(Traj<'_>, Traj<'_>)], classes: &[u32], extents: &[f64], dt: f64, max_gap: f64, trim: f64, noise: Noise) -> Result<Option<Registration>, ShiftError> {
    if tracks.len() != classes.len() {
        return Err(ShiftError::Lengths { fixed: tracks.len(), moving: classes.len() });
    }
    let dt = finite("dt", dt)?;
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    if !(0.0..1.0).contains(&trim) {
        return Err(rigid::RigidError::Trim(trim).into());
    }
    let points: u128 = tracks.iter().map(|(f, m)| (f.len() + m.len()) as u128).sum();
    limits::SHIFT_PAIR_FITS.check((BLOCKS as u128 + 2) * points).map_err(ShiftError::RegisterWork)?;
    let pp = build(tracks, classes, dt, max_gap);
    if pp.means.len() < 2 {
        return Ok(None);
    }
    let c = &pp.c;
    let full = match rigid::fit_trimmed(&c.fx, &c.fy, &c.mx, &c.my, trim, true) {
        Ok(f) => f,
        Err(rigid::RigidError::TooFew { .. } | rigid::RigidError::Degenerate) => return Ok(None),
        Err(e) => return Err(e.into()),
    };
    // The points kept: not the trimmed set itself (keeping the points whose two views' noises
    // happen to agree biased the scale 0.3 % low in a test), but every point within
    // KEEP_SIGMAS of the trimmed fit, sigma from the residuals' median (Rayleigh).
    let keep = {
        let map = full.transform.mapper();
        let r: Vec<f64> = (0..c.fx.len())
            .map(|i| {
                let (qx, qy) = map(c.mx[i], c.my[i]);
                (c.fx[i] - qx).hypot(c.fy[i] - qy)
            })
            .collect();
        let mut sorted = r.clone();
        let sigma = median(&mut sorted) / (2.0 * std::f64::consts::LN_2).sqrt();
        r.iter().map(|&v| v <= KEEP_SIGMAS * sigma).collect::<Vec<bool>>()
    };
    let lambda = noise_ratio(c, &keep, noise);
    // Random effects by iteration: start from the pooled fit (every pair's mean weighs its n_k
    // points: the offsets' spread τ = 0), measure each class's τ² from the offsets under that fit,
    // refit with the pairs' means weighted by σ² / (τ²_c + v_k), GLS_ROUNDS times. Without
    // offsets (a drone's view, the shared scenes) this stays the pooled fit, whose rotation the
    // whole view's extent fixes; with them the means weigh less and the rotation comes from
    // within the pairs.
    let mut off = offsets(&pp, &keep, 0.0, 1.0);
    let mut tau2 = vec![0.0; off.iter().map(|o| o.cls as usize + 1).max().unwrap_or(0)];
    let mut w: Vec<f64> = off.iter().map(|o| o.n).collect();
    let Some((mut theta_s, mut s)) = fit_masked(c, &keep, true, lambda, &between_part(&off, &w, &tau2, None)) else { return Ok(None) };
    let mut fit_keep = keep.clone();
    for _ in 0..GLS_ROUNDS {
        off = offsets(&pp, &keep, theta_s, s);
        tau2 = class_tau2(&off);
        w = pair_weights(&off, &tau2);
        fit_keep = without_outliers(&pp, &keep, &off, &w, &tau2);
        let Some(f) = fit_masked(c, &fit_keep, true, lambda, &between_part(&off, &w, &tau2, None)) else { return Ok(None) };
        (theta_s, s) = f;
    }
    let keep = fit_keep;
    let Some((theta_r, _)) = fit_masked(c, &keep, false, lambda, &between_part(&off, &w, &tau2, None)) else { return Ok(None) };
    // the jackknife: every block left out in turn (the weights stay)
    let mut jk_theta_s = Vec::new();
    let mut jk_theta_r = Vec::new();
    let mut jk_lns = Vec::new();
    for b in 0..BLOCKS {
        let mask: Vec<bool> = keep.iter().zip(&pp.k).map(|(&kp, &id)| kp && pp.block[id] != b).collect();
        if mask.iter().filter(|&&m| m).count() == keep.iter().filter(|&&m| m).count() {
            continue; // an empty block
        }
        let bp = between_part(&off, &w, &tau2, Some(b));
        if let (Some((ts, sb)), Some((tr, _))) = (fit_masked(c, &mask, true, lambda, &bp), fit_masked(c, &mask, false, lambda, &bp)) {
            jk_theta_s.push(wrap_angle(ts - theta_s));
            jk_theta_r.push(wrap_angle(tr - theta_r));
            jk_lns.push(sb.ln());
        }
    }
    let se_lns = jackknife(&jk_lns);
    let scale_significant = se_lns.is_finite() && s.ln().abs() > SCALE_Z * se_lns;
    let (theta, scale, se_theta) = if scale_significant { (theta_s, s, jackknife(&jk_theta_s)) } else { (theta_r, 1.0, jackknife(&jk_theta_r)) };
    let off = offsets(&pp, &keep, theta, scale);
    let tau2 = class_tau2(&off);
    let Some((t, sw, used)) = translation(&off, &tau2, extents, None) else { return Ok(None) };
    let mut jx = Vec::new();
    let mut jy = Vec::new();
    for b in 0..BLOCKS {
        if !off.iter().any(|o| o.block == b) {
            continue;
        }
        if let Some((tb, _, _)) = translation(&off, &tau2, extents, Some(b)) {
            jx.push(tb[0]);
            jy.push(tb[1]);
        }
    }
    let model = if sw > 0.0 { (1.0 / sw).sqrt() } else { f64::INFINITY };
    let transform = Transform2::new(theta, t[0], t[1], scale);
    // RMS about each pair's own offset, over the kept point pairs
    let rot = Transform2::new(theta, 0.0, 0.0, scale);
    let (mut ss, mut n) = (0.0, 0usize);
    for i in (0..c.fx.len()).filter(|&i| keep[i]) {
        let (qx, qy) = rot.apply(c.mx[i], c.my[i]);
        ss += (c.fx[i] - qx).powi(2) + (c.fy[i] - qy).powi(2);
        n += 1;
    }
    // the perspective term, within pairs, on the same kept point pairs and blocks
    let persp = {
        let idx: Vec<usize> = (0..c.fx.len()).filter(|&i| keep[i]).collect();
        let abs = |i: usize| {
            let mu = pp.means[pp.k[i]].0;
            ([c.fx[i] + mu[0], c.fy[i] + mu[1]], [c.mx[i] + mu[2], c.my[i] + mu[3]])
        };
        let (fa, ma): (Vec<[f64; 2]>, Vec<[f64; 2]>) = idx.iter().map(|&i| abs(i)).unzip();
        let pk: Vec<usize> = idx.iter().map(|&i| pp.k[i]).collect();
        let bk: Vec<usize> = idx.iter().map(|&i| pp.block[pp.k[i]]).collect();
        // the inputs are finite (the trajectories are) and as long as each other
        perspective::perspective(&fa, &ma, &pk, &bk).ok().flatten()
    };
    Ok(Some(Registration {
        perspective: persp,
        transform,
        scale_fit: s,
        se_theta,
        se_tx: jackknife(&jx).max(model),
        se_ty: jackknife(&jy).max(model),
        se_scale: s * se_lns,
        scale_significant,
        pairs_used: used,
        pairs: pp.means.len(),
        rms: if n > 0 { (ss / n as f64).sqrt() } else { f64::NAN },
        tau_max: tau2.iter().copied().fold(0.0, f64::max).sqrt(),
        tau2,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traj::OwnedTraj;

    use super::super::test_rng::{gauss, lcg};

    /// A scene of `k` road users crossing a 60 m view in many directions, seen by a fixed camera
    /// (world frame) and a moving one (world = `tf(moving)`), with a per-pair offset drawn per
    /// class (class 0 small, class 1 large, along a direction per pair) and noise.
    fn scene(k: usize, tf: &Transform2, bias: [f64; 2], sigma: f64, seed: u64) -> (Vec<OwnedTraj>, Vec<OwnedTraj>, Vec<u32>) {
        let mut st = seed;
        let inv = tf.invert();
        let (mut fs, mut ms, mut cs) = (vec![], vec![], vec![]);
        for i in 0..k {
            let cls = (i % 2) as u32;
            let dir = lcg(&mut st) * std::f64::consts::TAU;
            let (x0, y0) = (lcg(&mut st) * 40.0 - 20.0, lcg(&mut st) * 40.0 - 20.0);
            let v = if cls == 0 { 1.4 } else { 8.0 };
            let a = lcg(&mut st) * std::f64::consts::TAU;
            let b = bias[cls as usize] * (0.3 + 0.7 * lcg(&mut st));
            let (bx, by) = (b * a.cos(), b * a.sin());
            let t0 = i as f64 * 3.0;
            let (mut f, mut m) = (OwnedTraj { t: vec![], x: vec![], y: vec![] }, OwnedTraj { t: vec![], x: vec![], y: vec![] });
            for j in 0..60 {
                let t = t0 + j as f64 * 0.1;
                let (wx, wy) = (x0 + v * (t - t0) * dir.cos(), y0 + v * (t - t0) * dir.sin());
                f.t.push(t);
                f.x.push(wx + sigma * gauss(&mut st));
                f.y.push(wy + sigma * gauss(&mut st));
                let (lx, ly) = inv.apply(wx + bx + sigma * gauss(&mut st), wy + by + sigma * gauss(&mut st));
                m.t.push(t);
                m.x.push(lx);
                m.y.push(ly);
            }
            fs.push(f);
            ms.push(m);
            cs.push(cls);
        }
        (fs, ms, cs)
    }

    fn run(fs: &[OwnedTraj], ms: &[OwnedTraj], cs: &[u32]) -> Registration {
        let views: Vec<_> = fs.iter().zip(ms).map(|(a, b)| (a.view(), b.view())).collect();
        register(&views, cs, &[], 0.0, 0.5, 0.1, Noise::default()).unwrap().unwrap()
    }

    #[test]
    fn a_rigid_pair_stays_rigid_and_exact_without_bias() {
        let tf = Transform2::new(0.8, 12.0, -5.0, 1.0);
        let (fs, ms, cs) = scene(80, &tf, [0.0, 0.0], 0.05, 1);
        let r = run(&fs, &ms, &cs);
        assert!(!r.scale_significant, "{r:?}");
        assert_eq!(r.transform.scale, 1.0);
        assert!(wrap_angle(r.transform.theta - tf.theta).abs() < 1e-3, "{r:?}");
        assert!((r.transform.tx - tf.tx).abs() < 0.02 && (r.transform.ty - tf.ty).abs() < 0.02, "{r:?}");
        assert!(r.se_theta < 1e-3 && r.se_tx < 0.02 && r.se_tx > 0.0, "{r:?}");
        assert!((r.rms - 0.05 * 2f64.sqrt() * 2f64.sqrt()).abs() < 0.03, "{r:?}");
    }

    #[test]
    fn noisy_short_tracks_do_not_dilute_the_scale() {
        // pedestrians only, 0.15 m of noise in both views: least squares would be ~1 % low
        let tf = Transform2::new(0.4, 2.0, 3.0, 1.007);
        let (fs, ms, cs) = scene(400, &tf, [0.05, 0.05], 0.15, 7);
        let views: Vec<_> = fs.iter().zip(&ms).zip(&cs).filter(|(_, &c)| c == 0).map(|((a, b), _)| (a.view(), b.view())).collect();
        let cs = vec![0u32; views.len()];
        let r = register(&views, &cs, &[], 0.0, 0.5, 0.1, Noise::new(0.15, 0.15 / 1.007).unwrap()).unwrap().unwrap();
        assert!((r.scale_fit - 1.007).abs() < 0.002, "{r:?}");
        let keep = vec![true; 4];
        let p = Pairs { t: vec![0.0; 4], u: vec![0.0; 4], fx: vec![1.0, -1.0, 0.0, 0.0], fy: vec![0.0, 0.0, 1.0, -1.0], mx: vec![0.5, -0.5, 0.0, 0.0], my: vec![0.0, 0.0, 0.5, -0.5] };
        for lambda in [0.0, 1.0, 1e6, f64::INFINITY] {
            let (th, s) = fit_masked(&p, &keep, true, lambda, &[]).unwrap();
            assert!(th.abs() < 1e-12 && (s - 2.0).abs() < 1e-9, "{lambda} {s}");
        }
    }

    #[test]
    fn pairs_of_many_classes_still_register() {
        // every pair its own class (the probe: each class had tau = 0 and every pair was an outlier)
        let tf = Transform2::new(0.5, 10.0, -5.0, 1.0);
        let (fs, ms, _) = scene(40, &tf, [0.5, 0.5], 0.05, 8);
        let cs: Vec<u32> = (0..40).collect();
        let r = run(&fs, &ms, &cs);
        assert!(r.pairs_used > 30, "{r:?}");
        assert!((r.transform.tx - tf.tx).abs() < 0.3 && (r.transform.ty - tf.ty).abs() < 0.3, "{r:?}");
    }

    #[test]
    fn a_one_percent_scale_is_found_and_used() {
        let tf = Transform2::new(-2.0, 3.0, 40.0, 1.01);
        let (fs, ms, cs) = scene(80, &tf, [0.1, 1.0], 0.05, 2);
        let r = run(&fs, &ms, &cs);
        assert!(r.scale_significant, "{r:?}");
        assert!((r.transform.scale - 1.01).abs() < 0.002, "{r:?}");
        assert!(r.se_scale > 0.0 && r.se_scale < 0.002, "{r:?}");
    }

    #[test]
    fn large_offsets_of_one_class_do_not_move_the_translation() {
        // cars (class 1) see another point, up to 1.5 m off in a direction per pair; pedestrians
        // (class 0) 0.1 m: the translation follows the pedestrians
        let tf = Transform2::new(1.9, -7.0, 2.0, 1.0);
        let (fs, ms, cs) = scene(120, &tf, [0.1, 1.5], 0.05, 3);
        let r = run(&fs, &ms, &cs);
        assert!((r.transform.tx - tf.tx).abs() < 0.05 && (r.transform.ty - tf.ty).abs() < 0.05, "{r:?}");
        assert!(wrap_angle(r.transform.theta - tf.theta).abs() < 2e-3, "{r:?}");
        assert!(!r.scale_significant, "{r:?}");
        assert!(r.tau_max > 0.5, "{r:?}");
        // the pooled fit (shift::joint's) is pulled by the cars' offsets
        let mut p = Pairs::default();
        for (a, b) in fs.iter().zip(&ms) {
            correspond_into(a.view(), b.view(), 0.0, 0.5, &mut p);
        }
        let pooled = rigid::fit(&p.fx, &p.fy, &p.mx, &p.my, &[], false).unwrap().0;
        let err = |t: &Transform2| (t.tx - tf.tx).hypot(t.ty - tf.ty);
        assert!(err(&r.transform) < err(&pooled), "{r:?} {pooled:?}");
    }

    #[test]
    fn one_class_seen_off_by_one_camera_moves_the_translation_by_its_extent_share() {
        // every car (class 1) of the moving camera 1 m off along x, the same for all: the classes
        // disagree by 1 m. Weighted by extent (cars 5 m, pedestrians 1 m) the translation stays
        // within a few centimetres of the pedestrians'; with the classes alike it moves by half
        let tf = Transform2::new(0.4, 3.0, -1.0, 1.0);
        let (fs, mut ms, cs) = scene(120, &tf, [0.0, 0.0], 0.05, 6);
        for (m, &c) in ms.iter_mut().zip(&cs) {
            if c == 1 {
                for x in m.x.iter_mut() {
                    *x += 1.0;
                }
            }
        }
        let views: Vec<_> = fs.iter().zip(&ms).map(|(a, b)| (a.view(), b.view())).collect();
        let err = |r: &Registration| (r.transform.tx - tf.tx).hypot(r.transform.ty - tf.ty);
        let alike = register(&views, &cs, &[], 0.0, 0.5, 0.1, Noise::default()).unwrap().unwrap();
        let sized = register(&views, &cs, &[1.0, 5.0], 0.0, 0.5, 0.1, Noise::default()).unwrap().unwrap();
        assert!(err(&alike) > 0.3, "{alike:?}");
        assert!(err(&sized) < 0.1, "{sized:?}");
    }

    #[test]
    fn a_constant_offset_of_one_pair_barely_moves_the_rotation() {
        // metamorphic: adding a constant to every moving point of one pair changes that pair's
        // offset; it leaves the between-pairs part (an outlier there) and the rotation and scale
        // move by less than 1e-4
        let tf = Transform2::new(0.3, 1.0, 2.0, 1.0);
        let (fs, mut ms, cs) = scene(40, &tf, [0.0, 0.0], 0.05, 4);
        let a = run(&fs, &ms, &cs);
        for x in ms[5].x.iter_mut() {
            *x += 0.7;
        }
        let b = run(&fs, &ms, &cs);
        assert!((a.transform.theta - b.transform.theta).abs() < 1e-4 && (a.scale_fit - b.scale_fit).abs() < 1e-4, "{a:?} {b:?}");
    }

    #[test]
    fn too_little_gives_none_and_bad_parameters_name_themselves() {
        let tf = Transform2::new(0.0, 0.0, 0.0, 1.0);
        let (fs, ms, cs) = scene(1, &tf, [0.0, 0.0], 0.05, 5);
        let views: Vec<_> = fs.iter().zip(&ms).map(|(a, b)| (a.view(), b.view())).collect();
        assert_eq!(register(&views, &cs, &[], 0.0, 0.5, 0.1, Noise::default()).unwrap(), None);
        assert_eq!(register(&[], &[], &[], 0.0, 0.5, 0.1, Noise::default()).unwrap(), None);
        assert!(register(&views, &[], &[], 0.0, 0.5, 0.1, Noise::default()).is_err());
        assert_eq!(register(&views, &cs, &[], f64::NAN, 0.5, 0.1, Noise::default()).unwrap_err().to_string(), "dt must be finite, got NaN");
        assert!(register(&views, &cs, &[], 0.0, 0.5, 1.0, Noise::default()).is_err());
        // few pairs: no standard error, so no scale, whatever the points show
        let tf = Transform2::new(0.0, 0.0, 0.0, 1.05);
        let (fs, ms, cs) = scene(5, &tf, [0.0, 0.0], 0.0, 6);
        let r = run(&fs, &ms, &cs);
        assert!(!r.scale_significant && r.se_scale.is_infinite() && (r.scale_fit - 1.05).abs() < 1e-9, "{r:?}");
    }

    proptest::proptest! {
        /// Against the obvious version: the translation is the weighted mean, every offset being
        /// `mean(f) - s R mean(m)` over the kept points of its pair.
        #[test]
        fn offsets_are_the_pairs_means(seed in 0u64..1000, theta in -3.0f64..3.0) {
            let tf = Transform2::new(theta, 5.0, -1.0, 1.0);
            let (fs, ms, cs) = scene(12, &tf, [0.2, 0.8], 0.05, seed);
            let views: Vec<_> = fs.iter().zip(&ms).map(|(a, b)| (a.view(), b.view())).collect();
            let pp = build(&views, &cs, 0.0, 0.5);
            let keep = vec![true; pp.c.fx.len()];
            let off = offsets(&pp, &keep, theta, 1.0);
            let rot = Transform2::new(theta, 0.0, 0.0, 1.0);
            for (k, o) in off.iter().enumerate() {
                let p = super::super::correspond::correspond(fs[k].view(), ms[k].view(), 0.5).unwrap();
                let n = p.fx.len() as f64;
                let (mut sx, mut sy) = (0.0, 0.0);
                for i in 0..p.fx.len() {
                    let (qx, qy) = rot.apply(p.mx[i], p.my[i]);
                    sx += p.fx[i] - qx;
                    sy += p.fy[i] - qy;
                }
                proptest::prop_assert!((o.d[0] - sx / n).abs() < 1e-9 && (o.d[1] - sy / n).abs() < 1e-9);
            }
        }
    }
}
