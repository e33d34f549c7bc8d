//! Time-window LCSS: the thesis's `L_{ε,T,ξ}` (eq. 2.9), its similarity η (eq. 2.10) and the
//! matched pairs used by the merge step (Alg. 1 plus backtracking, section 2.3).
//!
//! Two points match when `‖a − b‖ < ε` **and** `|t_a − t_b| < T`. The result is 0 when either
//! side has fewer than ξ points. η = L / min(|A|, |B|) and lies in [0, 1].
//!
//! The 1-D form ([`series_length`] and friends) is the same with `|v_a − v_b| < ε`; the thesis
//! uses it on speeds (ε_speed = 2 m/s, T = 1 s, η ≥ 0.8) as a coordinate-free pre-match.
//!
//! Notes on the source:
//! - Alg. 1 line 10 computes `Δt ← |A[i,−1] − B[j,−1]|` with `i, j` where line 9 uses
//!   `i − 1, j − 1`: an off-by-one. We compare the times of the same two points whose
//!   distance is tested, as eq. 2.9 says.
//! - Alg. 1 fills the full N×M table. Because both trajectories are sorted by t, the points
//!   of B within T of `a_i` form one contiguous range whose ends only move right as i grows,
//!   so only that band is evaluated (see [`crate::lcss::band`]).
//!
//! # Complexity
//! O(n + m + Σ w_i) time, with w_i the number of points of B within T of a_i, and O(m)
//! memory ([`length`], [`similarity`]); [`matches`] needs O(n + Σ w_i) memory, 4 bytes a band
//! cell, checked against the limit `memory_bytes` before the work and allocated fallibly.

use super::band::{lcss_len, lcss_len_rows, table_bytes, BandTable};
use super::{LcssError, Within};
use crate::limits;
use crate::geometry::region::{clip, Region};
use crate::traj::band::{Bound, TimeBand};
use crate::traj::{Series, Traj};


/// Checked parameters of the time-window form. `epsilon` and `time_window` may be `+inf`
/// (no spatial or no temporal constraint); NaN, zero and negative values are rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeWindowParams {
    epsilon: f64,
    time_window: f64,
    min_points: usize,
}

impl TimeWindowParams {
    pub fn new(epsilon: f64, time_window: f64, min_points: i64) -> Result<Self, LcssError> {
        // `!(x > 0)` also rejects NaN.
        if !(epsilon > 0.0) {
            return Err(LcssError::Epsilon(epsilon));
        }
        if !(time_window > 0.0) {
            return Err(LcssError::TimeWindow(time_window));
        }
        if min_points < 0 {
            return Err(LcssError::MinPoints(min_points));
        }
        Ok(Self { epsilon, time_window, min_points: min_points as usize })
    }
    pub fn epsilon(&self) -> f64 {
        self.epsilon
    }
    pub fn time_window(&self) -> f64 {
        self.time_window
    }
    pub fn min_points(&self) -> usize {
        self.min_points
    }
    fn too_short(&self, n: usize, m: usize) -> bool {
        n == 0 || m == 0 || n < self.min_points || m < self.min_points
    }
}

/// The time band of eq. 2.9: for every point of A, B's points with `|t_a − t_b| < T`
/// ([`Bound::Open`]). Both inputs must be sorted.
fn time_band<'a>(a_t: &'a [f64], b_t: &'a [f64], tw: f64) -> TimeBand<'a> {
    TimeBand::new(a_t, b_t, tw, Bound::Open)
}

/// Half-open index range of the sorted times `t` that lie in `(lo, hi)`.
fn open_range(t: &[f64], lo: f64, hi: f64) -> (usize, usize) {
    let s = t.partition_point(|&v| !(v > lo));
    let e = t.partition_point(|&v| v < hi);
    (s, e.max(s))
}

/// Axis-aligned bounding box `(min_x, max_x, min_y, max_y)` of points `r` of `tr` (finite
/// coordinates, [`Traj::validate`]): plain comparisons (`f64::min` keeps NaN semantics and
/// is slower); on finite input the result is the same.
#[inline]
fn bbox(tr: Traj<'_>, r: (usize, usize)) -> (f64, f64, f64, f64) {
    let mut b = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for (&x, &y) in tr.x[r.0..r.1].iter().zip(&tr.y[r.0..r.1]) {
        b.0 = if x < b.0 { x } else { b.0 };
        b.1 = if x > b.1 { x } else { b.1 };
        b.2 = if y < b.2 { y } else { b.2 };
        b.3 = if y > b.3 { y } else { b.3 };
    }
    b
}

/// O(n + m) exact pre-check: can any point pair match at all? Only points of A within T of
/// B's time span (and vice versa) can match, and only if their bounding boxes come within ε
/// on both axes (`|dx| >= ε` already rules out `‖a − b‖ < ε`). Most time-overlapping pairs of
/// unrelated road users are rejected here without touching the band.
pub fn may_match(a: Traj<'_>, b: Traj<'_>, eps: f64, tw: f64) -> bool {
    let (Some(&b0), Some(&b1), Some(&a0), Some(&a1)) = (b.t.first(), b.t.last(), a.t.first(), a.t.last()) else {
        return false;
    };
    let ra = open_range(a.t, b0 - tw, b1 + tw);
    let rb = open_range(b.t, a0 - tw, a1 + tw);
    if ra.0 == ra.1 || rb.0 == rb.1 {
        return false;
    }
    let (ba, bb) = (bbox(a, ra), bbox(b, rb));
    // (eps = inf: no spatial constraint, also where a difference overflows to inf)
    eps == f64::INFINITY || !(ba.0 - bb.1 >= eps || bb.0 - ba.1 >= eps || ba.2 - bb.3 >= eps || bb.2 - ba.3 >= eps)
}

/// Rows per block in [`pruned_bands`].
const BLOCK: usize = 8;

/// The time band of every row of A, with whole blocks of [`BLOCK`] rows emptied when they
/// cannot match anything: the bounding box of the block's points and the bounding box of the
/// B blocks its band touches are more than ε apart on some axis. An emptied row is exactly a
/// row without matches, which leaves the LCSS table unchanged, so the result is identical;
/// the bands stay monotone (an emptied row becomes `(lo, lo)`). O(n + m).
fn pruned_bands(a: Traj<'_>, b: Traj<'_>, eps: f64, tw: f64, bands: &mut Vec<(usize, usize)>, boxes: &mut Vec<(f64, f64, f64, f64)>) -> Result<(), LcssError> {
    let (n, m) = (a.len(), b.len());
    bands.clear();
    boxes.clear();
    if bands.try_reserve(n).is_err() || boxes.try_reserve(m.div_ceil(BLOCK)).is_err() {
        return Err(LcssError::Alloc { bytes: n as u128 * 16 + m as u128 * 4 });
    }
    bands.resize(n, (0, 0));
    for (slot, band) in bands.iter_mut().zip(time_band(a.t, b.t, tw)) {
        *slot = band;
    }
    boxes.extend((0..m.div_ceil(BLOCK)).map(|k| bbox(b, (k * BLOCK, ((k + 1) * BLOCK).min(m)))));
    for r0 in (0..n).step_by(BLOCK) {
        let r1 = (r0 + BLOCK).min(n);
        let (lo, hi) = (bands[r0].0, bands[r1 - 1].1);
        if lo >= hi {
            continue;
        }
        let mut bb = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for q in &boxes[lo / BLOCK..=(hi - 1) / BLOCK] {
            bb = (bb.0.min(q.0), bb.1.max(q.1), bb.2.min(q.2), bb.3.max(q.3));
        }
        let ba = bbox(a, (r0, r1));
        if eps < f64::INFINITY && (ba.0 - bb.1 >= eps || bb.0 - ba.1 >= eps || ba.2 - bb.3 >= eps || bb.2 - ba.3 >= eps) {
            for row in &mut bands[r0..r1] {
                row.1 = row.0;
            }
        }
    }
    Ok(())
}

/// The buffers of [`pruned_bands`], kept per thread and reused (no allocation per pair once
/// a thread has seen trajectories as long); dropped after a call above [`KEEP_ROWS`] rows.
#[derive(Default)]
struct Bands {
    bands: Vec<(usize, usize)>,
    boxes: Vec<(f64, f64, f64, f64)>,
}

const KEEP_ROWS: usize = 1 << 16;

thread_local! {
    static BANDS: std::cell::RefCell<Bands> = std::cell::RefCell::new(Bands::default());
}

/// Runs `f` on the pruned bands of `a` against `b` ([`pruned_bands`]), in this thread's
/// buffers (fresh ones if they are in use).
fn with_pruned_bands<R>(a: Traj<'_>, b: Traj<'_>, eps: f64, tw: f64, f: impl FnOnce(&[(usize, usize)]) -> Result<R, LcssError>) -> Result<R, LcssError> {
    let run = |s: &mut Bands| {
        pruned_bands(a, b, eps, tw, &mut s.bands, &mut s.boxes)?;
        f(&s.bands)
    };
    BANDS.with(|cell| match cell.try_borrow_mut() {
        Ok(mut s) => {
            let r = run(&mut s);
            if a.len() > KEEP_ROWS || b.len() > KEEP_ROWS {
                *s = Bands::default();
            }
            r
        }
        Err(_) => run(&mut Bands::default()),
    })
}

/// The cells of the LCSS table inside the time band (before pruning), against the work limit
/// `lcss_cells`: `Err` before a call would run for long. O(n + m); `times` of A and B sorted.
///
/// The band has at most `n m` cells, so when `n m` is within the limit the band is not
/// counted (the answer is the same; the count is an O(n + m) pass over both time columns on
/// every call, most of which stop at [`may_match`]).
pub fn check_work(a_t: &[f64], b_t: &[f64], tw: f64) -> Result<(), LcssError> {
    if limits::LCSS_CELLS.check(a_t.len() as u128 * b_t.len() as u128).is_ok() {
        return Ok(());
    }
    limits::LCSS_CELLS.check(band_cells(a_t, b_t, tw)).map_err(LcssError::Work)
}

/// The cells of the LCSS table inside the time band (before pruning). O(n + m); sorted times.
pub fn band_cells(a_t: &[f64], b_t: &[f64], tw: f64) -> u128 {
    time_band(a_t, b_t, tw).cells()
}

/// `L_{ε,T,ξ}(A, B)` of eq. 2.9. Inputs must satisfy [`Traj::validate`]. The band's cells
/// are checked against `lcss_cells` before the work ([`check_work`], then the engine on the
/// pruned band).
pub fn length(a: Traj<'_>, b: Traj<'_>, p: &TimeWindowParams) -> Result<usize, LcssError> {
    if p.too_short(a.len(), b.len()) || !may_match(a, b, p.epsilon, p.time_window) {
        return Ok(0);
    }
    check_work(a.t, b.t, p.time_window)?;
    let w = Within::new(p.epsilon);
    with_pruned_bands(a, b, p.epsilon, p.time_window, |bands| {
        if bands.iter().all(|&(lo, hi)| lo == hi) {
            return Ok(0); // every block pruned: no point pair matches
        }
        lcss_len_rows(a.len(), b.len(), bands.iter().copied(), |i, lo, hi, hits| {
            let (ax, ay) = (a.x[i], a.y[i]);
            let pts = b.x[lo..hi].iter().zip(&b.y[lo..hi]);
            if let Some(e2) = w.squared_bound() {
                // the common case, branch-free so the row test vectorises
                hits.extend(pts.map(|(&bx, &by)| {
                    let (dx, dy) = (ax - bx, ay - by);
                    dx * dx + dy * dy < e2
                }));
            } else {
                hits.extend(pts.map(|(&bx, &by)| w.test(ax - bx, ay - by)));
            }
        })
    })
}

/// `l / min(n, m)`, and 0 when `l` is 0 (which covers empty sides).
pub fn ratio(l: usize, n: usize, m: usize) -> f64 {
    if l == 0 {
        0.0
    } else {
        l as f64 / n.min(m) as f64
    }
}

/// η of eq. 2.10: `L / min(|A|, |B|)`, 0 for an empty side or one shorter than ξ.
pub fn similarity(a: Traj<'_>, b: Traj<'_>, p: &TimeWindowParams) -> Result<f64, LcssError> {
    Ok(ratio(length(a, b, p)?, a.len(), b.len()))
}

/// The check before a traceback table is built from `bands`: the bytes it may take
/// ([`table_bytes`]) against the limit `memory_bytes`.
fn check_table(bands: impl Iterator<Item = (usize, usize)>, n: usize) -> Result<(), LcssError> {
    let cells: u128 = bands.map(|(lo, hi)| hi.saturating_sub(lo) as u128).sum();
    limits::MEMORY_BYTES.check(table_bytes(n, cells)).map_err(LcssError::Memory)
}

/// Builds the traceback table and backtracks it (a failed allocation is [`LcssError::Alloc`]).
fn traceback<B>(n: usize, m: usize, band: B, is_match: impl Fn(usize, usize) -> bool + Copy) -> Result<Vec<(usize, usize)>, LcssError>
where
    B: IntoIterator<Item = (usize, usize)>,
    B::IntoIter: Clone,
{
    let table = BandTable::build(n, m, band, is_match)?;
    Ok(table.backtrack(m, is_match))
}

/// The matched pairs `(i, j)` (0-based, increasing) of one longest common subsequence. The
/// traceback keeps the LCSS table inside the time band (after pruning; rows without a match
/// take nothing): its cells are checked against `lcss_cells` and its bytes against
/// `memory_bytes` before the work, and it is allocated fallibly ([`LcssError::Alloc`]).
pub fn matches(a: Traj<'_>, b: Traj<'_>, p: &TimeWindowParams) -> Result<Vec<(usize, usize)>, LcssError> {
    if p.too_short(a.len(), b.len()) || !may_match(a, b, p.epsilon, p.time_window) {
        return Ok(Vec::new());
    }
    let w = Within::new(p.epsilon);
    let is_match = |i: usize, j: usize| w.test(a.x[i] - b.x[j], a.y[i] - b.y[j]);
    check_work(a.t, b.t, p.time_window)?;
    with_pruned_bands(a, b, p.epsilon, p.time_window, |bands| {
        check_table(bands.iter().copied(), a.len())?;
        traceback(a.len(), b.len(), bands.iter().copied(), is_match)
    })
}

/// The positions in `a` and in `b` of the points a region kept.
type Kept = (Vec<usize>, Vec<usize>);

/// Runs `f` on `a` and `b` restricted to the points inside `region` (eq. 2.10: the lengths,
/// ξ and η are all counted inside the overlap `P^{k∩l}`), or on `a` and `b` themselves when
/// `region` is `None`; also returns the positions of the kept points in `a` and `b`.
fn restricted<R>(a: Traj<'_>, b: Traj<'_>, region: Option<&Region>, f: impl FnOnce(Traj<'_>, Traj<'_>) -> R) -> (R, Option<Kept>) {
    match region {
        None => (f(a, b), None),
        Some(r) => {
            let ((sa, ia), (sb, ib)) = (clip(a, r), clip(b, r));
            (f(sa.view(), sb.view()), Some((ia, ib)))
        }
    }
}

/// [`length`] counted inside `region` (eq. 2.10's `L` on `P^{k∩l}`).
pub fn length_in(a: Traj<'_>, b: Traj<'_>, p: &TimeWindowParams, region: Option<&Region>) -> Result<usize, LcssError> {
    restricted(a, b, region, |a, b| length(a, b, p)).0
}

/// [`similarity`] inside `region`: η of eq. 2.10 with both lengths counted inside it.
pub fn similarity_in(a: Traj<'_>, b: Traj<'_>, p: &TimeWindowParams, region: Option<&Region>) -> Result<f64, LcssError> {
    restricted(a, b, region, |a, b| similarity(a, b, p)).0
}

/// [`matches`] inside `region`, as 0-based positions into the full `a` and `b`.
pub fn matches_in(a: Traj<'_>, b: Traj<'_>, p: &TimeWindowParams, region: Option<&Region>) -> Result<Vec<(usize, usize)>, LcssError> {
    match restricted(a, b, region, |a, b| matches(a, b, p)) {
        (m, None) => m,
        (m, Some((ia, ib))) => Ok(m?.into_iter().map(|(i, j)| (ia[i], ib[j])).collect()),
    }
}

/// 1-D LCSS length on series: match when `|v_a − v_b| < ε` and `|t_a − t_b| < T` (checked
/// against `lcss_cells` by the engine).
pub fn series_length(a: Series<'_>, b: Series<'_>, p: &TimeWindowParams) -> Result<usize, LcssError> {
    if p.too_short(a.len(), b.len()) {
        return Ok(0);
    }
    let eps = p.epsilon;
    lcss_len(a.len(), b.len(), time_band(a.t, b.t, p.time_window), |i, j| (a.v[i] - b.v[j]).abs() < eps)
}

/// 1-D η: `series_length / min(|A|, |B|)`.
pub fn series_similarity(a: Series<'_>, b: Series<'_>, p: &TimeWindowParams) -> Result<f64, LcssError> {
    Ok(ratio(series_length(a, b, p)?, a.len(), b.len()))
}

/// Matched pairs of the 1-D form (checked and allocated as [`matches`]).
pub fn series_matches(a: Series<'_>, b: Series<'_>, p: &TimeWindowParams) -> Result<Vec<(usize, usize)>, LcssError> {
    if p.too_short(a.len(), b.len()) {
        return Ok(Vec::new());
    }
    let eps = p.epsilon;
    let is_match = |i: usize, j: usize| (a.v[i] - b.v[j]).abs() < eps;
    check_work(a.t, b.t, p.time_window)?;
    check_table(time_band(a.t, b.t, p.time_window), a.len())?;
    traceback(a.len(), b.len(), time_band(a.t, b.t, p.time_window), is_match)
}

#[cfg(test)]
mod tests {
    #[test]
    fn epsilon_at_the_ends_of_f64_matches_as_the_distance_does() {
        use crate::traj::OwnedTraj;
        let pt = |x: f64| {
            let mut o = OwnedTraj::default();
            o.push(0.0, x, 1.0);
            o
        };
        let sim = |a: &OwnedTraj, b: &OwnedTraj, eps: f64| similarity(a.view(), b.view(), &TimeWindowParams::new(eps, 1.0, 0).unwrap()).unwrap();
        // eps^2 underflows: identical points still match, points 2e-300 apart do not
        assert_eq!(sim(&pt(1.0), &pt(1.0), 1e-300), 1.0);
        assert_eq!(sim(&pt(0.0), &pt(2e-300), 1e-300), 0.0);
        // eps^2 overflows: 1e160 apart is within 1e200, 1e201 apart is not
        assert_eq!(sim(&pt(1.0), &pt(1e160), 1e200), 1.0);
        assert_eq!(sim(&pt(0.0), &pt(1e201), 1e200), 0.0);
        // eps = inf: no spatial constraint, even where the difference overflows
        assert_eq!(sim(&pt(-1e300), &pt(1e300), f64::INFINITY), 1.0);
        assert_eq!(sim(&pt(-1.7e308), &pt(1.7e308), f64::INFINITY), 1.0);
        let m = matches(pt(1.0).view(), pt(1.0).view(), &TimeWindowParams::new(1e-300, 1.0, 0).unwrap()).unwrap();
        assert_eq!(m, vec![(0, 0)]);
    }
    use crate::lcss::band::naive;
    use super::*;
    use proptest::prelude::*;

    /// Sorted timestamps on a coarse grid so that ties and duplicates are common.
    fn sorted_times(max: usize) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec(0u8..12, 0..max).prop_map(|mut v| {
            v.sort();
            v.into_iter().map(|k| k as f64 * 0.5).collect()
        })
    }
    fn coords(n: usize) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec((0u8..5).prop_map(|k| k as f64), n)
    }
    fn traj(max: usize) -> impl Strategy<Value = (Vec<f64>, Vec<f64>, Vec<f64>)> {
        sorted_times(max).prop_flat_map(|t| {
            let n = t.len();
            (Just(t), coords(n), coords(n))
        })
    }

    proptest! {
        #[test]
        fn time_window_matches_naive((at, ax, ay) in traj(10), (bt, bx, by) in traj(10),
                                     eps in prop::sample::select(vec![0.5, 1.0, 1.5, 3.0]),
                                     tw in prop::sample::select(vec![0.25, 0.5, 1.0, 2.0, f64::INFINITY]),
                                     xi in 0i64..4) {
            let a = Traj::new(&at, &ax, &ay);
            let b = Traj::new(&bt, &bx, &by);
            let p = TimeWindowParams::new(eps, tw, xi).unwrap();
            // Eq. 2.9 verbatim, evaluated on the full table / by recursion.
            let ok = |i: usize, j: usize| {
                (ax[i] - bx[j]).hypot(ay[i] - by[j]) < eps && (at[i] - bt[j]).abs() < tw
            };
            let short = at.len() < xi as usize || bt.len() < xi as usize;
            let want = if short { 0 } else { naive::table(at.len(), bt.len(), ok)[at.len()][bt.len()] };
            if !short && at.len() <= 7 && bt.len() <= 7 {
                prop_assert_eq!(naive::recursive(at.len(), bt.len(), ok), want);
            }
            prop_assert_eq!(length(a, b, &p).unwrap() as u32, want);
            prop_assert_eq!(length(b, a, &p).unwrap() as u32, want, "symmetry");
            // the SQL bindings' shortcut (boxes ε apart: no match) on short, scattered inputs
            if !a.validate_bounds().unwrap().within(&b.validate_bounds().unwrap(), eps) {
                prop_assert_eq!(want, 0);
            }
            let m = matches(a, b, &p).unwrap();
            prop_assert_eq!(m.len() as u32, want);
            for &(i, j) in &m { prop_assert!(ok(i, j)); }
            for w in m.windows(2) { prop_assert!(w[0].0 < w[1].0 && w[0].1 < w[1].1); }
            let s = similarity(a, b, &p).unwrap();
            prop_assert!((0.0..=1.0).contains(&s));
            // 1-D form on x only equals the 2-D form with y = 0.
            let zeros_a = vec![0.0; at.len()];
            let zeros_b = vec![0.0; bt.len()];
            let l1 = series_length(Series::new(&at, &ax), Series::new(&bt, &bx), &p).unwrap();
            let l2 = length(Traj::new(&at, &ax, &zeros_a), Traj::new(&bt, &bx, &zeros_b), &p).unwrap();
            prop_assert_eq!(l1, l2);
            prop_assert_eq!(series_matches(Series::new(&at, &ax), Series::new(&bt, &bx), &p).unwrap().len(), l1);
        }
    }

    /// Longer random walks so that the block pruning of `pruned_bands` empties some blocks.
    fn walk(max: usize) -> impl Strategy<Value = (Vec<f64>, Vec<f64>, Vec<f64>)> {
        prop::collection::vec((0u8..3, -2i8..=2, -2i8..=2), 0..max).prop_map(|steps| {
            let (mut t, mut x, mut y) = (0.0, 0.0, 0.0);
            let (mut ts, mut xs, mut ys) = (vec![], vec![], vec![]);
            for (dt, dx, dy) in steps {
                t += dt as f64 * 0.25;
                x += dx as f64;
                y += dy as f64;
                ts.push(t);
                xs.push(x);
                ys.push(y);
            }
            (ts, xs, ys)
        })
    }

    proptest! {
        #[test]
        fn pruned_long_walks_match_naive((at, ax, ay) in walk(60), (bt, bx, by) in walk(60),
                                         eps in prop::sample::select(vec![0.5, 1.5, 3.0]),
                                         tw in prop::sample::select(vec![0.3, 1.0, 4.0])) {
            let p = TimeWindowParams::new(eps, tw, 0).unwrap();
            let ok = |i: usize, j: usize| {
                (ax[i] - bx[j]).hypot(ay[i] - by[j]) < eps && (at[i] - bt[j]).abs() < tw
            };
            let want = naive::table(at.len(), bt.len(), ok)[at.len()][bt.len()];
            let (a, b) = (Traj::new(&at, &ax, &ay), Traj::new(&bt, &bx, &by));
            prop_assert_eq!(length(a, b, &p).unwrap() as u32, want);
            let m = matches(a, b, &p).unwrap();
            prop_assert_eq!(m.len() as u32, want);
            for &(i, j) in &m { prop_assert!(ok(i, j)); }
            // the SQL bindings' shortcut: boxes from the validating pass that are ε apart
            // mean no match (and every form's value for L = 0)
            if !a.validate_bounds().unwrap().within(&b.validate_bounds().unwrap(), eps) {
                prop_assert_eq!(want, 0);
            }
        }
    }

    /// Issue 19: `lcss_matches(tr, tr, 1, 'inf')` on 100k points is inside `lcss_cells` (1e10)
    /// but its traceback table (40 GB) aborted the host under a memory limit: now refused
    /// before any allocation, naming `memory_bytes` and what to shorten.
    #[test]
    fn a_huge_traceback_is_refused_before_it_is_allocated() {
        let n = 100_000;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
        let x: Vec<f64> = (0..n).map(|k| k as f64).collect();
        let y = vec![0.0; n];
        let a = Traj::new(&t, &x, &y);
        let p = TimeWindowParams::new(1.0, f64::INFINITY, 0).unwrap();
        let e = matches(a, a, &p).unwrap_err();
        assert_eq!(e, LcssError::Memory(limits::MEMORY_BYTES.check(table_bytes(n, (n * n) as u128)).unwrap_err()));
        let msg = e.to_string();
        assert!(msg.contains("memory_bytes") && msg.contains("shorten the trajectories or time_window"), "{msg}");
        let s = Series::new(&t, &x);
        assert!(matches!(series_matches(s, s, &p).unwrap_err(), LcssError::Memory(_)));
        // over lcss_cells: refused by the work limit first, without the O(n m / 64) pruning
        let long: Vec<f64> = (0..200_000).map(|k| k as f64).collect();
        let z = vec![0.0; 200_000];
        let b = Traj::new(&long, &long, &z);
        assert!(matches!(matches(b, b, &p).unwrap_err(), LcssError::Work(_)));
        // the same with a time window fits easily
        let q = TimeWindowParams::new(1.0, 0.15, 0).unwrap();
        assert_eq!(matches(a, a, &q).unwrap().len(), n);
        assert_eq!(
            LcssError::Alloc { bytes: 123 }.to_string(),
            "the LCSS table of the matched pairs could not be allocated (about 123 bytes); shorten the trajectories or time_window"
        );
    }

    /// Issue 27: every time-window form obeys lcss_cells (the engine checks the band before
    /// the work), not only the ones whose SQL binding checked it first.
    #[test]
    fn every_form_obeys_the_cell_limit() {
        use crate::limits::{with_scope, Limits};
        let t: Vec<f64> = (0..30).map(|k| k as f64).collect();
        let z = vec![0.0; 30];
        let (a, s) = (Traj::new(&t, &t, &z), Series::new(&t, &t));
        let p = TimeWindowParams::new(1.0, f64::INFINITY, 0).unwrap();
        let l = std::sync::Arc::new(Limits::default());
        l.set("lcss_cells", 899).unwrap();
        let work = |e: LcssError| matches!(e, LcssError::Work(x) if x.needed == 900);
        assert!(work(with_scope(&l, || length(a, a, &p)).unwrap_err()));
        assert!(work(with_scope(&l, || similarity_in(a, a, &p, None)).unwrap_err()));
        assert!(work(with_scope(&l, || matches(a, a, &p)).unwrap_err()));
        assert!(work(with_scope(&l, || series_length(s, s, &p)).unwrap_err()));
        assert!(work(with_scope(&l, || series_matches(s, s, &p)).unwrap_err()));
        l.set("lcss_cells", 900).unwrap();
        assert_eq!(with_scope(&l, || length(a, a, &p)), Ok(30));
        assert_eq!(with_scope(&l, || series_length(s, s, &p)), Ok(30));
    }

    #[test]
    fn params_are_checked() {
        assert_eq!(TimeWindowParams::new(-1.0, 1.0, 0).unwrap_err().to_string(), "epsilon must be > 0, got -1");
        assert!(TimeWindowParams::new(f64::NAN, 1.0, 0).is_err());
        assert_eq!(TimeWindowParams::new(1.0, 0.0, 0).unwrap_err().to_string(), "time_window must be > 0, got 0");
        assert_eq!(TimeWindowParams::new(1.0, 1.0, -2).unwrap_err().to_string(), "min_points must be >= 0, got -2");
        assert!(TimeWindowParams::new(f64::INFINITY, f64::INFINITY, 0).is_ok());
    }

    #[test]
    fn thesis_style_example() {
        // Same path, B offset 0.1 m and 0.2 s: every point matches with ε = 0.5, T = 1.
        let at: Vec<f64> = (0..10).map(|k| k as f64).collect();
        let bt: Vec<f64> = at.iter().map(|t| t + 0.2).collect();
        let ax: Vec<f64> = at.iter().map(|t| 2.0 * t).collect();
        let bx: Vec<f64> = ax.iter().map(|x| x + 0.1).collect();
        let y = vec![0.0; 10];
        let p = TimeWindowParams::new(0.5, 1.0, 3).unwrap();
        let (a, b) = (Traj::new(&at, &ax, &y), Traj::new(&bt, &bx, &y));
        assert_eq!(length(a, b, &p), Ok(10));
        assert_eq!(similarity(a, b, &p), Ok(1.0));
        assert_eq!(matches(a, b, &p).unwrap(), (0..10).map(|k| (k, k)).collect::<Vec<_>>());
        // ξ larger than either side gives 0.
        let p = TimeWindowParams::new(0.5, 1.0, 11).unwrap();
        assert_eq!(similarity(a, b, &p), Ok(0.0));
    }
}
