//! The phantom family's sweep at the scan's grid: each case calibrated and segmented, its
//! tissue volumes (voxel counts) against the analytic ones. `full` for the whole family.
use dentsim_cbct::*;
use std::time::Instant;

fn main() {
    let full = std::env::args().any(|a| a == "full");
    let only: Option<usize> = std::env::args().nth(1).and_then(|a| a.parse().ok());
    for (n, case) in phantom::family(full).into_iter().enumerate() {
        if only.is_some_and(|o| o != n) {
            continue;
        }
        let t = Instant::now();
        let ph = Phantom::new(&case.spec);
        let scan = ph.scan();
        let fdi = ph.tooth();
        let truth_grey = |l: Label| case.spec.scale as f64 * l.typical_hu() + case.spec.offset as f64;
        print!("{n:2} {:70} {:?} ", case.name, scan.dims);
        let cal = match calibrate(&scan) {
            Ok(c) => c,
            Err(e) => {
                println!("REFUSED {e}");
                continue;
            }
        };
        let contrast = truth_grey(Label::Enamel) - truth_grey(Label::Dentin);
        print!("conf {:.2} dentin {:+.2} enamel {:+.2} ", cal.confidence, (cal.peak(Label::Dentin) - truth_grey(Label::Dentin)) / contrast, (cal.peak(Label::Enamel) - truth_grey(Label::Enamel)) / contrast);
        let opts = SegmentOptions { tooth: Some(ToothSelect { fdi, seed: ph.tooth_seed(fdi).unwrap(), bounds: None }), ..Default::default() };
        match segment(&scan, &cal, &opts) {
            Ok(seg) => {
                let vols = ph.tooth_volumes_mm3(fdi);
                for l in [Label::Enamel, Label::Dentin, Label::Pulp] {
                    let (tv, sv) = (vols[l as usize], seg.volume_mm3(l));
                    print!("{} {:+.1}% ", l.name(), 100.0 * (sv - tv) / tv);
                }
            }
            Err(e) => print!("segment failed: {e}"),
        }
        println!("{:.1}s", t.elapsed().as_secs_f64());
        if std::env::args().any(|a| a == "-v") {
            println!("     measured {:?}; thresholds {}", cal.measured, cal.thresholds.iter().map(|t| format!("{}|{} {:.1}", t.below, t.above, t.value)).collect::<Vec<_>>().join(", "));
            for l in &cal.evidence {
                println!("     {l}");
            }
        }
    }
}
