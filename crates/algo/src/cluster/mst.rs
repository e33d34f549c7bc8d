//! Single linkage by Prim's minimum spanning tree on the condensed matrix (Müllner 2011,
//! "Modern hierarchical, agglomerative clustering algorithms", fig. 6; scipy's
//! `mst_single_linkage`, fastcluster's `MST_linkage_core`).
//!
//! Starting from item 0, every step adds the item `y` outside the tree whose distance to the
//! tree, `D[y] = min over tree items t of d(t, y)`, is smallest, after updating `D` with the
//! item `x` added last: `D[i] <- min(D[i], d(x, i))`. The step is recorded as `(x, y, D[y])`;
//! sorted by height (stably) and relabelled by union–find ([`super::linkage`]) these n − 1
//! edges are the single-linkage dendrogram (Müllner, theorem 3: every item added between the
//! tree end of `y`'s edge and `x` joined at a height `<= D[y]`).
//!
//! # Ties and cannot-links
//! `y` is the item with the smallest `(D[y], y)`: among equal distances the smallest index,
//! which is scipy's choice (its scan keeps the first strict minimum in index order), so the
//! steps are scipy's, ties included. `+inf` (cannot-link) is an ordinary value here: when every
//! item outside the tree is at `+inf`, the smallest index is added at height `+inf`.
//!
//! # Complexity
//! O(n²) time (every entry of the matrix is read once), O(n) memory besides the matrix (the
//! items outside the tree with their `D`, in index order, finished items marked NaN and
//! squeezed out when they are a quarter). From [`TEAM_MIN`] items on, with two or more threads,
//! the steps run on a team of threads that lives for the whole call ([`team`]): each owns every
//! T-th item and scans it at every step, and waits for the next step spinning on one counter
//! (a rayon split per step cost a few microseconds and woke sleeping workers, 20,000 times at
//! n = 20,000); below it, or on one thread, each step's scan runs in rayon chunks or serially. The items below `x` read column `x`, one cache line
//! (and, without huge pages, one page) per row: those loads are prefetched [`AHEAD`] items ahead,
//! which at n = 5,000 more than halves the time (the loads the core overlaps by itself are too
//! few to hide the memory's latency). The same pass checks every entry (NaN, negative) for
//! [`super::linkage::dendrogram_condensed`], which so needs no pass of its own.

use super::condensed::{Condensed, RawMerge};
use rayon::prelude::*;

/// Below this many items outside the tree a step is scanned on one thread: a rayon split costs a
/// few microseconds a step; at n = 5,000 on 2 cores the serial steps were as fast for single
/// linkage (0.095 s vs 0.093 s) and faster for the chain methods (0.112-0.142 s vs 0.132-0.155 s,
/// `examples/cluster_timing`; measured before the prefetch).
const PAR_MIN: usize = 8192;
/// Items per parallel chunk.
const CHUNK: usize = 2048;
/// From this many items on, the steps run on a team of threads ([`team`]).
const TEAM_MIN: usize = 4096;
/// At most this many threads in a team (the scan is bound by memory, not by cores).
const MAX_TEAM: usize = 8;
use super::condensed::AHEAD;

/// The smallest `(D, index)` of a chunk: `(distance, item, position)`; `None` if every item of
/// the chunk is finished.
type Best = Option<(f64, u32, usize)>;

fn better(a: Best, b: Best) -> Best {
    match (a, b) {
        (Some(x), Some(y)) => Some(if (y.0, y.1) < (x.0, x.1) { y } else { x }),
        (x, None) => x,
        (None, y) => y,
    }
}

/// Updates `dmin` with the distances to `x` and returns the chunk's best, and whether every
/// distance read was `>= 0` (not NaN); `base` is the position of the chunk's first item.
/// Finished items have `dmin` NaN and are never chosen.
#[inline]
fn scan(m: &Condensed<'_>, x: u32, items: &[u32], dmin: &mut [f64], base: usize) -> (Best, bool) {
    // items are increasing: those below x read column x (one per row), the others row x
    let split = items.partition_point(|&i| i < x);
    let mut best_d = f64::INFINITY;
    let mut best_k = usize::MAX;
    let xs = x as usize;
    let mut valid = true;
    // one item's step, the same on both sides of x: its distance to x lowers its dmin
    let mut step = |k: usize, d: f64| {
        valid &= d >= 0.0;
        let v = &mut dmin[k];
        if d < *v {
            *v = d;
        }
        if *v < best_d {
            best_d = *v;
            best_k = k;
        }
    };
    for k in 0..split {
        if let Some(&f) = items[..split].get(k + AHEAD) {
            m.prefetch_lower(f as usize, xs);
        }
        step(k, m.get_lower(items[k] as usize, xs));
    }
    let row = m.row(xs);
    // x itself may still be listed (finished, NaN) until the next squeeze
    let from = if split < items.len() && items[split] == x { split + 1 } else { split };
    for k in from..items.len() {
        step(k, row[items[k] as usize - xs - 1]);
    }
    if best_k == usize::MAX {
        // every live item at +inf (or none live): the first live one
        match dmin.iter().position(|v| !v.is_nan()) {
            Some(k) => best_k = k,
            None => return (None, valid),
        }
    }
    (Some((best_d, items[best_k], base + best_k)), valid)
}

/// The n − 1 Prim steps `(x, y, height)` in the order they are taken (unsorted), and whether
/// every entry of the matrix was `>= 0` and not NaN (each is read exactly once: the pair of `x`
/// and `i` when the first of them joins the tree; a NaN is never chosen).
pub(super) fn mst(m: &Condensed<'_>) -> Result<(Vec<RawMerge>, bool), std::collections::TryReserveError> {
    let threads = rayon::current_num_threads().min(MAX_TEAM);
    if threads >= 2 && m.n() >= TEAM_MIN {
        return team::mst(m, threads);
    }
    mst_rayon(m)
}

/// [`mst`] with each step's scan split in rayon chunks (or serial): what runs on one thread, or
/// below [`TEAM_MIN`] items.
fn mst_rayon(m: &Condensed<'_>) -> Result<(Vec<RawMerge>, bool), std::collections::TryReserveError> {
    let n = m.n();
    let mut steps = Vec::new();
    steps.try_reserve_exact(n.saturating_sub(1))?;
    if n < 2 {
        return Ok((steps, true));
    }
    let mut items: Vec<u32> = Vec::new();
    items.try_reserve_exact(n - 1)?;
    items.extend(1..n as u32);
    let mut dmin: Vec<f64> = Vec::new();
    dmin.try_reserve_exact(n - 1)?;
    dmin.resize(n - 1, f64::INFINITY);
    let mut finished = 0usize;
    let mut x = 0u32;
    let mut valid = true;
    for _ in 0..n - 1 {
        let (best, ok) = if items.len() >= PAR_MIN {
            items
                .par_chunks(CHUNK)
                .zip(dmin.par_chunks_mut(CHUNK))
                .enumerate()
                .map(|(c, (it, dm))| scan(m, x, it, dm, c * CHUNK))
                .reduce(|| (None, true), |a, b| (better(a.0, b.0), a.1 && b.1))
        } else {
            scan(m, x, &items, &mut dmin, 0)
        };
        valid &= ok;
        let (d, y, k) = best.expect("an item outside the tree remains");
        steps.push(RawMerge { x, y, distance: d });
        dmin[k] = f64::NAN;
        finished += 1;
        x = y;
        if finished * 4 > items.len() {
            let mut w = 0;
            for r in 0..items.len() {
                if !dmin[r].is_nan() {
                    items[w] = items[r];
                    dmin[w] = dmin[r];
                    w += 1;
                }
            }
            items.truncate(w);
            dmin.truncate(w);
            finished = 0;
        }
    }
    Ok((steps, valid))
}

/// Prim's steps on a team of threads that stays for the whole call: each thread owns every
/// T-th item (interleaved, so that each has its share of the column reads below `x` and of the
/// row reads above it) with its `D`, and scans them at every step; the smallest `(D, item)` of
/// the T parts is the step's item, as in one scan. A rayon split per step cost a few
/// microseconds and woke sleeping workers (20,000 steps at n = 20,000, each a scan of ~30 µs);
/// here the threads wait for the next step spinning on one counter. The steps, and so the
/// dendrogram, are those of the serial scan (the same minimum over the same values).
mod team {
    use super::{better, scan, Best, Condensed, RawMerge};
    use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};
    use std::sync::Mutex;

    /// One thread's items (increasing) and their `D`; finished ones are NaN until squeezed out.
    struct Part {
        items: Vec<u32>,
        dmin: Vec<f64>,
        finished: usize,
    }

    impl Part {
        fn finish(&mut self, pos: usize) {
            self.dmin[pos] = f64::NAN;
            self.finished += 1;
            if self.finished * 4 > self.items.len() {
                let mut w = 0;
                for r in 0..self.items.len() {
                    if !self.dmin[r].is_nan() {
                        self.items[w] = self.items[r];
                        self.dmin[w] = self.dmin[r];
                        w += 1;
                    }
                }
                self.items.truncate(w);
                self.dmin.truncate(w);
                self.finished = 0;
            }
        }
    }

    /// What the leader tells the team for step `go`: the item added (`x`), and which part's
    /// item was finished at the step before (part, position; part usize::MAX: none).
    struct Ctl {
        go: AtomicU64,
        x: AtomicU32,
        fin_part: AtomicUsize,
        fin_pos: AtomicUsize,
        done: AtomicU64,
        stop: AtomicBool,
        /// a member panicked: the leader stops waiting (the scope re-raises the panic)
        dead: AtomicBool,
        results: Vec<Mutex<(Best, bool)>>,
    }

    /// Waits until `ready()`, spinning, then yielding the core now and then.
    fn wait(ready: impl Fn() -> bool, ctl: &Ctl) -> bool {
        let mut spins = 0u32;
        while !ready() {
            if ctl.dead.load(Ordering::Acquire) {
                return false;
            }
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(1024) {
                std::thread::yield_now();
            } else {
                std::hint::spin_loop();
            }
        }
        true
    }

    /// Marks the team dead if its thread unwinds.
    struct Guard<'a>(&'a Ctl);
    impl Drop for Guard<'_> {
        fn drop(&mut self) {
            if std::thread::panicking() {
                self.0.dead.store(true, Ordering::Release);
            }
        }
    }

    fn member(m: &Condensed<'_>, ctl: &Ctl, me: usize, mut part: Part) {
        let _g = Guard(ctl);
        let mut step = 0u64;
        loop {
            step += 1;
            if !wait(|| ctl.go.load(Ordering::Acquire) >= step || ctl.stop.load(Ordering::Acquire), ctl) || ctl.stop.load(Ordering::Acquire) {
                return;
            }
            if ctl.fin_part.load(Ordering::Relaxed) == me {
                part.finish(ctl.fin_pos.load(Ordering::Relaxed));
            }
            let r = scan(m, ctl.x.load(Ordering::Relaxed), &part.items, &mut part.dmin, 0);
            if let Ok(mut slot) = ctl.results[me].lock() {
                *slot = r;
            }
            ctl.done.fetch_add(1, Ordering::Release);
        }
    }

    pub(super) fn mst(m: &Condensed<'_>, threads: usize) -> Result<(Vec<RawMerge>, bool), std::collections::TryReserveError> {
        let n = m.n();
        let mut steps = Vec::new();
        steps.try_reserve_exact(n - 1)?;
        let mut parts = Vec::new();
        for p in 0..threads {
            let k = (n - 1).div_ceil(threads);
            let (mut items, mut dmin) = (Vec::new(), Vec::new());
            items.try_reserve_exact(k)?;
            dmin.try_reserve_exact(k)?;
            items.extend((1 + p as u32..n as u32).step_by(threads));
            dmin.resize(items.len(), f64::INFINITY);
            parts.push(Part { items, dmin, finished: 0 });
        }
        let ctl = Ctl {
            go: AtomicU64::new(0),
            x: AtomicU32::new(0),
            fin_part: AtomicUsize::new(usize::MAX),
            fin_pos: AtomicUsize::new(0),
            done: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            dead: AtomicBool::new(false),
            results: (0..threads).map(|_| Mutex::new((None, true))).collect(),
        };
        let mut lead = parts.remove(0);
        let mut valid = true;
        std::thread::scope(|sc| {
            for (i, part) in parts.into_iter().enumerate() {
                let ctl = &ctl;
                sc.spawn(move || member(m, ctl, i + 1, part));
            }
            let _g = Guard(&ctl);
            let mut x = 0u32;
            let mut fin: (usize, usize) = (usize::MAX, 0);
            for s in 1..n as u64 {
                ctl.x.store(x, Ordering::Relaxed);
                ctl.fin_part.store(fin.0, Ordering::Relaxed);
                ctl.fin_pos.store(fin.1, Ordering::Relaxed);
                ctl.go.store(s, Ordering::Release);
                if fin.0 == 0 {
                    lead.finish(fin.1);
                }
                let (mut best, ok) = scan(m, x, &lead.items, &mut lead.dmin, 0);
                valid &= ok;
                let mut from = 0usize;
                // (a dead member: stop; the scope re-raises its panic)
                if !wait(|| ctl.done.load(Ordering::Acquire) >= s * (threads as u64 - 1), &ctl) {
                    break;
                }
                for (p, slot) in ctl.results.iter().enumerate().skip(1) {
                    let (b, ok) = slot.lock().map(|g| *g).unwrap_or((None, false));
                    valid &= ok;
                    let merged = better(best, b);
                    if merged != best {
                        from = p;
                    }
                    best = merged;
                }
                let (d, y, pos) = best.expect("an item outside the tree remains");
                steps.push(RawMerge { x, y, distance: d });
                fin = (from, pos);
                x = y;
            }
            ctl.stop.store(true, Ordering::Release);
        });
        Ok((steps, valid))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The team takes the same steps as the serial scan, ties included (distances on a
        /// coarse grid tie often; some are +inf), for any team size, also where items run out
        /// before threads.
        #[test]
        fn the_team_takes_the_serial_steps(seed in 0u64..1_000_000, n in 2usize..400, threads in 2usize..5, grid in prop::bool::ANY) {
            let mut s = seed;
            let mut rnd = || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 11) as f64) / ((1u64 << 53) as f64)
            };
            // (+inf: a cannot-link; the grid form has some)
            let d: Vec<f64> = (0..n * (n - 1) / 2).map(|_| if grid { if rnd() < 0.05 { f64::INFINITY } else { (rnd() * 5.0).floor() } } else { rnd() }).collect();
            let m = Condensed::read_only(&d, n).unwrap();
            let (a, va) = mst_rayon(&m).unwrap();
            let (b, vb) = team::mst(&m, threads).unwrap();
            prop_assert_eq!(va, vb);
            prop_assert_eq!(a.len(), b.len());
            for (x, y) in a.iter().zip(b.iter()) {
                prop_assert_eq!((x.x, x.y, x.distance.to_bits()), (y.x, y.y, y.distance.to_bits()));
            }
        }
    }
}
