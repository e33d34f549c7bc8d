//! SQL: one-to-one selection of candidate pairs (the Hungarian step of thesis Alg. 2–4):
//! `hungarian_match` (optimal assignment, absent pairs forbidden: scipy semantics) and
//! `assign_pairs` (maximum total weight, the thesis's dense-with-zeros variant).

use super::convert::*;
use crate::algo::{assign, hungarian};
use duckdb::core::{DataChunkHandle, LogicalTypeHandle};
use duckdb::vtab::arrow::WritableVector;
use duckdb::Connection;
use std::error::Error;

pub const DOCS: &[FnDoc] = &[
FnDoc {
    name: "hungarian_match",
    signatures: "hungarian_match(pairs STRUCT(a BIGINT, b BIGINT, score DOUBLE)[] [, maximize BOOLEAN [, min_score DOUBLE]]) -> STRUCT(a BIGINT, b BIGINT, score DOUBLE)[]",
    description: "Optimal one-to-one assignment over a sparse, possibly rectangular list of candidate pairs; pairs not in the list can never be matched. \
                  It matches as many pairs as possible and, among those, maximises (maximize = true, the default: similarities) or minimises (costs) the total, \
                  exactly like scipy.optimize.linear_sum_assignment on the dense matrix with absent pairs forbidden (rows that cannot be matched stay unmatched \
                  instead of raising). min_score removes candidates before solving: with maximize, pairs scoring below it; with costs, pairs above it. \
                  Duplicate (a, b) pairs keep their best score; ties are broken the same way whatever the list order; the result is sorted by (a, b). \
                  Connected components of the candidate graph are solved separately (in parallel), dense ones with lsap (scipy's LSAP), sparse ones with a sparse \
                  shortest-augmenting-path solver. NULL or NaN scores are errors; an empty list gives an empty list.",
    example: "SELECT hungarian_match([{'a': 1, 'b': 10, 'score': 0.9}, {'a': 1, 'b': 20, 'score': 0.8}, {'a': 2, 'b': 10, 'score': 0.8}], true, 0.5); -- [{'a': 1, 'b': 20, 'score': 0.8}, {'a': 2, 'b': 10, 'score': 0.8}]",
},
FnDoc {
    name: "assign_pairs",
    signatures: "assign_pairs(edges STRUCT(a BIGINT, b BIGINT, w DOUBLE)[]) -> STRUCT(a BIGINT, b BIGINT, w DOUBLE)[]",
    description: "Maximum-weight one-to-one matching of candidate pairs (a, b) with weights w >= 0, e.g. track pairs and their LCSS \
                  similarity: list the candidates with list({'a': ..., 'b': ..., 'w': ...}) and unnest the result. The graph is split into \
                  connected components and each is solved exactly (scipy's LSAP algorithm via the lsap crate). Pairs of weight 0 are never chosen.",
    example: "SELECT assign_pairs([{'a': 1, 'b': 10, 'w': 0.9}, {'a': 1, 'b': 20, 'w': 0.8}, {'a': 2, 'b': 10, 'w': 0.8}, {'a': 2, 'b': 20, 'w': 0.1}]); -- [{'a': 1, 'b': 20, 'w': 0.8}, {'a': 2, 'b': 10, 'w': 0.8}]",
},
];

fn pair_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&LogicalTypeHandle::struct_type(&[("a", bigint()), ("b", bigint()), ("score", double())]))
}

fn hungarian_match_fn(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "hungarian_match";
    let col = EdgeCol::new(input, 0, "pairs", ["a", "b", "score"]);
    let maximize = OptCol::new(input, 1);
    let min_score = OptCol::new(input, 2);
    let vals = map_rows(input.len(), |r| -> Result<Option<Vec<(i64, i64, f64)>>, Box<dyn Error>> {
        let Some(pairs) = col.get(r, F)? else { return Ok(None) };
        let Some(mx) = maximize.bool_or(r, true) else { return Ok(None) };
        let Some(t) = min_score.f64_opt(r) else { return Ok(None) };
        let params = hungarian::MatchParams::new(mx, t).map_err(|e| err(F, e))?;
        Ok(Some(hungarian::hungarian_match(&pairs, &params).map_err(|e| err(F, e))?))
    })?;
    write_edges(&mut output.list_vector(), &vals);
    Ok(())
}

fn edge_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&LogicalTypeHandle::struct_type(&[("a", bigint()), ("b", bigint()), ("w", double())]))
}

fn assign_pairs(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "assign_pairs";
    // The struct has BIGINT fields; read it as three columns through the generic list reader.
    let col = EdgeCol::new(input, 0, "edges", ["a", "b", "w"]);
    let vals = map_rows(input.len(), |r| -> Result<Option<Vec<(i64, i64, f64)>>, Box<dyn Error>> {
        let Some(edges) = col.get(r, F)? else { return Ok(None) };
        let chosen = assign::assign_max(&edges).map_err(|e| err(F, format!("edges {e}")))?;
        Ok(Some(chosen.into_iter().map(|k| edges[k]).collect()))
    })?;
    write_edges(&mut output.list_vector(), &vals);
    Ok(())
}

/// Reads `STRUCT(a BIGINT, b BIGINT, w DOUBLE)[]` straight from DuckDB's buffers.
struct EdgeCol<'a> {
    entries: &'a [duckdb::ffi::duckdb_list_entry],
    list_valid: *mut u64,
    pts_valid: *mut u64,
    a: &'a [i64],
    b: &'a [i64],
    w: &'a [f64],
    field_valid: [*mut u64; 3],
    param: &'static str,
    names: [&'static str; 3],
}

fn is_null(mask: *mut u64, row: usize) -> bool {
    // SAFETY: masks cover their vectors; a NULL mask means all valid.
    !mask.is_null() && unsafe { *mask.add(row / 64) >> (row % 64) & 1 == 0 }
}

impl<'a> EdgeCol<'a> {
    fn new(input: &'a DataChunkHandle, col: usize, param: &'static str, names: [&'static str; 3]) -> Self {
        use duckdb::ffi;
        // SAFETY: the signature fixes the column type; DuckDB flattens scalar inputs.
        unsafe {
            let lv = ffi::duckdb_data_chunk_get_vector(input.get_ptr(), col as u64);
            let total = ffi::duckdb_list_vector_get_size(lv) as usize;
            let child = ffi::duckdb_list_vector_get_child(lv);
            let f = |k: u64| ffi::duckdb_struct_vector_get_child(child, k);
            let sl = |v: ffi::duckdb_vector| ffi::duckdb_vector_get_data(v);
            EdgeCol {
                entries: std::slice::from_raw_parts(sl(lv) as *const ffi::duckdb_list_entry, input.len()),
                list_valid: ffi::duckdb_vector_get_validity(lv),
                pts_valid: ffi::duckdb_vector_get_validity(child),
                a: if total == 0 { &[] } else { std::slice::from_raw_parts(sl(f(0)) as *const i64, total) },
                b: if total == 0 { &[] } else { std::slice::from_raw_parts(sl(f(1)) as *const i64, total) },
                w: if total == 0 { &[] } else { std::slice::from_raw_parts(sl(f(2)) as *const f64, total) },
                field_valid: [
                    ffi::duckdb_vector_get_validity(f(0)),
                    ffi::duckdb_vector_get_validity(f(1)),
                    ffi::duckdb_vector_get_validity(f(2)),
                ],
                param,
                names,
            }
        }
    }
    fn get(&self, row: usize, f: &str) -> Result<Option<Vec<(i64, i64, f64)>>, Box<dyn Error>> {
        if is_null(self.list_valid, row) {
            return Ok(None);
        }
        let e = self.entries[row];
        let (off, len) = (e.offset as usize, e.length as usize);
        let mut out = Vec::with_capacity(len);
        for k in off..off + len {
            if is_null(self.pts_valid, k) {
                return Err(err(f, format!("{}[{}] is NULL", self.param, k - off + 1)));
            }
            for (i, name) in self.names.iter().enumerate() {
                if is_null(self.field_valid[i], k) {
                    return Err(err(f, format!("{}[{}].{name} is NULL", self.param, k - off + 1)));
                }
            }
            out.push((self.a[k], self.b[k], self.w[k]));
        }
        Ok(Some(out))
    }
}

fn write_edges(out: &mut duckdb::core::ListVector<'_>, vals: &[Option<Vec<(i64, i64, f64)>>]) {
    let total: usize = vals.iter().flatten().map(|v| v.len()).sum();
    {
        let child = out.struct_child(total);
        let (mut ca, mut cb, mut cw) = (child.child(0, total), child.child(1, total), child.child(2, total));
        // SAFETY: capacity `total` reserved; field types BIGINT, BIGINT, DOUBLE.
        let (da, db, dw) = unsafe {
            (
                ca.as_mut_slice_with_len::<i64>(total),
                cb.as_mut_slice_with_len::<i64>(total),
                cw.as_mut_slice_with_len::<f64>(total),
            )
        };
        let mut off = 0;
        for v in vals.iter().flatten() {
            for &(a, b, w) in v {
                da[off] = a;
                db[off] = b;
                dw[off] = w;
                off += 1;
            }
        }
    }
    write_list_entries(out, vals.iter().map(|v| v.as_ref().map(Vec::len)));
}

scalar_fn!(AssignPairs, vec![sig(vec![edge_type()], edge_type())], assign_pairs);
scalar_fn!(
    HungarianMatch,
    vec![
        sig(vec![pair_type()], pair_type()),
        sig(vec![pair_type(), boolean()], pair_type()),
        sig(vec![pair_type(), boolean(), double()], pair_type()),
    ],
    hungarian_match_fn
);

pub fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_scalar_function::<HungarianMatch>("hungarian_match")?;
    con.register_scalar_function::<AssignPairs>("assign_pairs")
}
