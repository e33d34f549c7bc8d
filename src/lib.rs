//! trajdb: multi-camera traffic-trajectory analysis as DuckDB SQL functions.
//!
//! - [`algo`]: the maths, pure Rust, no DuckDB (builds with `--no-default-features`).
//! - `bindings`: the DuckDB functions (descriptors, kernels, the vector module), compiled with
//!   either the `bundled` or the `extension` feature.
//! - [`app`]: the application behind the `trajdb` command (pipeline, score, report, simulate).
//! - The loadable-extension entry point (`trajdb_init_c_api`) with feature `extension`.

pub mod algo;

#[cfg(any(feature = "bundled", feature = "extension"))]
pub mod bindings;

/// The application behind the `trajdb` command: pipeline, parameters, score, report, simulator.
pub mod app;

#[cfg(all(feature = "bundled", feature = "extension"))]
compile_error!("features `bundled` and `extension` must not be enabled together: build the extension with --no-default-features --features extension");

/// Entry point of `trajdb.duckdb_extension` (C API v1.2.0, ABI C_STRUCT). `unsafe` because the
/// entry-point macro requires it; the registration itself is safe code.
#[cfg(feature = "extension")]
#[duckdb::duckdb_entrypoint_c_api(ext_name = "trajdb", min_duckdb_version = "v1.2.0")]
pub unsafe fn extension_entrypoint(con: duckdb::Connection) -> Result<(), Box<dyn std::error::Error>> {
    bindings::register_all(&con)?;
    Ok(())
}

/// Opens a connection (in memory, or on `path`) with every trajdb function registered.
#[cfg(feature = "bundled")]
pub fn open(path: Option<&str>) -> duckdb::Result<duckdb::Connection> {
    let con = match path {
        Some(p) => duckdb::Connection::open(p)?,
        None => duckdb::Connection::open_in_memory()?,
    };
    bindings::register_all(&con)?;
    Ok(con)
}
