//! An archive of site-days (issue 40; docs/archive.md): the decisions of `CALL trajdb_archive`,
//! `trajdb archive` and `trajdb.spark.archive`, without DuckDB. The hosts run the statements
//! and move the files; what is a partition, what is done, which calibration a day starts from,
//! what the names are and what a change says are decided here, once.
//!
//! | module | what |
//! |---|---|
//! | [`layout`] | the lake's partitions, the order of a site's days, the names allowed |
//! | [`fingerprint`] | input fingerprints, the build id, the parameters, calibration names |
//! | [`plan`] | the state row and the round's tasks (the incremental rule and the calibration chain) |
//! | [`folder`] | OUT: claim, lock, scratch, commit |
//! | [`change`] | a camera change in words |
//! | [`index`] | the site's index page |

pub mod change;
pub mod fingerprint;
pub mod folder;
pub mod index;
pub mod layout;
pub mod plan;

/// A refusal or failure of the archive, naming what and how to fix it.
#[derive(Debug, Clone, PartialEq)]
pub struct ArchiveError(pub String);

impl std::fmt::Display for ArchiveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ArchiveError {}

/// DuckDB's memory per task: a Mellingen-sized day (3 M points, 12 h) peaked at 2.3 GB without a
/// limit and at 1.5 GB (the process) with 1.2 GB, in the same time (DuckDB spills to the task's
/// scratch folder). A day that cannot fit fails with DuckDB's out-of-memory error, alone.
pub const TASK_MEMORY: &str = "1.5GB";
