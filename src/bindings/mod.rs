//! The DuckDB bindings: thin kernels that read arguments, call [`crate::algo`], and write
//! results. One file per algo family (`traj`, `lcss`, `align`, `geometry`, `matching`, `merge`,
//! `cluster`, `events`), each with the [`registry::Function`] descriptors of its SQL functions;
//! [`vector`] is the only code that touches DuckDB's vectors; [`registry`] turns descriptors into
//! registrations and the reference. The same [`register_all`] runs in the embedded build and in
//! the loadable extension.

pub mod align;
pub mod archive;
pub mod associate;
pub mod clock;
pub mod cluster;
pub mod conflict;
pub mod events;
pub mod fuse;
pub mod geometry;
pub mod lcss;
pub mod matching;
pub mod merge;
pub mod meta;
pub mod noise;
pub mod params;
pub mod registry;
pub mod report;
pub mod simulate;
pub mod pipeline;
pub mod traj;
pub mod types;
pub mod vector;

use duckdb::Connection;
use registry::{Doc, Function};

/// `f` of every element of `s`, into a vector allocated fallibly: result columns sized by the
/// input are errors naming their size when they do not fit, never an abort.
pub(crate) fn try_map<T, U>(s: &[T], f: impl FnMut(&T) -> U) -> Result<Vec<U>, String> {
    let mut v = Vec::new();
    v.try_reserve_exact(s.len())
        .map_err(|_| format!("the result holds {} rows (about {} bytes a column), more than this process can allocate; return less per call", s.len(), s.len() as u128 * std::mem::size_of::<U>() as u128))?;
    v.extend(s.iter().map(f));
    Ok(v)
}

/// Every function, in reference order.
pub fn functions() -> Vec<&'static Function> {
    [traj::FUNCTIONS, lcss::FUNCTIONS, align::FUNCTIONS, clock::FUNCTIONS, associate::FUNCTIONS, geometry::FUNCTIONS, matching::FUNCTIONS, merge::FUNCTIONS, fuse::FUNCTIONS, cluster::FUNCTIONS, conflict::FUNCTIONS, events::FUNCTIONS, noise::FUNCTIONS, meta::FUNCTIONS, params::FUNCTIONS, pipeline::FUNCTIONS, archive::FUNCTIONS, simulate::FUNCTIONS, report::FUNCTIONS]
        .into_iter()
        .flatten()
        .collect()
}

/// The reference rows (`trajdb_functions()`, `trajdb functions`, docs/functions.md).
pub fn docs() -> Vec<Doc> {
    functions().iter().map(|f| f.doc()).collect()
}

/// Registers every trajdb function on `con`.
pub fn register_all(con: &Connection) -> duckdb::Result<()> {
    registry::register(con, &functions())
}

/// Registers every trajdb function on `con` with the given work limits (a private database of
/// `trajdb_pipeline` shares its caller's).
pub fn register_all_with(con: &Connection, limits: std::sync::Arc<crate::algo::limits::Limits>) -> duckdb::Result<()> {
    registry::register_with(con, &functions(), limits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// From its name alone a newcomer finds a function's maths, binding, test and doc.
    #[test]
    fn every_function_names_existing_files_and_a_unique_name() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut names = std::collections::HashSet::new();
        for d in docs() {
            assert!(names.insert(d.name), "{} is described twice", d.name);
            for f in d.maths.split(", ").chain([d.binding]) {
                assert!(root.join(f).exists(), "{}: {f} does not exist", d.name);
            }
            assert!(root.join(&d.test).exists(), "{}: {} does not exist", d.name, d.test);
        }
    }
}
