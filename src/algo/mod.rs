//! Pure-Rust algorithms behind trajdb. Nothing in this module imports DuckDB:
//! it builds and tests with `cargo test --release --no-default-features --lib`.
//!
//! | file | what |
//! |---|---|
//! | [`traj`] | trajectory views, validation, speeds, WKT |
//! | [`hungarian`] | sparse rectangular optimal assignment (scipy semantics; components, lsap or sparse JV) |
//! | [`assign`] | sparse maximum-weight one-to-one assignment (components + scipy's LSAP via `lsap`) |
//! | [`cluster`] | agglomerative clustering with cannot-link pairs (kodama linkage, scipy-style cuts) |
//! | [`traj_cluster`] | trajectories clustered in one call: all Buzan S1/S2 distances in parallel, then [`cluster`] |
//! | [`band`] | the banded LCSS dynamic-programming engine shared by every LCSS form |
//! | [`lcss`] | time-window LCSS (thesis eq. 2.9, 2.10, Alg. 1), 2-D points and 1-D series |
//! | [`lcss_index`] | index-window LCSS of Buzan def. 4.1/4.2 (δ, ε, ρ, S1) |
//! | [`lcss_translate`] | translation-invariant S2 of Buzan def. 4.3, appendix / lemma 4.2 |
//! | [`events`] | broken / split / merge events of tracks within one camera (endpoints) |
//! | [`merge`] | trajectory merge (eq. 2.11, Alg. 3/4) and consistent road-user groups |
//! | [`region`] | polygon regions from WKT/WKB, validation, prepared point-in-polygon |
//! | [`hull`] | view polygons `P^k`: convex / concave hull with a density rule |
//! | [`polygon`] | overlaps, unions, area, WKB/WKT output |
//! | [`rigid`] | 2-D similarity transforms, Umeyama/Kabsch fit, trimmed robust fit |
//! | [`correspond`] | time-interpolated point pairs between two tracks (transform hypotheses) |
//! | [`cpd3`] | the same TimeCPD in 3-D (rotation by SVD, nalgebra) |
//! | [`cpd`] | rigid TimeCPD (thesis eq. 2.7/2.8, Alg. 5–8) with a sparse time-windowed E-step |

// `!(x > 0.0)` is used on purpose throughout: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod assign;
pub mod band;
pub mod cluster;
pub mod correspond;
pub mod cpd;
pub mod cpd3;
pub mod lcss;
pub mod lcss_index;
pub mod lcss_translate;
pub mod merge;
pub mod events;
pub mod hull;
pub mod hungarian;
pub mod polygon;
pub mod region;
pub mod rigid;
pub mod traj;
pub mod traj_cluster;
