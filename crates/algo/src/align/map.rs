//! Results on a map: the similarity that takes the reference camera's local frame (metres) to a
//! map's coordinates, fitted on control points `(x, y) -> (X, Y)`, and the local tangent plane a
//! longitude/latitude fit is made in.
//!
//! - A projected CRS (UTM, a national grid: metres): `X + iY = a (x + iy) + b` with
//!   `a = s e^{iθ}`, the least-squares similarity (Umeyama 1991, [`rigid::fit_trimmed`] with
//!   scale and no trimming). O(n).
//! - Longitude/latitude (EPSG:4326, degrees): the map points are first put into the east/north
//!   plane tangent at their mean (`e = Δλ · A cos φ0`, `n = Δφ · A`, angles in radians, A the
//!   WGS 84 semi-major axis: an equirectangular projection about the origin, whose error grows
//!   with the square of the distance, far below a metre over a site of a few hundred metres);
//!   the similarity is fitted there, and [`MapFit::apply`] maps a local point back to degrees.
//!   A site on the antimeridian works: differences of longitude are taken across it, and the
//!   longitudes returned lie in [-180, 180).
//!
//! python/trajdb/export.py (`fit_map`, `export`) calls this through `map_fit`, `map_apply` and `map_residual_m`.

use super::rigid::{self, RigidError, Transform2};
use crate::traj::{OwnedTraj, Traj};
use std::fmt;

/// An empty vector with room for `n` values, or [`MapError::Memory`].
fn room(n: usize) -> Result<Vec<f64>, MapError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| MapError::Memory(n))?;
    Ok(v)
}

/// The WGS 84 semi-major axis (m): the radius of the tangent plane of a longitude/latitude fit.
pub const WGS84_A: f64 = 6_378_137.0;

/// The local (x, y) of a control point closer to every other than this (m², summed squared
/// distance to their mean) tells no rotation or scale.
const COINCIDE_M2: f64 = 1e-12;

/// A fitted map: local (x, y) -> map (X, Y), through the tangent plane at (lon0, lat0) when
/// `lonlat`.
#[derive(Clone, Debug, PartialEq)]
pub struct MapFit {
    /// local -> map (projected) or local -> tangent plane east/north (m) (longitude/latitude).
    pub transform: Transform2,
    pub lonlat: bool,
    /// The tangent plane's origin (degrees); 0 for a projected map.
    pub lon0: f64,
    pub lat0: f64,
    /// |fit(local) - map| per control point, in the map's metres (the tangent plane's for
    /// longitude/latitude), in the order given.
    pub residuals_m: Vec<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum MapError {
    TooFew(usize),
    /// The k-th control point (1-based) holds NaN or infinity.
    NotFinite { index: usize, field: &'static str, value: f64 },
    /// A longitude/latitude control point outside [-180, 180] x [-90, 90].
    LonLat { index: usize, lon: f64, lat: f64 },
    /// The local points coincide.
    LocalCoincide,
    /// The fit failed or gave no usable similarity (scale near 0: the map points coincide).
    NoFit(String),
    /// A transform given to [`MapFit::apply`] that is not one (NaN, scale <= 0, a pole origin).
    Fit(String),
    /// No memory for this many points.
    Memory(usize),
    /// A single value that must be finite.
    Value { field: &'static str, value: f64 },
    /// A map point of a longitude/latitude fit outside [-180, 180] x [-90, 90].
    MapPoint { lon: f64, lat: f64 },
    /// A local point the fit maps beyond a pole or the range of doubles.
    Beyond { x: f64, y: f64, value: String },
}

impl fmt::Display for MapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MapError::TooFew(n) => write!(f, "needs at least two control points (x, y, map_x, map_y), got {n}"),
            MapError::NotFinite { index, field, value } => write!(f, "points[{index}].{field} must be finite, got {value:?}"),
            MapError::LonLat { index, lon, lat } => write!(
                f,
                "points[{index}] is not a longitude/latitude in degrees (map_x {lon:?} in [-180, 180], map_y {lat:?} in [-90, 90]); \
                 for a projected CRS give lonlat := false"
            ),
            MapError::LocalCoincide => write!(f, "the control points coincide in the local frame; give two or more distinct points"),
            MapError::NoFit(why) => write!(f, "the control points give no map fit: {why}; give distinct points in both frames"),
            MapError::Fit(why) => write!(f, "not a map fit: {why}"),
            MapError::Memory(n) => write!(f, "no memory for {n} points"),
            MapError::Value { field, value } => write!(f, "{field} must be finite, got {value:?}"),
            MapError::MapPoint { lon, lat } => write!(
                f,
                "(map_x, map_y) = ({lon:?}, {lat:?}) is not a longitude/latitude in degrees (map_x in [-180, 180], map_y in [-90, 90])"
            ),
            MapError::Beyond { x, y, value } => write!(
                f,
                "the fit maps ({x:?}, {y:?}) to {value}: off the map; are the control points (x, y, longitude, latitude) in that order, \
                 and the local frame in metres?"
            ),
        }
    }
}
impl std::error::Error for MapError {}

/// A longitude (or a difference of two) brought into [-180, 180) when it lies outside it;
/// unchanged (to the bit) inside.
fn wrap_lon(d: f64) -> f64 {
    if (-180.0..180.0).contains(&d) {
        d
    } else {
        (d + 180.0).rem_euclid(360.0) - 180.0
    }
}

/// The east/north metres of (lon, lat) in the plane tangent at (lon0, lat0). O(1).
pub fn to_plane(lon: f64, lat: f64, lon0: f64, lat0: f64) -> (f64, f64) {
    (wrap_lon(lon - lon0).to_radians() * (WGS84_A * lat0.to_radians().cos()), (lat - lat0).to_radians() * WGS84_A)
}

/// The inverse of [`to_plane`]: (lon, lat) in degrees of east/north metres. O(1).
pub fn from_plane(e: f64, n: f64, lon0: f64, lat0: f64) -> (f64, f64) {
    (wrap_lon(lon0 + (e / (WGS84_A * lat0.to_radians().cos())).to_degrees()), lat0 + (n / WGS84_A).to_degrees())
}

/// The mean longitude of points that may straddle the antimeridian: their plain mean when they
/// span at most 180 degrees, else the mean of their differences from the first, wrapped.
fn mean_lon(lon: &[f64]) -> f64 {
    let n = lon.len() as f64;
    let (lo, hi) = lon.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    if hi - lo <= 180.0 {
        lon.iter().sum::<f64>() / n
    } else {
        wrap_lon(lon[0] + lon.iter().map(|&v| wrap_lon(v - lon[0])).sum::<f64>() / n)
    }
}

/// Fits the map from control points: local `(x[k], y[k])` is map `(mx[k], my[k])` (degrees of
/// longitude and latitude when `lonlat`, else the CRS's metres). O(n).
pub fn fit(x: &[f64], y: &[f64], mx: &[f64], my: &[f64], lonlat: bool) -> Result<MapFit, MapError> {
    let n = x.len();
    if n < 2 {
        return Err(MapError::TooFew(n));
    }
    for (field, c) in [("x", x), ("y", y), ("map_x", mx), ("map_y", my)] {
        if let Some(k) = c.iter().position(|v| !v.is_finite()) {
            return Err(MapError::NotFinite { index: k + 1, field, value: c[k] });
        }
    }
    let (lon0, lat0, wx, wy) = if lonlat {
        if let Some(k) = (0..n).find(|&k| !((-180.0..=180.0).contains(&mx[k]) && (-90.0..=90.0).contains(&my[k]))) {
            return Err(MapError::LonLat { index: k + 1, lon: mx[k], lat: my[k] });
        }
        let (lon0, lat0) = (mean_lon(mx), my.iter().sum::<f64>() / n as f64);
        let (mut wx, mut wy) = (room(n)?, room(n)?);
        for k in 0..n {
            let (e, m) = to_plane(mx[k], my[k], lon0, lat0);
            wx.push(e);
            wy.push(m);
        }
        (lon0, lat0, wx, wy)
    } else {
        let (mut wx, mut wy) = (room(n)?, room(n)?);
        wx.extend_from_slice(mx);
        wy.extend_from_slice(my);
        (0.0, 0.0, wx, wy)
    };
    // a data check, not a fit: points closer than a micrometre tell no rotation or scale
    let (cx, cy) = (x.iter().sum::<f64>() / n as f64, y.iter().sum::<f64>() / n as f64);
    if (0..n).map(|k| (x[k] - cx).powi(2) + (y[k] - cy).powi(2)).sum::<f64>() <= COINCIDE_M2 {
        return Err(MapError::LocalCoincide);
    }
    let f = rigid::fit_trimmed(&wx, &wy, x, y, 0.0, true).map_err(|e: RigidError| MapError::NoFit(e.to_string()))?;
    let t = f.transform;
    // the fit must be one map_apply takes back (Transform2::validate), and tell a scale
    if !(t.scale.is_finite() && t.scale > 1e-9) || t.validate().is_err() {
        return Err(MapError::NoFit(format!("scale {:?}: do the map points coincide, or lie beyond the range of doubles?", t.scale)));
    }
    let map = t.mapper();
    let mut residuals_m = room(n)?;
    for k in 0..n {
        let (px, py) = map(x[k], y[k]);
        residuals_m.push((px - wx[k]).hypot(py - wy[k]));
    }
    if residuals_m.iter().any(|r| !r.is_finite()) {
        return Err(MapError::NoFit("a residual is beyond the range of doubles".to_string()));
    }
    Ok(MapFit { transform: t, lonlat, lon0, lat0, residuals_m })
}

impl MapFit {
    /// A fit given back (from SQL): its transform valid, a longitude/latitude origin off the poles.
    pub fn checked(transform: Transform2, lonlat: bool, lon0: f64, lat0: f64) -> Result<MapFit, MapError> {
        transform.validate().map_err(|e| MapError::Fit(e.to_string()))?;
        if lonlat && !((-180.0..=180.0).contains(&lon0) && lat0.abs() < 90.0) {
            return Err(MapError::Fit(format!("the origin ({lon0}, {lat0}) is no longitude/latitude off the poles")));
        }
        Ok(MapFit { transform, lonlat, lon0, lat0, residuals_m: Vec::new() })
    }

    /// The map point of a local point: (X, Y) of the CRS, or (longitude, latitude). O(1).
    /// An error when the point lands off the map: beyond a pole (latitude outside [-90, 90]:
    /// the tangent plane holds a site, not a hemisphere; wrong control points do this) or beyond
    /// the range of doubles. Longitudes come back in [-180, 180).
    pub fn apply(&self, x: f64, y: f64) -> Result<(f64, f64), MapError> {
        let (e, n) = self.transform.apply(x, y);
        let (mx, my) = if self.lonlat { from_plane(e, n, self.lon0, self.lat0) } else { (e, n) };
        if !(mx.is_finite() && my.is_finite()) {
            return Err(MapError::Beyond { x, y, value: format!("({mx:?}, {my:?})") });
        }
        if self.lonlat && !(-90.0..=90.0).contains(&my) {
            return Err(MapError::Beyond { x, y, value: format!("latitude {my:?}") });
        }
        Ok((mx, my))
    }

    /// Every point of `tr` on the map ([`MapFit::apply`]); t unchanged. O(n).
    pub fn apply_traj(&self, tr: Traj<'_>) -> Result<OwnedTraj, MapError> {
        let mut o = OwnedTraj::default();
        for k in 0..tr.len() {
            let (x, y) = self.apply(tr.x[k], tr.y[k])?;
            o.push(tr.t[k], x, y);
        }
        Ok(o)
    }

    /// [`MapFit::residual_m`] of values that must be finite (an error names the first that is not).
    pub fn residual_m_checked(&self, x: f64, y: f64, map_x: f64, map_y: f64) -> Result<f64, MapError> {
        for (field, value) in [("x", x), ("y", y), ("map_x", map_x), ("map_y", map_y)] {
            if !value.is_finite() {
                return Err(MapError::Value { field, value });
            }
        }
        if self.lonlat && !((-180.0..=180.0).contains(&map_x) && (-90.0..=90.0).contains(&map_y)) {
            return Err(MapError::MapPoint { lon: map_x, lat: map_y });
        }
        Ok(self.residual_m(x, y, map_x, map_y))
    }

    /// How far the fit puts local (x, y) from the map point (map_x, map_y), in metres (the
    /// tangent plane's for longitude/latitude): a control point's residual. O(1).
    pub fn residual_m(&self, x: f64, y: f64, map_x: f64, map_y: f64) -> f64 {
        let (px, py) = self.transform.apply(x, y);
        let (wx, wy) = if self.lonlat { to_plane(map_x, map_y, self.lon0, self.lat0) } else { (map_x, map_y) };
        (px - wx).hypot(py - wy)
    }

    /// The root mean square of the residuals (m).
    pub fn rms_m(&self) -> f64 {
        (self.residuals_m.iter().map(|r| r * r).sum::<f64>() / self.residuals_m.len().max(1) as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_projected_similarity_is_recovered() {
        let t = Transform2::new(0.3, 500_000.0, 5_700_000.0, 1.0);
        let (x, y) = (vec![0.0, 50.0, -20.0, 10.0], vec![0.0, 10.0, 40.0, -30.0]);
        let (mx, my): (Vec<f64>, Vec<f64>) = x.iter().zip(&y).map(|(&a, &b)| t.apply(a, b)).unzip();
        let f = fit(&x, &y, &mx, &my, false).unwrap();
        assert!((f.transform.theta - 0.3).abs() < 1e-9 && (f.transform.scale - 1.0).abs() < 1e-9, "{f:?}");
        assert!(f.rms_m() < 1e-6);
        let (px, py) = f.apply(5.0, 5.0).unwrap();
        let (qx, qy) = t.apply(5.0, 5.0);
        assert!((px - qx).abs() < 1e-6 && (py - qy).abs() < 1e-6);
    }

    #[test]
    fn longitude_latitude_round_trips_through_the_tangent_plane() {
        for &(lon0, lat0) in &[(11.97, 57.7), (-73.98, 40.75), (179.9995, -16.5), (-179.9995, 64.1)] {
            for &(e, n) in &[(0.0, 0.0), (120.0, -80.0), (-300.0, 250.0)] {
                let (lon, lat) = from_plane(e, n, lon0, lat0);
                assert!((-180.0..180.0).contains(&lon), "{lon}");
                let (e2, n2) = to_plane(lon, lat, lon0, lat0);
                assert!((e2 - e).abs() < 1e-6 && (n2 - n).abs() < 1e-6, "{lon0} {lat0}: {e} {n} -> {e2} {n2}");
            }
        }
        // a metre east at 60 N is half a metre's longitude at the equator
        let (a, _) = from_plane(1.0, 0.0, 0.0, 60.0);
        let (b, _) = from_plane(1.0, 0.0, 0.0, 0.0);
        assert!((a / b - 2.0).abs() < 1e-9);
    }

    #[test]
    fn a_site_on_the_antimeridian_is_fitted_across_it() {
        // a 200 m square centred on 180 E, 16.5 S
        let (x, y) = (vec![-100.0, 100.0, 100.0, -100.0], vec![-100.0, -100.0, 100.0, 100.0]);
        let (mx, my): (Vec<f64>, Vec<f64>) = x.iter().zip(&y).map(|(&a, &b)| from_plane(a, b, 180.0, -16.5)).unzip();
        assert!(mx.iter().any(|&v| v > 179.0) && mx.iter().any(|&v| v < -179.0), "{mx:?}");
        let f = fit(&x, &y, &mx, &my, true).unwrap();
        assert!(f.rms_m() < 1e-6 && (f.transform.scale - 1.0).abs() < 1e-9, "{f:?}");
        let (lon, lat) = f.apply(100.0, 100.0).unwrap();
        assert!((lon - mx[2]).abs() < 1e-9 && (lat - my[2]).abs() < 1e-9);
    }

    #[test]
    fn bad_control_points_are_refused_by_name() {
        let e = |x: &[f64], y: &[f64], mx: &[f64], my: &[f64], ll| fit(x, y, mx, my, ll).unwrap_err().to_string();
        assert!(e(&[0.0], &[0.0], &[1.0], &[1.0], false).contains("at least two control points"));
        assert!(e(&[0.0, 1.0], &[0.0, f64::NAN], &[1.0, 2.0], &[1.0, 2.0], false).contains("points[2].y must be finite"));
        assert!(e(&[0.0, 1.0], &[0.0, 0.0], &[1.0, 200.0], &[1.0, 2.0], true).contains("points[2] is not a longitude/latitude"));
        assert!(e(&[1.0, 1.0], &[1.0, 1.0], &[0.0, 5.0], &[0.0, 5.0], false).contains("coincide in the local frame"));
        assert!(e(&[0.0, 10.0], &[0.0, 0.0], &[5.0, 5.0], &[5.0, 5.0], false).contains("no map fit"));
        assert!(MapFit::checked(Transform2::IDENTITY, true, 0.0, 90.0).is_err());
        // a fit map_apply would refuse is no fit; a point mapped past a pole is an error
        assert!(e(&[0.0, 10.0], &[0.0, 0.0], &[1e200, 2e200], &[0.0, 0.0], false).contains("no map fit"));
        let f = MapFit::checked(Transform2::IDENTITY, true, 0.0, 89.9999).unwrap();
        assert!(f.apply(0.0, 1000.0).unwrap_err().to_string().contains("off the map"));
        let (lon, _) = f.apply(1000.0, 0.0).unwrap();
        assert!((-180.0..180.0).contains(&lon), "{lon}");
        assert!(f.residual_m_checked(0.0, 0.0, 720.0, 0.0).is_err());
        assert!(MapFit::checked(Transform2::new(0.0, 0.0, 0.0, -1.0), false, 0.0, 0.0).is_err());
    }
}
