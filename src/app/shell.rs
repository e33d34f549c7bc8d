//! Running SQL scripts the way the DuckDB CLI does (`trajdb sql`, `trajdb run`, stdin): `.read`
//! includes, statement splitting, and results as an aligned table, CSV or JSON.

use super::sql::{expand_reads, split_statements};
use arrow::record_batch::RecordBatch;
use duckdb::Connection;
use std::io::Write;

/// How results are printed.
#[derive(Clone, Copy, PartialEq, Debug)]
pub enum Format {
    Table,
    Csv,
    Json,
}

/// Runs a script (with `.read` includes) statement by statement, printing results to `out`.
pub fn run_script(con: &Connection, script: &str, format: Format, out: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
    let sql = expand_reads(script)?;
    for stmt in split_statements(&sql) {
        run_statement(con, &stmt, format, out)?;
    }
    Ok(())
}

/// Does the statement produce rows worth printing?
fn returns_rows(stmt: &str) -> bool {
    let first = stmt
        .trim_start()
        .split(|c: char| c.is_whitespace() || c == '(')
        .next()
        .unwrap_or("")
        .to_ascii_uppercase();
    matches!(
        first.as_str(),
        "SELECT" | "WITH" | "FROM" | "VALUES" | "TABLE" | "PRAGMA" | "DESCRIBE" | "SHOW" | "SUMMARIZE" | "EXPLAIN" | "CALL"
    ) || stmt.trim_start().starts_with('(')
}

fn run_statement(con: &duckdb::Connection, sql: &str, format: Format, out: &mut impl Write) -> Result<(), Box<dyn std::error::Error>> {
    if !returns_rows(sql) {
        con.execute_batch(sql)?;
        return Ok(());
    }
    let mut stmt = con.prepare(sql)?;
    let batches: Vec<RecordBatch> = stmt.query_arrow([])?.collect();
    match format {
        Format::Table => {
            if batches.is_empty() {
                return Ok(());
            }
            writeln!(out, "{}", arrow::util::pretty::pretty_format_batches(&batches)?)?;
        }
        Format::Csv => {
            let mut w = arrow::csv::WriterBuilder::new().with_header(true).build(&mut *out);
            for b in &batches {
                w.write(&flatten_nested(b)?)?;
            }
        }
        Format::Json => {
            let mut w = arrow::json::ArrayWriter::new(&mut *out);
            let refs: Vec<&RecordBatch> = batches.iter().collect();
            w.write_batches(&refs)?;
            w.finish()?;
            writeln!(out)?;
        }
    }
    Ok(())
}

/// CSV has no nested values: lists and structs are written as their display text.
fn flatten_nested(b: &RecordBatch) -> Result<RecordBatch, Box<dyn std::error::Error>> {
    use arrow::array::{ArrayRef, StringArray};
    use arrow::datatypes::{DataType, Field, Schema};
    use arrow::util::display::{ArrayFormatter, FormatOptions};
    use std::sync::Arc;
    let mut cols: Vec<ArrayRef> = Vec::new();
    let mut fields = Vec::new();
    for (f, c) in b.schema().fields().iter().zip(b.columns()) {
        if f.data_type().is_nested() {
            let fmt = ArrayFormatter::try_new(c.as_ref(), &FormatOptions::default().with_null("NULL"))?;
            let s: StringArray = (0..c.len()).map(|i| if c.is_null(i) { None } else { Some(fmt.value(i).to_string()) }).collect();
            cols.push(Arc::new(s));
            fields.push(Field::new(f.name(), DataType::Utf8, true));
        } else {
            cols.push(c.clone());
            fields.push(f.as_ref().clone());
        }
    }
    Ok(RecordBatch::try_new(Arc::new(Schema::new(fields)), cols)?)
}
