//! SQL: trajectory helpers. Maths: `crates/algo/src/traj.rs`.

use super::registry::{pd, Function, Param, Section, Signature, Ty, SERIES, TRAJ};
use super::vector::{Args, Column, Out, Value};
use crate::algo::traj;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const MATHS: &str = "crates/algo/src/traj.rs";

const TRAJ_ARG: Param = pd("traj", TRAJ, "the trajectory: points {t (s), x, y (m)} sorted by t");
const WITH_TIME: Param = pd("with_time", Ty::Boolean, "true: time as the M coordinate (LINESTRING M / POINT M); default false");

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "traj_num_points",
        description: "Number of points in the trajectory (no validation; NULL for a NULL list). For the length in metres see traj_length_m.",
        example: "SELECT traj_num_points([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}]); -- 2",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_length_m", "traj_duration"],
        signatures: &[Signature { params: &[TRAJ_ARG], arities: &[], returns: Ty::Bigint, kernel: length }],
        table: None,
    },
    Function {
        name: "traj_length_m",
        description: "Path length in metres: the sum of the distances between consecutive points (0 for one point; NULL for an empty or NULL \
                      trajectory; an error for NaN / infinite values or unsorted t).",
        example: "SELECT traj_length_m([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}, {'t': 2, 'x': 3, 'y': 6}]); -- 7.0",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_num_points", "traj_duration", "traj_speeds"],
        signatures: &[Signature { params: &[TRAJ_ARG], arities: &[], returns: Ty::Double, kernel: length_m }],
        table: None,
    },
    Function {
        name: "traj_length",
        description: "DEPRECATED (removed in the next release): the number of points, not metres. Use traj_num_points, or traj_length_m for \
                      the path length in metres.",
        example: "SELECT traj_length([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}]); -- 2",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_num_points", "traj_length_m"],
        signatures: &[Signature { params: &[TRAJ_ARG], arities: &[], returns: Ty::Bigint, kernel: length }],
        table: None,
    },
    Function {
        name: "traj_duration",
        description: "Last t minus first t in seconds; 0 for one point, NULL for an empty or NULL trajectory.",
        example: "SELECT traj_duration([{'t': 0, 'x': 0, 'y': 0}, {'t': 2.5, 'x': 3, 'y': 4}]); -- 2.5",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_time_range", "traj_length_m", "traj_num_points"],
        signatures: &[Signature { params: &[TRAJ_ARG], arities: &[], returns: Ty::Double, kernel: duration }],
        table: None,
    },
    Function {
        name: "traj_stationary",
        description: "Did a road user of this class never move (issue 39; crates/algo/src/traj/stationary.rs)? True when its path's extent \
                      (the diagonal of its bounding box) is under the class's length (class_length_m) and that extent per second of its \
                      duration is under 0.1 m/s: a parked car, a pedestrian waiting for the whole track; not a short fragment of a \
                      moving road user. speeds() and the report leave stationary road users out of speed statistics. NULL for NULL and \
                      for an empty trajectory. O(n).",
        example: "SELECT traj_stationary([{'t': 0, 'x': 0, 'y': 0}, {'t': 60, 'x': 0.1, 'y': 0}], 'car'); -- true",
        maths: "crates/algo/src/traj/stationary.rs",
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["class_length_m", "traj_speeds", "traj_length_m"],
        signatures: &[Signature {
            params: &[
                TRAJ_ARG,
                pd("class", Ty::Varchar, "the road user's class name, read by its words as class_length_m (e.g. 'car', 'pedestrian')"),
            ],
            arities: &[],
            returns: Ty::Boolean,
            kernel: stationary,
        }],
        table: None,
    },
    Function {
        name: "traj_time_range",
        description: "First and last timestamp; NULL for an empty or NULL trajectory.",
        example: "SELECT traj_time_range([{'t': 1, 'x': 0, 'y': 0}, {'t': 4, 'x': 3, 'y': 4}]); -- {'t_start': 1.0, 't_end': 4.0}",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_duration"],
        signatures: &[Signature {
            params: &[TRAJ_ARG],
            arities: &[],
            returns: Ty::Struct(&[("t_start", Ty::Double), ("t_end", Ty::Double)]),
            kernel: time_range,
        }],
        table: None,
    },
    Function {
        name: "traj_speeds",
        description: "Speed by forward finite differences, |p[k+1] - p[k]| / (t[k+1] - t[k]), stamped at t[k+1]; \
                      n points give n-1 samples. Pairs with equal timestamps are skipped (speed over zero time is undefined). \
                      The result feeds lcss_series_similarity (the thesis's speed pre-match).",
        example: "SELECT traj_speeds([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}]); -- [{'t': 1.0, 'v': 5.0}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_turn_rates", "lcss_series_similarity", "speed_lag"],
        signatures: &[Signature { params: &[TRAJ_ARG], arities: &[], returns: SERIES, kernel: speeds }],
        table: None,
    },
    Function {
        name: "traj_turn_rates",
        description: "Turn rate in rad/s, which does not change under rotation or translation: a coordinate-free signature for matching tracks \
                      across cameras (with traj_speeds). The track is cut into chords of at least min_step metres (default 1.0) to keep \
                      position noise out of the heading; each sample is the wrapped heading change between consecutive chords over their time difference.",
        example: "SELECT traj_turn_rates([{'t':0,'x':0,'y':0},{'t':1,'x':2,'y':0},{'t':2,'x':2,'y':2}]); -- [{'t': 2.0, 'v': 1.5707963267948966}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_speeds", "lcss_series_similarity"],
        signatures: &[Signature {
            params: &[TRAJ_ARG, pd("min_step", Ty::Double, "the least chord length (m) a heading is measured over, > 0; default 1.0")],
            arities: &[1, 2],
            returns: SERIES,
            kernel: turn_rates,
        }],
        table: None,
    },
    Function {
        name: "traj_to_wkt",
        description: "WKT for GIS tools: LINESTRING for two or more points, POINT for one, LINESTRING EMPTY for none. \
                      Time is dropped. ST_GeomFromText (DuckDB spatial) reads it.",
        example: "SELECT traj_to_wkt([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}]); -- LINESTRING (0 0, 3 4)",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_to_wkb", "traj_to_geometry", "polygon_to_wkt"],
        signatures: &[Signature { params: &[TRAJ_ARG], arities: &[], returns: Ty::Varchar, kernel: to_wkt }],
        table: None,
    },
    Function {
        name: "traj_to_wkb",
        description: "Little-endian ISO WKB of the geometry traj_to_wkt describes (LINESTRING, POINT for one point, LINESTRING EMPTY). \
                      ST_GeomFromWKB (DuckDB spatial) reads it; trajdb pipeline writes it as the GeoParquet geometry of merged.parquet. \
                      With with_time = true, time is the M coordinate (LINESTRING M / POINT M, ISO types 2002 / 2001).",
        example: "SELECT octet_length(traj_to_wkb([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}])); -- 41",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_to_wkt", "traj_to_geometry"],
        signatures: &[Signature { params: &[TRAJ_ARG, WITH_TIME], arities: &[1, 2], returns: Ty::Blob, kernel: to_wkb }],
        table: None,
    },
    Function {
        name: "traj_to_geometry",
        description: "The trajectory as DuckDB's core GEOMETRY (DuckDB 1.5+): the geometry traj_to_wkb writes (LINESTRING, POINT for one point, \
                      LINESTRING EMPTY), with time as M when with_time = true. GEOMETRY functions and GeoParquet writers take it directly; on hosts \
                      without the type use traj_to_wkb.",
        example: "SELECT typeof(traj_to_geometry([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}])); -- GEOMETRY",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["traj_to_wkb", "traj_to_wkt", "polygon_to_geometry"],
        signatures: &[Signature { params: &[TRAJ_ARG, WITH_TIME], arities: &[1, 2], returns: Ty::Geometry, kernel: to_wkb }],
        table: None,
    },
    Function {
        name: "traj_resample",
        description: "The trajectory at t = k * period seconds (k integer: one clock shared by every camera), by linear interpolation; \
                      no extrapolation, and no interpolation across a gap longer than max_gap seconds (default: no limit). \
                      Resample both tracks before LCSS when cameras sample at different phases: raw samples of a car at 12 m/s lie up to \
                      period/2 * 12 m apart, which can exceed epsilon. Errors: period or max_gap <= 0 or not finite, more than 50,000,000 output points.",
        example: "SELECT traj_resample([{'t': 0.125, 'x': 0, 'y': 0}, {'t': 0.625, 'x': 2, 'y': 0}], 0.25); -- [{'t': 0.25, 'x': 0.5, 'y': 0.0}, {'t': 0.5, 'x': 1.5, 'y': 0.0}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Trajectories,
        see_also: &["lcss_similarity", "traj_fuse", "traj_correspond"],
        signatures: &[Signature {
            params: &[
                TRAJ_ARG,
                pd("period", Ty::Double, "the sampling period (s), > 0: the points at t = k * period"),
                pd("max_gap", Ty::Double, "no interpolation across a gap between samples longer than this (s), > 0; default: no limit"),
            ],
            arities: &[2, 3],
            returns: TRAJ,
            kernel: resample,
        }],
        table: None,
    },
];

fn length(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let tr = a.traj(0);
    let vals: Vec<Option<i64>> = (0..a.rows()).map(|r| tr.raw_len(r).map(|n| n as i64)).collect();
    out.flat(&vals);
    Ok(())
}

fn length_m(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let tr = a.traj(0);
    out.flat(&a.map(|r| Ok(tr.get(r)?.and_then(traj::path_length)))?);
    Ok(())
}

fn duration(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let tr = a.traj(0);
    out.flat(&a.map(|r| Ok(tr.get(r)?.and_then(|t| traj::duration(t.t))))?);
    Ok(())
}

fn stationary(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tr, class) = (a.traj(0), a.text(1));
    let vals = a.map(|r| {
        let (Some(t), Some(c)) = (tr.get(r)?, class.get(r)) else { return Ok(None) };
        Ok((t.len() > 0).then(|| crate::algo::traj::stationary::stationary(t, &c)))
    })?;
    out.flat(&vals);
    Ok(())
}

fn time_range(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let tr = a.traj(0);
    let vals = a.map(|r| Ok(tr.get(r)?.and_then(|t| traj::time_range(t.t)).map(|(s, e)| vec![Value::F64(s), Value::F64(e)])))?;
    out.structs(&vals);
    Ok(())
}

/// Writes `(t, v)` series results.
fn write_series(out: &mut Out<'_>, vals: &[Option<(Vec<f64>, Vec<f64>)>]) -> Result<(), String> {
    let cols: Vec<_> = vals.iter().map(|v| v.as_ref().map(|(t, v)| vec![Column::F64(t), Column::F64(v)])).collect();
    out.struct_lists(&cols)
}

fn speeds(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let tr = a.traj(0);
    write_series(out, &a.map(|r| Ok(tr.get(r)?.map(traj::speeds)))?)?;
    Ok(())
}

fn turn_rates(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tr, step) = (a.traj(0), a.opt_double(1));
    let vals = a.map(|r| {
        let (Some(t), Some(s)) = (tr.get(r)?, step.or(r, 1.0)) else { return Ok(None) };
        Ok(Some(traj::turn_rates(t, s)?))
    })?;
    write_series(out, &vals)?;
    Ok(())
}

fn to_wkt(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let tr = a.traj(0);
    out.text(&a.map(|r| Ok(tr.get(r)?.map(traj::to_wkt)))?);
    Ok(())
}

fn to_wkb(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tr, with_time) = (a.traj(0), a.opt_boolean(1));
    out.blobs(&a.map(|r| {
        let Some(m) = with_time.or(r, false) else { return Ok(None) };
        Ok(tr.get(r)?.map(if m { traj::to_wkb_m } else { traj::to_wkb }))
    })?);
    Ok(())
}

fn resample(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tr, period, gap) = (a.traj(0), a.double(1), a.opt_double(2));
    let vals = a.par_map(|r| {
        let (Some(t), Some(p), Some(g)) = (tr.get(r)?, period.get(r), gap.or(r, f64::INFINITY)) else { return Ok(None) };
        Ok(Some(traj::resample(t, p, g)?))
    })?;
    out.trajs(&vals)?;
    Ok(())
}
