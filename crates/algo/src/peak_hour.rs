//! The peak hour of a traffic count and its peak hour factor (issue 39; the report's counts per
//! 15 minutes).
//!
//! The Highway Capacity Manual (HCM, 6th ed., TRB 2016, eq. 4-4): the **peak hour** is the 60
//! minutes with the largest volume V; the **peak hour factor** PHF = V / (4 · V15), where V15 is
//! the largest 15-minute volume within that hour. PHF is 1 for a uniform hour and 0.25 when the
//! whole hour arrives in one quarter; intersections typically show 0.80-0.95.
//!
//! Counts come in consecutive 15-minute bins. A bin the recording did not cover whole (the first
//! and last of a recording that does not start and end on a bin edge, or a gap) would undercount,
//! so an hour is a candidate only when its four bins are all whole; with no such hour there is no
//! peak hour (a 40-minute recording has none), not a guess.
//!
//! # Complexity
//! O(n) over the bins.

/// The peak hour of a sequence of 15-minute bins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeakHour {
    /// Index of the hour's first bin.
    pub first: usize,
    /// V: the hour's volume (sum of its four bins).
    pub volume: f64,
    /// V15: the largest bin of the hour.
    pub max_15: f64,
    /// PHF = V / (4 · V15); 0 volume gives none (no peak hour).
    pub phf: f64,
}

/// The peak hour of `bins` (consecutive 15-minute counts; `None` = a bin not covered whole):
/// the first of the four-bin windows of whole bins with the largest sum, or `None` when there is
/// no such window or every one is empty.
pub fn peak_hour(bins: &[Option<f64>]) -> Option<PeakHour> {
    let mut best: Option<PeakHour> = None;
    for first in 0..bins.len().saturating_sub(3) {
        let w: Option<Vec<f64>> = bins[first..first + 4].iter().copied().collect();
        let Some(w) = w else { continue };
        let volume: f64 = w.iter().sum();
        let max_15 = w.iter().copied().fold(0.0, f64::max);
        if volume > 0.0 && best.is_none_or(|b| volume > b.volume) {
            best = Some(PeakHour { first, volume, max_15, phf: volume / (4.0 * max_15) });
        }
    }
    best
}

/// How long the road can be empty before the recording, not the traffic, has stopped (s): ten
/// times the 99th percentile of the gaps between consecutive road users' first sightings, and at
/// least a minute. Under Poisson arrivals a gap of 10 × p99 happens by chance with probability
/// 0.01^10 per gap, never; a recording in sessions (07:00-08:05 and 16:00-17:05) shows a gap of
/// hours. The report's quarters inside such a gap are not recorded, and those it cuts are
/// partial (issue 39: an AM and a PM session of the same scene got PHF 0.79 and 0.97 when the
/// quarters around the gap counted as whole). At a quiet site (p99 = 2 min) an outage shorter than
/// 20 minutes is not seen. NaN or negative: the minute.
pub fn recording_gap_s(p99_interarrival_s: f64) -> f64 {
    let g = 10.0 * p99_interarrival_s;
    if g.is_finite() && g > 60.0 {
        g
    } else {
        60.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recording_gaps() {
        assert_eq!(recording_gap_s(2.0), 60.0);
        assert_eq!(recording_gap_s(30.0), 300.0);
        assert_eq!(recording_gap_s(f64::NAN), 60.0);
        assert_eq!(recording_gap_s(-1.0), 60.0);
    }

    #[test]
    fn hcm_example() {
        // 15-minute volumes 300, 350, 400, 450, 380: the peak hour is bins 1-4, V = 1580, V15 = 450
        let b = [300.0, 350.0, 400.0, 450.0, 380.0].map(Some);
        let p = peak_hour(&b).unwrap();
        assert_eq!((p.first, p.volume, p.max_15), (1, 1580.0, 450.0));
        assert!((p.phf - 1580.0 / 1800.0).abs() < 1e-12);
    }

    #[test]
    fn uniform_is_one_and_one_quarter_is_a_quarter() {
        assert_eq!(peak_hour(&[Some(5.0); 4]).unwrap().phf, 1.0);
        assert_eq!(peak_hour(&[Some(0.0), Some(8.0), Some(0.0), Some(0.0)]).unwrap().phf, 0.25);
    }

    #[test]
    fn partial_bins_and_short_recordings_have_none() {
        assert_eq!(peak_hour(&[Some(1.0); 3]), None);
        assert_eq!(peak_hour(&[Some(0.0); 6]), None);
        // the partial last bin is left out: the hour is the first four
        let p = peak_hour(&[Some(1.0), Some(1.0), Some(1.0), Some(1.0), None]).unwrap();
        assert_eq!(p.first, 0);
        assert_eq!(peak_hour(&[None, Some(9.0), Some(9.0), Some(9.0), None]), None);
    }

    /// Property: against the obvious search over every window.
    #[test]
    fn matches_brute_force() {
        use crate::align::test_rng::lcg;
        let mut st = 11u64;
        let mut rng = move || lcg(&mut st);
        for _ in 0..200 {
            let n = (rng() * 12.0) as usize;
            let b: Vec<Option<f64>> = (0..n).map(|_| if rng() < 0.1 { None } else { Some((rng() * 20.0).floor()) }).collect();
            let mut want: Option<(usize, f64)> = None;
            for i in 0..n.saturating_sub(3) {
                if b[i..i + 4].iter().all(Option::is_some) {
                    let v: f64 = b[i..i + 4].iter().map(|x| x.unwrap()).sum();
                    if v > 0.0 && want.is_none_or(|w| v > w.1) {
                        want = Some((i, v));
                    }
                }
            }
            assert_eq!(peak_hour(&b).map(|p| (p.first, p.volume)), want);
        }
    }
}
