//! trajdb: multi-camera traffic-trajectory analysis as DuckDB SQL functions. This crate is the
//! loadable extension (`trajdb.duckdb_extension`), the top of the workspace:
//!
//! - [`algo`] (crates/algo): the maths, pure Rust, no DuckDB;
//! - [`app`] (crates/app): the pipeline manifest, parameters, results folder, simulator and
//!   report renderer, no DuckDB;
//! - [`runner`]: executes the manifest in a private in-memory database per call (`trajdb_pipeline`);
//! - [`archive`]: an archive's site-day in private databases, and the driver of `trajdb_archive`;
//! - [`bindings`]: the DuckDB functions (descriptors, kernels, the vector module);
//! - the entry point (`trajdb_init_c_api`).
//!
//! Every arrow points down: bindings → runner (and archive) → app → algo. No crate compiles DuckDB: DuckDB's
//! C API is reached through the function pointers DuckDB fills in at LOAD.

pub use trajdb_algo as algo;
pub use trajdb_app as app;

pub mod archive;
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

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};

    fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                rust_files(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }

    /// The code lines (comments dropped) of every .rs file under `dir`.
    fn code(dir: &str) -> Vec<(PathBuf, String)> {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut files = Vec::new();
        rust_files(&root.join(dir), &mut files);
        files
            .into_iter()
            .map(|f| {
                let text = std::fs::read_to_string(&f).unwrap();
                let lines: String = text.lines().filter(|l| !l.trim_start().starts_with("//")).map(|l| format!("{l}\n")).collect();
                (f, lines)
            })
            .collect()
    }

    /// Every arrow points down: bindings → runner → app → algo, and within the bindings the
    /// vector module and the type vocabulary never reach up to the registry (no circle).
    #[test]
    fn arrows_point_down() {
        let rules: &[(&str, &[&str])] = &[
            ("crates/algo/src", &["duckdb", "trajdb_app", "crate::bindings", "crate::runner"]),
            ("crates/app/src", &["duckdb::", "use duckdb", "trajdb::", "crate::bindings", "crate::runner"]),
            ("src/runner.rs", &["crate::bindings", "super::bindings"]),
            ("src/archive", &["crate::bindings", "super::bindings"]),
            ("src/bindings/vector", &["registry"]),
            ("src/bindings/types.rs", &["registry", "vector::"]),
        ];
        for (dir, banned) in rules {
            let files = if dir.ends_with(".rs") {
                let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
                let text = std::fs::read_to_string(&p).unwrap();
                vec![(p.clone(), text.lines().filter(|l| !l.trim_start().starts_with("//")).map(|l| format!("{l}\n")).collect())]
            } else {
                code(dir)
            };
            assert!(!files.is_empty(), "{dir}: no files");
            for (f, text) in files {
                for b in *banned {
                    assert!(!text.contains(b), "{} names `{b}`: an arrow up (see the crate doc)", f.display());
                }
            }
        }
    }
}
