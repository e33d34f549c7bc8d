//! SQL: trajectory helpers (`traj_length`, `traj_duration`, `traj_speeds`, `traj_time_range`,
//! `traj_to_wkt`, `traj_to_wkb`, `traj_resample`).

use super::convert::*;
use crate::algo::traj;
use duckdb::core::DataChunkHandle;
use duckdb::vtab::arrow::WritableVector;
use duckdb::Connection;

pub const DOCS: &[FnDoc] = &[
    FnDoc {
        name: "traj_length",
        signatures: "traj_length(traj STRUCT(t, x, y)[]) -> BIGINT",
        description: "Number of points in the trajectory (no validation; NULL for a NULL list).",
        example: "SELECT traj_length([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}]); -- 2",
    },
    FnDoc {
        name: "traj_duration",
        signatures: "traj_duration(traj STRUCT(t, x, y)[]) -> DOUBLE",
        description: "Last t minus first t in seconds; 0 for one point, NULL for an empty or NULL trajectory.",
        example: "SELECT traj_duration([{'t': 0, 'x': 0, 'y': 0}, {'t': 2.5, 'x': 3, 'y': 4}]); -- 2.5",
    },
    FnDoc {
        name: "traj_time_range",
        signatures: "traj_time_range(traj STRUCT(t, x, y)[]) -> STRUCT(t_start DOUBLE, t_end DOUBLE)",
        description: "First and last timestamp; NULL for an empty or NULL trajectory.",
        example: "SELECT traj_time_range([{'t': 1, 'x': 0, 'y': 0}, {'t': 4, 'x': 3, 'y': 4}]); -- {'t_start': 1.0, 't_end': 4.0}",
    },
    FnDoc {
        name: "traj_speeds",
        signatures: "traj_speeds(traj STRUCT(t, x, y)[]) -> STRUCT(t DOUBLE, v DOUBLE)[]",
        description: "Speed by forward finite differences, |p[k+1] - p[k]| / (t[k+1] - t[k]), stamped at t[k+1]; \
                      n points give n-1 samples. Pairs with equal timestamps are skipped (speed over zero time is undefined). \
                      The result feeds lcss_series_similarity (the thesis's speed pre-match).",
        example: "SELECT traj_speeds([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}]); -- [{'t': 1.0, 'v': 5.0}]",
    },
    FnDoc {
        name: "traj_turn_rates",
        signatures: "traj_turn_rates(traj STRUCT(t, x, y)[] [, min_step DOUBLE]) -> STRUCT(t DOUBLE, v DOUBLE)[]",
        description: "Turn rate in rad/s, which does not change under rotation or translation: a coordinate-free signature for matching tracks \
                      across cameras (with traj_speeds). The track is cut into chords of at least min_step metres (default 1.0) to keep \
                      position noise out of the heading; each sample is the wrapped heading change between consecutive chords over their time difference.",
        example: "SELECT traj_turn_rates([{'t':0,'x':0,'y':0},{'t':1,'x':2,'y':0},{'t':2,'x':2,'y':2}]); -- [{'t': 2.0, 'v': 1.5707963267948966}]",
    },
    FnDoc {
        name: "traj_to_wkt",
        signatures: "traj_to_wkt(traj STRUCT(t, x, y)[]) -> VARCHAR",
        description: "WKT for GIS tools: LINESTRING for two or more points, POINT for one, LINESTRING EMPTY for none. \
                      Time is dropped. ST_GeomFromText (DuckDB spatial) reads it.",
        example: "SELECT traj_to_wkt([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}]); -- LINESTRING (0 0, 3 4)",
    },
    FnDoc {
        name: "traj_to_wkb",
        signatures: "traj_to_wkb(traj STRUCT(t, x, y)[]) -> BLOB",
        description: "Little-endian ISO WKB of the geometry traj_to_wkt describes (LINESTRING, POINT for one point, LINESTRING EMPTY). \
                      ST_GeomFromWKB (DuckDB spatial) reads it; trajdb pipeline writes it as the GeoParquet geometry of merged.parquet.",
        example: "SELECT octet_length(traj_to_wkb([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 3, 'y': 4}])); -- 41",
    },
    FnDoc {
        name: "traj_resample",
        signatures: "traj_resample(traj STRUCT(t, x, y)[], period DOUBLE [, max_gap DOUBLE]) -> STRUCT(t DOUBLE, x DOUBLE, y DOUBLE)[]",
        description: "The trajectory at t = k * period seconds (k integer: one clock shared by every camera), by linear interpolation; \
                      no extrapolation, and no interpolation across a gap longer than max_gap seconds (default: no limit). \
                      Resample both tracks before LCSS when cameras sample at different phases: raw samples of a car at 12 m/s lie up to \
                      period/2 * 12 m apart, which can exceed epsilon. Errors: period or max_gap <= 0 or not finite, more than 50,000,000 output points.",
        example: "SELECT traj_resample([{'t': 0.125, 'x': 0, 'y': 0}, {'t': 0.625, 'x': 2, 'y': 0}], 0.25); -- [{'t': 0.25, 'x': 0.5, 'y': 0.0}, {'t': 0.5, 'x': 1.5, 'y': 0.0}]",
    },
];

fn length(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    let a = TrajCol::new(input, 0);
    let vals: Vec<Option<i64>> = (0..input.len()).map(|r| a.raw_len(r).map(|n| n as i64)).collect();
    write_flat(&mut output.flat_vector(), &vals);
    Ok(())
}

fn duration(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_duration";
    let a = TrajCol::new(input, 0);
    let vals = map_rows(input.len(), |r| Ok(a.get(r, F, "traj")?.and_then(|t| traj::duration(t.t))))?;
    write_flat(&mut output.flat_vector(), &vals);
    Ok(())
}

fn time_range(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_time_range";
    let a = TrajCol::new(input, 0);
    let vals = map_rows(input.len(), |r| {
        Ok(a.get(r, F, "traj")?.and_then(|t| traj::time_range(t.t)).map(|(s, e)| vec![s, e]))
    })?;
    write_struct_f64(&mut output.struct_vector(), 2, &vals);
    Ok(())
}

fn speeds(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_speeds";
    let a = TrajCol::new(input, 0);
    let vals = map_rows(input.len(), |r| Ok(a.get(r, F, "traj")?.map(traj::speeds)))?;
    write_list_of_pairs::<f64, f64>(&mut output.list_vector(), &vals);
    Ok(())
}

fn turn_rates(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_turn_rates";
    let a = TrajCol::new(input, 0);
    let step = OptCol::new(input, 1);
    let vals = map_rows(input.len(), |r| {
        let Some(t) = a.get(r, F, "traj")? else { return Ok(None) };
        let Some(s) = step.f64_or(r, 1.0) else { return Ok(None) };
        if !(s > 0.0 && s.is_finite()) {
            return Err(err(F, format!("min_step must be > 0, got {s}")));
        }
        Ok(Some(traj::turn_rates(t, s)))
    })?;
    write_list_of_pairs::<f64, f64>(&mut output.list_vector(), &vals);
    Ok(())
}

fn to_wkt(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_to_wkt";
    let a = TrajCol::new(input, 0);
    let vals = map_rows(input.len(), |r| Ok(a.get(r, F, "traj")?.map(traj::to_wkt)))?;
    write_varchar(&mut output.flat_vector(), &vals);
    Ok(())
}

fn to_wkb(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_to_wkb";
    let a = TrajCol::new(input, 0);
    let vals = map_rows(input.len(), |r| Ok(a.get(r, F, "traj")?.map(traj::to_wkb)))?;
    write_blobs(output, &vals);
    Ok(())
}

fn resample(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_resample";
    let a = TrajCol::new(input, 0);
    let period = PrimCol::new(input, 1);
    let gap = OptCol::new(input, 2);
    let vals = map_rows(input.len(), |r| {
        let Some(t) = a.get(r, F, "traj")? else { return Ok(None) };
        let Some(p) = period.f64(r) else { return Ok(None) };
        if !(p > 0.0 && p.is_finite()) {
            return Err(err(F, format!("period must be > 0, got {p}")));
        }
        let Some(g) = gap.f64_or(r, f64::INFINITY) else { return Ok(None) };
        if !(g > 0.0) {
            return Err(err(F, format!("max_gap must be > 0, got {g}")));
        }
        traj::resample(t, p, g).map(Some).map_err(|e| err(F, e))
    })?;
    write_trajs(&mut output.list_vector(), &vals);
    Ok(())
}

scalar_fn!(TrajLength, vec![sig(vec![traj_type()], bigint())], length);
scalar_fn!(TrajDuration, vec![sig(vec![traj_type()], double())], duration);
scalar_fn!(
    TrajTimeRange,
    vec![sig(vec![traj_type()], struct_of(&[("t_start", double()), ("t_end", double())]))],
    time_range
);
scalar_fn!(TrajSpeeds, vec![sig(vec![traj_type()], series_type())], speeds);
scalar_fn!(
    TrajTurnRates,
    vec![sig(vec![traj_type()], series_type()), sig(vec![traj_type(), double()], series_type())],
    turn_rates
);
scalar_fn!(TrajToWkt, vec![sig(vec![traj_type()], varchar())], to_wkt);
scalar_fn!(TrajToWkb, vec![sig(vec![traj_type()], blob())], to_wkb);
scalar_fn!(
    TrajResample,
    vec![sig(vec![traj_type(), double()], traj_type()), sig(vec![traj_type(), double(), double()], traj_type())],
    resample
);

pub fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_scalar_function::<TrajLength>("traj_length")?;
    con.register_scalar_function::<TrajDuration>("traj_duration")?;
    con.register_scalar_function::<TrajTimeRange>("traj_time_range")?;
    con.register_scalar_function::<TrajSpeeds>("traj_speeds")?;
    con.register_scalar_function::<TrajTurnRates>("traj_turn_rates")?;
    con.register_scalar_function::<TrajToWkt>("traj_to_wkt")?;
    con.register_scalar_function::<TrajToWkb>("traj_to_wkb")?;
    con.register_scalar_function::<TrajResample>("traj_resample")?;
    Ok(())
}
