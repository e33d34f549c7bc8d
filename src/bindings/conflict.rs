//! SQL: surrogate safety measures between two road users (PET, TTC; docs/analysis.md).
//! Maths: `crates/algo/src/conflict/` (pet.rs, ttc.rs, pairs.rs, top.rs).

use super::registry::{pd, Function, Param, Section, Signature, Ty, TRAJ};
use super::vector::{Args, Column, Out, Value};
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
/// One kept pair of traj_conflicts: the ids, traj_pet's fields, traj_ttc's fields (prefixed ttc_).
const CONFLICTS: Ty = Ty::List(&Ty::Struct(&[
    ("a", Ty::Bigint),
    ("b", Ty::Bigint),
    ("pet", Ty::Double),
    ("x", Ty::Double),
    ("y", Ty::Double),
    ("t_first", Ty::Double),
    ("t_second", Ty::Double),
    ("angle", Ty::Double),
    ("a_first", Ty::Boolean),
    ("ttc", Ty::Double),
    ("ttc_t", Ty::Double),
    ("ttc_x", Ty::Double),
    ("ttc_y", Ty::Double),
    ("together_n", Ty::Bigint),
    ("together_m", Ty::Double),
]));

const A: Param = pd("a", TRAJ, "the first road user's trajectory, sorted by t");
const B: Param = pd("b", TRAJ, "the second road user's trajectory, sorted by t, on the same clock and in the same frame");
const IDS: Param = pd("ids", Ty::List(&Ty::Bigint), "the road users' ids (list(road_user ORDER BY road_user))");
const TRAJS: Param = pd("trajs", Ty::List(&TRAJ), "their trajectories, in the order of ids");
const RADII: Param = pd(
    "radii",
    Ty::List(&Ty::Double),
    "one radius per road user (m, e.g. class_radius_m(class)): a pair's TTC is at the sum of its two; default: radius for every pair",
);
const CLASS_A: Param = pd("class_a", Ty::Varchar, "the first road user's class name (read as class_kind reads it)");
const CLASS_B: Param = pd("class_b", Ty::Varchar, "the second road user's class name");

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
        section: Section::Conflicts,
        see_also: &["traj_ttc", "traj_conflicts", "conflict_kind"],
        signatures: &[Signature {
            params: &[A, B, pd("max_pet", Ty::Double, "crossings with a larger PET are left out (s), > 0; default: no limit")],
            arities: &[2, 3],
            returns: PET,
            kernel: pet,
        }],
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
        section: Section::Conflicts,
        see_also: &["traj_pet", "traj_conflicts", "class_radius_m"],
        signatures: &[Signature {
            params: &[A, B, pd("radius", Ty::Double, "the distance between the centres that is contact (m: the sum of both radii), >= 0")],
            arities: &[],
            returns: TTC,
            kernel: ttc,
        }],
        table: None,
    },
    Function {
        name: "traj_conflicts",
        description: "traj_pet and traj_ttc for every pair of a set of road users near each other, in one call: the pairs (ids a < b) with a PET \
                      <= max_pet or a TTC <= max_ttc. Kept: one element each, sorted by (a, b): traj_pet's fields (NULL: no crossing), \
                      then traj_ttc's as ttc, ttc_t, ttc_x, ttc_y (NULL: no collision course). Trajectories with fewer than 2 points \
                      take no part. Candidates from a space-time grid of path pieces (8 segments each, widened by radius / 2 + the \
                      piece's top speed x max_ttc, spans by max_pet / 2): only road users near each other are scored, O(P log P + K) for \
                      P pieces and K pairs of pieces near each other, linear in the road users per window; PET and TTC in parallel, the \
                      paths read in place (sql/analysis.sql conflicts: list(road_user ORDER BY road_user), list(traj ORDER BY \
                      road_user)). With radii (one per road user, m: class_radius_m(class)), a pair's TTC is at the sum of its two radii \
                      instead of radius (candidates searched at twice the largest). Errors: lists of different lengths, NULL elements, NaN \
                      / infinite values, unsorted t, max_pet <= 0, radius, a radius or max_ttc < 0 or not finite, more candidate pairs \
                      than the memory_bytes limit holds.",
        example: "SELECT unnest(traj_conflicts([1, 2], [[{'t': 0, 'x': -10, 'y': 0}, {'t': 2, 'x': 10, 'y': 0}], [{'t': 0, 'x': 0, 'y': -10}, {'t': 4, 'x': 0, 'y': 10}]], 5.0, 2.0, 3.0)).pet; -- 1.0",
        maths: "crates/algo/src/conflict/pairs.rs",
        binding: file!(),
        section: Section::Conflicts,
        see_also: &["traj_pet", "traj_ttc", "traj_conflicts_top", "class_radius_m"],
        signatures: &[Signature {
            params: &[
                IDS,
                TRAJS,
                pd("max_pet", Ty::Double, "a pair is kept with a PET up to this (s), > 0"),
                pd("radius", Ty::Double, "the distance between the centres that is contact for the TTC (m), >= 0"),
                pd("max_ttc", Ty::Double, "a pair is also kept with a TTC up to this (s), >= 0"),
                RADII,
            ],
            arities: &[5, 6],
            returns: CONFLICTS,
            kernel: conflicts,
        }],
        table: None,
    },
    Function {
        name: "traj_conflicts_top",
        description: "The k pairs of a set of road users with the smallest PET (at most max_pet), without scoring every pair that has \
                      one: the elements of traj_conflicts with a PET, the first k by (pet, a, b) (ties broken by the ids), sorted by (a, b), \
                      each with its TTC at radius. A pair with a TTC but no crossing is not included. The PET bound is searched upward \
                      from max_pet / 16, doubling until k pairs are found: each round scores only the pairs that cross within the \
                      bound, so the cost follows the near misses asked for, not the congestion (sql/analysis.sql top_conflicts; \
                      the report's near misses). k = 0: an empty list. With class_codes and min_gaps (one per road user: any code per \
                      class, and class_min_gap_m(class)), a pair of one class whose paths stay closer than that gap (together_m, the \
                      median distance over their common time, from at least 2 sample times) is one road user counted twice, not a near \
                      miss: it is left out and does not count towards k (conflict_probably_one; crates/algo/src/conflict/together.rs). \
                      With radii (one per road user, m: class_radius_m(class)) a pair's TTC is at the sum of its radii instead of radius; \
                      with walkers (one per road user: 1 a pedestrian, 0 not) a pair of two pedestrians is left out too (people passing \
                      close by are no traffic conflict: the report's near misses). \
                      Errors: those of traj_conflicts, k < 0, and class_codes, min_gaps, radii or walkers not one per id.",
        example: "SELECT len(traj_conflicts_top([1, 2], [[{'t': 0, 'x': -10, 'y': 0}, {'t': 2, 'x': 10, 'y': 0}], [{'t': 0, 'x': 0, 'y': -10}, {'t': 4, 'x': 0, 'y': 10}]], 1, 5.0, 2.0)); -- 1",
        maths: "crates/algo/src/conflict/top.rs",
        binding: file!(),
        section: Section::Conflicts,
        see_also: &["traj_conflicts", "conflict_probably_one", "class_min_gap_m"],
        signatures: &[Signature {
            params: &[
                IDS,
                TRAJS,
                pd("k", Ty::Bigint, "how many pairs to return (those with the smallest PET), >= 0"),
                pd("max_pet", Ty::Double, "the largest PET a returned pair may have (s), > 0"),
                pd("radius", Ty::Double, "the distance between the centres that is contact for the TTC (m), >= 0"),
                pd("class_codes", Ty::List(&Ty::Bigint), "one code per road user: its class (only equality counts); with min_gaps"),
                pd("min_gaps", Ty::List(&Ty::Double), "one least gap per road user (m, class_min_gap_m(class)): a pair of one class whose paths stay closer is one road user, left out"),
                RADII,
                pd("walkers", Ty::List(&Ty::Bigint), "one per road user: 1 a pedestrian, 0 not; a pair of two pedestrians is left out"),
            ],
            arities: &[5, 7, 9],
            returns: CONFLICTS,
            kernel: conflicts_top,
        }],
        table: None,
    },
    Function {
        name: "conflict_probably_one",
        description: "Is a pair of road users one road user counted twice, not a near miss (issue 39; crates/algo/src/conflict/together.rs)? \
                      True when both are of the same class, their paths share at least 2 sample times (together_n, from traj_conflicts) and \
                      the median distance between them over that time (together_m, m) is under the class's least gap (class_min_gap_m: \
                      two bodies cannot be closer). Measured on both DUT scenes: the pairs the truth calls one object lie 0.03-0.14 m \
                      apart, pedestrians walking in pairs 0.32 m and more. NULL for a NULL argument (no common time: traj_conflicts gives NULL \
                      together_n and together_m; conflicts() reads that as false). O(1).",
        example: "SELECT conflict_probably_one('pedestrian', 'pedestrian', 40, 0.08); -- true",
        maths: "crates/algo/src/conflict/together.rs",
        binding: file!(),
        section: Section::Conflicts,
        see_also: &["class_min_gap_m", "traj_conflicts_top"],
        signatures: &[Signature {
            params: &[
                CLASS_A,
                CLASS_B,
                pd("together_n", Ty::Bigint, "the sample times the two paths share (traj_conflicts' together_n)"),
                pd("together_m", Ty::Double, "the median distance between them over that time (m, traj_conflicts' together_m)"),
            ],
            arities: &[],
            returns: Ty::Boolean,
            kernel: probably_one,
        }],
        table: None,
    },
    Function {
        name: "conflict_kind",
        description: "The kind of a crossing between road users of classes class_a and class_b whose headings meet at angle_deg \
                      (traj_pet's angle, 0-180): SSAM's kinds between two vehicles (cars, heavy vehicles, two-wheelers; an angle outside 0-180 is folded into it): rear-end \
                      under 30 degrees, lane-change 30-85, crossing above 85 (Gettman et al. 2008); 'vehicle-pedestrian' when one is a \
                      pedestrian and 'pedestrian-pedestrian' when both are (SSAM's kinds are about vehicles in lanes: a pedestrian pair \
                      is no lane change). NULL when a class says nothing of the road user (class_kind 'unknown'), a vehicle pair has \
                      no finite angle, or an argument is NULL (crates/algo/src/conflict/kind.rs). conflicts()' kind column. O(1).",
        example: "SELECT conflict_kind('pedestrian', 'pedestrian', 40); -- pedestrian-pedestrian",
        maths: "crates/algo/src/conflict/kind.rs",
        binding: file!(),
        section: Section::Conflicts,
        see_also: &["traj_pet", "class_kind"],
        signatures: &[Signature {
            params: &[
                CLASS_A,
                CLASS_B,
                pd("angle_deg", Ty::Double, "the angle between their headings at the crossing (degrees, traj_pet's angle), 0-180; other values are folded into it"),
            ],
            arities: &[],
            returns: Ty::Varchar,
            kernel: kind,
        }],
        table: None,
    },
];

/// The columns of one row's kept pairs (CONFLICTS' fields, in order).
#[derive(Default)]
struct PairCols {
    a: Vec<i64>,
    b: Vec<i64>,
    pet: [Vec<Option<f64>>; 6],
    a_first: Vec<Option<bool>>,
    ttc: [Vec<Option<f64>>; 4],
    together_n: Vec<Option<i64>>,
    together_m: Vec<Option<f64>>,
}

impl PairCols {
    fn of(id: &[i64], found: &[conflict::Conflict]) -> PairCols {
        let mut c = PairCols::default();
        for f in found {
            c.a.push(id[f.a]);
            c.b.push(id[f.b]);
            let p = f.pet.map(|p| [p.pet, p.x, p.y, p.t_first(), p.t_second(), p.angle]);
            for (k, col) in c.pet.iter_mut().enumerate() {
                col.push(p.map(|v| v[k]));
            }
            c.a_first.push(f.pet.map(|p| p.t_a <= p.t_b));
            let t = f.ttc.map(|t| [t.ttc, t.t, t.x, t.y]);
            for (k, col) in c.ttc.iter_mut().enumerate() {
                col.push(t.map(|v| v[k]));
            }
            c.together_n.push(f.together.map(|g| g.n as i64));
            c.together_m.push(f.together.map(|g| g.median_m));
        }
        c
    }
}

fn conflicts(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ids, trajs, max_pet, radius, max_ttc) = (a.i64_list(0), a.traj_list(1), a.double(2), a.double(3), a.double(4));
    let radii = a.given(5).then(|| a.f64_list(5));
    let vals = a.map(|r| {
        let (Some(id), Some(tr), Some(m), Some(rad), Some(mt)) = (ids.get(r)?, trajs.get(r)?, max_pet.get(r), radius.get(r), max_ttc.get(r)) else {
            return Ok(None);
        };
        let radii: Option<Vec<f64>> = match &radii {
            None => None,
            Some(col) => match col.get(r)? {
                Some(v) => Some(v.to_vec()),
                None => return Ok(None),
            },
        };
        let found = conflict::conflicts(id, &tr, m, rad, mt, radii.as_deref()).map_err(|e| e.describe())?;
        Ok(Some(PairCols::of(id, &found)))
    })?;
    write_pairs(&vals, out)?;
    Ok(())
}

fn conflicts_top(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ids, trajs, k, max_pet, radius) = (a.i64_list(0), a.traj_list(1), a.bigint(2), a.double(3), a.double(4));
    let bodies = a.given(5).then(|| (a.i64_list(5), a.f64_list(6)));
    let extra = a.given(7).then(|| (a.f64_list(7), a.i64_list(8)));
    let vals = a.map(|r| {
        let (Some(id), Some(tr), Some(k), Some(m), Some(rad)) = (ids.get(r)?, trajs.get(r)?, k.get(r), max_pet.get(r), radius.get(r)) else {
            return Ok(None);
        };
        let body: Option<Vec<conflict::Body>> = match &bodies {
            None => None,
            Some((codes, gaps)) => match (codes.get(r)?, gaps.get(r)?) {
                (Some(c), Some(w)) => {
                    if c.len() != w.len() {
                        return Err(format!("class_codes and min_gaps must be as long, got {} and {}", c.len(), w.len()).into());
                    }
                    if let Some(bad) = w.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
                        return Err(format!("min_gaps must be finite and > 0 (m; class_min_gap_m(class)), got {bad}").into());
                    }
                    Some(c.iter().zip(w.iter()).map(|(&class, &min_gap_m)| conflict::Body { class, min_gap_m }).collect())
                }
                _ => return Ok(None),
            },
        };
        let (radii, walkers): (Option<Vec<f64>>, Option<Vec<bool>>) = match &extra {
            None => (None, None),
            Some((rs, ws)) => match (rs.get(r)?, ws.get(r)?) {
                (Some(rv), Some(wv)) => (Some(rv.to_vec()), Some(wv.iter().map(|&w| w != 0).collect())),
                _ => return Ok(None),
            },
        };
        let found = conflict::top_conflicts(id, &tr, k, m, rad, body.as_deref(), radii.as_deref(), walkers.as_deref()).map_err(|e| e.describe())?;
        Ok(Some(PairCols::of(id, &found)))
    })?;
    write_pairs(&vals, out)?;
    Ok(())
}

fn write_pairs(vals: &[Option<PairCols>], out: &mut Out<'_>) -> Result<(), String> {
    let cols: Vec<Option<Vec<Column<'_>>>> = vals
        .iter()
        .map(|v| {
            v.as_ref().map(|c| {
                let mut cols = vec![Column::I64(&c.a), Column::I64(&c.b)];
                cols.extend(c.pet.iter().map(|p| Column::OptF64(p)));
                cols.push(Column::OptBool(&c.a_first));
                cols.extend(c.ttc.iter().map(|t| Column::OptF64(t)));
                cols.push(Column::OptI64(&c.together_n));
                cols.push(Column::OptF64(&c.together_m));
                cols
            })
        })
        .collect();
    out.struct_lists(&cols)
}

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

fn kind(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ca, cb, g) = (a.text(0), a.text(1), a.double(2));
    let vals: Vec<Option<&str>> = a.map(|r| {
        let (Some(x), Some(y), Some(g)) = (ca.get(r), cb.get(r), g.get(r)) else { return Ok(None) };
        Ok(conflict::conflict_kind(&x, &y, Some(g)))
    })?;
    out.text(&vals);
    Ok(())
}

fn probably_one(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ca, cb, n, m) = (a.text(0), a.text(1), a.opt_bigint(2), a.opt_double(3));
    let vals = a.map(|r| {
        let (Some(x), Some(y)) = (ca.get(r), cb.get(r)) else { return Ok(None) };
        let t = match (n.or(r, -1), m.or(r, f64::NAN)) {
            (Some(n), Some(m)) if n >= 0 && m.is_finite() => Some(conflict::Together { n: n as usize, median_m: m, span_s: f64::NAN }),
            _ => None,
        };
        Ok(Some(conflict::probably_one(&x, &y, t)))
    })?;
    out.flat(&vals);
    Ok(())
}
