//! The coarse clock offset of two cameras from their activity alone: the lag that maximises the
//! cross-correlation of the two activity series, over EVERY lag the recordings allow (no search
//! range is assumed: a camera seconds, minutes or hours off, or on another epoch, is found the
//! same way).
//!
//! Each camera's activity is a step function built from weighted events: `(t, v)` adds `v` from
//! time `t` on (align.sql gives +1 when a track starts and -1 when it ends, so the activity is
//! the number of tracks in view). On bins of width `w`, with the means removed,
//!
//! ```text
//! C(L) = sum_k A[k] B[k + L] / sqrt(sum A^2 sum B^2),      dt = (o_b - o_a) + L w
//! ```
//!
//! where `o_a`, `o_b` are each camera's first event time: every bin is relative to its own
//! camera's origin, so shifting one clock by `X` moves `dt` by exactly `X` and nothing else. The
//! peak is refined to a fraction of a bin by a parabola through its neighbours.
//!
//! The estimate is coarse by nature: a road user is in both views at once only inside their
//! overlap, so the correlation peaks where the two views' activity lines up, which can be a
//! few seconds from the true offset when traffic mostly drives one way from one view into the
//! other. align.sql searches the exact offset around it (rigid_fit_scan), widening when needed.
//!
//! Complexity: O(n log n) time and O(n) memory for n = the sum of the two series' bins,
//! rounded up to a power of two (a radix-2 FFT, [`fft`]); the memory is checked against the
//! `memory_bytes` work limit before anything is allocated.

use crate::limits::{self, Exceeded};
use crate::traj::{Series, TrajError};
use std::fmt;

/// Why an activity lag could not be computed.
#[derive(Clone, Debug, PartialEq)]
pub enum XcorrError {
    /// `bin_s` not finite and positive.
    Bin(f64),
    /// An event series is not sorted, or holds NaN / infinity.
    Input(TrajError),
    /// The series need more working memory than `memory_bytes` allows.
    Memory(Exceeded),
    /// A bin count that does not fit the address space.
    TooLong(f64),
    /// The allocation failed.
    Alloc(usize),
}

impl fmt::Display for XcorrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            XcorrError::Bin(b) => write!(f, "bin_s must be a finite number > 0, got {b}"),
            XcorrError::Input(e) => write!(f, "{e}"),
            XcorrError::Memory(e) => write!(f, "{e}; use a larger bin_s"),
            XcorrError::TooLong(n) => write!(f, "the series span {n:.0} bins; use a larger bin_s"),
            XcorrError::Alloc(n) => write!(f, "could not allocate {n} bins; use a larger bin_s"),
        }
    }
}

impl std::error::Error for XcorrError {}

/// The best lag and how clearly it stands out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lag {
    /// b's clock minus a's clock at the peak (s).
    pub dt: f64,
    /// Normalised correlation at the peak (-1..1).
    pub score: f64,
    /// The best normalised correlation outside the peak's main lobe (where C > score / 2).
    pub runner_up: f64,
    /// Half the width of the main lobe (s): how sharply the peak is defined.
    pub half_width_s: f64,
}

/// The cross-correlation lag of two event series (see the module docs). `None` when either
/// series is empty or constant (no activity change: no lag is defined).
pub fn activity_lag(a: Series<'_>, b: Series<'_>, bin_s: f64) -> Result<Option<Lag>, XcorrError> {
    if !(bin_s.is_finite() && bin_s > 0.0) {
        return Err(XcorrError::Bin(bin_s));
    }
    a.validate().map_err(XcorrError::Input)?;
    b.validate().map_err(XcorrError::Input)?;
    if a.is_empty() || b.is_empty() {
        return Ok(None);
    }
    let bins = |s: Series<'_>| -> Result<usize, XcorrError> {
        let n = ((s.t[s.len() - 1] - s.t[0]) / bin_s).floor() + 2.0;
        if n > 1e12 {
            return Err(XcorrError::TooLong(n));
        }
        Ok(n as usize)
    };
    let (na, nb) = (bins(a)?, bins(b)?);
    let n = (na + nb).checked_next_power_of_two().ok_or(XcorrError::TooLong((na + nb) as f64))?;
    // four f64 vectors of n: the two spectra (re, im)
    limits::MEMORY_BYTES.check(n as u128 * 32).map_err(XcorrError::Memory)?;
    // the mean-removed series padded to n, and its energy (sum of squares)
    let series = |s: Series<'_>, len: usize| -> Result<Option<(Vec<f64>, f64)>, XcorrError> {
        let mut v = Vec::new();
        v.try_reserve_exact(n).map_err(|_| XcorrError::Alloc(n))?;
        v.resize(len, 0.0);
        for (t, w) in s.t.iter().zip(s.v) {
            v[((t - s.t[0]) / bin_s).floor() as usize] += w;
        }
        let mut acc = 0.0;
        for x in v.iter_mut() {
            acc += *x;
            *x = acc;
        }
        let mean = v.iter().sum::<f64>() / len as f64;
        v.iter_mut().for_each(|x| *x -= mean);
        let energy: f64 = v.iter().map(|x| x * x).sum();
        if energy <= 0.0 || !energy.is_finite() {
            return Ok(None);
        }
        v.resize(n, 0.0);
        Ok(Some((v, energy)))
    };
    let (Some((ar, ea)), Some((br, eb))) = (series(a, na)?, series(b, nb)?) else { return Ok(None) };
    let norm = (ea * eb).sqrt();
    let zeros = || -> Result<Vec<f64>, XcorrError> {
        let mut v = Vec::new();
        v.try_reserve_exact(n).map_err(|_| XcorrError::Alloc(n))?;
        v.resize(n, 0.0);
        Ok(v)
    };
    let (mut are, mut aim, mut bre, mut bim) = (ar, zeros()?, br, zeros()?);
    super::fft::fft(&mut are, &mut aim, false);
    super::fft::fft(&mut bre, &mut bim, false);
    // conj(A) * B, into a's buffers
    for k in 0..n {
        let (xr, xi, yr, yi) = (are[k], -aim[k], bre[k], bim[k]);
        are[k] = xr * yr - xi * yi;
        aim[k] = xr * yi + xi * yr;
    }
    drop((bre, bim));
    super::fft::fft(&mut are, &mut aim, true);
    // c[L] at index L for L >= 0, at n + L for L < 0; valid lags -(na-1) ..= nb-1
    let lag_of = |i: usize| if i < nb { i as i64 } else { i as i64 - n as i64 };
    let valid = |l: i64| l > -(na as i64) && l < nb as i64;
    let at = |l: i64| are[if l >= 0 { l as usize } else { (n as i64 + l) as usize }] / norm;
    let mut best: Option<(i64, f64)> = None;
    for i in 0..n {
        let l = lag_of(i);
        if !valid(l) {
            continue;
        }
        let c = at(l);
        // ties: the smaller |lag|, then the negative one (deterministic)
        if best.map_or(true, |(bl, bc)| c > bc || (c == bc && (l.abs(), l) < (bl.abs(), bl))) {
            best = Some((l, c));
        }
    }
    let Some((l, c)) = best else { return Ok(None) };
    // parabolic refinement through the neighbours
    let frac = if valid(l - 1) && valid(l + 1) {
        let (cm, cp) = (at(l - 1), at(l + 1));
        let den = cm - 2.0 * c + cp;
        if den < 0.0 { (0.5 * (cm - cp) / den).clamp(-0.5, 0.5) } else { 0.0 }
    } else {
        0.0
    };
    // main lobe: contiguous lags around the peak above half of it
    let (mut lo, mut hi) = (l, l);
    while valid(lo - 1) && at(lo - 1) > 0.5 * c {
        lo -= 1;
    }
    while valid(hi + 1) && at(hi + 1) > 0.5 * c {
        hi += 1;
    }
    let mut runner_up = f64::NEG_INFINITY;
    for i in 0..n {
        let q = lag_of(i);
        if valid(q) && (q < lo || q > hi) {
            runner_up = runner_up.max(at(q));
        }
    }
    Ok(Some(Lag {
        dt: (b.t[0] - a.t[0]) + (l as f64 + frac) * bin_s,
        score: c,
        runner_up: if runner_up.is_finite() { runner_up } else { 0.0 },
        half_width_s: 0.5 * (hi - lo + 1) as f64 * bin_s,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Intervals [s, e) as +1/-1 events, sorted.
    fn events(iv: &[(f64, f64)]) -> (Vec<f64>, Vec<f64>) {
        let mut e: Vec<(f64, f64)> = iv.iter().flat_map(|&(s, t)| [(s, 1.0), (t, -1.0)]).collect();
        e.sort_by(|p, q| p.partial_cmp(q).unwrap());
        e.into_iter().unzip()
    }

    /// A pseudo-random traffic of intervals (deterministic LCG).
    fn traffic(n: usize, seed: u64) -> Vec<(f64, f64)> {
        let mut s = seed;
        let mut r = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n).map(|_| {
            let t0 = r() * 1800.0;
            (t0, t0 + 3.0 + r() * 20.0)
        }).collect()
    }

    /// The slow, obviously right correlation at every lag, for the property test.
    fn slow(a: &[f64], b: &[f64]) -> Vec<(i64, f64)> {
        let (na, nb) = (a.len() as i64, b.len() as i64);
        (-(na - 1)..nb)
            .map(|l| (l, (0..na).filter(|&k| k + l >= 0 && k + l < nb).map(|k| a[k as usize] * b[(k + l) as usize]).sum()))
            .collect()
    }

    #[test]
    fn finds_any_offset_exactly_with_own_origins() {
        let iv = traffic(400, 7);
        let (ta, va) = events(&iv);
        for off in [0.0, 1.56, -37.3, 3600.0, -86400.0, 1.78e9] {
            let shifted: Vec<(f64, f64)> = iv.iter().map(|&(s, e)| (s + off, e + off)).collect();
            let (tb, vb) = events(&shifted);
            let lag = activity_lag(Series::new(&ta, &va), Series::new(&tb, &vb), 0.5).unwrap().unwrap();
            assert!((lag.dt - off).abs() < 1e-6 * (1.0 + off.abs() * 1e-9), "{off}: {lag:?}");
            assert!(lag.score > 0.99 && lag.runner_up < lag.score);
        }
    }

    #[test]
    fn partial_overlap_and_other_traffic() {
        // b sees half of a's road users (plus its own) 12.34 s later on its clock
        let iv = traffic(600, 3);
        let own = traffic(300, 99);
        let (ta, va) = events(&iv);
        let b: Vec<(f64, f64)> = iv.iter().step_by(2).map(|&(s, e)| (s + 12.34, e + 12.34)).chain(own).collect();
        let (tb, vb) = events(&b);
        let lag = activity_lag(Series::new(&ta, &va), Series::new(&tb, &vb), 0.5).unwrap().unwrap();
        assert!((lag.dt - 12.34).abs() < 0.5, "{lag:?}");
    }

    #[test]
    fn fft_correlation_equals_the_slow_one() {
        for seed in 0..20u64 {
            let iv = traffic(5 + seed as usize, seed);
            let (ta, va) = events(&iv);
            let iv2 = traffic(3 + 2 * seed as usize, seed + 100);
            let (tb, vb) = events(&iv2);
            let lag = activity_lag(Series::new(&ta, &va), Series::new(&tb, &vb), 1.0).unwrap().unwrap();
            // rebuild the binned series as the function does and correlate slowly
            let bin = |t: &[f64], v: &[f64]| {
                let n = ((t[t.len() - 1] - t[0]) / 1.0).floor() as usize + 2;
                let mut s = vec![0.0; n];
                for (x, w) in t.iter().zip(v) {
                    s[((x - t[0]) / 1.0).floor() as usize] += w;
                }
                let mut acc = 0.0;
                for x in s.iter_mut() {
                    acc += *x;
                    *x = acc;
                }
                let m = s.iter().sum::<f64>() / n as f64;
                s.iter().map(|x| x - m).collect::<Vec<f64>>()
            };
            let (sa, sb) = (bin(&ta, &va), bin(&tb, &vb));
            let norm = (sa.iter().map(|x| x * x).sum::<f64>() * sb.iter().map(|x| x * x).sum::<f64>()).sqrt();
            let c = slow(&sa, &sb);
            let max = c.iter().map(|&(_, v)| v / norm).fold(f64::NEG_INFINITY, f64::max);
            assert!((lag.score - max).abs() < 1e-9, "seed {seed}: {} vs {max}", lag.score);
        }
    }

    #[test]
    fn empty_constant_and_bad_input() {
        let (t, v) = (vec![0.0, 1.0], vec![1.0, -1.0]);
        assert_eq!(activity_lag(Series::new(&[], &[]), Series::new(&t, &v), 1.0), Ok(None));
        assert_eq!(activity_lag(Series::new(&t, &[0.0, 0.0]), Series::new(&t, &v), 1.0), Ok(None));
        assert!(matches!(activity_lag(Series::new(&t, &v), Series::new(&t, &v), 0.0), Err(XcorrError::Bin(_))));
        assert!(matches!(activity_lag(Series::new(&[1.0, 0.0], &v), Series::new(&t, &v), 1.0), Err(XcorrError::Input(_))));
        let far = [0.0, 1e15];
        assert!(matches!(activity_lag(Series::new(&far, &v), Series::new(&t, &v), 1e-3), Err(XcorrError::TooLong(_))));
        let wide = [0.0, 1e10];
        assert!(matches!(activity_lag(Series::new(&wide, &v), Series::new(&t, &v), 1.0), Err(XcorrError::Memory(_))));
    }
}
