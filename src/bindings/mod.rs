//! The DuckDB bindings: thin kernels that read arguments, call [`crate::algo`], and write
//! results. One file per algo family (`traj`, `lcss`, `align`, `geometry`, `matching`, `merge`,
//! `cluster`, `events`, ...), each with the [`registry::Function`] descriptors of its SQL
//! functions; no family file imports from another: what several share is in [`common`].
//! [`types`] is the descriptors' vocabulary, [`vector`] the only code that touches DuckDB's
//! vectors; [`registry`] turns descriptors into registrations and the reference. The same
//! [`register_all`] runs in the embedded build and in the loadable extension.

pub mod align;
pub mod archive;
pub mod associate;
pub mod clock;
pub mod cluster;
pub mod common;
pub mod conflict;
pub mod events;
pub mod fuse;
pub mod geometry;
pub mod lcss;
pub mod map;
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

/// Every function, in registration order (the reference lists them by section, in this order
/// within each).
pub fn functions() -> Vec<&'static Function> {
    [traj::FUNCTIONS, lcss::FUNCTIONS, align::FUNCTIONS, clock::FUNCTIONS, associate::FUNCTIONS, geometry::FUNCTIONS, matching::FUNCTIONS, merge::FUNCTIONS, fuse::FUNCTIONS, cluster::FUNCTIONS, conflict::FUNCTIONS, events::FUNCTIONS, noise::FUNCTIONS, map::FUNCTIONS, meta::FUNCTIONS, pipeline::FUNCTIONS, params::FUNCTIONS, archive::FUNCTIONS, simulate::FUNCTIONS, report::FUNCTIONS]
        .into_iter()
        .flatten()
        .collect()
}

/// The reference rows (`trajdb_functions()`, `trajdb functions`, docs/functions.md), in
/// reference order: by section, then in registration order.
pub fn docs() -> Vec<Doc> {
    let mut d: Vec<Doc> = functions().iter().map(|f| f.doc()).collect();
    d.sort_by_key(|d| d.section);
    d
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
    use registry::Section;
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

    /// Every argument of every function says what it is; one name means one thing within a
    /// function (its overloads share the reference's one row per argument).
    #[test]
    fn every_argument_is_documented() {
        for f in functions() {
            let params = f.params();
            for (p, _) in &params {
                assert!(!p.doc.trim().is_empty(), "{}: argument {} has no doc", f.name, p.name);
                assert!(!p.doc.contains('\n'), "{}: the doc of {} spans lines", f.name, p.name);
                for (q, _) in &params {
                    assert!(q.name != p.name || q.doc == p.doc, "{}: two docs of argument {}: {:?} and {:?}", f.name, p.name, p.doc, q.doc);
                }
            }
        }
    }

    /// "See also" names functions that exist, never the function itself, each once.
    #[test]
    fn see_also_names_existing_functions() {
        let names: std::collections::HashSet<&str> = functions().iter().map(|f| f.name).collect();
        for f in functions() {
            for (k, n) in f.see_also.iter().enumerate() {
                assert!(names.contains(n), "{}: see_also names {n}, which is no trajdb function", f.name);
                assert!(*n != f.name, "{}: see_also names itself", f.name);
                assert!(!f.see_also[..k].contains(n), "{}: see_also names {n} twice", f.name);
            }
        }
    }

    /// Every section holds a function, and the reference lists them section by section.
    #[test]
    fn sections_are_in_reading_order_and_none_is_empty() {
        let d = docs();
        for s in Section::ALL {
            assert!(d.iter().any(|x| x.section == s), "section {:?} has no function", s);
            assert!(!s.intro().is_empty() && !s.title().is_empty());
        }
        assert!(d.windows(2).all(|w| w[0].section <= w[1].section));
        assert!(Section::ALL.windows(2).all(|w| w[0] < w[1]));
    }

    /// No binding file imports from another: what several share lives in common.rs (or in
    /// types.rs, registry.rs, vector/), never in one of them.
    #[test]
    fn no_binding_file_imports_from_another() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/bindings");
        let shared = ["mod", "common", "registry", "types"];
        let mut families = Vec::new();
        for e in std::fs::read_dir(&dir).expect("src/bindings") {
            let p = e.expect("entry").path();
            let stem = p.file_stem().and_then(|s| s.to_str()).unwrap_or_default().to_string();
            if p.extension().is_some_and(|x| x == "rs") && !shared.contains(&stem.as_str()) {
                families.push(stem);
            }
        }
        assert!(families.len() > 10, "{families:?}");
        for f in families.iter().map(String::as_str).chain(["common"]) {
            let text = std::fs::read_to_string(dir.join(format!("{f}.rs"))).expect("binding file");
            let code: String = text.lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n");
            for other in families.iter().filter(|o| o.as_str() != f) {
                for pat in [format!("super::{other}::"), format!("super::{other};"), format!("super::{other},"), format!("super::{{{other}")] {
                    assert!(!code.contains(&pat), "src/bindings/{f}.rs imports from src/bindings/{other}.rs (`{pat}`): move what both need to common.rs");
                }
            }
        }
    }

    /// docs/functions.md is the generated reference, byte for byte (regenerate it with
    /// `python -m trajdb functions --markdown > docs/functions.md`).
    #[test]
    fn docs_functions_md_is_generated() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/functions.md");
        let have = std::fs::read_to_string(&path).expect("docs/functions.md");
        assert!(
            have == registry::markdown(&docs()),
            "docs/functions.md is stale: python -m trajdb functions --markdown > docs/functions.md"
        );
    }

    /// The family table of docs/development.md ("Where things live") is the generated one,
    /// between its markers (regenerate it with `python -m trajdb functions --families`).
    #[test]
    fn development_md_family_table_is_generated() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/development.md");
        let have = std::fs::read_to_string(&path).expect("docs/development.md");
        let (begin, end) = (registry::FAMILIES_BEGIN, registry::FAMILIES_END);
        let start = have.find(begin).expect("docs/development.md lacks the generated family table's begin marker") + begin.len();
        let stop = start + have[start..].find(end).expect("docs/development.md lacks the family table's end marker");
        assert!(
            have[start..stop] == registry::families(&docs()),
            "docs/development.md's family table is stale: replace the lines between its markers with python -m trajdb functions --families"
        );
    }
}
