//! What more than one binding file uses, in one place: no binding file imports from another
//! (each imports from here, [`super::types`], [`super::registry`] and [`super::vector`]).
//! - [`try_map`]: a result column allocated fallibly (events.rs);
//! - [`two_sets_params!`] and [`two_sets`]: calls on two sets of trajectories (align.rs's
//!   traj_msd_pairs, lcss.rs's lcss_similarity_pairs);
//! - [`pipeline_param`] and [`N_PARAMS`]: the declared pipeline parameters as named parameters
//!   (pipeline.rs's trajdb_pipeline, archive.rs's trajdb_archive);
//! - [`may_write_into`]: may the calling connection write into a folder (params.rs, pipeline.rs,
//!   archive.rs, simulate.rs).

use super::types::{pd, Param, Ty};
use super::vector::table::BindArgs;
use crate::app::outdir;
use crate::app::params::{Kind, PARAMS};
use std::error::Error;

/// `f` of every element of `s`, into a vector allocated fallibly: result columns sized by the
/// input are errors naming their size when they do not fit, never an abort.
pub(crate) fn try_map<T, U>(s: &[T], f: impl FnMut(&T) -> U) -> Result<Vec<U>, String> {
    let mut v = Vec::new();
    v.try_reserve_exact(s.len())
        .map_err(|_| format!("the result holds {} rows (about {} bytes a column), more than this process can allocate; return less per call", s.len(), s.len() as u128 * std::mem::size_of::<U>() as u128))?;
    v.extend(s.iter().map(f));
    Ok(v)
}

/// The parameters of a call on two sets of trajectories (`ids_a, trajs_a, ids_b, trajs_b`, then
/// `$rest`): traj_msd_pairs, lcss_similarity_pairs. Needs `pd`, `Ty` and `TRAJ` in scope.
macro_rules! two_sets_params {
    ($($rest:expr),*) => {
        &[
            pd("ids_a", Ty::List(&Ty::Bigint), "the ids of the first set, one per element of trajs_a and distinct (list(id ORDER BY id))"),
            pd("trajs_a", Ty::List(&TRAJ), "the first set's trajectories, in the order of ids_a (list(traj ORDER BY id))"),
            pd("ids_b", Ty::List(&Ty::Bigint), "the ids of the second set, one per element of trajs_b and distinct"),
            pd("trajs_b", Ty::List(&TRAJ), "the second set's trajectories, in the order of ids_b"),
            $($rest),*
        ]
    };
}
pub(super) use two_sets_params;

/// The id positions of one side of a two-set call.
pub(super) type Positions = std::collections::HashMap<i64, usize>;

/// The id positions of both sets of a two-set call; lists of different lengths or a duplicate
/// id on one side are errors.
pub(super) fn two_sets(ia: &[i64], ta: &[crate::algo::traj::Traj<'_>], ib: &[i64], tb: &[crate::algo::traj::Traj<'_>]) -> Result<(Positions, Positions), Box<dyn Error>> {
    for (ids, n, side) in [(ia, ta.len(), "a"), (ib, tb.len(), "b")] {
        if ids.len() != n {
            return Err(format!("ids_{side} has {} elements but trajs_{side} has {n}; pass list(id ORDER BY id) and list(traj ORDER BY id) of the same rows", ids.len()).into());
        }
    }
    Ok((positions(ia, "a")?, positions(ib, "b")?))
}

/// Positions of `ids` (one side of a two-set call); a duplicate id is an error.
fn positions(ids: &[i64], side: &str) -> Result<Positions, Box<dyn Error>> {
    let mut at = std::collections::HashMap::with_capacity(ids.len());
    for (k, &id) in ids.iter().enumerate() {
        if at.insert(id, k).is_some() {
            return Err(format!("ids_{side} must be distinct (one track per id), got {id} twice").into());
        }
    }
    Ok(at)
}

/// The SQL type of a declared parameter kind.
const fn ty_of(k: Kind) -> Ty {
    match k {
        Kind::Double => Ty::Double,
        Kind::Integer => Ty::Bigint,
        Kind::Boolean => Ty::Boolean,
        Kind::Text => Ty::Varchar,
    }
}

/// How many pipeline parameters are declared.
pub(super) const N_PARAMS: usize = PARAMS.len();

/// The `k`-th declared pipeline parameter as a named parameter (its name, SQL type and
/// description; its default and range are in `FROM trajdb_params()`).
pub(super) const fn pipeline_param(k: usize) -> Param {
    pd(PARAMS[k].name, ty_of(PARAMS[k].kind), PARAMS[k].description)
}

/// `Ok` when the calling connection may write into folder `out`: its readable settings, then
/// its own file system, which has the last word (src/bindings/vector/fs.rs).
pub(crate) fn may_write_into(args: &BindArgs<'_>, out: &str) -> Result<(), Box<dyn Error>> {
    args.file_access().may_write_into(out)?;
    args.caller_fs()?.may_write_into(&outdir::absolute(out)?)?;
    Ok(())
}
