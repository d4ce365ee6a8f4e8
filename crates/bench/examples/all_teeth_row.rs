//! The `all_teeth_arch` row alone (`quick`: the 3-tooth scan), as JSON; `ours`: only our run,
//! with each tooth's timings, its grids' content hashes and when each step began.
use dentsim_cbct::{Phantom, PhantomSpec};
use dentsim_sim::tissues::from_scan::TissuesFromScan;
use dentsim_sim::tissues::table::TissueTable;

fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    if !std::env::args().any(|a| a == "ours") {
        match dentsim_bench::all_teeth(quick) {
            Ok(row) => println!("{}", serde_json::to_string(&row).unwrap_or_default()),
            Err(e) => eprintln!("{e}"),
        }
        return;
    }
    let spec = if quick { PhantomSpec::default() } else { PhantomSpec::arch(36) };
    let scan = Phantom::new(&spec).scan();
    let start = std::time::Instant::now();
    let teeth = TissuesFromScan::default().run_all(&scan, &TissueTable::default(), &mut |step, _| {
        if !step.contains("level set") {
            eprintln!("{:>7.3} s {step}", start.elapsed().as_secs_f64());
        }
    });
    println!("total {:.3} s", start.elapsed().as_secs_f64());
    match teeth {
        Ok(teeth) => {
            for (model, report) in &teeth {
                let s = &report.seconds;
                let hashes: Vec<String> = model.tissues.iter().map(|t| format!("{:016x}", t.grid.content_hash())).collect();
                println!("segment {:.3} level sets {:.3} s, grids {}", s.segment, s.level_sets, hashes.join(" "));
            }
        }
        Err(e) => eprintln!("{e}"),
    }
}
