//! Union–find and the connected components of a bipartite edge list, shared by the
//! assignment solvers ([`crate::matching`]), road-user grouping ([`crate::merge`])
//! and the flat cuts of a dendrogram ([`crate::cluster::linkage`]).
//!
//! # Complexity
//! [`UnionFind::find`] is amortised O(α(n)) with path halving; [`dense_ids`] is O(m) when the
//! ids span a small range and O(m log m) otherwise; [`bipartite_components`] is O(m α(n)).

/// Disjoint sets over `0..n` with path halving. Which root survives a union is the caller's
/// choice ([`UnionFind::attach`]) or the smaller index ([`UnionFind::union`]), so results are
/// deterministic.
#[derive(Clone, Debug)]
pub struct UnionFind {
    parent: Vec<usize>,
}

impl UnionFind {
    pub fn new(n: usize) -> Self {
        UnionFind { parent: (0..n).collect() }
    }
    /// The root of `x`'s set.
    pub fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            let g = self.parent[self.parent[x]];
            self.parent[x] = g;
            x = g;
        }
        x
    }
    /// Makes root `child` a member of `root`'s set (both must be roots, or `root` a fresh node).
    pub fn attach(&mut self, child: usize, root: usize) {
        self.parent[child] = root;
    }
    /// Joins the sets of `a` and `b` under the smaller root; false when already joined.
    pub fn union(&mut self, a: usize, b: usize) -> bool {
        let (x, y) = (self.find(a), self.find(b));
        if x == y {
            return false;
        }
        self.parent[x.max(y)] = x.min(y);
        true
    }
}

/// Marks an id not yet numbered.
const NONE: u32 = u32::MAX;

/// Dense ids `0..n` for the distinct values of `ids`, in increasing order of value: a lookup
/// table when the values span a small range (the common case of row numbers), otherwise a
/// sort and binary search. Returns `(n, id of every element)`.
pub fn dense_ids(ids: &[i64]) -> (usize, Vec<u32>) {
    let m = ids.len();
    if m == 0 {
        return (0, Vec::new());
    }
    let (lo, hi) = ids.iter().fold((i64::MAX, i64::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    let span = (hi as i128 - lo as i128) as u128;
    if span < 4 * m as u128 + 1024 {
        let mut id = vec![NONE; span as usize + 1];
        for &v in ids {
            id[(v - lo) as usize] = 0;
        }
        let mut n = 0u32;
        for x in id.iter_mut() {
            if *x == 0 {
                *x = n;
                n += 1;
            }
        }
        (n as usize, ids.iter().map(|&v| id[(v - lo) as usize]).collect())
    } else {
        let mut sorted = ids.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        (sorted.len(), ids.iter().map(|v| sorted.binary_search(v).expect("id present") as u32).collect())
    }
}

/// The connected components of a bipartite graph given as edges `(a_of[k], b_of[k])`, with
/// `a` ids in `0..na` and `b` ids in `0..nb`.
#[derive(Clone, Debug, PartialEq)]
pub struct Components {
    /// Component `c` holds the edge indices `edges[start[c]..start[c + 1]]`, in input order.
    /// Components are numbered in order of their first edge.
    pub start: Vec<usize>,
    pub edges: Vec<u32>,
    /// Every edge's `a` and `b` renumbered inside its component, in order of first appearance.
    pub loc_a: Vec<u32>,
    pub loc_b: Vec<u32>,
    /// Per component, the number of distinct `a` and `b`.
    pub n_a: Vec<u32>,
    pub n_b: Vec<u32>,
}

impl Components {
    pub fn len(&self) -> usize {
        self.n_a.len()
    }
    pub fn is_empty(&self) -> bool {
        self.n_a.is_empty()
    }
    /// The edge indices of component `c`.
    pub fn edges_of(&self, c: usize) -> &[u32] {
        &self.edges[self.start[c]..self.start[c + 1]]
    }
}

/// Splits the edges into connected components (union–find plus counting sorts).
pub fn bipartite_components(a_of: &[u32], na: usize, b_of: &[u32], nb: usize) -> Components {
    let m = a_of.len();
    let mut uf = UnionFind::new(na + nb);
    for k in 0..m {
        uf.union(a_of[k] as usize, na + b_of[k] as usize);
    }
    let mut comp_id = vec![NONE; na + nb];
    let mut comp_of = Vec::with_capacity(m);
    let mut ncomp = 0u32;
    for &ak in a_of {
        let r = uf.find(ak as usize);
        if comp_id[r] == NONE {
            comp_id[r] = ncomp;
            ncomp += 1;
        }
        comp_of.push(comp_id[r]);
    }
    let nc = ncomp as usize;
    let mut start = vec![0usize; nc + 1];
    for &c in &comp_of {
        start[c as usize + 1] += 1;
    }
    for c in 0..nc {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut edges = vec![0u32; m];
    let (mut la, mut lb) = (vec![NONE; na], vec![NONE; nb]);
    let (mut n_a, mut n_b) = (vec![0u32; nc], vec![0u32; nc]);
    let (mut loc_a, mut loc_b) = (Vec::with_capacity(m), Vec::with_capacity(m));
    for k in 0..m {
        let c = comp_of[k] as usize;
        edges[fill[c]] = k as u32;
        fill[c] += 1;
        let (ga, gb) = (a_of[k] as usize, b_of[k] as usize);
        if la[ga] == NONE {
            la[ga] = n_a[c];
            n_a[c] += 1;
        }
        if lb[gb] == NONE {
            lb[gb] = n_b[c];
            n_b[c] += 1;
        }
        loc_a.push(la[ga]);
        loc_b.push(lb[gb]);
    }
    Components { start, edges, loc_a, loc_b, n_a, n_b }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn components_of_a_small_graph() {
        // a0-b0, a1-b1, a0-b1 join {a0, a1, b0, b1}; a2-b2 alone
        let c = bipartite_components(&[0, 1, 2, 0], 3, &[0, 1, 2, 1], 3);
        assert_eq!(c.len(), 2);
        assert_eq!(c.edges_of(0), &[0, 1, 3]);
        assert_eq!(c.edges_of(1), &[2]);
        assert_eq!((c.n_a.clone(), c.n_b.clone()), (vec![2, 1], vec![2, 1]));
        assert_eq!(c.loc_a, vec![0, 1, 0, 0]);
        assert!(bipartite_components(&[], 0, &[], 0).is_empty());
    }

    #[test]
    fn dense_ids_by_table_and_by_sort() {
        assert_eq!(dense_ids(&[7, 3, 7, 5]), (3, vec![2, 0, 2, 1]));
        assert_eq!(dense_ids(&[i64::MAX, i64::MIN, 0]), (3, vec![2, 0, 1]));
        assert_eq!(dense_ids(&[]), (0, vec![]));
    }

    proptest! {
        /// Same components as a naive flood fill.
        #[test]
        fn equals_flood_fill(edges in prop::collection::vec((0u32..6, 0u32..6), 0..14)) {
            let a: Vec<u32> = edges.iter().map(|e| e.0).collect();
            let b: Vec<u32> = edges.iter().map(|e| e.1).collect();
            let c = bipartite_components(&a, 6, &b, 6);
            // naive: label edges by repeated relaxation
            let mut label: Vec<usize> = (0..edges.len()).collect();
            loop {
                let mut changed = false;
                for i in 0..edges.len() {
                    for j in 0..edges.len() {
                        if (edges[i].0 == edges[j].0 || edges[i].1 == edges[j].1) && label[j] < label[i] {
                            label[i] = label[j];
                            changed = true;
                        }
                    }
                }
                if !changed { break; }
            }
            let mut comp_of = vec![0usize; edges.len()];
            for k in 0..c.len() {
                for &e in c.edges_of(k) { comp_of[e as usize] = k; }
            }
            for i in 0..edges.len() {
                for j in 0..edges.len() {
                    prop_assert_eq!(label[i] == label[j], comp_of[i] == comp_of[j]);
                }
            }
        }
    }
}
