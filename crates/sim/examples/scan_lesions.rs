//! ScanToTissues on the molar phantom with the caries lesion (and optionally the restoration) at
//! several blur levels: level-set volumes against the phantom's truth.
//! `cargo run --release -p dentsim-sim --example scan_lesions [metal] [blur=0.15,0.2]`
use dentsim_cbct::{Label, Phantom, PhantomSpec};
use dentsim_sim::scan::ScanToTissues;
use dentsim_sim::tissue::TissueTable;
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
        let request = ScanToTissues { seed_mm: phantom.tooth_seed(36), ..Default::default() };
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
            println!("{blur:.2}  {:<10} {t:8.2} {ours:12.2} {:+7.2}%", label.name(), if t > 0.0 { 100.0 * (ours / t - 1.0) } else { f64::NAN });
        }
        println!("      {secs:.1} s: {:?}", report.seconds);
    }
}
