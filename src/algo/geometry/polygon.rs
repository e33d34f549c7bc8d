//! Polygon set operations for camera views: the pairwise overlap `P^{k∩l} = P^k ∩ P^l`
//! (thesis §2.3) and the multi-camera overlap `P^{(k1,…,ki−1)∩ki} = (P^{k1} ∪ … ∪ P^{ki−1}) ∩ P^{ki}`
//! (thesis §2.3, eq. after 2.11), plus area and WKB/WKT output.
//!
//! The boolean operations are `geo`'s [`BooleanOps`] (the `i_overlay` engine); nothing here
//! clips polygons by hand.
//!
//! # Output shape
//! A result with no polygon is `POLYGON EMPTY`, one polygon is a `POLYGON`, more are a
//! `MULTIPOLYGON` — the shapes DuckDB spatial's `ST_Intersection` returns.
//!
//! # Complexity
//! Intersection and union are O((V + k) log V) for V input vertices and k edge crossings;
//! [`area`] is O(V); [`to_wkb`] and [`to_wkt`] are O(V).

use geo::{unary_union, Area, BooleanOps, Buffer, Coord, LineString, MultiPolygon, Polygon};
use crate::algo::{finite, ParamError};
use std::fmt::Write;

/// `a ∩ b`.
pub fn overlap(a: &MultiPolygon<f64>, b: &MultiPolygon<f64>) -> MultiPolygon<f64> {
    if a.0.is_empty() || b.0.is_empty() {
        return MultiPolygon(vec![]);
    }
    a.intersection(b)
}

/// The union of all of `parts` (empty input → empty result).
pub fn union_all<'a>(parts: impl IntoIterator<Item = &'a MultiPolygon<f64>>) -> MultiPolygon<f64> {
    let parts: Vec<&MultiPolygon<f64>> = parts.into_iter().filter(|p| !p.0.is_empty()).collect();
    match parts.len() {
        0 => MultiPolygon(vec![]),
        _ => unary_union(parts),
    }
}

/// `(P^{k1} ∪ … ∪ P^{k(i−1)}) ∩ P^{ki}`: the overlap in which the i-th camera of a merge
/// order meets everything merged before it.
pub fn overlap_with_union<'a>(
    merged: impl IntoIterator<Item = &'a MultiPolygon<f64>>,
    next: &MultiPolygon<f64>,
) -> MultiPolygon<f64> {
    overlap(&union_all(merged), next)
}

/// Offsets the boundary by `distance` (> 0 grows, < 0 shrinks, 0 is the identity), with
/// round joins, like `ST_Buffer` (geo's `Buffer`, the `i_overlay` outline). `distance` must be
/// finite. O((V + k) log V) plus the arc vertices of the round joins.
pub fn buffer(p: &MultiPolygon<f64>, distance: f64) -> Result<MultiPolygon<f64>, ParamError> {
    let distance = finite("distance", distance)?;
    if p.0.is_empty() || distance == 0.0 {
        return Ok(p.clone());
    }
    let out = p.buffer(distance);
    // Far beyond the polygon's own size the offset loses the polygon to rounding (an outward
    // buffer of 1e10 m came back with area 0): refuse what cannot be computed right.
    if distance > 0.0 && !(out.unsigned_area() >= p.unsigned_area()) {
        return Err(ParamError { name: "distance", rule: "small enough to keep the polygon within floating-point precision", value: distance });
    }
    Ok(out)
}

/// Unsigned area (holes subtracted).
pub fn area(p: &MultiPolygon<f64>) -> f64 {
    p.unsigned_area()
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
    use crate::algo::geometry::region::Region;

    fn square(x0: f64, y0: f64, s: f64) -> MultiPolygon<f64> {
        from_vertices(&[(x0, y0), (x0 + s, y0), (x0 + s, y0 + s), (x0, y0 + s)])
    }

    #[test]
    fn overlap_union_area() {
        let a = square(0.0, 0.0, 10.0);
        let b = square(5.0, 5.0, 10.0);
        assert!((area(&overlap(&a, &b)) - 25.0).abs() < 1e-9);
        assert!((area(&union_all([&a, &b])) - 175.0).abs() < 1e-9);
        let far = square(100.0, 100.0, 1.0);
        assert!(overlap(&a, &far).0.is_empty());
        assert_eq!(to_wkt(&overlap(&a, &far)), "POLYGON EMPTY");
        // (A ∪ B) ∩ C
        let c = square(8.0, -5.0, 10.0);
        let m = overlap_with_union([&a, &b], &c);
        // A∩C = [8,10]x[0,5] (10) ; B∩C = [8,15]x[5,5]: a line, no area
        assert!((area(&m) - 10.0).abs() < 1e-9);
        // Two disjoint pieces give a MULTIPOLYGON.
        let bar = from_vertices(&[(-1.0, 2.0), (20.0, 2.0), (20.0, 3.0), (-1.0, 3.0)]);
        let two = overlap(&bar, &union_all([&square(0.0, 0.0, 5.0), &square(10.0, 0.0, 5.0)]));
        assert_eq!(two.0.len(), 2);
        assert!(to_wkt(&two).starts_with("MULTIPOLYGON ((("));
    }

    /// Reference values from shapely 2.2.0 (GEOS 3.14): `a.intersection(b).area`,
    /// `union(a, b).area`, `a.buffer(-0.5).area`.
    #[test]
    fn pinned_against_shapely() {
        let a = Region::from_wkt("POLYGON ((0 0, 7.5 -1.25, 9 4, 5.5 8.25, 1 6, 0 0))").unwrap();
        let b = Region::from_wkt("POLYGON ((3 2, 11 0.5, 12 7, 4 9.5, 3 2), (6 4, 8 4, 7 6, 6 4))").unwrap();
        let (a, b) = (a.polygons(), b.polygons());
        // i_overlay snaps to a fine integer grid: agreement is ~1e-9 relative, not exact.
        assert!((area(&overlap(a, b)) / 26.765133171912833 - 1.0).abs() < 1e-8);
        assert!((area(&union_all([a, b])) / 88.35986682808716 - 1.0).abs() < 1e-8);
        // round joins are polygonised differently (GEOS: 8 segments per quadrant)
        assert!((area(&buffer(a, -0.5).unwrap()) - 45.2144326957364).abs() < 1e-6);
    }

    #[test]
    fn buffer_grows_and_shrinks() {
        let a = square(0.0, 0.0, 10.0);
        assert!((area(&buffer(&a, -1.0).unwrap()) - 64.0).abs() < 1e-6);
        let grown = area(&buffer(&a, 1.0).unwrap());
        // 100 + perimeter * 1 + pi (round corners, polygonised)
        assert!(grown > 143.0 && grown <= 140.0 + std::f64::consts::PI + 1e-9, "{grown}");
        assert!(buffer(&a, -6.0).unwrap().0.is_empty());
        assert!(buffer(&MultiPolygon(vec![]), 1.0).unwrap().0.is_empty());
    }

    #[test]
    fn wkb_round_trip() {
        for p in [MultiPolygon(vec![]), square(0.0, 0.0, 2.0), union_all([&square(0.0, 0.0, 1.0), &square(5.0, 0.0, 1.0)])] {
            let r = Region::from_wkb(&to_wkb(&p)).unwrap();
            assert_eq!(r.polygons().0.len(), p.0.len());
            assert!((area(r.polygons()) - area(&p)).abs() < 1e-12);
            let t = Region::from_wkt(&to_wkt(&p)).unwrap();
            assert!((area(t.polygons()) - area(&p)).abs() < 1e-12);
        }
        assert_eq!(to_wkt(&square(0.0, 0.0, 1.5)), "POLYGON ((0 0, 1.5 0, 1.5 1.5, 0 1.5, 0 0))");
    }
}
