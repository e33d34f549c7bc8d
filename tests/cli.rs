//! The `trajdb` command: sql / run / stdin, --db, --csv / --json, demo, functions.

use std::io::Write;
use std::process::{Command, Stdio};

fn trajdb(args: &[&str], stdin: Option<&str>) -> (bool, String, String) {
    let mut c = Command::new(env!("CARGO_BIN_EXE_trajdb"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    if let Some(s) = stdin {
        c.stdin.take().unwrap().write_all(s.as_bytes()).unwrap();
    }
    drop(c.stdin.take());
    let o = c.wait_with_output().unwrap();
    (o.status.success(), String::from_utf8_lossy(&o.stdout).into(), String::from_utf8_lossy(&o.stderr).into())
}

/// Simulates a scenario into a fresh temp folder named after `name` (simulator options `sim`),
/// then runs the pipeline on it into `results/` (extra pipeline options `pipeline`). Returns the
/// scenario and results folders.
fn simulated_run(name: &str, sim: &[&str], pipeline: &[&str]) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("trajdb-{name}-{}", std::process::id()));
    let mut args = vec!["simulate", "--out", dir.to_str().unwrap()];
    args.extend_from_slice(sim);
    let (ok, _, err) = trajdb(&args, None);
    assert!(ok, "{err}");
    let (res, input) = (dir.join("results"), dir.join("points.parquet"));
    let mut args = vec!["pipeline", "--input", input.to_str().unwrap(), "--out", res.to_str().unwrap()];
    args.extend_from_slice(pipeline);
    let (ok, _, err) = trajdb(&args, None);
    assert!(ok, "{err}");
    (dir, res)
}

/// The numbers of the `all` row in the section of `trajdb score`'s output that starts with
/// `section`, and the row itself.
fn score_all_row(text: &str, section: &str) -> (Vec<f64>, String) {
    let all = text.lines().skip_while(|l| !l.starts_with(section)).find(|l| l.trim_start().starts_with("all")).expect(text);
    (all.split_whitespace().skip(1).filter_map(|w| w.parse().ok()).collect(), all.to_string())
}

const Q: &str = "SELECT lcss_length([{'t': 0, 'x': 0, 'y': 0}], [{'t': 0.1, 'x': 0.2, 'y': 0}], 1.0, 0.5) AS l";

#[test]
fn sql_table_csv_json() {
    let (ok, out, _) = trajdb(&["sql", Q], None);
    assert!(ok && out.contains("| l |") && out.contains("| 1 |"), "{out}");
    let (ok, out, _) = trajdb(&["--csv", "sql", Q], None);
    assert!(ok);
    assert_eq!(out, "l\n1\n");
    let (ok, out, _) = trajdb(&["--json", "sql", Q], None);
    assert!(ok);
    assert_eq!(out.trim(), r#"[{"l":1}]"#);
}

#[test]
fn stdin_and_run_file_and_persistent_db() {
    let dir = std::env::temp_dir().join(format!("trajdb-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let db = dir.join("t.duckdb");
    let db = db.to_str().unwrap();
    let (ok, _, err) = trajdb(&["--db", db], Some("CREATE TABLE t AS SELECT 42 AS v; -- comment; with semicolon\n"));
    assert!(ok, "{err}");
    let script = dir.join("q.sql");
    std::fs::write(&script, "SELECT v FROM t;\nSELECT 'a;b' AS s;").unwrap();
    let (ok, out, err) = trajdb(&["--db", db, "--csv", "run", script.to_str().unwrap()], None);
    assert!(ok, "{err}");
    assert_eq!(out, "v\n42\ns\na;b\n");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn errors_exit_nonzero_with_the_message() {
    let (ok, _, err) = trajdb(&["sql", "SELECT lcss_similarity([], [], -1, 1)"], None);
    assert!(!ok);
    assert!(err.contains("lcss_similarity: epsilon must be > 0, got -1"), "{err}");
    let (ok, _, err) = trajdb(&["bogus"], None);
    assert!(!ok && err.contains("unrecognized subcommand 'bogus'"), "{err}");
    // every command has its own help, with defaults; `trajdb help` is the overview
    let (ok, out, _) = trajdb(&["simulate", "--help"], None);
    assert!(ok && out.contains("--rate-hz <X>") && out.contains("[default: 10]"), "{out}");
    let (ok, out, _) = trajdb(&["pipeline", "--help"], None);
    assert!(ok && out.contains("--param <NAME=VALUE>") && out.contains("merge_eta"), "{out}");
    let (ok, out, _) = trajdb(&["help"], None);
    assert!(ok && out.contains("pipeline") && out.contains("score") && out.contains("simulate"), "{out}");
}

#[test]
fn demo_simulates_runs_the_pipeline_and_passes_its_score() {
    let dir = std::env::temp_dir().join(format!("trajdb-demo-{}", std::process::id()));
    let (ok, out, err) = trajdb(&["demo", "--out", dir.to_str().unwrap()], None);
    assert!(ok, "{out}\n{err}");
    assert!(out.contains("demo PASSED"), "{out}");
    for f in ["points.parquet", "points.csv", "cameras.csv", "truth.csv", "world.csv", "objects.csv", "README.txt"] {
        assert!(dir.join(f).exists(), "{f}");
    }
    for f in ["transforms.csv", "matches.csv", "merged.parquet", "clusters.csv", "links.csv", "report.html"] {
        assert!(dir.join("results").join(f).exists(), "{f}");
    }
    let html = std::fs::read_to_string(dir.join("results/report.html")).unwrap();
    for needle in ["<svg", "Cayley", "Sample merges", "heavy_vehicle", "cyclist"] {
        assert!(html.contains(needle), "report lacks {needle}");
    }
    // every class of the simulator gets scored
    for class in ["car", "heavy_vehicle", "cyclist", "pedestrian"] {
        assert!(out.lines().any(|l| l.trim_start().starts_with(class)), "{class}: {out}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn simulate_is_deterministic_and_checks_its_options() {
    let base = std::env::temp_dir().join(format!("trajdb-sim-{}", std::process::id()));
    let run = |name: &str, extra: &[&str]| {
        let d = base.join(name);
        let mut args = vec!["simulate", "--cameras", "2", "--minutes", "1", "--seed", "5", "--out", d.to_str().unwrap()];
        args.extend_from_slice(extra);
        let (ok, _, err) = trajdb(&args, None);
        (ok, err, d)
    };
    let (ok, err, a) = run("a", &[]);
    assert!(ok, "{err}");
    let (ok, err, b) = run("b", &[]);
    assert!(ok, "{err}");
    let read = |d: &std::path::Path| std::fs::read_to_string(d.join("points.csv")).unwrap();
    assert_eq!(read(&a), read(&b));
    // the parquet copy holds the same rows, typed as in ../shared/data
    let q = format!("SELECT count(*), typeof(any_value(camera)), typeof(any_value(estimated)) FROM read_parquet('{}')", a.join("points.parquet").display());
    let (ok, out, err) = trajdb(&["--csv", "sql", &q], None);
    assert!(ok, "{err}");
    let n = read(&a).lines().count() - 1;
    assert!(out.contains(&format!("{n},INTEGER,INTEGER")), "{out} vs {n}");
    for (bad, msg) in [
        (vec!["--cameras", "0"], "cameras must be in 1..=16"),
        (vec!["--minutes", "x"], "--minutes must be a number"),
        (vec!["--rate-hz", "-1"], "rate_hz must be in (0, 1000] Hz, got -1"),
        (vec!["--rate-hz", "2,x"], "rate_hz must be a number or a comma list"),
        (vec!["--bogus", "1"], "unexpected argument '--bogus'"),
    ] {
        let (ok, err, _) = run("c", &bad);
        assert!(!ok && err.contains(msg), "{bad:?}: {err}");
    }
    std::fs::remove_dir_all(&base).ok();
}

#[test]
fn demo_sql_runs_and_finds_the_shared_objects() {
    let (ok, out, err) = trajdb(&["--csv", "demo", "--sql"], None);
    assert!(ok, "{err}");
    // Results: align_frames (from sql/align.sql), then the
    // summary candidate_pairs,above_threshold,correct,objects_seen_by_both,...
    let lines: Vec<&str> = out.lines().collect();
    let k = lines.iter().position(|l| l.starts_with("candidate_pairs")).expect(&out);
    let row: Vec<&str> = lines[k + 1].split(',').collect();
    // camera 2 was generated rotated by 120 degrees: its transform to camera 1 is found
    let cam2 = lines.iter().find(|l| l.starts_with("2,1,")).expect(&out);
    let theta: f64 = cam2.split(',').nth(2).unwrap().parse().unwrap();
    assert!((theta - 120.0).abs() < 0.5, "{cam2}");
    let (above, correct, both): (i64, i64, i64) = (row[1].parse().unwrap(), row[2].parse().unwrap(), row[3].parse().unwrap());
    assert_eq!(above, correct, "every pair above the threshold is the same object");
    assert_eq!(correct, both, "every object seen by both cameras is found");
}

#[test]
fn functions_reference_lists_every_function() {
    let (ok, out, _) = trajdb(&["functions", "--markdown"], None);
    assert!(ok);
    for f in ["lcss_similarity", "lcss_s2", "traj_speeds", "trajdb_functions"] {
        assert!(out.contains(&format!("## `{f}`")), "{f}");
    }
}

/// Every registered example runs, and where its comment gives the result, it matches.
#[test]
fn every_documented_example_runs_and_matches_its_comment() {
    let con = trajdb::open(None).unwrap();
    for d in trajdb::bindings::docs() {
        let (sql, expected) = match d.example.split_once("; --") {
            Some((s, e)) => (s, Some(e.trim())),
            None => (d.example.trim_end_matches(';'), None),
        };
        let wrapped = format!("SELECT COLUMNS(*)::VARCHAR FROM ({sql}) AS q");
        let mut stmt = con.prepare(&wrapped).unwrap_or_else(|e| panic!("{}: {e}\n{sql}", d.name));
        let mut rows = stmt.query([]).unwrap();
        let row = rows.next().unwrap().unwrap_or_else(|| panic!("{}: no rows", d.name));
        let got: Option<String> = row.get(0).unwrap();
        if let Some(e) = expected.filter(|e| !e.contains('~')) {
            assert_eq!(got.as_deref(), Some(e), "{}: {sql}", d.name);
        }
    }
}

/// `trajdb pipeline` on the demo's two synthetic cameras (written to Parquet and to CSV first):
/// every result file is written, the transforms cover both directions, and unknown parameters
/// are rejected.
#[test]
fn pipeline_writes_results() {
    let dir = std::env::temp_dir().join(format!("trajdb-pipeline-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let pq = dir.join("points.parquet");
    let csv = dir.join("points.csv");
    let script = format!(
        "{}\n;\nCOPY (SELECT camera, track_id, class, t, x, y, estimated FROM points) TO '{}' (FORMAT parquet);\nCOPY (SELECT camera, track_id, class, t, x, y, estimated FROM points) TO '{}' (HEADER);",
        include_str!("../sql/demo.sql"),
        pq.display(),
        csv.display()
    );
    let (ok, _, err) = trajdb(&[], Some(&script));
    assert!(ok, "{err}");
    for (input, out) in [(&pq, dir.join("out_pq")), (&csv, dir.join("out_csv"))] {
        let (ok, _, err) = trajdb(
            &["pipeline", "--input", input.to_str().unwrap(), "--out", out.to_str().unwrap(), "--param", "merge_eta=0.4"],
            None,
        );
        assert!(ok, "{err}");
        assert!(err.contains("[trajdb] align") && err.contains("[trajdb] total"), "progress: {err}");
        let transforms = std::fs::read_to_string(out.join("transforms.csv")).unwrap();
        assert_eq!(transforms.lines().count(), 3, "{transforms}");
        assert!(std::fs::read_to_string(out.join("matches.csv")).unwrap().lines().count() > 10);
        assert!(out.join("clusters.csv").exists());
        // GeoParquet: DuckDB reads the WKB column back as GEOMETRY (the geo metadata), LINESTRING M with M = t
        let q = format!(
            "SELECT typeof(geometry), count(*) > 0, bool_and(ST_AsWKB(geometry) = traj_to_wkb(traj, true)) FROM read_parquet('{}') GROUP BY ALL",
            out.join("merged.parquet").display()
        );
        let (ok, got, err) = trajdb(&["--csv", "sql", &q], None);
        assert!(ok, "{err}");
        assert!(got.contains("GEOMETRY,true,true"), "{got}");
    }
    let (ok, _, err) = trajdb(&["pipeline", "--input", pq.to_str().unwrap(), "--out", dir.join("x").to_str().unwrap(), "--param", "nope=1"], None);
    assert!(!ok && err.contains("unknown parameter \"nope\""), "{err}");
    let (ok, _, err) = trajdb(&["pipeline", "--out", "x"], None);
    assert!(!ok && err.contains("--input"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `sql/pipeline.sql` (with `.read` includes, as in the DuckDB CLI) runs through `trajdb run`.
#[test]
fn pipeline_sql_runs_with_read_includes() {
    let dir = std::env::temp_dir().join(format!("trajdb-pipesql-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let pq = dir.join("points.parquet");
    let script = format!(
        "{}\n;\nCOPY (SELECT camera, track_id, class, t, x, y, estimated FROM points) TO '{}' (FORMAT parquet);",
        include_str!("../sql/demo.sql"),
        pq.display()
    );
    assert!(trajdb(&[], Some(&script)).0);
    let run = format!(
        "SET VARIABLE pipeline_input = '{}';\n.read sql/pipeline.sql\nSELECT count(*) > 10 AS ok FROM merged WHERE n_tracks = 2;",
        pq.display()
    );
    let (ok, out, err) = trajdb(&["--csv"], Some(&run));
    assert!(ok, "{err}");
    assert!(out.trim_end().ends_with("ok\ntrue"), "{out}");
    let (ok, _, err) = trajdb(&[], Some(".read no/such/file.sql\n"));
    assert!(!ok && err.contains(".read no/such/file.sql"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `trajdb score` on a shared scenario (skipped when ../shared/data is not beside the clone):
/// the pipeline's transforms are within 0.5 degrees and 0.3 m, and match F1 is at least 0.95.
#[test]
fn score_on_shared_scenario() {
    let sc = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/dut_roundabout_2cam");
    if !sc.join("truth.csv").exists() {
        eprintln!("skipped: {} not found", sc.display());
        return;
    }
    let out = std::env::temp_dir().join(format!("trajdb-score-{}", std::process::id()));
    let (ok, _, err) = trajdb(&["pipeline", "--input", sc.join("points.parquet").to_str().unwrap(), "--out", out.to_str().unwrap()], None);
    assert!(ok, "{err}");
    let (ok, text, err) = trajdb(&["score", sc.to_str().unwrap(), "--results", out.to_str().unwrap()], None);
    assert!(ok, "{err}");
    let worst: Vec<f64> = text.lines().next().unwrap().split_whitespace().filter_map(|w| w.parse().ok()).collect();
    assert!(worst[0] <= 0.5 && worst[1] <= 0.3, "{text}");
    let f1: f64 = text.lines().last().unwrap().split_whitespace().nth(3).unwrap().parse().unwrap();
    assert!(f1 >= 0.95, "{text}");
    let (ok, _, err) = trajdb(&["score", "/no/such/dir", "--results", out.to_str().unwrap()], None);
    assert!(!ok && err.contains("no/such/dir"), "{err}");
    std::fs::remove_dir_all(&out).ok();
}

/// `trajdb score` measures road-user identity from merged.parquet alone: its `sources` name the
/// original tracks (every track the pipeline kept, exactly once), and the identity table gives
/// IDF1, exactly reconstructed objects and the within-camera links.
#[test]
fn score_reports_identity_from_original_sources() {
    let (dir, res) = simulated_run("identity", &["--cameras", "3", "--minutes", "2", "--seed", "3"], &[]);
    let d = dir.to_str().unwrap();
    // sources are original track ids: together they are exactly the tracks of links.csv, once each
    let q = format!(
        "WITH s AS (SELECT unnest(sources) AS s FROM read_parquet('{m}')),
              l AS (SELECT camera, track_id FROM read_csv('{l}'))
         SELECT (SELECT count(*) FROM s) = (SELECT count(DISTINCT (s.camera, s.track_id)) FROM s)
            AND (SELECT count(*) FROM s) = (SELECT count(*) FROM l)
            AND NOT EXISTS (SELECT 1 FROM s ANTI JOIN l ON l.camera = s.camera AND l.track_id = s.track_id) AS ok",
        m = res.join("merged.parquet").display(),
        l = res.join("links.csv").display()
    );
    let (ok, out, err) = trajdb(&["--csv", "sql", &q], None);
    assert!(ok, "{err}");
    assert_eq!(out, "ok\ntrue\n");
    let (ok, text, err) = trajdb(&["score", d, "--results", res.to_str().unwrap()], None);
    assert!(ok, "{err}");
    let (v, all) = score_all_row(&text, "road users");
    assert!(v[0] > 0.9 && v[0] <= 1.0, "IDF1: {all}");
    assert!(v[1] > 0.5 && v[1] <= 1.0, "exact share: {all}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Calibration (issue 14): on cameras whose clocks are off by up to 0.3 s, the pipeline
/// measures each camera's sampling period and noise, fits the clock offsets with the
/// transforms, writes calibration.csv, and `trajdb score` finds the offsets within 20 ms;
/// `--param merge_epsilon=0.4` is reported as given.
#[test]
fn calibration_measures_period_noise_and_clock_offsets() {
    let (dir, res) = simulated_run(
        "calib",
        &["--cameras", "3", "--minutes", "3", "--seed", "4", "--rate-hz", "5", "--clock-offset-max", "0.3"],
        &["--param", "merge_epsilon=0.4"],
    );
    let d = dir.to_str().unwrap();
    let q = format!(
        "SELECT count(*) FILTER (WHERE quantity = 'sampling period' AND abs(value - 0.2) < 1e-6) AS periods,
                count(*) FILTER (WHERE quantity = 'position noise sigma' AND value BETWEEN 0.02 AND 0.3) AS sigmas,
                count(*) FILTER (WHERE quantity = 'clock offset') AS offsets,
                bool_and(how = 'given') FILTER (WHERE quantity = 'merge_epsilon') AS eps_given
         FROM read_csv('{}')",
        res.join("calibration.csv").display()
    );
    let (ok, out, err) = trajdb(&["--csv", "sql", &q], None);
    assert!(ok, "{err}");
    assert_eq!(out, "periods,sigmas,offsets,eps_given\n3,3,3,true\n");
    let (ok, text, err) = trajdb(&["score", d, "--results", res.to_str().unwrap()], None);
    assert!(ok, "{err}");
    let first = text.lines().next().unwrap();
    let ms: f64 = first.rsplit("clock offset error ").next().unwrap().trim_end_matches(" ms").parse().expect(first);
    assert!(ms < 20.0, "{first}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Neighbours and merged paths (issue 14): in a pedestrian crowd, where pairs walk side by side
/// 0.7 m apart, no road user holds real tracks of two objects, matches.csv names original
/// tracks with their road user, and every merged point lies within 1 m of its object's true
/// path at the same time (`trajdb score`, against world.csv).
#[test]
fn crowd_neighbours_stay_apart_and_merged_paths_stay_on_the_true_path() {
    let (dir, res) = simulated_run("crowd", &["--cameras", "3", "--minutes", "2", "--seed", "5", "--pedestrians", "10"], &[]);
    let d = dir.to_str().unwrap();
    let q = format!(
        "WITH s AS (SELECT road_user, unnest(sources) AS s FROM read_parquet('{m}')),
              t AS (SELECT * FROM read_csv('{t}') WHERE is_noise = 0),
              mixed AS (SELECT road_user FROM s JOIN t ON t.camera = s.s.camera AND t.track_id = s.s.track_id
                        GROUP BY road_user HAVING count(DISTINCT t.object_id) > 1),
              m AS (SELECT * FROM read_csv('{x}'))
         SELECT (SELECT count(*) FROM mixed) AS mixed,
                (SELECT count(*) FROM m ANTI JOIN t ON t.camera = m.camera_a AND t.track_id = m.track_a) AS unknown_tracks,
                (SELECT count(*) FILTER (WHERE road_user IS NULL OR class IS NULL) FROM m) AS no_road_user",
        m = res.join("merged.parquet").display(),
        t = dir.join("truth.csv").display(),
        x = res.join("matches.csv").display()
    );
    let (ok, out, err) = trajdb(&["--csv", "sql", &q], None);
    assert!(ok, "{err}");
    assert_eq!(out, "mixed,unknown_tracks,no_road_user\n0,0,0\n");
    let (ok, text, err) = trajdb(&["score", d, "--results", res.to_str().unwrap()], None);
    assert!(ok, "{err}");
    let (v, all) = score_all_row(&text, "merged paths");
    assert!(v[0] > 1000.0 && v[3] < 1.0 && v[4] == 0.0, "points, median, p95, max, road users > 1 m: {all}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Input mapping (issue 15): own column names (input_columns), a TIMESTAMP t and no
/// `estimated` column give the same road users; a missing column fails the load stage with an
/// error that names the stage, the missing column and the fix, and leaves no output folder.
#[test]
fn pipeline_maps_columns_timestamps_and_fails_cleanly() {
    let dir = std::env::temp_dir().join(format!("trajdb-map-{}", std::process::id()));
    let d = dir.to_str().unwrap();
    let (ok, _, err) = trajdb(&["simulate", "--cameras", "2", "--minutes", "1", "--seed", "2", "--out", d], None);
    assert!(ok, "{err}");
    let mapped = dir.join("mapped.parquet");
    let q = format!(
        "COPY (SELECT camera AS cam, track_id AS id, class, TIMESTAMP '2024-05-01 08:00:00' + to_microseconds((t * 1e6)::BIGINT) AS ts, x, y
               FROM '{}' WHERE estimated = 0) TO '{}'",
        dir.join("points.parquet").display(),
        mapped.display()
    );
    let (ok, _, err) = trajdb(&["sql", &q], None);
    assert!(ok, "{err}");
    let (plain, remapped) = (dir.join("plain"), dir.join("remapped"));
    let (ok, _, err) = trajdb(&["pipeline", "--input", dir.join("points.parquet").to_str().unwrap(), "--out", plain.to_str().unwrap()], None);
    assert!(ok, "{err}");
    let (ok, _, err) = trajdb(
        &["pipeline", "--input", mapped.to_str().unwrap(), "--out", remapped.to_str().unwrap(), "--param", "input_columns=camera=cam, track_id=id, t=ts"],
        None,
    );
    assert!(ok, "{err}");
    assert!(err.contains("found") && err.contains("road users"), "{err}");
    let count = |p: &std::path::Path| {
        let (ok, out, err) = trajdb(&["--csv", "sql", &format!("SELECT count(*) AS n FROM '{}'", p.join("merged.parquet").display())], None);
        assert!(ok, "{err}");
        out
    };
    assert_eq!(count(&plain), count(&remapped));
    let failed = dir.join("failed");
    let (ok, _, err) = trajdb(&["pipeline", "--input", mapped.to_str().unwrap(), "--out", failed.to_str().unwrap()], None);
    assert!(!ok);
    assert!(err.contains("pipeline stage 'load'") && err.contains("has no column camera, track_id, t") && err.contains("input_columns"), "{err}");
    assert!(!failed.exists());
    let leftovers = std::fs::read_dir(&dir).unwrap().filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().contains("partial")).count();
    assert_eq!(leftovers, 0);
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 17, pipeline integrity: faulty inputs give a clear message, the exit code says whether
/// results exist, and a failed run leaves no partial results and keeps an earlier run's intact.
#[test]
fn pipeline_on_faulty_input_says_what_is_wrong() {
    let dir = std::env::temp_dir().join(format!("trajdb-faulty-{}", std::process::id()));
    let d = dir.to_str().unwrap();
    let (ok, _, err) = trajdb(&["simulate", "--cameras", "3", "--minutes", "1", "--seed", "5", "--out", d], None);
    assert!(ok, "{err}");
    let pts = dir.join("points.parquet");
    let p = pts.to_str().unwrap();
    let make = |name: &str, select: &str| {
        let f = dir.join(name);
        let (ok, _, err) = trajdb(&["sql", &format!("COPY ({select}) TO '{}'", f.display())], None);
        assert!(ok, "{err}");
        f
    };
    let run = |input: &std::path::Path, out: &str, extra: &[&str]| {
        let mut a = vec!["pipeline", "--input", input.to_str().unwrap(), "--out", out];
        a.extend_from_slice(extra);
        trajdb(&a, None)
    };
    let out = dir.join("out");
    let o = out.to_str().unwrap();

    // a classifier flicker: camera 1's longest track is 'cyclist' for a third of its points
    let flicker = make(
        "flicker.parquet",
        &format!("SELECT * REPLACE (CASE WHEN camera = 1 AND track_id = (SELECT track_id FROM '{p}' WHERE camera = 1 GROUP BY track_id ORDER BY count(*) DESC, track_id LIMIT 1) AND round(t * 10)::BIGINT % 3 = 0 THEN 'cyclist' ELSE class END AS class) FROM '{p}'"),
    );
    let (ok, _, err) = run(&flicker, o, &[]);
    assert!(ok, "a class flicker must not kill the run: {err}");
    assert!(err.contains("warning: 1 tracks change class partway; each keeps its majority class"), "{err}");
    assert!(out.join("merged.parquet").exists());

    // a failed run keeps the earlier results as they were; the error names the column and the fix
    let text_t = make("text_t.parquet", &format!("SELECT * REPLACE (t::VARCHAR || 's' AS t) FROM '{p}'"));
    let (ok, _, err) = run(&text_t, o, &[]);
    assert!(!ok);
    assert!(err.contains("column t is VARCHAR, not a number (seconds) or a TIMESTAMP") && err.contains("fix: cast it"), "{err}");
    assert!(out.join("merged.parquet").exists(), "a failed run must keep the earlier results");
    assert!(!std::fs::read_dir(&out).unwrap().any(|e| e.unwrap().file_name().to_string_lossy().starts_with(".trajdb-partial")));

    let text_cam = make("text_cam.parquet", &format!("SELECT * REPLACE ('cam' || camera AS camera) FROM '{p}'"));
    let (ok, _, err) = run(&text_cam, o, &[]);
    assert!(!ok && err.contains("column camera is VARCHAR, not an integer") && err.contains("dense_rank()"), "{err}");

    let nulls = make("nulls.parquet", &format!("SELECT * REPLACE (CASE WHEN track_id % 10 = 3 THEN NULL ELSE x END AS x) FROM '{p}'"));
    let (ok, _, err) = run(&nulls, o, &[]);
    assert!(!ok && err.contains("rows have a NULL, NaN or infinite camera, track_id, class, t, x or y") && err.contains("the first: camera"), "{err}");

    let empty = make("empty.parquet", &format!("SELECT * FROM '{p}' WHERE false"));
    let (ok, _, err) = run(&empty, o, &[]);
    assert!(!ok && err.contains("has no rows"), "{err}");
    assert!(out.join("merged.parquet").exists());

    // one camera, and cameras that share no time: results, with a warning that says why
    let one = make("one.parquet", &format!("SELECT * FROM '{p}' WHERE camera = 1"));
    let (ok, _, err) = run(&one, o, &[]);
    assert!(ok && err.contains("warning: one camera: nothing to align or match"), "{err}");
    // ... and its tracks are road users with trajectories (they were lost, then had a NULL traj)
    let road_users_with_traj = |cam: i32| {
        let q = format!("SELECT count(*) FILTER (WHERE traj IS NOT NULL AND len(traj) > 0) || '/' || count(*) FROM '{o}/merged.parquet' WHERE sources[1].camera = {cam}");
        let (ok, text, err) = trajdb(&["sql", "--csv", &q], None);
        assert!(ok, "{err}");
        let v: Vec<i64> = text.lines().last().unwrap().trim_matches('"').split('/').map(|n| n.parse().unwrap()).collect();
        assert!(v[1] > 0 && v[0] == v[1], "camera {cam}: {text}");
    };
    road_users_with_traj(1);
    // a camera whose recording shares no time with the others (its first 20 s, theirs after 40 s)
    let apart = make("apart.parquet", &format!("SELECT * FROM '{p}' WHERE (camera = 2 AND t < 20) OR (camera <> 2 AND t >= 40)"));
    let (ok, _, err) = run(&apart, o, &[]);
    assert!(ok && err.contains("warning: 2 of 3 cameras in one frame: cameras [2] share no consistent track pairs"), "{err}");
    road_users_with_traj(2);
    // a camera whose CLOCK is 100,000 s off shares the time: align.sql finds the offset over every lag
    let off = make("off.parquet", &format!("SELECT * REPLACE (CASE WHEN camera = 2 THEN t + 100000 ELSE t END AS t) FROM '{p}'"));
    let (ok, _, err) = run(&off, o, &[]);
    assert!(ok && err.contains("3 of 3 cameras in one frame") && !err.contains("share no consistent"), "{err}");

    // the clustered camera is measured (the one with the most tracks) unless given; a given one must exist
    let (ok, _, err) = run(&pts, o, &["--param", "cluster_camera=7"]);
    assert!(!ok && err.contains("cluster_camera 7 is not a camera of the input (cameras: 0, 1, 2)"), "{err}");
    // --param values are typed, never pasted into SQL
    let (ok, _, err) = run(&pts, o, &["--param", "quality_max_gap=2.5; SET threads=1"]);
    assert!(!ok && err.contains("parameter quality_max_gap must be a number or auto"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A reader that closes the pipe early (`trajdb ... | head -1`) ends trajdb quietly, no panic.
#[test]
fn closed_stdout_is_not_a_panic() {
    let mut c = Command::new(env!("CARGO_BIN_EXE_trajdb"))
        .args(["functions"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(c.stdout.take()); // the reader is gone before trajdb writes
    let o = c.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert!(o.status.success(), "status {:?}: {err}", o.status);
}

/// Issue 25, the binary as a careless or hostile user meets it: the results folder rules of
/// src/app/outdir.rs (a folder with the user's files, '', the input's folder are refused before
/// any work and left untouched; a failed run keeps the earlier results), an --input that is SQL
/// is a missing file, not a statement, and parameter values outside their range are refused.
#[test]
fn pipeline_never_touches_what_it_did_not_write() {
    let (dir, res) = simulated_run("safety", &["--cameras", "2", "--minutes", "1", "--seed", "4"], &[]);
    let input = dir.join("points.parquet");
    let i = input.to_str().unwrap();
    let user = dir.join("user");
    std::fs::create_dir_all(&user).unwrap();
    std::fs::write(user.join("notes.txt"), "mine").unwrap();
    for out in [user.to_str().unwrap(), "", dir.to_str().unwrap()] {
        let (ok, _, err) = trajdb(&["pipeline", "--input", i, "--out", out], None);
        assert!(!ok && (err.contains("did not write") || err.contains("empty") || err.contains("input")), "{out}: {err}");
    }
    assert_eq!(std::fs::read_to_string(user.join("notes.txt")).unwrap(), "mine");
    assert!(input.exists());
    // a typo'd input into the earlier results: refused by the load, the results stay
    let typo = dir.join("typo.parquet");
    let (ok, _, err) = trajdb(&["pipeline", "--input", typo.to_str().unwrap(), "--out", res.to_str().unwrap()], None);
    assert!(!ok && err.contains("neither a table or view"), "{err}");
    assert!(res.join("merged.parquet").exists() && res.join(".trajdb-results").exists());
    let marker = dir.join("pwned");
    let evil = format!("points; COPY (SELECT 1) TO '{}'", marker.display());
    let (ok, _, err) = trajdb(&["pipeline", "--input", &evil, "--out", dir.join("r2").to_str().unwrap()], None);
    assert!(!ok && !marker.exists() && err.contains("neither a table or view"), "{err}");
    let (ok, _, err) = trajdb(&["pipeline", "--input", i, "--out", dir.join("r3").to_str().unwrap(), "--param", "merge_eta=2"], None);
    assert!(!ok && err.contains("merge_eta must be in"), "{err}");
    assert!(!dir.join("r3").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// `trajdb score` on a run that placed no camera pair (transforms.csv with its header only, as
/// the pipeline writes it then): a score that says so, not a type error.
#[test]
fn score_says_when_no_camera_pair_was_placed() {
    let (dir, res) = simulated_run("unplaced", &["--cameras", "2", "--minutes", "1", "--seed", "9"], &[]);
    std::fs::write(res.join("transforms.csv"), "cam_from,cam_to,theta_rad,tx,ty,clock_offset_s\n").unwrap();
    let (ok, text, err) = trajdb(&["score", dir.to_str().unwrap(), "--results", res.to_str().unwrap()], None);
    assert!(ok, "{err}");
    assert!(text.contains("camera pairs: none placed") && text.contains("matches"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}
