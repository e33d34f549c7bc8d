//! Intentionally empty. The `[build-dependencies]` in Cargo.toml exist only to pin a host-side
//! crate feature (see the comment there), so that `cargo build` and `cargo test` resolve the
//! same features for libduckdb-sys's build script and share one compiled DuckDB.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
}
