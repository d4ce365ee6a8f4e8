//! Which mesh chunks a cut touched. A chunk is one leaf's 8³ cells; its triangles depend on the
//! voxel values from its origin −1 to origin +8, so a changed voxel dirties its own leaf and, when
//! it sits on a leaf's first or last layer, the neighbouring leaf on that side.
use std::collections::HashSet;
use std::hash::{BuildHasherDefault, Hasher};

use dentsim_vdb::VoxelChange;
use glam::IVec3;

use dentsim_vdb::LEAF_DIM;

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

    /// Records the chunks every change in `log` affects.
    pub fn record(&mut self, tissue: usize, log: &[VoxelChange]) {
        let mut last = None;
        for c in log {
            let v = IVec3::new(c.i, c.j, c.k);
            let leaf = v.div_euclid(IVec3::splat(LEAF_DIM)) * LEAF_DIM;
            let local = v - leaf;
            let edge = |l: i32| -> (i32, i32) { (if l == 0 { -1 } else { 0 }, if l == LEAF_DIM - 1 { 1 } else { 0 }) };
            let (ex, ey, ez) = (edge(local.x), edge(local.y), edge(local.z));
            // Runs of changes along a row share their leaf and layer flags: insert once per run.
            let key = (leaf, ex, ey, ez);
            if last == Some(key) {
                continue;
            }
            last = Some(key);
            for dx in [0, ex.0, ex.1] {
                for dy in [0, ey.0, ey.1] {
                    for dz in [0, ez.0, ez.1] {
                        self.set.insert((tissue, leaf + IVec3::new(dx, dy, dz) * LEAF_DIM));
                    }
                }
            }
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

/// A multiply-rotate hash for small integer keys: leaf origins are not adversarial input, and
/// SipHash would cost more than the cut itself.
#[derive(Default)]
pub struct LeafHasher(u64);

impl Hasher for LeafHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(u64::from(*b));
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_i32(&mut self, v: i32) {
        self.write_u64(v as u32 as u64);
    }
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
}
