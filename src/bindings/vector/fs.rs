//! The caller's own file system, and strings read whole.
//!
//! # Why every file access goes through the caller's file system
//! DuckDB decides which files SQL may touch in its file system of the client (the connection):
//! `enable_external_access`, `allowed_directories`, `allowed_paths`, `disabled_filesystems`,
//! and whatever it adds later. Reading those settings is no proof: DuckDB 2.0.1 reports
//! `disabled_filesystems` as `''` through the client context after
//! `SET disabled_filesystems = 'LocalFileSystem'` (issue 37, HIGH 1). So trajdb asks the file
//! system itself: [`CallerFs`] is the caller's (`duckdb_client_context_get_file_system`, C API
//! v1), and every path a trajdb function will read or write on the caller's behalf is first
//! opened through it ([`CallerFs::may_read`], [`CallerFs::may_write_into`]). DuckDB runs its
//! sandbox checks in that open, before the operating system is asked, and throws a
//! `PermissionException` when one refuses; trajdb then refuses too, with DuckDB's own message.
//!
//! The probes have no side effect: a read probe opens the file for reading (and closes it, no
//! byte read); a write probe opens a name that does not exist (`.trajdb-access-<pid>-<n>`)
//! for writing WITHOUT the create flag, so DuckDB runs its checks with the intent to write and
//! the operating system then answers "no such file": nothing is created, in a folder that may
//! not even exist yet.
//!
//! An answer that is neither "opened" nor an I/O error of the operating system (a permission
//! error, a missing extension, an unknown error) refuses: trajdb writes or reads only where it
//! knows the caller may.
//!
//! # Strings read whole
//! DuckDB keeps NUL bytes inside VARCHAR; its C API hands a value's text out as a C string,
//! which stops at the first NUL, so `'in.parquet' || chr(0) || 'zz'` was read as `in.parquet`.
//! [`text_of`] reads the text and proves it whole: the value's SQL literal (`ToSQLString`,
//! also a C string) must be exactly the quoted text, which it is not when a NUL cut both.

use duckdb::ffi;
use duckdb::vtab::{BindInfo, Value};
use std::ffi::{CStr, CString};
use std::path::Path;

// duckdb-rs keeps the raw handles of `BindInfo` and `Value` private; each is a struct of that
// one pointer. These checks stop the build if that ever changes.
const _: () = assert!(std::mem::size_of::<BindInfo>() == std::mem::size_of::<ffi::duckdb_bind_info>());
const _: () = assert!(std::mem::size_of::<Value>() == std::mem::size_of::<ffi::duckdb_value>());

fn raw_bind(b: &BindInfo) -> ffi::duckdb_bind_info {
    // SAFETY: BindInfo is a struct holding exactly one `duckdb_bind_info` (size checked above);
    // the copy is a plain pointer, used only while `b` is borrowed.
    unsafe { std::mem::transmute_copy::<BindInfo, ffi::duckdb_bind_info>(b) }
}

fn raw_value(v: &Value) -> ffi::duckdb_value {
    // SAFETY: as raw_bind: Value holds exactly one `duckdb_value`; the copy does not own it.
    unsafe { std::mem::transmute_copy::<Value, ffi::duckdb_value>(v) }
}

/// Takes a C string DuckDB allocated with malloc, and frees it.
fn take_c_string(p: *mut std::os::raw::c_char) -> Option<String> {
    if p.is_null() {
        return None;
    }
    // SAFETY: a NUL-terminated string malloc'ed by DuckDB, freed once here.
    let s = unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned();
    unsafe { ffi::duckdb_free(p.cast()) };
    Some(s)
}

/// The text of a VARCHAR value, whole: an error when it holds a NUL byte (module doc).
pub fn text_of(v: &Value) -> Result<String, String> {
    let text = v.to_string();
    let raw = raw_value(v);
    let sql = std::panic::catch_unwind(|| take_c_string(unsafe { ffi::duckdb_value_to_string(raw) })).ok().flatten();
    let quoted = format!("'{}'", text.replace('\'', "''"));
    match sql {
        Some(sql) if sql == quoted => Ok(text),
        Some(_) => Err(format!("contains a NUL byte (chr(0)) after {text:?}; remove it")),
        // the host cannot render the value: nothing proves the text whole
        None => Err(format!("could not be read whole (the text {text:?} may hold a NUL byte)")),
    }
}

/// What one open through the caller's file system said.
#[derive(Debug)]
enum Opened {
    /// Opened (and closed again).
    Yes,
    /// The operating system said no (e.g. no such file): DuckDB's checks had passed.
    Os,
    /// DuckDB refused (a sandbox setting), or an answer trajdb cannot read as "allowed".
    Refused(String),
}

/// The file system of the connection that called a table function (module doc).
pub struct CallerFs {
    fs: ffi::duckdb_file_system,
}

impl Drop for CallerFs {
    fn drop(&mut self) {
        // SAFETY: created by duckdb_client_context_get_file_system, destroyed once
        unsafe { ffi::duckdb_destroy_file_system(&mut self.fs) };
    }
}

// SAFETY: the handle is used only by the bind that made it, on its thread.
unsafe impl Send for CallerFs {}

impl CallerFs {
    /// The calling connection's file system, from a table function's bind; an error (access
    /// refused) when this DuckDB's C API does not offer it.
    pub fn of(bind: &BindInfo) -> Result<CallerFs, String> {
        let info = raw_bind(bind);
        let fs = std::panic::catch_unwind(|| unsafe {
            let mut ctx: ffi::duckdb_client_context = std::ptr::null_mut();
            ffi::duckdb_table_function_get_client_context(info, &mut ctx);
            if ctx.is_null() {
                return std::ptr::null_mut();
            }
            // the file system object refers to the connection's own, which outlives the
            // context wrapper destroyed here
            let fs = ffi::duckdb_client_context_get_file_system(ctx);
            ffi::duckdb_destroy_client_context(&mut ctx);
            fs
        })
        .unwrap_or(std::ptr::null_mut());
        if fs.is_null() {
            return Err("this DuckDB does not let the extension open files through the connection's own file system \
                        (DuckDB 1.5 or newer does), and trajdb touches files only where that file system allows it"
                .into());
        }
        Ok(CallerFs { fs })
    }

    fn open(&self, path: &str, flag: ffi::duckdb_file_flag) -> Opened {
        let Ok(cpath) = CString::new(path) else { return Opened::Refused(format!("{path:?} contains a NUL byte")) };
        let fs = self.fs;
        let r = std::panic::catch_unwind(|| unsafe {
            let mut opts = ffi::duckdb_create_file_open_options();
            if opts.is_null() {
                return Opened::Refused("could not create file open options".into());
            }
            ffi::duckdb_file_open_options_set_flag(opts, flag, true);
            let mut handle: ffi::duckdb_file_handle = std::ptr::null_mut();
            let state = ffi::duckdb_file_system_open(fs, cpath.as_ptr(), opts, &mut handle);
            ffi::duckdb_destroy_file_open_options(&mut opts);
            if state == ffi::duckdb_state_DuckDBSuccess && !handle.is_null() {
                ffi::duckdb_file_handle_close(handle);
                ffi::duckdb_destroy_file_handle(&mut handle);
                return Opened::Yes;
            }
            let mut err = ffi::duckdb_file_system_error_data(fs);
            let kind = ffi::duckdb_error_data_error_type(err);
            let msg_ptr = ffi::duckdb_error_data_message(err);
            let msg = if msg_ptr.is_null() { String::from("unknown error") } else { CStr::from_ptr(msg_ptr).to_string_lossy().into_owned() };
            ffi::duckdb_destroy_error_data(&mut err);
            if kind == ffi::duckdb_error_type_DUCKDB_ERROR_IO {
                Opened::Os
            } else {
                Opened::Refused(msg)
            }
        });
        r.unwrap_or_else(|_| Opened::Refused("this DuckDB's file system C API failed".into()))
    }

    /// `Ok` when the caller may read `path` (a file, a glob pattern or a URL, as the caller's
    /// own `FROM 'path'` would take it); a path that does not exist passes (the reader says so).
    pub fn may_read(&self, path: &str) -> Result<(), String> {
        match self.open(path, ffi::duckdb_file_flag_DUCKDB_FILE_FLAG_READ) {
            Opened::Yes | Opened::Os => Ok(()),
            Opened::Refused(m) => Err(format!("cannot read {path:?}: this connection's file system refuses it ({m})")),
        }
    }

    /// `Ok` when the caller may write files into folder `dir` (which need not exist yet):
    /// a name that does not exist there is opened for writing without creating it (module doc).
    pub fn may_write_into(&self, dir: &Path) -> Result<(), String> {
        static SEQ: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.subsec_nanos()).unwrap_or(0);
        let probe = dir.join(format!(".trajdb-access-{}-{n}-{nanos}", std::process::id()));
        let Some(p) = probe.to_str() else { return Err(format!("cannot write into {}: the path is not UTF-8", dir.display())) };
        match self.open(p, ffi::duckdb_file_flag_DUCKDB_FILE_FLAG_WRITE) {
            Opened::Yes | Opened::Os => Ok(()),
            Opened::Refused(m) => Err(format!("cannot write into {}: this connection's file system refuses it ({m})", dir.display())),
        }
    }
}
