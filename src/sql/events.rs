//! SQL: `traj_events` (broken / split / merge events of tracks within one camera, Zhao et al.
//! section III.A) and `traj_labels` (object / fragment / group, section IV), list in, list out.

use super::convert::*;
use crate::algo::events::{self, EventParams};
use duckdb::core::{DataChunkHandle, Inserter, LogicalTypeHandle};
use duckdb::vtab::arrow::WritableVector;
use duckdb::Connection;
use std::error::Error;

pub const DOCS: &[FnDoc] = &[
FnDoc {
    name: "traj_events",
    signatures: "traj_events(tracks STRUCT(id BIGINT, t0, x0, y0, t1, x1, y1, vx1, vy1 DOUBLE)[], max_gap DOUBLE, max_dist DOUBLE [, interior VARCHAR|BLOB]) -> STRUCT(kind VARCHAR, from_id BIGINT, to_id BIGINT, gap DOUBLE, distance DOUBLE)[]",
    description: "Events between the tracks of one camera, from their endpoints (first point, last point, velocity at the end): for a track a \
                  that ends and a track b that starts within max_gap seconds after it, b is near a when b's first point lies within max_dist metres \
                  of a's end moved on at a's final velocity for the gap. 'broken' a -> b: b is the only start near a's end and a the only end near \
                  b's start; 'split': several starts near one end; 'merge': several ends near one start. With interior (the view polygon shrunk by \
                  an inset, e.g. polygon_buffer(view_polygon(...), -3)), only endpoints inside it count: objects enter and leave at the margins. \
                  sql/quality.sql builds the endpoints and links broken tracks.",
    example: "SELECT traj_events([{'id': 1, 't0': 0, 'x0': 0, 'y0': 0, 't1': 10, 'x1': 10, 'y1': 0, 'vx1': 1, 'vy1': 0}, {'id': 2, 't0': 11.5, 'x0': 11.6, 'y0': 0, 't1': 20, 'x1': 20, 'y1': 0, 'vx1': 1, 'vy1': 0}], 2, 1); -- [{'kind': broken, 'from_id': 1, 'to_id': 2, 'gap': 1.5, 'distance': 0.09999999999999964}]",
},
FnDoc {
    name: "traj_labels",
    signatures: "traj_labels(tracks STRUCT(id BIGINT, t0, x0, y0, t1, x1, y1, vx1, vy1, vx0, vy0 DOUBLE)[], max_gap DOUBLE, max_dist DOUBLE [, interior VARCHAR|BLOB [, sigma_speed, sigma_heading, tau_speed, tau_heading, threshold DOUBLE]]) -> STRUCT(id BIGINT, label VARCHAR, coherence DOUBLE)[]",
    description: "Labels each track object, fragment or group (Zhao et al. IV) on the interaction graph of traj_events (same first arguments, plus the \
                  starting velocity vx0, vy0): the tracks a split produces (or the tracks that merge) are compared pairwise by motion coherency, eq. 3-5 \
                  (speed and heading differences, zero-mean Gaussians with sigma for one object and tau for different objects; defaults 0.5 m/s, \
                  0.25 rad, 3 m/s, 1.5 rad, threshold 0.7): coherent ones are fragments of one object, otherwise they are objects and their parent a \
                  group; tracks in no split or merge are objects. Shape coherency (eq. 1-2) needs object extents, which tracks do not carry: skipped. \
                  coherence is the minimum pairwise posterior of the set the track belongs to (1 if none).",
    example: "SELECT traj_labels([{'id': 1, 't0': 0, 'x0': 0, 'y0': 0, 't1': 10, 'x1': 10, 'y1': 0, 'vx1': 1, 'vy1': 0, 'vx0': 1, 'vy0': 0}, {'id': 2, 't0': 10.5, 'x0': 10.5, 'y0': 0.5, 't1': 20, 'x1': 20, 'y1': 9, 'vx1': 1, 'vy1': 1, 'vx0': 1, 'vy0': 1}, {'id': 3, 't0': 10.5, 'x0': 10.5, 'y0': -0.5, 't1': 20, 'x1': 20, 'y1': -9, 'vx1': 1, 'vy1': -1, 'vx0': 1, 'vy0': -1}], 2, 1); -- [{'id': 1, 'label': group, 'coherence': 1.0}, {'id': 2, 'label': object, 'coherence': 1.6664855972319293e-07}, {'id': 3, 'label': object, 'coherence': 1.6664855972319293e-07}]",
},
];

/// The endpoints of one row's tracks (the first nine fields of both track types).
fn decode_endpoints(f: &[&[f64]]) -> Vec<events::Endpoints> {
    (0..f[0].len())
        .map(|k| events::Endpoints { id: i64_bits(f[0][k]), t0: f[1][k], x0: f[2][k], y0: f[3][k], t1: f[4][k], x1: f[5][k], y1: f[6][k], vx1: f[7][k], vy1: f[8][k] })
        .collect()
}

/// The `max_gap`, `max_dist` and optional `interior` arguments (columns 1, 2, 3) of both functions.
struct EventArgs<'a> {
    gap: PrimCol<'a>,
    dist: PrimCol<'a>,
    interior: Option<RegionCol<'a>>,
}

impl<'a> EventArgs<'a> {
    fn new(input: &'a DataChunkHandle) -> Self {
        EventArgs { gap: PrimCol::new(input, 1), dist: PrimCol::new(input, 2), interior: (input.num_columns() > 3).then(|| RegionCol::new(input, 3)) }
    }
    /// Validated parameters and the interior polygon of `row`; `None` when an argument is NULL.
    #[allow(clippy::type_complexity)]
    fn get(&self, r: usize, f: &str) -> Result<Option<(EventParams, Option<std::rc::Rc<crate::algo::region::Region>>)>, Box<dyn Error>> {
        let (Some(g), Some(d)) = (self.gap.f64(r), self.dist.f64(r)) else { return Ok(None) };
        let p = EventParams::new(g, d).map_err(|e| err(f, e))?;
        let region = match &self.interior {
            None => None,
            Some(c) => match c.get(r, f, "interior")? {
                None => return Ok(None),
                v => v,
            },
        };
        Ok(Some((p, region)))
    }
}

const LABEL_FIELDS: &[&str] = &["id", "t0", "x0", "y0", "t1", "x1", "y1", "vx1", "vy1", "vx0", "vy0"];

fn labels_input_type() -> LogicalTypeHandle {
    let fields: Vec<(&str, LogicalTypeHandle)> = LABEL_FIELDS.iter().map(|&f| (f, if f == "id" { bigint() } else { double() })).collect();
    LogicalTypeHandle::list(&struct_of(&fields))
}
fn labels_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&struct_of(&[("id", bigint()), ("label", varchar()), ("coherence", double())]))
}

fn traj_labels_fn(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_labels";
    let tracks = ListOfStructCol::new_pub(input, 0, LABEL_FIELDS);
    let args = EventArgs::new(input);
    let extra: Vec<PrimCol<'_>> = (4..input.num_columns()).map(|c| PrimCol::new(input, c)).collect();
    let vals = map_rows(input.len(), |r| -> Result<Option<Vec<(i64, events::Label, f64)>>, Box<dyn Error>> {
        let Some(f) = tracks.row_fields(r, F, "tracks")? else { return Ok(None) };
        let Some((p, region)) = args.get(r, F)? else { return Ok(None) };
        let lp = if extra.is_empty() {
            events::LabelParams::default()
        } else {
            let v: Option<Vec<f64>> = extra.iter().map(|c| c.f64(r)).collect();
            let Some(v) = v else { return Ok(None) };
            events::LabelParams::new(v[0], v[1], v[2], v[3], v[4]).map_err(|e| err(F, e))?
        };
        let n = f[0].len();
        for k in 0..n {
            if !(f[9][k].is_finite() && f[10][k].is_finite()) {
                return Err(err(F, format!("tracks[{}].vx0/vy0 must be finite", k + 1)));
            }
        }
        let eps = decode_endpoints(&f);
        let ev = events::events(&eps, region.as_deref(), &p).map_err(|e| err(F, e))?;
        let motion: Vec<events::Motion> = (0..n)
            .map(|k| events::Motion {
                id: i64_bits(f[0][k]),
                v0: f[9][k].hypot(f[10][k]),
                h0: f[10][k].atan2(f[9][k]),
                v1: f[7][k].hypot(f[8][k]),
                h1: f[8][k].atan2(f[7][k]),
            })
            .collect();
        let l = events::labels(&motion, &ev, &lp);
        Ok(Some(motion.iter().zip(l).map(|(m, (lab, c))| (m.id, lab, c)).collect()))
    })?;
    let mut out = output.list_vector();
    let total: usize = vals.iter().flatten().map(|v| v.len()).sum();
    {
        let child = out.struct_child(total);
        let label = child.child(1, total);
        let (mut id, mut coh) = (child.child(0, total), child.child(2, total));
        // SAFETY: capacity `total` reserved; field types BIGINT and DOUBLE.
        let (di, dc) = unsafe { (id.as_mut_slice_with_len::<i64>(total), coh.as_mut_slice_with_len::<f64>(total)) };
        let mut off = 0;
        for (i, l, c) in vals.iter().flatten().flatten() {
            di[off] = *i;
            label.insert(off, l.as_str());
            dc[off] = *c;
            off += 1;
        }
    }
    write_list_entries(&mut out, vals.iter().map(|v| v.as_ref().map(Vec::len)));
    Ok(())
}

const FIELDS: &[&str] = &["id", "t0", "x0", "y0", "t1", "x1", "y1", "vx1", "vy1"];

fn endpoints_type() -> LogicalTypeHandle {
    let fields: Vec<(&str, LogicalTypeHandle)> = FIELDS.iter().map(|&f| (f, if f == "id" { bigint() } else { double() })).collect();
    LogicalTypeHandle::list(&struct_of(&fields))
}
fn events_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&struct_of(&[("kind", varchar()), ("from_id", bigint()), ("to_id", bigint()), ("gap", double()), ("distance", double())]))
}

fn write_events(out: &mut duckdb::core::ListVector<'_>, vals: &[Option<Vec<events::Event>>]) {
    let total: usize = vals.iter().flatten().map(|v| v.len()).sum();
    {
        let child = out.struct_child(total);
        let kind = child.child(0, total);
        let (mut from, mut to, mut gap, mut dist) = (child.child(1, total), child.child(2, total), child.child(3, total), child.child(4, total));
        // SAFETY: capacity `total` reserved; field types BIGINT, BIGINT, DOUBLE, DOUBLE.
        let (df, dt, dg, dd) = unsafe {
            (
                from.as_mut_slice_with_len::<i64>(total),
                to.as_mut_slice_with_len::<i64>(total),
                gap.as_mut_slice_with_len::<f64>(total),
                dist.as_mut_slice_with_len::<f64>(total),
            )
        };
        let mut off = 0;
        for e in vals.iter().flatten().flatten() {
            kind.insert(off, e.kind.as_str());
            df[off] = e.from;
            dt[off] = e.to;
            dg[off] = e.gap;
            dd[off] = e.dist;
            off += 1;
        }
    }
    write_list_entries(out, vals.iter().map(|v| v.as_ref().map(Vec::len)));
}

fn traj_events_fn(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_events";
    let tracks = ListOfStructCol::new_pub(input, 0, FIELDS);
    let args = EventArgs::new(input);
    let vals = map_rows(input.len(), |r| -> Result<Option<Vec<events::Event>>, Box<dyn Error>> {
        let Some(f) = tracks.row_fields(r, F, "tracks")? else { return Ok(None) };
        let Some((p, region)) = args.get(r, F)? else { return Ok(None) };
        Ok(Some(events::events(&decode_endpoints(&f), region.as_deref(), &p).map_err(|e| err(F, e))?))
    })?;
    write_events(&mut output.list_vector(), &vals);
    Ok(())
}

scalar_fn!(
    TrajEvents,
    {
        let mut v = vec![sig(vec![endpoints_type(), double(), double()], events_type())];
        for g in [varchar as fn() -> LogicalTypeHandle, blob] {
            v.push(sig(vec![endpoints_type(), double(), double(), g()], events_type()));
        }
        v
    },
    traj_events_fn
);

scalar_fn!(
    TrajLabels,
    {
        let mut v = vec![sig(vec![labels_input_type(), double(), double()], labels_type())];
        for g in [varchar as fn() -> LogicalTypeHandle, blob] {
            v.push(sig(vec![labels_input_type(), double(), double(), g()], labels_type()));
            v.push(sig(vec![labels_input_type(), double(), double(), g(), double(), double(), double(), double(), double()], labels_type()));
        }
        v
    },
    traj_labels_fn
);

pub fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_scalar_function::<TrajEvents>("traj_events")?;
    con.register_scalar_function::<TrajLabels>("traj_labels")
}
