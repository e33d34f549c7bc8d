//! Polygon regions (the thesis's overlap `P^{k∩l}`) read from WKT or WKB, and the restriction
//! of a trajectory to the points inside one.
//!
//! Parsing uses the `wkt` and `wkb` crates; containment uses `geo`'s boundary-inclusive
//! `Intersects<Coord>`: a point on the boundary counts as inside (the region is closed).
//!
//! # Complexity
//! Parsing is O(V) for V vertices. [`Region::contains`] is O(1) when the point falls outside
//! the bounding box and O(V) otherwise; [`restrict`] is O(n·V) worst case.

use geo::{BoundingRect, Coord, Geometry, Intersects, MultiPolygon, Rect};
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
}

impl fmt::Display for RegionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RegionError::Wkt(e) => write!(f, "invalid WKT: {e}"),
            RegionError::Wkb(e) => write!(f, "invalid WKB: {e}"),
            RegionError::NotPolygon(k) => write!(f, "must be a POLYGON or MULTIPOLYGON, got {k}"),
            RegionError::NotFinite => write!(f, "has a NaN or infinite vertex"),
        }
    }
}
impl std::error::Error for RegionError {}

/// A closed polygonal region, ready for repeated containment tests.
#[derive(Clone, Debug)]
pub struct Region {
    poly: MultiPolygon<f64>,
    bbox: Option<Rect<f64>>,
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
        let finite = poly
            .0
            .iter()
            .flat_map(|p| p.exterior().0.iter().chain(p.interiors().iter().flat_map(|r| r.0.iter())))
            .all(|c| c.x.is_finite() && c.y.is_finite());
        if !finite {
            return Err(RegionError::NotFinite);
        }
        let bbox = poly.bounding_rect();
        Ok(Region { poly, bbox })
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

    /// Boundary-inclusive point-in-polygon test.
    #[inline]
    pub fn contains(&self, x: f64, y: f64) -> bool {
        match &self.bbox {
            None => false,
            Some(b) => {
                if x < b.min().x || x > b.max().x || y < b.min().y || y > b.max().y {
                    return false;
                }
                self.poly.intersects(&Coord { x, y })
            }
        }
    }
}

/// Indices (0-based, increasing) of the points of `(x, y)` that lie in `region`.
pub fn inside_indices(x: &[f64], y: &[f64], region: &Region) -> Vec<usize> {
    (0..x.len()).filter(|&k| region.contains(x[k], y[k])).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
