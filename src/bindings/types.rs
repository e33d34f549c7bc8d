//! The type vocabulary of every descriptor: [`Ty`] (an SQL type, constant so that descriptors
//! can be `static`) and [`Param`] (a named, typed parameter). Below both the registry and the
//! vector module, which read arguments by these declarations.

use crate::algo::limits::Limits;
use duckdb::core::{LogicalTypeHandle, LogicalTypeId};
use duckdb::Connection;
use std::sync::Arc;

/// An SQL type, constant so that descriptors can be `static`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ty {
    Double,
    Bigint,
    Integer,
    Boolean,
    Varchar,
    Blob,
    /// DuckDB's core GEOMETRY (1.5+): WKB in a BLOB-like vector, read as WKB.
    Geometry,
    List(&'static Ty),
    Struct(&'static [(&'static str, Ty)]),
    /// Any one of these (an overload each), e.g. a polygon as WKT VARCHAR or WKB BLOB.
    OneOf(&'static [Ty]),
}

/// `STRUCT(t DOUBLE, x DOUBLE, y DOUBLE)[]`, a trajectory (written `TRAJ` in the reference).
pub const TRAJ: Ty = Ty::List(&Ty::Struct(&[("t", Ty::Double), ("x", Ty::Double), ("y", Ty::Double)]));
/// `STRUCT(theta DOUBLE, tx DOUBLE, ty DOUBLE, scale DOUBLE)`, a 2-D similarity transform.
pub const TRANSFORM: Ty = Ty::Struct(&[("theta", Ty::Double), ("tx", Ty::Double), ("ty", Ty::Double), ("scale", Ty::Double)]);
/// A polygon: WKT text, WKB bytes, or a GEOMETRY value (DuckDB 1.5+; e.g. merged.parquet's geometry).
pub const GEOMETRY: Ty = Ty::OneOf(&[Ty::Varchar, Ty::Blob, Ty::Geometry]);
/// A list of polygons: WKT, WKB or GEOMETRY elements.
pub const GEOMETRY_LIST: Ty = Ty::OneOf(&[Ty::List(&Ty::Varchar), Ty::List(&Ty::Blob), Ty::List(&Ty::Geometry)]);
/// `STRUCT(t DOUBLE, v DOUBLE)[]`, a 1-D series such as speeds.
pub const SERIES: Ty = Ty::List(&Ty::Struct(&[("t", Ty::Double), ("v", Ty::Double)]));

impl Ty {
    /// The DuckDB logical type (not defined for [`Ty::OneOf`]: expand it first).
    pub fn logical(&self) -> LogicalTypeHandle {
        match self {
            Ty::Double => LogicalTypeId::Double.into(),
            Ty::Bigint => LogicalTypeId::Bigint.into(),
            Ty::Integer => LogicalTypeId::Integer.into(),
            Ty::Boolean => LogicalTypeId::Boolean.into(),
            Ty::Varchar => LogicalTypeId::Varchar.into(),
            Ty::Blob => LogicalTypeId::Blob.into(),
            Ty::Geometry => LogicalTypeId::Geometry.into(),
            Ty::List(t) => LogicalTypeHandle::list(&t.logical()),
            Ty::Struct(fields) => {
                let f: Vec<(&str, LogicalTypeHandle)> = fields.iter().map(|(n, t)| (*n, t.logical())).collect();
                LogicalTypeHandle::struct_type(&f)
            }
            Ty::OneOf(_) => panic!("Ty::OneOf has no single logical type"),
        }
    }
    /// Every concrete type this one stands for.
    pub(crate) fn alternatives(&self) -> Vec<Ty> {
        match self {
            Ty::OneOf(ts) => ts.to_vec(),
            t => vec![*t],
        }
    }
    /// The type as SQL spells it (a cast target: no TRAJ alias, every field name quoted);
    /// not defined for [`Ty::OneOf`] (expand it first). The fuzz cases cast to it.
    pub fn concrete(&self) -> String {
        match self {
            Ty::List(t) => format!("{}[]", t.concrete()),
            Ty::Struct(fields) => {
                let f: Vec<String> = fields.iter().map(|(n, t)| format!("\"{n}\" {}", t.concrete())).collect();
                format!("STRUCT({})", f.join(", "))
            }
            Ty::OneOf(_) => panic!("Ty::OneOf has no single SQL type"),
            t => t.sql(),
        }
    }
    /// The SQL spelling used in the reference.
    pub fn sql(&self) -> String {
        if *self == TRAJ {
            return "TRAJ".into();
        }
        match self {
            Ty::Double => "DOUBLE".into(),
            Ty::Bigint => "BIGINT".into(),
            Ty::Integer => "INTEGER".into(),
            Ty::Boolean => "BOOLEAN".into(),
            Ty::Varchar => "VARCHAR".into(),
            Ty::Blob => "BLOB".into(),
            Ty::Geometry => "GEOMETRY".into(),
            Ty::List(t) => format!("{}[]", t.sql()),
            Ty::Struct(fields) => {
                let f: Vec<String> = fields.iter().map(|(n, t)| format!("{} {}", quote(n), t.sql())).collect();
                format!("STRUCT({})", f.join(", "))
            }
            Ty::OneOf(ts) => ts.iter().map(Ty::sql).collect::<Vec<_>>().join("|"),
        }
    }
}

/// Field names that are SQL keywords are quoted, as DuckDB prints them.
fn quote(name: &str) -> String {
    if matches!(name, "left" | "right") {
        format!("\"{name}\"")
    } else {
        name.to_string()
    }
}

/// A named, typed, documented parameter.
#[derive(Clone, Copy, Debug)]
pub struct Param {
    pub name: &'static str,
    pub ty: Ty,
    /// What the argument means, in one line for the reference: its unit, and its default and
    /// range where it has them (a unit test refuses an empty one on any function).
    pub doc: &'static str,
}

/// A parameter without its doc yet (add it with [`Param::doc`]): `p("epsilon", Ty::Double)`.
pub const fn p(name: &'static str, ty: Ty) -> Param {
    Param { name, ty, doc: "" }
}

/// Shorthand for descriptors: `pd("epsilon", Ty::Double, "matching distance (m), > 0")`.
pub const fn pd(name: &'static str, ty: Ty, doc: &'static str) -> Param {
    Param { name, ty, doc }
}

impl Param {
    /// This parameter with its doc (for shared parameters documented where they are used).
    pub const fn doc(self, doc: &'static str) -> Param {
        Param { doc, ..self }
    }
}

/// A table function's documented shape: positional and named parameters, result columns; it
/// registers itself (`vector::table::register::<T>`) under the function's name with the
/// database's limits.
#[derive(Clone, Copy)]
pub struct Table {
    pub params: &'static [Param],
    pub named: &'static [Param],
    pub columns: &'static [(&'static str, Ty)],
    pub register: fn(&Connection, &'static str, &Database) -> duckdb::Result<()>,
}

/// What every registration of one database shares: its work limits.
#[derive(Clone)]
pub struct Database {
    pub limits: Arc<Limits>,
}

