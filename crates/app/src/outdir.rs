//! The results folder (`out`): the one place that decides what trajdb may write and delete.
//!
//! The rules (docs/robustness.md; docs/outputs.md):
//! - `out` is a folder that does not exist yet, a truly empty folder, or a folder holding an
//!   earlier output of trajdb OF THE SAME KIND ([`Kind`]: pipeline results, or a simulated
//!   scenario with its ground truth), recognised by the manifest [`MANIFEST`] that trajdb writes
//!   into it. Any other `out` (a folder with anything in it but a valid manifest, a scenario
//!   folder as results or a results folder as scenario, a file, `''`, `/`, the input's own
//!   folder) is refused before any work.
//! - `out` must not be or contain the input: a path, a glob, a `file://` URL, or a view (followed
//!   to the literals and quoted names of its definition and of the views it names, from the
//!   caller's `duckdb_views()`; a view that builds its paths at run time is refused when `out`
//!   holds earlier files).
//! - trajdb removes or replaces only what it can prove it created: (a) a file listed in its own
//!   manifest whose size and 64-bit content fingerprint ([`Ident`]) still match what trajdb
//!   wrote (checked when the folder is claimed and again just before each replace or remove;
//!   a file you edited, even with its size and time restored, is never touched), and (b) a
//!   staging folder `out/.trajdb-partial-*` that the manifest names (written under the lock
//!   before the folder is created with `create_dir`, which fails if anything is there), and in
//!   it only files under the names trajdb writes. A manifest line without a fingerprint, of an
//!   earlier trajdb, or not in trajdb's form makes the whole folder refused. trajdb never
//!   removes `out` itself, nor a folder it did not create in this process.
//!   That is guaranteed by construction: this module is the only code of trajdb that removes
//!   anything from a results folder ([`remove_own_file`] and [`remove_partial`] are the only
//!   calls of `remove_file` / `remove_dir` on it, besides its own temporary manifest, created
//!   with `create_new`), and both check the manifest and the fingerprint first.
//! - No file is ever opened for writing under a name that may exist: the lock is an `flock` on
//!   `out`'s own directory descriptor (no lock file; a `.trajdb-lock` of an earlier trajdb or
//!   of yours is a file like any other), the manifest is written to a new temporary name
//!   (`create_new`) and renamed over the validated manifest (or linked into place where there
//!   was none, which fails if one appeared).
//! - A run writes into its staging folder; [`Claim::commit`] checks every target, moves each
//!   file into place with `rename` (atomic per file), deletes the files of the previous
//!   manifest that this run did not write (fingerprint checked), then writes the new manifest
//!   (atomically). A failed run, or any error while claiming (a full disk included), undoes
//!   what the claim made: its staging folder, the manifest it added, the folders it created.
//!   A run killed with `kill -9` leaves its staging folder, listed in the manifest; the next
//!   run on `out` removes it.
//! - Two runs on one `out`: the second fails at once with a clear error. The system releases
//!   the `flock` when a process ends, however it ends, so a killed run leaves no stale lock.
//! - Folders are created with the process's normal permissions (umask), not 0700.
//!
//! Pure std (and serde_json for the views): used through the extension by every runner.

use std::fmt;
use std::fs;
use std::io::{Read as _, Write as _};
use std::path::{Component, Path, PathBuf};

/// The manifest: a folder that trajdb made holds this file (its kind, then one line per file
/// with its fingerprint, one per staging folder).
pub const MANIFEST: &str = ".trajdb-results";
/// The lock file of earlier trajdb versions. Never opened any more: a file of this name is
/// like any other file that trajdb did not write.
pub const LOCK: &str = ".trajdb-lock";
/// The prefix of a run's staging folder inside `out`.
pub const PARTIAL_PREFIX: &str = ".trajdb-partial-";
const MANIFEST_HEAD: &str = "# trajdb manifest 2: the files below were written by trajdb (name, size:fingerprint) and may be replaced by its next run of the same kind into this folder\n";
/// The first line of an earlier trajdb's manifest (names with size, time and inode, or none):
/// those cannot prove a file unchanged, so such a folder is refused.
const LEGACY_HEAD: &str = "# trajdb results:";

/// What a folder of trajdb's holds: a pipeline's results, or a simulated scenario (its input and
/// ground truth). A run of one kind never writes into a folder of the other.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Results,
    Scenario,
}

impl Kind {
    pub fn word(self) -> &'static str {
        match self {
            Kind::Results => "results",
            Kind::Scenario => "scenario",
        }
    }
    pub fn parse(s: &str) -> Result<Kind, OutError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "" | "results" => Ok(Kind::Results),
            "scenario" => Ok(Kind::Scenario),
            _ => err(format!("results folder: kind {s:?} unknown; give 'results' (a pipeline run) or 'scenario' (a simulation)")),
        }
    }
}

/// What the caller knows of the tables and views an input name may be.
#[derive(Clone, Copy, Debug)]
pub enum Catalog<'a> {
    /// The inputs are files (no database behind them).
    Files,
    /// An input that is no file may be a view nobody described: refused where `out` holds files.
    Unknown,
    /// The caller's views, a JSON list of {database, schema, name, sql} (duckdb_views()).
    Views(&'a str),
}

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

/// A file's identity as trajdb wrote it: its size and a 64-bit fingerprint of its bytes. A
/// content fingerprint, not a time or an inode: an edit is seen whatever times the user
/// restores, and a copied folder (new inodes, new times, same bytes) is still trajdb's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ident {
    pub size: u64,
    pub hash: u64,
}

impl Ident {
    fn text(self) -> String {
        format!("{}:{:016x}", self.size, self.hash)
    }
    fn parse(s: &str) -> Option<Ident> {
        let (a, b) = s.split_once(':')?;
        if b.len() != 16 || a.is_empty() || !a.bytes().all(|c| c.is_ascii_digit()) {
            return None;
        }
        Some(Ident { size: a.parse().ok()?, hash: u64::from_str_radix(b, 16).ok()? })
    }
}

/// The fingerprint's hash, over 8-byte little-endian words (the last one zero-padded): each step
/// `h = rotl((h ^ w) * K, 29)` is a bijection of the word for a given state and of the state for
/// a given word, so two files differing in one word always differ; any other edit collides with
/// probability about 2^-64. Fixed here (not std's hasher, which may change between releases), so
/// a manifest stays valid across builds.
struct Hash64 {
    h: u64,
    pending: [u8; 8],
    npend: usize,
    len: u64,
}

impl Hash64 {
    const K: u64 = 0x9E37_79B9_7F4A_7C15;
    fn new() -> Self {
        Hash64 { h: 0x243F_6A88_85A3_08D3, pending: [0; 8], npend: 0, len: 0 }
    }
    fn word(&mut self, w: u64) {
        self.h = ((self.h ^ w).wrapping_mul(Self::K)).rotate_left(29);
    }
    fn update(&mut self, mut b: &[u8]) {
        self.len += b.len() as u64;
        if self.npend > 0 {
            let k = (8 - self.npend).min(b.len());
            self.pending[self.npend..self.npend + k].copy_from_slice(&b[..k]);
            self.npend += k;
            b = &b[k..];
            if self.npend < 8 {
                return;
            }
            let w = u64::from_le_bytes(self.pending);
            self.word(w);
            self.npend = 0;
        }
        let mut it = b.chunks_exact(8);
        for c in &mut it {
            self.word(u64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]));
        }
        let r = it.remainder();
        self.pending[..r.len()].copy_from_slice(r);
        self.npend = r.len();
    }
    fn finish(mut self) -> u64 {
        if self.npend > 0 {
            self.pending[self.npend..].fill(0);
            let w = u64::from_le_bytes(self.pending);
            self.word(w);
        }
        // splitmix64's finaliser over the state and the length
        let mut z = self.h ^ self.len.wrapping_mul(0xD6E8_FEB8_6659_FD93);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

/// The identity of the plain file at `p` (a link or a folder is no file of trajdb's: `None`).
fn fingerprint(p: &Path) -> Result<Option<Ident>, OutError> {
    match fs::symlink_metadata(p) {
        Ok(m) if m.is_file() => {}
        Ok(_) => return Ok(None),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io("read", p, e)),
    }
    let f = fs::File::open(p).map_err(|e| io("read", p, e))?;
    if !f.metadata().map_err(|e| io("read", p, e))?.is_file() {
        return Ok(None);
    }
    fingerprint_file(f, p).map(Some)
}

/// A staging folder opened once as a directory handle (`O_DIRECTORY | O_NOFOLLOW`): every read,
/// move and removal inside it goes through that handle (`openat`, `renameat`, `unlinkat`, each
/// not following a link), never through its path again. A staging folder swapped for a link to
/// someone else's folder during a run (the hostile probe of issue 37) is then either refused
/// (the handle is not the folder this claim made) or never reached: nothing is read, moved or
/// removed through the link.
struct Staged {
    dir: fs::File,
}

impl Staged {
    fn open(p: &Path) -> std::io::Result<Staged> {
        use std::os::unix::ffi::OsStrExt;
        use std::os::unix::io::FromRawFd;
        let c = std::ffi::CString::new(p.as_os_str().as_bytes()).map_err(|_| std::io::Error::from(std::io::ErrorKind::InvalidInput))?;
        // SAFETY: a NUL-terminated path; the returned descriptor is owned by the File below
        let fd = unsafe { libc::open(c.as_ptr(), libc::O_RDONLY | libc::O_DIRECTORY | libc::O_NOFOLLOW | libc::O_CLOEXEC) };
        if fd < 0 {
            return Err(std::io::Error::last_os_error());
        }
        Ok(Staged { dir: unsafe { fs::File::from_raw_fd(fd) } })
    }

    /// (device, inode) of the folder the handle holds.
    fn id(&self) -> std::io::Result<(u64, u64)> {
        use std::os::unix::fs::MetadataExt;
        let m = self.dir.metadata()?;
        Ok((m.dev(), m.ino()))
    }

    fn fd(&self) -> libc::c_int {
        use std::os::unix::io::AsRawFd;
        self.dir.as_raw_fd()
    }

    fn cname(name: &str) -> std::io::Result<std::ffi::CString> {
        std::ffi::CString::new(name).map_err(|_| std::io::Error::from(std::io::ErrorKind::InvalidInput))
    }

    /// `name` inside, opened for reading when it is a plain file (a link is not followed:
    /// `None`, as for a missing name or a folder).
    fn open_file(&self, name: &str) -> std::io::Result<Option<fs::File>> {
        use std::os::unix::io::FromRawFd;
        let c = Self::cname(name)?;
        // SAFETY: a NUL-terminated name relative to our open directory descriptor
        let fd = unsafe { libc::openat(self.fd(), c.as_ptr(), libc::O_RDONLY | libc::O_NOFOLLOW | libc::O_CLOEXEC | libc::O_NONBLOCK) };
        if fd < 0 {
            let e = std::io::Error::last_os_error();
            return match e.raw_os_error() {
                Some(libc::ENOENT) | Some(libc::ELOOP) | Some(libc::ENOTDIR) => Ok(None),
                _ => Err(e),
            };
        }
        let f = unsafe { fs::File::from_raw_fd(fd) };
        Ok(if f.metadata()?.is_file() { Some(f) } else { None })
    }

    /// Moves `name` out of the folder to `target` (renameat: the link itself, never its target).
    fn rename_to(&self, name: &str, target: &Path) -> std::io::Result<()> {
        use std::os::unix::ffi::OsStrExt;
        let (c, t) = (Self::cname(name)?, std::ffi::CString::new(target.as_os_str().as_bytes()).map_err(|_| std::io::Error::from(std::io::ErrorKind::InvalidInput))?);
        // SAFETY: NUL-terminated names; the source is relative to our directory descriptor
        if unsafe { libc::renameat(self.fd(), c.as_ptr(), libc::AT_FDCWD, t.as_ptr()) } != 0 {
            return Err(std::io::Error::last_os_error());
        }
        Ok(())
    }

    /// Removes the plain file `name` inside (a link or folder under the name stays).
    fn remove_file(&self, name: &str) -> std::io::Result<()> {
        if self.open_file(name)?.is_none() {
            return Ok(());
        }
        let c = Self::cname(name)?;
        // SAFETY: a NUL-terminated name relative to our directory descriptor
        if unsafe { libc::unlinkat(self.fd(), c.as_ptr(), 0) } != 0 {
            return Err(std::io::Error::last_os_error());
        }
        Ok(())
    }
}

/// The fingerprint of an open file (see [`fingerprint`]).
fn fingerprint_file(mut f: fs::File, p: &Path) -> Result<Ident, OutError> {
    let mut h = Hash64::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        match f.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => h.update(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(io("read", p, e)),
        }
    }
    let size = h.len;
    Ok(Ident { size, hash: h.finish() })
}

/// A folder's manifest as trajdb wrote it.
#[derive(Clone, Debug)]
struct Manifest {
    kind: Kind,
    /// Each file trajdb wrote, with its identity (a name may be listed twice while a commit
    /// moves the new file over the old one: either identity is trajdb's).
    files: Vec<(String, Ident)>,
    /// Staging folders trajdb created (named here before they were made).
    staging: Vec<String>,
}

impl Manifest {
    fn names(&self) -> Vec<String> {
        let mut v: Vec<String> = self.files.iter().map(|(n, _)| n.clone()).collect();
        v.sort();
        v.dedup();
        v
    }
    fn lists(&self, name: &str) -> bool {
        self.files.iter().any(|(n, _)| n == name)
    }
    fn owns(&self, name: &str, id: Ident) -> bool {
        self.files.iter().any(|(n, i)| n == name && *i == id)
    }
}

/// `dir`'s manifest, checked: `None` when there is none. Anything not exactly in trajdb's form
/// (another user's, a link, an earlier trajdb's, a line without a fingerprint, a name that is
/// not a plain file name) refuses the folder; a listed file whose bytes changed since trajdb
/// wrote them refuses it too (trajdb will not replace or delete it).
fn read_manifest(dir: &Path) -> Result<Option<Manifest>, OutError> {
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
    if text.starts_with(LEGACY_HEAD) {
        return err(format!(
            "results folder {}: its {MANIFEST} was written by an earlier trajdb, whose file identities (size, time, inode) cannot prove \
             the files unchanged; trajdb will not replace or delete by it: move those results away, or pick another out",
            dir.display()
        ));
    }
    if !text.starts_with(MANIFEST_HEAD) {
        return err(format!(
            "results folder {}: its {MANIFEST} was not written by trajdb (its first line is not trajdb's); trajdb will not delete by it (pick another out)",
            dir.display()
        ));
    }
    let refuse = |line: &str, why: &str| {
        err(format!(
            "results folder {}: its {MANIFEST} has the line {line:?}, {why}; trajdb will not delete by it (remove the folder yourself, or pick another out)",
            dir.display()
        ))
    };
    let mut kind = None;
    let (mut files, mut staging) = (Vec::new(), Vec::new());
    for line in text.lines().skip(1).filter(|l| !l.is_empty()) {
        let f: Vec<&str> = line.split('\t').collect();
        match f.as_slice() {
            ["kind", k] if kind.is_none() && (*k == "results" || *k == "scenario") => kind = Some(Kind::parse(k)?),
            ["file", name, id] => {
                if !plain_name(name) {
                    return refuse(line, "which is not a plain file name");
                }
                let Some(id) = Ident::parse(id) else { return refuse(line, "whose file has no fingerprint trajdb wrote") };
                files.push((name.to_string(), id));
            }
            ["staging", name] if staging_name(name) => staging.push(name.to_string()),
            [_] => return refuse(line, "a name without the fingerprint trajdb writes"),
            _ => return refuse(line, "not a line trajdb writes"),
        }
    }
    let Some(kind) = kind else { return refuse("", "no kind (results or scenario)") };
    let m = Manifest { kind, files, staging };
    for name in m.names() {
        if let Some(id) = fingerprint(&dir.join(&name))? {
            if !m.owns(&name, id) {
                return err(format!(
                    "results folder {}: {name} changed since trajdb wrote it (or is another file under its name); trajdb will not \
                     replace or delete it: move it away, or pick another out",
                    dir.display()
                ));
            }
        }
    }
    Ok(Some(m))
}

/// Every file name trajdb writes into a results or scenario folder (sql/export.sql,
/// sql/report.sql, the simulator and trajdb.simulate's points.parquet): the only names removed
/// from a staging folder.
pub const WRITTEN_NAMES: &[&str] = &[
    "transforms.csv", "calibration.csv", "matches.csv", "merged.parquet", "clusters.csv", "links.csv", "report.html", "analysis.sql",
    "points.csv", "points.parquet", "cameras.csv", "truth.csv", "objects.csv", "world.csv", "README.txt",
];

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

/// A file name with no separator or line break, not `.`/`..`, not one of trajdb's control names.
fn plain_name(s: &str) -> bool {
    !s.is_empty()
        && s != "."
        && s != ".."
        && !s.contains(['/', '\\', '\0', '\t', '\n', '\r'])
        && s != MANIFEST
        && !s.starts_with(&format!("{MANIFEST}."))
        && !s.starts_with(PARTIAL_PREFIX)
}

/// A staging folder's name: trajdb's prefix, no separator or line break.
fn staging_name(s: &str) -> bool {
    s.starts_with(PARTIAL_PREFIX) && s.len() > PARTIAL_PREFIX.len() && !s.contains(['/', '\\', '\0', '\t', '\n', '\r'])
}

/// A number no other process or call picks: pid, a sequence and the clock's nanoseconds mixed.
fn unique() -> String {
    let n = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let t = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos() as u64).unwrap_or(0);
    let mut h = Hash64::new();
    h.update(&t.to_le_bytes());
    h.update(&n.to_le_bytes());
    h.update(&(&h as *const Hash64 as usize as u64).to_le_bytes());
    format!("{}-{n}-{:08x}", std::process::id(), h.finish() as u32)
}

/// A results folder claimed for one run: the lock is held, the staging folder exists.
#[derive(Debug)]
pub struct Claim {
    pub out: PathBuf,
    pub partial: PathBuf,
    /// The manifest as it is on disk (once this claim has written it).
    manifest: Manifest,
    /// The folders this claim created (`out` and any missing parents, innermost first): a
    /// failed first run removes them again while they are empty.
    created: Vec<PathBuf>,
    /// This claim wrote the first manifest into `out` (new or empty).
    fresh: bool,
    manifest_written: bool,
    partial_made: bool,
    /// (device, inode) of the staging folder this claim created: the commit and the abort act
    /// only on that folder, through a handle ([`Staged`]).
    partial_id: Option<(u64, u64)>,
    lock: Option<fs::File>,
    done: bool,
}

static SEQ: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

#[cfg(test)]
thread_local! {
    /// A fault injected by the tests of this thread: 1 = writing the manifest fails (a full
    /// disk), 2 = creating the staging folder fails.
    static FAIL: std::cell::Cell<u8> = const { std::cell::Cell::new(0) };
}

/// [`claim_checked`] for inputs that are files (no database behind them).
pub fn claim(out: &str, inputs: &[&str], kind: Kind) -> Result<Claim, OutError> {
    claim_checked(out, inputs, Catalog::Files, kind)
}

/// Checks `out` against the rules above and claims it for a run of `kind`: creates it (and its
/// parents) when missing, takes the lock, checks the folder under it, removes stale staging
/// folders of killed runs, creates this run's staging folder. `inputs` are the run's input
/// strings (paths, globs, `file://` URLs or table and view names, described by `catalog`). Any
/// error undoes what the call made.
pub fn claim_checked(out: &str, inputs: &[&str], catalog: Catalog<'_>, kind: Kind) -> Result<Claim, OutError> {
    if out.trim().is_empty() {
        return err("results folder: out is '' (empty); name a new folder, e.g. out='results'".into());
    }
    let dir = absolute(out)?;
    if dir.parent().is_none() {
        return err(format!("results folder: out {out:?} is the root folder; name a new folder, e.g. out='results'"));
    }
    check_inputs(&dir, out, inputs, catalog)?;
    let mut created = Vec::new();
    if fs::symlink_metadata(&dir).is_ok() || dir.exists() {
        if !dir.is_dir() {
            return err(format!("results folder: out {out:?} ({}) is a file, not a folder; name a new folder", dir.display()));
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
    }
    let partial = dir.join(format!("{PARTIAL_PREFIX}{}", unique()));
    // from here on, dropping the claim (any `?` below) undoes what it made
    let mut c = Claim {
        out: dir.clone(),
        partial,
        manifest: Manifest { kind, files: Vec::new(), staging: Vec::new() },
        created,
        fresh: false,
        manifest_written: false,
        partial_made: false,
        partial_id: None,
        lock: None,
        done: false,
    };
    if !c.created.is_empty() {
        fs::create_dir_all(&dir).map_err(|e| io("create", &dir, e))?;
    }
    // the lock first, then everything else under it
    c.lock = Some(lock_dir(&dir, out)?);
    match read_manifest(&dir)? {
        Some(m) if m.kind != kind => return err(kind_refusal(out, &dir, m.kind)),
        Some(m) => c.manifest = m,
        None => {
            // no manifest: only a truly empty folder is free (a name that looks like trajdb's
            // is the user's as much as any other)
            if let Some(first) = fs::read_dir(&dir).map_err(|e| io("list", &dir, e))?.next() {
                let first = first.map_err(|e| io("list", &dir, e))?.file_name();
                return err(format!(
                    "results folder: out {out:?} ({}) already holds files that trajdb did not write (e.g. {:?}); \
                     trajdb writes only into a new folder, an empty one, or one with its own earlier {}: name another out, e.g. out='{}'",
                    dir.display(),
                    first.to_string_lossy(),
                    kind.word(),
                    Path::new(out).join(format!("trajdb-{}", kind.word())).display()
                ));
            }
            c.fresh = true;
        }
    }
    // staging folders the manifest names are dead runs' (we hold the lock): remove what can be
    // proven ours; one holding anything else stays, listed
    let stale = std::mem::take(&mut c.manifest.staging);
    for s in stale {
        if !remove_partial(&dir, &dir.join(&s), None)? {
            c.manifest.staging.push(s);
        }
    }
    // named in the manifest before it exists, so that a killed run's folder is known as ours
    let name = c.partial.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    c.manifest.staging.push(name);
    write_manifest(&dir, &c.manifest, c.fresh)?;
    c.manifest_written = true;
    #[cfg(test)]
    if FAIL.with(|f| f.get()) == 2 {
        return err("injected: no space left on device".into());
    }
    fs::create_dir(&c.partial).map_err(|e| io("create", &c.partial, e))?;
    c.partial_made = true;
    c.partial_id = Some(Staged::open(&c.partial).and_then(|d| d.id()).map_err(|e| io("open", &c.partial, e))?);
    Ok(c)
}

fn kind_refusal(out: &str, dir: &Path, found: Kind) -> String {
    let base = Path::new(out);
    match found {
        Kind::Scenario => format!(
            "results folder: out {out:?} ({}) holds a scenario written by trajdb simulate (its input and ground truth: points, truth, \
             cameras, world); a pipeline run never replaces those: put the results in a folder of their own, e.g. out='{}'",
            dir.display(),
            base.join("results").display()
        ),
        Kind::Results => format!(
            "results folder: out {out:?} ({}) holds the results of a trajdb pipeline run; a simulation never replaces them: write the \
             scenario into a folder of its own, e.g. '{}'",
            dir.display(),
            base.join("scenario").display()
        ),
    }
}

/// The run's lock: an advisory lock (`flock`) on `out`'s own directory descriptor (opened for
/// reading: no file is created or written), held for as long as the claim lives and released
/// by the system when the process ends however it ends.
fn lock_dir(dir: &Path, out: &str) -> Result<fs::File, OutError> {
    let f = fs::File::open(dir).map_err(|e| io("open", dir, e))?;
    match f.try_lock() {
        Ok(()) => {
            // the folder locked must still be the one at the path
            #[cfg(unix)]
            {
                use std::os::unix::fs::MetadataExt;
                let same = match (f.metadata(), fs::metadata(dir)) {
                    (Ok(a), Ok(b)) => a.ino() == b.ino() && a.dev() == b.dev() && a.is_dir(),
                    _ => false,
                };
                if !same {
                    return err(format!("results folder: out {out:?} was replaced while this run started; run again"));
                }
            }
            Ok(f)
        }
        Err(fs::TryLockError::WouldBlock) => err(format!(
            "results folder: another trajdb run is writing into out {out:?} (it holds the folder's lock); wait for it to finish, or pick another out"
        )),
        Err(fs::TryLockError::Error(e)) => Err(io("lock", dir, e)),
    }
}

/// Removes a staging folder of ours (named in the manifest, directly in `dir`, trajdb's
/// prefix): the files in it under names trajdb writes, then the folder if it is empty.
/// Returns whether it is gone (`false`: it holds something else and stays).
fn remove_partial(dir: &Path, partial: &Path, expect: Option<(u64, u64)>) -> Result<bool, OutError> {
    let ours = partial.parent() == Some(dir) && partial.file_name().is_some_and(|n| staging_name(&n.to_string_lossy()));
    if !ours {
        return err(format!("results folder: refusing to remove {}: not a staging folder of trajdb", partial.display()));
    }
    match fs::symlink_metadata(partial) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(true),
        Err(e) => return Err(io("read", partial, e)),
        // a file or link under the name: not the folder trajdb made; no longer listed
        Ok(m) if !m.is_dir() => return Ok(true),
        Ok(_) => {}
    }
    // through one handle that never follows a link (a link swapped in meanwhile fails to open)
    let Ok(d) = Staged::open(partial) else { return Ok(false) };
    if expect.is_some_and(|want| d.id().ok() != Some(want)) {
        return Ok(false); // another folder under the name now: not ours, left alone
    }
    for n in WRITTEN_NAMES.iter().copied().chain([MANIFEST]) {
        let _ = d.remove_file(n);
    }
    // remove_dir, not remove_dir_all: anything else in there stops it
    Ok(fs::remove_dir(partial).is_ok())
}

/// Removes one result file of an earlier run: a plain name the manifest lists, whose bytes are
/// still those trajdb wrote (checked now). Returns whether it was removed.
fn remove_own_file(dir: &Path, name: &str, manifest: &Manifest) -> Result<bool, OutError> {
    if !plain_name(name) || !manifest.lists(name) {
        return err(format!("results folder: refusing to remove {name:?}: not a result file that trajdb wrote"));
    }
    let p = dir.join(name);
    match fingerprint(&p)? {
        Some(id) if manifest.owns(name, id) => fs::remove_file(&p).map(|()| true).map_err(|e| io("remove", &p, e)),
        _ => Ok(false), // gone, a folder or link, or changed: not ours any more, left alone
    }
}

/// Writes `m` as `dir`'s manifest: into a new temporary file (`create_new`, a name no one else
/// picks), then renamed over the manifest read under the lock, or, where there was none
/// (`fresh`), linked into place (which fails if one appeared). The temporary file is removed on
/// any error (it is ours: this call created it).
fn write_manifest(dir: &Path, m: &Manifest, fresh: bool) -> Result<(), OutError> {
    let tmp = dir.join(format!("{MANIFEST}.{}.tmp", unique()));
    let mut text = String::from(MANIFEST_HEAD);
    text.push_str(&format!("kind\t{}\n", m.kind.word()));
    for (n, id) in &m.files {
        text.push_str(&format!("file\t{n}\t{}\n", id.text()));
    }
    for s in &m.staging {
        text.push_str(&format!("staging\t{s}\n"));
    }
    let mut f = fs::OpenOptions::new().write(true).create_new(true).open(&tmp).map_err(|e| io("write", &tmp, e))?;
    let target = dir.join(MANIFEST);
    let r = f
        .write_all(text.as_bytes())
        .and_then(|()| {
            #[cfg(test)]
            if FAIL.with(|f| f.get()) == 1 {
                return Err(std::io::Error::other("injected: no space left on device"));
            }
            Ok(())
        })
        .and_then(|()| f.sync_all())
        .map_err(|e| io("write", &tmp, e))
        .and_then(|()| {
            if fresh && fs::symlink_metadata(&target).is_err() {
                fs::hard_link(&tmp, &target).map_err(|e| io("write", &target, e))
            } else if fresh {
                err(format!("results folder {}: a {MANIFEST} appeared there while this run started; nothing was written (run again)", dir.display()))
            } else {
                fs::rename(&tmp, &target).map_err(|e| io("write", &target, e))
            }
        });
    drop(f);
    if r.is_err() || fresh {
        let _ = fs::remove_file(&tmp);
    }
    r
}

impl Claim {
    /// Moves this run's files into place, removes the earlier run's files that this run did not
    /// write, writes the manifest, drops the staging folder and the lock. Returns the file names.
    pub fn commit(mut self) -> Result<Vec<String>, OutError> {
        // the staging folder through one handle, and only if it is the folder this claim made
        // (a link or another folder swapped in under its name is refused: [`Staged`])
        let staged = Staged::open(&self.partial).map_err(|e| io("open the staging folder", &self.partial, e))?;
        if self.partial_id.is_none() || staged.id().ok() != self.partial_id {
            return err(format!(
                "results folder {}: its staging folder {} was replaced during the run; nothing was replaced (run again)",
                self.out.display(),
                self.partial.display()
            ));
        }
        // only the names trajdb writes, each a plain file (never a link) inside that folder
        let mut names = Vec::new();
        let mut new = Vec::new();
        for n in WRITTEN_NAMES {
            if let Some(f) = staged.open_file(n).map_err(|e| io("read", &self.partial.join(n), e))? {
                new.push((n.to_string(), fingerprint_file(f, &self.partial.join(n))?));
                names.push(n.to_string());
            }
        }
        let order: Vec<usize> = {
            let mut k: Vec<usize> = (0..names.len()).collect();
            k.sort_by(|&a, &b| names[a].cmp(&names[b]));
            k
        };
        let names: Vec<String> = order.iter().map(|&k| names[k].clone()).collect();
        let new: Vec<(String, Ident)> = order.iter().map(|&k| new[k].clone()).collect();
        // every target must be replaceable (absent, or a file trajdb wrote whose bytes are
        // unchanged): checked for all before the first is moved, so that a refusal never leaves
        // a mixed set
        for n in &names {
            let target = self.out.join(n);
            match fs::symlink_metadata(&target) {
                Err(_) => {}
                Ok(m) if !m.is_file() => {
                    return err(format!(
                        "results folder {}: {n} there is a folder or a link, not a result file of trajdb's; nothing was replaced (move it away and run again)",
                        self.out.display()
                    ))
                }
                Ok(_) if !self.manifest.lists(n) => {
                    return err(format!(
                        "results folder {}: {n} appeared there during the run and is not trajdb's; nothing was replaced",
                        self.out.display()
                    ))
                }
                Ok(_) => match fingerprint(&target)? {
                    Some(id) if self.manifest.owns(n, id) => {}
                    _ => {
                        return err(format!(
                            "results folder {}: {n} changed since trajdb wrote it; nothing was replaced (move it away and run again)",
                            self.out.display()
                        ))
                    }
                },
            }
        }
        // the manifest lists old and new identities while files move, so that a run killed in
        // between leaves every file listed (and removable by the next run)
        let previous = self.manifest.names();
        let mut during = self.manifest.clone();
        during.files.extend(new.iter().cloned());
        write_manifest(&self.out, &during, false)?;
        self.manifest = during;
        for n in &names {
            let to = self.out.join(n);
            staged.rename_to(n, &to).map_err(|e| io("move a result file into", &to, e))?;
        }
        for old in previous.iter().filter(|o| !names.contains(o)) {
            remove_own_file(&self.out, old, &self.manifest)?;
        }
        let staging_gone = remove_partial(&self.out, &self.partial, self.partial_id)?;
        self.partial_made = !staging_gone;
        let mut fin = Manifest { kind: self.manifest.kind, files: new, staging: self.manifest.staging.clone() };
        if staging_gone {
            let ours = self.partial.file_name().map(|n| n.to_string_lossy().into_owned());
            fin.staging.retain(|s| Some(s) != ours.as_ref());
        }
        write_manifest(&self.out, &fin, false)?;
        self.manifest = fin;
        self.done = true;
        self.lock = None;
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
        self.done = true;
        // while the lock is still held: the staging folder, then the manifest's line for it (or
        // the whole manifest, where this claim wrote the first one and the folder holds nothing
        // else)
        let gone = !self.partial_made || remove_partial(&self.out, &self.partial, self.partial_id).unwrap_or(false);
        if self.manifest_written && gone {
            let ours = self.partial.file_name().map(|n| n.to_string_lossy().into_owned());
            self.manifest.staging.retain(|s| Some(s) != ours.as_ref());
            let only_manifest = fs::read_dir(&self.out).map(|d| d.flatten().all(|e| e.file_name() == MANIFEST)).unwrap_or(false);
            if self.fresh && self.manifest.files.is_empty() && self.manifest.staging.is_empty() && only_manifest {
                let _ = fs::remove_file(self.out.join(MANIFEST));
            } else {
                let _ = write_manifest(&self.out, &self.manifest, false);
            }
        }
        // the folders this run created, while they are empty (remove_dir only removes an
        // empty folder), and only while this claim holds the lock: a claim that lost the race
        // for it does not own the folder it happened to create first (the winner, holding the
        // lock on that folder, is about to write its manifest there)
        if self.lock.is_some() {
            for d in &self.created {
                if fs::remove_dir(d).is_err() {
                    break;
                }
            }
        }
        self.lock = None;
    }
}

impl Drop for Claim {
    fn drop(&mut self) {
        self.abort_inner();
    }
}

/// The input checks: `out` must not be or contain a file the run reads.
fn check_inputs(dir: &Path, out: &str, inputs: &[&str], catalog: Catalog<'_>) -> Result<(), OutError> {
    let has_files = fs::symlink_metadata(dir.join(MANIFEST)).is_ok();
    for input in inputs.iter().filter(|i| !i.trim().is_empty()) {
        if check_path(dir, out, input, input, None)? {
            continue;
        }
        match catalog {
            Catalog::Files => {}
            Catalog::Unknown if has_files && !looks_like_a_file(input) => {
                return err(format!(
                    "results folder: the input {input:?} is no file trajdb can see (a table or view?) and out {out:?} holds earlier files; \
                     trajdb cannot tell whether the input reads them: run through trajdb_stages (which describes the views), or pick a new out"
                ))
            }
            Catalog::Unknown => {}
            Catalog::Views(json) => check_views(dir, out, input, json, has_files)?,
        }
    }
    Ok(())
}

/// A missing file rather than a table or view name: a separator, or a data file's extension.
fn looks_like_a_file(input: &str) -> bool {
    let l = input.to_ascii_lowercase();
    l.contains('/')
        || [".parquet", ".csv", ".tsv", ".json", ".ndjson", ".jsonl", ".txt", ".gz", ".zst"].iter().any(|e| l.ends_with(e))
}

/// `path` (a path, a glob or a `file://` URL) checked against `out`; `false` when it names no
/// local file or folder (a table name, a remote URL, a file that does not exist).
fn check_path(dir: &Path, out: &str, input: &str, path: &str, view: Option<&str>) -> Result<bool, OutError> {
    let local = match file_url(path) {
        Some(p) => p,
        None if path.contains("://") => return Ok(false),
        None => path.to_string(),
    };
    let Some((inp, deep)) = input_path(&local) else { return Ok(false) };
    let what = match view {
        Some(v) => format!("the input {input:?} (the view {v} reads {path:?})"),
        None => format!("the input {input:?}"),
    };
    if inp.starts_with(dir) {
        return err(format!(
            "results folder: out {out:?} ({}) is or contains {what}; results go into a folder of their own, e.g. out='results'",
            dir.display()
        ));
    }
    // a pattern that reaches into sub-folders would read the results as input next time
    if deep && dir.starts_with(&inp) {
        return err(format!(
            "results folder: out {out:?} ({}) lies under the folders {what} reads, so the next run would read the results as input; \
             put the results outside {}",
            dir.display(),
            inp.display()
        ));
    }
    Ok(true)
}

/// The local path of a `file://` URL (`file:///a/b`, `file://localhost/a/b`).
fn file_url(s: &str) -> Option<String> {
    let rest = s.get(..7).filter(|p| p.eq_ignore_ascii_case("file://")).map(|_| &s[7..])?;
    let rest = rest.strip_prefix("localhost").unwrap_or(rest);
    if rest.starts_with('/') {
        Some(rest.to_string())
    } else {
        Some(format!("/{rest}")) // file://a/b: no host but a relative-looking path; read as absolute (refuse rather than miss)
    }
}

#[derive(serde::Deserialize)]
struct View {
    #[serde(default)]
    database: Option<String>,
    #[serde(default)]
    schema: Option<String>,
    name: String,
    #[serde(default)]
    sql: Option<String>,
}

/// A view input followed to the files it reads: every string literal and quoted name in its
/// definition, and in the definitions of the views it names (by any word), is checked as a path.
/// A file reader whose argument is built at run time (not a literal) cannot be followed: refused
/// when `out` holds earlier files.
fn check_views(dir: &Path, out: &str, input: &str, json: &str, has_files: bool) -> Result<(), OutError> {
    let views: Vec<View> = serde_json::from_str(json)
        .map_err(|e| OutError(format!("results folder: views must be the JSON list of duckdb_views() (database, schema, name, sql): {e}")))?;
    let key = input.to_lowercase();
    let forms = |v: &View| {
        let (d, s, n) = (v.database.clone().unwrap_or_default(), v.schema.clone().unwrap_or_default(), v.name.clone());
        [n.clone(), format!("{s}.{n}"), format!("{d}.{n}"), format!("{d}.{s}.{n}")].map(|f| f.to_lowercase())
    };
    let mut seen = vec![false; views.len()];
    let mut todo: Vec<usize> = (0..views.len()).filter(|&k| forms(&views[k]).contains(&key)).collect();
    for &k in &todo {
        seen[k] = true;
    }
    while let Some(k) = todo.pop() {
        let v = &views[k];
        let scan = scan_sql(v.sql.as_deref().unwrap_or(""));
        for lit in &scan.literals {
            check_path(dir, out, input, lit, Some(&v.name))?;
        }
        if scan.dynamic && has_files {
            return err(format!(
                "results folder: the input {input:?} is a view ({}) that reads files whose names it builds at run time, so trajdb cannot \
                 tell whether they lie in out {out:?}, which holds earlier files; pick a new out, or make the input a table \
                 (CREATE TABLE t AS FROM {})",
                v.name, v.name
            ));
        }
        for (j, w) in views.iter().enumerate() {
            if !seen[j] && scan.words.contains(&w.name.to_lowercase()) {
                seen[j] = true;
                todo.push(j);
            }
        }
    }
    Ok(())
}

struct Scan {
    literals: Vec<String>,
    words: Vec<String>,
    dynamic: bool,
}

/// The string literals, quoted names and words of an SQL text, and whether a file reader
/// (`read_*`, `*_scan`, `query`, `query_table`, `glob`) takes anything but a literal first.
fn scan_sql(sql: &str) -> Scan {
    let c: Vec<char> = sql.chars().collect();
    let mut s = Scan { literals: Vec::new(), words: Vec::new(), dynamic: false };
    let mut k = 0;
    while k < c.len() {
        let q = c[k];
        if q == '\'' || q == '"' {
            let mut v = String::new();
            k += 1;
            while k < c.len() {
                if c[k] == q {
                    if c.get(k + 1) == Some(&q) {
                        v.push(q);
                        k += 2;
                        continue;
                    }
                    break;
                }
                v.push(c[k]);
                k += 1;
            }
            k += 1;
            if q == '"' {
                s.words.push(v.to_lowercase());
            }
            s.literals.push(v);
        } else if q.is_alphanumeric() || q == '_' {
            let start = k;
            while k < c.len() && (c[k].is_alphanumeric() || c[k] == '_') {
                k += 1;
            }
            let w: String = c[start..k].iter().collect::<String>().to_lowercase();
            let mut j = k;
            while j < c.len() && c[j].is_whitespace() {
                j += 1;
            }
            let reader = w.starts_with("read_") || w.ends_with("_scan") || w == "query" || w == "query_table" || w == "glob";
            if reader && c.get(j) == Some(&'(') {
                j += 1;
                while j < c.len() && c[j].is_whitespace() {
                    j += 1;
                }
                if !matches!(c.get(j), Some('\'') | Some('"') | Some('[')) {
                    s.dynamic = true;
                }
            }
            s.words.push(w);
        } else {
            k += 1;
        }
    }
    s
}

/// Claims that outlive one SQL call (the extension's `trajdb_results_begin` / `_end`): by
/// staging folder path.
pub mod open {
    use super::*;
    use std::sync::Mutex;

    static OPEN: Mutex<Vec<Claim>> = Mutex::new(Vec::new());

    /// [`claim_checked`], kept open; returns the staging folder to export into.
    pub fn begin(out: &str, inputs: &[&str], catalog: Catalog<'_>, kind: Kind) -> Result<PathBuf, OutError> {
        let c = claim_checked(out, inputs, catalog, kind)?;
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
        let c = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap();
        fs::write(c.partial.join("report.html"), "trajdb's").unwrap();
        c.commit().unwrap();
        assert!(fs::read_to_string(out.join(MANIFEST)).unwrap().contains("file\treport.html\t"));
        // the user saves their own report.html over it: the next claim refuses, the file stays
        std::thread::sleep(std::time::Duration::from_millis(20));
        fs::write(out.join("report.html"), "the user's own, longer text").unwrap();
        let e = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("report.html changed since trajdb wrote it"), "{e}");
        assert_eq!(fs::read_to_string(out.join("report.html")).unwrap(), "the user's own, longer text");
        // a manifest naming a file trajdb never writes (planted by hand) is refused
        let planted = base.join("p");
        fs::create_dir_all(&planted).unwrap();
        fs::write(planted.join("thesis.docx"), "mine").unwrap();
        fs::write(planted.join(MANIFEST), format!("{MANIFEST_HEAD}kind\tresults\nthesis.docx\n")).unwrap();
        let e = claim(planted.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("a name without the fingerprint"), "{e}");
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
        let c = claim(out.to_str().unwrap(), &[], Kind::Results)?;
        for f in files {
            fs::write(c.partial.join(f), f).unwrap();
        }
        c.commit()
    }

    #[test]
    fn a_folder_with_user_files_is_refused_and_untouched() {
        let d = tmp("user");
        fs::write(d.join("notes.txt"), "mine").unwrap();
        let e = claim(d.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("already holds files that trajdb did not write") && e.contains("notes.txt"), "{e}");
        assert_eq!(fs::read_to_string(d.join("notes.txt")).unwrap(), "mine");
        assert_eq!(fs::read_dir(&d).unwrap().count(), 1);
    }

    #[test]
    fn empty_root_home_and_input_folder_are_refused() {
        assert!(claim("", &[], Kind::Results).unwrap_err().to_string().contains("empty"));
        assert!(claim("   ", &[], Kind::Results).is_err());
        assert!(claim("/", &[], Kind::Results).unwrap_err().to_string().contains("root"));
        let d = tmp("input");
        fs::write(d.join("points.parquet"), "x").unwrap();
        let input = d.join("points.parquet");
        let e = claim(d.to_str().unwrap(), &[input.to_str().unwrap()], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("is or contains the input"), "{e}");
        let e = claim(d.to_str().unwrap(), &[&format!("{}/*.parquet", d.display())], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("is or contains the input"), "{e}");
        // a pattern into sub-folders: results beneath it would be read next time
        let e = claim(d.join("results").to_str().unwrap(), &[&format!("{}/*/*.csv", d.display())], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("lies under the folders the input"), "{e}");
        assert!(!d.join("results").exists());
        // x/y/.. is x, which holds the user's file
        fs::create_dir_all(d.join("y")).unwrap();
        assert!(claim(d.join("y").join("..").to_str().unwrap(), &[], Kind::Results).is_err());
        assert!(input.exists());
        let f = d.join("points.parquet");
        assert!(claim(f.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string().contains("is a file"));
    }

    /// The hostile probe of issue 37: the staging folder swapped for a link to someone else's
    /// folder during the run. The commit refuses (the handle is not the folder the claim made),
    /// the abort removes nothing through the link, and the other folder is untouched.
    #[cfg(unix)]
    #[test]
    fn a_staging_folder_swapped_for_a_link_moves_and_removes_nothing() {
        let d = tmp("swap");
        let out = d.join("results");
        run(&out, &["matches.csv"]).unwrap();
        let victim = d.join("victim");
        fs::create_dir(&victim).unwrap();
        for n in ["report.html", "points.csv", "notes.txt"] {
            fs::write(victim.join(n), format!("the user's {n}")).unwrap();
        }
        for commit in [true, false] {
            let c = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap();
            fs::write(c.partial.join("report.html"), "ours").unwrap();
            let aside = d.join(format!("aside-{commit}"));
            fs::rename(&c.partial, &aside).unwrap();
            std::os::unix::fs::symlink(&victim, &c.partial).unwrap();
            if commit {
                let e = c.commit().unwrap_err().to_string();
                assert!(e.contains("staging folder"), "{e}");
            } else {
                c.abort();
            }
            for n in ["report.html", "points.csv", "notes.txt"] {
                assert_eq!(fs::read_to_string(victim.join(n)).unwrap(), format!("the user's {n}"), "{n} (commit {commit})");
            }
            assert!(!out.join("report.html").exists() && !out.join("notes.txt").exists());
            assert_eq!(fs::read_to_string(out.join("matches.csv")).unwrap(), "matches.csv");
            let link = fs::read_dir(&out).unwrap().flatten().find(|e| e.file_type().unwrap().is_symlink()).unwrap();
            fs::remove_file(link.path()).unwrap();
        }
    }

    #[test]
    fn reruns_replace_only_their_own_files() {
        let d = tmp("rerun");
        let out = d.join("results");
        assert_eq!(run(&out, &["matches.csv", "links.csv"]).unwrap(), ["links.csv", "matches.csv"]);
        assert!(out.join(MANIFEST).exists());
        // the second run writes matches.csv and clusters.csv: links.csv (ours) goes, a user's file added later
        // under another name stays
        fs::write(out.join("mine.txt"), "mine").unwrap();
        assert_eq!(run(&out, &["matches.csv", "clusters.csv"]).unwrap(), ["clusters.csv", "matches.csv"]);
        assert!(!out.join("links.csv").exists());
        assert_eq!(fs::read_to_string(out.join("mine.txt")).unwrap(), "mine");
        assert_eq!(fs::read_to_string(out.join("matches.csv")).unwrap(), "matches.csv");
        let left: Vec<String> = fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        assert!(!left.iter().any(|n| n.starts_with(PARTIAL_PREFIX)), "{left:?}");
        claim(out.to_str().unwrap(), &[], Kind::Results).unwrap().abort(); // the lock was released
    }

    #[test]
    fn a_failed_run_keeps_the_previous_results_and_its_staging_goes() {
        let d = tmp("fail");
        let out = d.join("r");
        run(&out, &["matches.csv"]).unwrap();
        let c = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap();
        fs::write(c.partial.join("matches.csv"), "half").unwrap();
        let partial = c.partial.clone();
        c.abort();
        assert!(!partial.exists());
        // a failed first run into an empty folder of the user's leaves it empty
        fs::create_dir(d.join("empty")).unwrap();
        claim(d.join("empty").to_str().unwrap(), &[], Kind::Results).unwrap().abort();
        assert_eq!(fs::read_dir(d.join("empty")).unwrap().count(), 0);
        // a failed first run removes the folder it created
        let c = claim(d.join("new").join("deeper").to_str().unwrap(), &[], Kind::Results).unwrap();
        c.abort();
        assert!(!d.join("new").exists());
        // a folder in place of a result file: refused before anything moves
        let c = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap();
        fs::write(c.partial.join("matches.csv"), "new").unwrap();
        fs::write(c.partial.join("links.csv"), "new").unwrap();
        fs::create_dir(out.join("links.csv")).unwrap();
        assert!(c.commit().unwrap_err().to_string().contains("folder or a link"));
        assert_eq!(fs::read_to_string(out.join("matches.csv")).unwrap(), "matches.csv");
        fs::remove_dir(out.join("links.csv")).unwrap();
        assert_eq!(fs::read_to_string(out.join("matches.csv")).unwrap(), "matches.csv");
        claim(out.to_str().unwrap(), &[], Kind::Results).unwrap().abort(); // the lock was released
    }

    #[test]
    fn a_second_run_on_the_same_folder_fails_clearly_and_a_dead_lock_is_taken_over() {
        let d = tmp("lock");
        let out = d.join("r");
        run(&out, &["matches.csv"]).unwrap();
        let first = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap();
        let e = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("another trajdb run is writing"), "{e}");
        first.abort();
        // a killed run: its staging folder (named in the manifest) is left, its lock released by
        // the system
        let mut killed = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap();
        fs::write(killed.partial.join("matches.csv"), "x").unwrap();
        let stale = killed.partial.clone();
        killed.done = true;
        killed.lock = None;
        drop(killed);
        assert!(stale.exists() && fs::read_to_string(out.join(MANIFEST)).unwrap().contains("staging\t"));
        run(&out, &["matches.csv"]).unwrap();
        assert!(!stale.exists());
        assert!(!fs::read_to_string(out.join(MANIFEST)).unwrap().contains("staging\t"));
    }

    #[cfg(unix)]
    #[test]
    fn a_hostile_manifest_deletes_nothing() {
        let d = tmp("hostile");
        let out = d.join("r");
        fs::create_dir_all(&out).unwrap();
        fs::write(d.join("victim.txt"), "mine").unwrap();
        fs::write(out.join(MANIFEST), format!("{MANIFEST_HEAD}kind\tresults\nfile\t../victim.txt\t4:0000000000000000\n")).unwrap();
        assert!(claim(out.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string().contains("not a plain file name"));
        assert!(d.join("victim.txt").exists());
        // a manifest trajdb did not write, or one that is a link to the user's list of files
        fs::write(out.join(MANIFEST), "victim.txt\n").unwrap();
        assert!(claim(out.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string().contains("not written by trajdb"));
        fs::remove_file(out.join(MANIFEST)).unwrap();
        fs::write(d.join("list.txt"), format!("{MANIFEST_HEAD}victim.txt\n")).unwrap();
        std::os::unix::fs::symlink(d.join("list.txt"), out.join(MANIFEST)).unwrap();
        assert!(claim(out.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string().contains("not a plain file"));
        assert!(d.join("victim.txt").exists());
    }

    #[cfg(unix)]
    #[test]
    fn a_new_results_folder_has_normal_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let d = tmp("perm");
        let out = d.join("r");
        run(&out, &["matches.csv"]).unwrap();
        let mode = fs::metadata(&out).unwrap().permissions().mode() & 0o777;
        assert_ne!(mode, 0o700, "{mode:o}");
        assert_eq!(mode & 0o055, fs::metadata(&d).unwrap().permissions().mode() & 0o055);
    }
}

/// Issue 37: a folder's kind, names that look like trajdb's, identities by content, inputs
/// behind views and URLs, a claim that fails half-way.
#[cfg(test)]
mod issue37 {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("trajdb-i37-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn run(out: &Path, kind: Kind, files: &[(&str, &str)]) -> Result<Vec<String>, OutError> {
        let c = claim(out.to_str().unwrap(), &[], kind)?;
        for (f, text) in files {
            fs::write(c.partial.join(f), text).unwrap();
        }
        c.commit()
    }

    fn listing(d: &Path) -> Vec<(String, Vec<u8>)> {
        let mut v: Vec<(String, Vec<u8>)> = fs::read_dir(d)
            .unwrap()
            .flatten()
            .map(|e| (e.file_name().to_string_lossy().into_owned(), fs::read(e.path()).unwrap_or_default()))
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_scenario_folder_is_never_results_and_back() {
        let d = tmp("kind");
        let sim = d.join("sim");
        run(&sim, Kind::Scenario, &[("points.parquet", "pts"), ("truth.csv", "truth"), ("world.csv", "w"), ("cameras.csv", "c")]).unwrap();
        let before = listing(&sim);
        let e = claim(sim.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("holds a scenario") && e.contains("results"), "{e}");
        assert_eq!(listing(&sim), before, "nothing changed");
        // a scenario again into it is fine; results beside it, in a folder of their own, too
        run(&sim, Kind::Scenario, &[("points.parquet", "pts2"), ("truth.csv", "t2")]).unwrap();
        assert!(!sim.join("world.csv").exists());
        let res = sim.join("results");
        run(&res, Kind::Results, &[("merged.parquet", "m")]).unwrap();
        let e = claim(res.to_str().unwrap(), &[], Kind::Scenario).unwrap_err().to_string();
        assert!(e.contains("holds the results of a trajdb pipeline run"), "{e}");
        assert_eq!(fs::read_to_string(res.join("merged.parquet")).unwrap(), "m");
    }

    #[test]
    fn a_folder_with_only_names_like_trajdbs_is_not_empty() {
        // (a) a user's .trajdb-partial-old/ folder, (b) a user's .trajdb-lock
        let d = tmp("lookalike");
        let a = d.join("a");
        fs::create_dir_all(a.join(".trajdb-partial-old")).unwrap();
        fs::write(a.join(".trajdb-partial-old").join("points.csv"), "mine").unwrap();
        let e = claim(a.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("already holds files that trajdb did not write"), "{e}");
        assert_eq!(fs::read_to_string(a.join(".trajdb-partial-old").join("points.csv")).unwrap(), "mine");
        let b = d.join("b");
        fs::create_dir_all(&b).unwrap();
        fs::write(b.join(LOCK), "my lock notes").unwrap();
        assert!(claim(b.to_str().unwrap(), &[], Kind::Results).is_err());
        assert_eq!(fs::read_to_string(b.join(LOCK)).unwrap(), "my lock notes");
        // a temporary manifest name alone is not empty either
        let c = d.join("c");
        fs::create_dir_all(&c).unwrap();
        fs::write(c.join(format!("{MANIFEST}.1-1.tmp")), "mine").unwrap();
        assert!(claim(c.to_str().unwrap(), &[], Kind::Results).is_err());
        assert_eq!(fs::read_to_string(c.join(format!("{MANIFEST}.1-1.tmp"))).unwrap(), "mine");
    }

    #[cfg(unix)]
    #[test]
    fn a_lock_name_linked_to_a_users_file_is_never_written() {
        let d = tmp("hardlink");
        let out = d.join("r");
        run(&out, Kind::Results, &[("matches.csv", "a")]).unwrap();
        fs::write(d.join("thesis.txt"), "my thesis").unwrap();
        fs::hard_link(d.join("thesis.txt"), out.join(LOCK)).unwrap();
        run(&out, Kind::Results, &[("matches.csv", "b")]).unwrap();
        let first = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap();
        assert!(claim(out.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string().contains("another trajdb run"));
        first.abort();
        assert_eq!(fs::read_to_string(d.join("thesis.txt")).unwrap(), "my thesis");
        assert_eq!(fs::read_to_string(out.join(LOCK)).unwrap(), "my thesis");
    }

    #[test]
    fn a_name_only_or_old_manifest_line_is_never_trusted() {
        // (c) points.csv named without an identity, in the new and the old form
        let d = tmp("nameonly");
        for (k, text) in [format!("{MANIFEST_HEAD}kind\tresults\npoints.csv\n"), format!("{LEGACY_HEAD} the files below\npoints.csv\n"),
                          format!("{LEGACY_HEAD} the files below\npoints.csv\t8:123:456\n"), format!("{MANIFEST_HEAD}kind\tresults\nfile\tpoints.csv\n")]
            .iter()
            .enumerate()
        {
            let out = d.join(format!("r{k}"));
            fs::create_dir_all(&out).unwrap();
            fs::write(out.join("points.csv"), "my points").unwrap();
            fs::write(out.join(MANIFEST), text).unwrap();
            let e = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string();
            assert!(e.contains("will not"), "{e}");
            assert_eq!(fs::read_to_string(out.join("points.csv")).unwrap(), "my points");
        }
    }

    #[test]
    fn an_edit_with_size_and_time_restored_is_seen() {
        // (d) the same size, the same modification time, the same inode: other bytes
        let d = tmp("edit");
        let out = d.join("r");
        run(&out, Kind::Results, &[("merged.parquet", "trajdb's bytes"), ("links.csv", "l")]).unwrap();
        let p = out.join("merged.parquet");
        let t = fs::metadata(&p).unwrap().modified().unwrap();
        {
            let f = fs::OpenOptions::new().write(true).open(&p).unwrap();
            (&f).write_all(b"user's  bytes!").unwrap();
            f.set_modified(t).unwrap();
        }
        assert_eq!(fs::metadata(&p).unwrap().len(), "trajdb's bytes".len() as u64);
        let e = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string();
        assert!(e.contains("merged.parquet changed since trajdb wrote it"), "{e}");
        assert_eq!(fs::read_to_string(&p).unwrap(), "user's  bytes!");
        // an edit during the run: the commit checks again before replacing or removing
        let out2 = d.join("r2");
        run(&out2, Kind::Results, &[("merged.parquet", "trajdb's bytes"), ("links.csv", "l")]).unwrap();
        let c = claim(out2.to_str().unwrap(), &[], Kind::Results).unwrap();
        fs::write(c.partial.join("merged.parquet"), "new").unwrap();
        fs::write(out2.join("merged.parquet"), "user's  bytes!").unwrap();
        let e = c.commit().unwrap_err().to_string();
        assert!(e.contains("changed since trajdb wrote it") && e.contains("nothing was replaced"), "{e}");
        assert_eq!(fs::read_to_string(out2.join("merged.parquet")).unwrap(), "user's  bytes!");
        // an edited file this run does not write again is left (not deleted) and no longer listed
        let c = claim(d.join("r3").to_str().unwrap(), &[], Kind::Results).unwrap();
        fs::write(c.partial.join("links.csv"), "l").unwrap();
        c.commit().unwrap();
        let c = claim(d.join("r3").to_str().unwrap(), &[], Kind::Results).unwrap();
        fs::write(c.partial.join("other.csv"), "o").unwrap();
        fs::write(d.join("r3").join("links.csv"), "mine").unwrap();
        c.commit().unwrap();
        assert_eq!(fs::read_to_string(d.join("r3").join("links.csv")).unwrap(), "mine");
        assert!(!fs::read_to_string(d.join("r3").join(MANIFEST)).unwrap().contains("links.csv"));
    }

    #[test]
    fn a_copied_results_folder_is_still_trajdbs() {
        let d = tmp("copy");
        let out = d.join("r");
        run(&out, Kind::Results, &[("merged.parquet", "m"), ("links.csv", "l")]).unwrap();
        let copy = d.join("copy");
        fs::create_dir_all(&copy).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(10));
        for (n, bytes) in listing(&out) {
            fs::write(copy.join(n), bytes).unwrap(); // new inodes, new times
        }
        assert_eq!(run(&copy, Kind::Results, &[("merged.parquet", "m2")]).unwrap(), ["merged.parquet"]);
        assert!(!copy.join("links.csv").exists());
        assert_eq!(fs::read_to_string(copy.join("merged.parquet")).unwrap(), "m2");
    }

    #[test]
    fn the_fingerprint_sees_every_one_word_change() {
        let base: Vec<u8> = (0..1000u32).map(|k| (k * 7 % 251) as u8).collect();
        let h = |b: &[u8]| {
            let mut x = Hash64::new();
            x.update(b);
            x.finish()
        };
        let h0 = h(&base);
        // streaming in pieces gives the same value
        let mut x = Hash64::new();
        for c in base.chunks(13) {
            x.update(c);
        }
        assert_eq!(x.finish(), h0);
        let mut seen = std::collections::HashSet::new();
        for k in 0..base.len() {
            let mut b = base.clone();
            b[k] ^= 1;
            assert!(seen.insert(h(&b)) && h(&b) != h0, "byte {k}");
        }
        assert_ne!(h(b"ab"), h(b"ab\0"));
        let id = Ident { size: 12, hash: 0xabc };
        assert_eq!(Ident::parse(&id.text()), Some(id));
        assert_eq!(Ident::parse("12:123:456"), None);
    }

    #[test]
    fn staging_folders_go_only_when_listed_and_only_trajdbs_files_in_them() {
        let d = tmp("staging");
        let out = d.join("r");
        run(&out, Kind::Results, &[("matches.csv", "a")]).unwrap();
        // a lookalike folder the manifest does not name: the user's, beside the results
        fs::create_dir(out.join(".trajdb-partial-mine")).unwrap();
        fs::write(out.join(".trajdb-partial-mine").join("points.csv"), "mine").unwrap();
        // a killed run's staging folder holding a file trajdb does not write: kept, still listed
        let mut killed = claim(out.to_str().unwrap(), &[], Kind::Results).unwrap();
        fs::write(killed.partial.join("merged.parquet"), "x").unwrap();
        fs::write(killed.partial.join("notes.txt"), "mine").unwrap();
        let stale = killed.partial.clone();
        killed.done = true;
        killed.lock = None;
        drop(killed);
        run(&out, Kind::Results, &[("matches.csv", "b")]).unwrap();
        assert_eq!(fs::read_to_string(out.join(".trajdb-partial-mine").join("points.csv")).unwrap(), "mine");
        assert_eq!(fs::read_to_string(stale.join("notes.txt")).unwrap(), "mine");
        assert!(!stale.join("merged.parquet").exists());
        let name = stale.file_name().unwrap().to_string_lossy().into_owned();
        assert!(fs::read_to_string(out.join(MANIFEST)).unwrap().contains(&format!("staging\t{name}")));
    }

    #[test]
    fn a_claim_failing_half_way_undoes_what_it_made() {
        let d = tmp("enospc");
        for fail in [1u8, 2] {
            FAIL.with(|f| f.set(fail));
            // a new folder: gone again; an empty one: empty again; earlier results: as they were
            let new = d.join(format!("new{fail}")).join("deeper");
            assert!(claim(new.to_str().unwrap(), &[], Kind::Results).unwrap_err().to_string().contains("injected"));
            assert!(!d.join(format!("new{fail}")).exists());
            let empty = d.join(format!("empty{fail}"));
            fs::create_dir_all(&empty).unwrap();
            assert!(claim(empty.to_str().unwrap(), &[], Kind::Results).is_err());
            assert_eq!(fs::read_dir(&empty).unwrap().count(), 0);
            FAIL.with(|f| f.set(0));
            let out = d.join(format!("r{fail}"));
            run(&out, Kind::Results, &[("matches.csv", "a")]).unwrap();
            let before = listing(&out);
            FAIL.with(|f| f.set(fail));
            assert!(claim(out.to_str().unwrap(), &[], Kind::Results).is_err());
            FAIL.with(|f| f.set(0));
            assert_eq!(listing(&out), before);
            claim(out.to_str().unwrap(), &[], Kind::Results).unwrap().abort(); // not locked
        }
    }

    #[test]
    fn inputs_behind_urls_and_views_are_followed() {
        let d = tmp("views");
        let out = d.join("r");
        run(&out, Kind::Results, &[("merged.parquet", "m")]).unwrap();
        let o = out.to_str().unwrap();
        let merged = out.join("merged.parquet");
        let m = merged.to_str().unwrap();
        // a file:// URL
        let e = claim_checked(o, &[&format!("file://{m}")], Catalog::Files, Kind::Results).unwrap_err().to_string();
        assert!(e.contains("is or contains the input"), "{e}");
        assert!(claim_checked(o, &[&format!("FILE://localhost{m}")], Catalog::Files, Kind::Results).is_err());
        // a view over the file, and a view over that view
        let q = |s: &str| serde_json::to_string(s).unwrap();
        let views = format!(
            "[{{\"database\":\"memory\",\"schema\":\"main\",\"name\":\"pts\",\"sql\":{}}},
              {{\"database\":\"memory\",\"schema\":\"main\",\"name\":\"Outer\",\"sql\":\"CREATE VIEW \\\"Outer\\\" AS SELECT * FROM pts\"}},
              {{\"database\":\"memory\",\"schema\":\"main\",\"name\":\"raw\",\"sql\":{}}},
              {{\"database\":\"memory\",\"schema\":\"main\",\"name\":\"dyn\",\"sql\":\"CREATE VIEW dyn AS FROM read_parquet(getvariable('p'))\"}}]",
            q(&format!("CREATE VIEW pts AS SELECT * FROM read_parquet('{}')", m.replace('\'', "''"))),
            q(&format!("CREATE VIEW raw AS SELECT * FROM '{}/elsewhere.parquet'", d.display()))
        );
        for input in ["pts", "main.pts", "memory.main.PTS", "outer"] {
            let e = claim_checked(o, &[input], Catalog::Views(&views), Kind::Results).unwrap_err().to_string();
            assert!(e.contains("is or contains the input") && e.contains("the view pts reads"), "{input}: {e}");
        }
        let e = claim_checked(o, &["dyn"], Catalog::Views(&views), Kind::Results).unwrap_err().to_string();
        assert!(e.contains("builds at run time"), "{e}");
        // a table, or a view over other files: fine; a view nobody described, into earlier results: refused
        claim_checked(o, &["raw"], Catalog::Views(&views), Kind::Results).unwrap().abort();
        claim_checked(o, &["a_table"], Catalog::Views(&views), Kind::Results).unwrap().abort();
        assert!(claim_checked(o, &["pts"], Catalog::Unknown, Kind::Results).unwrap_err().to_string().contains("cannot tell"));
        claim_checked(o, &["missing/points.parquet"], Catalog::Unknown, Kind::Results).unwrap().abort();
        claim_checked(d.join("fresh").to_str().unwrap(), &["dyn"], Catalog::Views(&views), Kind::Results).unwrap().abort();
        assert_eq!(fs::read_to_string(&merged).unwrap(), "m");
    }
}
