//! Output writers: flat columns, STRUCT columns and `LIST(STRUCT)` columns, with NULL rows.

use crate::algo::traj::OwnedTraj;
use duckdb::core::{FlatVector, Inserter, ListVector};
use duckdb::vtab::arrow::WritableVector;

/// One field value of a STRUCT result row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    F64(f64),
    I64(i64),
    Bool(bool),
    /// a NULL field of a non-NULL row
    Null,
}

/// One field of a `LIST(STRUCT)` result row: the field's values for every element of the list.
#[derive(Clone, Copy, Debug)]
pub enum Column<'v> {
    F64(&'v [f64]),
    I64(&'v [i64]),
    I32(&'v [i32]),
    Text(&'v [&'v str]),
    /// DOUBLE fields that may be NULL
    OptF64(&'v [Option<f64>]),
    /// BIGINT fields that may be NULL
    OptI64(&'v [Option<i64>]),
    /// BOOLEAN fields that may be NULL
    OptBool(&'v [Option<bool>]),
}

impl Column<'_> {
    fn len(&self) -> usize {
        match self {
            Column::F64(s) => s.len(),
            Column::I64(s) => s.len(),
            Column::I32(s) => s.len(),
            Column::Text(s) => s.len(),
            Column::OptF64(s) => s.len(),
            Column::OptI64(s) => s.len(),
            Column::OptBool(s) => s.len(),
        }
    }
}

/// Fixed-width values a flat result column holds.
pub trait Flat: Copy {}
impl Flat for f64 {}
impl Flat for i64 {}
impl Flat for bool {}

/// The result vector of one call. Every writer writes `vals.len()` rows (the chunk's rows),
/// `None` as NULL.
pub struct Out<'a> {
    v: &'a mut dyn WritableVector,
}

impl<'a> Out<'a> {
    pub(crate) fn new(v: &'a mut dyn WritableVector) -> Self {
        Out { v }
    }

    /// DOUBLE, BIGINT or BOOLEAN results.
    pub fn flat<T: Flat>(&mut self, vals: &[Option<T>]) {
        let mut out = self.v.flat_vector();
        {
            // SAFETY: the registered return type is T's SQL type, and the output vector holds
            // at least the chunk's rows.
            let dst = unsafe { out.as_mut_slice_with_len::<T>(vals.len()) };
            for (d, v) in dst.iter_mut().zip(vals) {
                if let Some(v) = v {
                    *d = *v;
                }
            }
        }
        set_nulls(&mut out, vals.iter().map(Option::is_none));
    }

    /// VARCHAR results.
    pub fn text<S: AsRef<str>>(&mut self, vals: &[Option<S>]) {
        let mut out = self.v.flat_vector();
        for (row, v) in vals.iter().enumerate() {
            match v {
                Some(s) => out.insert(row, s.as_ref()),
                None => out.set_null(row),
            }
        }
    }

    /// BLOB results (WKB).
    pub fn blobs(&mut self, vals: &[Option<Vec<u8>>]) {
        let mut out = self.v.flat_vector();
        for (row, v) in vals.iter().enumerate() {
            match v {
                Some(b) => out.insert(row, b.as_slice()),
                None => out.set_null(row),
            }
        }
    }

    /// STRUCT results: every row has the declared fields in order.
    pub fn structs(&mut self, vals: &[Option<Vec<Value>>]) {
        let n = vals.len();
        let mut out = self.v.struct_vector();
        for f in 0..out.num_children() {
            let mut c = out.child(f, n);
            for (row, v) in vals.iter().enumerate() {
                // DuckDB reads a field of a NULL struct from the child vector: NULL it too.
                let Some(v) = v else {
                    c.set_null(row);
                    continue;
                };
                // SAFETY: the registered field type matches the variant written (one kernel
                // writes one fixed layout), and the child holds `n` rows.
                unsafe {
                    match v[f] {
                        Value::F64(x) => c.as_mut_slice_with_len::<f64>(n)[row] = x,
                        Value::I64(x) => c.as_mut_slice_with_len::<i64>(n)[row] = x,
                        Value::Bool(x) => c.as_mut_slice_with_len::<bool>(n)[row] = x,
                        Value::Null => c.set_null(row),
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

    /// `LIST(STRUCT)` results: each row is `None` (NULL) or one [`Column`] per declared field,
    /// all of the row's list length.
    ///
    /// DuckDB's reserve of the list child throws (and so aborts the host through this Rust
    /// frame) when it cannot allocate; so the bytes it will need are first allocated and freed
    /// here, fallibly ([`probe`]): too large a result is an error naming its size, never an abort.
    pub fn struct_lists(&mut self, vals: &[Option<Vec<Column<'_>>>]) -> Result<(), String> {
        let row_len = |cols: &Vec<Column<'_>>| cols.first().map_or(0, Column::len);
        let total: usize = vals.iter().flatten().map(row_len).sum();
        // every field of a list element: 16 bytes at most (a VARCHAR's string_t), plus validity
        let nfields = vals.iter().flatten().map(Vec::len).next().unwrap_or(0);
        probe(total, 17 * nfields.max(1))?;
        let mut out = self.v.list_vector();
        {
            // struct_child(total) reserves room for every element before any is written.
            let child = out.struct_child(total);
            let nfields = vals.iter().flatten().map(Vec::len).next().unwrap_or(0);
            let mut fields: Vec<FlatVector<'_>> = (0..nfields).map(|k| child.child(k, total)).collect();
            let mut off = 0;
            for cols in vals.iter().flatten() {
                let len = row_len(cols);
                for (dst, src) in fields.iter_mut().zip(cols) {
                    assert_eq!(src.len(), len, "struct_lists: the fields of one row differ in length");
                    copy_into(dst, total, off, src);
                }
                off += len;
            }
        }
        list_entries(&mut out, vals.iter().map(|v| v.as_ref().map(row_len)));
        Ok(())
    }

    /// Trajectory results (`STRUCT(t, x, y)[]`).
    pub fn trajs(&mut self, vals: &[Option<OwnedTraj>]) -> Result<(), String> {
        let cols: Vec<Option<Vec<Column<'_>>>> =
            vals.iter().map(|v| v.as_ref().map(|t| vec![Column::F64(&t.t), Column::F64(&t.x), Column::F64(&t.y)])).collect();
        self.struct_lists(&cols)
    }
}

/// `Ok` when `n` elements of `bytes_each` bytes could be allocated now (a fallible allocation
/// of that size, freed at once: untouched, it costs an address range, not memory); otherwise
/// the error that names the size. Run before DuckDB allocates a result of that size, whose
/// failure would throw through Rust and abort the host.
pub fn probe(n: usize, bytes_each: usize) -> Result<(), String> {
    let bytes = (n as u128) * (bytes_each as u128);
    let refuse = || format!("the result holds {n} list elements (about {bytes} bytes), more than this process can allocate; return less per call");
    let b = usize::try_from(bytes).map_err(|_| refuse())?;
    let mut v: Vec<u8> = Vec::new();
    v.try_reserve_exact(b).map_err(|_| refuse())?;
    Ok(())
}

/// Copies one field's values of one row to positions `off..` of a struct field vector of
/// capacity `total`.
fn copy_into(dst: &mut FlatVector<'_>, total: usize, off: usize, src: &Column<'_>) {
    // SAFETY: `dst` was reserved for `total` elements by `struct_child(total)`, its SQL type is
    // the one of `src`'s variant (fixed by the registered return type), and off + len <= total.
    unsafe {
        match src {
            Column::F64(s) => dst.as_mut_slice_with_len::<f64>(total)[off..off + s.len()].copy_from_slice(s),
            Column::I64(s) => dst.as_mut_slice_with_len::<i64>(total)[off..off + s.len()].copy_from_slice(s),
            Column::I32(s) => dst.as_mut_slice_with_len::<i32>(total)[off..off + s.len()].copy_from_slice(s),
            Column::Text(s) => {
                for (k, v) in s.iter().enumerate() {
                    dst.insert(off + k, *v);
                }
            }
            Column::OptF64(s) => {
                let d = &mut dst.as_mut_slice_with_len::<f64>(total)[off..off + s.len()];
                for (d, v) in d.iter_mut().zip(s.iter()) {
                    *d = v.unwrap_or(0.0);
                }
                set_nulls_from(dst, off, s.iter().map(Option::is_none));
            }
            Column::OptI64(s) => {
                let d = &mut dst.as_mut_slice_with_len::<i64>(total)[off..off + s.len()];
                for (d, v) in d.iter_mut().zip(s.iter()) {
                    *d = v.unwrap_or(0);
                }
                set_nulls_from(dst, off, s.iter().map(Option::is_none));
            }
            Column::OptBool(s) => {
                let d = &mut dst.as_mut_slice_with_len::<bool>(total)[off..off + s.len()];
                for (d, v) in d.iter_mut().zip(s.iter()) {
                    *d = v.unwrap_or(false);
                }
                set_nulls_from(dst, off, s.iter().map(Option::is_none));
            }
        }
    }
}

/// Sets the list entries of a list column whose child holds the rows' elements back to back:
/// `len` elements for each row, `None` = NULL row.
fn list_entries(out: &mut ListVector<'_>, lens: impl IntoIterator<Item = Option<usize>>) {
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

/// NULLs at positions `off + k` of a struct field vector for every `true` of `nulls`.
fn set_nulls_from(out: &mut FlatVector<'_>, off: usize, nulls: impl Iterator<Item = bool>) {
    for (k, null) in nulls.enumerate() {
        if null {
            out.set_null(off + k);
        }
    }
}

fn set_nulls(out: &mut FlatVector<'_>, nulls: impl Iterator<Item = bool>) {
    for (row, null) in nulls.enumerate() {
        if null {
            out.set_null(row);
        }
    }
}

/// Writes one DOUBLE into column `col`, row `row`, of a table function's output chunk
/// (`row` < 2048, the chunk's capacity).
pub fn chunk_set_f64(chunk: &mut duckdb::core::DataChunkHandle, col: usize, row: usize, v: f64) {
    assert!(row < 2048, "a data chunk holds 2048 rows");
    let mut c = chunk.flat_vector(col);
    // SAFETY: a table function's output vectors hold the standard vector size (2048) of the
    // column's type, DOUBLE here (the caller's bind declared it).
    unsafe { c.as_mut_slice_with_len::<f64>(2048)[row] = v };
}

/// Writes one BOOLEAN into column `col`, row `row`, of a table function's output chunk.
pub fn chunk_set_bool(chunk: &mut duckdb::core::DataChunkHandle, col: usize, row: usize, v: bool) {
    assert!(row < 2048, "a data chunk holds 2048 rows");
    let mut c = chunk.flat_vector(col);
    // SAFETY: a table function's output vectors hold the standard vector size (2048) of the
    // column's type, BOOLEAN (one byte per value) here (the caller's bind declared it).
    unsafe { c.as_mut_slice_with_len::<bool>(2048)[row] = v };
}

/// Writes NULL into column `col`, row `row`, of a table function's output chunk.
pub fn chunk_set_null(chunk: &mut duckdb::core::DataChunkHandle, col: usize, row: usize) {
    assert!(row < 2048, "a data chunk holds 2048 rows");
    chunk.flat_vector(col).set_null(row);
}

/// Writes one BIGINT into column `col`, row `row`, of a table function's output chunk
/// (`row` < 2048, the chunk's capacity).
pub fn chunk_set_i64(chunk: &mut duckdb::core::DataChunkHandle, col: usize, row: usize, v: i64) {
    assert!(row < 2048, "a data chunk holds 2048 rows");
    let mut c = chunk.flat_vector(col);
    // SAFETY: a table function's output vectors hold the standard vector size (2048) of the
    // column's type, BIGINT here (the caller's bind declared it).
    unsafe { c.as_mut_slice_with_len::<i64>(2048)[row] = v };
}
