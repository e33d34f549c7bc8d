//! Polygons: camera view polygons P^k and their overlaps (thesis section 2.3).
//!
//! | file | SQL | what |
//! |---|---|---|
//! | [`region`] | every polygon argument, `polygon_contains`, `traj_clip`, `traj_points_inside` | WKT/WKB parsing (nesting capped), prepared point-in-polygon (slab index), clipping |
//! | [`valid`] | every polygon argument | the one gate: ring orientation normalised (shells counter-clockwise, holes clockwise), invalid polygons refused |
//! | [`error`] | every polygon argument | why a polygon is refused ([`error::RegionError`], its rings named by [`error::RingId`]): a leaf |
//! | [`slabs`] | | the slab index shared by point-in-polygon and validation: a leaf |
//! | [`hull`] | `view_polygon` | convex / concave hull with a density rule |
//! | [`polygon`] | `polygon_overlap`, `polygon_union`, `polygon_buffer`, `polygon_area`, `polygon_to_wkt` | boolean operations (geo / i_overlay), area, WKB/WKT output |
//!
//! Every polygon argument of every SQL function becomes a [`region::Region`], whose only
//! constructor runs [`valid::normalise`]; the operations of [`polygon`] take `Region`s. So every
//! function sees the same polygon: counter-clockwise shells, clockwise holes, and valid (an
//! invalid polygon is an error naming the rule it breaks, in every function alike; [`valid`]
//! explains why it is refused rather than repaired).

pub mod error;
pub mod hull;
pub mod polygon;
pub mod region;
pub mod slabs;
pub mod valid;
