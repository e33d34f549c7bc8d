//! SQL: agglomerative clustering on pairwise distances (`agglomerative_cluster`,
//! `agglomerative_cluster_k`, `agglomerative_dendrogram`), Buzan et al. sections 4.3–4.5.

use super::convert::*;
use crate::algo::cluster::{self, Cut, Linkage};
use duckdb::core::{DataChunkHandle, LogicalTypeHandle};
use duckdb::vtab::arrow::WritableVector;
use duckdb::Connection;
use std::error::Error;


pub const DOCS: &[FnDoc] = &[
    FnDoc {
        name: "agglomerative_cluster",
        signatures: "agglomerative_cluster(pairs STRUCT(a BIGINT, b BIGINT, distance DOUBLE)[], method VARCHAR, threshold DOUBLE) -> STRUCT(id BIGINT, cluster INTEGER)[]",
        description: "Hierarchical clustering of the ids in pairs (e.g. track pairs with 1 - lcss similarity as distance), cut so that every merge \
                      of height <= threshold is applied (scipy fcluster 'distance'). method: 'single', 'complete', 'average', 'weighted' or 'ward' \
                      (kodama, the fastcluster algorithms scipy uses). A pair absent from the list, or with distance 'inf', is a cannot-link: under \
                      complete, average and weighted linkage such ids never share a cluster; single linkage still joins them through a chain of close \
                      pairs (its definition). Ward assumes Euclidean distances and needs every pair: missing or infinite pairs are an error. \
                      Clusters are numbered 1.. by their smallest id; duplicated pairs keep the smallest distance; NaN or negative distances and \
                      self pairs are errors; an empty list gives an empty list.",
        example: "SELECT agglomerative_cluster([{'a': 1, 'b': 2, 'distance': 0.1}, {'a': 2, 'b': 3, 'distance': 0.2}, {'a': 1, 'b': 3, 'distance': 0.9}], 'average', 0.3); -- [{'id': 1, 'cluster': 1}, {'id': 2, 'cluster': 1}, {'id': 3, 'cluster': 2}]",
    },
    FnDoc {
        name: "agglomerative_cluster_k",
        signatures: "agglomerative_cluster_k(pairs STRUCT(a BIGINT, b BIGINT, distance DOUBLE)[], method VARCHAR, k BIGINT) -> STRUCT(id BIGINT, cluster INTEGER)[]",
        description: "As agglomerative_cluster, cut at k clusters (scipy fcluster 'maxclust': the lowest merge height that leaves at most k clusters; \
                      tied heights can give fewer). Merges at infinite distance (cannot-link) are never applied, so more than k clusters come back \
                      when the cannot-links require it.",
        example: "SELECT agglomerative_cluster_k([{'a': 1, 'b': 2, 'distance': 0.1}, {'a': 2, 'b': 3, 'distance': 0.2}, {'a': 1, 'b': 3, 'distance': 0.9}], 'single', 1); -- [{'id': 1, 'cluster': 1}, {'id': 2, 'cluster': 1}, {'id': 3, 'cluster': 1}]",
    },
    FnDoc {
        name: "agglomerative_dendrogram",
        signatures: "agglomerative_dendrogram(pairs STRUCT(a BIGINT, b BIGINT, distance DOUBLE)[], method VARCHAR) -> STRUCT(\"left\" BIGINT, \"right\" BIGINT, distance DOUBLE, size BIGINT)[]",
        description: "The merges in scipy's linkage format, for plotting: leaves 0..n-1 are the ids in increasing order, merge i creates cluster n + i; \
                      left < right; distance 'inf' for merges forced across cannot-link pairs. Same methods and input rules as agglomerative_cluster.",
        example: "SELECT agglomerative_dendrogram([{'a': 7, 'b': 9, 'distance': 0.5}, {'a': 7, 'b': 8, 'distance': 0.25}, {'a': 8, 'b': 9, 'distance': 1}], 'complete'); -- [{'left': 0, 'right': 1, 'distance': 0.25, 'size': 2}, {'left': 2, 'right': 3, 'distance': 1.0, 'size': 3}]",
    },
];

fn pair_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&struct_of(&[("a", bigint()), ("b", bigint()), ("distance", double())]))
}
fn assignment_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&struct_of(&[("id", bigint()), ("cluster", integer())]))
}
fn dendrogram_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&struct_of(&[("left", bigint()), ("right", bigint()), ("distance", double()), ("size", bigint())]))
}

/// Reads the pairs and the method of a row, and builds its dendrogram.
fn dendrogram_of(pairs: &ListOfStructCol<'_>, methods: &VarcharCol<'_>, row: usize, f: &str) -> Result<Option<cluster::Dendrogram>, Box<dyn Error>> {
    let Some(fields) = pairs.row_fields(row, f, "pairs")? else { return Ok(None) };
    let Some(method) = methods.get(row) else { return Ok(None) };
    let method = Linkage::parse(&method).map_err(|e| err(f, e))?;
    let p: Vec<(i64, i64, f64)> = (0..fields[0].len()).map(|k| (i64_bits(fields[0][k]), i64_bits(fields[1][k]), fields[2][k])).collect();
    Ok(Some(cluster::dendrogram(&p, method).map_err(|e| err(f, e))?))
}

fn write_assignments(out: &mut duckdb::core::ListVector<'_>, vals: &[Option<(Vec<i64>, Vec<u32>)>]) {
    let total: usize = vals.iter().flatten().map(|v| v.0.len()).sum();
    {
        let child = out.struct_child(total);
        let (mut ci, mut cc) = (child.child(0, total), child.child(1, total));
        // SAFETY: capacity `total` reserved; field types BIGINT and INTEGER.
        let (di, dc) = unsafe { (ci.as_mut_slice_with_len::<i64>(total), cc.as_mut_slice_with_len::<i32>(total)) };
        let mut off = 0;
        for (ids, cl) in vals.iter().flatten() {
            for (id, c) in ids.iter().zip(cl) {
                di[off] = *id;
                dc[off] = *c as i32;
                off += 1;
            }
        }
    }
    write_list_entries(out, vals.iter().map(|v| v.as_ref().map(|(ids, _)| ids.len())));
}

fn cluster_fn(input: &mut DataChunkHandle, output: &mut dyn WritableVector, by_k: bool) -> FnResult {
    let f = if by_k { "agglomerative_cluster_k" } else { "agglomerative_cluster" };
    let pairs = ListOfStructCol::new_pub(input, 0, &["a", "b", "distance"]);
    let methods = VarcharCol::new(input, 1);
    let arg = PrimCol::new(input, 2);
    let vals = map_rows(input.len(), |r| {
        let cut = if by_k {
            let Some(k) = arg.i64(r) else { return Ok(None) };
            if k < 1 {
                return Err(err(f, cluster::ClusterError::K(k)));
            }
            Cut::K(k as usize)
        } else {
            let Some(t) = arg.f64(r) else { return Ok(None) };
            if t.is_nan() {
                return Err(err(f, cluster::ClusterError::Threshold(t)));
            }
            Cut::Threshold(t)
        };
        let Some(d) = dendrogram_of(&pairs, &methods, r, f)? else { return Ok(None) };
        let labels = cluster::flat(&d, cut);
        Ok(Some((d.ids, labels)))
    })?;
    write_assignments(&mut output.list_vector(), &vals);
    Ok(())
}

fn dendrogram_fn(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "agglomerative_dendrogram";
    let pairs = ListOfStructCol::new_pub(input, 0, &["a", "b", "distance"]);
    let methods = VarcharCol::new(input, 1);
    let vals = map_rows(input.len(), |r| {
        let Some(d) = dendrogram_of(&pairs, &methods, r, F)? else { return Ok(None) };
        let col = |g: &dyn Fn(&cluster::Merge) -> f64| d.merges.iter().map(g).collect::<Vec<f64>>();
        Ok(Some([
            col(&|m| bits_i64(m.left as i64)),
            col(&|m| bits_i64(m.right as i64)),
            col(&|m| m.distance),
            col(&|m| bits_i64(m.size as i64)),
        ]))
    })?;
    let cols: Vec<Option<Vec<&[f64]>>> = vals.iter().map(|v| v.as_ref().map(|c| c.iter().map(|x| &x[..]).collect())).collect();
    write_list_struct_f64(&mut output.list_vector(), 4, &cols);
    Ok(())
}

scalar_fn!(AggCluster, vec![sig(vec![pair_type(), varchar(), double()], assignment_type())], cluster_fn, false);
scalar_fn!(AggClusterK, vec![sig(vec![pair_type(), varchar(), bigint()], assignment_type())], cluster_fn, true);
scalar_fn!(AggDendrogram, vec![sig(vec![pair_type(), varchar()], dendrogram_type())], dendrogram_fn);

pub fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_scalar_function::<AggCluster>("agglomerative_cluster")?;
    con.register_scalar_function::<AggClusterK>("agglomerative_cluster_k")?;
    con.register_scalar_function::<AggDendrogram>("agglomerative_dendrogram")?;
    Ok(())
}
