//! The standing fuzz harness (issue 17), generation half: every scalar SQL function, every
//! overload, driven with generated arguments (proptest strategies, a fixed seed): NULLs, NaN and
//! ±inf, extreme magnitudes, unsorted and duplicate times, empty, single-point and long lists,
//! invalid WKT and WKB, bad parameters. This test only WRITES the calls (no DuckDB is opened:
//! the crate is the loadable extension); tests/run_fuzz_python.py runs them through the
//! extension in PyPI DuckDB 2.0 and 1.5, where each call must give a value, NULL, or an error
//! that names the function; never a panic, an INTERNAL error, a call that does not come back
//! within 30 s, or a connection that stops working.
//!
//! Quick mode (scripts/test.sh): `TRAJDB_FUZZ_OUT=cases.sql cargo test --release --test fuzz`,
//! TRAJDB_FUZZ_CASES cases per overload (default 24). Long mode: TRAJDB_FUZZ_CASES=2000. The
//! file holds one SQL statement per line: `SELECT (function(args))::VARCHAR;`.

use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use trajdb::bindings::registry::Ty;


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
    let ty = t.concrete();
    raw.prop_map(move |v| format!("CAST({v} AS {ty})")).boxed()
}

#[test]
fn every_function_gets_generated_arguments() {
    let cases: u32 = std::env::var("TRAJDB_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(24);
    let mut written = Vec::new();
    let mut names = Vec::new();
    for f in trajdb::bindings::functions() {
        for sig in f.signatures {
            for ov in sig.overloads() {
                let strategy: Vec<BoxedStrategy<String>> = ov.iter().map(value).collect();
                let mut runner = TestRunner::new_with_rng(Config { cases, ..Config::default() }, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
                for _ in 0..cases {
                    let args = strategy.new_tree(&mut runner).expect("tree").current();
                    let sql = format!("SELECT ({}({}))::VARCHAR", f.name, args.join(", "));
                    // one statement per line: tests/run_fuzz_python.py reads them so
                    assert!(!sql.contains('\n') && !sql.contains(';'), "{sql}");
                    written.push(sql);
                }
            }
        }
        if !f.signatures.is_empty() {
            names.push(f.name);
        }
    }
    assert!(names.len() > 40 && written.len() >= names.len() * cases as usize, "{} functions, {} cases", names.len(), written.len());
    match std::env::var("TRAJDB_FUZZ_OUT") {
        Ok(path) => {
            std::fs::write(&path, written.join(";\n") + ";\n").expect("write cases");
            eprintln!("fuzz: {} cases ({cases} per overload) of {} functions -> {path}; run them: tests/run_fuzz_python.py EXT {path}", written.len(), names.len());
        }
        Err(_) => eprintln!("fuzz: {} cases generated; set TRAJDB_FUZZ_OUT=FILE to write them for tests/run_fuzz_python.py", written.len()),
    }
}
