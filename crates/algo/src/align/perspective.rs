//! The perspective term between two cameras' ground planes, measured within track pairs
//! (issue 38, item 2; docs/alignment.md, "Ground-plane error").
//!
//! A camera's image-to-ground homography is estimated, not exact: besides a scale error
//! ([`register`](super::register) fits and tests it) it has a perspective row `h`, a relative
//! scale error that grows along `h` (arXiv 2604.10805). Between two cameras the map is a
//! homography; to first order in `h` (1 % over 50 m is `|h|` = 2e-4 per metre)
//!
//! `f (1 + h·(m − m₀)) = A m + t + b_k + e`, i.e. `f = A m + t + b_k − f (h·(m − m₀)) + e`,
//!
//! with `A` any 2×2 matrix (the scale, rotation and the part `f₀ hᵀ` that moving the origin
//! of `f` adds), `b_k` the constant offset of track pair `k` (viewpoint bias, which drops out
//! within a pair) and `m₀` the moving points' centroid. The model is linear in `(A, h)` once
//! every pair is centred on its own means (fixed effects): 6 parameters, two equations per point
//! pair, solved by least squares. `h` does not depend on the origins (an origin shift is
//! absorbed by `A` and by the pairs' means), and a clock offset that is constant along a track
//! shifts each pair by a constant, which the pair's mean absorbs.
//!
//! **When it is real.** `h`'s covariance is the block jackknife over [`BLOCKS`] consecutive
//! blocks of track pairs (cluster-robust, as the scale's), and least squares' own covariance
//! `σ² N⁻¹` is a floor. The term is significant when its Wald statistic `hᵀ V⁻¹ h` under both
//! covariances exceeds [`PERSPECTIVE_CHI2`], the χ²₂ quantile at the tail of 5 standard errors
//! (the scale's `SCALE_Z`: a site has many camera pairs). trajdb reports it
//! (calibration.csv, a warning); the registration stays a similarity (docs/alignment.md says
//! why: a fit relative to one camera cannot remove that camera's own error, which is what the
//! fused path's error is made of).
//!
//! # Complexity
//! O(P) for P point pairs (two passes), O(B · 6³) for the jackknife's solves.

use std::fmt;

/// The jackknife's blocks (the same as the scale's).
pub const BLOCKS: usize = super::register::BLOCKS;
/// χ²₂ at the two-sided tail of 5 standard errors, `−2 ln(erfc(5/√2))` = `−2 ln(5.733e-7)`:
/// the perspective term is reported as significant above this.
pub const PERSPECTIVE_CHI2: f64 = 28.743702426857556;
/// The range at which the relative error `|h| · r` is reported (m): the simulator's
/// `ground_plane_perspective` is defined at the same range.
pub const REPORT_RANGE_M: f64 = 50.0;

/// The perspective term of a camera pair (module docs): the moving camera's points relative to
/// their centroid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perspective {
    /// `h` (1/m), in the moving camera's axes.
    pub h: [f64; 2],
    /// The standard error of `|h|` (1/m) along `h`'s direction: the larger of the jackknife's and
    /// least squares'; infinite with fewer than `MIN_BLOCKS` non-empty blocks.
    pub se: f64,
    /// The Wald statistic `hᵀ V⁻¹ h`, the smaller under the two covariances.
    pub chi2: f64,
    /// `chi2 > PERSPECTIVE_CHI2`.
    pub significant: bool,
    /// Point pairs in the fit.
    pub points: usize,
}

impl Perspective {
    /// The relative scale error at [`REPORT_RANGE_M`] from the centroid: `|h| · 50 m`.
    pub fn at_report_range(&self) -> f64 {
        self.h[0].hypot(self.h[1]) * REPORT_RANGE_M
    }
}

/// Bad input to [`perspective`].
#[derive(Clone, Debug, PartialEq)]
pub enum PerspectiveError {
    /// The slices differ in length.
    Lengths { f: usize, m: usize, pair: usize, block: usize },
    /// A coordinate is NaN or infinite (index of the point pair).
    NonFinite(usize),
}

impl fmt::Display for PerspectiveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PerspectiveError::Lengths { f: a, m, pair, block } => {
                write!(f, "perspective: f, m, pair and block must be as long, got {a}, {m}, {pair} and {block}")
            }
            PerspectiveError::NonFinite(i) => write!(f, "perspective: point pair {i} has a NaN or infinite coordinate"),
        }
    }
}
impl std::error::Error for PerspectiveError {}

const P: usize = 6;

/// Solves the symmetric system `n x = r` (6×6, Gaussian elimination with partial pivoting);
/// `None` when singular (relative pivot under 1e-12).
fn solve(n: &[[f64; P]; P], r: &[f64; P]) -> Option<[f64; P]> {
    let mut a = [[0.0; P + 1]; P];
    let scale = (0..P).map(|i| n[i][i].abs()).fold(0.0, f64::max);
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    for i in 0..P {
        a[i][..P].copy_from_slice(&n[i]);
        a[i][P] = r[i];
    }
    for c in 0..P {
        let piv = (c..P).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[piv][c].abs() <= 1e-12 * scale {
            return None;
        }
        a.swap(c, piv);
        for row in c + 1..P {
            let k = a[row][c] / a[c][c];
            for col in c..=P {
                a[row][col] -= k * a[c][col];
            }
        }
    }
    let mut x = [0.0; P];
    for i in (0..P).rev() {
        let s: f64 = (i + 1..P).map(|j| a[i][j] * x[j]).sum();
        x[i] = (a[i][P] - s) / a[i][i];
    }
    Some(x)
}

/// `h` from the normal equations (the last two unknowns).
fn h_of(n: &[[f64; P]; P], r: &[f64; P]) -> Option<[f64; 2]> {
    solve(n, r).map(|x| [x[4], x[5]])
}

/// The Wald statistic `hᵀ V⁻¹ h` of a 2×2 covariance (infinite when `V` is singular and `h` ≠ 0).
fn wald(h: [f64; 2], v: [[f64; 2]; 2]) -> f64 {
    let det = v[0][0] * v[1][1] - v[0][1] * v[1][0];
    if !(det > 0.0) || !det.is_finite() {
        return if h == [0.0, 0.0] { 0.0 } else if det.is_finite() { f64::INFINITY } else { 0.0 };
    }
    (h[0] * h[0] * v[1][1] - 2.0 * h[0] * h[1] * v[0][1] + h[1] * h[1] * v[0][0]) / det
}

/// See the module docs. Point pair `i` is `f[i]` (fixed camera) and `m[i]` (moving camera, the
/// same instant), of track pair `pair[i]` in jackknife block `block[i]` (< [`BLOCKS`]; a pair's
/// points all in one block). `None` when the points do not fix the 6 parameters (fewer than 2
/// pairs with 3 points, all on one line, ...).
pub fn perspective(f: &[[f64; 2]], m: &[[f64; 2]], pair: &[usize], block: &[usize]) -> Result<Option<Perspective>, PerspectiveError> {
    if m.len() != f.len() || pair.len() != f.len() || block.len() != f.len() {
        return Err(PerspectiveError::Lengths { f: f.len(), m: m.len(), pair: pair.len(), block: block.len() });
    }
    if let Some(i) = (0..f.len()).find(|&i| !(f[i][0].is_finite() && f[i][1].is_finite() && m[i][0].is_finite() && m[i][1].is_finite())) {
        return Err(PerspectiveError::NonFinite(i));
    }
    let n = f.len();
    if n == 0 {
        return Ok(None);
    }
    let c = |v: &[[f64; 2]]| [0, 1].map(|ax| v.iter().map(|p| p[ax]).sum::<f64>() / n as f64);
    let (f0, m0) = (c(f), c(m));
    // per point: y (2) and the regressors g = (fx mx, fx my, fy mx, fy my) with f, m centred
    let row = |i: usize| {
        let (fx, fy, mx, my) = (f[i][0] - f0[0], f[i][1] - f0[1], m[i][0] - m0[0], m[i][1] - m0[1]);
        [fx, fy, mx, my, fx * mx, fx * my, fy * mx, fy * my]
    };
    // pass 1: per pair means of the 8 quantities
    let npair = pair.iter().copied().max().map_or(0, |p| p + 1);
    let mut sums = vec![[0.0f64; 9]; npair];
    for i in 0..n {
        let v = row(i);
        let s = &mut sums[pair[i]];
        s[0] += 1.0;
        for j in 0..8 {
            s[j + 1] += v[j];
        }
    }
    // pass 2: the centred rows' normal equations, per block
    let nb = block.iter().copied().max().map_or(0, |b| b + 1);
    let mut nmat = vec![[[0.0f64; P]; P]; nb];
    let mut rvec = vec![[0.0f64; P]; nb];
    let mut yy = 0.0;
    let mut used = 0usize;
    let mut pairs_used = 0usize;
    for s in &sums {
        if s[0] >= 3.0 {
            pairs_used += 1;
        }
    }
    for i in 0..n {
        let s = &sums[pair[i]];
        if s[0] < 3.0 {
            continue; // a pair of 1-2 points: its centred rows carry (almost) nothing
        }
        let v = row(i);
        let d: Vec<f64> = (0..8).map(|j| v[j] - s[j + 1] / s[0]).collect();
        // x: fx = a11 mx + a12 my - (fx mx h1 + fx my h2); y: fy = a21 mx + a22 my - (fy mx h1 + fy my h2)
        let xr = [d[2], d[3], 0.0, 0.0, -d[4], -d[5]];
        let yr = [0.0, 0.0, d[2], d[3], -d[6], -d[7]];
        let (nm, rv) = (&mut nmat[block[i]], &mut rvec[block[i]]);
        for (reg, y) in [(xr, d[0]), (yr, d[1])] {
            for a in 0..P {
                rv[a] += reg[a] * y;
                for b in 0..P {
                    nm[a][b] += reg[a] * reg[b];
                }
            }
            yy += y * y;
        }
        used += 1;
    }
    if pairs_used < 2 {
        return Ok(None);
    }
    let mut ntot = [[0.0; P]; P];
    let mut rtot = [0.0; P];
    for b in 0..nb {
        for a in 0..P {
            rtot[a] += rvec[b][a];
            for c in 0..P {
                ntot[a][c] += nmat[b][a][c];
            }
        }
    }
    let Some(beta) = solve(&ntot, &rtot) else { return Ok(None) };
    let h = [beta[4], beta[5]];
    // least squares' covariance: σ² N⁻¹ (its h block), σ² from the residuals (dof: 2 per point,
    // less the pairs' means and the 6 parameters)
    let rss = (yy - (0..P).map(|a| beta[a] * rtot[a]).sum::<f64>()).max(0.0);
    let dof = (2 * used) as f64 - 2.0 * pairs_used as f64 - P as f64;
    if dof <= 0.0 {
        return Ok(None);
    }
    let sigma2 = rss / dof;
    let col = |k: usize| {
        let mut e = [0.0; P];
        e[k] = 1.0;
        solve(&ntot, &e)
    };
    let (Some(c4), Some(c5)) = (col(4), col(5)) else { return Ok(None) };
    let v_ls = [[sigma2 * c4[4], sigma2 * c4[5]], [sigma2 * c5[4], sigma2 * c5[5]]];
    // the jackknife over the non-empty blocks
    let mut hs = Vec::new();
    for b in 0..nb {
        if nmat[b][0][0] == 0.0 && nmat[b][2][2] == 0.0 {
            continue;
        }
        let mut nn = ntot;
        let mut rr = rtot;
        for a in 0..P {
            rr[a] -= rvec[b][a];
            for c in 0..P {
                nn[a][c] -= nmat[b][a][c];
            }
        }
        if let Some(hb) = h_of(&nn, &rr) {
            hs.push(hb);
        }
    }
    let v_jk = if hs.len() < super::register::MIN_BLOCKS {
        [[f64::INFINITY, 0.0], [0.0, f64::INFINITY]]
    } else {
        let k = hs.len() as f64;
        let mean = [0, 1].map(|ax| hs.iter().map(|v| v[ax]).sum::<f64>() / k);
        let mut v = [[0.0; 2]; 2];
        for hb in &hs {
            for a in 0..2 {
                for c in 0..2 {
                    v[a][c] += (hb[a] - mean[a]) * (hb[c] - mean[c]) * (k - 1.0) / k;
                }
            }
        }
        v
    };
    let chi2 = if v_jk[0][0].is_infinite() { 0.0 } else { wald(h, v_jk).min(wald(h, v_ls)) };
    let norm = h[0].hypot(h[1]);
    let u = if norm > 0.0 { [h[0] / norm, h[1] / norm] } else { [1.0, 0.0] };
    let along = |v: [[f64; 2]; 2]| (u[0] * u[0] * v[0][0] + 2.0 * u[0] * u[1] * v[0][1] + u[1] * u[1] * v[1][1]).max(0.0).sqrt();
    let se = along(v_jk).max(along(v_ls));
    Ok(Some(Perspective { h, se, chi2, significant: chi2 > PERSPECTIVE_CHI2, points: used }))
}

#[cfg(test)]
mod tests {
    use super::*;

    use super::super::test_rng::{gauss, lcg};

    /// `k` straight tracks crossing a 60 m view; the fixed camera sees world point p as
    /// `c + s q / (1 + h·q)` (q = p − c, the simulator's model), the moving one rotated by
    /// `theta`, shifted, with a constant offset per pair (bias) and noise.
    fn scene(k: usize, h: [f64; 2], bias: f64, sigma: f64, seed: u64) -> (Vec<[f64; 2]>, Vec<[f64; 2]>, Vec<usize>, Vec<usize>) {
        let mut st = seed;
        let (c, s, theta) = ([-20.0, 10.0], 1.004, 0.7f64);
        let (mut fs, mut ms, mut ps, mut bs) = (vec![], vec![], vec![], vec![]);
        for p in 0..k {
            let (x0, y0) = (lcg(&mut st) * 60.0 - 30.0, lcg(&mut st) * 60.0 - 30.0);
            let a = lcg(&mut st) * std::f64::consts::TAU;
            let b = [bias * gauss(&mut st), bias * gauss(&mut st)];
            for i in 0..40 {
                let w = [x0 + a.cos() * i as f64 * 0.8, y0 + a.sin() * i as f64 * 0.8];
                let q = [w[0] - c[0], w[1] - c[1]];
                let den = 1.0 + h[0] * q[0] + h[1] * q[1];
                let fp = [c[0] + s * q[0] / den + sigma * gauss(&mut st), c[1] + s * q[1] / den + sigma * gauss(&mut st)];
                let mw = [w[0] + b[0] + sigma * gauss(&mut st) - 5.0, w[1] + b[1] + sigma * gauss(&mut st) + 3.0];
                let (ct, sn) = (theta.cos(), theta.sin());
                ms.push([ct * mw[0] - sn * mw[1], sn * mw[0] + ct * mw[1]]);
                fs.push(fp);
                ps.push(p);
                bs.push(p * BLOCKS / k);
            }
        }
        (fs, ms, ps, bs)
    }

    /// `h` as the moving camera's axes see it: the world's `h` rotated by `theta`.
    fn in_moving_axes(h: [f64; 2]) -> [f64; 2] {
        let t = 0.7f64;
        [t.cos() * h[0] - t.sin() * h[1], t.sin() * h[0] + t.cos() * h[1]]
    }

    #[test]
    fn a_two_percent_perspective_is_found_through_bias() {
        let h = [0.02 / 50.0 * 0.6, -0.02 / 50.0 * 0.8];
        let (f, m, p, b) = scene(120, h, 0.8, 0.1, 7);
        let r = perspective(&f, &m, &p, &b).unwrap().unwrap();
        let want = in_moving_axes(h);
        assert!(r.significant, "{r:?}");
        assert!((r.h[0] - want[0]).abs() < 4.0 * r.se + 2e-5 && (r.h[1] - want[1]).abs() < 4.0 * r.se + 2e-5, "{r:?} want {want:?}");
        assert!((r.at_report_range() - 0.02).abs() < 0.004, "{r:?}");
        assert!(r.se > 0.0 && r.se < 4e-5, "{r:?}");
    }

    #[test]
    fn none_is_not_significant_under_bias_and_noise() {
        for seed in 1..6 {
            let (f, m, p, b) = scene(120, [0.0, 0.0], 1.5, 0.15, seed);
            let r = perspective(&f, &m, &p, &b).unwrap().unwrap();
            assert!(!r.significant, "seed {seed}: {r:?}");
            assert!(r.at_report_range() < 0.005, "seed {seed}: {r:?}");
        }
    }

    #[test]
    fn origins_do_not_matter() {
        let h = [1e-4, 2e-4];
        let (f, m, p, b) = scene(60, h, 0.3, 0.05, 3);
        let a = perspective(&f, &m, &p, &b).unwrap().unwrap();
        let shift = |v: &[[f64; 2]], d: [f64; 2]| v.iter().map(|q| [q[0] + d[0], q[1] + d[1]]).collect::<Vec<_>>();
        let g = perspective(&shift(&f, [4.5e5, 5.7e6]), &shift(&m, [-300.0, 12.0]), &p, &b).unwrap().unwrap();
        assert!((a.h[0] - g.h[0]).abs() < 1e-9 && (a.h[1] - g.h[1]).abs() < 1e-9, "{a:?} {g:?}");
    }

    #[test]
    fn degenerate_and_bad_input() {
        assert_eq!(perspective(&[], &[], &[], &[]).unwrap(), None);
        // one pair: no within-pair fit of 6 parameters across pairs
        let f = vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]];
        assert_eq!(perspective(&f, &f, &[0; 4], &[0; 4]).unwrap(), None);
        // all on one line: singular
        let (f2, p2): (Vec<_>, Vec<_>) = (0..20).map(|i| ([i as f64, 0.0], i / 5)).unzip();
        assert_eq!(perspective(&f2, &f2, &p2, &p2).unwrap(), None);
        assert!(matches!(perspective(&f, &f[..3], &[0; 4], &[0; 4]), Err(PerspectiveError::Lengths { .. })));
        let mut g = f.clone();
        g[2][1] = f64::NAN;
        assert_eq!(perspective(&g, &f, &[0, 0, 1, 1], &[0; 4]), Err(PerspectiveError::NonFinite(2)));
    }

    /// The least-squares solve against the explicit formula on a case solvable by hand: a pure
    /// affine map (h = 0) is recovered exactly.
    #[test]
    fn an_exact_affine_map_gives_zero() {
        let mut st = 5u64;
        let (mut f, mut m, mut p, mut b) = (vec![], vec![], vec![], vec![]);
        for k in 0..30 {
            let off = [lcg(&mut st), lcg(&mut st)];
            for _ in 0..6 {
                let q = [lcg(&mut st) * 40.0, lcg(&mut st) * 40.0];
                m.push(q);
                f.push([1.01 * q[0] + 0.02 * q[1] + off[0], -0.03 * q[0] + 0.99 * q[1] + off[1]]);
                p.push(k);
                b.push(k * BLOCKS / 30);
            }
        }
        let r = perspective(&f, &m, &p, &b).unwrap().unwrap();
        assert!(r.h[0].abs() < 1e-10 && r.h[1].abs() < 1e-10, "{r:?}");
    }
}
