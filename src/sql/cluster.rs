//! SQL: agglomerative clustering on pairwise distances (`agglomerative_cluster`,
//! `agglomerative_cluster_k`, `agglomerative_dendrogram`) and of trajectories in one call
//! (`traj_cluster`), Buzan et al. sections 4.3–4.5.

use super::convert::*;
use crate::algo::cluster::{self, Cut, Linkage};
use crate::algo::lcss_index::IndexParams;
use crate::algo::traj_cluster::{self, Similarity};
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
    FnDoc {
        name: "traj_cluster",
        signatures: "traj_cluster(ids BIGINT[], trajs STRUCT(t, x, y)[][], method VARCHAR, threshold DOUBLE, delta BIGINT, epsilon DOUBLE [, rho DOUBLE [, translation_invariant BOOLEAN]]) -> STRUCT(id BIGINT, cluster INTEGER)[]",
        description: "Clusters trajectories in one call: the distance of every pair is 1 - min(S_x, S_y) of Buzan's S1 (delta samples of time warping, \
                      epsilon metres, length ratio rho in (0, 1], default: no ratio test), or of S2 when translation_invariant is true; all pairs are computed in \
                      parallel straight into the distance matrix (no pair rows), and the linkage and cut are agglomerative_cluster's. A pair with no \
                      common subsequence is a cannot-link; a trajectory with no similar trajectory at all gets cluster 0, the others 1.. by smallest \
                      id. Use it with list(id ORDER BY id), list(traj ORDER BY id) over a GROUP BY; it is the fast form of lcss_s1 pairs + \
                      agglomerative_cluster. Errors: lists of different lengths, duplicate ids, NULL elements, the parameter rules of lcss_s1 and \
                      agglomerative_cluster; more than 80,000 trajectories.",
        example: "SELECT traj_cluster([1, 2, 3], [[{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':0,'x':0,'y':0.1},{'t':1,'x':1,'y':0.1}], [{'t':0,'x':50,'y':50},{'t':1,'x':51,'y':50}]], 'average', 0.5, 1, 1.0); -- [{'id': 1, 'cluster': 1}, {'id': 2, 'cluster': 1}, {'id': 3, 'cluster': 0}]",
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

fn traj_cluster_fn(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_cluster";
    let ids = I64ListCol::new(input, 0);
    let trajs = TrajListCol::new(input, 1);
    let methods = VarcharCol::new(input, 2);
    let (thr, delta, eps) = (PrimCol::new(input, 3), PrimCol::new(input, 4), PrimCol::new(input, 5));
    let rho = OptCol::new(input, 6);
    let ti = OptCol::new(input, 7);
    let vals = map_rows(input.len(), |r| {
        let (Some(id), Some(tr), Some(method), Some(t), Some(d), Some(e)) =
            (ids.get(r, F, "ids")?, trajs.get(r, F, "trajs")?, methods.get(r), thr.f64(r), delta.i64(r), eps.f64(r))
        else {
            return Ok(None);
        };
        let Some(rho) = rho.f64_opt(r) else { return Ok(None) };
        let Some(translation_invariant) = ti.bool_or(r, false) else { return Ok(None) };
        let sim = if translation_invariant { Similarity::S2 } else { Similarity::S1 };
        if t.is_nan() {
            return Err(err(F, cluster::ClusterError::Threshold(t)));
        }
        let method = Linkage::parse(&method).map_err(|e| err(F, e))?;
        let p = IndexParams::new(d, e, rho).map_err(|e| err(F, e))?;
        let (ids, labels) = traj_cluster::cluster_trajectories(id, &tr, &p, sim, method, Cut::Threshold(t)).map_err(|e| err(F, e))?;
        Ok(Some((ids, labels)))
    })?;
    write_assignments(&mut output.list_vector(), &vals);
    Ok(())
}

fn traj_cluster_sigs() -> Vec<duckdb::vscalar::ScalarFunctionSignature> {
    let base = || vec![LogicalTypeHandle::list(&bigint()), LogicalTypeHandle::list(&traj_type()), varchar(), double(), bigint(), double()];
    let mut with_rho = base();
    with_rho.push(double());
    let mut with_ti = base();
    with_ti.extend([double(), boolean()]);
    vec![sig(base(), assignment_type()), sig(with_rho, assignment_type()), sig(with_ti, assignment_type())]
}

scalar_fn!(AggCluster, vec![sig(vec![pair_type(), varchar(), double()], assignment_type())], cluster_fn, false);
scalar_fn!(AggClusterK, vec![sig(vec![pair_type(), varchar(), bigint()], assignment_type())], cluster_fn, true);
scalar_fn!(AggDendrogram, vec![sig(vec![pair_type(), varchar()], dendrogram_type())], dendrogram_fn);
scalar_fn!(TrajCluster, traj_cluster_sigs(), traj_cluster_fn);

pub fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_scalar_function::<AggCluster>("agglomerative_cluster")?;
    con.register_scalar_function::<AggClusterK>("agglomerative_cluster_k")?;
    con.register_scalar_function::<AggDendrogram>("agglomerative_dendrogram")?;
    con.register_scalar_function::<TrajCluster>("traj_cluster")?;
    Ok(())
}
