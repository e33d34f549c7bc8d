//! SQL: `trajdb_simulate(dir, ...)`, the simulator as a table function, so that stock DuckDB
//! makes the same scenarios as `trajdb simulate`. The simulator: `src/app/simulate.rs`.

use super::registry::{Function, Table, Ty};
use super::vector::chunk_set_i64;
use crate::app::simulate::{self, SimParams};
use duckdb::core::{DataChunkHandle, Inserter, LogicalTypeHandle, LogicalTypeId};
use duckdb::vtab::{BindInfo, InitInfo, TableFunctionInfo, VTab};
use duckdb::Connection;
use std::sync::atomic::{AtomicBool, Ordering};

const COLUMNS: &[(&str, Ty)] = &[("dir", Ty::Varchar), ("objects", Ty::Bigint), ("cameras", Ty::Bigint), ("tracks", Ty::Bigint), ("points", Ty::Bigint)];

/// The named parameters (all optional; defaults of `trajdb simulate`): name, type.
const NAMED: &[(&str, LogicalTypeId)] = &[
    ("cameras", LogicalTypeId::Bigint),
    ("minutes", LogicalTypeId::Double),
    ("seed", LogicalTypeId::Bigint),
    ("rate_hz", LogicalTypeId::Double),
    ("traffic", LogicalTypeId::Double),
    ("pedestrians", LogicalTypeId::Double),
    ("noise_sigma_min", LogicalTypeId::Double),
    ("noise_sigma_max", LogicalTypeId::Double),
    ("noise_tracks_per_min", LogicalTypeId::Double),
    ("clock_offset_max", LogicalTypeId::Double),
    ("world_rate_hz", LogicalTypeId::Double),
];

pub static FUNCTIONS: &[Function] = &[Function {
    name: "trajdb_simulate",
    description: "Simulates an intersection seen by several cameras (the simulator of `trajdb simulate`, same seed, same scenario) and writes \
                  the scenario files into dir: points.csv (the input of sql/pipeline.sql), cameras.csv, truth.csv, world.csv, objects.csv and \
                  README.txt. One row: dir and the counts. Named parameters (defaults): cameras (3), minutes (5), seed (1), rate_hz (10), \
                  traffic (1), pedestrians (1), noise_sigma_min / noise_sigma_max (0.05 / 0.15 m), noise_tracks_per_min (1), clock_offset_max \
                  (0 s), world_rate_hz (10).",
    example: "SELECT objects > 0 FROM trajdb_simulate('/tmp/trajdb-sim-example', cameras := 2, minutes := 1, seed := 3); -- true",
    maths: "src/app/simulate.rs",
    binding: file!(),
    signatures: &[],
    table: Some(Table { columns: COLUMNS, register }),
}];

struct SimulateTable;

pub struct Bind {
    dir: String,
    params: SimParams,
}

pub struct Once {
    done: AtomicBool,
}

impl VTab for SimulateTable {
    type InitData = Once;
    type BindData = Bind;

    fn bind(bind: &BindInfo) -> Result<Self::BindData, Box<dyn std::error::Error>> {
        for (name, ty) in COLUMNS {
            bind.add_result_column(name, ty.logical());
        }
        let dir = bind.get_parameter(0).to_string();
        let mut p = SimParams::default();
        let num = |name: &str| -> Option<f64> { bind.get_named_parameter(name).filter(|v| !v.is_null()).map(|v| v.to_double()) };
        let int = |name: &str| -> Option<i64> { bind.get_named_parameter(name).filter(|v| !v.is_null()).map(|v| v.to_int64()) };
        if let Some(v) = int("cameras") {
            p.cameras = usize::try_from(v).map_err(|_| format!("trajdb_simulate: cameras must be >= 1, got {v}"))?;
        }
        if let Some(v) = int("seed") {
            p.seed = u64::try_from(v).map_err(|_| format!("trajdb_simulate: seed must be >= 0, got {v}"))?;
        }
        for (name, slot) in [
            ("minutes", &mut p.minutes),
            ("rate_hz", &mut p.rate_hz),
            ("traffic", &mut p.traffic),
            ("pedestrians", &mut p.pedestrians),
            ("noise_sigma_min", &mut p.noise_sigma.0),
            ("noise_sigma_max", &mut p.noise_sigma.1),
            ("noise_tracks_per_min", &mut p.noise_tracks_per_min),
            ("clock_offset_max", &mut p.clock_offset_max),
            ("world_rate_hz", &mut p.world_rate_hz),
        ] {
            if let Some(v) = num(name) {
                *slot = v;
            }
        }
        // noise_sigma_min alone: one sigma for every camera
        if num("noise_sigma_min").is_some() && num("noise_sigma_max").is_none() {
            p.noise_sigma.1 = p.noise_sigma.0;
        }
        p.validate().map_err(|e| format!("trajdb_simulate: {}", e.to_string().trim_start_matches("simulate: ")))?;
        Ok(Bind { dir, params: p })
    }

    fn init(_: &InitInfo) -> Result<Self::InitData, Box<dyn std::error::Error>> {
        Ok(Once { done: AtomicBool::new(false) })
    }

    fn func(func: &TableFunctionInfo<Self>, output: &mut DataChunkHandle) -> Result<(), Box<dyn std::error::Error>> {
        if func.get_init_data().done.swap(true, Ordering::SeqCst) {
            output.set_len(0);
            return Ok(());
        }
        let b = func.get_bind_data();
        let s = simulate::simulate(&b.params).map_err(|e| format!("trajdb_simulate: {e}"))?;
        s.write(std::path::Path::new(&b.dir), &format!("trajdb_simulate('{}', ...)", b.dir)).map_err(|e| format!("trajdb_simulate: {e}"))?;
        let tracks = s.truth.len() as i64;
        output.flat_vector(0).insert(0, b.dir.as_str());
        for (k, v) in [s.objects.len() as i64, s.cameras.len() as i64, tracks, s.points.len() as i64].into_iter().enumerate() {
            chunk_set_i64(output, k + 1, 0, v);
        }
        output.set_len(1);
        Ok(())
    }

    fn parameters() -> Option<Vec<LogicalTypeHandle>> {
        Some(vec![LogicalTypeHandle::from(LogicalTypeId::Varchar)])
    }

    fn named_parameters() -> Option<Vec<(String, LogicalTypeHandle)>> {
        Some(NAMED.iter().map(|(n, t)| (n.to_string(), LogicalTypeHandle::from(*t))).collect())
    }
}

fn register(con: &Connection) -> duckdb::Result<()> {
    con.register_table_function::<SimulateTable>("trajdb_simulate")
}
