//! Prints phantom timings and volumes and writes mid slices as PGM images to /tmp.
use dentsim_cbct::{Label, Phantom, PhantomSpec};
use std::time::Instant;

fn pgm(path: &str, w: usize, h: usize, px: impl Fn(usize, usize) -> u8) {
    let mut s = format!("P5\n{w} {h}\n255\n").into_bytes();
    for y in (0..h).rev() {
        for x in 0..w {
            s.push(px(x, y));
        }
    }
    std::fs::write(path, s).unwrap();
}

fn main() {
    let mut spec = PhantomSpec::default();
    spec.caries = std::env::args().any(|a| a == "caries");
    spec.restoration = std::env::args().any(|a| a == "metal");
    let ph = Phantom::new(&spec);
    let t = Instant::now();
    let scan = ph.scan();
    println!("scan {:?} in {:?}", scan.dims, t.elapsed());
    let t = Instant::now();
    let lab = ph.labels();
    println!("labels in {:?}", t.elapsed());
    let t = Instant::now();
    let vols = ph.tooth_volumes_mm3(36);
    println!("octree volumes in {:?}", t.elapsed());
    let t = Instant::now();
    let v2 = ph.tooth_volumes_at(36, 0.05);
    println!("0.05 volumes in {:?}", t.elapsed());
    let tl = ph.tooth_labels(36);
    for l in [Label::Enamel, Label::Dentin, Label::Pulp, Label::Caries] {
        println!("{:?} true {:.3} mm3 (0.05: {:.3}), voxel count {:.2}", l, vols[l as usize], v2[l as usize], tl.volume_mm3(l));
    }
    println!("volumes in {:?}", t.elapsed());
    let [nx, ny, nz] = scan.dims;
    let seed = ph.tooth_seed(36).unwrap();
    let idx = scan.world_to_index(seed).unwrap();
    let (i0, k0) = (idx[0].round() as usize, idx[2].round() as usize);
    let (lo, hi) = scan.min_max();
    let g = |v: f32| (((v - lo) / (hi - lo)) * 255.0) as u8;
    pgm("/tmp/ph_sag.pgm", ny, nz, |y, z| g(scan.values[i0 + nx * (y + ny * z)]));
    pgm("/tmp/ph_ax.pgm", nx, ny, |x, y| g(scan.values[x + nx * (y + ny * k0)]));
    pgm("/tmp/ph_lab.pgm", ny, nz, |y, z| lab.labels[i0 + nx * (y + ny * z)] * 28);
    println!("range {lo}..{hi}");
}
