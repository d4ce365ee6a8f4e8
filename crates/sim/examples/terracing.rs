//! A picture of what is left of the scan grid's terraces: one family case's enamel, segmented to
//! 0.05 mm, written as <out>/enamel.vtp with each vertex's angle (degrees) between the surface
//! normal and the analytic enamel's, and the analytic enamel as <out>/analytic_enamel.vtp.
//! Render with plugin/scripts/render_normal_error.py.
//! `cargo run --release -p dentsim-sim --example terracing -- OUT [CASE]` (CASE: index in the
//! fast family, default 1: an upper molar in air at 0.3 mm).
use dentsim_cbct::{Label, Phantom};
use dentsim_sim::tissues::export::write_vtp_with;
use dentsim_sim::tissues::from_scan::TissuesFromScan;
use dentsim_sim::tissues::table::TissueTable;
use dentsim_vdb::LevelSet;
use glam::DVec3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::path::PathBuf::from(std::env::args().nth(1).ok_or("usage: terracing OUT [CASE]")?);
    let index: usize = std::env::args().nth(2).map_or(Ok(1), |a| a.parse())?;
    let case = dentsim_cbct::phantom::family(false).into_iter().nth(index).ok_or("no such case")?;
    std::fs::create_dir_all(&out)?;
    let phantom = Phantom::new(&case.spec);
    let scan = phantom.scan();
    let fdi = phantom.tooth();
    let request = TissuesFromScan { seed_mm: phantom.tooth_seed(fdi), fdi, ..Default::default() };
    let (model, _) = request.run(&scan, &TissueTable::default(), &mut |_, _| {})?;
    let enamel = model.get("enamel").ok_or("no enamel")?;
    let mesh = dentsim_sim::tissues::surface::surface(&enamel.grid)?;
    let sdf = |p: DVec3| phantom.tooth_sdf(fdi, Label::Enamel, p).unwrap_or(f64::INFINITY);
    let error: Vec<f32> = mesh
        .points
        .iter()
        .zip(&mesh.normals)
        .map(|(p, n)| {
            let (p, h) = (p.as_dvec3(), 1e-3);
            let g = DVec3::new(sdf(p + DVec3::X * h) - sdf(p - DVec3::X * h), sdf(p + DVec3::Y * h) - sdf(p - DVec3::Y * h), sdf(p + DVec3::Z * h) - sdf(p - DVec3::Z * h));
            if g.length() < 1e-9 || n.length() < 1e-9 {
                return 0.0;
            }
            n.as_dvec3().normalize().dot(g.normalize()).clamp(-1.0, 1.0).acos().to_degrees() as f32
        })
        .collect();
    let mean = error.iter().map(|&e| f64::from(e)).sum::<f64>() / error.len().max(1) as f64;
    let mut sorted = error.clone();
    sorted.sort_by(f32::total_cmp);
    println!("{}: enamel vertex normal error mean {mean:.1}°, median {:.1}°, 90th percentile {:.1}°", case.name, sorted[sorted.len() / 2], sorted[sorted.len() * 9 / 10]);
    write_vtp_with(&out.join("enamel.vtp"), &mesh, &enamel.props, &[("NormalErrorDeg", &error)])?;
    let (lo, hi) = phantom.tooth_bounds(fdi).ok_or("no bounds")?;
    let truth = LevelSet::from_sdf(0.05, 3.0, DVec3::from_array(lo) - 1.0, DVec3::from_array(hi) + 1.0, sdf)?;
    write_vtp_with(&out.join("analytic_enamel.vtp"), &dentsim_sim::tissues::surface::surface(&truth)?, &enamel.props, &[])?;
    println!("wrote {}/enamel.vtp and analytic_enamel.vtp", out.display());
    Ok(())
}
