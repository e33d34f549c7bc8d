//! SQL: fused paths (one road user's observations from every camera, smoothed into one path).
//! Maths: `crates/algo/src/fuse/` (constant-velocity Kalman filter + RTS smoother, seed 003 §3.8).

use super::registry::{pd, Function, Param, Section, Signature, Ty, SERIES, TRAJ};
use super::vector::{Args, Column, Out};
use crate::algo::fuse::{self, FusedPath, Obs};
use crate::algo::traj::OwnedTraj;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const MATHS: &str = "crates/algo/src/fuse/smooth.rs, crates/algo/src/fuse/sample.rs";

/// `STRUCT(t DOUBLE, x DOUBLE, y DOUBLE, sigma DOUBLE)[]`: observations with their noise.
const OBS: Ty = Ty::List(&Ty::Struct(&[("t", Ty::Double), ("x", Ty::Double), ("y", Ty::Double), ("sigma", Ty::Double)]));
const PARAMS: [Param; 4] = [
    pd("obs", OBS, "every observation of the road user, sorted by t: t (s), x, y (m) in one frame and on one clock, sigma > 0 its camera's position noise per axis (m)"),
    pd("q", Ty::Double, "the white-acceleration noise density per axis (m²/s³), >= 0; 0: a straight line at one velocity"),
    pd("period", Ty::Double, "the path at t = k * period (s), > 0; default: one point per distinct observation time"),
    pd("max_gap", Ty::Double, "with period: no point across a gap between observations longer than this (s), > 0; default: no limit"),
];

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "traj_fuse",
        description: "One road user's observations from any number of cameras, fused into one path: a constant-velocity Kalman filter and \
                      Rauch-Tung-Striebel smoother (seed 003 eq. 3.10-3.15). obs: every observation (t, x, y in one frame and on one clock, \
                      sigma = its camera's position noise in metres per axis, e.g. calib_cameras.sigma_m), ordered by t; observations less than \
                      1 microsecond apart are one time. q: the white-acceleration noise density in m^2/s^3 per axis (the velocity wanders by \
                      sqrt(q dt) in dt seconds; 0 = a straight line at one velocity; the pipeline uses 0.25 x the class's 95th-percentile \
                      acceleration squared, see docs/fusion.md). Without period: one point per distinct time; with period: the smoothed path at \
                      t = k * period (the clock of traj_resample), not across gaps longer than max_gap seconds (default: no limit) between \
                      observations. The result is an ordinary TRAJ (traj_speeds etc. take it); traj_fuse_sigma gives each point's uncertainty. \
                      O(n) per call. Errors: sigma <= 0, q < 0, NaN / infinite values, unsorted t, period / max_gap <= 0.",
        example: "SELECT traj_fuse([{'t': 0, 'x': 0, 'y': 0, 'sigma': 0.1}, {'t': 1, 'x': 1, 'y': 0, 'sigma': 0.1}, {'t': 1, 'x': 1, 'y': 0, 'sigma': 0.2}, {'t': 2, 'x': 2, 'y': 0, 'sigma': 0.1}], 0.5); -- [{'t': 0.0, 'x': 0.0, 'y': 0.0}, {'t': 1.0, 'x': 1.0, 'y': 0.0}, {'t': 2.0, 'x': 2.0, 'y': 0.0}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Fusion,
        see_also: &["traj_fuse_sigma", "traj_fuse_with_sigma", "traj_resample", "noise_process_q"],
        signatures: &[Signature { params: &PARAMS, arities: &[2, 3, 4], returns: TRAJ, kernel: fuse_traj }],
        table: None,
    },
    Function {
        name: "traj_fuse_sigma",
        description: "The uncertainty of traj_fuse's path (same arguments, same points): per point t and v = the 1-sigma position error per axis \
                      of the fused position in metres, sqrt of the mean of the smoothed position covariance's diagonal. Smaller than any one \
                      camera's sigma where several cameras or many samples agree; it grows where the path is bridged between observations.",
        example: "SELECT traj_fuse_sigma([{'t': 0, 'x': 0, 'y': 0, 'sigma': 0.1}, {'t': 0, 'x': 0.1, 'y': 0, 'sigma': 0.1}], 0.5); -- [{'t': 0.0, 'v': 0.07071067811865477}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Fusion,
        see_also: &["traj_fuse", "traj_fuse_with_sigma"],
        signatures: &[Signature { params: &PARAMS, arities: &[2, 3, 4], returns: SERIES, kernel: fuse_sigma }],
        table: None,
    },
    Function {
        name: "traj_fuse_with_sigma",
        description: "traj_fuse and traj_fuse_sigma in one call (same arguments, one smoother run): per point t, x, y and sigma = the \
                      1-sigma position error per axis in metres. The pipeline's fuse stage uses it; the path is [{'t': p.t, 'x': p.x, 'y': p.y} \
                      FOR p IN ...] and the uncertainties [p.sigma FOR p IN ...].",
        example: "SELECT traj_fuse_with_sigma([{'t': 0, 'x': 0, 'y': 0, 'sigma': 0.1}, {'t': 0, 'x': 0.1, 'y': 0, 'sigma': 0.1}], 0.5); -- [{'t': 0.0, 'x': 0.05000000000000001, 'y': 0.0, 'sigma': 0.07071067811865477}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Fusion,
        see_also: &["traj_fuse", "traj_fuse_sigma"],
        signatures: &[Signature {
            params: &PARAMS,
            arities: &[2, 3, 4],
            returns: Ty::List(&Ty::Struct(&[("t", Ty::Double), ("x", Ty::Double), ("y", Ty::Double), ("sigma", Ty::Double)])),
            kernel: fuse_with_sigma,
        }],
        table: None,
    },
    Function {
        name: "traj_source_offsets",
        description: "Each source track's constant offset within one road user (issue 38; docs/fusion.md): sources are one road user's \
                      tracks from every camera in one frame and clock (list(traj)); for every two that share time, d = the mean of a - b \
                      over it (each interpolated at the other's times, not across gaps longer than max_gap s, both ways); the offsets \
                      minimise the sum of n_common |o_a - o_b - d|² with the offsets of each group of sources linked by common time \
                      summing to 0 (the reference point: the mean of the sources' points). source - (dx, dy) are then views of one point \
                      of the road user. A source that shares no time with another keeps 0 (n_common 0), as do groups of more than 64 \
                      sources. One element per source, in their order. O(n) per pair of sources that overlap in time.",
        example: "SELECT [round(o.dx, 6) FOR o IN traj_source_offsets([[{'t':0,'x':1,'y':0},{'t':1,'x':2,'y':0},{'t':2,'x':3,'y':0}], [{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0},{'t':2,'x':2,'y':0}]], 0.5)]; -- [0.5, -0.5]",
        maths: "crates/algo/src/fuse/offsets.rs",
        binding: file!(),
        section: Section::Fusion,
        see_also: &["traj_fuse", "traj_msd_pairs"],
        signatures: &[Signature {
            params: &[
                pd("sources", Ty::List(&TRAJ), "one road user's tracks from every camera, in one frame and on one clock (list(traj))"),
                pd("max_gap", Ty::Double, "no interpolation across a gap of a track longer than this (s), > 0"),
            ],
            arities: &[],
            returns: Ty::List(&Ty::Struct(&[("dx", Ty::Double), ("dy", Ty::Double), ("n_common", Ty::Bigint)])),
            kernel: source_offsets,
        }],
        table: None,
    },
];

/// The fused path of every row (`None`: a NULL argument).
fn fused(a: &Args<'_>) -> Result<Vec<Option<FusedPath>>, Box<dyn Error>> {
    let (obs, q) = (a.struct_list(0), a.double(1));
    let period = a.given(2).then(|| a.double(2));
    let gap = a.opt_double(3);
    let name = a.name(0);
    a.par_map(|r| {
        let (Some(o), Some(q)) = (obs.get(r)?, q.get(r)) else { return Ok(None) };
        let clock = match &period {
            None => None,
            Some(c) => {
                let (Some(p), Some(g)) = (c.get(r), gap.or(r, f64::INFINITY)) else { return Ok(None) };
                Some((p, g))
            }
        };
        let ob = Obs::new(o.f64(0), o.f64(1), o.f64(2), o.f64(3));
        Ok(Some(fuse::fuse(ob, q, clock).map_err(|e| e.describe(name))?))
    })
}

fn fuse_traj(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let vals: Vec<Option<OwnedTraj>> = fused(a)?.into_iter().map(|f| f.map(|f| OwnedTraj { t: f.t, x: f.x, y: f.y })).collect();
    out.trajs(&vals)?;
    Ok(())
}

fn fuse_sigma(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let vals = fused(a)?;
    let cols: Vec<_> = vals.iter().map(|v| v.as_ref().map(|f| vec![Column::F64(&f.t), Column::F64(&f.sigma)])).collect();
    out.struct_lists(&cols)?;
    Ok(())
}

fn fuse_with_sigma(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let vals = fused(a)?;
    let cols: Vec<_> =
        vals.iter().map(|v| v.as_ref().map(|f| vec![Column::F64(&f.t), Column::F64(&f.x), Column::F64(&f.y), Column::F64(&f.sigma)])).collect();
    out.struct_lists(&cols)?;
    Ok(())
}

fn source_offsets(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (src, gap) = (a.traj_list(0), a.double(1));
    let vals = a.par_map(|r| {
        let (Some(src), Some(gap)) = (src.get(r)?, gap.get(r)) else { return Ok(None) };
        let o = fuse::offsets::source_offsets(&src, gap)?;
        let dx: Vec<f64> = o.iter().map(|v| v.dx).collect();
        let dy: Vec<f64> = o.iter().map(|v| v.dy).collect();
        let n: Vec<i64> = o.iter().map(|v| v.n_common as i64).collect();
        Ok(Some((dx, dy, n)))
    })?;
    let cols: Vec<_> = vals.iter().map(|v| v.as_ref().map(|(x, y, n)| vec![Column::F64(x), Column::F64(y), Column::I64(n)])).collect();
    out.struct_lists(&cols)?;
    Ok(())
}
