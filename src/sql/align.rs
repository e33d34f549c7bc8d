//! SQL: camera alignment: `cpd_align` (rigid TimeCPD), `rigid_fit`, and the transform helpers
//! `transform_apply`, `transform_compose`, `transform_invert`.

use super::convert::*;
use crate::algo::cpd::{self, CpdParams};
use crate::algo::rigid::{self, Transform2};
use crate::algo::traj::OwnedTraj;
use duckdb::core::{DataChunkHandle, LogicalTypeHandle, LogicalTypeId};
use duckdb::vscalar::ScalarFunctionSignature;
use duckdb::vtab::arrow::WritableVector;
use duckdb::Connection;
use std::error::Error;

pub const DOCS: &[FnDoc] = &[
    FnDoc {
        name: "cpd_align",
        signatures: "cpd_align(fixed TRAJ, moving TRAJ, w DOUBLE [, tau DOUBLE [, max_iter BIGINT, tol DOUBLE [, with_scale BOOLEAN, starts BIGINT]]]) -> STRUCT(theta, tx, ty, scale, r11, r12, r21, r22, sigma2, iterations, converged, q, log_likelihood, inlier_fraction, rms, start_theta, pairs_in_band)\ncpd_align(fixed STRUCT(t, x, y, z)[], moving STRUCT(t, x, y, z)[], w [, ...same options]) -> STRUCT(r11..r33, tx, ty, tz, scale, sigma2, iterations, converged, q, log_likelihood, inlier_fraction, rms, pairs_in_band)",
        description: "Rigid TimeCPD (thesis eq. 2.7/2.8, Alg. 5-8): the transform p_fixed = scale*R(theta)*p_moving + (tx, ty) that best explains the \
                      fixed points (x, y, t) as noisy copies of the moving ones, with outlier weight w in [0, 1) and time standard deviation tau (s). \
                      Without tau, or tau = 'inf', it is plain rigid CPD (Myronenko & Song); a NULL tau gives NULL like any NULL argument. \
                      The E-step only visits pairs with |t - s| <= 7.43*tau (time weight < 1e-12) and runs on all cores. \
                      Defaults: max_iter 100, tol 1e-5, with_scale false, starts 8 (EM from 8 rotations 2*pi*k/8, the best log-likelihood after 15 \
                      iterations continues; starts = 1 is the thesis's R = I start). converged = false when max_iter ran out (the estimate is still returned). \
                      With STRUCT(t, x, y, z)[] inputs it runs in 3-D (rotation from the SVD of the 3x3 cross-covariance; starts rotate about z).",
        example: "SELECT round(degrees(cpd_align(a, b, 0.0, 1.0).theta)) FROM (SELECT [{'t':0,'x':0,'y':0},{'t':1,'x':4,'y':0},{'t':2,'x':4,'y':3}] AS a, [{'t':0,'x':0,'y':0},{'t':1,'x':0,'y':-4},{'t':2,'x':3,'y':-4}] AS b); -- 90.0",
    },
    FnDoc {
        name: "rigid_fit",
        signatures: "rigid_fit(pairs STRUCT(fx, fy, mx, my)[] [, trim DOUBLE [, with_scale BOOLEAN]]) -> STRUCT(theta, tx, ty, scale, rms, inliers BIGINT, n BIGINT)",
        description: "Least-squares transform from known correspondences (Umeyama/Kabsch; closed form in 2-D): p_fixed = scale*R(theta)*p_moving + (tx, ty) \
                      for pairs (fx, fy) <- (mx, my). With trim in [0, 1), least trimmed squares: refit on the best (1 - trim) share of pairs until the kept \
                      set is stable (robust to wrong correspondences). Needs 2 pairs that are not all at one point; otherwise an error.",
        example: "SELECT round(degrees(rigid_fit([{'fx':0,'fy':0,'mx':0,'my':0},{'fx':0,'fy':1,'mx':1,'my':0}]).theta)); -- 90.0",
    },
    FnDoc {
        name: "traj_correspond",
        signatures: "traj_correspond(fixed TRAJ, moving TRAJ [, max_gap DOUBLE]) -> STRUCT(fx, fy, mx, my)[]",
        description: "Point pairs for rigid_fit from two tracks of (presumably) the same road user in two cameras with synchronised clocks: for each \
                      fixed point inside the moving track's time span, the moving track interpolated linearly at that time (not across gaps longer \
                      than max_gap seconds, default 0.5). rigid_fit(traj_correspond(a, b)) is one transform hypothesis, found in closed form, with no \
                      initial rotation needed. O(n + m).",
        example: "SELECT traj_correspond([{'t':1,'x':0,'y':0}], [{'t':0,'x':0,'y':0},{'t':2,'x':4,'y':2}], 3.0); -- [{'fx': 0.0, 'fy': 0.0, 'mx': 2.0, 'my': 1.0}]",
    },
    FnDoc {
        name: "transform_apply",
        signatures: "transform_apply(traj TRAJ, tf STRUCT(theta, tx, ty, scale)) -> TRAJ",
        description: "Maps every point of the trajectory with p' = scale*R(theta)*p + (tx, ty); t is unchanged. Use it to bring a camera's tracks into the fixed frame.",
        example: "SELECT transform_apply([{'t':0,'x':1,'y':0}], {'theta': pi()/2, 'tx': 10, 'ty': 0, 'scale': 1})[1].x; -- 10.0",
    },
    FnDoc {
        name: "transform_point",
        signatures: "transform_point(tf STRUCT(theta, tx, ty, scale), x DOUBLE, y DOUBLE) -> STRUCT(x DOUBLE, y DOUBLE)",
        description: "One point mapped with p' = scale*R(theta)*p + (tx, ty), for point tables: transform_point(f.to_reference, p.x, p.y).x. \
                      NaN or infinite x/y is an error.",
        example: "SELECT transform_point({'theta': 0, 'tx': 10, 'ty': -1, 'scale': 2}, 1, 0); -- {'x': 12.0, 'y': -1.0}",
    },
    FnDoc {
        name: "rigid_rms",
        signatures: "rigid_rms(pairs STRUCT(fx, fy, mx, my)[], tf STRUCT(theta, tx, ty, scale)) -> DOUBLE",
        description: "Root mean square of |(fx, fy) - tf(mx, my)| over the pairs: how well a transform explains point pairs (e.g. one track pair's \
                      traj_correspond under a camera pair's fit). NULL for an empty list.",
        example: "SELECT rigid_rms([{'fx': 1, 'fy': 0, 'mx': 0, 'my': 0}], {'theta': 0, 'tx': 0, 'ty': 0, 'scale': 1}); -- 1.0",
    },
    FnDoc {
        name: "transform_compose",
        signatures: "transform_compose(a STRUCT(theta, tx, ty, scale), b STRUCT(theta, tx, ty, scale)) -> STRUCT(theta, tx, ty, scale)",
        description: "a after b: transform_apply(p, transform_compose(a, b)) = transform_apply(transform_apply(p, b), a). To chain camera k -> l -> ref use \
                      transform_compose(l_to_ref, k_to_l). theta is wrapped to (-pi, pi].",
        example: "SELECT transform_compose({'theta': 0, 'tx': 1, 'ty': 0, 'scale': 1}, {'theta': 0, 'tx': 0, 'ty': 2, 'scale': 1}); -- {'theta': 0.0, 'tx': 1.0, 'ty': 2.0, 'scale': 1.0}",
    },
    FnDoc {
        name: "transform_invert",
        signatures: "transform_invert(tf STRUCT(theta, tx, ty, scale)) -> STRUCT(theta, tx, ty, scale)",
        description: "The inverse transform (fixed frame back to moving frame); transform_compose(tf, transform_invert(tf)) is the identity.",
        example: "SELECT transform_invert({'theta': 0, 'tx': 3, 'ty': -1, 'scale': 2}); -- {'theta': -0.0, 'tx': -1.5, 'ty': 0.5, 'scale': 0.5}",
    },
];

fn boolean() -> LogicalTypeHandle {
    LogicalTypeId::Boolean.into()
}

fn cpd_result_type() -> LogicalTypeHandle {
    let d = double;
    LogicalTypeHandle::struct_type(&[
        ("theta", d()),
        ("tx", d()),
        ("ty", d()),
        ("scale", d()),
        ("r11", d()),
        ("r12", d()),
        ("r21", d()),
        ("r22", d()),
        ("sigma2", d()),
        ("iterations", bigint()),
        ("converged", boolean()),
        ("q", d()),
        ("log_likelihood", d()),
        ("inlier_fraction", d()),
        ("rms", d()),
        ("start_theta", d()),
        ("pairs_in_band", bigint()),
    ])
}

fn cpd3_result_type() -> LogicalTypeHandle {
    let d = double;
    LogicalTypeHandle::struct_type(&[
        ("r11", d()),
        ("r12", d()),
        ("r13", d()),
        ("r21", d()),
        ("r22", d()),
        ("r23", d()),
        ("r31", d()),
        ("r32", d()),
        ("r33", d()),
        ("tx", d()),
        ("ty", d()),
        ("tz", d()),
        ("scale", d()),
        ("sigma2", d()),
        ("iterations", bigint()),
        ("converged", boolean()),
        ("q", d()),
        ("log_likelihood", d()),
        ("inlier_fraction", d()),
        ("rms", d()),
        ("pairs_in_band", bigint()),
    ])
}

fn cpd_signatures() -> Vec<ScalarFunctionSignature> {
    let mut v = vec![sig(vec![traj_type(), traj_type(), double()], cpd_result_type())];
    v.push(sig(vec![traj_type(), traj_type(), double(), double()], cpd_result_type()));
    v.push(sig(vec![traj_type(), traj_type(), double(), double(), bigint(), double()], cpd_result_type()));
    v.push(sig(
        vec![traj_type(), traj_type(), double(), double(), bigint(), double(), boolean(), bigint()],
        cpd_result_type(),
    ));
    // 3-D overloads: STRUCT(t, x, y, z)[] inputs.
    let t3 = traj3_type;
    v.push(sig(vec![t3(), t3(), double()], cpd3_result_type()));
    v.push(sig(vec![t3(), t3(), double(), double()], cpd3_result_type()));
    v.push(sig(vec![t3(), t3(), double(), double(), bigint(), double()], cpd3_result_type()));
    v.push(sig(vec![t3(), t3(), double(), double(), bigint(), double(), boolean(), bigint()], cpd3_result_type()));
    v
}

/// The optional `tau, max_iter, tol, with_scale, starts` arguments (columns 3..7), defaulted.
fn cpd_params(input: &DataChunkHandle) -> impl Fn(usize, f64) -> Result<Option<CpdParams>, Box<dyn Error>> + '_ {
    let tau = OptCol::new(input, 3);
    let max_iter = OptCol::new(input, 4);
    let tol = OptCol::new(input, 5);
    let scale = OptCol::new(input, 6);
    let starts = OptCol::new(input, 7);
    move |r, w| {
        let (Some(tau), Some(max_iter), Some(tol), Some(scale), Some(starts)) =
            (tau.f64_or(r, f64::INFINITY), max_iter.i64_or(r, 100), tol.f64_or(r, 1e-5), scale.bool_or(r, false), starts.i64_or(r, 8))
        else {
            return Ok(None);
        };
        let p = CpdParams::new(w, Some(tau), max_iter, tol, scale, starts)
        .map_err(|e| err("cpd_align", e))?;
        Ok(Some(p))
    }
}

fn is_3d(input: &DataChunkHandle) -> bool {
    input.flat_vector(0).logical_type().child(0).num_children() == 4
}

/// The shared row loop of both `cpd_align` forms: reads (fixed, moving) with `read`, w and the
/// options, and turns each solved row into struct fields with `solve`.
fn cpd_rows<P>(
    input: &DataChunkHandle,
    nfields: usize,
    output: &mut dyn WritableVector,
    read: impl Fn(usize) -> Result<Option<(P, P)>, Box<dyn Error>>,
    solve: impl Fn(P, P, &CpdParams) -> Result<Vec<Field>, Box<dyn Error>>,
) -> FnResult {
    let w = PrimCol::new(input, 2);
    let params = cpd_params(input);
    let vals = map_rows(input.len(), |r| -> Result<Option<Vec<Field>>, Box<dyn Error>> {
        let (Some((a, b)), Some(w)) = (read(r)?, w.f64(r)) else { return Ok(None) };
        let Some(p) = params(r, w)? else { return Ok(None) };
        Ok(Some(solve(a, b, &p)?))
    })?;
    write_struct(&mut output.struct_vector(), nfields, &vals);
    Ok(())
}

fn cpd_align3(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "cpd_align";
    let a = Traj3Col::new(input, 0);
    let b = Traj3Col::new(input, 1);
    let read = |r| -> Result<_, Box<dyn Error>> {
        let (Some(a), Some(b)) = (a.get(r, F, "fixed")?, b.get(r, F, "moving")?) else { return Ok(None) };
        Ok(Some((a, b)))
    };
    cpd_rows(input, 21, output, read, |a, b, p| {
        let res = crate::algo::cpd3::align3((a.1, a.2, a.3, a.0), (b.1, b.2, b.3, b.0), p).map_err(|e| err(F, e))?;
        let t = res.transform;
        let mut v: Vec<Field> = t.r.iter().flat_map(|row| row.iter().map(|&x| Field::F(x))).collect();
        v.extend([Field::F(t.t[0]), Field::F(t.t[1]), Field::F(t.t[2]), Field::F(t.scale), Field::F(res.sigma2)]);
        v.extend([Field::I(res.iterations as i64), Field::B(res.converged), Field::F(res.q), Field::F(res.log_likelihood)]);
        v.extend([Field::F(res.inlier_fraction), Field::F(res.rms), Field::I(res.pairs_in_band as i64)]);
        Ok(v)
    })
}

fn cpd_align(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "cpd_align";
    if is_3d(input) {
        return cpd_align3(input, output);
    }
    let a = TrajCol::new(input, 0);
    let b = TrajCol::new(input, 1);
    let read = |r| -> Result<_, Box<dyn Error>> {
        let (Some(a), Some(b)) = (a.get(r, F, "fixed")?, b.get(r, F, "moving")?) else { return Ok(None) };
        Ok(Some((a, b)))
    };
    cpd_rows(input, 17, output, read, |a, b, p| {
        let res = cpd::align((a.x, a.y, a.t), (b.x, b.y, b.t), p).map_err(|e| err(F, e))?;
        let t = res.transform;
        let m = Transform2 { scale: 1.0, ..t }.matrix();
        Ok(vec![
            Field::F(t.theta),
            Field::F(t.tx),
            Field::F(t.ty),
            Field::F(t.scale),
            Field::F(m[0][0]),
            Field::F(m[0][1]),
            Field::F(m[1][0]),
            Field::F(m[1][1]),
            Field::F(res.sigma2),
            Field::I(res.iterations as i64),
            Field::B(res.converged),
            Field::F(res.q),
            Field::F(res.log_likelihood),
            Field::F(res.inlier_fraction),
            Field::F(res.rms),
            Field::F(res.start_theta),
            Field::I(res.pairs_in_band as i64),
        ])
    })
}

fn pairs_col_type() -> LogicalTypeHandle {
    LogicalTypeHandle::list(&LogicalTypeHandle::struct_type(&[("fx", double()), ("fy", double()), ("mx", double()), ("my", double())]))
}

fn rigid_fit_type() -> LogicalTypeHandle {
    LogicalTypeHandle::struct_type(&[
        ("theta", double()),
        ("tx", double()),
        ("ty", double()),
        ("scale", double()),
        ("rms", double()),
        ("inliers", bigint()),
        ("n", bigint()),
    ])
}

fn rigid_fit(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "rigid_fit";
    let pairs = FourCol::new(input, 0);
    let trim = OptCol::new(input, 1);
    let scale = OptCol::new(input, 2);
    let vals = map_rows(input.len(), |r| -> Result<Option<Vec<Field>>, Box<dyn Error>> {
        let Some(cols) = pairs.get(r, F, "pairs")? else { return Ok(None) };
        let Some(trim) = trim.f64_or(r, 0.0) else { return Ok(None) };
        let Some(with_scale) = scale.bool_or(r, false) else { return Ok(None) };
        let f = rigid::fit_trimmed(cols[0], cols[1], cols[2], cols[3], trim, with_scale).map_err(|e| err(F, e))?;
        let t = f.transform;
        let kept = f.inliers.iter().filter(|&&b| b).count();
        Ok(Some(vec![
            Field::F(t.theta),
            Field::F(t.tx),
            Field::F(t.ty),
            Field::F(t.scale),
            Field::F(f.rms),
            Field::I(kept as i64),
            Field::I(f.inliers.len() as i64),
        ]))
    })?;
    write_struct(&mut output.struct_vector(), 7, &vals);
    Ok(())
}

fn transform_arg(c: &StructF64Col<'_>, r: usize, f: &str, param: &str) -> Result<Option<Transform2>, Box<dyn Error>> {
    let Some(v) = c.get(r, f, param)? else { return Ok(None) };
    let t = Transform2::new(v[0], v[1], v[2], v[3]);
    t.validate().map_err(|e| err(f, format!("{param}: {e}")))?;
    Ok(Some(t))
}

const TF_FIELDS: &[&str] = &["theta", "tx", "ty", "scale"];

fn tf_vals(t: Transform2) -> Vec<f64> {
    vec![t.theta, t.tx, t.ty, t.scale]
}

fn apply(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "transform_apply";
    let a = TrajCol::new(input, 0);
    let tf = StructF64Col::new(input, 1, TF_FIELDS);
    let vals = map_rows(input.len(), |r| -> Result<Option<OwnedTraj>, Box<dyn Error>> {
        let (Some(a), Some(t)) = (a.get(r, F, "traj")?, transform_arg(&tf, r, F, "tf")?) else { return Ok(None) };
        let mut o = OwnedTraj::default();
        for k in 0..a.len() {
            let (x, y) = t.apply(a.x[k], a.y[k]);
            o.push(a.t[k], x, y);
        }
        Ok(Some(o))
    })?;
    write_trajs(&mut output.list_vector(), &vals);
    Ok(())
}

fn point(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "transform_point";
    let tf = StructF64Col::new(input, 0, TF_FIELDS);
    let (x, y) = (PrimCol::new(input, 1), PrimCol::new(input, 2));
    let vals = map_rows(input.len(), |r| {
        let (Some(t), Some(x), Some(y)) = (transform_arg(&tf, r, F, "tf")?, x.f64(r), y.f64(r)) else { return Ok(None) };
        for (name, v) in [("x", x), ("y", y)] {
            if !v.is_finite() {
                return Err(err(F, format!("{name} must be finite, got {v}")));
            }
        }
        let (px, py) = t.apply(x, y);
        Ok(Some(vec![px, py]))
    })?;
    write_struct_f64(&mut output.struct_vector(), 2, &vals);
    Ok(())
}

fn rms(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "rigid_rms";
    let pairs = FourCol::new(input, 0);
    let tf = StructF64Col::new(input, 1, TF_FIELDS);
    let vals = map_rows(input.len(), |r| {
        let (Some(c), Some(t)) = (pairs.get(r, F, "pairs")?, transform_arg(&tf, r, F, "tf")?) else { return Ok(None) };
        if c[0].is_empty() {
            return Ok(None);
        }
        Ok(Some(rigid::residual_rms(&t, c[0], c[1], c[2], c[3], &[])))
    })?;
    write_flat(&mut output.flat_vector(), &vals);
    Ok(())
}

fn compose(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "transform_compose";
    let a = StructF64Col::new(input, 0, TF_FIELDS);
    let b = StructF64Col::new(input, 1, TF_FIELDS);
    let vals = map_rows(input.len(), |r| {
        let (Some(a), Some(b)) = (transform_arg(&a, r, F, "a")?, transform_arg(&b, r, F, "b")?) else { return Ok(None) };
        Ok(Some(tf_vals(a.compose(&b))))
    })?;
    write_struct_f64(&mut output.struct_vector(), 4, &vals);
    Ok(())
}

fn invert(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "transform_invert";
    let a = StructF64Col::new(input, 0, TF_FIELDS);
    let vals = map_rows(input.len(), |r| Ok(transform_arg(&a, r, F, "tf")?.map(|t| tf_vals(t.invert()))))?;
    write_struct_f64(&mut output.struct_vector(), 4, &vals);
    Ok(())
}

/// The `pairs STRUCT(fx, fy, mx, my)[]` argument of `rigid_fit`: four DOUBLE columns per row.
struct FourCol<'a>(ListOfStructCol<'a>);

impl<'a> FourCol<'a> {
    fn new(input: &'a DataChunkHandle, col: usize) -> Self {
        FourCol(ListOfStructCol::new_pub(input, col, &["fx", "fy", "mx", "my"]))
    }
    fn get(&self, row: usize, f: &str, param: &str) -> Result<Option<[&'a [f64]; 4]>, Box<dyn Error>> {
        let Some(cols) = self.0.row_fields(row, f, param)? else { return Ok(None) };
        for (k, c) in cols.iter().enumerate() {
            if let Some(i) = c.iter().position(|v| !v.is_finite()) {
                return Err(err(f, format!("{param}[{}].{} must be finite, got {}", i + 1, ["fx", "fy", "mx", "my"][k], c[i])));
            }
        }
        Ok(Some([cols[0], cols[1], cols[2], cols[3]]))
    }
}

fn correspond(input: &mut DataChunkHandle, output: &mut dyn WritableVector) -> FnResult {
    const F: &str = "traj_correspond";
    let a = TrajCol::new(input, 0);
    let b = TrajCol::new(input, 1);
    let gap = OptCol::new(input, 2);
    let vals = map_rows(input.len(), |r| -> Result<Option<crate::algo::correspond::Pairs>, Box<dyn Error>> {
        let (Some(a), Some(b)) = (a.get(r, F, "fixed")?, b.get(r, F, "moving")?) else { return Ok(None) };
        let Some(g) = gap.f64_or(r, 0.5) else { return Ok(None) };
        if !(g > 0.0) {
            return Err(err(F, format!("max_gap must be > 0, got {g}")));
        }
        Ok(Some(crate::algo::correspond::correspond(a, b, g)))
    })?;
    write_pairs4(&mut output.list_vector(), &vals);
    Ok(())
}

/// Writes `STRUCT(fx, fy, mx, my)[]` rows.
fn write_pairs4(out: &mut duckdb::core::ListVector<'_>, vals: &[Option<crate::algo::correspond::Pairs>]) {
    let cols: Vec<Option<Vec<&[f64]>>> =
        vals.iter().map(|v| v.as_ref().map(|p| vec![&p.fx[..], &p.fy[..], &p.mx[..], &p.my[..]])).collect();
    write_list_struct_f64(out, 4, &cols);
}

scalar_fn!(CpdAlign, cpd_signatures(), cpd_align);
scalar_fn!(
    TrajCorrespond,
    vec![
        sig(vec![traj_type(), traj_type()], pairs_col_type()),
        sig(vec![traj_type(), traj_type(), double()], pairs_col_type())
    ],
    correspond
);
scalar_fn!(
    RigidFit,
    vec![
        sig(vec![pairs_col_type()], rigid_fit_type()),
        sig(vec![pairs_col_type(), double()], rigid_fit_type()),
        sig(vec![pairs_col_type(), double(), boolean()], rigid_fit_type()),
    ],
    rigid_fit
);
scalar_fn!(TransformApply, vec![sig(vec![traj_type(), transform_type()], traj_type())], apply);
scalar_fn!(
    TransformPoint,
    vec![sig(vec![transform_type(), double(), double()], struct_of(&[("x", double()), ("y", double())]))],
    point
);
scalar_fn!(RigidRms, vec![sig(vec![pairs_col_type(), transform_type()], double())], rms);
scalar_fn!(TransformCompose, vec![sig(vec![transform_type(), transform_type()], transform_type())], compose);
scalar_fn!(TransformInvert, vec![sig(vec![transform_type()], transform_type())], invert);

pub fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_scalar_function::<CpdAlign>("cpd_align")?;
    con.register_scalar_function::<RigidFit>("rigid_fit")?;
    con.register_scalar_function::<TrajCorrespond>("traj_correspond")?;
    con.register_scalar_function::<TransformApply>("transform_apply")?;
    con.register_scalar_function::<TransformPoint>("transform_point")?;
    con.register_scalar_function::<RigidRms>("rigid_rms")?;
    con.register_scalar_function::<TransformCompose>("transform_compose")?;
    con.register_scalar_function::<TransformInvert>("transform_invert")?;
    Ok(())
}
