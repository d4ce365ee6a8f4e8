//! Where the time of one tooth from the 400×400×300 bench scan goes (report timings + peak memory).
use dentsim_cbct::{Phantom, PhantomSpec};
use dentsim_sim::tissues::from_scan::TissuesFromScan;
use dentsim_sim::tissues::table::TissueTable;

fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    let spec = if quick { PhantomSpec::default() } else { PhantomSpec::benchmark() };
    let phantom = Phantom::new(&spec);
    let scan = phantom.scan();
    let request = TissuesFromScan { seed_mm: phantom.tooth_seed(36), ..Default::default() };
    let start = std::time::Instant::now();
    let mut last = start;
    let (model, report) = request
        .run(&scan, &TissueTable::default(), &mut |step, _| {
            eprintln!("{:>7.3} s (+{:.3}) {step}", start.elapsed().as_secs_f64(), last.elapsed().as_secs_f64());
            last = std::time::Instant::now();
        })
        .unwrap();
    println!("total {:.3} s {:?}", start.elapsed().as_secs_f64(), report.seconds);
    for t in &report.tissues {
        println!("{} {:.3} mm3 active {}", t.name, t.volume_mm3, t.active_voxels);
    }
    let _ = model;
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    println!("{}", status.lines().find(|l| l.starts_with("VmHWM")).unwrap());
}
