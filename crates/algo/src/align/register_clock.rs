//! The clock offset of a camera pair when the cameras do not see the same point of a road user
//! (issue 38, item 2: "resolve the clock/space confound"; docs/alignment.md, "The clock offset
//! with a bias per track pair").
//!
//! The pooled fit of [`shift::joint`](super::shift::joint) finds the clock offset `dt` that
//! minimises every point pair's residual about ONE translation. When one camera sees every car
//! from behind (1 m along its line of sight) and every pedestrian at the feet, no single
//! translation fits both classes, and along the main flow a time shift looks like a translation:
//! the pooled `dt` moves to trade one against the other (61 ms on a simulated scene whose camera
//! 1 saw every car 1 m off along its x axis; the truth: 0.3 ms).
//!
//! Here `dt` is the minimum of the random-effects model's objective of
//! [`register`](super::register::register) (`f_ki = s R m_ki + T + b_k + e_ki`, `b_k ~ N(μ_c, τ²_c)`),
//! with the rotation, scale, noise σ² and the classes' spreads τ²_c held at the registration's
//! at the pooled `dt` ("conditional" likelihood), and each class with its OWN mean offset `μ_c`
//! (a camera that sees every car from behind shifts the cars' mean, not the clock):
//!
//! `J(dt) = Σ_k [ n_k · mean_i ρ(|r_ki|² / σ²) + |d_k − μ_c|² / (τ²_c + σ²/n_k) ]`
//!
//! * `r_ki` the residual of point pair i of track pair k about the pair's own means (centred as
//!   in `register`): a constant offset drops out, and so does a time shift of a straight track at
//!   constant speed; a turn or a change of speed pins `dt` whatever the track's offset;
//! * `d_k` the pair's mean offset: for the classes whose offsets scatter little (pedestrians,
//!   0.1–0.3 m) a wrong `dt` moves each pair's `d_k` by `v_k · Δdt`, along its direction of travel,
//!   and road users in several directions pin `dt`; cars (τ ≈ 1 m) weigh little;
//! * `n_k` is the pair's count of point pairs at the starting `dt`, and each pair's within-part
//!   counts as its MEAN per point times `n_k`: the number of point pairs two tracks share changes
//!   with the shift at their ends, and a plain sum would prefer the shift that pairs fewest;
//! * each squared residual is weighted by its interpolation ([`interpolation_weight`]: a moving
//!   point interpolated half-way between two samples has less noise, and `J` would prefer the
//!   shifts that interpolate);
//! * `ρ(z) = min(z, KEEP_SIGMAS²)`: a gross error costs a constant; the pairs whose offset lies
//!   beyond `OUTLIER_D2` of their class's mean at the starting shift (two road users side by
//!   side) are left out of `J` at every shift.
//!
//! The result replaces the pooled offset (the grid's centre) only when the two differ by more
//! than [`MOVE_Z`] of its standard error ([`clock_moves`], Hausman's rule): where no class is
//! seen off, the pooled fit is the more precise.
//!
//! `J` is evaluated on a grid of shifts ([`ShiftGrid`]) and its minimum refined by a parabola
//! through the neighbours; the standard error is the block jackknife (the same
//! [`BLOCKS`](super::register::BLOCKS) consecutive blocks of track pairs as `register`): every
//! block's part of `J` left out in turn, the minimum found again. The registration is then
//! fitted at the new `dt`.
//!
//! Pairs that do not have [`MIN_PAIR_POINTS`] point pairs at every shift of the grid are left
//! out of `J` (their count would change the sum).
//!
//! # Complexity
//! O(G·P) for G shifts and P points of the track pairs (each shift interpolates every pair once),
//! plus O(B·G) for the jackknife and two [`register`] calls; counted against the work limit
//! `shift_pair_fits` (as `G·P` point-pair fits, plus `register`'s own count) before any work.

use super::correspond::{correspond_into, interpolation_weight, Pairs};
use super::register::{self, Registration, BLOCKS, KEEP_SIGMAS, MIN_PAIR_POINTS, OUTLIER_D2};
use super::rigid::Transform2;
use super::shift::{Noise, ShiftError, ShiftGrid};
use crate::limits;
use crate::positive_or_inf;
use crate::traj::Traj;

/// Rounds of scan and registration: the spreads τ² and the rotation come from the registration
/// at the last round's offset (at the pooled offset, a wrong clock spreads the fast classes'
/// offsets and the first scan trusts them too little: 4 ms off in a unit test, 0.3 ms after);
/// stops when the offset moves less than half a step.
pub const CLOCK_ROUNDS: usize = 3;

/// The clock offset and the registration at it (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ClockRegistration {
    /// Moving clock minus fixed clock (s), the minimum of `J`.
    pub dt: f64,
    /// Its standard error (s): the block jackknife; infinite with fewer than
    /// [`MIN_BLOCKS`](super::register::MIN_BLOCKS) blocks.
    pub se_dt: f64,
    /// The minimum lies on the grid's first or last shift: the true offset may lie beyond.
    pub at_edge: bool,
    /// Track pairs in `J` (those with enough point pairs at every shift).
    pub pairs: usize,
    /// `dt` is this model's minimum, not the grid's centre ([`clock_moves`]).
    pub moved: bool,
    /// The registration at `dt`.
    pub registration: Registration,
}

/// Per track pair and shift: the within-part (mean capped z per point) and the mean offset.
struct Cell {
    within: f64,
    d: [f64; 2],
}

/// See the module docs. Arguments as [`register::register`], with the grid of shifts in place
/// of one `dt`; `None` when `register` gives none at the grid's centre; when no pair has point
/// pairs at every shift, the centre's registration with an infinite `se_dt`. When the minimum
/// lies on the grid's edge, `dt` is the grid's centre and the registration is at it (`at_edge`
/// says so).
pub fn register_clock(tracks: &[(Traj<'_>, Traj<'_>)], classes: &[u32], extents: &[f64], grid: &ShiftGrid, max_gap: f64, trim: f64, noise: Noise) -> Result<Option<ClockRegistration>, ShiftError> {
    let max_gap = positive_or_inf("max_gap", max_gap)?;
    let points: u128 = tracks.iter().map(|(f, m)| (f.len() + m.len()) as u128).sum();
    let shifts: Vec<f64> = grid.shifts().collect();
    limits::SHIFT_PAIR_FITS.check((CLOCK_ROUNDS as u128 + 1) * shifts.len() as u128 * points).map_err(ShiftError::RegisterWork)?;
    let Some(start) = register::register(tracks, classes, extents, grid.centre, max_gap, trim, noise)? else { return Ok(None) };
    let (mut reg, mut at) = (start.clone(), grid.centre);
    let mut round = 0;
    loop {
        let Some(fit) = scan(tracks, classes, &shifts, &reg, at, max_gap, noise) else {
            // no pair overlaps at every shift (the same at every round): the pooled offset stands
            return Ok(Some(ClockRegistration { dt: grid.centre, se_dt: f64::INFINITY, at_edge: false, pairs: 0, moved: false, registration: start }));
        };
        if fit.at_edge {
            // the minimum may lie beyond the grid: the grid's centre (the pooled fit's offset) and
            // its registration stand, flagged
            return Ok(Some(ClockRegistration { dt: grid.centre, registration: start, ..fit }));
        }
        if round == CLOCK_ROUNDS {
            return Ok(Some(settle(ClockRegistration { dt: at, registration: reg, ..fit }, grid.centre, start)));
        }
        let Some(next) = register::register(tracks, classes, extents, fit.dt, max_gap, trim, noise)? else { return Ok(None) };
        let moved = (fit.dt - at).abs();
        (reg, at) = (next, fit.dt);
        if moved < 0.5 * grid.step {
            return Ok(Some(settle(ClockRegistration { registration: reg, ..fit }, grid.centre, start)));
        }
        round += 1;
    }
}

/// Hausman's rule: the pooled offset (the grid's centre) is the efficient estimate when no class
/// is seen off by one camera, and this model's is the robust one; the robust one is used only
/// when the two differ by more than [`MOVE_Z`] of its standard error (which bounds the
/// difference's: `Var(robust − efficient) = Var(robust) − Var(efficient)`). On the shared
/// intersection's pedestrians this model's offset was 55-100 ms from the pooled one with a
/// standard error of 126-132 ms (few turns, slow walkers: little to pin a clock beyond the pooled
/// fit's common translation), and the pooled one is 9-14 ms from the truth; on a scene whose
/// camera 1 saw every car 1 m off, 61 ms apart with an error of under 1 ms.
pub fn clock_moves(pooled: f64, robust: f64, se: f64) -> bool {
    se.is_finite() && (robust - pooled).abs() > MOVE_Z * se
}

/// Standard errors by which the robust offset must differ from the pooled one to replace it
/// ([`clock_moves`]); 3: one pooled offset in 400 replaced for nothing.
pub const MOVE_Z: f64 = 3.0;

fn settle(fit: ClockRegistration, centre: f64, start: Registration) -> ClockRegistration {
    if clock_moves(centre, fit.dt, fit.se_dt) {
        ClockRegistration { moved: true, ..fit }
    } else {
        ClockRegistration { dt: centre, moved: false, registration: start, ..fit }
    }
}

/// One scan of `J` over `shifts` with the rotation, scale, noise and τ² of `reg` (fitted at
/// `at`, where each pair's count n_k is taken); the registration field is `reg` itself.
fn scan(tracks: &[(Traj<'_>, Traj<'_>)], classes: &[u32], shifts: &[f64], reg: &Registration, at: f64, max_gap: f64, noise: Noise) -> Option<ClockRegistration> {
    let (theta, s) = (reg.transform.theta, reg.transform.scale);
    // the noise per axis: the registration's RMS about each pair's own offset is over both axes
    let sigma2 = (reg.rms * reg.rms / 2.0).max(register::MIN_VAR_M2);
    let cells = profile(tracks, shifts, theta, s, sigma2, max_gap, noise)?;
    let kk = cells.len();
    // the pairs' counts at `at` (module docs: each pair's weight stays the same over the shifts)
    let mut tmp = Pairs::default();
    let n0: Vec<f64> = cells
        .iter()
        .map(|(k, _)| {
            tmp.clear();
            correspond_into(tracks[*k].0, tracks[*k].1, at, max_gap, &mut tmp);
            tmp.fx.len().max(MIN_PAIR_POINTS) as f64
        })
        .collect();
    let cls: Vec<usize> = cells.iter().map(|(k, _)| classes[*k] as usize).collect();
    let tau2 = |c: usize| reg.tau2.get(c).copied().unwrap_or(0.0);
    let block: Vec<usize> = (0..kk).map(|i| i * BLOCKS / kk.max(1)).collect();
    // J per block and shift
    let g = shifts.len();
    let mut jb = vec![vec![0.0f64; g]; BLOCKS];
    let ncls = cls.iter().copied().max().map_or(0, |c| c + 1);
    let w: Vec<f64> = (0..kk).map(|i| 1.0 / (tau2(cls[i]) + sigma2 / n0[i])).collect();
    // each class's weighted mean offset at shift j over the pairs `keep`
    let class_means = |j: usize, keep: &dyn Fn(usize) -> bool| {
        let mut acc = vec![[0.0f64; 3]; ncls];
        for i in (0..kk).filter(|&i| keep(i)) {
            let a = &mut acc[cls[i]];
            a[0] += w[i];
            a[1] += w[i] * cells[i].1[j].d[0];
            a[2] += w[i] * cells[i].1[j].d[1];
        }
        acc.iter().map(|a| if a[0] > 0.0 { Some([a[1] / a[0], a[2] / a[0]]) } else { None }).collect::<Vec<_>>()
    };
    let d2 = |i: usize, j: usize, mu: &[Option<[f64; 2]>]| {
        mu[cls[i]].map_or(0.0, |m| {
            let d = cells[i].1[j].d;
            ((d[0] - m[0]).powi(2) + (d[1] - m[1]).powi(2)) * w[i]
        })
    };
    // The pairs of J: chosen once, at the shift nearest `at`, as the pairs within OUTLIER_D2 of
    // their class's mean (two road users side by side are left out of every shift). A cap per
    // shift instead (a truncated quadratic) saturated at wrong shifts: J was flat and its
    // minimum 80-120 ms off on the shared intersection's pedestrians, where the pooled fit is 9 ms off.
    let j0 = (0..g).min_by(|&x, &y| (shifts[x] - at).abs().total_cmp(&(shifts[y] - at).abs())).unwrap_or(0);
    let first = class_means(j0, &|_| true);
    let inlier: Vec<bool> = (0..kk).map(|i| d2(i, j0, &first) <= OUTLIER_D2).collect();
    for j in 0..g {
        let mu = class_means(j, &|i| inlier[i]);
        for i in (0..kk).filter(|&i| inlier[i]) {
            jb[block[i]][j] += n0[i] * cells[i].1[j].within + d2(i, j, &mu);
        }
    }
    let total: Vec<f64> = (0..g).map(|j| jb.iter().map(|b| b[j]).sum()).collect();
    let (dt, at_edge) = minimum(&shifts, &total);
    let mut jk = Vec::new();
    for b in 0..BLOCKS {
        if !block.contains(&b) {
            continue;
        }
        let rest: Vec<f64> = (0..g).map(|j| total[j] - jb[b][j]).collect();
        jk.push(minimum(&shifts, &rest).0);
    }
    Some(ClockRegistration { dt, se_dt: register::jackknife(&jk), at_edge, pairs: kk, moved: false, registration: reg.clone() })
}

/// Every track pair's cells at every shift, for the pairs with [`MIN_PAIR_POINTS`] point pairs
/// at every shift (with the pair's index); `None` when no pair has.
fn profile(tracks: &[(Traj<'_>, Traj<'_>)], shifts: &[f64], theta: f64, s: f64, sigma2: f64, max_gap: f64, noise: Noise) -> Option<Vec<(usize, Vec<Cell>)>> {
    let rot = Transform2::new(theta, 0.0, 0.0, s);
    let cap = KEEP_SIGMAS * KEEP_SIGMAS;
    let mut tmp = Pairs::default();
    let mut out = Vec::new();
    'pairs: for (k, &(f, m)) in tracks.iter().enumerate() {
        let mut cells = Vec::with_capacity(shifts.len());
        for &dt in shifts {
            tmp.clear();
            correspond_into(f, m, dt, max_gap, &mut tmp);
            let n = tmp.fx.len();
            if n < MIN_PAIR_POINTS {
                continue 'pairs;
            }
            let mean = |v: &[f64]| v.iter().sum::<f64>() / n as f64;
            let mu = [mean(&tmp.fx), mean(&tmp.fy), mean(&tmp.mx), mean(&tmp.my)];
            let mut z = 0.0;
            for i in 0..n {
                let (qx, qy) = rot.apply(tmp.mx[i] - mu[2], tmp.my[i] - mu[3]);
                let r2 = (tmp.fx[i] - mu[0] - qx).powi(2) + (tmp.fy[i] - mu[1] - qy).powi(2);
                // z per axis pair: |r|² / σ² is χ²₂ for Gaussian noise of σ² per axis, once the
                // interpolated point's smaller noise is undone (interpolation_weight: without it
                // J prefers the shifts that interpolate half-way, 44 ms off in a unit test)
                z += (interpolation_weight(tmp.u[i], noise.fixed, noise.moving) * r2 / sigma2).min(cap);
            }
            let (qx, qy) = rot.apply(mu[2], mu[3]);
            cells.push(Cell { within: z / n as f64, d: [mu[0] - qx, mu[1] - qy] });
        }
        out.push((k, cells));
    }
    (!out.is_empty()).then_some(out)
}

/// The shift of the smallest value, refined by the parabola through its neighbours (within half
/// a step); whether it lies on the grid's first or last shift.
fn minimum(shifts: &[f64], v: &[f64]) -> (f64, bool) {
    let mut best = 0;
    for j in 1..v.len() {
        if v[j] < v[best] {
            best = j;
        }
    }
    let edge = best == 0 || best + 1 == v.len();
    if edge {
        return (shifts[best], v.len() > 1);
    }
    let (a, b, c) = (v[best - 1], v[best], v[best + 1]);
    let den = a - 2.0 * b + c;
    let step = shifts[best + 1] - shifts[best];
    let off = if den > 0.0 { (0.5 * (a - c) / den).clamp(-0.5, 0.5) } else { 0.0 };
    (shifts[best] + off * step, false)
}


#[cfg(test)]
mod tests {
    use super::*;
    use crate::align::shift;
    use crate::traj::OwnedTraj;

    use super::super::test_rng::{gauss, lcg};

    /// Pedestrians crossing in four directions and cars on a one-way road, some turning; the
    /// moving camera's clock runs `dt0` ahead; class 1 (cars) is seen `car_bias` off along the
    /// moving camera's x axis (every car from behind), class 0 (pedestrians) at 0.05 m.
    fn scene(k: usize, tf: &Transform2, dt0: f64, car_bias: f64, seed: u64) -> (Vec<OwnedTraj>, Vec<OwnedTraj>, Vec<u32>) {
        let mut st = seed;
        let inv = tf.invert();
        let (mut fs, mut ms, mut cs) = (vec![], vec![], vec![]);
        for i in 0..k {
            let cls = (i % 2) as u32;
            // pedestrians in four directions, cars one way (the flow a time shift looks like)
            let dir = if cls == 0 { (i / 2 % 4) as f64 * std::f64::consts::FRAC_PI_2 } else { 0.0 } + 0.05 * gauss(&mut st);
            let turn = if i % 5 == 0 { 0.3 } else { 0.0 };
            let v = if cls == 0 { 1.4 } else { 9.0 };
            let off = (lcg(&mut st) - 0.5) * 6.0;
            let t0 = i as f64 * 2.0;
            let (mut f, mut m) = (OwnedTraj { t: vec![], x: vec![], y: vec![] }, OwnedTraj { t: vec![], x: vec![], y: vec![] });
            let pos = |t: f64| {
                let a = dir + turn * t;
                let (c, s) = (a.cos(), a.sin());
                let along = -20.0 + v * t;
                (along * dir.cos() - off * dir.sin() + if turn > 0.0 { 3.0 * (c - dir.cos()) } else { 0.0 }, along * dir.sin() + off * dir.cos() + if turn > 0.0 { 3.0 * (s - dir.sin()) } else { 0.0 })
            };
            let (b, pb) = (if cls == 1 { car_bias } else { 0.0 }, if cls == 0 { 0.05 * gauss(&mut st) } else { 0.0 });
            for j in 0..50 {
                let t = j as f64 * 0.1;
                let (wx, wy) = pos(t);
                f.t.push(t0 + t);
                f.x.push(wx + 0.03 * gauss(&mut st));
                f.y.push(wy + 0.03 * gauss(&mut st));
                let (lx, ly) = inv.apply(wx + pb + 0.03 * gauss(&mut st), wy + 0.03 * gauss(&mut st));
                m.t.push(t0 + t + dt0);
                m.x.push(lx + b);
                m.y.push(ly);
            }
            fs.push(f);
            ms.push(m);
            cs.push(cls);
        }
        (fs, ms, cs)
    }

    #[test]
    fn a_class_seen_off_by_one_camera_does_not_move_the_clock() {
        let tf = Transform2::new(0.4, 10.0, -3.0, 1.0);
        let dt0 = 0.137;
        let (fs, ms, cs) = scene(120, &tf, dt0, 1.0, 1);
        let views: Vec<_> = fs.iter().zip(&ms).map(|(a, b)| (a.view(), b.view())).collect();
        let grid = ShiftGrid::new(0.1, 0.2, 0.005).unwrap();
        let r = register_clock(&views, &cs, &[], &grid, 0.5, 0.1, Noise::default()).unwrap().unwrap();
        assert!((r.dt - dt0).abs() < 0.005 && r.moved, "{r:?}");
        assert!(r.se_dt.is_finite() && r.se_dt < 0.01 && !r.at_edge, "{r:?}");
        // the pooled fit trades the cars' offset against the clock
        let pooled = shift::joint(&views, &grid, 0.5, 0.1, Noise::default());
        let pooled = pooled.unwrap().unwrap();
        assert!((pooled.dt - dt0).abs() > 2.0 * (r.dt - dt0).abs(), "pooled {pooled:?} ours {r:?}");
    }

    #[test]
    fn without_offsets_it_is_the_pooled_clock() {
        let tf = Transform2::new(-1.0, 3.0, 4.0, 1.0);
        let (fs, ms, cs) = scene(80, &tf, -0.042, 0.0, 2);
        let views: Vec<_> = fs.iter().zip(&ms).map(|(a, b)| (a.view(), b.view())).collect();
        let grid = ShiftGrid::new(0.0, 0.2, 0.005).unwrap();
        let pooled = shift::joint(&views, &grid, 0.5, 0.1, Noise::default()).unwrap().unwrap();
        let r = register_clock(&views, &cs, &[], &ShiftGrid::new(pooled.dt, 0.2, 0.005).unwrap(), 0.5, 0.1, Noise::default()).unwrap().unwrap();
        assert!((pooled.dt + 0.042).abs() < 0.006, "{pooled:?}");
        // the model agrees within its error: the pooled offset stands
        assert!(!r.moved && r.dt == pooled.dt, "{r:?} {pooled:?}");
    }

    #[test]
    fn edges_little_data_and_limits() {
        let tf = Transform2::new(0.0, 0.0, 0.0, 1.0);
        let (fs, ms, cs) = scene(60, &tf, 0.5, 0.0, 3);
        let views: Vec<_> = fs.iter().zip(&ms).map(|(a, b)| (a.view(), b.view())).collect();
        // the truth beyond the grid: the minimum on its edge, said so
        let r = register_clock(&views, &cs, &[], &ShiftGrid::new(0.0, 0.1, 0.01).unwrap(), 0.5, 0.1, Noise::default()).unwrap().unwrap();
        assert!(r.at_edge && r.dt == 0.0, "{r:?}");
        assert_eq!(register_clock(&[], &[], &[], &ShiftGrid::new(0.0, 0.1, 0.01).unwrap(), 0.5, 0.1, Noise::default()).unwrap(), None);
        // no pair overlaps at every shift: the centre stands, with no error
        let short: Vec<_> = views.iter().map(|(f, m)| (*f, *m)).collect();
        let r = register_clock(&short, &cs, &[], &ShiftGrid::new(0.0, 100.0, 10.0).unwrap(), 0.5, 0.1, Noise::default()).unwrap().unwrap();
        assert!(r.dt == 0.0 && r.se_dt.is_infinite() && r.pairs == 0 && !r.moved, "{r:?}");
        assert!(register_clock(&views, &cs, &[], &ShiftGrid::new(0.0, 0.1, 0.01).unwrap(), f64::NAN, 0.1, Noise::default()).is_err());
        let low = std::sync::Arc::new(limits::Limits::default());
        low.set("shift_pair_fits", 10).unwrap();
        let e = limits::with_scope(&low, || register_clock(&views, &cs, &[], &ShiftGrid::new(0.0, 0.1, 0.01).unwrap(), 0.5, 0.1, Noise::default()));
        assert!(matches!(e, Err(ShiftError::RegisterWork(_))), "{e:?}");
    }

    #[test]
    fn the_clock_moves_only_beyond_three_standard_errors() {
        assert!(clock_moves(0.0, 0.061, 0.001));
        assert!(!clock_moves(0.0, 0.055, 0.13));
        assert!(!clock_moves(0.0, 1.0, f64::INFINITY));
        assert!(!clock_moves(0.0, 0.003, 0.001));
    }

    #[test]
    fn minimum_refines_within_half_a_step() {
        let s = [0.0, 1.0, 2.0, 3.0];
        let v: Vec<f64> = s.iter().map(|x: &f64| (x - 1.3).powi(2)).collect();
        let (m, e) = minimum(&s, &v);
        assert!((m - 1.3).abs() < 1e-9 && !e);
        assert_eq!(minimum(&[5.0], &[1.0]), (5.0, false));
    }
}
