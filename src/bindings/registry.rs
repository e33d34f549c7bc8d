//! One descriptor per SQL function ([`Function`]): name, overloads with named and typed
//! parameters, return type, description, example, the kernel, and where its maths lives.
//!
//! Everything else is generated from these descriptors:
//! - registration in DuckDB ([`register`]): one overload per arity of a [`Signature`] and per
//!   alternative of a [`Ty::OneOf`] parameter;
//! - the `trajdb_functions()` table, `trajdb functions [--markdown | --families]`,
//!   docs/functions.md (sections in reading order, an index, per-argument docs, see also) and
//!   the family table of docs/development.md ([`Doc`], [`markdown`], [`text`], [`families`]);
//! - the argument names in every error message: the vector readers take them from the
//!   declared parameters, and the dispatcher prefixes the function name.
//!
//! DuckDB's C API has no parameter names for scalar functions (`duckdb_functions()` lists them
//! as `col0, col1, ...`), so the names live in the generated reference instead.
//!
//! Every registration of one database shares one [`Limits`] (the work limits of
//! `trajdb_limit`): the scalar dispatcher and the table adapter (`vector::table`) run each call
//! inside its scope, so limits set in one database never bind another.

use super::vector::{Args, Out};
use crate::algo::limits::{self, Limits};
use std::sync::Arc;
use duckdb::vscalar::{ScalarFunctionSignature, VScalar};
use duckdb::Connection;
use std::cell::Cell;
use std::error::Error;
use std::fmt::Write as _;

pub use super::types::{p, pd, Database, Param, Table, Ty, GEOMETRY, GEOMETRY_LIST, SERIES, TRAJ, TRANSFORM};

/// What a kernel does with one chunk: read `args`, call algo, write `out`. Errors are
/// prefixed with the function name by the dispatcher.
pub type Kernel = fn(&Args<'_>, &mut Out<'_>) -> Result<(), Box<dyn Error>>;

/// A family of overloads sharing one kernel: `params` in order, callable with the first
/// `arities[k]` of them (optional trailing parameters), each [`Ty::OneOf`] expanded.
#[derive(Clone, Copy)]
pub struct Signature {
    pub params: &'static [Param],
    /// The accepted argument counts, increasing; empty = all `params`.
    pub arities: &'static [usize],
    pub returns: Ty,
    pub kernel: Kernel,
}

/// The one description of an SQL function.
#[derive(Clone, Copy)]
pub struct Function {
    pub name: &'static str,
    pub description: &'static str,
    /// Runs as written; after `-- ` the expected result (checked by tests/test_cli_python.py unless it
    /// contains `~`).
    pub example: &'static str,
    /// The file(s) that hold the maths, e.g. `crates/algo/src/lcss/time_window.rs`.
    pub maths: &'static str,
    /// The binding file (`file!()`).
    pub binding: &'static str,
    /// Where the reference lists it (every function is in exactly one section).
    pub section: Section,
    /// Related functions, by name (a unit test checks that each exists).
    pub see_also: &'static [&'static str],
    pub signatures: &'static [Signature],
    pub table: Option<Table>,
}

/// The sections of the reference, in reading order: the building blocks first (one trajectory,
/// polygons, similarity), then the steps of the pipeline in its order, then the runners.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Section {
    Trajectories,
    Geometry,
    Similarity,
    Alignment,
    Clocks,
    Association,
    Matching,
    Fusion,
    Quality,
    Clustering,
    Conflicts,
    Classes,
    Noise,
    Maps,
    Pipeline,
    Archive,
    Simulation,
    Reference,
}

impl Section {
    /// Every section, in reading order.
    pub const ALL: [Section; 18] = [
        Section::Trajectories,
        Section::Geometry,
        Section::Similarity,
        Section::Alignment,
        Section::Clocks,
        Section::Association,
        Section::Matching,
        Section::Fusion,
        Section::Quality,
        Section::Clustering,
        Section::Conflicts,
        Section::Classes,
        Section::Noise,
        Section::Maps,
        Section::Pipeline,
        Section::Archive,
        Section::Simulation,
        Section::Reference,
    ];

    /// The heading.
    pub const fn title(self) -> &'static str {
        match self {
            Section::Trajectories => "Trajectories",
            Section::Geometry => "Geometry",
            Section::Similarity => "Similarity (LCSS)",
            Section::Alignment => "Alignment",
            Section::Clocks => "Clocks",
            Section::Association => "Association",
            Section::Matching => "Matching and merging",
            Section::Fusion => "Fusion",
            Section::Quality => "Track quality",
            Section::Clustering => "Clustering",
            Section::Conflicts => "Conflicts",
            Section::Classes => "Road-user classes",
            Section::Noise => "Noise model",
            Section::Maps => "Maps",
            Section::Pipeline => "Pipeline",
            Section::Archive => "Archive",
            Section::Simulation => "Simulation",
            Section::Reference => "Reference and limits",
        }
    }

    /// What the section's functions are for, in a sentence or two.
    pub const fn intro(self) -> &'static str {
        match self {
            Section::Trajectories => {
                "One trajectory at a time. A TRAJ is a list of points {t, x, y} (t in seconds, x and y in metres) sorted by t: its \
                 size, length, duration and time range, speeds and turn rates, whether its road user stood still, resampling onto a \
                 clock every camera shares, and export as WKT, WKB or GEOMETRY for GIS tools."
            }
            Section::Geometry => {
                "View polygons and their overlaps (thesis 2.3): a camera's view as the hull of the points it saw, boolean operations \
                 on polygons, point-in-polygon tests and a trajectory clipped to a region. Polygon arguments are WKT VARCHAR, WKB BLOB \
                 or GEOMETRY; polygon results are WKB BLOBs (polygon_to_wkt and polygon_to_geometry read them)."
            }
            Section::Similarity => {
                "How alike two trajectories are: the longest common subsequence (LCSS) with a distance and a time window (thesis eq. \
                 2.9 / 2.10) and its matched point pairs, the 1-D form for series such as speeds, Buzan's index-window S1 and \
                 translation-invariant S2, and the sparse similarity matrix of two sets of trajectories in one call."
            }
            Section::Alignment => {
                "Bringing two cameras into one frame: a transform from point pairs (rigid_fit) or from unpaired points in space and \
                 time (cpd_align), a camera pair's final registration when the cameras see different points of a road user, applying, \
                 composing and inverting transforms, and the checks that a camera is another one exported twice or has moved."
            }
            Section::Clocks => {
                "Bringing two cameras onto one clock: coarse offsets from activity or speed profiles, scans of one track pair's \
                 offset, the offset and transform that fit many track pairs together, one pair's offset under a known transform, \
                 a camera pair's clock drift, and the cameras' values solved from every pair's difference. The clock model itself, \
                 t_camera = (1 + drift) t_reference + offset, is written once (crates/algo/src/align/clock.rs): clock_to_reference, \
                 clock_compose, clock_invert, clock_between and clock_from_relative."
            }
            Section::Association => {
                "Deciding which tracks of two cameras are one road user (docs/association.md): the distance and constant offset of \
                 candidate pairs over their common time, a camera pair's bias state (the offset between its views of one road user, \
                 per class), and each candidate's evidence and ratio test."
            }
            Section::Matching => {
                "From candidate pairs to road users: the optimal one-to-one assignment of candidate pairs, the matched tracks grouped \
                 into road users, and matched trajectories merged into one (thesis eq. 2.11)."
            }
            Section::Fusion => {
                "One road user's observations from every camera smoothed into one path with its uncertainty (a constant-velocity \
                 Kalman filter and Rauch-Tung-Striebel smoother; docs/fusion.md), and the constant offsets between its source tracks."
            }
            Section::Quality => {
                "Tracks within one camera: events between track ends and starts (broken, split, merge), object / fragment / group \
                 labels, and the evidence and decisions that join the pieces of a broken track (sql/stages/quality.sql)."
            }
            Section::Clustering => {
                "Route patterns: agglomerative clustering of pairwise distances (scipy's linkage methods and cuts), and of \
                 trajectories in one call by Buzan's LCSS distance, exactly or through prototypes (docs/clustering.md)."
            }
            Section::Conflicts => {
                "Surrogate safety measures between road users (docs/analysis.md): post-encroachment time (PET) and time-to-collision \
                 (TTC) of a pair, of every pair near each other or of the k nearest misses in one call, the kind of a conflict, and \
                 whether a pair is one road user counted twice."
            }
            Section::Classes => {
                "What a class name means, read from its words the same way in every stage: the kind of road user it names and its \
                 size (length, the least gap between two of them, its radius for time-to-collision)."
            }
            Section::Noise => {
                "The noise model's conversions (crates/algo/src/noise.rs): from what the calibrate stage measures (medians and \
                 percentiles of distances) to the sigmas, gates, radii, windows and densities the other stages use; and the gap \
                 that ends a recording session."
            }
            Section::Maps => {
                "Results on a map (docs/maps.md): the similarity from the reference camera's local frame to a map's coordinates, \
                 fitted on control points (a projected CRS in metres, or longitude/latitude through the plane tangent at the site), \
                 each control point's residual, and paths mapped with it."
            }
            Section::Pipeline => {
                "The whole pipeline from SQL: one statement (trajdb_pipeline), or its manifest for hosts that run the statements \
                 themselves, the embedded SQL files, the declared parameters, the results folder and the QA report."
            }
            Section::Archive => {
                "An archive of site-days (docs/archive.md): the whole incremental run in one call, or its steps (open, next, task, \
                 commit, close) for hosts that run the days in processes of their own."
            }
            Section::Simulation => {
                "An intersection seen by several cameras, simulated with its ground truth (docs/simulate.md): what trajdb's tests, \
                 demo and benchmarks run on."
            }
            Section::Reference => "This reference as a table or a text, and the work limits that keep every call short.",
        }
    }

    /// The Markdown anchor of its heading in docs/functions.md.
    pub fn anchor(self) -> String {
        anchor(self.title())
    }
}

/// The anchor GitHub gives a heading: lower case, spaces as `-`, other punctuation dropped.
fn anchor(heading: &str) -> String {
    heading
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c.to_ascii_lowercase()),
            _ => None,
        })
        .collect()
}

impl Signature {
    fn arities(&self) -> Vec<usize> {
        if self.arities.is_empty() {
            vec![self.params.len()]
        } else {
            self.arities.to_vec()
        }
    }
    /// Every concrete overload: parameter types and return type.
    pub fn overloads(&self) -> Vec<Vec<Ty>> {
        let mut out = Vec::new();
        for n in self.arities() {
            let mut combos: Vec<Vec<Ty>> = vec![vec![]];
            for p in &self.params[..n] {
                combos = combos.into_iter().flat_map(|c| p.ty.alternatives().into_iter().map(move |t| [c.clone(), vec![t]].concat())).collect();
            }
            out.extend(combos);
        }
        out
    }
    /// One line: `name(a TRAJ, b TRAJ, epsilon DOUBLE [, min_points BIGINT [, region VARCHAR|BLOB]]) -> BIGINT`.
    fn render(&self, name: &str) -> String {
        let ar = self.arities();
        let mut s = format!("{name}(");
        let mut open = 0;
        for (k, p) in self.params.iter().enumerate() {
            if k > 0 && ar.contains(&k) && k < self.params.len() {
                s.push_str(" [");
                open += 1;
            }
            if k > 0 {
                s.push_str(", ");
            }
            let _ = write!(s, "{} {}", p.name, p.ty.sql());
        }
        s.push_str(&"]".repeat(open));
        let _ = write!(s, ") -> {}", self.returns.sql());
        s
    }
}

/// One row of the reference (`trajdb_functions()`).
#[derive(Clone, Debug)]
pub struct Doc {
    pub name: &'static str,
    /// One line per signature family.
    pub signatures: String,
    pub description: &'static str,
    pub example: &'static str,
    pub maths: &'static str,
    pub binding: &'static str,
    /// `tests/sql/<name>.slt`.
    pub test: String,
    pub section: Section,
    pub see_also: &'static [&'static str],
    /// Every argument once, in order of first appearance over the overloads.
    pub arguments: Vec<ArgDoc>,
}

/// One argument of the reference: its name (`name :=` for a table function's named
/// parameter), its type (`A or B` when overloads differ) and its doc.
#[derive(Clone, Debug, PartialEq)]
pub struct ArgDoc {
    pub name: String,
    pub ty: String,
    pub doc: &'static str,
}

impl Function {
    /// Every parameter of every overload (a table function's positional, then named ones),
    /// with whether it is named.
    pub fn params(&self) -> Vec<(&'static Param, bool)> {
        match &self.table {
            Some(t) => t.params.iter().map(|p| (p, false)).chain(t.named.iter().map(|p| (p, true))).collect(),
            None => self.signatures.iter().flat_map(|s| s.params.iter().map(|p| (p, false))).collect(),
        }
    }

    pub fn doc(&self) -> Doc {
        let signatures = match &self.table {
            Some(t) => {
                let cols: Vec<String> = t.columns.iter().map(|(n, ty)| format!("{n} {}", ty.sql())).collect();
                let args: Vec<String> = t
                    .params
                    .iter()
                    .map(|p| format!("{} {}", p.name, p.ty.sql()))
                    .chain(t.named.iter().map(|p| format!("{} := {}", p.name, p.ty.sql())))
                    .collect();
                format!("{}({}) -> TABLE({})", self.name, args.join(", "), cols.join(", "))
            }
            None => self.signatures.iter().map(|s| s.render(self.name)).collect::<Vec<_>>().join("\n"),
        };
        let mut arguments: Vec<ArgDoc> = Vec::new();
        for (p, named) in self.params() {
            let name = if named { format!("{} :=", p.name) } else { p.name.to_string() };
            let ty = p.ty.sql();
            match arguments.iter_mut().find(|a| a.name == name) {
                Some(a) => {
                    if !a.ty.split(" or ").any(|t| t == ty) {
                        a.ty = format!("{} or {ty}", a.ty);
                    }
                }
                None => arguments.push(ArgDoc { name, ty, doc: p.doc }),
            }
        }
        Doc {
            name: self.name,
            signatures,
            description: self.description,
            example: self.example,
            maths: self.maths,
            binding: self.binding,
            test: format!("tests/sql/{}.slt", self.name),
            section: self.section,
            see_also: self.see_also,
            arguments,
        }
    }
}

/// The docs of one section, in the order given.
fn in_section(docs: &[Doc], s: Section) -> impl Iterator<Item = &Doc> {
    docs.iter().filter(move |d| d.section == s)
}

/// The sections that hold at least one function, in reading order.
fn sections(docs: &[Doc]) -> impl Iterator<Item = Section> + '_ {
    Section::ALL.into_iter().filter(|s| docs.iter().any(|d| d.section == *s))
}

/// A Markdown table cell: one line, `|` escaped.
fn cell(s: &str) -> String {
    s.replace('\n', " ").replace('|', "\\|")
}

/// `[`name`](#name)`: a link to a function of docs/functions.md from inside it.
fn link(name: &str) -> String {
    format!("[`{name}`](#{})", anchor(name))
}

/// The function reference as Markdown (docs/functions.md): a title and introduction, an
/// index of the sections, then per section its heading, introduction and functions, each with
/// its signatures, description, arguments, example, see also, and where it lives.
pub fn markdown(docs: &[Doc]) -> String {
    let mut s = String::from("# trajdb function reference\n\n");
    s.push_str("Generated by `trajdb functions --markdown` from the function descriptors in `src/bindings/` (the same rows as\n");
    s.push_str("`SELECT * FROM trajdb_functions()`). `TRAJ` is `STRUCT(t DOUBLE, x DOUBLE, y DOUBLE)[]`, a trajectory (t in seconds, x\n");
    s.push_str("and y in metres, sorted by t); `A|B` means either type; `[, ...]` marks optional trailing arguments; `name := TYPE` is a\n");
    s.push_str("named parameter of a table function. Polygon results are WKB `BLOB`s.\n\n");
    s.push_str("## Contents\n\n");
    for sec in sections(docs) {
        let names: Vec<String> = in_section(docs, sec).map(|d| link(d.name)).collect();
        let _ = writeln!(s, "- [{}](#{}): {}", sec.title(), sec.anchor(), names.join(", "));
    }
    s.push('\n');
    for sec in sections(docs) {
        let _ = writeln!(s, "## {}\n\n{}\n", sec.title(), sec.intro());
        for d in in_section(docs, sec) {
            let _ = writeln!(s, "### `{}`\n", d.name);
            for line in d.signatures.lines() {
                let _ = writeln!(s, "    {line}");
            }
            let _ = writeln!(s, "\n{}\n", d.description);
            if !d.arguments.is_empty() {
                s.push_str("| argument | type | description |\n|---|---|---|\n");
                for a in &d.arguments {
                    let _ = writeln!(s, "| `{}` | `{}` | {} |", cell(&a.name), cell(&a.ty), cell(a.doc));
                }
                s.push('\n');
            }
            let _ = writeln!(s, "```sql\n{}\n```\n", d.example);
            if !d.see_also.is_empty() {
                let links: Vec<String> = d.see_also.iter().map(|n| link(n)).collect();
                let _ = writeln!(s, "See also: {}\n", links.join(", "));
            }
            let _ = writeln!(s, "Maths: `{}` · binding: `{}` · tests: `{}`\n", d.maths, d.binding, d.test);
        }
    }
    s
}

/// The function reference as plain text (`trajdb functions`): per section its title and
/// introduction, then each function's overloads, description, arguments and see also.
pub fn text(docs: &[Doc]) -> String {
    let mut s = String::new();
    for sec in sections(docs) {
        let _ = writeln!(s, "== {} ==\n{}\n", sec.title(), sec.intro());
        for d in in_section(docs, sec) {
            let _ = writeln!(s, "{}\n    {}", d.signatures, d.description);
            for a in &d.arguments {
                let _ = writeln!(s, "    - {} {}: {}", a.name, a.ty, a.doc);
            }
            if !d.see_also.is_empty() {
                let _ = writeln!(s, "    see also: {}", d.see_also.join(", "));
            }
            s.push('\n');
        }
    }
    s
}

/// The lines around the generated family table in docs/development.md (each ends its line).
pub const FAMILIES_BEGIN: &str = "<!-- generated: trajdb functions --families -->\n";
pub const FAMILIES_END: &str = "<!-- end generated -->\n";

/// Where each section's functions live, as the Markdown table of docs/development.md
/// ("Where things live", between its `generated` markers): per section its maths files, its
/// binding files and its functions.
pub fn families(docs: &[Doc]) -> String {
    let mut s = String::from("| section | maths | binding | functions |\n|---|---|---|---|\n");
    for sec in sections(docs) {
        let mut maths: Vec<&str> = Vec::new();
        let mut bindings: Vec<&str> = Vec::new();
        for d in in_section(docs, sec) {
            for m in d.maths.split(", ") {
                if !maths.contains(&m) {
                    maths.push(m);
                }
            }
            if !bindings.contains(&d.binding) {
                bindings.push(d.binding);
            }
        }
        let code = |v: &[&str]| v.iter().map(|x| format!("`{x}`")).collect::<Vec<_>>().join(", ");
        let names: Vec<&str> = in_section(docs, sec).map(|d| d.name).collect();
        let _ = writeln!(s, "| [{}](functions.md#{}) | {} | {} | {} |", sec.title(), sec.anchor(), code(&maths), code(&bindings), code(&names));
    }
    s
}

/// The function and signature a registered overload runs, and its database's limits.
#[derive(Clone)]
pub struct Bound {
    name: &'static str,
    sig: &'static Signature,
    limits: Arc<Limits>,
}

thread_local! {
    /// The signature being registered: [`VScalar::signatures`] is an associated function
    /// without state, so the one generic [`Dispatch`] reads what to declare from here during
    /// [`register`] (single-threaded, scoped to one call).
    static REGISTERING: Cell<Option<&'static Signature>> = const { Cell::new(None) };
}

/// The one `VScalar` of every trajdb scalar function: declares the overloads of the signature
/// being registered, and runs its kernel on every chunk.
struct Dispatch;

impl VScalar for Dispatch {
    type State = Bound;

    fn invoke(
        b: &Bound,
        input: &mut duckdb::core::DataChunkHandle,
        output: &mut dyn duckdb::vtab::arrow::WritableVector,
    ) -> Result<(), Box<dyn Error>> {
        let args = Args::new(input, b.sig.params);
        let mut out = Out::new(output);
        // the error is formatted inside the scope too: a message may read the limit it names
        limits::with_scope(&b.limits, || (b.sig.kernel)(&args, &mut out).map_err(|e| format!("{}: {e}", b.name).into()))
    }

    fn signatures() -> Vec<ScalarFunctionSignature> {
        let sig = REGISTERING.with(Cell::get).expect("Dispatch::signatures outside registry::register");
        sig.overloads()
            .into_iter()
            .map(|tys| ScalarFunctionSignature::exact(tys.iter().map(Ty::logical).collect(), sig.returns.logical()))
            .collect()
    }
}

/// Registers `functions` on `con`: every overload of every scalar signature, and the table
/// functions, all sharing one new [`Database`] (call once per database, at LOAD).
pub fn register(con: &Connection, functions: &[&'static Function]) -> duckdb::Result<()> {
    register_with(con, functions, Arc::new(Limits::default()))
}

/// [`register`] with given work limits: the private database of a `trajdb_pipeline` call gets
/// its caller's (src/runner.rs).
pub fn register_with(con: &Connection, functions: &[&'static Function], limits: Arc<Limits>) -> duckdb::Result<()> {
    let db = Database { limits: Arc::clone(&limits) };
    for f in functions {
        if let Some(t) = &f.table {
            (t.register)(con, f.name, &db)?;
            continue;
        }
        for sig in f.signatures {
            REGISTERING.with(|c| c.set(Some(sig)));
            let r = con.register_scalar_function_with_state::<Dispatch>(f.name, &Bound { name: f.name, sig, limits: Arc::clone(&limits) });
            REGISTERING.with(|c| c.set(None));
            r?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn k(_: &Args<'_>, _: &mut Out<'_>) -> Result<(), Box<dyn Error>> {
        Ok(())
    }

    #[test]
    fn optional_arguments_and_alternatives_expand_into_overloads() {
        static S: Signature = Signature {
            params: &[p("a", TRAJ), p("eps", Ty::Double), p("n", Ty::Bigint), p("region", GEOMETRY)],
            arities: &[2, 4],
            returns: Ty::Double,
            kernel: k,
        };
        // (a, eps) and (a, eps, n, region) with region as VARCHAR, BLOB or GEOMETRY
        assert_eq!(S.overloads().len(), 4);
        assert_eq!(S.render("f"), "f(a TRAJ, eps DOUBLE [, n BIGINT, region VARCHAR|BLOB|GEOMETRY]) -> DOUBLE");
        static T: Signature = Signature { params: &[p("a", Ty::Double), p("b", Ty::Double), p("c", Ty::Double)], arities: &[1, 2, 3], returns: Ty::Double, kernel: k };
        assert_eq!(T.render("g"), "g(a DOUBLE [, b DOUBLE [, c DOUBLE]]) -> DOUBLE");
        assert_eq!(Ty::List(&Ty::Struct(&[("left", Ty::Bigint)])).sql(), "STRUCT(\"left\" BIGINT)[]");
    }

    #[test]
    fn the_reference_has_sections_an_index_argument_tables_and_see_also() {
        static F: [Function; 2] = [
            Function {
                name: "f_one",
                description: "One.",
                example: "SELECT f_one(1); -- 1",
                maths: "m/a.rs",
                binding: "b/x.rs",
                section: Section::Geometry,
                see_also: &["f_two"],
                signatures: &[Signature {
                    params: &[pd("a", GEOMETRY, "a |polygon|"), pd("n", Ty::Bigint, "how many")],
                    arities: &[1, 2],
                    returns: Ty::Double,
                    kernel: k,
                }],
                table: None,
            },
            Function {
                name: "f_two",
                description: "Two.",
                example: "SELECT f_two();",
                maths: "m/a.rs, m/b.rs",
                binding: "b/y.rs",
                section: Section::Trajectories,
                see_also: &[],
                signatures: &[
                    Signature { params: &[pd("x", Ty::Double, "x (m)")], arities: &[], returns: Ty::Double, kernel: k },
                    Signature { params: &[pd("x", Ty::Bigint, "x (m)")], arities: &[], returns: Ty::Double, kernel: k },
                ],
                table: None,
            },
        ];
        let mut docs: Vec<Doc> = F.iter().map(Function::doc).collect();
        docs.sort_by_key(|d| d.section);
        let md = markdown(&docs);
        // sections in reading order, each in the index with links to its functions
        let (t, g) = (md.find("## Trajectories").unwrap(), md.find("## Geometry").unwrap());
        assert!(t < g, "{md}");
        assert!(md.contains("- [Trajectories](#trajectories): [`f_two`](#f_two)\n- [Geometry](#geometry): [`f_one`](#f_one)\n"), "{md}");
        assert!(md.contains(Section::Geometry.intro()));
        // one row per argument, `|` escaped, the overloads' types joined
        assert!(md.contains("| `a` | `VARCHAR\\|BLOB\\|GEOMETRY` | a \\|polygon\\| |\n| `n` | `BIGINT` | how many |\n"), "{md}");
        assert!(md.contains("| `x` | `DOUBLE or BIGINT` | x (m) |"), "{md}");
        assert!(md.contains("See also: [`f_two`](#f_two)\n"), "{md}");
        assert!(!md.contains("See also: \n"));
        let text = text(&docs);
        assert!(text.starts_with("== Trajectories ==\n") && text.contains("    - n BIGINT: how many\n") && text.contains("    see also: f_two\n"), "{text}");
        assert!(!text.contains("## "));
        let fam = families(&docs);
        assert_eq!(
            fam,
            "| section | maths | binding | functions |\n|---|---|---|---|\n\
             | [Trajectories](functions.md#trajectories) | `m/a.rs`, `m/b.rs` | `b/y.rs` | `f_two` |\n\
             | [Geometry](functions.md#geometry) | `m/a.rs` | `b/x.rs` | `f_one` |\n"
        );
        assert_eq!(anchor("Similarity (LCSS)"), "similarity-lcss");
        assert_eq!(anchor("`lcss_s2`"), "lcss_s2");
    }
}
