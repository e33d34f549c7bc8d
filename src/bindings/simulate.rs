//! SQL: `trajdb_simulate(dir, ...)`, the simulator as a table function, so that stock DuckDB
//! makes the same scenarios as `trajdb simulate`. The simulator: `crates/app/src/simulate.rs`.

use super::registry::{pd, Function, Param, Section, Table, Ty};
use super::vector::table::{self, BindArgs, Rows, TableFn};
use crate::app::simulate::{self, SimParams};
use std::error::Error;
use std::sync::atomic::{AtomicBool, Ordering};

const COLUMNS: &[(&str, Ty)] = &[("dir", Ty::Varchar), ("objects", Ty::Bigint), ("cameras", Ty::Bigint), ("tracks", Ty::Bigint), ("points", Ty::Bigint)];

/// The named parameters (all optional; defaults of `trajdb simulate`).
const NAMED: &[Param] = &[
    pd("cameras", Ty::Bigint, "how many cameras, >= 1; default 3"),
    pd("minutes", Ty::Double, "the simulated time (minutes); default 5"),
    pd("seed", Ty::Bigint, "the random seed of the traffic (and of the cameras without site_seed), >= 0; default 1"),
    pd("site_seed", Ty::Bigint, "the cameras' seed, >= 0: days of one site share their cameras; default: none (seed)"),
    pd("rate_hz", Ty::OneOf(&[Ty::Double, Ty::Varchar]), "each camera's sampling rate (Hz): a number, or text with one per camera, cycled ('2,5,7.5,10'); default 10"),
    pd("traffic", Ty::Double, "a multiplier of the traffic volume; default 1"),
    pd("pedestrians", Ty::Double, "an extra multiplier of the pedestrians arriving; default 1"),
    pd("noise_sigma_min", Ty::Double, "each camera's position noise (m per axis) is drawn from noise_sigma_min to noise_sigma_max; default 0.05 (alone: every camera's)"),
    pd("noise_sigma_max", Ty::Double, "the largest position noise (m per axis); default 0.15"),
    pd("noise_tracks_per_min", Ty::Double, "spurious tracks per camera and minute; default 1"),
    pd("clock_offset_max", Ty::Double, "each camera's clock is offset by a draw in +-this (s); default 0"),
    pd("world_rate_hz", Ty::Double, "the sampling rate of world.csv (Hz; 0: no world.csv); default 10"),
    pd("waiting_groups", Ty::Double, "groups of pedestrians and cyclists waiting at a crossing's kerb, per minute; default 0"),
    pd("cyclists", Ty::Double, "an extra multiplier of the cyclists in the bike lanes (2 a minute at 1); default 1"),
    pd("clock_drift_ppm", Ty::Double, "each camera's clock runs fast or slow by a draw in +-this (ppm); default 0"),
    pd("clock_epoch", Ty::Double, "seconds added to every clock, e.g. 1.78e9 (Unix time); default 0"),
    pd("time_jitter_s", Ty::Double, "each time stamp is off the capture time by N(0, this) (s), clipped to 0.45 frame periods; default 0"),
    pd("origin", Ty::Varchar, "where the cameras' local frames lie: 'none', 'utm' or 'X,Y' (m) added to every local coordinate; default 'none'"),
    pd("viewpoint_bias_vehicle", Ty::Double, "the largest offset along the line of sight between a camera's point of a car or heavy vehicle and its centre (m); default 0"),
    pd("viewpoint_bias_vru", Ty::Double, "the same for pedestrians and cyclists (m); default 0"),
    pd("ground_plane_scale", Ty::Double, "each camera's ground plane is scaled by 1 + a draw in +-this (a fraction); default 0"),
    pd("ground_plane_perspective", Ty::Double, "a perspective term of each camera's ground plane whose relative error reaches this at 50 m; default 0"),
    pd("occlusion", Ty::Double, "tracks are cut mid-view at this rate per second and per other road user within 2 m; default 0"),
];

const TABLE: Table = Table {
    params: &[pd("dir", Ty::Varchar, "the folder to write the scenario into: new, empty or holding an earlier scenario")],
    named: NAMED,
    columns: COLUMNS,
    register: table::register::<SimulateTable>,
};

pub static FUNCTIONS: &[Function] = &[Function {
    name: "trajdb_simulate",
    description: "Simulates an intersection seen by several cameras (the simulator of `trajdb simulate`, same seed, same scenario) and writes \
                  the scenario files into dir, a new or empty folder or one holding an earlier scenario (any other folder is refused, and \
                  files are replaced whole, never half-written; it writes only where this connection's own file system \
                  lets it, as for COPY ... TO): points.csv (the input of sql/pipeline.sql), cameras.csv, truth.csv, world.csv, objects.csv and \
                  README.txt. One row: dir and the counts. Named parameters (defaults): cameras (3), minutes (5), seed (1), site_seed (none: \
                  the cameras are drawn from it and the traffic from seed, so days of one site share their cameras), rate_hz (10 Hz; or a list \
                  as text, one per camera, cycled: '2,5,7.5,10'), \
                  traffic (1), pedestrians (1), noise_sigma_min / noise_sigma_max (0.05 / 0.15 m), noise_tracks_per_min (1), clock_offset_max \
                  (0 s), world_rate_hz (10), waiting_groups (0 per minute: groups of 2-8 pedestrians and cyclists standing 0.6-2 m apart \
                  at a crossing's kerb for 10-60 s, then crossing together), cyclists (1: a multiplier of the 2 cyclists a minute in the bike lanes), \
                  clock_drift_ppm (0: each camera's clock runs fast or slow by a draw in +-this; t_cam = (1 + drift 1e-6) t_world + \
                  clock_offset_s), clock_epoch (0 s: added to every clock, e.g. 1.78e9), \
                  time_jitter_s (0: each time stamp off the capture time by N(0, this), clipped to 0.45 frame periods), \
                  origin ('none'; 'utm': each camera's local coordinates near x 4.5e5-5e5, y 5.7e6 m; 'X,Y': added to every local \
                  coordinate; cameras.csv tx, ty follow); \
                  viewpoint_bias_vehicle / viewpoint_bias_vru (0 / 0 m: the largest offset along the camera's line of sight between \
                  a camera's reported point and a road user's centre, per camera and road user, for cars and heavy vehicles / \
                  pedestrians and cyclists), ground_plane_scale (0: each camera's ground plane scaled by 1 + a draw in +-this), \
                  ground_plane_perspective (0: a homography term whose relative error reaches this at 50 m from the camera), \
                  occlusion (0: tracks cut mid-view at this rate per second and per road user within 2 m); \
                  docs/simulate.md.",
    example: "SELECT objects > 0 FROM trajdb_simulate('/tmp/trajdb-sim-example', cameras := 2, minutes := 1, seed := 3); -- true",
    maths: "crates/app/src/simulate.rs",
    binding: file!(),
    section: Section::Simulation,
    see_also: &["trajdb_pipeline"],
    signatures: &[],
    table: Some(TABLE),
}];

struct SimulateTable;

pub struct Bind {
    dir: String,
    params: SimParams,
}

pub struct Once {
    done: AtomicBool,
}

impl TableFn for SimulateTable {
    const TABLE: &'static Table = &TABLE;
    type Bind = Bind;
    type Scan = Once;

    fn bind(args: &BindArgs<'_>) -> Result<Bind, Box<dyn Error>> {
        let dir = args.text(0)?.ok_or("dir is NULL; name a new (or empty) folder for the scenario, e.g. trajdb_simulate('sim')")?;
        if dir.trim().is_empty() {
            return Err("dir is '' (empty); name a new (or empty) folder for the scenario, e.g. trajdb_simulate('sim')".into());
        }
        // the connection's sandbox, before any work. Checked at bind, as DuckDB's own readers
        // check their files: DuckDB 2.0 binds a prepared statement again at EXECUTE, 1.5 does
        // not, so there a statement PREPAREd before SET enable_external_access = false still
        // writes; it was prepared by whoever could write then (the setting cannot be turned
        // back on, so nothing prepared after it escapes).
        super::common::may_write_into(args, &dir)?;
        let mut p = SimParams::default();
        if let Some(v) = args.named_bigint("cameras")? {
            p.cameras = usize::try_from(v).map_err(|_| format!("cameras must be >= 1, got {v}"))?;
        }
        if let Some(v) = args.named_bigint("seed")? {
            p.seed = u64::try_from(v).map_err(|_| format!("seed must be >= 0, got {v}"))?;
        }
        if let Some(v) = args.named_bigint("site_seed")? {
            p.site_seed = Some(u64::try_from(v).map_err(|_| format!("site_seed must be >= 0, got {v}"))?);
        }
        for (name, slot) in [
            ("minutes", &mut p.minutes),
            ("traffic", &mut p.traffic),
            ("pedestrians", &mut p.pedestrians),
            ("noise_sigma_min", &mut p.noise_sigma.0),
            ("noise_sigma_max", &mut p.noise_sigma.1),
            ("noise_tracks_per_min", &mut p.noise_tracks_per_min),
            ("clock_offset_max", &mut p.clock_offset_max),
            ("world_rate_hz", &mut p.world_rate_hz),
            ("waiting_groups", &mut p.waiting_groups),
            ("cyclists", &mut p.cyclists),
            ("clock_drift_ppm", &mut p.clock_drift_ppm),
            ("clock_epoch", &mut p.clock_epoch),
            ("time_jitter_s", &mut p.time_jitter_s),
            ("viewpoint_bias_vehicle", &mut p.viewpoint_bias.0),
            ("viewpoint_bias_vru", &mut p.viewpoint_bias.1),
            ("ground_plane_scale", &mut p.ground_plane_scale),
            ("ground_plane_perspective", &mut p.ground_plane_perspective),
            ("occlusion", &mut p.occlusion),
        ] {
            if let Some(v) = args.named_double(name)? {
                *slot = v;
            }
        }
        // rate_hz: a number, or text: one number or a comma list (one per camera, cycled)
        match args.named_double("rate_hz") {
            Ok(Some(v)) => p.rate_hz = vec![v],
            Ok(None) => {}
            Err(e) => match args.named_text("rate_hz") {
                Ok(Some(t)) => p.rate_hz = simulate::parse_rates(&t).map_err(|e| e.to_string().trim_start_matches("simulate: ").to_string())?,
                _ => return Err(e),
            },
        }
        if let Some(t) = args.named_text("origin")? {
            p.origin = simulate::Origin::parse(&t).map_err(|e| e.to_string().trim_start_matches("simulate: ").to_string())?;
        }
        // noise_sigma_min alone: one sigma for every camera
        if args.named_double("noise_sigma_min")?.is_some() && args.named_double("noise_sigma_max")?.is_none() {
            p.noise_sigma.1 = p.noise_sigma.0;
        }
        p.validate().map_err(|e| e.to_string().trim_start_matches("simulate: ").to_string())?;
        Ok(Bind { dir, params: p })
    }

    fn init(_: &Bind) -> Result<Once, Box<dyn Error>> {
        Ok(Once { done: AtomicBool::new(false) })
    }

    fn func(b: &Bind, once: &Once, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        if once.done.swap(true, Ordering::SeqCst) {
            return Ok(0);
        }
        let quoted = format!("'{}'", b.dir.replace('\'', "''"));
        let command = format!("trajdb_simulate({quoted}, ...)");
        let s = simulate::simulate_into(&b.params, std::path::Path::new(&b.dir), &command)
            .map_err(|e| format!("dir {quoted}: {}", e.to_string().trim_start_matches("simulate: ")))?;
        out.text(0, 0, &b.dir);
        for (k, v) in [s.objects.len(), s.cameras.len(), s.truth.len(), s.points.len()].into_iter().enumerate() {
            out.bigint(k + 1, 0, i64::try_from(v).unwrap_or(i64::MAX));
        }
        Ok(1)
    }
}
