//! SQL: the clock model `t_camera = (1 + D) · t_reference + O`, written once. Maths:
//! `crates/algo/src/align/clock.rs`. align.sql, sql/score.sql and python/trajdb/spark.py call these.

use super::registry::{pd, Function, Section, Signature, Ty};
use super::vector::{Args, Out, Value};
use crate::algo::align::clock::Clock;
use crate::algo::traj::grid::window_index;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const CLOCK_RS: &str = "crates/algo/src/align/clock.rs";
/// A clock against a reference: `t = (1 + drift) · t_reference + offset`.
pub const CLOCK: Ty = Ty::Struct(&[("offset", Ty::Double), ("drift", Ty::Double)]);

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "clock_to_reference",
        section: Section::Clocks,
        see_also: &["clock_compose", "clock_invert", "clock_between"],
        description: "A camera's time t on the reference clock, with the camera's clock t = (1 + drift) t_reference + offset (offset in \
                      seconds, drift a fraction: 200 ppm is 2e-4): (t - offset) / (1 + drift). align.sql puts every point on the \
                      reference camera's clock with it. NULL when any argument is NULL. O(1).",
        example: "SELECT clock_to_reference(103.02, 3.0, 2e-4); -- 100.0",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature {
            params: &[pd("t", Ty::Double, "a time on the camera's clock (s)"), pd("offset", Ty::Double, "O (s): the camera's time when the reference reads 0"), pd("drift", Ty::Double, "D: the clock's rate error, a fraction (2e-4 is 200 ppm)")],
            arities: &[],
            returns: Ty::Double,
            kernel: clock_to_reference,
        }],
        table: None,
    },
    Function {
        name: "clock_compose",
        section: Section::Clocks,
        see_also: &["clock_invert", "clock_between", "clock_to_reference"],
        description: "outer after inner: with outer the clock of A against B and inner the clock of B against C, the clock of A \
                      against C: offset (1 + D_outer) O_inner + O_outer, drift D_outer + D_inner + D_outer D_inner (align.sql \
                      composes clocks along the spanning tree of camera pairs with it). Without drift, the sum of the offsets exactly. O(1).",
        example: "SELECT clock_compose({'offset': 1.0, 'drift': 0.0}, {'offset': 2.0, 'drift': 0.0}); -- {'offset': 3.0, 'drift': 0.0}",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature { params: &[pd("outer", CLOCK, "the clock of A against B: {offset (s), drift}"), pd("inner", CLOCK, "the clock of B against C: {offset (s), drift}")], arities: &[], returns: CLOCK, kernel: clock_compose }],
        table: None,
    },
    Function {
        name: "clock_invert",
        section: Section::Clocks,
        see_also: &["clock_compose", "clock_between"],
        description: "The reference against this clock: offset -O / (1 + D), drift -D / (1 + D); \
                      clock_compose(c, clock_invert(c)) is the identity. O(1).",
        example: "SELECT clock_invert({'offset': 2.0, 'drift': 0.0}); -- {'offset': -2.0, 'drift': -0.0}",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature { params: &[pd("clock", CLOCK, "a clock against a reference: {offset (s), drift}")], arities: &[], returns: CLOCK, kernel: clock_invert }],
        table: None,
    },
    Function {
        name: "clock_between",
        section: Section::Clocks,
        see_also: &["clock_compose", "clock_invert"],
        description: "The clock of camera a against camera b, both given against one reference: t_a = (1 + D_a)/(1 + D_b) t_b + O_a - \
                      (1 + D_a)/(1 + D_b) O_b (transforms.csv's t_from = (1 + drift) t_to + offset); without drift O_a - O_b \
                      exactly. Equal to clock_compose(a, clock_invert(b)) in exact arithmetic. O(1).",
        example: "SELECT clock_between({'offset': 0.5, 'drift': 0.0}, {'offset': 0.25, 'drift': 0.0}); -- {'offset': 0.25, 'drift': 0.0}",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature { params: &[pd("a", CLOCK, "camera a's clock against the reference: {offset (s), drift}"), pd("b", CLOCK, "camera b's clock against the same reference: {offset (s), drift}")], arities: &[], returns: CLOCK, kernel: clock_between }],
        table: None,
    },
    Function {
        name: "clock_from_relative",
        section: Section::Clocks,
        see_also: &["clock_compose", "rigid_fit_shifted", "clock_network"],
        description: "A camera pair's clock on the cameras' own clocks from a fit on relative clocks (each camera's times taken from \
                      its own first time, origin_moving and origin_fixed): the fit says t_m - o_m = (1 + drift)(t_f - o_f + c), so \
                      offset = c (1 + drift) + (o_m - o_f) - drift o_f; without drift c + (o_m - o_f) exactly (align.sql's camera \
                      pair clocks). O(1).",
        example: "SELECT clock_from_relative(0.25, 0.0, 10.0, 4.0); -- {'offset': 6.25, 'drift': 0.0}",
        maths: CLOCK_RS,
        binding: file!(),
        signatures: &[Signature {
            params: &[pd("c", Ty::Double, "the fit's clock offset between the relative clocks, on the fixed camera's rate (s)"), pd("drift", Ty::Double, "D: the clock's rate error, a fraction (2e-4 is 200 ppm)"), pd("origin_moving", Ty::Double, "the moving camera's origin: the time its relative clock counts from (s)"), pd("origin_fixed", Ty::Double, "the fixed camera's origin (s)")],
            arities: &[],
            returns: CLOCK,
            kernel: clock_from_relative,
        }],
        table: None,
    },
    Function {
        name: "clock_window",
        section: Section::Clocks,
        see_also: &["clock_to_reference"],
        description: "The window of a time on the reference clock: the k with k width <= t < (k + 1) width, each bound \
                      computed as one product k * width in doubles (floor(t / width) alone can be one off near a bound). \
                      trajdb.spark assigns each road user to the window of its first observation with it, and a window \
                      [k width, (k + 1) width) keeps exactly those road users (sql/window.sql). NULL when t or width is NULL; \
                      an error for a width that is not finite and > 0, a t that is not finite, or |t / width| >= 2^53. O(1).",
        example: "SELECT clock_window(7199.9, 3600.0); -- 1",
        maths: "crates/algo/src/traj/grid.rs",
        binding: file!(),
        signatures: &[Signature {
            params: &[pd("t", Ty::Double, "a time on the reference clock (s), finite"), pd("width", Ty::Double, "the windows' width (s), finite and > 0")],
            arities: &[],
            returns: Ty::Bigint,
            kernel: clock_window,
        }],
        table: None,
    },
];

/// A computed clock, checked (`Clock::result`: an overflow is an error).
fn values(c: Clock) -> Result<Vec<Value>, Box<dyn Error>> {
    let c = c.result()?;
    Ok(vec![Value::F64(c.offset), Value::F64(c.drift)])
}

/// A CLOCK argument, checked (the error names the argument).
fn read(a: &Args<'_>, col: usize, v: &[f64]) -> Result<Clock, Box<dyn Error>> {
    Clock::checked(v[0], v[1]).map_err(|e| format!("{}.{e}", a.name(col)).into())
}

fn clock_to_reference(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let get = a.doubles::<3>();
    let vals = a.map(|r| {
        let Some([t, o, d]) = get(r) else { return Ok(None) };
        Ok(Some(Clock::checked(o, d)?.to_reference_checked(t)?))
    })?;
    out.flat(&vals);
    Ok(())
}

fn clock_compose(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (x, y) = (a.structure(0), a.structure(1));
    let vals = a.map(|r| {
        let (Some(u), Some(v)) = (x.get(r)?, y.get(r)?) else { return Ok(None) };
        Ok(Some(values(read(a, 0, &u)?.compose(&read(a, 1, &v)?))?))
    })?;
    out.structs(&vals);
    Ok(())
}

fn clock_invert(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let x = a.structure(0);
    let vals = a.map(|r| {
        let Some(u) = x.get(r)? else { return Ok(None) };
        Ok(Some(values(read(a, 0, &u)?.invert())?))
    })?;
    out.structs(&vals);
    Ok(())
}

fn clock_between(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (x, y) = (a.structure(0), a.structure(1));
    let vals = a.map(|r| {
        let (Some(u), Some(v)) = (x.get(r)?, y.get(r)?) else { return Ok(None) };
        Ok(Some(values(Clock::between(&read(a, 0, &u)?, &read(a, 1, &v)?))?))
    })?;
    out.structs(&vals);
    Ok(())
}

fn clock_from_relative(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let get = a.doubles::<4>();
    let vals = a.map(|r| {
        let Some([c, d, om, of]) = get(r) else { return Ok(None) };
        Ok(Some(values(Clock::from_relative_checked(c, d, om, of)?)?))
    })?;
    out.structs(&vals);
    Ok(())
}

fn clock_window(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let get = a.doubles::<2>();
    let vals = a.map(|r| {
        let Some([t, w]) = get(r) else { return Ok(None) };
        Ok(Some(window_index(t, w)?))
    })?;
    out.flat(&vals);
    Ok(())
}
