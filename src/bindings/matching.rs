//! SQL: one-to-one selection of candidate pairs (the Hungarian step of thesis Alg. 2–4).
//! Maths: `crates/algo/src/matching/` (hungarian.rs, assign.rs).

use super::registry::{pd, Function, Section, Signature, Ty};
use super::vector::{Args, Column, Out};
use crate::algo::matching::{assign, hungarian};
use std::error::Error;

type R = Result<(), Box<dyn Error>>;

const PAIRS: Ty = Ty::List(&Ty::Struct(&[("a", Ty::Bigint), ("b", Ty::Bigint), ("score", Ty::Double)]));
const EDGES: Ty = Ty::List(&Ty::Struct(&[("a", Ty::Bigint), ("b", Ty::Bigint), ("w", Ty::Double)]));

pub static FUNCTIONS: &[Function] = &[
    Function {
        name: "hungarian_match",
        description: "Optimal one-to-one assignment over a sparse, possibly rectangular list of candidate pairs; pairs not in the list can never be matched. \
                      It matches as many pairs as possible and, among those, maximises (maximize = true, the default: similarities) or minimises (costs) the total, \
                      exactly like scipy.optimize.linear_sum_assignment on the dense matrix with absent pairs forbidden (rows that cannot be matched stay unmatched \
                      instead of raising). min_score removes candidates before solving: with maximize, pairs scoring below it; with costs, pairs above it. \
                      Duplicate (a, b) pairs keep their best score; ties are broken the same way whatever the list order; the result is sorted by (a, b). \
                      Connected components of the candidate graph are solved separately (in parallel): a complete list or component with the dense Jonker-Volgenant \
                      algorithm (LAPJV), the others with its sparse shortest-augmenting-path form (as scipy's min_weight_full_bipartite_matching). \
                      NULL or NaN scores are errors; an empty list gives an empty list.",
        example: "SELECT hungarian_match([{'a': 1, 'b': 10, 'score': 0.9}, {'a': 1, 'b': 20, 'score': 0.8}, {'a': 2, 'b': 10, 'score': 0.8}], true, 0.5); -- [{'a': 1, 'b': 20, 'score': 0.8}, {'a': 2, 'b': 10, 'score': 0.8}]",
        maths: "crates/algo/src/matching/hungarian.rs",
        binding: file!(),
        section: Section::Matching,
        see_also: &["assign_pairs", "merge_groups", "lcss_similarity_pairs"],
        signatures: &[Signature {
            params: &[
                pd("pairs", PAIRS, "the candidate pairs {a, b, score}; a pair not listed is never matched; a NULL or NaN score is an error"),
                pd("maximize", Ty::Boolean, "true: maximise the total score (similarities), false: minimise it (costs); default true"),
                pd("min_score", Ty::Double, "candidates scoring below it (maximize) or above it (costs) are removed before solving; default: none"),
            ],
            arities: &[1, 2, 3],
            returns: PAIRS,
            kernel: hungarian_match,
        }],
        table: None,
    },
    Function {
        name: "assign_pairs",
        description: "Maximum-weight one-to-one matching of candidate pairs (a, b) with weights w >= 0, e.g. track pairs and their LCSS \
                      similarity: list the candidates with list({'a': ..., 'b': ..., 'w': ...}) and unnest the result. The graph is split into \
                      connected components and each is solved exactly (scipy's LSAP algorithm via the lsap crate). Pairs of weight 0 are never chosen.",
        example: "SELECT assign_pairs([{'a': 1, 'b': 10, 'w': 0.9}, {'a': 1, 'b': 20, 'w': 0.8}, {'a': 2, 'b': 10, 'w': 0.8}, {'a': 2, 'b': 20, 'w': 0.1}]); -- [{'a': 1, 'b': 20, 'w': 0.8}, {'a': 2, 'b': 10, 'w': 0.8}]",
        maths: "crates/algo/src/matching/assign.rs",
        binding: file!(),
        section: Section::Matching,
        see_also: &["hungarian_match"],
        signatures: &[Signature {
            params: &[pd("edges", EDGES, "the candidate pairs {a, b, w} with weights w >= 0 (0: never chosen)")],
            arities: &[],
            returns: EDGES,
            kernel: assign_pairs,
        }],
        table: None,
    },
];

/// `(a, b, score)` candidate pairs of one list.
type Triples = Vec<(i64, i64, f64)>;

/// Writes `STRUCT(a BIGINT, b BIGINT, score|w DOUBLE)[]` rows.
fn write_triples(out: &mut Out<'_>, vals: &[Option<Triples>]) -> Result<(), String> {
    type Split = (Vec<i64>, Vec<i64>, Vec<f64>);
    let split: Vec<Option<Split>> = vals
        .iter()
        .map(|v| {
            v.as_ref().map(|t| {
                let (ab, w): (Vec<(i64, i64)>, Vec<f64>) = t.iter().map(|&(a, b, w)| ((a, b), w)).unzip();
                let (a, b) = ab.into_iter().unzip();
                (a, b, w)
            })
        })
        .collect();
    let cols: Vec<_> = split.iter().map(|v| v.as_ref().map(|(a, b, w)| vec![Column::I64(a), Column::I64(b), Column::F64(w)])).collect();
    out.struct_lists(&cols)
}

fn hungarian_match(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let (pairs, maximize, min_score) = (a.struct_list(0), a.opt_boolean(1), a.opt_double(2));
    let vals = a.map(|r| {
        let (Some(rows), Some(mx), Some(t)) = (pairs.get(r)?, maximize.or(r, true), min_score.opt(r)) else { return Ok(None) };
        let params = hungarian::MatchParams::new(mx, t)?;
        Ok(Some(hungarian::hungarian_match_columns(rows.i64(0), rows.i64(1), rows.f64(2), &params)?))
    })?;
    write_triples(out, &vals)?;
    Ok(())
}

fn assign_pairs(a: &Args<'_>, out: &mut Out<'_>) -> R {
    let edges = a.struct_list(0);
    let vals = a.map(|r| {
        let Some(rows) = edges.get(r)? else { return Ok(None) };
        let (ea, eb, ew) = (rows.i64(0), rows.i64(1), rows.f64(2));
        let chosen = assign::assign_max_columns(ea, eb, ew).map_err(|x| match x {
            assign::AssignError::Weight { .. } => format!("edges {x}"),
            _ => x.to_string(),
        })?;
        Ok(Some(chosen.into_iter().map(|k| (ea[k], eb[k], ew[k])).collect()))
    })?;
    write_triples(out, &vals)?;
    Ok(())
}
