//! How good a preparation is: what it removed from each tissue; against a reference preparation,
//! how much it over- and under-cut and how far its surface lies from the reference's; how much
//! dentin it left over the pulp and whether it opened the pulp; each figure graded against the
//! ranges in docs/REFERENCE.md ("Preparation assessment").
//!
//! Volumes come from the level sets (their CSG); distances from the meshed surfaces, exact to
//! the triangles ([`nearest`]), since a level set's band ends a few voxels from its surface.
pub mod nearest;
pub mod report;

use std::collections::BTreeMap;

use dentsim_vdb::{LevelSet, TriMesh};
use serde::Serialize;

use crate::error::{invalid, Result};
use crate::tissues::{surface, TissueModel};
use nearest::NearestSurface;

/// The tissues that make up the tooth whose outer surface is prepared.
pub const TOOTH_TISSUES: [&str; 4] = ["enamel", "dentin", "pulp", "caries"];
/// Dentin left over the pulp below this (mm) is graded as too thin (Murray 2003, REFERENCE.md).
pub const MIN_REMAINING_DENTIN_MM: f64 = 0.5;

/// One tissue's figures.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TissueFigures {
    /// Original minus prepared.
    pub removed_mm3: f64,
    /// Removed here but kept by the reference.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overcut_mm3: Option<f64>,
    /// Removed by the reference but kept here.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub undercut_mm3: Option<f64>,
}

/// The prepared surface's signed distance from the reference surface (mm; positive where the
/// preparation went deeper than the reference), over the surface either of them cut.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Deviation {
    pub mean: f64,
    pub mean_abs: f64,
    pub p95: f64,
    pub min: f64,
    pub max: f64,
    pub points: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Ideal,
    Acceptable,
    OutOfRange,
}

/// One criterion against its literature range.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Grade {
    pub criterion: String,
    pub value: f64,
    pub unit: String,
    pub range: String,
    pub verdict: Verdict,
    pub source: String,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Assessment {
    pub tissues: BTreeMap<String, TissueFigures>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub deviation_mm: Option<Deviation>,
    /// Thinnest dentin between the cut surface and the pulp (0 when the pulp is open; None when
    /// nothing was cut or the tooth has no pulp).
    pub min_remaining_dentin_mm: Option<f64>,
    pub pulp_exposed: bool,
    pub pulp_exposed_area_mm2: f64,
    /// Points of the prepared surface that the preparation cut (inside the original tooth).
    pub cut_surface_points: usize,
    pub grades: Vec<Grade>,
    /// The prepared tooth's surface, with per point: signed deviation from the reference (0
    /// without one) and depth below the original surface (0 where uncut). Not in the JSON.
    #[serde(skip)]
    pub surface: AssessedSurface,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct AssessedSurface {
    pub mesh: TriMesh,
    pub deviation_mm: Vec<f32>,
    pub cut_depth_mm: Vec<f32>,
}

/// The outer surface of a model's tooth tissues, and the grids that tell inside from outside.
/// Tissues that abut (enamel on dentin) both mesh their interface; a triangle of one tissue
/// with a corner within a quarter voxel of another tooth tissue is interface, not
/// surface, and is left out (a union of the grids keeps such a sheet too: both are near zero
/// along it).
struct Tooth<'a> {
    mesh: TriMesh,
    grids: Vec<&'a LevelSet>,
}

impl<'a> Tooth<'a> {
    fn of(model: &'a TissueModel, what: &str) -> Result<Self> {
        let tissues: Vec<_> = model.tissues.iter().filter(|t| TOOTH_TISSUES.contains(&t.props.name.as_str())).collect();
        if tissues.is_empty() {
            return Err(invalid(what, "has none of the tooth tissues (enamel, dentin, pulp, caries)"));
        }
        let h = model.voxel_size().unwrap_or(0.0);
        let mut mesh = TriMesh::default();
        for (k, t) in tissues.iter().enumerate() {
            let own = surface(&t.grid)?;
            let mut others: Vec<_> = tissues.iter().enumerate().filter(|(o, _)| *o != k).map(|(_, o)| o.grid.reader()).collect();
            let outer: Vec<bool> = own.points.iter().map(|p| others.iter_mut().all(|r| f64::from(r.value(p.as_dvec3())) > 0.25 * h)).collect();
            let base = mesh.points.len() as u32;
            mesh.points.extend_from_slice(&own.points);
            mesh.normals.extend_from_slice(&own.normals);
            mesh.triangles.extend(own.triangles.iter().filter(|t| t.iter().all(|v| outer[*v as usize])).map(|t| t.map(|v| v + base)));
        }
        Ok(Tooth { mesh, grids: tissues.iter().map(|t| &t.grid).collect() })
    }

    /// Readers of its grids, for [`Tooth::value`].
    fn readers(&self) -> Vec<dentsim_vdb::Reader<'a>> {
        self.grids.iter().map(|g| g.reader()).collect()
    }

    /// The tooth's level-set value at `p` (the least of its tissues'): its sign says inside.
    fn value(readers: &mut [dentsim_vdb::Reader], p: glam::DVec3) -> f64 {
        readers.iter_mut().map(|r| f64::from(r.value(p))).fold(f64::INFINITY, f64::min)
    }
}

/// Assesses `prepared` against the `original` it was cut from and, when given, a `reference`
/// preparation of the same tooth. The three must share a voxel size and tissue names.
pub fn assess(prepared: &TissueModel, original: &TissueModel, reference: Option<&TissueModel>) -> Result<Assessment> {
    let h = prepared.voxel_size().ok_or_else(|| invalid("prepared model", "has no tissues"))?;
    for (what, m) in [("original model", Some(original)), ("reference model", reference)] {
        if let Some(m) = m {
            let mh = m.voxel_size().ok_or_else(|| invalid(what, "has no tissues"))?;
            if (mh - h).abs() > 1e-9 * h {
                return Err(invalid(what, format!("voxel size {mh} mm differs from the prepared model's {h} mm")));
            }
        }
    }
    let mut tissues = BTreeMap::new();
    for t in &prepared.tissues {
        let name = &t.props.name;
        let before = original.get(name).ok_or_else(|| invalid("original model", format!("has no tissue '{name}' (the prepared model has)")))?;
        let here = t.grid.volume();
        // What both keep, once: over-cut is the reference's material less it, under-cut ours.
        let (overcut, undercut) = match reference {
            Some(r) => {
                let rt = r.get(name).ok_or_else(|| invalid("reference model", format!("has no tissue '{name}' (the prepared model has)")))?;
                let mut both = t.grid.clone();
                both.csg_intersection(&rt.grid)?;
                let kept = both.volume();
                (Some((rt.grid.volume() - kept).max(0.0)), Some((here - kept).max(0.0)))
            }
            None => (None, None),
        };
        tissues.insert(name.clone(), TissueFigures { removed_mm3: before.grid.volume() - here, overcut_mm3: overcut, undercut_mm3: undercut });
    }
    let prepared_tooth = Tooth::of(prepared, "prepared model")?;
    let original_tooth = Tooth::of(original, "original model")?;
    let reference_tooth = reference.map(|r| Tooth::of(r, "reference model")).transpose()?;
    let mesh = drop_unused_points(prepared_tooth.mesh);
    let points: Vec<glam::DVec3> = mesh.points.iter().map(|p| p.as_dvec3()).collect();
    // Tolerance for "on the original surface": meshing puts vertices within a small fraction of
    // a voxel of the zero level; a quarter voxel is far above that and far below a cut.
    let tol = 0.25 * h;
    // The distance from the mesh (exact to its triangles, 0 on the same surface), the sign from
    // the grids (their band or an inside tile says it everywhere).
    let signed = |near: &NearestSurface, p: glam::DVec3, readers: &mut [dentsim_vdb::Reader]| -> f64 { near.distance(p).copysign(Tooth::value(readers, p)) };
    let original_near = NearestSurface::new(&original_tooth.mesh);
    let mut original_readers = original_tooth.readers();
    let cut_depth: Vec<f64> = points.iter().map(|p| (-signed(&original_near, *p, &mut original_readers)).max(0.0)).collect();
    let cut: Vec<bool> = cut_depth.iter().map(|d| *d > tol).collect();
    let cut_surface_points = cut.iter().filter(|c| **c).count();

    let mut deviation = vec![0f64; points.len()];
    let deviation_mm = match &reference_tooth {
        Some(r) => {
            let near = NearestSurface::new(&r.mesh);
            let mut readers = r.readers();
            let mut values = Vec::new();
            for (i, p) in points.iter().enumerate() {
                // Positive where the prepared surface lies inside the reference's material.
                let d = -signed(&near, *p, &mut readers);
                deviation[i] = d;
                if cut[i] || d.abs() > tol {
                    values.push(d);
                }
            }
            Some(deviation_stats(&mut values))
        }
        None => None,
    };

    // The pulp: exposure where the prepared surface runs inside the original pulp, and the
    // thinnest dentin between the cut surface and the pulp elsewhere.
    let (mut min_dentin, mut exposed_area) = (None, 0.0);
    if let Some(pulp) = original.get("pulp") {
        // Inside the pulp the grid's sign says so (a band value or an inside tile).
        let mut reader = pulp.grid.reader();
        let inside: Vec<f64> = points.iter().map(|p| f64::from(reader.value(*p))).collect();
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| i as usize);
            if inside[a] + inside[b] + inside[c] < 0.0 {
                exposed_area += 0.5 * (points[b] - points[a]).cross(points[c] - points[a]).length();
            }
        }
        let pulp_near = NearestSurface::new(&surface(&pulp.grid)?);
        if cut_surface_points > 0 && !pulp_near.is_empty() {
            min_dentin = Some(if exposed_area > 0.0 {
                0.0
            } else {
                points.iter().zip(&cut).filter(|(_, c)| **c).map(|(p, _)| pulp_near.distance(*p)).fold(f64::INFINITY, f64::min)
            });
        }
    }
    let pulp_exposed = exposed_area > 0.0;
    let mut grades = Vec::new();
    if let Some(d) = min_dentin {
        grades.push(Grade {
            criterion: "remaining dentin over the pulp".into(),
            value: d,
            unit: "mm".into(),
            range: format!(">= {MIN_REMAINING_DENTIN_MM}"),
            verdict: if d >= MIN_REMAINING_DENTIN_MM { Verdict::Ideal } else { Verdict::OutOfRange },
            source: "Murray 2003, Int Endod J 36:33".into(),
        });
    }
    let surface = AssessedSurface {
        deviation_mm: deviation.iter().map(|d| *d as f32).collect(),
        cut_depth_mm: cut_depth.iter().map(|d| *d as f32).collect(),
        mesh,
    };
    Ok(Assessment { tissues, deviation_mm, min_remaining_dentin_mm: min_dentin, pulp_exposed, pulp_exposed_area_mm2: exposed_area, cut_surface_points, grades, surface })
}

/// The mesh with only the points its triangles use, re-indexed.
fn drop_unused_points(mesh: TriMesh) -> TriMesh {
    let mut index = vec![u32::MAX; mesh.points.len()];
    let mut out = TriMesh::default();
    for t in &mesh.triangles {
        let mut tri = [0u32; 3];
        for (k, &v) in t.iter().enumerate() {
            if index[v as usize] == u32::MAX {
                index[v as usize] = out.points.len() as u32;
                out.points.push(mesh.points[v as usize]);
                if let Some(n) = mesh.normals.get(v as usize) {
                    out.normals.push(*n);
                }
            }
            tri[k] = index[v as usize];
        }
        out.triangles.push(tri);
    }
    out
}

fn deviation_stats(values: &mut [f64]) -> Deviation {
    if values.is_empty() {
        return Deviation { mean: 0.0, mean_abs: 0.0, p95: 0.0, min: 0.0, max: 0.0, points: 0 };
    }
    values.sort_by(f64::total_cmp);
    let n = values.len() as f64;
    let p95 = values[((0.95 * (n - 1.0)).round() as usize).min(values.len() - 1)];
    Deviation {
        mean: values.iter().sum::<f64>() / n,
        mean_abs: values.iter().map(|v| v.abs()).sum::<f64>() / n,
        p95,
        min: values[0],
        max: values[values.len() - 1],
        points: values.len(),
    }
}

#[cfg(test)]
mod tests;
