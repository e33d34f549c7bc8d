//! The application behind the `trajdb` command. The binary only parses arguments and calls
//! into this module.
//!
//! | module | what |
//! |---|---|
//! | [`simulate`] | synthetic multi-camera intersection traffic with ground truth (pure Rust) |
//! | `params` | the one declared table of pipeline parameters; generates sql/params.sql |
//! | `sql` | the embedded SQL files, `.read` includes, statement splitting, the stage list |
//! | `pipeline` | the stage runner over sql/pipeline.sql, then sql/export.sql and the report |
//! | `score` | `trajdb score` (sql/score.sql) |
//! | [`report`] | report.html: the page from the data of sql/report.sql (pure Rust) |
//! | `shell` | running SQL scripts and printing results |
//! | `demo` | `trajdb demo`, `trajdb demo --sql`, `trajdb simulate` |

pub mod report;
pub mod simulate;

#[cfg(feature = "bundled")]
pub mod demo;
#[cfg(feature = "bundled")]
pub mod params;
#[cfg(feature = "bundled")]
pub mod pipeline;
#[cfg(feature = "bundled")]
pub mod score;
#[cfg(feature = "bundled")]
pub mod shell;
#[cfg(feature = "bundled")]
pub mod sql;

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
