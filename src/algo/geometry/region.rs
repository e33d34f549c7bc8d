//! Polygon regions (the thesis's overlap `P^{k∩l}`, sections 2.3 and 4.3.2) read from WKT or
//! WKB, validated once, and prepared for fast repeated point-in-polygon tests.
//!
//! * Parsing uses the `wkt` and `wkb` crates.
//! * Validation: every vertex must be finite and every ring simple. Self-intersection is found
//!   with `geo`'s sweep-line [`Intersections`] (a simplified Bentley–Ottmann); a ring that
//!   crosses or touches itself anywhere except between consecutive edges is rejected rather
//!   than silently reinterpreted (a bow-tie has no agreed inside). Relations *between* rings
//!   (holes touching the shell) are not checked; containment then follows the even–odd rule.
//! * Containment ([`Region::contains`]) is boundary-inclusive: a point on an edge counts as
//!   inside (the region is closed, like `ST_Intersects`, unlike `ST_Contains`).
//!
//! # The prepared index, and why it is hand-written
//! Each polygon's edges are bucketed into horizontal slabs (as many slabs as edges). A query
//! rejects on the bounding box, picks its slab in O(1) and runs the crossing-number test over
//! the few edges in it, with `geo`'s robust `orient2d` for the side and on-edge tests.
//! `geo` 0.33 has `IntervalTreeMultiPolygon`, but its public API answers only `Contains`
//! (boundary excluded), and `Intersects<Coord>` on a plain `MultiPolygon` is O(V). The bench
//! `cargo bench --no-default-features --bench polygon` measures all three on a 50-vertex
//! polygon; the slab index is the fastest there and is the only one that is boundary-inclusive
//! and sub-linear, so it is used. A property test checks it against `geo`'s `Intersects`.
//!
//! # Complexity
//! Parsing and preparing is O(V log V) for V vertices (plus the sweep's x-overlap pairs).
//! [`Region::contains`] is O(1) outside the bounding box and O(edges in one slab) inside it,
//! which is O(1) for polygons whose edges are spread in y; [`inside_indices`] is O(n) such tests.

use geo::sweep::{Cross, Intersections};
use geo::{BoundingRect, Coord, GeoNum, Geometry, Kernel, Line, LineIntersection, MultiPolygon, Orientation, Rect};
use crate::algo::traj::{OwnedTraj, Traj};
use crate::algo::{finite, ParamError};
use std::fmt;

/// Why a region could not be used.
#[derive(Clone, Debug, PartialEq)]
pub enum RegionError {
    /// The text is not valid WKT.
    Wkt(String),
    /// The bytes are not valid WKB.
    Wkb(String),
    /// Valid geometry, but not a POLYGON or MULTIPOLYGON.
    NotPolygon(&'static str),
    /// A vertex is NaN or infinite.
    NotFinite,
    /// A ring crosses or touches itself (near the given point).
    SelfIntersection { x: f64, y: f64 },
    /// A ring with fewer than 4 points (3 distinct corners and the closing point).
    ShortRing { points: usize },
    /// A vertex beyond ±[`MAX_COORD`]: areas and intersections would overflow.
    Magnitude { x: f64, y: f64 },
}

/// Largest |coordinate| of a polygon vertex: products of two coordinates (areas, orientation
/// tests) stay far from overflow. Larger polygons are refused, not computed wrongly.
pub const MAX_COORD: f64 = 1e150;

impl fmt::Display for RegionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RegionError::Wkt(e) => write!(f, "invalid WKT: {e}"),
            RegionError::Wkb(e) => write!(f, "invalid WKB: {e}"),
            RegionError::NotPolygon(k) => write!(f, "must be a POLYGON or MULTIPOLYGON, got {k}"),
            RegionError::NotFinite => write!(f, "has a NaN or infinite vertex"),
            RegionError::SelfIntersection { x, y } => {
                write!(f, "is not a valid polygon: a ring intersects itself at ({x} {y})")
            }
            RegionError::ShortRing { points } => {
                write!(f, "is not a valid polygon: a ring has {points} points, fewer than 4 (3 corners and the closing point)")
            }
            RegionError::Magnitude { x, y } => write!(f, "has a vertex ({x:?} {y:?}) beyond ±{MAX_COORD:e}"),
        }
    }
}
impl std::error::Error for RegionError {}

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
    fn new(poly: &geo::Polygon<f64>) -> Option<Self> {
        let bbox = poly.bounding_rect()?;
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
        let nslab = all.len().clamp(1, 1 << 16);
        let (y0, height) = (bbox.min().y, bbox.height());
        let inv_h = if height > 0.0 { nslab as f64 / height } else { 0.0 };
        let slab = |y: f64| (((y - y0) * inv_h) as usize).min(nslab - 1);
        let mut count = vec![0u32; nslab + 1];
        for e in &all {
            for s in slab(e.y_lo)..=slab(e.y_hi) {
                count[s + 1] += 1;
            }
        }
        for s in 0..nslab {
            count[s + 1] += count[s];
        }
        let mut fill = count.clone();
        let mut edges = vec![all.first().copied()?; count[nslab] as usize];
        for e in &all {
            for s in slab(e.y_lo)..=slab(e.y_hi) {
                edges[fill[s] as usize] = *e;
                fill[s] += 1;
            }
        }
        Some(SlabIndex { bbox, y0, inv_h, start: count, edges })
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

/// A ring edge tagged with its position, so that the sweep can tell neighbours apart.
#[derive(Clone, Copy, Debug)]
struct RingEdge {
    line: Line<f64>,
    k: usize,
}
impl Cross for RingEdge {
    type Scalar = f64;
    fn line(&self) -> Line<f64> {
        self.line
    }
}

/// First point where `ring` (closed, repeated points removed) crosses or touches itself.
/// O((V + m) log V) with m the x-overlapping edge pairs (geo's sweep).
fn ring_self_intersection(ring: &geo::LineString<f64>) -> Option<Coord<f64>> {
    let edges: Vec<RingEdge> = ring
        .lines()
        .filter(|l| l.start != l.end)
        .enumerate()
        .map(|(k, line)| RingEdge { line, k })
        .collect();
    let n = edges.len();
    if n < 3 {
        // A ring of fewer than three edges has no area; it cannot "contain" anything and the
        // crossing test treats it as empty, so it is harmless.
        return None;
    }
    let lines: Vec<Line<f64>> = edges.iter().map(|e| e.line).collect();
    for (a, b, hit) in Intersections::from_iter(edges) {
        let (i, j) = (a.k.min(b.k), a.k.max(b.k));
        // The vertex consecutive edges share: end of the earlier = start of the later.
        let shared = if j == i + 1 {
            Some(lines[i].end)
        } else if i == 0 && j == n - 1 {
            Some(lines[0].start)
        } else {
            None
        };
        match hit {
            // Consecutive edges may meet only at their shared vertex.
            LineIntersection::SinglePoint { intersection, .. } if Some(intersection) == shared => {}
            LineIntersection::SinglePoint { intersection, .. } => return Some(intersection),
            // Overlapping collinear edges: a spike or a doubled-back ring.
            LineIntersection::Collinear { intersection } => return Some(intersection.start),
        }
    }
    None
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

    /// Validates (finite vertices, simple rings) and prepares `poly`.
    /// Polygons with an empty shell (`POLYGON EMPTY` parts) are dropped.
    pub fn from_multipolygon(mut poly: MultiPolygon<f64>) -> Result<Self, RegionError> {
        poly.0.retain(|p| !p.exterior().0.is_empty());
        let rings = || poly.0.iter().flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()));
        if !rings().flat_map(|r| r.0.iter()).all(|c| c.x.is_finite() && c.y.is_finite()) {
            return Err(RegionError::NotFinite);
        }
        if let Some(c) = rings().flat_map(|r| r.0.iter()).find(|c| c.x.abs() > MAX_COORD || c.y.abs() > MAX_COORD) {
            return Err(RegionError::Magnitude { x: c.x, y: c.y });
        }
        if let Some(r) = rings().find(|r| r.0.len() < 4) {
            return Err(RegionError::ShortRing { points: r.0.len() });
        }
        if let Some(c) = rings().find_map(ring_self_intersection) {
            return Err(RegionError::SelfIntersection { x: c.x, y: c.y });
        }
        let index = poly.0.iter().filter_map(SlabIndex::new).collect();
        Ok(Region { poly, index })
    }

    /// Parses `POLYGON (...)` or `MULTIPOLYGON (...)` (EMPTY allowed: it contains nothing).
    pub fn from_wkt(s: &str) -> Result<Self, RegionError> {
        use wkt::TryFromWkt;
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

    pub fn polygons(&self) -> &MultiPolygon<f64> {
        &self.poly
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
        let nan = crate::algo::geometry::polygon::from_vertices(&[(0.0, 0.0), (f64::NAN, 0.0), (1.0, 1.0)]);
        assert_eq!(Region::from_multipolygon(nan).unwrap_err(), RegionError::NotFinite);
        let r = Region::from_wkt("POLYGON ((0 0, 10 0, 10 10, 0 0))").unwrap();
        assert!(!r.contains(f64::NAN, 1.0) && !r.contains(5.0, f64::NAN));
        // degenerate (zero-area) polygon contains only its boundary
        let flat = Region::from_wkt("POLYGON ((0 0, 10 0, 5 0, 0 0))");
        assert!(flat.is_err() || !flat.unwrap().contains(20.0, 0.0));
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
