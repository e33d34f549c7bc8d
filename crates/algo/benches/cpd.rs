//! Criterion benches for cpd_align's engine (pure algo): `cargo bench --no-default-features --bench cpd`
//! Ten EM iterations of plain CPD (dense E-step) and TimeCPD (time band) on a synthetic scene.

use criterion::{criterion_group, criterion_main, Criterion};
use trajdb_algo::align::cpd::{align, CpdParams};

fn scene(n: usize, shift: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut x, mut y, mut t) = (vec![], vec![], vec![]);
    for k in 0..n {
        let obj = (k % 20) as f64;
        let s = (k / 20) as f64 * 0.1;
        t.push(s);
        x.push((obj * 0.7).cos() * (s * 8.0 % 60.0 - 30.0) + shift);
        y.push((obj * 0.7).sin() * (s * 8.0 % 60.0 - 30.0) - shift);
    }
    (x, y, t)
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("cpd_10_iterations");
    g.sample_size(10);
    for n in [1000usize, 5000] {
        let f = scene(n, 0.0);
        let m = scene(n, 1.5);
        let dense = CpdParams::new(0.1, None, 10, 0.0, true, 1).unwrap();
        g.bench_function(format!("plain_{n}x{n}"), |b| b.iter(|| align((&f.0, &f.1, &f.2), (&m.0, &m.1, &m.2), &dense).unwrap()));
        let timed = CpdParams::new(0.1, Some(0.1), 10, 0.0, false, 1).unwrap();
        g.bench_function(format!("time_tau0.1_{n}x{n}"), |b| b.iter(|| align((&f.0, &f.1, &f.2), (&m.0, &m.1, &m.2), &timed).unwrap()));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
