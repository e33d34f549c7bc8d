//! Times trajdb's LCSS called directly from Rust on a batch of pairs written by
//! `benches/peers_lcss.py`, and writes the per-pair results back for the equality check.
//!
//! ```text
//! cargo run --release --no-default-features --example lcss_pairs -- PAIRS.bin OUT.bin index DELTA EPS
//! cargo run --release --no-default-features --example lcss_pairs -- PAIRS.bin OUT.bin time EPS T
//! ```
//! PAIRS.bin: u32 count, then per pair: u32 n, n×(t, x, y) f64, u32 m, m×(t, x, y) f64 (little endian).
//! OUT.bin: count × f64 similarity. Prints `{"pairs": N, "single_thread_s": .., "parallel_s": .., "threads": ..}`.
//!
//! Profiling modes (same arguments as `time`): `prefilter` (only `may_match`), `validate` (only
//! the input checks of both sides), `sqlpath` (what `lcss_length` does per row in SQL: validate
//! with bounding boxes, the work check, the box shortcut, then `length`). `REPS=N` in the
//! environment sets the repetitions (default 10); a small PAIRS.bin that fits in cache times the
//! kernel as SQL sees it (DuckDB hands over a chunk it has just materialised).

use rayon::prelude::*;
use std::time::Instant;
use trajdb_algo::lcss::time_window::{self as lcss, TimeWindowParams};
use trajdb_algo::lcss::index::{self as lcss_index, IndexParams};
use trajdb_algo::traj::OwnedTraj;

fn read_u32(b: &[u8], p: &mut usize) -> u32 {
    let v = u32::from_le_bytes(b[*p..*p + 4].try_into().unwrap());
    *p += 4;
    v
}

fn read_traj(b: &[u8], p: &mut usize) -> OwnedTraj {
    let n = read_u32(b, p) as usize;
    let mut o = OwnedTraj::default();
    for _ in 0..n {
        let mut f = [0.0; 3];
        for v in &mut f {
            *v = f64::from_le_bytes(b[*p..*p + 8].try_into().unwrap());
            *p += 8;
        }
        o.push(f[0], f[1], f[2]);
    }
    o
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 6 {
        eprintln!("usage: lcss_pairs PAIRS.bin OUT.bin (index DELTA EPS | time EPS T)");
        std::process::exit(2);
    }
    let bytes = std::fs::read(&args[1]).expect("read pairs");
    let mut p = 0;
    let count = read_u32(&bytes, &mut p) as usize;
    let pairs: Vec<(OwnedTraj, OwnedTraj)> = (0..count).map(|_| (read_traj(&bytes, &mut p), read_traj(&bytes, &mut p))).collect();
    type Score = Box<dyn Fn(&OwnedTraj, &OwnedTraj) -> f64 + Sync>;
    let f: Score = match args[3].as_str() {
        "index" => {
            let ip = IndexParams::new(args[4].parse().unwrap(), args[5].parse().unwrap(), None).unwrap();
            Box::new(move |a, b| lcss_index::joint_similarity(a.view(), b.view(), &ip).expect("within lcss_cells"))
        }
        "time" => {
            let tp = TimeWindowParams::new(args[4].parse().unwrap(), args[5].parse().unwrap(), 0).unwrap();
            Box::new(move |a, b| lcss::length(a.view(), b.view(), &tp).expect("within lcss_cells") as f64)
        }
        "prefilter" => {
            let (e, t): (f64, f64) = (args[4].parse().unwrap(), args[5].parse().unwrap());
            Box::new(move |a, b| lcss::may_match(a.view(), b.view(), e, t) as u8 as f64)
        }
        "validate" => Box::new(move |a, b| (a.view().validate().is_ok() && b.view().validate().is_ok()) as u8 as f64),
        "sqlpath" => {
            let tp = TimeWindowParams::new(args[4].parse().unwrap(), args[5].parse().unwrap(), 0).unwrap();
            Box::new(move |a, b| {
                let (ba, bb) = (a.view().validate_bounds().unwrap(), b.view().validate_bounds().unwrap());
                lcss::check_work(&a.t, &b.t, tp.time_window()).unwrap();
                if !ba.within(&bb, tp.epsilon()) {
                    return 0.0;
                }
                lcss::length(a.view(), b.view(), &tp).expect("within lcss_cells") as f64
            })
        }
        m => panic!("unknown mode {m}"),
    };
    // One warm-up pass (page faults, CPU clock ramp), then the best of 10 repetitions, single
    // thread then all cores.
    let mut out: Vec<f64> = pairs.iter().map(|(a, b)| f(a, b)).collect();
    let reps: usize = std::env::var("REPS").ok().and_then(|v| v.parse().ok()).unwrap_or(10);
    let mut best1 = f64::INFINITY;
    for _ in 0..reps {
        let t0 = Instant::now();
        out = pairs.iter().map(|(a, b)| f(a, b)).collect::<Vec<f64>>();
        best1 = best1.min(t0.elapsed().as_secs_f64());
    }
    let mut bestn = f64::INFINITY;
    for _ in 0..10 {
        let t0 = Instant::now();
        let par: Vec<f64> = pairs.par_iter().map(|(a, b)| f(a, b)).collect();
        bestn = bestn.min(t0.elapsed().as_secs_f64());
        assert_eq!(par, out);
    }
    let mut w = Vec::with_capacity(out.len() * 8);
    for v in &out {
        w.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(&args[2], w).expect("write results");
    println!(
        "{{\"pairs\": {count}, \"single_thread_s\": {best1}, \"parallel_s\": {bestn}, \"threads\": {}}}",
        rayon::current_num_threads()
    );
}
