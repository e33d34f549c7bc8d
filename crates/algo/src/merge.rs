//! Merging matched trajectories (thesis eq. 2.11, Alg. 3 and 4) and grouping matched tracks
//! into road users without contradictions.
//!
//! # Θ(A, B), eq. 2.11
//! The LCSS (eq. 2.9, restricted to the overlap polygon as in eq. 2.10) pairs points of A and
//! B; a matched pair becomes one point at the midpoint of the two, at their mid time
//! `min(a_t, b_t) + |a_t − b_t| / 2`; unmatched points of both are kept; the result is sorted by
//! t (stable: on equal t, merged points, then A's, then B's, each in input order). LCSS matches
//! increase in both indices, so merged times never go backwards.
//!
//! # Several cameras: φ_i = Θ(φ_{i−1}, A^{k_i})
//! The thesis takes the plain midpoint at every step, so in a three-camera merge the last
//! camera weighs 1/2 and the first two 1/4 each. That is an artefact of the recursion, not a
//! modelling choice; we carry a weight (the number of original points averaged into each point)
//! and average with it, which is exactly eq. 2.11 for two trajectories and gives every camera
//! the same say for more.
//!
//! # Consistent groups (Alg. 4's "remove duplicates", and its false links)
//! [`consistent_groups`] applies links (track pairs judged to be the same road user) in the
//! given order with union–find, and refuses a link that would put two tracks of the same camera
//! that overlap in time into one road user (a camera cannot see one road user twice at once).
//! Two pieces of a track that one camera split (disjoint in time) may both join the same road
//! user: this is how a split track is matched as a whole although the assignment is one-to-one
//! per camera pair. Every track ends in exactly one group, so a road user is listed once and
//! φ_ij never survives next to a φ_ijk that contains it.
//!
//! # Complexity
//! [`merge_pair`]: the LCSS of [`crate::lcss::time_window`] plus O((n + m) log(n + m)) for the sort.
//! [`consistent_groups`]: O((T + L) log² T) for T tracks and L links (small-to-large merging of
//! per-camera interval sets), plus O(min(|A|, |B|) log T) once per pair of groups in conflict.

use crate::lcss::time_window::{band_cells, matches_in, TimeWindowParams};
use crate::lcss::LcssError;
use crate::geometry::region::Region;
use crate::graph::UnionFind;
use crate::traj::{OwnedTraj, Traj};
use std::collections::{HashMap, HashSet};
use std::fmt;

/// A trajectory whose points carry the number of original points averaged into them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Weighted {
    pub t: Vec<f64>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub w: Vec<f64>,
}

impl Weighted {
    pub fn from_traj(a: Traj<'_>) -> Self {
        Weighted { t: a.t.to_vec(), x: a.x.to_vec(), y: a.y.to_vec(), w: vec![1.0; a.len()] }
    }
    pub fn view(&self) -> Traj<'_> {
        Traj::new(&self.t, &self.x, &self.y)
    }
    pub fn into_traj(self) -> OwnedTraj {
        OwnedTraj { t: self.t, x: self.x, y: self.y }
    }
}

/// Θ(a, b) of eq. 2.11 given the matched pairs, with weights (see module docs).
pub fn merge_pair(a: &Weighted, b: &Weighted, matches: &[(usize, usize)]) -> Weighted {
    let mut used_a = vec![false; a.t.len()];
    let mut used_b = vec![false; b.t.len()];
    // (t, kind, order, x, y, w): kind 0 = merged, 1 = a, 2 = b
    let mut pts: Vec<(f64, u8, usize, f64, f64, f64)> = Vec::with_capacity(a.t.len() + b.t.len());
    for (k, &(i, j)) in matches.iter().enumerate() {
        used_a[i] = true;
        used_b[j] = true;
        let (wa, wb) = (a.w[i], b.w[j]);
        let w = wa + wb;
        // weights first: (wa·p + wb·q) / w overflowed for coordinates near f64::MAX, while a
        // convex combination of two finite numbers is always finite
        let (fa, fb) = (wa / w, wb / w);
        let avg = |p: f64, q: f64| fa * p + fb * q;
        pts.push((avg(a.t[i], b.t[j]), 0, k, avg(a.x[i], b.x[j]), avg(a.y[i], b.y[j]), w));
    }
    for i in (0..a.t.len()).filter(|&i| !used_a[i]) {
        pts.push((a.t[i], 1, i, a.x[i], a.y[i], a.w[i]));
    }
    for j in (0..b.t.len()).filter(|&j| !used_b[j]) {
        pts.push((b.t[j], 2, j, b.x[j], b.y[j], b.w[j]));
    }
    pts.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)).then(p.2.cmp(&q.2)));
    Weighted {
        t: pts.iter().map(|p| p.0).collect(),
        x: pts.iter().map(|p| p.3).collect(),
        y: pts.iter().map(|p| p.4).collect(),
        w: pts.iter().map(|p| p.5).collect(),
    }
}

/// Θ(a, b) of eq. 2.11 in one call (`trajectory_merge(a, b, ...)`): the LCSS pairs inside
/// `region` (eq. 2.10), merged. The LCSS is checked against the limits `lcss_cells` and
/// `memory_bytes` ([`matches_in`]).
pub fn merge_two(a: Traj<'_>, b: Traj<'_>, p: &TimeWindowParams, region: Option<&Region>) -> Result<OwnedTraj, MergeError> {
    let m = matches_in(a, b, p, region).map_err(MergeError::Lcss)?;
    Ok(merge_pair(&Weighted::from_traj(a), &Weighted::from_traj(b), &m).into_traj())
}

/// φ_{N−1}: merges `trajs` in the given order, step i (i ≥ 1) restricted to `regions[i − 1]`
/// when regions are given (then exactly one per step, else [`MergeError::Regions`]). Returns
/// the merged trajectory and the number of matched pairs at each step. Each step's LCSS is
/// checked against the limits before it runs ([`matches_in`]), and the cells of all steps so
/// far against `lcss_cells`.
pub fn merge_chain(trajs: &[Traj<'_>], p: &TimeWindowParams, regions: Option<&[&Region]>) -> Result<(OwnedTraj, Vec<usize>), MergeError> {
    if let Some(r) = regions {
        if r.len() + 1 != trajs.len().max(1) {
            return Err(MergeError::Regions { steps: trajs.len().saturating_sub(1), got: r.len() });
        }
    }
    let Some(first) = trajs.first() else { return Ok((OwnedTraj::default(), vec![])) };
    let mut phi = Weighted::from_traj(*first);
    let mut counts = Vec::with_capacity(trajs.len().saturating_sub(1));
    // the cells of all steps so far, against lcss_cells before each step: the whole chain stays
    // within the limit, not only each step
    let mut cells: u128 = 0;
    for (k, next) in trajs.iter().enumerate().skip(1) {
        cells += band_cells(&phi.t, next.t, p.time_window());
        crate::limits::LCSS_CELLS.check(cells).map_err(|e| MergeError::Lcss(LcssError::Work(e)))?;
        let region = regions.map(|r| r[k - 1]);
        let m = matches_in(phi.view(), *next, p, region).map_err(MergeError::Lcss)?;
        counts.push(m.len());
        phi = merge_pair(&phi, &Weighted::from_traj(*next), &m);
    }
    Ok((phi.into_traj(), counts))
}

/// Why merging or grouping failed.
#[derive(Clone, Debug, PartialEq)]
pub enum MergeError {
    /// A link names a track that is not in the track list (1-based link index).
    UnknownTrack { link: usize, id: i64 },
    /// The same track id is listed twice.
    DuplicateTrack(i64),
    /// A track's time range is NaN or reversed.
    TimeRange { id: i64 },
    /// [`merge_chain`] got a region list whose length is not one per merge step.
    Regions { steps: usize, got: usize },
    /// The LCSS of a merge step is over a limit.
    Lcss(LcssError),
}

impl fmt::Display for MergeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MergeError::UnknownTrack { link, id } => write!(f, "links[{link}] names track {id}, which is not in tracks"),
            MergeError::DuplicateTrack(id) => write!(f, "tracks lists id {id} twice"),
            MergeError::TimeRange { id } => write!(f, "track {id} needs finite t0 <= t1"),
            MergeError::Regions { steps, got } => {
                write!(f, "regions needs one polygon per merge step (len(trajs) - 1 = {steps}), got {got}")
            }
            MergeError::Lcss(e) => e.fmt(f),
        }
    }
}
impl std::error::Error for MergeError {}

/// One track: a unique id (e.g. `camera * 1e9 + track_id`), its camera and time range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    pub id: i64,
    pub camera: i64,
    pub t0: f64,
    pub t1: f64,
}

/// An order-preserving key for a finite time: `a <= b` exactly when `key(a) <= key(b)`
/// (−0 and +0 are one key, as they are one number).
fn time_key(t: f64) -> u64 {
    let b = (t + 0.0).to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | 1 << 63
    }
}

/// The tracks of one group: per camera, their time ranges `(t0, t1)`, which never overlap
/// (the invariant [`consistent_groups`] keeps), keyed by `(camera, start)`. Empty for a group
/// of one track, its root (most tracks never join anything: no allocation for them).
type Ranges = std::collections::BTreeMap<(i64, u64), (f64, f64)>;

/// The tracks `(camera, t0, t1)` of the group rooted at `root`.
fn group_tracks<'a>(tracks: &'a [Span], ranges: &'a Ranges, root: usize) -> impl Iterator<Item = (i64, f64, f64)> + 'a {
    let alone = ranges.is_empty().then(|| (tracks[root].camera, tracks[root].t0, tracks[root].t1));
    alone.into_iter().chain(ranges.iter().map(|(&(c, _), &(t0, t1))| (c, t0, t1)))
}

/// Does a track of camera `c` on `[t0, t1]` overlap a track of the same camera in the group
/// rooted at `root`? Its ranges per camera are disjoint and sorted by start, so the range that
/// starts last at or before `t1` also ends last among those, and is the only candidate. O(log g).
fn overlaps(tracks: &[Span], ranges: &Ranges, root: usize, c: i64, t0: f64, t1: f64) -> bool {
    if ranges.is_empty() {
        let s = &tracks[root];
        return s.camera == c && s.t0 <= t1 && t0 <= s.t1;
    }
    match ranges.range(..=(c, time_key(t1))).next_back() {
        Some((&(c2, _), &(_, e))) => c2 == c && t0 <= e,
        None => false,
    }
}

/// Groups tracks into road users by applying `links` in order (see module docs). Returns, for
/// every track in input order, its group: the smallest track id in the group. `accepted[k]`
/// tells whether link k was applied (false when it contradicted the group or was redundant).
///
/// Every track and link is checked before any work. A link joins two groups unless a track of
/// one overlaps in time a track of the same camera in the other: each track of the smaller
/// group is looked up in the larger one ([`overlaps`]), then moved into it (small to large: a
/// track moves O(log T) times). Two groups found in conflict stay in conflict as they grow, so
/// the pair is remembered while both are roots and never checked again. O((T + L) log² T) for
/// T tracks and L links, plus O(min(|A|, |B|) log T) once per pair of groups A, B in conflict.
pub fn consistent_groups(tracks: &[Span], links: &[(i64, i64)]) -> Result<(Vec<i64>, Vec<bool>), MergeError> {
    let mut index: HashMap<i64, usize> = HashMap::with_capacity(tracks.len());
    for (k, s) in tracks.iter().enumerate() {
        if !(s.t0 <= s.t1) || !s.t0.is_finite() || !s.t1.is_finite() {
            return Err(MergeError::TimeRange { id: s.id });
        }
        if index.insert(s.id, k).is_some() {
            return Err(MergeError::DuplicateTrack(s.id));
        }
    }
    let resolved: Vec<(usize, usize)> = links
        .iter()
        .enumerate()
        .map(|(l, &(a, b))| {
            let ia = *index.get(&a).ok_or(MergeError::UnknownTrack { link: l + 1, id: a })?;
            let ib = *index.get(&b).ok_or(MergeError::UnknownTrack { link: l + 1, id: b })?;
            Ok((ia, ib))
        })
        .collect::<Result<_, MergeError>>()?;
    drop(index);
    let n = tracks.len();
    let mut uf = UnionFind::new(n);
    let mut ranges: Vec<Ranges> = (0..n).map(|_| Ranges::new()).collect();
    let mut conflict: HashSet<(usize, usize)> = HashSet::new();
    let mut accepted = vec![false; links.len()];
    for (l, &(ia, ib)) in resolved.iter().enumerate() {
        let (ra, rb) = (uf.find(ia), uf.find(ib));
        if ra == rb {
            continue;
        }
        let pair = (ra.min(rb), ra.max(rb));
        if conflict.contains(&pair) {
            continue;
        }
        let (big, small) = if ranges[ra].len().max(1) >= ranges[rb].len().max(1) { (ra, rb) } else { (rb, ra) };
        if group_tracks(tracks, &ranges[small], small).any(|(c, t0, t1)| overlaps(tracks, &ranges[big], big, c, t0, t1)) {
            conflict.insert(pair);
            continue;
        }
        let moved: Vec<(i64, f64, f64)> = group_tracks(tracks, &ranges[small], small).collect();
        ranges[small] = Ranges::new();
        if ranges[big].is_empty() {
            let s = &tracks[big];
            ranges[big].insert((s.camera, time_key(s.t0)), (s.t0, s.t1));
        }
        for (c, t0, t1) in moved {
            ranges[big].insert((c, time_key(t0)), (t0, t1));
        }
        uf.attach(small, big);
        accepted[l] = true;
    }
    let mut label: Vec<i64> = vec![i64::MAX; n];
    for (k, t) in tracks.iter().enumerate() {
        let r = uf.find(k);
        label[r] = label[r].min(t.id);
    }
    let groups = (0..n).map(|k| label[uf.find(k)]).collect();
    Ok((groups, accepted))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(t0: f64, n: usize, y: f64) -> OwnedTraj {
        OwnedTraj { t: (0..n).map(|k| t0 + k as f64 * 0.1).collect(), x: (0..n).map(|k| (t0 + k as f64 * 0.1) * 10.0).collect(), y: vec![y; n] }
    }

    #[test]
    fn eq_2_11_midpoints_and_kept_points() {
        // A: t 0..0.9, B: t 0.5..1.4 shifted 0.2 m in y; overlap t 0.5..0.9 matches
        let (a, b) = (line(0.0, 10, 0.0), line(0.5, 10, 0.2));
        let p = TimeWindowParams::new(0.5, 0.05, 1).unwrap();
        let m = matches_in(a.view(), b.view(), &p, None).unwrap();
        assert_eq!(m.len(), 5);
        let merged = merge_pair(&Weighted::from_traj(a.view()), &Weighted::from_traj(b.view()), &m).into_traj();
        assert_eq!(merged.t.len(), 15); // 10 + 10 - 5
        assert!(merged.t.windows(2).all(|w| w[0] <= w[1]));
        let k = merged.t.iter().position(|&t| (t - 0.6).abs() < 1e-9).unwrap();
        assert!((merged.y[k] - 0.1).abs() < 1e-12, "midpoint");
        assert!(merged.y[..5].iter().all(|&y| y == 0.0) && merged.y[10..].iter().all(|&y| y == 0.2));
        // eq. 2.11's time: min + |dt| / 2, here with a time offset
        let c = OwnedTraj { t: vec![1.0], x: vec![0.0], y: vec![0.0] };
        let d = OwnedTraj { t: vec![1.4], x: vec![2.0], y: vec![0.0] };
        let r = merge_pair(&Weighted::from_traj(c.view()), &Weighted::from_traj(d.view()), &[(0, 0)]);
        assert_eq!((r.t[0], r.x[0], r.w[0]), (1.2, 1.0, 2.0));
    }

    /// Issue 17: merging points near f64::MAX used to overflow to inf in the weighted mean.
    #[test]
    fn merged_points_stay_finite_near_the_largest_doubles() {
        let big = f64::MAX * 0.99;
        let a = Weighted { t: vec![0.0], x: vec![big], y: vec![-big], w: vec![1.0] };
        let b = Weighted { t: vec![0.0], x: vec![big], y: vec![-big], w: vec![3.0] };
        let m = merge_pair(&a, &b, &[(0, 0)]);
        assert!(m.x[0].is_finite() && m.y[0].is_finite(), "{:?}", m.x);
        assert!((m.x[0] - big).abs() <= big * 1e-15);
    }

    #[test]
    fn chain_weights_every_camera_equally() {
        let p = TimeWindowParams::new(1.0, 0.05, 1).unwrap();
        let (a, b, c) = (line(0.0, 5, 0.0), line(0.0, 5, 0.3), line(0.0, 5, 0.9));
        let (m, counts) = merge_chain(&[a.view(), b.view(), c.view()], &p, None).unwrap();
        assert_eq!(counts, vec![5, 5]);
        assert!(m.y.iter().all(|&y| (y - 0.4).abs() < 1e-12), "mean of 0, 0.3, 0.9 (the thesis's recursion would give 0.6)");
        // regions restrict each step
        let r = Region::from_wkt("POLYGON ((-1 -1, 2.5 -1, 2.5 2, -1 2, -1 -1))").unwrap();
        let (m2, counts2) = merge_chain(&[a.view(), b.view()], &p, Some(&[&r])).unwrap();
        assert_eq!(counts2, vec![3]); // x = 0, 1, 2 inside
        assert_eq!(m2.t.len(), 7);
        assert_eq!(merge_chain(&[], &p, None).unwrap().0.t.len(), 0);
        assert_eq!(merge_chain(&[a.view()], &p, None).unwrap().0, a);
        assert_eq!(merge_chain(&[a.view(), b.view()], &p, Some(&[])).unwrap_err(), MergeError::Regions { steps: 1, got: 0 });
    }

    /// Issue 19: the LCSS of every step is bounded, and so is the chain: the cells of all
    /// steps add up against lcss_cells.
    #[test]
    fn chains_are_bounded_by_the_cells_of_all_steps() {
        use crate::limits::{with_scope, Limits};
        let p = TimeWindowParams::new(1.0, f64::INFINITY, 1).unwrap();
        let (a, b) = (line(0.0, 40, 0.0), line(0.0, 40, 5.0));
        let l = std::sync::Arc::new(Limits::default());
        l.set("lcss_cells", 2500).unwrap();
        // step 1: 40 x 40 = 1600 cells (nothing matches 5 m away: 80 points merged); step 2: 80 x 40 more
        assert!(with_scope(&l, || merge_chain(&[a.view(), b.view()], &p, None)).is_ok());
        let e = with_scope(&l, || merge_chain(&[a.view(), b.view(), a.view()], &p, None)).unwrap_err();
        assert!(matches!(&e, MergeError::Lcss(LcssError::Work(x)) if x.needed == 1600 + 80 * 40), "{e}");
        l.set("lcss_cells", 10_000_000_000).unwrap();
        l.set("memory_bytes", 1000).unwrap();
        let e = with_scope(&l, || merge_two(a.view(), a.view(), &p, None)).unwrap_err();
        assert!(e.to_string().contains("memory_bytes"), "{e}");
    }

    /// Issue 27: trajectory_merge of two tracks over lcss_cells is refused before the LCSS
    /// runs, with the error that names the limit and how to raise it.
    #[test]
    fn merging_two_tracks_over_the_cell_limit_is_an_error() {
        use crate::limits::{with_scope, Limits};
        let p = TimeWindowParams::new(1.0, f64::INFINITY, 1).unwrap();
        let a = line(0.0, 40, 0.0);
        let l = std::sync::Arc::new(Limits::default());
        l.set("lcss_cells", 1599).unwrap();
        let e = with_scope(&l, || merge_two(a.view(), a.view(), &p, None)).unwrap_err();
        assert!(matches!(&e, MergeError::Lcss(LcssError::Work(x)) if x.needed == 1600 && x.limit == 1599), "{e}");
        assert!(e.to_string().contains("lcss_cells") && e.to_string().contains("trajdb_set_limit('lcss_cells', 1600)"), "{e}");
        l.set("lcss_cells", 1600).unwrap();
        assert_eq!(with_scope(&l, || merge_two(a.view(), a.view(), &p, None)).unwrap(), a);
    }

    #[test]
    fn no_matches_keeps_everything_sorted() {
        let p = TimeWindowParams::new(0.01, 0.01, 1).unwrap();
        let (a, b) = (line(0.0, 3, 0.0), line(0.05, 3, 50.0));
        let m = merge_chain(&[a.view(), b.view()], &p, None).unwrap().0;
        assert_eq!(m.t, vec![0.0, 0.05, 0.1, 0.15000000000000002, 0.2, 0.25]);
    }

    #[test]
    fn groups_refuse_same_camera_overlaps_and_accept_split_tracks() {
        let s = |id, camera, t0, t1| Span { id, camera, t0, t1 };
        // camera 1: track 10; camera 2: a split track 20 (t 0..5) + 21 (t 6..10), and 22 which
        // overlaps 20 in time (a pedestrian walking alongside)
        let tracks = [s(10, 1, 0.0, 10.0), s(20, 2, 0.0, 5.0), s(21, 2, 6.0, 10.0), s(22, 2, 1.0, 4.0)];
        let (g, acc) = consistent_groups(&tracks, &[(10, 20), (10, 21), (10, 22)]).unwrap();
        assert_eq!(g, vec![10, 10, 10, 22]);
        assert_eq!(acc, vec![true, true, false]);
        // transitive chains across three cameras
        let tracks = [s(1, 1, 0.0, 1.0), s(2, 2, 0.0, 1.0), s(3, 3, 0.0, 1.0), s(4, 3, 0.5, 2.0)];
        let (g, acc) = consistent_groups(&tracks, &[(1, 2), (2, 3), (1, 4), (2, 3)]).unwrap();
        assert_eq!(g, vec![1, 1, 1, 4]);
        assert_eq!(acc, vec![true, true, false, false]);
        assert_eq!(consistent_groups(&tracks, &[(1, 9)]).unwrap_err(), MergeError::UnknownTrack { link: 1, id: 9 });
        assert_eq!(consistent_groups(&[s(1, 1, 0.0, 1.0), s(1, 2, 0.0, 1.0)], &[]).unwrap_err(), MergeError::DuplicateTrack(1));
        assert!(consistent_groups(&[s(1, 1, 2.0, 1.0)], &[]).is_err());
    }

    /// The obviously right version of [`consistent_groups`] (the one before issue 19): every
    /// link compares all members of both groups, O(L · g²).
    fn consistent_groups_slow(tracks: &[Span], links: &[(i64, i64)]) -> Result<(Vec<i64>, Vec<bool>), MergeError> {
        let mut index: HashMap<i64, usize> = HashMap::new();
        for (k, s) in tracks.iter().enumerate() {
            if !(s.t0 <= s.t1) || !s.t0.is_finite() || !s.t1.is_finite() {
                return Err(MergeError::TimeRange { id: s.id });
            }
            if index.insert(s.id, k).is_some() {
                return Err(MergeError::DuplicateTrack(s.id));
            }
        }
        for (l, &(a, b)) in links.iter().enumerate() {
            for id in [a, b] {
                if !index.contains_key(&id) {
                    return Err(MergeError::UnknownTrack { link: l + 1, id });
                }
            }
        }
        let mut group: Vec<usize> = (0..tracks.len()).collect();
        let mut accepted = vec![false; links.len()];
        for (l, &(a, b)) in links.iter().enumerate() {
            let (ga, gb) = (group[index[&a]], group[index[&b]]);
            if ga == gb {
                continue;
            }
            let clash = (0..tracks.len()).filter(|&x| group[x] == ga).any(|x| {
                (0..tracks.len()).filter(|&y| group[y] == gb).any(|y| {
                    let (p, q) = (&tracks[x], &tracks[y]);
                    p.camera == q.camera && p.t0 <= q.t1 && q.t0 <= p.t1
                })
            });
            if !clash {
                group.iter_mut().filter(|g| **g == gb).for_each(|g| *g = ga);
                accepted[l] = true;
            }
        }
        let groups = (0..tracks.len()).map(|k| (0..tracks.len()).filter(|&y| group[y] == group[k]).map(|y| tracks[y].id).min().unwrap()).collect();
        Ok((groups, accepted))
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(500))]
        /// Issue 19: the small-to-large grouping equals the all-pairs one, for tracks of 1-3
        /// cameras on a coarse time grid (touching and equal ranges, -0 and 0), links in any
        /// order, repeated and sometimes naming an unknown track.
        #[test]
        fn groups_equal_the_all_pairs_version(
            raw in proptest::collection::vec((0i64..3, -3i32..12, 0i32..4), 0..24),
            links in proptest::collection::vec((0usize..26, 0usize..26), 0..40),
        ) {
            let tracks: Vec<Span> = raw.iter().enumerate().map(|(k, &(camera, t0, d))| {
                let t0 = if t0 == 0 && k % 2 == 1 { -0.0 } else { t0 as f64 * 0.5 };
                Span { id: 100 - 3 * k as i64, camera, t0, t1: t0 + d as f64 * 0.5 }
            }).collect();
            // ids of tracks, and 24/25 for tracks that do not exist
            let id = |k: usize| if k < tracks.len() { tracks[k].id } else { 1000 + k as i64 };
            let mut pairs: Vec<(i64, i64)> = links.iter().map(|&(a, b)| (id(a % (tracks.len() + 1)), id(b % (tracks.len() + 1)))).collect();
            if links.len() % 3 != 0 {
                // mostly valid links: unknown ones only in a third of the cases
                pairs.retain(|&(a, b)| a < 1000 && b < 1000);
            }
            proptest::prop_assert_eq!(consistent_groups(&tracks, &pairs), consistent_groups_slow(&tracks, &pairs));
        }
    }

    /// Issue 19: long chains are near-linear (120k links took 22 s with the all-pairs check),
    /// and a bad link is reported before any grouping work.
    #[test]
    fn long_chains_and_links_checked_first() {
        let n = 200_000usize;
        // one camera, consecutive disjoint pieces: one chain of n tracks
        let tracks: Vec<Span> = (0..n).map(|k| Span { id: k as i64, camera: 1, t0: k as f64, t1: k as f64 + 0.5 }).collect();
        let mut links: Vec<(i64, i64)> = (1..n).map(|k| (k as i64 - 1, k as i64)).collect();
        let (g, acc) = consistent_groups(&tracks, &links).unwrap();
        assert!(g.iter().all(|&x| x == 0) && acc.iter().all(|&a| a));
        // a second chain in the same camera overlapping the first everywhere: every cross link refused
        let two: Vec<Span> = tracks.iter().flat_map(|s| [*s, Span { id: s.id + n as i64, t0: s.t0 + 0.25, t1: s.t1 + 0.25, ..*s }]).collect();
        let mut l2 = links.clone();
        l2.extend((1..n).map(|k| (k as i64 - 1 + n as i64, k as i64 + n as i64)));
        l2.extend((0..n).map(|k| (k as i64, ((k * 7919) % n + n) as i64)));
        let (g2, acc2) = consistent_groups(&two, &l2).unwrap();
        assert_eq!(g2.iter().filter(|&&x| x == 0).count(), n);
        assert!(acc2[2 * (n - 1)..].iter().all(|&a| !a));
        links.push((5, -1));
        assert_eq!(consistent_groups(&tracks, &links).unwrap_err(), MergeError::UnknownTrack { link: n, id: -1 });
    }

    /// Position of a source at time `t` by linear interpolation, if `t` lies inside it and the
    /// two samples around it are at most `max_gap` apart.
    fn at(tr: &OwnedTraj, t: f64, max_gap: f64) -> Option<(f64, f64)> {
        let n = tr.t.len();
        if n == 0 || t < tr.t[0] || t > tr.t[n - 1] {
            return None;
        }
        let j = tr.t.partition_point(|&s| s <= t).saturating_sub(1);
        if j + 1 >= n || tr.t[j] == t {
            return Some((tr.x[j], tr.y[j]));
        }
        let (t0, t1) = (tr.t[j], tr.t[j + 1]);
        if t1 - t0 > max_gap {
            return None;
        }
        let u = (t - t0) / (t1 - t0);
        Some((tr.x[j] + u * (tr.x[j + 1] - tr.x[j]), tr.y[j] + u * (tr.y[j + 1] - tr.y[j])))
    }

    proptest::proptest! {
        /// Issue 14: a merged trajectory is never farther than eps from any of its sources at the
        /// same time. Sources: one walking road user seen by 2-4 cameras at 2 or 10 Hz with
        /// bounded noise, some cameras in two time-disjoint pieces (a break), merged in camera
        /// order then start time as the pipeline does.
        #[test]
        fn merged_points_stay_within_eps_of_their_sources(
            rate in proptest::sample::select(vec![2.0f64, 10.0]),
            cams in proptest::collection::vec((0.0f64..20.0, 5.0f64..40.0, proptest::option::of((0.2f64..0.8, 1.0f64..6.0)), 0.0f64..0.5), 2..5),
            seed in 0u64..1000,
        ) {
            let (eps, t_win, noise) = (0.5, 0.25, 0.1);
            let path = |t: f64| (1.4 * t, 3.0 * (t / 6.0).sin());
            let mut st = seed.wrapping_add(1);
            let mut rnd = || {
                st = st.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((st >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
            };
            let mut sources: Vec<OwnedTraj> = Vec::new();
            for &(t0, len, brk, phase) in &cams {
                let spans: Vec<(f64, f64)> = match brk {
                    Some((at, gap)) => vec![(t0, t0 + at * len), (t0 + at * len + gap, t0 + len + gap)],
                    None => vec![(t0, t0 + len)],
                };
                for (a, b) in spans {
                    let mut tr = OwnedTraj::default();
                    let mut t = a + phase / rate;
                    while t <= b {
                        let (x, y) = path(t);
                        tr.push(t, x + noise * rnd(), y + noise * rnd());
                        t += 1.0 / rate;
                    }
                    if tr.t.len() >= 2 {
                        sources.push(tr);
                    }
                }
            }
            let views: Vec<Traj<'_>> = sources.iter().map(|s| s.view()).collect();
            let p = TimeWindowParams::new(eps, t_win, 1).unwrap();
            let (merged, _) = merge_chain(&views, &p, None).unwrap();
            for k in 0..merged.t.len() {
                for s in &sources {
                    if let Some((x, y)) = at(s, merged.t[k], 1.5 / rate) {
                        let d = (merged.x[k] - x).hypot(merged.y[k] - y);
                        proptest::prop_assert!(d <= eps, "merged point {k} at t {} is {d} m from a source", merged.t[k]);
                    }
                }
            }
        }
    }
}
