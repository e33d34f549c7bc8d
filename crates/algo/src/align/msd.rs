//! Mean squared distance of two tracks over their common time: the evidence merge.sql weighs a
//! candidate pair with (docs/association.md), for a whole list of pairs in one call.
//!
//! For the correspondences `(a_i, b(t_i))` of [`super::correspond`] (every fixed point inside
//! the moving track's span, the moving track interpolated there, not across gaps over
//! `max_gap`), `n` = their count and
//!
//! ```text
//! msd = (1/n) Σ_i ((a_i.x − b(t_i).x)² + (a_i.y − b(t_i).y)²)      (none when n = 0)
//! ```
//!
//! summed in time order, left to right: the same floating-point result as SQL's
//! `list_avg([(c.fx - c.mx) ** 2 + (c.fy - c.my) ** 2 FOR c IN traj_correspond(a, b, max_gap)])`,
//! without building the list (the .slt test compares them bit for bit).
//!
//! # Complexity
//! O(n + m) a pair, no allocation; [`msd_pairs`] runs the pairs in parallel (rayon) on the
//! tracks in place, so a camera pair's hundreds of thousands of candidates (a crowded day)
//! never copy a trajectory per pair.

use super::correspond::each_pair;
use crate::traj::Traj;
use crate::{positive_or_inf, ParamError};
use rayon::prelude::*;

/// `(n, msd)` of `fixed` against `moving` (see the module docs); `max_gap` > 0 or `+inf`.
pub fn msd(fixed: Traj<'_>, moving: Traj<'_>, max_gap: f64) -> Result<(usize, Option<f64>), ParamError> {
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    let c = common(fixed, moving, max_gap);
    Ok((c.n, c.msd))
}

/// Two tracks over their common time: `n` correspondences, `msd`, and the mean offset
/// `(dx, dy)` = mean of `fixed − moving` (issue 38: the constant offset of two cameras' views of
/// one road user; [`crate::associate::pair`]). None when `n = 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Common {
    pub n: usize,
    pub msd: Option<f64>,
    pub dx: Option<f64>,
    pub dy: Option<f64>,
}

fn common(fixed: Traj<'_>, moving: Traj<'_>, max_gap: f64) -> Common {
    let (mut n, mut sum, mut sx, mut sy) = (0usize, 0.0f64, 0.0f64, 0.0f64);
    each_pair(fixed, moving, 0.0, max_gap, |_, _, fx, fy, mx, my| {
        let (dx, dy) = (fx - mx, fy - my);
        sum += dx * dx + dy * dy;
        sx += dx;
        sy += dy;
        n += 1;
    });
    let mean = |v: f64| (n > 0).then(|| v / n as f64);
    Common { n, msd: mean(sum), dx: mean(sx), dy: mean(sy) }
}

/// [`Common`] of `a[p]` against `b[q]` for every `(p, q)` of `pairs` (positions), in order.
pub fn msd_pairs(a: &[Traj<'_>], b: &[Traj<'_>], pairs: &[(usize, usize)], max_gap: f64) -> Result<Vec<Common>, ParamError> {
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    Ok(pairs.par_iter().map(|&(p, q)| common(a[p], b[q], max_gap)).collect())
}

#[cfg(test)]
mod tests {
    use super::super::correspond::correspond;
    use super::*;
    use crate::traj::OwnedTraj;
    use proptest::prelude::*;

    fn walk(seed: u64, n: usize, dt: f64) -> OwnedTraj {
        let mut s = seed;
        let mut rnd = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64) / ((1u64 << 53) as f64)
        };
        let mut o = OwnedTraj::default();
        let mut t = rnd() * 3.0;
        for _ in 0..n {
            o.push(t, rnd() * 50.0, rnd() * 50.0);
            t += dt * (0.5 + rnd() * 2.0);
        }
        o
    }

    proptest! {
        /// Bit for bit the mean of the squared distances of the correspondences.
        #[test]
        fn equals_the_mean_over_correspondences(seed in 0u64..1_000_000, n in 0usize..60, m in 0usize..60, gap in 0.05f64..2.0) {
            let (a, b) = (walk(seed, n, 0.1), walk(seed ^ 77, m, 0.13));
            let c = correspond(a.view(), b.view(), gap).unwrap();
            let mut sum = 0.0;
            for k in 0..c.fx.len() {
                sum += (c.fx[k] - c.mx[k]).powi(2) + (c.fy[k] - c.my[k]).powi(2);
            }
            let want = (c.fx.len(), (!c.fx.is_empty()).then(|| sum / c.fx.len() as f64));
            prop_assert_eq!(msd(a.view(), b.view(), gap).unwrap(), want);
            let got = msd_pairs(&[a.view()], &[b.view()], &[(0, 0)], gap).unwrap()[0];
            prop_assert_eq!((got.n, got.msd), want);
            // the mean offset: the mean of fixed - moving over the same correspondences
            let n = c.fx.len() as f64;
            if !c.fx.is_empty() {
                let mx = c.fx.iter().zip(&c.mx).map(|(f, m)| f - m).sum::<f64>() / n;
                let my = c.fy.iter().zip(&c.my).map(|(f, m)| f - m).sum::<f64>() / n;
                prop_assert!((got.dx.unwrap() - mx).abs() <= 1e-9 * (1.0 + mx.abs()) && (got.dy.unwrap() - my).abs() <= 1e-9 * (1.0 + my.abs()));
            } else {
                prop_assert!(got.dx.is_none() && got.dy.is_none());
            }
        }
    }

    #[test]
    fn bad_max_gap_is_an_error() {
        let a = walk(1, 3, 0.1);
        assert_eq!(msd(a.view(), a.view(), 0.0).unwrap_err().to_string(), "max_gap must be > 0, got 0");
        assert_eq!(msd(a.view(), a.view(), f64::INFINITY).unwrap(), (3, Some(0.0)));
    }
}
