//! SQL: events between the tracks of one camera (Zhao et al. III.A) and object / fragment /
//! group labels (section IV). Maths: `crates/algo/src/events.rs`.

use super::common::try_map;
use super::registry::{pd, Function, Param, Section, Signature, Ty, GEOMETRY};
use super::vector::{Args, Column, Out, Rows, Value};
use crate::algo::break_link::{self, BreakModel};
use crate::algo::events::{self, Endpoints, EventParams, LabelParams};
use crate::algo::geometry::region::Region;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const MATHS: &str = "crates/algo/src/events.rs";

/// The endpoint fields both functions read first.
macro_rules! endpoint_fields {
    ($($extra:expr),*) => {
        Ty::List(&Ty::Struct(&[
            ("id", Ty::Bigint),
            ("t0", Ty::Double),
            ("x0", Ty::Double),
            ("y0", Ty::Double),
            ("t1", Ty::Double),
            ("x1", Ty::Double),
            ("y1", Ty::Double),
            ("vx1", Ty::Double),
            ("vy1", Ty::Double),
            $($extra),*
        ]))
    };
}
const ENDPOINTS: Ty = endpoint_fields!();
const LABEL_TRACKS: Ty = endpoint_fields!(("vx0", Ty::Double), ("vy0", Ty::Double));
const GAP_DIST: [Param; 3] = [
    pd("max_gap", Ty::Double, "a start counts for an end up to this long after it (s), >= 0"),
    pd("max_dist", Ty::Double, "a start counts only when it lies within this distance of the end moved on at its final velocity for the gap (m), >= 0"),
    pd("interior", GEOMETRY, "only endpoints inside this polygon count, e.g. polygon_buffer(view_polygon(...), -3); default: all"),
];

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "traj_events",
        description: "Events between the tracks of one camera, from their endpoints (first point, last point, velocity at the end): for a track a \
                      that ends and a track b that starts within max_gap seconds after it, b is near a when b's first point lies within max_dist metres \
                      of a's end moved on at a's final velocity for the gap. 'broken' a -> b: b is the only start near a's end and a the only end near \
                      b's start; 'split': several starts near one end; 'merge': several ends near one start. With interior (the view polygon shrunk by \
                      an inset, e.g. polygon_buffer(view_polygon(...), -3)), only endpoints inside it count: objects enter and leave at the margins. \
                      With accel (m/s², default 0) the radius grows to max_dist + accel * gap^2 / 2: a road user that braked or sped up during \
                      the gap. sql/stages/quality.sql builds the endpoints and links broken tracks.",
        example: "SELECT traj_events([{'id': 1, 't0': 0, 'x0': 0, 'y0': 0, 't1': 10, 'x1': 10, 'y1': 0, 'vx1': 1, 'vy1': 0}, {'id': 2, 't0': 11.5, 'x0': 11.6, 'y0': 0, 't1': 20, 'x1': 20, 'y1': 0, 'vx1': 1, 'vy1': 0}], 2, 1); -- [{'kind': broken, 'from_id': 1, 'to_id': 2, 'gap': 1.5, 'distance': 0.09999999999999964}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Quality,
        see_also: &["traj_labels", "break_evidence", "polygon_buffer"],
        signatures: &[Signature {
            params: &[
                pd("tracks", ENDPOINTS, "one per track of one camera: its id, first point (t0 (s), x0, y0 (m)), last point (t1, x1, y1) and velocity at the end (vx1, vy1; m/s)"),
                GAP_DIST[0],
                GAP_DIST[1],
                GAP_DIST[2],
                pd("accel", Ty::Double, "an acceleration allowance (m/s²), >= 0: the distance grows to max_dist + accel gap² / 2; default 0"),
            ],
            arities: &[3, 4, 5],
            returns: Ty::List(&Ty::Struct(&[
                ("kind", Ty::Varchar),
                ("from_id", Ty::Bigint),
                ("to_id", Ty::Bigint),
                ("gap", Ty::Double),
                ("distance", Ty::Double),
            ])),
            kernel: traj_events,
        }],
        table: None,
    },
    Function {
        name: "traj_labels",
        description: "Labels each track object, fragment or group (Zhao et al. IV) on the interaction graph of traj_events (same first arguments, plus the \
                      starting velocity vx0, vy0): the tracks a split produces (or the tracks that merge) are compared pairwise by motion coherency, eq. 3-5 \
                      (speed and heading differences, zero-mean Gaussians with sigma for one object and tau for different objects; defaults 0.5 m/s, \
                      0.25 rad, 3 m/s, 1.5 rad, threshold 0.7): coherent ones are fragments of one object, otherwise they are objects and their parent a \
                      group; tracks in no split or merge are objects. Shape coherency (eq. 1-2) needs object extents, which tracks do not carry: skipped. \
                      coherence is the minimum pairwise posterior of the set the track belongs to (1 if none).",
        example: "SELECT traj_labels([{'id': 1, 't0': 0, 'x0': 0, 'y0': 0, 't1': 10, 'x1': 10, 'y1': 0, 'vx1': 1, 'vy1': 0, 'vx0': 1, 'vy0': 0}, {'id': 2, 't0': 10.5, 'x0': 10.5, 'y0': 0.5, 't1': 20, 'x1': 20, 'y1': 9, 'vx1': 1, 'vy1': 1, 'vx0': 1, 'vy0': 1}, {'id': 3, 't0': 10.5, 'x0': 10.5, 'y0': -0.5, 't1': 20, 'x1': 20, 'y1': -9, 'vx1': 1, 'vy1': -1, 'vx0': 1, 'vy0': -1}], 2, 1); -- [{'id': 1, 'label': group, 'coherence': 1.0}, {'id': 2, 'label': object, 'coherence': 1.6664855972319293e-07}, {'id': 3, 'label': object, 'coherence': 1.6664855972319293e-07}]",
        maths: MATHS,
        binding: file!(),
        section: Section::Quality,
        see_also: &["traj_events"],
        signatures: &[Signature {
            params: &[
                pd("tracks", LABEL_TRACKS, "as traj_events' tracks, plus the velocity at the start (vx0, vy0; m/s)"),
                GAP_DIST[0],
                GAP_DIST[1],
                GAP_DIST[2],
                pd("sigma_speed", Ty::Double, "the spread of the speed difference within one object (m/s), > 0; default 0.5 (the four coherency parameters and threshold: all or none)"),
                pd("sigma_heading", Ty::Double, "the spread of the heading difference within one object (rad), > 0; default 0.25"),
                pd("tau_speed", Ty::Double, "the spread of the speed difference between different objects (m/s), > 0; default 3"),
                pd("tau_heading", Ty::Double, "the spread of the heading difference between different objects (rad), > 0; default 1.5"),
                pd("threshold", Ty::Double, "tracks are fragments of one object when their least pairwise posterior is at least this, in [0, 1]; default 0.7"),
            ],
            arities: &[3, 4, 9],
            returns: Ty::List(&Ty::Struct(&[("id", Ty::Bigint), ("label", Ty::Varchar), ("coherence", Ty::Double)])),
            kernel: traj_labels,
        }],
        table: None,
    },
    Function {
        name: "break_evidence",
        description: "The evidence that a track's start continues an earlier track's end in one camera (sql/stages/quality.sql; \
                      docs/association.md): d = (dx, dy), the difference of the two ends' positions extrapolated to the middle of the gap \
                      (m), and dv = (dvx, dvy) of their velocities (m/s), under a mixture of two models: the road user kept its velocity \
                      (share pi; variances var_cv per axis of d and varv_cv of dv) or accelerated as its class may (var_cv + var_acc, \
                      varv_cv + varv_acc). Returns z2_cv and z2 (the chi2(4) statistics of each model; quality.sql's candidate gate is \
                      z2 <= 13.28, given as candidate; candidate_cv: z2_cv within it), ll (the mixture's log-density: ranks the candidates of an end and of a start) and ll_bg (the \
                      mixture's log position density over start_density, the density of unrelated starts per m² in the gap's time \
                      window). NULL for NULL; a variance <= 0 (var_acc, varv_acc: < 0), pi outside [0, 1) (0: the acceleration model alone), a non-finite difference or a start_density <= 0 is an \
                      error naming it. O(1).",
        example: "SELECT round(break_evidence(0.1, 0.0, 0.0, 0.0, 0.01, 1.0, 0.05, 0.5, 0.5, 0.001).ll_bg, 3); -- 8.498",
        maths: "crates/algo/src/break_link.rs",
        binding: file!(),
        section: Section::Quality,
        see_also: &["break_link_kind", "break_standing", "noise_reappear_radius_95"],
        signatures: &[Signature {
            params: &[
                pd("dx", Ty::Double, "the x difference of the two ends' positions extrapolated to the middle of the gap (m), finite"),
                pd("dy", Ty::Double, "the y difference of those positions (m), finite"),
                pd("dvx", Ty::Double, "the x difference of the two ends' velocities (m/s), finite"),
                pd("dvy", Ty::Double, "the y difference of their velocities (m/s), finite"),
                pd("var_cv", Ty::Double, "the position difference's variance per axis if the road user kept its velocity (m²), > 0"),
                pd("var_acc", Ty::Double, "what acceleration adds to it (m²), >= 0"),
                pd("varv_cv", Ty::Double, "the velocity difference's variance per axis if it kept its velocity (m²/s²), > 0"),
                pd("varv_acc", Ty::Double, "what acceleration adds to it (m²/s²), >= 0"),
                pd("pi", Ty::Double, "the share of the constant-velocity model in the mixture, in [0, 1) (0: the acceleration model alone)"),
                pd("start_density", Ty::Double, "the density of unrelated starts in the gap's time window (per m²), > 0"),
            ],
            arities: &[],
            returns: Ty::Struct(&[("z2_cv", Ty::Double), ("z2", Ty::Double), ("ll", Ty::Double), ("ll_bg", Ty::Double), ("candidate", Ty::Boolean), ("candidate_cv", Ty::Boolean)]),
            kernel: break_evidence,
        }],
        table: None,
    },
    Function {
        name: "break_link_kind",
        description: "The link decision for a candidate that is the mutual best of its track end and its start (sql/stages/quality.sql; \
                      crates/algo/src/break_link.rs link_kind): the ratio test (ll beats ll_next_end and ll_next_start, the best \
                      other candidates of the end and of the start, by ln 100; pass -infinity for none), then no link when \
                      ll_bg < 0 (less likely than an unrelated start); 'broken' when z2_cv is within the chi2(4) 0.99 gate (13.28) \
                      and ll_bg >= ln 100, else 'reach'. NULL: no link (or a NULL or NaN argument); a negative z2_cv is an error. O(1).",
        example: "SELECT break_link_kind(1.0, 0.0, 5.0, '-inf'::DOUBLE, '-inf'::DOUBLE); -- broken",
        maths: "crates/algo/src/break_link.rs",
        binding: file!(),
        section: Section::Quality,
        see_also: &["break_evidence"],
        signatures: &[Signature {
            params: &[
                pd("z2_cv", Ty::Double, "the candidate's constant-velocity statistic (break_evidence's z2_cv), >= 0"),
                pd("ll", Ty::Double, "the candidate's log-density (break_evidence's ll)"),
                pd("ll_bg", Ty::Double, "its log-density over unrelated starts (break_evidence's ll_bg)"),
                pd("ll_next_end", Ty::Double, "the best other candidate's ll for the same track end; -infinity for none"),
                pd("ll_next_start", Ty::Double, "the best other candidate's ll for the same start; -infinity for none"),
            ],
            arities: &[],
            returns: Ty::Varchar,
            kernel: break_link_kind,
        }],
        table: None,
    },
    Function {
        name: "break_standing",
        description: "Whether a track end stands (sql/stages/quality.sql; crates/algo/src/break_link.rs standing): its velocity \
                      (vx, vy, m/s) within its fit's noise of 0, |v|² <= 9.21 var_v (chi2(2) at 0.99; var_v: the per-axis \
                      variance of the fitted velocity, m²/s²). False for var_v <= 0 or a non-finite argument; NULL for NULL. O(1).",
        example: "SELECT break_standing(0.05, 0.0, 0.01); -- true",
        maths: "crates/algo/src/break_link.rs",
        binding: file!(),
        section: Section::Quality,
        see_also: &["break_evidence", "noise_velocity_window_s"],
        signatures: &[Signature {
            params: &[
                pd("vx", Ty::Double, "the track end's fitted velocity, x (m/s)"),
                pd("vy", Ty::Double, "its y (m/s)"),
                pd("var_v", Ty::Double, "the fitted velocity's variance per axis (m²/s²); <= 0 gives false"),
            ],
            arities: &[],
            returns: Ty::Boolean,
            kernel: break_standing,
        }],
        table: None,
    },
];

/// The endpoints of one row's tracks (the first nine fields of both track types).
fn endpoints(f: &Rows<'_>) -> Vec<Endpoints> {
    (0..f.len())
        .map(|k| {
            let d = |i: usize| f.f64(i)[k];
            Endpoints { id: f.i64(0)[k], t0: d(1), x0: d(2), y0: d(3), t1: d(4), x1: d(5), y1: d(6), vx1: d(7), vy1: d(8) }
        })
        .collect()
}

/// The checked thresholds and the optional interior polygon of one row.
type EventArgs = (EventParams, Option<std::sync::Arc<Region>>);

/// `max_gap`, `max_dist` (checked by [`EventParams::new`]) and the optional interior of `row`;
/// `None` when one is NULL.
fn event_args<'a>(a: &Args<'a>) -> impl Fn(usize) -> Result<Option<EventArgs>, Box<dyn Error>> + 'a {
    let (gap, dist) = (a.double(1), a.double(2));
    let interior = a.opt_region(3);
    move |r| {
        let (Some(g), Some(d)) = (gap.get(r), dist.get(r)) else { return Ok(None) };
        let p = EventParams::new(g, d)?;
        let Some(region) = interior.get(r)? else { return Ok(None) };
        Ok(Some((p, region)))
    }
}

fn traj_events(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tracks, args, accel) = (a.struct_list(0), event_args(a), a.opt_double(4));
    let vals = a.map(|r| {
        let Some(f) = tracks.get(r)? else { return Ok(None) };
        let Some((p, region)) = args(r)? else { return Ok(None) };
        let Some(acc) = accel.or(r, 0.0) else { return Ok(None) };
        let p = p.with_accel(acc)?;
        Ok(Some(events::events(&endpoints(&f), region.as_deref(), &p)?))
    })?;
    // the result's columns are as long as the events: allocated fallibly (super::common::try_map)
    let split: Vec<Option<_>> = vals
        .iter()
        .map(|v| {
            v.as_ref()
                .map(|ev: &Vec<events::Event>| -> Result<_, String> {
                    let kind: Vec<&str> = try_map(ev, |e| e.kind.as_str())?;
                    let from: Vec<i64> = try_map(ev, |e| e.from)?;
                    let to: Vec<i64> = try_map(ev, |e| e.to)?;
                    let gap: Vec<f64> = try_map(ev, |e| e.gap)?;
                    let dist: Vec<f64> = try_map(ev, |e| e.dist)?;
                    Ok((kind, from, to, gap, dist))
                })
                .transpose()
        })
        .collect::<Result<_, String>>()?;
    let cols: Vec<_> = split
        .iter()
        .map(|v| v.as_ref().map(|(k, f, t, g, d)| vec![Column::Text(k), Column::I64(f), Column::I64(t), Column::F64(g), Column::F64(d)]))
        .collect();
    out.struct_lists(&cols)?;
    Ok(())
}

fn traj_labels(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tracks, args) = (a.struct_list(0), event_args(a));
    let coherency: Vec<_> = (4..9).map(|c| a.opt_double(c)).collect();
    let vals = a.map(|r| {
        let Some(f) = tracks.get(r)? else { return Ok(None) };
        let Some((p, region)) = args(r)? else { return Ok(None) };
        let lp = if a.given(4) {
            let v: Option<Vec<f64>> = coherency.iter().map(|c| c.or(r, f64::NAN)).collect();
            let Some(v) = v else { return Ok(None) };
            LabelParams::new(v[0], v[1], v[2], v[3], v[4])?
        } else {
            LabelParams::default()
        };
        let ends = endpoints(&f);
        let tracks: Vec<(Endpoints, f64, f64)> = ends.into_iter().enumerate().map(|(k, e)| (e, f.f64(9)[k], f.f64(10)[k])).collect();
        Ok(Some(events::label_tracks(&tracks, region.as_deref(), &p, &lp)?))
    })?;
    let split: Vec<Option<_>> = vals
        .iter()
        .map(|v| {
            v.as_ref()
                .map(|l: &Vec<(i64, events::Label, f64)>| -> Result<_, String> {
                    Ok((try_map(l, |x| x.0)?, try_map(l, |x| x.1.as_str())?, try_map(l, |x| x.2)?))
                })
                .transpose()
        })
        .collect::<Result<_, String>>()?;
    let cols: Vec<_> = split.iter().map(|v| v.as_ref().map(|(i, l, c)| vec![Column::I64(i), Column::Text(l), Column::F64(c)])).collect();
    out.struct_lists(&cols)?;
    Ok(())
}

fn break_evidence(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let row = a.doubles::<10>();
    let vals = a.map(|r| {
        let Some(v) = row(r) else { return Ok(None) };
        let m = BreakModel::new(v[4], v[5], v[6], v[7], v[8])?;
        let e = break_link::evidence(v[0] * v[0] + v[1] * v[1], v[2] * v[2] + v[3] * v[3], &m, v[9])?;
        let mut v = [e.z2_cv, e.z2, e.ll, e.ll_bg].map(Value::F64).to_vec();
        v.extend([Value::Bool(break_link::candidate(e.z2)), Value::Bool(break_link::candidate(e.z2_cv))]);
        Ok(Some(v))
    })?;
    out.structs(&vals);
    Ok(())
}

fn break_link_kind(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let row = a.doubles::<5>();
    let vals = a.map(|r| {
        let Some(v) = row(r) else { return Ok(None) };
        Ok(break_link::link_kind(v[0], v[1], v[2], v[3], v[4])?.map(|k| k.as_str()))
    })?;
    out.text(&vals);
    Ok(())
}

fn break_standing(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let row = a.doubles::<3>();
    let vals = a.map(|r| {
        let Some([x, y, v]) = row(r) else { return Ok(None) };
        Ok(Some(break_link::standing(x * x + y * y, v)))
    })?;
    out.flat(&vals);
    Ok(())
}
