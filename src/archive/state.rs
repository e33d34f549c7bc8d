//! The archive's state (`_state/partitions.parquet`, rewritten whole and renamed into place) and
//! its runs log (`_state/runs.csv`, one line per site-day run).

use super::task::TaskResult;
use crate::app::archive::plan::{StateRow, STATE_COLUMNS};
use crate::app::sql::sql_string;
use duckdb::Connection;
use std::collections::HashMap;
use std::error::Error;
use std::fs;
use std::path::{Path, PathBuf};

/// The state is rewritten whole (one Parquet file) at most this often, and at each round's end.
pub(super) const STATE_EVERY_S: f64 = 2.0;

fn state_path(out: &Path) -> PathBuf {
    out.join("_state").join("partitions.parquet")
}

/// The archive's state, as any host wrote it.
pub fn load_state(out: &Path) -> Result<HashMap<(String, String), StateRow>, Box<dyn Error>> {
    let p = state_path(out);
    let mut state = HashMap::new();
    if !p.exists() {
        return Ok(state);
    }
    let con = Connection::open_in_memory()?;
    let cols: Vec<String> = STATE_COLUMNS.iter().map(|(c, t)| format!("\"{c}\"::{t}")).collect();
    let mut st = con.prepare(&format!("SELECT {} FROM read_parquet(?, hive_partitioning = false)", cols.join(", ")))?;
    let rows = st.query_map([p.to_string_lossy().as_ref()], |r| {
        Ok(StateRow {
            site: r.get(0)?,
            date: r.get(1)?,
            status: r.get(2)?,
            inputs: r.get(3)?,
            fingerprint: r.get(4)?,
            trajdb_version: r.get(5)?,
            params: r.get(6)?,
            calibration_in: r.get(7)?,
            calibration_out: r.get(8)?,
            calibration_made: r.get(9)?,
            changes: r.get(10)?,
            cameras: r.get(11)?,
            points: r.get(12)?,
            road_users: r.get(13)?,
            matches: r.get(14)?,
            checks: r.get(15)?,
            warnings: r.get(16)?,
            error: r.get(17)?,
        })
    })?;
    for r in rows {
        let r = r?;
        state.insert((r.site.clone(), r.date.clone()), r);
    }
    Ok(state)
}

/// Writes the state whole (sorted by site and date) and renames it into place.
pub fn save_state(out: &Path, state: &HashMap<(String, String), StateRow>) -> Result<(), Box<dyn Error>> {
    let con = Connection::open_in_memory()?;
    let cols: Vec<String> = STATE_COLUMNS.iter().map(|(c, t)| format!("\"{c}\" {t}")).collect();
    con.execute_batch(&format!("CREATE TABLE s ({})", cols.join(", ")))?;
    {
        let mut app = con.appender("s")?;
        let mut keys: Vec<&(String, String)> = state.keys().collect();
        keys.sort();
        for k in keys {
            let r = &state[k];
            app.append_row(duckdb::params![
                r.site, r.date, r.status, r.inputs, r.fingerprint, r.trajdb_version, r.params, r.calibration_in, r.calibration_out,
                r.calibration_made, r.changes, r.cameras, r.points, r.road_users, r.matches, r.checks, r.warnings, r.error
            ])?;
        }
    }
    let ns = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let tmp = out.join("_work").join(format!("task-tmp-{}-{ns}.parquet", std::process::id()));
    con.execute_batch(&format!("COPY s TO {} (FORMAT parquet)", sql_string(&tmp.to_string_lossy())))?;
    fs::rename(&tmp, state_path(out))?;
    Ok(())
}

/// Now as 2026-11-28T21:29:41Z.
fn utc_now() -> String {
    let s = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0) as i64;
    let (days, rem) = (s.div_euclid(86400), s.rem_euclid(86400));
    // civil from days (H. Hinnant)
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60)
}

pub(super) fn append_run(out: &Path, r: &TaskResult) {
    use std::io::Write;
    let p = out.join("_state").join("runs.csv");
    let new = !p.exists();
    use std::os::unix::fs::OpenOptionsExt;
    // never through a symbolic link (a file trajdb did not make)
    if let Ok(mut f) = fs::OpenOptions::new().create(true).append(true).custom_flags(libc::O_NOFOLLOW).open(&p) {
        if new {
            let _ = f.write_all(b"finished_utc,site,date,status,seconds,peak_rss_mb,points\n");
        }
        let pts = r.row.points.map(|p| p.to_string()).unwrap_or_default();
        let rss = r.peak_rss_mb.map(|m| format!("{m:.1}")).unwrap_or_default();
        let secs = if r.seconds > 0.0 { format!("{:.2}", r.seconds) } else { String::new() };
        let _ = writeln!(f, "{},{},{},{},{secs},{rss},{pts}", utc_now(), r.row.site, r.row.date, r.row.status);
    }
}

