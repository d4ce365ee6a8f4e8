//! A narrow-band level set straight from a smooth field on a scan's grid: the surface is the
//! field's iso-surface under trilinear or cubic B-spline reconstruction. The fine voxels next to
//! it (a face neighbour on the other side) are projected onto it (Newton steps along the field's gradient);
//! every other voxel of the band takes the nearest of those surface points, carried outward from
//! neighbour to neighbour, and its distance to that point's tangent plane. This replaces meshing
//! the field and converting the mesh back (OpenVDB's `levelSetRebuild`: half the time on the
//! bench scan); only leaves within the band of a cell the surface crosses are visited, in
//! parallel. On a scan's grid without direction cosines the spline is sampled a leaf at a time
//! separably, and each sweep of the nearest points visits only voxels next to a change.
use dentsim_vdb::{LevelSet, LEAF_DIM};
use glam::{DMat3, DVec3, IVec3};
use rayon::prelude::*;

use crate::error::Result;

/// Voxels of a leaf (8³), z fastest as OpenVDB stores them.
const LEAF_VOXELS: usize = (LEAF_DIM * LEAF_DIM * LEAF_DIM) as usize;
const NEWTON_STEPS: usize = 12;
/// A projection has converged when the field is this close to the iso value.
const CONVERGED: f64 = 1e-4;

/// The field on its grid (x fastest) with its voxel→world affine (row-major 4×4).
pub struct GridField<'a> {
    pub dims: [usize; 3],
    pub index_to_world: [f64; 16],
    pub values: &'a [f32],
}

impl GridField<'_> {
    fn frame(&self) -> (DMat3, DVec3) {
        let m = &self.index_to_world;
        let a = DMat3::from_cols(DVec3::new(m[0], m[4], m[8]), DVec3::new(m[1], m[5], m[9]), DVec3::new(m[2], m[6], m[10]));
        (a, DVec3::new(m[3], m[7], m[11]))
    }

    fn at(&self, i: usize, j: usize, k: usize) -> f64 {
        f64::from(self.values[i + self.dims[0] * (j + self.dims[1] * k)])
    }

    /// Value and gradient (per index unit) at a continuous index under `kernel`.
    fn sample(&self, kernel: Kernel, u: DVec3) -> (f64, DVec3) {
        match kernel {
            Kernel::Trilinear => self.trilinear(u),
            Kernel::CubicBSpline => self.bspline(u),
        }
    }

    /// Trilinear value at a continuous index (outside the grid the border's values continue).
    pub fn trilinear_at(&self, u: DVec3) -> f64 {
        self.trilinear(u).0
    }

    /// The cubic B-spline's value at a continuous index, the values being its coefficients.
    pub fn spline_at(&self, u: DVec3) -> f64 {
        self.value(Kernel::CubicBSpline, u)
    }

    /// The cubic B-spline's value at every point of the tensor grid whose continuous indices
    /// along each axis are `axes` (x fastest), as [`Self::spline_at`] gives it, separably: 12
    /// coefficients read per point instead of 64.
    pub fn spline_on_grid(&self, axes: &[Vec<f64>; 3]) -> Vec<f32> {
        let taps = |c: usize| -> Vec<([usize; 4], [f64; 4])> {
            let last = self.dims[c] as i64 - 1;
            axes[c]
                .iter()
                .map(|&u| {
                    let x = u.clamp(0.0, last as f64);
                    let i = x.floor();
                    (std::array::from_fn(|o| (i as i64 - 1 + o as i64).clamp(0, last) as usize), cubic_weights(x - i))
                })
                .collect()
        };
        let (tx, ty, tz) = (taps(0), taps(1), taps(2));
        let range = |t: &[([usize; 4], [f64; 4])]| (t.iter().map(|(i, _)| i[0]).min().unwrap_or(0), t.iter().map(|(i, _)| i[3]).max().unwrap_or(0));
        let ((y0, y1), (z0, z1)) = (range(&ty), range(&tz));
        let (ny, nz) = (y1 + 1 - y0, z1 + 1 - z0);
        let (fx, fy, fz) = (tx.len(), ty.len(), tz.len());
        // Along x for every coefficient row the grid reaches, then y, then z.
        let mut along_x = vec![0f64; fx * ny * nz];
        along_x.par_chunks_mut(fx).enumerate().for_each(|(row, out)| {
            let (y, z) = (y0 + row % ny, z0 + row / ny);
            let line = &self.values[self.dims[0] * (y + self.dims[1] * z)..][..self.dims[0]];
            for (o, (i, w)) in out.iter_mut().zip(&tx) {
                *o = i.iter().zip(w).map(|(&i, w)| f64::from(line[i]) * w).sum();
            }
        });
        let mut along_y = vec![0f64; fx * fy * nz];
        along_y.par_chunks_mut(fx).enumerate().for_each(|(row, out)| {
            let (b, z) = (row % fy, row / fy);
            let (i, w) = &ty[b];
            for (tap, wy) in i.iter().zip(w) {
                let from = &along_x[fx * (tap - y0 + ny * z)..][..fx];
                for (o, v) in out.iter_mut().zip(from) {
                    *o += wy * v;
                }
            }
        });
        let mut out = vec![0f32; fx * fy * fz];
        out.par_chunks_mut(fx).enumerate().for_each(|(row, out)| {
            let (b, c) = (row % fy, row / fy);
            let (i, w) = &tz[c];
            let mut sum = vec![0f64; fx];
            for (tap, wz) in i.iter().zip(w) {
                let from = &along_y[fx * (b + fy * (tap - z0))..][..fx];
                for (o, v) in sum.iter_mut().zip(from) {
                    *o += wz * v;
                }
            }
            for (o, v) in out.iter_mut().zip(sum) {
                *o = v as f32;
            }
        });
        out
    }

    /// Value alone at a continuous index under `kernel` (the spline's without its gradient).
    fn value(&self, kernel: Kernel, u: DVec3) -> f64 {
        if kernel == Kernel::Trilinear {
            return self.trilinear(u).0;
        }
        let mut base = [0usize; 3];
        let mut w = [[0f64; 4]; 3];
        let mut interior = true;
        for c in 0..3 {
            let x = u[c].clamp(0.0, (self.dims[c] - 1) as f64);
            let i = x.floor();
            let t = x - i;
            w[c] = cubic_weights(t);
            interior &= i >= 1.0 && (i as usize) + 2 < self.dims[c];
            base[c] = (i as usize).saturating_sub(1);
        }
        if !interior {
            return self.bspline(u).0;
        }
        let (sy, sz) = (self.dims[0], self.dims[0] * self.dims[1]);
        let start = base[0] + sy * base[1] + sz * base[2];
        let mut value = 0.0;
        for (c, wz) in w[2].iter().enumerate() {
            let mut plane = 0.0;
            for (b, wy) in w[1].iter().enumerate() {
                let row = &self.values[start + c * sz + b * sy..][..4];
                let line: f64 = row.iter().zip(&w[0]).map(|(v, wx)| f64::from(*v) * wx).sum();
                plane += wy * line;
            }
            value += wz * plane;
        }
        value
    }

    /// Cubic B-spline value and gradient at a continuous index, the values being the spline's
    /// coefficients; outside the grid the border's values continue.
    fn bspline(&self, u: DVec3) -> (f64, DVec3) {
        let mut base = [0i64; 3];
        let mut w = [[0f64; 4]; 3];
        let mut d = [[0f64; 4]; 3];
        for c in 0..3 {
            let x = u[c].clamp(0.0, (self.dims[c] - 1) as f64);
            let i = x.floor();
            let t = x - i;
            base[c] = i as i64 - 1;
            let s = 1.0 - t;
            w[c] = cubic_weights(t);
            d[c] = [-0.5 * s * s, 0.5 * (3.0 * t * t - 4.0 * t), 0.5 * (-3.0 * t * t + 2.0 * t + 1.0), 0.5 * t * t];
        }
        // The taps' offsets along each axis (clamped to the grid), once per sample.
        let (sy, sz) = (self.dims[0], self.dims[0] * self.dims[1]);
        let taps = |c: usize, stride: usize| -> [usize; 4] { std::array::from_fn(|o| (base[c] + o as i64).clamp(0, self.dims[c] as i64 - 1) as usize * stride) };
        let (xs, ys, zs) = (taps(0, 1), taps(1, sy), taps(2, sz));
        let (mut value, mut g) = (0.0, DVec3::ZERO);
        for c in 0..4 {
            let (mut v_yz, mut gx_yz, mut gy_yz) = (0.0, 0.0, 0.0);
            let mut v_y = [0.0; 4];
            for b in 0..4 {
                let row = ys[b] + zs[c];
                let (mut v, mut gx) = (0.0, 0.0);
                for a in 0..4 {
                    let f = f64::from(self.values[row + xs[a]]);
                    v += w[0][a] * f;
                    gx += d[0][a] * f;
                }
                v_y[b] = v;
                v_yz += w[1][b] * v;
                gx_yz += w[1][b] * gx;
                gy_yz += d[1][b] * v;
            }
            value += w[2][c] * v_yz;
            g += DVec3::new(w[2][c] * gx_yz, w[2][c] * gy_yz, d[2][c] * v_yz);
        }
        (value, g)
    }

    /// The spline's value at the leaf's voxels in `wanted` (voxel `n` at index `(u[0][n >> 6],
    /// u[1][(n >> 3) & 7], u[2][n & 7])`), written to `out[n]`. Separable: sums along x for
    /// every coefficient row the leaf reaches, then along y, then z, each in [`Self::value`]'s
    /// order, so every value is the same to the bit.
    fn bspline_block(&self, u: &[[f64; 8]; 3], wanted: &VoxelMask, out: &mut [f32]) {
        let taps: [[([usize; 4], [f64; 4]); 8]; 3] = std::array::from_fn(|c| {
            std::array::from_fn(|i| {
                let x = u[c][i].clamp(0.0, (self.dims[c] - 1) as f64);
                let first = x.floor();
                let index = std::array::from_fn(|o| (first as i64 - 1 + o as i64).clamp(0, self.dims[c] as i64 - 1) as usize);
                (index, cubic_weights(x - first))
            })
        });
        let span = |c: usize| {
            let lo = taps[c].iter().map(|t| t.0[0]).min().unwrap_or(0);
            (lo, taps[c].iter().map(|t| t.0[3]).max().unwrap_or(0) + 1 - lo)
        };
        let ((jlo, jn), (klo, kn)) = (span(1), span(2));
        let mut lines = vec![0f64; jn * kn];
        let mut planes = vec![0f64; kn];
        for (x, &slice) in wanted.0.iter().enumerate() {
            if slice == 0 {
                continue;
            }
            let (ix, wx) = &taps[0][x];
            for k in 0..kn {
                for j in 0..jn {
                    lines[k * jn + j] = ix.iter().zip(wx).map(|(&i, w)| self.at(i, jlo + j, klo + k) * w).sum();
                }
            }
            for y in (0..8).filter(|y| (slice >> (8 * y)) & 0xff != 0) {
                let (iy, wy) = &taps[1][y];
                for (k, plane) in planes.iter_mut().enumerate() {
                    *plane = 0.0;
                    for (&j, w) in iy.iter().zip(wy) {
                        *plane += w * lines[k * jn + j - jlo];
                    }
                }
                for z in (0..8).filter(|z| (slice >> (8 * y + z)) & 1 == 1) {
                    let (iz, wz) = &taps[2][z];
                    let mut value = 0.0;
                    for (&k, w) in iz.iter().zip(wz) {
                        value += w * planes[k - klo];
                    }
                    out[(x << 6) | (y << 3) | z] = value as f32;
                }
            }
        }
    }

    /// Trilinear value and gradient (per index unit) at a continuous index; outside the grid
    /// the border's values continue.
    fn trilinear(&self, u: DVec3) -> (f64, DVec3) {
        let mut base = [0usize; 3];
        let mut t = [0f64; 3];
        for c in 0..3 {
            let n = self.dims[c];
            let x = u[c].clamp(0.0, (n - 1) as f64);
            let i = (x.floor() as usize).min(n.saturating_sub(2));
            base[c] = i;
            t[c] = if n > 1 { x - i as f64 } else { 0.0 };
        }
        let step = |c: usize| usize::from(self.dims[c] > 1);
        let [i, j, k] = base;
        let (di, dj, dk) = (step(0), step(1), step(2));
        let v = [
            self.at(i, j, k),
            self.at(i + di, j, k),
            self.at(i, j + dj, k),
            self.at(i + di, j + dj, k),
            self.at(i, j, k + dk),
            self.at(i + di, j, k + dk),
            self.at(i, j + dj, k + dk),
            self.at(i + di, j + dj, k + dk),
        ];
        let [x, y, z] = t;
        let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
        let (x00, x10, x01, x11) = (lerp(v[0], v[1], x), lerp(v[2], v[3], x), lerp(v[4], v[5], x), lerp(v[6], v[7], x));
        let (y0, y1) = (lerp(x00, x10, y), lerp(x01, x11, y));
        let value = lerp(y0, y1, z);
        let gx = lerp(lerp(v[1] - v[0], v[3] - v[2], y), lerp(v[5] - v[4], v[7] - v[6], y), z);
        let gy = lerp(x10 - x00, x11 - x01, z);
        let gz = y1 - y0;
        (value, DVec3::new(gx, gy, gz))
    }
}

/// The cubic B-spline's four weights at fraction `t` of a cell.
fn cubic_weights(t: f64) -> [f64; 4] {
    let s = 1.0 - t;
    [s * s * s / 6.0, (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0, (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0, t * t * t / 6.0]
}

/// How the field is reconstructed between its samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    Trilinear,
    /// The values are a cubic B-spline's coefficients (not prefiltered: the spline smooths as a
    /// blur of σ ≈ 0.58 samples would, so it does not pass through them): normals continuous
    /// across the scan's cells. Prefiltered to pass through the samples it kept the partial
    /// volume's aliasing (a ball at 0.3 mm: 5.6° against 2.1°, trilinear 6.3°).
    CubicBSpline,
}

/// Level set (voxel `voxel_size` mm, band `half_width` voxels each side) of where `field` >
/// `iso`, with distances to the field's trilinear iso-surface (see the module's text). The
/// distances come from surface points, not from the field's slope, so they hold where the field
/// is flat (far inside or outside, on a fine scan).
pub fn level_set_from_field(field: &GridField<'_>, iso: f32, voxel_size: f64, half_width: f64) -> Result<LevelSet> {
    level_set_from_field_with(field, Kernel::Trilinear, iso, voxel_size, half_width)
}

/// As [`level_set_from_field`], the field reconstructed by `kernel`.
pub fn level_set_from_field_with(field: &GridField<'_>, kernel: Kernel, iso: f32, voxel_size: f64, half_width: f64) -> Result<LevelSet> {
    // Samples a cell's value depends on: its corners, or for the spline one more on each side.
    let reach = match kernel {
        Kernel::Trilinear => 0usize,
        Kernel::CubicBSpline => 1,
    };
    let [nx, ny, nz] = field.dims;
    let iso = f64::from(iso);
    let h = voxel_size;
    let band = half_width * h;
    let (a, t) = field.frame();
    let inverse = a.inverse();
    let gradient_to_world = inverse.transpose();
    let spacing = [a.x_axis.length(), a.y_axis.length(), a.z_axis.length()];
    let max_step = 0.5 * spacing.iter().cloned().fold(f64::INFINITY, f64::min);

    // Every cell's side of the surface: 1 or −1 where the surface does not cross the cell (the
    // field there lies between the values it is made of: the trilinear's corners, the spline's
    // 4³ coefficients, the corners of the cell and its 26 neighbours), else 0.
    let (cx, cy, cz) = (nx.max(2) - 1, ny.max(2) - 1, nz.max(2) - 1);
    let cells = cx * cy * cz;
    let mut cell_side: Vec<i8> = (0..cells)
        .into_par_iter()
        .map(|c| {
            let (i, j, k) = (c % cx, (c / cx) % cy, c / (cx * cy));
            let (mut above, mut below) = (false, false);
            for z in k..=(k + 1).min(nz - 1) {
                for y in j..=(j + 1).min(ny - 1) {
                    for x in i..=(i + 1).min(nx - 1) {
                        let v = field.at(x, y, z);
                        above |= v > iso;
                        below |= v <= iso;
                    }
                }
            }
            if above && below { 0 } else if above { 1 } else { -1 }
        })
        .collect();
    for _ in 0..reach {
        for (axis, stride) in [(0, 1), (1, cx), (2, cx * cy)] {
            let len = [cx, cy, cz][axis];
            let src = cell_side.clone();
            cell_side.par_iter_mut().enumerate().for_each(|(c, side)| {
                let at = (c / stride) % len;
                let lo = if at > 0 { src[c - stride] } else { *side };
                let hi = if at + 1 < len { src[c + stride] } else { *side };
                if lo != *side || hi != *side {
                    *side = 0;
                }
            });
        }
    }

    // Leaves within the band of a cell the iso-surface passes through.
    let mut leaves: Vec<IVec3> = (0..cells)
        .into_par_iter()
        .flat_map_iter(|c| {
            let (i, j, k) = (c % cx, (c / cx) % cy, c / (cx * cy));
            let crosses = cell_side[c] == 0;
            let (mut wlo, mut whi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            if crosses {
                for corner in 0..8 {
                    let u = DVec3::new((i + (corner & 1)) as f64, (j + ((corner >> 1) & 1)) as f64, (k + ((corner >> 2) & 1)) as f64);
                    let w = a * u + t;
                    wlo = wlo.min(w);
                    whi = whi.max(w);
                }
            }
            let reach = band + h;
            let first = ((wlo - reach) / h).floor().as_ivec3().div_euclid(IVec3::splat(LEAF_DIM));
            let last = ((whi + reach) / h).floor().as_ivec3().div_euclid(IVec3::splat(LEAF_DIM));
            let range = move |lo: i32, hi: i32| if crosses { lo..=hi } else { 1..=0 };
            range(first.x, last.x).flat_map(move |x| range(first.y, last.y).flat_map(move |y| range(first.z, last.z).map(move |z| IVec3::new(x, y, z) * LEAF_DIM)))
        })
        .collect();
    leaves.par_sort_unstable_by_key(|o| (o.x, o.y, o.z));
    leaves.dedup();

    let origin_index: std::collections::HashMap<IVec3, usize> = leaves.iter().enumerate().map(|(i, &o)| (o, i)).collect();
    // Each leaf's face-neighbour leaves (−x, +x, −y, +y, −z, +z), where they exist.
    let around: Vec<[usize; 6]> = leaves
        .iter()
        .map(|&o| {
            let mut out = [usize::MAX; 6];
            for (slot, out) in out.iter_mut().enumerate() {
                let mut q = o;
                q[slot / 2] += if slot % 2 == 0 { -LEAF_DIM } else { LEAF_DIM };
                if let Some(&l) = origin_index.get(&q) {
                    *out = l;
                }
            }
            out
        })
        .collect();
    drop(origin_index);
    let voxel_of = |leaf: usize, n: usize| leaves[leaf] + IVec3::new((n >> 6) as i32, ((n >> 3) & 7) as i32, (n & 7) as i32);
    // Voxel `n` of leaf `leaf` stepped by one along `axis` (±1): (leaf, n), if that leaf exists.
    let step = |leaf: usize, n: usize, axis: usize, dir: i32| -> Option<(usize, usize)> {
        let shift = [6, 3, 0][axis];
        let c = ((n >> shift) & 7) as i32 + dir;
        if (0..LEAF_DIM).contains(&c) {
            return Some((leaf, if dir > 0 { n + (1 << shift) } else { n - (1 << shift) }));
        }
        let m = around[leaf][2 * axis + usize::from(dir > 0)];
        let wrapped = (n & !(7 << shift)) | ((c.rem_euclid(LEAF_DIM) as usize) << shift);
        (m != usize::MAX).then_some((m, wrapped))
    };

    // Every voxel's side of the surface: its cell's where the surface does not cross the cell,
    // else the field sampled.
    let inside_value = (iso + 1.0) as f32;
    let outside_value = (iso - 1.0) as f32;
    let cell_of = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1);
    // A scan's grid along the level set's axes (no direction cosines) samples the spline per
    // leaf separably: each axis's index depends on that axis's voxel alone.
    let axis_aligned = [inverse.x_axis.y, inverse.x_axis.z, inverse.y_axis.x, inverse.y_axis.z, inverse.z_axis.x, inverse.z_axis.y].iter().all(|&v| v == 0.0);
    let values: Vec<Vec<f32>> = leaves
        .par_iter()
        .enumerate()
        .map(|(l, &origin)| {
            if kernel == Kernel::CubicBSpline && axis_aligned {
                let u = [0, 1, 2].map(|c| {
                    std::array::from_fn(|i| {
                        let mut v = origin;
                        v[c] += i as i32;
                        (inverse * (v.as_dvec3() * h - t))[c]
                    })
                });
                let side = |n: usize| cell_side[cell_of(u[0][n >> 6], cx) + cx * (cell_of(u[1][(n >> 3) & 7], cy) + cy * cell_of(u[2][n & 7], cz))];
                let mut out: Vec<f32> = (0..LEAF_VOXELS).map(|n| if side(n) == 1 { inside_value } else { outside_value }).collect();
                field.bspline_block(&u, &VoxelMask::of(|n| side(n) == 0), &mut out);
                return out;
            }
            (0..LEAF_VOXELS)
                .map(|n| {
                    let u = inverse * (voxel_of(l, n).as_dvec3() * h - t);
                    match cell_side[cell_of(u.x, cx) + cx * (cell_of(u.y, cy) + cy * cell_of(u.z, cz))] {
                        1 => inside_value,
                        -1 => outside_value,
                        _ => field.value(kernel, u) as f32,
                    }
                })
                .collect()
        })
        .collect();
    let inside = |l: usize, n: usize| f64::from(values[l][n]) > iso;

    // Seeds: voxels with a face neighbour on the other side, projected onto the surface (Newton
    // steps along the gradient; the crossing on the edge where they do not converge).
    // Returns the point and the field's gradient there (world units).
    let project = |p: DVec3| -> Option<(DVec3, DVec3)> {
        let mut q = p;
        for _ in 0..NEWTON_STEPS {
            let (f, g) = field.sample(kernel, inverse * (q - t));
            let r = f - iso;
            let gw = gradient_to_world * g;
            if r.abs() < CONVERGED {
                return Some((q, gw));
            }
            let g2 = gw.length_squared();
            if g2 < 1e-12 {
                return None;
            }
            let mut s = -r * gw / g2;
            let len = s.length();
            if len > max_step {
                s *= max_step / len;
            }
            q += s;
            if q.distance(p) > 2.0 * h + max_step {
                return None;
            }
        }
        None
    };
    const NONE: u32 = u32::MAX;
    // Each seed's surface point and the surface's normal there (the leaves side by side).
    let seeds: Vec<Vec<(usize, DVec3, DVec3)>> = (0..leaves.len())
        .into_par_iter()
        .map(|l| {
            let mut out = Vec::new();
            for n in 0..LEAF_VOXELS {
                let side = inside(l, n);
                let mut edge = None;
                'axes: for axis in 0..3 {
                    for dir in [-1, 1] {
                        if let Some((m, k)) = step(l, n, axis, dir) {
                            if inside(m, k) != side {
                                edge = Some((m, k));
                                break 'axes;
                            }
                        }
                    }
                }
                let Some((m, k)) = edge else { continue };
                let p = voxel_of(l, n).as_dvec3() * h;
                // (The gradient at a converged foot is the last step's.)
                let (foot, gradient) = project(p).unwrap_or_else(|| {
                    let (a, b) = (f64::from(values[l][n]), f64::from(values[m][k]));
                    let s = ((iso - a) / (b - a)).clamp(0.0, 1.0);
                    let foot = p + (voxel_of(m, k).as_dvec3() * h - p) * s;
                    (foot, gradient_to_world * field.sample(kernel, inverse * (foot - t)).1)
                });
                let normal = gradient.normalize_or_zero();
                out.push((n, foot, normal));
            }
            out
        })
        .collect();
    let mut feet: Vec<DVec3> = Vec::new();
    let mut normals: Vec<DVec3> = Vec::new();
    let mut nearest: Vec<Vec<u32>> = vec![vec![NONE; LEAF_VOXELS]; leaves.len()];
    for (l, list) in seeds.into_iter().enumerate() {
        for (n, foot, normal) in list {
            nearest[l][n] = feet.len() as u32;
            feet.push(foot);
            normals.push(normal);
        }
    }

    // Each voxel takes the nearest of its face neighbours' surface points, sweep after sweep,
    // until the band is covered (one voxel per sweep). Only a voxel next to one that changed in
    // the last sweep can change in this one (its own choice already beats the rest).
    let sweeps = half_width.ceil() as usize + 1;
    let mut changed: Vec<VoxelMask> = nearest.iter().map(|v| VoxelMask::of(|n| v[n] != NONE)).collect();
    for _ in 0..sweeps {
        let next: Vec<Option<(Vec<u32>, VoxelMask)>> = (0..leaves.len())
            .into_par_iter()
            .map(|l| {
                let mut faces = [VoxelMask::EMPTY; 6];
                for (slot, face) in faces.iter_mut().enumerate() {
                    if around[l][slot] != usize::MAX {
                        *face = changed[around[l][slot]];
                    }
                }
                let due = changed[l].next_to(&faces);
                if due.is_empty() {
                    return None;
                }
                let mut own = nearest[l].clone();
                let mut moved = VoxelMask::EMPTY;
                due.for_each(|n| {
                    let p = voxel_of(l, n).as_dvec3() * h;
                    let mut best = if own[n] == NONE { f64::INFINITY } else { feet[own[n] as usize].distance_squared(p) };
                    for axis in 0..3 {
                        for dir in [-1, 1] {
                            if let Some((m, k)) = step(l, n, axis, dir) {
                                let id = nearest[m][k];
                                if id != NONE && id != own[n] {
                                    let d = feet[id as usize].distance_squared(p);
                                    if d < best {
                                        best = d;
                                        own[n] = id;
                                        moved.insert(n);
                                    }
                                }
                            }
                        }
                    }
                });
                (!moved.is_empty()).then_some((own, moved))
            })
            .collect();
        changed = next.iter().map(|v| v.as_ref().map_or(VoxelMask::EMPTY, |(_, moved)| *moved)).collect();
        for (l, v) in next.into_iter().enumerate() {
            if let Some((v, _)) = v {
                nearest[l] = v;
            }
        }
    }
    let leaves: Vec<(IVec3, Vec<f32>)> = (0..leaves.len())
        .into_par_iter()
        .map(|l| {
            let out = (0..LEAF_VOXELS)
                .map(|n| {
                    let sign = if inside(l, n) { -1.0 } else { 1.0 };
                    let id = nearest[l][n];
                    let d = if id == NONE {
                        band
                    } else {
                        // The foot is a surface point near the closest one, not always it: the
                        // distance to its tangent plane is off only by the surface's curvature
                        // times the two's separation squared, the distance to the foot itself
                        // by the separation (see TANGENT_PLANE_COS2).
                        let v = voxel_of(l, n).as_dvec3() * h - feet[id as usize];
                        let along = v.dot(normals[id as usize]);
                        if along * along >= TANGENT_PLANE_COS2 * v.length_squared() { along.abs() } else { v.length() }.min(band)
                    };
                    (sign * d) as f32
                })
                .collect();
            (leaves[l], out)
        })
        .collect();
    Ok(LevelSet::from_leaves(voxel_size, half_width, &leaves)?)
}

/// A band voxel's distance is its foot's tangent plane's where the foot lies within 60° of the
/// normal through it (cos² 0.25), beyond (a tip, an edge) the distance to the foot. Within 27°
/// (0.8), the feet a voxel apart put voxels half a voxel out up to 0.2 voxel too far, and a
/// surface moved by shifting the values ([`LevelSet::offset`]) took that roughness (every
/// tooth's, core's and pulp's is moved to its volume): a root's normals 0.70° → 1.68° moved
/// by 0.45 voxel, 0.68° now; the family's pulps up to 0.9° better, dentins and enamels up to
/// 0.4°.
const TANGENT_PLANE_COS2: f64 = 0.25;

/// One bit per voxel of a leaf (bit `n` of voxel `n`, z fastest): a word per x-slice, y in its
/// byte, z in the byte's bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct VoxelMask([u64; LEAF_DIM as usize]);

impl VoxelMask {
    const EMPTY: VoxelMask = VoxelMask([0; LEAF_DIM as usize]);
    /// Bits of the voxels at z = 0 and at z = 7 of every row.
    const Z_FIRST: u64 = 0x0101_0101_0101_0101;
    const Z_LAST: u64 = 0x8080_8080_8080_8080;

    fn of(mut set: impl FnMut(usize) -> bool) -> VoxelMask {
        let mut mask = VoxelMask::EMPTY;
        for n in (0..LEAF_VOXELS).filter(|&n| set(n)) {
            mask.insert(n);
        }
        mask
    }

    fn insert(&mut self, n: usize) {
        self.0[n >> 6] |= 1 << (n & 63);
    }

    fn is_empty(&self) -> bool {
        self.0.iter().all(|&w| w == 0)
    }

    fn for_each(&self, mut f: impl FnMut(usize)) {
        for (x, &word) in self.0.iter().enumerate() {
            let mut w = word;
            while w != 0 {
                f((x << 6) | w.trailing_zeros() as usize);
                w &= w - 1;
            }
        }
    }

    /// The voxels with a face neighbour in this mask, or across a face in `faces` (the masks of
    /// the leaves at −x, +x, −y, +y, −z, +z).
    fn next_to(&self, faces: &[VoxelMask; 6]) -> VoxelMask {
        let c = &self.0;
        let mut out = [0u64; LEAF_DIM as usize];
        for (x, word) in out.iter_mut().enumerate() {
            let w = c[x];
            let mut d = ((w << 1) & !Self::Z_FIRST) | ((w >> 1) & !Self::Z_LAST) | (w << 8) | (w >> 8);
            d |= if x > 0 { c[x - 1] } else { faces[0].0[7] };
            d |= if x < 7 { c[x + 1] } else { faces[1].0[0] };
            d |= (faces[2].0[x] >> 56) | (faces[3].0[x] << 56);
            d |= ((faces[4].0[x] & Self::Z_LAST) >> 7) | ((faces[5].0[x] & Self::Z_FIRST) << 7);
            *word = d;
        }
        VoxelMask(out)
    }
}

/// How [`curvature_flow`] runs: `steps` explicit steps of `dt` (in squared units of the
/// smallest spacing; stable up to ≈ 1/6), each voxel held on its side of 0.5 (`inside`) by at
/// least `side`; `held` voxels (none if empty) keep their value.
pub struct Flow<'a> {
    pub inside: &'a [bool],
    pub side: f32,
    pub held: &'a [bool],
    pub steps: usize,
    pub dt: f32,
}

/// Mean-curvature flow of a smooth inside-fraction field (x fastest): each level set moves
/// along its normal by its mean curvature, so a terraced or noisy surface relaxes toward a
/// smooth one while a flat wall stays put. After every step each voxel is held on its side of
/// 0.5, so no voxel changes side and thin walls keep their topology. Only the band 0.05…0.95
/// moves (the rest has no surface to smooth). The flow shrinks convex parts by about their
/// curvature times the flow's time; the caller restores the volume.
pub fn curvature_flow(values: &mut [f32], dims: [usize; 3], spacing: [f64; 3], flow: &Flow<'_>) {
    let [nx, ny, nz] = dims;
    let Flow { inside, side, held, steps, dt } = *flow;
    if nx < 3 || ny < 3 || nz < 3 || values.len() != nx * ny * nz || inside.len() != values.len() || !(held.is_empty() || held.len() == values.len()) {
        return;
    }
    let h = spacing.iter().cloned().fold(f64::INFINITY, f64::min);
    // Derivatives per unit of the smallest spacing.
    let [ax, ay, az] = spacing.map(|s| (h / s) as f32);
    let (sy, sz) = (nx, nx * ny);
    let mut src = values.to_vec();
    for _ in 0..steps {
        src.copy_from_slice(values);
        let src = &src;
        values.par_chunks_mut(sz).enumerate().for_each(|(k, plane)| {
            if k == 0 || k + 1 >= nz {
                return;
            }
            for j in 1..ny - 1 {
                for i in 1..nx - 1 {
                    let n = i + sy * j + sz * k;
                    let c = src[n];
                    if !(0.05..=0.95).contains(&c) || held.get(n) == Some(&true) {
                        continue;
                    }
                    let at = |d: isize| src[(n as isize + d) as usize];
                    let (dx, dy, dz) = (1isize, sy as isize, sz as isize);
                    let fx = 0.5 * ax * (at(dx) - at(-dx));
                    let fy = 0.5 * ay * (at(dy) - at(-dy));
                    let fz = 0.5 * az * (at(dz) - at(-dz));
                    let g2 = fx * fx + fy * fy + fz * fz;
                    if g2 < 1e-8 {
                        continue;
                    }
                    let fxx = ax * ax * (at(dx) - 2.0 * c + at(-dx));
                    let fyy = ay * ay * (at(dy) - 2.0 * c + at(-dy));
                    let fzz = az * az * (at(dz) - 2.0 * c + at(-dz));
                    let fxy = 0.25 * ax * ay * (at(dx + dy) - at(dx - dy) - at(dy - dx) + at(-dx - dy));
                    let fxz = 0.25 * ax * az * (at(dx + dz) - at(dx - dz) - at(dz - dx) + at(-dx - dz));
                    let fyz = 0.25 * ay * az * (at(dy + dz) - at(dy - dz) - at(dz - dy) + at(-dy - dz));
                    let num = fxx * (fy * fy + fz * fz) + fyy * (fx * fx + fz * fz) + fzz * (fx * fx + fy * fy)
                        - 2.0 * (fx * fy * fxy + fx * fz * fxz + fy * fz * fyz);
                    let v = c + dt * num / g2;
                    plane[i + sy * j] = if inside[n] { v.max(0.5 + side) } else { v.min(0.5 - side) };
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spline on a tensor grid (inside, at the border and beyond it) as sampled point by point.
    #[test]
    fn the_spline_on_a_grid_is_the_spline_at_each_point() {
        let mut random = crate::unit_random(11);
        let dims = [7usize, 9, 6];
        let values: Vec<f32> = (0..dims.iter().product::<usize>()).map(|_| random() as f32).collect();
        let field = GridField { dims, index_to_world: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0], values: &values };
        let axes: [Vec<f64>; 3] = std::array::from_fn(|a| (0..2 * dims[a] + 3).map(|f| -1.0 + f as f64 * 0.5 + 0.1 * random()).collect());
        let grid = field.spline_on_grid(&axes);
        for (n, v) in grid.iter().enumerate() {
            let (i, j, k) = (n % axes[0].len(), (n / axes[0].len()) % axes[1].len(), n / (axes[0].len() * axes[1].len()));
            let u = DVec3::new(axes[0][i], axes[1][j], axes[2][k]);
            assert!((f64::from(*v) - field.spline_at(u)).abs() < 1e-6, "at {u}: {v} against {}", field.spline_at(u));
        }
    }

    /// `next_to` against the neighbours counted one by one, on random masks of a leaf and its six
    /// face neighbours.
    #[test]
    fn voxels_next_to_a_mask_are_its_face_neighbours() {
        let mut random = crate::unit_random(7);
        let d = LEAF_DIM;
        for _ in 0..50 {
            let density = random() * 0.2;
            let mut bit = || random() < density;
            let own = VoxelMask::of(|_| bit());
            let faces = [(); 6].map(|_| VoxelMask::of(|_| bit()));
            let set = |m: &VoxelMask, v: IVec3| m.0[v.x as usize] >> (v.y * d + v.z) & 1 == 1;
            let got = own.next_to(&faces);
            for n in 0..LEAF_VOXELS {
                let v = IVec3::new((n >> 6) as i32, ((n >> 3) & 7) as i32, (n & 7) as i32);
                let mut expected = false;
                for axis in 0..3 {
                    for (dir, slot) in [(-1, 2 * axis), (1, 2 * axis + 1)] {
                        let mut q = v;
                        q[axis] += dir;
                        expected |= if (0..d).contains(&q[axis]) {
                            set(&own, q)
                        } else {
                            q[axis] = q[axis].rem_euclid(d);
                            set(&faces[slot], q)
                        };
                    }
                }
                assert_eq!(set(&got, v), expected, "voxel {v}");
            }
        }
        let mut seen = Vec::new();
        VoxelMask::of(|n| n % 37 == 3).for_each(|n| seen.push(n));
        assert_eq!(seen, (0..LEAF_VOXELS).filter(|n| n % 37 == 3).collect::<Vec<_>>());
    }

    /// A ball of radius 2 mm on a 0.3 mm grid, labelled by voxel centre and blurred and held as
    /// `from_scan`'s unions are (without the grey): its surface keeps the grid's terraces. The flow takes them off
    /// (normal error falls) and moves the surface little (the volume within a stated bound).
    #[test]
    fn curvature_flow_takes_the_terraces_off_a_labelled_ball() {
        let (h, n, r) = (0.3, 26usize, 2.0);
        let centre = DVec3::splat(3.77);
        let dims = [n; 3];
        let mut values: Vec<f32> = (0..n * n * n)
            .map(|m| {
                let p = DVec3::new((m % n) as f64, ((m / n) % n) as f64, (m / (n * n)) as f64) * h;
                f32::from(u8::from(p.distance(centre) < r))
            })
            .collect();
        let inside: Vec<bool> = values.iter().map(|&v| v > 0.5).collect();
        dentsim_cbct::phantom::gaussian_blur(&mut values, dims, [0.35; 3]);
        for (v, inside) in values.iter_mut().zip(&inside) {
            *v = if *inside { v.max(0.9234) } else { v.min(0.0766) };
        }
        dentsim_cbct::phantom::gaussian_blur(&mut values, dims, [0.5; 3]);
        for (v, inside) in values.iter_mut().zip(&inside) {
            *v = if *inside { v.max(0.52) } else { v.min(0.48) };
        }
        let index_to_world = [h, 0.0, 0.0, 0.0, 0.0, h, 0.0, 0.0, 0.0, 0.0, h, 0.0, 0.0, 0.0, 0.0, 1.0];
        let surface = |values: &[f32]| {
            let grid = level_set_from_field_with(&GridField { dims, index_to_world, values }, Kernel::CubicBSpline, 0.5, 0.05, 3.0).unwrap();
            (crate::tissues::test_shapes::radial_normal_error(&grid.to_mesh(), centre, |_| true), grid.volume())
        };
        let (before_deg, before_mm3) = surface(&values);
        curvature_flow(&mut values, dims, [h; 3], &Flow { inside: &inside, side: 0.02, held: &[], steps: 4, dt: 0.1 });
        assert!(values.iter().zip(&inside).all(|(v, i)| (*v > 0.5) == *i), "a voxel changed side");
        let (after_deg, after_mm3) = surface(&values);
        let truth = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        // Measured: normals 7.81° → 3.67°, volume −4.4 %. The flow shrinks a ball of radius R
        // (voxels) by 2t/R in radius over its time t (voxels²): −5.4 % of the volume here, less
        // where a voxel's side holds the surface; the caller restores the volume.
        println!("normals {before_deg:.2}° → {after_deg:.2}°, volume {before_mm3:.3} → {after_mm3:.3} mm³ (ball {truth:.3})");
        assert!(after_deg < 0.6 * before_deg, "normals {before_deg:.2}° → {after_deg:.2}°");
        let shrink = 3.0 * 2.0 * 0.4 / (r / h).powi(2);
        assert!(after_mm3 < before_mm3 && after_mm3 > before_mm3 * (1.0 - shrink), "volume {before_mm3:.3} → {after_mm3:.3} mm³");
    }

    /// A ball's level set from its blurred indicator holds distances to its surface through the
    /// band: moved by shifting its values (up to half a voxel), its normals stay as they were
    /// and its radius moves by as much.
    #[test]
    fn a_level_set_from_a_field_moves_by_its_distances() {
        let (h, n, r) = (0.2, 40usize, 2.3);
        let centre = DVec3::new(3.93, 4.01, 3.87);
        let dims = [n; 3];
        // Each voxel's share of the ball (4³ samples), blurred by a voxel.
        let mut values: Vec<f32> = (0..n * n * n)
            .map(|m| {
                let at = DVec3::new((m % n) as f64, ((m / n) % n) as f64, (m / (n * n)) as f64);
                (0..64).filter(|s| ((at + DVec3::new((s % 4) as f64, ((s / 4) % 4) as f64, (s / 16) as f64) / 4.0 - 0.375) * h).distance(centre) < r).count() as f32 / 64.0
            })
            .collect();
        dentsim_cbct::phantom::gaussian_blur(&mut values, dims, [1.0; 3]);
        let index_to_world = [h, 0.0, 0.0, 0.0, 0.0, h, 0.0, 0.0, 0.0, 0.0, h, 0.0, 0.0, 0.0, 0.0, 1.0];
        let grid = level_set_from_field_with(&GridField { dims, index_to_world, values: &values }, Kernel::CubicBSpline, 0.5, 0.05, 3.0).unwrap();
        let radius = |grid: &LevelSet| {
            let mesh = grid.to_mesh();
            mesh.points.iter().map(|p| p.as_dvec3().distance(centre)).sum::<f64>() / mesh.points.len() as f64
        };
        let normals = |grid: &LevelSet| crate::tissues::test_shapes::radial_normal_error(&grid.to_mesh(), centre, |_| true);
        let (deg, mm) = (normals(&grid), radius(&grid));
        for d in [0.011, 0.0225, -0.0225] {
            let mut moved = grid.clone();
            moved.offset(d).unwrap();
            let (moved_deg, moved_mm) = (normals(&moved), radius(&moved));
            // Measured: 0.61° → 0.59–0.61°, the radius by d within 0.03 µm (with the foot's own
            // distance beyond 27° of its normal: 0.78° a quarter voxel out).
            println!("moved {d:+.4} mm: normals {deg:.2}° → {moved_deg:.2}°, radius {:+.5} mm", moved_mm - mm);
            assert!(moved_deg < deg + 0.1, "moved {d:+.4} mm: normals {deg:.2}° → {moved_deg:.2}°");
            assert!((moved_mm - mm - d).abs() < 0.002, "moved {d:+.4} mm: radius {:+.5} mm", moved_mm - mm);
        }
    }
}
