//! Agglomerative clustering (Buzan et al. sections 4.3–4.5).
//!
//! | file | SQL | what |
//! |---|---|---|
//! | [`condensed`] | | the shared vocabulary: the linkage method, a raw merge, the condensed matrix (a leaf) |
//! | [`linkage`] | `agglomerative_cluster`, `agglomerative_cluster_k`, `agglomerative_dendrogram` | linkage on sparse pairs with cannot-links, scipy-style cuts (dispatch, matrix, labels) |
//! | [`mst`] | (single) | Prim's minimum spanning tree on the condensed matrix |
//! | [`nn_chain`] | (complete, average, weighted, ward) | the nearest-neighbour chain, Lance–Williams updates in place |
//! | [`traj_cluster`] | `traj_cluster` | all pairwise S1/S2 distances in parallel, then [`linkage`] |
//! | [`prototype`] | `traj_cluster_prototypes` | prototypes (leader clustering, linear in n), then [`linkage`] over them |

pub mod condensed;
pub mod linkage;
pub mod mst;
pub mod nn_chain;
pub mod prototype;
pub mod traj_cluster;
