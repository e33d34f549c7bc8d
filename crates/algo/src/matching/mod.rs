//! One-to-one selection of candidate pairs (the Hungarian step of thesis Alg. 2–4).
//!
//! | file | SQL | what |
//! |---|---|---|
//! | [`hungarian`] | `hungarian_match` | maximum-cardinality optimal assignment, absent pairs forbidden (scipy semantics); sparse Jonker–Volgenant per component |
//! | [`assign`] | `assign_pairs` | maximum total weight (the thesis's dense-with-zeros variant), lsap per component |
//!
//! Both split the candidate graph into connected components with [`crate::graph`].

pub mod assign;
pub mod hungarian;
