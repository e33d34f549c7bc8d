//! Times hungarian_match on the peer script's shapes without DuckDB (best of `reps` runs):
//! `cargo run --release -p trajdb-algo --example hungarian_sparse -- [sparse|dense|all] [reps]`
use std::time::Instant;
use trajdb_algo::matching::hungarian::{hungarian_match_columns, MatchParams};

/// CPU time of the calling thread in seconds (Linux; 0 elsewhere): steadier than wall time
/// on a shared machine.
fn cpu() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat").ok().and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok()).unwrap_or(0.0) / 1e9
}

fn best(reps: usize, what: &str, a: &[i64], b: &[i64], s: &[f64], maximize: bool) {
    let (mut t_best, mut c_best) = (f64::INFINITY, f64::INFINITY);
    let mut m = Vec::new();
    for _ in 0..reps {
        let (t, c) = (Instant::now(), cpu());
        m = hungarian_match_columns(a, b, s, &MatchParams::new(maximize, None).unwrap()).unwrap();
        t_best = t_best.min(t.elapsed().as_secs_f64());
        c_best = c_best.min(cpu() - c);
    }
    println!("{what}: {} matched, total {:.3}, best {t_best:.3} s wall, {c_best:.3} s cpu (this thread)", m.len(), m.iter().map(|p| p.2).sum::<f64>());
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map(String::as_str).unwrap_or("all");
    let reps: usize = args.get(2).and_then(|r| r.parse().ok()).unwrap_or(3);
    let mut s = 7u64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    if which != "dense" {
        // sparse 50k x 50k, 500k pairs with a hidden perfect matching
        let n = 50_000i64;
        let mut pairs: Vec<(i64, i64, f64)> = (0..n).map(|i| (i, (i * 7919 + 13) % n, 1.0 + (rnd() % 9900) as f64 / 100.0)).collect();
        for _ in 0..450_000 {
            pairs.push(((rnd() % n as u64) as i64, (rnd() % n as u64) as i64, 1.0 + (rnd() % 9900) as f64 / 100.0));
        }
        let (a, b, w): (Vec<i64>, Vec<i64>, Vec<f64>) = (pairs.iter().map(|p| p.0).collect(), pairs.iter().map(|p| p.1).collect(), pairs.iter().map(|p| p.2).collect());
        best(reps, "sparse 50k", &a, &b, &w, false);
    }
    if which != "sparse" {
        for n in [1000i64, 2000] {
            let k = 0..n * n;
            let (a, b): (Vec<i64>, Vec<i64>) = (k.clone().map(|k| k / n).collect(), k.map(|k| k % n).collect());
            let w: Vec<f64> = (0..n * n).map(|_| (rnd() % 1_000_000) as f64 / 1e6).collect();
            best(reps, &format!("dense {n}"), &a, &b, &w, true);
        }
    }
}
