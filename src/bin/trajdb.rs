//! `trajdb`: DuckDB with the trajdb functions built in. Argument parsing only (clap); the work
//! is in `trajdb::app`. `trajdb help`, `trajdb help <command>` and `trajdb <command> --help`
//! describe every command and option with its default.
//!
//! ```text
//! trajdb [--db FILE] [--csv | --json] sql "<query>"
//! trajdb [--db FILE] [--csv | --json] run file.sql
//! trajdb [--db FILE] [--csv | --json] < file.sql        (SQL on stdin)
//! trajdb pipeline --input FILE --out DIR [--param name=value ...]
//! trajdb score SCENARIO_DIR --results DIR
//! trajdb simulate --out DIR [--cameras N --minutes M --seed S ...]
//! trajdb demo [--out DIR] [simulate options]   (simulate → pipeline → score); demo --sql
//! trajdb functions [--markdown]                  (function reference)
//! trajdb params [--sql]                          (pipeline parameters; --sql: sql/params.sql)
//! ```

use clap::{Arg, ArgAction, ArgMatches, Command};
use std::io::Read;
use std::path::Path;
use std::process::ExitCode;
use trajdb::app::{self, shell::Format};

fn main() -> ExitCode {
    match real_main() {
        Ok(()) => ExitCode::SUCCESS,
        // a reader that closed the pipe (trajdb sql ... | head) is not an error
        Err(e) if e.downcast_ref::<std::io::Error>().is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The simulator's options, with their defaults (shared by `simulate` and `demo`).
fn simulate_args(cmd: Command, out_default: Option<&'static str>) -> Command {
    let d = app::simulate::SimParams::default();
    let num = |name: &'static str, default: String, help: &'static str| Arg::new(name).long(name).value_name("X").allow_negative_numbers(true).default_value(&*Box::leak(default.into_boxed_str())).help(help);
    let out = Arg::new("out").long("out").value_name("DIR").help("folder for points.parquet / points.csv and the ground truth");
    cmd.args_override_self(true).arg(match out_default {
        Some(v) => out.default_value(v),
        None => out.required(true),
    })
    .arg(num("cameras", d.cameras.to_string(), "number of cameras (1-64)"))
    .arg(num("minutes", d.minutes.to_string(), "simulated minutes"))
    .arg(num("seed", d.seed.to_string(), "random seed (the same seed gives the same files)"))
    .arg(num("rate-hz", d.rate_hz.iter().map(f64::to_string).collect::<Vec<_>>().join(","), "camera sampling rate (Hz): R, or R1,R2,... one per camera (cycled)"))
    .arg(num("traffic", d.traffic.to_string(), "traffic volume multiplier"))
    .arg(num("pedestrians", d.pedestrians.to_string(), "extra pedestrian multiplier (a crowd: 10)"))
    .arg(num("cyclists", d.cyclists.to_string(), "extra cyclist multiplier (bike lanes; 2 a minute at 1)"))
    .arg(num("noise-sigma", format!("{},{}", d.noise_sigma.0, d.noise_sigma.1), "camera position noise sigma (m): S, or LO,HI drawn per camera"))
    .arg(num("noise-tracks-per-min", d.noise_tracks_per_min.to_string(), "spurious tracks per camera and minute"))
    .arg(num("clock-offset-max", d.clock_offset_max.to_string(), "camera clocks offset by a uniform draw in +-X s (up to 1e7)"))
    .arg(num("clock-drift-ppm", d.clock_drift_ppm.to_string(), "camera clocks run fast/slow by a uniform draw in +-X ppm (up to 1e4)"))
    .arg(num("time-jitter-s", d.time_jitter_s.to_string(), "each time stamp off the capture time by N(0, X) s, clipped to 0.45 frame"))
    .arg(num("clock-epoch", d.clock_epoch.to_string(), "seconds added to every camera clock alike (e.g. 1.78e9, Unix time in 2026)"))
    .arg(num("origin", d.origin.to_string(), "camera frames far from 0: none, utm (each camera x 4.5e5-5e5, y 5.7e6 m) or X,Y added to every local coordinate").allow_hyphen_values(true))
    .arg(num("world-rate-hz", d.world_rate_hz.to_string(), "sampling rate of world.csv (Hz); 0 skips it"))
    .arg(num("waiting-groups", d.waiting_groups.to_string(), "groups of 2-8 pedestrians and cyclists waiting 10-60 s at a crossing's kerb, 0.6-2 m apart, per minute (docs/simulate.md)"))
}

/// The simulator's options back as `--name value` pairs for `app::demo::parse_simulate`, which
/// validates them.
fn simulate_argv(m: &ArgMatches) -> Vec<String> {
    let names = ["out", "cameras", "minutes", "seed", "rate-hz", "traffic", "pedestrians", "noise-sigma", "noise-tracks-per-min", "clock-offset-max", "world-rate-hz", "waiting-groups", "cyclists", "clock-drift-ppm", "clock-epoch", "time-jitter-s", "origin"];
    let mut v = Vec::new();
    for n in names {
        if let Some(x) = m.get_one::<String>(n) {
            v.push(format!("--{n}"));
            v.push(x.clone());
        }
    }
    v
}

fn cli() -> Command {
    Command::new("trajdb")
        .version(env!("CARGO_PKG_VERSION"))
        .about("Multi-camera traffic-trajectory analysis in DuckDB: align cameras, match and merge tracks, cluster routes.\n\
                With no command, SQL is read from stdin.")
        .arg(Arg::new("db").long("db").value_name("FILE").global(true).help("a DuckDB database file (default: in memory)"))
        .arg(Arg::new("csv").long("csv").action(ArgAction::SetTrue).global(true).help("print query results as CSV"))
        .arg(Arg::new("json").long("json").action(ArgAction::SetTrue).global(true).conflicts_with("csv").help("print query results as JSON"))
        .subcommand(Command::new("sql").about("run one SQL statement (or several, separated by ;)").arg(Arg::new("query").required(true)))
        .subcommand(Command::new("run").about("run a SQL file (.read lines are followed)").arg(Arg::new("file").required(true)))
        .subcommand(
            Command::new("pipeline")
                .about("the whole pipeline: calibrate, clean, link, align, overlap, match and merge, cluster; writes the results and report.html")
                .arg(Arg::new("input").long("input").value_name("FILE").required(true).help("points as Parquet or CSV: camera, track_id, class, t, x, y[, estimated]"))
                .arg(Arg::new("out").long("out").value_name("DIR").required(true).help("results folder (replaced only when the run succeeds)"))
                .arg(Arg::new("param").long("param").value_name("NAME=VALUE").action(ArgAction::Append).help("set a parameter (repeatable); the list follows"))
                .after_help(format!("Parameters (name, type, default, stage, description; `auto` = measured by the calibrate stage):\n{}", app::params::table())),
        )
        .subcommand(
            Command::new("score")
                .about("score a results folder against a scenario's ground truth (cameras.csv, truth.csv, world.csv)")
                .arg(Arg::new("scenario").required(true).value_name("SCENARIO_DIR"))
                .arg(Arg::new("results").long("results").value_name("DIR").required(true).help("the --out folder of trajdb pipeline")),
        )
        .subcommand(simulate_args(Command::new("simulate").about("simulate an intersection seen by N cameras, with ground truth"), None))
        .subcommand(
            simulate_args(Command::new("demo").about("simulate, run the pipeline and score it (no outside data needed)"), Some("trajdb-demo"))
                .arg(Arg::new("sql").long("sql").action(ArgAction::SetTrue).help("instead: the SQL-only demo on built-in tracks")),
        )
        .subcommand(Command::new("functions").about("the SQL function reference").arg(Arg::new("markdown").long("markdown").action(ArgAction::SetTrue).help("as docs/functions.md")))
        .subcommand(Command::new("params").about("the pipeline parameters").arg(Arg::new("sql").long("sql").action(ArgAction::SetTrue).help("as sql/params.sql")))
}

fn real_main() -> Result<(), Box<dyn std::error::Error>> {
    let m = cli().get_matches();
    let db = m.get_one::<String>("db").map(String::as_str);
    let format = if m.get_flag("json") {
        Format::Json
    } else if m.get_flag("csv") {
        Format::Csv
    } else {
        Format::Table
    };
    let script = match m.subcommand() {
        None => {
            let mut s = String::new();
            std::io::stdin().read_to_string(&mut s)?;
            s
        }
        Some(("sql", s)) => s.get_one::<String>("query").cloned().expect("required"),
        Some(("run", s)) => {
            let f = s.get_one::<String>("file").expect("required");
            std::fs::read_to_string(f).map_err(|e| format!("cannot read {f}: {e}"))?
        }
        Some(("demo", s)) if s.get_flag("sql") => return app::demo::demo_sql(db, format),
        Some(("demo", s)) => return app::demo::demo(db, &simulate_argv(s)),
        Some(("score", s)) => {
            let con = trajdb::open(db)?;
            let (scenario, results) = (s.get_one::<String>("scenario").expect("required"), s.get_one::<String>("results").expect("required"));
            app::score::score(&con, Path::new(scenario), Path::new(results))?;
            return Ok(());
        }
        Some(("pipeline", s)) => {
            let mut params = Vec::new();
            for p in s.get_many::<String>("param").into_iter().flatten() {
                let (k, v) = p.split_once('=').ok_or_else(|| format!("--param needs name=value, got {p:?}"))?;
                params.push((k.trim().to_string(), v.trim().to_string()));
            }
            let con = trajdb::open(db)?;
            let (input, out) = (s.get_one::<String>("input").expect("required"), s.get_one::<String>("out").expect("required"));
            app::pipeline::run(&con, input, Path::new(out), &params)?;
            return Ok(());
        }
        Some(("simulate", s)) => {
            let argv = simulate_argv(s);
            let (params, out) = app::demo::parse_simulate(&argv)?;
            app::demo::simulate(db, &params, &out, &format!("simulate {}", argv.join(" ")))?;
            return Ok(());
        }
        Some(("functions", s)) => {
            trajdb::out!("{}", app::functions_reference(s.get_flag("markdown")));
            return Ok(());
        }
        Some(("params", s)) => {
            trajdb::out!("{}", if s.get_flag("sql") { app::params::params_sql() } else { app::params::table() });
            return Ok(());
        }
        Some((other, _)) => unreachable!("clap knows no command {other}"),
    };
    let con = trajdb::open(db)?;
    app::shell::run_script(&con, &script, format, &mut std::io::stdout().lock())
}
