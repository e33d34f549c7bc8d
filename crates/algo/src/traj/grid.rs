//! One axis of a uniform grid (space or time), for the space-time grids that find the pairs
//! near each other ([`crate::lcss::sparse`], [`crate::conflict::candidates`]).

/// Cells of `size` along one axis; a size that is not finite and > 0 is one cell (index 0).
#[derive(Clone, Copy, Debug)]
pub struct CellAxis(pub f64);

impl CellAxis {
    /// The index of the cell holding `v`. `as` saturates: values past ±2^63 cells share the end
    /// cells, which only adds candidates, never loses one (floor and division are monotone).
    pub fn cell(&self, v: f64) -> i64 {
        if self.0.is_finite() && self.0 > 0.0 {
            (v / self.0).floor() as i64
        } else {
            0
        }
    }
}
