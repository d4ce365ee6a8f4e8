//! ASCII maps of a sagittal slice through tooth 36's crown: truth, segmentation, grey (HU-ish).
use dentsim_cbct::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let blur: f64 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(0.2);
    let di: i64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(0);
    let ph = Phantom::new(&PhantomSpec { caries: true, blur_sigma_mm: blur, ..Default::default() });
    let scan = ph.scan();
    let cal = calibrate(&scan).unwrap();
    let opts = SegmentOptions { tooth: Some(ToothSelect { fdi: 36, seed: ph.tooth_seed(36).unwrap(), bounds: None }), ..Default::default() };
    let seg = segment(&scan, &cal, &opts).unwrap();
    let truth = ph.tooth_labels(36);
    let [nx, ny, _] = scan.dims;
    let idx = scan.world_to_index(ph.tooth_seed(36).unwrap()).unwrap();
    let (i0, j0, k0) = ((idx[0].round() as i64 + di) as usize, idx[1].round() as usize, idx[2].round() as usize);
    let ch = b".sbBdePcM";
    let hu = |v: f32| (v as f64 - cal.hu_offset) / cal.hu_scale;
    for k in (k0 - 8..k0 + 30).rev() {
        let mut a = String::new();
        let mut b = String::new();
        let mut c = String::new();
        for j in j0 - 28..j0 + 28 {
            let n = i0 + nx * (j + ny * k);
            a.push(ch[truth.labels[n] as usize] as char);
            b.push(ch[seg.labels[n] as usize] as char);
            let h = hu(scan.values[n]);
            c.push(if h < 100.0 { ' ' } else if h < 600.0 { '-' } else if h < 1300.0 { 'o' } else if h < 2000.0 { 'O' } else { '#' });
        }
        println!("{k:3} {a}  {b}  {c}");
    }
}
