use std::marker::PhantomData;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};

use cxx::UniquePtr;
use glam::{DVec3, IVec3, Vec3};

use crate::error::{openvdb, Error, Result};
use crate::mesh::TriMesh;
use crate::sys::ffi;
pub use crate::sys::ffi::VoxelChange;
use crate::LEAF_DIM;

/// A narrow-band level set: `FloatGrid` of class level set, background = half width in mm.
pub struct LevelSet {
    pub(crate) inner: UniquePtr<ffi::LevelSet>,
    /// See [`LevelSet::stamp`].
    stamp: u64,
}

static NEXT_STAMP: AtomicU64 = AtomicU64::new(1);

fn fresh_stamp() -> u64 {
    NEXT_STAMP.fetch_add(1, Ordering::Relaxed)
}

/// How many leaf-aligned 8³ blocks an index box overlaps along each axis, and the first block's
/// origin (see [`LevelSet::mark_material_blocks`]).
pub fn block_counts(index_min: IVec3, dims: [u32; 3]) -> (IVec3, [usize; 3]) {
    let first = index_min & IVec3::splat(!(LEAF_DIM - 1));
    let last = index_min + IVec3::from_array(dims.map(|d| d as i32)) - IVec3::ONE;
    let count = ((last - first) / LEAF_DIM + IVec3::ONE).max(IVec3::ONE);
    (first, count.to_array().map(|c| c as usize))
}

/// An inclusive box of voxel indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IndexBox {
    pub min: IVec3,
    pub max: IVec3,
}

/// Tool signed distances (mm) at the centres of a box of voxels, x fastest.
#[derive(Clone, Debug, Default)]
pub struct DensePatch {
    pub index_min: IVec3,
    pub dims: [u32; 3],
    pub values: Vec<f32>,
    /// Per row (`j + ny·k`), the x range `[start, end)` outside which every value is at least the
    /// cut grid's background plus 1.5 voxels (a cut neither changes nor reads those voxels),
    /// flattened; empty for whole rows.
    pub spans: Vec<u32>,
}

/// A [`DensePatch`]'s runs along z: outside them every value of the patch is at least the
/// cut-off (as outside its spans), and each run's values are also kept z fastest, so that a
/// subtract along the runs reads them contiguously ([`LevelSet::subtract_logged_runs`]).
#[derive(Clone, Debug, Default)]
pub struct ColumnRuns {
    /// Per run: its column (`i + nx·j`), first `k`, end `k` (exclusive), and where its first
    /// value sits in `values`; flattened.
    pub runs: Vec<u32>,
    /// The runs' values, each run's z fastest: the patch's values bit for bit.
    pub values: Vec<f32>,
}

impl ColumnRuns {
    pub fn is_empty(&self) -> bool {
        self.runs.is_empty()
    }

    pub fn clear(&mut self) {
        self.runs.clear();
        self.values.clear();
    }
}

/// A scalar volume on a regular grid: value `n = i + nx * (j + ny * k)` sits at
/// `index_to_world * (i, j, k, 1)` (row-major 4×4, mm).
#[derive(Clone, Debug)]
pub struct DenseVolume<'a> {
    pub dims: [u32; 3],
    pub index_to_world: [f64; 16],
    pub values: &'a [f32],
}

/// Whether a cut measures the volume it removes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Measure {
    #[default]
    Volume,
    Skip,
}

/// What a local cut changed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CutStats {
    pub changed_voxels: u64,
    /// Enclosed volume removed (mm³), measured as [`LevelSet::volume`] measures; 0 when the cut
    /// was not measured.
    pub removed_mm3: f64,
}

/// A grid metadata value as stored in the .vdb file.
#[derive(Clone, Debug, PartialEq)]
pub enum MetaValue {
    String(String),
    F64(f64),
    I64(i64),
    Vec3(Vec3),
}

impl MetaValue {
    /// The type's name as OpenVDB's metadata calls it (for messages).
    pub fn kind(&self) -> &'static str {
        match self {
            MetaValue::String(_) => "a string",
            MetaValue::F64(_) => "a number",
            MetaValue::I64(_) => "an integer",
            MetaValue::Vec3(_) => "a vec3",
        }
    }
}

impl LevelSet {
    /// An empty level set (everything outside).
    pub fn new(voxel_size: f64, half_width: f64) -> Result<Self> {
        Self::wrap(ffi::new_level_set(voxel_size, half_width), "create level set")
    }

    /// OpenVDB's own sphere builder (`createLevelSetSphere`).
    pub fn sphere(center: DVec3, radius: f64, voxel_size: f64, half_width: f64) -> Result<Self> {
        Self::wrap(
            ffi::level_set_sphere(center.to_array(), radius, voxel_size, half_width),
            "build sphere",
        )
    }

    /// Samples a signed distance function (mm, negative inside, |∇| ≤ 1) in the narrow band
    /// around its zero set inside `min..max`. Leaves whose centre lies farther from the surface
    /// than their half-diagonal plus the band are skipped, so the cost follows the surface area.
    pub fn from_sdf(
        voxel_size: f64,
        half_width: f64,
        min: DVec3,
        max: DVec3,
        sdf: impl Fn(DVec3) -> f64,
    ) -> Result<Self> {
        let mut out = Self::new(voxel_size, half_width)?;
        if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
            return Err(Error::Invalid {
                op: "build from SDF",
                message: format!("bounds {min} .. {max} are not a box"),
            });
        }
        let band = f64::from(out.background());
        let h = voxel_size;
        let reach = (half_width.ceil() as i32) + 1;
        let lo = (min / h).floor().as_ivec3() - IVec3::splat(reach);
        let hi = (max / h).ceil().as_ivec3() + IVec3::splat(reach);
        let leaf_lo = lo.div_euclid(IVec3::splat(LEAF_DIM)) * LEAF_DIM;
        let half_diagonal = f64::from(LEAF_DIM) * h * 3f64.sqrt() / 2.0;
        let mut values = vec![0f32; (LEAF_DIM * LEAF_DIM * LEAF_DIM) as usize];
        let mut origin = leaf_lo;
        while origin.x <= hi.x {
            origin.y = leaf_lo.y;
            while origin.y <= hi.y {
                origin.z = leaf_lo.z;
                while origin.z <= hi.z {
                    let centre = (origin.as_dvec3() + f64::from(LEAF_DIM - 1) / 2.0) * h;
                    if sdf(centre).abs() <= half_diagonal + band
                        && sample_leaf(origin, h, band, &sdf, &mut values)
                    {
                        out.inner
                            .pin_mut()
                            .set_leaf(origin.to_array(), &values)
                            .map_err(openvdb("build from SDF"))?;
                    }
                    origin.z += LEAF_DIM;
                }
                origin.y += LEAF_DIM;
            }
            origin.x += LEAF_DIM;
        }
        out.inner.pin_mut().finish_build();
        Ok(out)
    }

    /// A level set from leaves of signed distances computed elsewhere (each leaf's origin in
    /// voxels, a multiple of [`LEAF_DIM`], and its 512 values, z fastest, mm, negative inside).
    /// The leaves must hold the whole narrow band: the inside beyond it is signed by flood fill.
    pub fn from_leaves(voxel_size: f64, half_width: f64, leaves: &[(IVec3, Vec<f32>)]) -> Result<Self> {
        let mut out = Self::new(voxel_size, half_width)?;
        for (origin, values) in leaves {
            out.inner
                .pin_mut()
                .set_leaf(origin.to_array(), values)
                .map_err(openvdb("build from leaves"))?;
        }
        out.inner.pin_mut().finish_build();
        Ok(out)
    }

    /// OpenVDB's `meshToLevelSet` of a closed triangle mesh (world mm).
    pub fn from_mesh(mesh: &TriMesh, voxel_size: f64, half_width: f64) -> Result<Self> {
        Self::wrap(
            ffi::level_set_from_mesh(
                &mesh.flat_points(),
                &mesh.flat_triangles(),
                voxel_size,
                half_width,
            ),
            "mesh to level set",
        )
    }

    /// The iso-surface of a dense volume as a level set at `voxel_size` (which may be finer than
    /// the volume's spacing): the volume is meshed at `iso` and the mesh converted back, so no
    /// staircase of the source grid remains. `inside_above`: material is where value > iso.
    pub fn from_dense(
        volume: &DenseVolume<'_>,
        iso: f32,
        inside_above: bool,
        voxel_size: f64,
        half_width: f64,
    ) -> Result<Self> {
        Self::wrap(
            ffi::level_set_from_dense(
                volume.dims,
                volume.index_to_world,
                volume.values,
                iso,
                inside_above,
                voxel_size,
                half_width,
            ),
            "dense volume to level set",
        )
    }

    fn wrap(made: Result<UniquePtr<ffi::LevelSet>, cxx::Exception>, op: &'static str) -> Result<Self> {
        let inner = made.map_err(openvdb(op))?;
        Ok(LevelSet { inner, stamp: fresh_stamp() })
    }

    pub(crate) fn from_inner(inner: UniquePtr<ffi::LevelSet>) -> Self {
        LevelSet { inner, stamp: fresh_stamp() }
    }

    pub(crate) fn inner(&self) -> &ffi::LevelSet {
        &self.inner
    }

    pub fn voxel_size(&self) -> f64 {
        self.inner.voxel_size()
    }

    /// Narrow-band half width in mm (the grid's background value).
    pub fn background(&self) -> f32 {
        self.inner.background()
    }

    pub fn name(&self) -> String {
        self.inner.name()
    }

    pub fn set_name(&mut self, name: &str) {
        self.inner.pin_mut().set_name(name);
    }

    pub fn active_voxel_count(&self) -> u64 {
        self.inner.active_voxel_count()
    }

    pub fn leaf_count(&self) -> u64 {
        self.inner.leaf_count()
    }

    /// Bytes held by the tree, as OpenVDB's `memUsage` counts them.
    pub fn mem_bytes(&self) -> u64 {
        self.inner.mem_bytes()
    }

    /// Bounding box of the active voxels, or `None` for an empty grid.
    pub fn index_bbox(&self) -> Option<IndexBox> {
        let b = self.inner.index_bbox();
        let (min, max) = (IVec3::new(b[0], b[1], b[2]), IVec3::new(b[3], b[4], b[5]));
        min.cmple(max).all().then_some(IndexBox { min, max })
    }

    /// Voxel index whose centre is nearest to a world point.
    pub fn world_to_index(&self, p: DVec3) -> IVec3 {
        (p / self.voxel_size()).round().as_ivec3()
    }

    pub fn index_to_world(&self, ijk: IVec3) -> DVec3 {
        ijk.as_dvec3() * self.voxel_size()
    }

    /// Enclosed volume in mm³: smoothed Heaviside over ±1.5 voxels summed over the tree, minus its
    /// curvature bias (ε²(1/6 − 1/π²)·δ_ε(φ)·Δφ per voxel), which alone overcounts a 0.6 mm ball
    /// by ~2.5 % at 0.05 mm voxels; with it the error is second order in h/R.
    pub fn volume(&self) -> f64 {
        self.inner.volume()
    }

    /// Turns the inside tiles into leaves (inactive, at −background) so that later cuts write
    /// into existing leaves and never allocate (the haptic thread must not); the grid's values
    /// do not change. Costs a leaf (≈2 KiB) per 8³ voxels of the interior.
    pub fn voxelize_inside(&mut self) -> Result<()> {
        self.edit().voxelize_inside().map_err(openvdb("voxelize inside tiles"))
    }

    /// OpenVDB's `pruneLevelSet`: uniform inactive leaves collapse back into tiles.
    pub fn prune(&mut self) {
        self.edit().prune();
    }

    /// A number that changes whenever the grid's values may have changed, and that no other grid
    /// (clones included) ever shares: whoever saw a stamp after editing the grid knows, seeing
    /// it again, that nothing touched the grid since.
    pub fn stamp(&self) -> u64 {
        self.stamp
    }

    /// The C++ grid for a call that may change its values.
    pub(crate) fn edit(&mut self) -> Pin<&mut ffi::LevelSet> {
        self.stamp = fresh_stamp();
        self.inner.pin_mut()
    }

    /// A reader for one thread; the grid cannot change while it lives.
    pub fn reader(&self) -> Reader<'_> {
        Reader { inner: ffi::new_reader(&self.inner), _grid: PhantomData }
    }

    /// Local CSG difference: every voxel of the patch takes `max(value, -tool)`.
    pub fn subtract(&mut self, patch: &DensePatch) -> Result<CutStats> {
        let s = self
            .edit()
            .subtract_dense(patch.index_min.to_array(), patch.dims, &patch.values, &patch.spans)
            .map_err(openvdb("subtract tool patch"))?;
        Ok(CutStats { changed_voxels: s.changed_voxels, removed_mm3: s.removed_volume })
    }

    /// [`subtract`](Self::subtract) with the tool grown by `-offset` (a positive offset shrinks it,
    /// for partial-depth cuts), appending each changed voxel's old value to `log` (its capacity is
    /// reused: no allocation once it is large enough). [`Measure::Skip`] leaves the removed volume
    /// at 0: its curvature term costs as much again as the cut.
    pub fn subtract_logged(&mut self, patch: &DensePatch, offset: f32, measure: Measure, log: &mut Vec<VoxelChange>) -> Result<CutStats> {
        self.subtract_logged_runs(patch, &ColumnRuns::default(), offset, measure, log)
    }

    /// [`subtract_logged`](Self::subtract_logged) along a patch's [`ColumnRuns`] instead of its
    /// row spans: the same voxels to the same values, read along z (the leaves' fastest axis) from
    /// the runs' own copy of the values, so neither side is read with a stride; logged in the
    /// runs' order. Empty runs: the spans (with runs, the spans are not read, nor checked).
    pub fn subtract_logged_runs(&mut self, patch: &DensePatch, runs: &ColumnRuns, offset: f32, measure: Measure, log: &mut Vec<VoxelChange>) -> Result<CutStats> {
        let measured = measure == Measure::Volume;
        let s = self
            .edit()
            .subtract_logged(patch.index_min.to_array(), patch.dims, &patch.values, &patch.spans, &runs.runs, &runs.values, offset, measured)
            .map_err(openvdb("subtract tool patch"))?;
        // Copied in one go: a push per voxel across the bridge cost a tenth of the cut.
        log.extend_from_slice(self.inner.last_changes());
        Ok(CutStats { changed_voxels: s.changed_voxels, removed_mm3: s.removed_volume })
    }

    /// The voxels the last [`subtract_logged`](Self::subtract_logged) changed, with their new
    /// values, appended to `out` in its log's order: what a copy of the grid must write to follow
    /// the cut without cutting again. No allocation once `out` has room.
    pub fn last_cut_values(&self, out: &mut Vec<VoxelChange>) {
        let start = out.len();
        out.extend_from_slice(self.inner.last_changes());
        self.inner.last_new_values(&mut out[start..]);
    }

    /// Marks in `out` each leaf-aligned 8³ block overlapping the index box that holds a voxel
    /// below the background (an inside tile, or a leaf with such a voxel) with 2: where a cut
    /// could change anything. A cut sets no voxel above the background, so a block all at it
    /// cannot change: an outside tile is left as it is in `out`, a leaf a cut left all at the
    /// background raises its block to at least 1. Blocks keep the largest mark any grid gives.
    /// Blocks are counted from the one holding `index_min`, x fastest ([`block_counts`]).
    pub fn mark_material_blocks(&self, index_min: IVec3, dims: [u32; 3], out: &mut [u8]) -> Result<()> {
        self.inner.mark_material_blocks(index_min.to_array(), dims, out).map_err(openvdb("mark material blocks"))
    }

    /// Grows the cut's working buffers for patches of up to `dims` voxels, so such cuts allocate
    /// nothing (values unchanged).
    pub fn reserve_cut(&mut self, dims: [u32; 3]) {
        self.inner.pin_mut().reserve_cut(dims);
    }

    /// Dry run: the volume (mm³, smoothed Heaviside) each tool offset would remove; nothing changes.
    pub fn removal_by_offset(&self, patch: &DensePatch, offsets: &[f32], removed: &mut [f64]) -> Result<()> {
        self.inner
            .removal_by_offset(patch.index_min.to_array(), patch.dims, &patch.values, offsets, removed)
            .map_err(openvdb("removal by offset"))
    }

    /// Writes voxel values back (active inside the band, off at ±background outside it).
    pub fn write_voxels(&mut self, changes: &[VoxelChange]) {
        self.edit().write_voxels(changes);
    }

    /// Fills each entry's `value` with the grid's current value at its voxel.
    pub fn read_voxels(&self, changes: &mut [VoxelChange]) {
        self.inner.read_voxels(changes);
    }

    /// Values of an index box, x fastest, into `out` (length must be the box's voxel count).
    pub fn read_dense(&self, index_min: IVec3, dims: [u32; 3], out: &mut [f32]) -> Result<()> {
        self.inner.read_dense(index_min.to_array(), dims, out).map_err(openvdb("read dense box"))
    }

    /// Origins (voxel index) of every leaf node.
    pub fn leaf_origins(&self) -> Vec<IVec3> {
        self.inner.leaf_origins().chunks_exact(3).map(|c| IVec3::new(c[0], c[1], c[2])).collect()
    }

    /// OpenVDB's `csgDifference` (the other grid is copied, not emptied).
    pub fn csg_difference(&mut self, other: &LevelSet) -> Result<()> {
        self.edit().csg_difference(&other.inner).map_err(openvdb("CSG difference"))
    }

    pub fn csg_union(&mut self, other: &LevelSet) -> Result<()> {
        self.edit().csg_union(&other.inner).map_err(openvdb("CSG union"))
    }

    pub fn csg_intersection(&mut self, other: &LevelSet) -> Result<()> {
        self.edit().csg_intersection(&other.inner).map_err(openvdb("CSG intersection"))
    }

    /// Moves the surface along its normals by `distance` mm, outward when positive: by shifting
    /// the values where the band keeps 2.5 voxels each side after it (half a voxel in a 3-voxel
    /// band; build a wider band, then [`Self::narrow_band`], to move farther at that cost),
    /// beyond by OpenVDB's `LevelSetFilter::offset` (re-tracks the narrow band per half voxel).
    /// A small offset changes the enclosed volume by about area × distance.
    pub fn offset(&mut self, distance: f64) -> Result<()> {
        self.edit().offset(distance).map_err(openvdb("level set offset"))
    }

    /// Trims the band to `half_width_voxels` each side (no change if it is no wider): the
    /// values beyond become the inactive outside or inside, and the background the new width.
    pub fn narrow_band(&mut self, half_width_voxels: f64) -> Result<()> {
        self.edit().narrow_band(half_width_voxels).map_err(openvdb("level set narrow band"))
    }

    /// The zero iso-surface as triangles with outward normals (OpenVDB's `volumeToMesh`).
    pub fn to_mesh(&self) -> TriMesh {
        TriMesh::from_buffers(self.inner.to_mesh())
    }

    pub fn set_meta(&mut self, key: &str, value: &MetaValue) {
        let g = self.inner.pin_mut();
        match value {
            MetaValue::String(s) => g.set_meta_string(key, s),
            MetaValue::F64(v) => g.set_meta_f64(key, *v),
            MetaValue::I64(v) => g.set_meta_i64(key, *v),
            MetaValue::Vec3(v) => g.set_meta_vec3(key, v.to_array()),
        }
    }

    pub fn meta_keys(&self) -> Vec<String> {
        self.inner.meta_keys()
    }

    /// A metadata value, converted from whatever numeric type the file stored.
    pub fn meta(&self, key: &str) -> Result<MetaValue> {
        let op = "read metadata";
        let kind = self.inner.meta_type(key).map_err(openvdb(op))?;
        Ok(match kind.as_str() {
            "string" => MetaValue::String(self.inner.meta_string(key).map_err(openvdb(op))?),
            "int32" | "int64" => MetaValue::I64(self.inner.meta_f64(key).map_err(openvdb(op))? as i64),
            "float" | "double" => MetaValue::F64(self.inner.meta_f64(key).map_err(openvdb(op))?),
            "vec3s" | "vec3d" => {
                MetaValue::Vec3(Vec3::from_array(self.inner.meta_vec3(key).map_err(openvdb(op))?))
            }
            other => {
                return Err(Error::Invalid {
                    op,
                    message: format!("metadata '{key}' of grid '{}' has type {other}", self.name()),
                })
            }
        })
    }

    /// Trilinear signed distances at world points (x, y, z, …) without a [`Reader`]: the
    /// accessor lives on the C++ stack, so no allocation and no lock (for the haptic tick).
    pub fn sample_values(&self, xyz: &[f32], out: &mut [f32]) {
        self.inner.sample_values(xyz, out);
    }

    /// Like [`LevelSet::sample_values`] with the gradient: `out` holds (value, gx, gy, gz) per point.
    pub fn sample_value_gradients(&self, xyz: &[f32], out: &mut [f32]) {
        self.inner.sample_value_gradients(xyz, out);
    }

    /// A 64-bit FNV-1a hash over every value, coordinate, level and active state of the tree:
    /// equal grids give equal hashes; used to check that a replay is bit-exact.
    pub fn content_hash(&self) -> u64 {
        self.inner.content_hash()
    }
}

impl Clone for LevelSet {
    /// OpenVDB's `deepCopy`.
    fn clone(&self) -> Self {
        LevelSet { inner: self.inner.deep_copy(), stamp: fresh_stamp() }
    }
}

impl std::fmt::Debug for LevelSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LevelSet")
            .field("name", &self.name())
            .field("voxel_size", &self.voxel_size())
            .field("active_voxels", &self.active_voxel_count())
            .finish()
    }
}

/// Fills one leaf (x slowest, as OpenVDB stores it); true if any voxel lies in the band.
fn sample_leaf(origin: IVec3, h: f64, band: f64, sdf: &impl Fn(DVec3) -> f64, out: &mut [f32]) -> bool {
    let mut any = false;
    let mut n = 0;
    for x in 0..LEAF_DIM {
        for y in 0..LEAF_DIM {
            for z in 0..LEAF_DIM {
                let d = sdf((origin + IVec3::new(x, y, z)).as_dvec3() * h);
                any |= d.abs() < band;
                out[n] = d as f32;
                n += 1;
            }
        }
    }
    any
}

/// Trilinear sampling through a cached accessor; one per thread.
pub struct Reader<'a> {
    inner: UniquePtr<ffi::Reader>,
    _grid: PhantomData<&'a LevelSet>,
}

impl Reader<'_> {
    /// Signed distance (mm) at a world point.
    pub fn value(&mut self, p: DVec3) -> f32 {
        self.inner.pin_mut().value(p.x, p.y, p.z)
    }

    /// Signed distance and its gradient (of the trilinear interpolant) at a world point.
    pub fn value_gradient(&mut self, p: DVec3) -> (f32, Vec3) {
        let [v, gx, gy, gz] = self.inner.pin_mut().value_gradient(p.x, p.y, p.z);
        (v, Vec3::new(gx, gy, gz))
    }

    /// Values at many points (x, y, z, …) in one call.
    pub fn values(&mut self, xyz: &[f32], out: &mut [f32]) {
        self.inner.pin_mut().values(xyz, out);
    }
}
