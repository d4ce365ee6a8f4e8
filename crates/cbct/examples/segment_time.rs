//! Times `segment` on the benchmark-sized phantom scan (400×400×300 at 0.2 mm), cached as raw f32
//! in the temporary folder between runs: `segment_time [reps=N] [caries] [metal]`.
use dentsim_cbct::*;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let reps: usize = args.iter().find_map(|a| a.strip_prefix("reps=")).map_or(3, |s| s.parse().unwrap());
    let spec = PhantomSpec { caries: args.iter().any(|a| a == "caries"), restoration: args.iter().any(|a| a == "metal"), ..PhantomSpec::benchmark() };
    let ph = Phantom::new(&spec);
    let cache = std::env::temp_dir().join(format!("dentsim_bench_scan_{}{}.f32", spec.caries, spec.restoration));
    let scan = match std::fs::read(&cache) {
        Ok(bytes) if bytes.len() == 4 * spec.dims.iter().product::<usize>() => {
            let values = bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
            Volume { dims: spec.dims, spacing: [spec.spacing_mm; 3], origin: ph.origin, direction: dentsim_cbct::volume::IDENTITY, values, source: SourceInfo::default() }
        }
        _ => {
            let t = Instant::now();
            let v = ph.scan();
            println!("scan {:?} in {:.1} s", v.dims, t.elapsed().as_secs_f64());
            std::fs::write(&cache, v.values.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
            v
        }
    };
    let cal = calibrate(&scan).unwrap();
    let opts = SegmentOptions { tooth: Some(ToothSelect { fdi: 36, seed: ph.tooth_seed(36).unwrap(), bounds: None }), ..Default::default() };
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        let seg = segment(&scan, &cal, &opts).unwrap();
        best = best.min(t.elapsed().as_secs_f64());
        std::hint::black_box(seg);
    }
    println!("segment {best:.3} s (fastest of {reps})");
}
