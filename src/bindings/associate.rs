//! SQL: the decisions of cross-camera association (issue 38). Maths:
//! `crates/algo/src/associate/` (pair.rs: a candidate's evidence; bias.rs: a camera pair's bias
//! state).

use super::registry::{pd, Function, Param, Section, Signature, Ty};
use super::vector::{Args, Out, Value};
use crate::algo::associate::bias::{self, BiasState, Offset};
use crate::algo::associate::pair;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;

const STATE: Ty =
    Ty::Struct(&[("mx", Ty::Double), ("my", Ty::Double), ("sxx", Ty::Double), ("sxy", Ty::Double), ("syy", Ty::Double), ("n", Ty::Bigint)]);
const OFFSETS: Ty = Ty::List(&Ty::Struct(&[("dx", Ty::Double), ("dy", Ty::Double), ("se2", Ty::Double)]));
const STATE_ARG: Param =
    pd("state", STATE, "a bias state: mean (mx, my; m), covariance (sxx, sxy, syy; m²) and n anchors, as bias_state or bias_state_none give");
const CLASS: Param = pd("class", Ty::Varchar, "the class name (e.g. 'car', 'Bicycle', 'heavy_vehicle'), read by its words");
const SIGMA_D: Param = pd("sigma_d", Ty::Double, "the camera pair's position noise (m per axis), >= 0 and finite");

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "bias_state",
        description: "A camera pair's bias state for one class (issue 38; docs/association.md): the mean (mx, my, m) and covariance (sxx, sxy, \
                      syy, m²) of the constant offsets between two cameras' views of one road user, estimated robustly from the offsets \
                      (dx, dy) of unambiguous matches, each measured with variance se2 per axis (σ_d² / n_eff): coordinate-wise median and MAD, \
                      then concentration steps on the offsets within chi2(2) at 0.99 with the truncation corrected; the mean se2 is taken \
                      out of the diagonal (at least 1 cm² stays). n = the offsets kept. NULL with fewer than 5 finite offsets (the caller \
                      falls back: the camera pair's offsets of every class, then bias_state_none). O(n log n).",
        example: "SELECT round(bias_state([{'dx': 1.0, 'dy': 0.0, 'se2': 0.0}, {'dx': 1.1, 'dy': 0.1, 'se2': 0.0}, {'dx': 0.9, 'dy': -0.1, 'se2': 0.0}, {'dx': 1.0, 'dy': 0.05, 'se2': 0.0}, {'dx': 1.05, 'dy': -0.05, 'se2': 0.0}]).mx, 2); -- 1.01",
        maths: "crates/algo/src/associate/bias.rs",
        binding: file!(),
        section: Section::Association,
        see_also: &["bias_state_between", "bias_state_none", "bias_fits", "pair_evidence"],
        signatures: &[Signature {
            params: &[
                pd("offsets", OFFSETS, "the offsets (dx, dy; m) of unambiguous matches of one class, each with its measurement variance se2 per axis (m², sigma_d² / n_eff)"),
            ],
            arities: &[],
            returns: STATE,
            kernel: bias_state,
        }],
        table: None,
    },
    Function {
        name: "bias_state_between",
        description: "The bias state of a class with too few unambiguous matches for its own (docs/association.md, issue 38), from the \
                      states of the camera pair's other classes: the mean of their means, and the mean of their covariances plus the \
                      sample covariance of their means (classes that differ, such as cars seen from behind and pedestrians, widen it to \
                      cover them all); n = their anchors together. NULL with fewer than 2 finite states (the caller falls back). O(C).",
        example: "SELECT bias_state_between([{'mx': 1.0, 'my': 0.0, 'sxx': 0.01, 'sxy': 0.0, 'syy': 0.01, 'n': 40}, {'mx': 0.0, 'my': 0.0, 'sxx': 0.01, 'sxy': 0.0, 'syy': 0.01, 'n': 15}]).sxx; -- 0.51",
        maths: "crates/algo/src/associate/bias_between.rs",
        binding: file!(),
        section: Section::Association,
        see_also: &["bias_state", "bias_state_none"],
        signatures: &[Signature {
            params: &[pd("states", Ty::List(&STATE), "the bias states of the camera pair's other classes")],
            arities: &[],
            returns: STATE,
            kernel: bias_state_between,
        }],
        table: None,
    },
    Function {
        name: "bias_fits",
        description: "Whether an offset (dx, dy; m) measured with variance se2 per axis (m²) belongs to a bias state: its squared \
                      Mahalanobis distance (b - mean)ᵀ (Σ + se2 I)⁻¹ (b - mean) is within the state's gate (chi2(2) at 0.999 for \
                      bias_state_none, Hotelling's predictive bound for a state of n anchors; docs/association.md). align.sql's second \
                      pass keeps the track pairs whose offset fits their class's state (two road users side by side do not). \
                      NULL for NULL; a negative or non-finite se2 counts as 0.",
        example: "SELECT bias_fits(bias_state_none(0.2), 0.3, 0.0, 0.0); -- true",
        maths: "crates/algo/src/associate/bias.rs",
        binding: file!(),
        section: Section::Association,
        see_also: &["bias_state", "bias_state_none", "pair_evidence"],
        signatures: &[Signature {
            params: &[
                STATE_ARG,
                pd("dx", Ty::Double, "the offset's x (m)"),
                pd("dy", Ty::Double, "the offset's y (m)"),
                pd("se2", Ty::Double, "the offset's measurement variance per axis (m²); negative or not finite counts as 0"),
            ],
            arities: &[],
            returns: Ty::Boolean,
            kernel: bias_fits,
        }],
        table: None,
    },
    Function {
        name: "bias_state_none",
        description: "The bias state of 'no bias': mean 0 and covariance sigma_d² I (at least 1 cm²), the tolerance of a constant offset \
                      the association had before issue 38; for a camera pair without 5 unambiguous matches.",
        example: "SELECT bias_state_none(0.2).sxx; -- 0.04000000000000001",
        maths: "crates/algo/src/associate/bias.rs",
        binding: file!(),
        section: Section::Association,
        see_also: &["bias_state", "bias_fits"],
        signatures: &[Signature { params: &[SIGMA_D], arities: &[], returns: STATE, kernel: bias_state_none }],
        table: None,
    },
    Function {
        name: "bias_search_m",
        description: "How far apart two cameras' reported points of one road user of this class can lie (m), for the candidate search only \
                      (merge.sql's LCSS proposes pairs within the camera pair's epsilon plus this; pair_evidence decides): the road user's \
                      length, since a detector's ground point lies on its outline (a pedestrian 1 m, a two-wheeler 2 m, a car 5 m, a bus or \
                      truck 12 m; classes are recognised by their words, any other class is searched as a car), plus 1 m of ground-plane \
                      error (2 % at 50 m). NULL for NULL.",
        example: "SELECT bias_search_m('car'); -- 6.0",
        maths: "crates/algo/src/associate/mod.rs",
        binding: file!(),
        section: Section::Association,
        see_also: &["class_length_m", "lcss_similarity_pairs"],
        signatures: &[Signature { params: &[CLASS], arities: &[], returns: Ty::Double, kernel: bias_search_m }],
        table: None,
    },
    Function {
        name: "class_length_m",
        description: "The length of a road user of this class (m), recognised by the class name's words: a pedestrian 1 m, a two-wheeler 2 m, \
                      a car 5 m, a bus or truck 12 m (any other class: a car). A detector's ground point lies on the road user's outline, so \
                      two cameras' points of one road user differ by at most this; align.sql's registration weighs the classes' \
                      disagreement by it (register_pair's class_lengths). NULL for NULL.",
        example: "SELECT class_length_m('heavy_vehicle'); -- 12.0",
        maths: "crates/algo/src/associate/mod.rs",
        binding: file!(),
        section: Section::Classes,
        see_also: &["class_kind", "bias_search_m", "register_pair", "traj_stationary"],
        signatures: &[Signature { params: &[CLASS], arities: &[], returns: Ty::Double, kernel: class_length_m }],
        table: None,
    },
    Function {
        name: "class_kind",
        description: "What kind of road user a class name means, by its words (the one reading of class names, as class_length_m): \
                      'two_wheeler' (cycl, bike, motor, scooter, pedelec, ...), 'pedestrian' (ped, person, walk, ...), 'heavy' (truck, bus, \
                      lorry, tram, ...), 'unknown' (a name that says nothing: unknown, the load's class without a class column, '', \
                      object, other) or 'car' (anything else). approaches() finds a site's arms from the road users that are not \
                      pedestrians. NULL for NULL.",
        example: "SELECT class_kind('Bicycle'); -- two_wheeler",
        maths: "crates/algo/src/associate/mod.rs",
        binding: file!(),
        section: Section::Classes,
        see_also: &["class_length_m", "class_min_gap_m", "class_radius_m"],
        signatures: &[Signature { params: &[CLASS], arities: &[], returns: Ty::Varchar, kernel: class_kind }],
        table: None,
    },
    Function {
        name: "class_min_gap_m",
        description: "The least distance between the centres of two distinct road users of this class (m), recognised by the class \
                      name's words as class_length_m: a pedestrian 0.25 m (torso depth: two people shoulder to shoulder; pedestrians \
                      walking in pairs on the DUT scenes were 0.32 m apart and more, one pedestrian split in two 0.03-0.14 m), a \
                      two-wheeler 0.6 m (a handlebar), a car 1.8 m, a bus or truck 2.55 m (widths; any other class: a car; a class \
                      that says nothing, such as 'unknown': 0.25 m, the least of any road user). Two road \
                      users of the class whose centres stay closer are one body counted twice (conflict_probably_one). NULL for NULL.",
        example: "SELECT class_min_gap_m('pedestrian'); -- 0.25",
        maths: "crates/algo/src/associate/mod.rs",
        binding: file!(),
        section: Section::Classes,
        see_also: &["class_kind", "conflict_probably_one"],
        signatures: &[Signature { params: &[CLASS], arities: &[], returns: Ty::Double, kernel: class_min_gap_m }],
        table: None,
    },
    Function {
        name: "class_radius_m",
        description: "A road user of this class as a disc for time-to-collision (m): half its width, recognised by the class name's words \
                      as class_length_m: a pedestrian 0.25 m, a two-wheeler 0.35 m, a car 0.9 m, a bus or truck 1.275 m; a class that \
                      says nothing ('unknown') 1 m. Two road users are in contact when their centres come within the sum of their radii \
                      (conflicts() and top_conflicts() by default: traj_conflicts' radii; a 2 m disc put pedestrians 1.9 m apart in \
                      contact, TTC 0). Side by side that is contact; nose to tail the bodies meet while the centres are a length apart, \
                      so a rear-end TTC is later than the bumpers'. NULL for NULL.",
        example: "SELECT class_radius_m('pedestrian'); -- 0.25",
        maths: "crates/algo/src/associate/mod.rs",
        binding: file!(),
        section: Section::Classes,
        see_also: &["class_kind", "traj_ttc", "traj_conflicts"],
        signatures: &[Signature { params: &[CLASS], arities: &[], returns: Ty::Double, kernel: class_radius_m }],
        table: None,
    },
    Function {
        name: "pair_evidence",
        description: "The evidence of one candidate pair of tracks over their whole common time (docs/association.md, issue 38): from \
                      traj_msd_pairs's msd and mean offset (dx, dy), the camera pair's noise sigma_d (m, per axis), the independent samples \
                      n_eff and the bias state: r_res = (msd - dx² - dy²) / (2 sigma_d²) (the residual after removing the constant offset), \
                      r_gate = chi2(2 n_eff - 2) at 0.999 / (2 n_eff) + 0.25, d2 = the offset's squared Mahalanobis distance from the bias \
                      state with the offset's own variance sigma_d² / n_eff added, nll = n_eff r_res + d2 / 2, score = n_eff (r_gate - \
                      r_res) + (gate - d2) / 2 (Hungarian's weight) and candidate = r_res <= r_gate AND d2 <= gate, gate = 13.82 (chi2(2) at \
                      0.999) for bias_state_none and, for a state estimated from n anchors, Hotelling's predictive bound (n + 1) / n \
                      2 (n - 1) / (n - 2) F(2, n - 2) at 0.999 (70.9 for 8 anchors, 17.0 for 100: the state's own uncertainty). \
                      NULL when an argument is NULL.",
        example: "SELECT pair_evidence(1.02, 1.0, 0.0, 0.1, 100, bias_state_none(0.5)).candidate; -- true",
        maths: "crates/algo/src/associate/pair.rs",
        binding: file!(),
        section: Section::Association,
        see_also: &["traj_msd_pairs", "bias_state", "pair_clear_of", "hungarian_match"],
        signatures: &[Signature {
            params: &[
                pd("msd", Ty::Double, "the pair's mean squared distance over its common time (m²), traj_msd_pairs' msd"),
                pd("dx", Ty::Double, "its mean offset's x (m), traj_msd_pairs' dx"),
                pd("dy", Ty::Double, "its mean offset's y (m), traj_msd_pairs' dy"),
                SIGMA_D,
                pd("n_eff", Ty::Double, "the pair's independent samples (one per period of the slower camera); below 1 counts as 1"),
                STATE_ARG,
            ],
            arities: &[],
            returns: Ty::Struct(&[
                ("r_res", Ty::Double),
                ("r_gate", Ty::Double),
                ("d2", Ty::Double),
                ("nll", Ty::Double),
                ("score", Ty::Double),
                ("candidate", Ty::Boolean),
            ]),
            kernel: pair_evidence,
        }],
        table: None,
    },
    Function {
        name: "pair_clear_of",
        description: "The ratio test of a match against a rival candidate of either of its tracks (docs/association.md): true when the match \
                      (r_res, d2, n_eff of pair_evidence) is 10 times likelier than the rival (r_rival, d2_rival, n_rival): \
                      (r_rival - r_res) min(n_eff, n_rival) + (d2_rival - d2) / 2 >= ln 10. NULL when an argument is NULL.",
        example: "SELECT pair_clear_of(1.0, 1.0, 100, 1.1, 2.0, 100); -- true",
        maths: "crates/algo/src/associate/pair.rs",
        binding: file!(),
        section: Section::Association,
        see_also: &["pair_evidence"],
        signatures: &[Signature {
            params: &[
                pd("r_res", Ty::Double, "the match's r_res (pair_evidence)"),
                pd("d2", Ty::Double, "the match's d2 (pair_evidence)"),
                pd("n_eff", Ty::Double, "the match's independent samples"),
                pd("r_rival", Ty::Double, "the rival candidate's r_res"),
                pd("d2_rival", Ty::Double, "the rival's d2"),
                pd("n_rival", Ty::Double, "the rival's independent samples"),
            ],
            arities: &[],
            returns: Ty::Boolean,
            kernel: pair_clear_of,
        }],
        table: None,
    },
];

fn state_values(s: &BiasState) -> Vec<Value> {
    vec![Value::F64(s.mx), Value::F64(s.my), Value::F64(s.sxx), Value::F64(s.sxy), Value::F64(s.syy), Value::I64(s.n as i64)]
}

fn bias_state(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let offs = a.struct_list(0);
    let vals = a.map(|r| {
        let Some(c) = offs.get(r)? else { return Ok(None) };
        let (dx, dy, se2) = (c.f64(0), c.f64(1), c.f64(2));
        let v: Vec<Offset> = (0..c.len()).map(|k| Offset { dx: dx[k], dy: dy[k], se2: se2[k] }).collect();
        Ok(bias::bias_state(&v).map(|s| state_values(&s)))
    })?;
    out.structs(&vals);
    Ok(())
}

fn bias_state_between(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let states = a.struct_list(0);
    let vals = a.map(|r| {
        let Some(c) = states.get(r)? else { return Ok(None) };
        let (mx, my, sxx, sxy, syy, n) = (c.f64(0), c.f64(1), c.f64(2), c.f64(3), c.f64(4), c.i64(5));
        let v: Vec<BiasState> = (0..c.len()).map(|k| BiasState { mx: mx[k], my: my[k], sxx: sxx[k], sxy: sxy[k], syy: syy[k], n: n[k].max(0) as usize }).collect();
        Ok(crate::algo::associate::bias_between::bias_state_between(&v).map(|s| state_values(&s)))
    })?;
    out.structs(&vals);
    Ok(())
}

fn bias_fits(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (st, dx, dy, se2) = (a.structure(0), a.double(1), a.double(2), a.double(3));
    let vals = a.map(|r| {
        let (Some(s), Some(dx), Some(dy), Some(se2)) = (st.get(r)?, dx.get(r), dy.get(r), se2.get(r)) else { return Ok(None) };
        let state = BiasState { mx: s[0], my: s[1], sxx: s[2], sxy: s[3], syy: s[4], n: s[5].max(0.0) as usize };
        Ok(Some(state.d2(dx, dy, se2) <= state.gate()))
    })?;
    out.flat(&vals);
    Ok(())
}

fn bias_state_none(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let sd = a.double(0);
    let vals = a.map(|r| {
        let Some(sd) = sd.get(r) else { return Ok(None) };
        if !(sd.is_finite() && sd >= 0.0) {
            return Err(format!("sigma_d must be >= 0 and finite (m), got {sd}").into());
        }
        Ok(Some(state_values(&BiasState::none(sd))))
    })?;
    out.structs(&vals);
    Ok(())
}

fn pair_evidence(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (msd, dx, dy, sd, n, st) = (a.double(0), a.double(1), a.double(2), a.double(3), a.double(4), a.structure(5));
    let vals = a.map(|r| {
        let (Some(msd), Some(dx), Some(dy), Some(sd), Some(n), Some(s)) = (msd.get(r), dx.get(r), dy.get(r), sd.get(r), n.get(r), st.get(r)?) else {
            return Ok(None);
        };
        if !(sd.is_finite() && sd >= 0.0) {
            return Err(format!("sigma_d must be >= 0 and finite (m), got {sd}").into());
        }
        let state = BiasState { mx: s[0], my: s[1], sxx: s[2], sxy: s[3], syy: s[4], n: s[5].max(0.0) as usize };
        let e = pair::pair_evidence(msd, dx, dy, sd, n, &state);
        Ok(Some(vec![Value::F64(e.r_res), Value::F64(e.r_gate), Value::F64(e.d2), Value::F64(e.nll), Value::F64(e.score), Value::Bool(e.candidate)]))
    })?;
    out.structs(&vals);
    Ok(())
}

fn pair_clear_of(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let c: Vec<_> = (0..6).map(|k| a.double(k)).collect();
    let vals = a.map(|r| {
        let v: Option<Vec<f64>> = c.iter().map(|col| col.get(r)).collect();
        Ok(v.map(|v| pair::clear_of(v[0], v[1], v[2], v[3], v[4], v[5])))
    })?;
    out.flat(&vals);
    Ok(())
}

/// A DOUBLE of a class name (the road user's size by its kind), NULL for NULL.
fn by_class(a: &Args<'_>, out: &mut Out<'_>, f: fn(&str) -> f64) -> R {
    let c = a.text(0);
    let vals = a.map(|r| Ok(c.get(r).map(|c| f(&c))))?;
    out.flat(&vals);
    Ok(())
}

fn bias_search_m(a: &Args<'_>, out: &mut Out<'_>) -> R {
    by_class(a, out, crate::algo::associate::search_reach_m)
}

fn class_length_m(a: &Args<'_>, out: &mut Out<'_>) -> R {
    by_class(a, out, crate::algo::associate::class_length_m)
}

fn class_min_gap_m(a: &Args<'_>, out: &mut Out<'_>) -> R {
    by_class(a, out, crate::algo::associate::class_min_gap_m)
}

fn class_radius_m(a: &Args<'_>, out: &mut Out<'_>) -> R {
    by_class(a, out, crate::algo::associate::class_radius_m)
}

fn class_kind(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let c = a.text(0);
    let vals: Vec<Option<&str>> = a.map(|r| Ok(c.get(r).map(|c| crate::algo::associate::Kind::of(&c).name())))?;
    out.text(&vals);
    Ok(())
}
