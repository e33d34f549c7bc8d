//! `trajdb simulate`: synthetic multi-camera traffic at a four-arm intersection, with exact
//! ground truth, written in the format of the shared benchmark scenarios (`../shared/data`):
//! points.csv (+ points.parquet, written by the caller), cameras.csv, truth.csv, world.csv,
//! objects.csv and README.txt.
//!
//! Pure Rust (no DuckDB). Deterministic for a seed (ChaCha8).
//!
//! # The world
//! - Two straight roads cross at the origin: arms E (+x), N (+y), W (−x), S (−y), 70 m long,
//!   one 3.5 m lane per direction, driving on the right; bike lanes 5 m from the centre line;
//!   sidewalks 8 m from it, crosswalks 10 m from the centre on every arm.
//! - Cars, heavy vehicles and cyclists enter on one arm and leave on another (straight, left,
//!   right; no U-turns). The turn is a quadratic Bézier between the lane lines. Speeds follow a
//!   profile along the path: cruise speed, a lower curve speed in turns, acceleration and braking
//!   limits, and (sometimes) a stop of a few seconds at the stop line (12 m from the centre).
//! - Pedestrians walk the sidewalks, cross 1–2 crosswalks (sometimes waiting at the curb), and
//!   sometimes walk in pairs side by side (0.7 m apart): the hard case for matching.
//! - Arrivals are Poisson per class (per minute: car 10, heavy vehicle 1, cyclist 2 times
//!   `cyclists`, pedestrian 3 times `pedestrians`; all times `traffic`). A vehicle entering a lane less than 2.5 s behind the
//!   previous one on that lane waits, and never cruises faster than it (no driving through).
//! - Waiting groups (`waiting_groups` per minute, default 0; [`waiting_groups`]): 2–8
//!   pedestrians and cyclists standing 0.6–2 m apart at a crossing's kerb for 10–60 s, then
//!   starting together and crossing: the crowd that defeats association on real intersections.
//!
//! Every option beyond the original ones draws from a random stream of its own, and draws
//! nothing at its default: the scenario of the original options stays byte for byte the same.
//! docs/simulate.md describes every option, its range and the truth files.
//!
//! # The cameras
//! N rotated rectangular views (48 m × 36 m) around the centre, long axis pointing at it, so that
//! neighbours overlap over the junction. Each camera has a random rigid frame
//! (p_local = R(−θ)(p − t)), its own sampling phase at `rate_hz`, Gaussian noise σ drawn from
//! `noise_sigma`, and an optional clock offset. Then the degradations of the shared scenarios:
//! track breaks (a gap of 0.5–2 s, both parts ≥ 1 s, two ids), coasting tails (2–5 extrapolated
//! points, estimated = 1), spurious tracks (3–8 points, estimated = 1, object −1), fresh track
//! ids increasing with start time, and speed by finite differences.
//!
//! Cost: O(objects × samples) time and memory; a 12-hour day of 2 cameras (≈ 12k objects) takes
//! a few seconds. The memory is counted against the limit `memory_bytes` (default 4e9) before
//! it is allocated ([`simulate`]): a scenario larger than that (the largest parameters allow
//! hundreds of GB) is an error that says what to reduce.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp, Normal};
use std::fmt::Write as _;
use std::io::{BufWriter, Write};
use std::path::Path;

use super::outdir;

/// Simulation parameters (validated by [`SimParams::validate`]).
#[derive(Clone, Debug)]
pub struct SimParams {
    pub cameras: usize,
    pub minutes: f64,
    pub seed: u64,
    /// The site's seed (issue 40: an archive of days at one site): when set, the cameras (views,
    /// frames, clocks, noise, ground planes) are drawn from it and only the traffic from `seed`,
    /// so that days of one site differ in their road users and share their cameras.
    pub site_seed: Option<u64>,
    /// Camera sampling rates (Hz): camera k samples at `rate_hz[k % len]` (one rate for every
    /// camera, or a list such as 2, 5, 7.5, 10, 12.5, 15, 25, 30).
    pub rate_hz: Vec<f64>,
    /// Traffic volume multiplier (1 = the default arrival rates).
    pub traffic: f64,
    /// Extra multiplier of the pedestrian arrival rate (a crowd: 10 gives 30 a minute at traffic 1).
    pub pedestrians: f64,
    /// Camera position noise σ is drawn uniformly from this range (m).
    pub noise_sigma: (f64, f64),
    pub p_break: f64,
    pub p_est: f64,
    /// Spurious tracks per camera and minute.
    pub noise_tracks_per_min: f64,
    /// Camera clocks are offset by a uniform draw in ±this (s).
    pub clock_offset_max: f64,
    /// Sampling rate of world.csv (Hz); 0 skips world.csv.
    pub world_rate_hz: f64,
    /// Groups of pedestrians and cyclists waiting at a crossing's kerb, per minute (0: none;
    /// [`waiting_groups`]).
    pub waiting_groups: f64,
    /// Extra multiplier of the cyclist arrival rate (cyclists in the bike lanes; 5 gives 10 a
    /// minute at traffic 1).
    pub cyclists: f64,
    /// Camera clocks run fast or slow by a uniform draw in ±this (ppm):
    /// t_cam = (1 + drift·1e-6) · t_world + clock_offset_s.
    pub clock_drift_ppm: f64,
    /// Seconds added to every camera's clock alike (e.g. 1.78e9, Unix time in 2026).
    pub clock_epoch: f64,
    /// Each reported time stamp is off the real capture time by N(0, σ) with this σ (s),
    /// clipped to ±0.45 frame periods so that times stay increasing within a track.
    pub time_jitter_s: f64,
    /// Where the cameras' local frames lie ([`Origin`]).
    pub origin: Origin,
    /// Viewpoint bias (m): the largest offset, along the camera's line of sight, between the
    /// point a camera reports for a road user and its true centre, for (vehicles, pedestrians
    /// and cyclists); drawn per (camera, road user) and constant while the camera sees it
    /// ([`viewpoint_bias`]). (0, 0): none.
    pub viewpoint_bias: (f64, f64),
    /// Ground-plane calibration error ([`GroundPlane`]): each camera's scale is off by a
    /// uniform draw in ±this (a fraction: 0.015 is 1.5 %). 0: none.
    pub ground_plane_scale: f64,
    /// Ground-plane calibration error: a perspective (homography) term whose relative error is
    /// at most this at [`PERSPECTIVE_RANGE_M`] from the camera, growing with range. 0: none.
    pub ground_plane_perspective: f64,
    /// Occlusion in crowds ([`occlude`]): a track is cut mid-view at this rate per second and
    /// per other road user within [`OCCLUSION_RADIUS_M`]. 0: none.
    pub occlusion: f64,
}

/// Where each camera's local frame lies: every local coordinate gets an offset O (p_local' =
/// p_local + O, so t' = t − R(θ)·O and p_world = R(θ) p_local' + t' still holds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Origin {
    /// No offset: local coordinates within about 100 m of 0.
    Near,
    /// UTM-like: each camera its own O, x in [4.5e5, 5e5], y in [5.7e6, 5.75e6] m.
    Utm,
    /// The same O = (x, y) for every camera.
    At(f64, f64),
}

impl Origin {
    /// `none`, `utm`, or `X,Y` (m).
    pub fn parse(text: &str) -> Result<Origin, SimError> {
        let bad = || SimError::Param(format!("origin must be none, utm or X,Y (metres), got {text:?}; give e.g. utm or 480000,5700000"));
        match text.trim().to_ascii_lowercase().as_str() {
            "none" | "" => Ok(Origin::Near),
            "utm" => Ok(Origin::Utm),
            xy => {
                let (x, y) = xy.split_once(',').ok_or_else(bad)?;
                Ok(Origin::At(x.trim().parse().map_err(|_| bad())?, y.trim().parse().map_err(|_| bad())?))
            }
        }
    }
}

impl std::fmt::Display for Origin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Origin::Near => write!(f, "none"),
            Origin::Utm => write!(f, "utm"),
            Origin::At(x, y) => write!(f, "{x},{y}"),
        }
    }
}

impl Default for SimParams {
    fn default() -> Self {
        SimParams {
            cameras: 3,
            minutes: 5.0,
            seed: 1,
            site_seed: None,
            rate_hz: vec![10.0],
            traffic: 1.0,
            pedestrians: 1.0,
            noise_sigma: (0.05, 0.15),
            p_break: 0.1,
            p_est: 0.1,
            noise_tracks_per_min: 1.0,
            clock_offset_max: 0.0,
            world_rate_hz: 10.0,
            waiting_groups: 0.0,
            cyclists: 1.0,
            clock_drift_ppm: 0.0,
            clock_epoch: 0.0,
            time_jitter_s: 0.0,
            origin: Origin::Near,
            viewpoint_bias: (0.0, 0.0),
            ground_plane_scale: 0.0,
            ground_plane_perspective: 0.0,
            occlusion: 0.0,
        }
    }
}

/// Errors of the simulator.
#[derive(Debug)]
pub enum SimError {
    Param(String),
    Io(std::io::Error),
    /// The folder cannot take the scenario (not new, empty or an earlier scenario; locked; ...).
    Folder(String),
}

impl std::fmt::Display for SimError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SimError::Param(s) => write!(f, "simulate: {s}"),
            SimError::Io(e) => write!(f, "simulate: {e}"),
            SimError::Folder(e) => write!(f, "simulate: {e}"),
        }
    }
}
impl std::error::Error for SimError {}
impl From<std::io::Error> for SimError {
    fn from(e: std::io::Error) -> Self {
        SimError::Io(e)
    }
}
impl From<outdir::OutError> for SimError {
    fn from(e: outdir::OutError) -> Self {
        SimError::Folder(e.0)
    }
}

impl SimParams {
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |s: String| Err(SimError::Param(s));
        if !(1..=16).contains(&self.cameras) {
            return bad(format!("cameras must be in 1..=16, got {}", self.cameras));
        }
        if !(self.minutes.is_finite() && self.minutes > 0.0 && self.minutes <= 24.0 * 60.0) {
            return bad(format!("minutes must be in (0, 1440], got {}", self.minutes));
        }
        if self.rate_hz.is_empty() || self.rate_hz.len() > 64 {
            return bad(format!("rate_hz must list 1 to 64 rates (Hz; one per camera, cycled), got {}; give e.g. 10 or 2,5,7.5,10", self.rate_hz.len()));
        }
        for &r in &self.rate_hz {
            if !(r.is_finite() && r > 0.0 && r <= MAX_RATE_HZ) {
                return bad(format!("rate_hz must be in (0, {MAX_RATE_HZ}] Hz, got {r}; give e.g. 10 (or a list, one per camera: 2,5,7.5,10)"));
            }
        }
        if !(self.traffic.is_finite() && self.traffic > 0.0 && self.traffic <= 50.0) {
            return bad(format!("traffic must be in (0, 50], got {}", self.traffic));
        }
        if !(self.pedestrians.is_finite() && self.pedestrians >= 0.0 && self.pedestrians <= 50.0) {
            return bad(format!("pedestrians must be in [0, 50], got {}", self.pedestrians));
        }
        if !(self.cyclists.is_finite() && (0.0..=50.0).contains(&self.cyclists)) {
            return bad(format!("cyclists must be in [0, 50] (a multiplier of 2 cyclists a minute), got {}; give e.g. 5 (1 = the default rate)", self.cyclists));
        }
        let (lo, hi) = self.noise_sigma;
        if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi >= lo) {
            return bad(format!("noise_sigma must be 0 <= lo <= hi, got {lo}..{hi}"));
        }
        for (n, p) in [("p_break", self.p_break), ("p_est", self.p_est)] {
            if !(0.0..=1.0).contains(&p) {
                return bad(format!("{n} must be in [0, 1], got {p}"));
            }
        }
        if !(self.noise_tracks_per_min.is_finite() && self.noise_tracks_per_min >= 0.0) {
            return bad(format!("noise_tracks_per_min must be >= 0, got {}", self.noise_tracks_per_min));
        }
        if !(self.clock_offset_max.is_finite() && (0.0..=MAX_CLOCK_OFFSET).contains(&self.clock_offset_max)) {
            return bad(format!(
                "clock_offset_max must be in [0, {MAX_CLOCK_OFFSET:e}] s, got {}; give e.g. 3600 (an hour) or 86400 (a day)",
                self.clock_offset_max
            ));
        }
        if !(self.clock_drift_ppm.is_finite() && (0.0..=MAX_CLOCK_DRIFT_PPM).contains(&self.clock_drift_ppm)) {
            return bad(format!(
                "clock_drift_ppm must be in [0, {MAX_CLOCK_DRIFT_PPM:e}] ppm (each camera draws its drift in +-this), got {}; give e.g. 200",
                self.clock_drift_ppm
            ));
        }
        if let Origin::At(x, y) = self.origin {
            if !(x.is_finite() && y.is_finite() && x.abs() <= MAX_ORIGIN && y.abs() <= MAX_ORIGIN) {
                return bad(format!("origin must lie within +-{MAX_ORIGIN:e} m, got {x},{y}; give e.g. utm or 480000,5700000"));
            }
        }
        let fastest = self.rate_hz.iter().copied().fold(0.0, f64::max);
        if !(self.time_jitter_s.is_finite() && self.time_jitter_s >= 0.0 && self.time_jitter_s < 1.0 / fastest) {
            return bad(format!(
                "time_jitter_s must be >= 0 and below the frame period (1/rate_hz = {} s), got {}; give e.g. 0.01",
                1.0 / fastest,
                self.time_jitter_s
            ));
        }
        if !(self.clock_epoch.is_finite() && self.clock_epoch.abs() <= MAX_CLOCK_EPOCH) {
            return bad(format!(
                "clock_epoch must be in [-{MAX_CLOCK_EPOCH:e}, {MAX_CLOCK_EPOCH:e}] s, got {}; give e.g. 1.78e9 (Unix time in 2026)",
                self.clock_epoch
            ));
        }
        if !(self.world_rate_hz.is_finite() && self.world_rate_hz >= 0.0) {
            return bad(format!("world_rate_hz must be >= 0, got {}", self.world_rate_hz));
        }
        let (bv, bp) = self.viewpoint_bias;
        if !(bv.is_finite() && (0.0..=MAX_VIEWPOINT_BIAS_M).contains(&bv) && bp.is_finite() && (0.0..=MAX_VIEWPOINT_BIAS_M).contains(&bp)) {
            return bad(format!(
                "viewpoint_bias must be in [0, {MAX_VIEWPOINT_BIAS_M}] m for vehicles and for pedestrians and cyclists, got {bv},{bp}; give e.g. 1.2,0.2"
            ));
        }
        for (n, v) in [("ground_plane_scale", self.ground_plane_scale), ("ground_plane_perspective", self.ground_plane_perspective)] {
            if !(v.is_finite() && (0.0..=MAX_GROUND_PLANE_ERROR).contains(&v)) {
                return bad(format!("{n} must be in [0, {MAX_GROUND_PLANE_ERROR}] (a fraction: 0.015 is 1.5 %), got {v}; give e.g. 0.015"));
            }
        }
        if !(self.occlusion.is_finite() && (0.0..=MAX_OCCLUSION).contains(&self.occlusion)) {
            return bad(format!(
                "occlusion must be in [0, {MAX_OCCLUSION}] cuts per second and per neighbour within {OCCLUSION_RADIUS_M} m, got {}; give e.g. 0.05",
                self.occlusion
            ));
        }
        if !(self.waiting_groups.is_finite() && (0.0..=MAX_WAITING_GROUPS).contains(&self.waiting_groups)) {
            return bad(format!(
                "waiting_groups must be in [0, {MAX_WAITING_GROUPS}] groups per minute, got {}; give e.g. 2 (0 = no waiting groups)",
                self.waiting_groups
            ));
        }
        Ok(())
    }
}

/// The largest viewpoint bias of either class (m): half a long bus.
pub const MAX_VIEWPOINT_BIAS_M: f64 = 6.0;
/// The largest ground-plane scale or perspective error (a fraction: 10 %).
pub const MAX_GROUND_PLANE_ERROR: f64 = 0.1;
/// The largest occlusion rate (cuts per second and neighbour).
pub const MAX_OCCLUSION: f64 = 10.0;

/// The largest |x|, |y| of `origin` (m).
pub const MAX_ORIGIN: f64 = 1e7;

/// The fastest camera (Hz).
pub const MAX_RATE_HZ: f64 = 1000.0;

/// Reads `rate_hz`: one number, or a comma list of numbers (one per camera, cycled).
pub fn parse_rates(text: &str) -> Result<Vec<f64>, SimError> {
    text.split(',')
        .map(|r| {
            r.trim().parse::<f64>().map_err(|_| {
                SimError::Param(format!("rate_hz must be a number or a comma list of numbers (Hz, one per camera), got {text:?}; give e.g. 10 or 2,5,7.5,10"))
            })
        })
        .collect()
}

/// The largest `clock_offset_max` (s): beyond days, f64 time stamps lose microseconds.
pub const MAX_CLOCK_OFFSET: f64 = 1e7;
/// The largest `clock_drift_ppm` (1 %).
pub const MAX_CLOCK_DRIFT_PPM: f64 = 1e4;
/// The largest |`clock_epoch`| (s; 1e10 s is the year 2286, and a time stamp's unit in the last
/// place is still 2 µs).
pub const MAX_CLOCK_EPOCH: f64 = 1e10;

/// Road-user classes, as written in the `class` column.
pub const CLASSES: [&str; 4] = ["car", "heavy_vehicle", "cyclist", "pedestrian"];

/// One road user: its class, route and noise-free trajectory (t, x, y) at 20 Hz.
#[derive(Clone, Debug)]
pub struct Object {
    pub id: i64,
    pub class: &'static str,
    pub route: String,
    pub samples: Vec<[f64; 3]>,
}

/// One camera: local→world transform (p_world = R(θ) p_local + t), view rectangle (world).
#[derive(Clone, Debug)]
pub struct Camera {
    pub id: i64,
    pub theta: f64,
    pub tx: f64,
    pub ty: f64,
    pub view_world: [[f64; 2]; 4],
    /// Includes `clock_epoch`: t_cam = (1 + clock_drift_ppm·1e-6) · t_world + clock_offset.
    pub clock_offset: f64,
    pub clock_drift_ppm: f64,
    pub sigma: f64,
    pub rate_hz: f64,
    pub phase: f64,
    /// The camera's ground-plane calibration error (exact unless `ground_plane_*`).
    pub ground: GroundPlane,
}

/// A camera's ground-plane calibration error: the world point it reports for a true world point
/// p is `c + s·q / (1 + h·q)`, `q = p − c`, c the camera's position ([`Camera::position`]): a
/// homography that keeps the camera's foot point, with a scale error `s − 1` (the same share of
/// every distance: 1 m at 100 m for 1 %) and a perspective term h whose relative error `h·q`
/// grows with range along h (a tilt error of the estimated ground plane). No rigid transform
/// undoes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundPlane {
    pub scale: f64,
    /// The perspective row (1/m).
    pub h: [f64; 2],
}

impl GroundPlane {
    /// No error.
    pub const EXACT: GroundPlane = GroundPlane { scale: 1.0, h: [0.0, 0.0] };
    /// The reported point of true world point `p` for a camera standing at `c`.
    pub fn apply(&self, c: [f64; 2], p: [f64; 2]) -> [f64; 2] {
        if *self == Self::EXACT {
            return p;
        }
        let q = [p[0] - c[0], p[1] - c[1]];
        // |h·q| <= 0.1 / 50 m * 100 m = 0.2 within any view; the floor keeps a wild point finite
        let w = (1.0 + self.h[0] * q[0] + self.h[1] * q[1]).max(0.5);
        [c[0] + self.scale * q[0] / w, c[1] + self.scale * q[1] / w]
    }
}

impl Camera {
    /// Where the camera stands (world): [`CAMERA_SETBACK_M`] beyond the middle of its view's far
    /// short side, looking along the view's long axis at the junction (a pole at the roadside).
    pub fn position(&self) -> [f64; 2] {
        let v = &self.view_world;
        let far = [(v[1][0] + v[2][0]) / 2.0, (v[1][1] + v[2][1]) / 2.0];
        let near = [(v[0][0] + v[3][0]) / 2.0, (v[0][1] + v[3][1]) / 2.0];
        let l = dist(far, near).max(1e-12);
        add(far, [(far[0] - near[0]) / l, (far[1] - near[1]) / l], CAMERA_SETBACK_M)
    }
    /// The camera's clock at world time `t`: (1 + drift·1e-6) · t + offset (exactly t + offset
    /// without drift).
    pub fn clock(&self, t: f64) -> f64 {
        (1.0 + self.clock_drift_ppm * 1e-6) * t + self.clock_offset
    }
    /// The camera's frame period in world time: its frames are 1/rate_hz apart on its own clock.
    fn world_period(&self) -> f64 {
        (1.0 / self.rate_hz) / (1.0 + self.clock_drift_ppm * 1e-6)
    }
    fn to_local(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.theta.sin_cos();
        let (dx, dy) = (x - self.tx, y - self.ty);
        (c * dx + s * dy, -s * dx + c * dy)
    }
    fn sees(&self, x: f64, y: f64) -> bool {
        // convex quadrilateral, counter-clockwise
        (0..4).all(|i| {
            let a = self.view_world[i];
            let b = self.view_world[(i + 1) % 4];
            (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]) >= 0.0
        })
    }
}

/// One observed point, in the camera's frame and clock.
#[derive(Clone, Debug)]
pub struct PointRow {
    pub camera: i64,
    pub track_id: i64,
    pub class: &'static str,
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub speed: f64,
    pub estimated: bool,
}

/// A simulated scenario.
#[derive(Debug)]
pub struct Scenario {
    pub params: SimParams,
    pub objects: Vec<Object>,
    pub cameras: Vec<Camera>,
    pub points: Vec<PointRow>,
    /// (camera, track_id, object_id or −1, is_noise)
    pub truth: Vec<(i64, i64, i64, bool)>,
}

const ROAD: f64 = 70.0;
const LANE: f64 = 1.75;
const BIKE: f64 = 5.0;
const WALK: f64 = 8.0;
const CROSS: f64 = 10.0;
const STOP: f64 = 12.0;
const WORLD_DT: f64 = 0.05;
const DS: f64 = 0.25;

fn arm(a: usize) -> [f64; 2] {
    [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]][a % 4]
}
fn add(p: [f64; 2], q: [f64; 2], s: f64) -> [f64; 2] {
    [p[0] + s * q[0], p[1] + s * q[1]]
}
fn dist(p: [f64; 2], q: [f64; 2]) -> f64 {
    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt()
}

/// Resamples a polyline every DS metres (keeping the end point).
fn resample(poly: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut out = vec![poly[0]];
    let mut carry = 0.0;
    for w in poly.windows(2) {
        let l = dist(w[0], w[1]);
        if l == 0.0 {
            continue;
        }
        let mut s = DS - carry;
        while s <= l {
            let f = s / l;
            out.push([w[0][0] + f * (w[1][0] - w[0][0]), w[0][1] + f * (w[1][1] - w[0][1])]);
            s += DS;
        }
        carry = l - (s - DS);
    }
    if dist(*out.last().unwrap(), *poly.last().unwrap()) > 1e-9 {
        out.push(*poly.last().unwrap());
    }
    out
}

/// A vehicle path from arm `a` to arm `b` at lateral offset `off` (lane or bike lane), with
/// the index ranges of the turn and the stop-line position.
fn vehicle_path(a: usize, b: usize, off: f64) -> (Vec<[f64; 2]>, f64, (f64, f64)) {
    let (ua, ub) = (arm(a), arm(b));
    let r_in = [-ua[1], ua[0]]; // right of the inbound direction −ua
    let r_out = [ub[1], -ub[0]]; // right of the outbound direction ub
    let box_d = 8.0;
    let p_start = add([ROAD * ua[0], ROAD * ua[1]], r_in, off);
    let p_in = add([box_d * ua[0], box_d * ua[1]], r_in, off);
    let p_out = add([box_d * ub[0], box_d * ub[1]], r_out, off);
    let p_end = add([ROAD * ub[0], ROAD * ub[1]], r_out, off);
    let mut poly = vec![p_start, p_in];
    if (b + 4 - a) % 4 != 2 {
        // control point: where the inbound lane line meets the outbound lane line
        // p_in + s (−ua) = p_out − u ub  →  solve the 2×2 system
        let (d1, d2) = ([-ua[0], -ua[1]], [ub[0], ub[1]]);
        let det = d1[0] * (-d2[1]) - d1[1] * (-d2[0]);
        let rx = p_out[0] - p_in[0];
        let ry = p_out[1] - p_in[1];
        let s = (rx * (-d2[1]) - ry * (-d2[0])) / det;
        let c = add(p_in, d1, s);
        for k in 1..20 {
            let f = k as f64 / 20.0;
            let g = 1.0 - f;
            poly.push([
                g * g * p_in[0] + 2.0 * g * f * c[0] + f * f * p_out[0],
                g * g * p_in[1] + 2.0 * g * f * c[1] + f * f * p_out[1],
            ]);
        }
    }
    poly.push(p_out);
    poly.push(p_end);
    let turn_start = ROAD - box_d;
    let turn_len: f64 = poly[1..poly.len() - 1].windows(2).map(|w| dist(w[0], w[1])).sum();
    (resample(&poly), ROAD - STOP, (turn_start, turn_start + turn_len))
}

/// Speed profile along a resampled path: cruise speed, capped speed in `slow` ranges,
/// acceleration `acc` and braking `brake` limits, a stop of `dwell` s at arc length `stop`.
/// Returns the time at each path point, starting at `t0`.
#[allow(clippy::too_many_arguments)]
fn time_along(n: usize, v0: f64, slow: &[(f64, f64, f64)], stop: Option<(f64, f64)>, acc: f64, brake: f64, t0: f64) -> Vec<f64> {
    let mut vmax: Vec<f64> = (0..n)
        .map(|i| {
            let s = i as f64 * DS;
            slow.iter().filter(|(a, b, _)| s >= *a && s <= *b).fold(v0, |v, (_, _, c)| v.min(*c))
        })
        .collect();
    let stop_i = stop.map(|(s, _)| ((s / DS) as usize).min(n - 1));
    if let Some(i) = stop_i {
        vmax[i] = 0.0;
    }
    for i in (0..n - 1).rev() {
        vmax[i] = vmax[i].min((vmax[i + 1].powi(2) + 2.0 * brake * DS).sqrt());
    }
    for i in 1..n {
        vmax[i] = vmax[i].min((vmax[i - 1].powi(2) + 2.0 * acc * DS).sqrt());
    }
    let mut t = vec![t0; n];
    for i in 1..n {
        let v = (vmax[i - 1] + vmax[i]) / 2.0;
        // a step from or into v = 0 (the stop): constant acceleration over DS
        let dt = if v > 1e-9 { DS / v } else { (2.0 * DS / acc).sqrt() };
        t[i] = t[i - 1] + dt + if Some(i) == stop_i { stop.unwrap().1 } else { 0.0 };
    }
    t
}

/// Samples a timed path every WORLD_DT seconds (linear interpolation); adds `lateral` metres to
/// the left of the direction of travel. The samples are counted against `budget` before they are
/// allocated (fallibly).
fn sample_world(path: &[[f64; 2]], times: &[f64], lateral: f64, budget: &mut Budget) -> Result<Vec<[f64; 3]>, SimError> {
    let t_end = *times.last().unwrap();
    let mut t = (times[0] / WORLD_DT).ceil() * WORLD_DT;
    let n = ((t_end - t) / WORLD_DT).max(0.0) as usize + 2;
    budget.charge(n, std::mem::size_of::<[f64; 3]>())?;
    let mut out = Vec::new();
    budget.reserve(&mut out, n)?;
    let mut j = 0;
    while t <= t_end {
        while j + 1 < times.len() - 1 && times[j + 1] < t {
            j += 1;
        }
        let (ta, tb) = (times[j], times[j + 1]);
        let f = if tb > ta { ((t - ta) / (tb - ta)).clamp(0.0, 1.0) } else { 0.0 };
        let (a, b) = (path[j], path[j + 1]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let l = (dx * dx + dy * dy).sqrt().max(1e-12);
        budget.push(&mut out, [t, a[0] + f * dx - lateral * dy / l, a[1] + f * dy + lateral * dx / l])?;
        t += WORLD_DT;
    }
    Ok(out)
}

/// Memory that must stay free after every reservation of the simulation (64 MiB): room for the
/// small allocations no one can make fallible.
const HEADROOM_BYTES: usize = 64 << 20;

/// The memory one simulation holds, counted against the limit `memory_bytes` before it is
/// allocated (and every large allocation fallible), so that a scenario too large is an error
/// that says what to reduce, never an abort of the host process.
struct Budget {
    used: u128,
    limit: u64,
}

impl Budget {
    fn new() -> Self {
        Budget { used: 0, limit: trajdb_algo::limits::MEMORY_BYTES.get() }
    }

    fn too_large(&self) -> SimError {
        SimError::Param(format!(
            "this scenario needs more than memory_bytes = {} bytes; reduce minutes, traffic or pedestrians (or cameras, rate_hz, \
             noise_tracks_per_min), or raise the limit (in SQL: CALL trajdb_set_limit('memory_bytes', {}))",
            self.limit,
            self.limit.saturating_mul(4)
        ))
    }

    /// Counts `n` items of `each` bytes.
    fn charge(&mut self, n: usize, each: usize) -> Result<(), SimError> {
        self.used = self.used.saturating_add(n as u128 * each as u128);
        if self.used > self.limit as u128 {
            return Err(self.too_large());
        }
        Ok(())
    }

    /// Gives back `n` items of `each` bytes (freed).
    fn release(&mut self, n: usize, each: usize) {
        self.used = self.used.saturating_sub(n as u128 * each as u128);
    }

    /// Room for `n` more items, or the error. After the reservation, [`HEADROOM_BYTES`] more
    /// must still be available (a trial allocation, freed at once): with `memory_bytes` lifted,
    /// the fallible buffers could otherwise fill the address space to the last page, and the
    /// next small infallible allocation (a route name, DuckDB's own) would abort the host (the
    /// harness saw "memory allocation of 8192 bytes failed" under a 3.5 GB cap).
    fn reserve<T>(&self, v: &mut Vec<T>, n: usize) -> Result<(), SimError> {
        v.try_reserve(n).map_err(|_| self.too_large())?;
        let mut probe: Vec<u8> = Vec::new();
        probe.try_reserve_exact(HEADROOM_BYTES).map_err(|_| self.too_large())
    }

    /// A push that cannot abort the process.
    fn push<T>(&self, v: &mut Vec<T>, x: T) -> Result<(), SimError> {
        if v.len() == v.capacity() {
            self.reserve(v, v.len().max(16))?;
        }
        v.push(x);
        Ok(())
    }
}

/// About the fewest bytes a scenario takes, before any work: the expected road users times the
/// fewest world samples one can have (a car crossing at 14 m/s: 10 s; a pedestrian: 59 s), and
/// the spurious tracks (at least 3 points each).
fn expected_bytes(p: &SimParams) -> f64 {
    let (vehicles, walkers) = (p.minutes * p.traffic * (11.0 + 2.0 * p.cyclists), p.minutes * p.traffic * 3.0 * p.pedestrians);
    let sample = std::mem::size_of::<[f64; 3]>() as f64;
    let noise = p.cameras as f64 * (p.noise_tracks_per_min * p.minutes).round() * 3.0;
    let point = (std::mem::size_of::<(f64, f64, f64, bool)>() + std::mem::size_of::<PointRow>()) as f64;
    // a waiting group: at least 2 people standing 10 s and crossing in 5 s
    let grouped = p.minutes * p.waiting_groups * 2.0;
    (vehicles * 10.0 + walkers * 59.0 + grouped * 15.0) / WORLD_DT * sample + noise * point
}

fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    if hi > lo {
        rng.gen_range(lo..hi)
    } else {
        lo
    }
}

/// Generates the road users (their samples counted against `budget`).
fn objects(p: &SimParams, rng: &mut ChaCha8Rng, budget: &mut Budget) -> Result<Vec<Object>, SimError> {
    let horizon = p.minutes * 60.0;
    let rates = [10.0, 1.0, 2.0, 3.0];
    let mut out = Vec::new();
    // per entry lane (arm, kind 0 = road, 1 = bike): the last vehicle's (entry time, cruise
    // speed, time it leaves the stop line)
    let mut lane_last: [[(f64, f64, f64); 2]; 4] = [[(-1e9, f64::INFINITY, -1e9); 2]; 4];
    let mut arrivals: Vec<(f64, usize)> = Vec::new();
    for (c, r) in rates.iter().enumerate() {
        let r = match c {
            3 => r * p.pedestrians,
            2 => r * p.cyclists,
            _ => *r,
        };
        if r <= 0.0 {
            continue;
        }
        let exp = Exp::new(r * p.traffic / 60.0).unwrap();
        let mut t = exp.sample(rng);
        while t < horizon {
            budget.charge(1, std::mem::size_of::<(f64, usize)>())?;
            budget.push(&mut arrivals, (t, c))?;
            t += exp.sample(rng);
        }
    }
    arrivals.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n_arrivals = arrivals.len();
    for (t_arr, c) in arrivals {
        let class = CLASSES[c];
        if c < 3 {
            let a = rng.gen_range(0..4);
            let turn = rng.gen_range(0..10); // 0..5 straight, 5..7 left, 7..10 right
            let b = match turn {
                0..=4 => (a + 2) % 4,
                5..=6 => (a + 3) % 4, // from E heading west, a left turn goes south
                _ => (a + 1) % 4,
            };
            let kind = usize::from(c == 2);
            let off = if c == 2 { BIKE } else { LANE };
            let (path, stop_s, turn_rng) = vehicle_path(a, b, off);
            let (mut v, v_turn, acc) = match c {
                0 => (uniform(rng, 9.0, 14.0), if turn >= 7 { uniform(rng, 4.5, 6.0) } else { uniform(rng, 6.0, 8.0) }, 2.0),
                1 => (uniform(rng, 7.0, 10.0), if turn >= 7 { uniform(rng, 3.5, 4.5) } else { uniform(rng, 4.5, 6.0) }, 1.2),
                _ => (uniform(rng, 3.5, 6.5), uniform(rng, 3.0, 4.5), 1.0),
            };
            let (last_t, last_v, last_pass) = lane_last[a][kind];
            let t0 = t_arr.max(last_t + 2.5);
            if t0 - last_t < 15.0 {
                v = v.min(last_v);
            }
            let slow = if (b + 4 - a) % 4 == 2 { vec![] } else { vec![(turn_rng.0, turn_rng.1, v_turn.min(v))] };
            let mut stop = if rng.gen_bool(if c == 2 { 0.2 } else { 0.35 }) { Some((stop_s, uniform(rng, 1.0, 8.0))) } else { None };
            let stop_i = ((stop_s / DS) as usize).min(path.len() - 1);
            let mut times = time_along(path.len(), v, &slow, stop, acc, 3.0, t0);
            // a queue: never pass the stop line less than 2 s after the vehicle ahead
            if times[stop_i] < last_pass + 2.0 {
                let dwell = stop.map_or(0.0, |s| s.1) + last_pass + 2.0 - times[stop_i] + 1.0;
                stop = Some((stop_s, dwell));
                times = time_along(path.len(), v, &slow, stop, acc, 3.0, t0);
            }
            lane_last[a][kind] = (t0, v, times[stop_i]);
            let names = ["E", "N", "W", "S"];
            let samples = sample_world(&path, &times, 0.0, budget)?;
            budget.charge(1, std::mem::size_of::<Object>() + 32)?;
            budget.push(&mut out, Object { id: 0, class, route: format!("{class}:{}->{}", names[a], names[b]), samples })?;
        } else {
            // pedestrian: sidewalk graph; node (arm, side) is the curb point at CROSS metres
            let (mut a, mut side) = (rng.gen_range(0..4usize), if rng.gen_bool(0.5) { 1.0 } else { -1.0 });
            let jitter = uniform(rng, -0.8, 0.8);
            let w = WALK + jitter;
            let sw = |a: usize, side: f64, d: f64| -> [f64; 2] {
                let u = arm(a);
                let n = [-u[1], u[0]];
                [d * u[0] + side * w * n[0], d * u[1] + side * w * n[1]]
            };
            let mut poly = vec![sw(a, side, 50.0), sw(a, side, CROSS)];
            let mut waits = Vec::new();
            let hops = rng.gen_range(1..=3);
            let mut crossed = false;
            for h in 0..hops {
                if !crossed && (h == 0 || rng.gen_bool(0.5)) {
                    // cross arm a
                    let s_before: f64 = poly.windows(2).map(|q| dist(q[0], q[1])).sum();
                    if rng.gen_bool(0.3) {
                        waits.push((s_before, uniform(rng, 2.0, 10.0)));
                    }
                    side = -side;
                    poly.push(sw(a, side, CROSS));
                    crossed = true;
                } else {
                    // round the corner to the neighbouring arm on this side
                    let b = if side > 0.0 { (a + 1) % 4 } else { (a + 3) % 4 };
                    let u = arm(a);
                    let ub = arm(b);
                    poly.push([w * u[0] + w * ub[0], w * u[1] + w * ub[1]]);
                    side = -side;
                    a = b;
                    poly.push(sw(a, side, CROSS));
                    crossed = false;
                }
            }
            poly.push(sw(a, side, 50.0));
            let path = resample(&poly);
            let v = uniform(rng, 1.0, 1.6);
            let times = time_along(path.len(), v, &[], waits.first().copied(), 0.8, 1.0, t_arr);
            let samples = sample_world(&path, &times, 0.0, budget)?;
            let pair = rng.gen_bool(0.15);
            budget.charge(1, std::mem::size_of::<Object>() + 32)?;
            budget.push(&mut out, Object { id: 0, class, route: format!("pedestrian:{hops} hops"), samples })?;
            if pair {
                let samples = sample_world(&path, &times, 0.7, budget)?;
                budget.charge(1, std::mem::size_of::<Object>() + 48)?;
                budget.push(&mut out, Object { id: 0, class, route: format!("pedestrian:{hops} hops, walking in a pair"), samples })?;
            }
        }
    }
    budget.release(n_arrivals, std::mem::size_of::<(f64, usize)>());
    waiting_groups(p, budget, &mut out)?;
    for (i, o) in out.iter_mut().enumerate() {
        o.id = i as i64;
    }
    Ok(out)
}

/// The most waiting groups per minute (`waiting_groups`).
pub const MAX_WAITING_GROUPS: f64 = 60.0;
/// A waiting group's members stand this far from their nearest neighbour (m).
pub const GROUP_SPACING: (f64, f64) = (0.6, 2.0);
/// A waiting group stands for this long (s), from its last member's arrival to the green.
pub const GROUP_WAIT: (f64, f64) = (10.0, 60.0);
/// Members arrive at their spots within this long before the last one (s).
const GROUP_ARRIVAL_SPREAD: f64 = 2.0;
/// Each member starts this long after the green (s).
const GROUP_START_DELAY: f64 = 1.0;
/// Cyclists' cruise speed range (m/s) in waiting groups.
const CYCLIST_SPEED: (f64, f64) = (3.0, 7.0);

/// A random stream of its own for each optional degradation (ChaCha8 streams of the seed), so
/// that an option left at its default draws nothing and the scenario stays what it was.
fn stream(seed: u64, k: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(k);
    r
}
const STREAM_GROUPS: u64 = 1;
const STREAM_DRIFT: u64 = 2;
const STREAM_JITTER: u64 = 3;
const STREAM_ORIGIN: u64 = 4;
const STREAM_BIAS: u64 = 5;
const STREAM_GROUND: u64 = 6;
const STREAM_OCCLUSION: u64 = 7;
const STREAM_SITE: u64 = 8;

/// A camera stands this far beyond its view's far short side (m; [`Camera::position`]).
pub const CAMERA_SETBACK_M: f64 = 5.0;
/// A perspective error of `ground_plane_perspective` is its relative error at this range (m).
pub const PERSPECTIVE_RANGE_M: f64 = 50.0;
/// A viewpoint bias is drawn uniformly in [this, 1] times its class's largest (a detector's
/// ground point is never the centre: at least the half width of the road user).
pub const VIEWPOINT_BIAS_MIN_SHARE: f64 = 0.3;
/// Road users closer than this (m, centre to centre) occlude each other ([`occlude`]).
pub const OCCLUSION_RADIUS_M: f64 = 2.0;
/// An occlusion hides its road user for a uniform draw in this range (s).
pub const OCCLUSION_GAP_S: (f64, f64) = (0.3, 3.0);
/// Of the occlusions, these shares end the track for the rest of the view (the tracker lost it)
/// and drop the track so far (it was only picked up after the occlusion); the rest hide the
/// road user for a gap, after which it is a new track.
pub const OCCLUSION_LOST_SHARE: f64 = 0.2;
pub const OCCLUSION_LATE_SHARE: f64 = 0.2;
/// The crowd is counted every this many seconds.
const OCCLUSION_BIN_S: f64 = 0.5;

/// Viewpoint bias (issue 38): a detector reports the bottom of a road user's box, the point of
/// it nearest the camera, not its centre: seen from the front, back or side, a car's reported
/// point is 0.5–2 m from its centre (CAROM, arXiv 2104.00893: 0.8 m mean within 50 m of the
/// camera), a pedestrian's or cyclist's 0.1–0.3 m. The offset lies along the camera's line of
/// sight, towards the camera, and stays while the camera sees the road user. Per (camera, road
/// user): magnitude uniform in [[`VIEWPOINT_BIAS_MIN_SHARE`], 1] × the class's largest
/// (`viewpoint_bias`: vehicles, then pedestrians and cyclists), direction from the road user's
/// position in the middle of its first run in the view towards the camera. Returns the
/// magnitudes, one per object (drawn for every object, seen or not, from a stream of its own).
fn viewpoint_bias_magnitudes(p: &SimParams, rng: &mut ChaCha8Rng, objects: &[Object]) -> Vec<f64> {
    if p.viewpoint_bias == (0.0, 0.0) {
        return vec![0.0; objects.len()];
    }
    objects
        .iter()
        .map(|o| {
            let max = if matches!(o.class, "car" | "heavy_vehicle") { p.viewpoint_bias.0 } else { p.viewpoint_bias.1 };
            max * uniform(rng, VIEWPOINT_BIAS_MIN_SHARE, 1.0)
        })
        .collect()
}

/// Where road users are every [`OCCLUSION_BIN_S`] seconds, on a grid of [`OCCLUSION_RADIUS_M`]
/// cells: `(time bin, cell x, cell y) → (object, x, y)`.
struct Crowd {
    cells: std::collections::HashMap<(i64, i64, i64), Vec<(usize, f64, f64)>>,
}

impl Crowd {
    fn new(objects: &[Object], budget: &mut Budget) -> Result<Crowd, SimError> {
        let mut cells: std::collections::HashMap<(i64, i64, i64), Vec<(usize, f64, f64)>> = std::collections::HashMap::new();
        for (i, o) in objects.iter().enumerate() {
            let (t0, t1) = (o.samples[0][0], o.samples[o.samples.len() - 1][0]);
            let mut k = (t0 / OCCLUSION_BIN_S).ceil() as i64;
            while k as f64 * OCCLUSION_BIN_S <= t1 {
                if let Some((x, y)) = at(o, k as f64 * OCCLUSION_BIN_S) {
                    budget.charge(1, 48)?;
                    let key = (k, (x / OCCLUSION_RADIUS_M).floor() as i64, (y / OCCLUSION_RADIUS_M).floor() as i64);
                    let v = cells.entry(key).or_default();
                    budget.push(v, (i, x, y))?;
                }
                k += 1;
            }
        }
        Ok(Crowd { cells })
    }

    /// Other road users within [`OCCLUSION_RADIUS_M`] of object `o` (at `x`, `y`) in time bin `k`.
    fn near(&self, k: i64, o: usize, x: f64, y: f64) -> usize {
        let (cx, cy) = ((x / OCCLUSION_RADIUS_M).floor() as i64, (y / OCCLUSION_RADIUS_M).floor() as i64);
        let mut n = 0;
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(v) = self.cells.get(&(k, cx + dx, cy + dy)) {
                    n += v.iter().filter(|q| q.0 != o && (q.1 - x).hypot(q.2 - y) < OCCLUSION_RADIUS_M).count();
                }
            }
        }
        n
    }
}

/// Occlusion in crowds (issue 38): at a real crossing, pedestrians appear and vanish in the
/// middle of a camera's view all the time (hidden by the people around them, detection gaps).
/// Every [`OCCLUSION_BIN_S`] s of a visible run, a cut happens with probability
/// `1 − exp(−occlusion · n · bin)`, n the other road users within [`OCCLUSION_RADIUS_M`]. A cut
/// hides the road user for a gap drawn in [`OCCLUSION_GAP_S`] (it reappears as a new track), or
/// ([`OCCLUSION_LOST_SHARE`]) ends the track for the rest of the view, or
/// ([`OCCLUSION_LATE_SHARE`]) drops the track so far (it is picked up only after the cut): tracks
/// that start or end mid-view with no partner. Returns the run's pieces.
fn occlude(run: Vec<(f64, f64, f64, bool)>, o: usize, crowd: &Crowd, rate: f64, rng: &mut ChaCha8Rng) -> Vec<Vec<(f64, f64, f64, bool)>> {
    let mut pieces = Vec::new();
    let mut cur = Vec::new();
    let mut hidden_until = f64::NEG_INFINITY;
    let mut lost = false;
    let mut bin = i64::MIN;
    for q in run {
        if lost {
            break;
        }
        if q.0 <= hidden_until {
            continue;
        }
        let k = (q.0 / OCCLUSION_BIN_S).round() as i64;
        if k != bin {
            bin = k;
            let n = crowd.near(k, o, q.1, q.2);
            if n > 0 && rng.gen_bool(1.0 - (-rate * n as f64 * OCCLUSION_BIN_S).exp()) {
                let u: f64 = rng.gen();
                if u < OCCLUSION_LOST_SHARE {
                    lost = true;
                    continue;
                } else if u < OCCLUSION_LOST_SHARE + OCCLUSION_LATE_SHARE {
                    cur.clear();
                } else {
                    hidden_until = q.0 + uniform(rng, OCCLUSION_GAP_S.0, OCCLUSION_GAP_S.1);
                    if !cur.is_empty() {
                        pieces.push(std::mem::take(&mut cur));
                    }
                    continue;
                }
            }
        }
        cur.push(q);
    }
    if !cur.is_empty() {
        pieces.push(cur);
    }
    pieces
}
/// Time-stamp jitter is clipped to this many frame periods (so a track's times stay increasing).
pub const JITTER_CLIP: f64 = 0.45;

/// Waiting groups at crossings (issue 26): group events arrive as a Poisson process,
/// `waiting_groups` per minute, each at one crossing (arm a) on one kerb, or on both kerbs at once
/// with probability 1/2 (one green for both). A group has 2–8 members, each a pedestrian or (with
/// probability 0.3) a cyclist. The members arrive one by one within [`GROUP_ARRIVAL_SPREAD`] s,
/// from along the sidewalk or round the corner, and stand still on the pavement at the kerb,
/// each 0.6–2 m from its nearest neighbour ([`GROUP_SPACING`]: positions drawn one by one, each
/// at a random distance in that range from a random earlier member, refused when closer than
/// 0.6 m to any), for W ∈ [10, 60] s drawn per group ([`GROUP_WAIT`]), from the last arrival to
/// the green, swaying slowly by 3–15 cm about the spot (standing people are not frozen). At the green each starts from rest after 0–1 s, crosses straight over (keeping
/// its place in the group's width) and leaves along the far sidewalk or round the far corner:
/// pedestrians at 1.0–1.6 m/s, cyclists at 3–7 m/s. Every member is one object, seen by the
/// cameras like any other road user. Times before 0 are cut (a group already there at the
/// start). Drawn from a random stream of its own: other road users are unchanged.
fn waiting_groups(p: &SimParams, budget: &mut Budget, out: &mut Vec<Object>) -> Result<(), SimError> {
    if p.waiting_groups <= 0.0 {
        return Ok(());
    }
    let rng = &mut stream(p.seed, STREAM_GROUPS);
    let horizon = p.minutes * 60.0;
    let exp = Exp::new(p.waiting_groups / 60.0).unwrap();
    let names = ["E", "N", "W", "S"];
    let mut t = exp.sample(rng);
    let mut g = 0usize;
    while t < horizon {
        let a = rng.gen_range(0..4usize);
        let wait = uniform(rng, GROUP_WAIT.0, GROUP_WAIT.1);
        let green = t + GROUP_ARRIVAL_SPREAD + wait;
        let s0 = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        let sides: &[f64] = if rng.gen_bool(0.5) { &[1.0, -1.0] } else { &[1.0] };
        for &k in sides {
            let side = s0 * k;
            let spots = group_spots(rng);
            g += 1;
            for (m, &(d, l)) in spots.iter().enumerate() {
                let cyclist = rng.gen_bool(0.3);
                let class = if cyclist { "cyclist" } else { "pedestrian" };
                let arrive = t + uniform(rng, 0.0, GROUP_ARRIVAL_SPREAD);
                let start = green + uniform(rng, 0.0, GROUP_START_DELAY);
                let samples = group_member(rng, a, side, (d, l), cyclist, arrive, start, budget)?;
                if samples.is_empty() {
                    continue;
                }
                budget.charge(1, std::mem::size_of::<Object>() + 64)?;
                let route = format!(
                    "{class}:waiting group {g} ({} people) at crossing {}{}; member {}; waits {wait:.1} s",
                    spots.len(),
                    names[a],
                    if side > 0.0 { "+" } else { "-" },
                    m + 1
                );
                budget.push(out, Object { id: 0, class, route, samples })?;
            }
        }
        t += exp.sample(rng);
    }
    Ok(())
}

/// The standing spots of one waiting group, in kerb coordinates (d along the arm from the centre,
/// l from the centre line towards the group's sidewalk): 2–8 people, each 0.6–2 m from its
/// nearest neighbour, on the pavement (l ≥ 6.8 m, the road edge being at 6 m) beside the
/// crosswalk (d within ±4 m of it).
fn group_spots(rng: &mut ChaCha8Rng) -> Vec<(f64, f64)> {
    let n = rng.gen_range(2..=8usize);
    let mut spots = vec![(CROSS + uniform(rng, -1.0, 1.0), 6.8 + uniform(rng, 0.0, 0.4))];
    for _ in 1..n {
        for _try in 0..200 {
            let j = rng.gen_range(0..spots.len());
            let r = uniform(rng, GROUP_SPACING.0, GROUP_SPACING.1);
            let phi = uniform(rng, 0.0, std::f64::consts::TAU);
            let c = (spots[j].0 + r * phi.cos(), spots[j].1 + r * phi.sin());
            let ok = (CROSS - 4.0..=CROSS + 4.0).contains(&c.0)
                && (6.8..=11.0).contains(&c.1)
                && spots.iter().all(|q| (q.0 - c.0).hypot(q.1 - c.1) >= GROUP_SPACING.0);
            if ok {
                spots.push(c);
                break;
            }
        }
    }
    spots
}

/// One waiting-group member's world samples: it arrives at its spot `at` (kerb coordinates of arm
/// `a`, side `side`) at time `arrive`, stands, starts from rest at `start`, crosses the arm and
/// leaves. Samples before t = 0 are dropped.
#[allow(clippy::too_many_arguments)]
fn group_member(
    rng: &mut ChaCha8Rng,
    a: usize,
    side: f64,
    at: (f64, f64),
    cyclist: bool,
    arrive: f64,
    start: f64,
    budget: &mut Budget,
) -> Result<Vec<[f64; 3]>, SimError> {
    let u = arm(a);
    let n = [-u[1], u[0]];
    let kerb = |a: usize, side: f64, d: f64, l: f64| -> [f64; 2] {
        let u = arm(a);
        let n = [-u[1], u[0]];
        [d * u[0] + side * l * n[0], d * u[1] + side * l * n[1]]
    };
    let spot = [at.0 * u[0] + side * at.1 * n[0], at.0 * u[1] + side * at.1 * n[1]];
    let w = WALK + uniform(rng, -0.8, 0.8);
    // from along the sidewalk, or round the corner from the neighbouring arm on this side
    let mut approach = if rng.gen_bool(0.5) {
        vec![kerb(a, side, 50.0, w)]
    } else {
        let b = if side > 0.0 { (a + 1) % 4 } else { (a + 3) % 4 };
        let ub = arm(b);
        vec![kerb(b, -side, 50.0, w), [w * u[0] + w * ub[0], w * u[1] + w * ub[1]]]
    };
    approach.push(spot);
    // straight over to the far kerb, then along the far sidewalk or round the far corner
    let far = kerb(a, -side, at.0 + uniform(rng, -0.5, 0.5), 6.8 + uniform(rng, 0.0, 1.2));
    let w2 = WALK + uniform(rng, -0.8, 0.8);
    let mut leave = vec![spot, far];
    if rng.gen_bool(0.5) {
        leave.push(kerb(a, -side, 50.0, w2));
    } else {
        let b = if -side > 0.0 { (a + 1) % 4 } else { (a + 3) % 4 };
        let ub = arm(b);
        leave.push([w2 * u[0] + w2 * ub[0], w2 * u[1] + w2 * ub[1]]);
        leave.push(kerb(b, side, 50.0, w2));
    }
    let (v, acc, brake) = if cyclist { (uniform(rng, CYCLIST_SPEED.0, CYCLIST_SPEED.1), 1.0, 1.5) } else { (uniform(rng, 1.0, 1.6), 0.8, 1.0) };
    let (pa, pl) = (resample(&approach), resample(&leave));
    // the approach ends at rest on the spot; the departure starts from rest
    let ta = time_along(pa.len(), v, &[], Some((f64::MAX, 0.0)), acc, brake, 0.0);
    let shift = arrive - ta[ta.len() - 1];
    let tl = time_along(pl.len(), v, &[], Some((0.0, 0.0)), acc, brake, start);
    let path: Vec<[f64; 2]> = pa.iter().chain(pl.iter()).copied().collect();
    let times: Vec<f64> = ta.iter().map(|t| t + shift).chain(tl.iter().copied()).collect();
    let mut samples = sample_world(&path, &times, 0.0, budget)?;
    // people standing are not frozen: a slow sway of a few centimetres about the spot (two
    // sines of 7-20 s, faded in and out over the wait)
    let amp = uniform(rng, 0.03, 0.15);
    let (f1, f2) = (uniform(rng, 0.05, 0.15), uniform(rng, 0.05, 0.15));
    let (p1, p2) = (uniform(rng, 0.0, std::f64::consts::TAU), uniform(rng, 0.0, std::f64::consts::TAU));
    for q in samples.iter_mut().filter(|q| q[0] > arrive && q[0] < start) {
        let (dt, tau) = (q[0] - arrive, std::f64::consts::TAU);
        let fade = (std::f64::consts::PI * dt / (start - arrive)).sin();
        q[1] += amp * fade * (tau * f1 * dt + p1).sin();
        q[2] += amp * fade * (tau * f2 * dt + p2).sin();
    }
    samples.retain(|s| s[0] >= 0.0);
    Ok(samples)
}

/// The cameras, drawn from `rng` (after the road users, as the first simulator did) or, with a
/// site seed, from a stream of the site's own; their degradations from streams of `seed` (the
/// site's when given).
fn place_cameras(p: &SimParams, rng: &mut ChaCha8Rng) -> Vec<Camera> {
    let seed = p.site_seed.unwrap_or(p.seed);
    let mut cams = match p.site_seed {
        Some(s) => place_cameras_rigid(p, &mut stream(s, STREAM_SITE)),
        None => place_cameras_rigid(p, rng),
    };
    // the clock degradations, from a stream of their own (nothing drawn at their defaults)
    if p.clock_drift_ppm > 0.0 {
        let rng = &mut stream(seed, STREAM_DRIFT);
        for c in &mut cams {
            c.clock_drift_ppm = uniform(rng, -p.clock_drift_ppm, p.clock_drift_ppm);
        }
    }
    if p.clock_epoch != 0.0 {
        for c in &mut cams {
            c.clock_offset += p.clock_epoch;
        }
    }
    // the ground-plane calibration errors, from a stream of their own
    if p.ground_plane_scale > 0.0 || p.ground_plane_perspective > 0.0 {
        let rng = &mut stream(seed, STREAM_GROUND);
        for c in &mut cams {
            let scale = 1.0 + uniform(rng, -p.ground_plane_scale, p.ground_plane_scale);
            let (m, phi) = (uniform(rng, 0.0, p.ground_plane_perspective) / PERSPECTIVE_RANGE_M, uniform(rng, 0.0, std::f64::consts::TAU));
            c.ground = GroundPlane { scale, h: [m * phi.cos(), m * phi.sin()] };
        }
    }
    // frames far from the origin: p_local' = p_local + O, so t' = t − R(θ)·O
    if p.origin != Origin::Near {
        let rng = &mut stream(seed, STREAM_ORIGIN);
        for c in &mut cams {
            let (ox, oy) = match p.origin {
                Origin::At(x, y) => (x, y),
                _ => (uniform(rng, 4.5e5, 5e5), uniform(rng, 5.7e6, 5.75e6)),
            };
            let (sn, cs) = c.theta.sin_cos();
            c.tx -= cs * ox - sn * oy;
            c.ty -= sn * ox + cs * oy;
        }
    }
    cams
}

/// The cameras' views, frames, offsets, noise and phases (the draws of the original simulator).
fn place_cameras_rigid(p: &SimParams, rng: &mut ChaCha8Rng) -> Vec<Camera> {
    let base = uniform(rng, 0.0, std::f64::consts::TAU);
    (0..p.cameras)
        .map(|k| {
            let phi = base + std::f64::consts::TAU * k as f64 / p.cameras as f64 + uniform(rng, -0.2, 0.2);
            let r = uniform(rng, 14.0, 20.0);
            let c = [r * phi.cos(), r * phi.sin()];
            let ang = phi + uniform(rng, -0.15, 0.15);
            let (u, v) = ([ang.cos(), ang.sin()], [-ang.sin(), ang.cos()]);
            let (hl, hw) = (24.0, 18.0);
            let corner = |a: f64, b: f64| [c[0] + a * hl * u[0] + b * hw * v[0], c[1] + a * hl * u[1] + b * hw * v[1]];
            Camera {
                id: k as i64,
                theta: uniform(rng, 0.0, std::f64::consts::TAU),
                tx: uniform(rng, -60.0, 60.0),
                ty: uniform(rng, -60.0, 60.0),
                view_world: [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)],
                clock_offset: uniform(rng, -p.clock_offset_max, p.clock_offset_max),
                clock_drift_ppm: 0.0,
                sigma: uniform(rng, p.noise_sigma.0, p.noise_sigma.1),
                rate_hz: p.rate_hz[k % p.rate_hz.len()],
                phase: uniform(rng, 0.0, 1.0 / p.rate_hz[k % p.rate_hz.len()]),
                ground: GroundPlane::EXACT,
            }
        })
        .collect()
}

/// Interpolated world position of `o` at time t (None outside its lifetime).
fn at(o: &Object, t: f64) -> Option<(f64, f64)> {
    let s = &o.samples;
    if s.is_empty() || t < s[0][0] || t > s[s.len() - 1][0] {
        return None;
    }
    let j = (((t - s[0][0]) / WORLD_DT) as usize).min(s.len().saturating_sub(2));
    if s.len() == 1 {
        return Some((s[0][1], s[0][2]));
    }
    let (a, b) = (s[j], s[j + 1]);
    let f = ((t - a[0]) / (b[0] - a[0])).clamp(0.0, 1.0);
    Some((a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])))
}

/// One camera's view of one object: (object id or −1, class, world samples (t, x, y, estimated)).
type SeenTrack = (i64, &'static str, Vec<(f64, f64, f64, bool)>);

/// Runs the simulation. Its memory is counted against the limit `memory_bytes`: a scenario
/// whose expected road users alone exceed it is refused before any work ([`expected_bytes`]),
/// and the samples, tracks and points are counted as they are made (an error as soon as they
/// pass it; every large allocation fallible).
pub fn simulate(p: &SimParams) -> Result<Scenario, SimError> {
    p.validate()?;
    let mut budget = Budget::new();
    if expected_bytes(p) > budget.limit as f64 {
        return Err(budget.too_large());
    }
    let mut rng = ChaCha8Rng::seed_from_u64(p.seed);
    let objects = objects(p, &mut rng, &mut budget)?;
    let cameras = place_cameras(p, &mut rng);
    let mut points = Vec::new();
    let mut truth = Vec::new();
    const SEEN: usize = std::mem::size_of::<(f64, f64, f64, bool)>();
    // time-stamp jitter, from a stream of its own (none drawn without it)
    let mut jitter = (p.time_jitter_s > 0.0).then(|| (stream(p.seed, STREAM_JITTER), Normal::new(0.0, p.time_jitter_s).unwrap()));
    // occlusion in crowds, from a stream of its own (nothing built or drawn without it)
    let crowd = if p.occlusion > 0.0 { Some(Crowd::new(&objects, &mut budget)?) } else { None };
    let mut occ_rng = stream(p.seed, STREAM_OCCLUSION);
    // viewpoint bias, from a stream of its own (camera by camera, object by object)
    let mut bias_rng = stream(p.seed, STREAM_BIAS);
    for cam in &cameras {
        let cam_pos = cam.position();
        let bias_m = viewpoint_bias_magnitudes(p, &mut bias_rng, &objects);
        // per object: its viewpoint bias in this camera (world vector; set at its first run)
        let mut bias: Vec<Option<[f64; 2]>> = vec![None; objects.len()];
        let mut seen = 0usize;
        // the frames are 1/rate_hz apart on the camera's clock: dt in world time
        let dt = cam.world_period();
        let noise = Normal::new(0.0, cam.sigma.max(1e-12)).unwrap();
        let mut tracks: Vec<SeenTrack> = Vec::new();
        for o in &objects {
            let (t0, t1) = (o.samples[0][0], o.samples[o.samples.len() - 1][0]);
            let mut k = ((t0 - cam.phase) / dt).ceil() as i64;
            let mut run: Vec<(f64, f64, f64, bool)> = Vec::new();
            let mut runs = Vec::new();
            loop {
                let t = cam.phase + k as f64 * dt;
                if t > t1 {
                    break;
                }
                k += 1;
                match at(o, t) {
                    Some((x, y)) if cam.sees(x, y) => {
                        budget.charge(1, SEEN)?;
                        seen += 1;
                        budget.push(&mut run, (t, x, y, false))?;
                    }
                    _ => {
                        if !run.is_empty() {
                            runs.push(std::mem::take(&mut run));
                        }
                    }
                }
            }
            if !run.is_empty() {
                runs.push(run);
            }
            if let (Some(first), true) = (runs.first(), bias_m[o.id as usize] > 0.0) {
                let mid = first[first.len() / 2];
                let (dx, dy) = (cam_pos[0] - mid.1, cam_pos[1] - mid.2);
                let l = dx.hypot(dy).max(1e-9);
                let m = bias_m[o.id as usize];
                bias[o.id as usize] = Some([m * dx / l, m * dy / l]);
            }
            if let Some(crowd) = &crowd {
                runs = runs.into_iter().flat_map(|r| occlude(r, o.id as usize, crowd, p.occlusion, &mut occ_rng)).collect();
            }
            for r in runs.into_iter().filter(|r| r.len() >= 3) {
                // a break: a gap of 0.5–2 s, both parts >= 1 s (so the run must last > 1 + 2 + 1 s)
                let dur = r[r.len() - 1].0 - r[0].0;
                if rng.gen_bool(p.p_break) && dur > 4.0 {
                    let gap = uniform(&mut rng, 0.5, 2.0);
                    let cut = r[0].0 + uniform(&mut rng, 1.0, dur - 1.0 - gap);
                    let first: Vec<_> = r.iter().copied().filter(|q| q.0 < cut).collect();
                    let second: Vec<_> = r.iter().copied().filter(|q| q.0 > cut + gap).collect();
                    for part in [first, second] {
                        if part.len() >= 3 {
                            budget.charge(part.len(), SEEN)?;
                            seen += part.len();
                            budget.push(&mut tracks, (o.id, o.class, part))?;
                        }
                    }
                } else {
                    budget.push(&mut tracks, (o.id, o.class, r))?;
                }
            }
        }
        // coasting tails
        for (_, _, tr) in tracks.iter_mut() {
            if tr.len() >= 2 && rng.gen_bool(p.p_est) {
                let (a, b) = (tr[tr.len() - 2], tr[tr.len() - 1]);
                let (vx, vy) = ((b.1 - a.1) / dt, (b.2 - a.2) / dt);
                for j in 1..=rng.gen_range(2..=5) {
                    let h = j as f64 * dt;
                    budget.charge(1, SEEN)?;
                    seen += 1;
                    budget.push(tr, (b.0 + h, b.1 + vx * h, b.2 + vy * h, true))?;
                }
            }
        }
        // spurious tracks, inside the view
        let n_noise = (p.noise_tracks_per_min * p.minutes).round() as usize;
        for _ in 0..n_noise {
            let (fa, fb) = (uniform(&mut rng, 0.1, 0.9), uniform(&mut rng, 0.1, 0.9));
            let v = cam.view_world;
            let x = v[0][0] + fa * (v[1][0] - v[0][0]) + fb * (v[3][0] - v[0][0]);
            let y = v[0][1] + fa * (v[1][1] - v[0][1]) + fb * (v[3][1] - v[0][1]);
            let (sp, hd) = (uniform(&mut rng, 0.0, 2.0), uniform(&mut rng, 0.0, std::f64::consts::TAU));
            let t0 = cam.phase + (uniform(&mut rng, 0.0, p.minutes * 60.0) / dt).floor() * dt;
            // i32, as the type inference gave it before: the draw (and so the scenario) stays the same
            let n: i32 = rng.gen_range(3..=8);
            budget.charge(n as usize, SEEN)?;
            seen += n as usize;
            let pts = (0..n).map(|j| (t0 + j as f64 * dt, x + sp * hd.cos() * j as f64 * dt, y + sp * hd.sin() * j as f64 * dt, true)).collect();
            budget.push(&mut tracks, (-1, CLASSES[rng.gen_range(0..4)], pts))?;
        }
        // fresh ids increasing with start time
        tracks.sort_by(|a, b| a.2[0].0.total_cmp(&b.2[0].0));
        let mut id = rng.gen_range(1000..5000i64);
        for (obj, class, tr) in tracks {
            id += rng.gen_range(1..=3);
            budget.charge(1 + tr.len(), std::mem::size_of::<PointRow>())?;
            budget.reserve(&mut points, tr.len())?;
            budget.push(&mut truth, (cam.id, id, obj, obj < 0))?;
            let b = if obj >= 0 { bias[obj as usize].unwrap_or([0.0, 0.0]) } else { [0.0, 0.0] };
            let local: Vec<(f64, f64, f64, bool)> = tr
                .iter()
                .map(|&(t, x, y, e)| {
                    // the reported point: viewpoint bias, then the ground-plane error, then noise
                    let (x, y) = if b == [0.0, 0.0] { (x, y) } else { (x + b[0], y + b[1]) };
                    let [x, y] = cam.ground.apply(cam_pos, [x, y]);
                    let (lx, ly) = cam.to_local(x + noise.sample(&mut rng), y + noise.sample(&mut rng));
                    let off = jitter.as_mut().map_or(0.0, |(r, n)| n.sample(r).clamp(-JITTER_CLIP / cam.rate_hz, JITTER_CLIP / cam.rate_hz));
                    (cam.clock(t) + off, lx, ly, e)
                })
                .collect();
            for (j, &(t, x, y, e)) in local.iter().enumerate() {
                let (a, b) = if j == 0 { (local[0], local[1]) } else { (local[j - 1], local[j]) };
                let speed = ((b.1 - a.1).powi(2) + (b.2 - a.2).powi(2)).sqrt() / (b.0 - a.0);
                points.push(PointRow { camera: cam.id, track_id: id, class, t, x, y, speed, estimated: e });
            }
        }
        // this camera's tracks are gone: only its points stay
        budget.release(seen, SEEN);
    }
    Ok(Scenario { params: p.clone(), objects, cameras, points, truth })
}

fn wkt(ring: &[[f64; 2]; 4]) -> String {
    let mut s = String::from("POLYGON ((");
    for p in ring.iter().chain(std::iter::once(&ring[0])) {
        let _ = write!(s, "{} {}, ", p[0], p[1]);
    }
    s.truncate(s.len() - 2);
    s.push_str("))");
    s
}

/// Simulates into folder `dir`: claims the folder first (before any work: it must be new, empty
/// or hold an earlier scenario; [`outdir`]), simulates, writes the files into the claim's
/// staging folder and moves them into place ([`Scenario::write`]). A failure leaves `dir` as it
/// was.
pub fn simulate_into(p: &SimParams, dir: &Path, command: &str) -> Result<Scenario, SimError> {
    p.validate()?;
    let claim = claim(dir)?;
    match simulate(p).and_then(|s| s.write_files(&claim.partial, command).map(|()| s)) {
        Ok(s) => {
            claim.commit()?;
            Ok(s)
        }
        Err(e) => {
            claim.abort();
            Err(e)
        }
    }
}

/// The scenario's files: a new, empty or earlier-scenario folder, with its lock and staging
/// folder ([`outdir::claim`]).
fn claim(dir: &Path) -> Result<outdir::Claim, SimError> {
    let out = dir.to_str().ok_or_else(|| SimError::Folder(format!("the folder name {} is not UTF-8; name another folder", dir.display())))?;
    Ok(outdir::claim(out, &[], outdir::Kind::Scenario)?)
}

impl Scenario {
    /// Writes points.csv, cameras.csv, truth.csv, world.csv (unless world_rate_hz = 0),
    /// objects.csv and README.txt into `dir` (created if needed).
    ///
    /// Never loses a file: `dir` must be new, empty, or hold an earlier trajdb scenario (its
    /// manifest `.trajdb-results`, of kind scenario, lists what trajdb wrote; a pipeline's
    /// results folder is refused, as a pipeline refuses a scenario's); any other folder is refused
    /// before anything is written. The files are written into a staging folder inside `dir` and
    /// renamed into place, so a failure leaves the earlier scenario (or nothing) behind, never a
    /// half-written one; files of the earlier scenario that this one does not write go.
    /// `more` writes further files into the staging folder before the move (the `trajdb
    /// simulate` command's points.parquet, which needs DuckDB).
    pub fn write_with(&self, dir: &Path, command: &str, more: impl FnOnce(&Path) -> Result<(), SimError>) -> Result<(), SimError> {
        let claim = claim(dir)?;
        match self.write_files(&claim.partial, command).and_then(|()| more(&claim.partial)) {
            Ok(()) => {
                claim.commit()?;
                Ok(())
            }
            Err(e) => {
                claim.abort();
                Err(e)
            }
        }
    }

    /// [`Scenario::write_with`] without further files.
    pub fn write(&self, dir: &Path, command: &str) -> Result<(), SimError> {
        self.write_with(dir, command, |_| Ok(()))
    }

    /// Writes the files into `dir`, an existing folder of our own (the staging folder).
    fn write_files(&self, dir: &Path, command: &str) -> Result<(), SimError> {
        // the writers' buffers and lines are small infallible allocations: refuse, not abort,
        // when the simulation left no room for them (limits lifted, the address space full)
        let mut probe: Vec<u8> = Vec::new();
        probe.try_reserve_exact(HEADROOM_BYTES).map_err(|_| Budget::new().too_large())?;
        drop(probe);
        let file = |n: &str| -> Result<BufWriter<std::fs::File>, SimError> { Ok(BufWriter::new(std::fs::File::create(dir.join(n))?)) };
        let mut f = file("points.csv")?;
        writeln!(f, "camera,track_id,class,t,x,y,speed,estimated")?;
        for p in &self.points {
            writeln!(f, "{},{},{},{:.6},{:.6},{:.6},{:.6},{}", p.camera, p.track_id, p.class, p.t, p.x, p.y, p.speed, u8::from(p.estimated))?;
        }
        f.flush()?;
        let mut f = file("cameras.csv")?;
        // the camera's position and ground-plane error only when the scene has them (older
        // scenes stay byte for byte the same)
        let seen_from = self.params.viewpoint_bias != (0.0, 0.0) || self.params.ground_plane_scale > 0.0 || self.params.ground_plane_perspective > 0.0;
        writeln!(
            f,
            "camera,theta_rad,tx,ty,view_wkt_world,view_wkt_local,clock_offset_s,noise_sigma_m,rate_hz,phase_s,clock_drift_ppm{}",
            if seen_from { ",camera_x,camera_y,ground_scale,ground_hx,ground_hy" } else { "" }
        )?;
        for c in &self.cameras {
            let local = c.view_world.map(|q| {
                let (x, y) = c.to_local(q[0], q[1]);
                [x, y]
            });
            write!(
                f,
                "{},{},{},{},\"{}\",\"{}\",{},{},{},{},{}",
                c.id,
                c.theta,
                c.tx,
                c.ty,
                wkt(&c.view_world),
                wkt(&local),
                c.clock_offset,
                c.sigma,
                c.rate_hz,
                c.phase,
                c.clock_drift_ppm
            )?;
            if seen_from {
                let q = c.position();
                write!(f, ",{},{},{},{},{}", q[0], q[1], c.ground.scale, c.ground.h[0], c.ground.h[1])?;
            }
            writeln!(f)?;
        }
        f.flush()?;
        let mut f = file("truth.csv")?;
        writeln!(f, "camera,track_id,object_id,is_noise")?;
        for (c, t, o, n) in &self.truth {
            writeln!(f, "{c},{t},{o},{}", u8::from(*n))?;
        }
        f.flush()?;
        let mut f = file("objects.csv")?;
        writeln!(f, "object_id,class,source")?;
        for o in &self.objects {
            // quoted when it holds a comma ("..., walking in a pair" broke the row before)
            if o.route.contains([',', '"']) {
                writeln!(f, "{},{},\"sim:{}\"", o.id, o.class, o.route.replace('"', "\"\""))?;
            } else {
                writeln!(f, "{},{},sim:{}", o.id, o.class, o.route)?;
            }
        }
        f.flush()?;
        if self.params.world_rate_hz > 0.0 {
            let step = ((1.0 / self.params.world_rate_hz / WORLD_DT).round() as usize).max(1);
            let mut f = file("world.csv")?;
            writeln!(f, "object_id,class,t,x,y")?;
            for o in &self.objects {
                for s in o.samples.iter().step_by(step) {
                    writeln!(f, "{},{},{:.6},{:.6},{:.6}", o.id, o.class, s[0], s[1], s[2])?;
                }
            }
            f.flush()?;
        }
        let mut f = file("README.txt")?;
        write!(f, "{}", self.readme(command))?;
        f.flush()?;
        Ok(())
    }

    /// The scenario's README.txt: how it was made, and its statistics.
    pub fn readme(&self, command: &str) -> String {
        let p = &self.params;
        let mut s = String::new();
        let _ = writeln!(s, "Synthetic intersection scenario made by `{command}` (trajdb {}).", env!("CARGO_PKG_VERSION"));
        let _ = writeln!(s, "Parameters: {p:?}");
        let _ = writeln!(s, "World: four-arm intersection at the origin (arms E/N/W/S, 70 m), lanes at 1.75 m, bike lanes at 5 m, sidewalks at 8 m, crosswalks 10 m from the centre; see crates/app/src/simulate.rs and docs/simulate.md.");
        let per_class = |c: &str| self.objects.iter().filter(|o| o.class == c).count();
        let _ = writeln!(
            s,
            "Objects: {} (car {}, heavy_vehicle {}, cyclist {}, pedestrian {}).",
            self.objects.len(),
            per_class("car"),
            per_class("heavy_vehicle"),
            per_class("cyclist"),
            per_class("pedestrian")
        );
        if p.waiting_groups > 0.0 {
            let members: Vec<&str> = self.objects.iter().filter_map(|o| o.route.split("waiting group ").nth(1)).collect();
            let groups: std::collections::HashSet<&str> = members.iter().filter_map(|r| r.split(' ').next()).collect();
            let _ = writeln!(s, "Waiting groups: {} people in {} groups (objects.csv source 'waiting group N').", members.len(), groups.len());
        }
        let _ = writeln!(s, "Totals: {} points, {} tracks ({} spurious).", self.points.len(), self.truth.len(), self.truth.iter().filter(|t| t.3).count());
        for c in &self.cameras {
            let n_pts = self.points.iter().filter(|q| q.camera == c.id).count();
            let n_tr = self.truth.iter().filter(|t| t.0 == c.id).count();
            let _ = writeln!(
                s,
                "  cam {}: theta {:.4} rad, t=({:.3},{:.3}) m, sigma {:.3} m, rate {} Hz phase {:.4} s, clock offset {:+.3} s, drift {:+.1} ppm; {} points, {} tracks",
                c.id, c.theta, c.tx, c.ty, c.sigma, c.rate_hz, c.phase, c.clock_offset, c.clock_drift_ppm, n_pts, n_tr
            );
        }
        let _ = writeln!(s, "Files: points.csv / points.parquet (the input), cameras.csv, truth.csv, world.csv, objects.csv (ground truth), as in ../shared/data.");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> SimParams {
        SimParams { cameras: 3, minutes: 2.0, seed: 7, ..SimParams::default() }
    }

    #[test]
    fn deterministic_for_a_seed() {
        let a = simulate(&small()).unwrap();
        let b = simulate(&small()).unwrap();
        assert_eq!(a.points.len(), b.points.len());
        assert!(a.points.iter().zip(&b.points).all(|(p, q)| p.x == q.x && p.t == q.t && p.track_id == q.track_id));
        let c = simulate(&SimParams { seed: 8, ..small() }).unwrap();
        assert_ne!(a.points.len(), c.points.len());
    }

    /// Issue 40: days of one site share their cameras (frames, clocks, noise) and not their traffic.
    #[test]
    fn a_site_seed_keeps_the_cameras() {
        let day = |seed| simulate(&SimParams { seed, site_seed: Some(11), clock_offset_max: 2.0, ..small() }).unwrap();
        let (a, b) = (day(1), day(2));
        for (p, q) in a.cameras.iter().zip(&b.cameras) {
            assert_eq!((p.theta, p.tx, p.ty, p.clock_offset, p.sigma, p.phase), (q.theta, q.tx, q.ty, q.clock_offset, q.sigma, q.phase));
        }
        assert_ne!(a.points.len(), b.points.len());
        let other = simulate(&SimParams { seed: 1, site_seed: Some(12), ..small() }).unwrap();
        assert_ne!(a.cameras[0].theta, other.cameras[0].theta);
    }

    #[test]
    fn points_map_back_to_the_truth() {
        let s = simulate(&SimParams { noise_sigma: (0.0, 0.0), p_est: 0.0, noise_tracks_per_min: 0.0, ..small() }).unwrap();
        let truth: std::collections::HashMap<(i64, i64), i64> = s.truth.iter().map(|t| ((t.0, t.1), t.2)).collect();
        for p in s.points.iter().step_by(37) {
            let cam = &s.cameras[p.camera as usize];
            let (c, sn) = (cam.theta.cos(), cam.theta.sin());
            let (wx, wy) = (c * p.x - sn * p.y + cam.tx, sn * p.x + c * p.y + cam.ty);
            let o = &s.objects[truth[&(p.camera, p.track_id)] as usize];
            let (ex, ey) = at(o, p.t).unwrap();
            assert!((wx - ex).abs() < 1e-6 && (wy - ey).abs() < 1e-6);
            assert!(cam.sees(wx, wy));
        }
    }

    /// World position of a point (the camera's rigid frame undone).
    fn world_of(cam: &Camera, p: &PointRow) -> [f64; 2] {
        let (c, sn) = (cam.theta.cos(), cam.theta.sin());
        [c * p.x - sn * p.y + cam.tx, sn * p.x + c * p.y + cam.ty]
    }

    #[test]
    fn viewpoint_bias_is_constant_along_the_line_of_sight_per_camera_and_road_user() {
        let base = SimParams { noise_sigma: (0.0, 0.0), p_est: 0.0, noise_tracks_per_min: 0.0, ..small() };
        let s = simulate(&SimParams { viewpoint_bias: (1.2, 0.2), ..base.clone() }).unwrap();
        // the other draws are untouched: the same tracks, points and times
        let plain = simulate(&base).unwrap();
        assert_eq!(s.points.len(), plain.points.len());
        assert!(s.points.iter().zip(&plain.points).all(|(a, b)| a.t == b.t && a.track_id == b.track_id));
        let truth: std::collections::HashMap<(i64, i64), i64> = s.truth.iter().map(|t| ((t.0, t.1), t.2)).collect();
        let mut per: std::collections::HashMap<(i64, i64), Vec<[f64; 2]>> = std::collections::HashMap::new();
        for p in &s.points {
            let cam = &s.cameras[p.camera as usize];
            let w = world_of(cam, p);
            let o = &s.objects[truth[&(p.camera, p.track_id)] as usize];
            let (ex, ey) = at(o, p.t).unwrap();
            per.entry((p.camera, o.id)).or_default().push([w[0] - ex, w[1] - ey]);
        }
        let mut seen = [0usize; 2];
        for ((c, o), d) in &per {
            // constant while the camera sees the road user
            assert!(d.iter().all(|q| (q[0] - d[0][0]).abs() < 1e-6 && (q[1] - d[0][1]).abs() < 1e-6), "{c} {o}");
            let m = d[0][0].hypot(d[0][1]);
            let vehicle = matches!(s.objects[*o as usize].class, "car" | "heavy_vehicle");
            let max = if vehicle { 1.2 } else { 0.2 };
            assert!(m >= VIEWPOINT_BIAS_MIN_SHARE * max - 1e-9 && m <= max + 1e-9, "{m} {max}");
            seen[usize::from(vehicle)] += 1;
            // towards the camera: the offset points from the road user to where the camera stands
            let cam = &s.cameras[*c as usize];
            let q = cam.position();
            let (x, y) = at(&s.objects[*o as usize], s.points.iter().find(|p| p.camera == *c && truth[&(p.camera, p.track_id)] == *o).unwrap().t).unwrap();
            assert!(d[0][0] * (q[0] - x) + d[0][1] * (q[1] - y) > 0.0);
        }
        assert!(seen[0] > 5 && seen[1] > 5, "{seen:?}");
        // the cameras stand outside their views
        assert!(s.cameras.iter().all(|c| !c.sees(c.position()[0], c.position()[1])));
    }

    #[test]
    fn ground_plane_error_scales_about_the_camera() {
        let base = SimParams { noise_sigma: (0.0, 0.0), p_est: 0.0, noise_tracks_per_min: 0.0, ..small() };
        let s = simulate(&SimParams { ground_plane_scale: 0.02, ground_plane_perspective: 0.0, ..base.clone() }).unwrap();
        let plain = simulate(&base).unwrap();
        assert!(s.cameras.iter().all(|c| c.ground.h == [0.0, 0.0] && (c.ground.scale - 1.0).abs() <= 0.02 && c.ground.scale != 1.0));
        for (p, q) in s.points.iter().zip(&plain.points).step_by(53) {
            let cam = &s.cameras[p.camera as usize];
            let (w, v, c) = (world_of(cam, p), world_of(cam, q), cam.position());
            // w − c = s (v − c)
            assert!((w[0] - c[0] - cam.ground.scale * (v[0] - c[0])).abs() < 1e-6 && (w[1] - c[1] - cam.ground.scale * (v[1] - c[1])).abs() < 1e-6);
        }
        // a perspective term: the relative error at 50 m is at most the parameter
        let s = simulate(&SimParams { ground_plane_scale: 0.0, ground_plane_perspective: 0.03, ..base }).unwrap();
        for c in &s.cameras {
            let m = c.ground.h[0].hypot(c.ground.h[1]) * PERSPECTIVE_RANGE_M;
            assert!(m > 0.0 && m <= 0.03 && c.ground.scale == 1.0);
        }
        assert_eq!(GroundPlane::EXACT.apply([1.0, 2.0], [3.0, 4.0]), [3.0, 4.0]);
    }

    #[test]
    fn occlusion_cuts_tracks_in_crowds_mid_view() {
        let base = SimParams { waiting_groups: 4.0, pedestrians: 3.0, p_break: 0.0, p_est: 0.0, noise_tracks_per_min: 0.0, ..small() };
        let plain = simulate(&base).unwrap();
        let s = simulate(&SimParams { occlusion: 0.1, ..base.clone() }).unwrap();
        let (n0, n1) = (plain.truth.len(), s.truth.len());
        assert!(n1 > n0 + 20, "{n0} -> {n1}");
        // vehicles alone on their lanes are rarely within 2 m of another road user: far fewer cuts
        let cars = |sc: &Scenario| sc.truth.iter().filter(|t| sc.objects[t.2 as usize].class == "car").count();
        assert!(cars(&s) <= cars(&plain) + cars(&plain) / 5, "{} {}", cars(&plain), cars(&s));
        // a track that starts mid-view: its first point is far inside the view
        let inside = s.points.iter().filter(|p| {
            let cam = &s.cameras[p.camera as usize];
            let w = world_of(cam, p);
            let first = s.points.iter().find(|q| q.camera == p.camera && q.track_id == p.track_id).unwrap();
            std::ptr::eq(first, *p) && cam.sees(w[0] + 3.0, w[1]) && cam.sees(w[0] - 3.0, w[1]) && cam.sees(w[0], w[1] + 3.0) && cam.sees(w[0], w[1] - 3.0)
        });
        assert!(inside.count() > 20);
        // nothing is drawn without it: the same scenario as before
        let again = simulate(&SimParams { occlusion: 0.0, ..base }).unwrap();
        assert_eq!(again.points.len(), plain.points.len());
    }

    #[test]
    fn new_degradations_validate() {
        for (p, want) in [
            (SimParams { viewpoint_bias: (-1.0, 0.0), ..small() }, "viewpoint_bias must be in [0, 6] m"),
            (SimParams { viewpoint_bias: (1.0, f64::NAN), ..small() }, "viewpoint_bias must be in [0, 6] m"),
            (SimParams { ground_plane_scale: 0.2, ..small() }, "ground_plane_scale must be in [0, 0.1]"),
            (SimParams { ground_plane_perspective: -0.01, ..small() }, "ground_plane_perspective must be in [0, 0.1]"),
            (SimParams { occlusion: 11.0, ..small() }, "occlusion must be in [0, 10]"),
        ] {
            let e = simulate(&p).unwrap_err().to_string();
            assert!(e.contains(want), "{e}");
        }
    }

    #[test]
    fn realistic_speeds_and_every_class() {
        let s = simulate(&small()).unwrap();
        for class in CLASSES {
            let objs: Vec<&Object> = s.objects.iter().filter(|o| o.class == class).collect();
            assert!(!objs.is_empty(), "{class}");
            let vmax = objs
                .iter()
                .flat_map(|o| o.samples.windows(2).map(|w| ((w[1][1] - w[0][1]).hypot(w[1][2] - w[0][2])) / (w[1][0] - w[0][0])))
                .fold(0.0f64, f64::max);
            let limit = match class {
                "pedestrian" => 1.7,
                "cyclist" => 6.6,
                _ => 14.1,
            };
            assert!(vmax <= limit, "{class}: {vmax}");
        }
        // tracks ids unique per camera, every track has >= 3 points
        let mut seen = std::collections::HashSet::new();
        for t in &s.truth {
            assert!(seen.insert((t.0, t.1)));
        }
        assert!(s.truth.iter().any(|t| t.3));
        assert!(s.points.iter().any(|p| p.estimated));
    }

    #[test]
    fn neighbouring_views_overlap() {
        let s = simulate(&small()).unwrap();
        let shared = s.objects.iter().filter(|o| o.samples.iter().any(|q| s.cameras[0].sees(q[1], q[2]) && s.cameras[1].sees(q[1], q[2]))).count();
        assert!(shared > 10, "{shared}");
    }

    fn tiny() -> SimParams {
        SimParams { cameras: 1, minutes: 0.3, seed: 5, ..SimParams::default() }
    }

    fn tmp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("trajdb-simwrite-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// The folder's entries but for the run lock (which stays, unlocked: crates/app/src/outdir.rs).
    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).filter(|n| n != outdir::LOCK).collect();
        v.sort();
        v
    }

    #[test]
    fn a_folder_with_a_users_file_is_refused_and_the_file_untouched() {
        let d = tmp("user");
        std::fs::write(d.join("points.csv"), "my own points").unwrap();
        let s = simulate(&tiny()).unwrap();
        for e in [s.write(&d, "test").unwrap_err(), simulate_into(&tiny(), &d, "test").unwrap_err()] {
            let e = e.to_string();
            assert!(e.contains("did not write") && e.contains("points.csv"), "{e}");
        }
        assert_eq!(std::fs::read_to_string(d.join("points.csv")).unwrap(), "my own points");
        assert_eq!(names(&d), ["points.csv"]);
        // a file where the folder should be, and no folder at all
        let e = s.write(&d.join("points.csv"), "test").unwrap_err().to_string();
        assert!(e.contains("is a file"), "{e}");
        assert!(s.write(Path::new(""), "test").unwrap_err().to_string().contains("empty"));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_rerun_replaces_its_own_scenario_whole_and_keeps_other_files() {
        let d = tmp("rerun").join("sim");
        let a = simulate_into(&tiny(), &d, "test a").unwrap();
        assert_eq!(names(&d), [outdir::MANIFEST, "README.txt", "cameras.csv", "objects.csv", "points.csv", "truth.csv", "world.csv"]);
        let manifest = std::fs::read_to_string(d.join(outdir::MANIFEST)).unwrap();
        assert!(manifest.lines().any(|l| l.split('\t').nth(1) == Some("points.csv")), "{manifest}");
        assert_eq!(std::fs::read_to_string(d.join("points.csv")).unwrap().lines().count(), a.points.len() + 1);
        // a file the user adds later is not trajdb's: it stays; world.csv (not written now) goes
        std::fs::write(d.join("notes.txt"), "mine").unwrap();
        let b = simulate_into(&SimParams { seed: 6, world_rate_hz: 0.0, ..tiny() }, &d, "test b").unwrap();
        assert_eq!(names(&d), [outdir::MANIFEST, "README.txt", "cameras.csv", "notes.txt", "objects.csv", "points.csv", "truth.csv"]);
        assert_eq!(std::fs::read_to_string(d.join("points.csv")).unwrap().lines().count(), b.points.len() + 1);
        assert!(std::fs::read_to_string(d.join("README.txt")).unwrap().contains("`test b`"));
        assert_eq!(std::fs::read_to_string(d.join("notes.txt")).unwrap(), "mine");
        let _ = std::fs::remove_dir_all(d.parent().unwrap());
    }

    #[test]
    fn a_failed_write_leaves_the_earlier_scenario_and_no_half_files() {
        let d = tmp("fail").join("sim");
        simulate_into(&tiny(), &d, "test").unwrap();
        let before: Vec<(String, Vec<u8>)> = names(&d).into_iter().map(|n| (n.clone(), std::fs::read(d.join(&n)).unwrap())).collect();
        let s = simulate(&SimParams { seed: 99, ..tiny() }).unwrap();
        let e = s.write_with(&d, "test", |_| Err(SimError::Param("disk full".into()))).unwrap_err();
        assert!(e.to_string().contains("disk full"));
        let after: Vec<(String, Vec<u8>)> = names(&d).into_iter().map(|n| (n.clone(), std::fs::read(d.join(&n)).unwrap())).collect();
        assert!(before == after, "the earlier scenario changed");
        // bad parameters: refused before the folder is even created
        let fresh = d.parent().unwrap().join("never");
        assert!(simulate_into(&SimParams { cameras: 0, ..tiny() }, &fresh, "test").is_err());
        assert!(!fresh.exists());
        let _ = std::fs::remove_dir_all(d.parent().unwrap());
    }

    /// Issue 19: the documented maximum parameters (hundreds of GB) aborted the host under a
    /// memory limit; now refused before any work, and a scenario that passes the estimate but
    /// grows beyond `memory_bytes` stops with the same error while it is made.
    #[test]
    fn scenarios_beyond_memory_bytes_are_errors() {
        use trajdb_algo::limits::{with_scope, Limits};
        let max = SimParams { cameras: 16, minutes: 1440.0, rate_hz: vec![1000.0], traffic: 50.0, pedestrians: 50.0, noise_tracks_per_min: 1e300, ..small() };
        let e = simulate(&max).unwrap_err().to_string();
        assert!(e.starts_with("simulate: this scenario needs more than memory_bytes = ") && e.contains("reduce minutes, traffic or pedestrians"), "{e}");
        assert!(simulate(&SimParams { noise_tracks_per_min: 1e12, ..small() }).is_err());
        let l = std::sync::Arc::new(Limits::default());
        l.set("memory_bytes", 1_000_000).unwrap();
        let e = with_scope(&l, || simulate(&small())).unwrap_err().to_string();
        assert!(e.contains("memory_bytes = 1000000 bytes"), "{e}");
        assert!(expected_bytes(&small()) < 1e6);
        // the default limit holds the usual scenarios
        assert!(simulate(&small()).is_ok());
    }

    /// The members of each waiting group, by group number (from the route).
    fn groups(s: &Scenario) -> std::collections::BTreeMap<usize, Vec<&Object>> {
        let mut g: std::collections::BTreeMap<usize, Vec<&Object>> = Default::default();
        for o in &s.objects {
            if let Some(rest) = o.route.split("waiting group ").nth(1) {
                g.entry(rest.split(' ').next().unwrap().parse().unwrap()).or_default().push(o);
            }
        }
        g
    }

    /// The interval an object stands (the longest run of steps slower than 0.5 m/s) and its mean
    /// position there: (from, to, x, y).
    fn standing(o: &Object) -> (f64, f64, f64, f64) {
        let s = &o.samples;
        let slow = |j: usize| (s[j + 1][1] - s[j][1]).hypot(s[j + 1][2] - s[j][2]) / (s[j + 1][0] - s[j][0]) < 0.5;
        let (mut best, mut i) = ((0, 0), 0);
        while i + 1 < s.len() {
            let mut j = i;
            while j + 1 < s.len() && slow(j) {
                j += 1;
            }
            if s[j][0] - s[i][0] > s[best.1][0] - s[best.0][0] {
                best = (i, j);
            }
            i = j + 1;
        }
        let n = (best.1 - best.0 + 1) as f64;
        let (x, y) = s[best.0..=best.1].iter().fold((0.0, 0.0), |a, q| (a.0 + q[1] / n, a.1 + q[2] / n));
        (s[best.0][0], s[best.1][0], x, y)
    }

    #[test]
    fn waiting_groups_stand_together_then_cross() {
        let base = simulate(&SimParams { minutes: 4.0, ..small() }).unwrap();
        let s = simulate(&SimParams { waiting_groups: 4.0, ..base.params.clone() }).unwrap();
        // the other road users are unchanged (the groups draw from a stream of their own)
        assert!(s.objects.len() > base.objects.len());
        for (a, b) in base.objects.iter().zip(&s.objects) {
            assert!(a.route == b.route && a.samples == b.samples);
        }
        let g = groups(&s);
        assert!(g.len() >= 3, "{}", g.len());
        let (mut cyclists, mut people) = (0, 0);
        for (k, members) in &g {
            let wait: f64 = members[0].route.split("waits ").nth(1).unwrap().trim_end_matches(" s").parse().unwrap();
            assert!((GROUP_WAIT.0..=GROUP_WAIT.1 + 0.05).contains(&wait), "{wait}");
            let st: Vec<_> = members.iter().map(|o| standing(o)).collect();
            for (i, (o, a)) in members.iter().zip(&st).enumerate() {
                people += 1;
                cyclists += usize::from(o.class == "cyclist");
                // stands from its arrival (within 2 s before the last) to its start (0-1 s after the green);
                // a group already there at t = 0 is cut
                let d = a.1 - a.0;
                // (slower than 0.5 m/s: also the last and first ~0.6 s of walking)
                if a.0 > 0.0 {
                    assert!(d >= wait - 0.1 && d <= wait + 3.0 + 1.5, "group {k}: stands {d} s for a wait of {wait}");
                }
                // 0.6-2 m from its nearest neighbour (mean positions: the sway is 3-15 cm), all standing at once for the wait
                let near = st.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, b)| (a.2 - b.2).hypot(a.3 - b.3)).fold(f64::INFINITY, f64::min);
                assert!((GROUP_SPACING.0 - 0.15..=GROUP_SPACING.1 + 0.15).contains(&near), "group {k}: nearest {near} m");
                for b in &st {
                    assert!(a.1.min(b.1) - a.0.max(b.0) >= wait - 0.1 || a.0.min(b.0) <= 0.0);
                    assert!((a.1 - b.1).abs() <= 1.0 + 0.7, "starts together");
                }
                // then it moves: at walking or cycling speed, and it crosses the road
                let vmax = o.samples.windows(2).map(|w| (w[1][1] - w[0][1]).hypot(w[1][2] - w[0][2]) / (w[1][0] - w[0][0])).fold(0.0, f64::max);
                assert!(vmax <= if o.class == "cyclist" { 7.01 } else { 1.61 }, "{vmax}");
                let last = o.samples[o.samples.len() - 1];
                assert!(last[0] > a.1 + 5.0);
            }
        }
        assert!(cyclists > 0 && cyclists < people, "{cyclists} of {people}");
        // seen by the cameras like anyone else
        let truth: std::collections::HashSet<i64> = s.truth.iter().map(|t| t.2).collect();
        assert!(g.values().flatten().filter(|o| truth.contains(&o.id)).count() * 2 > people);
    }

    #[test]
    fn cyclists_multiply_the_cyclist_rate() {
        let count = |s: &Scenario, c: &str| s.objects.iter().filter(|o| o.class == c).count();
        let base = simulate(&SimParams { minutes: 4.0, ..small() }).unwrap();
        let many = simulate(&SimParams { cyclists: 5.0, ..base.params.clone() }).unwrap();
        let none = simulate(&SimParams { cyclists: 0.0, ..base.params.clone() }).unwrap();
        assert!(count(&many, "cyclist") > 3 * count(&base, "cyclist"), "{} vs {}", count(&many, "cyclist"), count(&base, "cyclist"));
        assert_eq!(count(&none, "cyclist"), 0);
        // ride the bike lanes (5 m from the centre line) at 3-7 m/s
        for o in many.objects.iter().filter(|o| o.class == "cyclist") {
            let q = o.samples[0];
            assert!((q[1].abs().min(q[2].abs()) - BIKE).abs() < 1e-6, "{q:?}");
            let v = o.samples.windows(2).map(|w| (w[1][1] - w[0][1]).hypot(w[1][2] - w[0][2]) / (w[1][0] - w[0][0])).fold(0.0, f64::max);
            assert!((3.0..=7.0).contains(&v), "{v}");
        }
        assert!(simulate(&SimParams { cyclists: 51.0, ..small() }).unwrap_err().to_string().contains("cyclists must be in [0, 50]"));
    }

    /// The truth's clock model holds exactly: every point's world time, from its camera time
    /// through t_world = (t_cam − clock_offset) / (1 + drift·1e-6), puts the object where the
    /// point is; the frames are 1/rate_hz apart on the camera's own clock.
    #[test]
    fn clock_drift_offsets_and_epoch_follow_the_truth() {
        let p = SimParams { noise_sigma: (0.0, 0.0), p_est: 0.0, noise_tracks_per_min: 0.0, clock_drift_ppm: 300.0, clock_offset_max: 3600.0, clock_epoch: 1.78e9, ..small() };
        let s = simulate(&p).unwrap();
        let truth: std::collections::HashMap<(i64, i64), i64> = s.truth.iter().map(|t| ((t.0, t.1), t.2)).collect();
        for c in &s.cameras {
            assert!(c.clock_drift_ppm.abs() <= 300.0 && c.clock_drift_ppm != 0.0);
            assert!((c.clock_offset - 1.78e9).abs() <= 3600.0);
        }
        assert!(s.cameras.iter().any(|c| (c.clock_offset - 1.78e9).abs() > 60.0));
        for p in s.points.iter().step_by(17) {
            let cam = &s.cameras[p.camera as usize];
            let tw = (p.t - cam.clock_offset) / (1.0 + cam.clock_drift_ppm * 1e-6);
            let (c, sn) = (cam.theta.cos(), cam.theta.sin());
            let (wx, wy) = (c * p.x - sn * p.y + cam.tx, sn * p.x + c * p.y + cam.ty);
            let (ex, ey) = at(&s.objects[truth[&(p.camera, p.track_id)] as usize], tw).unwrap();
            // 1e-6 s of time stamp rounding at 1.78e9 s is < 1e-5 m at 14 m/s
            assert!((wx - ex).hypot(wy - ey) < 1e-4, "{} {}", wx - ex, wy - ey);
        }
        for w in s.points.windows(2).filter(|w| w[0].camera == w[1].camera && w[0].track_id == w[1].track_id) {
            let frames = (w[1].t - w[0].t) * s.cameras[w[0].camera as usize].rate_hz;
            assert!((frames - frames.round()).abs() < 1e-4 && frames.round() >= 1.0, "{frames}");
        }
        // without drift and epoch: exactly t_world + offset, and the same scenario
        let a = simulate(&SimParams { clock_drift_ppm: 0.0, clock_epoch: 0.0, ..p.clone() }).unwrap();
        let b = simulate(&SimParams { clock_drift_ppm: 0.0, ..p.clone() }).unwrap();
        assert!(a.points.len() == b.points.len() && a.points.iter().zip(&b.points).all(|(q, r)| (q.t + 1.78e9 - r.t).abs() < 1e-6 && q.x == r.x));
        // drift changes the times, not the scene
        assert_eq!(a.objects.len(), s.objects.len());
        // over 30 minutes 300 ppm is 0.54 s: the drift is visible in the time stamps
        let long = simulate(&SimParams { minutes: 30.0, clock_drift_ppm: 300.0, cameras: 2, ..SimParams::default() }).unwrap();
        let last = long.points.iter().filter(|q| q.camera == 1).map(|q| q.t).fold(0.0, f64::max);
        let c1 = &long.cameras[1];
        assert!((c1.clock(last) - last).abs() > 0.0 && (last * c1.clock_drift_ppm * 1e-6).abs() < 0.6);
    }

    #[test]
    fn time_jitter_moves_stamps_not_positions() {
        let p = SimParams { rate_hz: vec![10.0], ..small() };
        let a = simulate(&p).unwrap();
        let b = simulate(&SimParams { time_jitter_s: 0.01, ..p.clone() }).unwrap();
        assert_eq!(a.points.len(), b.points.len());
        let d: Vec<f64> = a.points.iter().zip(&b.points).map(|(q, r)| {
            assert!(q.x == r.x && q.y == r.y && q.track_id == r.track_id);
            r.t - q.t
        }).collect();
        let sd = (d.iter().map(|e| e * e).sum::<f64>() / d.len() as f64).sqrt();
        assert!((sd - 0.01).abs() < 0.0005, "{sd}");
        assert!(d.iter().all(|e| e.abs() <= JITTER_CLIP / 10.0 + 1e-12));
        // clipped: a jitter near the period keeps every track's times increasing
        let c = simulate(&SimParams { time_jitter_s: 0.099, ..p.clone() }).unwrap();
        for w in c.points.windows(2).filter(|w| w[0].camera == w[1].camera && w[0].track_id == w[1].track_id) {
            assert!(w[1].t > w[0].t);
        }
        let e = simulate(&SimParams { time_jitter_s: 0.1, ..p }).unwrap_err().to_string();
        assert!(e.contains("time_jitter_s must be >= 0 and below the frame period (1/rate_hz = 0.1 s), got 0.1"), "{e}");
    }

    #[test]
    fn each_camera_its_own_frame_rate() {
        let rates = vec![2.0, 5.0, 7.5, 10.0, 12.5, 15.0, 25.0, 30.0];
        let s = simulate(&SimParams { cameras: 10, rate_hz: rates.clone(), ..small() }).unwrap();
        for c in &s.cameras {
            assert_eq!(c.rate_hz, rates[c.id as usize % rates.len()]);
            assert!(c.phase >= 0.0 && c.phase < 1.0 / c.rate_hz);
            // every step within a track is a whole number of this camera's periods
            let mut steps = 0;
            for w in s.points.windows(2).filter(|w| w[0].camera == c.id && w[1].camera == c.id && w[0].track_id == w[1].track_id) {
                let frames = (w[1].t - w[0].t) * c.rate_hz;
                assert!((frames - frames.round()).abs() < 1e-6 && frames.round() >= 1.0, "cam {}: {frames}", c.id);
                steps += usize::from(frames.round() == 1.0);
            }
            assert!(steps > 100, "cam {}: {steps}", c.id);
        }
        // a single rate is the old scenario
        assert_eq!(simulate(&SimParams { rate_hz: vec![10.0; 3], ..small() }).unwrap().points.len(), simulate(&small()).unwrap().points.len());
        assert_eq!(parse_rates("2, 5,7.5").unwrap(), [2.0, 5.0, 7.5]);
        assert!(parse_rates("2,,5").unwrap_err().to_string().contains("comma list"));
    }

    #[test]
    fn frames_far_from_the_origin_stay_consistent() {
        let near = simulate(&SimParams { noise_sigma: (0.0, 0.0), p_est: 0.0, ..small() }).unwrap();
        for origin in [Origin::Utm, Origin::At(-3e6, 9e6)] {
            let s = simulate(&SimParams { origin, ..near.params.clone() }).unwrap();
            assert_eq!(s.points.len(), near.points.len());
            for (c, c0) in s.cameras.iter().zip(&near.cameras) {
                assert_eq!((c.theta, c.view_world), (c0.theta, c0.view_world));
                // p_world = R p_local + t, for the view's corners and for every point
                let (cs, sn) = (c.theta.cos(), c.theta.sin());
                let world = |x: f64, y: f64| (cs * x - sn * y + c.tx, sn * x + cs * y + c.ty);
                for q in c.view_world {
                    let (lx, ly) = c.to_local(q[0], q[1]);
                    let (wx, wy) = world(lx, ly);
                    assert!((wx - q[0]).hypot(wy - q[1]) < 1e-8);
                    if origin == Origin::Utm {
                        assert!((4.5e5 - 100.0..5e5 + 100.0).contains(&lx) && (5.7e6 - 100.0..5.75e6 + 100.0).contains(&ly), "{lx} {ly}");
                    }
                }
            }
            for (p, p0) in s.points.iter().zip(&near.points).step_by(13) {
                let c = &s.cameras[p.camera as usize];
                let (wx, wy) = (c.theta.cos() * p.x - c.theta.sin() * p.y + c.tx, c.theta.sin() * p.x + c.theta.cos() * p.y + c.ty);
                let c0 = &near.cameras[p.camera as usize];
                let (vx, vy) = (c0.theta.cos() * p0.x - c0.theta.sin() * p0.y + c0.tx, c0.theta.sin() * p0.x + c0.theta.cos() * p0.y + c0.ty);
                assert!(p.t == p0.t && (wx - vx).hypot(wy - vy) < 1e-6);
                if let Origin::At(ox, oy) = origin {
                    assert!((p.x - p0.x - ox).abs() < 1e-6 && (p.y - p0.y - oy).abs() < 1e-6);
                }
            }
        }
        assert!(matches!(Origin::parse(" UTM ").unwrap(), Origin::Utm));
        assert_eq!(Origin::parse("450000, 5.7e6").unwrap(), Origin::At(450000.0, 5.7e6));
        assert_eq!(Origin::parse("none").unwrap(), Origin::Near);
        assert!(Origin::parse("5").unwrap_err().to_string().contains("origin must be none, utm or X,Y"));
        assert!(simulate(&SimParams { origin: Origin::At(2e7, 0.0), ..small() }).unwrap_err().to_string().contains("origin must lie within"));
    }

    #[test]
    fn bad_parameters_are_errors() {
        for p in [
            SimParams { cameras: 0, ..small() },
            SimParams { minutes: -1.0, ..small() },
            SimParams { rate_hz: vec![f64::NAN], ..small() },
            SimParams { rate_hz: vec![], ..small() },
            SimParams { rate_hz: vec![10.0, 0.0], ..small() },
            SimParams { rate_hz: vec![1001.0], ..small() },
            SimParams { noise_sigma: (0.2, 0.1), ..small() },
            SimParams { p_break: 2.0, ..small() },
            SimParams { waiting_groups: -1.0, ..small() },
            SimParams { waiting_groups: f64::NAN, ..small() },
            SimParams { waiting_groups: 61.0, ..small() },
            SimParams { clock_drift_ppm: 1.1e4, ..small() },
            SimParams { clock_drift_ppm: -1.0, ..small() },
            SimParams { clock_offset_max: 1.1e7, ..small() },
            SimParams { clock_epoch: f64::INFINITY, ..small() },
            SimParams { clock_epoch: -2e10, ..small() },
            SimParams { time_jitter_s: -0.1, ..small() },
            SimParams { time_jitter_s: f64::NAN, ..small() },
        ] {
            assert!(simulate(&p).unwrap_err().to_string().starts_with("simulate: "));
        }
    }
}
