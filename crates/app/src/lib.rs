//! trajdb's application layer, without DuckDB: everything the extension's runner and SQL
//! functions need that is not maths. Nothing here imports DuckDB; the extension crate (the
//! bindings and the runner) sits on top, and [`trajdb_algo`] below.
//!
//! | module | what |
//! |---|---|
//! | [`archive`] | an archive of site-days: partitions, state, the incremental rule, the calibration chain, commits |
//! | [`params`] | the one declared table of pipeline parameters (types, defaults, ranges); generates sql/params.sql |
//! | [`sql`] | the embedded SQL files, `.read` includes, statement splitting |
//! | [`plan`] | the pipeline manifest: the statements of one run, stage by stage, with the tables each makes |
//! | [`outdir`] | the results folder: what may be written and deleted (pure std) |
//! | [`simulate`] | synthetic multi-camera intersection traffic with ground truth |
//! | [`report`] | report.html: the page from the data of sql/report.sql |

pub mod archive;
pub mod outdir;
pub mod params;
pub mod plan;
pub mod report;
pub mod simulate;
pub mod sql;
