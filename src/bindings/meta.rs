//! SQL: `trajdb_functions()`, the function reference as a table (rows from the registry).

use super::registry::{p, Doc, Function, Signature, Table, Ty};
use super::vector::table::{self, BindArgs, Rows, TableFn};
use super::vector::{Args, Out};
use crate::algo::limits;
use std::error::Error;
use std::sync::atomic::{AtomicUsize, Ordering};

const COLUMNS: &[(&str, Ty)] = &[
    ("name", Ty::Varchar),
    ("signatures", Ty::Varchar),
    ("description", Ty::Varchar),
    ("example", Ty::Varchar),
    ("maths", Ty::Varchar),
    ("binding", Ty::Varchar),
    ("test", Ty::Varchar),
];

pub static FUNCTIONS: &[Function] = &[TRAJDB_FUNCTIONS, TRAJDB_LIMIT];

const TRAJDB_LIMIT: Function = Function {
    name: "trajdb_limit",
    description: "Reads or sets a work limit, the most work one call may do (crates/algo/src/limits.rs): 'lcss_cells' (cells of one LCSS table; traj_cluster with S2 sums them over pairs and translations, \
                  default 1e10), 'cpd_pair_visits' (pairs in cpd_align's time band x max_iter, default 2e10), 'output_points' (points one \
                  call returns, default 5e7), 'memory_bytes' (working memory of one call beyond its input and output, default 4e9), \
                  'shift_pair_fits' (point pairs one rigid_fit_shifted fits, default 2e8), 'label_pairs' (child pairs traj_labels compares, \
                  default 1e9), 'assign_steps' (assign_pairs' dense solves, rows x columns x min of each component, default 2e11). A call above a limit stops at once with an error that names it. With a value it sets the limit \
                  for this database (every connection to it; other databases in the process keep their own) and returns the previous one. \
                  DuckDB's C API lets no extension see Ctrl-C inside a call: the limits keep every call short instead.",
    example: "SELECT trajdb_limit('lcss_cells'); -- 10000000000",
    maths: "crates/algo/src/limits.rs",
    binding: file!(),
    signatures: &[Signature { params: &[p("name", Ty::Varchar), p("value", Ty::Bigint)], arities: &[1, 2], returns: Ty::Bigint, kernel: limit }],
    table: None,
};

fn limit(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn std::error::Error>> {
    let (name, value) = (a.text(0), a.opt_bigint(1));
    // the calling database's limits: the dispatcher runs every kernel in their scope
    let mine = limits::current().ok_or("no database limits in scope (please report this)")?;
    let vals = a.map(|r| {
        let (Some(n), Some(v)) = (name.get(r), value.opt(r)) else { return Ok(None) };
        Ok(Some(match v {
            Some(v) => mine.set(&n, v)?,
            None => mine.get(limits::find(&n)?),
        } as i64))
    })?;
    out.flat(&vals);
    Ok(())
}

const TRAJDB_FUNCTIONS: Function = Function {
    name: "trajdb_functions",
    description: "One row per trajdb function with its overloads (parameter names and types), description, example, and where its maths, \
                  binding and tests live; docs/functions.md is generated from the same descriptors.",
    example: "SELECT name FROM trajdb_functions() ORDER BY name;",
    maths: "src/bindings/registry.rs",
    binding: file!(),
    signatures: &[],
    table: Some(TABLE),
};

const TABLE: Table = Table { params: &[], named: &[], columns: COLUMNS, register: table::register::<FunctionsTable> };

struct FunctionsTable;

struct Cursor {
    next: AtomicUsize,
}

impl TableFn for FunctionsTable {
    const TABLE: &'static Table = &TABLE;
    type Bind = Vec<Doc>;
    type Scan = Cursor;

    fn bind(_: &BindArgs<'_>) -> Result<Self::Bind, Box<dyn Error>> {
        Ok(super::docs())
    }

    fn init(_: &Self::Bind) -> Result<Self::Scan, Box<dyn Error>> {
        Ok(Cursor { next: AtomicUsize::new(0) })
    }

    fn func(docs: &Self::Bind, cursor: &Self::Scan, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        // at most one chunk per call
        let start = cursor.next.fetch_add(Rows::CAPACITY, Ordering::SeqCst).min(docs.len());
        let rows = &docs[start..(start + Rows::CAPACITY).min(docs.len())];
        for (r, d) in rows.iter().enumerate() {
            for (k, v) in [d.name, d.signatures.as_str(), d.description, d.example, d.maths, d.binding, d.test.as_str()].into_iter().enumerate() {
                out.text(k, r, v);
            }
        }
        Ok(rows.len())
    }
}
