//! TissuesFromScan on the molar phantom with the caries lesion (and optionally the restoration) at
//! several blur levels: level-set volumes against the phantom's truth.
//! `cargo run --release -p dentsim-sim --example scan_lesions [metal] [blur=0.15,0.2]`
use dentsim_cbct::{Label, Phantom, PhantomSpec};
use dentsim_sim::tissues::from_scan::TissuesFromScan;
use dentsim_sim::tissues::table::TissueTable;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let metal = args.iter().any(|a| a == "metal");
    let caries = !args.iter().any(|a| a == "sound");
    let blurs: Vec<f64> = args.iter().find_map(|a| a.strip_prefix("blur=")).map(|s| s.split(',').map(|x| x.parse().unwrap()).collect()).unwrap_or(vec![0.15]);
    println!("blur  tissue     true mm3  level set mm3  error");
    for blur in blurs {
        let phantom = Phantom::new(&PhantomSpec { caries, restoration: metal, blur_sigma_mm: blur, ..Default::default() });
        let scan = phantom.scan();
        let request = TissuesFromScan { seed_mm: phantom.tooth_seed(36), ..Default::default() };
        let t = Instant::now();
        let (model, report) = request.run(&scan, &TissueTable::default(), &mut |_, _| {}).unwrap();
        let secs = t.elapsed().as_secs_f64();
        let truth = phantom.tooth_volumes_mm3(36);
        for label in [Label::Enamel, Label::Dentin, Label::Pulp, Label::Caries] {
            let t = truth[label as usize];
            let ours = model.get(label.name()).map_or(0.0, |x| x.grid.volume());
            if t == 0.0 && ours == 0.0 {
                continue;
            }
            let msd = model.get(label.name()).map_or(f64::NAN, |x| {
                let mesh = x.grid.to_mesh();
                let step = (mesh.points.len() / 4000).max(1);
                let d: Vec<f64> = mesh.points.iter().step_by(step).map(|p| phantom.tooth_sdf(36, label, p.as_dvec3()).unwrap().abs()).collect();
                d.iter().sum::<f64>() / d.len().max(1) as f64
            });
            println!("{blur:.2}  {:<10} {t:8.2} {ours:12.2} {:+7.2}%   MSD ours->true {msd:.4} mm", label.name(), if t > 0.0 { 100.0 * (ours / t - 1.0) } else { f64::NAN });
        }
        if let Some(x) = model.get("caries") {
            let mesh = x.grid.to_mesh();
            let mut bins = [0usize; 6];
            let mut hi_z = Vec::new();
            let zs: Vec<f64> = mesh.points.iter().map(|p| p.as_dvec3().z).collect();
            let (zmin, zmax) = zs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &z| (a.0.min(z), a.1.max(z)));
            for p in &mesh.points {
                let d = phantom.tooth_sdf(36, Label::Caries, p.as_dvec3()).unwrap();
                let b = if d < -0.2 { 0 } else if d < -0.1 { 1 } else if d < 0.0 { 2 } else if d < 0.1 { 3 } else if d < 0.2 { 4 } else { 5 };
                bins[b] += 1;
                if d > 0.1 {
                    hi_z.push((p.as_dvec3().z - zmin) / (zmax - zmin));
                }
            }
            let mut h = [0usize; 5];
            for z in &hi_z { h[((z * 5.0) as usize).min(4)] += 1; }
            println!("      caries vertices by signed distance (<-0.2, -0.2..-0.1, -0.1..0, 0..0.1, 0.1..0.2, >0.2 mm): {bins:?}; those >0.1 mm out by height (bottom..top fifths): {h:?}");
        }
        println!("      {secs:.1} s: {:?}", report.seconds);
    }
}
