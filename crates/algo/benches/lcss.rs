//! Criterion benches for the LCSS family (pure algo; no DuckDB needed):
//! `cargo bench --no-default-features --bench lcss`
//!
//! Inputs are synthetic 10 Hz trajectories of 200 points (20 s), the shape of the DUT tracks.
//! `full_band` runs the same time-window LCSS with T = inf, i.e. the dense O(n·m) table of
//! Alg. 1, to show what the band saves.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use trajdb_algo::lcss::time_window::{self as lcss, TimeWindowParams};
use trajdb_algo::lcss::index::{self as lcss_index, IndexParams};
use trajdb_algo::lcss::translate as lcss_translate;
use trajdb_algo::traj::{OwnedTraj, Series};

fn track(n: usize, phase: f64, dx: f64, seed: u64) -> OwnedTraj {
    let mut s = seed;
    let mut noise = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((s >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.2
    };
    let mut o = OwnedTraj::default();
    for k in 0..n {
        let t = k as f64 * 0.1 + phase;
        o.push(t, 8.0 * t + dx + noise(), 0.5 * (t * 0.3).sin() + noise());
    }
    o
}

fn bench(c: &mut Criterion) {
    let a = track(200, 0.0, 0.0, 1);
    let b = track(200, 0.05, 0.3, 2);
    let mut g = c.benchmark_group("lcss_200x200");
    let p = TimeWindowParams::new(1.0, 0.5, 0).unwrap();
    g.bench_function("time_window_length", |bn| bn.iter(|| lcss::length(black_box(a.view()), black_box(b.view()), &p)));
    g.bench_function("time_window_matches", |bn| bn.iter(|| lcss::matches(black_box(a.view()), black_box(b.view()), &p)));
    let full = TimeWindowParams::new(1.0, f64::INFINITY, 0).unwrap();
    g.bench_function("full_band_length(dense_alg1)", |bn| {
        bn.iter(|| lcss::length(black_box(a.view()), black_box(b.view()), &full))
    });
    let (sa_t, sa_v) = trajdb_algo::traj::speeds(a.view());
    let (sb_t, sb_v) = trajdb_algo::traj::speeds(b.view());
    g.bench_function("series_speed_length", |bn| {
        bn.iter(|| lcss::series_length(Series::new(&sa_t, &sa_v), Series::new(&sb_t, &sb_v), &p))
    });
    for delta in [5i64, 20] {
        let ip = IndexParams::new(delta, 1.0, None).unwrap();
        g.bench_with_input(BenchmarkId::new("index_joint", delta), &ip, |bn, ip| {
            bn.iter(|| lcss_index::joint_length(black_box(a.view()), black_box(b.view()), ip))
        });
        g.bench_with_input(BenchmarkId::new("s1", delta), &ip, |bn, ip| {
            bn.iter(|| lcss_index::s1(black_box(a.view()), black_box(b.view()), ip))
        });
        g.bench_with_input(BenchmarkId::new("s2_translation", delta), &ip, |bn, ip| {
            bn.iter(|| lcss_translate::s2(black_box(a.view()), black_box(b.view()), ip))
        });
    }
    g.finish();

    let mut g = c.benchmark_group("lcss_long");
    let la = track(20_000, 0.0, 0.0, 3);
    let lb = track(20_000, 0.05, 0.3, 4);
    g.sample_size(20);
    g.bench_function("time_window_20000x20000", |bn| bn.iter(|| lcss::length(la.view(), lb.view(), &p)));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
