//! The SQL layer: thin wrappers that turn DuckDB vectors into slices (see [`convert`]), call
//! [`crate::algo`], and write the results back. One file per function family. The same
//! [`register_all`] runs in the embedded build and in the loadable extension.

pub mod align;
pub mod assign;
pub mod cluster;
pub mod convert;
pub mod events;
pub mod lcss;
pub mod merge;
pub mod meta;
pub mod polygon;
pub mod traj;

use duckdb::Connection;

/// Every documented function, in reference order.
pub fn docs() -> Vec<convert::FnDoc> {
    let mut v = Vec::new();
    v.extend_from_slice(traj::DOCS);
    v.extend_from_slice(lcss::DOCS);
    v.extend_from_slice(align::DOCS);
    v.extend_from_slice(polygon::DOCS);
    v.extend_from_slice(assign::DOCS);
    v.extend_from_slice(merge::DOCS);
    v.extend_from_slice(cluster::DOCS);
    v.extend_from_slice(events::DOCS);
    v.extend_from_slice(meta::DOCS);
    v
}

/// Registers every trajdb function on `con`.
pub fn register_all(con: &Connection) -> duckdb::Result<()> {
    traj::register(con)?;
    lcss::register(con)?;
    align::register(con)?;
    polygon::register(con)?;
    assign::register(con)?;
    merge::register(con)?;
    cluster::register(con)?;
    events::register(con)?;
    meta::register(con)?;
    Ok(())
}
