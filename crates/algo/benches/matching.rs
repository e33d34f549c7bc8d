//! Criterion benches for matching and merging (pure algo):
//! `cargo bench --no-default-features --bench matching`
//! * hungarian_match on a dense 500 × 500 instance and a sparse 20,000 × 20,000 one with
//!   200,000 candidate pairs (a hidden perfect matching plus random pairs);
//! * trajectory_merge of two 600-point tracks that overlap for 300 points, and a 3-track chain.

use criterion::{criterion_group, criterion_main, Criterion};
use trajdb_algo::matching::hungarian::{hungarian_match, MatchParams};
use trajdb_algo::lcss::time_window::TimeWindowParams;
use trajdb_algo::merge::merge_chain;
use trajdb_algo::traj::OwnedTraj;

fn xorshift(s: &mut u64) -> u64 {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    *s
}

fn bench(c: &mut Criterion) {
    let mut s = 11u64;
    let n = 500i64;
    let dense: Vec<(i64, i64, f64)> = (0..n * n).map(|k| (k / n, k % n, (xorshift(&mut s) % 1_000_000) as f64 / 1e6)).collect();
    let n = 20_000i64;
    let mut sparse: Vec<(i64, i64, f64)> = (0..n).map(|i| (i, (i * 7919 + 13) % n, 1.0 + (xorshift(&mut s) % 9900) as f64 / 100.0)).collect();
    for _ in 0..180_000 {
        sparse.push(((xorshift(&mut s) % n as u64) as i64, (xorshift(&mut s) % n as u64) as i64, 1.0 + (xorshift(&mut s) % 9900) as f64 / 100.0));
    }
    let mut g = c.benchmark_group("hungarian_match");
    g.sample_size(10);
    g.bench_function("dense_500x500_max", |b| b.iter(|| hungarian_match(&dense, &MatchParams::new(true, None).unwrap()).unwrap()));
    g.bench_function("sparse_20k_200k_pairs_min", |b| b.iter(|| hungarian_match(&sparse, &MatchParams::new(false, None).unwrap()).unwrap()));
    g.finish();

    let line = |t0: f64, n: usize, y: f64| OwnedTraj {
        t: (0..n).map(|k| t0 + k as f64 * 0.1).collect(),
        x: (0..n).map(|k| (t0 + k as f64 * 0.1) * 8.0).collect(),
        y: vec![y; n],
    };
    let (a, b, d) = (line(0.0, 600, 0.0), line(30.0, 600, 0.1), line(50.0, 600, -0.1));
    let p = TimeWindowParams::new(0.5, 0.25, 3).unwrap();
    let mut g = c.benchmark_group("trajectory_merge");
    g.bench_function("pair_600_points_300_overlap", |bn| bn.iter(|| merge_chain(&[a.view(), b.view()], &p, None)));
    g.bench_function("chain_3x600_points", |bn| bn.iter(|| merge_chain(&[a.view(), b.view(), d.view()], &p, None)));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
