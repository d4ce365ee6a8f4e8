//! Safe Rust API over Debian's OpenVDB 10: narrow-band level sets (signed distance in mm,
//! negative inside) with a uniform voxel size and the world origin at voxel (0, 0, 0).
//!
//! This is the only crate with C++ and `unsafe`; it knows nothing of teeth.

mod error;
mod file;
mod level_set;
mod mesh;
#[cfg(feature = "peer")]
mod peer;
mod reader_process;
mod sys;

pub use error::{Error, Result};
pub use file::{check_layout, read_bytes, read_file, read_file_with, read_unguarded, write_file, FileGrid, ReadLimits};
pub use level_set::{block_counts, ColumnRuns, CutStats, DensePatch, DenseVolume, IndexBox, LevelSet, Measure, MetaValue, Reader, VoxelChange};
pub use mesh::TriMesh;

/// Voxels per edge of an OpenVDB leaf node (the tree's `LeafNode<float, 3>`).
pub const LEAF_DIM: i32 = 8;
