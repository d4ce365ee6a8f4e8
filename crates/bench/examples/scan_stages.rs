//! The scan rows' stages with their results' fingerprints, to compare a change against a base
//! binary (same output = same results). `scan_stages [arch] [reps=N]`: without `arch`, one tooth
//! of the 400×400×300 bench scan (`segment_scan`); with it, every tooth of the 16-tooth arch
//! (`all_teeth_arch`). The scan is cached as raw f32 in the temporary folder (making it is not
//! what the rows time). Prints each run's stage times, then per tooth its tissues' volumes and
//! grid content hashes, and the peak resident memory.
use dentsim_cbct::{Phantom, PhantomSpec, SourceInfo, Volume};
use dentsim_sim::tissues::from_scan::TissuesFromScan;
use dentsim_sim::tissues::table::TissueTable;
use std::time::Instant;

fn cached_scan(spec: &PhantomSpec, name: &str) -> Volume {
    let phantom = Phantom::new(spec);
    let path = std::env::temp_dir().join(format!("dentsim_scan_stages_{name}.f32"));
    let n: usize = spec.dims.iter().product();
    if let Ok(bytes) = std::fs::read(&path) {
        if bytes.len() == 4 * n {
            let values = bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
            // As `Phantom::scan` makes it.
            let source = SourceInfo {
                format: "phantom".into(),
                path: format!("phantom:seed={}", spec.seed),
                modality: Some("CT".into()),
                manufacturer: Some("dentsim phantom".into()),
                ..Default::default()
            };
            return Volume { dims: spec.dims, spacing: spec.spacing(), origin: phantom.origin, direction: spec.direction(), values, source };
        }
    }
    let scan = phantom.scan();
    let _ = std::fs::write(&path, scan.values.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>());
    scan
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arch = args.iter().any(|a| a == "arch");
    let reps: usize = args.iter().find_map(|a| a.strip_prefix("reps=")).map_or(1, |s| s.parse().expect("reps=N"));
    let spec = if arch { PhantomSpec::arch(36) } else { PhantomSpec::benchmark() };
    let scan = cached_scan(&spec, if arch { "arch36" } else { "bench" });
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    let table = TissueTable::default();
    let mut last = Vec::new();
    for rep in 0..reps {
        let start = Instant::now();
        let teeth = if arch {
            TissuesFromScan::default().run_all(&scan, &table, &mut |_, _| {}).expect("run_all")
        } else {
            let seed = Phantom::new(&spec).tooth_seed(36);
            vec![TissuesFromScan { seed_mm: seed, ..Default::default() }.run(&scan, &table, &mut |_, _| {}).expect("run")]
        };
        let total = start.elapsed().as_secs_f64();
        let sum = |f: &dyn Fn(&dentsim_sim::tissues::from_scan::Timings) -> f64| teeth.iter().map(|(_, r)| f(&r.seconds)).sum::<f64>();
        println!(
            "run {rep}: total {total:.3} s; summed over teeth: calibrate {:.3} segment {:.3} crop {:.3} canals {:.3} level_sets {:.3}",
            sum(&|s| s.calibrate),
            sum(&|s| s.segment),
            sum(&|s| s.crop),
            sum(&|s| s.canals),
            sum(&|s| s.level_sets)
        );
        last = teeth;
    }
    for (k, (model, report)) in last.iter().enumerate() {
        let tissues: Vec<String> = report.tissues.iter().map(|t| format!("{} {:.4} mm3 ({} scan voxels)", t.name, t.volume_mm3, t.scan_voxels)).collect();
        let hashes: Vec<String> = model.tissues.iter().map(|t| format!("{:016x}", t.grid.content_hash())).collect();
        println!("tooth {}: crop {:?}..{:?} {} | {}", k + 1, report.crop_min, report.crop_max, tissues.join(", "), hashes.join(" "));
    }
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    println!("{}", status.lines().find(|l| l.starts_with("VmHWM")).unwrap_or("VmHWM: ?"));
}
