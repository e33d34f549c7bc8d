//! An archive's site-days run in private databases (issue 40; docs/archive.md): one day's task
//! ([`run_task`], the same on every host: `CALL trajdb_archive`, a Python worker through
//! `trajdb_archive_task`, a Spark task) and the one-machine driver of `CALL trajdb_archive`
//! ([`Driver`]). The decisions (partitions, fingerprints, the incremental rule, the calibration
//! chain, names, commits) are crates/app/src/archive; this module runs the statements.
//!
//! # One day ([`run_task`])
//! 1. The site's calibration in effect (a folder of Parquet files made from an earlier day) is
//!    loaded instead of measured, or, when the site has none, measured from this day (the
//!    manifest's part 'site': crates/app/src/plan.rs).
//! 2. The day runs on it (part 'day', its results folder in the task's scratch), then
//!    sql/archive_check.sql re-registers every camera pair on the day's matches. A camera change
//!    (a pair moved beyond `archive_change_z` standard errors, a pair whose matches collapsed, a
//!    camera the calibration never saw) calibrates the site again from this day and runs the day
//!    again on it, with a warning that says which camera and by how much.
//! 3. The result files go to the task's scratch folder; the driver moves them into place.
//!
//! Each database has one thread (a day's bytes do not depend on what runs beside it), the
//! task's memory limit, DuckDB's spill folder in the scratch, and a sandbox that allows
//! exactly the partition's files and the calibration's (read) and the scratch (write), locked.
//!
//! | file | what |
//! |---|---|
//! | [`task`] | one site-day: the calibration loaded or made, the day, its check, its files |
//! | [`driver`] | a run: the lake read, rounds of tasks, commits, the summary |
//! | [`state`] | the state file and the runs log |

pub mod driver;
pub mod state;
pub mod task;

pub use driver::{partitions, ArchiveRequest, ChangeNote, Driver, PartitionRow, Summary};
pub use task::{failed_row, run_task, Register, TaskResult, TaskSpec};
