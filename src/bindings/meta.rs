//! SQL: `trajdb_functions()`, the function reference as a table (rows from the registry);
//! `trajdb_limit(name)`, a work limit read; `CALL trajdb_set_limit(name, value)`, a work limit set.
//!
//! # Limits under `lock_configuration`
//! Setting a limit changes what every connection to the database may do, as a setting does, so
//! a locked configuration locks it too. Only a table function's bind sees the caller's client
//! context (a scalar function has none in C API v1), so the setter is the table function
//! `trajdb_set_limit`, whose bind reads `lock_configuration` ([`BindArgs::configuration_locked`])
//! and refuses when it is true or cannot be read; the scalar `trajdb_limit` only reads. No other
//! function changes a limit ([`limits::Limits::set`] is called here alone).

use super::registry::{pd, Doc, Function, Section, Signature, Table, Ty};
use super::vector::table::{self, BindArgs, Rows, TableFn};
use super::vector::{Args, Out};
use crate::algo::limits;
use std::error::Error;
use std::sync::atomic::{AtomicUsize, Ordering};

const COLUMNS: &[(&str, Ty)] = &[
    ("name", Ty::Varchar),
    ("signatures", Ty::Varchar),
    ("description", Ty::Varchar),
    ("example", Ty::Varchar),
    ("maths", Ty::Varchar),
    ("binding", Ty::Varchar),
    ("test", Ty::Varchar),
    ("section", Ty::Varchar),
    ("see_also", Ty::Varchar),
    ("arguments", Ty::Varchar),
];

pub static FUNCTIONS: &[Function] = &[TRAJDB_FUNCTIONS, TRAJDB_LIMIT, TRAJDB_SET_LIMIT];

const TRAJDB_LIMIT: Function = Function {
    name: "trajdb_limit",
    description: "Reads a work limit, the most work one call may do (crates/algo/src/limits.rs; the names are listed under trajdb_set_limit). \
                  A call above a limit stops at once with an error that names it. Setting one is CALL trajdb_set_limit(name, value): \
                  trajdb_limit(name, value) is an error that says so.",
    example: "SELECT trajdb_limit('lcss_cells'); -- 10000000000",
    maths: "crates/algo/src/limits.rs",
    binding: file!(),
    section: Section::Reference,
    see_also: &["trajdb_set_limit"],
    signatures: &[Signature {
        params: &[
            pd("name", Ty::Varchar, "the limit's name, one of those listed under trajdb_set_limit (e.g. 'lcss_cells')"),
            pd("value", Ty::Bigint, "not taken: setting a limit is CALL trajdb_set_limit(name, value), and trajdb_limit(name, value) an error that says so"),
        ],
        arities: &[1, 2],
        returns: Ty::Bigint,
        kernel: limit,
    }],
    table: None,
};

fn limit(a: &Args<'_>, out: &mut Out<'_>) -> Result<(), Box<dyn std::error::Error>> {
    let (name, value) = (a.text(0), a.opt_bigint(1));
    // the calling database's limits: the dispatcher runs every kernel in their scope
    let mine = limits::current().ok_or("no database limits in scope (please report this)")?;
    let vals = a.map(|r| {
        let (Some(n), Some(v)) = (name.get(r), value.opt(r)) else { return Ok(None) };
        let l = limits::find(&n)?;
        if let Some(v) = v {
            // a scalar sees no client context, so it cannot honour lock_configuration: it never sets
            return Err(format!("setting a limit is CALL trajdb_set_limit('{}', {v}) (refused while lock_configuration is true); trajdb_limit(name) only reads", l.name).into());
        }
        Ok(Some(mine.get(l) as i64))
    })?;
    out.flat(&vals);
    Ok(())
}

const TRAJDB_SET_LIMIT: Function = Function {
    name: "trajdb_set_limit",
    description: concat!(
        "Sets a work limit, the most work one call may do (crates/algo/src/limits.rs), for this database (every connection to it; other \
         databases in the process keep their own), and returns its name, the previous value and the new one. The limits: ",
        "'lcss_cells' (cells of one LCSS table; traj_cluster with S2 sums them over pairs and translations, default 1e10), 'cpd_pair_visits' \
         (pairs in cpd_align's time band x max_iter, default 2e10), 'output_points' (points one call returns, default 5e7), 'memory_bytes' \
         (working memory of one call beyond its input and output, default 4e9), 'shift_pair_fits' (point pairs one rigid_fit_shifted fits, \
         default 2e8), 'label_pairs' (child pairs traj_labels compares, default 1e9), 'assign_steps' (assign_pairs' dense solves, rows x \
         columns x min of each component, default 2e11), 'pet_segment_pairs' (segment pairs one traj_pet examines; traj_conflicts and traj_conflicts_top: per pair of road users, \
         default 5e7). Refused while lock_configuration is true (or cannot be read): a locked configuration locks trajdb's limits too. \
         DuckDB's C API lets no extension see Ctrl-C inside a call: the limits keep every call short instead. Whatever a limit says, an \
         allocation that does not fit is an error, never an abort."
    ),
    example: "SELECT value FROM trajdb_set_limit('lcss_cells', 20000000000); -- 20000000000",
    maths: "crates/algo/src/limits.rs",
    binding: file!(),
    section: Section::Reference,
    see_also: &["trajdb_limit"],
    signatures: &[],
    table: Some(SET_TABLE),
};

const SET_COLUMNS: &[(&str, Ty)] = &[("name", Ty::Varchar), ("previous", Ty::Bigint), ("value", Ty::Bigint)];

const SET_TABLE: Table = Table {
    params: &[
        pd("name", Ty::Varchar, "the limit's name: 'lcss_cells', 'cpd_pair_visits', 'output_points', 'memory_bytes', 'shift_pair_fits', 'label_pairs', 'assign_steps' or 'pet_segment_pairs'"),
        pd("value", Ty::Bigint, "the new value, a whole number >= 1"),
    ],
    named: &[],
    columns: SET_COLUMNS,
    register: table::register::<SetLimit>,
};

struct SetLimit;

struct SetBind {
    limits: std::sync::Arc<limits::Limits>,
    name: &'static str,
    value: i64,
}

impl TableFn for SetLimit {
    const TABLE: &'static Table = &SET_TABLE;
    type Bind = SetBind;
    /// The previous value, once set (init runs once per execution), and whether the row was sent.
    type Scan = (u64, std::sync::atomic::AtomicBool);

    fn bind(args: &BindArgs<'_>) -> Result<Self::Bind, Box<dyn Error>> {
        let name = args.text(0)?.ok_or("name is NULL; give one of the limits' names")?;
        let l = limits::find(&name)?;
        let value = args.bigint(1)?.ok_or("value is NULL; give a whole number >= 1")?;
        if value < 1 {
            return Err(limits::LimitError::Value(value).into());
        }
        if args.configuration_locked() {
            return Err(format!(
                "lock_configuration is true (or cannot be read), so the work limits are locked as every setting is; {} stays {}",
                l.name,
                args.limits().get(l)
            )
            .into());
        }
        Ok(SetBind { limits: std::sync::Arc::clone(args.limits()), name: l.name, value })
    }

    fn init(b: &Self::Bind) -> Result<Self::Scan, Box<dyn Error>> {
        Ok((b.limits.set(b.name, b.value)?, std::sync::atomic::AtomicBool::new(false)))
    }

    fn func(b: &Self::Bind, scan: &Self::Scan, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        if scan.1.swap(true, Ordering::SeqCst) {
            return Ok(0);
        }
        out.text(0, 0, b.name);
        out.bigint(1, 0, scan.0.min(i64::MAX as u64) as i64);
        out.bigint(2, 0, b.value);
        Ok(1)
    }
}

const TRAJDB_FUNCTIONS: Function = Function {
    name: "trajdb_functions",
    description: "One row per trajdb function with its overloads (parameter names and types), description, example, where its maths, \
                  binding and tests live, its section of the reference, related functions (see_also, comma-separated) and its \
                  arguments (one line each: name, type and what it means); docs/functions.md is generated from the same descriptors.",
    example: "SELECT name FROM trajdb_functions() ORDER BY name;",
    maths: "src/bindings/registry.rs",
    binding: file!(),
    section: Section::Reference,
    see_also: &["trajdb_reference"],
    signatures: &[],
    table: Some(TABLE),
};

const TABLE: Table = Table { params: &[], named: &[], columns: COLUMNS, register: table::register::<FunctionsTable> };

struct FunctionsTable;

struct Cursor {
    next: AtomicUsize,
}

impl TableFn for FunctionsTable {
    const TABLE: &'static Table = &TABLE;
    type Bind = Vec<Doc>;
    type Scan = Cursor;

    fn bind(_: &BindArgs<'_>) -> Result<Self::Bind, Box<dyn Error>> {
        Ok(super::docs())
    }

    fn init(_: &Self::Bind) -> Result<Self::Scan, Box<dyn Error>> {
        Ok(Cursor { next: AtomicUsize::new(0) })
    }

    fn func(docs: &Self::Bind, cursor: &Self::Scan, out: &mut Rows<'_>) -> Result<usize, Box<dyn Error>> {
        // at most one chunk per call
        let start = cursor.next.fetch_add(Rows::CAPACITY, Ordering::SeqCst).min(docs.len());
        let rows = &docs[start..(start + Rows::CAPACITY).min(docs.len())];
        for (r, d) in rows.iter().enumerate() {
            let see_also = d.see_also.join(", ");
            let arguments: Vec<String> = d.arguments.iter().map(|a| format!("{} {}: {}", a.name, a.ty, a.doc)).collect();
            let arguments = arguments.join("\n");
            let row = [d.name, d.signatures.as_str(), d.description, d.example, d.maths, d.binding, d.test.as_str(), d.section.title(), see_also.as_str(), arguments.as_str()];
            for (k, v) in row.into_iter().enumerate() {
                out.text(k, r, v);
            }
        }
        Ok(rows.len())
    }
}
