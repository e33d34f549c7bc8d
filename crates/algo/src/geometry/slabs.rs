//! The slab index ([`Slabs`]): items with y-ranges bucketed into horizontal slabs, shared by the
//! point-in-polygon index of [`super::region`] and the edge sweep of [`super::valid`]. A leaf.
//!
//! Building is O(n + entries) with at most about 4n entries (see [`Slabs`]); a lookup is O(1)
//! plus the items of one slab. Every allocation is fallible ([`RegionError::TooLarge`]).

use super::error::RegionError;

/// Items with y-ranges bucketed into horizontal slabs of `[y0, y0 + height]`: `items[start[s]..
/// start[s + 1]]` are the items whose range meets slab `s`. The slab count adapts so that the
/// entries stay O(n) however tall the items are (at most `2n + n · nslab · (mean height /
/// height)`, about 4n): with one slab per item a comb of 40,000 full-height edges needed
/// 88 GB and aborted the host.
pub(super) struct Slabs {
    pub(super) y0: f64,
    pub(super) inv_h: f64,
    pub(super) start: Vec<u32>,
    pub(super) items: Vec<u32>,
}

impl Slabs {
    /// Errors only when the index cannot be allocated.
    pub(super) fn new(ranges: &[(f64, f64)], y0: f64, height: f64) -> Result<Self, RegionError> {
        let n = ranges.len();
        let too_large = || RegionError::TooLarge { edges: n };
        if n >= (u32::MAX / 8) as usize {
            return Err(too_large());
        }
        let cap = n.clamp(1, 1 << 16);
        let (nslab, inv_h) = if height > 0.0 {
            let span: f64 = ranges.iter().map(|&(lo, hi)| (hi - lo) / height).sum();
            let nslab = if span > 0.0 { ((2.0 * n as f64 / span) as usize).clamp(1, cap) } else { cap };
            (nslab, nslab as f64 / height)
        } else {
            (1, 0.0)
        };
        let mut slabs = Slabs { y0, inv_h, start: Vec::new(), items: Vec::new() };
        slabs.start.try_reserve_exact(nslab + 1).map_err(|_| too_large())?;
        slabs.start.resize(nslab + 1, 0);
        for &(lo, hi) in ranges {
            for s in slabs.slab(lo)..=slabs.slab(hi) {
                slabs.start[s + 1] += 1;
            }
        }
        for s in 0..nslab {
            slabs.start[s + 1] += slabs.start[s];
        }
        let total = slabs.start[nslab] as usize;
        slabs.items.try_reserve_exact(total).map_err(|_| too_large())?;
        slabs.items.resize(total, 0);
        let mut fill: Vec<u32> = Vec::new();
        fill.try_reserve_exact(nslab).map_err(|_| too_large())?;
        fill.extend_from_slice(&slabs.start[..nslab]);
        for (k, &(lo, hi)) in ranges.iter().enumerate() {
            let (first, last) = (slabs.slab(lo), slabs.slab(hi));
            for f in &mut fill[first..=last] {
                slabs.items[*f as usize] = k as u32;
                *f += 1;
            }
        }
        Ok(slabs)
    }

    /// How many slabs.
    pub(super) fn len(&self) -> usize {
        self.start.len() - 1
    }

    /// The items of slab `s`.
    pub(super) fn items(&self, s: usize) -> &[u32] {
        &self.items[self.start[s] as usize..self.start[s + 1] as usize]
    }

    /// The items of slab `s`, to reorder.
    pub(super) fn items_mut(&mut self, s: usize) -> &mut [u32] {
        &mut self.items[self.start[s] as usize..self.start[s + 1] as usize]
    }

    /// The slab of `y` (clamped to the first and last).
    #[inline]
    pub(super) fn slab(&self, y: f64) -> usize {
        (((y - self.y0) * self.inv_h) as usize).min(self.start.len() - 2)
    }

    /// The items whose range may contain `y`.
    pub(super) fn get(&self, y: f64) -> &[u32] {
        self.items(self.slab(y))
    }
}

