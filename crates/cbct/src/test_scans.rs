//! Small synthetic scans for the unit tests.
use crate::calibrate::Calibration;
use crate::phantom::gaussian_blur;
use crate::volume::{LabelVolume, SourceInfo, Volume, IDENTITY};
use crate::Label;

/// Dentin (2585) holding pulp (1370) where `inside(p)` (p in mm, voxel centres at `ijk · h`):
/// each voxel the pulp's share of 4³ samples, blurred by `blur_voxels`, labelled by the
/// pulp/dentin midpoint. Returns the scan, its labels, their calibration and the pulp's volume
/// as the voxels hold it (mm³).
pub(crate) fn pulp_in_dentin(h: f64, dims: [usize; 3], blur_voxels: f64, inside: impl Fn([f64; 3]) -> bool) -> (Volume, LabelVolume, Calibration, f64) {
    let (dentin, pulp) = (2585.0f32, 1370.0f32);
    let mut values = vec![0f32; dims[0] * dims[1] * dims[2]];
    let mut truth = 0.0;
    for (n, v) in values.iter_mut().enumerate() {
        let ijk = [n % dims[0], (n / dims[0]) % dims[1], n / (dims[0] * dims[1])];
        let mut share = 0.0;
        for s in 0..64 {
            let sub = [s % 4, (s / 4) % 4, s / 16].map(|q| (q as f64 + 0.5) / 4.0 - 0.5);
            share += f32::from(u8::from(inside([0, 1, 2].map(|c| (ijk[c] as f64 + sub[c]) * h))));
        }
        truth += f64::from(share) / 64.0 * h * h * h;
        *v = dentin + (pulp - dentin) * share / 64.0;
    }
    gaussian_blur(&mut values, dims, [blur_voxels; 3]);
    let vol = Volume { dims, spacing: [h; 3], origin: [0.0; 3], direction: IDENTITY, values, source: SourceInfo::default() };
    let mut labels = vol.label_volume();
    let mid = 0.5 * (dentin + pulp);
    for (l, v) in labels.labels.iter_mut().zip(&vol.values) {
        *l = if *v < mid { Label::Pulp } else { Label::Dentin } as u8;
    }
    let cal = Calibration::manual(&[(Label::Dentin, f64::from(dentin)), (Label::Pulp, f64::from(pulp))]).unwrap();
    (vol, labels, cal, truth)
}
