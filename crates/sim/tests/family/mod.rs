//! One case of the phantom family through the whole pipeline (calibrate, segment, level sets),
//! measured against the analytic tooth: volume error, mean surface distance and mean normal
//! error per tissue. Shared by tests/family_sweep.rs and examples/family_sweep.rs.
#![allow(dead_code)]

use dentsim_cbct::phantom::FamilyCase;
use dentsim_cbct::{Label, Phantom};
use dentsim_sim::tissues::from_scan::TissuesFromScan;
use dentsim_sim::tissues::table::TissueTable;
use glam::DVec3;

/// One tissue's figures.
#[derive(Debug, Clone)]
pub struct TissueError {
    pub label: Label,
    pub volume_error: f64,
    /// mean |true SDF| at our surface's vertices, mm
    pub surface_mm: f64,
    /// mean angle between our triangles' normals and the true SDF's gradient, degrees
    pub normal_deg: f64,
}

pub struct CaseResult {
    pub name: String,
    pub tissues: Vec<TissueError>,
    pub confidence: f64,
    pub seconds: f64,
    /// The pulp's true volume, its scan voxels' volume, its partial-volume measure and the
    /// surface's offset to it (mm³, mm³, mm³, mm): where the pulp's error comes from.
    pub pulp: Option<(f64, f64, f64, f64)>,
    /// The scan's blur segmentation read from the tooth's edge profile (σ, mm).
    pub edge_blur_mm: Option<f64>,
    /// The periodontal ligament's width segmentation read from the roots' profile (mm).
    pub ligament_mm: Option<f64>,
}

/// The goals: enamel and dentin volume within 2 %, pulp within 5 %, mean surface
/// distance ≤ 0.05 mm, mean normal error ≤ 5°.
pub fn meets_goals(t: &TissueError) -> bool {
    let volume = if t.label == Label::Pulp { 0.05 } else { 0.02 };
    t.volume_error.abs() <= volume && t.surface_mm <= 0.05 && t.normal_deg <= 5.0
}

pub fn run(case: &FamilyCase, voxel_mm: f64) -> Result<CaseResult, String> {
    let start = std::time::Instant::now();
    let phantom = Phantom::new(&case.spec);
    let scan = phantom.scan();
    let fdi = phantom.tooth();
    let request = TissuesFromScan { seed_mm: phantom.tooth_seed(fdi), fdi, voxel_size_mm: voxel_mm, ..Default::default() };
    let (model, report) = request.run(&scan, &TissueTable::default(), &mut |_, _| {}).map_err(|e| format!("{}: {e}", case.name))?;
    let truth = phantom.tooth_volumes_mm3(fdi);
    let mut tissues = Vec::new();
    for label in [Label::Enamel, Label::Dentin, Label::Pulp] {
        let tissue = model.get(label.name()).ok_or_else(|| format!("{}: no {}", case.name, label.name()))?;
        let sdf = |p: DVec3| phantom.tooth_sdf(fdi, label, p).unwrap_or(f64::INFINITY);
        let (dist, angle) = mesh_errors(&tissue.grid.to_mesh(), sdf);
        tissues.push(TissueError { label, volume_error: tissue.grid.volume() / truth[label as usize] - 1.0, surface_mm: dist, normal_deg: angle });
    }
    let voxel_mm3 = scan.voxel_volume_mm3();
    let pulp = report.tissues.iter().find(|t| t.name == Label::Pulp.name()).map(|t| {
        let measure = t.partial_volume.as_ref().map_or(f64::NAN, |m| m.volume_mm3);
        (truth[Label::Pulp as usize], t.scan_voxels as f64 * voxel_mm3, measure, t.surface_offset_mm)
    });
    Ok(CaseResult { name: case.name.clone(), tissues, confidence: report.calibration.confidence, seconds: start.elapsed().as_secs_f64(), pulp, edge_blur_mm: report.edge_blur_mm, ligament_mm: report.ligament_mm })
}

pub fn print(r: &CaseResult) {
    print!("{:70} conf {:.2}", r.name, r.confidence);
    for t in &r.tissues {
        print!(" | {} {:+.1}% {:.3} mm {:.1}°{}", t.label.name(), 100.0 * t.volume_error, t.surface_mm, t.normal_deg, if meets_goals(t) { "" } else { " ✗" });
    }
    println!(" | {:.1} s", r.seconds);
}

/// The metric's floor: the same measures on the analytic tooth's own level set at `voxel_mm`.
pub fn floor(case: &FamilyCase, voxel_mm: f64) -> Vec<(Label, f64, f64)> {
    let phantom = Phantom::new(&case.spec);
    let fdi = phantom.tooth();
    let (lo, hi) = phantom.tooth_bounds(fdi).unwrap();
    let (lo, hi) = (DVec3::from_array(lo) - 1.0, DVec3::from_array(hi) + 1.0);
    [Label::Enamel, Label::Dentin, Label::Pulp]
        .into_iter()
        .map(|label| {
            let sdf = |p: DVec3| phantom.tooth_sdf(fdi, label, p).unwrap_or(f64::INFINITY);
            let grid = dentsim_vdb::LevelSet::from_sdf(voxel_mm, 3.0, lo, hi, sdf).unwrap();
            let (dist, angle) = mesh_errors(&grid.to_mesh(), sdf);
            (label, dist, angle)
        })
        .collect()
}

/// Mean |true SDF| (mm) at the triangles' centres and mean angle (degrees) between their normals
/// and the SDF's gradient, over at most ~20,000 triangles spread over the mesh.
fn mesh_errors(mesh: &dentsim_vdb::TriMesh, sdf: impl Fn(DVec3) -> f64) -> (f64, f64) {
    let (mut dist, mut angle, mut n) = (0.0, 0.0, 0usize);
    for (centre, a) in triangle_angles(mesh, 20000, &sdf) {
        dist += sdf(centre).abs();
        angle += a;
        n += 1;
    }
    let n = n.max(1) as f64;
    (dist / n, angle / n)
}

/// Over at most ~`most` triangles spread over the mesh, each one's centre and the angle
/// (degrees) between its normal and `sdf`'s gradient there; degenerate triangles and points
/// where the gradient is not defined are left out.
fn triangle_angles<'a>(mesh: &'a dentsim_vdb::TriMesh, most: usize, sdf: &'a impl Fn(DVec3) -> f64) -> impl Iterator<Item = (DVec3, f64)> + 'a {
    let step = (mesh.triangles.len() / most).max(1);
    mesh.triangles.iter().step_by(step).filter_map(move |tri| {
        let [a, b, c] = tri.map(|i| mesh.points[i as usize].as_dvec3());
        let normal = (b - a).cross(c - a);
        if normal.length() < 1e-12 {
            return None;
        }
        let centre = (a + b + c) / 3.0;
        let h = 1e-3;
        let grad = DVec3::new(
            sdf(centre + DVec3::X * h) - sdf(centre - DVec3::X * h),
            sdf(centre + DVec3::Y * h) - sdf(centre - DVec3::Y * h),
            sdf(centre + DVec3::Z * h) - sdf(centre - DVec3::Z * h),
        );
        if grad.length() < 1e-9 || !grad.is_finite() {
            return None;
        }
        Some((centre, normal.normalize().dot(grad.normalize()).clamp(-1.0, 1.0).acos().to_degrees()))
    })
}

/// What the scan's resolution allows a reconstruction that does not sharpen: each tissue's
/// indicator blurred by the scan's point spread (its Gaussian and the voxel's box, taken as a
/// Gaussian of the box's variance along each world axis), without noise or grey steps, and
/// its half-way surface at `voxel_mm`; the same measures as [`run`]. Sampled at 0.1 mm, the
/// spline's own blur (σ² = ⅓ sample²) taken out of the point spread; `sampled`: then sampled
/// on the scan's grid and reconstructed by the pipeline's spline there, as the scan gives it.
pub fn resolution_floor(case: &FamilyCase, voxel_mm: f64, sampled: bool) -> Vec<(Label, f64, f64)> {
    let phantom = Phantom::new(&case.spec);
    let fdi = phantom.tooth();
    resolution_floor_grids(case, voxel_mm, sampled)
        .into_iter()
        .map(|(label, grid)| {
            let (dist, angle) = mesh_errors(&grid.to_mesh(), |p| phantom.tooth_sdf(fdi, label, p).unwrap_or(f64::INFINITY));
            (label, dist, angle)
        })
        .collect()
}

/// The floor's surfaces of [`resolution_floor`].
pub fn resolution_floor_grids(case: &FamilyCase, voxel_mm: f64, sampled: bool) -> Vec<(Label, dentsim_vdb::LevelSet)> {
    use dentsim_sim::tissues::field::{level_set_from_field_with, GridField, Kernel};
    use rayon::prelude::*;
    let phantom = Phantom::new(&case.spec);
    let fdi = phantom.tooth();
    let (lo, hi) = phantom.tooth_bounds(fdi).unwrap();
    let (lo, hi) = (DVec3::from_array(lo) - 1.0, DVec3::from_array(hi) + 1.0);
    let g = 0.1;
    let dims = ((hi - lo) / g).ceil().as_uvec3().to_array().map(|n| n as usize + 1);
    let spacing = case.spec.spacing();
    let sigma = [0, 1, 2].map(|c| (case.spec.blur_sigma_mm.powi(2) + spacing[c].powi(2) / 12.0 - g * g / 3.0).max(0.0).sqrt() / g);
    let index_to_world = [g, 0.0, 0.0, lo.x, 0.0, g, 0.0, lo.y, 0.0, 0.0, g, lo.z, 0.0, 0.0, 0.0, 1.0];
    [Label::Enamel, Label::Dentin, Label::Pulp]
        .into_iter()
        .map(|label| {
            let sdf = |p: DVec3| phantom.tooth_sdf(fdi, label, p).unwrap_or(f64::INFINITY);
            let mut values: Vec<f32> = (0..dims[0] * dims[1] * dims[2])
                .into_par_iter()
                .map(|n| {
                    let (i, j, k) = (n % dims[0], (n / dims[0]) % dims[1], n / (dims[0] * dims[1]));
                    let p = lo + DVec3::new(i as f64, j as f64, k as f64) * g;
                    (0.5 - sdf(p) / g).clamp(0.0, 1.0) as f32
                })
                .collect();
            dentsim_cbct::phantom::gaussian_blur(&mut values, dims, sigma);
            let grid = if sampled {
                // On the scan's grid (its spacing along the world axes), as a scan samples it.
                let fine = GridField { dims, index_to_world, values: &values };
                let coarse_dims = [0, 1, 2].map(|c| ((hi[c] - lo[c]) / spacing[c]).floor() as usize + 1);
                let coarse: Vec<f32> = (0..coarse_dims.iter().product::<usize>())
                    .map(|n| {
                        let ijk = [n % coarse_dims[0], (n / coarse_dims[0]) % coarse_dims[1], n / (coarse_dims[0] * coarse_dims[1])];
                        let u = DVec3::from_array([0, 1, 2].map(|c| ijk[c] as f64 * spacing[c] / g));
                        fine.trilinear_at(u) as f32
                    })
                    .collect();
                let to_world = [spacing[0], 0.0, 0.0, lo.x, 0.0, spacing[1], 0.0, lo.y, 0.0, 0.0, spacing[2], lo.z, 0.0, 0.0, 0.0, 1.0];
                let field = GridField { dims: coarse_dims, index_to_world: to_world, values: &coarse };
                level_set_from_field_with(&field, Kernel::CubicBSpline, 0.5, voxel_mm, 3.0).unwrap()
            } else {
                let field = GridField { dims, index_to_world, values: &values };
                level_set_from_field_with(&field, Kernel::CubicBSpline, 0.5, voxel_mm, 3.0).unwrap()
            };
            (label, grid)
        })
        .collect()
}

/// [`region_errors`]' pulp: its half-width (mm) below which a part is a canal or a horn, and
/// how near the root's outside (mm) such a part is its apex.
const PULP_THIN_MM: f64 = 0.45;
const PULP_APEX_MM: f64 = 0.8;
/// [`region_errors`]' dentin: a root is in bone where bone lies this near (mm; the phantom's
/// ligament is 0.2 mm).
const ROOT_IN_BONE_MM: f64 = 0.5;
/// ... and by the cortex where cortical bone lies within this (mm) too.
const ROOT_BY_CORTEX_MM: f64 = 1.0;

/// `steps` points along each of the six axis directions from `centre`, out to `reach` (mm).
fn along_axes(centre: DVec3, reach: f64, steps: u32) -> impl Iterator<Item = DVec3> {
    (1..=steps).flat_map(move |i| [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z].map(|d| centre + d * (f64::from(i) * reach / f64::from(steps))))
}

/// Where a tissue's normal error lies: its triangles sorted into the tooth's regions by the
/// analytic SDFs at their centres (`h`: the scan's finest spacing). Enamel: the DEJ, the outer
/// surface where the enamel is thinner than `h` (the cervical edge), the rest of the outer
/// surface, and triangles with no true enamel within 2 `h` (slivers); dentin: the pulp's wall,
/// the DEJ by the enamel's thickness over it (under 0.3 mm, to 0.6 mm, more), the outer surface within 2 `h` of the enamel (its edge) and the rest of the root,
/// clear of bone, in it, and in it by the cortex;
/// pulp: its chamber, its thin parts (canals, horns) and their ends at the root's outside.
/// Per region: triangles, mean angle (degrees), mean signed distance from the truth (mm, + outside).
pub fn region_errors(mesh: &dentsim_vdb::TriMesh, phantom: &Phantom, fdi: u8, label: Label, h: f64) -> Vec<(&'static str, usize, f64, f64)> {
    let sdf = |l: Label, p: DVec3| phantom.tooth_sdf(fdi, l, p).unwrap_or(f64::INFINITY);
    let names: &[&'static str] = match label {
        Label::Enamel => &["DEJ", "outer thin", "outer", "no enamel within 2h"],
        Label::Pulp => &["chamber", "thin (canal, horn)", "apex"],
        _ => &["pulp wall", "DEJ, enamel < 0.3 mm", "DEJ, enamel 0.3–0.6 mm", "DEJ, thicker enamel", "root at enamel edge", "root", "root in bone", "root by cortex"],
    };
    let mut bins: Vec<(usize, f64, f64)> = vec![(0, 0.0, 0.0); names.len()];
    let own = |p: DVec3| sdf(label, p);
    for (centre, angle) in triangle_angles(mesh, 40000, &own) {
        let tooth = sdf(Label::Air, centre);
        if label == Label::Pulp {
            // Thin where the pulp is nowhere deeper than PULP_THIN_MM within reach along an
            // axis; an apex where such a part comes within PULP_APEX_MM of the root's outside.
            let deepest = along_axes(centre, 1.2, 24).map(own).fold(own(centre), f64::min);
            let bin = if deepest < -PULP_THIN_MM { 0 } else if tooth < -PULP_APEX_MM { 1 } else { 2 };
            bins[bin].0 += 1;
            bins[bin].1 += angle;
            bins[bin].2 += own(centre);
            continue;
        }
        // Enamel within 2 h along an axis: the enamel's SDF, max(tooth, −core), is ~0 all over
        // the root, so it cannot tell the root from the enamel's edge by itself.
        let near_enamel = std::iter::once(centre).chain(along_axes(centre, 2.0 * h, 40)).any(|p| sdf(Label::Enamel, p) < -0.005);
        let bin = match label {
            Label::Enamel => {
                let core = sdf(Label::Dentin, centre);
                if !near_enamel {
                    3
                } else if core.abs() < tooth.abs() {
                    0
                } else if core < h {
                    1
                } else {
                    2
                }
            }
            _ => {
                if sdf(Label::Pulp, centre).abs() < tooth.abs() {
                    0
                } else if !near_enamel {
                    // In bone where bone lies within ROOT_IN_BONE_MM along an axis.
                    let in_bone = along_axes(centre, ROOT_IN_BONE_MM, 12).any(|p| matches!(phantom.label_at(p), Label::BoneCancellous | Label::BoneCortical));
                    let by_cortex = || along_axes(centre, ROOT_BY_CORTEX_MM, 20).any(|p| phantom.label_at(p) == Label::BoneCortical);
                    if in_bone && by_cortex() { 7 } else if in_bone { 6 } else { 5 }
                } else if tooth < -0.05 {
                    // A DEJ triangle's depth under the outer surface is the enamel's thickness there.
                    if tooth > -0.3 { 1 } else if tooth > -0.6 { 2 } else { 3 }
                } else {
                    4
                }
            }
        };
        bins[bin].0 += 1;
        bins[bin].1 += angle;
        bins[bin].2 += own(centre);
    }
    names.iter().zip(bins).map(|(n, (count, sum, signed))| (*n, count, sum / count.max(1) as f64, signed / count.max(1) as f64)).collect()
}

/// [`region_errors`] of the pipeline's enamel and dentin and of the sampled resolution floor's,
/// printed side by side.
pub fn print_regions(case: &FamilyCase, voxel_mm: f64) -> Result<(), String> {
    let phantom = Phantom::new(&case.spec);
    let scan = phantom.scan();
    let fdi = phantom.tooth();
    let request = TissuesFromScan { seed_mm: phantom.tooth_seed(fdi), fdi, voxel_size_mm: voxel_mm, ..Default::default() };
    let (model, _) = request.run(&scan, &TissueTable::default(), &mut |_, _| {}).map_err(|e| format!("{}: {e}", case.name))?;
    let h = case.spec.spacing().into_iter().fold(f64::INFINITY, f64::min);
    let floor = resolution_floor_grids(case, voxel_mm, true);
    println!("{}", case.name);
    for label in [Label::Enamel, Label::Dentin, Label::Pulp] {
        let ours = region_errors(&model.get(label.name()).ok_or("no tissue")?.grid.to_mesh(), &phantom, fdi, label, h);
        let theirs = region_errors(&floor.iter().find(|(l, _)| *l == label).unwrap().1.to_mesh(), &phantom, fdi, label, h);
        let (n_ours, n_floor) = (ours.iter().map(|r| r.1).sum::<usize>().max(1) as f64, theirs.iter().map(|r| r.1).sum::<usize>().max(1) as f64);
        let text: Vec<String> = ours
            .iter()
            .zip(&theirs)
            .map(|(o, f)| format!("{} {:.0}%/{:.0}% {:.1}°/{:.1}° {:+.3}/{:+.3} mm (adds {:.2}°)", o.0, 100.0 * o.1 as f64 / n_ours, 100.0 * f.1 as f64 / n_floor, o.2, f.2, o.3, f.3, o.1 as f64 * o.2 / n_ours - f.1 as f64 * f.2 / n_floor))
            .collect();
        println!("  {:7} ours/floor: {}", label.name(), text.join(" | "));
    }
    Ok(())
}

/// Where a tissue's volume error lies: the volume ours holds and the truth does not (+) and the
/// truth holds and ours does not (−), mm³, by the truth's nearest interface, sampled on a
/// `step` mm grid over the tooth's box; what lies past our level set's band (a body of one
/// tissue read as another whole) is its own bin. The phantom's distances are bounds in blended
/// regions, so regions are told apart by which interface is nearer, not by how far.
pub fn volume_regions(case: &FamilyCase, voxel_mm: f64, label: Label, step: f64) -> Result<Vec<(&'static str, f64, f64)>, String> {
    let phantom = Phantom::new(&case.spec);
    let scan = phantom.scan();
    let fdi = phantom.tooth();
    let request = TissuesFromScan { seed_mm: phantom.tooth_seed(fdi), fdi, voxel_size_mm: voxel_mm, ..Default::default() };
    let (model, _) = request.run(&scan, &TissueTable::default(), &mut |_, _| {}).map_err(|e| format!("{}: {e}", case.name))?;
    let grid = &model.get(label.name()).ok_or("no tissue")?.grid;
    let bg = grid.background();
    let (lo, hi) = phantom.tooth_bounds(fdi).ok_or("no tooth")?;
    let (lo, hi) = (DVec3::from(lo) - 0.5, DVec3::from(hi) + 0.5);
    let n = ((hi - lo) / step).ceil().as_ivec3();
    let names = ["pulp wall", "outer surface", "DEJ / enamel", "past our band"];
    let mut bins = [(0.0f64, 0.0f64); 4];
    let mut reader = grid.reader();
    let cell = step * step * step;
    for k in 0..n.z {
        for j in 0..n.y {
            for i in 0..n.x {
                let p = lo + DVec3::new(f64::from(i), f64::from(j), f64::from(k)) * step;
                let v = reader.value(p);
                // Past the band, every fourth sample along each axis stands for its 4³ (the
                // phantom's distance is the cost).
                let past = v.abs() >= 0.999 * bg;
                if past && (i % 4 != 0 || j % 4 != 0 || k % 4 != 0) {
                    continue;
                }
                let cell = if past { 64.0 * cell } else { cell };
                let sdf = |l: Label| phantom.tooth_sdf(fdi, l, p).unwrap_or(f64::INFINITY);
                let truth_in = sdf(label) < 0.0;
                let ours_in = v < 0.0;
                if truth_in == ours_in {
                    continue;
                }
                let (pulp, tooth) = (sdf(Label::Pulp).abs(), sdf(Label::Air));
                let region = if past {
                    3
                } else if label != Label::Pulp && pulp < tooth.abs() && pulp < 0.3 {
                    0
                } else if tooth > -0.15 {
                    1
                } else {
                    2
                };
                if ours_in {
                    bins[region].0 += cell;
                } else {
                    bins[region].1 -= cell;
                }
            }
        }
    }
    Ok(names.iter().zip(bins).map(|(n, (a, b))| (*n, a, b)).collect())
}
