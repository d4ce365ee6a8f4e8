//! The cxx contract with cpp/vdb. Keep it small: every edit recompiles the OpenVDB side.

#[cxx::bridge(namespace = "dentsim::vdb")]
pub(crate) mod ffi {
    /// Triangles (counter-clockwise seen from outside) with unit normals, flat arrays.
    struct MeshBuffers {
        points: Vec<f32>,
        normals: Vec<f32>,
        triangles: Vec<u32>,
    }

    /// What one local cut changed.
    struct CutStats {
        changed_voxels: u64,
        removed_volume: f64,
    }

    /// One voxel's value (old value in an undo log, or the value to write back).
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    struct VoxelChange {
        i: i32,
        j: i32,
        k: i32,
        value: f32,
    }

    unsafe extern "C++" {
        include!("vdb/level_set.h");

        type LevelSet;
        type Reader;
        type GridList;

        fn new_level_set(voxel_size: f64, half_width: f64) -> Result<UniquePtr<LevelSet>>;
        fn level_set_sphere(
            center: [f64; 3],
            radius: f64,
            voxel_size: f64,
            half_width: f64,
        ) -> Result<UniquePtr<LevelSet>>;
        fn level_set_from_mesh(
            points: &[f32],
            triangles: &[u32],
            voxel_size: f64,
            half_width: f64,
        ) -> Result<UniquePtr<LevelSet>>;
        #[allow(clippy::too_many_arguments)]
        fn level_set_from_dense(
            dims: [u32; 3],
            index_to_world: [f64; 16],
            values: &[f32],
            iso: f32,
            inside_above: bool,
            voxel_size: f64,
            half_width: f64,
        ) -> Result<UniquePtr<LevelSet>>;

        fn voxel_size(self: &LevelSet) -> f64;
        fn background(self: &LevelSet) -> f32;
        fn name(self: &LevelSet) -> String;
        fn set_name(self: Pin<&mut LevelSet>, name: &str);
        fn active_voxel_count(self: &LevelSet) -> u64;
        fn leaf_count(self: &LevelSet) -> u64;
        fn mem_bytes(self: &LevelSet) -> u64;
        fn index_bbox(self: &LevelSet) -> [i32; 6];
        fn deep_copy(self: &LevelSet) -> UniquePtr<LevelSet>;
        fn set_leaf(self: Pin<&mut LevelSet>, origin: [i32; 3], values: &[f32]) -> Result<()>;
        fn finish_build(self: Pin<&mut LevelSet>);
        fn voxelize_inside(self: Pin<&mut LevelSet>) -> Result<()>;
        fn prune(self: Pin<&mut LevelSet>);
        fn volume(self: &LevelSet) -> f64;
        fn subtract_dense(
            self: Pin<&mut LevelSet>,
            index_min: [i32; 3],
            dims: [u32; 3],
            tool: &[f32],
            spans: &[u32],
        ) -> Result<CutStats>;
        fn csg_difference(self: Pin<&mut LevelSet>, other: &LevelSet) -> Result<()>;
        fn csg_union(self: Pin<&mut LevelSet>, other: &LevelSet) -> Result<()>;
        fn csg_intersection(self: Pin<&mut LevelSet>, other: &LevelSet) -> Result<()>;
        fn offset(self: Pin<&mut LevelSet>, distance: f64) -> Result<()>;
        fn narrow_band(self: Pin<&mut LevelSet>, half_width_voxels: f64) -> Result<()>;
        fn to_mesh(self: &LevelSet) -> MeshBuffers;

        fn set_meta_string(self: Pin<&mut LevelSet>, key: &str, value: &str);
        fn set_meta_f64(self: Pin<&mut LevelSet>, key: &str, value: f64);
        fn set_meta_i64(self: Pin<&mut LevelSet>, key: &str, value: i64);
        fn set_meta_vec3(self: Pin<&mut LevelSet>, key: &str, value: [f32; 3]);
        fn meta_keys(self: &LevelSet) -> Vec<String>;
        fn meta_type(self: &LevelSet, key: &str) -> Result<String>;
        fn meta_string(self: &LevelSet, key: &str) -> Result<String>;
        fn meta_f64(self: &LevelSet, key: &str) -> Result<f64>;
        fn meta_vec3(self: &LevelSet, key: &str) -> Result<[f32; 3]>;

        fn new_reader(grid: &LevelSet) -> UniquePtr<Reader>;
        fn value(self: Pin<&mut Reader>, x: f64, y: f64, z: f64) -> f32;
        fn value_gradient(self: Pin<&mut Reader>, x: f64, y: f64, z: f64) -> [f32; 4];
        fn values(self: Pin<&mut Reader>, xyz: &[f32], out: &mut [f32]);

        fn subtract_logged(
            self: Pin<&mut LevelSet>,
            index_min: [i32; 3],
            dims: [u32; 3],
            tool: &[f32],
            spans: &[u32],
            runs: &[u32],
            run_values: &[f32],
            offset: f32,
            measured: bool,
        ) -> Result<CutStats>;
        fn last_changes(self: &LevelSet) -> &[VoxelChange];
        fn last_new_values(self: &LevelSet, out: &mut [VoxelChange]);
        fn reserve_cut(self: Pin<&mut LevelSet>, dims: [u32; 3]);
        fn mark_material_blocks(self: &LevelSet, index_min: [i32; 3], dims: [u32; 3], out: &mut [u8]) -> Result<()>;
        fn removal_by_offset(
            self: &LevelSet,
            index_min: [i32; 3],
            dims: [u32; 3],
            tool: &[f32],
            offsets: &[f32],
            removed: &mut [f64],
        ) -> Result<()>;
        fn write_voxels(self: Pin<&mut LevelSet>, changes: &[VoxelChange]);
        fn read_voxels(self: &LevelSet, changes: &mut [VoxelChange]);
        fn read_dense(self: &LevelSet, index_min: [i32; 3], dims: [u32; 3], out: &mut [f32]) -> Result<()>;
        fn leaf_origins(self: &LevelSet) -> Vec<i32>;

        fn new_grid_list() -> UniquePtr<GridList>;
        fn read_bytes(bytes: &[u8]) -> Result<UniquePtr<GridList>>;
        fn push(self: Pin<&mut GridList>, grid: &LevelSet);
        fn len(self: &GridList) -> usize;
        fn grid_name(self: &GridList, i: usize) -> Result<String>;
        fn grid_type(self: &GridList, i: usize) -> Result<String>;
        fn grid_class(self: &GridList, i: usize) -> Result<String>;
        fn take(self: Pin<&mut GridList>, i: usize) -> Result<UniquePtr<LevelSet>>;
        fn write_file(self: &GridList, path: &str) -> Result<()>;

        fn sample_values(self: &LevelSet, xyz: &[f32], out: &mut [f32]);
        fn sample_value_gradients(self: &LevelSet, xyz: &[f32], out: &mut [f32]);
        fn content_hash(self: &LevelSet) -> u64;
    }
}

// SAFETY: a LevelSet owns its grid; OpenVDB trees allow concurrent reads through separate
// accessors, and every mutation goes through `Pin<&mut LevelSet>`, i.e. a unique borrow.
unsafe impl Send for ffi::LevelSet {}
unsafe impl Sync for ffi::LevelSet {}
// SAFETY: a Reader is used by one thread at a time; moving it between threads is fine.
unsafe impl Send for ffi::Reader {}
// SAFETY: a GridList only holds shared pointers to grids.
unsafe impl Send for ffi::GridList {}
