//! SQL: the LCSS family. Maths: `crates/algo/src/lcss/` (time_window.rs for the thesis's eq. 2.9/2.10
//! and the 1-D series form, index.rs for Buzan's S1, translate.rs for S2).

use super::registry::{pd, Function, Param, Section, Signature, Ty, GEOMETRY, SERIES, TRAJ};
use super::vector::{Args, Column, Out, Value};
use crate::algo::lcss::index::{self, IndexParams};
use crate::algo::lcss::time_window::{self as tw, TimeWindowParams};
use crate::algo::lcss::translate;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const TW_MATHS: &str = "crates/algo/src/lcss/time_window.rs";
const INDEX_MATHS: &str = "crates/algo/src/lcss/index.rs";

const A: Param = pd("a", TRAJ, "the first trajectory, sorted by t");
const B: Param = pd("b", TRAJ, "the second trajectory, sorted by t");
const EPSILON: Param = pd("epsilon", Ty::Double, "points match when closer than this (m), > 0");
const TIME_WINDOW: Param = pd("time_window", Ty::Double, "a match must also be closer than this in time (s), > 0");
const MIN_POINTS: Param =
    pd("min_points", Ty::Bigint, "a side with fewer points than this (counted inside region when one is given) scores 0, >= 0; default 0");
const REGION: Param = pd("region", GEOMETRY, "only the points inside this polygon take part (WKT, WKB or GEOMETRY); default: all points");
/// `(a, b, epsilon, time_window [, min_points [, region]])` of the time-window forms.
const TW_PARAMS: &[Param] = &[A, B, EPSILON, TIME_WINDOW, MIN_POINTS, REGION];
const TW_ARITIES: &[usize] = &[4, 5, 6];
/// `(a, b, epsilon, time_window [, min_points])` of the series forms.
const SERIES_PARAMS: &[Param] = &[
    pd("a", SERIES, "the first series {t (s), v} sorted by t, e.g. traj_speeds(...)"),
    pd("b", SERIES, "the second series {t (s), v} sorted by t"),
    pd("epsilon", Ty::Double, "values match when |v_a - v_b| is less than this (the series' unit), > 0"),
    TIME_WINDOW,
    pd("min_points", Ty::Bigint, "a side with fewer samples than this scores 0, >= 0; default 0"),
];
/// `(a, b, delta, epsilon [, rho])` of the index-window forms.
const INDEX_PARAMS: &[Param] = &[
    pd("a", TRAJ, "the first trajectory (its list positions count, t is not read)"),
    pd("b", TRAJ, "the second trajectory (its list positions count, t is not read)"),
    pd("delta", Ty::Bigint, "the largest difference |i - j| of the list positions of a match (samples), >= 0"),
    pd("epsilon", Ty::Double, "the matching distance (m), > 0: between the points for lcss_index_similarity, per axis for lcss_s1 and lcss_s2"),
    pd("rho", Ty::Double, "the least length ratio min(n, m) / max(n, m), in (0, 1]: a pair below it scores 0; default: no ratio test"),
];
const PAIRS: Ty = Ty::List(&Ty::Struct(&[("i", Ty::Integer), ("j", Ty::Integer)]));

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "lcss_length",
        description: "Longest common subsequence L(eps, T, xi) of thesis eq. 2.9: points match when their distance is < epsilon (metres) \
                      and their time difference is < time_window (seconds). 0 when either side has fewer than min_points points. \
                      With region (WKT or WKB polygon) only points inside it take part, and min_points counts them after the restriction. \
                      Banded: O((n+m)*w) time with w the points of the other trajectory within time_window; O(n+m) memory.",
        example: "SELECT lcss_length(a, b, 1.0, 0.5) FROM (SELECT [{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}] AS a, [{'t':0.1,'x':0.2,'y':0},{'t':1.1,'x':1.2,'y':0}] AS b); -- 2",
        maths: TW_MATHS,
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_similarity", "lcss_distance", "lcss_matches", "lcss_series_length"],
        signatures: &[Signature { params: TW_PARAMS, arities: TW_ARITIES, returns: Ty::Bigint, kernel: length }],
        table: None,
    },
    Function {
        name: "lcss_similarity",
        description: "eta of thesis eq. 2.10: lcss_length / min(|a|, |b|), in [0, 1]; 0 for an empty side or one with fewer than min_points points. \
                      With region, both lengths are counted inside the region (P^{k∩l} in the thesis).",
        example: "SELECT lcss_similarity(a, b, 1.0, 0.5, 2, 'POLYGON((-1 -1, 5 -1, 5 5, -1 5, -1 -1))') FROM (SELECT [{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}] AS a, [{'t':0.1,'x':0.2,'y':0},{'t':1.1,'x':1.2,'y':0}] AS b); -- 1.0",
        maths: TW_MATHS,
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_length", "lcss_distance", "lcss_matches", "lcss_similarity_pairs", "lcss_s2"],
        signatures: &[Signature { params: TW_PARAMS, arities: TW_ARITIES, returns: Ty::Double, kernel: similarity }],
        table: None,
    },
    Function {
        name: "lcss_distance",
        description: "1 - lcss_similarity, in [0, 1], for clustering. Buzan's D = 1/S (eq. 4.7, in [1, inf]) is 1.0 / lcss_similarity(...) in SQL.",
        example: "SELECT lcss_distance([{'t':0,'x':0,'y':0}], [{'t':0,'x':5,'y':0}], 1.0, 1.0); -- 1.0",
        maths: TW_MATHS,
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_similarity", "agglomerative_cluster"],
        signatures: &[Signature { params: TW_PARAMS, arities: TW_ARITIES, returns: Ty::Double, kernel: distance }],
        table: None,
    },
    Function {
        name: "lcss_matches",
        description: "The matched point pairs of one longest common subsequence, by backtracking (thesis section 2.3): 1-based positions \
                      into a and b (so a[i] and b[j] index the inputs directly, also with a region), increasing in both. \
                      Ties prefer the latest match. Empty when nothing matches.",
        example: "SELECT lcss_matches([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':1.1,'x':1.2,'y':0}], 1.0, 0.5); -- [{'i': 2, 'j': 1}]",
        maths: TW_MATHS,
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_length", "lcss_series_matches", "trajectory_merge"],
        signatures: &[Signature { params: TW_PARAMS, arities: TW_ARITIES, returns: PAIRS, kernel: matches }],
        table: None,
    },
    Function {
        name: "lcss_series_length",
        description: "1-D time-window LCSS on series such as traj_speeds(...): match when |v_a - v_b| < epsilon (series units) and |t_a - t_b| < time_window.",
        example: "SELECT lcss_series_length([{'t':0,'v':1.0},{'t':1,'v':2.0}], [{'t':0.2,'v':1.5},{'t':1.2,'v':2.1}], 1.0, 0.5); -- 2",
        maths: TW_MATHS,
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_series_similarity", "lcss_series_matches", "lcss_length"],
        signatures: &[Signature { params: SERIES_PARAMS, arities: &[4, 5], returns: Ty::Bigint, kernel: series_length }],
        table: None,
    },
    Function {
        name: "lcss_series_similarity",
        description: "lcss_series_length / min(|a|, |b|). The thesis's coordinate-free speed pre-match is \
                      lcss_series_similarity(traj_speeds(a), traj_speeds(b), 2.0, 1.0) >= 0.8.",
        example: "SELECT lcss_series_similarity([{'t':0,'v':1.0},{'t':1,'v':2.0}], [{'t':0.2,'v':1.5},{'t':1.2,'v':5.0}], 1.0, 0.5); -- 0.5",
        maths: TW_MATHS,
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_series_length", "traj_speeds", "traj_turn_rates", "lcss_similarity"],
        signatures: &[Signature { params: SERIES_PARAMS, arities: &[4, 5], returns: Ty::Double, kernel: series_similarity }],
        table: None,
    },
    Function {
        name: "lcss_series_matches",
        description: "Matched 1-based index pairs of the 1-D form.",
        example: "SELECT lcss_series_matches([{'t':0,'v':1.0},{'t':1,'v':2.0}], [{'t':0.2,'v':1.5}], 1.0, 0.5); -- [{'i': 1, 'j': 1}]",
        maths: TW_MATHS,
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_series_length", "lcss_matches"],
        signatures: &[Signature { params: SERIES_PARAMS, arities: &[4, 5], returns: PAIRS, kernel: series_matches }],
        table: None,
    },
    Function {
        name: "lcss_index_similarity",
        description: "Index-window LCSS with one 2-D match: ||a_i - b_j|| < epsilon and |i - j| <= delta (list positions, t unused), \
                      divided by min(n, m); 0 when min(n,m) < rho*max(n,m). Equals tslearn's lcss(a, b, eps, sakoe_chiba_radius=delta) \
                      on equal-length inputs for delta >= 1 (for delta = 0 tslearn 0.10 returns only the trailing run of matches; this is the true LCSS). O(delta*(n+m)) (Buzan lemma 4.1).",
        example: "SELECT lcss_index_similarity([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':0,'x':0.1,'y':0},{'t':1,'x':5,'y':0}], 1, 0.5); -- 0.5",
        maths: INDEX_MATHS,
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_s1", "lcss_s2", "lcss_similarity"],
        signatures: &[Signature { params: INDEX_PARAMS, arities: &[4, 5], returns: Ty::Double, kernel: index_similarity }],
        table: None,
    },
    Function {
        name: "lcss_s1",
        description: "Buzan's S1_2D (def. 4.1/4.2): per-axis LCSS (|a_x - b_x| < epsilon, |i - j| <= delta) over min(n, m); \
                      both 0 when min(n,m) < rho*max(n,m). Buzan's distance D1 = 1/S1 per axis.",
        example: "SELECT lcss_s1([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':0,'x':0.1,'y':9},{'t':1,'x':1.1,'y':9}], 1, 0.5); -- {'sx': 1.0, 'sy': 0.0}",
        maths: INDEX_MATHS,
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_s2", "lcss_index_similarity", "traj_cluster"],
        signatures: &[Signature {
            params: INDEX_PARAMS,
            arities: &[4, 5],
            returns: Ty::Struct(&[("sx", Ty::Double), ("sy", Ty::Double)]),
            kernel: s1,
        }],
        table: None,
    },
    Function {
        name: "lcss_s2",
        description: "Buzan's translation-invariant S2_2D (def. 4.3): the best S1 over all translations of b, searched per axis over the \
                      O(delta*(n+m)) candidate translations of lemma 4.2 with branch-and-bound pruning; (cx, cy) is a translation that \
                      achieves it (add it to b).",
        example: "SELECT lcss_s2([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':1}], [{'t':0,'x':10,'y':20},{'t':1,'x':11,'y':21}], 1, 0.5); -- sx = sy = 1, cx ~ -10, cy ~ -20",
        maths: "crates/algo/src/lcss/translate.rs",
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_s1", "lcss_similarity", "traj_cluster"],
        signatures: &[Signature {
            params: INDEX_PARAMS,
            arities: &[4, 5],
            returns: Ty::Struct(&[("sx", Ty::Double), ("sy", Ty::Double), ("cx", Ty::Double), ("cy", Ty::Double)]),
            kernel: s2,
        }],
        table: None,
    },
    Function {
        name: "lcss_similarity_pairs",
        description: "lcss_similarity for every pair of two sets of trajectories, in one call, returning only the pairs with eta > 0 (a pair \
                      not listed has eta = 0): a sparse similarity matrix. Each element: a, b (the ids of the pair, from ids_a and \
                      ids_b) and eta, exactly lcss_similarity(trajs_a[i], trajs_b[j], epsilon, time_window, min_points, region). \
                      Candidates come from a space-time grid (cells of 2 epsilon by 2 time_window; with region every trajectory is \
                      restricted to it once): only pairs that come within epsilon of each other within time_window seconds are \
                      scored, so the cost grows with the road users near each other, not with all pairs that overlap in time \
                      (sql/stages/merge.sql scores each camera pair this way). O(P log P + lookups + banded LCSS of the candidates), \
                      P the points of trajs_b; pairs in parallel. Sorted by (position in trajs_a, position in trajs_b). Errors: ids \
                      and trajs lists of different lengths, duplicate ids on one side, NULL elements, NaN / infinite values, unsorted t, \
                      epsilon or time_window <= 0, min_points < 0, a bad polygon, a pair over the lcss_cells limit.",
        example: "SELECT unnest(lcss_similarity_pairs([1, 2], [[{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}], [{'t':0,'x':50,'y':0}]], [7], [[{'t':0.1,'x':0.2,'y':0},{'t':1.1,'x':1.2,'y':0}]], 1.0, 0.5)); -- {'a': 1, 'b': 7, 'eta': 1.0}",
        maths: "crates/algo/src/lcss/sparse.rs",
        binding: file!(),
        section: Section::Similarity,
        see_also: &["lcss_similarity", "hungarian_match", "traj_msd_pairs"],
        signatures: &[Signature {
            params: super::common::two_sets_params!(EPSILON, TIME_WINDOW, MIN_POINTS, REGION),
            arities: &[6, 7, 8],
            returns: Ty::List(&Ty::Struct(&[("a", Ty::Bigint), ("b", Ty::Bigint), ("eta", Ty::Double)])),
            kernel: similarity_pairs,
        }],
        table: None,
    },
];

/// The time-window parameters of `row` (columns 2, 3 and the optional 4); `None` when one is NULL.
fn tw_params<'a>(a: &Args<'a>) -> impl Fn(usize) -> Result<Option<TimeWindowParams>, Box<dyn Error>> + 'a {
    let (eps, t, xi) = (a.double(2), a.double(3), a.opt_bigint(4));
    move |r| {
        let (Some(eps), Some(t), Some(xi)) = (eps.get(r), t.get(r), xi.or(r, 0)) else { return Ok(None) };
        Ok(Some(TimeWindowParams::new(eps, t, xi)?))
    }
}

/// Runs `f(a, b, params, region)` for every row of a time-window call; the first error stops it.
/// A pair whose bounding boxes are ε or more apart ([`crate::algo::traj::Bounds::within`], from the pass that
/// validates the points) has no matching point pair, inside any region too: it gets `unmatched`
/// (the form's value for L = 0) without `f`, after the same argument checks.
fn time_window_rows<T: Send + Sync + Clone, E: Error + 'static>(
    a: &Args<'_>,
    unmatched: T,
    f: impl Fn(crate::algo::traj::Traj<'_>, crate::algo::traj::Traj<'_>, &TimeWindowParams, Option<&crate::algo::geometry::region::Region>) -> Result<T, E> + Sync,
) -> Result<Vec<Option<T>>, Box<dyn Error>> {
    let (ta, tb, params, region) = (a.traj(0), a.traj(1), tw_params(a), a.opt_region(5));
    // the polygons first (parsed once per distinct polygon, RegionCol's cache is not shared), a
    // bad one kept as its row's error; then the rows on all cores, each checking its arguments in
    // the order of a row-by-row run: a NULL trajectory still gives NULL, the first bad row wins
    let regions: Vec<Result<Option<Option<std::sync::Arc<crate::algo::geometry::region::Region>>>, String>> =
        (0..a.rows()).map(|r| region.get(r).map_err(|e| e.to_string())).collect();
    a.par_map(|r| {
        let (Some((x, bx)), Some((y, by)), Some(p)) = (ta.get_bounded(r)?, tb.get_bounded(r)?, params(r)?) else { return Ok(None) };
        let Some(reg) = regions[r].clone()? else { return Ok(None) };
        tw::check_work(x.t, y.t, p.time_window())?;
        if !bx.within(&by, p.epsilon()) {
            return Ok(Some(unmatched.clone()));
        }
        Ok(Some(f(x, y, &p, reg.as_deref())?))
    })
}

fn length(a: &Args<'_>, out: &mut Out<'_>) -> R {
    out.flat(&time_window_rows(a, 0, |x, y, p, reg| tw::length_in(x, y, p, reg).map(|l| l as i64))?);
    Ok(())
}

fn similarity(a: &Args<'_>, out: &mut Out<'_>) -> R {
    out.flat(&time_window_rows(a, 0.0, tw::similarity_in)?);
    Ok(())
}

fn distance(a: &Args<'_>, out: &mut Out<'_>) -> R {
    out.flat(&time_window_rows(a, 1.0, |x, y, p, reg| tw::similarity_in(x, y, p, reg).map(|s| 1.0 - s))?);
    Ok(())
}

/// Writes matched pairs as 1-based `STRUCT(i, j)[]`.
fn write_pairs(out: &mut Out<'_>, vals: &[Option<Vec<(usize, usize)>>]) -> Result<(), String> {
    let ij: Vec<Option<(Vec<i32>, Vec<i32>)>> =
        vals.iter().map(|v| v.as_ref().map(|m| m.iter().map(|&(i, j)| (i as i32 + 1, j as i32 + 1)).unzip())).collect();
    let cols: Vec<_> = ij.iter().map(|v| v.as_ref().map(|(i, j)| vec![Column::I32(i), Column::I32(j)])).collect();
    out.struct_lists(&cols)
}

fn matches(a: &Args<'_>, out: &mut Out<'_>) -> R {
    write_pairs(out, &time_window_rows(a, Vec::new(), tw::matches_in)?)?;
    Ok(())
}

/// Runs `f(a, b, params)` for every row of a series call; the first error stops it.
fn series_rows<T: Send, E: Error + 'static>(
    a: &Args<'_>,
    f: impl Fn(crate::algo::traj::Series<'_>, crate::algo::traj::Series<'_>, &TimeWindowParams) -> Result<T, E> + Sync,
) -> Result<Vec<Option<T>>, Box<dyn Error>> {
    let (sa, sb, params) = (a.series(0), a.series(1), tw_params(a));
    a.par_map(|r| {
        let (Some(x), Some(y), Some(p)) = (sa.get(r)?, sb.get(r)?, params(r)?) else { return Ok(None) };
        tw::check_work(x.t, y.t, p.time_window())?;
        Ok(Some(f(x, y, &p)?))
    })
}

fn series_length(a: &Args<'_>, out: &mut Out<'_>) -> R {
    out.flat(&series_rows(a, |x, y, p| tw::series_length(x, y, p).map(|l| l as i64))?);
    Ok(())
}

fn series_similarity(a: &Args<'_>, out: &mut Out<'_>) -> R {
    out.flat(&series_rows(a, tw::series_similarity)?);
    Ok(())
}

fn series_matches(a: &Args<'_>, out: &mut Out<'_>) -> R {
    write_pairs(out, &series_rows(a, tw::series_matches)?)?;
    Ok(())
}

/// Runs `f(a, b, params)` for every row of an index-window call.
fn index_rows<T: Send>(
    a: &Args<'_>,
    f: impl Fn(crate::algo::traj::Traj<'_>, crate::algo::traj::Traj<'_>, &IndexParams) -> Result<T, Box<dyn Error>> + Sync,
) -> Result<Vec<Option<T>>, Box<dyn Error>> {
    let (ta, tb, delta, eps, rho) = (a.traj(0), a.traj(1), a.bigint(2), a.double(3), a.opt_double(4));
    a.par_map(|r| {
        let (Some(x), Some(y), Some(d), Some(e), Some(rho)) = (ta.get(r)?, tb.get(r)?, delta.get(r), eps.get(r), rho.opt(r)) else {
            return Ok(None);
        };
        let p = IndexParams::new(d, e, rho)?;
        index::check_work(x.len(), y.len(), &p)?;
        Ok(Some(f(x, y, &p)?))
    })
}

fn index_similarity(a: &Args<'_>, out: &mut Out<'_>) -> R {
    out.flat(&index_rows(a, |x, y, p| Ok(index::joint_similarity(x, y, p)?))?);
    Ok(())
}

fn s1(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let vals = index_rows(a, |x, y, p| {
        let s = index::s1(x, y, p)?;
        Ok(vec![Value::F64(s.sx), Value::F64(s.sy)])
    })?;
    out.structs(&vals);
    Ok(())
}

fn s2(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let vals = index_rows(a, |x, y, p| {
        let s = translate::s2_checked(x, y, p)?;
        Ok([s.sx, s.sy, s.cx, s.cy].map(Value::F64).to_vec())
    })?;
    out.structs(&vals);
    Ok(())
}

/// lcss_similarity_pairs: one sparse similarity matrix per row (the pairs in parallel inside).
fn similarity_pairs(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ia, ta, ib, tb) = (a.i64_list(0), a.traj_list(1), a.i64_list(2), a.traj_list(3));
    let (eps, t, xi, region) = (a.double(4), a.double(5), a.opt_bigint(6), a.opt_region(7));
    let vals = a.map(|r| {
        let (Some(ia), Some(ta), Some(ib), Some(tb)) = (ia.get(r)?, ta.get(r)?, ib.get(r)?, tb.get(r)?) else { return Ok(None) };
        let (Some(eps), Some(t), Some(xi)) = (eps.get(r), t.get(r), xi.or(r, 0)) else { return Ok(None) };
        let p = TimeWindowParams::new(eps, t, xi)?;
        let Some(reg) = region.get(r)? else { return Ok(None) };
        // lists of one length, one trajectory per id (a repeated id would give pairs no one can tell apart)
        super::common::two_sets(ia, &ta, ib, &tb)?;
        let found = crate::algo::lcss::sparse::similarity_sparse(&ta, &tb, &p, reg.as_deref())?;
        let (ka, kb, eta): (Vec<i64>, Vec<i64>, Vec<f64>) = (
            found.iter().map(|q| ia[q.a]).collect(),
            found.iter().map(|q| ib[q.b]).collect(),
            found.iter().map(|q| q.eta).collect(),
        );
        Ok(Some((ka, kb, eta)))
    })?;
    let cols: Vec<_> = vals.iter().map(|v| v.as_ref().map(|(x, y, e)| vec![Column::I64(x), Column::I64(y), Column::F64(e)])).collect();
    out.struct_lists(&cols)?;
    Ok(())
}
