//! Polygon set operations for camera views: the pairwise overlap `P^{k∩l} = P^k ∩ P^l`
//! (thesis §2.3) and the multi-camera overlap `P^{(k1,…,ki−1)∩ki} = (P^{k1} ∪ … ∪ P^{ki−1}) ∩ P^{ki}`
//! (thesis §2.3, eq. after 2.11), plus area and WKB/WKT output.
//!
//! The boolean operations are `geo`'s [`BooleanOps`] (the `i_overlay` engine); nothing here
//! clips polygons by hand.
//!
//! # Input: `Region`s only
//! Every operation takes [`Region`]s, whose only constructor validates the polygon and
//! normalises its rings ([`super::valid`]: shells counter-clockwise, holes clockwise, invalid
//! polygons refused). The boolean operations depend on it: geo's `unary_union` takes its fill
//! rule (i_overlay's Positive or Negative winding) from the first ring's direction, so a
//! clockwise square united with a counter-clockwise one gave area 0 and a hole wound like its
//! shell was filled in; intersection uses the even–odd rule, which reads overlapping parts of
//! a MULTIPOLYGON as holes. On valid, normalised input all rules agree.
//!
//! # Output shape
//! A result with no polygon is `POLYGON EMPTY`, one polygon is a `POLYGON`, more are a
//! `MULTIPOLYGON` — the shapes DuckDB spatial's `ST_Intersection` returns. Results are valid
//! (i_overlay's OGC mode) and wound like the input: shells counter-clockwise, holes clockwise.
//!
//! # Complexity
//! Intersection and union are O((V + k) log V) for V input vertices and k edge crossings;
//! [`area`] is O(V); [`to_wkb`] and [`to_wkt`] are O(V).

use super::region::Region;
use geo::orient::{Direction, Orient};
use geo::{unary_union, Area, BooleanOps, Buffer, Coord, LineString, MultiPolygon, Polygon};
use crate::{finite, ParamError};
use std::fmt::Write;

/// Shells counter-clockwise, holes clockwise (results are written in the input's convention).
fn wound(p: MultiPolygon<f64>) -> MultiPolygon<f64> {
    p.orient(Direction::Default)
}

fn intersect(a: &MultiPolygon<f64>, b: &MultiPolygon<f64>) -> MultiPolygon<f64> {
    if a.0.is_empty() || b.0.is_empty() {
        return MultiPolygon(vec![]);
    }
    wound(a.intersection(b))
}

/// `a ∩ b`.
pub fn overlap(a: &Region, b: &Region) -> MultiPolygon<f64> {
    intersect(a.polygons(), b.polygons())
}

/// The union of all of `parts` (empty input → empty result).
pub fn union_all<'a>(parts: impl IntoIterator<Item = &'a Region>) -> MultiPolygon<f64> {
    let parts: Vec<&MultiPolygon<f64>> = parts.into_iter().map(|r| r.polygons()).filter(|p| !p.0.is_empty()).collect();
    match parts.len() {
        0 => MultiPolygon(vec![]),
        // the first ring is a counter-clockwise shell, so unary_union counts windings with
        // i_overlay's Positive rule: shells +1, holes −1, covered where the sum is > 0
        _ => wound(unary_union(parts)),
    }
}

/// `(P^{k1} ∪ … ∪ P^{k(i−1)}) ∩ P^{ki}`: the overlap in which the i-th camera of a merge
/// order meets everything merged before it.
pub fn overlap_with_union<'a>(merged: impl IntoIterator<Item = &'a Region>, next: &Region) -> MultiPolygon<f64> {
    intersect(&union_all(merged), next.polygons())
}

/// Offsets the boundary by `distance` (> 0 grows, < 0 shrinks, 0 is the identity), with
/// round joins, like `ST_Buffer` (geo's `Buffer`, the `i_overlay` outline). `distance` must be
/// finite. Rings of more than 256 vertices are first simplified (Douglas–Peucker at
/// |distance| / 100: [`simplified`]), so the result is within |distance| / 100 of the exact
/// offset and a dense ring costs about its simplified size: near-linear in the vertices for the
/// view polygons of long tracks. O((V' + k) log V') plus the arc vertices of the round joins,
/// V' the vertices after simplification.
pub fn buffer(p: &Region, distance: f64) -> Result<MultiPolygon<f64>, Box<dyn std::error::Error + Send + Sync>> {
    let distance = finite("distance", distance)?;
    let p = p.polygons();
    if p.0.is_empty() || distance == 0.0 {
        return Ok(p.clone());
    }
    let simple = simplified(p, distance.abs() * BUFFER_TOLERANCE);
    let ring = simple.as_ref().unwrap_or(p);
    room(vertices(ring), BUFFER_BYTES_PER_VERTEX)?;
    let out = wound(ring.buffer(distance));
    // Far beyond the polygon's own size the offset loses the polygon to rounding (an outward
    // buffer of 1e10 m came back with area 0): refuse what cannot be computed right.
    if distance > 0.0 && !(out.unsigned_area() >= p.unsigned_area()) {
        return Err(Box::new(ParamError { name: "distance", rule: "small enough to keep the polygon within floating-point precision", value: distance }));
    }
    Ok(out)
}

/// Working bytes the boolean engine (i_overlay, whose allocations are not fallible) is allowed
/// per input vertex: a generous bound of its segment, event and output tables.
pub const OVERLAY_BYTES_PER_VERTEX: u128 = 4096;

/// `Ok` when an overlay (union, intersection, buffer) of `parts` may run: their vertices times
/// [`OVERLAY_BYTES_PER_VERTEX`] within the `memory_bytes` limit, and that many bytes allocatable
/// now (a fallible allocation, freed at once: it reserves address space, not memory), so that
/// an overlay that would exhaust memory is an error before it starts, never an abort inside
/// i_overlay, whatever the limit says.
pub fn overlay_room<'a>(parts: impl IntoIterator<Item = &'a Region>) -> Result<(), String> {
    room(parts.into_iter().map(|r| vertices(r.polygons())).sum(), OVERLAY_BYTES_PER_VERTEX)
}

/// Working bytes [`buffer`] is allowed per vertex of the (simplified) rings it offsets: every
/// vertex of a jagged ring makes a round join of many segments, and i_overlay's outline of a
/// 100,000-vertex zig-zag ring asked for 1.4 GB in one allocation (about 14 KiB per vertex;
/// the hostile probe of issue 37). Four times that, so that the trial allocation of [`room`]
/// fails first.
pub const BUFFER_BYTES_PER_VERTEX: u128 = 64 * 1024;

/// The vertices of every ring of `p`.
fn vertices(p: &MultiPolygon<f64>) -> usize {
    p.0.iter().map(|p| p.exterior().0.len() + p.interiors().iter().map(|h| h.0.len()).sum::<usize>()).sum()
}

/// `Ok` when `v` vertices at `per_vertex` bytes fit the `memory_bytes` limit and that many bytes
/// can be allocated now (see [`overlay_room`]).
fn room(v: usize, per_vertex: u128) -> Result<(), String> {
    let bytes = v as u128 * per_vertex;
    crate::limits::MEMORY_BYTES.check(bytes).map_err(|e| format!("{v} polygon vertices: {e}"))?;
    let refuse = || format!("{v} polygon vertices need up to {bytes} bytes of working memory, which could not be allocated; pass fewer or simpler polygons per call");
    let mut probe: Vec<u8> = Vec::new();
    probe.try_reserve_exact(usize::try_from(bytes).map_err(|_| refuse())?).map_err(|_| refuse())?;
    Ok(())
}

/// The Douglas–Peucker tolerance of [`buffer`], as a fraction of |distance|.
pub const BUFFER_TOLERANCE: f64 = 0.01;

/// Rings of more vertices than this are simplified before [`buffer`].
const SIMPLIFY_ABOVE: usize = 256;

/// `p` with every ring of more than [`SIMPLIFY_ABOVE`] vertices simplified by Douglas–Peucker at
/// tolerance `eps` (a ring that would collapse below a triangle: at the largest eps / 2^k that
/// keeps one); `None` when
/// no ring is that long (small polygons are buffered exactly as given).
///
/// Why: i_overlay's outline costs far more than linear in the vertices of a dense ring (3.5 s at
/// 100,000 vertices), and a view polygon drawn from a long track has a vertex every few
/// centimetres, while the buffer distance is metres. Error bound: every removed vertex lies
/// within `eps` of the simplified ring (Douglas–Peucker's guarantee), so the two boundaries are
/// within Hausdorff distance `eps`, and so are their offsets at any distance (offsetting is
/// 1-Lipschitz in the Hausdorff distance): the buffered boundary is within |distance| / 100 of
/// the exact one.
fn simplified(p: &MultiPolygon<f64>, eps: f64) -> Option<MultiPolygon<f64>> {
    use geo::Simplify;
    let long = |r: &LineString<f64>| r.0.len() > SIMPLIFY_ABOVE;
    if !(eps > 0.0 && eps.is_finite()) || !p.0.iter().any(|q| long(q.exterior()) || q.interiors().iter().any(long)) {
        return None;
    }
    let ring = |r: &LineString<f64>| {
        if !long(r) {
            return r.clone();
        }
        // a ring smaller than eps collapses: simplified at a finer tolerance instead (halved
        // until it keeps a triangle; a ring of thousands of vertices offset by a distance far
        // beyond its size made round joins without end and exhausted memory)
        let mut e = eps;
        for _ in 0..64 {
            let s = r.simplify(e);
            if s.0.len() >= 4 {
                return s;
            }
            e /= 2.0;
        }
        r.clone()
    };
    Some(MultiPolygon(p.0.iter().map(|q| Polygon::new(ring(q.exterior()), q.interiors().iter().map(ring).collect())).collect()))
}

/// Area, holes subtracted: the sum of the shells' areas minus the holes' (exact for a valid
/// region, whose parts do not overlap and whose holes lie in their shells).
pub fn area(p: &Region) -> f64 {
    p.polygons().unsigned_area()
}

/// Little-endian ISO WKB: `POLYGON EMPTY`, `POLYGON` or `MULTIPOLYGON` (see module docs).
pub fn to_wkb(p: &MultiPolygon<f64>) -> Vec<u8> {
    let opts = wkb::writer::WriteOptions { endianness: wkb::Endianness::LittleEndian };
    let mut out = Vec::new();
    // Writing to a Vec cannot fail.
    let written = match p.0.len() {
        0 => {
            // An empty polygon has zero rings (geo's empty Polygon would write one empty ring).
            out.extend_from_slice(&[1, 3, 0, 0, 0, 0, 0, 0, 0]);
            Ok(())
        }
        1 => wkb::writer::write_polygon(&mut out, &p.0[0], &opts),
        _ => wkb::writer::write_multi_polygon(&mut out, p, &opts),
    };
    debug_assert!(written.is_ok());
    out
}

fn ring_text(out: &mut String, ring: &LineString<f64>) {
    out.push('(');
    for (k, c) in ring.0.iter().enumerate() {
        if k > 0 {
            out.push_str(", ");
        }
        let _ = write!(out, "{} {}", c.x, c.y);
    }
    out.push(')');
}

fn polygon_text(out: &mut String, p: &Polygon<f64>) {
    out.push('(');
    ring_text(out, p.exterior());
    for r in p.interiors() {
        out.push_str(", ");
        ring_text(out, r);
    }
    out.push(')');
}

/// WKT in the style of DuckDB spatial's `ST_AsText`: `POLYGON ((0 0, 1 0, 1 1, 0 0))`.
pub fn to_wkt(p: &MultiPolygon<f64>) -> String {
    let mut s = String::new();
    match p.0.len() {
        0 => s.push_str("POLYGON EMPTY"),
        1 => {
            s.push_str("POLYGON ");
            polygon_text(&mut s, &p.0[0]);
        }
        _ => {
            s.push_str("MULTIPOLYGON (");
            for (k, q) in p.0.iter().enumerate() {
                if k > 0 {
                    s.push_str(", ");
                }
                polygon_text(&mut s, q);
            }
            s.push(')');
        }
    }
    s
}

/// A polygon from a closed or open list of vertices (test and demo helper).
pub fn from_vertices(v: &[(f64, f64)]) -> MultiPolygon<f64> {
    let ring: Vec<Coord<f64>> = v.iter().map(|&(x, y)| Coord { x, y }).collect();
    MultiPolygon(vec![Polygon::new(LineString(ring), vec![])])
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn reg(p: &MultiPolygon<f64>) -> Region {
        Region::from_multipolygon(p.clone()).unwrap()
    }
    /// Area of an operation's result, which must itself pass the gate (results are valid).
    fn a(p: &MultiPolygon<f64>) -> f64 {
        area(&reg(p))
    }
    fn square(x0: f64, y0: f64, s: f64) -> Region {
        reg(&from_vertices(&[(x0, y0), (x0 + s, y0), (x0 + s, y0 + s), (x0, y0 + s)]))
    }
    fn wkt(s: &str) -> Region {
        Region::from_wkt(s).unwrap()
    }

    #[test]
    fn overlap_union_area() {
        let sa = square(0.0, 0.0, 10.0);
        let sb = square(5.0, 5.0, 10.0);
        assert!((a(&overlap(&sa, &sb)) - 25.0).abs() < 1e-9);
        assert!((a(&union_all([&sa, &sb])) - 175.0).abs() < 1e-9);
        let far = square(100.0, 100.0, 1.0);
        assert!(overlap(&sa, &far).0.is_empty());
        assert_eq!(to_wkt(&overlap(&sa, &far)), "POLYGON EMPTY");
        // (A ∪ B) ∩ C
        let c = square(8.0, -5.0, 10.0);
        let m = overlap_with_union([&sa, &sb], &c);
        // A∩C = [8,10]x[0,5] (10) ; B∩C = [8,15]x[5,5]: a line, no area
        assert!((a(&m) - 10.0).abs() < 1e-9);
        // Two disjoint pieces give a MULTIPOLYGON.
        let bar = reg(&from_vertices(&[(-1.0, 2.0), (20.0, 2.0), (20.0, 3.0), (-1.0, 3.0)]));
        let two = overlap(&bar, &reg(&union_all([&square(0.0, 0.0, 5.0), &square(10.0, 0.0, 5.0)])));
        assert_eq!(two.0.len(), 2);
        assert!(to_wkt(&two).starts_with("MULTIPOLYGON ((("));
    }

    /// The cases: ring direction used to change union and overlap results.
    #[test]
    fn ring_direction_does_not_matter() {
        let ccw = wkt("POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))");
        let cw = wkt("POLYGON ((0 0, 0 4, 4 4, 4 0, 0 0))");
        assert_eq!(area(&cw), 16.0);
        assert_eq!(a(&union_all([&cw, &ccw])), 16.0); // was 0
        let other = wkt("POLYGON ((2 2, 6 2, 6 6, 2 6, 2 2))");
        assert_eq!(a(&union_all([&cw, &other])), 28.0); // was 12
        assert_eq!(a(&overlap(&cw, &other)), 4.0);
        // a hole wound like its shell (both counter-clockwise) is still a hole
        let holed = wkt("POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (4 4, 6 4, 6 6, 4 6, 4 4))");
        assert_eq!(area(&holed), 96.0);
        let u = union_all([&holed]);
        assert_eq!(u.0[0].interiors().len(), 1, "{}", to_wkt(&u)); // was dropped
        assert_eq!(a(&u), 96.0);
        assert_eq!(a(&union_all([&holed, &square(20.0, 0.0, 1.0)])), 97.0);
        // the hole stays open where the other polygon does not cover it
        assert_eq!(a(&union_all([&holed, &square(4.0, 4.0, 1.0)])), 97.0);
        // results are wound like the input convention
        let out = union_all([&cw, &other]);
        assert!(to_wkt(&out).starts_with("POLYGON (("));
        use geo::winding_order::{Winding, WindingOrder};
        assert_eq!(out.0[0].exterior().winding_order(), Some(WindingOrder::CounterClockwise));
        assert_eq!(u.0[0].interiors()[0].winding_order(), Some(WindingOrder::Clockwise));
        // the ring is rewound in place: same first vertex
        assert_eq!(to_wkt(cw.polygons()), "POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))");
    }

    /// Reference values from shapely 2.2.0 (GEOS 3.14): `a.intersection(b).area`,
    /// `union(a, b).area`, `a.buffer(-0.5).area`.
    #[test]
    fn pinned_against_shapely() {
        let pa = wkt("POLYGON ((0 0, 7.5 -1.25, 9 4, 5.5 8.25, 1 6, 0 0))");
        let pb = wkt("POLYGON ((3 2, 11 0.5, 12 7, 4 9.5, 3 2), (6 4, 8 4, 7 6, 6 4))");
        // i_overlay snaps to a fine integer grid: agreement is ~1e-9 relative, not exact.
        assert!((a(&overlap(&pa, &pb)) / 26.765133171912833 - 1.0).abs() < 1e-8);
        assert!((a(&union_all([&pa, &pb])) / 88.35986682808716 - 1.0).abs() < 1e-8);
        // round joins are polygonised differently (GEOS: 8 segments per quadrant)
        assert!((a(&buffer(&pa, -0.5).unwrap()) - 45.2144326957364).abs() < 1e-6);
    }

    #[test]
    fn a_dense_ring_is_simplified_within_the_tolerance_before_buffering() {
        use geo::{Contains, Point};
        // a circle of radius 50 with 20,000 vertices and 1 cm of wobble: buffered by 2 m
        let n = 20_000;
        let ring: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let a = k as f64 / n as f64 * std::f64::consts::TAU;
                let r = 50.0 + 0.01 * ((k * 7919) % 13) as f64 / 13.0;
                (r * a.cos(), r * a.sin())
            })
            .collect();
        let mp = from_vertices(&ring);
        let s = simplified(&mp, 2.0 * BUFFER_TOLERANCE).expect("a ring of 20,000 vertices is simplified");
        let kept = s.0[0].exterior().0.len();
        assert!(kept < n / 10, "{kept} vertices kept of {n}");
        // every vertex of the simplified ring is a vertex of the original (Douglas-Peucker keeps a subset)
        for d in [2.0, -2.0] {
            let r = reg(&mp);
            let out = buffer(&r, d).unwrap();
            let exact = wound(mp.buffer(d));
            // areas agree within the band the tolerance allows: perimeter x eps
            let band = 2.0 * std::f64::consts::PI * 52.0 * (d.abs() * BUFFER_TOLERANCE);
            assert!((out.unsigned_area() - exact.unsigned_area()).abs() <= band, "{d}: {} vs {}", out.unsigned_area(), exact.unsigned_area());
            // points clearly inside / outside the exact offset are on the same side of the result
            let edge = 50.0 + d;
            for k in 0..360 {
                let a = (k as f64).to_radians();
                let (inside, outside) = (edge - 0.05, edge + 0.05);
                assert!(out.contains(&Point::new(inside * a.cos(), inside * a.sin())), "{d} {k}");
                assert!(!out.contains(&Point::new(outside * a.cos(), outside * a.sin())), "{d} {k}");
            }
        }
        // a small polygon is buffered as given
        assert!(simplified(&from_vertices(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]), 0.01).is_none());
    }

    #[test]
    fn buffer_grows_and_shrinks() {
        let sq = square(0.0, 0.0, 10.0);
        assert!((a(&buffer(&sq, -1.0).unwrap()) - 64.0).abs() < 1e-6);
        let grown = a(&buffer(&sq, 1.0).unwrap());
        // 100 + perimeter * 1 + pi (round corners, polygonised)
        assert!(grown > 143.0 && grown <= 140.0 + std::f64::consts::PI + 1e-9, "{grown}");
        assert!(buffer(&sq, -6.0).unwrap().0.is_empty());
        assert!(buffer(&reg(&MultiPolygon(vec![])), 1.0).unwrap().0.is_empty());
        // a hole shrinks when the polygon grows, whichever way it is wound
        for w in ["POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (3 3, 7 3, 7 7, 3 7, 3 3))", "POLYGON ((0 0, 0 10, 10 10, 10 0, 0 0), (3 3, 3 7, 7 7, 7 3, 3 3))"] {
            let g = buffer(&wkt(w), 1.0).unwrap();
            assert_eq!(g.0[0].interiors().len(), 1, "{w}");
            let hole = geo::Polygon::new(g.0[0].interiors()[0].clone(), vec![]).unsigned_area();
            assert!((hole - 4.0).abs() < 0.05, "{w}: {hole}");
        }
    }

    #[test]
    fn wkb_round_trip() {
        for p in [MultiPolygon(vec![]), square(0.0, 0.0, 2.0).into_polygons(), union_all([&square(0.0, 0.0, 1.0), &square(5.0, 0.0, 1.0)])] {
            let r = Region::from_wkb(&to_wkb(&p)).unwrap();
            assert_eq!(r.polygons().0.len(), p.0.len());
            assert!((area(&r) - p.unsigned_area()).abs() < 1e-12);
            let t = Region::from_wkt(&to_wkt(&p)).unwrap();
            assert!((area(&t) - p.unsigned_area()).abs() < 1e-12);
        }
        assert_eq!(to_wkt(square(0.0, 0.0, 1.5).polygons()), "POLYGON ((0 0, 1.5 0, 1.5 1.5, 0 1.5, 0 0))");
    }

    /// A star-shaped (so simple) ring around (cx, cy) on a coarse grid, counter-clockwise.
    fn star(cx: f64, cy: f64, radii: &[f64]) -> Vec<Coord<f64>> {
        let n = radii.len();
        let mut v: Vec<Coord<f64>> = radii
            .iter()
            .enumerate()
            .map(|(k, r)| {
                let t = std::f64::consts::TAU * k as f64 / n as f64;
                Coord { x: cx + (r * t.cos() * 4.0).round() / 4.0, y: cy + (r * t.sin() * 4.0).round() / 4.0 }
            })
            .collect();
        v.dedup();
        v
    }

    /// A polygon with an optional hole (a small star at its centre), every ring wound as
    /// `flip` says (bit 0 the shell, bit 1 the hole), or `None` when rounding broke the star.
    fn polygon(cx: f64, cy: f64, radii: &[f64], hole: bool, flip: u8) -> Option<Region> {
        let wind = |mut v: Vec<Coord<f64>>, rev: bool| {
            if rev {
                v.reverse();
            }
            LineString(v)
        };
        let holes = if hole { vec![wind(star(cx, cy, &[1.0, 1.2, 0.9, 1.1, 1.0]), flip & 2 != 0)] } else { vec![] };
        Region::from_multipolygon(MultiPolygon(vec![Polygon::new(wind(star(cx, cy, radii), flip & 1 != 0), holes)])).ok()
    }

    /// Distance from `p` to the nearest edge of `r`.
    fn edge_distance(r: &Region, p: Coord<f64>) -> f64 {
        use geo::{Distance, Euclidean, Point};
        r.polygons()
            .0
            .iter()
            .flat_map(|q| std::iter::once(q.exterior()).chain(q.interiors()))
            .flat_map(|l| l.lines())
            .map(|l| Euclidean.distance(&l, &Point(p)))
            .fold(f64::INFINITY, f64::min)
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

        /// area(A ∪ reverse(A)) = area(A); every operation gives the same result whatever the
        /// ring directions of its inputs; the union contains exactly the points of A or B (the
        /// obviously right version, away from the boundaries that i_overlay snaps).
        #[test]
        fn results_do_not_depend_on_ring_direction(
            ra in prop::collection::vec(2.0f64..6.0, 3..12),
            rb in prop::collection::vec(2.0f64..6.0, 3..12),
            shift in (-6.0f64..6.0, -6.0f64..6.0),
            holes in (any::<bool>(), any::<bool>()),
            pts in prop::collection::vec((-12.0f64..12.0, -12.0f64..12.0), 40),
        ) {
            let (bx, by) = ((shift.0 * 4.0).round() / 4.0, (shift.1 * 4.0).round() / 4.0);
            let variants = |radii: &[f64], cx: f64, cy: f64, hole: bool| -> Result<Option<Vec<Region>>, TestCaseError> {
                let v: Vec<Option<Region>> = (0..4u8).map(|f| polygon(cx, cy, radii, hole, f)).collect();
                // validity does not depend on ring direction either
                prop_assert!(v.iter().all(|r| r.is_some()) || v.iter().all(|r| r.is_none()));
                Ok(v.into_iter().collect())
            };
            let (Some(va), Some(vb)) = (variants(&ra, 0.0, 0.0, holes.0)?, variants(&rb, bx, by, holes.1)?) else {
                return Ok(()); // rounding to the grid made a ring invalid (every variant refused alike)
            };
            let a0 = area(&va[0]);
            for v in &va {
                prop_assert_eq!(area(v), a0);
                // union(A, reverse(A)) = A
                prop_assert!((a(&union_all([&va[0], v])) - a0).abs() <= 1e-9 * a0);
            }
            let (u0, o0, b0) = (a(&union_all([&va[0], &vb[0]])), a(&overlap(&va[0], &vb[0])), a(&buffer(&va[0], -0.25).unwrap()));
            for x in &va {
                prop_assert!((a(&buffer(x, -0.25).unwrap()) - b0).abs() <= 1e-9 * a0);
                for y in &vb {
                    prop_assert!((a(&union_all([x, y])) - u0).abs() <= 1e-9 * u0, "union");
                    prop_assert!((a(&overlap(x, y)) - o0).abs() <= 1e-9 * u0, "overlap");
                    for &(px, py) in &pts {
                        prop_assert_eq!(x.contains(px, py), va[0].contains(px, py));
                    }
                }
            }
            let u = reg(&union_all([&va[0], &vb[0]]));
            let o = reg(&overlap(&va[0], &vb[0]));
            for &(px, py) in &pts {
                let p = Coord { x: px, y: py };
                if edge_distance(&va[0], p) < 1e-6 || edge_distance(&vb[0], p) < 1e-6 {
                    continue;
                }
                let (ina, inb) = (va[0].contains(px, py), vb[0].contains(px, py));
                prop_assert_eq!(u.contains(px, py), ina || inb, "union at {:?}", p);
                prop_assert_eq!(o.contains(px, py), ina && inb, "overlap at {:?}", p);
            }
        }
    }
}
