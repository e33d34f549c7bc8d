//! Each source track's constant offset within one road user (issue 38, fusion; docs/fusion.md,
//! "Sources that see different points").
//!
//! Two cameras see different points of one road user (a car's front and its back, 0.5–2 m apart)
//! for as long as both see it. Fused as they are, the path lies between the two where both see
//! it and jumps to each alone where only one does. Here every source `a` (one camera's track of
//! the road user) gets an offset `o_a` such that `source_a − o_a` are views of one point:
//!
//! * for every two sources that overlap in time, `d_ab` = the mean of `a − b` over their common
//!   time (each interpolated at the other's times, both ways: [`correspond`]), over `n_ab` point
//!   pairs;
//! * the offsets minimise `Σ n_ab |o_a − o_b − d_ab|²` with `Σ o_a = 0` over each group of sources
//!   linked by common time: the least-squares solution of the differences (any `o + c` fits them
//!   as well; the constraint picks the one whose **reference point is the mean of the sources'
//!   points**: with cameras on several sides of a car, near its centre);
//! * a source that shares no time with another keeps offset 0, and so does every source of a
//!   road user of more than [`MAX_SOURCES`] sources (`n_common` then 0 too).
//!
//! The fused path of the de-biased observations then follows one point of the road user
//! throughout: no jump where a camera's view begins or ends.
//!
//! # Complexity
//! O(Σ (n_a + n_b)) for the interpolations of every pair of sources that overlap in time (the
//! pairs are found by a sweep over the sources' time spans) and O(m³) to solve a group of m ≤
//! [`MAX_SOURCES`] sources.

use crate::align::correspond::correspond;
use crate::traj::Traj;
use crate::{positive_or_inf, ParamError};

/// The most sources solved (a road user seen by more tracks keeps its offsets 0):
/// 64 sources is 64³ = 262k operations, far beyond any road user (2–6 sources in practice).
pub const MAX_SOURCES: usize = 64;
/// Two sources need this many point pairs in common for their difference to count.
pub const MIN_COMMON: usize = 3;

/// The offset of one source (m) and the point pairs it shares with the others.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SourceOffset {
    pub dx: f64,
    pub dy: f64,
    pub n_common: usize,
}

/// `Σ (a − b̂)` over a's times, and the count, b interpolated (max_gap as [`correspond`]).
fn diff_sum(a: Traj<'_>, b: Traj<'_>, max_gap: f64) -> Result<([f64; 2], usize), ParamError> {
    let p = correspond(a, b, max_gap)?;
    let mut s = [0.0; 2];
    for i in 0..p.fx.len() {
        s[0] += p.fx[i] - p.mx[i];
        s[1] += p.fy[i] - p.my[i];
    }
    Ok((s, p.fx.len()))
}

/// Solves `A x = b` (m × m, row-major) by Gaussian elimination with partial pivoting, for two
/// right-hand sides at once; `None` when singular.
fn solve(mut a: Vec<f64>, mut b: Vec<[f64; 2]>, m: usize) -> Option<Vec<[f64; 2]>> {
    for col in 0..m {
        let piv = (col..m).max_by(|&i, &j| a[i * m + col].abs().total_cmp(&a[j * m + col].abs()))?;
        if !(a[piv * m + col].abs() > 1e-300) {
            return None;
        }
        if piv != col {
            for k in 0..m {
                a.swap(col * m + k, piv * m + k);
            }
            b.swap(col, piv);
        }
        for r in col + 1..m {
            let f = a[r * m + col] / a[col * m + col];
            if f != 0.0 {
                for k in col..m {
                    a[r * m + k] -= f * a[col * m + k];
                }
                for ax in 0..2 {
                    b[r][ax] -= f * b[col][ax];
                }
            }
        }
    }
    let mut x = vec![[0.0; 2]; m];
    for r in (0..m).rev() {
        for ax in 0..2 {
            let mut s = b[r][ax];
            for k in r + 1..m {
                s -= a[r * m + k] * x[k][ax];
            }
            x[r][ax] = s / a[r * m + r];
        }
    }
    Some(x)
}

/// See the module docs: one offset per source, in the order given. `max_gap`: the longest gap
/// (s) interpolated across (+inf: any).
pub fn source_offsets(sources: &[Traj<'_>], max_gap: f64) -> Result<Vec<SourceOffset>, ParamError> {
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    let k = sources.len();
    let mut out = vec![SourceOffset { dx: 0.0, dy: 0.0, n_common: 0 }; k];
    // more sources than can be solved: offsets 0 at once (the hostile probe's 20,000 sources made
    // k² pairs, 2.7 GB, before the group size was looked at)
    if k > MAX_SOURCES {
        return Ok(out);
    }
    // pairs that overlap in time: a sweep over the spans, sorted by start
    let span = |s: &Traj<'_>| if s.is_empty() { None } else { Some((s.t[0], s.t[s.len() - 1])) };
    let mut order: Vec<(f64, f64, usize)> = sources.iter().enumerate().filter_map(|(i, s)| span(s).map(|(a, b)| (a, b, i))).collect();
    order.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)));
    let mut edges: Vec<(usize, usize, [f64; 2], f64)> = Vec::new();
    for (p, &(_, e0, a)) in order.iter().enumerate() {
        for &(s1, _, b) in &order[p + 1..] {
            if s1 > e0 {
                break;
            }
            let (sab, nab) = diff_sum(sources[a], sources[b], max_gap)?;
            let (sba, nba) = diff_sum(sources[b], sources[a], max_gap)?;
            let n = nab + nba;
            if n < MIN_COMMON {
                continue;
            }
            let d = [(sab[0] - sba[0]) / n as f64, (sab[1] - sba[1]) / n as f64];
            if let Some(&v) = d.iter().find(|v| !v.is_finite()) {
                // coordinates near ±1.8e308 whose differences overflow
                return Err(ParamError { name: "sources", rule: "made of coordinates whose differences are finite (within ±1e300)", value: v });
            }
            let (lo, hi, d) = if a < b { (a, b, d) } else { (b, a, [-d[0], -d[1]]) };
            edges.push((lo, hi, d, n as f64));
            out[a].n_common += n;
            out[b].n_common += n;
        }
    }
    // groups linked by common time (union-find)
    let mut parent: Vec<usize> = (0..k).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for &(a, b, _, _) in &edges {
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        if ra != rb {
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let roots: Vec<usize> = (0..k).map(|i| find(&mut parent, i)).collect();
    let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = std::collections::BTreeMap::new();
    for (i, &r) in roots.iter().enumerate() {
        groups.entry(r).or_default().push(i);
    }
    for members in groups.values().filter(|g| g.len() >= 2) {
        let m = members.len();
        let pos = |i: usize| members.binary_search(&i).ok();
        // normal equations L o = Σ w d, plus c·11ᵀ (c: the mean weight) for Σ o = 0
        let mut a = vec![0.0; m * m];
        let mut rhs = vec![[0.0; 2]; m];
        let mut wsum = 0.0;
        for &(x, y, d, w) in edges.iter().filter(|e| roots[e.0] == roots[members[0]]) {
            let (i, j) = (pos(x).unwrap(), pos(y).unwrap());
            a[i * m + i] += w;
            a[j * m + j] += w;
            a[i * m + j] -= w;
            a[j * m + i] -= w;
            for ax in 0..2 {
                rhs[i][ax] += w * d[ax];
                rhs[j][ax] -= w * d[ax];
            }
            wsum += w;
        }
        let c = wsum / m as f64;
        a.iter_mut().for_each(|v| *v += c);
        if let Some(o) = solve(a, rhs, m) {
            for (q, &i) in members.iter().enumerate() {
                out[i].dx = o[q][0];
                out[i].dy = o[q][1];
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traj::OwnedTraj;

    fn line(t0: f64, t1: f64, rate: f64, off: [f64; 2]) -> OwnedTraj {
        let mut tr = OwnedTraj { t: vec![], x: vec![], y: vec![] };
        let mut t = t0;
        while t <= t1 + 1e-9 {
            tr.t.push(t);
            tr.x.push(8.0 * t + 0.3 * (t * 0.7).sin() + off[0]);
            tr.y.push(2.0 * t + off[1]);
            t += 1.0 / rate;
        }
        tr
    }

    #[test]
    fn three_sources_get_their_offsets_about_their_mean() {
        // three cameras, each seeing another point, partly overlapping in time (a chain a-b-c)
        let offs = [[1.0, 0.0], [-0.5, 0.5], [0.2, -1.1]];
        let a = line(0.0, 6.0, 10.0, offs[0]);
        let b = line(4.0, 12.0, 7.0, offs[1]);
        let c = line(10.0, 15.0, 10.0, offs[2]);
        let o = source_offsets(&[a.view(), b.view(), c.view()], 0.5).unwrap();
        let mean = [(offs[0][0] + offs[1][0] + offs[2][0]) / 3.0, (offs[0][1] + offs[1][1] + offs[2][1]) / 3.0];
        for (g, w) in o.iter().zip(offs) {
            assert!((g.dx - (w[0] - mean[0])).abs() < 1e-3 && (g.dy - (w[1] - mean[1])).abs() < 1e-3, "{o:?}");
            assert!(g.n_common > 0);
        }
        let s: f64 = o.iter().map(|g| g.dx).sum();
        assert!(s.abs() < 1e-9);
    }

    #[test]
    fn sources_without_common_time_keep_zero_and_bad_gaps_are_refused() {
        let a = line(0.0, 3.0, 10.0, [1.0, 0.0]);
        let b = line(5.0, 8.0, 10.0, [0.0, 0.0]);
        let o = source_offsets(&[a.view(), b.view()], 0.5).unwrap();
        assert!(o.iter().all(|g| g.dx == 0.0 && g.dy == 0.0 && g.n_common == 0));
        assert_eq!(source_offsets(&[], 0.5).unwrap(), vec![]);
        assert!(source_offsets(&[a.view()], 0.0).is_err());
        let e = OwnedTraj { t: vec![], x: vec![], y: vec![] };
        assert_eq!(source_offsets(&[e.view(), a.view()], 0.5).unwrap().len(), 2);
    }

    #[test]
    fn too_many_sources_or_overflowing_coordinates() {
        let many: Vec<OwnedTraj> = (0..MAX_SOURCES + 1).map(|k| line(0.0, 1.0, 10.0, [k as f64, 0.0])).collect();
        let views: Vec<_> = many.iter().map(|t| t.view()).collect();
        assert!(source_offsets(&views, 0.5).unwrap().iter().all(|o| o.dx == 0.0 && o.n_common == 0));
        let a = OwnedTraj { t: vec![0.0, 1.0, 2.0], x: vec![1.7e308; 3], y: vec![0.0; 3] };
        let b = OwnedTraj { t: vec![0.0, 1.0, 2.0], x: vec![-1.7e308; 3], y: vec![0.0; 3] };
        assert_eq!(source_offsets(&[a.view(), b.view()], 0.5).unwrap_err().name, "sources");
    }

    proptest::proptest! {
        /// Against the obvious version for two sources: o_a = d/2, o_b = -d/2, d the mean of the
        /// two directions' differences.
        #[test]
        fn two_sources_split_their_difference(dx in -2.0f64..2.0, dy in -2.0f64..2.0, t0 in 0.0f64..3.0, rate in 2.0f64..20.0) {
            let a = line(0.0, 5.0, 10.0, [dx, dy]);
            let b = line(t0, 8.0, rate, [0.0, 0.0]);
            let o = source_offsets(&[a.view(), b.view()], 1.0).unwrap();
            let (s1, n1) = diff_sum(a.view(), b.view(), 1.0).unwrap();
            let (s2, n2) = diff_sum(b.view(), a.view(), 1.0).unwrap();
            let n = (n1 + n2) as f64;
            proptest::prop_assume!(n1 + n2 >= MIN_COMMON);
            let d = [(s1[0] - s2[0]) / n, (s1[1] - s2[1]) / n];
            proptest::prop_assert!((o[0].dx - d[0] / 2.0).abs() < 1e-9 && (o[1].dy + d[1] / 2.0).abs() < 1e-9);
        }
    }
}
