//! A small tissue's surface fitted to the scan through the scanner's blur.
//!
//! Read voxel by voxel, a grey is a two-tissue mix only across a flat border: where the body is
//! small on the blur's scale (a pulp's horns and canals), the blur spreads its darkness over
//! more dentin than a flat border would, and any surface read from each voxel's grey comes out
//! rounded and short (the family's pulps: at or above the blurred analytic pulp's own normal
//! error). Here the surface is the one whose body, blurred as the scanner blurs and averaged
//! over each voxel, gives the scan's greys: a level set on a grid finer than the scan's is moved
//! along its normals by the back-projected residual until the two agree.
use dentsim_cbct::phantom::gaussian_blur;
use dentsim_cbct::{within_box, Volume};
use rayon::prelude::*;

use crate::tissues::field::GridField;

/// The two tissues' greys and the scanner's point spread (σ, mm, without the voxel's box).
#[derive(Clone, Copy, Debug)]
pub struct TwoTissueBlur {
    pub inside_grey: f64,
    pub outside_grey: f64,
    pub sigma_mm: f64,
}

/// A field on a grid finer than the scan's, positive inside (a distance near its surface).
pub struct FineField {
    pub dims: [usize; 3],
    pub index_to_world: [f64; 16],
    pub values: Vec<f32>,
}

impl FineField {
    pub fn grid(&self) -> GridField<'_> {
        GridField { dims: self.dims, index_to_world: self.index_to_world, values: &self.values }
    }
}

/// The fit's fine cells are at most this many σ wide (0.67 σ: within 0.1° at 0.3 mm, up to 0.6°
/// better at 0.15–0.2 mm, for 2.4 times the cells; 1.3 σ: the family's 0.2 mm pulps 0.6–1.9°
/// worse), and no finer than a quarter of a scan voxel.
const CELL_PER_SIGMA: f64 = 1.0;
const MAX_REFINE: usize = 4;
/// With the curvature prior 5–20 steps come out within 0.3° of each other on the family.
const MAX_STEPS: usize = 8;
/// Share of the Gauss–Newton step taken (the back-projection's gain is a flat border's).
const DAMPING: f64 = 0.7;
/// Fine cells whose back-projection weighs less than this (far from fitted voxels) stay put.
const MIN_WEIGHT: f32 = 0.3;
/// The residual is back-projected through a blur this many scan voxels wider than the point
/// spread (a Sobolev gradient): the greys tell where the surface lies per voxel, not within
/// one, and the plain back-projection moved it in voxel-sized steps (the family's pulps: 0.3 mm
/// scans 0.9–1.4° worse than placed by grey; 0.7 voxel: 0.0–0.3° better, 1.0: 0.6–1.5°).
const BACK_PROJECTION_VOXELS: f64 = 1.0;
/// Each step also lets the field diffuse this many fine cells² (mean-curvature motion, the
/// surface's area as a prior): without it more steps fitted the noise (12 → 24 steps, the
/// noisy family's pulps 0.1–0.7° worse); with it 8–20 steps come out within 0.2°.
const CURVATURE_CELLS2: f64 = 0.05;

/// The surface inside the scan voxels `lo..hi` (index box, exclusive) whose blurred body best
/// gives the greys of the voxels `fitted` admits (those whose grey mixes only the two tissues),
/// starting from `start`'s 0.5 iso-surface (a field on the scan's grid, cubic B-spline
/// coefficients, more than 0.5 inside). `None` when the blur or the contrast is not usable.
pub fn fit_through_blur(scan: &Volume, start: &[f32], lo: [usize; 3], hi: [usize; 3], fitted: impl Fn(usize) -> bool + Sync, model: TwoTissueBlur) -> Option<FineField> {
    let contrast = model.inside_grey - model.outside_grey;
    if !(model.sigma_mm.is_finite() && model.sigma_mm > 0.0 && contrast.is_finite() && contrast.abs() > 0.0) {
        return None;
    }
    let span: [usize; 3] = std::array::from_fn(|a| hi[a].saturating_sub(lo[a]));
    if span.iter().any(|&s| s < 2) {
        return None;
    }
    let refine: [usize; 3] = std::array::from_fn(|a| ((scan.spacing[a] / (CELL_PER_SIGMA * model.sigma_mm)).ceil() as usize).clamp(1, MAX_REFINE));
    let dims: [usize; 3] = std::array::from_fn(|a| span[a] * refine[a]);
    let cell: [f64; 3] = std::array::from_fn(|a| scan.spacing[a] / refine[a] as f64);
    let cell_mm = cell.iter().sum::<f64>() / 3.0;
    let len = dims[0] * dims[1] * dims[2];
    let unravel = |n: usize| [n % dims[0], (n / dims[0]) % dims[1], n / (dims[0] * dims[1])];
    let coarse = GridField { dims: scan.dims, index_to_world: scan.index_to_world(), values: start };

    // The start: the spline's field minus its iso value over its slope, a distance near the surface.
    let axes: [Vec<f64>; 3] = std::array::from_fn(|a| (0..dims[a]).map(|f| lo[a] as f64 + (f as f64 + 0.5) / refine[a] as f64 - 0.5).collect());
    let u: Vec<f32> = coarse.spline_on_grid(&axes).into_par_iter().map(|v| v - 0.5).collect();
    let slope = |n: usize| -> f64 {
        let f = unravel(n);
        (0..3)
            .map(|a| {
                let stride = [1, dims[0], dims[0] * dims[1]][a];
                let (m, p) = (if f[a] > 0 { n - stride } else { n }, if f[a] + 1 < dims[a] { n + stride } else { n });
                let d = f64::from(u[p] - u[m]) / (((p - m) / stride) as f64 * cell[a]).max(cell[a]);
                d * d
            })
            .sum::<f64>()
            .sqrt()
    };
    let mut at_surface: Vec<f64> = (0..len).into_par_iter().filter(|&n| u[n].abs() < 0.1).map(slope).filter(|s| *s > 0.0).collect();
    if at_surface.is_empty() {
        return None;
    }
    let k = at_surface.len() / 2;
    let typical = *at_surface.select_nth_unstable_by(k, f64::total_cmp).1;
    let reach = 3.0 * cell_mm + 2.0 * model.sigma_mm;
    let mut phi: Vec<f32> = (0..len).into_par_iter().map(|n| (f64::from(u[n]) / slope(n).max(typical / 3.0)).clamp(-reach, reach) as f32).collect();

    // The scan's voxels in the box, their share of the inside tissue and whether they are fitted.
    let coarse_len = span[0] * span[1] * span[2];
    let voxel_of = |c: usize| scan.index(lo[0] + c % span[0], lo[1] + (c / span[0]) % span[1], lo[2] + c / (span[0] * span[1]));
    // Only voxels within reach of the start's surface: the back-projection carries a voxel's
    // residual 3 of its widths (σ and a voxel) at most, and the surface moves at most `reach`;
    // farther voxels would only move cells that stay on their side.
    let near_mm = reach + 3.0 * (model.sigma_mm.powi(2) + (BACK_PROJECTION_VOXELS * scan.min_spacing()).powi(2)).sqrt();
    let inside: Vec<bool> = (0..coarse_len).into_par_iter().map(|c| start[voxel_of(c)] > 0.5).collect();
    let border: Vec<bool> = (0..coarse_len)
        .into_par_iter()
        .map(|c| {
            let at = [c % span[0], (c / span[0]) % span[1], c / (span[0] * span[1])];
            let strides = [1, span[0], span[0] * span[1]];
            (0..3).any(|a| at[a] + 1 < span[a] && inside[c + strides[a]] != inside[c])
        })
        .collect();
    let near = within_box(border, span, (near_mm / scan.min_spacing()).ceil() as usize);
    let observed: Vec<Option<f32>> = (0..coarse_len)
        .into_par_iter()
        .map(|c| {
            let n = voxel_of(c);
            (near[c] && fitted(n)).then(|| ((f64::from(scan.values[n]) - model.outside_grey) / contrast) as f32)
        })
        .collect();
    if observed.iter().all(Option::is_none) {
        return None;
    }
    // Each fine cell's scan voxel, a row of x at a time.
    let upsample = |coarse: &[f32]| -> Vec<f32> {
        let mut fine = vec![0f32; len];
        fine.par_chunks_mut(dims[0]).enumerate().for_each(|(row, out)| {
            let (y, z) = (row % dims[1], row / dims[1]);
            let from = &coarse[span[0] * (y / refine[1] + span[1] * (z / refine[2]))..][..span[0]];
            for (x, v) in out.iter_mut().enumerate() {
                *v = from[x / refine[0]];
            }
        });
        fine
    };
    let sigma_cells: [f64; 3] = std::array::from_fn(|a| model.sigma_mm / cell[a]);
    // The back-projection's widening is done on the scan's grid, the point spread on the fine one.
    let widen = [BACK_PROJECTION_VOXELS; 3];
    let back_project = |coarse: &mut Vec<f32>| -> Vec<f32> {
        gaussian_blur(coarse, span, widen);
        let mut fine = upsample(coarse);
        gaussian_blur(&mut fine, dims, sigma_cells);
        fine
    };
    let weight = back_project(&mut observed.iter().map(|o| f32::from(u8::from(o.is_some()))).collect());
    // A flat border displaced by d leaves a residual share d·N(x; σₜ) (σₜ the point spread and
    // the voxel's box together); back-projected through both again it reads d / (2√π σₜ) at the border.
    let sigma_t = (model.sigma_mm.powi(2) + scan.box_variance_mm2()).sqrt();
    let gain = (DAMPING * 2.0 * std::f64::consts::PI.sqrt() * sigma_t) as f32;
    let limit = (0.5 * cell_mm) as f32;
    let per_voxel = (refine[0] * refine[1] * refine[2]) as f32;
    let diffusion = CURVATURE_CELLS2 * cell_mm * cell_mm;
    for _ in 0..MAX_STEPS {
        // The body's share per fine cell: a flat border through a cell at φ from its centre.
        let mut body: Vec<f32> = phi.par_iter().map(|&p| (0.5 + p / cell_mm as f32).clamp(0.0, 1.0)).collect();
        gaussian_blur(&mut body, dims, sigma_cells);
        let predicted = voxel_sums(&body, dims, refine, span);
        let back = back_project(&mut observed.iter().zip(&predicted).map(|(o, p)| o.map_or(0.0, |o| o - p / per_voxel)).collect());
        let moved = phi
            .par_iter_mut()
            .zip(&back)
            .zip(&weight)
            .filter(|(_, w)| **w >= MIN_WEIGHT)
            .map(|((p, b), w)| {
                let step = (gain * b / w).clamp(-limit, limit);
                let near = p.abs() < 2.0 * limit;
                *p = (*p + step).clamp(-reach as f32, reach as f32);
                if near { step.abs() } else { 0.0 }
            })
            .reduce(|| 0.0, f32::max);
        diffuse(&mut phi, dims, cell, diffusion);
        if moved < 0.02 * limit {
            break;
        }
    }
    // Fine index → world: the scan's affine after the fine grid's scale and shift.
    let m = scan.index_to_world();
    let mut index_to_world = m;
    for r in 0..3 {
        let mut shift = m[r * 4 + 3];
        for a in 0..3 {
            index_to_world[r * 4 + a] = m[r * 4 + a] / refine[a] as f64;
            shift += m[r * 4 + a] * (lo[a] as f64 + 0.5 / refine[a] as f64 - 0.5);
        }
        index_to_world[r * 4 + 3] = shift;
    }
    Some(FineField { dims, index_to_world, values: phi })
}

/// Each scan voxel's sum over its fine cells (`refine` per axis, `span` scan voxels).
fn voxel_sums(fine: &[f32], dims: [usize; 3], refine: [usize; 3], span: [usize; 3]) -> Vec<f32> {
    (0..span[0] * span[1] * span[2])
        .into_par_iter()
        .map(|c| {
            let at = [c % span[0], (c / span[0]) % span[1], c / (span[0] * span[1])];
            let mut sum = 0f32;
            for z in at[2] * refine[2]..(at[2] + 1) * refine[2] {
                for y in at[1] * refine[1]..(at[1] + 1) * refine[1] {
                    let row = dims[0] * (y + dims[1] * z);
                    sum += fine[row + at[0] * refine[0]..row + (at[0] + 1) * refine[0]].iter().sum::<f32>();
                }
            }
            sum
        })
        .collect()
}

/// One explicit step of the field's diffusion by `amount` mm² (cells on the grid's faces kept).
fn diffuse(field: &mut [f32], dims: [usize; 3], cell: [f64; 3], amount: f64) {
    let [nx, ny, nz] = dims;
    let src = field.to_vec();
    let [wx, wy, wz]: [f32; 3] = std::array::from_fn(|a| (amount / (cell[a] * cell[a])) as f32);
    field.par_chunks_mut(nx).enumerate().for_each(|(row, out)| {
        let (y, z) = (row % ny, row / ny);
        if y == 0 || z == 0 || y + 1 >= ny || z + 1 >= nz {
            return;
        }
        let at = |dy: isize, dz: isize| &src[nx * ((y as isize + dy) as usize + ny * (z as isize + dz) as usize)..][..nx];
        let (here, (south, north), (below, above)) = (at(0, 0), (at(-1, 0), at(1, 0)), (at(0, -1), at(0, 1)));
        for x in 1..nx.saturating_sub(1) {
            let c = here[x];
            out[x] += wx * (here[x - 1] + here[x + 1] - 2.0 * c) + wy * (south[x] + north[x] - 2.0 * c) + wz * (below[x] + above[x] - 2.0 * c);
        }
    });
}
