//! Why a polygon could not be used ([`RegionError`]), for every polygon argument of every SQL
//! function alike, and the names of its rings in the messages ([`RingId`]). A leaf: the parser
//! ([`super::region`]) and the validation ([`super::valid`]) both return these errors and import
//! nothing of each other's for it.

use std::fmt;

/// A ring of a (multi)polygon, 0-based; shown 1-based.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RingId {
    pub polygon: usize,
    /// `None` for the shell.
    pub hole: Option<usize>,
}

impl fmt::Display for RingId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.hole {
            None => write!(f, "the shell of polygon {}", self.polygon + 1),
            Some(h) => write!(f, "hole {} of polygon {}", h + 1, self.polygon + 1),
        }
    }
}

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
    /// WKT nested deeper than [`MAX_WKT_DEPTH`] parentheses.
    WktTooDeep { depth: usize },
    /// A ring with fewer than 3 distinct corners.
    Degenerate { ring: RingId, corners: usize },
    /// Two rings cross (near the given point).
    Crossing { a: RingId, b: RingId, x: f64, y: f64 },
    /// Two rings share a stretch of boundary (from the given point).
    SharedBoundary { a: RingId, b: RingId, x: f64, y: f64 },
    /// A hole is not inside its shell (the point is in the hole, outside the shell).
    HoleOutside { hole: RingId, x: f64, y: f64 },
    /// A hole lies inside another hole of the same polygon.
    HoleInHole { inner: RingId, outer: RingId, x: f64, y: f64 },
    /// Parts `a` and `b` (0-based) of a MULTIPOLYGON overlap (the point is in both).
    PartsOverlap { a: usize, b: usize, x: f64, y: f64 },
    /// Validation would need more than [`super::valid::MAX_EDGE_TESTS`] edge-pair tests.
    TooComplex { tests: u64, cap: u64 },
    /// The index of a polygon this large could not be allocated.
    TooLarge { edges: usize },
}

/// Deepest parenthesis nesting accepted in WKT, as the `wkb` reader's 128 GEOMETRYCOLLECTION
/// levels (a POLYGON needs 2, a MULTIPOLYGON 3).
pub const MAX_WKT_DEPTH: usize = 128;

const REPAIR: &str = "fix the data, or repair it with ST_MakeValid and the method you mean";
const UNITE: &str = "pass them as separate elements of polygon_union to unite them";

/// How to fix a problem between rings `a` and `b`: parts of a MULTIPOLYGON that meet can be
/// united by polygon_union.
fn repair(a: &RingId, b: &RingId) -> String {
    if a.polygon != b.polygon {
        format!("if the polygons are meant to overlap, {UNITE}; else {REPAIR}")
    } else {
        REPAIR.to_string()
    }
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
            RegionError::WktTooDeep { depth } => write!(
                f,
                "is WKT nested {depth} parentheses deep, above the cap of {MAX_WKT_DEPTH} \
                 (a POLYGON needs 2, a MULTIPOLYGON 3); pass a POLYGON or MULTIPOLYGON"
            ),
            RegionError::Degenerate { ring, corners } => {
                write!(f, "is not a valid polygon: {ring} has {corners} distinct corners, fewer than 3")
            }
            RegionError::Crossing { a, b, x, y } => {
                write!(f, "is not a valid polygon: {a} and {b} cross at ({x} {y}); {}", repair(a, b))
            }
            RegionError::SharedBoundary { a, b, x, y } => write!(
                f,
                "is not a valid polygon: {a} and {b} share a stretch of boundary from ({x} {y}) \
                 (rings may touch only at points); {}",
                repair(a, b)
            ),
            RegionError::HoleOutside { hole, x, y } => write!(
                f,
                "is not a valid polygon: {hole} is not inside its shell ({x} {y} is in the hole, outside the shell); {REPAIR}"
            ),
            RegionError::HoleInHole { inner, outer, x, y } => {
                write!(f, "is not a valid polygon: {inner} lies inside {outer} (at {x} {y}); {REPAIR}")
            }
            RegionError::PartsOverlap { a, b, x, y } => write!(
                f,
                "is not a valid polygon: polygons {} and {} of the MULTIPOLYGON overlap (at {x} {y}); \
                 {UNITE}, or {REPAIR}",
                a + 1,
                b + 1
            ),
            RegionError::TooComplex { tests, cap } => write!(
                f,
                "is too complex to validate: {tests} edge-pair tests, above the cap of {cap}; simplify it (fewer vertices)"
            ),
            RegionError::TooLarge { edges } => {
                write!(f, "has {edges} edges: the index could not be allocated; simplify it (fewer vertices)")
            }
        }
    }
}
impl std::error::Error for RegionError {}
