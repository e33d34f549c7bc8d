//! Criterion benches for the polygon family (pure algo): `cargo bench --no-default-features --bench polygon`
//!
//! * `pip_50_vertices`: 100k point-in-polygon tests against a 50-vertex star-shaped polygon,
//!   points uniform over 1.2× its bounding box (about half inside). Compares trajdb's prepared
//!   slab index (`Region::contains`, boundary-inclusive) with geo 0.33's `Intersects<Coord>`
//!   on the `MultiPolygon` (O(V), boundary-inclusive) and geo's `IntervalTreeMultiPolygon`
//!   (`Contains`, boundary excluded). Throughput = tests per second on one core.
//! * `prepare_50_vertices`: parse WKB + validate + build the index (the per-chunk cost).
//! * `hull_100k`: convex and concave view polygon of 100k points; `overlap`: intersection of
//!   two 200-vertex concave hulls.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use geo::indexed::IntervalTreeMultiPolygon;
use geo::{Contains, Coord, Intersects, LineString, MultiPolygon, Polygon};
use std::hint::black_box;
use trajdb_algo::geometry::hull::{view_polygon, HullParams};
use trajdb_algo::geometry::polygon::{overlap, to_wkb};
use trajdb_algo::geometry::region::Region;

fn lcg(s: &mut u64) -> f64 {
    *s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*s >> 11) as f64 / (1u64 << 53) as f64
}

fn star(v: usize, seed: &mut u64) -> MultiPolygon<f64> {
    let ring: Vec<Coord<f64>> = (0..v)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / v as f64;
            let r = 30.0 + 20.0 * lcg(seed);
            Coord { x: r * a.cos(), y: r * a.sin() }
        })
        .collect();
    MultiPolygon(vec![Polygon::new(LineString(ring), vec![])])
}

fn bench(c: &mut Criterion) {
    let mut seed = 5u64;
    let mp = star(50, &mut seed);
    let pts: Vec<Coord<f64>> = (0..100_000).map(|_| Coord { x: lcg(&mut seed) * 120.0 - 60.0, y: lcg(&mut seed) * 120.0 - 60.0 }).collect();
    let region = Region::from_multipolygon(mp.clone()).unwrap();
    let itree = IntervalTreeMultiPolygon::new(&mp);

    let mut g = c.benchmark_group("pip_50_vertices");
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("trajdb_slab_index", |b| b.iter(|| pts.iter().filter(|p| region.contains(black_box(p.x), p.y)).count()));
    g.bench_function("geo_multipolygon_intersects", |b| b.iter(|| pts.iter().filter(|p| mp.intersects(black_box(*p))).count()));
    g.bench_function("geo_interval_tree_contains", |b| b.iter(|| pts.iter().filter(|p| itree.contains(black_box(*p))).count()));
    g.finish();

    let wkb = to_wkb(&mp);
    let mut g = c.benchmark_group("prepare_50_vertices");
    g.bench_function("wkb_parse_validate_index", |b| b.iter(|| Region::from_wkb(black_box(&wkb)).unwrap()));
    g.finish();

    let (x, y): (Vec<f64>, Vec<f64>) =
        (0..100_000).map(|k| if k % 2 == 0 { (lcg(&mut seed) * 100.0, lcg(&mut seed) * 10.0) } else { (lcg(&mut seed) * 10.0, lcg(&mut seed) * 100.0) }).unzip();
    let mut g = c.benchmark_group("hull_100k");
    g.sample_size(10);
    g.bench_function("convex", |b| b.iter(|| view_polygon(&x, &y, &HullParams::new("convex", None).unwrap()).unwrap()));
    g.bench_function("concave_2", |b| b.iter(|| view_polygon(&x, &y, &HullParams::new("concave", Some(2.0)).unwrap()).unwrap()));
    g.bench_function("convex_density_1m_3", |b| {
        b.iter(|| view_polygon(&x, &y, &HullParams::new("convex", None).unwrap().with_density(1.0, 3).unwrap()).unwrap())
    });
    g.finish();

    let a = star(200, &mut seed);
    let bpoly = star(200, &mut seed);
    let shifted = MultiPolygon(vec![Polygon::new(
        LineString(bpoly.0[0].exterior().0.iter().map(|c| Coord { x: c.x + 20.0, y: c.y }).collect()),
        vec![],
    )]);
    let (a, shifted) = (Region::from_multipolygon(a).unwrap(), Region::from_multipolygon(shifted).unwrap());
    let mut g = c.benchmark_group("overlap");
    g.bench_function("intersection_200x200_vertices", |b| b.iter(|| overlap(black_box(&a), &shifted)));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
