//! Which mesh chunks a cut touched. A chunk is one leaf's 8³ cells; its triangles depend on the
//! voxel values from its origin −1 to origin +8, so a changed voxel dirties its own leaf and, when
//! it sits on a leaf's first or last layer, the neighbouring leaf on that side.
use dentsim_vdb::VoxelChange;
use glam::IVec3;

use dentsim_vdb::LEAF_DIM;

/// Dirty leaf origins per tissue (index into the model's tissues). Kept sorted and deduplicated
/// lazily; the buffer's capacity is reused, so recording allocates nothing once warmed up.
#[derive(Debug)]
pub struct DirtyLeaves {
    entries: Vec<(usize, IVec3)>,
}

impl Default for DirtyLeaves {
    /// Room for 64 k entries (1.5 MiB), compacted long before it would have to grow.
    fn default() -> Self {
        DirtyLeaves::with_capacity(1 << 16)
    }
}

impl DirtyLeaves {
    pub fn with_capacity(n: usize) -> Self {
        DirtyLeaves { entries: Vec::with_capacity(n) }
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
            if (ex, ey, ez) == ((0, 0), (0, 0), (0, 0)) {
                if last != Some(leaf) {
                    self.push(tissue, leaf);
                    last = Some(leaf);
                }
                continue;
            }
            for dx in [0, ex.0, ex.1] {
                for dy in [0, ey.0, ey.1] {
                    for dz in [0, ez.0, ez.1] {
                        self.push(tissue, leaf + IVec3::new(dx, dy, dz) * LEAF_DIM);
                    }
                }
            }
        }
        // Deduplicate before the buffer would have to grow.
        if self.entries.len() > self.entries.capacity() * 3 / 4 {
            self.compact();
        }
    }

    fn push(&mut self, tissue: usize, leaf: IVec3) {
        self.entries.push((tissue, leaf));
    }

    fn compact(&mut self) {
        self.entries.sort_unstable_by_key(|(t, l)| (*t, l.x, l.y, l.z));
        self.entries.dedup();
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The distinct dirty (tissue, leaf origin) pairs so far, in a stable order; clears the set.
    pub fn drain_into(&mut self, out: &mut Vec<(usize, IVec3)>) {
        self.compact();
        out.extend(self.entries.drain(..));
    }
}
