//! The candidate pairs of [`super::conflicts`]: every pair of road users that *can* have a PET
//! of at most `max_pet` or a TTC of at most `max_ttc`, found on a space-time grid of path
//! pieces, so the work grows with the road users near each other, not with every pair that
//! shares some time (at 4 times the road users per window that was 16 times the pairs; the
//! report stage grew as n^1.65 in density, benches/scale_series.py).
//!
//! Each path is cut into pieces of at most [`PIECE`] segments. A piece is the box of its points
//! widened by its reach `radius / 2 + v_max · max_ttc` (`v_max`: its fastest segment), over its
//! time span widened by `max_pet / 2` each side. A pair is a candidate when a piece of one and a
//! piece of the other meet in both. That is a superset of the kept pairs:
//!
//! * PET <= max_pet: two segments cross at a point inside both segments' boxes, at times
//!   `t_a`, `t_b` inside their spans with `|t_a − t_b| <= max_pet`; each segment lies in one
//!   piece, so those pieces' boxes overlap and their spans, widened by `max_pet / 2`, meet.
//! * TTC <= max_ttc ([`super::ttc`]): at the end `v` of an interval on which both move along
//!   one segment each (velocities `v_a`, `v_b`), `|Δp(v) + Δv τ| = radius` with `τ <= max_ttc`,
//!   so `|Δp(v)| <= radius + (|v_a| + |v_b|) max_ttc`: the two positions at the common time `v`
//!   (on those segments, inside their pieces' boxes) are within the sum of the two reaches, and
//!   the pieces' spans share `v`. (In contact, `|Δp| <= radius`, is the case τ = 0.)
//!
//! So the kept pairs, and their PET and TTC, are exactly those of the whole-path rule (the
//! property test in pairs.rs compares with all pairs).
//!
//! The grid: cells of twice the median piece size in space and twice the median widened span in
//! time, so a piece covers 1 or 2 cells a dimension. Each road user is entered once in every cell its
//! pieces cover; the road users sharing a cell are the coarse pairs, and a pair is kept when
//! two of its pieces meet (two pointers over both paths' pieces in time). A piece that would
//! cover more than [`MAX_CELLS`] cells (a very fast or very long one) is tested against every
//! piece instead. O(E log E + Σ_cells u² + Σ_pairs pieces) for E entries and u road users per
//! cell: linear in the road users at a given density in space.

use super::ConflictError;
use crate::limits::{Exceeded, MEMORY_BYTES};
use crate::traj::grid::CellAxis;
use crate::traj::Traj;
use rayon::prelude::*;

/// Segments per piece: at 5 to 25 Hz a piece spans 0.3 to 1.6 s.
pub const PIECE: usize = 8;
/// Cells a piece may cover before it is tested against every piece instead.
pub const MAX_CELLS: u64 = 4096;

/// A piece: `who` (position of its road user), its widened span and box.
#[derive(Clone, Copy, Debug)]
struct Piece {
    who: u32,
    t0: f64,
    t1: f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Piece {
    fn meets(&self, o: &Piece) -> bool {
        self.t0 <= o.t1 && o.t0 <= self.t1 && self.x0 <= o.x1 && o.x0 <= self.x1 && self.y0 <= o.y1 && o.y0 <= self.y1
    }
}

fn pieces_of(who: usize, tr: Traj<'_>, radius: f64, max_ttc: f64, half_pet: f64, out: &mut Vec<Piece>) {
    let n = tr.len();
    let mut s = 0;
    while s + 1 < n {
        let e = (s + PIECE).min(n - 1);
        // widened by a few units of rounding too: a pair whose PET is exactly max_pet meets
        let slack = 16.0 * f64::EPSILON * (tr.t[s].abs().max(tr.t[e].abs()) + half_pet);
        let (t0, t1) = (tr.t[s] - half_pet - slack, tr.t[e] + half_pet + slack);
        let mut p = Piece { who: who as u32, t0, t1, x0: f64::INFINITY, x1: f64::NEG_INFINITY, y0: f64::INFINITY, y1: f64::NEG_INFINITY };
        let mut vmax: f64 = 0.0;
        for k in s..=e {
            p.x0 = p.x0.min(tr.x[k]);
            p.x1 = p.x1.max(tr.x[k]);
            p.y0 = p.y0.min(tr.y[k]);
            p.y1 = p.y1.max(tr.y[k]);
            if k < e {
                let dt = tr.t[k + 1] - tr.t[k];
                if dt > 0.0 {
                    vmax = vmax.max((tr.x[k + 1] - tr.x[k]).hypot(tr.y[k + 1] - tr.y[k]) / dt);
                }
            }
        }
        // `0 * inf` (max_ttc 0, an unbounded speed) is no reach, not NaN
        let reach = radius / 2.0 + if max_ttc == 0.0 { 0.0 } else { vmax * max_ttc };
        p.x0 -= reach;
        p.x1 += reach;
        p.y0 -= reach;
        p.y1 += reach;
        out.push(p);
        s = e;
    }
}

/// The size of the pieces that move, for the space cells: the mean of the finite sizes up to the
/// 99th percentile, or the median when that is larger. In a queue most pieces stand still (a
/// few centimetres wide); cells of their size would enter every moving piece in hundreds of
/// cells. The mean follows the moving ones, and the cap keeps a few huge pieces (a jump
/// across the site) from making one cell of everything. The cell size decides the cost only,
/// never the pairs.
fn typical(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::INFINITY;
    }
    let n = v.len();
    let cap = *v.select_nth_unstable_by(n - 1 - n / 100, f64::total_cmp).1;
    let cnt = v.iter().filter(|&&x| x <= cap).count() as f64;
    // each term divided first: the sum of a million sizes near f64::MAX stays finite
    let mean = v.iter().filter(|&&x| x <= cap).map(|&x| x / cnt).sum::<f64>();
    let med = *v.select_nth_unstable_by(n / 2, f64::total_cmp).1;
    mean.max(med)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::INFINITY;
    }
    let k = v.len() / 2;
    *v.select_nth_unstable_by(k, f64::total_cmp).1
}

fn memory(bytes: u128) -> Result<(), ConflictError> {
    MEMORY_BYTES.check(bytes).map_err(ConflictError::Work)
}

/// An allocation the system refused, as the memory limit's error (it says how much was asked).
pub(super) fn alloc_error(bytes: u128) -> ConflictError {
    ConflictError::Work(Exceeded { name: MEMORY_BYTES.name, counts: MEMORY_BYTES.counts, needed: bytes, limit: MEMORY_BYTES.get() })
}

fn try_vec<T>(n: usize) -> Result<Vec<T>, ConflictError> {
    let bytes = (n as u128) * std::mem::size_of::<T>() as u128;
    memory(bytes)?;
    let mut v = Vec::new();
    v.try_reserve(n).map_err(|_| alloc_error(bytes))?;
    Ok(v)
}

/// Whether a piece of one road user meets a piece of the other (`p`, `q`: their pieces, each in
/// time order): two pointers over the spans, O(|p| + |q| + the span overlaps).
fn paths_meet(p: &[Piece], q: &[Piece]) -> bool {
    // the shorter path against the part of the longer one inside its span: a road user that stays
    // for hours (parked, queued) costs each passer-by the pieces of its seconds, not of its hours
    let (p, q) = if p.len() <= q.len() { (p, q) } else { (q, p) };
    let Some(first) = p.first() else { return false };
    // widened spans of one path's pieces start and end in time order
    let mut j0 = q.partition_point(|b| b.t1 < first.t0);
    for a in p {
        while j0 < q.len() && q[j0].t1 < a.t0 {
            j0 += 1;
        }
        for b in &q[j0..] {
            if b.t0 > a.t1 {
                break;
            }
            if a.meets(b) {
                return true;
            }
        }
    }
    false
}

/// The candidate pairs among `trajs` (positions; paths of 2+ points, already validated), as
/// `(p, q)` with `p < q`, sorted and distinct. `half_pet` = max_pet / 2 (may be infinite).
pub(crate) fn candidates(trajs: &[Traj<'_>], radius: f64, max_ttc: f64, half_pet: f64) -> Result<Vec<(u32, u32)>, ConflictError> {
    // every road user's pieces (in parallel), then one list: pieces[first[k]..first[k + 1]] are
    // road user k's, in time order
    let per_user: Vec<Result<Vec<Piece>, ConflictError>> = trajs
        .par_iter()
        .enumerate()
        .map(|(k, tr)| {
            let mut v = Vec::new();
            if tr.len() >= 2 {
                let n = tr.len() / PIECE + 1;
                v.try_reserve(n).map_err(|_| alloc_error((n * std::mem::size_of::<Piece>()) as u128))?;
                pieces_of(k, *tr, radius, max_ttc, half_pet, &mut v);
            }
            Ok(v)
        })
        .collect();
    let total: usize = per_user.iter().map(|r| r.as_ref().map_or(0, Vec::len)).sum();
    let mut pieces: Vec<Piece> = try_vec(total)?;
    let mut first: Vec<usize> = try_vec(trajs.len() + 1)?;
    for r in per_user {
        first.push(pieces.len());
        pieces.extend(r?);
    }
    first.push(pieces.len());
    let of = |k: u32| &pieces[first[k as usize]..first[k as usize + 1]];
    // cell sizes: what a piece spans (medians: a few fast or long pieces do not set them)
    let gs = CellAxis(2.0 * typical(pieces.iter().map(|p| (p.x1 - p.x0).max(p.y1 - p.y0)).collect()));
    let gt = CellAxis(2.0 * median(pieces.iter().map(|p| p.t1 - p.t0).collect()));
    let range = |p: &Piece| ((gt.cell(p.t0), gt.cell(p.t1)), (gs.cell(p.x0), gs.cell(p.x1)), (gs.cell(p.y0), gs.cell(p.y1)));
    let span = |(a, b): (i64, i64)| (b as i128 - a as i128 + 1) as u128;
    type Key = (i64, i64, i64);
    // the cells each road user's pieces cover, once per road user and cell (its consecutive
    // pieces mostly cover the same cells: deduplicated per road user, in parallel); pieces that
    // would cover more than MAX_CELLS cells are `wide`
    type Cells = (Vec<(Key, u32)>, Vec<u32>);
    let per_user: Vec<Result<Cells, ConflictError>> = (0..trajs.len())
        .into_par_iter()
        .map(|k| {
            let (mut cells, mut wide): Cells = (Vec::new(), Vec::new());
            for (i, p) in pieces[first[k]..first[k + 1]].iter().enumerate() {
                let (rt, rx, ry) = range(p);
                // saturating: a reach past f64::MAX spans 2^64 cells a side, 2^192 in all
                let n = span(rt).saturating_mul(span(rx)).saturating_mul(span(ry));
                if n > MAX_CELLS as u128 {
                    wide.push((first[k] + i) as u32);
                    continue;
                }
                cells.try_reserve(n as usize).map_err(|_| alloc_error(n * std::mem::size_of::<(Key, u32)>() as u128))?;
                for ct in rt.0..=rt.1 {
                    for cx in rx.0..=rx.1 {
                        for cy in ry.0..=ry.1 {
                            cells.push(((ct, cx, cy), k as u32));
                        }
                    }
                }
            }
            cells.sort_unstable();
            cells.dedup();
            Ok((cells, wide))
        })
        .collect();
    let mut n_entries = 0usize;
    for r in &per_user {
        n_entries += r.as_ref().map_or(0, |c| c.0.len());
    }
    let mut entries: Vec<(Key, u32)> = try_vec(n_entries)?;
    let mut wide: Vec<u32> = Vec::new();
    for r in per_user {
        let (c, w) = r?;
        entries.extend(c);
        wide.extend(w);
    }
    entries.par_sort_unstable();
    entries.dedup();
    // the road users sharing a cell, pair by pair
    let mut groups: Vec<(usize, usize)> = Vec::new();
    let mut s = 0;
    while s < entries.len() {
        let mut e = s + 1;
        while e < entries.len() && entries[e].0 == entries[s].0 {
            e += 1;
        }
        if e - s > 1 {
            groups.push((s, e));
        }
        s = e;
    }
    // the coarse pairs are the working table: their bytes checked before any is made
    let coarse: u128 = groups.iter().map(|&(s, e)| ((e - s) as u128) * ((e - s - 1) as u128) / 2).sum();
    memory(coarse * std::mem::size_of::<(u32, u32)>() as u128)?;
    let per_group: Vec<Result<Vec<(u32, u32)>, ConflictError>> = groups
        .par_iter()
        .map(|&(s, e)| {
            let k = (e - s) * (e - s - 1) / 2;
            let mut out = Vec::new();
            out.try_reserve(k).map_err(|_| alloc_error((k * std::mem::size_of::<(u32, u32)>()) as u128))?;
            for i in s..e {
                for j in i + 1..e {
                    out.push((entries[i].1, entries[j].1)); // sorted by who within a cell
                }
            }
            Ok(out)
        })
        .collect();
    let mut pairs: Vec<(u32, u32)> = try_vec(coarse as usize)?;
    for g in per_group {
        pairs.extend(g?);
    }
    // the wide pieces against every piece (time-sorted: only those whose span can meet)
    if !wide.is_empty() {
        let mut by_t0: Vec<u32> = (0..pieces.len() as u32).collect();
        by_t0.sort_unstable_by(|&a, &b| pieces[a as usize].t0.total_cmp(&pieces[b as usize].t0));
        for &w in &wide {
            let pw = &pieces[w as usize];
            let end = by_t0.partition_point(|&q| pieces[q as usize].t0 <= pw.t1);
            for &q in &by_t0[..end] {
                let pq = &pieces[q as usize];
                if pq.who != pw.who && pw.meets(pq) {
                    if pairs.len() == pairs.capacity() {
                        let want = pairs.len().max(1024);
                        let bytes = (2 * want * std::mem::size_of::<(u32, u32)>()) as u128;
                        memory(bytes)?;
                        pairs.try_reserve(want).map_err(|_| alloc_error(bytes))?;
                    }
                    pairs.push((pw.who.min(pq.who), pw.who.max(pq.who)));
                }
            }
        }
    }
    pairs.par_sort_unstable();
    pairs.dedup();
    // sharing a cell is not meeting: keep the pairs with two pieces that meet
    Ok(pairs.into_par_iter().filter(|&(p, q)| paths_meet(of(p), of(q))).collect())
}

#[cfg(test)]
mod tests {
    use super::super::pet::pet_checked;
    use super::super::ttc::ttc_checked;
    use super::*;
    use crate::traj::OwnedTraj;
    use proptest::prelude::*;

    /// A crowd: random walks with stops and sprints in a small square, at random rates.
    fn crowd(seed: u64, n: usize, size: f64) -> Vec<OwnedTraj> {
        let mut s = seed;
        let mut rnd = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64) / ((1u64 << 53) as f64)
        };
        (0..n)
            .map(|_| {
                let mut o = OwnedTraj::default();
                let (mut t, mut x, mut y) = (rnd() * 30.0, rnd() * size, rnd() * size);
                let len = 1 + (rnd() * 80.0) as usize;
                let dt = 0.04 + rnd() * 0.5;
                for _ in 0..len {
                    o.push(t, x, y);
                    let v = if rnd() < 0.3 { 0.0 } else if rnd() < 0.1 { 20.0 } else { 1.5 };
                    let h = rnd() * std::f64::consts::TAU;
                    t += dt;
                    x += v * dt * h.cos();
                    y += v * dt * h.sin();
                }
                o
            })
            .collect()
    }

    #[test]
    fn a_reach_past_the_grid_is_a_wide_piece_not_an_abort() {
        // max_ttc 1e20 (or an infinite speed) makes a piece span more cells than i64 holds
        let still = |x: f64, y: f64| {
            let mut o = OwnedTraj::default();
            o.push(0.0, x, y);
            o.push(1.0, x, y);
            o
        };
        let mut fast = OwnedTraj::default();
        fast.push(0.0, 0.0, 10.0);
        fast.push(1.0, 1.0, 10.0);
        let mut inf_speed = OwnedTraj::default();
        for (t, x) in [(0.0, 0.0), (5e-324, 1.0), (1.0, 2.0)] {
            inf_speed.push(t, x, 10.0);
        }
        let (a, b) = (still(0.0, 0.0), still(50.0, 0.0));
        for (c, max_ttc) in [(&fast, 1e20), (&fast, 1e300), (&inf_speed, 2.0)] {
            let v = [a.view(), b.view(), c.view()];
            let got = candidates(&v, 1.0, max_ttc, 0.5).unwrap();
            assert_eq!(got, vec![(0, 2), (1, 2)], "max_ttc {max_ttc}");
        }
    }

    proptest! {
        /// Every pair with a PET <= max_pet or a TTC <= max_ttc is a candidate (crowds, stops,
        /// sprints, one-point paths), and candidates are distinct and ordered.
        #[test]
        fn every_kept_pair_is_a_candidate(seed in 0u64..1_000_000, n in 0usize..40, size in 2.0f64..60.0,
                                          max_pet in prop::sample::select(vec![0.2, 1.0, 5.0, f64::INFINITY]),
                                          radius in 0.0f64..3.0, max_ttc in prop::sample::select(vec![0.0, 0.5, 3.0])) {
            let trajs = crowd(seed, n, size);
            let views: Vec<Traj<'_>> = trajs.iter().map(OwnedTraj::view).collect();
            let got = candidates(&views, radius, max_ttc, max_pet / 2.0).unwrap();
            prop_assert!(got.windows(2).all(|w| w[0] < w[1]) && got.iter().all(|&(p, q)| p < q));
            for p in 0..n {
                for q in p + 1..n {
                    if views[p].len() < 2 || views[q].len() < 2 {
                        continue;
                    }
                    let kept = pet_checked(views[p], views[q], max_pet, &super::super::pet::Budget::new(u64::MAX)).unwrap().is_some()
                        || ttc_checked(views[p], views[q], radius).is_some_and(|c| c.ttc <= max_ttc);
                    if kept {
                        prop_assert!(got.binary_search(&(p as u32, q as u32)).is_ok(), "pair ({p}, {q}) kept but not a candidate");
                    }
                }
            }
        }
    }
}
