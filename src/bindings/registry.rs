//! One descriptor per SQL function ([`Function`]): name, overloads with named and typed
//! parameters, return type, description, example, the kernel, and where its maths lives.
//!
//! Everything else is generated from these descriptors:
//! - registration in DuckDB ([`register`]): one overload per arity of a [`Signature`] and per
//!   alternative of a [`Ty::OneOf`] parameter;
//! - the `trajdb_functions()` table, `trajdb functions [--markdown]` and docs/functions.md
//!   ([`Doc`], [`markdown`]);
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

pub use super::types::{p, Database, Param, Table, Ty, GEOMETRY, GEOMETRY_LIST, SERIES, TRAJ, TRANSFORM};

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
    pub signatures: &'static [Signature],
    pub table: Option<Table>,
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
}

impl Function {
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
        Doc {
            name: self.name,
            signatures,
            description: self.description,
            example: self.example,
            maths: self.maths,
            binding: self.binding,
            test: format!("tests/sql/{}.slt", self.name),
        }
    }
}

/// The function reference as Markdown (docs/functions.md).
pub fn markdown(docs: &[Doc]) -> String {
    let mut s = String::from("# trajdb function reference\n\n");
    s.push_str("Generated by `trajdb functions --markdown` from the function descriptors in `src/bindings/` (the same rows as\n");
    s.push_str("`SELECT * FROM trajdb_functions()`). `TRAJ` is `STRUCT(t DOUBLE, x DOUBLE, y DOUBLE)[]`; `A|B` means either type;\n");
    s.push_str("`[, ...]` marks optional trailing arguments. Polygon results are WKB `BLOB`s.\n\n");
    for d in docs {
        let _ = writeln!(s, "## `{}`\n", d.name);
        for line in d.signatures.lines() {
            let _ = writeln!(s, "    {line}");
        }
        let _ = writeln!(s, "\n{}\n", d.description);
        let _ = writeln!(s, "```sql\n{}\n```\n", d.example);
        let _ = writeln!(s, "Maths: `{}` · binding: `{}` · tests: `{}`\n", d.maths, d.binding, d.test);
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
}
