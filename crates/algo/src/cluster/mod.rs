//! Agglomerative clustering (Buzan et al. sections 4.3–4.5).
//!
//! | file | SQL | what |
//! |---|---|---|
//! | [`linkage`] | `agglomerative_cluster`, `agglomerative_cluster_k`, `agglomerative_dendrogram` | linkage on sparse pairs with cannot-links (kodama), scipy-style cuts |
//! | [`traj_cluster`] | `traj_cluster` | all pairwise S1/S2 distances in parallel, then [`linkage`] |
//! | [`prototype`] | `traj_cluster_prototypes` | prototypes (leader clustering, linear in n), then [`linkage`] over them |

pub mod linkage;
pub mod prototype;
pub mod traj_cluster;
