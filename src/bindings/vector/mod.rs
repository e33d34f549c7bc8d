//! The only place that touches DuckDB vectors: every `unsafe` block and FFI call of the
//! bindings is in this module (`read.rs`, `write.rs`; `table.rs`: table functions' arguments,
//! settings and rows).
//!
//! A kernel gets an [`Args`] (the input chunk with its declared parameters) and an [`Out`] (the
//! result vector). It reads with the typed column readers of [`Args`], calls `crate::algo`, and
//! writes with one [`Out`] writer; it never sees a raw vector.
//!
//! # NULL policy (every trajdb scalar function)
//! - A NULL argument (a NULL list, number, text or polygon) gives a NULL result for that row.
//! - A NULL *inside* a list argument (a NULL point, a NULL t, x or y, a NULL pair) is an error
//!   naming the argument and the 1-based position (`b[2] is NULL; filter NULL points out
//!   first`): dropping the element silently would change lengths and similarities.
//! - An absent optional argument takes its default ([`OptCol`]); a present NULL one gives NULL.
//! - NaN / infinite values, unsorted timestamps and out-of-range parameters are errors decided
//!   in `crate::algo` (its parameter types and `validate` methods). An empty list is a valid,
//!   empty trajectory.

pub mod fs;
mod read;
pub mod table;
mod write;

pub use read::{F64ListCol, I64ListCol, OptCol, OptRegionCol, PrimCol, RegionCol, RegionListCol, Rows, SeriesCol, StructCol, StructListCol, TextCol, Traj3Col, TrajCol, TrajListCol};
pub use write::{chunk_set_bool, chunk_set_f64, chunk_set_i64, chunk_set_null, Column, Out, Value};

use super::types::{Param, Ty};
use duckdb::core::DataChunkHandle;
use std::error::Error;

/// The file this library was loaded from (its bytes name the build an archive's results depend
/// on: crates/app/src/archive/fingerprint.rs `build`); `None` where the loader cannot say.
pub fn extension_file() -> Option<std::path::PathBuf> {
    // SAFETY: dladdr only reads the loader's tables for an address inside this library, and
    // fills `info`, zeroed here; the name it points to lives as long as the library is loaded
    unsafe {
        let mut info: libc::Dl_info = std::mem::zeroed();
        if libc::dladdr(extension_file as *const libc::c_void, &mut info) == 0 || info.dli_fname.is_null() {
            return None;
        }
        Some(std::path::PathBuf::from(std::ffi::CStr::from_ptr(info.dli_fname).to_string_lossy().into_owned()))
    }
}

/// The storage of a struct field the readers support (8-byte DOUBLE or BIGINT; BOOLEAN, one
/// byte, read by `StructCol::get` as 0 or 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    F64,
    I64,
    Bool,
}

/// The fields of a declared `STRUCT` type (or of the element type of a `LIST(STRUCT)`).
fn struct_fields(ty: &Ty) -> Vec<(&'static str, Kind)> {
    let fields = match ty {
        Ty::Struct(f) => *f,
        Ty::List(Ty::Struct(f)) => *f,
        other => panic!("not a struct or a list of structs: {other:?}"),
    };
    fields
        .iter()
        .map(|(name, t)| match t {
            Ty::Double => (*name, Kind::F64),
            Ty::Bigint => (*name, Kind::I64),
            Ty::Boolean => (*name, Kind::Bool),
            other => panic!("struct field {name} has type {other:?}; the readers take DOUBLE, BIGINT and BOOLEAN fields"),
        })
        .collect()
}

/// Rows per work item of [`Args::par_map`] (a 2,048-row chunk makes 64 items).
const PAR_BLOCK: usize = 32;

/// The input of one call: the chunk, and the declared parameters of the matched signature.
pub struct Args<'a> {
    chunk: &'a DataChunkHandle,
    params: &'static [Param],
}

type Res<T> = Result<T, Box<dyn Error>>;

impl<'a> Args<'a> {
    pub(crate) fn new(chunk: &'a DataChunkHandle, params: &'static [Param]) -> Self {
        Args { chunk, params }
    }
    /// Rows in this chunk.
    pub fn rows(&self) -> usize {
        self.chunk.len()
    }
    /// Whether the call passed argument `col` (optional trailing arguments).
    pub fn given(&self, col: usize) -> bool {
        col < self.chunk.num_columns()
    }
    /// The declared name of argument `col`.
    pub fn name(&self, col: usize) -> &'static str {
        self.params[col].name
    }
    /// Runs `f` for every row and collects the results; the first error aborts the query.
    pub fn map<T>(&self, f: impl FnMut(usize) -> Res<Option<T>>) -> Res<Vec<Option<T>>> {
        (0..self.rows()).map(f).collect()
    }
    /// As [`Args::map`], the rows on all cores (rayon), for kernels whose rows are expensive.
    /// DuckDB parallelises across morsels of ~122,880 rows, so a chunk of a small table (12,000
    /// track pairs to fit, 16,000 road users to fuse) runs on one thread however many cores
    /// there are; here its rows spread over all of them. The column readers are read-only views
    /// of the chunk's vectors, shared by the workers for the duration of the call (their `Sync`
    /// below); the work limits of the caller's scope hold on the workers; the error reported is
    /// the first row's in row order (every row runs), with its message.
    ///
    /// The rows go to the workers in blocks of [`PAR_BLOCK`], each block entering the caller's
    /// scope once: per row, the scope's shared reference count was touched by both cores
    /// (cache-line traffic that cost more than a cheap row, e.g. an LCSS pair that cannot match).
    pub fn par_map<T: Send>(&self, f: impl Fn(usize) -> Res<Option<T>> + Sync) -> Res<Vec<Option<T>>> {
        use rayon::prelude::*;
        let scope = crate::algo::limits::current();
        let n = self.rows();
        let blocks: Vec<Vec<Result<Option<T>, String>>> = (0..n.div_ceil(PAR_BLOCK))
            .into_par_iter()
            .map(|k| {
                crate::algo::limits::within(&scope, || {
                    (k * PAR_BLOCK..((k + 1) * PAR_BLOCK).min(n)).map(|r| f(r).map_err(|e| e.to_string())).collect()
                })
            })
            .collect();
        blocks.into_iter().flatten().map(|v| v.map_err(|e| e.into())).collect()
    }

    pub fn traj(&self, col: usize) -> TrajCol<'a> {
        TrajCol::new(self.chunk, col, self.name(col))
    }
    pub fn traj3(&self, col: usize) -> Traj3Col<'a> {
        Traj3Col::new(self.chunk, col, self.name(col))
    }
    pub fn series(&self, col: usize) -> SeriesCol<'a> {
        SeriesCol::new(self.chunk, col, self.name(col))
    }
    pub fn traj_list(&self, col: usize) -> TrajListCol<'a> {
        TrajListCol::new(self.chunk, col, self.name(col))
    }
    pub fn i64_list(&self, col: usize) -> I64ListCol<'a> {
        debug_assert!(matches!(self.params[col].ty, Ty::List(Ty::Bigint)));
        // SAFETY: the registered signature declares `col` as BIGINT[].
        unsafe { I64ListCol::new(self.chunk, col, self.name(col)) }
    }
    pub fn f64_list(&self, col: usize) -> F64ListCol<'a> {
        debug_assert!(matches!(self.params[col].ty, Ty::List(Ty::Double)));
        // SAFETY: the registered signature declares `col` as DOUBLE[].
        unsafe { F64ListCol::new(self.chunk, col, self.name(col)) }
    }
    /// A `LIST(STRUCT)` argument with the fields of its declared type.
    pub fn struct_list(&self, col: usize) -> StructListCol<'a> {
        StructListCol::new(self.chunk, col, self.name(col), &struct_fields(&self.params[col].ty))
    }
    /// A `STRUCT` argument with the fields of its declared type.
    pub fn structure(&self, col: usize) -> StructCol<'a> {
        StructCol::new(self.chunk, col, self.name(col), &struct_fields(&self.params[col].ty))
    }
    pub fn double(&self, col: usize) -> PrimCol<'a, f64> {
        PrimCol::new(self.chunk, col)
    }
    /// The first `N` arguments, all DOUBLE, as one reader: row `r` gives `[f64; N]`, or `None`
    /// when any of them is NULL (the kernels of scalar formulas).
    pub fn doubles<const N: usize>(&self) -> impl Fn(usize) -> Option<[f64; N]> + 'a {
        let cols: [PrimCol<'a, f64>; N] = std::array::from_fn(|i| self.double(i));
        move |r| {
            let mut v = [0.0; N];
            for (x, c) in v.iter_mut().zip(&cols) {
                *x = c.get(r)?;
            }
            Some(v)
        }
    }
    pub fn bigint(&self, col: usize) -> PrimCol<'a, i64> {
        PrimCol::new(self.chunk, col)
    }
    pub fn opt_double(&self, col: usize) -> OptCol<'a, f64> {
        OptCol::new(self.chunk, col)
    }
    pub fn opt_bigint(&self, col: usize) -> OptCol<'a, i64> {
        OptCol::new(self.chunk, col)
    }
    pub fn opt_boolean(&self, col: usize) -> OptCol<'a, bool> {
        OptCol::new(self.chunk, col)
    }
    pub fn text(&self, col: usize) -> TextCol<'a> {
        TextCol::new(self.chunk, col)
    }
    /// A polygon argument (WKT VARCHAR or WKB BLOB).
    pub fn region(&self, col: usize) -> RegionCol<'a> {
        RegionCol::new(self.chunk, col, self.name(col))
    }
    /// A polygon argument that only the longer overloads pass.
    pub fn opt_region(&self, col: usize) -> OptRegionCol<'a> {
        OptRegionCol(self.given(col).then(|| self.region(col)))
    }
    /// A `VARCHAR[]` / `BLOB[]` argument of polygons.
    pub fn region_list(&self, col: usize) -> RegionListCol<'a> {
        RegionListCol::new(self.chunk, col, self.name(col))
    }
}
