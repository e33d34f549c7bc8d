//! Times `dendrogram_condensed` (the SQL path's maths: checks, copy, linkage, labels) on the
//! condensed distances of n random 2-D points held in an ordinary allocation (as DuckDB's list
//! child is: no huge pages), against the linkage alone on a ready matrix. Best of REPS=3.
//! `cargo run --release -p trajdb-algo --example condensed_timing -- 5000 [method ...]`
use std::time::Instant;

#[path = "common/points.rs"]
mod points;
use trajdb_algo::cluster::linkage::{alloc_condensed, dendrogram_condensed, linkage_condensed, Linkage};

/// CPU time of this thread (with CPU=1 in the environment, on Linux: steadier than wall time on a
/// shared machine, for the serial sizes below 8,192 items), else wall time since `t`.
fn secs(t: Instant) -> f64 {
    #[cfg(target_os = "linux")]
    if std::env::var_os("CPU").is_some() {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: a valid timespec pointer.
        unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        return ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9;
    }
    t.elapsed().as_secs_f64()
}

fn main() {
    let (n, methods, pts) = points::setup();
    let mut d = Vec::with_capacity(n * (n - 1) / 2);
    for i in 0..n {
        for j in i + 1..n {
            d.push(points::dist(&pts, i, j));
        }
    }
    let ids: Vec<i64> = (0..n as i64).collect();
    let reps = points::reps();
    for m in &methods {
        let method = Linkage::parse(m).unwrap();
        let (mut total, mut link) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..reps {
            let t = Instant::now();
            let c0 = secs(t);
            let full = dendrogram_condensed(&d, method).unwrap();
            total = total.min(secs(t) - c0);
            let mut m2 = alloc_condensed(n, 0.0).unwrap();
            m2.copy_from_slice(&d);
            let t = Instant::now();
            let c0 = secs(t);
            let only = linkage_condensed(ids.clone(), m2, method).unwrap();
            link = link.min(secs(t) - c0);
            assert_eq!(full, only);
        }
        println!("{m:9} n={n}: condensed->dendrogram {total:.3} s, linkage alone {link:.3} s (best of {reps})");
    }
}
