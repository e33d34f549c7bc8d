//! Table functions: the one generic `VTab` of every trajdb table function ([`Tab`]), its safe
//! bind-time readers ([`BindArgs`]) and its output ([`Rows`]).
//!
//! A table function implements [`TableFn`] (bind, init, one chunk of rows) and is described by a
//! [`Table`] descriptor; [`register`] registers it with the database's [`Limits`]. [`Tab`] then
//! - declares the descriptor's positional and named parameters and result columns;
//! - reads every argument through [`BindArgs`], which looks at a value's NULL-ness and type
//!   before converting it: DuckDB's converters throw a C++ exception on a NULL value (for
//!   example `duckdb_get_varchar`), which Rust cannot catch, so the host process aborted on
//!   `FROM trajdb_simulate(NULL)`;
//! - runs bind, init and every chunk inside the database's limit scope
//!   ([`crate::algo::limits::with_scope`]) and prefixes every error with the function's name.
//!
//! # NULL policy (table functions)
//! A NULL positional argument reaches the function as `None` ([`BindArgs::text`]), which decides
//! (trajdb_simulate: an error). A named argument given as NULL (`cameras := NULL`) is an error
//! naming it: leave it out for its default.
//!
//! Parameters (positional and named) are registered as `ANY` and converted here, so that a
//! value of the wrong type is an error naming the function and the parameter in every DuckDB
//! (DuckDB's own cast said only `Failed to cast value: Could not convert string 'x' to INT64`);
//! the reference shows their declared types.

use super::fs::{text_of, CallerFs};
use crate::algo::limits::{self, Limits};
use crate::bindings::types::{Database, Param, Table};
use duckdb::core::{DataChunkHandle, Inserter, LogicalTypeHandle, LogicalTypeId};
use duckdb::vtab::{BindInfo, InitInfo, TableFunctionInfo, VTab, Value};
use duckdb::Connection;
use std::error::Error;
use std::marker::PhantomData;
use std::path::PathBuf;
use std::sync::Arc;

type Res<T> = Result<T, Box<dyn Error>>;

/// One trajdb table function: what [`Tab`] calls. Errors are prefixed with the function name.
pub trait TableFn: Sized + Send + Sync + 'static {
    /// Its descriptor (parameters, named parameters, result columns).
    const TABLE: &'static Table;
    /// What bind decides (the arguments, read and checked).
    type Bind: Send + Sync + 'static;
    /// The scan state shared by the threads that call [`TableFn::func`].
    type Scan: Send + Sync + 'static;
    fn bind(args: &BindArgs<'_>) -> Res<Self::Bind>;
    fn init(bind: &Self::Bind) -> Res<Self::Scan>;
    /// Writes the next rows (at most [`Rows::CAPACITY`]) and returns how many; 0 ends the scan.
    fn func(bind: &Self::Bind, scan: &Self::Scan, out: &mut Rows<'_>) -> Res<usize>;
}

/// What one registration carries into DuckDB's catalog (one per database).
#[derive(Clone)]
struct TabInfo {
    name: &'static str,
    limits: Arc<Limits>,
}

/// The bind data of [`Tab`]: the registration, and the function's own.
pub struct Bound<B> {
    info: TabInfo,
    data: B,
}

/// The generic `VTab` behind every [`TableFn`].
pub struct Tab<T>(PhantomData<T>);

fn prefixed(name: &str, e: Box<dyn Error>) -> Box<dyn Error> {
    format!("{name}: {e}").into()
}

impl<T: TableFn> VTab for Tab<T> {
    type BindData = Bound<T::Bind>;
    type InitData = T::Scan;

    fn bind(bind: &BindInfo) -> Res<Self::BindData> {
        // SAFETY: `register::<T>` registered this function with a `TabInfo` as its extra info,
        // which DuckDB owns for as long as the function's catalog entry exists.
        let info = unsafe { bind.get_extra_info::<TabInfo>().as_ref() }.ok_or("a trajdb table function registered without its TabInfo")?.clone();
        for (name, ty) in T::TABLE.columns {
            bind.add_result_column(name, ty.logical());
        }
        let args = BindArgs { info: bind, table: T::TABLE, limits: &info.limits };
        // errors are formatted inside the scope too: a message may read the limit it names
        let data = limits::with_scope(&info.limits, || T::bind(&args).map_err(|e| prefixed(info.name, e)))?;
        Ok(Bound { info, data })
    }

    fn init(init: &InitInfo) -> Res<Self::InitData> {
        // SAFETY: DuckDB hands init the bind data that `bind` above returned (a `Bound<T::Bind>`,
        // boxed by duckdb-rs), alive until the scan ends.
        let b = unsafe { init.get_bind_data::<Bound<T::Bind>>().as_ref() }.ok_or("a trajdb table function initialised without its bind data")?;
        limits::with_scope(&b.info.limits, || T::init(&b.data).map_err(|e| prefixed(b.info.name, e)))
    }

    fn func(func: &TableFunctionInfo<Self>, output: &mut DataChunkHandle) -> Res<()> {
        let b = func.get_bind_data();
        let mut rows = Rows { chunk: output };
        let n = limits::with_scope(&b.info.limits, || T::func(&b.data, func.get_init_data(), &mut rows).map_err(|e| prefixed(b.info.name, e)))?;
        output.set_len(n.min(Rows::CAPACITY));
        Ok(())
    }

    fn parameters() -> Option<Vec<LogicalTypeHandle>> {
        Some(T::TABLE.params.iter().map(|_| LogicalTypeHandle::from(LogicalTypeId::Any)).collect())
    }

    fn named_parameters() -> Option<Vec<(String, LogicalTypeHandle)>> {
        Some(T::TABLE.named.iter().map(|p| (p.name.to_string(), LogicalTypeHandle::from(LogicalTypeId::Any))).collect())
    }
}

/// Registers table function `T` as `name` on `con`, bound to the database's `limits`.
pub fn register<T: TableFn>(con: &Connection, name: &'static str, db: &Database) -> duckdb::Result<()> {
    con.register_table_function_with_extra_info::<Tab<T>, TabInfo>(name, &TabInfo { name, limits: Arc::clone(&db.limits) })
}

/// The arguments of one table-function call, read safely (module doc).
pub struct BindArgs<'a> {
    info: &'a BindInfo,
    table: &'static Table,
    limits: &'a Arc<Limits>,
}

/// A value as text: VARCHAR read whole (an error naming `name` when it holds a NUL byte),
/// any other type as DuckDB prints it.
fn value_text(name: &str, v: &Value) -> Res<String> {
    if matches!(v.logical_type_id(), LogicalTypeId::Varchar | LogicalTypeId::StringLiteral) {
        return text_of(v).map_err(|e| format!("{name} {e}").into());
    }
    Ok(v.to_string())
}

/// An SQL type name for messages.
fn type_name(t: LogicalTypeId) -> String {
    match t {
        LogicalTypeId::StringLiteral => "VARCHAR".into(),
        LogicalTypeId::IntegerLiteral => "INTEGER".into(),
        other => format!("{other:?}").to_uppercase(),
    }
}

impl BindArgs<'_> {
    fn param(&self, k: usize) -> Res<&'static Param> {
        self.table.params.get(k).ok_or_else(|| format!("argument {} is not declared", k + 1).into())
    }

    fn named_param(&self, name: &str) -> Res<&'static Param> {
        self.table.named.iter().find(|p| p.name == name).ok_or_else(|| format!("named parameter {name} is not declared").into())
    }

    /// The calling database's work limits (trajdb_limit).
    pub fn limits(&self) -> &Arc<Limits> {
        self.limits
    }

    /// A setting as the calling connection sees it, as text (`threads`, `memory_limit`); `None`
    /// when it cannot be read. Only settings every supported DuckDB has: a debug DuckDB build
    /// aborts on an unknown name.
    pub fn setting(&self, name: &str) -> Option<String> {
        let v = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.info.get_config_option(name))).ok().flatten()?;
        (!v.is_null()).then(|| v.to_string())
    }

    /// Every named argument given (not NULL), as text: numbers as DuckDB prints them, booleans
    /// as true / false. For functions whose named parameters are checked by their own table
    /// (the pipeline parameters).
    pub fn named_as_text(&self) -> Res<Vec<(String, String)>> {
        let mut out = Vec::new();
        for p in self.table.named {
            if let Some((_, v)) = self.named(p.name)? {
                out.push((p.name.to_string(), value_text(p.name, &v)?));
            }
        }
        Ok(out)
    }

    /// Positional argument `k`, present and not NULL (`None` when NULL), with its declaration.
    fn positional(&self, k: usize) -> Res<Option<(&'static Param, Value)>> {
        let p = self.param(k)?;
        if (self.info.get_parameter_count() as usize) <= k {
            return Err(format!("{} is missing", p.name).into());
        }
        let v = self.info.get_parameter(k as u64);
        Ok((!v.is_null()).then_some((p, v)))
    }

    /// Positional VARCHAR argument `k`; `None` when it is NULL.
    pub fn text(&self, k: usize) -> Res<Option<String>> {
        let Some((p, v)) = self.positional(k)? else { return Ok(None) };
        let ty = v.logical_type_id();
        if !matches!(ty, LogicalTypeId::Varchar | LogicalTypeId::StringLiteral) {
            return Err(format!("{} must be text (VARCHAR), got {} {:?}", p.name, type_name(ty), v.to_string()).into());
        }
        Ok(Some(text_of(&v).map_err(|e| format!("{} {e}", p.name))?))
    }

    /// Positional BOOLEAN argument `k` (true / false, or the text 'true' / 'false'); `None` when
    /// it is NULL.
    pub fn boolean(&self, k: usize) -> Res<Option<bool>> {
        let Some((p, v)) = self.positional(k)? else { return Ok(None) };
        let ty = v.logical_type_id();
        if ty == LogicalTypeId::Boolean {
            return Ok(Some(v.to_bool()));
        }
        let text = value_text(p.name, &v)?;
        match text.trim().to_ascii_lowercase().as_str() {
            "true" if matches!(ty, LogicalTypeId::Varchar | LogicalTypeId::StringLiteral) => Ok(Some(true)),
            "false" if matches!(ty, LogicalTypeId::Varchar | LogicalTypeId::StringLiteral) => Ok(Some(false)),
            _ => Err(format!("{} must be true or false (BOOLEAN), got {} {text:?}", p.name, type_name(ty)).into()),
        }
    }

    /// A named argument that is present, with its declared parameter: `None` when left out;
    /// NULL is an error naming it.
    fn named(&self, name: &str) -> Res<Option<(&'static Param, Value)>> {
        let p = self.named_param(name)?;
        let Some(v) = self.info.get_named_parameter(name) else { return Ok(None) };
        if v.is_null() {
            return Err(format!("{name} := NULL; leave {name} out for its default, or give a {} value", p.ty.sql()).into());
        }
        Ok(Some((p, v)))
    }

    /// A named BIGINT argument (`None`: left out): an integer, or a number or text that is a
    /// whole number in BIGINT's range.
    pub fn named_bigint(&self, name: &str) -> Res<Option<i64>> {
        let Some((p, v)) = self.named(name)? else { return Ok(None) };
        use LogicalTypeId as L;
        let ty = v.logical_type_id();
        if matches!(ty, L::Tinyint | L::Smallint | L::Integer | L::Bigint | L::UTinyint | L::USmallint | L::UInteger) {
            return Ok(Some(v.to_int64()));
        }
        let numeric = matches!(ty, L::UBigint | L::Hugeint | L::UHugeint | L::Decimal | L::Float | L::Double | L::IntegerLiteral);
        let text = value_text(p.name, &v)?;
        let t = text.trim();
        let whole = t.parse::<i64>().ok().or_else(|| t.parse::<f64>().ok().filter(|f| f.fract() == 0.0 && f.abs() < 9.2e18).map(|f| f as i64));
        match whole {
            Some(n) if numeric || matches!(ty, L::Varchar | L::StringLiteral) => Ok(Some(n)),
            _ => Err(format!("{name} must be a whole number ({}), got {} {text:?}", p.ty.sql(), type_name(ty)).into()),
        }
    }

    /// A named VARCHAR argument (`None`: left out); another type is an error naming it.
    pub fn named_text(&self, name: &str) -> Res<Option<String>> {
        let Some((p, v)) = self.named(name)? else { return Ok(None) };
        let ty = v.logical_type_id();
        if !matches!(ty, LogicalTypeId::Varchar | LogicalTypeId::StringLiteral) {
            return Err(format!("{name} must be text ({}), got {} {:?}", p.ty.sql(), type_name(ty), v.to_string()).into());
        }
        Ok(Some(text_of(&v).map_err(|e| format!("{name} {e}"))?))
    }

    /// A named DOUBLE argument (`None`: left out): a number, or text that reads as one.
    pub fn named_double(&self, name: &str) -> Res<Option<f64>> {
        let Some((p, v)) = self.named(name)? else { return Ok(None) };
        use LogicalTypeId as L;
        let ty = v.logical_type_id();
        if matches!(
            ty,
            L::Tinyint | L::Smallint | L::Integer | L::Bigint | L::UTinyint | L::USmallint | L::UInteger | L::UBigint | L::Hugeint | L::UHugeint | L::Decimal | L::Float | L::Double
        ) {
            return Ok(Some(v.to_double()));
        }
        let text = value_text(p.name, &v)?;
        match text.trim().parse::<f64>() {
            Ok(f) if matches!(ty, L::Varchar | L::StringLiteral | L::IntegerLiteral) => Ok(Some(f)),
            _ => Err(format!("{name} must be a number ({}), got {} {text:?}", p.ty.sql(), type_name(ty)).into()),
        }
    }

    /// The calling connection's own file system: every path trajdb reads or writes for the
    /// caller is opened through it first (`super::fs`), so that every sandbox setting DuckDB
    /// has applies as to the caller's own SQL.
    pub fn caller_fs(&self) -> Res<CallerFs> {
        Ok(CallerFs::of(self.info)?)
    }

    /// DuckDB's file-access settings as the calling connection sees them.
    ///
    /// Read through the bind's client context (`duckdb_table_function_get_client_context` +
    /// `duckdb_client_context_get_config_option`, C API v1 from DuckDB 1.5): the caller's own
    /// view, with no connection kept by the extension (a connection kept from load time would
    /// hold the database open until the process ends). Only settings every supported DuckDB
    /// has are read: a debug DuckDB build aborts on an unknown name.
    pub fn file_access(&self) -> FileAccess {
        // a DuckDB without the function (older than 1.5) panics in duckdb-rs's loader wrapper:
        // caught, and then nothing is known, which refuses the write
        let get = |name: &str| std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.info.get_config_option(name))).ok().flatten();
        let external = get("enable_external_access").filter(|v| !v.is_null() && v.logical_type_id() == LogicalTypeId::Boolean).map(|v| v.to_bool());
        let mut allowed_directories = Vec::new();
        if let Some(list) = get("allowed_directories").and_then(|v| v.to_list()) {
            for item in list {
                if !item.is_null() && item.logical_type_id() == LogicalTypeId::Varchar {
                    allowed_directories.push(item.to_string());
                }
            }
        }
        let disabled = get("disabled_filesystems").filter(|v| !v.is_null() && v.logical_type_id() == LogicalTypeId::Varchar).map(|v| v.to_string()).unwrap_or_default();
        FileAccess { external, allowed_directories, local_disabled: disabled.split(',').any(|f| f.trim().eq_ignore_ascii_case("LocalFileSystem")) }
    }

    /// Positional BIGINT argument `k` (`None` when NULL): an integer, or a number or text that is
    /// a whole number in BIGINT's range.
    pub fn bigint(&self, k: usize) -> Res<Option<i64>> {
        let Some((p, v)) = self.positional(k)? else { return Ok(None) };
        use LogicalTypeId as L;
        let ty = v.logical_type_id();
        if matches!(ty, L::Tinyint | L::Smallint | L::Integer | L::Bigint | L::UTinyint | L::USmallint | L::UInteger) {
            return Ok(Some(v.to_int64()));
        }
        let numeric = matches!(ty, L::UBigint | L::Hugeint | L::UHugeint | L::Decimal | L::Float | L::Double | L::IntegerLiteral);
        let text = v.to_string();
        let t = text.trim();
        let whole = t.parse::<i64>().ok().or_else(|| t.parse::<f64>().ok().filter(|f| f.fract() == 0.0 && f.abs() < 9.2e18).map(|f| f as i64));
        match whole {
            Some(n) if numeric || matches!(ty, L::Varchar | L::StringLiteral) => Ok(Some(n)),
            _ => Err(format!("{} must be a whole number ({}), got {} {text:?}", p.name, p.ty.sql(), type_name(ty)).into()),
        }
    }

    /// `lock_configuration` as the calling connection sees it (through the bind's client
    /// context): `true` when it is true, and also when it cannot be read (a DuckDB without
    /// `duckdb_client_context_get_config_option`, or a value that is not a boolean), so that
    /// what a locked configuration forbids is never allowed by an unreadable one.
    pub fn configuration_locked(&self) -> bool {
        let v = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.info.get_config_option("lock_configuration"))).ok().flatten();
        match v {
            Some(v) if !v.is_null() && v.logical_type_id() == LogicalTypeId::Boolean => v.to_bool(),
            _ => true,
        }
    }
}

/// DuckDB's settings that decide which files SQL may touch (as `COPY ... TO` obeys them).
#[derive(Clone, Debug, PartialEq)]
pub struct FileAccess {
    /// `enable_external_access`; `None` when it could not be read.
    pub external: Option<bool>,
    /// `allowed_directories`: with external access off, folders that stay allowed.
    pub allowed_directories: Vec<String>,
    /// `disabled_filesystems` names `LocalFileSystem`.
    pub local_disabled: bool,
}

/// `p` as trajdb's writers will use it: `~` expanded, made absolute, the longest existing
/// prefix resolved through `canonicalize` (links followed), `..` below a missing folder refused.
/// The same function as the writers' own ([`crate::app::outdir::absolute`]), so that the folder
/// checked here is the folder written.
fn resolve(p: &str) -> Result<PathBuf, String> {
    crate::app::outdir::absolute(p).map_err(|e| e.to_string())
}

impl FileAccess {
    /// `Ok` when DuckDB's settings let SQL write files into folder `dir` (what `COPY ... TO`
    /// into it would be allowed): external access on, or `dir` inside one of
    /// `allowed_directories` (resolved, links followed; `allowed_paths` names single files
    /// and does not cover a folder). Otherwise the reason and the fix.
    pub fn may_write_into(&self, dir: &str) -> Result<(), String> {
        if self.local_disabled {
            return Err(format!(
                "cannot write into {dir:?}: this database's disabled_filesystems setting disables LocalFileSystem (COPY TO a local file is refused as well)"
            ));
        }
        match self.external {
            Some(true) => Ok(()),
            None => Err(format!(
                "cannot write into {dir:?}: this DuckDB does not let the extension read enable_external_access (DuckDB 1.5 or newer does), \
                 and files are written only where that setting can be checked"
            )),
            Some(false) => {
                let target = resolve(dir)?;
                let inside = self.allowed_directories.iter().filter(|a| !a.trim().is_empty()).any(|a| resolve(a).is_ok_and(|a| target.starts_with(a)));
                if inside {
                    Ok(())
                } else {
                    Err(format!(
                        "cannot write into {dir:?}: enable_external_access is false (this connection is sandboxed, as for COPY ... TO) and {} is not inside \
                         allowed_directories ({}); use a folder inside one of them, or have the database's owner add one \
                         (SET allowed_directories = ['...'] before SET enable_external_access = false)",
                        target.display(),
                        if self.allowed_directories.is_empty() { "none".to_string() } else { self.allowed_directories.join(", ") }
                    ))
                }
            }
        }
    }
}

/// The output chunk of one [`TableFn::func`] call, written by row and column.
pub struct Rows<'a> {
    chunk: &'a mut DataChunkHandle,
}

impl Rows<'_> {
    /// Rows one call may write (DuckDB's standard vector size).
    pub const CAPACITY: usize = 2048;

    /// Writes text into column `col` (a VARCHAR column) at `row`.
    pub fn text(&mut self, col: usize, row: usize, v: &str) {
        assert!(row < Self::CAPACITY, "a data chunk holds {} rows", Self::CAPACITY);
        self.chunk.flat_vector(col).insert(row, v);
    }

    /// Writes `v` into column `col` (a BIGINT column) at `row`.
    pub fn bigint(&mut self, col: usize, row: usize, v: i64) {
        super::chunk_set_i64(self.chunk, col, row, v);
    }

    /// Writes `v` into column `col` (a DOUBLE column) at `row`.
    pub fn double(&mut self, col: usize, row: usize, v: f64) {
        super::chunk_set_f64(self.chunk, col, row, v);
    }

    /// Writes `v` into column `col` (a BOOLEAN column) at `row`.
    pub fn boolean(&mut self, col: usize, row: usize, v: bool) {
        super::chunk_set_bool(self.chunk, col, row, v);
    }

    /// Writes `v`, or NULL for `None`, into column `col` (a BIGINT column) at `row`.
    pub fn opt_bigint(&mut self, col: usize, row: usize, v: Option<i64>) {
        match v {
            Some(v) => self.bigint(col, row, v),
            None => super::chunk_set_null(self.chunk, col, row),
        }
    }

    /// Writes `v`, or NULL for `None`, into column `col` (a BOOLEAN column) at `row`.
    pub fn opt_boolean(&mut self, col: usize, row: usize, v: Option<bool>) {
        match v {
            Some(v) => self.boolean(col, row, v),
            None => super::chunk_set_null(self.chunk, col, row),
        }
    }

    /// Writes text, or NULL for `None`, into column `col` (a VARCHAR column) at `row`.
    pub fn opt_text(&mut self, col: usize, row: usize, v: Option<&str>) {
        match v {
            Some(v) => self.text(col, row, v),
            None => super::chunk_set_null(self.chunk, col, row),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn access(external: Option<bool>, dirs: &[&str]) -> FileAccess {
        FileAccess { external, allowed_directories: dirs.iter().map(|s| s.to_string()).collect(), local_disabled: false }
    }

    #[test]
    fn sandbox_rules() {
        let base = std::env::temp_dir().join(format!("trajdb-access-{}", std::process::id()));
        let ok = base.join("ok");
        std::fs::create_dir_all(&ok).unwrap();
        let (okd, based) = (ok.to_str().unwrap().to_string(), base.to_str().unwrap().to_string());
        assert!(access(Some(true), &[]).may_write_into("/anywhere").is_ok());
        let e = access(Some(false), &[]).may_write_into(&okd).unwrap_err();
        assert!(e.contains("enable_external_access is false") && e.contains("allowed_directories (none)"), "{e}");
        assert!(access(None, &[]).may_write_into(&okd).unwrap_err().contains("enable_external_access"));
        // inside an allowed folder (also a new subfolder), with DuckDB's trailing slash
        let sandbox = access(Some(false), &[&format!("{okd}/")]);
        assert!(sandbox.may_write_into(&okd).is_ok());
        assert!(sandbox.may_write_into(&format!("{okd}/new/deeper")).is_ok());
        // a sibling, the parent, a name that only starts the same, and '..' out of it
        assert!(sandbox.may_write_into(&based).is_err());
        assert!(sandbox.may_write_into(&format!("{okd}x")).is_err());
        assert!(sandbox.may_write_into(&format!("{okd}/../escape")).is_err());
        assert!(sandbox.may_write_into(&format!("{okd}/new/../../escape")).is_err());
        // a link inside the allowed folder that points out of it
        #[cfg(unix)]
        {
            let _ = std::fs::remove_file(ok.join("link"));
            std::os::unix::fs::symlink(&base, ok.join("link")).unwrap();
            assert!(sandbox.may_write_into(&format!("{okd}/link/out")).is_err());
        }
        let mut off = access(Some(true), &[]);
        off.local_disabled = true;
        assert!(off.may_write_into(&okd).unwrap_err().contains("disabled_filesystems"));
        let _ = std::fs::remove_dir_all(&base);
    }
}
