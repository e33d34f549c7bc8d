//! SQL: results on a map. Maths: `crates/algo/src/align/map.rs` (the control-point fit, the
//! tangent plane of a longitude/latitude map). python/trajdb/export.py (`fit_map`, `export`)
//! calls these.

use super::registry::{pd, Function, Section, Signature, Ty, TRAJ};
use super::vector::{Args, Out, Value};
use crate::algo::align::map::{self, MapFit};
use crate::algo::align::rigid::Transform2;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const MAP_RS: &str = "crates/algo/src/align/map.rs";

/// A fitted map (`map_fit`'s result, the argument of `map_apply` and `map_residual_m`).
pub const MAP_FIT: Ty = Ty::Struct(&[
    ("theta", Ty::Double),
    ("tx", Ty::Double),
    ("ty", Ty::Double),
    ("scale", Ty::Double),
    ("lonlat", Ty::Boolean),
    ("lon0", Ty::Double),
    ("lat0", Ty::Double),
    ("rms_m", Ty::Double),
    ("max_residual_m", Ty::Double),
    ("points", Ty::Bigint),
]);
const CONTROL: Ty = Ty::List(&Ty::Struct(&[("x", Ty::Double), ("y", Ty::Double), ("map_x", Ty::Double), ("map_y", Ty::Double)]));
const FIT_DOC: &str = "a fitted map: map_fit's result";

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "map_fit",
        section: Section::Maps,
        see_also: &["map_apply", "map_residual_m", "rigid_fit"],
        description: "The map of the reference camera's local frame, fitted on control points (x, y) -> (map_x, map_y): the \
                      least-squares similarity (rotation, uniform scale, translation; Umeyama 1991, rigid_fit with scale) in the \
                      map's metres. With lonlat, map_x/map_y are longitude/latitude in degrees (EPSG:4326) and the fit is made \
                      in the plane tangent at their mean (east/north metres on the WGS 84 radius; across the antimeridian too). \
                      Returns the transform, the tangent origin (lon0, lat0; 0 for a projected map), the residuals' rms and \
                      largest value (m) and the number of points. Needs two or more finite points that are distinct in both \
                      frames; NULL when an argument is NULL. O(n).",
        example: "SELECT round(map_fit([{'x': 0, 'y': 0, 'map_x': 500000, 'map_y': 5700000}, {'x': 10, 'y': 0, 'map_x': 500000, 'map_y': 5700010}], false).theta, 4); -- 1.5708",
        maths: MAP_RS,
        binding: file!(),
        signatures: &[Signature {
            params: &[
                pd("points", CONTROL, "control points: (x, y) in the reference camera's frame (m) and (map_x, map_y) on the map, two or more"),
                pd("lonlat", Ty::Boolean, "true: map_x, map_y are longitude, latitude (degrees, EPSG:4326); false: a projected CRS in metres"),
            ],
            arities: &[],
            returns: MAP_FIT,
            kernel: map_fit,
        }],
        table: None,
    },
    Function {
        name: "map_apply",
        section: Section::Maps,
        see_also: &["map_fit", "transform_apply", "traj_to_wkb"],
        description: "Every point of a trajectory on the map: (x, y) of the reference camera's frame to the fitted map's \
                      coordinates (longitude/latitude in degrees, in [-180, 180), for a lonlat fit); t unchanged. NULL when an \
                      argument is NULL; an error for a point it maps past a pole or beyond the range of doubles (wrong \
                      control points). O(n).",
        example: "SELECT map_apply([{'t': 0, 'x': 10, 'y': 0}], map_fit([{'x': 0, 'y': 0, 'map_x': 500000, 'map_y': 5700000}, {'x': 10, 'y': 0, 'map_x': 500010, 'map_y': 5700000}], false))[1].x; -- 500010.0",
        maths: MAP_RS,
        binding: file!(),
        signatures: &[Signature {
            params: &[pd("traj", TRAJ, "a path in the reference camera's frame (e.g. merged.parquet's traj)"), pd("fit", MAP_FIT, FIT_DOC)],
            arities: &[],
            returns: TRAJ,
            kernel: map_apply,
        }],
        table: None,
    },
    Function {
        name: "map_residual_m",
        section: Section::Maps,
        see_also: &["map_fit"],
        description: "How far a fitted map puts the local point (x, y) from the map point (map_x, map_y), in metres (in the \
                      tangent plane for a lonlat fit): one control point's residual, to find a badly placed one. NULL when an \
                      argument is NULL; an error for a value that is not finite. O(1).",
        example: "SELECT round(map_residual_m(map_fit([{'x': 0, 'y': 0, 'map_x': 0, 'map_y': 0}, {'x': 10, 'y': 0, 'map_x': 10, 'map_y': 0}], false), 5, 0, 5, 1), 6); -- 1.0",
        maths: MAP_RS,
        binding: file!(),
        signatures: &[Signature {
            params: &[
                pd("fit", MAP_FIT, FIT_DOC),
                pd("x", Ty::Double, "the control point's x in the reference camera's frame (m)"),
                pd("y", Ty::Double, "its y (m)"),
                pd("map_x", Ty::Double, "its map x (longitude in degrees for a lonlat fit)"),
                pd("map_y", Ty::Double, "its map y (latitude in degrees for a lonlat fit)"),
            ],
            arities: &[],
            returns: Ty::Double,
            kernel: map_residual_m,
        }],
        table: None,
    },
];

/// A MAP_FIT argument, checked (the error names the argument).
fn fit_of(a: &Args<'_>, col: usize, v: &[f64]) -> Result<MapFit, Box<dyn Error>> {
    let t = Transform2::new(v[0], v[1], v[2], v[3]);
    MapFit::checked(t, v[4] != 0.0, v[5], v[6]).map_err(|e| format!("{}: {e}", a.name(col)).into())
}

fn map_fit(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (pts, lonlat) = (a.struct_list(0), a.opt_boolean(1));
    let vals = a.map(|r| {
        let (Some(c), Some(ll)) = (pts.get(r)?, lonlat.or(r, false)) else { return Ok(None) };
        let f = map::fit(c.f64(0), c.f64(1), c.f64(2), c.f64(3), ll)?;
        let t = f.transform;
        let max = f.residuals_m.iter().fold(0.0f64, |m, &v| m.max(v));
        Ok(Some(vec![
            Value::F64(t.theta),
            Value::F64(t.tx),
            Value::F64(t.ty),
            Value::F64(t.scale),
            Value::Bool(f.lonlat),
            Value::F64(f.lon0),
            Value::F64(f.lat0),
            Value::F64(f.rms_m()),
            Value::F64(max),
            Value::I64(f.residuals_m.len() as i64),
        ]))
    })?;
    out.structs(&vals);
    Ok(())
}

fn map_apply(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tr, fit) = (a.traj(0), a.structure(1));
    let vals = a.map(|r| {
        let (Some(x), Some(f)) = (tr.get(r)?, fit.get(r)?) else { return Ok(None) };
        Ok(Some(fit_of(a, 1, &f)?.apply_traj(x)?))
    })?;
    out.trajs(&vals)?;
    Ok(())
}

fn map_residual_m(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let fit = a.structure(0);
    let (x, y, mx, my) = (a.double(1), a.double(2), a.double(3), a.double(4));
    let vals = a.map(|r| {
        let (Some(f), Some(x), Some(y), Some(mx), Some(my)) = (fit.get(r)?, x.get(r), y.get(r), mx.get(r), my.get(r)) else { return Ok(None) };
        Ok(Some(fit_of(a, 0, &f)?.residual_m_checked(x, y, mx, my)?))
    })?;
    out.flat(&vals);
    Ok(())
}
