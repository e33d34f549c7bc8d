//! SQL: surrogate safety measures between two road users (PET, TTC; docs/analysis.md).
//! Maths: `crates/algo/src/conflict/` (pet.rs, ttc.rs).

use super::registry::{p, Function, Signature, Ty, TRAJ};
use super::vector::{Args, Out, Value};
use crate::algo::conflict;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;

const PET: Ty = Ty::Struct(&[
    ("pet", Ty::Double),
    ("x", Ty::Double),
    ("y", Ty::Double),
    ("t_first", Ty::Double),
    ("t_second", Ty::Double),
    ("angle", Ty::Double),
    ("a_first", Ty::Boolean),
]);
const TTC: Ty = Ty::Struct(&[("ttc", Ty::Double), ("t", Ty::Double), ("x", Ty::Double), ("y", Ty::Double)]);

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "traj_pet",
        description: "Post-encroachment time where the paths of two road users cross (Allen et al. 1978; SSAM, FHWA-HRT-08-051; \
                      TrafficIntelligence): the time between the first road user leaving the crossing point and the second arriving, \
                      road users as points moving linearly between their samples. Of every crossing (segment intersections), the one with \
                      the smallest PET: pet (s), the crossing point x, y, t_first / t_second (when the first and the second were there), \
                      angle (degrees between their directions there: SSAM calls < 30 rear-end, 30-85 lane change, > 85 crossing) and \
                      a_first (a was there first). NULL when the paths do not cross (collinear overlaps are not crossings), when either has \
                      fewer than 2 points, or when every crossing's PET exceeds max_pet (default: no limit; segment pairs further apart \
                      in time are skipped unread). O((n + m) log(n + m) + K), K = segment pairs overlapping along the sweep axis; pass \
                      candidate pairs from a time-overlap join (sql/analysis.sql conflicts), not all pairs. Errors: max_pet <= 0, NaN / \
                      infinite values, unsorted t.",
        example: "SELECT traj_pet([{'t': 0, 'x': -10, 'y': 0}, {'t': 2, 'x': 10, 'y': 0}], [{'t': 0, 'x': 0, 'y': -10}, {'t': 4, 'x': 0, 'y': 10}]).pet; -- 1.0",
        maths: "crates/algo/src/conflict/pet.rs",
        binding: file!(),
        signatures: &[Signature { params: &[p("a", TRAJ), p("b", TRAJ), p("max_pet", Ty::Double)], arities: &[2, 3], returns: PET, kernel: pet }],
        table: None,
    },
    Function {
        name: "traj_ttc",
        description: "Time-to-collision at constant velocity (Hayward 1972; SSAM; TrafficIntelligence's constant-velocity prediction): at \
                      each time s of the two road users' common period, both are extrapolated along their current velocities (of the \
                      segment between samples); TTC(s) is the first time their centres come within radius metres (the sum of their \
                      radii, e.g. 2 m for two cars side on). Returns the minimum over the common period, exact for paths linear between \
                      samples: ttc (s; 0 = in contact), t (when), x, y (the predicted collision point: midpoint of both centres then). \
                      NULL when they are never on a collision course, share less than an interval of time, or either has fewer than 2 \
                      points. O(n + m). Errors: radius < 0 or not finite, NaN / infinite values, unsorted t.",
        example: "SELECT traj_ttc([{'t': 0, 'x': -50, 'y': 0}, {'t': 1, 'x': -40, 'y': 0}], [{'t': 0, 'x': 50, 'y': 0}, {'t': 1, 'x': 40, 'y': 0}], 2.0); -- {'ttc': 3.9000000000000004, 't': 1.0, 'x': 0.0, 'y': 0.0}",
        maths: "crates/algo/src/conflict/ttc.rs",
        binding: file!(),
        signatures: &[Signature { params: &[p("a", TRAJ), p("b", TRAJ), p("radius", Ty::Double)], arities: &[], returns: TTC, kernel: ttc }],
        table: None,
    },
];

fn pet(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ta, tb, max_pet) = (a.traj(0), a.traj(1), a.opt_double(2));
    let vals = a.map(|r| {
        let (Some(x), Some(y), Some(m)) = (ta.get(r)?, tb.get(r)?, max_pet.or(r, f64::INFINITY)) else { return Ok(None) };
        let p = conflict::pet(x, y, m).map_err(|e| e.describe())?;
        Ok(Some(p.map(|p| {
            vec![
                Value::F64(p.pet),
                Value::F64(p.x),
                Value::F64(p.y),
                Value::F64(p.t_first()),
                Value::F64(p.t_second()),
                Value::F64(p.angle),
                Value::Bool(p.t_a <= p.t_b),
            ]
        })))
    })?;
    out.structs(&vals.into_iter().map(Option::flatten).collect::<Vec<_>>());
    Ok(())
}

fn ttc(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ta, tb, radius) = (a.traj(0), a.traj(1), a.double(2));
    let vals = a.map(|r| {
        let (Some(x), Some(y), Some(rad)) = (ta.get(r)?, tb.get(r)?, radius.get(r)) else { return Ok(None) };
        let c = conflict::ttc(x, y, rad).map_err(|e| e.describe())?;
        Ok(Some(c.map(|c| vec![Value::F64(c.ttc), Value::F64(c.t), Value::F64(c.x), Value::F64(c.y)])))
    })?;
    out.structs(&vals.into_iter().map(Option::flatten).collect::<Vec<_>>());
    Ok(())
}
