//! The standing fuzz harness (issue 17): every scalar SQL function, every overload, driven with
//! generated arguments (proptest strategies, a fixed seed): NULLs, NaN and ±inf, extreme
//! magnitudes, unsorted and duplicate times, empty, single-point and long lists, invalid WKT
//! and WKB, bad parameters. Each call must give a value, NULL, or an error that names the
//! function; never a panic, an INTERNAL error, a call that does not come back, or a connection
//! that stops working.
//!
//! Quick mode (`cargo test --release --test fuzz`, in scripts/test.sh): TRAJDB_FUZZ_CASES
//! cases per overload (default 24). Long mode: `TRAJDB_FUZZ_CASES=2000 cargo test --release
//! --test fuzz`. With TRAJDB_FUZZ_OUT=FILE the cases are also written there, one SQL statement
//! per line, for tests/run_fuzz_python.py (the loadable extension in PyPI DuckDB 2.0 and 1.5).

use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use std::time::{Duration, Instant};
use trajdb::bindings::registry::Ty;

/// A call slower than this counts as a hang (documented work limits keep every call far below).
const HANG: Duration = Duration::from_secs(30);

fn sql_type(t: &Ty) -> String {
    match t {
        Ty::Double => "DOUBLE".into(),
        Ty::Bigint => "BIGINT".into(),
        Ty::Integer => "INTEGER".into(),
        Ty::Boolean => "BOOLEAN".into(),
        Ty::Varchar => "VARCHAR".into(),
        Ty::Blob => "BLOB".into(),
        Ty::Geometry => "GEOMETRY".into(),
        Ty::List(i) => format!("{}[]", sql_type(i)),
        Ty::Struct(f) => format!("STRUCT({})", f.iter().map(|(n, t)| format!("\"{n}\" {}", sql_type(t))).collect::<Vec<_>>().join(", ")),
        Ty::OneOf(_) => unreachable!("expanded first"),
    }
}

fn pick(v: &[&'static str]) -> BoxedStrategy<String> {
    proptest::sample::select(v.to_vec()).prop_map(String::from).boxed()
}

const WKT: &[&str] = &[
    "'POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))'",
    "'POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0), (1 1, 2 1, 2 2, 1 2, 1 1))'",
    "'MULTIPOLYGON (((0 0, 1 0, 1 1, 0 0)), ((5 5, 7 5, 7 7, 5 5)))'",
    "'POLYGON EMPTY'",
    "'POLYGON ((0 0, 1 1))'",
    "'POLYGON ((0 0, 1 0, 1 1))'",
    "'POLYGON ((0 0, 1e200 0, 1e200 1e200, 0 0))'",
    "'POLYGON ((0 0, 1e300 0, 0 1e300, 0 0))'",
    "'POLYGON ((0 0, NaN 0, 1 1, 0 0))'",
    "'POLYGON ((0 0, 2 2, 2 0, 0 2, 0 0))'",
    "'POINT (1 2)'",
    "'LINESTRING (0 0, 1 1)'",
    "'POLYGON ((0 0, 1 0'",
    "''",
    "'garbage'",
];

const WORDS: &[&str] = &[
    "'single'", "'complete'", "'average'", "'weighted'", "'ward'", "'convex'", "'concave'", "'density'", "'S1'", "'S2'",
    "'inf'", "''", "'x'", "'euclidean'",
];

fn double() -> BoxedStrategy<String> {
    prop_oneof![
        4 => (-1e3f64..1e3).prop_map(|v| format!("{v:?}")),
        2 => pick(&["0", "1", "-1", "0.5", "2", "3", "10", "100"]),
        2 => pick(&["'NaN'", "'inf'", "'-inf'", "1e308", "-1.7e308", "1e-320", "1e154", "1e200", "1e-300", "9.2e18"]),
        1 => Just("NULL".to_string()),
    ]
    .boxed()
}

fn integer(lo: i64, hi: i64) -> BoxedStrategy<String> {
    prop_oneof![
        4 => (-3i64..60).prop_map(|v| v.to_string()),
        2 => pick(&["0", "1", "2", "3", "4", "8", "100000000"]),
        1 => Just(lo.to_string()),
        1 => Just(hi.to_string()),
        1 => Just("NULL".to_string()),
    ]
    .boxed()
}

/// A point list (TRAJ or any `STRUCT(t, x, y[, ...])[]` with a time field): sorted, unsorted or
/// with repeated times; or long (thousands of points).
fn point_list(fields: &'static [(&'static str, Ty)]) -> BoxedStrategy<String> {
    let n_fields = fields.len();
    let row = proptest::collection::vec(double(), n_fields);
    prop_oneof![
        1 => Just("NULL".to_string()),
        1 => Just("[]".to_string()),
        1 => Just("[NULL]".to_string()),
        6 => (proptest::collection::vec(row, 1..9), 0u8..3).prop_map(move |(rows, mode)| {
            let mut rows: Vec<Vec<String>> = rows;
            // mode 0: times increasing, 1: as drawn (unsorted), 2: every time equal
            for (k, r) in rows.iter_mut().enumerate() {
                if let Some(pos) = fields.iter().position(|(n, _)| *n == "t") {
                    r[pos] = match mode {
                        0 => format!("{}", k as f64 * 0.1),
                        2 => "1.0".to_string(),
                        _ => r[pos].clone(),
                    };
                }
            }
            let items: Vec<String> = rows
                .iter()
                .map(|r| format!("{{{}}}", fields.iter().zip(r).map(|((n, _), v)| format!("'{n}': {v}")).collect::<Vec<_>>().join(", ")))
                .collect();
            format!("[{}]", items.join(", "))
        }),
        1 => (prop_oneof![Just(2000usize), Just(20000usize)]).prop_map(move |n| {
            let body = fields.iter().map(|(f, _)| match *f {
                "t" => "'t': i * 0.04".to_string(),
                "x" => "'x': 12 * sin(i * 0.001) + i * 0.01".to_string(),
                "y" => "'y': 5 * cos(i * 0.002)".to_string(),
                other => format!("'{other}': (i % 7) * 0.5"),
            }).collect::<Vec<_>>().join(", ");
            format!("[{{{body}}} FOR i IN range({n})]")
        }),
    ]
    .boxed()
}

fn value(t: &Ty) -> BoxedStrategy<String> {
    let raw: BoxedStrategy<String> = match t {
        Ty::Double => double(),
        Ty::Bigint => integer(i64::MIN, i64::MAX),
        Ty::Integer => integer(i32::MIN as i64, i32::MAX as i64),
        Ty::Boolean => pick(&["true", "false", "NULL"]),
        Ty::Varchar => prop_oneof![3 => pick(WKT), 2 => pick(WORDS), 1 => Just("NULL".to_string())].boxed(),
        Ty::Blob => pick(&[
            "NULL",
            "''",
            "'\\x01\\x03\\x00'",
            // a valid little-endian WKB square, and the same cut short
            "from_hex('010300000001000000050000000000000000000000000000000000000000000000000024400000000000000000000000000000244000000000000024400000000000000000000000000000244000000000000000000000000000000000')",
            "from_hex('01030000000100000005000000000000000000000000000000')",
        ]),
        Ty::Geometry => pick(&[
            "NULL",
            "'POLYGON ((0 0, 10 0, 10 10, 0 10, 0 0))'",
            "'POLYGON EMPTY'",
            "'POINT (1 2)'",
            "'LINESTRING (0 0, 1 1)'",
            "'MULTIPOLYGON (((0 0, 1 0, 1 1, 0 0)), ((5 5, 7 5, 7 7, 5 5)))'",
        ]),
        Ty::List(inner) => match inner {
            Ty::Struct(fields) if fields.iter().any(|(n, _)| *n == "t") => point_list(fields),
            _ => {
                let el = value(inner);
                prop_oneof![
                    1 => Just("NULL".to_string()),
                    1 => Just("[]".to_string()),
                    6 => proptest::collection::vec(el, 1..8).prop_map(|v| format!("[{}]", v.join(", "))),
                ]
                .boxed()
            }
        },
        Ty::Struct(fields) => {
            let parts: Vec<BoxedStrategy<String>> = fields.iter().map(|(_, t)| value(t)).collect();
            let names: Vec<&'static str> = fields.iter().map(|(n, _)| *n).collect();
            prop_oneof![
                1 => Just("NULL".to_string()),
                8 => parts.prop_map(move |vs| format!("{{{}}}", names.iter().zip(vs).map(|(n, v)| format!("'{n}': {v}")).collect::<Vec<_>>().join(", "))),
            ]
            .boxed()
        }
        Ty::OneOf(_) => unreachable!("expanded first"),
    };
    let ty = sql_type(t);
    raw.prop_map(move |v| format!("CAST({v} AS {ty})")).boxed()
}

/// What a call's error may be: anything but a panic or an INTERNAL error; trajdb's own errors
/// (Invalid Input) name the function.
fn bad_error(name: &str, msg: &str) -> Option<String> {
    let lower = msg.to_lowercase();
    if lower.contains("panic") || msg.contains("INTERNAL") {
        return Some(format!("panic / internal error: {msg}"));
    }
    if msg.contains("Invalid Input Error") && !msg.contains(&format!("{name}:")) && !msg.contains("Conversion") {
        return Some(format!("an error that does not name {name}: {msg}"));
    }
    None
}

#[test]
fn every_function_survives_generated_arguments() {
    let cases: u32 = std::env::var("TRAJDB_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(24);
    let con = trajdb::open(None).expect("open");
    let mut written = Vec::new();
    let mut failures = Vec::new();
    let (mut n_cases, mut n_err, mut n_null, mut slowest) = (0usize, 0usize, 0usize, (Duration::ZERO, String::new()));
    for f in trajdb::bindings::functions() {
        for sig in f.signatures {
            for ov in sig.overloads() {
                let strategy: Vec<BoxedStrategy<String>> = ov.iter().map(value).collect();
                let mut runner = TestRunner::new_with_rng(Config { cases, ..Config::default() }, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
                for _ in 0..cases {
                    let args = strategy.new_tree(&mut runner).expect("tree").current();
                    let call = format!("{}({})", f.name, args.join(", "));
                    let sql = format!("SELECT ({call})::VARCHAR");
                    // a watchdog interrupts a call that does not come back
                    let handle = con.interrupt_handle();
                    let (done, wait) = std::sync::mpsc::channel::<()>();
                    let watched: String = call.chars().take(400).collect();
                    let dog = std::thread::spawn(move || {
                        if wait.recv_timeout(HANG).is_err() {
                            eprintln!("HANG (> {HANG:?}, interrupting): {watched}");
                            handle.interrupt();
                            return true;
                        }
                        false
                    });
                    let t = Instant::now();
                    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| con.query_row(&sql, [], |r| r.get::<_, Option<String>>(0))));
                    let took = t.elapsed();
                    let _ = done.send(());
                    let hung = dog.join().unwrap_or(false);
                    n_cases += 1;
                    if took > Duration::from_secs(2) {
                        eprintln!("slow case ({:.1} s): {}", took.as_secs_f64(), call.chars().take(300).collect::<String>());
                    }
                    if n_cases % 5000 == 0 {
                        eprintln!("fuzz: {n_cases} cases so far, {} failures", failures.len());
                    }
                    if took > slowest.0 {
                        slowest = (took, call.chars().take(160).collect());
                    }
                    match r {
                        Err(_) => failures.push(format!("{call}: the call panicked through the boundary")),
                        Ok(Ok(None)) => n_null += 1,
                        Ok(Ok(Some(_))) => {}
                        Ok(Err(e)) => {
                            n_err += 1;
                            if let Some(why) = bad_error(f.name, &e.to_string()) {
                                failures.push(format!("{call}: {why}"));
                            }
                        }
                    }
                    if hung {
                        failures.push(format!("{call}: did not come back within {HANG:?}"));
                    }
                    if con.query_row("SELECT 42", [], |r| r.get::<_, i64>(0)).ok() != Some(42) {
                        failures.push(format!("{call}: the connection stopped working"));
                    }
                    written.push(sql);
                }
            }
        }
    }
    if let Ok(path) = std::env::var("TRAJDB_FUZZ_OUT") {
        std::fs::write(&path, written.join(";\n") + ";\n").expect("write cases");
    }
    eprintln!(
        "fuzz: {n_cases} cases ({cases} per overload), {n_err} errors, {n_null} NULLs, {} failures; slowest {:.2} s: {}",
        failures.len(),
        slowest.0.as_secs_f64(),
        slowest.1
    );
    for f in failures.iter().take(40) {
        eprintln!("FAIL {f}");
    }
    assert!(failures.is_empty(), "{} of {n_cases} fuzz cases failed (first: {})", failures.len(), failures[0]);
}
