//! A crown preparation's form along its path of insertion: total occlusal convergence (taper),
//! occlusal and axial reduction, margin width, undercut, and height against width.
//!
//! The cut surface's triangles are sorted by their normal against the axis: axial walls (within
//! 60° of parallel to it), occlusal or ledge faces (facing along it within 30°), the rest are
//! rounded transitions and count for nothing. Reductions are measured as a dentist would with a
//! probe: from the prepared surface to the original one, along the axis for occlusal faces and
//! straight out from the axis for walls.
use glam::DVec3;
use serde::Serialize;

use dentsim_vdb::{Reader, TriMesh};

/// The figures of a crown preparation (mm and degrees).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CrownFigures {
    /// The path of insertion (unit, toward the occlusal surface).
    pub axis: [f64; 3],
    /// Total occlusal convergence: twice the axial walls' mean inclination to the axis.
    pub taper_deg: f64,
    pub occlusal_reduction_mm: f64,
    pub axial_reduction_mean_mm: f64,
    pub axial_reduction_min_mm: f64,
    /// The axial reduction where the walls meet the margin (a shoulder's or chamfer's width).
    pub margin_width_mm: f64,
    /// Walls hidden from the path of insertion (material of the preparation above them along
    /// it), and their area. A triangle's own lean says little: a voxel mesh's facets step.
    pub undercut: bool,
    pub undercut_area_mm2: f64,
    pub height_mm: f64,
    pub width_mm: f64,
    pub height_to_width: f64,
}

/// A wall's normal lies within 30° of square to the axis (|n·axis| < sin 30°).
const WALL_MAX_NORMAL_ALONG: f64 = 0.5;
/// Faces whose normal lies within 30° of the axis face occlusally.
const FACE_MIN_NORMAL_ALONG: f64 = 0.866;

/// How far from `p` along `dir` the tooth ends (its value turns positive), marching by the
/// value (a distance) and at least a quarter voxel; None within `limit` mm.
fn probe(readers: &mut [Reader], value: impl Fn(&mut [Reader], DVec3) -> f64, p: DVec3, dir: DVec3, h: f64, limit: f64) -> Option<f64> {
    let mut t = 0.0;
    let mut v = value(readers, p);
    while t < limit {
        if v > 0.0 {
            // Back to the zero crossing between the last two samples (linear).
            return Some(t);
        }
        let step = (-v).max(0.25 * h);
        let (t1, v1) = (t + step, value(readers, p + dir * (t + step)));
        if v1 > 0.0 {
            return Some(t + step * (-v) / (v1 - v).max(1e-12));
        }
        (t, v) = (t1, v1);
    }
    None
}

/// The crown figures of the prepared `mesh` (its points `cut` where inside the original tooth),
/// measured against the original tooth (`original`) and the prepared one (`prepared`), each a
/// set of readers whose level-set value at a point `value` gives.
#[allow(clippy::too_many_arguments)]
pub fn measure(
    mesh: &TriMesh,
    cut: &[bool],
    axis: DVec3,
    h: f64,
    original: &mut [Reader],
    prepared: &mut [Reader],
    value: impl Fn(&mut [Reader], DVec3) -> f64 + Copy,
) -> Option<CrownFigures> {
    let readers = original;
    let a = axis.normalize();
    let pts: Vec<DVec3> = mesh.points.iter().map(|p| p.as_dvec3()).collect();
    let tris: Vec<([DVec3; 3], DVec3, f64)> = mesh
        .triangles
        .iter()
        .filter(|t| t.iter().all(|v| cut[*v as usize]))
        .map(|t| {
            let [p0, p1, p2] = t.map(|v| pts[v as usize]);
            let n = (p1 - p0).cross(p2 - p0);
            let area = 0.5 * n.length();
            ([p0, p1, p2], n.normalize_or_zero(), area)
        })
        .filter(|(_, _, area)| *area > 0.0)
        .collect();
    if tris.is_empty() {
        return None;
    }
    // The axis line through the cut surface's centre; heights along it.
    let total: f64 = tris.iter().map(|t| t.2).sum();
    let centre = tris.iter().map(|(p, _, area)| (p[0] + p[1] + p[2]) / 3.0 * *area).sum::<DVec3>() / total;
    let height = |p: DVec3| (p - centre).dot(a);
    let radial = |p: DVec3| {
        let r = (p - centre) - a * height(p);
        r.normalize_or_zero()
    };
    let margin = tris.iter().flat_map(|(p, _, _)| p.iter().map(|q| height(*q))).fold(f64::INFINITY, f64::min);
    let top = tris.iter().flat_map(|(p, _, _)| p.iter().map(|q| height(*q))).fold(f64::NEG_INFINITY, f64::max);
    let limit = 10.0;
    let (mut wall_area, mut incline, mut undercut_area) = (0.0, 0.0, 0.0);
    let (mut axial_sum, mut axial_n, mut axial_min) = (0.0, 0usize, f64::INFINITY);
    let (mut margin_sum, mut margin_n, mut radius_sum) = (0.0, 0usize, 0.0);
    let (mut occlusal_sum, mut occlusal_area) = (0.0, 0.0);
    for (p, facet, area) in &tris {
        let c = (p[0] + p[1] + p[2]) / 3.0;
        // The surface's normal from the preparation's level set (central differences a voxel
        // apart): a voxel mesh's facets step, and their own normals lean by tens of degrees.
        let g = DVec3::new(
            value(prepared, c + DVec3::X * h) - value(prepared, c - DVec3::X * h),
            value(prepared, c + DVec3::Y * h) - value(prepared, c - DVec3::Y * h),
            value(prepared, c + DVec3::Z * h) - value(prepared, c - DVec3::Z * h),
        );
        let n = &if g.length() > 0.0 { g.normalize() } else { *facet };
        let along = n.dot(a);
        if along.abs() < WALL_MAX_NORMAL_ALONG {
            // Inclination: positive when the wall leans in toward the occlusal end.
            // The taper from the walls' straight run: within a few voxels of the margin or the
            // top they round into the shoulder and the occlusal surface.
            let z = height(c);
            if z > margin + 3.0 * h && z < top - 3.0 * h {
                wall_area += area;
                incline += along.asin().to_degrees() * area;
            }
            // Hidden from the path: from just outside the wall, straight along the axis to the
            // preparation's top, the ray meets the preparation's material again.
            let start = c + *n * (0.5 * h);
            let steps = ((top - height(start)).max(0.0) / (0.5 * h)).ceil() as usize;
            if (1..=steps).any(|k| value(prepared, start + a * (0.5 * h * k as f64)) < -0.5 * h) {
                undercut_area += area;
            }
            let out = radial(c);
            if let Some(d) = probe(readers, value, c, out, h, limit) {
                axial_sum += d;
                axial_n += 1;
                axial_min = axial_min.min(d);
                if height(c) - margin < 3.0 * h {
                    margin_sum += d;
                    margin_n += 1;
                    radius_sum += ((c - centre) - a * height(c)).length();
                }
            }
        } else if along > FACE_MIN_NORMAL_ALONG && height(c) > (margin + top) / 2.0 {
            if let Some(d) = probe(readers, value, c, a, h, limit) {
                occlusal_sum += d * area;
                occlusal_area += area;
            }
        }
    }
    if wall_area == 0.0 {
        return None;
    }
    let width = if margin_n > 0 { 2.0 * radius_sum / margin_n as f64 } else { f64::NAN };
    let height_mm = top - margin;
    Some(CrownFigures {
        axis: a.to_array(),
        taper_deg: 2.0 * incline / wall_area,
        occlusal_reduction_mm: if occlusal_area > 0.0 { occlusal_sum / occlusal_area } else { 0.0 },
        axial_reduction_mean_mm: if axial_n > 0 { axial_sum / axial_n as f64 } else { f64::NAN },
        axial_reduction_min_mm: axial_min,
        margin_width_mm: if margin_n > 0 { margin_sum / margin_n as f64 } else { f64::NAN },
        undercut: undercut_area > 0.05,
        undercut_area_mm2: undercut_area,
        height_mm,
        width_mm: width,
        height_to_width: height_mm / width,
    })
}

/// The tooth's long axis from its surface points (the direction of greatest spread), turned
/// toward `toward` (e.g. where the cut is).
pub fn long_axis(points: &[DVec3], toward: DVec3) -> DVec3 {
    let n = points.len().max(1) as f64;
    let mean = points.iter().sum::<DVec3>() / n;
    let mut cov = glam::DMat3::ZERO;
    for p in points {
        let d = *p - mean;
        cov += glam::DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    }
    // Power iteration: the dominant eigenvector.
    let mut v = DVec3::new(0.3, 0.5, 0.8).normalize();
    for _ in 0..100 {
        v = (cov * v).normalize_or_zero();
        if v == DVec3::ZERO {
            return DVec3::Z;
        }
    }
    if (toward - mean).dot(v) < 0.0 {
        -v
    } else {
        v
    }
}
