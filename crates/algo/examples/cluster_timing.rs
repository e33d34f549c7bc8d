//! Times agglomerative clustering on n random 2-D points (all pairs) without DuckDB, in phases:
//! pairs -> dendrogram, and the linkage alone on a ready matrix (best of REPS=3).
//! `cargo run --release -p trajdb-algo --example cluster_timing -- 5000 [method ...]`
use std::time::Instant;

#[path = "common/points.rs"]
mod points;
use trajdb_algo::cluster::linkage::{dendrogram_pairs, linkage_condensed, Linkage, Pairs};

fn main() {
    let (n, methods, pts) = points::setup();
    let len = n * (n - 1) / 2;
    let (mut a, mut b, mut d) = (Vec::with_capacity(len), Vec::with_capacity(len), Vec::with_capacity(len));
    for i in 0..n {
        for j in i + 1..n {
            a.push(i as i64);
            b.push(j as i64);
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
            let full = dendrogram_pairs(Pairs { a: &a, b: &b, distance: &d }, method).unwrap();
            total = total.min(t.elapsed().as_secs_f64());
            let mut m2 = trajdb_algo::cluster::linkage::alloc_condensed(n, 0.0).unwrap();
            m2.copy_from_slice(&d);
            let t = Instant::now();
            let only = linkage_condensed(ids.clone(), m2, method).unwrap();
            link = link.min(t.elapsed().as_secs_f64());
            assert_eq!(full, only);
        }
        println!("{m:9} n={n}: pairs->dendrogram {total:.3} s, linkage alone {link:.3} s (best of {reps})");
    }
}
