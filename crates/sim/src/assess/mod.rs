//! How good a preparation is: what it removed from each tissue; against a reference preparation,
//! how much it over- and under-cut and how far its surface lies from the reference's; how much
//! dentin it left over the pulp and whether it opened the pulp; each figure graded against the
//! ranges in docs/REFERENCE.md ("Preparation assessment").
//!
//! Volumes come from the level sets (their CSG); distances from the meshed surfaces, exact to
//! the triangles ([`nearest`]), since a level set's band ends a few voxels from its surface.
pub mod crown;
pub mod nearest;
pub mod report;
pub mod session;

use std::collections::BTreeMap;

use dentsim_vdb::{LevelSet, TriMesh};
use serde::Serialize;

use crate::error::{invalid, Result};
use crate::tissues::{surface, TissueModel};
use crown::CrownFigures;
use nearest::NearestSurface;

/// What kind of preparation is assessed: a cavity (the default), or a crown preparation with its
/// path of insertion (default: the tooth's long axis, turned toward the cut).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Kind {
    #[default]
    Cavity,
    Crown { axis: Option<glam::DVec3> },
}

/// The tissues that make up the tooth whose outer surface is prepared.
pub const TOOTH_TISSUES: [&str; 4] = ["enamel", "dentin", "pulp", "caries"];
/// Dentin left over the pulp below this (mm) is graded as too thin: the live warning's threshold.
pub const MIN_REMAINING_DENTIN_MM: f64 = crate::haptics::guidance::THIN_DENTIN_MM;

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
    /// A crown preparation's form (`Kind::Crown`; None when no axial wall was cut).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crown: Option<CrownFigures>,
    /// Points of the prepared surface that the preparation cut (inside the original tooth).
    pub cut_surface_points: usize,
    pub grades: Vec<Grade>,
    /// When a session was assessed: its folder, the tick, and its live guidance events.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub session: Option<session::SessionPoint>,
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

/// One line of an assessment's table: a figure, graded when it has a range.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub criterion: String,
    pub value: f64,
    pub unit: String,
    pub range: String,
    /// "ideal", "acceptable", "out_of_range", or empty for an ungraded figure.
    pub verdict: String,
    pub source: String,
}

impl Assessment {
    /// Every figure as a table (a ParaView table, a report): the volumes, the deviation, the
    /// pulp, the crown's form, then the grades.
    pub fn rows(&self) -> Vec<Row> {
        let figure = |criterion: String, value: f64, unit: &str| Row { criterion, value, unit: unit.into(), range: String::new(), verdict: String::new(), source: String::new() };
        let mut rows = Vec::new();
        for (name, t) in &self.tissues {
            rows.push(figure(format!("{name} removed"), t.removed_mm3, "mm³"));
            if let (Some(o), Some(u)) = (t.overcut_mm3, t.undercut_mm3) {
                rows.push(figure(format!("{name} over-cut"), o, "mm³"));
                rows.push(figure(format!("{name} under-cut"), u, "mm³"));
            }
        }
        if let Some(d) = &self.deviation_mm {
            for (what, v) in [("mean", d.mean), ("mean |deviation|", d.mean_abs), ("p95", d.p95), ("min", d.min), ("max", d.max)] {
                rows.push(figure(format!("deviation {what}"), v, "mm"));
            }
        }
        rows.push(figure("pulp exposed area".into(), self.pulp_exposed_area_mm2, "mm²"));
        if let Some(c) = &self.crown {
            rows.push(figure("axial reduction (least)".into(), c.axial_reduction_min_mm, "mm"));
            rows.push(figure("width at the margin".into(), c.width_mm, "mm"));
        }
        for g in &self.grades {
            let verdict = match g.verdict {
                Verdict::Ideal => "ideal",
                Verdict::Acceptable => "acceptable",
                Verdict::OutOfRange => "out_of_range",
            };
            rows.push(Row { criterion: g.criterion.clone(), value: g.value, unit: g.unit.clone(), range: g.range.clone(), verdict: verdict.into(), source: g.source.clone() });
        }
        rows
    }
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
    assess_as(prepared, original, reference, Kind::Cavity)
}

/// [`assess`] a preparation of a given [`Kind`].
pub fn assess_as(prepared: &TissueModel, original: &TissueModel, reference: Option<&TissueModel>, kind: Kind) -> Result<Assessment> {
    assess_until(prepared, original, reference, kind, &mut |_| true)
}

/// [`assess_as`], calling `go_on(fraction)` between its steps; when it answers false the
/// assessment stops there with an error ([`crate::error::STOPPED`]): how a GUI's abort reaches it.
pub fn assess_until(prepared: &TissueModel, original: &TissueModel, reference: Option<&TissueModel>, kind: Kind, go_on: &mut dyn FnMut(f64) -> bool) -> Result<Assessment> {
    let mut step = |fraction: f64| if go_on(fraction) { Ok(()) } else { Err(crate::error::stopped("assessment")) };
    step(0.0)?;
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
    step(0.15)?;
    let prepared_tooth = Tooth::of(prepared, "prepared model")?;
    step(0.3)?;
    let original_tooth = Tooth::of(original, "original model")?;
    step(0.45)?;
    let reference_tooth = reference.map(|r| Tooth::of(r, "reference model")).transpose()?;
    step(0.6)?;
    let mut prepared_tooth_readers = prepared_tooth.readers();
    let mesh = drop_unused_points(prepared_tooth.mesh.clone());
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
    step(0.7)?;

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

    step(0.8)?;
    // The pulp: exposure where the prepared surface runs inside the original pulp, and the
    // thinnest dentin between the cut surface and the pulp elsewhere.
    let (mut min_dentin, mut exposed_area) = (None, 0.0);
    if let Some(pulp) = original.get("pulp") {
        // Inside the pulp the grid's sign says so (a band value or an inside tile).
        let mut reader = pulp.grid.reader();
        let inside: Vec<f64> = points.iter().map(|p| f64::from(reader.value(*p))).collect();
        // Only a cut that took pulp opens it (a voxel's worth, far above rounding): where the
        // pulp's own surface turns a sharp corner its mesh cuts inside it, and those facets are
        // no opening.
        let pulp_lost = tissues.get("pulp").is_some_and(|t| t.removed_mm3 > h * h * h);
        for t in mesh.triangles.iter().filter(|_| pulp_lost) {
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
    step(0.9)?;
    let crown = match kind {
        Kind::Cavity => None,
        Kind::Crown { axis } => {
            let axis = match axis {
                Some(a) if a.is_finite() && a.length() > 0.0 => a,
                Some(a) => return Err(invalid("path of insertion", format!("{a} is not a direction"))),
                None => {
                    let cut_points: Vec<glam::DVec3> = points.iter().zip(&cut).filter(|(_, c)| **c).map(|(p, _)| *p).collect();
                    let toward = cut_points.iter().sum::<glam::DVec3>() / cut_points.len().max(1) as f64;
                    let all: Vec<glam::DVec3> = original_tooth.mesh.points.iter().map(|p| p.as_dvec3()).collect();
                    crown::long_axis(&all, toward)
                }
            };
            crown::measure(&mesh, &cut, axis, h, &mut original_readers, &mut prepared_tooth_readers, Tooth::value)
        }
    };
    let mut grades = Vec::new();
    if let Some(c) = &crown {
        grades.extend(crown_grades(c));
    }
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
    // Done: the answer no longer matters.
    go_on(1.0);
    Ok(Assessment { tissues, deviation_mm, min_remaining_dentin_mm: min_dentin, pulp_exposed, pulp_exposed_area_mm2: exposed_area, crown, cut_surface_points, grades, session: None, surface })
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

/// A crown preparation's figures against docs/REFERENCE.md ("Preparation assessment"): within
/// `ideal` is ideal, within `acceptable` acceptable, else out of range.
fn crown_grades(c: &CrownFigures) -> Vec<Grade> {
    let grade = |criterion: &str, value: f64, unit: &str, ideal: (f64, f64), acceptable: (f64, f64), source: &str| {
        let within = |(lo, hi): (f64, f64)| value >= lo && value <= hi;
        let show = |(lo, hi): (f64, f64)| if hi.is_infinite() { format!(">= {lo}") } else { format!("{lo}–{hi}") };
        Grade {
            criterion: criterion.into(),
            value,
            unit: unit.into(),
            range: format!("ideal {}, acceptable {}", show(ideal), show(acceptable)),
            verdict: if within(ideal) { Verdict::Ideal } else if within(acceptable) { Verdict::Acceptable } else { Verdict::OutOfRange },
            source: source.into(),
        }
    };
    vec![
        grade("total occlusal convergence", c.taper_deg, "deg", (4.0, 14.0), (4.0, 20.0), "Rafeek 2010 (ideal); Goodacre 2001, J Prosthet Dent (acceptable 10–20)"),
        grade("occlusal reduction", c.occlusal_reduction_mm, "mm", (1.5, 2.0), (1.0, 2.5), "REFERENCE.md: 1.5–2 mm; prepCheck flags < 1 mm"),
        grade("axial reduction (mean)", c.axial_reduction_mean_mm, "mm", (1.0, 1.5), (0.5, 2.0), "REFERENCE.md: 1.2–1.5 buccal, 0.5–0.7 palatal; prepCheck flags > 2 mm"),
        grade("margin width", c.margin_width_mm, "mm", (1.0, 1.5), (0.5, 2.0), "REFERENCE.md: 1–1.5 mm recommended"),
        grade("undercut area", c.undercut_area_mm2, "mm²", (0.0, 0.05), (0.0, 0.05), "REFERENCE.md: no undercut along the path of insertion"),
        grade("height", c.height_mm, "mm", (4.0, f64::INFINITY), (3.0, f64::INFINITY), "REFERENCE.md: ≥ 4 mm on molars, 3 mm elsewhere"),
        grade("height / width", c.height_to_width, "", (0.4, f64::INFINITY), (0.4, f64::INFINITY), "REFERENCE.md: ≥ 0.4"),
    ]
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
