//! The only place that touches DuckDB vectors: SQL types, column readers, output writers,
//! and the NULL policy.
//!
//! # NULL policy (every trajdb scalar function)
//! - A NULL argument (a NULL list, a NULL number, a NULL region) gives a NULL result for
//!   that row.
//! - A NULL *inside* a trajectory (a NULL point, or a NULL t, x or y) is an error that names
//!   the function, the argument and the 1-based position: dropping the point silently would
//!   change lengths and similarities.
//! - NaN or infinite coordinates and unsorted timestamps are errors too (see
//!   [`crate::algo::traj`]). An empty list is a valid, empty trajectory.

use crate::algo::region::Region;
use crate::algo::traj::{Series, Traj};
use duckdb::core::{DataChunkHandle, FlatVector, Inserter, ListVector, LogicalTypeHandle, LogicalTypeId, StructVector};
use duckdb::types::DuckString;
use duckdb::vscalar::ScalarFunctionSignature;
use duckdb::ffi::{self, duckdb_string_t};
use std::cell::RefCell;
use std::error::Error;

pub type FnResult = Result<(), Box<dyn Error>>;

// ---------------------------------------------------------------- types

pub fn double() -> LogicalTypeHandle {
    LogicalTypeId::Double.into()
}
pub fn bigint() -> LogicalTypeHandle {
    LogicalTypeId::Bigint.into()
}
pub fn integer() -> LogicalTypeHandle {
    LogicalTypeId::Integer.into()
}
pub fn varchar() -> LogicalTypeHandle {
    LogicalTypeId::Varchar.into()
}
pub fn blob() -> LogicalTypeHandle {
    LogicalTypeId::Blob.into()
}
pub fn boolean() -> LogicalTypeHandle {
    LogicalTypeId::Boolean.into()
}
/// `STRUCT(t DOUBLE, x DOUBLE, y DOUBLE)[]`, the trajectory type.
pub fn traj_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&LogicalTypeHandle::struct_type(&[("t", double()), ("x", double()), ("y", double())]))
}
/// `STRUCT(t DOUBLE, v DOUBLE)[]`, a 1-D series such as speeds.
pub fn series_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&LogicalTypeHandle::struct_type(&[("t", double()), ("v", double())]))
}
/// `STRUCT(i INTEGER, j INTEGER)[]`, matched index pairs (1-based).
pub fn pairs_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&LogicalTypeHandle::struct_type(&[("i", integer()), ("j", integer())]))
}
pub fn struct_of(fields: &[(&str, LogicalTypeHandle)]) -> LogicalTypeHandle {
    LogicalTypeHandle::struct_type(fields)
}
pub fn sig(params: Vec<LogicalTypeHandle>, ret: LogicalTypeHandle) -> ScalarFunctionSignature {
    ScalarFunctionSignature::exact(params, ret)
}

// ---------------------------------------------------------------- errors

/// `"<function>: <message>"`, the form of every trajdb error.
pub fn err(function: &str, msg: impl std::fmt::Display) -> Box<dyn Error> {
    format!("{function}: {msg}").into()
}

// ---------------------------------------------------------------- readers

/// Validity mask of one vector, read once per chunk (NULL pointer = all rows valid).
#[derive(Clone, Copy)]
struct Validity(*mut u64);

impl Validity {
    fn of(v: ffi::duckdb_vector) -> Self {
        // SAFETY: `v` is a live vector of the current chunk.
        Validity(unsafe { ffi::duckdb_vector_get_validity(v) })
    }
    #[inline]
    fn is_null(&self, row: usize) -> bool {
        // SAFETY: the mask covers every row of its vector; `row` is within it.
        !self.0.is_null() && unsafe { *self.0.add(row / 64) >> (row % 64) & 1 == 0 }
    }
    fn all_valid(&self) -> bool {
        self.0.is_null()
    }
}

/// A column of lists of structs whose fields are all DOUBLE (trajectories or series).
///
/// Reads DuckDB's buffers directly (list entries, field data, validity masks), fetched once
/// per chunk: per-element FFI calls cost more than the LCSS itself on short tracks.
pub struct ListOfStructCol<'a> {
    entries: &'a [ffi::duckdb_list_entry],
    list_validity: Validity,
    pts_validity: Validity,
    field_validity: Vec<Validity>,
    fields: Vec<&'a [f64]>,
    names: &'static [&'static str],
}

impl<'a> ListOfStructCol<'a> {
    fn new(input: &'a DataChunkHandle, col: usize, names: &'static [&'static str]) -> Self {
        // SAFETY: `col` is a LIST(STRUCT(DOUBLE, ...)) column of this chunk (fixed by the
        // registered signature). DuckDB flattens scalar-function inputs, so entries are indexed
        // by row.
        unsafe {
            let lv = ffi::duckdb_data_chunk_get_vector(input.get_ptr(), col as u64);
            Self::from_list_vector(lv, input.len(), names)
        }
    }

    /// # Safety
    /// `lv` is a live LIST(STRUCT(8-byte fields...)) vector with at least `n` entries; its child
    /// has `duckdb_list_vector_get_size` elements and each struct field is a flat vector of that size.
    unsafe fn from_list_vector(lv: ffi::duckdb_vector, n: usize, names: &'static [&'static str]) -> Self {
        unsafe {
            let total = ffi::duckdb_list_vector_get_size(lv) as usize;
            let child = ffi::duckdb_list_vector_get_child(lv);
            let entries = std::slice::from_raw_parts(ffi::duckdb_vector_get_data(lv) as *const ffi::duckdb_list_entry, n);
            let mut fields = Vec::with_capacity(names.len());
            let mut field_validity = Vec::with_capacity(names.len());
            for k in 0..names.len() {
                let fv = ffi::duckdb_struct_vector_get_child(child, k as u64);
                let data = ffi::duckdb_vector_get_data(fv) as *const f64;
                fields.push(if total == 0 { &[][..] } else { std::slice::from_raw_parts(data, total) });
                field_validity.push(Validity::of(fv));
            }
            ListOfStructCol {
                entries,
                list_validity: Validity::of(lv),
                pts_validity: Validity::of(child),
                field_validity,
                fields,
                names,
            }
        }
    }

    /// `(offset, len)` of `row`, or `None` for a NULL list. Errors on a NULL point or NULL
    /// field inside the list.
    fn entry(&self, row: usize, function: &str, param: &str) -> Result<Option<(usize, usize)>, Box<dyn Error>> {
        if self.list_validity.is_null(row) {
            return Ok(None);
        }
        let e = self.entries[row];
        let (off, len) = (e.offset as usize, e.length as usize);
        if !self.pts_validity.all_valid() {
            if let Some(k) = (off..off + len).find(|&k| self.pts_validity.is_null(k)) {
                return Err(err(function, format!("{param}[{}] is NULL; filter NULL points out first", k - off + 1)));
            }
        }
        for (f, v) in self.field_validity.iter().enumerate() {
            if v.all_valid() {
                continue;
            }
            if let Some(k) = (off..off + len).find(|&k| v.is_null(k)) {
                return Err(err(
                    function,
                    format!("{param}[{}].{} is NULL; filter NULL points out first", k - off + 1, self.names[f]),
                ));
            }
        }
        Ok(Some((off, len)))
    }

    fn field(&self, k: usize) -> &'a [f64] {
        self.fields[k]
    }

    /// Public constructor for other list-of-DOUBLE-struct arguments.
    pub fn new_pub(input: &'a DataChunkHandle, col: usize, names: &'static [&'static str]) -> Self {
        Self::new(input, col, names)
    }

    /// The field slices of `row` (NULL list → `None`; NULL inside → error).
    pub fn row_fields(&self, row: usize, function: &str, param: &str) -> Result<Option<Vec<&'a [f64]>>, Box<dyn Error>> {
        let Some((off, len)) = self.entry(row, function, param)? else { return Ok(None) };
        Ok(Some(self.fields.iter().map(|f| &f[off..off + len]).collect()))
    }

    /// Number of points of a row without validating them (NULL list → `None`).
    pub fn raw_len(&self, row: usize) -> Option<usize> {
        if self.list_validity.is_null(row) {
            None
        } else {
            Some(self.entries[row].length as usize)
        }
    }
}

/// A VARCHAR argument, its vector fetched once per chunk.
pub struct VarcharCol<'a> {
    v: FlatVector<'a>,
    n: usize,
}

impl<'a> VarcharCol<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        VarcharCol { v: input.flat_vector(col), n: input.len() }
    }
    /// The text of `row`, `None` when NULL.
    pub fn get(&self, row: usize) -> Option<String> {
        if self.v.row_is_null(row as u64) {
            return None;
        }
        // SAFETY: the column is VARCHAR (fixed by the signature); `row` < chunk length.
        let mut s = unsafe { self.v.as_slice_with_len::<duckdb_string_t>(self.n) }[row];
        Some(DuckString::new(&mut s).as_str().to_string())
    }
}

/// Reads a list of trajectories (`STRUCT(t, x, y)[][]`) straight from DuckDB's buffers.
pub struct TrajListCol<'a> {
    outer: &'a [ffi::duckdb_list_entry],
    outer_validity: Validity,
    inner_validity: Validity,
    inner: ListOfStructCol<'a>,
}

impl<'a> TrajListCol<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        // SAFETY: `col` is a LIST(LIST(STRUCT(t, x, y DOUBLE))) column (fixed by the signature);
        // the inner list vector is the outer one's child, holding `duckdb_list_vector_get_size`
        // entries.
        unsafe {
            let lv = ffi::duckdb_data_chunk_get_vector(input.get_ptr(), col as u64);
            let n_inner = ffi::duckdb_list_vector_get_size(lv) as usize;
            let inner_lv = ffi::duckdb_list_vector_get_child(lv);
            let outer = std::slice::from_raw_parts(ffi::duckdb_vector_get_data(lv) as *const ffi::duckdb_list_entry, input.len());
            TrajListCol {
                outer,
                outer_validity: Validity::of(lv),
                inner_validity: Validity::of(inner_lv),
                inner: ListOfStructCol::from_list_vector(inner_lv, n_inner, &["t", "x", "y"]),
            }
        }
    }

    /// The validated trajectories of `row`; a NULL element is an error naming its position.
    pub fn get(&self, row: usize, function: &str, param: &str) -> Result<Option<Vec<Traj<'a>>>, Box<dyn Error>> {
        if self.outer_validity.is_null(row) {
            return Ok(None);
        }
        let e = self.outer[row];
        let mut out = Vec::with_capacity(e.length as usize);
        for k in e.offset as usize..(e.offset + e.length) as usize {
            let name = format!("{param}[{}]", k - e.offset as usize + 1);
            if self.inner_validity.is_null(k) {
                return Err(err(function, format!("{name} is NULL; filter NULL trajectories out first")));
            }
            let (off, len) = self.inner.entry(k, function, &name)?.expect("checked non-NULL");
            let r = off..off + len;
            let tr = Traj::new(&self.inner.field(0)[r.clone()], &self.inner.field(1)[r.clone()], &self.inner.field(2)[r]);
            tr.validate().map_err(|e| err(function, e.describe(&name)))?;
            out.push(tr);
        }
        Ok(Some(out))
    }
}

/// Reads a `BIGINT[]` argument.
pub struct I64ListCol<'a> {
    entries: &'a [ffi::duckdb_list_entry],
    validity: Validity,
    child_validity: Validity,
    data: &'a [i64],
}

impl<'a> I64ListCol<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        // SAFETY: `col` is a LIST(BIGINT) column of this chunk (fixed by the signature), flattened;
        // its child holds `duckdb_list_vector_get_size` BIGINTs.
        unsafe {
            let lv = ffi::duckdb_data_chunk_get_vector(input.get_ptr(), col as u64);
            let total = ffi::duckdb_list_vector_get_size(lv) as usize;
            let child = ffi::duckdb_list_vector_get_child(lv);
            let data = ffi::duckdb_vector_get_data(child) as *const i64;
            I64ListCol {
                entries: std::slice::from_raw_parts(ffi::duckdb_vector_get_data(lv) as *const ffi::duckdb_list_entry, input.len()),
                validity: Validity::of(lv),
                child_validity: Validity::of(child),
                data: if total == 0 { &[][..] } else { std::slice::from_raw_parts(data, total) },
            }
        }
    }

    /// The values of `row`; a NULL element is an error naming its position.
    pub fn get(&self, row: usize, function: &str, param: &str) -> Result<Option<&'a [i64]>, Box<dyn Error>> {
        if self.validity.is_null(row) {
            return Ok(None);
        }
        let e = self.entries[row];
        let r = e.offset as usize..(e.offset + e.length) as usize;
        if !self.child_validity.all_valid() {
            if let Some(k) = r.clone().find(|&k| self.child_validity.is_null(k)) {
                return Err(err(function, format!("{param}[{}] is NULL", k - r.start + 1)));
            }
        }
        Ok(Some(&self.data[r]))
    }
}

/// An `i64` stored in a DOUBLE-typed 8-byte slot (for BIGINT struct fields read or written
/// through the DOUBLE-field helpers: DuckDB only sees the bytes).
pub fn i64_bits(v: f64) -> i64 {
    v.to_bits() as i64
}
pub fn bits_i64(v: i64) -> f64 {
    f64::from_bits(v as u64)
}

/// Reads a trajectory argument (`STRUCT(t, x, y)[]`).
pub struct TrajCol<'a>(ListOfStructCol<'a>);

impl<'a> TrajCol<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        TrajCol(ListOfStructCol::new(input, col, &["t", "x", "y"]))
    }
    /// The validated trajectory of `row`, `None` when the list is NULL.
    pub fn get(&self, row: usize, function: &str, param: &str) -> Result<Option<Traj<'_>>, Box<dyn Error>> {
        let Some((off, len)) = self.0.entry(row, function, param)? else { return Ok(None) };
        let r = off..off + len;
        let tr = Traj::new(&self.0.field(0)[r.clone()], &self.0.field(1)[r.clone()], &self.0.field(2)[r]);
        tr.validate().map_err(|e| err(function, e.describe(param)))?;
        Ok(Some(tr))
    }
    pub fn raw_len(&self, row: usize) -> Option<usize> {
        self.0.raw_len(row)
    }
}

/// `STRUCT(t DOUBLE, x DOUBLE, y DOUBLE, z DOUBLE)[]`, a 3-D trajectory.
pub fn traj3_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&LogicalTypeHandle::struct_type(&[("t", double()), ("x", double()), ("y", double()), ("z", double())]))
}

/// Reads a 3-D trajectory argument (`STRUCT(t, x, y, z)[]`): `(t, x, y, z)` slices.
pub struct Traj3Col<'a>(ListOfStructCol<'a>);

impl<'a> Traj3Col<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        Traj3Col(ListOfStructCol::new(input, col, &["t", "x", "y", "z"]))
    }
    #[allow(clippy::type_complexity)]
    pub fn get(&self, row: usize, function: &str, param: &str) -> Result<Option<(&'a [f64], &'a [f64], &'a [f64], &'a [f64])>, Box<dyn Error>> {
        let Some(c) = self.0.row_fields(row, function, param)? else { return Ok(None) };
        for (k, name) in ["t", "x", "y", "z"].iter().enumerate() {
            if let Some(i) = c[k].iter().position(|v| !v.is_finite()) {
                return Err(err(function, format!("{param}[{}].{name} must be finite, got {}", i + 1, c[k][i])));
            }
        }
        if let Some(i) = c[0].windows(2).position(|w| w[1] < w[0]) {
            return Err(err(function, format!("{param} must be ordered by t, but {param}[{}].t follows a later t", i + 2)));
        }
        Ok(Some((c[0], c[1], c[2], c[3])))
    }
}

/// Reads a series argument (`STRUCT(t, v)[]`).
pub struct SeriesCol<'a>(ListOfStructCol<'a>);

impl<'a> SeriesCol<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        SeriesCol(ListOfStructCol::new(input, col, &["t", "v"]))
    }
    pub fn get(&self, row: usize, function: &str, param: &str) -> Result<Option<Series<'_>>, Box<dyn Error>> {
        let Some((off, len)) = self.0.entry(row, function, param)? else { return Ok(None) };
        let r = off..off + len;
        let s = Series::new(&self.0.field(0)[r.clone()], &self.0.field(1)[r]);
        s.validate().map_err(|e| err(function, e.describe(param)))?;
        Ok(Some(s))
    }
}

/// `STRUCT(theta DOUBLE, tx DOUBLE, ty DOUBLE, scale DOUBLE)`, the 2-D transform type.
pub fn transform_type() -> LogicalTypeHandle {
    LogicalTypeHandle::struct_type(&[("theta", double()), ("tx", double()), ("ty", double()), ("scale", double())])
}

/// Reads a column of structs whose fields are all DOUBLE (e.g. transforms), straight from
/// DuckDB's buffers. A NULL struct gives `None`; a NULL field is an error.
pub struct StructF64Col<'a> {
    validity: Validity,
    fields: Vec<(&'a [f64], Validity)>,
    names: &'static [&'static str],
}

impl<'a> StructF64Col<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize, names: &'static [&'static str]) -> Self {
        let n = input.len();
        // SAFETY: `col` is a STRUCT of DOUBLE fields (fixed by the signature), flattened.
        unsafe {
            let v = ffi::duckdb_data_chunk_get_vector(input.get_ptr(), col as u64);
            let fields = (0..names.len())
                .map(|k| {
                    let fv = ffi::duckdb_struct_vector_get_child(v, k as u64);
                    let data = ffi::duckdb_vector_get_data(fv) as *const f64;
                    (if n == 0 { &[][..] } else { std::slice::from_raw_parts(data, n) }, Validity::of(fv))
                })
                .collect();
            StructF64Col { validity: Validity::of(v), fields, names }
        }
    }
    pub fn get(&self, row: usize, function: &str, param: &str) -> Result<Option<Vec<f64>>, Box<dyn Error>> {
        if self.validity.is_null(row) {
            return Ok(None);
        }
        let mut out = Vec::with_capacity(self.fields.len());
        for (k, (data, v)) in self.fields.iter().enumerate() {
            if v.is_null(row) {
                return Err(err(function, format!("{param}.{} is NULL", self.names[k])));
            }
            out.push(data[row]);
        }
        Ok(Some(out))
    }
}

/// A flat column of a fixed-width primitive (DOUBLE → f64, BIGINT → i64).
pub struct PrimCol<'a> {
    v: FlatVector<'a>,
    n: usize,
}

impl<'a> PrimCol<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        PrimCol { v: input.flat_vector(col), n: input.len() }
    }
    pub fn f64(&self, row: usize) -> Option<f64> {
        if self.v.row_is_null(row as u64) {
            None
        } else {
            // SAFETY: the signature declares this column DOUBLE; `row < n`.
            Some(unsafe { self.v.as_slice_with_len::<f64>(self.n) }[row])
        }
    }
    pub fn bool(&self, row: usize) -> Option<bool> {
        if self.v.row_is_null(row as u64) {
            None
        } else {
            // SAFETY: the signature declares this column BOOLEAN (one byte, 0 or 1); `row < n`.
            Some(unsafe { self.v.as_slice_with_len::<u8>(self.n) }[row] != 0)
        }
    }
    pub fn i64(&self, row: usize) -> Option<i64> {
        if self.v.row_is_null(row as u64) {
            None
        } else {
            // SAFETY: the signature declares this column BIGINT; `row < n`.
            Some(unsafe { self.v.as_slice_with_len::<i64>(self.n) }[row])
        }
    }
}

/// An optional trailing argument (absent from the shorter signatures of a function). Each
/// getter gives `None` when the argument is present and NULL in `row` (so the row's result is
/// NULL), else its value, or the default when the argument is absent: the NULL policy of every
/// optional argument, once.
pub struct OptCol<'a>(Option<PrimCol<'a>>);

impl<'a> OptCol<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        OptCol((col < input.num_columns()).then(|| PrimCol::new(input, col)))
    }
    pub fn f64_or(&self, row: usize, default: f64) -> Option<f64> {
        self.0.as_ref().map_or(Some(default), |c| c.f64(row))
    }
    pub fn i64_or(&self, row: usize, default: i64) -> Option<i64> {
        self.0.as_ref().map_or(Some(default), |c| c.i64(row))
    }
    pub fn bool_or(&self, row: usize, default: bool) -> Option<bool> {
        self.0.as_ref().map_or(Some(default), |c| c.bool(row))
    }
    /// `Some(None)` when absent (no default: the callee decides).
    pub fn f64_opt(&self, row: usize) -> Option<Option<f64>> {
        self.0.as_ref().map_or(Some(None), |c| c.f64(row).map(Some))
    }
    pub fn bool_opt(&self, row: usize) -> Option<Option<bool>> {
        self.0.as_ref().map_or(Some(None), |c| c.bool(row).map(Some))
    }
}

/// A polygon argument given as WKT (VARCHAR) or WKB (BLOB). The parsed region of the last
/// distinct value is cached, so a constant region is parsed once per chunk, not per row.
pub struct RegionCol<'a> {
    v: FlatVector<'a>,
    n: usize,
    is_text: bool,
    /// The last few distinct polygons of this chunk, parsed, validated and indexed: a polygon
    /// repeated over rows (one overlap per class or camera pair) is prepared once per chunk.
    cache: RefCell<Vec<(Vec<u8>, std::rc::Rc<Region>)>>,
}

/// How many distinct polygons [`RegionCol`] keeps prepared per chunk.
const REGION_CACHE: usize = 8;

impl<'a> RegionCol<'a> {
    pub fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        let v = input.flat_vector(col);
        let is_text = matches!(v.logical_type().id(), LogicalTypeId::Varchar);
        RegionCol { v, n: input.len(), is_text, cache: RefCell::new(Vec::new()) }
    }
    pub fn get(&self, row: usize, function: &str, param: &str) -> Result<Option<std::rc::Rc<Region>>, Box<dyn Error>> {
        if self.v.row_is_null(row as u64) {
            return Ok(None);
        }
        // SAFETY: VARCHAR and BLOB columns both store duckdb_string_t.
        let s = unsafe { self.v.as_slice_with_len::<duckdb_string_t>(self.n) }[row];
        let mut s = s;
        let bytes = DuckString::new(&mut s).as_bytes();
        if let Some((_, r)) = self.cache.borrow().iter().find(|(k, _)| k.as_slice() == bytes) {
            return Ok(Some(r.clone()));
        }
        let region = if self.is_text {
            let text = std::str::from_utf8(bytes).map_err(|_| err(function, format!("{param} is not valid UTF-8")))?;
            Region::from_wkt(text)
        } else {
            Region::from_wkb(bytes)
        }
        .map_err(|e| err(function, format!("{param} {e}")))?;
        let region = std::rc::Rc::new(region);
        let mut cache = self.cache.borrow_mut();
        if cache.len() == REGION_CACHE {
            cache.remove(0);
        }
        cache.push((bytes.to_vec(), region.clone()));
        Ok(Some(region))
    }
}

// ---------------------------------------------------------------- writers

/// Runs `f` for every row and collects the results; the first error aborts the query.
pub fn map_rows<T>(
    n: usize,
    mut f: impl FnMut(usize) -> Result<Option<T>, Box<dyn Error>>,
) -> Result<Vec<Option<T>>, Box<dyn Error>> {
    (0..n).map(&mut f).collect()
}

/// Sets the list entries of a list column whose child already holds the rows' elements back
/// to back: `lens[row]` elements for each row, `None` = NULL row.
pub fn write_list_entries(out: &mut ListVector<'_>, lens: impl IntoIterator<Item = Option<usize>>) {
    let mut off = 0;
    for (row, len) in lens.into_iter().enumerate() {
        match len {
            Some(len) => {
                out.set_entry(row, off, len);
                off += len;
            }
            None => out.set_null(row),
        }
    }
    out.set_len(off);
}

/// Writes a column of `f64`/`i64`/... with NULLs.
pub fn write_flat<T: Copy>(out: &mut FlatVector<'_>, vals: &[Option<T>]) {
    {
        // SAFETY: the output vector has the declared fixed-width type and capacity >= rows.
        let dst = unsafe { out.as_mut_slice_with_len::<T>(vals.len()) };
        for (d, v) in dst.iter_mut().zip(vals) {
            if let Some(v) = v {
                *d = *v;
            }
        }
    }
    for (row, v) in vals.iter().enumerate() {
        if v.is_none() {
            out.set_null(row);
        }
    }
}

/// Writes BLOB results (WKB), NULL where `None`.
pub fn write_blobs(output: &mut dyn duckdb::vtab::arrow::WritableVector, vals: &[Option<Vec<u8>>]) {
    let mut out = output.flat_vector();
    for (row, v) in vals.iter().enumerate() {
        match v {
            Some(b) => out.insert(row, b.as_slice()),
            None => out.set_null(row),
        }
    }
}

pub fn write_varchar(out: &mut FlatVector<'_>, vals: &[Option<String>]) {
    for (row, v) in vals.iter().enumerate() {
        match v {
            Some(s) => out.insert(row, s.as_str()),
            None => out.set_null(row),
        }
    }
}

/// Writes a column of structs whose fields are all `f64`, one `Vec` per row.
pub fn write_struct_f64(out: &mut StructVector<'_>, nfields: usize, vals: &[Option<Vec<f64>>]) {
    let n = vals.len();
    for f in 0..nfields {
        let mut c = out.child(f, n);
        // SAFETY: every field of this struct type is DOUBLE.
        let dst = unsafe { c.as_mut_slice_with_len::<f64>(n) };
        for (row, v) in vals.iter().enumerate() {
            if let Some(v) = v {
                dst[row] = v[f];
            }
        }
    }
    for (row, v) in vals.iter().enumerate() {
        if v.is_none() {
            out.set_null(row);
        }
    }
}

/// One field value of a struct row for [`write_struct`].
#[derive(Clone, Copy, Debug)]
pub enum Field {
    F(f64),
    I(i64),
    B(bool),
}

/// Writes a column of structs with mixed DOUBLE / BIGINT / BOOLEAN fields; every row has the
/// same field kinds in the declared order.
pub fn write_struct(out: &mut StructVector<'_>, nfields: usize, vals: &[Option<Vec<Field>>]) {
    let n = vals.len();
    for f in 0..nfields {
        let mut c = out.child(f, n);
        for (row, v) in vals.iter().enumerate() {
            let Some(v) = v else { continue };
            // SAFETY: the declared field type matches the variant written (see callers).
            unsafe {
                match v[f] {
                    Field::F(x) => c.as_mut_slice_with_len::<f64>(n)[row] = x,
                    Field::I(x) => c.as_mut_slice_with_len::<i64>(n)[row] = x,
                    Field::B(x) => c.as_mut_slice_with_len::<bool>(n)[row] = x,
                }
            }
        }
    }
    for (row, v) in vals.iter().enumerate() {
        if v.is_none() {
            out.set_null(row);
        }
    }
}

/// Writes a column of lists of 2-field structs. Each row is `None` (NULL) or two equally long
/// columns of field values.
pub fn write_list_of_pairs<A: Copy, B: Copy>(out: &mut ListVector<'_>, vals: &[Option<(Vec<A>, Vec<B>)>]) {
    let total: usize = vals.iter().flatten().map(|(a, _)| a.len()).sum();
    {
        let child = out.struct_child(total);
        let mut c0 = child.child(0, total);
        let mut c1 = child.child(1, total);
        // SAFETY: capacity `total` was reserved by `struct_child`; field types are A and B.
        let d0 = unsafe { c0.as_mut_slice_with_len::<A>(total) };
        let d1 = unsafe { c1.as_mut_slice_with_len::<B>(total) };
        let mut off = 0;
        for (a, b) in vals.iter().flatten() {
            d0[off..off + a.len()].copy_from_slice(a);
            d1[off..off + b.len()].copy_from_slice(b);
            off += a.len();
        }
    }
    write_list_entries(out, vals.iter().map(|v| v.as_ref().map(|(a, _)| a.len())));
}

/// Writes a column of lists of structs whose fields are all DOUBLE. Each row is `None` (NULL)
/// or one equally long column per field.
pub fn write_list_struct_f64(out: &mut ListVector<'_>, nfields: usize, vals: &[Option<Vec<&[f64]>>]) {
    let total: usize = vals.iter().flatten().map(|cols| cols[0].len()).sum();
    {
        let child = out.struct_child(total);
        let mut cols: Vec<FlatVector<'_>> = (0..nfields).map(|k| child.child(k, total)).collect();
        let mut off = 0;
        for row in vals.iter().flatten() {
            let len = row[0].len();
            for (k, src) in row.iter().enumerate() {
                // SAFETY: capacity `total` was reserved by `struct_child`; fields are DOUBLE.
                let d = unsafe { cols[k].as_mut_slice_with_len::<f64>(total) };
                d[off..off + len].copy_from_slice(src);
            }
            off += len;
        }
    }
    write_list_entries(out, vals.iter().map(|v| v.as_ref().map(|cols| cols[0].len())));
}

/// Writes a column of trajectories (`STRUCT(t, x, y)[]`).
pub fn write_trajs(out: &mut ListVector<'_>, vals: &[Option<crate::algo::traj::OwnedTraj>]) {
    let cols: Vec<Option<Vec<&[f64]>>> =
        vals.iter().map(|v| v.as_ref().map(|t| vec![&t.t[..], &t.x[..], &t.y[..]])).collect();
    write_list_struct_f64(out, 3, &cols);
}

/// Documentation attached to every registered function; `trajdb_functions()` and
/// `docs/functions.md` are generated from these.
#[derive(Clone, Copy, Debug)]
pub struct FnDoc {
    pub name: &'static str,
    /// One line per overload, e.g. `lcss_length(a TRAJ, b TRAJ, epsilon DOUBLE, time_window DOUBLE) -> BIGINT`.
    pub signatures: &'static str,
    pub description: &'static str,
    pub example: &'static str,
}

/// Declares a unit struct implementing `VScalar` whose `invoke` calls `$body`.
macro_rules! scalar_fn {
    // A shared implementation `$body(input, output, $arg...)`.
    ($ty:ident, $sigs:expr, $body:path, $($arg:expr),+) => {
        scalar_fn!($ty, $sigs, |i: &mut duckdb::core::DataChunkHandle, o: &mut dyn duckdb::vtab::arrow::WritableVector| $body(i, o, $($arg),+));
    };
    ($ty:ident, $sigs:expr, $body:expr) => {
        pub struct $ty;
        impl duckdb::vscalar::VScalar for $ty {
            type State = ();
            fn invoke(
                _: &(),
                input: &mut duckdb::core::DataChunkHandle,
                output: &mut dyn duckdb::vtab::arrow::WritableVector,
            ) -> Result<(), Box<dyn std::error::Error>> {
                $body(input, output)
            }
            fn signatures() -> Vec<duckdb::vscalar::ScalarFunctionSignature> {
                $sigs
            }
        }
    };
}
pub(crate) use scalar_fn;
