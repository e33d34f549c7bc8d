//! SQL: merging matched trajectories (`trajectory_merge`, thesis eq. 2.11 and the
//! φ_i = Θ(φ_{i−1}, A^{k_i}) recursion) and grouping matched tracks into road users
//! (`merge_groups`, Alg. 4's duplicate removal made consistent).

use super::convert::*;
use super::polygon::RegionListCol;
use crate::algo::lcss::TimeWindowParams;
use crate::algo::merge;
use crate::algo::traj::OwnedTraj;
use duckdb::core::{DataChunkHandle, LogicalTypeHandle};
use duckdb::vtab::arrow::WritableVector;
use duckdb::Connection;
use std::error::Error;

pub const DOCS: &[FnDoc] = &[
    FnDoc {
        name: "trajectory_merge",
        signatures: "trajectory_merge(a TRAJ, b TRAJ, epsilon DOUBLE, time_window DOUBLE [, [min_points BIGINT,] region VARCHAR|BLOB]) -> TRAJ\n\
                     trajectory_merge(trajs TRAJ[], epsilon DOUBLE, time_window DOUBLE [, regions VARCHAR[]|BLOB[]]) -> TRAJ",
        description: "Θ(A, B) of thesis eq. 2.11: the points LCSS pairs (eq. 2.9, epsilon metres, time_window seconds, counted inside region as in \
                      eq. 2.10) become one point at their midpoint and mid time; unmatched points of both are kept; the result is sorted by t. \
                      The list form merges in the given order, φ_i = Θ(φ_{i-1}, A^{k_i}), step i restricted to regions[i] \
                      (the overlap of the cameras merged so far with the next, polygon_overlap(polygon_union(...), ...)); regions, when given, has one \
                      polygon per step (len(trajs) - 1). Unlike the thesis's plain midpoint at every step, points are averaged with the number of \
                      original points behind them, so each camera weighs the same (identical to eq. 2.11 for two trajectories). \
                      Keep the sources next to it: list({'camera': camera, 'track_id': track_id} ORDER BY position).",
        example: "SELECT trajectory_merge([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 1, 'y': 0}], [{'t': 1, 'x': 1, 'y': 0.2}, {'t': 2, 'x': 2, 'y': 0.2}], 0.5, 0.1); -- [{'t': 0.0, 'x': 0.0, 'y': 0.0}, {'t': 1.0, 'x': 1.0, 'y': 0.1}, {'t': 2.0, 'x': 2.0, 'y': 0.2}]",
    },
    FnDoc {
        name: "merge_groups",
        signatures: "merge_groups(tracks STRUCT(id BIGINT, camera BIGINT, t0 DOUBLE, t1 DOUBLE)[], links STRUCT(a BIGINT, b BIGINT)[]) -> STRUCT(id BIGINT, grp BIGINT)[]",
        description: "Groups tracks into road users: links (pairs of track ids judged to be the same road user, e.g. hungarian_match results \
                      per camera pair) are applied in list order with union-find, and a link is refused when it would put two tracks of the same \
                      camera that overlap in time into one group (a camera cannot see one road user twice at once). Pieces of a track that one \
                      camera split (disjoint in time) may join the same group. Every track gets exactly one group, named by its smallest id: one \
                      row per road user, no duplicates (Alg. 4, line 7). Order the links by priority, e.g. list({...} ORDER BY score DESC).",
        example: "SELECT merge_groups([{'id': 1, 'camera': 1, 't0': 0, 't1': 9}, {'id': 2, 'camera': 2, 't0': 0, 't1': 4}, {'id': 3, 'camera': 2, 't0': 5, 't1': 9}, {'id': 4, 'camera': 2, 't0': 1, 't1': 3}], [{'a': 1, 'b': 2}, {'a': 1, 'b': 3}, {'a': 1, 'b': 4}]); -- [{'id': 1, 'grp': 1}, {'id': 2, 'grp': 1}, {'id': 3, 'grp': 1}, {'id': 4, 'grp': 4}]",
    },
];

fn params(eps: Option<f64>, tw: Option<f64>, min_points: Option<i64>, f: &str) -> Result<Option<TimeWindowParams>, Box<dyn Error>> {
    let (Some(e), Some(t), Some(m)) = (eps, tw, min_points) else { return Ok(None) };
    Ok(Some(TimeWindowParams::new(e, t, m).map_err(|x| err(f, x))?))
}

fn merge_pair_fn(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "trajectory_merge";
    let (a, b) = (TrajCol::new(input, 0), TrajCol::new(input, 1));
    let (eps, tw) = (PrimCol::new(input, 2), PrimCol::new(input, 3));
    let ncol = input.num_columns();
    let min_points = (ncol == 6).then(|| PrimCol::new(input, 4));
    let region = (ncol >= 5).then(|| RegionCol::new(input, ncol - 1));
    let vals = map_rows(input.len(), |r| {
        let (Some(a), Some(b)) = (a.get(r, F, "a")?, b.get(r, F, "b")?) else { return Ok(None) };
        let mp = match &min_points {
            None => Some(1),
            Some(c) => c.i64(r),
        };
        let Some(p) = params(eps.f64(r), tw.f64(r), mp, F)? else { return Ok(None) };
        let reg = match &region {
            None => None,
            Some(c) => match c.get(r, F, "region")? {
                None => return Ok(None),
                v => v,
            },
        };
        let m = merge::matches_in(a, b, &p, reg.as_deref());
        Ok(Some(merge::merge_pair(&merge::Weighted::from_traj(a), &merge::Weighted::from_traj(b), &m).into_traj()))
    })?;
    write_trajs(&mut output.list_vector(), &vals);
    Ok(())
}

fn merge_list_fn(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "trajectory_merge";
    let trajs = TrajListCol::new(input, 0);
    let (eps, tw) = (PrimCol::new(input, 1), PrimCol::new(input, 2));
    let regions = (input.num_columns() > 3).then(|| RegionListCol::new(input, 3));
    let vals = map_rows(input.len(), |r| -> Result<Option<OwnedTraj>, Box<dyn Error>> {
        let Some(ts) = trajs.get(r, F, "trajs")? else { return Ok(None) };
        let Some(p) = params(eps.f64(r), tw.f64(r), Some(1), F)? else { return Ok(None) };
        let regs = match &regions {
            None => Vec::new(),
            Some(c) => match c.get(r, F, "regions")? {
                None => return Ok(None),
                Some(v) => {
                    if v.len() + 1 != ts.len().max(1) {
                        return Err(err(F, format!("regions needs one polygon per merge step (len(trajs) - 1 = {}), got {}", ts.len().saturating_sub(1), v.len())));
                    }
                    v
                }
            },
        };
        let refs: Vec<Option<&crate::algo::region::Region>> = regs.iter().map(Some).collect();
        Ok(Some(merge::merge_chain(&ts, &p, &refs).0))
    })?;
    write_trajs(&mut output.list_vector(), &vals);
    Ok(())
}

fn span_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&struct_of(&[("id", bigint()), ("camera", bigint()), ("t0", double()), ("t1", double())]))
}
fn link_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&struct_of(&[("a", bigint()), ("b", bigint())]))
}
fn group_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&struct_of(&[("id", bigint()), ("grp", bigint())]))
}

fn merge_groups_fn(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "merge_groups";
    // BIGINT and DOUBLE fields are both 8 bytes: read through the DOUBLE-field reader and
    // reinterpret the BIGINT ones.
    let tracks = ListOfStructCol::new_pub(input, 0, &["id", "camera", "t0", "t1"]);
    let links = ListOfStructCol::new_pub(input, 1, &["a", "b"]);
    let vals = map_rows(input.len(), |r| -> Result<Option<(Vec<f64>, Vec<f64>)>, Box<dyn Error>> {
        let (Some(t), Some(l)) = (tracks.row_fields(r, F, "tracks")?, links.row_fields(r, F, "links")?) else { return Ok(None) };
        let spans: Vec<merge::Span> = (0..t[0].len())
            .map(|k| merge::Span { id: i64_bits(t[0][k]), camera: i64_bits(t[1][k]), t0: t[2][k], t1: t[3][k] })
            .collect();
        let pairs: Vec<(i64, i64)> = (0..l[0].len()).map(|k| (i64_bits(l[0][k]), i64_bits(l[1][k]))).collect();
        let (groups, _) = merge::consistent_groups(&spans, &pairs).map_err(|e| err(F, e))?;
        Ok(Some((spans.iter().map(|s| bits_i64(s.id)).collect(), groups.into_iter().map(bits_i64).collect())))
    })?;
    let cols: Vec<Option<Vec<&[f64]>>> = vals.iter().map(|v| v.as_ref().map(|(a, b)| vec![&a[..], &b[..]])).collect();
    write_list_struct_f64(&mut output.list_vector(), 2, &cols);
    Ok(())
}

scalar_fn!(
    TrajectoryMerge,
    {
        let mut v = vec![sig(vec![traj_type(), traj_type(), double(), double()], traj_type())];
        for g in [varchar as fn() -> LogicalTypeHandle, blob] {
            v.push(sig(vec![traj_type(), traj_type(), double(), double(), g()], traj_type()));
            v.push(sig(vec![traj_type(), traj_type(), double(), double(), bigint(), g()], traj_type()));
        }
        v
    },
    merge_pair_fn
);
scalar_fn!(
    TrajectoryMergeList,
    {
        let list = || LogicalTypeHandle::list(&traj_type());
        let mut v = vec![sig(vec![list(), double(), double()], traj_type())];
        for g in [varchar as fn() -> LogicalTypeHandle, blob] {
            v.push(sig(vec![list(), double(), double(), LogicalTypeHandle::list(&g())], traj_type()));
        }
        v
    },
    merge_list_fn
);
scalar_fn!(MergeGroups, vec![sig(vec![span_type(), link_type()], group_type())], merge_groups_fn);

pub fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_scalar_function::<TrajectoryMerge>("trajectory_merge")?;
    con.register_scalar_function::<TrajectoryMergeList>("trajectory_merge")?;
    con.register_scalar_function::<MergeGroups>("merge_groups")?;
    Ok(())
}
