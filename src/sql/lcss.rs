//! SQL: the LCSS family.
//!
//! - time-window form (thesis eq. 2.9/2.10): `lcss_length`, `lcss_similarity`, `lcss_distance`,
//!   `lcss_matches`, each with optional `min_points` and `region`;
//! - 1-D series form: `lcss_series_length`, `lcss_series_similarity`, `lcss_series_matches`;
//! - index-window forms (Buzan def. 4.1–4.3): `lcss_index_similarity`, `lcss_s1`, `lcss_s2`.

use super::convert::*;
use crate::algo::lcss::{self, TimeWindowParams};
use crate::algo::lcss_index::{self, IndexParams};
use crate::algo::lcss_translate;
use crate::algo::region::inside_indices;
use crate::algo::traj::{OwnedTraj, Traj};
use duckdb::core::{DataChunkHandle, LogicalTypeHandle};
use duckdb::vscalar::ScalarFunctionSignature;
use duckdb::vtab::arrow::WritableVector;
use duckdb::Connection;
use std::error::Error;

pub const DOCS: &[FnDoc] = &[
    FnDoc {
        name: "lcss_length",
        signatures: "lcss_length(a TRAJ, b TRAJ, epsilon DOUBLE, time_window DOUBLE [, min_points BIGINT [, region VARCHAR|BLOB]]) -> BIGINT",
        description: "Longest common subsequence L(eps, T, xi) of thesis eq. 2.9: points match when their distance is < epsilon (metres) \
                      and their time difference is < time_window (seconds). 0 when either side has fewer than min_points points. \
                      With region (WKT or WKB polygon) only points inside it take part, and min_points counts them after the restriction. \
                      Banded: O((n+m)*w) time with w the points of the other trajectory within time_window; O(n+m) memory.",
        example: "SELECT lcss_length(a, b, 1.0, 0.5) FROM (SELECT [{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}] AS a, [{'t':0.1,'x':0.2,'y':0},{'t':1.1,'x':1.2,'y':0}] AS b); -- 2",
    },
    FnDoc {
        name: "lcss_similarity",
        signatures: "lcss_similarity(a TRAJ, b TRAJ, epsilon DOUBLE, time_window DOUBLE [, min_points BIGINT [, region VARCHAR|BLOB]]) -> DOUBLE",
        description: "eta of thesis eq. 2.10: lcss_length / min(|a|, |b|), in [0, 1]; 0 for an empty side or one with fewer than min_points points. \
                      With region, both lengths are counted inside the region (P^{k∩l} in the thesis).",
        example: "SELECT lcss_similarity(a, b, 1.0, 0.5, 2, 'POLYGON((-1 -1, 5 -1, 5 5, -1 5, -1 -1))') FROM (SELECT [{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}] AS a, [{'t':0.1,'x':0.2,'y':0},{'t':1.1,'x':1.2,'y':0}] AS b); -- 1.0",
    },
    FnDoc {
        name: "lcss_distance",
        signatures: "lcss_distance(a TRAJ, b TRAJ, epsilon DOUBLE, time_window DOUBLE [, min_points BIGINT [, region VARCHAR|BLOB]]) -> DOUBLE",
        description: "1 - lcss_similarity, in [0, 1], for clustering. Buzan's D = 1/S (eq. 4.7, in [1, inf]) is 1.0 / lcss_similarity(...) in SQL.",
        example: "SELECT lcss_distance([{'t':0,'x':0,'y':0}], [{'t':0,'x':5,'y':0}], 1.0, 1.0); -- 1.0",
    },
    FnDoc {
        name: "lcss_matches",
        signatures: "lcss_matches(a TRAJ, b TRAJ, epsilon DOUBLE, time_window DOUBLE [, min_points BIGINT [, region VARCHAR|BLOB]]) -> STRUCT(i INTEGER, j INTEGER)[]",
        description: "The matched point pairs of one longest common subsequence, by backtracking (thesis section 2.3): 1-based positions \
                      into a and b (so a[i] and b[j] index the inputs directly, also with a region), increasing in both. \
                      Ties prefer the latest match. Empty when nothing matches.",
        example: "SELECT lcss_matches([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':1.1,'x':1.2,'y':0}], 1.0, 0.5); -- [{'i': 2, 'j': 1}]",
    },
    FnDoc {
        name: "lcss_series_length",
        signatures: "lcss_series_length(a STRUCT(t, v)[], b STRUCT(t, v)[], epsilon DOUBLE, time_window DOUBLE [, min_points BIGINT]) -> BIGINT",
        description: "1-D time-window LCSS on series such as traj_speeds(...): match when |v_a - v_b| < epsilon (series units) and |t_a - t_b| < time_window.",
        example: "SELECT lcss_series_length([{'t':0,'v':1.0},{'t':1,'v':2.0}], [{'t':0.2,'v':1.5},{'t':1.2,'v':2.1}], 1.0, 0.5); -- 2",
    },
    FnDoc {
        name: "lcss_series_similarity",
        signatures: "lcss_series_similarity(a STRUCT(t, v)[], b STRUCT(t, v)[], epsilon DOUBLE, time_window DOUBLE [, min_points BIGINT]) -> DOUBLE",
        description: "lcss_series_length / min(|a|, |b|). The thesis's coordinate-free speed pre-match is \
                      lcss_series_similarity(traj_speeds(a), traj_speeds(b), 2.0, 1.0) >= 0.8.",
        example: "SELECT lcss_series_similarity([{'t':0,'v':1.0},{'t':1,'v':2.0}], [{'t':0.2,'v':1.5},{'t':1.2,'v':5.0}], 1.0, 0.5); -- 0.5",
    },
    FnDoc {
        name: "lcss_series_matches",
        signatures: "lcss_series_matches(a STRUCT(t, v)[], b STRUCT(t, v)[], epsilon DOUBLE, time_window DOUBLE [, min_points BIGINT]) -> STRUCT(i INTEGER, j INTEGER)[]",
        description: "Matched 1-based index pairs of the 1-D form.",
        example: "SELECT lcss_series_matches([{'t':0,'v':1.0},{'t':1,'v':2.0}], [{'t':0.2,'v':1.5}], 1.0, 0.5); -- [{'i': 1, 'j': 1}]",
    },
    FnDoc {
        name: "lcss_index_similarity",
        signatures: "lcss_index_similarity(a TRAJ, b TRAJ, delta BIGINT, epsilon DOUBLE [, rho DOUBLE]) -> DOUBLE",
        description: "Index-window LCSS with one 2-D match: ||a_i - b_j|| < epsilon and |i - j| <= delta (list positions, t unused), \
                      divided by min(n, m); 0 when min(n,m) < rho*max(n,m). Equals tslearn's lcss(a, b, eps, sakoe_chiba_radius=delta) \
                      on equal-length inputs for delta >= 1 (for delta = 0 tslearn 0.10 returns only the trailing run of matches; this is the true LCSS). O(delta*(n+m)) (Buzan lemma 4.1).",
        example: "SELECT lcss_index_similarity([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':0,'x':0.1,'y':0},{'t':1,'x':5,'y':0}], 1, 0.5); -- 0.5",
    },
    FnDoc {
        name: "lcss_s1",
        signatures: "lcss_s1(a TRAJ, b TRAJ, delta BIGINT, epsilon DOUBLE [, rho DOUBLE]) -> STRUCT(sx DOUBLE, sy DOUBLE)",
        description: "Buzan's S1_2D (def. 4.1/4.2): per-axis LCSS (|a_x - b_x| < epsilon, |i - j| <= delta) over min(n, m); \
                      both 0 when min(n,m) < rho*max(n,m). Buzan's distance D1 = 1/S1 per axis.",
        example: "SELECT lcss_s1([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':0,'x':0.1,'y':9},{'t':1,'x':1.1,'y':9}], 1, 0.5); -- {'sx': 1.0, 'sy': 0.0}",
    },
    FnDoc {
        name: "lcss_s2",
        signatures: "lcss_s2(a TRAJ, b TRAJ, delta BIGINT, epsilon DOUBLE [, rho DOUBLE]) -> STRUCT(sx DOUBLE, sy DOUBLE, cx DOUBLE, cy DOUBLE)",
        description: "Buzan's translation-invariant S2_2D (def. 4.3): the best S1 over all translations of b, searched per axis over the \
                      O(delta*(n+m)) candidate translations of lemma 4.2 with branch-and-bound pruning; (cx, cy) is a translation that \
                      achieves it (add it to b).",
        example: "SELECT lcss_s2([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':1}], [{'t':0,'x':10,'y':20},{'t':1,'x':11,'y':21}], 1, 0.5); -- sx = sy = 1, cx ~ -10, cy ~ -20",
    },
];

/// What a time-window call returns.
#[derive(Clone, Copy)]
enum Out {
    Length,
    Similarity,
    Distance,
    Matches,
}

fn tw_signatures(ret: fn() -> LogicalTypeHandle) -> Vec<ScalarFunctionSignature> {
    let base = || vec![traj_type(), traj_type(), double(), double()];
    let with_xi = || {
        let mut p = base();
        p.push(bigint());
        p
    };
    let mut v = vec![sig(base(), ret()), sig(with_xi(), ret())];
    for region in [varchar, blob] {
        let mut p = with_xi();
        p.push(region());
        v.push(sig(p, ret()));
    }
    v
}

fn subset(tr: Traj<'_>, idx: &[usize]) -> OwnedTraj {
    let mut o = OwnedTraj::default();
    for &k in idx {
        o.push(tr.t[k], tr.x[k], tr.y[k]);
    }
    o
}

/// One value of a time-window call: `(length, similarity, matches)` depending on `out`.
enum Val {
    F(f64),
    I(i64),
    P(Vec<i32>, Vec<i32>),
}

/// The `epsilon, time_window [, min_points]` arguments (columns 2, 3 and optionally 4) of the
/// time-window and series forms, checked once per row; `Ok(None)` when one is NULL.
struct TwArgs<'a> {
    eps: PrimCol<'a>,
    tw: PrimCol<'a>,
    xi: OptCol<'a>,
}

impl<'a> TwArgs<'a> {
    fn new(input: &'a DataChunkHandle) -> Self {
        let xi = OptCol::new(input, 4);
        TwArgs { eps: PrimCol::new(input, 2), tw: PrimCol::new(input, 3), xi }
    }
    fn get(&self, r: usize, f: &str) -> Result<Option<TimeWindowParams>, Box<dyn Error>> {
        let (Some(eps), Some(tw)) = (self.eps.f64(r), self.tw.f64(r)) else { return Ok(None) };
        let Some(xi) = self.xi.i64_or(r, 0) else { return Ok(None) };
        TimeWindowParams::new(eps, tw, xi).map(Some).map_err(|e| err(f, e))
    }
}

fn time_window(input: &mut DataChunkHandle, output: &mut dyn WritableVector, f: &str, out: Out) -> FnResult {
    let a = TrajCol::new(input, 0);
    let b = TrajCol::new(input, 1);
    let args = TwArgs::new(input);
    let region = (input.num_columns() > 5).then(|| RegionCol::new(input, 5));
    let vals = map_rows(input.len(), |r| -> Result<Option<Val>, Box<dyn Error>> {
        let (Some(a), Some(b), Some(p)) = (a.get(r, f, "a")?, b.get(r, f, "b")?, args.get(r, f)?) else {
            return Ok(None);
        };
        let reg = match &region {
            None => None,
            Some(c) => match c.get(r, f, "region")? {
                None => return Ok(None),
                Some(reg) => Some(reg),
            },
        };
        // Restrict to the region first: lengths and ξ are counted inside it (eq. 2.10).
        let (ia, ib) = match &reg {
            None => (Vec::new(), Vec::new()),
            Some(reg) => (inside_indices(a.x, a.y, reg), inside_indices(b.x, b.y, reg)),
        };
        let (oa, ob) = (subset(a, &ia), subset(b, &ib));
        let (va, vb) = if reg.is_some() { (oa.view(), ob.view()) } else { (a, b) };
        Ok(Some(match out {
            Out::Length => Val::I(lcss::length(va, vb, &p) as i64),
            Out::Similarity => Val::F(lcss::similarity(va, vb, &p)),
            Out::Distance => Val::F(1.0 - lcss::similarity(va, vb, &p)),
            Out::Matches => {
                let m = lcss::matches(va, vb, &p);
                let map_a = |i: usize| if reg.is_some() { ia[i] } else { i };
                let map_b = |j: usize| if reg.is_some() { ib[j] } else { j };
                Val::P(
                    m.iter().map(|&(i, _)| map_a(i) as i32 + 1).collect(),
                    m.iter().map(|&(_, j)| map_b(j) as i32 + 1).collect(),
                )
            }
        }))
    })?;
    write_vals(output, vals, out);
    Ok(())
}

fn write_vals(output: &mut dyn WritableVector, vals: Vec<Option<Val>>, out: Out) {
    match out {
        Out::Similarity | Out::Distance => {
            let v: Vec<Option<f64>> = vals.into_iter().map(|v| v.map(|v| if let Val::F(x) = v { x } else { 0.0 })).collect();
            write_flat(&mut output.flat_vector(), &v)
        }
        Out::Length => {
            let v: Vec<Option<i64>> = vals.into_iter().map(|v| v.map(|v| if let Val::I(x) = v { x } else { 0 })).collect();
            write_flat(&mut output.flat_vector(), &v)
        }
        Out::Matches => {
            let v: Vec<Option<(Vec<i32>, Vec<i32>)>> = vals
                .into_iter()
                .map(|v| v.map(|v| if let Val::P(i, j) = v { (i, j) } else { (vec![], vec![]) }))
                .collect();
            write_list_of_pairs(&mut output.list_vector(), &v)
        }
    }
}

fn series(input: &mut DataChunkHandle, output: &mut dyn WritableVector, f: &str, out: Out) -> FnResult {
    let a = SeriesCol::new(input, 0);
    let b = SeriesCol::new(input, 1);
    let args = TwArgs::new(input);
    let vals = map_rows(input.len(), |r| -> Result<Option<Val>, Box<dyn Error>> {
        let (Some(a), Some(b), Some(p)) = (a.get(r, f, "a")?, b.get(r, f, "b")?, args.get(r, f)?) else {
            return Ok(None);
        };
        Ok(Some(match out {
            Out::Length => Val::I(lcss::series_length(a, b, &p) as i64),
            Out::Similarity => Val::F(lcss::series_similarity(a, b, &p)),
            Out::Distance => Val::F(1.0 - lcss::series_similarity(a, b, &p)),
            Out::Matches => {
                let m = lcss::series_matches(a, b, &p);
                Val::P(m.iter().map(|&(i, _)| i as i32 + 1).collect(), m.iter().map(|&(_, j)| j as i32 + 1).collect())
            }
        }))
    })?;
    write_vals(output, vals, out);
    Ok(())
}

fn index_params(f: &str, delta: i64, eps: f64, rho: Option<f64>) -> Result<IndexParams, Box<dyn Error>> {
    IndexParams::new(delta, eps, rho).map_err(|e| err(f, e))
}

/// Shared reader for the index-window forms; `g` computes the per-row value.
fn index_rows<T>(
    input: &mut DataChunkHandle,
    f: &str,
    mut g: impl FnMut(Traj<'_>, Traj<'_>, &IndexParams) -> T,
) -> Result<Vec<Option<T>>, Box<dyn Error>> {
    let a = TrajCol::new(input, 0);
    let b = TrajCol::new(input, 1);
    let delta = PrimCol::new(input, 2);
    let eps = PrimCol::new(input, 3);
    let rho = OptCol::new(input, 4);
    map_rows(input.len(), |r| {
        let (Some(a), Some(b), Some(d), Some(e)) = (a.get(r, f, "a")?, b.get(r, f, "b")?, delta.i64(r), eps.f64(r)) else {
            return Ok(None);
        };
        let Some(rho) = rho.f64_opt(r) else { return Ok(None) };
        let p = index_params(f, d, e, rho)?;
        Ok(Some(g(a, b, &p)))
    })
}

fn index_similarity(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    let vals = index_rows(input, "lcss_index_similarity", lcss_index::joint_similarity)?;
    write_flat(&mut output.flat_vector(), &vals);
    Ok(())
}

fn s1(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    let vals = index_rows(input, "lcss_s1", |a, b, p| {
        let r = lcss_index::s1(a, b, p);
        vec![r.sx, r.sy]
    })?;
    write_struct_f64(&mut output.struct_vector(), 2, &vals);
    Ok(())
}

fn s2(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    let mut too_large = None;
    let vals = index_rows(input, "lcss_s2", |a, b, p| {
        if let Err(e) = lcss_translate::check_size(a.len(), b.len(), p) {
            too_large = Some(e);
            return vec![0.0; 4];
        }
        let r = lcss_translate::s2(a, b, p);
        vec![r.sx, r.sy, r.cx, r.cy]
    })?;
    if let Some(e) = too_large {
        return Err(err("lcss_s2", e));
    }
    write_struct_f64(&mut output.struct_vector(), 4, &vals);
    Ok(())
}

fn index_signatures(ret: fn() -> LogicalTypeHandle) -> Vec<ScalarFunctionSignature> {
    let base = || vec![traj_type(), traj_type(), bigint(), double()];
    let mut with_rho = base();
    with_rho.push(double());
    vec![sig(base(), ret()), sig(with_rho, ret())]
}

fn series_signatures(ret: fn() -> LogicalTypeHandle) -> Vec<ScalarFunctionSignature> {
    let base = || vec![series_type(), series_type(), double(), double()];
    let mut with_xi = base();
    with_xi.push(bigint());
    vec![sig(base(), ret()), sig(with_xi, ret())]
}

fn s1_type() -> LogicalTypeHandle {
    struct_of(&[("sx", double()), ("sy", double())])
}
fn s2_type() -> LogicalTypeHandle {
    struct_of(&[("sx", double()), ("sy", double()), ("cx", double()), ("cy", double())])
}

scalar_fn!(LcssLength, tw_signatures(bigint), time_window, "lcss_length", Out::Length);
scalar_fn!(LcssSimilarity, tw_signatures(double), time_window, "lcss_similarity", Out::Similarity);
scalar_fn!(LcssDistance, tw_signatures(double), time_window, "lcss_distance", Out::Distance);
scalar_fn!(LcssMatches, tw_signatures(pairs_type), time_window, "lcss_matches", Out::Matches);
scalar_fn!(LcssSeriesLength, series_signatures(bigint), series, "lcss_series_length", Out::Length);
scalar_fn!(LcssSeriesSimilarity, series_signatures(double), series, "lcss_series_similarity", Out::Similarity);
scalar_fn!(LcssSeriesMatches, series_signatures(pairs_type), series, "lcss_series_matches", Out::Matches);
scalar_fn!(LcssIndexSimilarity, index_signatures(double), index_similarity);
scalar_fn!(LcssS1, index_signatures(s1_type), s1);
scalar_fn!(
    LcssS2,
    index_signatures(s2_type),
    s2
);

pub fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_scalar_function::<LcssLength>("lcss_length")?;
    con.register_scalar_function::<LcssSimilarity>("lcss_similarity")?;
    con.register_scalar_function::<LcssDistance>("lcss_distance")?;
    con.register_scalar_function::<LcssMatches>("lcss_matches")?;
    con.register_scalar_function::<LcssSeriesLength>("lcss_series_length")?;
    con.register_scalar_function::<LcssSeriesSimilarity>("lcss_series_similarity")?;
    con.register_scalar_function::<LcssSeriesMatches>("lcss_series_matches")?;
    con.register_scalar_function::<LcssIndexSimilarity>("lcss_index_similarity")?;
    con.register_scalar_function::<LcssS1>("lcss_s1")?;
    con.register_scalar_function::<LcssS2>("lcss_s2")?;
    Ok(())
}
