//! SQL: camera alignment. Maths: `crates/algo/src/align/` (cpd.rs and cpd3.rs for `cpd_align`, rigid.rs
//! for the fit and the transforms, correspond.rs for `traj_correspond`).

use super::registry::{pd, Function, Param, Section, Signature, Ty, SERIES, TRAJ, TRANSFORM};
use super::vector::{Args, Column, Out, StructCol, Value};
use crate::algo::align::correspond::Pairs;
use crate::algo::align::cpd::{self, CpdParams};
use crate::algo::align::cpd3;
use crate::algo::align::rigid::{self, Transform2};
use crate::algo::align::shift::{self, ShiftGrid};
use crate::algo::align::shift_under;
use crate::algo::align::speed_lag;
use crate::algo::align::xcorr;
use std::error::Error;

type R = Result<(), Box<dyn Error>>;
const RIGID: &str = "crates/algo/src/align/rigid.rs";

const TRAJ3: Ty = Ty::List(&Ty::Struct(&[("t", Ty::Double), ("x", Ty::Double), ("y", Ty::Double), ("z", Ty::Double)]));
const PAIRS4: Ty = Ty::List(&Ty::Struct(&[("fx", Ty::Double), ("fy", Ty::Double), ("mx", Ty::Double), ("my", Ty::Double)]));
const PAIRS_ARG: Param = pd("pairs", PAIRS4, "point pairs: (fx, fy) in the fixed frame and (mx, my) in the moving frame (m), e.g. traj_correspond(...)");
const TF: Param =
    pd("tf", TRANSFORM, "a transform from the moving frame into the fixed one, p' = scale R(theta) p + (tx, ty): theta (rad), tx, ty (m), scale > 0");
const GAP_05: Param = pd("max_gap", Ty::Double, "no interpolation across a gap of the moving track longer than this (s), > 0; default 0.5");
const FIXED: Param = pd("fixed", TRAJ, "the fixed camera's track, sorted by t");
const MOVING: Param = pd("moving", TRAJ, "the moving camera's track of the same road user, sorted by t");
const FIXED_LIST: Param = pd("fixed", Ty::List(&TRAJ), "the fixed camera's tracks, one per track pair (e.g. list(a.traj))");
const MOVING_LIST: Param = pd("moving", Ty::List(&TRAJ), "the moving camera's tracks, one per track pair, in the order of fixed");
const CENTRE: Param = pd("centre", Ty::Double, "the middle of the clock offsets tried (s; the moving clock minus the fixed clock)");
const HALF_WIDTH: Param = pd("half_width", Ty::Double, "offsets are tried up to this far either side of centre (s), >= 0");
const STEP: Param = pd("step", Ty::Double, "the step between the offsets tried (s), > 0 (at most 100001 offsets)");
const SIGMA_FIXED: Param = pd("sigma_fixed", Ty::Double, "the fixed camera's position noise (m per axis), >= 0; default 0");
const SIGMA_MOVING: Param = pd("sigma_moving", Ty::Double, "the moving camera's position noise (m per axis), >= 0; default 0");
const TRIM_01: Param = pd("trim", Ty::Double, "the share of point pairs least trimmed squares leaves out, in [0, 1); default 0.1");
const DRIFT_OBS: Param = pd(
    "obs",
    Ty::List(&Ty::Struct(&[("x", Ty::Double), ("y", Ty::Double), ("w", Ty::Double)])),
    "one per track pair, in time order: its clock offset y (s) at time x (s), weight w = 1 / se^2 (finite, > 0)",
);

/// `(fixed, moving, w [, tau [, max_iter, tol [, with_scale, starts]]])` with `T` the point type.
macro_rules! cpd_params {
    ($t:expr) => {
        &[
            pd("fixed", $t, "the fixed camera's points {t (s), x, y (m)}, or {t, x, y, z} in 3-D: the frame the transform maps into"),
            pd("moving", $t, "the moving camera's points, of the same form: the transform maps them onto fixed"),
            pd("w", Ty::Double, "the outlier weight, in [0, 1)"),
            pd("tau", Ty::Double, "the time standard deviation (s), in [1e-100, 1e100] or 'inf'; default 'inf' (plain rigid CPD, time unused)"),
            pd("max_iter", Ty::Bigint, "the most EM iterations, 1 to 100000; default 100"),
            pd("tol", Ty::Double, "EM stops when its objective q changes by less than this, in [0, 1); default 1e-5"),
            pd("with_scale", Ty::Boolean, "true: estimate a scale too (a similarity transform); default false"),
            pd("starts", Ty::Bigint, "EM starts from this many rotations 2 pi k / starts, 1 to 360; default 8"),
        ]
    };
}
const CPD_PARAMS: &[Param] = cpd_params!(TRAJ);
const CPD3_PARAMS: &[Param] = cpd_params!(TRAJ3);
const CPD_ARITIES: &[usize] = &[3, 4, 6, 8];

const CPD_RESULT: Ty = Ty::Struct(&[
    ("theta", Ty::Double),
    ("tx", Ty::Double),
    ("ty", Ty::Double),
    ("scale", Ty::Double),
    ("r11", Ty::Double),
    ("r12", Ty::Double),
    ("r21", Ty::Double),
    ("r22", Ty::Double),
    ("sigma2", Ty::Double),
    ("iterations", Ty::Bigint),
    ("converged", Ty::Boolean),
    ("q", Ty::Double),
    ("log_likelihood", Ty::Double),
    ("inlier_fraction", Ty::Double),
    ("rms", Ty::Double),
    ("start_theta", Ty::Double),
    ("pairs_in_band", Ty::Bigint),
]);
const CPD3_RESULT: Ty = Ty::Struct(&[
    ("r11", Ty::Double),
    ("r12", Ty::Double),
    ("r13", Ty::Double),
    ("r21", Ty::Double),
    ("r22", Ty::Double),
    ("r23", Ty::Double),
    ("r31", Ty::Double),
    ("r32", Ty::Double),
    ("r33", Ty::Double),
    ("tx", Ty::Double),
    ("ty", Ty::Double),
    ("tz", Ty::Double),
    ("scale", Ty::Double),
    ("sigma2", Ty::Double),
    ("iterations", Ty::Bigint),
    ("converged", Ty::Boolean),
    ("q", Ty::Double),
    ("log_likelihood", Ty::Double),
    ("inlier_fraction", Ty::Double),
    ("rms", Ty::Double),
    ("pairs_in_band", Ty::Bigint),
]);

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "cpd_align",
        description: "Rigid TimeCPD (thesis eq. 2.7/2.8, Alg. 5-8): the transform p_fixed = scale*R(theta)*p_moving + (tx, ty) that best explains the \
                      fixed points (x, y, t) as noisy copies of the moving ones, with outlier weight w in [0, 1) and time standard deviation tau (s). \
                      Without tau, or tau = 'inf', it is plain rigid CPD (Myronenko & Song); a NULL tau gives NULL like any NULL argument. \
                      The E-step only visits pairs with |t - s| <= 7.43*tau (time weight < 1e-12) and runs on all cores. \
                      Defaults: max_iter 100, tol 1e-5, with_scale false, starts 8 (EM from 8 rotations 2*pi*k/8, the best log-likelihood after 15 \
                      iterations continues; starts = 1 is the thesis's R = I start). converged = false when max_iter ran out (the estimate is still returned); converged = true also when sigma² falls to 1e-16 of its \
                      first value (noise-free points: the fit is exact). Limits: max_iter <= 100000, tau in [1e-100, 1e100] s, |x|, |y|, |z|, |t| <= 1e150. \
                      Errors: no pair of points within 7.43*tau in time (the sets do not overlap), every point an outlier. \
                      With STRUCT(t, x, y, z)[] inputs it runs in 3-D (rotation from the SVD of the 3x3 cross-covariance; starts rotate about z).",
        example: "SELECT round(degrees(cpd_align(a, b, 0.0, 1.0).theta)) FROM (SELECT [{'t':0,'x':0,'y':0},{'t':1,'x':4,'y':0},{'t':2,'x':4,'y':3}] AS a, [{'t':0,'x':0,'y':0},{'t':1,'x':0,'y':-4},{'t':2,'x':3,'y':-4}] AS b); -- 90.0",
        maths: "crates/algo/src/align/cpd.rs, crates/algo/src/align/cpd3.rs",
        binding: file!(),
        section: Section::Alignment,
        see_also: &["rigid_fit", "register_pair", "transform_apply"],
        signatures: &[
            Signature { params: CPD_PARAMS, arities: CPD_ARITIES, returns: CPD_RESULT, kernel: cpd_align },
            Signature { params: CPD3_PARAMS, arities: CPD_ARITIES, returns: CPD3_RESULT, kernel: cpd_align3 },
        ],
        table: None,
    },
    Function {
        name: "rigid_fit",
        description: "Least-squares transform from known correspondences (Umeyama/Kabsch; closed form in 2-D): p_fixed = scale*R(theta)*p_moving + (tx, ty) \
                      for pairs (fx, fy) <- (mx, my). With trim in [0, 1), least trimmed squares: refit on the best (1 - trim) share of pairs until the kept \
                      set is stable (robust to wrong correspondences). Needs 2 pairs that are not all at one point; otherwise an error.",
        example: "SELECT round(degrees(rigid_fit([{'fx':0,'fy':0,'mx':0,'my':0},{'fx':0,'fy':1,'mx':1,'my':0}]).theta)); -- 90.0",
        maths: RIGID,
        binding: file!(),
        section: Section::Alignment,
        see_also: &["traj_correspond", "rigid_rms", "rigid_fit_scan", "cpd_align"],
        signatures: &[Signature {
            params: &[
                PAIRS_ARG,
                pd("trim", Ty::Double, "the share of pairs least trimmed squares leaves out, in [0, 1); default 0 (plain least squares)"),
                pd("with_scale", Ty::Boolean, "true: fit a scale too (a similarity transform); default false (rigid)"),
            ],
            arities: &[1, 2, 3],
            returns: Ty::Struct(&[
                ("theta", Ty::Double),
                ("tx", Ty::Double),
                ("ty", Ty::Double),
                ("scale", Ty::Double),
                ("rms", Ty::Double),
                ("inliers", Ty::Bigint),
                ("n", Ty::Bigint),
            ]),
            kernel: rigid_fit,
        }],
        table: None,
    },
    Function {
        name: "rigid_rms",
        description: "Root mean square of |(fx, fy) - tf(mx, my)| over the pairs: how well a transform explains point pairs (e.g. one track pair's \
                      traj_correspond under a camera pair's fit). NULL for an empty list.",
        example: "SELECT rigid_rms([{'fx': 1, 'fy': 0, 'mx': 0, 'my': 0}], {'theta': 0, 'tx': 0, 'ty': 0, 'scale': 1}); -- 1.0",
        maths: RIGID,
        binding: file!(),
        section: Section::Alignment,
        see_also: &["rigid_fit", "traj_correspond"],
        signatures: &[Signature { params: &[PAIRS_ARG, TF], arities: &[], returns: Ty::Double, kernel: rigid_rms }],
        table: None,
    },
    Function {
        name: "traj_correspond",
        description: "Point pairs for rigid_fit from two tracks of (presumably) the same road user in two cameras with synchronised clocks: for each \
                      fixed point inside the moving track's time span, the moving track interpolated linearly at that time (not across gaps longer \
                      than max_gap seconds, default 0.5). rigid_fit(traj_correspond(a, b)) is one transform hypothesis, found in closed form, with no \
                      initial rotation needed. With shift (s, the moving clock minus the fixed clock; default 0) the moving times are read as t - shift. O(n + m).",
        example: "SELECT traj_correspond([{'t':1,'x':0,'y':0}], [{'t':0,'x':0,'y':0},{'t':2,'x':4,'y':2}], 3.0); -- [{'fx': 0.0, 'fy': 0.0, 'mx': 2.0, 'my': 1.0}]",
        maths: "crates/algo/src/align/correspond.rs",
        binding: file!(),
        section: Section::Alignment,
        see_also: &["rigid_fit", "rigid_fit_scan", "traj_msd_pairs"],
        signatures: &[Signature {
            params: &[
                FIXED,
                MOVING,
                GAP_05,
                pd("shift", Ty::Double, "the moving clock minus the fixed clock (s): the moving times are read as t - shift; default 0"),
            ],
            arities: &[2, 3, 4],
            returns: PAIRS4,
            kernel: traj_correspond,
        }],
        table: None,
    },
    Function {
        name: "traj_msd_pairs",
        description: "Mean squared distance of many track pairs over their common time, in one call: for each (a, b) of pairs (ids from ids_a \
                      and ids_b), n_common = the point pairs of traj_correspond(trajs_a[a], trajs_b[b], max_gap) and msd = the mean of their \
                      squared distances (m², NULL when n_common = 0), bit for bit list_avg([(c.fx - c.mx) ** 2 + (c.fy - c.my) ** 2 FOR c \
                      IN traj_correspond(...)]) without building the list, and the mean offset (dx, dy) = the mean of (fx - mx, fy - my) \
                      (m; NULL when n_common = 0: the constant offset of two cameras' views of one road user). One element per pair, in the order of pairs. The tracks are \
                      read in place and the pairs run in parallel: no trajectory is copied per pair (sql/stages/merge.sql weighs its \
                      candidates with it). O(n + m) a pair. Errors: ids and trajs lists of different lengths, duplicate ids on one \
                      side, a pair naming an id not in its side, max_gap <= 0.",
        example: "SELECT traj_msd_pairs([1], [[{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0}]], [2], [[{'t':0,'x':0,'y':1},{'t':1,'x':1,'y':1}]], [{'a': 1, 'b': 2}], 0.5); -- [{'a': 1, 'b': 2, 'n_common': 2, 'msd': 1.0, 'dx': 0.0, 'dy': -1.0}]",
        maths: "crates/algo/src/align/msd.rs",
        binding: file!(),
        section: Section::Association,
        see_also: &["traj_correspond", "pair_evidence", "lcss_similarity_pairs"],
        signatures: &[Signature {
            params: super::common::two_sets_params!(
                pd("pairs", Ty::List(&Ty::Struct(&[("a", Ty::Bigint), ("b", Ty::Bigint)])), "the track pairs to measure: a an id of ids_a, b an id of ids_b"),
                pd("max_gap", Ty::Double, "no interpolation across a gap of trajs_b's track longer than this (s), > 0")
            ),
            arities: &[],
            returns: Ty::List(&Ty::Struct(&[
                ("a", Ty::Bigint),
                ("b", Ty::Bigint),
                ("n_common", Ty::Bigint),
                ("msd", Ty::Double),
                ("dx", Ty::Double),
                ("dy", Ty::Double),
            ])),
            kernel: traj_msd_pairs,
        }],
        table: None,
    },
    Function {
        name: "rigid_fit_scan",
        description: "Clock offset hypotheses of one track pair: rigid_fit(traj_correspond(fixed, moving, max_gap, dt)) at every dt = -max_shift, \
                      -max_shift + step, ..., max_shift (dt: moving clock minus fixed clock). A straight track fits at every dt (the translation slides \
                      along the road); a turning one only near its true offset. Voting over (theta, tx, ty, dt) across many track pairs finds the \
                      offset and the transform together. Shifts with fewer than 2 pairs are left out; span is the larger side of the bounding box of \
                      the moving points paired. O(S (n + m)) for S shifts (at most 100001).",
        example: "SELECT len(rigid_fit_scan([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0},{'t':2,'x':2,'y':1}], [{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0},{'t':2,'x':2,'y':1}], 1.0, 0.5)); -- 3",
        maths: "crates/algo/src/align/shift.rs",
        binding: file!(),
        section: Section::Clocks,
        see_also: &["rigid_fit", "traj_correspond", "activity_lag", "rigid_fit_shifted"],
        signatures: &[Signature {
            params: &[
                FIXED,
                MOVING,
                pd("max_shift", Ty::Double, "the clock offsets tried run from -max_shift to max_shift (s; moving clock minus fixed clock), >= 0"),
                STEP,
                GAP_05,
            ],
            arities: &[4, 5],
            returns: Ty::List(&Ty::Struct(&[
                ("dt", Ty::Double),
                ("theta", Ty::Double),
                ("tx", Ty::Double),
                ("ty", Ty::Double),
                ("rms", Ty::Double),
                ("n", Ty::Bigint),
                ("span", Ty::Double),
            ])),
            kernel: rigid_fit_scan,
        }],
        table: None,
    },
    Function {
        name: "rigid_fit_shifted",
        description: "The clock offset and transform that fit many track pairs of one camera pair best together: at every dt = centre + k step, \
                      |k step| <= half_width, all pairs traj_correspond(fixed[i], moving[i], max_gap, dt) are fitted together by least trimmed squares \
                      (trim, default 0.1); the dt with the least trimmed RMS is refined by a parabola through its neighbours. Tracks in two or more \
                      directions separate the offset from a translation along the road. With the cameras' position noise (sigma_fixed, \
                      sigma_moving, m) each squared residual is weighted so that pairs interpolated between two samples count as much as \
                      exact ones (otherwise the phase half-way between samples looks best). NULL when no shift gives 2 pairs. \
                      Aggregate with list(): rigid_fit_shifted(list(a.traj), list(b.traj), 0.3, 0.05, 0.005).",
        example: "SELECT rigid_fit_shifted([[{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0},{'t':2,'x':1,'y':1}]], [[{'t':0.5,'x':0,'y':0},{'t':1.5,'x':1,'y':0},{'t':2.5,'x':1,'y':1}]], 0.5, 0.1, 0.1, 1.0, 0.0).dt; -- 0.5",
        maths: "crates/algo/src/align/shift.rs",
        binding: file!(),
        section: Section::Clocks,
        see_also: &["rigid_fit_scan", "register_pair", "rigid_shift_under"],
        signatures: &[Signature {
            params: &[
                FIXED_LIST,
                MOVING_LIST,
                CENTRE,
                HALF_WIDTH,
                STEP,
                GAP_05,
                TRIM_01,
                SIGMA_FIXED,
                SIGMA_MOVING,
            ],
            arities: &[5, 6, 7, 9],
            returns: Ty::Struct(&[
                ("dt", Ty::Double),
                ("theta", Ty::Double),
                ("tx", Ty::Double),
                ("ty", Ty::Double),
                ("scale", Ty::Double),
                ("rms", Ty::Double),
                ("n", Ty::Bigint),
            ]),
            kernel: rigid_fit_shifted,
        }],
        table: None,
    },
    Function {
        name: "activity_lag",
        description: "The coarse clock offset of two cameras from their activity alone, over every lag the recordings allow (no search range): \
                      each camera's events (t, v) add v from time t on (align.sql: +1 where a track starts, -1 where it ends, so the activity is \
                      the number of tracks in view); both step functions are binned at bin_s from their OWN first event (so shifting one clock \
                      moves dt by exactly that), their means removed, and cross-correlated by FFT. dt = b's clock minus a's clock at the \
                      normalised peak score (refined by a parabola); runner_up is the best correlation outside the peak's main lobe (where it \
                      is above half the peak) and half_width_s half that lobe's width. Coarse by nature (a few seconds where traffic drives \
                      mostly one way between the views): rigid_fit_scan searches around it. NULL when either series is empty or constant. \
                      Events must be sorted by t. O(n log n) for n bins; the memory_bytes limit applies.",
        example: "SELECT round(activity_lag([{'t':0,'v':1},{'t':5,'v':-1},{'t':9,'v':1},{'t':12,'v':-1}], [{'t':100,'v':1},{'t':105,'v':-1},{'t':109,'v':1},{'t':112,'v':-1}], 0.5).dt, 3); -- 100.0",
        maths: "crates/algo/src/align/xcorr.rs",
        binding: file!(),
        section: Section::Clocks,
        see_also: &["speed_lag", "rigid_fit_scan"],
        signatures: &[Signature {
            params: &[
                pd("a", SERIES, "camera a's events {t (s), v}, sorted by t: v is added to its activity from t on (+1 where a track starts, -1 where it ends)"),
                pd("b", SERIES, "camera b's events, in the same form on b's own clock"),
                pd("bin_s", Ty::Double, "the bin width of the activity (s), > 0"),
            ],
            arities: &[],
            returns: Ty::Struct(&[("dt", Ty::Double), ("score", Ty::Double), ("runner_up", Ty::Double), ("half_width_s", Ty::Double)]),
            kernel: activity_lag,
        }],
        table: None,
    },
    Function {
        name: "register_pair",
        description: "The final registration of one camera pair when the cameras see different points of a road user (docs/alignment.md, \
                      issue 38): model fixed = s R moving + T + b_k + noise, b_k a constant offset per track pair k (a viewpoint bias) drawn \
                      per class. Rotation and scale come from each pair's points centred on the pair's own means (least trimmed squares, \
                      trim), so a constant offset drops out; the scale is used only when |ln s| > 5 jackknife standard errors (16 \
                      consecutive blocks of pairs), else scale = 1. The translation is the mean of the pairs' offsets weighted by \
                      1 / (tau_c² + the variance of the pair's mean), tau_c the robust spread of class c's offsets, refitted without \
                      the pairs beyond chi2(2) at 0.999, per class; the classes' means combined by a random-effects meta-analysis whose \
                      between-class variance scales with (class_length / 2)² (class_lengths: one per pair, m, e.g. class_length_m(class); \
                      default all alike), so a class seen off by one camera moves the translation by its share of the classes' extents, \
                      not by half. class_codes: one integer per pair (its class; only equality counts). Every \
                      parameter has a standard error (se_*). The clock offset: dt as given (rigid_fit_shifted's; se_dt NULL) or, with \
                      max_shift and step, the minimum over dt ± max_shift (grid of step) of the same model's objective with each class \
                      its own mean offset (crates/algo/src/align/register_clock.rs: a time shift is seen within pairs that turn or change \
                      speed and in the classes whose offsets scatter little, and one class seen off by one camera does not move it), its \
                      jackknife se_dt, and dt_at_edge when the minimum is on the grid's edge; the given dt stands unless the model's differs \
                      by more than 3 se_dt (Hausman's rule; dt_moved says which). NULL when fewer than 2 pairs have 3 point pairs. perspective_hx, perspective_hy \
                      (1/m, the moving camera's axes): the perspective term between the two ground planes, f (1 + h.(m - m0)) = A m + t + b_k, \
                      fitted within pairs (crates/algo/src/align/perspective.rs) and NOT applied; perspective_se: the standard error of |h| \
                      (jackknife or least squares, the larger); perspective_chi2: the Wald statistic; perspective_significant: chi2 over the \
                      chi2(2) quantile of 5 sigma (28.74); all NULL when the points do not fix it. sigma_fixed, sigma_moving: the cameras' position noise (m), whose ratio Deming's scale needs (the \
                      least-squares scale is diluted by the moving view's noise); default 0 and 0: the symmetric fit. Aggregate with list(), \
                      in the order of the recording.",
        example: "SELECT round(register_pair([[{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0},{'t':2,'x':2,'y':1}], [{'t':0,'x':5,'y':5},{'t':1,'x':5,'y':6},{'t':2,'x':6,'y':8}]], [[{'t':0,'x':1,'y':0},{'t':1,'x':2,'y':0},{'t':2,'x':3,'y':1}], [{'t':0,'x':6,'y':5},{'t':1,'x':6,'y':6},{'t':2,'x':7,'y':8}]], [1, 1], 0.0).tx, 6); -- -1.0",
        maths: "crates/algo/src/align/register.rs",
        binding: file!(),
        section: Section::Alignment,
        see_also: &["rigid_fit_shifted", "class_length_m", "frame_change"],
        signatures: &[Signature {
            params: &[
                FIXED_LIST,
                MOVING_LIST,
                pd("class_codes", Ty::List(&Ty::Bigint), "one integer per track pair: its class (only equality counts)"),
                pd("dt", Ty::Double, "the clock offset (s; the moving clock minus the fixed clock), e.g. rigid_fit_shifted's dt"),
                GAP_05,
                TRIM_01,
                SIGMA_FIXED,
                SIGMA_MOVING,
                pd("max_shift", Ty::Double, "with step: the clock offset is searched over dt +- max_shift (s), >= 0; default: dt as given"),
                pd("step", Ty::Double, "the grid step of that search (s), > 0"),
                pd("class_lengths", Ty::List(&Ty::Double), "one road-user length per track pair (m), in (0, 10000], the same within a class, e.g. class_length_m(class); default: all classes alike"),
            ],
            arities: &[4, 5, 6, 8, 10, 11],
            returns: Ty::Struct(&[
                ("dt", Ty::Double),
                ("se_dt", Ty::Double),
                ("dt_at_edge", Ty::Boolean),
                ("dt_moved", Ty::Boolean),
                ("theta", Ty::Double),
                ("tx", Ty::Double),
                ("ty", Ty::Double),
                ("scale", Ty::Double),
                ("scale_fit", Ty::Double),
                ("se_theta", Ty::Double),
                ("se_tx", Ty::Double),
                ("se_ty", Ty::Double),
                ("se_scale", Ty::Double),
                ("scale_significant", Ty::Boolean),
                ("pairs_used", Ty::Bigint),
                ("pairs", Ty::Bigint),
                ("rms", Ty::Double),
                ("tau_max", Ty::Double),
                ("perspective_hx", Ty::Double),
                ("perspective_hy", Ty::Double),
                ("perspective_se", Ty::Double),
                ("perspective_chi2", Ty::Double),
                ("perspective_significant", Ty::Boolean),
            ]),
            kernel: register_pair,
        }],
        table: None,
    },
    Function {
        name: "rigid_shift_under",
        description: "The clock offset of ONE track pair under a KNOWN transform tf (moving frame into fixed frame): the dt (moving clock minus \
                      fixed clock) on the grid centre + k step, |k step| <= half_width, that minimises the mean squared distance between the \
                      fixed points and the transformed moving track interpolated at t + dt (gaps over max_gap, default 0.5 s, not bridged), \
                      refined by a parabola. With the transform known even a straight track pins its offset. rms and n are those of the best \
                      grid shift; se is the offset's standard error from the curvature (infinite when flat); at_edge: the minimum is on the \
                      grid's edge. Shifts pairing fewer than min_pairs (default 10) points are not compared. NULL when none pairs enough. \
                      align.sql measures clock drift from these offsets over the recording. O(S (n + m)) for S shifts.",
        example: "SELECT round(rigid_shift_under([{'t':0,'x':0,'y':0},{'t':1,'x':1,'y':0},{'t':2,'x':2,'y':0},{'t':3,'x':3,'y':0}], [{'t':0.5,'x':0,'y':0},{'t':1.5,'x':1,'y':0},{'t':2.5,'x':2,'y':0},{'t':3.5,'x':3,'y':0}], {'theta':0,'tx':0,'ty':0,'scale':1}, 0.5, 0.2, 0.1, 2.0, 2).dt, 3); -- 0.5",
        maths: "crates/algo/src/align/shift_under.rs",
        binding: file!(),
        section: Section::Clocks,
        see_also: &["rigid_fit_shifted", "clock_drift_fit"],
        signatures: &[Signature {
            params: &[
                FIXED,
                MOVING,
                TF,
                CENTRE,
                HALF_WIDTH,
                STEP,
                GAP_05,
                pd("min_pairs", Ty::Bigint, "offsets pairing fewer points than this are not compared, >= 2; default 10"),
            ],
            arities: &[6, 7, 8],
            returns: Ty::Struct(&[("dt", Ty::Double), ("rms", Ty::Double), ("n", Ty::Bigint), ("se", Ty::Double), ("at_edge", Ty::Boolean)]),
            kernel: rigid_shift_under,
        }],
        table: None,
    },
    Function {
        name: "camera_twin",
        description: "Is one camera the other exported twice (under another id)? From counts the caller's join makes: points_a and points_b, each \
                      camera's points that fill a 0.1 mm cell of its own frame alone, and shared, the most of them that fall in the same cell as \
                      a point of the other camera at ONE time difference (0 for a plain copy, a constant for a copy with a shifted clock). share = \
                      shared / min(points_a, points_b); twin when share >= min_share (default 0.5: real camera pairs measure 0, a copy 1); copy = \
                      the camera to drop: 1 (a) or 2 (b), the one with fewer points (b on a tie); 0 when not a twin. sql/pipeline.sql drops the \
                      copy's points after the load and warns, naming both cameras. Detects identical, subset and clock-shifted copies; not a \
                      copy whose frame was moved or with noise added. Errors: min_share outside (0, 1], a negative count, shared larger than \
                      the smaller count. O(1).",
        example: "SELECT camera_twin(1000, 1000, 1000); -- {'share': 1.0, 'twin': true, 'copy': 2}",
        maths: "crates/algo/src/align/twin.rs",
        binding: file!(),
        section: Section::Alignment,
        see_also: &["register_pair"],
        signatures: &[Signature {
            params: &[
                pd("points_a", Ty::Bigint, "camera a's points that fill a 0.1 mm cell of its own frame alone, >= 0"),
                pd("points_b", Ty::Bigint, "camera b's points counted the same way, >= 0"),
                pd("shared", Ty::Bigint, "the most of them that fall in the same cell as a point of the other camera at one time difference, >= 0, at most the smaller count"),
                pd("min_share", Ty::Double, "the share shared / min(points_a, points_b) that makes a twin, in (0, 1]; default 0.5"),
            ],
            arities: &[3, 4],
            returns: Ty::Struct(&[("share", Ty::Double), ("twin", Ty::Boolean), ("copy", Ty::Bigint)]),
            kernel: camera_twin_fn,
        }],
        table: None,
    },
    Function {
        name: "speed_lag",
        description: "The clock offset of one track pair from their speed profiles alone (speed does not depend on either camera's frame): \
                      for every lag on the grid centre + k step, |k step| <= half_width, the Pearson correlation of a's speed (central \
                      difference over 1 s, sampled every 0.25 s) with b's speed at t + lag; lag (b's clock minus a's), corr and the samples \
                      compared (n) at the best lag. A pair whose speed hardly changes has no clear peak. NULL when no lag compares \
                      min_samples (default 8) speeds with variance on both sides. align.sql votes these lags over many pairs where \
                      activity_lag's coarse offset was too far off. O(n + m + S n) for S lags.",
        example: "SELECT speed_lag([{'t':0,'x':0,'y':0},{'t':2,'x':0,'y':0},{'t':4,'x':4,'y':0},{'t':6,'x':12,'y':0}], [{'t':10,'x':0,'y':0},{'t':12,'x':0,'y':0},{'t':14,'x':0,'y':4},{'t':16,'x':0,'y':12}], 10, 1, 0.5, 3).lag; -- 10.0",
        maths: "crates/algo/src/align/speed_lag.rs",
        binding: file!(),
        section: Section::Clocks,
        see_also: &["activity_lag", "traj_speeds"],
        signatures: &[Signature {
            params: &[
                pd("a", TRAJ, "camera a's track of the road user, sorted by t"),
                pd("b", TRAJ, "camera b's track of the same road user, on b's clock"),
                pd("centre", Ty::Double, "the middle of the lags tried (s; b's clock minus a's)"),
                pd("half_width", Ty::Double, "lags are tried up to this far either side of centre (s), >= 0"),
                pd("step", Ty::Double, "the step between the lags tried (s), > 0"),
                pd("min_samples", Ty::Bigint, "the least speeds a lag must compare, >= 3; default 8"),
            ],
            arities: &[5, 6],
            returns: Ty::Struct(&[("lag", Ty::Double), ("corr", Ty::Double), ("n", Ty::Bigint)]),
            kernel: speed_lag_fn,
        }],
        table: None,
    },
    Function {
        name: "transform_apply",
        description: "Maps every point of the trajectory with p' = scale*R(theta)*p + (tx, ty); t is unchanged. Use it to bring a camera's tracks into the fixed frame.",
        example: "SELECT transform_apply([{'t':0,'x':1,'y':0}], {'theta': pi()/2, 'tx': 10, 'ty': 0, 'scale': 1})[1].x; -- 10.0",
        maths: RIGID,
        binding: file!(),
        section: Section::Alignment,
        see_also: &["transform_point", "transform_compose", "transform_invert"],
        signatures: &[Signature {
            params: &[pd("traj", TRAJ, "the trajectory to map (t unchanged)"), TF],
            arities: &[],
            returns: TRAJ,
            kernel: transform_apply,
        }],
        table: None,
    },
    Function {
        name: "transform_point",
        description: "One point mapped with p' = scale*R(theta)*p + (tx, ty), for point tables: transform_point(f.to_reference, p.x, p.y).x. \
                      NaN or infinite x/y is an error.",
        example: "SELECT transform_point({'theta': 0, 'tx': 10, 'ty': -1, 'scale': 2}, 1, 0); -- {'x': 12.0, 'y': -1.0}",
        maths: RIGID,
        binding: file!(),
        section: Section::Alignment,
        see_also: &["transform_apply", "transform_invert"],
        signatures: &[Signature {
            params: &[TF, pd("x", Ty::Double, "the point's x (m), finite"), pd("y", Ty::Double, "the point's y (m), finite")],
            arities: &[],
            returns: Ty::Struct(&[("x", Ty::Double), ("y", Ty::Double)]),
            kernel: transform_point,
        }],
        table: None,
    },
    Function {
        name: "transform_compose",
        description: "a after b: transform_apply(p, transform_compose(a, b)) = transform_apply(transform_apply(p, b), a). To chain camera k -> l -> ref use \
                      transform_compose(l_to_ref, k_to_l). theta is wrapped to (-pi, pi].",
        example: "SELECT transform_compose({'theta': 0, 'tx': 1, 'ty': 0, 'scale': 1}, {'theta': 0, 'tx': 0, 'ty': 2, 'scale': 1}); -- {'theta': 0.0, 'tx': 1.0, 'ty': 2.0, 'scale': 1.0}",
        maths: RIGID,
        binding: file!(),
        section: Section::Alignment,
        see_also: &["transform_invert", "transform_apply"],
        signatures: &[Signature {
            params: &[
                pd("a", TRANSFORM, "the transform applied second: theta (rad), tx, ty (m), scale > 0"),
                pd("b", TRANSFORM, "the transform applied first: theta (rad), tx, ty (m), scale > 0"),
            ],
            arities: &[],
            returns: TRANSFORM,
            kernel: transform_compose,
        }],
        table: None,
    },
    Function {
        name: "transform_invert",
        description: "The inverse transform (fixed frame back to moving frame); transform_compose(tf, transform_invert(tf)) is the identity.",
        example: "SELECT transform_invert({'theta': 0, 'tx': 3, 'ty': -1, 'scale': 2}); -- {'theta': -0.0, 'tx': -1.5, 'ty': 0.5, 'scale': 0.5}",
        maths: RIGID,
        binding: file!(),
        section: Section::Alignment,
        see_also: &["transform_compose", "transform_apply"],
        signatures: &[Signature { params: &[TF], arities: &[], returns: TRANSFORM, kernel: transform_invert }],
        table: None,
    },
    Function {
        name: "transform_identity",
        description: "The identity transform {'theta': 0, 'tx': 0, 'ty': 0, 'scale': 1}: a camera's transform into its own frame \
                      (the reference camera's, and a camera that no camera pair placed). O(1).",
        example: "SELECT transform_identity(); -- {'theta': 0.0, 'tx': 0.0, 'ty': 0.0, 'scale': 1.0}",
        maths: RIGID,
        binding: file!(),
        section: Section::Alignment,
        see_also: &["transform_compose", "transform_invert"],
        signatures: &[Signature { params: &[], arities: &[], returns: TRANSFORM, kernel: transform_identity }],
        table: None,
    },
    Function {
        name: "angle_wrap_deg",
        description: "An angle, or the difference of two, in degrees wrapped to [-180, 180): ((a + 540) % 360) - 180 (align.sql's \
                      agreement of two rotations, the score's rotation error), also right below -540. NULL for NULL; an error for a \
                      value that is not finite or beyond +-1e15 degrees. O(1).",
        example: "SELECT [angle_wrap_deg(350.0), angle_wrap_deg(-190.0)]; -- [-10.0, 170.0]",
        maths: RIGID,
        binding: file!(),
        section: Section::Alignment,
        see_also: &["transform_compose"],
        signatures: &[Signature { params: &[pd("a", Ty::Double, "an angle in degrees")], arities: &[], returns: Ty::Double, kernel: angle_wrap_deg }],
        table: None,
    },
    Function {
        name: "clock_network",
        description: "One value per camera from every camera pair's measurement of their difference (align.sql's clock drift; \
                      crates/algo/src/align/clock_network.rs): each pair says value ≈ x[moving] - x[fixed] with standard error se; with \
                      x[reference] = 0 the cameras' values are the weighted least-squares solution over the pairs' graph, each with its \
                      standard error (scaled by the pairs' reduced chi-square when above 1). Also per row, for the whole network: chi2 \
                      (the pairs' weighted residuals), dof (pairs - unknowns), t2 (the values' chi-square against 0) and shown (t2 above \
                      the chi-square bound at the two-sided 5-sigma level: the recording shows drift). A group of cameras not joined to the \
                      reference is anchored at its own smallest camera id (only differences are measured); NULL for no pair. A non-finite \
                      value, an se <= 0 or a pair of a camera with itself is an error naming the pair; more than 1000 cameras an error. \
                      O(E log C + C³).",
        example: "SELECT [round(c.value, 1) FOR c IN clock_network([{'fixed': 0, 'moving': 1, 'value': 100.0, 'se': 10.0}, {'fixed': 1, 'moving': 2, 'value': -40.0, 'se': 10.0}, {'fixed': 0, 'moving': 2, 'value': 60.0, 'se': 10.0}], 0)]; -- [0.0, 100.0, 60.0]",
        maths: "crates/algo/src/align/clock_network.rs",
        binding: file!(),
        section: Section::Clocks,
        see_also: &["clock_drift_fit", "clock_offset_se"],
        signatures: &[Signature {
            params: &[
                pd(
                    "pairs",
                    Ty::List(&Ty::Struct(&[("fixed", Ty::Bigint), ("moving", Ty::Bigint), ("value", Ty::Double), ("se", Ty::Double)])),
                    "one measurement per camera pair: value ~ x[moving] - x[fixed] (finite) with its standard error se > 0; fixed and moving are camera ids",
                ),
                pd("reference", Ty::Bigint, "the camera whose value is 0"),
            ],
            arities: &[],
            returns: Ty::List(&Ty::Struct(&[
                ("camera", Ty::Bigint),
                ("value", Ty::Double),
                ("se", Ty::Double),
                ("chi2", Ty::Double),
                ("dof", Ty::Bigint),
                ("t2", Ty::Double),
                ("shown", Ty::Boolean),
            ])),
            kernel: clock_network,
        }],
        table: None,
    },
    Function {
        name: "clock_drift_fit",
        description: "A camera pair's clock drift D from its candidate track pairs' own clock offsets (align.sql step 3b; \
                      crates/algo/src/align/drift_fit.rs): y ≈ a + D x by weighted least squares (weight w = 1 / se²), refitted \
                      without the pairs beyond 3 robust standard deviations (1.4826 · median |z|) of the first fit; the drift's \
                      standard error is the larger of least squares' and the delete-a-block jackknife's over 8 blocks of the pairs in \
                      the order given (pass them in time order; infinite with fewer than 4 blocks). One element per observation, in \
                      the order given: kept (by the outlier test), z (its standardised residual about the first fit), and the fit of \
                      the kept pairs repeated (n, x_span, slope, intercept, se, se_ls, se_jk, sw, swx, swy: the weighted sums, for \
                      the intercept under another slope), usable (at least 8 kept pairs and a finite se > 0: the camera network \
                      may use the drift). NULL when no fit is defined (no observation, or all at one time). A \
                      non-finite x or y, or a w that is not finite and > 0, is an error naming the observation. O(n log n).",
        example: "SELECT round(f[1].slope * 1e6) FROM (SELECT clock_drift_fit([{'x': i * 10.0, 'y': 0.5 + 2e-4 * i * 10.0, 'w': 1e4} FOR i IN range(20)]) AS f); -- 200.0",
        maths: "crates/algo/src/align/drift_fit.rs",
        binding: file!(),
        section: Section::Clocks,
        see_also: &["clock_offset_se", "clock_network", "rigid_shift_under"],
        signatures: &[Signature {
            params: &[DRIFT_OBS],
            arities: &[],
            returns: Ty::List(&Ty::Struct(&[
                ("kept", Ty::Boolean),
                ("z", Ty::Double),
                ("n", Ty::Bigint),
                ("x_span", Ty::Double),
                ("slope", Ty::Double),
                ("intercept", Ty::Double),
                ("se", Ty::Double),
                ("se_ls", Ty::Double),
                ("se_jk", Ty::Double),
                ("sw", Ty::Double),
                ("swx", Ty::Double),
                ("swy", Ty::Double),
                ("usable", Ty::Boolean),
            ])),
            kernel: clock_drift_fit,
        }],
        table: None,
    },
    Function {
        name: "clock_offset_se",
        description: "The standard error of a camera pair's clock offset (align.sql; crates/algo/src/align/drift_fit.rs): with the \
                      drift removed (y - drift · x), the offset is the weighted mean of the pairs' own offsets, and its standard error \
                      the larger of the mean's (1 / sqrt(sum of w)) and the delete-a-block jackknife's over 8 blocks of the pairs in \
                      the order given (pass them in time order). blocks: the blocks used; se NULL with fewer than 4. NULL for a NULL \
                      argument; a bad observation is an error naming it. O(n).",
        example: "SELECT clock_offset_se([{'x': i * 10.0, 'y': 0.5, 'w': 1e4} FOR i IN range(16)], 0.0).blocks; -- 8",
        maths: "crates/algo/src/align/drift_fit.rs",
        binding: file!(),
        section: Section::Clocks,
        see_also: &["clock_drift_fit", "clock_network"],
        signatures: &[Signature {
            params: &[DRIFT_OBS, pd("drift", Ty::Double, "the camera pair's clock drift (s per s), removed as y - drift x")],
            arities: &[],
            returns: Ty::Struct(&[("blocks", Ty::Bigint), ("se", Ty::Double)]),
            kernel: clock_offset_se,
        }],
        table: None,
    },
    Function {
        name: "frame_change",
        description: "Has a camera's frame or clock changed since its calibration (an archive's daily check, issue 40; \
                      crates/algo/src/align/frame_change.rs): the day's registration of a camera pair minus the calibration day's, \
                      rotation d_theta (rad), the anchor's position d_x, d_y (m) and the clock d_dt (s), each with its standard error \
                      (the two days' in quadrature). z_theta = |d_theta| / se_theta, z_pos = sqrt((d_x / se_x)^2 + (d_y / se_y)^2), \
                      z_clock = |d_dt| / se_dt; changed when the largest, z, exceeds z_crit. `pairs` (optional): the track pairs of the smaller \
                      of the two registrations (register_pair's pairs), whose block jackknife over min(pairs, 16) blocks gives the standard \
                      errors' degrees of freedom: each ratio is then first turned into the normal value with Student's t tail (Wallace's \
                      approximation; z_pos by F(2, dof)), so that estimated errors raise no false alarms (t = 5 at 15 degrees of freedom is \
                      z = 3.77); absent: known errors; NULL, NaN, negative or < 8: NULL (nothing tested). A part whose value or standard error is NaN, infinite or NULL, or whose standard error is 0, \
                      is not tested (its z NULL; a NULL literal argument makes the whole call NULL, as for any SQL function); NULL when no part is \
                      tested, or z_crit is NULL; z_crit not > 0 is an error. \
                      O(1).",
        example: "SELECT frame_change(0.0, 0.001, 1.0, 0.1, 0.0, 0.1, 0.0, 0.01, 5.0).changed; -- true",
        maths: "crates/algo/src/align/frame_change.rs",
        binding: file!(),
        section: Section::Alignment,
        see_also: &["register_pair", "trajdb_archive"],
        signatures: &[Signature {
            params: &[
                pd("d_theta", Ty::Double, "the day's rotation minus the calibration day's (rad)"),
                pd("se_theta", Ty::Double, "its standard error (rad), both days' in quadrature"),
                pd("d_x", Ty::Double, "the change of the anchor's x (m)"),
                pd("se_x", Ty::Double, "its standard error (m)"),
                pd("d_y", Ty::Double, "the change of the anchor's y (m)"),
                pd("se_y", Ty::Double, "its standard error (m)"),
                pd("d_dt", Ty::Double, "the change of the clock offset (s)"),
                pd("se_dt", Ty::Double, "its standard error (s)"),
                pd("z_crit", Ty::Double, "changed when the largest z exceeds this, > 0"),
                pd("pairs", Ty::Double, "the track pairs of the smaller registration: the standard errors' degrees of freedom (NULL, NaN or < 8: nothing tested); default: known errors"),
            ],
            arities: &[9, 10],
            returns: Ty::Struct(&[("changed", Ty::Boolean), ("z", Ty::Double), ("z_theta", Ty::Double), ("z_pos", Ty::Double), ("z_clock", Ty::Double)]),
            kernel: frame_change,
        }],
        table: None,
    },
];

/// The optional `tau, max_iter, tol, with_scale, starts` (columns 3..7) with their defaults,
/// checked by [`CpdParams::new`]; `None` when one is NULL.
fn cpd_params<'a>(a: &Args<'a>) -> impl Fn(usize) -> Result<Option<CpdParams>, Box<dyn Error>> + 'a {
    let (w, tau, max_iter, tol, scale, starts) = (a.double(2), a.opt_double(3), a.opt_bigint(4), a.opt_double(5), a.opt_boolean(6), a.opt_bigint(7));
    move |r| {
        let (Some(w), Some(tau), Some(max_iter), Some(tol), Some(scale), Some(starts)) =
            (w.get(r), tau.or(r, f64::INFINITY), max_iter.or(r, 100), tol.or(r, 1e-5), scale.or(r, false), starts.or(r, 8))
        else {
            return Ok(None);
        };
        Ok(Some(CpdParams::new(w, Some(tau), max_iter, tol, scale, starts)?))
    }
}

/// The statistics every `cpd_align` result ends with.
fn fit_stats<T>(res: &cpd::CpdResult<T>) -> [Value; 4] {
    [Value::F64(res.q), Value::F64(res.log_likelihood), Value::F64(res.inlier_fraction), Value::F64(res.rms)]
}

fn cpd_align(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (fixed, moving, params) = (a.traj(0), a.traj(1), cpd_params(a));
    let vals = a.map(|r| {
        let (Some(f), Some(m)) = (fixed.get(r)?, moving.get(r)?) else { return Ok(None) };
        let Some(p) = params(r)? else { return Ok(None) };
        let res = cpd::align((f.x, f.y, f.t), (m.x, m.y, m.t), &p)?;
        let t = res.transform;
        let m = Transform2 { scale: 1.0, ..t }.matrix();
        let mut v: Vec<Value> = [t.theta, t.tx, t.ty, t.scale, m[0][0], m[0][1], m[1][0], m[1][1], res.sigma2].map(Value::F64).to_vec();
        v.extend([Value::I64(res.iterations as i64), Value::Bool(res.converged)]);
        v.extend(fit_stats(&res));
        v.extend([Value::F64(res.start_theta), Value::I64(res.pairs_in_band as i64)]);
        Ok(Some(v))
    })?;
    out.structs(&vals);
    Ok(())
}

fn cpd_align3(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (fixed, moving, params) = (a.traj3(0), a.traj3(1), cpd_params(a));
    let vals = a.map(|r| {
        let (Some(f), Some(m)) = (fixed.get(r)?, moving.get(r)?) else { return Ok(None) };
        let Some(p) = params(r)? else { return Ok(None) };
        let res = cpd3::align3((f.x, f.y, f.z, f.t), (m.x, m.y, m.z, m.t), &p)?;
        let t = &res.transform;
        let mut v: Vec<Value> = t.r.iter().flat_map(|row| row.iter().map(|&x| Value::F64(x))).collect();
        v.extend([t.t[0], t.t[1], t.t[2], t.scale, res.sigma2].map(Value::F64));
        v.extend([Value::I64(res.iterations as i64), Value::Bool(res.converged)]);
        v.extend(fit_stats(&res));
        v.push(Value::I64(res.pairs_in_band as i64));
        Ok(Some(v))
    })?;
    out.structs(&vals);
    Ok(())
}

fn rigid_fit(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (pairs, trim, scale) = (a.struct_list(0), a.opt_double(1), a.opt_boolean(2));
    let vals = a.map(|r| {
        let Some(c) = pairs.get(r)? else { return Ok(None) };
        let (Some(trim), Some(with_scale)) = (trim.or(r, 0.0), scale.or(r, false)) else { return Ok(None) };
        rigid::check_pairs(c.f64(0), c.f64(1), c.f64(2), c.f64(3))?;
        let f = rigid::fit_trimmed(c.f64(0), c.f64(1), c.f64(2), c.f64(3), trim, with_scale)?;
        let t = f.transform;
        let kept = f.inliers.iter().filter(|&&b| b).count();
        let mut v: Vec<Value> = [t.theta, t.tx, t.ty, t.scale, f.rms].map(Value::F64).to_vec();
        v.extend([Value::I64(kept as i64), Value::I64(f.inliers.len() as i64)]);
        Ok(Some(v))
    })?;
    out.structs(&vals);
    Ok(())
}

/// A transform argument, checked by [`Transform2::validate`].
fn transform(c: &StructCol<'_>, a: &Args<'_>, col: usize, r: usize) -> Result<Option<Transform2>, Box<dyn Error>> {
    let Some(v) = c.get(r)? else { return Ok(None) };
    let t = Transform2::new(v[0], v[1], v[2], v[3]);
    t.validate().map_err(|e| format!("{}: {e}", a.name(col)))?;
    Ok(Some(t))
}

fn rigid_rms(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (pairs, tf) = (a.struct_list(0), a.structure(1));
    let vals = a.map(|r| {
        let (Some(c), Some(t)) = (pairs.get(r)?, transform(&tf, a, 1, r)?) else { return Ok(None) };
        rigid::check_pairs(c.f64(0), c.f64(1), c.f64(2), c.f64(3))?;
        Ok((!c.is_empty()).then(|| rigid::residual_rms(&t, c.f64(0), c.f64(1), c.f64(2), c.f64(3), &[])))
    })?;
    out.flat(&vals);
    Ok(())
}

fn traj_correspond(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (fixed, moving, gap, dt) = (a.traj(0), a.traj(1), a.opt_double(2), a.opt_double(3));
    let vals: Vec<Option<Pairs>> = a.par_map(|r| {
        let (Some(f), Some(m), Some(g), Some(dt)) = (fixed.get(r)?, moving.get(r)?, gap.or(r, 0.5), dt.or(r, 0.0)) else { return Ok(None) };
        Ok(Some(shift::correspond_at(f, m, dt, g)?))
    })?;
    let cols: Vec<_> =
        vals.iter().map(|v| v.as_ref().map(|p| vec![Column::F64(&p.fx), Column::F64(&p.fy), Column::F64(&p.mx), Column::F64(&p.my)])).collect();
    out.struct_lists(&cols)?;
    Ok(())
}

fn transform_apply(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tr, tf) = (a.traj(0), a.structure(1));
    let vals = a.map(|r| {
        let (Some(x), Some(t)) = (tr.get(r)?, transform(&tf, a, 1, r)?) else { return Ok(None) };
        Ok(Some(t.apply_traj(x)))
    })?;
    out.trajs(&vals)?;
    Ok(())
}

fn transform_point(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (tf, x, y) = (a.structure(0), a.double(1), a.double(2));
    let vals = a.map(|r| {
        let (Some(t), Some(x), Some(y)) = (transform(&tf, a, 0, r)?, x.get(r), y.get(r)) else { return Ok(None) };
        let (px, py) = t.apply_checked(x, y)?;
        Ok(Some(vec![Value::F64(px), Value::F64(py)]))
    })?;
    out.structs(&vals);
    Ok(())
}

fn tf_values(t: Transform2) -> Vec<Value> {
    [t.theta, t.tx, t.ty, t.scale].map(Value::F64).to_vec()
}

fn transform_compose(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ta, tb) = (a.structure(0), a.structure(1));
    let vals = a.map(|r| {
        let (Some(x), Some(y)) = (transform(&ta, a, 0, r)?, transform(&tb, a, 1, r)?) else { return Ok(None) };
        Ok(Some(tf_values(x.compose(&y))))
    })?;
    out.structs(&vals);
    Ok(())
}

fn transform_identity(a: &Args<'_>, out: &mut Out<'_>) -> R {
    out.structs(&vec![Some(tf_values(Transform2::IDENTITY)); a.rows()]);
    Ok(())
}

fn angle_wrap_deg(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let get = a.doubles::<1>();
    let vals = a.map(|r| {
        let Some([v]) = get(r) else { return Ok(None) };
        Ok(Some(rigid::wrap_deg_checked(v)?))
    })?;
    out.flat(&vals);
    Ok(())
}

fn transform_invert(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let tf = a.structure(0);
    out.structs(&a.map(|r| Ok(transform(&tf, a, 0, r)?.map(|t| tf_values(t.invert()))))?);
    Ok(())
}

fn rigid_fit_scan(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (fixed, moving, max, step, gap) = (a.traj(0), a.traj(1), a.double(2), a.double(3), a.opt_double(4));
    let vals = a.par_map(|r| {
        let (Some(f), Some(m), Some(max), Some(step), Some(g)) = (fixed.get(r)?, moving.get(r)?, max.get(r), step.get(r), gap.or(r, 0.5)) else {
            return Ok(None);
        };
        Ok(Some(shift::scan(f, m, &ShiftGrid::new(0.0, max, step)?, g)?))
    })?;
    // columns per row: dt, theta, tx, ty, rms, n, span
    type Cols = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<i64>, Vec<f64>);
    let owned: Vec<Option<Cols>> = vals
        .iter()
        .map(|v| {
            v.as_ref().map(|fits| {
                let col = |g: fn(&shift::ShiftFit) -> f64| fits.iter().map(g).collect::<Vec<f64>>();
                (col(|f| f.dt), col(|f| f.transform.theta), col(|f| f.transform.tx), col(|f| f.transform.ty), col(|f| f.rms), fits.iter().map(|f| f.n as i64).collect(), col(|f| f.span))
            })
        })
        .collect();
    let cols: Vec<_> = owned
        .iter()
        .map(|v| v.as_ref().map(|(dt, th, tx, ty, rms, n, span)| vec![Column::F64(dt), Column::F64(th), Column::F64(tx), Column::F64(ty), Column::F64(rms), Column::I64(n), Column::F64(span)]))
        .collect();
    out.struct_lists(&cols)?;
    Ok(())
}

fn rigid_fit_shifted(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (fixed, moving, centre, half, step) = (a.traj_list(0), a.traj_list(1), a.double(2), a.double(3), a.double(4));
    let (gap, trim, sf, sm) = (a.opt_double(5), a.opt_double(6), a.opt_double(7), a.opt_double(8));
    let vals = a.par_map(|r| {
        let (Some(f), Some(m), Some(c), Some(h), Some(s)) = (fixed.get(r)?, moving.get(r)?, centre.get(r), half.get(r), step.get(r)) else {
            return Ok(None);
        };
        let (Some(g), Some(trim), Some(sf), Some(sm)) = (gap.or(r, 0.5), trim.or(r, 0.1), sf.or(r, 0.0), sm.or(r, 0.0)) else { return Ok(None) };
        let grid = ShiftGrid::new(c, h, s)?;
        let pairs = shift::zip_tracks(&f, &m)?;
        let Some(fit) = shift::joint(&pairs, &grid, g, trim, shift::Noise::new(sf, sm)?)? else { return Ok(None) };
        let t = fit.transform;
        let mut v: Vec<Value> = [fit.dt, t.theta, t.tx, t.ty, t.scale, fit.rms].map(Value::F64).to_vec();
        v.push(Value::I64(fit.n as i64));
        Ok(Some(v))
    })?;
    out.structs(&vals);
    Ok(())
}

fn activity_lag(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (sa, sb, bin) = (a.series(0), a.series(1), a.double(2));
    let vals = a.par_map(|r| {
        let (Some(x), Some(y), Some(bin)) = (sa.get(r)?, sb.get(r)?, bin.get(r)) else { return Ok(None) };
        Ok(xcorr::activity_lag(x, y, bin)?.map(|l| [l.dt, l.score, l.runner_up, l.half_width_s].map(Value::F64).to_vec()))
    })?;
    out.structs(&vals);
    Ok(())
}

fn register_pair(a: &Args<'_>, out: &mut Out<'_>) -> R {
    use crate::algo::align::register;
    let (fixed, moving, codes, dt, gap, trim) = (a.traj_list(0), a.traj_list(1), a.i64_list(2), a.double(3), a.opt_double(4), a.opt_double(5));
    let (sf, sm, max_shift, step) = (a.opt_double(6), a.opt_double(7), a.opt_double(8), a.opt_double(9));
    let scanning = a.given(8);
    // class_lengths, read per row before the parallel part (a list column is not shared between threads)
    let lengths: Option<Vec<Option<Vec<f64>>>> = match a.given(10) {
        false => None,
        true => {
            let l = a.f64_list(10);
            Some((0..a.rows()).map(|r| l.get(r).map(|o| o.map(|v| v.to_vec()))).collect::<Result<_, _>>()?)
        }
    };
    let vals = a.par_map(|r| {
        let (Some(f), Some(m), Some(c), Some(dt)) = (fixed.get(r)?, moving.get(r)?, codes.get(r)?, dt.get(r)) else { return Ok(None) };
        let lens: Option<&Vec<f64>> = match &lengths {
            None => None,
            Some(l) => match &l[r] {
                Some(v) => Some(v),
                None => return Ok(None),
            },
        };
        let (Some(g), Some(trim), Some(sf), Some(sm)) = (gap.or(r, 0.5), trim.or(r, 0.1), sf.or(r, 0.0), sm.or(r, 0.0)) else { return Ok(None) };
        // max_shift and step: both or neither (arity 10 gives both; a NULL in either: NULL)
        let scan = match (max_shift.or(r, 0.0), step.or(r, 1.0)) {
            (Some(h), Some(s)) => scanning.then(|| shift::ShiftGrid::new(dt, h, s)).transpose()?,
            _ => return Ok(None),
        };
        // class codes -> dense indices (only equality counts)
        let mut uniq: Vec<i64> = c.to_vec();
        uniq.sort_unstable();
        uniq.dedup();
        let cls: Vec<u32> = c.iter().map(|v| uniq.binary_search(v).unwrap_or(0) as u32).collect();
        let pairs = shift::zip_tracks(&f, &m)?;
        if pairs.len() != cls.len() {
            return Err(format!("class_codes must list one code per track pair, got {} codes for {} pairs", cls.len(), pairs.len()).into());
        }
        // class_lengths: one per pair, the same for every pair of a class -> one per class index
        let mut extents = Vec::new();
        if let Some(l) = lens {
            if l.len() != cls.len() {
                return Err(format!("class_lengths must list one length per track pair, got {} for {} pairs", l.len(), cls.len()).into());
            }
            extents = vec![f64::NAN; uniq.len()];
            for (i, (&k, &v)) in cls.iter().zip(l).enumerate() {
                if !(v > 0.0 && v <= 1e4) {
                    return Err(format!("class_lengths[{}] must be in (0, 10000] m (a road user's length), got {v}", i + 1).into());
                }
                let e = &mut extents[k as usize];
                if e.is_nan() {
                    *e = v;
                } else if *e != v {
                    return Err(format!("class_lengths[{}] is {v}, but an earlier pair of the same class code has {}: one length per class", i + 1, *e).into());
                }
            }
        }
        let noise = shift::Noise::new(sf, sm)?;
        let (g, dt, se_dt, edge, moved) = match scan {
            None => match register::register(&pairs, &cls, &extents, dt, g, trim, noise)? {
                Some(reg) => (reg, dt, None, false, false),
                None => return Ok(None),
            },
            Some(grid) => match crate::algo::align::register_clock::register_clock(&pairs, &cls, &extents, &grid, g, trim, noise)? {
                Some(c) => (c.registration, c.dt, Some(c.se_dt), c.at_edge, c.moved),
                None => return Ok(None),
            },
        };
        let t = g.transform;
        let mut v: Vec<Value> = vec![Value::F64(dt), se_dt.map_or(Value::Null, Value::F64), Value::Bool(edge), Value::Bool(moved)];
        v.extend([t.theta, t.tx, t.ty, t.scale, g.scale_fit, g.se_theta, g.se_tx, g.se_ty, g.se_scale].map(Value::F64));
        v.push(Value::Bool(g.scale_significant));
        v.push(Value::I64(g.pairs_used as i64));
        v.push(Value::I64(g.pairs as i64));
        v.push(Value::F64(g.rms));
        v.push(Value::F64(g.tau_max));
        match g.perspective {
            Some(p) => v.extend([Value::F64(p.h[0]), Value::F64(p.h[1]), Value::F64(p.se), Value::F64(p.chi2), Value::Bool(p.significant)]),
            None => v.extend([Value::Null, Value::Null, Value::Null, Value::Null, Value::Null]),
        }
        Ok(Some(v))
    })?;
    out.structs(&vals);
    Ok(())
}

fn rigid_shift_under(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (fixed, moving, tf) = (a.traj(0), a.traj(1), a.structure(2));
    let (centre, half, step, gap, minp) = (a.double(3), a.double(4), a.double(5), a.opt_double(6), a.opt_bigint(7));
    let vals = a.map(|r| {
        let (Some(f), Some(m), Some(t), Some(c), Some(h), Some(s)) = (fixed.get(r)?, moving.get(r)?, transform(&tf, a, 2, r)?, centre.get(r), half.get(r), step.get(r)) else {
            return Ok(None);
        };
        let (Some(g), Some(mp)) = (gap.or(r, 0.5), minp.or(r, 10)) else { return Ok(None) };
        if mp < 2 {
            return Err(format!("min_pairs must be >= 2, got {mp}").into());
        }
        let grid = ShiftGrid::new(c, h, s)?;
        Ok(shift_under::best_shift_under(f, m, &t, &grid, g, mp as usize)?
            .map(|b| vec![Value::F64(b.dt), Value::F64(b.rms), Value::I64(b.n as i64), Value::F64(b.se), Value::Bool(b.at_edge)]))
    })?;
    out.structs(&vals);
    Ok(())
}

fn camera_twin_fn(a: &Args<'_>, out: &mut Out<'_>) -> R {
    use crate::algo::align::twin::{self, Side};
    let (na, nb, sh, ms) = (a.bigint(0), a.bigint(1), a.bigint(2), a.opt_double(3));
    let vals = a.map(|r| {
        let (Some(na), Some(nb), Some(sh), Some(ms)) = (na.get(r), nb.get(r), sh.get(r), ms.or(r, twin::DEFAULT_MIN_SHARE)) else {
            return Ok(None);
        };
        let count = |name: &str, v: i64| u64::try_from(v).map_err(|_| format!("{name} must be >= 0 (a count of points), got {v}"));
        let v = twin::camera_twin(count("points_a", na)?, count("points_b", nb)?, count("shared", sh)?, ms)?;
        let copy = match v.copy {
            None => 0,
            Some(Side::A) => 1,
            Some(Side::B) => 2,
        };
        Ok(Some(vec![Value::F64(v.share), Value::Bool(v.twin), Value::I64(copy)]))
    })?;
    out.structs(&vals);
    Ok(())
}

fn speed_lag_fn(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ta, tb, centre, half, step, mins) = (a.traj(0), a.traj(1), a.double(2), a.double(3), a.double(4), a.opt_bigint(5));
    let vals = a.map(|r| {
        let (Some(x), Some(y), Some(c), Some(h), Some(s), Some(m)) = (ta.get(r)?, tb.get(r)?, centre.get(r), half.get(r), step.get(r), mins.or(r, 8)) else {
            return Ok(None);
        };
        if m < 3 {
            return Err(format!("min_samples must be >= 3, got {m}").into());
        }
        let grid = ShiftGrid::new(c, h, s)?;
        Ok(speed_lag::speed_lag(x, y, &grid, m as usize)?.map(|l| vec![Value::F64(l.lag), Value::F64(l.corr), Value::I64(l.n as i64)]))
    })?;
    out.structs(&vals);
    Ok(())
}

fn traj_msd_pairs(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (ia, ta, ib, tb, pairs, gap) = (a.i64_list(0), a.traj_list(1), a.i64_list(2), a.traj_list(3), a.struct_list(4), a.double(5));
    let vals = a.map(|r| {
        let (Some(ia), Some(ta), Some(ib), Some(tb), Some(pairs), Some(gap)) = (ia.get(r)?, ta.get(r)?, ib.get(r)?, tb.get(r)?, pairs.get(r)?, gap.get(r)) else {
            return Ok(None);
        };
        let (pa, pb) = super::common::two_sets(ia, &ta, ib, &tb)?;
        let (ka, kb) = (pairs.i64(0), pairs.i64(1));
        let mut at = Vec::new();
        at.try_reserve(ka.len()).map_err(|_| "traj_msd_pairs: out of memory for the pairs")?;
        for k in 0..ka.len() {
            let p = *pa.get(&ka[k]).ok_or_else(|| format!("pairs[{}].a = {} is not in ids_a", k + 1, ka[k]))?;
            let q = *pb.get(&kb[k]).ok_or_else(|| format!("pairs[{}].b = {} is not in ids_b", k + 1, kb[k]))?;
            at.push((p, q));
        }
        let m = crate::algo::align::msd::msd_pairs(&ta, &tb, &at, gap)?;
        let n: Vec<i64> = m.iter().map(|v| v.n as i64).collect();
        let msd: Vec<Option<f64>> = m.iter().map(|v| v.msd).collect();
        let dx: Vec<Option<f64>> = m.iter().map(|v| v.dx).collect();
        let dy: Vec<Option<f64>> = m.iter().map(|v| v.dy).collect();
        Ok(Some((ka.to_vec(), kb.to_vec(), n, msd, dx, dy)))
    })?;
    let cols: Vec<_> = vals
        .iter()
        .map(|v| {
            v.as_ref().map(|(x, y, n, m, dx, dy)| vec![Column::I64(x), Column::I64(y), Column::I64(n), Column::OptF64(m), Column::OptF64(dx), Column::OptF64(dy)])
        })
        .collect();
    out.struct_lists(&cols)?;
    Ok(())
}

fn clock_network(a: &Args<'_>, out: &mut Out<'_>) -> R {
    use crate::algo::align::clock_network::{adjust, PairMeasure};
    let (pairs, reference) = (a.struct_list(0), a.bigint(1));
    type Cols = (Vec<i64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<i64>, Vec<f64>, Vec<Option<bool>>);
    let nets: Vec<Option<Cols>> = a.map(|r| {
        let (Some(c), Some(rf)) = (pairs.get(r)?, reference.get(r)) else { return Ok(None) };
        let (f, m, v, se) = (c.i64(0), c.i64(1), c.f64(2), c.f64(3));
        let ps: Vec<PairMeasure> = (0..c.len()).map(|k| PairMeasure { fixed: f[k], moving: m[k], value: v[k], se: se[k] }).collect();
        let Some(n) = adjust(&ps, rf)? else { return Ok(None) };
        let k = n.cameras.len();
        Ok(Some((
            n.cameras.iter().map(|c| c.0).collect(),
            n.cameras.iter().map(|c| c.1).collect(),
            n.cameras.iter().map(|c| c.2).collect(),
            vec![n.chi2; k],
            vec![n.dof as i64; k],
            vec![n.t2; k],
            vec![Some(n.shown); k],
        )))
    })?;
    let cols: Vec<Option<Vec<Column<'_>>>> = nets
        .iter()
        .map(|v| {
            v.as_ref().map(|(c, x, se, chi2, dof, t2, shown)| {
                vec![Column::I64(c), Column::F64(x), Column::F64(se), Column::F64(chi2), Column::I64(dof), Column::F64(t2), Column::OptBool(shown)]
            })
        })
        .collect();
    out.struct_lists(&cols)?;
    Ok(())
}

fn drift_obs(c: &super::vector::Rows<'_>) -> Vec<crate::algo::align::drift_fit::Obs> {
    let (x, y, w) = (c.f64(0), c.f64(1), c.f64(2));
    (0..c.len()).map(|k| crate::algo::align::drift_fit::Obs { x: x[k], y: y[k], w: w[k] }).collect()
}

fn clock_drift_fit(a: &Args<'_>, out: &mut Out<'_>) -> R {
    use crate::algo::align::drift_fit::fit;
    let obs = a.struct_list(0);
    type Cols = (Vec<Option<bool>>, Vec<f64>, Vec<i64>, [Vec<f64>; 9], Vec<Option<bool>>);
    let fits: Vec<Option<Cols>> = a.map(|r| {
        let Some(c) = obs.get(r)? else { return Ok(None) };
        let Some(f) = fit(&drift_obs(&c))? else { return Ok(None) };
        let k = f.kept.len();
        let rep = |v: f64| vec![v; k];
        Ok(Some((
            f.kept.iter().map(|&b| Some(b)).collect(),
            f.z.clone(),
            vec![f.n as i64; k],
            [rep(f.x_span), rep(f.slope), rep(f.intercept), rep(f.se), rep(f.se_ls), rep(f.se_jk), rep(f.sw), rep(f.swx), rep(f.swy)],
            vec![Some(f.usable); k],
        )))
    })?;
    let cols: Vec<Option<Vec<Column<'_>>>> = fits
        .iter()
        .map(|v| {
            v.as_ref().map(|(kept, z, n, f, usable)| {
                let mut c = vec![Column::OptBool(kept), Column::F64(z), Column::I64(n)];
                c.extend(f.iter().map(|v| Column::F64(v)));
                c.push(Column::OptBool(usable));
                c
            })
        })
        .collect();
    out.struct_lists(&cols)?;
    Ok(())
}

fn clock_offset_se(a: &Args<'_>, out: &mut Out<'_>) -> R {
    use crate::algo::align::drift_fit::offset_se;
    let (obs, drift) = (a.struct_list(0), a.double(1));
    let vals = a.map(|r| {
        let (Some(c), Some(d)) = (obs.get(r)?, drift.get(r)) else { return Ok(None) };
        let (blocks, se) = offset_se(&drift_obs(&c), d)?;
        Ok(Some(vec![Value::I64(blocks as i64), se.map_or(Value::Null, Value::F64)]))
    })?;
    out.structs(&vals);
    Ok(())
}

fn frame_change(a: &Args<'_>, out: &mut Out<'_>) -> R {
    use crate::algo::align::frame_change::frame_change as test;
    let c: Vec<_> = (0..10).take_while(|&k| a.given(k)).map(|k| a.double(k)).collect();
    let vals = a.map(|r| {
        let Some(z_crit) = c[8].get(r) else { return Ok(None) };
        let g = |k: usize| c[k].get(r);
        // pairs given but NULL: nothing tested (NaN: frame_change's "no jackknife")
        let pairs = if c.len() > 9 { Some(g(9).unwrap_or(f64::NAN)) } else { None };
        let Some(f) = test(g(0), g(1), g(2), g(3), g(4), g(5), g(6), g(7), z_crit, pairs)? else { return Ok(None) };
        let o = |v: Option<f64>| v.map_or(Value::Null, Value::F64);
        Ok(Some(vec![Value::Bool(f.changed), Value::F64(f.z), o(f.z_theta), o(f.z_pos), o(f.z_clock)]))
    })?;
    out.structs(&vals);
    Ok(())
}
