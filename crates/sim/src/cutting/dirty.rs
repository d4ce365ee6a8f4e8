//! Which mesh chunks a cut touched. A chunk is one leaf's 8³ cells; its triangles depend on the
//! voxel values from its origin −1 to origin +8, so a changed voxel dirties its own leaf and, when
//! it sits on a leaf's first or last layer, the neighbouring leaf on that side.
use std::collections::HashSet;
use std::hash::BuildHasherDefault;

use dentsim_vdb::VoxelChange;
use glam::IVec3;

use dentsim_vdb::LEAF_DIM;

use crate::tissues::surface::LeafHasher;

/// Dirty leaf origins per tissue (index into the model's tissues), as a set whose capacity is
/// reserved up front: recording allocates nothing until 64 k distinct chunks are dirty at once
/// (a mesher drains far more often than that).
#[derive(Debug)]
pub struct DirtyLeaves {
    set: HashSet<(usize, IVec3), BuildHasherDefault<LeafHasher>>,
}

impl Default for DirtyLeaves {
    fn default() -> Self {
        DirtyLeaves::with_capacity(1 << 16)
    }
}

impl DirtyLeaves {
    pub fn with_capacity(n: usize) -> Self {
        DirtyLeaves { set: HashSet::with_capacity_and_hasher(n, Default::default()) }
    }

    /// Records the chunks every change in `log` affects. A stroke's changes touch a few dozen
    /// leaves, revisited row after row: each leaf's neighbour mask is gathered in a small local
    /// table and inserted once (a set insert per changed voxel cost a fifth of a haptic cut).
    pub fn record(&mut self, tissue: usize, log: &[VoxelChange]) {
        const SLOTS: usize = 128;
        let mut table = [(IVec3::ZERO, 0u32); SLOTS]; // mask 0: empty slot
        let mut used = 0;
        let mut last: Option<usize> = None;
        for c in log {
            let v = IVec3::new(c.i, c.j, c.k);
            let leaf = v & IVec3::splat(!(LEAF_DIM - 1));
            let mask = neighbour_mask(v - leaf);
            if let Some(s) = last.filter(|s| table[*s].0 == leaf) {
                table[s].1 |= mask;
                continue;
            }
            if used == SLOTS / 2 {
                self.flush(tissue, &mut table);
                used = 0;
            }
            let h = (leaf.x as u32).wrapping_mul(0x9e37_79b1) ^ (leaf.y as u32).wrapping_mul(0x85eb_ca77) ^ (leaf.z as u32).wrapping_mul(0xc2b2_ae3d);
            let mut s = (h >> 7) as usize % SLOTS;
            while table[s].1 != 0 && table[s].0 != leaf {
                s = (s + 1) % SLOTS;
            }
            if table[s].1 == 0 {
                table[s].0 = leaf;
                used += 1;
            }
            table[s].1 |= mask;
            last = Some(s);
        }
        self.flush(tissue, &mut table);
    }

    fn flush(&mut self, tissue: usize, table: &mut [(IVec3, u32)]) {
        for slot in table.iter_mut().filter(|s| s.1 != 0) {
            self.insert_neighbours(tissue, slot.0, slot.1);
            *slot = (IVec3::ZERO, 0);
        }
    }

    /// Inserts the leaves of `leaf`'s 3×3×3 neighbourhood whose bit is set in `mask`.
    fn insert_neighbours(&mut self, tissue: usize, leaf: IVec3, mut mask: u32) {
        while mask != 0 {
            let bit = mask.trailing_zeros() as i32;
            mask &= mask - 1;
            let offset = IVec3::new(bit % 3, bit / 3 % 3, bit / 9) - IVec3::ONE;
            self.set.insert((tissue, leaf + offset * LEAF_DIM));
        }
    }

    pub fn is_empty(&self) -> bool {
        self.set.is_empty()
    }

    pub fn len(&self) -> usize {
        self.set.len()
    }

    /// Appends the distinct dirty (tissue, leaf origin) pairs, sorted, to `out`; clears the set
    /// (keeping its capacity).
    pub fn drain_into(&mut self, out: &mut Vec<(usize, IVec3)>) {
        let start = out.len();
        out.extend(self.set.drain());
        out[start..].sort_unstable_by_key(|(t, l)| (*t, l.x, l.y, l.z));
    }
}

/// Which leaves of the 3×3×3 neighbourhood (bit `9·(dz+1) + 3·(dy+1) + (dx+1)`) a change at
/// `local` (within its leaf) dirties: its own, and across each face it lies on. A lookup by which
/// face (first, inner or last layer) it lies on along each axis: this runs per changed voxel.
#[inline]
fn neighbour_mask(local: IVec3) -> u32 {
    let layer = |l: i32| usize::from(l == 0) | usize::from(l == LEAF_DIM - 1) << 1;
    NEIGHBOUR_MASKS[layer(local.x) | layer(local.y) << 2 | layer(local.z) << 4]
}

/// The leaves along one axis a voxel in `layer` dirties (bit 0: the one before, 1: its own, 2:
/// the one after).
const fn sides(layer: usize) -> u32 {
    0b010 | (layer & 1) as u32 | (((layer >> 1) & 1) as u32) << 2
}

/// [`neighbour_mask`] by layer along x, y and z (2 bits each: 1 first, 2 last, 0 inner).
const NEIGHBOUR_MASKS: [u32; 64] = {
    let mut table = [0u32; 64];
    let mut i = 0;
    while i < 64 {
        let (x, y, z) = (sides(i & 3), sides(i >> 2 & 3), sides(i >> 4 & 3));
        let mut mask = 0;
        let mut dz = 0;
        while dz < 3 {
            let mut dy = 0;
            while dy < 3 {
                if (z >> dz) & (y >> dy) & 1 == 1 {
                    mask |= x << (9 * dz + 3 * dy);
                }
                dy += 1;
            }
            dz += 1;
        }
        table[i] = mask;
        i += 1;
    }
    table
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Per voxel, the leaves whose chunk reads it: its own and across each leaf face it lies on.
    fn naive(log: &[VoxelChange]) -> Vec<(usize, IVec3)> {
        let mut out = Vec::new();
        for c in log {
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        // A chunk at origin o reads voxels o-1 ..= o+8.
                        let leaf = (IVec3::new(c.i, c.j, c.k).div_euclid(IVec3::splat(LEAF_DIM)) + IVec3::new(dx, dy, dz)) * LEAF_DIM;
                        let v = IVec3::new(c.i, c.j, c.k);
                        if v.cmpge(leaf - 1).all() && v.cmple(leaf + LEAF_DIM).all() {
                            out.push((0, leaf));
                        }
                    }
                }
            }
        }
        out.sort_unstable_by_key(|(t, l)| (*t, l.x, l.y, l.z));
        out.dedup();
        out
    }

    /// The table gives, for every voxel of a leaf, the mask of its own leaf and those across
    /// each face it lies on (the leaves whose chunks read it).
    #[test]
    fn the_neighbour_masks_name_the_leaves_reading_each_voxel() {
        for (x, y, z) in (0..LEAF_DIM).flat_map(|x| (0..LEAF_DIM).flat_map(move |y| (0..LEAF_DIM).map(move |z| (x, y, z)))) {
            let mut want = 0u32;
            for (bit, (dx, dy, dz)) in (-1..=1).flat_map(|dz| (-1..=1).flat_map(move |dy| (-1..=1).map(move |dx| (dx, dy, dz)))).enumerate() {
                // The leaf at offset d reads voxels from its origin −1 to its origin +8.
                let reads = |l: i32, d: i32| l >= d * LEAF_DIM - 1 && l <= d * LEAF_DIM + LEAF_DIM;
                if reads(x, dx) && reads(y, dy) && reads(z, dz) {
                    want |= 1 << bit;
                }
            }
            assert_eq!(neighbour_mask(IVec3::new(x, y, z)), want, "voxel ({x}, {y}, {z})");
        }
    }

    #[test]
    fn leaf_runs_dirty_exactly_the_chunks_reading_their_voxels() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: i32| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % n as u64) as i32 - n / 2
        };
        // Runs along rows (as cuts log them) and scattered voxels, across negative coordinates.
        let mut log = Vec::new();
        for _ in 0..200 {
            let (i, j, k) = (next(40), next(40), next(40));
            for d in 0..(next(12) + 6) {
                log.push(VoxelChange { i: i + d, j, k, value: 0.0 });
            }
        }
        let mut dirty = DirtyLeaves::with_capacity(1024);
        dirty.record(0, &log);
        let mut got = Vec::new();
        dirty.drain_into(&mut got);
        assert_eq!(got, naive(&log));
    }
}
