//! SQL: `trajdb_functions()`, the function reference as a table (the source of
//! `docs/functions.md`).

use super::convert::{FnDoc, varchar};
use duckdb::core::{DataChunkHandle, Inserter};
use duckdb::vtab::{BindInfo, InitInfo, TableFunctionInfo, VTab};
use duckdb::Connection;
use std::sync::atomic::{AtomicUsize, Ordering};

pub const DOCS: &[FnDoc] = &[FnDoc {
    name: "trajdb_functions",
    signatures: "trajdb_functions() -> TABLE(name VARCHAR, signatures VARCHAR, description VARCHAR, example VARCHAR)",
    description: "One row per trajdb function with its overloads, description and example; docs/functions.md is generated from it.",
    example: "SELECT name FROM trajdb_functions() ORDER BY name;",
}];

pub struct FunctionsTable;

pub struct Cursor {
    next: AtomicUsize,
}

impl VTab for FunctionsTable {
    type InitData = Cursor;
    type BindData = Vec<FnDoc>;

    fn bind(bind: &BindInfo) -> Result<Self::BindData, Box<dyn std::error::Error>> {
        for c in ["name", "signatures", "description", "example"] {
            bind.add_result_column(c, varchar());
        }
        Ok(super::docs())
    }

    fn init(_: &InitInfo) -> Result<Self::InitData, Box<dyn std::error::Error>> {
        Ok(Cursor { next: AtomicUsize::new(0) })
    }

    fn func(func: &TableFunctionInfo<Self>, output: &mut DataChunkHandle) -> Result<(), Box<dyn std::error::Error>> {
        let docs = func.get_bind_data();
        let start = func.get_init_data().next.fetch_add(docs.len(), Ordering::SeqCst).min(docs.len());
        let rows = &docs[start..];
        let cols: Vec<_> = (0..4).map(|k| output.flat_vector(k)).collect();
        for (r, d) in rows.iter().enumerate() {
            cols[0].insert(r, d.name);
            cols[1].insert(r, d.signatures);
            cols[2].insert(r, d.description);
            cols[3].insert(r, d.example);
        }
        output.set_len(rows.len());
        Ok(())
    }
}

pub fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_table_function::<FunctionsTable>("trajdb_functions")
}
