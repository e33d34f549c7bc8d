//! `trajdb demo` (simulate → pipeline → score, with accuracy targets), `trajdb demo --sql`, and
//! `trajdb simulate` (the simulator's files plus points.parquet).

use super::shell::{run_script, Format};

/// `trajdb demo [--out DIR] [simulate options]`: simulate (3 cameras, 5 minutes, seed 1 unless
/// given), run the pipeline on the simulated points, score the result against the simulator's
/// ground truth, and fail unless match F1 >= 0.95 and every camera pair is within 0.5° / 0.3 m.
pub fn demo(db: Option<&str>, args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = args.to_vec();
    if !args.iter().any(|a| a == "--out") {
        args.extend(["--out".to_string(), "trajdb-demo".to_string()]);
    }
    let (params, out) = parse_simulate(&args)?;
    let dir = std::path::Path::new(&out);
    eprintln!("[trajdb] demo: simulate {} cameras, {} minutes of intersection traffic (seed {}) -> {out}", params.cameras, params.minutes, params.seed);
    simulate(db, &params, &out, &format!("demo {}", args.join(" ")))?;
    let con = crate::open(db)?;
    let results = dir.join("results");
    super::pipeline::run(&con, &dir.join("points.parquet").to_string_lossy(), &results, &[])?;
    crate::outln!("score of {} against the simulator's ground truth:", results.display());
    let (rot, trans, f1) = super::score::score(&con, dir, &results)?;
    let ok = f1 >= 0.95 && rot <= 0.5 && trans <= 0.3;
    crate::outln!(
        "demo {}: match F1 {f1:.3} (target >= 0.95), worst camera pair {rot:.3} deg / {trans:.3} m (targets 0.5 deg / 0.3 m)",
        if ok { "PASSED" } else { "FAILED" }
    );
    crate::outln!("results: {}/{{transforms.csv, matches.csv, merged.parquet, clusters.csv, report.html}}", results.display());
    if ok {
        Ok(())
    } else {
        Err("demo: the pipeline missed its accuracy targets".into())
    }
}

/// `trajdb demo --sql`: two synthetic cameras generated in SQL (sql/demo.sql), the pipeline's
/// parameters and stages (sql/params.sql, sql/stages.sql: the one stage list), then
/// sql/demo_match.sql, which checks the matches against the generator's objects.
pub fn demo_sql(db: Option<&str>, format: Format) -> Result<(), Box<dyn std::error::Error>> {
    let con = crate::open(db)?;
    super::pipeline::set_params(&con, &[])?;
    let script = ".read sql/demo.sql\n.read sql/params.sql\n.read sql/stages.sql\n.read sql/demo_match.sql\n";
    run_script(&con, script, format, &mut std::io::stdout().lock())
}

/// `simulate` options: --cameras N --minutes M --seed S --out DIR [--rate-hz R | R1,R2,...] [--traffic X]
/// [--pedestrians X] [--noise-sigma S | LO,HI] [--noise-tracks-per-min K] [--clock-offset-max S]
/// [--world-rate-hz R (0: no world.csv)] [--waiting-groups G] [--cyclists X]
/// [--clock-drift-ppm D] [--clock-epoch S] [--time-jitter-s SIGMA]
/// [--origin none | utm | X,Y].
pub fn parse_simulate(args: &[String]) -> Result<(super::simulate::SimParams, String), Box<dyn std::error::Error>> {
    let mut p = super::simulate::SimParams::default();
    let mut out = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut val = |name: &str| -> Result<String, Box<dyn std::error::Error>> { it.next().cloned().ok_or_else(|| format!("simulate: {name} needs a value").into()) };
        let num = |name: &str, v: String| -> Result<f64, Box<dyn std::error::Error>> { v.parse::<f64>().map_err(|_| format!("simulate: {name} must be a number, got {v:?}").into()) };
        match a.as_str() {
            "--cameras" => p.cameras = num(a, val(a)?)? as usize,
            "--minutes" => p.minutes = num(a, val(a)?)?,
            "--seed" => p.seed = val(a)?.parse().map_err(|_| "simulate: --seed must be a non-negative integer")?,
            "--rate-hz" => p.rate_hz = super::simulate::parse_rates(&val(a)?)?,
            "--traffic" => p.traffic = num(a, val(a)?)?,
            "--pedestrians" => p.pedestrians = num(a, val(a)?)?,
            "--noise-sigma" => {
                let v = val(a)?;
                p.noise_sigma = match v.split_once(',') {
                    Some((lo, hi)) => (num(a, lo.to_string())?, num(a, hi.to_string())?),
                    None => {
                        let s = num(a, v)?;
                        (s, s)
                    }
                };
            }
            "--noise-tracks-per-min" => p.noise_tracks_per_min = num(a, val(a)?)?,
            "--clock-offset-max" => p.clock_offset_max = num(a, val(a)?)?,
            "--world-rate-hz" => p.world_rate_hz = num(a, val(a)?)?,
            "--waiting-groups" => p.waiting_groups = num(a, val(a)?)?,
            "--cyclists" => p.cyclists = num(a, val(a)?)?,
            "--clock-drift-ppm" => p.clock_drift_ppm = num(a, val(a)?)?,
            "--clock-epoch" => p.clock_epoch = num(a, val(a)?)?,
            "--time-jitter-s" => p.time_jitter_s = num(a, val(a)?)?,
            "--origin" => p.origin = super::simulate::Origin::parse(&val(a)?)?,
            "--out" => out = Some(val(a)?),
            other => return Err(format!("simulate: unknown option {other:?}\n{}", super::USAGE).into()),
        }
    }
    Ok((p, out.ok_or("simulate needs --out DIR")?))
}

/// Simulates a scenario into `out` (CSV files by the simulator, points.parquet through DuckDB).
pub fn simulate(db: Option<&str>, p: &super::simulate::SimParams, out: &str, command: &str) -> Result<(), Box<dyn std::error::Error>> {
    let t = std::time::Instant::now();
    let s = super::simulate::simulate(p)?;
    let dir = std::path::Path::new(out);
    let con = crate::open(db)?;
    // points.parquet is written into the claim's staging folder with the other files, so it is
    // in the manifest and a later scenario into this folder replaces it (src/app/outdir.rs)
    s.write_with(dir, &format!("trajdb {command}"), |staging| {
        let q = |f: &str| super::sql::sql_string(&staging.join(f).to_string_lossy());
        con.execute_batch(&format!(
            "COPY (SELECT camera::INTEGER AS camera, track_id::BIGINT AS track_id, class::VARCHAR AS class, t::DOUBLE AS t,
                          x::DOUBLE AS x, y::DOUBLE AS y, speed::DOUBLE AS speed, estimated::INTEGER AS estimated
                   FROM read_csv({}, header = true)) TO {} (FORMAT parquet)",
            q("points.csv"),
            q("points.parquet")
        ))
        .map_err(|e| super::simulate::SimError::Param(format!("writing points.parquet: {e}")))
    })?;
    eprintln!(
        "[trajdb] simulate {:>7.2} s  {} objects, {} cameras, {} tracks, {} points -> {out}",
        t.elapsed().as_secs_f64(),
        s.objects.len(),
        s.cameras.len(),
        s.truth.len(),
        s.points.len()
    );
    Ok(())
}
