//! Benchmark peers (cargo feature `peer`, which only `dentsim-bench` enables): what plain OpenVDB
//! code does for the same jobs, so `dentsim bench` can time ours beside them. Nothing else calls
//! them; they are not part of the default build.
use glam::DVec3;

use crate::error::{openvdb, Result};
use crate::{LevelSet, TriMesh};

#[cxx::bridge(namespace = "dentsim::vdb")]
mod ffi {
    unsafe extern "C++" {
        include!("vdb/level_set.h");
        type LevelSet = crate::sys::ffi::LevelSet;

        fn peer_sample_sum(self: &LevelSet, xyz: &[f32]) -> f64;
        fn peer_sphere_cut(self: Pin<&mut LevelSet>, center: [f64; 3], radius: f64) -> Result<()>;
        fn peer_mesh_cut(self: Pin<&mut LevelSet>, points: &[f32], triangles: &[u32]) -> Result<()>;
        fn peer_full_mesh(self: &LevelSet) -> u64;
    }
}

impl LevelSet {
    /// Benchmark peer: one C++ loop of OpenVDB's `BoxSampler` over world points (x, y, z, …).
    pub fn peer_sample_sum(&self, xyz: &[f32]) -> f64 {
        self.inner.peer_sample_sum(xyz)
    }

    /// Benchmark peer: `createLevelSetSphere` + `csgDifference`, the usual per-stroke cut.
    pub fn peer_sphere_cut(&mut self, center: DVec3, radius: f64) -> Result<()> {
        self.edit()
            .peer_sphere_cut(center.to_array(), radius)
            .map_err(openvdb("peer sphere cut"))
    }

    /// Benchmark peer for any tool shape: `meshToLevelSet` of the tool's closed mesh (world mm,
    /// already at the stroke's pose) in this grid's frame and band, then `csgDifference`.
    pub fn peer_mesh_cut(&mut self, tool: &TriMesh) -> Result<()> {
        self.edit()
            .peer_mesh_cut(&tool.flat_points(), &tool.flat_triangles())
            .map_err(openvdb("peer mesh cut"))
    }

    /// Benchmark peer: a full `volumeToMesh`; returns the triangle count.
    pub fn peer_full_mesh(&self) -> u64 {
        self.inner.peer_full_mesh()
    }
}
