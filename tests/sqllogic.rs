//! Runs every `tests/sql/*.slt` file against the bundled DuckDB with trajdb registered,
//! through the `sqllogictest` crate. `tests/run_slt_python.py` runs the same files against
//! the loadable extension in stock DuckDB; both format values the same way: every result
//! column is cast to VARCHAR by DuckDB itself, NULL prints as `NULL`, '' as `(empty)`.

use sqllogictest::{DBOutput, DefaultColumnType};
use std::path::PathBuf;

struct Duck(duckdb::Connection);

#[derive(Debug)]
struct DuckErr(String);
impl std::fmt::Display for DuckErr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for DuckErr {}
impl From<duckdb::Error> for DuckErr {
    fn from(e: duckdb::Error) -> Self {
        DuckErr(e.to_string())
    }
}

/// Statements whose rows the test compares (the same rule as tests/run_slt_python.py).
fn returns_rows(sql: &str) -> bool {
    let first = sql.trim_start().split(|c: char| c.is_whitespace() || c == '(').next().unwrap_or("").to_ascii_uppercase();
    matches!(first.as_str(), "SELECT" | "WITH" | "FROM" | "VALUES")
}

impl sqllogictest::DB for Duck {
    type Error = DuckErr;
    type ColumnType = DefaultColumnType;

    fn run(&mut self, sql: &str) -> Result<DBOutput<DefaultColumnType>, DuckErr> {
        if !returns_rows(sql) {
            self.0.execute_batch(sql)?;
            return Ok(DBOutput::StatementComplete(0));
        }
        let wrapped = format!("SELECT COLUMNS(*)::VARCHAR FROM ({}) AS slt_q", sql.trim().trim_end_matches(';'));
        let mut stmt = self.0.prepare(&wrapped)?;
        let mut rows = stmt.query([])?;
        let ncol = rows.as_ref().map(|s| s.column_count()).unwrap_or(0);
        let mut out = Vec::new();
        while let Some(row) = rows.next()? {
            let mut cells = Vec::with_capacity(ncol);
            for i in 0..ncol {
                let v: Option<String> = row.get(i)?;
                cells.push(match v {
                    None => "NULL".to_string(),
                    Some(s) if s.is_empty() => "(empty)".to_string(),
                    Some(s) => s,
                });
            }
            out.push(cells);
        }
        Ok(DBOutput::Rows { types: vec![DefaultColumnType::Text; ncol], rows: out })
    }

    fn engine_name(&self) -> &str {
        "duckdb-bundled"
    }
}

fn main() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/sql");
    let filter = std::env::args().nth(1).filter(|a| !a.starts_with('-'));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("tests/sql")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "slt"))
        .filter(|p| filter.as_ref().is_none_or(|f| p.to_string_lossy().contains(f.as_str())))
        .collect();
    files.sort();
    let (mut passed, mut failed) = (0, 0);
    for f in &files {
        let mut runner = sqllogictest::Runner::new(|| async {
            Ok::<_, DuckErr>(Duck(trajdb::open(None).map_err(|e| DuckErr(e.to_string()))?))
        });
        match runner.run_file(f) {
            Ok(()) => {
                passed += 1;
                println!("ok   {}", f.file_name().unwrap().to_string_lossy());
            }
            Err(e) => {
                failed += 1;
                println!("FAIL {}\n{}", f.file_name().unwrap().to_string_lossy(), e.display(false));
            }
        }
    }
    println!("sqllogictest: {passed} passed, {failed} failed");
    if failed > 0 || passed == 0 {
        std::process::exit(1);
    }
}
