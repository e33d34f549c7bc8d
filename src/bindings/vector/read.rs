//! Column readers: DuckDB's buffers (list entries, struct fields, validity masks) borrowed
//! once per chunk, then read by row without further FFI calls.
//!
//! Every reader knows its function's declared parameter name (from the registry), so its
//! errors say which argument and which position is wrong: `b[2] is NULL; filter NULL points
//! out first`. The function name is added by the registry's dispatcher.

use super::Kind;
use crate::algo::geometry::region::Region;
use crate::algo::traj::{Bounds, Series, Traj, Traj3};
use duckdb::core::{DataChunkHandle, FlatVector, LogicalTypeId};
use duckdb::ffi::{self, duckdb_string_t};
use duckdb::types::DuckString;
use std::cell::RefCell;
use std::error::Error;
use std::ops::Range;
use std::sync::Arc;

type Res<T> = Result<T, Box<dyn Error>>;

/// Validity mask of one vector (NULL pointer = every row valid).
#[derive(Clone, Copy)]
struct Validity(*mut u64);

impl Validity {
    fn of(v: ffi::duckdb_vector) -> Self {
        // SAFETY: `v` is a live vector of the current chunk.
        Validity(unsafe { ffi::duckdb_vector_get_validity(v) })
    }
    #[inline]
    fn is_null(&self, row: usize) -> bool {
        // SAFETY: the mask covers every row of its vector and `row` is within it.
        !self.0.is_null() && unsafe { *self.0.add(row / 64) >> (row % 64) & 1 == 0 }
    }
    fn all_valid(&self) -> bool {
        self.0.is_null()
    }
    /// The first NULL position in `r`, if any: 64 rows a step (a mask word whose rows in `r`
    /// are all valid is skipped whole; this runs over every point of every trajectory argument).
    fn first_null(&self, r: Range<usize>) -> Option<usize> {
        if self.all_valid() || r.is_empty() {
            return None;
        }
        let (mut k, end) = (r.start, r.end);
        while k < end {
            let (w, bit) = (k / 64, k % 64);
            let span = (64 - bit).min(end - k);
            // SAFETY: the mask covers every row of its vector and `k < end <= rows`.
            let word = unsafe { *self.0.add(w) } >> bit;
            let want = if span == 64 { u64::MAX } else { (1u64 << span) - 1 };
            let nulls = !word & want;
            if nulls != 0 {
                return Some(k + nulls.trailing_zeros() as usize);
            }
            k += span;
        }
        None
    }
}

/// The vector of argument `col`.
fn vector(chunk: &DataChunkHandle, col: usize) -> ffi::duckdb_vector {
    // SAFETY: `col` is a column of this live chunk (the registered signature fixes the count).
    unsafe { ffi::duckdb_data_chunk_get_vector(chunk.get_ptr(), col as u64) }
}

/// A typed slice over a vector's data buffer.
///
/// # Safety
/// `v` is a live flat vector of at least `n` elements of type `T`.
unsafe fn data<'a, T>(v: ffi::duckdb_vector, n: usize) -> &'a [T] {
    if n == 0 {
        &[]
    } else {
        unsafe { std::slice::from_raw_parts(ffi::duckdb_vector_get_data(v) as *const T, n) }
    }
}

/// A LIST vector: entries, validity and its child.
#[derive(Clone, Copy)]
struct Lists<'a> {
    entries: &'a [ffi::duckdb_list_entry],
    validity: Validity,
    child: ffi::duckdb_vector,
    child_len: usize,
}

impl<'a> Lists<'a> {
    /// # Safety
    /// `v` is a live LIST vector with at least `n` entries (DuckDB flattens scalar inputs).
    unsafe fn of(v: ffi::duckdb_vector, n: usize) -> Self {
        unsafe {
            Lists {
                entries: data(v, n),
                validity: Validity::of(v),
                child: ffi::duckdb_list_vector_get_child(v),
                child_len: ffi::duckdb_list_vector_get_size(v) as usize,
            }
        }
    }
    /// The child positions of `row`; `None` for a NULL list.
    fn range(&self, row: usize) -> Option<Range<usize>> {
        if self.validity.is_null(row) {
            return None;
        }
        let e = self.entries[row];
        Some(e.offset as usize..(e.offset + e.length) as usize)
    }
}

/// One field of a struct vector.
#[derive(Clone, Copy)]
enum FieldData<'a> {
    F64(&'a [f64]),
    I64(&'a [i64]),
    /// BOOLEAN: one byte per row, 0 or 1 (read as bytes, never as Rust `bool`)
    Bool(&'a [u8]),
}

/// A STRUCT vector of DOUBLE, BIGINT or BOOLEAN fields, `n` rows.
struct Fields<'a> {
    validity: Validity,
    data: Vec<(FieldData<'a>, Validity)>,
    names: Vec<&'static str>,
}

impl<'a> Fields<'a> {
    /// # Safety
    /// `v` is a live STRUCT vector of `n` rows whose fields have the kinds `fields`.
    unsafe fn of(v: ffi::duckdb_vector, n: usize, fields: &[(&'static str, Kind)]) -> Self {
        let data = fields
            .iter()
            .enumerate()
            .map(|(k, (_, kind))| unsafe {
                let fv = ffi::duckdb_struct_vector_get_child(v, k as u64);
                let d = match kind {
                    Kind::F64 => FieldData::F64(data(fv, n)),
                    Kind::I64 => FieldData::I64(data(fv, n)),
                    Kind::Bool => FieldData::Bool(data(fv, n)),
                };
                (d, Validity::of(fv))
            })
            .collect();
        Fields { validity: Validity::of(v), data, names: fields.iter().map(|f| f.0).collect() }
    }
    /// Errors on the first NULL field in `r` (`param[k].field is NULL`).
    fn check(&self, r: Range<usize>, param: &str, hint: &str) -> Res<()> {
        let off = r.start;
        if let Some(k) = self.validity.first_null(r.clone()) {
            return Err(format!("{param}[{}] is NULL{hint}", k - off + 1).into());
        }
        for (f, (_, v)) in self.data.iter().enumerate() {
            if let Some(k) = v.first_null(r.clone()) {
                return Err(format!("{param}[{}].{} is NULL{hint}", k - off + 1, self.names[f]).into());
            }
        }
        Ok(())
    }
    fn rows(&self, r: Range<usize>) -> Rows<'a> {
        let len = r.len();
        let data = self
            .data
            .iter()
            .map(|(d, _)| match d {
                FieldData::F64(s) => FieldData::F64(&s[r.clone()]),
                FieldData::I64(s) => FieldData::I64(&s[r.clone()]),
                FieldData::Bool(s) => FieldData::Bool(&s[r.clone()]),
            })
            .collect();
        Rows { data, len }
    }
}

/// The elements of one list of structs: one slice per field, all of length [`Rows::len`].
pub struct Rows<'a> {
    data: Vec<FieldData<'a>>,
    len: usize,
}

impl<'a> Rows<'a> {
    pub fn len(&self) -> usize {
        self.len
    }
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// Number of fields.
    pub fn width(&self) -> usize {
        self.data.len()
    }
    /// Field `k`, declared DOUBLE.
    pub fn f64(&self, k: usize) -> &'a [f64] {
        match self.data[k] {
            FieldData::F64(s) => s,
            _ => panic!("field {k} is not DOUBLE (declared type)"),
        }
    }
    /// Field `k`, declared BIGINT.
    pub fn i64(&self, k: usize) -> &'a [i64] {
        match self.data[k] {
            FieldData::I64(s) => s,
            _ => panic!("field {k} is not BIGINT (declared type)"),
        }
    }
}

/// `LIST(STRUCT(...))` with DOUBLE / BIGINT fields: trajectories, series, pairs, edges,
/// endpoints. A NULL list gives `None`; a NULL element or field is an error.
pub struct StructListCol<'a> {
    lists: Lists<'a>,
    fields: Fields<'a>,
    param: &'static str,
    hint: &'static str,
}

impl<'a> StructListCol<'a> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize, param: &'static str, fields: &[(&'static str, Kind)]) -> Self {
        // SAFETY: the registered signature declares `col` as LIST(STRUCT(fields)); the chunk is
        // flat and holds `chunk.len()` rows.
        unsafe { Self::of(vector(chunk, col), chunk.len(), param, fields) }
    }
    /// # Safety
    /// `v` is a live LIST(STRUCT(fields)) vector with at least `n` entries.
    unsafe fn of(v: ffi::duckdb_vector, n: usize, param: &'static str, fields: &[(&'static str, Kind)]) -> Self {
        unsafe {
            let lists = Lists::of(v, n);
            let f = Fields::of(lists.child, lists.child_len, fields);
            let is_points = fields.iter().any(|f| f.0 == "t");
            StructListCol { lists, fields: f, param, hint: if is_points { "; filter NULL points out first" } else { "" } }
        }
    }
    /// The elements of `row`, named `name` in errors.
    fn get_named(&self, row: usize, name: &str) -> Res<Option<Rows<'a>>> {
        Ok(self.checked_range(row, name)?.map(|r| self.fields.rows(r)))
    }
    /// The element positions of `row` after the NULL checks (`None` for a NULL list).
    fn checked_range(&self, row: usize, name: &str) -> Res<Option<Range<usize>>> {
        let Some(r) = self.lists.range(row) else { return Ok(None) };
        self.fields.check(r.clone(), name, self.hint)?;
        Ok(Some(r))
    }
    /// DOUBLE field `k` at positions `r`, without building a [`Rows`] (the per-row path of the
    /// point readers, which run once per row of every LCSS call).
    fn f64_at(&self, k: usize, r: Range<usize>) -> &'a [f64] {
        match self.fields.data[k].0 {
            FieldData::F64(s) => &s[r],
            _ => panic!("field {k} is not DOUBLE (declared type)"),
        }
    }
    pub fn get(&self, row: usize) -> Res<Option<Rows<'a>>> {
        self.get_named(row, self.param)
    }
    /// Number of elements of `row` without validating them (`None` for a NULL list).
    pub fn raw_len(&self, row: usize) -> Option<usize> {
        self.lists.range(row).map(|r| r.len())
    }
}

const TXY: [(&str, Kind); 3] = [("t", Kind::F64), ("x", Kind::F64), ("y", Kind::F64)];

/// A trajectory argument (`STRUCT(t, x, y)[]`), validated by [`Traj::validate`].
pub struct TrajCol<'a>(StructListCol<'a>);

impl<'a> TrajCol<'a> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize, param: &'static str) -> Self {
        TrajCol(StructListCol::new(chunk, col, param, &TXY))
    }
    pub fn get(&self, row: usize) -> Res<Option<Traj<'a>>> {
        to_traj(&self.0, row, self.0.param)
    }
    /// [`TrajCol::get`] with the bounding box of the points, from the same validating pass
    /// ([`Traj::validate_bounds`]).
    pub fn get_bounded(&self, row: usize) -> Res<Option<(Traj<'a>, Bounds)>> {
        let (c, name) = (&self.0, self.0.param);
        let Some(r) = c.checked_range(row, name)? else { return Ok(None) };
        let tr = Traj::new(c.f64_at(0, r.clone()), c.f64_at(1, r.clone()), c.f64_at(2, r));
        let b = tr.validate_bounds().map_err(|e| e.describe(name))?;
        Ok(Some((tr, b)))
    }
    pub fn raw_len(&self, row: usize) -> Option<usize> {
        self.0.raw_len(row)
    }
}

fn to_traj<'a>(c: &StructListCol<'a>, row: usize, name: &str) -> Res<Option<Traj<'a>>> {
    let Some(r) = c.checked_range(row, name)? else { return Ok(None) };
    let tr = Traj::new(c.f64_at(0, r.clone()), c.f64_at(1, r.clone()), c.f64_at(2, r));
    tr.validate().map_err(|e| e.describe(name))?;
    Ok(Some(tr))
}

/// A 3-D trajectory argument (`STRUCT(t, x, y, z)[]`), validated by [`Traj3::validate`].
pub struct Traj3Col<'a>(StructListCol<'a>);

impl<'a> Traj3Col<'a> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize, param: &'static str) -> Self {
        Traj3Col(StructListCol::new(chunk, col, param, &[("t", Kind::F64), ("x", Kind::F64), ("y", Kind::F64), ("z", Kind::F64)]))
    }
    pub fn get(&self, row: usize) -> Res<Option<Traj3<'a>>> {
        let c = &self.0;
        let Some(r) = c.checked_range(row, c.param)? else { return Ok(None) };
        let tr = Traj3::new(c.f64_at(0, r.clone()), c.f64_at(1, r.clone()), c.f64_at(2, r.clone()), c.f64_at(3, r));
        tr.validate().map_err(|e| e.describe(self.0.param))?;
        Ok(Some(tr))
    }
}

/// A series argument (`STRUCT(t, v)[]`), validated by [`Series::validate`].
pub struct SeriesCol<'a>(StructListCol<'a>);

impl<'a> SeriesCol<'a> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize, param: &'static str) -> Self {
        SeriesCol(StructListCol::new(chunk, col, param, &[("t", Kind::F64), ("v", Kind::F64)]))
    }
    pub fn get(&self, row: usize) -> Res<Option<Series<'a>>> {
        let c = &self.0;
        let Some(r) = c.checked_range(row, c.param)? else { return Ok(None) };
        let s = Series::new(c.f64_at(0, r.clone()), c.f64_at(1, r));
        s.validate().map_err(|e| e.describe(self.0.param))?;
        Ok(Some(s))
    }
}

/// A list of trajectories (`STRUCT(t, x, y)[][]`).
pub struct TrajListCol<'a> {
    outer: Lists<'a>,
    inner: StructListCol<'a>,
    param: &'static str,
}

impl<'a> TrajListCol<'a> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize, param: &'static str) -> Self {
        // SAFETY: the signature declares `col` as LIST(LIST(STRUCT(t, x, y DOUBLE))); the inner
        // list vector is the outer one's child and holds `child_len` entries.
        unsafe {
            let outer = Lists::of(vector(chunk, col), chunk.len());
            let inner = StructListCol::of(outer.child, outer.child_len, param, &TXY);
            TrajListCol { outer, inner, param }
        }
    }
    /// The validated trajectories of `row`; a NULL trajectory is an error naming its position.
    pub fn get(&self, row: usize) -> Res<Option<Vec<Traj<'a>>>> {
        let Some(r) = self.outer.range(row) else { return Ok(None) };
        let off = r.start;
        let mut out = Vec::with_capacity(r.len());
        for k in r {
            let name = format!("{}[{}]", self.param, k - off + 1);
            match to_traj(&self.inner, k, &name)? {
                Some(t) => out.push(t),
                None => return Err(format!("{name} is NULL; filter NULL trajectories out first").into()),
            }
        }
        Ok(Some(out))
    }
}

/// A `BIGINT[]` argument.
pub type I64ListCol<'a> = PrimListCol<'a, i64>;
/// A `DOUBLE[]` argument.
pub type F64ListCol<'a> = PrimListCol<'a, f64>;

/// A list of a fixed-width type (`BIGINT[]` → i64, `DOUBLE[]` → f64), read in place.
pub struct PrimListCol<'a, T> {
    lists: Lists<'a>,
    data: &'a [T],
    validity: Validity,
    param: &'static str,
}

impl<'a, T> PrimListCol<'a, T> {
    /// # Safety
    /// The signature declares `col` as a LIST of the SQL type whose values are `T`.
    pub(super) unsafe fn new(chunk: &'a DataChunkHandle, col: usize, param: &'static str) -> Self {
        // SAFETY: the child of the LIST vector holds `child_len` values of type T (caller).
        unsafe {
            let lists = Lists::of(vector(chunk, col), chunk.len());
            PrimListCol { data: data(lists.child, lists.child_len), validity: Validity::of(lists.child), lists, param }
        }
    }
    pub fn get(&self, row: usize) -> Res<Option<&'a [T]>> {
        let Some(r) = self.lists.range(row) else { return Ok(None) };
        if let Some(k) = self.validity.first_null(r.clone()) {
            return Err(format!("{}[{}] is NULL", self.param, k - r.start + 1).into());
        }
        Ok(Some(&self.data[r]))
    }
}

/// A STRUCT argument of DOUBLE, BIGINT or BOOLEAN fields (a transform, a map fit), each read as
/// an f64 (BOOLEAN as 0 or 1). A NULL struct gives `None`; a NULL field is an error.
pub struct StructCol<'a> {
    fields: Fields<'a>,
    param: &'static str,
}

impl<'a> StructCol<'a> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize, param: &'static str, fields: &[(&'static str, Kind)]) -> Self {
        // SAFETY: the signature declares `col` as STRUCT(fields) of these kinds; the chunk is flat.
        unsafe { StructCol { fields: Fields::of(vector(chunk, col), chunk.len(), fields), param } }
    }
    pub fn get(&self, row: usize) -> Res<Option<Vec<f64>>> {
        if self.fields.validity.is_null(row) {
            return Ok(None);
        }
        let mut out = Vec::with_capacity(self.fields.data.len());
        for (k, (d, v)) in self.fields.data.iter().enumerate() {
            if v.is_null(row) {
                return Err(format!("{}.{} is NULL", self.param, self.fields.names[k]).into());
            }
            match d {
                FieldData::F64(s) => out.push(s[row]),
                FieldData::I64(s) => out.push(s[row] as f64),
                FieldData::Bool(s) => out.push(if s[row] != 0 { 1.0 } else { 0.0 }),
            }
        }
        Ok(Some(out))
    }
}

/// A flat column of one fixed-width type `T` (DOUBLE → f64, BIGINT → i64, BOOLEAN → bool).
pub struct PrimCol<'a, T: Prim> {
    data: &'a [T::Raw],
    validity: Validity,
}

/// The Rust types [`PrimCol`] reads, with the storage of their SQL type.
pub trait Prim: Copy {
    type Raw: Copy;
    fn from_raw(r: Self::Raw) -> Self;
}
impl Prim for f64 {
    type Raw = f64;
    fn from_raw(r: f64) -> f64 {
        r
    }
}
impl Prim for i64 {
    type Raw = i64;
    fn from_raw(r: i64) -> i64 {
        r
    }
}
impl Prim for bool {
    // BOOLEAN is one byte, 0 or 1.
    type Raw = u8;
    fn from_raw(r: u8) -> bool {
        r != 0
    }
}

impl<'a, T: Prim> PrimCol<'a, T> {
    /// The data buffer and validity mask, borrowed once (a row read is then a load, not two
    /// FFI calls).
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize) -> Self {
        let v = vector(chunk, col);
        // SAFETY: the signature declares this column with T's SQL type, whose storage is
        // `T::Raw`; the chunk is flat and holds `chunk.len()` rows.
        PrimCol { data: unsafe { data(v, chunk.len()) }, validity: Validity::of(v) }
    }
    /// The value of `row`, `None` when NULL.
    pub fn get(&self, row: usize) -> Option<T> {
        if self.validity.is_null(row) {
            None
        } else {
            Some(T::from_raw(self.data[row]))
        }
    }
}

/// An optional trailing argument (absent from the shorter overloads). The NULL policy of every
/// optional argument, once: present and NULL gives `None` (the row's result is NULL); absent
/// gives the default.
pub struct OptCol<'a, T: Prim>(Option<PrimCol<'a, T>>);

impl<'a, T: Prim> OptCol<'a, T> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize) -> Self {
        OptCol((col < chunk.num_columns()).then(|| PrimCol::new(chunk, col)))
    }
    /// The value, or `default` when the argument is absent; `None` when it is NULL.
    pub fn or(&self, row: usize, default: T) -> Option<T> {
        self.0.as_ref().map_or(Some(default), |c| c.get(row))
    }
    /// `Some(None)` when absent (the callee decides the default), `None` when NULL.
    pub fn opt(&self, row: usize) -> Option<Option<T>> {
        self.0.as_ref().map_or(Some(None), |c| c.get(row).map(Some))
    }
}

/// A VARCHAR argument.
pub struct TextCol<'a> {
    v: FlatVector<'a>,
    n: usize,
}

impl<'a> TextCol<'a> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize) -> Self {
        TextCol { v: chunk.flat_vector(col), n: chunk.len() }
    }
    pub fn get(&self, row: usize) -> Option<String> {
        if self.v.row_is_null(row as u64) {
            return None;
        }
        // SAFETY: the column is VARCHAR (fixed by the signature); `row < n`.
        let mut s = unsafe { self.v.as_slice_with_len::<duckdb_string_t>(self.n) }[row];
        Some(DuckString::new(&mut s).as_str().to_string())
    }
}

/// Parses one polygon given as WKT text or WKB bytes; errors name `param`.
fn parse_region(bytes: &[u8], is_text: bool, param: &str) -> Res<Region> {
    let region = if is_text {
        let text = std::str::from_utf8(bytes).map_err(|_| format!("{param} is not valid UTF-8"))?;
        Region::from_wkt(text)
    } else {
        Region::from_wkb(bytes)
    };
    Ok(region.map_err(|e| format!("{param} {e}"))?)
}

/// A polygon argument, WKT (VARCHAR) or WKB (BLOB). The last few distinct polygons of a chunk
/// are kept parsed, validated and indexed: a polygon repeated over rows (one overlap per class
/// or camera pair) is prepared once per chunk, not per row.
pub struct RegionCol<'a> {
    v: FlatVector<'a>,
    n: usize,
    is_text: bool,
    param: &'static str,
    cache: RefCell<Vec<(Vec<u8>, Arc<Region>)>>,
}

/// How many distinct polygons [`RegionCol`] keeps prepared per chunk.
const REGION_CACHE: usize = 8;

impl<'a> RegionCol<'a> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize, param: &'static str) -> Self {
        let v = chunk.flat_vector(col);
        let is_text = matches!(v.logical_type().id(), LogicalTypeId::Varchar);
        RegionCol { v, n: chunk.len(), is_text, param, cache: RefCell::new(Vec::new()) }
    }
    pub fn get(&self, row: usize) -> Res<Option<Arc<Region>>> {
        if self.v.row_is_null(row as u64) {
            return Ok(None);
        }
        // SAFETY: VARCHAR and BLOB columns both store duckdb_string_t; `row < n`.
        let mut s = unsafe { self.v.as_slice_with_len::<duckdb_string_t>(self.n) }[row];
        let bytes = DuckString::new(&mut s).as_bytes();
        if let Some((_, r)) = self.cache.borrow().iter().find(|(k, _)| k.as_slice() == bytes) {
            return Ok(Some(r.clone()));
        }
        let region = Arc::new(parse_region(bytes, self.is_text, self.param)?);
        let mut cache = self.cache.borrow_mut();
        if cache.len() == REGION_CACHE {
            cache.remove(0);
        }
        cache.push((bytes.to_vec(), region.clone()));
        Ok(Some(region))
    }
}

/// An optional trailing polygon argument, with the NULL policy of [`OptCol`]: absent gives
/// `Some(None)` (no region), present and NULL gives `None` (the row's result is NULL).
pub struct OptRegionCol<'a>(pub(super) Option<RegionCol<'a>>);

impl OptRegionCol<'_> {
    pub fn get(&self, row: usize) -> Res<Option<Option<Arc<Region>>>> {
        match &self.0 {
            None => Ok(Some(None)),
            Some(c) => Ok(c.get(row)?.map(Some)),
        }
    }
}

/// A `VARCHAR[]` or `BLOB[]` argument of polygons.
pub struct RegionListCol<'a> {
    lists: Lists<'a>,
    strings: &'a [duckdb_string_t],
    validity: Validity,
    is_text: bool,
    param: &'static str,
}

impl<'a> RegionListCol<'a> {
    pub(super) fn new(chunk: &'a DataChunkHandle, col: usize, param: &'static str) -> Self {
        let is_text = matches!(chunk.flat_vector(col).logical_type().child(0).id(), LogicalTypeId::Varchar);
        // SAFETY: the signature declares `col` as LIST(VARCHAR) or LIST(BLOB); both children
        // store `child_len` duckdb_string_t.
        unsafe {
            let lists = Lists::of(vector(chunk, col), chunk.len());
            RegionListCol { strings: data(lists.child, lists.child_len), validity: Validity::of(lists.child), lists, is_text, param }
        }
    }
    pub fn get(&self, row: usize) -> Res<Option<Vec<Region>>> {
        let Some(r) = self.lists.range(row) else { return Ok(None) };
        let off = r.start;
        let mut out = Vec::with_capacity(r.len());
        for k in r {
            let name = format!("{}[{}]", self.param, k - off + 1);
            if self.validity.is_null(k) {
                return Err(format!("{name} is NULL; filter NULL polygons out first").into());
            }
            let mut s = self.strings[k];
            out.push(parse_region(DuckString::new(&mut s).as_bytes(), self.is_text, &name)?);
        }
        Ok(Some(out))
    }
}

// The readers [`Args::par_map`] shares between its workers. Each is a read-only view of the
// chunk's vectors (data pointers, validity masks, lengths): nothing in them is written after
// `new`, and DuckDB neither moves nor frees the chunk while the scalar function runs, so shared
// references from several threads read the same immutable memory. RegionCol (a RefCell cache)
// is not among them: the compiler keeps it out of par_map.
// SAFETY: as above.
unsafe impl Sync for StructListCol<'_> {}
unsafe impl Sync for TrajCol<'_> {}
unsafe impl Sync for Traj3Col<'_> {}
unsafe impl Sync for SeriesCol<'_> {}
unsafe impl Sync for TrajListCol<'_> {}
unsafe impl Sync for I64ListCol<'_> {}
unsafe impl Sync for StructCol<'_> {}
unsafe impl<T: Prim> Sync for PrimCol<'_, T> {}
unsafe impl<T: Prim> Sync for OptCol<'_, T> {}
unsafe impl Sync for TextCol<'_> {}
