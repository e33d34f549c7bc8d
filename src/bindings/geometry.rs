//! SQL: view polygons and overlaps. Maths: `crates/algo/src/geometry/` (hull.rs for `view_polygon`,
//! polygon.rs for the boolean operations and output, region.rs for parsing, point-in-polygon
//! and clipping).
//!
//! Polygon arguments are WKT `VARCHAR`, WKB `BLOB` or `GEOMETRY`; polygon results are
//! little-endian WKB `BLOB`s that DuckDB spatial's `ST_GeomFromWKB` reads. A polygon repeated
//! over rows is parsed, validated and indexed once per chunk (see the vector module's `RegionCol`).
//!
//! Every polygon argument becomes a `Region` (crates/algo/src/geometry/region.rs), whose constructor is
//! the one gate of crates/algo/src/geometry/valid.rs: rings are rewound (shells counter-clockwise,
//! holes clockwise) and invalid polygons are refused, with the same error in every function
//! below; valid.rs says why they are refused rather than repaired. WKT nested deeper than 128
//! parentheses is refused before it is parsed. Each description ends with [`polygon_rules!`].

use super::registry::{pd, Function, Param, Section, Signature, Ty, GEOMETRY, GEOMETRY_LIST, TRAJ};
use super::vector::{Args, Out};
use crate::algo::geometry::{hull, polygon, region};
use std::error::Error;

type R = Result<(), Box<dyn Error>>;

/// The rules every polygon argument follows, appended to each description.
macro_rules! polygon_rules {
    () => {
        " Polygon arguments may wind their rings either way (they are normalised: shells counter-clockwise, holes clockwise). \
         An invalid polygon is an error, the same in every polygon function, never repaired (a repair is a guess): rings that cross \
         themselves or each other or share a stretch of boundary, a hole outside its shell or inside another hole, or overlapping \
         parts of one MULTIPOLYGON (to unite those, pass them as separate elements of polygon_union). WKT nested more than 128 \
         parentheses deep is refused."
    };
}
const POLYGON: &str = "crates/algo/src/geometry/polygon.rs";
const REGION: &str = "crates/algo/src/geometry/region.rs";
const XY: Ty = Ty::List(&Ty::Struct(&[("x", Ty::Double), ("y", Ty::Double)]));
const P: Param = pd("p", GEOMETRY, "the polygon: WKT, WKB or GEOMETRY (POLYGON or MULTIPOLYGON)");
const TRAJ_ARG: Param = pd("traj", TRAJ, "the trajectory: points {t (s), x, y (m)}");
const CLOSED: Param = pd("p", GEOMETRY, "the polygon (closed: points on its boundary are inside), WKT, WKB or GEOMETRY");

/// `(points, method [, param [, radius, min_neighbours]])` with `T` the point type.
macro_rules! hull_signature {
    ($t:expr) => {
        Signature {
            params: &[
                pd("points", $t, "the points one camera saw (of one class): {x, y} (m), or a TRAJ such as flatten(list(traj))"),
                pd("method", Ty::Varchar, "'convex' or 'concave'"),
                pd("param", Ty::Double, "'concave': the concavity, > 0 (1 tight, larger smoother, 'Infinity' the convex hull); default 2; 'convex' ignores it"),
                pd("radius", Ty::Double, "with min_neighbours: a point counts only when enough other points lie within this distance (m), > 0"),
                pd("min_neighbours", Ty::Bigint, "the other points within radius a point needs to count, >= 0"),
            ],
            arities: &[2, 3, 5],
            returns: Ty::Blob,
            kernel: view_polygon,
        }
    };
}

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "view_polygon",
        description: "The view polygon P^k of a camera: the hull of all points of one class it saw (thesis 2.3). \
                      Aggregate the points first: view_polygon(list({'x': x, 'y': y}), 'convex') per camera and class, or \
                      view_polygon(flatten(list(traj)), ...) over trajectories. \
                      method 'convex' (the default choice: a camera's field of view is convex; it ignores param) or 'concave'. \
                      For 'concave', param is the concavity (like the ratio of DuckDB spatial's ST_ConcaveHull, on another scale): \
                      a hull edge of length L is pulled in towards an interior point within L/param of it; \
                      1 gives a tight, detailed shape, larger values a smoother one, 'Infinity' the convex hull; without param it is 2. \
                      Robust option: with radius and min_neighbours, a point counts only if at least min_neighbours other points \
                      lie within radius metres (the DBSCAN core-point rule), so a few spurious detections cannot inflate the view; \
                      filter estimated points with WHERE. Fewer than 3 distinct points, or collinear points, give POLYGON EMPTY (documented rule, never an error). \
                      NaN or infinite coordinates are an error. The result is a valid polygon with its shell counter-clockwise.",
        example: "SELECT polygon_to_wkt(view_polygon([{'x': 0, 'y': 0}, {'x': 4, 'y': 0}, {'x': 1, 'y': 1}, {'x': 0, 'y': 4}], 'convex')); -- POLYGON ((4 0, 0 4, 0 0, 4 0))",
        maths: "crates/algo/src/geometry/hull.rs",
        binding: file!(),
        section: Section::Geometry,
        see_also: &["polygon_overlap", "polygon_union", "polygon_buffer", "polygon_to_wkt"],
        signatures: &[hull_signature!(XY), hull_signature!(TRAJ)],
        table: None,
    },
    Function {
        name: "polygon_overlap",
        description: concat!(
            "The intersection P^k ∩ P^l (thesis 2.3): POLYGON, MULTIPOLYGON when the overlap falls apart, or POLYGON EMPTY. \
             For the multi-camera overlap (P^k1 ∪ … ∪ P^ki-1) ∩ P^ki use polygon_overlap(polygon_union(list), p). \
             Boolean operations come from the geo crate (i_overlay).",
            polygon_rules!()
        ),
        example: "SELECT polygon_to_wkt(polygon_overlap('POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))', 'POLYGON ((2 2, 6 2, 6 6, 2 6, 2 2))')); -- POLYGON ((2 4, 2 2, 4 2, 4 4, 2 4))",
        maths: POLYGON,
        binding: file!(),
        section: Section::Geometry,
        see_also: &["polygon_union", "view_polygon", "polygon_area"],
        signatures: &[Signature {
            params: &[pd("a", GEOMETRY, "the first polygon (WKT, WKB or GEOMETRY)"), pd("b", GEOMETRY, "the second polygon")],
            arities: &[],
            returns: Ty::Blob,
            kernel: overlap,
        }],
        table: None,
    },
    Function {
        name: "polygon_union",
        description: concat!(
            "The union of a list of polygons (use list(p) to aggregate); holes stay holes where no other polygon covers them. \
             An empty list gives POLYGON EMPTY; a NULL element is an error.",
            polygon_rules!()
        ),
        example: "SELECT polygon_area(polygon_union(['POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))', 'POLYGON ((2 2, 6 2, 6 6, 2 6, 2 2))'])); -- 28.0",
        maths: POLYGON,
        binding: file!(),
        section: Section::Geometry,
        see_also: &["polygon_overlap", "view_polygon", "polygon_area"],
        signatures: &[Signature {
            params: &[pd("polygons", GEOMETRY_LIST, "the polygons, e.g. list(p); no NULL element")],
            arities: &[],
            returns: Ty::Blob,
            kernel: union,
        }],
        table: None,
    },
    Function {
        name: "polygon_buffer",
        description: concat!(
            "Moves the boundary outward by distance (> 0) or inward (< 0), with round joins, like ST_Buffer on a polygon. \
                      sql/stages/overlap.sql shrinks each view polygon by the camera's measured position noise, because the hull of noisy \
                      points overshoots the true view edge. Shrinking past the middle gives POLYGON EMPTY. distance must be finite.",
            polygon_rules!()
        ),
        example: "SELECT polygon_area(polygon_buffer('POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))', -1)); -- 64.0",
        maths: POLYGON,
        binding: file!(),
        section: Section::Geometry,
        see_also: &["view_polygon", "polygon_overlap"],
        signatures: &[Signature {
            params: &[P, pd("distance", Ty::Double, "how far the boundary moves, in the coordinates' unit (m): > 0 outward, < 0 inward; finite")],
            arities: &[],
            returns: Ty::Blob,
            kernel: buffer,
        }],
        table: None,
    },
    Function {
        name: "polygon_area",
        description: concat!("Area (holes subtracted; 0 for POLYGON EMPTY), in the square units of the coordinates.", polygon_rules!()),
        example: "SELECT polygon_area('POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0), (1 1, 2 1, 2 2, 1 2, 1 1))'); -- 15.0",
        maths: POLYGON,
        binding: file!(),
        section: Section::Geometry,
        see_also: &["polygon_overlap", "polygon_union"],
        signatures: &[Signature { params: &[P], arities: &[], returns: Ty::Double, kernel: area }],
        table: None,
    },
    Function {
        name: "polygon_contains",
        description: concat!(
            "True when (x, y) lies in the closed polygon: points on the boundary count as inside \
                      (like ST_Intersects, unlike ST_Contains). Uses a prepared slab index (about 24 million tests per second per core \
                      for a 50-vertex polygon). NaN or infinite x/y is an error.",
            polygon_rules!()
        ),
        example: "SELECT polygon_contains('POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))', 4, 2); -- true",
        maths: REGION,
        binding: file!(),
        section: Section::Geometry,
        see_also: &["traj_points_inside", "traj_clip"],
        signatures: &[Signature {
            params: &[CLOSED, pd("x", Ty::Double, "the point's x, finite"), pd("y", Ty::Double, "the point's y, finite")],
            arities: &[],
            returns: Ty::Boolean,
            kernel: contains,
        }],
        table: None,
    },
    Function {
        name: "polygon_to_wkt",
        description: concat!(
            "WKT text of a polygon, in DuckDB spatial's ST_AsText style. Use it to read view_polygon / polygon_overlap / polygon_union results. \
             The text is of the normalised polygon: rings rewound, repeated points dropped.",
            polygon_rules!()
        ),
        example: "SELECT polygon_to_wkt('POLYGON((0 0,1 0,1 1,0 0))'); -- POLYGON ((0 0, 1 0, 1 1, 0 0))",
        maths: POLYGON,
        binding: file!(),
        section: Section::Geometry,
        see_also: &["polygon_to_geometry", "traj_to_wkt"],
        signatures: &[Signature { params: &[P], arities: &[], returns: Ty::Varchar, kernel: to_wkt }],
        table: None,
    },
    Function {
        name: "polygon_to_geometry",
        description: concat!(
            "The polygon as DuckDB's core GEOMETRY (DuckDB 1.5+), for GEOMETRY functions and GeoParquet writers: \
                      view_polygon, polygon_overlap, polygon_union and polygon_buffer return WKB (BLOB), which hosts without the type also read. \
                      The polygon is validated and normalised as everywhere (WKT, WKB or GEOMETRY in).",
            polygon_rules!()
        ),
        example: "SELECT polygon_to_geometry(view_polygon([{'x': 0, 'y': 0}, {'x': 4, 'y': 0}, {'x': 0, 'y': 4}], 'convex'))::VARCHAR; -- POLYGON ((0 0, 4 0, 0 4, 0 0))",
        maths: POLYGON,
        binding: file!(),
        section: Section::Geometry,
        see_also: &["polygon_to_wkt", "traj_to_geometry"],
        signatures: &[Signature { params: &[P], arities: &[], returns: Ty::Geometry, kernel: to_geometry }],
        table: None,
    },
    Function {
        name: "traj_clip",
        description: concat!(
            "The points of the trajectory that lie in the closed polygon, in their original order (an empty list when none does).",
            polygon_rules!()
        ),
        example: "SELECT traj_clip([{'t': 0, 'x': 1, 'y': 1}, {'t': 1, 'x': 9, 'y': 1}, {'t': 2, 'x': 2, 'y': 2}], 'POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))'); -- [{'t': 0.0, 'x': 1.0, 'y': 1.0}, {'t': 2.0, 'x': 2.0, 'y': 2.0}]",
        maths: REGION,
        binding: file!(),
        section: Section::Geometry,
        see_also: &["traj_points_inside", "polygon_contains", "lcss_similarity"],
        signatures: &[Signature { params: &[TRAJ_ARG, CLOSED], arities: &[], returns: TRAJ, kernel: clip }],
        table: None,
    },
    Function {
        name: "traj_points_inside",
        description: concat!(
            "How many points of the trajectory lie in the closed polygon (len(traj_clip(traj, p)) without building the list).",
            polygon_rules!()
        ),
        example: "SELECT traj_points_inside([{'t': 0, 'x': 1, 'y': 1}, {'t': 1, 'x': 9, 'y': 1}, {'t': 2, 'x': 2, 'y': 2}], 'POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))'); -- 2",
        maths: REGION,
        binding: file!(),
        section: Section::Geometry,
        see_also: &["traj_clip", "polygon_contains"],
        signatures: &[Signature { params: &[TRAJ_ARG, CLOSED], arities: &[], returns: Ty::Bigint, kernel: points_inside }],
        table: None,
    },
];

/// Both point types (`STRUCT(x, y)[]` and `TRAJ`): x and y are the last two fields.
fn view_polygon(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (pts, methods, param, radius, min_nb) = (a.struct_list(0), a.text(1), a.opt_double(2), a.opt_double(3), a.opt_bigint(4));
    // one hull per row (a camera's or class's points: up to millions), the rows on all cores
    let vals = a.par_map(|r| {
        let Some(rows) = pts.get(r)? else { return Ok(None) };
        let (Some(method), Some(param), Some(rad), Some(k)) = (methods.get(r), param.opt(r), radius.opt(r), min_nb.opt(r)) else { return Ok(None) };
        let params = hull::HullParams::parse(&method, param, rad.zip(k))?;
        let n = rows.width();
        let poly = hull::view_polygon(rows.f64(n - 2), rows.f64(n - 1), &params)?;
        Ok(Some(polygon::to_wkb(&poly)))
    })?;
    out.blobs(&vals);
    Ok(())
}

fn overlap(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (pa, pb) = (a.region(0), a.region(1));
    let vals = a.map(|r| {
        let (Some(x), Some(y)) = (pa.get(r)?, pb.get(r)?) else { return Ok(None) };
        polygon::overlay_room([&*x, &*y])?;
        Ok(Some(polygon::to_wkb(&polygon::overlap(&x, &y))))
    })?;
    out.blobs(&vals);
    Ok(())
}

fn union(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let l = a.region_list(0);
    out.blobs(&a.map(|r| {
        let Some(ps) = l.get(r)? else { return Ok(None) };
        polygon::overlay_room(ps.iter())?;
        Ok(Some(polygon::to_wkb(&polygon::union_all(ps.iter()))))
    })?);
    Ok(())
}

fn buffer(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (pc, d) = (a.region(0), a.double(1));
    let vals = a.map(|r| {
        let (Some(x), Some(d)) = (pc.get(r)?, d.get(r)) else { return Ok(None) };
        // the memory check is buffer's own, on the simplified rings (polygon::buffer)
        let b = polygon::buffer(&x, d).map_err(|e| -> Box<dyn std::error::Error> { e.to_string().into() })?;
        Ok(Some(polygon::to_wkb(&b)))
    })?;
    out.blobs(&vals);
    Ok(())
}

fn area(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let pc = a.region(0);
    out.flat(&a.map(|r| Ok(pc.get(r)?.map(|x| polygon::area(&x))))?);
    Ok(())
}

fn to_wkt(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let pc = a.region(0);
    out.text(&a.map(|r| Ok(pc.get(r)?.map(|x| polygon::to_wkt(x.polygons()))))?);
    Ok(())
}

fn to_geometry(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let pc = a.region(0);
    out.blobs(&a.map(|r| Ok(pc.get(r)?.map(|x| polygon::to_wkb(x.polygons()))))?);
    Ok(())
}

fn contains(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (pc, x, y) = (a.region(0), a.double(1), a.double(2));
    let vals = a.map(|r| {
        let (Some(reg), Some(x), Some(y)) = (pc.get(r)?, x.get(r), y.get(r)) else { return Ok(None) };
        Ok(Some(reg.contains_checked(x, y)?))
    })?;
    out.flat(&vals);
    Ok(())
}

fn clip(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tr, pc) = (a.traj(0), a.region(1));
    let vals = a.map(|r| {
        let (Some(t), Some(reg)) = (tr.get(r)?, pc.get(r)?) else { return Ok(None) };
        Ok(Some(region::clip(t, &reg).0))
    })?;
    out.trajs(&vals)?;
    Ok(())
}

fn points_inside(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tr, pc) = (a.traj(0), a.region(1));
    let vals = a.map(|r| {
        let (Some(t), Some(reg)) = (tr.get(r)?, pc.get(r)?) else { return Ok(None) };
        Ok(Some(region::count_inside(t, &reg) as i64))
    })?;
    out.flat(&vals);
    Ok(())
}
