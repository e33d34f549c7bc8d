//! Embeds every file under the repository's `sql/` in the library (`crates/app/src/sql.rs` looks them up
//! by path), so that the extension's runner runs the same SQL files the DuckDB CLI `.read`s,
//! without a second list of them in Rust.
use std::path::Path;

fn walk(dir: &Path, out: &mut Vec<String>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).expect("sql/").map(|e| e.expect("entry").path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            walk(&p, out);
        } else if p.extension().is_some_and(|e| e == "sql") {
            out.push(p.to_string_lossy().replace('\\', "/"));
        }
    }
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=../../sql");
    // the SQL files live at the repository root (sql/), two levels above this crate
    let manifest = std::env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR");
    let root = Path::new(&manifest).join("../..").canonicalize().expect("repository root").to_string_lossy().replace('\\', "/");
    let mut files = Vec::new();
    walk(&Path::new(&root).join("sql"), &mut files);
    let mut code = String::from("/// Every file under sql/: (path relative to the crate root, contents).\npub const SQL_FILES: &[(&str, &str)] = &[\n");
    for f in &files {
        println!("cargo:rerun-if-changed={f}");
        let rel = f.strip_prefix(&format!("{}/", root.replace('\\', "/"))).unwrap_or(f);
        code.push_str(&format!("    ({rel:?}, include_str!({f:?})),\n"));
    }
    code.push_str("];\n");
    std::fs::write(Path::new(&std::env::var("OUT_DIR").expect("OUT_DIR")).join("sql_files.rs"), code).expect("write sql_files.rs");
}
