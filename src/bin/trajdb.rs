//! `trajdb`: DuckDB with the trajdb functions built in.
//!
//! ```text
//! trajdb [--db FILE] [--csv | --json] sql "<query>"
//! trajdb [--db FILE] [--csv | --json] run file.sql
//! trajdb [--db FILE] [--csv | --json] < file.sql        (SQL on stdin)
//! trajdb demo [--out DIR] [--cameras N --minutes M --seed S]   (simulate → pipeline → score)
//! trajdb [--csv | --json] demo --sql                    (the SQL-only demo: sql/demo.sql …)
//! trajdb functions [--markdown]                         (function reference)
//! ```

use arrow::record_batch::RecordBatch;
use std::io::{Read, Write};
use std::process::ExitCode;

const USAGE: &str = "usage: trajdb [--db FILE] [--csv|--json] (sql \"<query>\" | run FILE.sql | demo [--sql] | functions [--markdown])\n       trajdb pipeline --input points.parquet|points.csv --out DIR [--param name=value ...]\n       trajdb score SCENARIO_DIR --results DIR\n       trajdb simulate --cameras N --minutes M --seed S --out DIR [--rate-hz R] [--traffic X]\n       SQL is read from stdin when no command is given.";

/// The embedded demo: generate two cameras (each in its own frame), align them, build the
/// view polygons and overlaps, merge the tracks into road users, and check the matches.
const DEMO_SQL: [&str; 5] = [
    include_str!("../../sql/demo.sql"),
    include_str!("../../sql/align.sql"),
    include_str!("../../sql/overlap.sql"),
    include_str!("../../sql/merge.sql"),
    include_str!("../../sql/demo_match.sql"),
];

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Table,
    Csv,
    Json,
}

fn main() -> ExitCode {
    match real_main() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn real_main() -> Result<(), Box<dyn std::error::Error>> {
    let mut db: Option<String> = None;
    let mut format = Format::Table;
    let mut markdown = false;
    let mut rest: Vec<String> = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--db" => db = Some(args.next().ok_or("--db needs a file name")?),
            "--csv" => format = Format::Csv,
            "--json" => format = Format::Json,
            "--markdown" => markdown = true,
            "-h" | "--help" => {
                println!("{USAGE}");
                return Ok(());
            }
            "--version" | "-V" => {
                println!("trajdb {}", env!("CARGO_PKG_VERSION"));
                return Ok(());
            }
            _ => rest.push(a),
        }
    }
    let sql: String = match rest.first().map(String::as_str) {
        None => {
            let mut s = String::new();
            std::io::stdin().read_to_string(&mut s)?;
            s
        }
        Some("sql") => rest.get(1).cloned().ok_or("sql needs a query")?,
        Some("run") => {
            let f = rest.get(1).ok_or("run needs a file")?;
            std::fs::read_to_string(f).map_err(|e| format!("cannot read {f}: {e}"))?
        }
        Some("demo") if rest.iter().any(|a| a == "--sql") => DEMO_SQL.join("\n;\n"),
        Some("demo") => {
            return demo(db.as_deref(), &rest[1..]);
        }
        Some("score") => {
            let scenario = rest.get(1).ok_or("score needs a scenario directory")?;
            let mut results = None;
            let mut it = rest.iter().skip(2);
            while let Some(a) = it.next() {
                match a.as_str() {
                    "--results" => results = it.next().cloned(),
                    other => return Err(format!("score: unknown option {other:?}\n{USAGE}").into()),
                }
            }
            let results = results.ok_or("score needs --results DIR (the output of trajdb pipeline)")?;
            let con = trajdb::open(db.as_deref())?;
            trajdb::pipeline::score(&con, std::path::Path::new(scenario), std::path::Path::new(&results))?;
            return Ok(());
        }
        Some("pipeline") => {
            let (mut input, mut out, mut params) = (None, None, Vec::new());
            let mut it = rest.iter().skip(1);
            while let Some(a) = it.next() {
                match a.as_str() {
                    "--input" => input = it.next().cloned(),
                    "--out" => out = it.next().cloned(),
                    "--param" => {
                        let p = it.next().ok_or("--param needs name=value")?;
                        let (k, v) = p.split_once('=').ok_or_else(|| format!("--param needs name=value, got {p:?}"))?;
                        params.push((k.trim().to_string(), v.trim().to_string()));
                    }
                    other => return Err(format!("pipeline: unknown option {other:?}\n{USAGE}").into()),
                }
            }
            let input = input.ok_or("pipeline needs --input FILE")?;
            let out = out.ok_or("pipeline needs --out DIR")?;
            let con = trajdb::open(db.as_deref())?;
            trajdb::pipeline::run(&con, &input, std::path::Path::new(&out), &params)?;
            return Ok(());
        }
        Some("simulate") => {
            let (params, out) = parse_simulate(&rest[1..])?;
            simulate(db.as_deref(), &params, &out, &rest.join(" "))?;
            return Ok(());
        }
        Some("functions") => {
            print_functions(markdown);
            return Ok(());
        }
        Some(other) => return Err(format!("unknown command {other:?}\n{USAGE}").into()),
    };
    let sql = expand_reads(&sql, 0)?;
    let con = trajdb::open(db.as_deref())?;
    let mut out = std::io::stdout().lock();
    for stmt in split_statements(&sql) {
        run_statement(&con, &stmt, format, &mut out)?;
    }
    Ok(())
}

/// `trajdb demo [--out DIR] [simulate options]`: simulate (3 cameras, 5 minutes, seed 1 unless
/// given), run the pipeline on the simulated points, score the result against the simulator's
/// ground truth, and fail unless match F1 >= 0.95 and every camera pair is within 0.5° / 0.3 m.
fn demo(db: Option<&str>, args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = args.to_vec();
    if !args.iter().any(|a| a == "--out") {
        args.extend(["--out".to_string(), "trajdb-demo".to_string()]);
    }
    let (params, out) = parse_simulate(&args)?;
    let dir = std::path::Path::new(&out);
    eprintln!("[trajdb] demo: simulate {} cameras, {} minutes of intersection traffic (seed {}) -> {out}", params.cameras, params.minutes, params.seed);
    simulate(db, &params, &out, &format!("demo {}", args.join(" ")))?;
    let con = trajdb::open(db)?;
    let results = dir.join("results");
    trajdb::pipeline::run(&con, &dir.join("points.parquet").to_string_lossy(), &results, &[])?;
    println!("score of {} against the simulator's ground truth:", results.display());
    let (rot, trans, f1) = trajdb::pipeline::score(&con, dir, &results)?;
    let ok = f1 >= 0.95 && rot <= 0.5 && trans <= 0.3;
    println!(
        "demo {}: match F1 {f1:.3} (target >= 0.95), worst camera pair {rot:.3} deg / {trans:.3} m (targets 0.5 deg / 0.3 m)",
        if ok { "PASSED" } else { "FAILED" }
    );
    println!("results: {}/{{transforms.csv, matches.csv, merged.parquet, clusters.csv, report.html}}", results.display());
    if ok {
        Ok(())
    } else {
        Err("demo: the pipeline missed its accuracy targets".into())
    }
}

/// `simulate` options: --cameras N --minutes M --seed S --out DIR [--rate-hz R] [--traffic X]
/// [--noise-tracks-per-min K] [--clock-offset-max S] [--world-rate-hz R (0: no world.csv)].
fn parse_simulate(args: &[String]) -> Result<(trajdb::simulate::SimParams, String), Box<dyn std::error::Error>> {
    let mut p = trajdb::simulate::SimParams::default();
    let mut out = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut val = |name: &str| -> Result<String, Box<dyn std::error::Error>> { it.next().cloned().ok_or_else(|| format!("simulate: {name} needs a value").into()) };
        let num = |name: &str, v: String| -> Result<f64, Box<dyn std::error::Error>> { v.parse::<f64>().map_err(|_| format!("simulate: {name} must be a number, got {v:?}").into()) };
        match a.as_str() {
            "--cameras" => p.cameras = num(a, val(a)?)? as usize,
            "--minutes" => p.minutes = num(a, val(a)?)?,
            "--seed" => p.seed = val(a)?.parse().map_err(|_| "simulate: --seed must be a non-negative integer")?,
            "--rate-hz" => p.rate_hz = num(a, val(a)?)?,
            "--traffic" => p.traffic = num(a, val(a)?)?,
            "--noise-tracks-per-min" => p.noise_tracks_per_min = num(a, val(a)?)?,
            "--clock-offset-max" => p.clock_offset_max = num(a, val(a)?)?,
            "--world-rate-hz" => p.world_rate_hz = num(a, val(a)?)?,
            "--out" => out = Some(val(a)?),
            other => return Err(format!("simulate: unknown option {other:?}\n{USAGE}").into()),
        }
    }
    Ok((p, out.ok_or("simulate needs --out DIR")?))
}

/// Simulates a scenario into `out` (CSV files by the simulator, points.parquet through DuckDB).
fn simulate(db: Option<&str>, p: &trajdb::simulate::SimParams, out: &str, command: &str) -> Result<(), Box<dyn std::error::Error>> {
    let t = std::time::Instant::now();
    let s = trajdb::simulate::simulate(p)?;
    let dir = std::path::Path::new(out);
    s.write(dir, &format!("trajdb {command}"))?;
    let con = trajdb::open(db)?;
    let q = |f: &str| trajdb::pipeline::sql_string(&dir.join(f).to_string_lossy());
    con.execute_batch(&format!(
        "COPY (SELECT camera::INTEGER AS camera, track_id::BIGINT AS track_id, class::VARCHAR AS class, t::DOUBLE AS t,
                      x::DOUBLE AS x, y::DOUBLE AS y, speed::DOUBLE AS speed, estimated::INTEGER AS estimated
               FROM read_csv({}, header = true)) TO {} (FORMAT parquet)",
        q("points.csv"),
        q("points.parquet")
    ))?;
    eprintln!(
        "[trajdb] simulate {:>7.2} s  {} objects, {} cameras, {} tracks, {} points -> {out}",
        t.elapsed().as_secs_f64(),
        s.objects.len(),
        s.cameras.len(),
        s.truth.len(),
        s.points.len()
    );
    Ok(())
}

fn print_functions(markdown: bool) {
    let docs = trajdb::bindings::docs();
    if markdown {
        print!("{}", trajdb::bindings::registry::markdown(&docs));
        return;
    }
    for d in &docs {
        println!("{}\n    {}\n", d.signatures, d.description);
    }
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

/// Replaces every line `.read FILE` (the DuckDB CLI's include, path relative to the working
/// directory) by the file's contents, so that `sql/pipeline.sql` runs in both tools.
fn expand_reads(sql: &str, depth: usize) -> Result<String, Box<dyn std::error::Error>> {
    if depth > 16 {
        return Err(".read nested more than 16 levels".into());
    }
    let mut out = String::with_capacity(sql.len());
    for line in sql.lines() {
        match line.trim().strip_prefix(".read ") {
            Some(f) => {
                let f = f.trim().trim_matches(|c| c == '\'' || c == '"');
                let text = std::fs::read_to_string(f).map_err(|e| format!(".read {f}: {e}"))?;
                out.push_str(&expand_reads(&text, depth + 1)?);
                out.push_str("\n;\n");
            }
            None => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    Ok(out)
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

/// Splits a script into statements at `;`, ignoring semicolons inside quotes and comments.
fn split_statements(sql: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut chars = sql.chars().peekable();
    let mut has_code = false;
    while let Some(c) = chars.next() {
        match c {
            '\'' | '"' => {
                cur.push(c);
                has_code = true;
                while let Some(d) = chars.next() {
                    cur.push(d);
                    if d == c {
                        if chars.peek() == Some(&c) {
                            cur.push(chars.next().unwrap());
                        } else {
                            break;
                        }
                    }
                }
            }
            '-' if chars.peek() == Some(&'-') => {
                for d in chars.by_ref() {
                    if d == '\n' {
                        cur.push('\n');
                        break;
                    }
                }
            }
            '/' if chars.peek() == Some(&'*') => {
                chars.next();
                let mut prev = ' ';
                for d in chars.by_ref() {
                    if prev == '*' && d == '/' {
                        break;
                    }
                    prev = d;
                }
                cur.push(' ');
            }
            ';' => {
                if has_code {
                    out.push(std::mem::take(&mut cur));
                }
                cur.clear();
                has_code = false;
            }
            _ => {
                if !c.is_whitespace() {
                    has_code = true;
                }
                cur.push(c);
            }
        }
    }
    if has_code {
        out.push(cur);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::split_statements;

    #[test]
    fn splits_outside_quotes_and_comments() {
        let s = split_statements("SELECT 'a;b'; -- c;d\nSELECT \"x;\" /* ; */ ;  ;");
        assert_eq!(s.len(), 2);
        assert!(s[0].contains("'a;b'"));
        assert!(s[1].contains("\"x;\""));
    }
}
