//! Polygons: camera view polygons P^k and their overlaps (thesis section 2.3).
//!
//! | file | SQL | what |
//! |---|---|---|
//! | [`region`] | every polygon argument, `polygon_contains`, `traj_clip`, `traj_points_inside` | WKT/WKB parsing and validation, prepared point-in-polygon (slab index), clipping |
//! | [`hull`] | `view_polygon` | convex / concave hull with a density rule |
//! | [`polygon`] | `polygon_overlap`, `polygon_union`, `polygon_buffer`, `polygon_area`, `polygon_to_wkt` | boolean operations (geo / i_overlay), area, WKB/WKT output |

pub mod hull;
pub mod polygon;
pub mod region;
