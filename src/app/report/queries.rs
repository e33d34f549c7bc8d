//! The report's data, read from the pipeline's tables on the open connection.

use super::R;
use duckdb::Connection;

pub fn query_rows<T>(con: &Connection, sql: &str, f: impl FnMut(&duckdb::Row) -> duckdb::Result<T>) -> R<Vec<T>> {
    let mut st = con.prepare(sql)?;
    let rows = st.query_map([], f)?;
    Ok(rows.collect::<Result<Vec<T>, _>>()?)
}

/// What every section needs: the cameras, the classes, and ξ (merge_min_points).
pub struct Ctx {
    pub cameras: Vec<i64>,
    pub classes: Vec<String>,
    pub xi: i64,
}

impl Ctx {
    pub fn load(con: &Connection) -> R<Ctx> {
        Ok(Ctx {
            cameras: query_rows(con, "SELECT DISTINCT camera FROM points ORDER BY camera", |r| r.get(0))?,
            classes: query_rows(con, "SELECT DISTINCT class FROM points ORDER BY class", |r| r.get(0))?,
            xi: con.query_row("SELECT calibrated('merge_min_points')::BIGINT", [], |r| r.get(0))?,
        })
    }
}

/// The view polygons: (camera, class, WKT).
pub fn views(con: &Connection) -> R<Vec<(i64, String, String)>> {
    query_rows(con, "SELECT camera, class, polygon_to_wkt(polygon) FROM view_polygons ORDER BY camera, class", |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
}

/// (x, y) pairs of a trajectory value (`STRUCT(t, x, y)[]`).
pub fn value_xy(v: &duckdb::types::Value) -> Vec<(f64, f64)> {
    use duckdb::types::Value;
    let f = |v: &Value| match v {
        Value::Double(d) => *d,
        _ => f64::NAN,
    };
    match v {
        Value::List(items) => items
            .iter()
            .filter_map(|it| match it {
                Value::Struct(m) => Some((f(m.get(&"x".to_string())?), f(m.get(&"y".to_string())?))),
                _ => None,
            })
            .collect(),
        _ => Vec::new(),
    }
}

