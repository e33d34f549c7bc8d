//! SQL: the clock model `t_camera = (1 + D) · t_reference + O`, written once. Maths:
//! `crates/algo/src/align/clock.rs`. align.sql, sql/score.sql and python/trajdb/spark.py call these.

use super::registry::{p, Function, Signature, Ty};
use super::vector::{Args, Out, Value};
use crate::algo::align::clock::Clock;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const CLOCK_RS: &str = "crates/algo/src/align/clock.rs";
/// A clock against a reference: `t = (1 + drift) · t_reference + offset`.
pub const CLOCK: Ty = Ty::Struct(&[("offset", Ty::Double), ("drift", Ty::Double)]);

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "clock_to_reference",
        description: "A camera's time t on the reference clock, with the camera's clock t = (1 + drift) t_reference + offset (offset in \
                      seconds, drift a fraction: 200 ppm is 2e-4): (t - offset) / (1 + drift). align.sql puts every point on the \
                      reference camera's clock with it. NULL when any argument is NULL. O(1).",
        example: "SELECT clock_to_reference(103.02, 3.0, 2e-4); -- 100.0",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature {
            params: &[p("t", Ty::Double), p("offset", Ty::Double), p("drift", Ty::Double)],
            arities: &[],
            returns: Ty::Double,
            kernel: clock_to_reference,
        }],
        table: None,
    },
    Function {
        name: "clock_compose",
        description: "outer after inner: with outer the clock of A against B and inner the clock of B against C, the clock of A \
                      against C: offset (1 + D_outer) O_inner + O_outer, drift D_outer + D_inner + D_outer D_inner (align.sql \
                      composes clocks along the spanning tree of camera pairs with it). Without drift, the sum of the offsets exactly. O(1).",
        example: "SELECT clock_compose({'offset': 1.0, 'drift': 0.0}, {'offset': 2.0, 'drift': 0.0}); -- {'offset': 3.0, 'drift': 0.0}",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature { params: &[p("outer", CLOCK), p("inner", CLOCK)], arities: &[], returns: CLOCK, kernel: clock_compose }],
        table: None,
    },
    Function {
        name: "clock_invert",
        description: "The reference against this clock: offset -O / (1 + D), drift -D / (1 + D); \
                      clock_compose(c, clock_invert(c)) is the identity. O(1).",
        example: "SELECT clock_invert({'offset': 2.0, 'drift': 0.0}); -- {'offset': -2.0, 'drift': -0.0}",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature { params: &[p("clock", CLOCK)], arities: &[], returns: CLOCK, kernel: clock_invert }],
        table: None,
    },
    Function {
        name: "clock_between",
        description: "The clock of camera a against camera b, both given against one reference: t_a = (1 + D_a)/(1 + D_b) t_b + O_a - \
                      (1 + D_a)/(1 + D_b) O_b (transforms.csv's t_from = (1 + drift) t_to + offset); without drift O_a - O_b \
                      exactly. Equal to clock_compose(a, clock_invert(b)) in exact arithmetic. O(1).",
        example: "SELECT clock_between({'offset': 0.5, 'drift': 0.0}, {'offset': 0.25, 'drift': 0.0}); -- {'offset': 0.25, 'drift': 0.0}",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature { params: &[p("a", CLOCK), p("b", CLOCK)], arities: &[], returns: CLOCK, kernel: clock_between }],
        table: None,
    },
    Function {
        name: "clock_from_relative",
        description: "A camera pair's clock on the cameras' own clocks from a fit on relative clocks (each camera's times taken from \
                      its own first time, origin_moving and origin_fixed): the fit says t_m - o_m = (1 + drift)(t_f - o_f + c), so \
                      offset = c (1 + drift) + (o_m - o_f) - drift o_f; without drift c + (o_m - o_f) exactly (align.sql's camera \
                      pair clocks). O(1).",
        example: "SELECT clock_from_relative(0.25, 0.0, 10.0, 4.0); -- {'offset': 6.25, 'drift': 0.0}",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature {
            params: &[p("c", Ty::Double), p("drift", Ty::Double), p("origin_moving", Ty::Double), p("origin_fixed", Ty::Double)],
            arities: &[],
            returns: CLOCK,
            kernel: clock_from_relative,
        }],
        table: None,
    },
];

fn values(c: Clock) -> Vec<Value> {
    vec![Value::F64(c.offset), Value::F64(c.drift)]
}

fn read(v: &[f64]) -> Clock {
    Clock::new(v[0], v[1])
}

fn clock_to_reference(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let get = a.doubles::<3>();
    out.flat(&a.map(|r| Ok(get(r).map(|[t, o, d]| Clock::new(o, d).to_reference(t))))?);
    Ok(())
}

fn clock_compose(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (x, y) = (a.structure(0), a.structure(1));
    let vals = a.map(|r| {
        let (Some(u), Some(v)) = (x.get(r)?, y.get(r)?) else { return Ok(None) };
        Ok(Some(values(read(&u).compose(&read(&v)))))
    })?;
    out.structs(&vals);
    Ok(())
}

fn clock_invert(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let x = a.structure(0);
    out.structs(&a.map(|r| Ok(x.get(r)?.map(|u| values(read(&u).invert()))))?);
    Ok(())
}

fn clock_between(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (x, y) = (a.structure(0), a.structure(1));
    let vals = a.map(|r| {
        let (Some(u), Some(v)) = (x.get(r)?, y.get(r)?) else { return Ok(None) };
        Ok(Some(values(Clock::between(&read(&u), &read(&v)))))
    })?;
    out.structs(&vals);
    Ok(())
}

fn clock_from_relative(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let get = a.doubles::<4>();
    out.structs(&a.map(|r| Ok(get(r).map(|[c, d, om, of]| values(Clock::from_relative(c, d, om, of)))))?);
    Ok(())
}
