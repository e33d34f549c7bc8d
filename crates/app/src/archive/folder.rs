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

/// `p` absolute, `~` expanded, its existing part resolved (symbolic links, `..`): the path the
/// file system will write to, as the sandbox check sees it (crates/app/src/outdir.rs `absolute`).
pub fn resolve(p: &Path) -> Result<PathBuf, ArchiveError> {
    let text = p.to_str().ok_or_else(|| err(format!("trajdb archive: the path {} is not UTF-8", p.display())))?;
    let r = crate::outdir::absolute(text).map_err(|e| err(format!("trajdb archive: {e}")))?;
    // a '..' left after the existing part was resolved climbs out of a folder that does not
    // exist yet: where it lands is decided only when the folders are made
    if r.components().any(|c| matches!(c, std::path::Component::ParentDir)) {
        return Err(err(format!("trajdb archive: the path {text:?} goes through '..' out of a folder that does not exist; give the folder without '..'")));
    }
    Ok(r)
}

/// `a` is `b` or inside it (both resolved).
pub fn inside(a: &Path, b: &Path) -> bool {
    let r = |p: &Path| resolve(p).unwrap_or_else(|_| p.to_path_buf());
    r(a).starts_with(r(b))
}

/// Refuses an archive folder that holds a symbolic link anywhere below it: trajdb writes,
/// renames and removes only in folders it made, and a link (to a folder of the user's, to a
/// file outside the sandbox) would carry its writes elsewhere. O(entries), no file opened.
pub fn refuse_links(out: &Path) -> Result<(), ArchiveError> {
    let mut stack = vec![out.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(rd) = fs::read_dir(&dir) else { continue };
        for e in rd.flatten() {
            let Ok(t) = e.file_type() else { continue };
            if t.is_symlink() {
                return Err(err(format!(
                    "trajdb archive: {} in the archive folder is a symbolic link; trajdb writes only into folders it made (remove the link, or name a new out_dir)",
                    e.path().display()
                )));
            }
            if t.is_dir() {
                stack.push(e.path());
            }
        }
    }
    Ok(())
}

/// Checks OUT and writes its marker; returns its absolute path (module doc).
pub fn claim(out: &Path, lake: &Path) -> Result<PathBuf, ArchiveError> {
    let out = resolve(out)?;
    let lake = &resolve(lake)?;
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
    let lake_abs = lake.clone();
    if fs::symlink_metadata(&marker).is_err() {
        // made in place (create_new: of two first runs, one makes it and both then see it; a
        // marker cut short by a kill holds no lake line and is taken as this lake's)
        match fs::OpenOptions::new().write(true).create_new(true).open(&marker) {
            Ok(mut f) => f.write_all(format!("{MARKER_HEAD}input\t{}\n", lake_abs.display()).as_bytes()).map_err(io("write", &marker))?,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(io("write", &marker)(e)),
        }
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
    refuse_links(&out)?;
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
    use std::os::unix::fs::OpenOptionsExt;
    let f = fs::OpenOptions::new().create(true).append(true).read(true).custom_flags(libc::O_NOFOLLOW).open(&p).map_err(io("open", &p))?;
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

/// No symbolic link between `out` and `path` (each folder on the way, and `path` itself).
pub fn no_links(out: &Path, path: &Path) -> Result<(), ArchiveError> {
    let rel = path.strip_prefix(out).map_err(|_| err(format!("trajdb archive: {} is not inside the archive folder", path.display())))?;
    let mut p = out.to_path_buf();
    for c in rel.components() {
        p.push(c);
        if fs::symlink_metadata(&p).is_ok_and(|m| m.file_type().is_symlink()) {
            return Err(err(format!("trajdb archive: {} in the archive folder is a symbolic link; trajdb writes only into folders it made", p.display())));
        }
    }
    Ok(())
}

fn place(out: &Path, src: &Path, dest: &Path) -> Result<(), ArchiveError> {
    no_links(out, dest)?;
    if let Some(d) = dest.parent() {
        fs::create_dir_all(d).map_err(io("create", d))?;
    }
    fs::rename(src, dest).map_err(io("move into place", dest))
}

/// Removes trajdb's file `name` in `folder`, and the folder when that leaves it empty (never
/// through a symbolic link).
fn unlink_own(out: &Path, folder: &Path, name: &str) {
    let p = folder.join(name);
    if no_links(out, &p).is_err() {
        return;
    }
    if fs::symlink_metadata(&p).is_ok_and(|m| m.is_file()) {
        let _ = fs::remove_file(&p);
    }
    let _ = fs::remove_dir(folder); // only when empty
}

/// Moves a finished task's files into place (ok), or removes the partition's files of an
/// earlier run (failed: they no longer describe its input), then the task's scratch. The
/// caller records the partition in the state afterwards: that is the commit point.
pub fn commit(out: &Path, site: &str, date: &str, ok: bool, scratch: Option<&Path>, calibration: Option<(&Path, &str)>) -> Result<(), ArchiveError> {
    let r = if ok { place_all(out, site, date, scratch, calibration) } else { Ok(()) };
    if !ok || r.is_err() {
        // a failed partition: the files of an earlier run no longer describe its input, and a
        // commit that failed half way leaves no half of a partition
        for (folder, _, _) in TABLES {
            unlink_own(out, &part_dir(out, folder, site, date), "part-0.parquet");
        }
        unlink_own(out, &part_dir(out, REPORT.0, site, date), REPORT.1);
    }
    if let Some(s) = scratch {
        let _ = fs::remove_dir_all(s);
    }
    r
}

fn place_all(out: &Path, site: &str, date: &str, scratch: Option<&Path>, calibration: Option<(&Path, &str)>) -> Result<(), ArchiveError> {
    let scratch = scratch.ok_or_else(|| err("trajdb archive: an ok task without its scratch folder".into()))?;
    // every file there before any moves (a commit never leaves half a partition)
    let files: Vec<PathBuf> = TABLES.iter().map(|(_, name, _)| scratch.join(name)).chain([scratch.join(REPORT.1)]).collect();
    if let Some(f) = files.iter().find(|f| !fs::symlink_metadata(f).is_ok_and(|m| m.is_file())) {
        return Err(err(format!("trajdb archive: the task's result file {} is missing", f.display())));
    }
    if let Some((src, id)) = calibration {
        if !fs::symlink_metadata(src).is_ok_and(|m| m.is_dir()) {
            return Err(err(format!("trajdb archive: the task's calibration folder {} is missing", src.display())));
        }
        let dest = cal_dir(out, site, id);
        no_links(out, &dest)?;
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
    for ((folder, _, _), f) in TABLES.iter().zip(&files) {
        place(out, f, &part_file(out, folder, site, date, "part-0.parquet"))?;
    }
    place(out, &files[TABLES.len()], &part_file(out, REPORT.0, site, date, REPORT.1))
}
