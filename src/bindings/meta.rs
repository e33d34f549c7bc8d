//! SQL: `trajdb_functions()`, the function reference as a table (rows from the registry).

use super::registry::{Doc, Function, Table, Ty};
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

pub static FUNCTIONS: &[Function] = &[Function {
    name: "trajdb_functions",
    description: "One row per trajdb function with its overloads (parameter names and types), description, example, and where its maths, \
                  binding and tests live; docs/functions.md is generated from the same descriptors.",
    example: "SELECT name FROM trajdb_functions() ORDER BY name;",
    maths: "src/bindings/registry.rs",
    binding: file!(),
    signatures: &[],
    table: Some(Table { columns: COLUMNS, register }),
}];

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
