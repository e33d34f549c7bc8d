//! View polygons `P^k`: the polygon of all points of one class seen by camera k (thesis §2.3,
//! §4.2.2, figures 4.7, 4.13, 4.21, 4.26). The thesis builds them with shapely and does not say
//! which hull; we offer the convex hull (default, best match to a camera's field of view) and a
//! concave hull, both from `geo`.
//!
//! * **convex**: `geo`'s `ConvexHull` (quickhull).
//! * **concave**: `geo`'s `ConcaveHull`, a port of mapbox/concaveman. Its `concavity` plays the
//!   role of the `ratio` of DuckDB spatial's `ST_ConcaveHull`, with a different scale: a hull
//!   edge of length L is drilled inward to an interior point only if that point lies within
//!   L / `concavity` of the edge. Small values (≈1) give a detailed, tightly wrapped shape;
//!   larger values a smoother one; `+∞` gives exactly the convex hull. Default 2.
//! * **robust (density rule)**: optional; before the hull, a point is kept only if at least
//!   `min_neighbours` other points lie within `radius` metres of it (the DBSCAN core-point rule).
//!   Real tracks at 10 Hz leave a dense trail; a handful of spurious detections do not, and so
//!   cannot inflate the view. (Dropping `estimated` points is done in SQL with a `WHERE`.)
//!
//! # Degenerate input (documented rule)
//! Empty input, fewer than three distinct points, or points that are all collinear (after the
//! density rule; or so nearly collinear that the hull is a sliver that touches itself in
//! floating point) have no area: the result is the empty polygon (`POLYGON EMPTY`), which
//! contains nothing and overlaps nothing. NaN or infinite coordinates, or beyond ±1e150, are an
//! error.
//!
//! # Complexity
//! Deduplication O(n log n) (parallel sort for large n); convex hull O(n log n); concave hull
//! O(n log n) expected (R-tree queries); the density rule O(n · k) expected with a uniform
//! grid of cell radius/√2 (a cell with more than k points keeps them all at once), stopping each
//! count at k = `min_neighbours` (parallel over points).

use geo::{Area, ConcaveHull, ConvexHull, Coord, LineString, MultiPoint, MultiPolygon, Point, Polygon};
use rayon::prelude::*;
use std::collections::HashMap;
use std::fmt;

/// Why a view polygon could not be built.
#[derive(Clone, Debug, PartialEq)]
pub enum HullError {
    UnknownMethod(String),
    Concavity(f64),
    Radius(f64),
    MinNeighbours(i64),
    /// 0-based index of a NaN or infinite point, and the field.
    NotFinite { index: usize, field: &'static str },
    /// 0-based index of a point beyond ±MAX_COORD, and the field.
    Magnitude { index: usize, field: &'static str },
    /// The hull is too large to validate or index.
    Polygon(super::region::RegionError),
}

impl fmt::Display for HullError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HullError::UnknownMethod(m) => write!(f, "method must be 'convex' or 'concave', got '{m}'"),
            HullError::Concavity(c) => write!(f, "param (concavity) must be > 0, got {c}"),
            HullError::Radius(r) => write!(f, "radius must be > 0 and finite, got {r}"),
            HullError::MinNeighbours(k) => write!(f, "min_neighbours must be >= 0, got {k}"),
            HullError::NotFinite { index, field } => {
                write!(f, "points[{}].{field} is NaN or infinite", index + 1)
            }
            HullError::Magnitude { index, field } => {
                write!(f, "points[{}].{field} is beyond ±{:e} (polygon areas would overflow)", index + 1, super::region::MAX_COORD)
            }
            HullError::Polygon(e) => write!(f, "the hull {e}"),
        }
    }
}
impl std::error::Error for HullError {}

/// Which hull.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HullMethod {
    Convex,
    Concave { concavity: f64 },
}

/// The robust option: keep a point only with `min_neighbours` others within `radius`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityRule {
    pub radius: f64,
    pub min_neighbours: usize,
}

/// Validated parameters of [`view_polygon`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HullParams {
    pub method: HullMethod,
    pub density: Option<DensityRule>,
}

/// Default concavity of the concave hull (concaveman's default).
pub const DEFAULT_CONCAVITY: f64 = 2.0;

impl HullParams {
    /// `method` is `'convex'` or `'concave'` (case-insensitive); `param` is the concavity of
    /// the concave hull (default 2, `+∞` = convex); `'convex'` ignores it (so that the robust
    /// form, which needs a value in that position, works for both methods).
    pub fn new(method: &str, param: Option<f64>) -> Result<Self, HullError> {
        let method = match method.trim().to_ascii_lowercase().as_str() {
            "convex" => HullMethod::Convex,
            "concave" => {
                let c = param.unwrap_or(DEFAULT_CONCAVITY);
                if !(c > 0.0) {
                    return Err(HullError::Concavity(c));
                }
                HullMethod::Concave { concavity: c }
            }
            _ => return Err(HullError::UnknownMethod(method.to_string())),
        };
        Ok(HullParams { method, density: None })
    }

    /// [`HullParams::new`], then [`HullParams::with_density`] when `density` is
    /// `Some((radius, min_neighbours))`: the arguments of `view_polygon`, checked once.
    pub fn parse(method: &str, param: Option<f64>, density: Option<(f64, i64)>) -> Result<Self, HullError> {
        let p = HullParams::new(method, param)?;
        match density {
            Some((radius, k)) => p.with_density(radius, k),
            None => Ok(p),
        }
    }

    /// Adds the density rule (robust option).
    pub fn with_density(mut self, radius: f64, min_neighbours: i64) -> Result<Self, HullError> {
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(HullError::Radius(radius));
        }
        if min_neighbours < 0 {
            return Err(HullError::MinNeighbours(min_neighbours));
        }
        self.density = Some(DensityRule { radius, min_neighbours: min_neighbours as usize });
        Ok(self)
    }
}

const PAR_MIN: usize = 50_000;

/// Indices of the points that have at least `rule.min_neighbours` other points within
/// `rule.radius` (boundary inclusive). Uniform grid of cell side radius/√2, so that any two
/// points of one cell are within the radius: a point whose cell holds more than
/// `min_neighbours` points is kept at once (O(1); stop-line queues and parked road users make
/// cells with thousands of points, which a radius-sized grid scanned point by point — measured
/// 6.8 s for 1 M simulated points, now a fraction of a second). Otherwise the count runs over the
/// 5×5 cells around it, own cell first, and stops at `min_neighbours`.
pub fn dense_points(x: &[f64], y: &[f64], rule: DensityRule) -> Vec<usize> {
    let n = x.len();
    if rule.min_neighbours == 0 {
        return (0..n).collect();
    }
    let r = rule.radius;
    let side = r / std::f64::consts::SQRT_2;
    let cell = |k: usize| ((x[k] / side).floor() as i64, (y[k] / side).floor() as i64);
    // Points sorted by cell; each cell is a range of `order`.
    let mut order: Vec<(i64, i64, u32)> = (0..n).map(|k| (cell(k).0, cell(k).1, k as u32)).collect();
    if n >= PAR_MIN {
        order.par_sort_unstable();
    } else {
        order.sort_unstable();
    }
    let mut ranges: HashMap<(i64, i64), (usize, usize)> = HashMap::new();
    let mut s = 0;
    while s < n {
        let mut e = s + 1;
        while e < n && order[e].0 == order[s].0 && order[e].1 == order[s].1 {
            e += 1;
        }
        ranges.insert((order[s].0, order[s].1), (s, e));
        s = e;
    }
    let r2 = r * r;
    // the own cell first, then the rest of the 5×5 block (cells 2 away can still hold points
    // within r = √2 sides)
    let mut offsets: Vec<(i64, i64)> = vec![(0, 0)];
    for dx in -2..=2i64 {
        for dy in -2..=2i64 {
            if (dx, dy) != (0, 0) {
                offsets.push((dx, dy));
            }
        }
    }
    let keep = |k: usize| {
        let (cx, cy) = cell(k);
        let mut count = 0usize;
        for (i, &(dx, dy)) in offsets.iter().enumerate() {
            let Some(&(s, e)) = ranges.get(&(cx + dx, cy + dy)) else { continue };
            if i == 0 && e - s > rule.min_neighbours {
                // two points of a cell are < side·√2 = r apart (up to one rounding of x/side at a
                // cell boundary, i.e. a relative 1e-16 of r: immaterial for a density rule)
                return true;
            }
            for &(_, _, j) in &order[s..e] {
                let j = j as usize;
                if j != k && (x[j] - x[k]).powi(2) + (y[j] - y[k]).powi(2) <= r2 {
                    count += 1;
                    if count >= rule.min_neighbours {
                        return true;
                    }
                }
            }
        }
        false
    };
    if n >= PAR_MIN {
        (0..n).into_par_iter().filter(|&k| keep(k)).collect()
    } else {
        (0..n).filter(|&k| keep(k)).collect()
    }
}

/// The empty polygon (`POLYGON EMPTY`).
pub fn empty() -> MultiPolygon<f64> {
    MultiPolygon(vec![])
}

/// The view polygon of the points `(x[k], y[k])` (see the module docs for the rules).
/// Returns a [`MultiPolygon`] with zero polygons (degenerate input) or one.
pub fn view_polygon(x: &[f64], y: &[f64], params: &HullParams) -> Result<MultiPolygon<f64>, HullError> {
    debug_assert_eq!(x.len(), y.len());
    for (k, (&a, &b)) in x.iter().zip(y).enumerate() {
        if !a.is_finite() {
            return Err(HullError::NotFinite { index: k, field: "x" });
        }
        if !b.is_finite() {
            return Err(HullError::NotFinite { index: k, field: "y" });
        }
        if a.abs() > super::region::MAX_COORD {
            return Err(HullError::Magnitude { index: k, field: "x" });
        }
        if b.abs() > super::region::MAX_COORD {
            return Err(HullError::Magnitude { index: k, field: "y" });
        }
    }
    let kept: Vec<usize> = match params.density {
        Some(rule) => dense_points(x, y, rule),
        None => (0..x.len()).collect(),
    };
    let mut pts: Vec<Coord<f64>> = kept.iter().map(|&k| Coord { x: x[k], y: y[k] }).collect();
    let by_xy = |a: &Coord<f64>, b: &Coord<f64>| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y));
    if pts.len() >= PAR_MIN {
        pts.par_sort_unstable_by(by_xy);
    } else {
        pts.sort_unstable_by(by_xy);
    }
    pts.dedup();
    if pts.len() < 3 {
        return Ok(empty());
    }
    let mp = MultiPoint(pts.into_iter().map(Point).collect());
    let convex = mp.convex_hull();
    if !(convex.unsigned_area() > 0.0) {
        return Ok(empty()); // all collinear
    }
    let hull = match params.method {
        HullMethod::Convex => convex,
        HullMethod::Concave { concavity } if concavity.is_infinite() => convex,
        HullMethod::Concave { concavity } => {
            let opts = geo::concave_hull::ConcaveHullOptions { concavity, length_threshold: 0.0 };
            let h = mp.concave_hull_with_options(opts);
            if h.unsigned_area() > 0.0 {
                h
            } else {
                convex
            }
        }
    };
    let out = MultiPolygon(vec![normalise(hull)]);
    // Nearly collinear points can give a sliver whose ring touches itself in floating point:
    // that is no area either, and every polygon function would refuse it. The result is the
    // gate's normalised polygon (counter-clockwise), like every polygon trajdb returns.
    use super::region::{Region, RegionError};
    match Region::from_multipolygon(out) {
        Ok(r) => Ok(r.into_polygons()),
        Err(e @ (RegionError::TooComplex { .. } | RegionError::TooLarge { .. })) => Err(HullError::Polygon(e)),
        Err(_) => Ok(empty()),
    }
}

/// Closed exterior ring, no holes (both hulls are simple polygons).
fn normalise(p: Polygon<f64>) -> Polygon<f64> {
    let (ext, _) = p.into_inner();
    Polygon::new(LineString(ext.0), vec![])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::region::Region;
    use geo::{Contains, Validation};

    fn cloud(n: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let mut s = seed;
        let mut r = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        // An L-shaped "road" layout: concave in the corner.
        (0..n)
            .map(|k| if k % 2 == 0 { (r() * 100.0, r() * 10.0) } else { (r() * 10.0, r() * 100.0) })
            .unzip()
    }

    #[test]
    fn convex_and_concave_cover_every_point() {
        let (x, y) = cloud(4000, 7);
        let conv = view_polygon(&x, &y, &HullParams::new("convex", None).unwrap()).unwrap();
        let conc = view_polygon(&x, &y, &HullParams::new("concave", Some(2.0)).unwrap()).unwrap();
        let (ac, ak) = (conv.unsigned_area(), conc.unsigned_area());
        assert!(ak < 0.5 * ac, "concave {ak} should hug the L, convex {ac}");
        for p in [&conv, &conc] {
            assert!(p.is_valid());
            let r = Region::from_multipolygon(p.clone()).unwrap();
            assert!((0..x.len()).all(|k| r.contains(x[k], y[k])), "hull must cover its points");
        }
        // concavity = +inf is the convex hull
        let inf = view_polygon(&x, &y, &HullParams::new("concave", Some(f64::INFINITY)).unwrap()).unwrap();
        assert_eq!(inf, conv);
    }

    #[test]
    fn degenerate_inputs_are_empty() {
        let p = HullParams::new("convex", None).unwrap();
        assert_eq!(view_polygon(&[], &[], &p).unwrap(), empty());
        assert_eq!(view_polygon(&[1.0], &[1.0], &p).unwrap(), empty());
        assert_eq!(view_polygon(&[1.0, 1.0, 2.0, 2.0], &[1.0, 1.0, 2.0, 2.0], &p).unwrap(), empty());
        // collinear
        assert_eq!(view_polygon(&[0.0, 1.0, 2.0, 3.0], &[0.0, 1.0, 2.0, 3.0], &p).unwrap(), empty());
        let c = HullParams::new("concave", Some(0.1)).unwrap();
        assert_eq!(view_polygon(&[0.0, 1.0, 2.0], &[0.0, 0.0, 0.0], &c).unwrap(), empty());
        let tri = view_polygon(&[0.0, 1.0, 0.0], &[0.0, 0.0, 1.0], &c).unwrap();
        assert!((tri.unsigned_area() - 0.5).abs() < 1e-12);
    }

    /// Nearly collinear points (a line through rounded coordinates) give POLYGON EMPTY or a valid
    /// polygon, never a ring that the polygon functions refuse; huge coordinates are an error.
    #[test]
    fn nearly_collinear_points_never_give_an_invalid_ring() {
        let p = HullParams::new("convex", None).unwrap();
        for k in 0..2000 {
            let (c, s) = ((k as f64).cos(), (k as f64 * 1.3).sin());
            let x: Vec<f64> = (0..40).map(|i| i as f64 * c).collect();
            let y: Vec<f64> = (0..40).map(|i| i as f64 * s).collect();
            let h = view_polygon(&x, &y, &p).unwrap();
            assert!(super::super::region::Region::from_multipolygon(h).is_ok(), "k = {k}");
        }
        assert!(matches!(view_polygon(&[0.0, 1e200, 0.0], &[0.0, 0.0, 1.0], &p).unwrap_err(), HullError::Magnitude { index: 1, field: "x" }));
    }

    #[test]
    fn bad_parameters() {
        assert_eq!(HullParams::new("star", None), Err(HullError::UnknownMethod("star".into())));
        assert_eq!(HullParams::new("convex", Some(1.0)).unwrap().method, HullMethod::Convex);
        assert!(matches!(HullParams::new("concave", Some(0.0)), Err(HullError::Concavity(_))));
        assert!(matches!(HullParams::new("concave", Some(f64::NAN)), Err(HullError::Concavity(_))));
        let p = HullParams::new("Convex", None).unwrap();
        assert!(matches!(p.with_density(0.0, 3), Err(HullError::Radius(_))));
        assert!(matches!(p.with_density(1.0, -1), Err(HullError::MinNeighbours(-1))));
        assert_eq!(
            view_polygon(&[0.0, f64::NAN], &[0.0, 0.0], &p).unwrap_err().to_string(),
            "points[2].x is NaN or infinite"
        );
    }

    #[test]
    fn density_rule_drops_isolated_detections() {
        // A dense 10x10 square of points plus three far-away spurious detections.
        let mut x: Vec<f64> = (0..400).map(|k| (k % 20) as f64 * 0.5).collect();
        let mut y: Vec<f64> = (0..400).map(|k| (k / 20) as f64 * 0.5).collect();
        for (a, b) in [(50.0, 50.0), (-40.0, 3.0), (5.0, 80.0)] {
            x.push(a);
            y.push(b);
        }
        let plain = view_polygon(&x, &y, &HullParams::new("convex", None).unwrap()).unwrap();
        let robust =
            view_polygon(&x, &y, &HullParams::new("convex", None).unwrap().with_density(1.0, 3).unwrap()).unwrap();
        assert!(plain.unsigned_area() > 1000.0);
        assert!((robust.unsigned_area() - 9.5 * 9.5).abs() < 1e-9);
        assert!(!robust.contains(&Point::new(20.0, 20.0)));
        // min_neighbours = 0 keeps everything
        let all = view_polygon(&x, &y, &HullParams::new("convex", None).unwrap().with_density(1.0, 0).unwrap()).unwrap();
        assert_eq!(all, plain);
    }

    /// The grid count equals a brute-force O(n²) count.
    #[test]
    fn density_matches_brute_force() {
        let (x, y) = cloud(600, 3);
        for (r, k) in [(1.0, 1), (2.5, 4), (7.0, 10)] {
            let rule = DensityRule { radius: r, min_neighbours: k };
            let brute: Vec<usize> = (0..x.len())
                .filter(|&i| {
                    (0..x.len()).filter(|&j| j != i && (x[i] - x[j]).powi(2) + (y[i] - y[j]).powi(2) <= r * r).count() >= k
                })
                .collect();
            assert_eq!(dense_points(&x, &y, rule), brute);
        }
    }
}
