//! SQL: merging matched trajectories and grouping matched tracks into road users.
//! Maths: `crates/algo/src/merge.rs` (eq. 2.11, the φ_i = Θ(φ_{i−1}, A^{k_i}) recursion, consistent
//! groups).

use super::registry::{pd, Function, Param, Section, Signature, Ty, GEOMETRY, GEOMETRY_LIST, TRAJ};
use super::vector::{Args, Column, Out};
use crate::algo::geometry::region::Region;
use crate::algo::lcss::time_window::TimeWindowParams;
use crate::algo::merge;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const MATHS: &str = "crates/algo/src/merge.rs";

const EPSILON: Param = pd("epsilon", Ty::Double, "points match when closer than this (m), > 0");
const TIME_WINDOW: Param = pd("time_window", Ty::Double, "a match must also be closer than this in time (s), > 0");
const AB: [Param; 4] = [
    pd("a", TRAJ, "the first trajectory, sorted by t"),
    pd("b", TRAJ, "the second trajectory, sorted by t, in the same frame and on the same clock"),
    EPSILON,
    TIME_WINDOW,
];
const REGION: Param = pd("region", GEOMETRY, "only the points inside this polygon are matched (eq. 2.10); the others are kept as they are; default: all points");

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "trajectory_merge",
        description: "Θ(A, B) of thesis eq. 2.11: the points LCSS pairs (eq. 2.9, epsilon metres, time_window seconds, counted inside region as in \
                      eq. 2.10) become one point at their midpoint and mid time; unmatched points of both are kept; the result is sorted by t. \
                      The list form merges in the given order, φ_i = Θ(φ_{i-1}, A^{k_i}), step i restricted to regions[i] \
                      (the overlap of the cameras merged so far with the next, polygon_overlap(polygon_union(...), ...)); regions, when given, has one \
                      polygon per step (len(trajs) - 1). Unlike the thesis's plain midpoint at every step, points are averaged with the number of \
                      original points behind them, so each camera weighs the same (identical to eq. 2.11 for two trajectories). \
                      Keep the sources next to it: list({'camera': camera, 'track_id': track_id} ORDER BY position).",
        example: "SELECT trajectory_merge([{'t': 0, 'x': 0, 'y': 0}, {'t': 1, 'x': 1, 'y': 0}], [{'t': 1, 'x': 1, 'y': 0.2}, {'t': 2, 'x': 2, 'y': 0.2}], 0.5, 0.1); -- [{'t': 0.0, 'x': 0.0, 'y': 0.0}, {'t': 1.0, 'x': 1.0, 'y': 0.1}, {'t': 2.0, 'x': 2.0, 'y': 0.2}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Matching,
        see_also: &["lcss_matches", "merge_groups", "polygon_overlap", "traj_fuse"],
        signatures: &[
            Signature {
                params: &[
                    AB[0],
                    AB[1],
                    AB[2],
                    AB[3],
                    pd("min_points", Ty::Bigint, "nothing is matched when a side has fewer points than this (counted inside region), >= 0; default 1"),
                    REGION,
                ],
                arities: &[4, 6],
                returns: TRAJ,
                kernel: merge_pair,
            },
            Signature { params: &[AB[0], AB[1], AB[2], AB[3], REGION], arities: &[], returns: TRAJ, kernel: merge_pair },
            Signature {
                params: &[
                    pd("trajs", Ty::List(&TRAJ), "the trajectories to merge, in merge order (one per camera)"),
                    EPSILON,
                    TIME_WINDOW,
                    pd("regions", GEOMETRY_LIST, "one polygon per merge step (len(trajs) - 1): step i matches inside regions[i] only; default: all points"),
                ],
                arities: &[3, 4],
                returns: TRAJ,
                kernel: merge_list,
            },
        ],
        table: None,
    },
    Function {
        name: "merge_groups",
        description: "Groups tracks into road users: links (pairs of track ids judged to be the same road user, e.g. hungarian_match results \
                      per camera pair) are applied in list order with union-find, and a link is refused when it would put two tracks of the same \
                      camera that overlap in time into one group (a camera cannot see one road user twice at once). Pieces of a track that one \
                      camera split (disjoint in time) may join the same group. Every track gets exactly one group, named by its smallest id: one \
                      row per road user, no duplicates (Alg. 4, line 7). Order the links by priority, e.g. list({...} ORDER BY score DESC).",
        example: "SELECT merge_groups([{'id': 1, 'camera': 1, 't0': 0, 't1': 9}, {'id': 2, 'camera': 2, 't0': 0, 't1': 4}, {'id': 3, 'camera': 2, 't0': 5, 't1': 9}, {'id': 4, 'camera': 2, 't0': 1, 't1': 3}], [{'a': 1, 'b': 2}, {'a': 1, 'b': 3}, {'a': 1, 'b': 4}]); -- [{'id': 1, 'grp': 1}, {'id': 2, 'grp': 1}, {'id': 3, 'grp': 1}, {'id': 4, 'grp': 4}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Matching,
        see_also: &["hungarian_match", "trajectory_merge"],
        signatures: &[Signature {
            params: &[
                pd(
                    "tracks",
                    Ty::List(&Ty::Struct(&[("id", Ty::Bigint), ("camera", Ty::Bigint), ("t0", Ty::Double), ("t1", Ty::Double)])),
                    "every track: its id, camera and time span t0 to t1 (s)",
                ),
                pd("links", Ty::List(&Ty::Struct(&[("a", Ty::Bigint), ("b", Ty::Bigint)])), "pairs of track ids judged one road user, in priority order (applied first to last)"),
            ],
            arities: &[],
            returns: Ty::List(&Ty::Struct(&[("id", Ty::Bigint), ("grp", Ty::Bigint)])),
            kernel: merge_groups,
        }],
        table: None,
    },
];

/// `(a, b, epsilon, time_window [, min_points,] [region])`: both pair overloads; the region is
/// the last argument when there are 5 or 6.
fn merge_pair(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ta, tb, eps, t) = (a.traj(0), a.traj(1), a.double(2), a.double(3));
    // 4 arguments; 5 = region; 6 = min_points, region
    let (min_points, region) = if a.given(5) { (Some(a.bigint(4)), a.opt_region(5)) } else { (None, a.opt_region(4)) };
    let vals = a.map(|r| {
        let (Some(x), Some(y), Some(e), Some(t)) = (ta.get(r)?, tb.get(r)?, eps.get(r), t.get(r)) else { return Ok(None) };
        let Some(mp) = min_points.as_ref().map_or(Some(1), |c| c.get(r)) else { return Ok(None) };
        let p = TimeWindowParams::new(e, t, mp)?;
        let Some(reg) = region.get(r)? else { return Ok(None) };
        Ok(Some(merge::merge_two(x, y, &p, reg.as_deref())?))
    })?;
    out.trajs(&vals)?;
    Ok(())
}

fn merge_list(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (trajs, eps, t) = (a.traj_list(0), a.double(1), a.double(2));
    let regions = a.given(3).then(|| a.region_list(3));
    let vals = a.map(|r| {
        let (Some(ts), Some(e), Some(t)) = (trajs.get(r)?, eps.get(r), t.get(r)) else { return Ok(None) };
        let p = TimeWindowParams::new(e, t, 1)?;
        let regs: Option<Vec<Region>> = match &regions {
            None => None,
            Some(c) => match c.get(r)? {
                None => return Ok(None),
                v => v,
            },
        };
        let refs: Option<Vec<&Region>> = regs.as_ref().map(|v| v.iter().collect());
        Ok(Some(merge::merge_chain(&ts, &p, refs.as_deref())?.0))
    })?;
    out.trajs(&vals)?;
    Ok(())
}

fn merge_groups(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tracks, links) = (a.struct_list(0), a.struct_list(1));
    let vals = a.map(|r| {
        let (Some(t), Some(l)) = (tracks.get(r)?, links.get(r)?) else { return Ok(None) };
        let spans: Vec<merge::Span> =
            (0..t.len()).map(|k| merge::Span { id: t.i64(0)[k], camera: t.i64(1)[k], t0: t.f64(2)[k], t1: t.f64(3)[k] }).collect();
        let pairs: Vec<(i64, i64)> = (0..l.len()).map(|k| (l.i64(0)[k], l.i64(1)[k])).collect();
        let (groups, _) = merge::consistent_groups(&spans, &pairs)?;
        Ok(Some((t.i64(0).to_vec(), groups)))
    })?;
    let cols: Vec<_> = vals.iter().map(|v| v.as_ref().map(|(ids, g)| vec![Column::I64(ids), Column::I64(g)])).collect();
    out.struct_lists(&cols)?;
    Ok(())
}
