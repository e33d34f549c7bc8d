//! SQL: agglomerative clustering. Maths: `crates/algo/src/cluster/` (linkage.rs for the pairwise
//! forms, traj_cluster.rs for trajectories in one call), Buzan et al. sections 4.3–4.5.

use super::registry::{pd, Function, Param, Section, Signature, Ty, TRAJ};
use super::vector::{Args, Column, Out};
use crate::algo::cluster::linkage::{self, Cut, Dendrogram, Linkage};
use crate::algo::cluster::prototype;
use crate::algo::cluster::traj_cluster::{self, Similarity};
use crate::algo::lcss::index::IndexParams;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const LINKAGE: &str = "crates/algo/src/cluster/linkage.rs";

const PAIRS: Ty = Ty::List(&Ty::Struct(&[("a", Ty::Bigint), ("b", Ty::Bigint), ("distance", Ty::Double)]));
const DENDROGRAM: Ty = Ty::List(&Ty::Struct(&[("left", Ty::Bigint), ("right", Ty::Bigint), ("distance", Ty::Double), ("size", Ty::Bigint)]));
const ASSIGNMENT: Ty = Ty::List(&Ty::Struct(&[("id", Ty::Bigint), ("cluster", Ty::Integer)]));
const PROTOTYPE_ASSIGNMENT: Ty = Ty::List(&Ty::Struct(&[("id", Ty::Bigint), ("cluster", Ty::Integer), ("prototype", Ty::Bigint)]));
const METHOD: Param = pd("method", Ty::Varchar, "the linkage: 'single', 'complete', 'average', 'weighted' or 'ward'");
const PAIRS_METHOD: [Param; 2] = [
    pd("pairs", PAIRS, "the distances between ids: {a, b, distance >= 0}; an absent pair or distance 'inf' is a cannot-link"),
    METHOD,
];
const CONDENSED_METHOD: [Param; 2] = [
    pd("condensed", Ty::List(&Ty::Double), "the upper triangle of the n x n distance matrix row by row, n(n-1)/2 values >= 0 ('inf': a cannot-link)"),
    METHOD,
];
const THRESHOLD: Param = pd("threshold", Ty::Double, "every merge at a height (distance) up to this is applied; not NaN");
const IDS: Param = pd("ids", Ty::List(&Ty::Bigint), "the trajectories' ids, distinct (list(id ORDER BY id))");
const TRAJS: Param = pd("trajs", Ty::List(&TRAJ), "the trajectories, in the order of ids (list(traj ORDER BY id))");
const DELTA: Param = pd("delta", Ty::Bigint, "the largest difference |i - j| of the list positions of a match (samples), >= 0");
const EPSILON: Param = pd("epsilon", Ty::Double, "the matching distance per axis (m), > 0");
const RHO: Param = pd("rho", Ty::Double, "the least length ratio min(n, m) / max(n, m), in (0, 1]; default: no ratio test");
const TRANSLATION_INVARIANT: Param =
    pd("translation_invariant", Ty::Boolean, "true: Buzan's translation-invariant S2 (lcss_s2) instead of S1; default false");

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "agglomerative_cluster",
        description: "Hierarchical clustering of the ids in pairs (e.g. track pairs with 1 - lcss similarity as distance), cut so that every merge \
                      of height <= threshold is applied (scipy fcluster 'distance'). method: 'single', 'complete', 'average', 'weighted' or 'ward' \
                      (scipy's algorithms and merge order, ties included: Prim's minimum spanning tree for single, the nearest-neighbour chain for the others). A pair absent from the list, or with distance 'inf', is a cannot-link: under \
                      complete, average and weighted linkage such ids never share a cluster; single linkage still joins them through a chain of close \
                      pairs (its definition). Ward assumes Euclidean distances and needs every pair: missing or infinite pairs are an error. \
                      Clusters are numbered 1.. by their smallest id; duplicated pairs keep the smallest distance; NaN or negative distances and \
                      self pairs are errors; an empty list gives an empty list.",
        example: "SELECT agglomerative_cluster([{'a': 1, 'b': 2, 'distance': 0.1}, {'a': 2, 'b': 3, 'distance': 0.2}, {'a': 1, 'b': 3, 'distance': 0.9}], 'average', 0.3); -- [{'id': 1, 'cluster': 1}, {'id': 2, 'cluster': 1}, {'id': 3, 'cluster': 2}]",
        maths: LINKAGE,
        binding: file!(),
        section: Section::Clustering,
        see_also: &["agglomerative_cluster_k", "agglomerative_dendrogram", "traj_cluster", "lcss_distance"],
        signatures: &[Signature { params: &[PAIRS_METHOD[0], PAIRS_METHOD[1], THRESHOLD], arities: &[], returns: ASSIGNMENT, kernel: cluster_threshold }],
        table: None,
    },
    Function {
        name: "agglomerative_cluster_k",
        description: "As agglomerative_cluster, cut at k clusters (scipy fcluster 'maxclust': the lowest merge height that leaves at most k clusters; \
                      tied heights can give fewer). Merges at infinite distance (cannot-link) are never applied, so more than k clusters come back \
                      when the cannot-links require it.",
        example: "SELECT agglomerative_cluster_k([{'a': 1, 'b': 2, 'distance': 0.1}, {'a': 2, 'b': 3, 'distance': 0.2}, {'a': 1, 'b': 3, 'distance': 0.9}], 'single', 1); -- [{'id': 1, 'cluster': 1}, {'id': 2, 'cluster': 1}, {'id': 3, 'cluster': 1}]",
        maths: LINKAGE,
        binding: file!(),
        section: Section::Clustering,
        see_also: &["agglomerative_cluster", "agglomerative_dendrogram"],
        signatures: &[Signature {
            params: &[PAIRS_METHOD[0], PAIRS_METHOD[1], pd("k", Ty::Bigint, "the most clusters to cut at, >= 1")],
            arities: &[],
            returns: ASSIGNMENT,
            kernel: cluster_k,
        }],
        table: None,
    },
    Function {
        name: "agglomerative_dendrogram",
        description: "The merges in scipy's linkage format, for plotting: leaves 0..n-1 are the ids in increasing order, merge i creates cluster n + i; \
                      left < right; distance 'inf' for merges forced across cannot-link pairs. Same methods and input rules as agglomerative_cluster (a condensed matrix: \
                      agglomerative_dendrogram_condensed). Equal heights keep scipy's order (the merges are scipy.cluster.hierarchy.linkage's, ties included).",
        example: "SELECT agglomerative_dendrogram([{'a': 7, 'b': 9, 'distance': 0.5}, {'a': 7, 'b': 8, 'distance': 0.25}, {'a': 8, 'b': 9, 'distance': 1}], 'complete'); -- [{'left': 0, 'right': 1, 'distance': 0.25, 'size': 2}, {'left': 2, 'right': 3, 'distance': 1.0, 'size': 3}]",
        maths: LINKAGE,
        binding: file!(),
        section: Section::Clustering,
        see_also: &["agglomerative_dendrogram_condensed", "agglomerative_cluster"],
        signatures: &[Signature { params: &PAIRS_METHOD, arities: &[], returns: DENDROGRAM, kernel: dendrogram }],
        table: None,
    },
    Function {
        name: "agglomerative_dendrogram_condensed",
        description: "agglomerative_dendrogram of a scipy-style condensed distance matrix instead of pairs: the upper triangle of the n x n \
                      matrix row by row, n(n-1)/2 values (scipy.spatial.distance.pdist's layout, what scipy.cluster.hierarchy.linkage takes); \
                      'inf' is a cannot-link. The leaves are 0..n-1. Same methods, rules and merges (scipy's, ties included); single linkage reads \
                      the list in place, without a copy of the matrix. Errors: a length that is n(n-1)/2 for no n, NaN or negative values.",
        example: "SELECT agglomerative_dendrogram_condensed([0.5, 0.25, 1.0], 'complete'); -- [{'left': 0, 'right': 2, 'distance': 0.25, 'size': 2}, {'left': 1, 'right': 3, 'distance': 1.0, 'size': 3}]",
        maths: LINKAGE,
        binding: file!(),
        section: Section::Clustering,
        see_also: &["agglomerative_dendrogram"],
        signatures: &[Signature { params: &CONDENSED_METHOD, arities: &[], returns: DENDROGRAM, kernel: dendrogram_condensed }],
        table: None,
    },
    Function {
        name: "traj_cluster",
        description: "Clusters trajectories in one call: the distance of every pair is 1 - min(S_x, S_y) of Buzan's S1 (delta samples of time warping, \
                      epsilon metres, length ratio rho in (0, 1], default: no ratio test), or of S2 when translation_invariant is true; all pairs are computed in \
                      parallel straight into the distance matrix (no pair rows), and the linkage and cut are agglomerative_cluster's. A pair with no \
                      common subsequence is a cannot-link; a trajectory with no similar trajectory at all gets cluster 0, the others 1.. by smallest \
                      id. Use it with list(id ORDER BY id), list(traj ORDER BY id) over a GROUP BY; it is the fast form of lcss_s1 pairs + \
                      agglomerative_cluster. Errors: lists of different lengths, duplicate ids, NULL elements, the parameter rules of lcss_s1 and \
                      agglomerative_cluster; more than 80,000 trajectories.",
        example: "SELECT traj_cluster([1, 2, 3], [[{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':0,'x':0,'y':0.1},{'t':1,'x':1,'y':0.1}], [{'t':0,'x':50,'y':50},{'t':1,'x':51,'y':50}]], 'average', 0.5, 1, 1.0); -- [{'id': 1, 'cluster': 1}, {'id': 2, 'cluster': 1}, {'id': 3, 'cluster': 0}]",
        maths: "crates/algo/src/cluster/traj_cluster.rs",
        binding: file!(),
        section: Section::Clustering,
        see_also: &["traj_cluster_prototypes", "lcss_s1", "lcss_s2", "agglomerative_cluster"],
        signatures: &[Signature {
            params: &[
                IDS,
                TRAJS,
                METHOD,
                THRESHOLD,
                DELTA,
                EPSILON,
                RHO,
                TRANSLATION_INVARIANT,
            ],
            arities: &[6, 7, 8],
            returns: ASSIGNMENT,
            kernel: traj_cluster,
        }],
        table: None,
    },
    Function {
        name: "traj_cluster_prototypes",
        description: "Clusters trajectories through prototypes, in time linear in the trajectories for a fixed number of route patterns (traj_cluster \
                      compares every pair): visited longest first, each trajectory joins the nearest prototype within radius (a distance \
                      1 - min(S_x, S_y), e.g. half the threshold) or becomes a new prototype (TrafficIntelligence's prototype clustering with \
                      LCSS); then the prototypes are clustered exactly as traj_cluster does (method, cut at threshold) and every member takes its \
                      prototype's cluster. Returns id, cluster (0: isolated, 1.. by smallest id) and the id of its prototype. Members of one \
                      prototype share a cluster even when their own distance is larger (docs/clustering.md measures the agreement with \
                      traj_cluster). Same parameters and rules as traj_cluster; radius must be in [0, 1].",
        example: "SELECT traj_cluster_prototypes([1, 2, 3], [[{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':0,'x':0,'y':0.1},{'t':1,'x':1,'y':0.1}], [{'t':0,'x':50,'y':50},{'t':1,'x':51,'y':50}]], 'average', 0.5, 0.25, 1, 1.0); -- [{'id': 1, 'cluster': 1, 'prototype': 1}, {'id': 2, 'cluster': 1, 'prototype': 1}, {'id': 3, 'cluster': 0, 'prototype': 3}]",
        maths: "crates/algo/src/cluster/prototype.rs",
        binding: file!(),
        section: Section::Clustering,
        see_also: &["traj_cluster"],
        signatures: &[Signature {
            params: &[
                IDS,
                TRAJS,
                METHOD,
                pd("threshold", Ty::Double, "the prototypes' clustering applies every merge at a height up to this; not NaN"),
                pd("radius", Ty::Double, "a trajectory joins the nearest prototype within this distance 1 - min(S_x, S_y), in [0, 1] (e.g. half the threshold)"),
                DELTA,
                EPSILON,
                RHO,
                TRANSLATION_INVARIANT,
            ],
            arities: &[7, 8, 9],
            returns: PROTOTYPE_ASSIGNMENT,
            kernel: traj_cluster_prototypes,
        }],
        table: None,
    },
];

/// The dendrogram of one row's pairs (or condensed matrix) and method.
fn dendrogram_of(a: &Args<'_>, condensed: bool, r: usize) -> Result<Option<Dendrogram>, Box<dyn Error>> {
    let Some(method) = a.text(1).get(r) else { return Ok(None) };
    if condensed {
        let Some(m) = a.f64_list(0).get(r)? else { return Ok(None) };
        return Ok(Some(linkage::dendrogram_condensed(m, Linkage::parse(&method)?)?));
    }
    let Some(rows) = a.struct_list(0).get(r)? else { return Ok(None) };
    let p = linkage::Pairs { a: rows.i64(0), b: rows.i64(1), distance: rows.f64(2) };
    Ok(Some(linkage::dendrogram_pairs(p, Linkage::parse(&method)?)?))
}

/// Writes `STRUCT(id BIGINT, cluster INTEGER)[]` rows.
fn write_assignments(out: &mut Out<'_>, vals: &[Option<(Vec<i64>, Vec<u32>)>]) -> Result<(), String> {
    let as_i32: Vec<Option<(&Vec<i64>, Vec<i32>)>> = vals.iter().map(|v| v.as_ref().map(|(ids, c)| (ids, c.iter().map(|&x| x as i32).collect()))).collect();
    let cols: Vec<_> = as_i32.iter().map(|v| v.as_ref().map(|(ids, c)| vec![Column::I64(ids), Column::I32(c)])).collect();
    out.struct_lists(&cols)
}

/// Both flat cuts (of pairs; `condensed` for a condensed matrix); `cut` reads column 2 of a row.
fn cluster_with(a: &Args<'_>, out: &mut Out<'_>, condensed: bool, cut: impl Fn(usize) -> Result<Option<Cut>, Box<dyn Error>>) -> R {
    let vals = a.map(|r| {
        let Some(c) = cut(r)? else { return Ok(None) };
        let Some(d) = dendrogram_of(a, condensed, r)? else { return Ok(None) };
        let labels = linkage::flat(&d, c);
        Ok(Some((d.ids, labels)))
    })?;
    write_assignments(out, &vals)?;
    Ok(())
}

fn cluster_threshold(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let t = a.double(2);
    cluster_with(a, out, false, |r| Ok(t.get(r).map(Cut::threshold).transpose()?))
}

fn cluster_k(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let k = a.bigint(2);
    cluster_with(a, out, false, |r| Ok(k.get(r).map(Cut::k).transpose()?))
}

fn write_dendrogram(a: &Args<'_>, out: &mut Out<'_>, condensed: bool) -> R {
    let vals = a.map(|r| {
        let Some(d) = dendrogram_of(a, condensed, r)? else { return Ok(None) };
        let m = &d.merges;
        Ok(Some((
            m.iter().map(|x| x.left as i64).collect::<Vec<_>>(),
            m.iter().map(|x| x.right as i64).collect::<Vec<_>>(),
            m.iter().map(|x| x.distance).collect::<Vec<_>>(),
            m.iter().map(|x| x.size as i64).collect::<Vec<_>>(),
        )))
    })?;
    let cols: Vec<_> =
        vals.iter().map(|v| v.as_ref().map(|(l, r, d, s)| vec![Column::I64(l), Column::I64(r), Column::F64(d), Column::I64(s)])).collect();
    out.struct_lists(&cols)?;
    Ok(())
}
fn dendrogram(a: &Args<'_>, out: &mut Out<'_>) -> R {
    write_dendrogram(a, out, false)
}
fn dendrogram_condensed(a: &Args<'_>, out: &mut Out<'_>) -> R {
    write_dendrogram(a, out, true)
}

/// The trailing similarity arguments of traj_cluster and traj_cluster_prototypes, from column
/// `first`: delta, epsilon [, rho [, translation_invariant]], per row as S1 / S2 and the values
/// (checked by `IndexParams::new` where each caller checked them before); `None` when one is NULL.
type SimilarityRow = (Similarity, i64, f64, Option<f64>);
fn similarity_args<'a>(a: &Args<'a>, first: usize) -> impl Fn(usize) -> Option<SimilarityRow> + 'a {
    let (delta, eps, rho, ti) = (a.bigint(first), a.double(first + 1), a.opt_double(first + 2), a.opt_boolean(first + 3));
    move |r| {
        let (Some(d), Some(e), Some(rho), Some(translation_invariant)) = (delta.get(r), eps.get(r), rho.opt(r), ti.or(r, false)) else {
            return None;
        };
        Some((if translation_invariant { Similarity::S2 } else { Similarity::S1 }, d, e, rho))
    }
}

fn traj_cluster(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ids, trajs, methods, thr, similarity) = (a.i64_list(0), a.traj_list(1), a.text(2), a.double(3), similarity_args(a, 4));
    let vals = a.map(|r| {
        let (Some(id), Some(tr), Some(method), Some(t)) = (ids.get(r)?, trajs.get(r)?, methods.get(r), thr.get(r)) else { return Ok(None) };
        let Some((sim, d, e, rho)) = similarity(r) else { return Ok(None) };
        let cut = Cut::threshold(t)?;
        let method = Linkage::parse(&method)?;
        let p = IndexParams::new(d, e, rho)?;
        Ok(Some(traj_cluster::cluster_trajectories(id, &tr, &p, sim, method, cut)?))
    })?;
    write_assignments(out, &vals)?;
    Ok(())
}

fn traj_cluster_prototypes(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ids, trajs, methods, thr, radius) = (a.i64_list(0), a.traj_list(1), a.text(2), a.double(3), a.double(4));
    let similarity = similarity_args(a, 5);
    let vals = a.map(|r| {
        let (Some(id), Some(tr), Some(method), Some(t), Some(rad)) = (ids.get(r)?, trajs.get(r)?, methods.get(r), thr.get(r), radius.get(r)) else {
            return Ok(None);
        };
        let Some((sim, d, e, rho)) = similarity(r) else { return Ok(None) };
        let method = Linkage::parse(&method)?;
        let p = IndexParams::new(d, e, rho)?;
        let c = prototype::cluster_prototypes(id, &tr, &p, sim, method, t, rad)?;
        Ok(Some((c.ids, c.cluster.iter().map(|&x| x as i32).collect::<Vec<i32>>(), c.prototype)))
    })?;
    let cols: Vec<_> = vals.iter().map(|v| v.as_ref().map(|(i, c, p)| vec![Column::I64(i), Column::I32(c), Column::I64(p)])).collect();
    out.struct_lists(&cols)?;
    Ok(())
}
