//! Times hungarian_match on the peer script's shapes without DuckDB:
//! `cargo run --release -p trajdb-algo --example hungarian_sparse`
use std::time::Instant;
use trajdb_algo::matching::hungarian::{hungarian_match, MatchParams};

fn main() {
    let mut s = 7u64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    // sparse 50k x 50k, 500k pairs with a hidden perfect matching
    let n = 50_000i64;
    let mut pairs: Vec<(i64, i64, f64)> = (0..n).map(|i| (i, (i * 7919 + 13) % n, 1.0 + (rnd() % 9900) as f64 / 100.0)).collect();
    for _ in 0..450_000 {
        pairs.push(((rnd() % n as u64) as i64, (rnd() % n as u64) as i64, 1.0 + (rnd() % 9900) as f64 / 100.0));
    }
    for _ in 0..2 {
        let t = Instant::now();
        let m = hungarian_match(&pairs, &MatchParams::new(false, None).unwrap()).unwrap();
        println!("sparse 50k: {} matched, total {:.3}, {:.3} s", m.len(), m.iter().map(|p| p.2).sum::<f64>(), t.elapsed().as_secs_f64());
    }
    for n in [1000i64, 2000] {
        let pairs: Vec<(i64, i64, f64)> = (0..n * n).map(|k| (k / n, k % n, (rnd() % 1_000_000) as f64 / 1e6)).collect();
        for _ in 0..2 {
            let t = Instant::now();
            let m = hungarian_match(&pairs, &MatchParams::new(true, None).unwrap()).unwrap();
            println!("dense {n} sorted: {} matched, total {:.3}, {:.3} s", m.len(), m.iter().map(|p| p.2).sum::<f64>(), t.elapsed().as_secs_f64());
        }
        // the same pairs in another order (b-major)
        let mut shuffled = pairs.clone();
        shuffled.sort_by_key(|p| (p.1, p.0));
        let t = Instant::now();
        let m = hungarian_match(&shuffled, &MatchParams::new(true, None).unwrap()).unwrap();
        println!("dense {n} b-major: {} matched, total {:.3}, {:.3} s", m.len(), m.iter().map(|p| p.2).sum::<f64>(), t.elapsed().as_secs_f64());
    }
}
