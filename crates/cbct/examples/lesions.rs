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
    let fdi: u8 = args.iter().find_map(|a| a.strip_prefix("fdi=")).map_or(36, |s| s.parse().unwrap());
    println!("caries {caries} metal {metal} tooth {fdi}");
    println!("blur  tissue     true mm3   seg mm3   error    Dice");
    for blur in blurs {
        let seed: u64 = args.iter().find_map(|a| a.strip_prefix("seed=")).map_or(36, |s| s.parse().unwrap());
        let noise: f32 = args.iter().find_map(|a| a.strip_prefix("noise=")).map_or(40.0, |s| s.parse().unwrap());
        let ph = Phantom::new(&PhantomSpec { caries, restoration: metal, blur_sigma_mm: blur, seed, noise_sigma: noise, ..Default::default() });
        let scan = ph.scan();
        let cal = calibrate(&scan).unwrap();
        let opts = SegmentOptions { tooth: Some(ToothSelect { fdi, seed: ph.tooth_seed(fdi).unwrap(), bounds: None }), ..Default::default() };
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
        let hash = seg.labels.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3));
        println!("      labels hash {hash:016x}");
        let truth = ph.tooth_labels(fdi);
        let all = ph.labels();
        let vols = ph.tooth_volumes_mm3(fdi);
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
            // Metal voxels by their distance to the true metal (the restoration's SDF), mm.
            let mut bins = [0usize; 6];
            let edges = [0.0, 0.1, 0.2, 0.4, 0.8, 1e9];
            let mut missed = 0;
            for n in 0..seg.labels.len() {
                let p = seg.voxel_center(n % seg.dims[0], (n / seg.dims[0]) % seg.dims[1], n / (seg.dims[0] * seg.dims[1]));
                let is_metal = seg.labels[n] == Label::Metal as u8;
                if is_metal {
                    let d = ph.sdf(Label::Metal, glam::DVec3::from_array(p));
                    let b = if d <= 0.0 { 0 } else { 1 + edges.windows(2).position(|w| d > w[0] && d <= w[1]).unwrap_or(4) };
                    bins[b.min(5)] += 1;
                } else if all.labels[n] == Label::Metal as u8 {
                    missed += 1;
                }
            }
            println!("      metal voxels inside the true metal {}, outside by <=0.1 mm {}, 0.1-0.2 {}, 0.2-0.4 {}, 0.4-0.8 {}, >0.8 {}; true metal voxels missed {missed}", bins[0], bins[1], bins[2], bins[3], bins[4], bins[5]);
            if args.iter().any(|a| a == "where") {
                let mut by = std::collections::BTreeMap::new();
                for n in (0..seg.labels.len()).filter(|&n| seg.labels[n] == Label::Metal as u8) {
                    let p = seg.voxel_center(n % seg.dims[0], (n / seg.dims[0]) % seg.dims[1], n / (seg.dims[0] * seg.dims[1]));
                    let d = ph.sdf(Label::Metal, glam::DVec3::from_array(p));
                    if d > 0.8 {
                        *by.entry((all.labels[n], (d * 2.0).floor() as i64)).or_insert(0usize) += 1;
                    }
                }
                println!("      far metal (truth label, distance/0.5mm): {by:?}");
            }
            let in36 = (0..seg.labels.len()).filter(|&n| seg.labels[n] == Label::Metal as u8 && tooth_codes_all().contains(&truth.labels[n])).count();
            println!("      metal-labelled voxels in tooth {fdi}: {in36}");

        }
        // Voxels labelled as 36's tissues more than a voxel outside its true outline: specks
        let stray = (0..seg.labels.len())
            .filter(|&n| tooth_codes_all().contains(&seg.labels[n]))
            .filter(|&n| {
                let p = seg.voxel_center(n % seg.dims[0], (n / seg.dims[0]) % seg.dims[1], n / (seg.dims[0] * seg.dims[1]));
                ph.tooth_sdf(fdi, Label::Air, glam::DVec3::from_array(p)).unwrap() > seg.spacing[0]
            })
            .count();
        println!("      tooth-labelled voxels more than a voxel outside {fdi}: {stray}");
        {
            let [nx, ny, nz] = seg.dims;
            let off: Vec<usize> = (0..seg.labels.len())
                .filter(|&n| seg.labels[n] == Label::Enamel as u8 || seg.labels[n] == Label::Dentin as u8)
                .filter(|&n| {
                    let (i, j, k) = ((n % nx) as i64, ((n / nx) % ny) as i64, (n / (nx * ny)) as i64);
                    !(-1..=1).any(|dk| (-1..=1).any(|dj| (-1..=1).any(|di| {
                        let (a, b, c) = (i + di, j + dj, k + dk);
                        (0..nx as i64).contains(&a) && (0..ny as i64).contains(&b) && (0..nz as i64).contains(&c) && tooth_codes_all().contains(&truth.labels[(a + nx as i64 * (b + ny as i64 * c)) as usize])
                    })))
                })
                .collect();
            let mut by = std::collections::BTreeMap::new();
            for &n in &off {
                *by.entry((all.labels[n], seg.labels[n])).or_insert(0usize) += 1;
            }
            println!("      enamel/dentin voxels off the tooth (no true tooth voxel among 26 neighbours): {} by (truth, seg) {by:?}", off.len());
        }
        if args.iter().any(|a| a == "where") {
            let seed = ph.tooth_seed(fdi).unwrap();
            for n in (0..seg.labels.len()).filter(|&n| tooth_codes_all().contains(&seg.labels[n])) {
                let p = seg.voxel_center(n % seg.dims[0], (n / seg.dims[0]) % seg.dims[1], n / (seg.dims[0] * seg.dims[1]));
                let d = ph.tooth_sdf(fdi, Label::Air, glam::DVec3::from_array(p)).unwrap();
                if d > seg.spacing[0] {
                    println!("        stray {} at {:?} ({:.2} mm outside; truth {})", seg.labels[n], [p[0] - seed[0], p[1] - seed[1], p[2] - seed[2]].map(|x| (x * 10.0).round() / 10.0), d, all.labels[n]);
                }
            }
        }
        // where each true tissue of 36 went
        // Label counts of the voxels `other` gives where `mine` says `l`, as "name count, ...".
        let spread = |mine: &[u8], other: &[u8], l: Label| -> Option<String> {
            let mut counts = [0usize; 9];
            for (m, o) in mine.iter().zip(other) {
                if *m == l as u8 {
                    counts[*o as usize] += 1;
                }
            }
            let row: Vec<String> = Label::ALL.iter().filter(|x| counts[**x as usize] > 0).map(|x| format!("{} {}", x.name(), counts[*x as usize])).collect();
            (!row.is_empty()).then(|| row.join(", "))
        };
        for l in [Label::Pulp, Label::Caries] {
            if let Some(row) = spread(&truth.labels, &seg.labels, l) {
                println!("      true {} -> {row}", l.name());
            }
            if let Some(row) = spread(&seg.labels, &truth.labels, l) {
                println!("      seg {} <- {row}", l.name());
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

fn tooth_codes_all() -> [u8; 4] {
    [Label::Enamel as u8, Label::Dentin as u8, Label::Pulp as u8, Label::Caries as u8]
}
