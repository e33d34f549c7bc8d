//! Times agglomerative clustering on n random 2-D points (all pairs) without DuckDB:
//! `cargo run --release --no-default-features --example cluster_timing -- 5000`
use std::time::Instant;
use trajdb_algo::cluster::linkage::{dendrogram, Linkage};

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(5000);
    let mut s = 5u64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 1000.0
    };
    let pts: Vec<(f64, f64)> = (0..n).map(|_| (rnd(), rnd())).collect();
    let mut pairs = Vec::with_capacity(n * (n - 1) / 2);
    for i in 0..n {
        for j in i + 1..n {
            pairs.push((i as i64, j as i64, ((pts[i].0 - pts[j].0).powi(2) + (pts[i].1 - pts[j].1).powi(2)).sqrt()));
        }
    }
    for m in ["single", "complete", "average", "weighted", "ward"] {
        let t = Instant::now();
        let d = dendrogram(&pairs, Linkage::parse(m).unwrap()).unwrap();
        println!("{m:9} n={n}: {:.3} s (last merge {:.3})", t.elapsed().as_secs_f64(), d.merges.last().unwrap().distance);
    }
}
