//! The results folder (`out`): the one place that decides what trajdb may write and delete.
//!
//! The rules (README, "Never failing badly"):
//! - `out` is a folder that does not exist yet, an empty folder, or a folder holding an earlier
//!   trajdb result set, recognised by the manifest [`MANIFEST`] that trajdb writes into it. Any
//!   other `out` (a folder with the user's own files, a file, `''`, `/`, the home folder, the
//!   input's own folder) is refused before any work.
//! - `out` must not be or contain the input.
//! - trajdb deletes only (a) the files named in its own manifest, each a plain file name inside
//!   `out`, when a new run replaces them, and (b) its own staging folder `out/.trajdb-partial-*`
//!   with what it wrote there. It never removes `out` itself, nor any folder it did not create.
//!   That is guaranteed by construction: this module is the only code of trajdb that removes
//!   anything from a results folder ([`remove_own_file`] and [`remove_partial`] are the only
//!   calls of `remove_file` / `remove_dir` on it), and both check the name they remove against
//!   the manifest or the staging prefix first.
//! - A run writes into `out/.trajdb-partial-<pid>-<n>/`; [`Claim::commit`] moves each file into
//!   place with `rename` (atomic per file), deletes the files of the previous manifest that this
//!   run did not write, then writes the new manifest (atomically). A failed run calls
//!   [`Claim::abort`]: its staging folder goes, the previous results stay intact. A run killed
//!   with `kill -9` leaves its staging folder; the next run on `out` removes it (it is ours).
//! - Two runs on one `out`: each takes an advisory lock (`flock`) on [`LOCK`]; the second run
//!   fails at once with an error naming the first. The system releases the lock when a process
//!   ends, however it ends, so a killed run leaves no stale lock.
//! - Folders are created with the process's normal permissions (umask), not 0700.
//!
//! Pure std: used by the `trajdb` binary and, through the extension, by every other runner.

use std::fmt;
use std::fs;
use std::io::Write as _;
use std::path::{Component, Path, PathBuf};

/// The manifest: a results folder that trajdb made holds this file; one result file name a line.
pub const MANIFEST: &str = ".trajdb-results";
/// The lock file of a run in progress (its content: the process id).
pub const LOCK: &str = ".trajdb-lock";
/// The prefix of a run's staging folder inside `out`.
pub const PARTIAL_PREFIX: &str = ".trajdb-partial-";
const MANIFEST_HEAD: &str = "# trajdb results: the files below were written by trajdb and may be replaced by its next run into this folder\n";

/// Why a results folder cannot be used (or an I/O failure), with the fix.
#[derive(Debug)]
pub struct OutError(pub String);

impl fmt::Display for OutError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for OutError {}

fn err<T>(msg: String) -> Result<T, OutError> {
    Err(OutError(msg))
}

fn io(what: &str, p: &Path, e: std::io::Error) -> OutError {
    OutError(format!("results folder: cannot {what} {}: {e}", p.display()))
}

/// `p` made absolute and resolved: the longest existing prefix through `canonicalize` (symbolic
/// links followed), the rest appended lexically; `..` in the rest is refused.
fn resolve(p: &Path) -> Result<PathBuf, OutError> {
    let abs = if p.is_absolute() { p.to_path_buf() } else { std::env::current_dir().map_err(|e| io("read the working folder", p, e))?.join(p) };
    let mut existing = abs.clone();
    let mut rest: Vec<std::ffi::OsString> = Vec::new();
    loop {
        if let Ok(c) = existing.canonicalize() {
            let mut out = c;
            for part in rest.iter().rev() {
                out.push(part);
            }
            return Ok(out);
        }
        match (existing.file_name(), existing.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name.to_os_string());
                existing = parent.to_path_buf();
            }
            _ => {
                // a trailing `..` or `.` of a path that does not exist
                if abs.components().any(|c| matches!(c, Component::ParentDir)) {
                    return err(format!("results folder {}: a path through '..' into a folder that does not exist", p.display()));
                }
                return Ok(abs);
            }
        }
    }
}

/// The folder part of an input that is a file path or glob (`data/*.parquet` -> `data`),
/// resolved, and whether the pattern reaches into sub-folders (`data/*/x.csv`, `data/**`).
fn input_path(input: &str) -> Option<(PathBuf, bool)> {
    if input.is_empty() || input.contains("://") {
        return None;
    }
    let input = expand_home(input);
    let input = input.as_str();
    let wild = input.find(['*', '?', '[', '{']);
    let deep = wild.is_some_and(|k| input[k..].contains('/'));
    let cut = wild.map(|k| &input[..k]).unwrap_or(input);
    let p = Path::new(cut);
    // a pattern: the folder it lies in ("data/*.parquet" -> "data", "data/pts*" -> "data")
    let p = if cut.len() < input.len() && !cut.ends_with('/') { p.parent().unwrap_or(Path::new(".")) } else { p };
    let p = if p.as_os_str().is_empty() { Path::new(".") } else { p };
    if !p.exists() {
        return None; // a table name, or a file that does not exist (the load will say so)
    }
    resolve(p).ok().map(|p| (p, deep))
}

/// `p` as every writer of trajdb uses it (and as the sandbox check sees it): `~` expanded, made
/// absolute, the longest existing prefix resolved through `canonicalize`.
pub fn absolute(p: &str) -> Result<PathBuf, OutError> {
    resolve(Path::new(&expand_home(p)))
}

/// A leading `~` or `~/` is the home folder, as in a shell and in DuckDB's own paths.
fn expand_home(p: &str) -> String {
    match (p.strip_prefix('~'), std::env::var("HOME")) {
        (Some(rest), Ok(home)) if rest.is_empty() || rest.starts_with('/') => format!("{home}{rest}"),
        _ => p.to_string(),
    }
}

/// The file names listed in `dir`'s manifest; `None` when `dir` has no manifest. A name that is
/// not a plain file name (a separator, `..`) makes the manifest invalid: nothing is trusted.
fn read_manifest(dir: &Path) -> Result<Option<Vec<String>>, OutError> {
    let path = dir.join(MANIFEST);
    match fs::symlink_metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io("read", &path, e)),
        Ok(m) if !m.is_file() => {
            return err(format!(
                "results folder {}: its {MANIFEST} is not a plain file (a link or a folder); trajdb will not delete by it (pick another out)",
                dir.display()
            ))
        }
        Ok(_) => {}
    }
    // a manifest of another user's is never trusted: in a folder others may write into (a
    // shared /tmp), anyone could plant one naming your files
    if let (Some(owner), Some(me)) = (owner_of(&path), process_uid()) {
        if owner != me {
            return err(format!(
                "results folder {}: its {MANIFEST} belongs to another user (uid {owner}); trajdb will not delete by it (pick another out)",
                dir.display()
            ));
        }
    }
    let text = fs::read_to_string(&path).map_err(|e| io("read", &path, e))?;
    if !text.starts_with(MANIFEST_HEAD.trim_end()) {
        return err(format!(
            "results folder {}: its {MANIFEST} was not written by trajdb (its first line is not trajdb's); trajdb will not delete by it (pick another out)",
            dir.display()
        ));
    }
    let mut names = Vec::new();
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')) {
        // `name<TAB>identity` (size, modification time and inode when trajdb wrote it), or
        // `name` alone (a manifest of an earlier trajdb, or a file not yet moved in)
        let (line, ident) = match line.split_once('\t') {
            Some((n, i)) => (n.trim(), Some(i.trim())),
            None => (line, None),
        };
        if let (Some(want), Ok(m)) = (ident, fs::symlink_metadata(dir.join(line))) {
            if m.is_file() && identity(&m).as_deref() != Some(want) {
                return err(format!(
                    "results folder {}: {line} changed since trajdb wrote it (or is another file under its name); trajdb will not \
                     replace or delete it: move it away, or pick another out",
                    dir.display()
                ));
            }
        }
        if !plain_name(line) {
            return err(format!(
                "results folder {}: its {MANIFEST} lists {line:?}, which is not a plain file name; trajdb will not delete by it (remove the folder yourself, or pick another out)",
                dir.display()
            ));
        }
        // a name-only line is trusted only for a name trajdb writes (or a file that is gone): a
        // hand-made manifest naming other files never makes trajdb delete them
        if ident.is_none() && !WRITTEN_NAMES.contains(&line) && fs::symlink_metadata(dir.join(line)).is_ok() {
            return err(format!(
                "results folder {}: its {MANIFEST} lists {line:?}, a file trajdb never writes; trajdb will not delete by it (remove the folder yourself, or pick another out)",
                dir.display()
            ));
        }
        names.push(line.to_string());
    }
    Ok(Some(names))
}

/// Every file name trajdb writes into a results folder (sql/export.sql, sql/report.sql, the
/// simulator and trajdb.simulate's points.parquet).
pub const WRITTEN_NAMES: &[&str] = &[
    "transforms.csv", "calibration.csv", "matches.csv", "merged.parquet", "clusters.csv", "links.csv", "report.html",
    "points.csv", "points.parquet", "cameras.csv", "truth.csv", "objects.csv", "world.csv", "README.txt",
];

/// What identifies a file trajdb wrote: size, modification time (ns) and inode.
fn identity(m: &fs::Metadata) -> Option<String> {
    let t = m.modified().ok()?.duration_since(std::time::UNIX_EPOCH).ok()?.as_nanos();
    #[cfg(unix)]
    let ino = std::os::unix::fs::MetadataExt::ino(m);
    #[cfg(not(unix))]
    let ino = 0u64;
    Some(format!("{}:{t}:{ino}", m.len()))
}

/// The owner (uid) of a path; `None` where unknown (not unix).
fn owner_of(p: &Path) -> Option<u32> {
    #[cfg(unix)]
    {
        fs::symlink_metadata(p).ok().map(|m| std::os::unix::fs::MetadataExt::uid(&m))
    }
    #[cfg(not(unix))]
    {
        let _ = p;
        None
    }
}

/// This process's user: the owner of `/proc/self` (Linux); `None` where unknown.
fn process_uid() -> Option<u32> {
    owner_of(Path::new("/proc/self"))
}

/// A file name with no separator, not `.`/`..`, not one of trajdb's own control names.
fn plain_name(s: &str) -> bool {
    !s.is_empty() && s != "." && s != ".." && !s.contains(['/', '\\', '\0']) && s != MANIFEST && s != LOCK && !s.starts_with(PARTIAL_PREFIX)
}

/// A results folder claimed for one run: the lock is held, the staging folder exists.
#[derive(Debug)]
pub struct Claim {
    pub out: PathBuf,
    pub partial: PathBuf,
    previous: Vec<String>,
    /// The folders this claim created (`out` and any missing parents, innermost first): a
    /// failed first run removes them again while they hold nothing else.
    created: Vec<PathBuf>,
    /// This claim wrote the first manifest into `out` (new or empty): a failed run removes it
    /// again, so that an empty folder of the user's stays as it was.
    fresh: bool,
    lock: Option<fs::File>,
    done: bool,
}

static SEQ: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Checks `out` against the rules above and claims it: creates it (and its parents) when
/// missing, takes the lock, removes stale staging folders of killed runs, creates this run's
/// staging folder. `inputs` are the run's input strings (paths, globs or table names).
pub fn claim(out: &str, inputs: &[&str]) -> Result<Claim, OutError> {
    if out.trim().is_empty() {
        return err("results folder: out is '' (empty); name a new folder, e.g. out='results'".into());
    }
    let dir = absolute(out)?;
    if dir.parent().is_none() {
        return err(format!("results folder: out {out:?} is the root folder; name a new folder, e.g. out='results'"));
    }
    for input in inputs {
        if let Some((inp, deep)) = input_path(input) {
            if inp.starts_with(&dir) {
                return err(format!(
                    "results folder: out {out:?} ({}) is or contains the input {input:?}; results go into a folder of their own, e.g. out='results'",
                    dir.display()
                ));
            }
            // a pattern that reaches into sub-folders would read the results as input next time
            if deep && dir.starts_with(&inp) {
                return err(format!(
                    "results folder: out {out:?} ({}) lies under the folders the input pattern {input:?} reads, so the next run would read the \
                     results as input; put the results outside {}",
                    dir.display(),
                    inp.display()
                ));
            }
        }
    }
    let mut created = Vec::new();
    if dir.exists() {
        if !dir.is_dir() {
            return err(format!("results folder: out {out:?} ({}) is a file, not a folder; name a new folder", dir.display()));
        }
        if read_manifest(&dir)?.is_none() {
            // no manifest: only trajdb's own control entries (another run's lock, a staging
            // folder) may be there; anything else is the user's
            let foreign = fs::read_dir(&dir).map_err(|e| io("list", &dir, e))?.flatten().map(|e| e.file_name()).find(|n| {
                let n = n.to_string_lossy();
                // (the manifest itself: another run wrote it since the read above; it is
                // read again, and checked, under the lock)
                n != LOCK && n != MANIFEST && !n.starts_with(PARTIAL_PREFIX) && !n.starts_with(&format!("{MANIFEST}."))
            });
            if let Some(first) = foreign {
                return err(format!(
                    "results folder: out {out:?} ({}) already holds files that trajdb did not write (e.g. {:?}); \
                     trajdb writes only into a new folder, an empty one, or one with its own earlier results: name another out, e.g. out='{}'",
                    dir.display(),
                    first.to_string_lossy(),
                    Path::new(out).join("trajdb-results").display()
                ));
            }
        }
    } else {
        let mut d = dir.as_path();
        while !d.exists() {
            created.push(d.to_path_buf());
            d = match d.parent() {
                Some(p) => p,
                None => break,
            };
        }
        fs::create_dir_all(&dir).map_err(|e| io("create", &dir, e))?;
    }
    // the lock first, then everything else under it: the manifest read (another run may have
    // committed meanwhile) or written (a new folder becomes recognisably trajdb's)
    let lock = take_lock(&dir, out)?;
    let (previous, fresh) = match read_manifest(&dir)? {
        Some(names) => (names, false),
        None => {
            write_manifest(&dir, &[])?;
            (Vec::new(), true)
        }
    };
    // holding the lock, every staging folder in `out` is a dead run's (or an aborted one's)
    remove_stale_partials(&dir)?;
    let n = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let partial = dir.join(format!("{PARTIAL_PREFIX}{}-{n}", std::process::id()));
    fs::create_dir(&partial).map_err(|e| io("create", &partial, e))?;
    Ok(Claim { out: dir, partial, previous, created, fresh, lock: Some(lock), done: false })
}

/// The run's lock: an advisory lock (`flock`) on `out/.trajdb-lock`, held by the open file for
/// as long as the claim lives and released by the system when the process ends however it ends
/// (so a killed run never leaves a stale lock, and no pid is trusted). The file itself stays:
/// deleting it while another process waits on it would let two runs in.
fn take_lock(dir: &Path, out: &str) -> Result<fs::File, OutError> {
    let lock = dir.join(LOCK);
    if fs::symlink_metadata(&lock).is_ok_and(|m| !m.is_file()) {
        return err(format!("results folder: {} is not a file that trajdb made; remove it, or pick another out", lock.display()));
    }
    let f = fs::OpenOptions::new().write(true).create(true).truncate(false).open(&lock).map_err(|e| io("create", &lock, e))?;
    match f.try_lock() {
        Ok(()) => {
            // the file locked must still be the one at the path (a run that removed its lock
            // file in between would otherwise let two runs in)
            #[cfg(unix)]
            {
                use std::os::unix::fs::MetadataExt;
                let same = match (f.metadata(), fs::symlink_metadata(&lock)) {
                    (Ok(a), Ok(b)) => a.ino() == b.ino() && a.dev() == b.dev(),
                    _ => false,
                };
                if !same {
                    return err(format!("results folder: another trajdb run changed out {out:?} while this one started; run again"));
                }
            }
            let _ = f.set_len(0);
            let _ = write!(&f, "{}", std::process::id());
            Ok(f)
        }
        Err(fs::TryLockError::WouldBlock) => {
            let pid = fs::read_to_string(&lock).unwrap_or_default();
            err(format!(
                "results folder: another trajdb run is writing into out {out:?} (process {}); wait for it to finish, or pick another out",
                if pid.trim().is_empty() { "?" } else { pid.trim() }
            ))
        }
        Err(fs::TryLockError::Error(e)) => Err(io("lock", &lock, e)),
    }
}

/// Staging folders of runs whose process is gone (`kill -9`): ours by name, inside our folder.
fn remove_stale_partials(dir: &Path) -> Result<(), OutError> {
    for entry in fs::read_dir(dir).map_err(|e| io("list", dir, e))?.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with(PARTIAL_PREFIX) && entry.file_type().is_ok_and(|t| t.is_dir()) {
            remove_partial(dir, &entry.path())?;
        }
    }
    Ok(())
}

/// Removes a staging folder of ours: its name carries our prefix and it lies directly in `dir`;
/// only the plain files in it (what the export wrote) and then the empty folder are removed.
fn remove_partial(dir: &Path, partial: &Path) -> Result<(), OutError> {
    let ours = partial.parent() == Some(dir) && partial.file_name().is_some_and(|n| n.to_string_lossy().starts_with(PARTIAL_PREFIX));
    if !ours {
        return err(format!("results folder: refusing to remove {}: not a staging folder of trajdb", partial.display()));
    }
    if let Ok(entries) = fs::read_dir(partial) {
        for e in entries.flatten() {
            if e.file_type().is_ok_and(|t| t.is_file()) {
                let _ = fs::remove_file(e.path());
            }
        }
    }
    // remove_dir, not remove_dir_all: a folder someone else put in there stops it
    fs::remove_dir(partial).map_err(|e| io("remove the staging folder", partial, e))
}

/// Removes one result file of an earlier run: a plain name listed in the manifest.
fn remove_own_file(dir: &Path, name: &str, manifest: &[String]) -> Result<(), OutError> {
    if !plain_name(name) || !manifest.iter().any(|m| m == name) {
        return err(format!("results folder: refusing to remove {name:?}: not a result file that trajdb wrote"));
    }
    let p = dir.join(name);
    match fs::symlink_metadata(&p) {
        Ok(m) if m.is_file() => fs::remove_file(&p).map_err(|e| io("remove", &p, e)),
        Ok(_) => Ok(()), // a folder or link under that name is not ours: left alone
        Err(_) => Ok(()),
    }
}

fn write_manifest(dir: &Path, names: &[String]) -> Result<(), OutError> {
    let n = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!("{MANIFEST}.{}-{n}.tmp", std::process::id()));
    let mut text = String::from(MANIFEST_HEAD);
    for n in names {
        text.push_str(n);
        // the file as it is now, so that a later change (a user's own file saved under the
        // name) is never taken for trajdb's
        if let Some(i) = fs::symlink_metadata(dir.join(n)).ok().filter(|m| m.is_file()).and_then(|m| identity(&m)) {
            text.push('\t');
            text.push_str(&i);
        }
        text.push('\n');
    }
    let _ = fs::remove_file(&tmp); // a leftover of a killed run of this pid (a plain name of ours)
    // create_new: never through a link someone planted under this name
    let mut f = fs::OpenOptions::new().write(true).create_new(true).open(&tmp).map_err(|e| io("write", &tmp, e))?;
    f.write_all(text.as_bytes()).map_err(|e| io("write", &tmp, e))?;
    drop(f);
    fs::rename(&tmp, dir.join(MANIFEST)).map_err(|e| io("write", &dir.join(MANIFEST), e))
}

impl Claim {
    /// Moves this run's files into place, removes the earlier run's files that this run did not
    /// write, writes the manifest, drops the staging folder and the lock. Returns the file names.
    pub fn commit(mut self) -> Result<Vec<String>, OutError> {
        let mut names = Vec::new();
        for e in fs::read_dir(&self.partial).map_err(|e| io("list", &self.partial, e))? {
            let e = e.map_err(|e| io("list", &self.partial, e))?;
            let name = e.file_name().to_string_lossy().into_owned();
            if e.file_type().is_ok_and(|t| t.is_file()) && plain_name(&name) {
                names.push(name);
            }
        }
        names.sort();
        // a name this run writes must not be a file of the user's: the folder held only our
        // files when it was claimed, but check again (a user may have added one meanwhile)
        // and every target must be replaceable (absent, or a plain file of ours): checked for
        // all before the first is moved, so that a refusal never leaves a mixed set
        for n in &names {
            let target = self.out.join(n);
            match fs::symlink_metadata(&target) {
                Err(_) => {}
                Ok(m) if m.is_file() && self.previous.contains(n) => {}
                Ok(m) if !m.is_file() => {
                    return err(format!(
                        "results folder {}: {n} there is a folder or a link, not a result file of trajdb's; nothing was replaced (move it away and run again)",
                        self.out.display()
                    ))
                }
                Ok(_) => {
                    return err(format!(
                        "results folder {}: {n} appeared there during the run and is not trajdb's; nothing was replaced",
                        self.out.display()
                    ))
                }
            }
        }
        // the manifest lists old and new names while files move, so that a run killed in
        // between leaves every file listed (and removable by the next run)
        let mut both: Vec<String> = self.previous.iter().chain(names.iter()).cloned().collect();
        both.sort();
        both.dedup();
        write_manifest(&self.out, &both)?;
        for n in &names {
            let (from, to) = (self.partial.join(n), self.out.join(n));
            fs::rename(&from, &to).map_err(|e| io("move a result file into", &to, e))?;
        }
        for old in self.previous.clone() {
            if !names.contains(&old) {
                remove_own_file(&self.out, &old, &both)?;
            }
        }
        write_manifest(&self.out, &names)?;
        self.finish();
        Ok(names)
    }

    /// A failed run: the staging folder goes, the earlier results stay as they were. (Dropping
    /// a claim that was neither committed nor aborted does the same: a runner that returns
    /// early on an error aborts by leaving.)
    pub fn abort(mut self) {
        self.abort_inner();
    }

    fn abort_inner(&mut self) {
        if self.done {
            return;
        }
        // while the lock is still held: the staging folder, then, where this claim wrote the
        // first manifest and the folder holds nothing but it and the lock, those two files
        let _ = remove_partial(&self.out, &self.partial);
        let ours = |n: &std::ffi::OsStr| n == MANIFEST || n == LOCK;
        let only_ours = self.fresh && fs::read_dir(&self.out).map(|d| d.flatten().all(|e| ours(&e.file_name()))).unwrap_or(false);
        if only_ours {
            let _ = fs::remove_file(self.out.join(MANIFEST));
            let _ = fs::remove_file(self.out.join(LOCK));
        }
        self.finish();
        if only_ours {
            // the folders this run created, while they are empty (remove_dir only removes an
            // empty folder)
            for d in &self.created {
                if fs::remove_dir(d).is_err() {
                    break;
                }
            }
        }
    }

    fn finish(&mut self) {
        if !self.done {
            self.done = true;
            let _ = remove_partial(&self.out, &self.partial);
            self.lock = None; // releases the flock; the file stays (see take_lock)
        }
    }
}

impl Drop for Claim {
    fn drop(&mut self) {
        self.abort_inner();
    }
}

/// Claims that outlive one SQL call (the extension's `trajdb_results_begin` / `_end`): by
/// staging folder path.
pub mod open {
    use super::*;
    use std::sync::Mutex;

    static OPEN: Mutex<Vec<Claim>> = Mutex::new(Vec::new());

    /// [`claim`], kept open; returns the staging folder to export into.
    pub fn begin(out: &str, inputs: &[&str]) -> Result<PathBuf, OutError> {
        let c = claim(out, inputs)?;
        let p = c.partial.clone();
        OPEN.lock().unwrap_or_else(|e| e.into_inner()).push(c);
        Ok(p)
    }

    /// Commits (or, with `commit` false, aborts) this process's open claim on `out` (the folder
    /// given to [`begin`], or its staging folder). Aborting when no claim is open is nothing to
    /// do (`Ok` with no names); committing then is an error.
    pub fn end(out: &str, commit: bool) -> Result<Vec<String>, OutError> {
        let dir = absolute(out).ok();
        let c = {
            let mut open = OPEN.lock().unwrap_or_else(|e| e.into_inner());
            match open.iter().position(|c| Some(&c.out) == dir.as_ref() || c.partial == Path::new(out)) {
                Some(k) => open.swap_remove(k),
                None if !commit => return Ok(Vec::new()),
                None => return err(format!("results folder: no run of this process is writing into {out:?} (start one with trajdb_results_begin)")),
            }
        };
        if commit {
            c.commit()
        } else {
            c.abort();
            Ok(Vec::new())
        }
    }
}

#[cfg(test)]
mod identity_tests {
    use super::*;

    /// A result file replaced by the user after the run (same name) is never deleted or
    /// overwritten by the next run; a manifest naming a file trajdb did not write is refused.
    #[test]
    fn a_changed_or_planted_file_is_refused() {
        let base = std::env::temp_dir().join(format!("trajdb-ident-{}", std::process::id()));
        let _ = fs::remove_dir_all(&base);
        let out = base.join("r");
        let c = claim(out.to_str().unwrap(), &[]).unwrap();
        fs::write(c.partial.join("report.html"), "trajdb's").unwrap();
        c.commit().unwrap();
        assert!(fs::read_to_string(out.join(MANIFEST)).unwrap().contains("report.html\t"));
        // the user saves their own report.html over it: the next claim refuses, the file stays
        std::thread::sleep(std::time::Duration::from_millis(20));
        fs::write(out.join("report.html"), "the user's own, longer text").unwrap();
        let e = claim(out.to_str().unwrap(), &[]).unwrap_err().to_string();
        assert!(e.contains("report.html changed since trajdb wrote it"), "{e}");
        assert_eq!(fs::read_to_string(out.join("report.html")).unwrap(), "the user's own, longer text");
        // a manifest naming a file trajdb never writes (planted by hand) is refused
        let planted = base.join("p");
        fs::create_dir_all(&planted).unwrap();
        fs::write(planted.join("thesis.docx"), "mine").unwrap();
        fs::write(planted.join(MANIFEST), format!("{MANIFEST_HEAD}thesis.docx\n")).unwrap();
        let e = claim(planted.to_str().unwrap(), &[]).unwrap_err().to_string();
        assert!(e.contains("a file trajdb never writes"), "{e}");
        assert!(planted.join("thesis.docx").exists());
        let _ = fs::remove_dir_all(&base);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("trajdb-outdir-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn run(out: &Path, files: &[&str]) -> Result<Vec<String>, OutError> {
        let c = claim(out.to_str().unwrap(), &[])?;
        for f in files {
            fs::write(c.partial.join(f), f).unwrap();
        }
        c.commit()
    }

    #[test]
    fn a_folder_with_user_files_is_refused_and_untouched() {
        let d = tmp("user");
        fs::write(d.join("notes.txt"), "mine").unwrap();
        let e = claim(d.to_str().unwrap(), &[]).unwrap_err().to_string();
        assert!(e.contains("already holds files that trajdb did not write") && e.contains("notes.txt"), "{e}");
        assert_eq!(fs::read_to_string(d.join("notes.txt")).unwrap(), "mine");
        assert_eq!(fs::read_dir(&d).unwrap().count(), 1);
    }

    #[test]
    fn empty_root_home_and_input_folder_are_refused() {
        assert!(claim("", &[]).unwrap_err().to_string().contains("empty"));
        assert!(claim("   ", &[]).is_err());
        assert!(claim("/", &[]).unwrap_err().to_string().contains("root"));
        let d = tmp("input");
        fs::write(d.join("points.parquet"), "x").unwrap();
        let input = d.join("points.parquet");
        let e = claim(d.to_str().unwrap(), &[input.to_str().unwrap()]).unwrap_err().to_string();
        assert!(e.contains("is or contains the input"), "{e}");
        let e = claim(d.to_str().unwrap(), &[&format!("{}/*.parquet", d.display())]).unwrap_err().to_string();
        assert!(e.contains("is or contains the input"), "{e}");
        // a pattern into sub-folders: results beneath it would be read next time
        let e = claim(d.join("results").to_str().unwrap(), &[&format!("{}/*/*.csv", d.display())]).unwrap_err().to_string();
        assert!(e.contains("lies under the folders the input pattern"), "{e}");
        assert!(!d.join("results").exists());
        // x/y/.. is x, which holds the user's file
        fs::create_dir_all(d.join("y")).unwrap();
        assert!(claim(d.join("y").join("..").to_str().unwrap(), &[]).is_err());
        assert!(input.exists());
        let f = d.join("points.parquet");
        assert!(claim(f.to_str().unwrap(), &[]).unwrap_err().to_string().contains("is a file"));
    }

    #[test]
    fn reruns_replace_only_their_own_files() {
        let d = tmp("rerun");
        let out = d.join("results");
        assert_eq!(run(&out, &["a.csv", "b.csv"]).unwrap(), ["a.csv", "b.csv"]);
        assert!(out.join(MANIFEST).exists());
        // the second run writes a.csv and c.csv: b.csv (ours) goes, a user's file added later
        // under another name stays
        fs::write(out.join("mine.txt"), "mine").unwrap();
        assert_eq!(run(&out, &["a.csv", "c.csv"]).unwrap(), ["a.csv", "c.csv"]);
        assert!(!out.join("b.csv").exists());
        assert_eq!(fs::read_to_string(out.join("mine.txt")).unwrap(), "mine");
        assert_eq!(fs::read_to_string(out.join("a.csv")).unwrap(), "a.csv");
        let left: Vec<String> = fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        assert!(!left.iter().any(|n| n.starts_with(PARTIAL_PREFIX)), "{left:?}");
        claim(out.to_str().unwrap(), &[]).unwrap().abort(); // the lock was released
    }

    #[test]
    fn a_failed_run_keeps_the_previous_results_and_its_staging_goes() {
        let d = tmp("fail");
        let out = d.join("r");
        run(&out, &["a.csv"]).unwrap();
        let c = claim(out.to_str().unwrap(), &[]).unwrap();
        fs::write(c.partial.join("a.csv"), "half").unwrap();
        let partial = c.partial.clone();
        c.abort();
        assert!(!partial.exists());
        // a failed first run into an empty folder of the user's leaves it empty
        fs::create_dir(d.join("empty")).unwrap();
        claim(d.join("empty").to_str().unwrap(), &[]).unwrap().abort();
        assert_eq!(fs::read_dir(d.join("empty")).unwrap().count(), 0);
        // a failed first run removes the folder it created
        let c = claim(d.join("new").join("deeper").to_str().unwrap(), &[]).unwrap();
        c.abort();
        assert!(!d.join("new").exists());
        // a folder in place of a result file: refused before anything moves
        let c = claim(out.to_str().unwrap(), &[]).unwrap();
        fs::write(c.partial.join("a.csv"), "new").unwrap();
        fs::write(c.partial.join("b.csv"), "new").unwrap();
        fs::create_dir(out.join("b.csv")).unwrap();
        assert!(c.commit().unwrap_err().to_string().contains("folder or a link"));
        assert_eq!(fs::read_to_string(out.join("a.csv")).unwrap(), "a.csv");
        fs::remove_dir(out.join("b.csv")).unwrap();
        assert_eq!(fs::read_to_string(out.join("a.csv")).unwrap(), "a.csv");
        claim(out.to_str().unwrap(), &[]).unwrap().abort(); // the lock was released
    }

    #[test]
    fn a_second_run_on_the_same_folder_fails_clearly_and_a_dead_lock_is_taken_over() {
        let d = tmp("lock");
        let out = d.join("r");
        run(&out, &["a.csv"]).unwrap();
        let first = claim(out.to_str().unwrap(), &[]).unwrap();
        let e = claim(out.to_str().unwrap(), &[]).unwrap_err().to_string();
        assert!(e.contains("another trajdb run is writing"), "{e}");
        first.abort();
        // a killed run: its lock file is left (unlocked: the system released it), and its
        // staging folder
        fs::write(out.join(LOCK), "999999999").unwrap();
        fs::create_dir(out.join(format!("{PARTIAL_PREFIX}999999999-0"))).unwrap();
        fs::write(out.join(format!("{PARTIAL_PREFIX}999999999-0")).join("a.csv"), "x").unwrap();
        run(&out, &["a.csv"]).unwrap();
        assert!(!out.join(format!("{PARTIAL_PREFIX}999999999-0")).exists());
    }

    #[cfg(unix)]
    #[test]
    fn a_hostile_manifest_deletes_nothing() {
        let d = tmp("hostile");
        let out = d.join("r");
        fs::create_dir_all(&out).unwrap();
        fs::write(d.join("victim.txt"), "mine").unwrap();
        fs::write(out.join(MANIFEST), format!("{MANIFEST_HEAD}../victim.txt\n")).unwrap();
        assert!(claim(out.to_str().unwrap(), &[]).unwrap_err().to_string().contains("not a plain file name"));
        assert!(d.join("victim.txt").exists());
        // a manifest trajdb did not write, or one that is a link to the user's list of files
        fs::write(out.join(MANIFEST), "victim.txt\n").unwrap();
        assert!(claim(out.to_str().unwrap(), &[]).unwrap_err().to_string().contains("not written by trajdb"));
        fs::remove_file(out.join(MANIFEST)).unwrap();
        fs::write(d.join("list.txt"), format!("{MANIFEST_HEAD}victim.txt\n")).unwrap();
        std::os::unix::fs::symlink(d.join("list.txt"), out.join(MANIFEST)).unwrap();
        assert!(claim(out.to_str().unwrap(), &[]).unwrap_err().to_string().contains("not a plain file"));
        assert!(d.join("victim.txt").exists());
    }

    #[cfg(unix)]
    #[test]
    fn a_new_results_folder_has_normal_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let d = tmp("perm");
        let out = d.join("r");
        run(&out, &["a.csv"]).unwrap();
        let mode = fs::metadata(&out).unwrap().permissions().mode() & 0o777;
        assert_ne!(mode, 0o700, "{mode:o}");
        assert_eq!(mode & 0o055, fs::metadata(&d).unwrap().permissions().mode() & 0o055);
    }
}
