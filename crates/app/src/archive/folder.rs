//! The archive folder OUT: claimed (new, empty, or an archive trajdb made from this lake: its
//! marker), locked (one run at a time), its scratch cleaned, and each finished partition
//! committed (files renamed into place, a reader sees the old file or the new one). trajdb
//! removes only what it wrote: a partition's `part-0.parquet` and `report.html`, and its own
//! scratch folders `_work/task-*`.

use super::ArchiveError;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

pub const MARKER: &str = ".trajdb-archive";
pub const MARKER_HEAD: &str =
    "# trajdb archive 1: this folder and the files below it were written by trajdb archive; it replaces only its own files\n";
/// The per-day result files: (folder under OUT, file name in the task's scratch, what it is).
pub const TABLES: &[(&str, &str, &str)] = &[
    ("road_users", "road_users.parquet", "one row per road user: merged.parquet of the day (GeoParquet)"),
    ("matches", "matches.parquet", "the accepted cross-camera links (matches.csv)"),
    ("links", "links.parquet", "each track's chain of pieces within its camera (links.csv)"),
    ("transforms", "transforms.parquet", "each camera pair's transform and clock relation in effect (transforms.csv)"),
    ("calibration", "calibration.parquet", "what the day's run measured and derived (calibration.csv)"),
];
/// The day's report: (folder, file name).
pub const REPORT: (&str, &str) = ("reports", "report.html");

fn err(msg: String) -> ArchiveError {
    ArchiveError(msg)
}

fn io<'a>(what: &'a str, p: &'a Path) -> impl Fn(std::io::Error) -> ArchiveError + 'a {
    let what = what.to_string();
    move |e| err(format!("trajdb archive: cannot {what} {}: {e}", p.display()))
}

/// `a` is `b` or inside it (both resolved).
pub fn inside(a: &Path, b: &Path) -> bool {
    let r = |p: &Path| fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    r(a).starts_with(r(b))
}

/// Checks OUT and writes its marker; returns its absolute path (module doc).
pub fn claim(out: &Path, lake: &Path) -> Result<PathBuf, ArchiveError> {
    let out = std::path::absolute(out).map_err(io("resolve", out))?;
    let o = out.display().to_string();
    if out.parent().is_none() {
        return Err(err(format!("trajdb archive: out {o:?} is not a folder trajdb can own; name a new folder")));
    }
    if inside(&out, lake) || inside(lake, &out) {
        return Err(err(format!("trajdb archive: out {o:?} and the input {:?} hold one another; put the results outside the lake", lake.display().to_string())));
    }
    if out.exists() {
        if !out.is_dir() {
            return Err(err(format!("trajdb archive: out {o:?} is a file; name a new folder")));
        }
        let mut names: Vec<String> = fs::read_dir(&out).map_err(io("list", &out))?.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        if !names.is_empty() && !names.iter().any(|n| n == MARKER) {
            return Err(err(format!(
                "trajdb archive: out {o:?} holds files trajdb did not write ({}); name a new or empty folder (trajdb never writes among your files)",
                names.iter().take(3).cloned().collect::<Vec<_>>().join(", ")
            )));
        }
    }
    fs::create_dir_all(&out).map_err(io("create", &out))?;
    let marker = out.join(MARKER);
    let lake_abs = std::path::absolute(lake).unwrap_or_else(|_| lake.to_path_buf());
    if !marker.exists() {
        write_atomic(&marker, format!("{MARKER_HEAD}input\t{}\n", lake_abs.display()).as_bytes(), None)?;
    } else {
        // one archive, one lake: a run from another lake would mix two lakes' days in one state
        let text = fs::read(&marker).map_err(io("read", &marker))?;
        let text = String::from_utf8_lossy(&text);
        if let Some(made) = text.lines().find_map(|l| l.strip_prefix("input\t")) {
            let r = |p: &Path| fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
            if r(Path::new(made)) != r(lake) {
                return Err(err(format!(
                    "trajdb archive: {o:?} is the archive of the lake {made:?}, not of {:?}; name another out for this lake (or give that lake's path)",
                    lake_abs.display().to_string()
                )));
            }
        }
    }
    for d in ["_state", "_work"] {
        fs::create_dir_all(out.join(d)).map_err(io("create", &out))?;
    }
    Ok(out)
}

/// `data` into `path` whole or not at all: written under a scratch name (in `work`, OUT/_work,
/// which the next run cleans when a kill leaves it; else beside `path`), synced, then renamed.
pub fn write_atomic(path: &Path, data: &[u8], work: Option<&Path>) -> Result<(), ArchiveError> {
    let stamp = format!("{}-{}", std::process::id(), std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0));
    let tmp = match work {
        Some(w) => w.join(format!("task-tmp-{stamp}")),
        None => PathBuf::from(format!("{}.tmp-{stamp}", path.display())),
    };
    let mut f = fs::OpenOptions::new().write(true).create_new(true).open(&tmp).map_err(io("write", &tmp))?;
    f.write_all(data).and_then(|_| f.sync_all()).map_err(io("write", &tmp))?;
    fs::rename(&tmp, path).map_err(io("write", path))
}

/// One archive run per OUT at a time: an advisory lock on `_state/lock`, held while the
/// returned file is open (the system drops it when the process ends, however it ends). The same
/// lock as Python's `fcntl.flock`.
pub fn lock(out: &Path) -> Result<fs::File, ArchiveError> {
    let p = out.join("_state").join("lock");
    let f = fs::OpenOptions::new().create(true).append(true).read(true).open(&p).map_err(io("open", &p))?;
    // SAFETY: flock on a descriptor this function owns
    let r = unsafe { libc::flock(std::os::fd::AsRawFd::as_raw_fd(&f), libc::LOCK_EX | libc::LOCK_NB) };
    if r != 0 {
        return Err(err(format!("trajdb archive: another trajdb archive is writing into {:?}; wait for it to finish", out.display().to_string())));
    }
    Ok(f)
}

/// Removes the scratch of earlier, interrupted runs: only trajdb's own (`_work/task-*`).
pub fn clean_work(out: &Path) {
    let work = out.join("_work");
    let Ok(rd) = fs::read_dir(&work) else { return };
    for e in rd.flatten() {
        if e.file_name().to_string_lossy().starts_with("task-") {
            let p = e.path();
            match fs::symlink_metadata(&p) {
                Ok(m) if m.is_dir() => {
                    let _ = fs::remove_dir_all(&p);
                }
                Ok(_) => {
                    let _ = fs::remove_file(&p);
                }
                Err(_) => {}
            }
        }
    }
}

/// The folder of a site's calibration `id`.
pub fn cal_dir(out: &Path, site: &str, id: &str) -> PathBuf {
    out.join("_calibrations").join(format!("site={site}")).join(format!("from={id}"))
}

/// A partition's folder under `folder` of OUT.
pub fn part_dir(out: &Path, folder: &str, site: &str, date: &str) -> PathBuf {
    out.join(folder).join(format!("site={site}")).join(format!("date={date}"))
}

/// A partition's file `name` under `folder` of OUT.
pub fn part_file(out: &Path, folder: &str, site: &str, date: &str, name: &str) -> PathBuf {
    part_dir(out, folder, site, date).join(name)
}

fn place(src: &Path, dest: &Path) -> Result<(), ArchiveError> {
    if let Some(d) = dest.parent() {
        fs::create_dir_all(d).map_err(io("create", d))?;
    }
    fs::rename(src, dest).map_err(io("move into place", dest))
}

/// Removes trajdb's file `name` in `folder`, and the folder when that leaves it empty.
fn unlink_own(folder: &Path, name: &str) {
    let p = folder.join(name);
    if fs::symlink_metadata(&p).is_ok_and(|m| m.is_file()) {
        let _ = fs::remove_file(&p);
    }
    let _ = fs::remove_dir(folder); // only when empty
}

/// Moves a finished task's files into place (ok), or removes the partition's files of an
/// earlier run (failed: they no longer describe its input), then the task's scratch. The
/// caller records the partition in the state afterwards: that is the commit point.
pub fn commit(out: &Path, site: &str, date: &str, ok: bool, scratch: Option<&Path>, calibration: Option<(&Path, &str)>) -> Result<(), ArchiveError> {
    if ok {
        let scratch = scratch.ok_or_else(|| err("trajdb archive: an ok task without its scratch folder".into()))?;
        if let Some((src, id)) = calibration {
            let dest = cal_dir(out, site, id);
            if let Some(d) = dest.parent() {
                fs::create_dir_all(d).map_err(io("create", d))?;
            }
            if dest.exists() {
                // an interrupted run's copy of the same calibration
                let old = scratch.with_file_name(format!("task-old-{}-{}", std::process::id(), date));
                fs::rename(&dest, &old).map_err(io("replace", &dest))?;
                let _ = fs::remove_dir_all(&old);
            }
            fs::rename(src, &dest).map_err(io("move into place", &dest))?;
        }
        for (folder, name, _) in TABLES {
            place(&scratch.join(name), &part_file(out, folder, site, date, "part-0.parquet"))?;
        }
        place(&scratch.join(REPORT.1), &part_file(out, REPORT.0, site, date, REPORT.1))?;
    } else {
        for (folder, _, _) in TABLES {
            unlink_own(&part_dir(out, folder, site, date), "part-0.parquet");
        }
        unlink_own(&part_dir(out, REPORT.0, site, date), REPORT.1);
    }
    if let Some(s) = scratch {
        let _ = fs::remove_dir_all(s);
    }
    Ok(())
}
