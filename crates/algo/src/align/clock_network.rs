//! One clock drift per camera from every camera pair's drift (align.sql step 3b): a network
//! adjustment.
//!
//! Each camera pair (f, m) measures the moving camera's clock rate against the fixed one's,
//! `v_fm ≈ D_m − D_f` (ppm-sized, so first order is exact to 1e-8), with a standard error
//! `se_fm`. With the reference camera's drift 0, the cameras' drifts are the weighted least
//! squares solution of
//!
//! `min Σ_pairs (D_m − D_f − v_fm)² / se_fm²`,
//!
//! the normal equations `L D = b` of the pairs' weighted graph Laplacian (the reference's row and
//! column removed), solved by Cholesky. Their covariance is `L⁻¹`, scaled by the pairs' reduced
//! chi-square `χ² / (E − C + 1)` when above 1 (pairs that disagree more than their standard
//! errors say: each pair's own se is then too small). Whether the recording shows drift at all
//! is one test of every camera at once, `T = Dᵀ L D / scale ~ χ²_{C−1}` under no drift, against
//! the 5-sigma level ([`DRIFT_P`]: the rule a single pair had before, `|D| > 5 se`).
//!
//! Why: each pair on its own needed `|D| > 5 se`, and a camera's drift reached the reference
//! along one path of the spanning tree. On `trajdb simulate --cameras 4 --clock-drift-ppm 200`
//! (issue 38's torture cell) two of six pairs passed, neither on the tree's path, and every
//! camera was left at 0 ppm: 216 ppm off, 76 ms over 10 minutes. Together the six pairs pin
//! every camera's drift to ~15 ppm.
//!
//! A group of cameras not connected to the reference is anchored at its own smallest id (only
//! differences are measured). O(E log C + Σ C_k³) for E pairs and components of C_k cameras, at
//! most [`MAX_CAMERAS`] cameras per call.

use std::fmt;

/// The level of the test "the recording shows clock drift": a two-sided 5-sigma normal tail,
/// `2 Φ(−5)`.
pub const DRIFT_P: f64 = 5.733031437583892e-7;
/// The one-sided standard normal quantile at [`DRIFT_P`] (Wilson–Hilferty's z for the
/// chi-square bound with 2 or more degrees of freedom).
const DRIFT_Z_ONE_SIDED: f64 = 4.864648093129667;

#[derive(Clone, Debug, PartialEq)]
pub enum NetworkError {
    /// Pair `index` (1-based) has a non-finite value, or an se that is not > 0.
    Pair { index: usize, what: &'static str, value: f64 },
    /// Pair `index` (1-based) joins a camera to itself.
    SelfPair { index: usize, camera: i64 },
    /// More cameras than [`MAX_CAMERAS`].
    TooMany(usize),
}

impl fmt::Display for NetworkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NetworkError::Pair { index, what, value } => write!(f, "pairs[{index}].{what} must be finite{}, got {value}", if *what == "se" { " and > 0" } else { "" }),
            NetworkError::SelfPair { index, camera } => write!(f, "pairs[{index}] joins camera {camera} to itself"),
            NetworkError::TooMany(n) => write!(f, "pairs name {n} cameras, more than {MAX_CAMERAS} (each connected group is solved densely); pass one site's camera pairs per call"),
        }
    }
}
impl std::error::Error for NetworkError {}

/// One camera pair's measurement: `value ≈ x[moving] − x[fixed]` with standard error `se`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairMeasure {
    pub fixed: i64,
    pub moving: i64,
    pub value: f64,
    pub se: f64,
}

/// The adjusted network.
#[derive(Clone, Debug, PartialEq)]
pub struct Network {
    /// (camera, value, se), in camera order; the reference has value 0 and se 0.
    pub cameras: Vec<(i64, f64, f64)>,
    /// Σ (residual / se)² over the pairs.
    pub chi2: f64,
    /// Pairs − unknowns.
    pub dof: usize,
    /// `Dᵀ Cov⁻¹ D`: chi-square with `cameras − 1` degrees of freedom when nothing drifts.
    pub t2: f64,
    /// Whether `t2` exceeds the chi-square bound at [`DRIFT_P`].
    pub shown: bool,
}

/// The chi-square bound with `k` degrees of freedom at [`DRIFT_P`] (k = 1: 25 exactly, 5²;
/// else Wilson–Hilferty).
pub fn drift_bound(k: usize) -> f64 {
    if k <= 1 {
        return 25.0;
    }
    let k = k as f64;
    let h = 2.0 / (9.0 * k);
    k * (1.0 - h + DRIFT_Z_ONE_SIDED * h.sqrt()).powi(3)
}

/// The most cameras one call adjusts: each connected component is solved densely, `O(C³)` time
/// and `O(C²)` memory (1000 cameras: about a second and 8 MB).
pub const MAX_CAMERAS: usize = 1000;

/// The weighted least-squares adjustment (module docs). Each connected component of the pairs'
/// graph is solved on its own, anchored at `reference` when it holds it, else at its smallest
/// camera id (only differences within a component are measured, so the anchor changes no
/// difference); `t2` and `dof` add over the components. `None` when there is no pair (or the
/// weights overflow: an se below 1e-154).
pub fn adjust(pairs: &[PairMeasure], reference: i64) -> Result<Option<Network>, NetworkError> {
    for (i, p) in pairs.iter().enumerate() {
        if !p.value.is_finite() {
            return Err(NetworkError::Pair { index: i + 1, what: "value", value: p.value });
        }
        if !(p.se.is_finite() && p.se > 0.0) {
            return Err(NetworkError::Pair { index: i + 1, what: "se", value: p.se });
        }
        if p.fixed == p.moving {
            return Err(NetworkError::SelfPair { index: i + 1, camera: p.fixed });
        }
    }
    if pairs.is_empty() {
        return Ok(None);
    }
    let mut ids: Vec<i64> = pairs.iter().flat_map(|p| [p.fixed, p.moving]).collect();
    ids.sort_unstable();
    ids.dedup();
    if ids.len() > MAX_CAMERAS {
        return Err(NetworkError::TooMany(ids.len()));
    }
    let at = |c: i64| ids.binary_search(&c).expect("every camera of a pair is listed");
    let mut uf = crate::graph::UnionFind::new(ids.len());
    for p in pairs {
        uf.union(at(p.fixed), at(p.moving));
    }
    let (mut cameras, mut chi2, mut dof, mut t2, mut unknowns_all) = (Vec::with_capacity(ids.len()), 0.0, 0usize, 0.0, 0usize);
    let roots: Vec<usize> = (0..ids.len()).map(|i| uf.find(i)).collect();
    let mut comps: Vec<usize> = roots.clone();
    comps.sort_unstable();
    comps.dedup();
    for root in comps {
        let members: Vec<usize> = (0..ids.len()).filter(|&i| roots[i] == root).collect();
        let anchor = members.iter().copied().find(|&i| ids[i] == reference).unwrap_or(members[0]);
        let unknowns: Vec<usize> = members.iter().copied().filter(|&i| i != anchor).collect();
        let index = |i: usize| unknowns.binary_search(&i).ok();
        let n = unknowns.len();
        let mut l = vec![0.0; n * n];
        let mut b = vec![0.0; n];
        let used: Vec<&PairMeasure> = pairs.iter().filter(|p| roots[at(p.fixed)] == root).collect();
        for p in &used {
            let w = 1.0 / (p.se * p.se);
            if !w.is_finite() {
                return Ok(None);
            }
            let (f, m) = (index(at(p.fixed)), index(at(p.moving)));
            if let Some(m) = m {
                l[m * n + m] += w;
                b[m] += w * p.value;
            }
            if let Some(f) = f {
                l[f * n + f] += w;
                b[f] -= w * p.value;
            }
            if let (Some(f), Some(m)) = (f, m) {
                l[f * n + m] -= w;
                l[m * n + f] -= w;
            }
        }
        // the Laplacian of a connected graph without its anchor is positive definite
        let Some(chol) = cholesky(&l, n) else { return Ok(None) };
        let x = chol_solve(&chol, n, &b);
        let val = |i: usize| index(i).map_or(0.0, |k| x[k]);
        let c_chi2: f64 = used.iter().map(|p| ((val(at(p.moving)) - val(at(p.fixed)) - p.value) / p.se).powi(2)).sum();
        let c_dof = used.len().saturating_sub(n);
        let scale = if c_dof > 0 { (c_chi2 / c_dof as f64).max(1.0) } else { 1.0 };
        // x' L x / scale = x' Cov^-1 x
        let lx: Vec<f64> = (0..n).map(|i| (0..n).map(|j| l[i * n + j] * x[j]).sum()).collect();
        t2 += x.iter().zip(&lx).map(|(a, b)| a * b).sum::<f64>() / scale;
        chi2 += c_chi2;
        dof += c_dof;
        unknowns_all += n;
        for &i in &members {
            match index(i) {
                None => cameras.push((ids[i], 0.0, 0.0)),
                Some(k) => {
                    let mut e = vec![0.0; n];
                    e[k] = 1.0;
                    let col = chol_solve(&chol, n, &e);
                    cameras.push((ids[i], x[k], (col[k] * scale).sqrt()));
                }
            }
        }
    }
    cameras.sort_by_key(|c| c.0);
    Ok(Some(Network { cameras, chi2, dof, t2, shown: t2 > drift_bound(unknowns_all) }))
}

/// Lower-triangular Cholesky factor of the n×n row-major matrix `a`; None if not positive definite.
fn cholesky(a: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut g = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..=i {
            let s: f64 = a[i * n + j] - (0..j).map(|k| g[i * n + k] * g[j * n + k]).sum::<f64>();
            if i == j {
                if !(s > 0.0) {
                    return None;
                }
                g[i * n + i] = s.sqrt();
            } else {
                g[i * n + j] = s / g[j * n + j];
            }
        }
    }
    Some(g)
}

fn chol_solve(g: &[f64], n: usize, b: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; n];
    for i in 0..n {
        y[i] = (b[i] - (0..i).map(|k| g[i * n + k] * y[k]).sum::<f64>()) / g[i * n + i];
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        x[i] = (y[i] - (i + 1..n).map(|k| g[k * n + i] * x[k]).sum::<f64>()) / g[i * n + i];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pm(fixed: i64, moving: i64, value: f64, se: f64) -> PairMeasure {
        PairMeasure { fixed, moving, value, se }
    }

    #[test]
    fn consistent_pairs_give_the_cameras_back() {
        // true drifts (ppm) 0, 77, -138, -68 relative to camera 1
        let d = [(0, 77.0), (1, 0.0), (2, -138.0), (3, -68.0)];
        let v = |f: usize, m: usize| d[m].1 - d[f].1;
        let pairs = [pm(1, 0, v(1, 0), 30.0), pm(2, 0, v(2, 0), 20.0), pm(2, 1, v(2, 1), 15.0), pm(3, 0, v(3, 0), 25.0), pm(3, 2, v(3, 2), 40.0)];
        let n = adjust(&pairs, 1).unwrap().unwrap();
        for (c, x, se) in &n.cameras {
            assert!((x - d[*c as usize].1).abs() < 1e-9, "camera {c}: {x}");
            assert!(*c == 1 && *se == 0.0 || *se > 0.0 && *se < 30.0, "camera {c}: se {se}");
        }
        assert!(n.chi2 < 1e-12 && n.dof == 2 && n.shown);
    }

    /// The slow, obviously right version for two cameras: the weighted mean of the direct
    /// measurements (one pair each way counts with its sign).
    #[test]
    fn two_cameras_are_the_weighted_mean() {
        let pairs = [pm(0, 1, 10.0, 1.0), pm(1, 0, -14.0, 2.0)];
        let n = adjust(&pairs, 0).unwrap().unwrap();
        let (w1, w2) = (1.0, 0.25);
        let mean = (w1 * 10.0 + w2 * 14.0) / (w1 + w2);
        assert!((n.cameras[1].1 - mean).abs() < 1e-12);
        // the two disagree by 4 with a combined se of sqrt(5): chi2 = 16/5 > 1 scales the se
        assert!((n.chi2 - 16.0 / 5.0).abs() < 1e-9 && n.dof == 1);
        assert!((n.cameras[1].2 - (16.0 / 5.0 / (w1 + w2)).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn no_drift_is_not_shown() {
        let pairs = [pm(0, 1, 3.0, 10.0), pm(0, 2, -5.0, 10.0), pm(1, 2, -4.0, 10.0)];
        let n = adjust(&pairs, 0).unwrap().unwrap();
        assert!(!n.shown, "t2 {}", n.t2);
    }

    #[test]
    fn a_group_apart_from_the_reference_is_anchored_at_its_own_camera() {
        let pairs = [pm(0, 1, 100.0, 10.0), pm(2, 3, 50.0, 10.0)];
        let n = adjust(&pairs, 0).unwrap().unwrap();
        assert_eq!(n.cameras.iter().map(|c| (c.0, c.1)).collect::<Vec<_>>(), vec![(0, 0.0), (1, 100.0), (2, 0.0), (3, 50.0)]);
        // t2 adds over the groups: 100 + 25, two unknowns
        assert!((n.t2 - 125.0).abs() < 1e-9 && n.shown);
        // a reference in no pair: every group its own anchor
        let m = adjust(&pairs, 7).unwrap().unwrap();
        assert_eq!(m.cameras.iter().map(|c| c.1).collect::<Vec<_>>(), vec![0.0, 100.0, 0.0, 50.0]);
        assert!(adjust(&[], 0).unwrap().is_none());
    }

    #[test]
    fn too_many_cameras_are_refused() {
        let pairs: Vec<PairMeasure> = (0..MAX_CAMERAS as i64).map(|i| pm(i, i + 1, 1.0, 1.0)).collect();
        assert_eq!(adjust(&pairs, 0), Err(NetworkError::TooMany(MAX_CAMERAS + 1)));
    }

    #[test]
    fn the_bound_is_five_sigma() {
        assert_eq!(drift_bound(1), 25.0);
        // chi2(3) at 5.7e-7 is 31.81 (erfc(sqrt(x/2)) + sqrt(2x/pi) exp(-x/2) = 5.733e-7);
        // Wilson-Hilferty's 34.17 is conservative by 7 %
        assert!(drift_bound(3) > 31.81 && drift_bound(3) < 31.81 * 1.08, "{}", drift_bound(3));
    }

    #[test]
    fn bad_pairs_are_named() {
        assert!(matches!(adjust(&[pm(0, 1, f64::NAN, 1.0)], 0), Err(NetworkError::Pair { index: 1, what: "value", .. })));
        assert!(adjust(&[pm(0, 1, 1.0, 1e-200)], 0).unwrap().is_none());
        assert!(matches!(adjust(&[pm(0, 1, 1.0, 0.0)], 0), Err(NetworkError::Pair { what: "se", .. })));
        assert_eq!(adjust(&[pm(2, 2, 1.0, 1.0)], 2), Err(NetworkError::SelfPair { index: 1, camera: 2 }));
        assert!(NetworkError::Pair { index: 3, what: "se", value: 0.0 }.to_string().contains("pairs[3].se must be finite and > 0"));
    }
}
