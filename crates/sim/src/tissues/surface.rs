//! Incremental meshing: each tissue's surface as one triangle patch per leaf-sized chunk, so a cut
//! re-meshes only the chunks it dirtied.
//!
//! The surface is a dual contour ("surface nets", the same family as OpenVDB's `volumeToMesh` at
//! adaptivity 0): one vertex per cell whose corners change sign, at the mean of its edges' zero
//! crossings; one quad per sign-changing voxel edge, joining the four cells around it, wound
//! counter-clockwise seen from outside. A chunk owns the edges whose lower voxel lies in its leaf;
//! its triangles depend only on the values from its origin −1 to origin +8, read in one call, and
//! every cell vertex is computed from its own eight corners alone, so a chunk re-meshed after a cut
//! is bit-identical to the same chunk in a full re-mesh.
//!
//! This is the one mesher: live frames ([`Mesher::frame`]: the chunks themselves, shared, seam
//! vertices repeated) and every finished surface ([`surface`], [`Mesher::surface`]: the same
//! triangles with each cell's vertex shared, so the surface is closed) come from it.
use std::collections::{BTreeMap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::Arc;

use dentsim_vdb::{LevelSet, TriMesh, LEAF_DIM};
use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::error::Result;
use crate::tissues::model::TissueModel;

const N: usize = LEAF_DIM as usize + 2;

/// One chunk's triangles (vertices not shared with other chunks).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ChunkMesh {
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Each vertex's cell (voxel index of its lower corner): the key that joins chunks' seams.
    pub cells: Vec<IVec3>,
}

/// One tissue's surface as the mesher's chunks, shared: publishing a frame costs a pointer per
/// chunk, not a copy of every triangle; whoever shows it flattens it ([`SurfaceFrame::to_mesh`]).
#[derive(Clone, Debug, Default)]
pub struct SurfaceFrame {
    chunks: Vec<Arc<ChunkMesh>>,
}

impl SurfaceFrame {
    /// The chunks' triangles side by side, in origin order (seam vertices repeated).
    pub fn to_mesh(&self) -> TriMesh {
        let mut out = TriMesh::default();
        let points = self.chunks.iter().map(|c| c.points.len()).sum();
        out.points.reserve(points);
        out.normals.reserve(points);
        out.triangles.reserve(self.triangle_count());
        for c in &self.chunks {
            let base = out.points.len() as u32;
            out.points.extend_from_slice(&c.points);
            out.normals.extend_from_slice(&c.normals);
            out.triangles.extend(c.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        out
    }

    pub fn triangle_count(&self) -> usize {
        self.chunks.iter().map(|c| c.triangles.len()).sum()
    }
}

impl From<TriMesh> for SurfaceFrame {
    fn from(m: TriMesh) -> Self {
        let chunk = ChunkMesh { points: m.points, normals: m.normals, triangles: m.triangles, cells: Vec::new() };
        SurfaceFrame { chunks: vec![Arc::new(chunk)] }
    }
}

/// Chunk meshes of every tissue, keyed by leaf origin.
#[derive(Default)]
pub struct Mesher {
    tissues: Vec<BTreeMap<(i32, i32, i32), Arc<ChunkMesh>>>,
    values: Vec<f32>,
}

impl Mesher {
    /// Meshes every leaf of every tissue.
    pub fn full(model: &TissueModel) -> Result<Self> {
        let mut m = Mesher { tissues: Vec::new(), values: vec![0.0; N * N * N] };
        for t in &model.tissues {
            let mut chunks = BTreeMap::new();
            for origin in t.grid.leaf_origins() {
                let c = mesh_chunk(&t.grid, origin, &mut m.values)?;
                if !c.triangles.is_empty() {
                    chunks.insert(origin.into(), Arc::new(c));
                }
            }
            m.tissues.push(chunks);
        }
        Ok(m)
    }

    /// Re-meshes the given (tissue, leaf origin) chunks; returns how many were re-meshed.
    pub fn update(&mut self, model: &TissueModel, dirty: &[(usize, IVec3)]) -> Result<usize> {
        if self.values.len() != N * N * N {
            self.values = vec![0.0; N * N * N];
        }
        while self.tissues.len() < model.tissues.len() {
            self.tissues.push(BTreeMap::new());
        }
        for &(t, origin) in dirty {
            let Some(tissue) = model.tissues.get(t) else { continue };
            let c = mesh_chunk(&tissue.grid, origin, &mut self.values)?;
            if c.triangles.is_empty() {
                self.tissues[t].remove(&origin.into());
            } else {
                self.tissues[t].insert(origin.into(), Arc::new(c));
            }
        }
        Ok(dirty.len())
    }

    pub fn chunk_count(&self, tissue: usize) -> usize {
        self.tissues.get(tissue).map_or(0, |c| c.len())
    }

    /// One tissue's surface, closed: [`mesh`](Self::mesh)'s triangles with the vertices the
    /// chunks repeat along their seams joined.
    pub fn surface(&self, tissue: usize) -> TriMesh {
        let chunks = self.tissues.get(tissue);
        let mut out = TriMesh::default();
        // Only a vertex of a cell on a chunk's faces can be repeated in another chunk.
        let mut seams: HashMap<IVec3, u32, BuildHasherDefault<LeafHasher>> = HashMap::default();
        let mut index = Vec::new();
        for ((x, y, z), c) in chunks.into_iter().flat_map(|m| m.iter()) {
            let origin = IVec3::new(*x, *y, *z);
            index.clear();
            for (k, cell) in c.cells.iter().enumerate() {
                let local = *cell - origin;
                let on_seam = local.min_element() < 0 || local.max_element() >= LEAF_DIM - 1;
                let next = out.points.len() as u32;
                let at = if on_seam { *seams.entry(*cell).or_insert(next) } else { next };
                if at == next {
                    out.points.push(c.points[k]);
                    out.normals.push(c.normals[k]);
                }
                index.push(at);
            }
            out.triangles.extend(c.triangles.iter().map(|t| t.map(|i| index[i as usize])));
        }
        out
    }

    /// One tissue's current chunks, shared (a live frame).
    pub fn frame(&self, tissue: usize) -> SurfaceFrame {
        SurfaceFrame { chunks: self.tissues.get(tissue).into_iter().flat_map(|m| m.values().cloned()).collect() }
    }

    /// One tissue's surface, chunks concatenated in origin order (a live frame, flattened).
    pub fn mesh(&self, tissue: usize) -> TriMesh {
        self.frame(tissue).to_mesh()
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

/// A grid's closed surface: every leaf meshed, on every core (chunks are independent, and the
/// grid is only read), seams joined (see [`Mesher::surface`]).
pub fn surface(grid: &LevelSet) -> Result<TriMesh> {
    let meshed: Vec<Result<(IVec3, ChunkMesh)>> = grid
        .leaf_origins()
        .into_par_iter()
        .map_init(|| vec![0.0; N * N * N], |values, origin| Ok((origin, mesh_chunk(grid, origin, values)?)))
        .collect();
    let mut chunks = BTreeMap::new();
    for m in meshed {
        let (origin, c) = m?;
        if !c.triangles.is_empty() {
            chunks.insert(origin.into(), Arc::new(c));
        }
    }
    Ok(Mesher { tissues: vec![chunks], values: Vec::new() }.surface(0))
}

/// The triangles of the chunk whose leaf starts at `origin`.
pub fn mesh_chunk(grid: &LevelSet, origin: IVec3, values: &mut [f32]) -> Result<ChunkMesh> {
    let lo = origin - IVec3::ONE;
    grid.read_dense(lo, [N as u32; 3], values)?;
    let h = grid.voxel_size() as f32;
    let at = |x: usize, y: usize, z: usize| values[x + N * (y + N * z)];
    let mut out = ChunkMesh::default();
    // Vertex index of each cell (lower corner local 0..N-1), u32::MAX when it has none.
    let mut cell = [u32::MAX; (N - 1) * (N - 1) * (N - 1)];
    let cid = |x: usize, y: usize, z: usize| x + (N - 1) * (y + (N - 1) * z);
    let mut vertex = |x: usize, y: usize, z: usize, out: &mut ChunkMesh| -> u32 {
        let id = cid(x, y, z);
        if cell[id] != u32::MAX {
            return cell[id];
        }
        let mut c = [[[0f32; 2]; 2]; 2];
        for (dx, plane) in c.iter_mut().enumerate() {
            for (dy, row) in plane.iter_mut().enumerate() {
                for (dz, v) in row.iter_mut().enumerate() {
                    *v = at(x + dx, y + dy, z + dz);
                }
            }
        }
        let (mut sum, mut count) = (Vec3::ZERO, 0f32);
        let mut edge = |a: Vec3, b: Vec3, va: f32, vb: f32| {
            if (va < 0.0) != (vb < 0.0) {
                let t = va / (va - vb);
                sum += a + (b - a) * t;
                count += 1.0;
            }
        };
        for i in 0..2 {
            for j in 0..2 {
                let (fi, fj) = (i as f32, j as f32);
                edge(Vec3::new(0.0, fi, fj), Vec3::new(1.0, fi, fj), c[0][i][j], c[1][i][j]);
                edge(Vec3::new(fi, 0.0, fj), Vec3::new(fi, 1.0, fj), c[i][0][j], c[i][1][j]);
                edge(Vec3::new(fi, fj, 0.0), Vec3::new(fi, fj, 1.0), c[i][j][0], c[i][j][1]);
            }
        }
        let f = sum / count.max(1.0);
        // Gradient of the trilinear interpolant at the vertex.
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let gx = lerp(lerp(c[1][0][0] - c[0][0][0], c[1][1][0] - c[0][1][0], f.y), lerp(c[1][0][1] - c[0][0][1], c[1][1][1] - c[0][1][1], f.y), f.z);
        let gy = lerp(lerp(c[0][1][0] - c[0][0][0], c[1][1][0] - c[1][0][0], f.x), lerp(c[0][1][1] - c[0][0][1], c[1][1][1] - c[1][0][1], f.x), f.z);
        let gz = lerp(lerp(c[0][0][1] - c[0][0][0], c[1][0][1] - c[1][0][0], f.x), lerp(c[0][1][1] - c[0][1][0], c[1][1][1] - c[1][1][0], f.x), f.y);
        let p = (lo.as_vec3() + Vec3::new(x as f32, y as f32, z as f32) + f) * h;
        out.points.push(p);
        out.normals.push(Vec3::new(gx, gy, gz).normalize_or_zero());
        out.cells.push(lo + IVec3::new(x as i32, y as i32, z as i32));
        cell[id] = (out.points.len() - 1) as u32;
        cell[id]
    };
    // Edges whose lower voxel lies in the leaf (local 1..=LEAF_DIM).
    for z in 1..N - 1 {
        for y in 1..N - 1 {
            for x in 1..N - 1 {
                let v = at(x, y, z);
                for axis in 0..3 {
                    let (nx, ny, nz) = match axis {
                        0 => (x + 1, y, z),
                        1 => (x, y + 1, z),
                        _ => (x, y, z + 1),
                    };
                    let w = at(nx, ny, nz);
                    if (v < 0.0) == (w < 0.0) {
                        continue;
                    }
                    // The four cells around the edge, counter-clockwise about +axis.
                    let quad: [(usize, usize, usize); 4] = match axis {
                        0 => [(x, y - 1, z - 1), (x, y, z - 1), (x, y, z), (x, y - 1, z)],
                        1 => [(x - 1, y, z - 1), (x - 1, y, z), (x, y, z), (x, y, z - 1)],
                        _ => [(x - 1, y - 1, z), (x, y - 1, z), (x, y, z), (x - 1, y, z)],
                    };
                    let ids = quad.map(|(a, b, c)| vertex(a, b, c, &mut out));
                    // Outward = toward the positive end; the quad's normal is +axis.
                    let [a, b, c, d] = if v < 0.0 { ids } else { [ids[3], ids[2], ids[1], ids[0]] };
                    out.triangles.push([a, b, c]);
                    out.triangles.push([a, c, d]);
                }
            }
        }
    }
    Ok(out)
}
