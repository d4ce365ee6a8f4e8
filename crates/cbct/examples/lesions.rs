//! Segmentation of tooth 36 over scan blur levels, with the caries lesion and the amalgam
//! restoration on or off: volumes against the phantom's truth and Dice per tissue, and the
//! segment time. `cargo run --release -p dentsim-cbct --example lesions [caries] [metal] [blur=0.1,0.2]`
use dentsim_cbct::*;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let caries = args.iter().any(|a| a == "caries");
    let metal = args.iter().any(|a| a == "metal");
    let blurs: Vec<f64> = args
        .iter()
        .find_map(|a| a.strip_prefix("blur="))
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or(vec![0.10, 0.15, 0.18, 0.20, 0.25]);
    println!("caries {caries} metal {metal}");
    println!("blur  tissue     true mm3   seg mm3   error    Dice");
    for blur in blurs {
        let ph = Phantom::new(&PhantomSpec { caries, restoration: metal, blur_sigma_mm: blur, ..Default::default() });
        let scan = ph.scan();
        let cal = calibrate(&scan).unwrap();
        let opts = SegmentOptions { tooth: Some(ToothSelect { fdi: 36, seed: ph.tooth_seed(36).unwrap(), bounds: None }), ..Default::default() };
        let reps: usize = args.iter().find_map(|a| a.strip_prefix("reps=")).map_or(1, |s| s.parse().unwrap());
        let mut secs = f64::INFINITY;
        let mut seg = None;
        let cpu0 = cpu_seconds();
        for _ in 0..reps {
            let t = Instant::now();
            seg = Some(segment(&scan, &cal, &opts).unwrap());
            secs = secs.min(t.elapsed().as_secs_f64());
        }
        let cpu = (cpu_seconds() - cpu0) / reps as f64;
        let seg = seg.unwrap();
        let truth = ph.tooth_labels(36);
        let all = ph.labels();
        let vols = ph.tooth_volumes_mm3(36);
        for l in [Label::Enamel, Label::Dentin, Label::Pulp, Label::Caries] {
            let (tv, sv) = (vols[l as usize], seg.volume_mm3(l));
            if tv == 0.0 && sv == 0.0 {
                continue;
            }
            let err = if tv > 0.0 { format!("{:+7.2}%", 100.0 * (sv / tv - 1.0)) } else { "    n/a".into() };
            println!("{blur:.2}  {:10} {tv:8.2} {sv:9.2} {err} {:7.4}", l.name(), dice(&seg, &truth, l));
        }
        if metal {
            let (tv, sv) = (all.volume_mm3(Label::Metal), seg.volume_mm3(Label::Metal));
            println!("{blur:.2}  {:10} {tv:8.2} {sv:9.2} {:+7.2}% {:7.4}  (voxel-count truth)", "metal", 100.0 * (sv / tv - 1.0), dice(&seg, &all, Label::Metal));
            // Tooth labels where truth is not tooth of 36: streak specks
            let tooth_codes = [Label::Enamel as u8, Label::Dentin as u8, Label::Pulp as u8, Label::Caries as u8];
            let stray = (0..seg.labels.len()).filter(|&n| tooth_codes.contains(&seg.labels[n]) && !tooth_codes.contains(&truth.labels[n])).count();
            println!("      tooth-labelled voxels outside 36's tooth: {stray}");
        }
        // where each true tissue of 36 went
        for l in [Label::Pulp, Label::Caries] {
            let mut to = [0usize; 9];
            for (t, s) in truth.labels.iter().zip(&seg.labels) {
                if *t == l as u8 {
                    to[*s as usize] += 1;
                }
            }
            if to.iter().sum::<usize>() > 0 {
                let row: Vec<String> = Label::ALL.iter().filter(|x| to[**x as usize] > 0).map(|x| format!("{} {}", x.name(), to[*x as usize])).collect();
                println!("      true {} -> {}", l.name(), row.join(", "));
            }
            let mut from = [0usize; 9];
            for (t, s) in truth.labels.iter().zip(&seg.labels) {
                if *s == l as u8 {
                    from[*t as usize] += 1;
                }
            }
            if from.iter().sum::<usize>() > 0 {
                let row: Vec<String> = Label::ALL.iter().filter(|x| from[**x as usize] > 0).map(|x| format!("{} {}", x.name(), from[*x as usize])).collect();
                println!("      seg {} <- {}", l.name(), row.join(", "));
            }
        }
        println!("      segment {secs:.3} s (fastest of {reps}), CPU {cpu:.3} s per run");
    }
}

/// CPU time (user + system, all threads) of this process so far, from /proc (Linux), s.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks: f64 = fields.get(11).and_then(|u| u.parse::<f64>().ok()).unwrap_or(0.0) + fields.get(12).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    ticks / 100.0
}
