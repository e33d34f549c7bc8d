//! trajdb: multi-camera traffic-trajectory analysis as DuckDB SQL functions. This crate is the
//! loadable extension (`trajdb.duckdb_extension`), the top of the workspace:
//!
//! - [`algo`] (crates/algo): the maths, pure Rust, no DuckDB;
//! - [`app`] (crates/app): the pipeline manifest, parameters, results folder, simulator and
//!   report renderer, no DuckDB;
//! - [`runner`]: executes the manifest on the database's runner connection (`trajdb_pipeline`);
//! - [`bindings`]: the DuckDB functions (descriptors, kernels, the vector module);
//! - the entry point (`trajdb_init_c_api`).
//!
//! Every arrow points down: bindings → runner → app → algo. No crate compiles DuckDB: DuckDB's
//! C API is reached through the function pointers DuckDB fills in at LOAD.

pub use trajdb_algo as algo;
pub use trajdb_app as app;

pub mod bindings;
pub mod runner;

/// Entry point of `trajdb.duckdb_extension` (C API v1.2.0, ABI C_STRUCT). `unsafe` because the
/// entry-point macro requires it; the registration itself is safe code.
#[cfg(feature = "extension")]
#[duckdb::duckdb_entrypoint_c_api(ext_name = "trajdb", min_duckdb_version = "v1.2.0")]
pub unsafe fn extension_entrypoint(con: duckdb::Connection) -> Result<(), Box<dyn std::error::Error>> {
    bindings::register_all(&con)?;
    Ok(())
}
