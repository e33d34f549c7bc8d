//! The application behind the `trajdb` command. The binary only parses arguments and calls
//! into this module.
//!
//! | module | what |
//! |---|---|
//! | [`outdir`] | the results folder: what may be written and deleted (pure std) |
//! | [`simulate`] | synthetic multi-camera intersection traffic with ground truth (pure Rust) |
//! | `params` | the one declared table of pipeline parameters; generates sql/params.sql |
//! | `sql` | the embedded SQL files, `.read` includes, statement splitting, the stage list |
//! | `pipeline` | the stage runner over sql/pipeline.sql, then sql/export.sql and the report |
//! | `score` | `trajdb score` (sql/score.sql) |
//! | [`report`] | report.html: the page from the data of sql/report.sql (pure Rust) |
//! | `shell` | running SQL scripts and printing results |
//! | `demo` | `trajdb demo`, `trajdb demo --sql`, `trajdb simulate` |

pub mod outdir;
pub mod params;
pub mod report;
pub mod simulate;

#[cfg(feature = "bundled")]
pub mod demo;
#[cfg(feature = "bundled")]
pub mod pipeline;
#[cfg(feature = "bundled")]
pub mod score;
#[cfg(feature = "bundled")]
pub mod shell;
#[cfg(feature = "bundled")]
pub mod sql;

/// Writes to stdout. A reader that closed the pipe (`trajdb score ... | head`) ends the process
/// quietly with status 0, as `head` expects; `println!` would panic there.
pub fn stdout_write(args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    if let Err(e) = std::io::stdout().lock().write_fmt(args) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("Error: cannot write to stdout: {e}");
        std::process::exit(1);
    }
}

/// `println!` for the command's output, through [`stdout_write`] (no panic on a closed pipe).
#[macro_export]
macro_rules! outln {
    ($($t:tt)*) => { $crate::app::stdout_write(format_args!("{}\n", format_args!($($t)*))) };
}

/// `print!` through [`stdout_write`].
#[macro_export]
macro_rules! out {
    ($($t:tt)*) => { $crate::app::stdout_write(format_args!($($t)*)) };
}

/// The command line summary.
pub const USAGE: &str = "usage: trajdb [--db FILE] [--csv|--json] (sql \"<query>\" | run FILE.sql | demo [--sql] | functions [--markdown] | params [--sql])\n       trajdb pipeline --input points.parquet|points.csv --out DIR [--param name=value ...]\n       trajdb score SCENARIO_DIR --results DIR\n       trajdb simulate --cameras N --minutes M --seed S --out DIR [--rate-hz R] [--traffic X]\n         [--pedestrians X] [--noise-sigma S|LO,HI] [--noise-tracks-per-min K] [--clock-offset-max S] [--world-rate-hz R]\n       SQL is read from stdin when no command is given.";

/// The function reference: Markdown (docs/functions.md) or plain text.
#[cfg(feature = "bundled")]
pub fn functions_reference(markdown: bool) -> String {
    let docs = crate::bindings::docs();
    if markdown {
        return crate::bindings::registry::markdown(&docs);
    }
    docs.iter().map(|d| format!("{}\n    {}\n\n", d.signatures, d.description)).collect()
}
