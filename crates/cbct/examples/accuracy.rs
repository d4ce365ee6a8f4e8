//! Phantom → calibrate → segment tooth 36; prints calibration, volumes vs truth, Dice, timings.
use dentsim_cbct::*;
use std::time::Instant;

fn main() {
    let mut spec = PhantomSpec::default();
    spec.caries = std::env::args().any(|a| a == "caries");
    spec.restoration = std::env::args().any(|a| a == "metal");
    if std::env::args().any(|a| a == "big") {
        spec = PhantomSpec { caries: spec.caries, restoration: spec.restoration, ..PhantomSpec::benchmark() };
    }
    let ph = Phantom::new(&spec);
    let t = Instant::now();
    let scan = ph.scan();
    println!("scan {:?} {:?}", scan.dims, t.elapsed());
    let t = Instant::now();
    let cal = calibrate(&scan).unwrap();
    println!("calibrate {:?}: {} measured {:?} scale {:.3} offset {:.1}", t.elapsed(), cal.method, cal.measured, cal.hu_scale, cal.hu_offset);
    let t = Instant::now();
    let opts = SegmentOptions { tooth: Some(ToothSelect { fdi: 36, seed: ph.tooth_seed(36).unwrap(), bounds: None }), ..Default::default() };
    let seg = segment(&scan, &cal, &opts).unwrap();
    println!("segment {:?}", t.elapsed());
    let t = Instant::now();
    let b = tooth_box(&seg, 36, None, 1.0).unwrap();
    let c = crop(&scan, &b).unwrap();
    println!("crop {:?} -> {:?}", t.elapsed(), c.dims);
    if spec.dims[0] > 200 { return; }
    let truth = ph.tooth_labels(36);
    let [nx, ny, nz] = scan.dims;
    let idx = scan.world_to_index(ph.tooth_seed(36).unwrap()).unwrap();
    let i0 = idx[0].round() as usize;
    let mut stats = std::collections::BTreeMap::new();
    for n in 0..truth.labels.len() { if truth.labels[n] == Label::Pulp as u8 { let e = stats.entry(seg.labels[n]).or_insert((0usize, 0f64)); e.0 += 1; e.1 += (n / (nx*ny)) as f64; } }
    for (k, (c, s)) in &stats { println!("truth pulp -> seg {k}: {c} voxels, mean k {:.0}", s / *c as f64); }
    for (name, lv) in [("seg", &seg), ("truth", &truth)] {
        let mut s = format!("P5\n{ny} {nz}\n255\n").into_bytes();
        for z in (0..nz).rev() { for y in 0..ny { s.push(lv.labels[i0 + nx * (y + ny * z)] * 28); } }
        std::fs::write(format!("/tmp/acc_{name}.pgm"), s).unwrap();
    }
    let vols = ph.tooth_volumes_mm3(36);
    for l in [Label::Enamel, Label::Dentin, Label::Pulp, Label::Caries] {
        let tv = vols[l as usize];
        let sv = seg.volume_mm3(l);
        println!("{:8} true {:8.2} seg {:8.2} err {:+6.2}% dice {:.4}", l.name(), tv, sv, if tv > 0.0 { 100.0 * (sv - tv) / tv } else { 0.0 }, dice(&seg, &truth, l));
    }
}
