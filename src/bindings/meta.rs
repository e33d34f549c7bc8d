//! SQL: `trajdb_functions()`, the function reference as a table (rows from the registry).

use super::registry::{p, Doc, Function, Signature, Table, Ty};
use super::vector::{Args, Out};
use crate::algo::limits;
use duckdb::core::{DataChunkHandle, Inserter};
use duckdb::vtab::{BindInfo, InitInfo, TableFunctionInfo, VTab};
use duckdb::Connection;
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
    description: "Reads or sets a work limit, the most work one call may do (src/algo/limits.rs): 'lcss_cells' (cells of one LCSS table; traj_cluster with S2 sums them over pairs and translations, \
                  default 1e10), 'cpd_pair_visits' (pairs in cpd_align's time band x max_iter, default 2e10), 'output_points' (points one \
                  call returns, default 5e7). A call above a limit stops at once with an error that names it. With a value it sets the limit \
                  for the whole process and returns the previous one. DuckDB's C API lets no extension see Ctrl-C inside a call: the limits \
                  keep every call short instead.",
    example: "SELECT trajdb_limit('lcss_cells'); -- 10000000000",
    maths: "src/algo/limits.rs",
    binding: file!(),
    signatures: &[Signature { params: &[p("name", Ty::Varchar), p("value", Ty::Bigint)], arities: &[1, 2], returns: Ty::Bigint, kernel: limit }],
    table: None,
};

fn limit(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn std::error::Error>> {
    let (name, value) = (a.text(0), a.opt_bigint(1));
    let vals = a.map(|r| {
        let (Some(n), Some(v)) = (name.get(r), value.opt(r)) else { return Ok(None) };
        Ok(Some(match v {
            Some(v) => limits::set(&n, v)?,
            None => limits::find(&n)?.get(),
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
    table: Some(Table { columns: COLUMNS, register }),
};

struct FunctionsTable;

struct Cursor {
    next: AtomicUsize,
}

impl VTab for FunctionsTable {
    type InitData = Cursor;
    type BindData = Vec<Doc>;

    fn bind(bind: &BindInfo) -> Result<Self::BindData, Box<dyn std::error::Error>> {
        for (name, ty) in COLUMNS {
            bind.add_result_column(name, ty.logical());
        }
        Ok(super::docs())
    }

    fn init(_: &InitInfo) -> Result<Self::InitData, Box<dyn std::error::Error>> {
        Ok(Cursor { next: AtomicUsize::new(0) })
    }

    fn func(func: &TableFunctionInfo<Self>, output: &mut DataChunkHandle) -> Result<(), Box<dyn std::error::Error>> {
        let docs = func.get_bind_data();
        // at most one chunk of 2048 rows per call
        let start = func.get_init_data().next.fetch_add(2048, Ordering::SeqCst).min(docs.len());
        let rows = &docs[start..(start + 2048).min(docs.len())];
        let cols: Vec<_> = (0..COLUMNS.len()).map(|k| output.flat_vector(k)).collect();
        for (r, d) in rows.iter().enumerate() {
            for (k, v) in [d.name, d.signatures.as_str(), d.description, d.example, d.maths, d.binding, d.test.as_str()].iter().enumerate() {
                cols[k].insert(r, *v);
            }
        }
        output.set_len(rows.len());
        Ok(())
    }
}

fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_table_function::<FunctionsTable>("trajdb_functions")
}
