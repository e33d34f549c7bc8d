//! Polygon regions (the thesis's overlap `P^{k∩l}`, sections 2.3 and 4.3.2) read from WKT or
//! WKB, validated once, and prepared for fast repeated point-in-polygon tests.
//!
//! * Parsing uses the `wkt` and `wkb` crates. Both parse GEOMETRYCOLLECTIONs recursively, one
//!   stack frame per level: the `wkb` reader stops at 128 levels, and [`Region::from_wkt`]
//!   counts the parenthesis depth first (a linear scan; WKT has no string literals) and
//!   refuses more than [`MAX_WKT_DEPTH`] = 128 levels before the parser sees the text (10,000
//!   levels overflowed the stack and killed the host). A polygon needs 2 levels, a
//!   MULTIPOLYGON 3.
//! * Validation and ring orientation: [`super::valid`], the one gate every polygon passes
//!   ([`Region::from_multipolygon`]). Shells come out counter-clockwise, holes clockwise;
//!   invalid polygons are refused (the module documents the rules and why they are not repaired).
//! * Containment ([`Region::contains`]) is boundary-inclusive: a point on an edge counts as
//!   inside (the region is closed, like `ST_Intersects`, unlike `ST_Contains`).
//!
//! # The prepared index, and why it is hand-written
//! Each polygon's edges are bucketed into horizontal slabs ([`Slabs`]: about as many slabs as
//! edges, fewer when the edges are tall, so that the index stays O(V)). A query rejects on the
//! bounding box, picks its slab in O(1) and runs the crossing-number test over the edges in it,
//! with `geo`'s robust `orient2d` for the side and on-edge tests.
//! `geo` 0.33 has `IntervalTreeMultiPolygon`, but its public API answers only `Contains`
//! (boundary excluded), and `Intersects<Coord>` on a plain `MultiPolygon` is O(V). The bench
//! `cargo bench --no-default-features --bench polygon` measures all three on a 50-vertex
//! polygon; the slab index is the fastest there and is the only one that is boundary-inclusive
//! and sub-linear, so it is used. A property test checks it against `geo`'s `Intersects`.
//!
//! # Complexity
//! Parsing is O(n) for n bytes or V vertices; validation is O(V log V + m) (see [`super::valid`]);
//! preparing is O(V). [`Region::contains`] is O(1) outside the bounding box and O(edges in one
//! slab) inside it, which is O(1) for polygons whose edges are spread in y (and O(V) for a comb
//! whose every edge spans its height: a horizontal ray then crosses them all);
//! [`inside_indices`] is O(n) such tests.

pub use super::error::{RegionError, MAX_COORD, MAX_WKT_DEPTH};
use super::slabs::Slabs;
use super::valid;
use geo::{BoundingRect, Coord, GeoNum, Geometry, Kernel, MultiPolygon, Orientation, Rect};
use crate::traj::{OwnedTraj, Traj};
use crate::{finite, ParamError};

/// The deepest parenthesis nesting of `s` (a `)` without its `(` counts as nothing, so this is
/// never below the depth the parser would reach). O(n), no recursion.
pub fn wkt_depth(s: &str) -> usize {
    let (mut depth, mut deepest) = (0usize, 0usize);
    for b in s.bytes() {
        match b {
            b'(' => {
                depth += 1;
                deepest = deepest.max(depth);
            }
            b')' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    deepest
}



/// One edge in a slab, with its y-range and largest x kept inline for early rejection.
#[derive(Clone, Copy, Debug)]
struct Edge {
    a: Coord<f64>,
    b: Coord<f64>,
    y_lo: f64,
    y_hi: f64,
    x_hi: f64,
}

/// The slab index of one polygon (shell and holes together: even–odd rule).
#[derive(Clone, Debug)]
struct SlabIndex {
    bbox: Rect<f64>,
    y0: f64,
    inv_h: f64,
    /// `edges[start[s]..start[s + 1]]` are the edges whose y-range meets slab `s`.
    start: Vec<u32>,
    edges: Vec<Edge>,
}

impl SlabIndex {
    /// `None` for a polygon without edges.
    fn new(poly: &geo::Polygon<f64>) -> Result<Option<Self>, RegionError> {
        let Some(bbox) = poly.bounding_rect() else { return Ok(None) };
        let all: Vec<Edge> = std::iter::once(poly.exterior())
            .chain(poly.interiors())
            .flat_map(|r| r.lines())
            .filter(|l| l.start != l.end)
            .map(|l| Edge {
                a: l.start,
                b: l.end,
                y_lo: l.start.y.min(l.end.y),
                y_hi: l.start.y.max(l.end.y),
                x_hi: l.start.x.max(l.end.x),
            })
            .collect();
        if all.is_empty() {
            return Ok(None);
        }
        let ranges: Vec<(f64, f64)> = all.iter().map(|e| (e.y_lo, e.y_hi)).collect();
        let slabs = Slabs::new(&ranges, bbox.min().y, bbox.height())?;
        let mut edges = Vec::new();
        edges.try_reserve_exact(slabs.items.len()).map_err(|_| RegionError::TooLarge { edges: all.len() })?;
        edges.extend(slabs.items.iter().map(|&k| all[k as usize]));
        Ok(Some(SlabIndex { bbox, y0: slabs.y0, inv_h: slabs.inv_h, start: slabs.start, edges }))
    }

    /// Boundary-inclusive containment; `x`, `y` finite.
    #[inline]
    fn contains(&self, x: f64, y: f64) -> bool {
        let (lo, hi) = (self.bbox.min(), self.bbox.max());
        if !(x >= lo.x && x <= hi.x && y >= lo.y && y <= hi.y) {
            return false;
        }
        let nslab = self.start.len() - 1;
        let s = (((y - self.y0) * self.inv_h) as usize).min(nslab - 1);
        let p = Coord { x, y };
        let mut inside = false;
        for e in &self.edges[self.start[s] as usize..self.start[s + 1] as usize] {
            if y < e.y_lo || y > e.y_hi || x > e.x_hi {
                continue; // cannot touch p nor cross the ray to its right
            }
            let o = <f64 as GeoNum>::Ker::orient2d(e.a, e.b, p);
            if o == Orientation::Collinear && x >= e.a.x.min(e.b.x) {
                return true; // on the edge (y and x both within the edge's box)
            }
            // Half-open crossing rule: an upward edge counts when p is on its left, a downward
            // one when p is on its right; horizontal edges never count.
            if (e.a.y <= y) != (e.b.y <= y) {
                let up = e.b.y > e.a.y;
                if (up && o == Orientation::CounterClockwise) || (!up && o == Orientation::Clockwise) {
                    inside = !inside;
                }
            }
        }
        inside
    }
}

/// A closed polygonal region, validated and prepared for repeated containment tests.
#[derive(Clone, Debug)]
pub struct Region {
    poly: MultiPolygon<f64>,
    index: Vec<SlabIndex>,
}

fn kind(g: &Geometry<f64>) -> &'static str {
    match g {
        Geometry::Point(_) => "POINT",
        Geometry::Line(_) => "LINE",
        Geometry::LineString(_) => "LINESTRING",
        Geometry::Polygon(_) => "POLYGON",
        Geometry::MultiPoint(_) => "MULTIPOINT",
        Geometry::MultiLineString(_) => "MULTILINESTRING",
        Geometry::MultiPolygon(_) => "MULTIPOLYGON",
        Geometry::GeometryCollection(_) => "GEOMETRYCOLLECTION",
        Geometry::Rect(_) => "RECT",
        Geometry::Triangle(_) => "TRIANGLE",
    }
}

impl Region {
    pub fn from_geometry(g: Geometry<f64>) -> Result<Self, RegionError> {
        let poly = match g {
            Geometry::Polygon(p) => MultiPolygon(vec![p]),
            Geometry::MultiPolygon(mp) => mp,
            Geometry::Rect(r) => MultiPolygon(vec![r.to_polygon()]),
            other => return Err(RegionError::NotPolygon(kind(&other))),
        };
        Self::from_multipolygon(poly)
    }

    /// The one gate: validates `poly` and normalises its rings ([`valid::normalise`]), then
    /// prepares the index. Polygons with an empty shell (`POLYGON EMPTY` parts) are dropped.
    pub fn from_multipolygon(poly: MultiPolygon<f64>) -> Result<Self, RegionError> {
        let poly = valid::normalise(poly)?;
        let mut index = Vec::new();
        for p in &poly.0 {
            if let Some(ix) = SlabIndex::new(p)? {
                index.push(ix);
            }
        }
        Ok(Region { poly, index })
    }

    /// Parses `POLYGON (...)` or `MULTIPOLYGON (...)` (EMPTY allowed: it contains nothing).
    /// Text nested deeper than [`MAX_WKT_DEPTH`] parentheses is refused before parsing.
    pub fn from_wkt(s: &str) -> Result<Self, RegionError> {
        use wkt::TryFromWkt;
        let depth = wkt_depth(s);
        if depth > MAX_WKT_DEPTH {
            return Err(RegionError::WktTooDeep { depth });
        }
        let g: Geometry<f64> = Geometry::try_from_wkt_str(s.trim()).map_err(|e| RegionError::Wkt(e.to_string()))?;
        Self::from_geometry(g)
    }

    /// Parses ISO/OGC WKB (either byte order). Z/M ordinates are dropped.
    pub fn from_wkb(bytes: &[u8]) -> Result<Self, RegionError> {
        use geo_traits::to_geo::ToGeoGeometry;
        let w = wkb::reader::read_wkb(bytes).map_err(|e| RegionError::Wkb(e.to_string()))?;
        let g = w
            .try_to_geometry()
            .ok_or_else(|| RegionError::Wkb("empty point geometry".to_string()))?;
        Self::from_geometry(g)
    }

    /// The polygons: valid, shells counter-clockwise, holes clockwise.
    pub fn polygons(&self) -> &MultiPolygon<f64> {
        &self.poly
    }

    /// [`Region::polygons`], by value.
    pub fn into_polygons(self) -> MultiPolygon<f64> {
        self.poly
    }

    /// [`Region::contains`] for a point that must be finite (`polygon_contains`).
    pub fn contains_checked(&self, x: f64, y: f64) -> Result<bool, ParamError> {
        Ok(self.contains(finite("x", x)?, finite("y", y)?))
    }

    /// Boundary-inclusive point-in-polygon test; NaN coordinates are never inside.
    #[inline]
    pub fn contains(&self, x: f64, y: f64) -> bool {
        self.index.iter().any(|ix| ix.contains(x, y))
    }
}

/// Indices (0-based, increasing) of the points of `(x, y)` that lie in `region`.
pub fn inside_indices(x: &[f64], y: &[f64], region: &Region) -> Vec<usize> {
    (0..x.len()).filter(|&k| region.contains(x[k], y[k])).collect()
}

/// The points of `tr` inside `region` (`traj_clip`), in order, with their 0-based positions in
/// `tr`. O(n · c) for c the cost of one [`Region::contains`].
pub fn clip(tr: Traj<'_>, region: &Region) -> (OwnedTraj, Vec<usize>) {
    let idx = inside_indices(tr.x, tr.y, region);
    (tr.select(&idx), idx)
}

/// How many points of `tr` lie inside `region` (`traj_points_inside`), without building them.
pub fn count_inside(tr: Traj<'_>, region: &Region) -> usize {
    (0..tr.len()).filter(|&k| region.contains(tr.x[k], tr.y[k])).count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo::Intersects;

    #[test]
    fn wkt_and_wkb_agree() {
        let r = Region::from_wkt("POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))").unwrap();
        assert!(r.contains(5.0, 5.0));
        assert!(r.contains(10.0, 5.0), "boundary is inside");
        assert!(!r.contains(10.5, 5.0));
        // Little-endian WKB of the same square.
        let mut wkb = vec![1u8, 3, 0, 0, 0, 1, 0, 0, 0, 5, 0, 0, 0];
        for (x, y) in [(0.0f64, 0.0f64), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)] {
            wkb.extend_from_slice(&x.to_le_bytes());
            wkb.extend_from_slice(&y.to_le_bytes());
        }
        let r2 = Region::from_wkb(&wkb).unwrap();
        assert!(r2.contains(5.0, 5.0) && !r2.contains(-1.0, 5.0));
    }

    #[test]
    fn errors_and_empty() {
        assert!(matches!(Region::from_wkt("POLYGON ((0 0, 1"), Err(RegionError::Wkt(_))));
        assert_eq!(
            Region::from_wkt("LINESTRING (0 0, 1 1)").unwrap_err().to_string(),
            "must be a POLYGON or MULTIPOLYGON, got LINESTRING"
        );
        assert!(matches!(Region::from_wkb(&[1, 2, 3]), Err(RegionError::Wkb(_))));
        let e = Region::from_wkt("POLYGON EMPTY").unwrap();
        assert!(!e.contains(0.0, 0.0));
        let holes = Region::from_wkt("POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0), (4 4, 6 4, 6 6, 4 6, 4 4))").unwrap();
        assert!(!holes.contains(5.0, 5.0) && holes.contains(1.0, 1.0));
        assert_eq!(inside_indices(&[1.0, 5.0, 20.0], &[1.0, 5.0, 1.0], &holes), vec![0]);
    }

    /// Issue 17: a ring of fewer than 4 points, and vertices whose products would overflow,
    /// are errors (they used to give false / NaN / EMPTY silently).
    #[test]
    fn short_rings_and_huge_vertices_are_rejected() {
        assert_eq!(Region::from_wkt("POLYGON((0 0,1 1))").unwrap_err().to_string(), "is not a valid polygon: a ring has 3 points, fewer than 4 (3 corners and the closing point)");
        assert!(matches!(Region::from_wkt("POLYGON((0 0,1 0,0 0))").unwrap_err(), RegionError::ShortRing { .. }));
        assert!(Region::from_wkt("POLYGON((0 0,1 0,1 1,0 0))").is_ok());
        assert!(matches!(Region::from_wkt("POLYGON((0 0,1e200 0,1e200 1e200,0 0))").unwrap_err(), RegionError::Magnitude { .. }));
        assert!(Region::from_wkt("POLYGON((0 0,1e100 0,1e100 1e100,0 0))").unwrap().contains(0.9e100, 0.1e100));
        assert!(Region::from_wkt("POLYGON EMPTY").is_ok());
    }

    #[test]
    fn self_intersection_and_nan_are_rejected() {
        let bow = Region::from_wkt("POLYGON ((0 0, 10 10, 10 0, 0 10, 0 0))").unwrap_err();
        assert_eq!(bow, RegionError::SelfIntersection { x: 5.0, y: 5.0 });
        assert_eq!(bow.to_string(), "is not a valid polygon: a ring intersects itself at (5 5)");
        // spike (edge doubling back on itself)
        assert!(matches!(
            Region::from_wkt("POLYGON ((0 0, 10 0, 10 10, 10 5, 10 20, 0 10, 0 0))"),
            Err(RegionError::SelfIntersection { .. })
        ));
        // repeated vertices are fine
        assert!(Region::from_wkt("POLYGON ((0 0, 10 0, 10 0, 10 10, 0 10, 0 0))").is_ok());
        let nan = crate::geometry::polygon::from_vertices(&[(0.0, 0.0), (f64::NAN, 0.0), (1.0, 1.0)]);
        assert_eq!(Region::from_multipolygon(nan).unwrap_err(), RegionError::NotFinite);
        let r = Region::from_wkt("POLYGON ((0 0, 10 0, 10 10, 0 0))").unwrap();
        assert!(!r.contains(f64::NAN, 1.0) && !r.contains(5.0, f64::NAN));
        // degenerate (zero-area) polygon contains only its boundary
        let flat = Region::from_wkt("POLYGON ((0 0, 10 0, 5 0, 0 0))");
        assert!(flat.is_err() || !flat.unwrap().contains(20.0, 0.0));
    }

    /// The host crash: WKT nested 10,000 levels deep overflowed the stack in the `wkt`
    /// parser. Now refused before parsing, in a thread with a small stack (256 KiB; DuckDB's
    /// threads have more), while the deepest accepted nesting still parses there.
    #[test]
    fn deep_wkt_and_wkb_are_refused_without_recursing() {
        let run = |f: Box<dyn FnOnce() -> Result<Region, RegionError> + Send>| std::thread::Builder::new().stack_size(256 << 10).spawn(f).unwrap().join().unwrap();
        let deep = |n: usize| format!("{}POINT(0 0){}", "GEOMETRYCOLLECTION(".repeat(n), ")".repeat(n));
        let e = run(Box::new(move || Region::from_wkt(&deep(10_000)))).unwrap_err();
        assert_eq!(e, RegionError::WktTooDeep { depth: 10_001 });
        assert_eq!(e.to_string(), "is WKT nested 10001 parentheses deep, above the cap of 128 (a POLYGON needs 2, a MULTIPOLYGON 3); pass a POLYGON or MULTIPOLYGON");
        // unbalanced text counts its deepest open nesting; a stray ')' never lowers it below 0
        assert_eq!(wkt_depth(&"(".repeat(500)), 500);
        assert_eq!(wkt_depth(&format!("))))){}", "(".repeat(200))), 200);
        assert_eq!(wkt_depth("MULTIPOLYGON (((0 0, 1 0, 1 1, 0 0)), ((5 5, 6 5, 6 6, 5 5)))"), 3);
        // 128 levels (127 collections around a point) reach the parser and its answer
        assert_eq!(run(Box::new(move || Region::from_wkt(&deep(127)))).unwrap_err(), RegionError::NotPolygon("GEOMETRYCOLLECTION"));
        assert_eq!(run(Box::new(move || Region::from_wkt(&deep(128)))).unwrap_err(), RegionError::WktTooDeep { depth: 129 });
        // WKB: the wkb reader stops at 128 collection levels itself
        let wkb = |n: usize| {
            let mut b: Vec<u8> = [1u8, 7, 0, 0, 0, 1, 0, 0, 0].repeat(n);
            b.extend_from_slice(&[1, 1, 0, 0, 0]);
            b.extend_from_slice(&[0u8; 16]);
            b
        };
        assert!(matches!(run(Box::new(move || Region::from_wkb(&wkb(10_000)))), Err(RegionError::Wkb(_))));
        assert_eq!(run(Box::new(move || Region::from_wkb(&wkb(100)))).unwrap_err(), RegionError::NotPolygon("GEOMETRYCOLLECTION"));
    }

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A random star-shaped (hence simple) polygon with `v` vertices, optionally with a hole.
    fn star(v: usize, seed: &mut u64, hole: bool) -> geo::Polygon<f64> {
        let ring = |r0: f64, r1: f64, s: &mut u64, n: usize| -> geo::LineString<f64> {
            geo::LineString(
                (0..n)
                    .map(|k| {
                        let a = std::f64::consts::TAU * (k as f64 + 0.3 * lcg(s)) / n as f64;
                        let r = r0 + (r1 - r0) * lcg(s);
                        // integer-ish coordinates make boundary hits exact and common
                        Coord { x: (r * a.cos()).round(), y: (r * a.sin()).round() }
                    })
                    .collect(),
            )
        };
        let ext = ring(60.0, 100.0, seed, v);
        let holes = if hole { vec![ring(10.0, 20.0, seed, 8)] } else { vec![] };
        geo::Polygon::new(ext, holes)
    }

    /// The slab index agrees with geo's boundary-inclusive `Intersects<Coord>` on random
    /// polygons, at random points, at every vertex and at edge midpoints.
    #[test]
    fn slab_index_matches_geo_intersects() {
        use geo::Validation;
        let mut seed = 11u64;
        let mut checked = 0;
        for case in 0..200 {
            let p = star(3 + case % 60, &mut seed, case % 3 == 0);
            if !p.is_valid() {
                continue;
            }
            let mp = MultiPolygon(vec![p]);
            let r = Region::from_multipolygon(mp.clone()).unwrap();
            let mut pts: Vec<Coord<f64>> =
                (0..300).map(|_| Coord { x: (lcg(&mut seed) * 240.0 - 120.0).round(), y: lcg(&mut seed) * 240.0 - 120.0 }).collect();
            for l in mp.0[0].exterior().lines().chain(mp.0[0].interiors().iter().flat_map(|h| h.lines())) {
                pts.push(l.start);
                pts.push(Coord { x: (l.start.x + l.end.x) / 2.0, y: (l.start.y + l.end.y) / 2.0 });
            }
            for c in pts {
                assert_eq!(r.contains(c.x, c.y), mp.intersects(&c), "case {case} at {c:?}");
                checked += 1;
            }
        }
        assert!(checked > 50_000);
    }
}
