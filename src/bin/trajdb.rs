//! `trajdb`: DuckDB with the trajdb functions built in. Argument parsing only; the work is in
//! `trajdb::app`.
//!
//! ```text
//! trajdb [--db FILE] [--csv | --json] sql "<query>"
//! trajdb [--db FILE] [--csv | --json] run file.sql
//! trajdb [--db FILE] [--csv | --json] < file.sql        (SQL on stdin)
//! trajdb pipeline --input FILE --out DIR [--param name=value ...]
//! trajdb score SCENARIO_DIR --results DIR
//! trajdb simulate --cameras N --minutes M --seed S --out DIR [...]
//! trajdb demo [--out DIR] [--cameras N --minutes M --seed S]   (simulate → pipeline → score)
//! trajdb [--csv | --json] demo --sql                    (the SQL-only demo)
//! trajdb functions [--markdown]                         (function reference)
//! trajdb params [--sql]                                 (pipeline parameters; --sql: sql/params.sql)
//! ```

use std::io::Read;
use std::path::Path;
use std::process::ExitCode;
use trajdb::app::{self, shell::Format, USAGE};

fn main() -> ExitCode {
    match real_main() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `--name value` options of a subcommand, in order.
fn options<'a>(cmd: &str, args: &'a [String], known: &[&str]) -> Result<Vec<(&'a str, &'a str)>, Box<dyn std::error::Error>> {
    let mut out = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if !known.contains(&a.as_str()) {
            return Err(format!("{cmd}: unknown option {a:?}\n{USAGE}").into());
        }
        let v = it.next().ok_or_else(|| format!("{cmd}: {a} needs a value"))?;
        out.push((a.as_str(), v.as_str()));
    }
    Ok(out)
}

fn real_main() -> Result<(), Box<dyn std::error::Error>> {
    let mut db: Option<String> = None;
    let mut format = Format::Table;
    let mut flags = (false, false); // --markdown, --sql
    let mut rest: Vec<String> = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--db" => db = Some(args.next().ok_or("--db needs a file name")?),
            "--csv" => format = Format::Csv,
            "--json" => format = Format::Json,
            "--markdown" => flags.0 = true,
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
    let db = db.as_deref();
    let script = match rest.first().map(String::as_str) {
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
        Some("demo") if rest.iter().any(|a| a == "--sql") => return app::demo::demo_sql(db, format),
        Some("demo") => return app::demo::demo(db, &rest[1..]),
        Some("score") => {
            let scenario = rest.get(1).ok_or("score needs a scenario directory")?;
            let opts = options("score", &rest[2..], &["--results"])?;
            let results = opts.iter().rev().find(|o| o.0 == "--results").ok_or("score needs --results DIR (the output of trajdb pipeline)")?.1;
            let con = trajdb::open(db)?;
            app::score::score(&con, Path::new(scenario), Path::new(results))?;
            return Ok(());
        }
        Some("pipeline") => {
            let opts = options("pipeline", &rest[1..], &["--input", "--out", "--param"])?;
            let get = |k: &str| opts.iter().rev().find(|o| o.0 == k).map(|o| o.1);
            let mut params = Vec::new();
            for (_, p) in opts.iter().filter(|o| o.0 == "--param") {
                let (k, v) = p.split_once('=').ok_or_else(|| format!("--param needs name=value, got {p:?}"))?;
                params.push((k.trim().to_string(), v.trim().to_string()));
            }
            let input = get("--input").ok_or("pipeline needs --input FILE")?;
            let out = get("--out").ok_or("pipeline needs --out DIR")?;
            let con = trajdb::open(db)?;
            app::pipeline::run(&con, input, Path::new(out), &params)?;
            return Ok(());
        }
        Some("simulate") => {
            let (params, out) = app::demo::parse_simulate(&rest[1..])?;
            app::demo::simulate(db, &params, &out, &rest.join(" "))?;
            return Ok(());
        }
        Some("functions") => {
            print!("{}", app::functions_reference(flags.0));
            return Ok(());
        }
        Some("params") => {
            flags.1 = rest.iter().any(|a| a == "--sql");
            print!("{}", if flags.1 { app::params::params_sql() } else { app::params::table() });
            return Ok(());
        }
        Some(other) => return Err(format!("unknown command {other:?}\n{USAGE}").into()),
    };
    let con = trajdb::open(db)?;
    app::shell::run_script(&con, &script, format, &mut std::io::stdout().lock())
}
