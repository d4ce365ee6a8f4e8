//! Partial-volume measure of a tissue enclosed by another (the pulp in the dentin).
//!
//! A voxel's grey value mixes the grey values of the tissues in its footprint in proportion to
//! their share of it, and the scanner's point spread moves grey between voxels without changing
//! its sum. So the volume of a tissue inside a surround is the sum, over the tissue's voxels and a
//! band of surround around them, of `(g_surround − g) / (g_surround − g_tissue)`, however blurred
//! the scan and however thin the tissue. A count of voxels past a threshold is not: wherever the
//! tissue is curved on the scale of the blur (root canals 1.5–2.5 voxels wide, pulp horns), its
//! midpoint contour lies inside the true surface; on the molar phantom the pulp's lies ~0.03 mm
//! inside, 9 % of its volume.
//!
//! Inputs: scan, labels, the tissue and its surround, the calibration. The band is the surround
//! within 3 voxels of the tissue, cut where any third label (enamel, bone, air) is nearer than the
//! tissue, so that the third tissue's own blur stays out of the sum. Reference grey values: the
//! surround's measured in the shell 4–8 voxels out (its nearest voxels beyond 4 where that
//! shell is thin); the tissue's where it is at least 3 voxels
//! deep, else the calibration's, bounded on both sides by the voxels 2 deep (a thin pulp has no voxel free of the dentin's blur; its
//! measured grey would be biased toward the dentin's and the volume with it). Noise averages
//! out: the sum is not clamped to 0..1.
//! Cost: three Euclidean distance transforms and a few linear passes over the (cropped) volume.

use crate::Label;
use crate::calibrate::Calibration;
use crate::volume::{LabelVolume, Volume};
use rayon::prelude::*;

/// Band of surround summed around the tissue, in voxels.
const BAND_VOXELS: f32 = 3.0;
/// Depth (voxels) from which a tissue voxel counts as free of its surround's blur.
const PURE_DEPTH_VOXELS: f32 = 3.0;
/// Fewest voxels a measured reference grey value is taken from.
const MIN_REFERENCE_VOXELS: usize = 64;
/// Depth and count of the voxels that bound a predicted grey ([`reference_grey`]).
const NEAR_PURE_DEPTH_VOXELS: f32 = 2.0;
const MIN_NEAR_PURE_VOXELS: usize = 16;
/// Voxels from this depth to 2 deep: how fast the blur's share falls.
const SHALLOWER_DEPTH_VOXELS: f32 = 1.4;
/// Once the scan's blur σ is known ([`PartialVolume::with_blur`]), a tissue voxel this many σ
/// inside its labels' border holds 0.6 % of its surround's grey by a flat border, up to 4 % in
/// a tube and 10 % at a ball's centre (a Gaussian's tail past 2.5 σ in one, two and three
/// dimensions; the family's 0.3 mm molars' pulps read 4–5 % of the contrast toward the dentin):
/// a reading of the tissue's grey to within that, where the calibration's line only predicts it.
const PURE_BLUR_SIGMAS: f32 = 2.5;
/// ... read from at least this many such voxels, its median's standard error within this share
/// of the contrast (a coarse incisor's chamber holds 6, their median 1 % of it from the truth).
const MIN_PURE_VOXELS: usize = 5;
const MAX_GREY_ERROR_SHARE: f64 = 0.02;

/// The partial-volume measure of one tissue.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PartialVolume {
    pub volume_mm3: f64,
    /// Grey value of the tissue itself and of its surround used for the fractions.
    pub tissue_grey: f64,
    pub surround_grey: f64,
    /// Whether the tissue's grey value was measured (deep voxels) or the calibration's.
    pub tissue_grey_measured: bool,
    /// Voxels summed: the tissue's and its band's.
    pub voxels: usize,
    /// Where the tissue's grey was not measured 3 deep: its voxels at least 2 deep, each one's depth
    /// inside the labels' border (mm, half a voxel less than to the nearest voxel outside) and
    /// grey, for [`PartialVolume::with_blur`].
    #[serde(skip)]
    pub near_pure: Vec<(f32, f32)>,
}

impl PartialVolume {
    /// The measure with the tissue's grey read once the scan's blur (σ, mm, the voxel's box
    /// within) is known: where no voxel lay 3 deep (the grey predicted, or bounded by the
    /// voxels 2 deep), the median of those the blur leaves pure
    /// ([`PURE_BLUR_SIGMAS`]) when there are enough, the volume rescaled to it. The calibration
    /// only predicts a grey it has no peak for (a coarse incisor's 300 HU pulp at 113, volume
    /// −11 %), and the bound from the voxels 2 deep is the farthest the grey may lie (the same
    /// pulp in a jaw at 171); its voxels 2 deep, 2.6 σ inside at 0.4 mm, show it. Unchanged where
    /// the grey was measured 3 deep, or too few voxels lie deep enough.
    pub fn with_blur(self, blur_mm: f64) -> PartialVolume {
        let depth = PURE_BLUR_SIGMAS * blur_mm as f32;
        let pure: Vec<f32> = self.near_pure.iter().filter(|(d, _)| *d >= depth).map(|(_, g)| *g).collect();
        if !blur_mm.is_finite() || pure.len() < MIN_PURE_VOXELS {
            return self;
        }
        let n = pure.len() as f64;
        let grey = median(pure.clone());
        // The median's standard error from the voxels' own spread (MAD): a reading too noisy
        // to be worth more than the prediction is not taken.
        let spread = 1.4826 * median(pure.iter().map(|g| (f64::from(*g) - grey).abs() as f32).collect());
        let (before, after) = (self.surround_grey - self.tissue_grey, self.surround_grey - grey);
        let precise = 1.2533 * spread / n.sqrt() <= MAX_GREY_ERROR_SHARE * after.abs();
        // A grey at or past the surround's is no reading.
        if !precise || after * before <= 0.0 || !apart(after, self.surround_grey) {
            return self;
        }
        PartialVolume { volume_mm3: self.volume_mm3 * before / after, tissue_grey: grey, tissue_grey_measured: true, near_pure: Vec::new(), ..self }
    }
}

/// Volume of `tissue` by partial volume against `surround` (see the module comment); `None` when
/// the labels hold no `tissue` or the two grey values are not apart.
pub fn enclosed_volume(vol: &Volume, labels: &LabelVolume, tissue: Label, surround: Label, cal: &Calibration) -> Option<PartialVolume> {
    let (t, s) = (tissue as u8, surround as u8);
    if labels.labels.len() != vol.values.len() || !labels.labels.contains(&t) {
        return None;
    }
    let h = (vol.spacing.iter().sum::<f64>() / 3.0) as f32;
    let is_tissue: Vec<bool> = labels.labels.iter().map(|&l| l == t).collect();
    let is_other: Vec<bool> = labels.labels.iter().map(|&l| l != t && l != s).collect();
    let is_outside_tissue: Vec<bool> = is_tissue.iter().map(|&b| !b).collect();
    let to_tissue = distance_mm(vol.dims, vol.spacing, &is_tissue);
    let to_other = distance_mm(vol.dims, vol.spacing, &is_other);
    let depth = distance_mm(vol.dims, vol.spacing, &is_outside_tissue);

    let (tissue_grey, reading) = reference_grey(vol, &is_tissue, &depth, h, cal.peak(tissue), cal.peak(surround));
    let (shell_in, shell_out) = ((BAND_VOXELS + 1.0) * h, (BAND_VOXELS + 5.0) * h);
    let surround_grey = surround_reference(vol, labels, s, &to_tissue, &to_other, (shell_in, shell_out), BAND_VOXELS * h).unwrap_or_else(|| cal.peak(surround));
    let contrast = surround_grey - tissue_grey;
    if !apart(contrast, surround_grey) {
        return None;
    }
    let band = BAND_VOXELS * h;
    let (sum, voxels) = (0..vol.values.len())
        .into_par_iter()
        .filter(|&n| is_tissue[n] || (labels.labels[n] == s && to_tissue[n] <= band && to_tissue[n] < to_other[n]))
        .map(|n| ((surround_grey - f64::from(vol.values[n])) / contrast, 1usize))
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    let near_pure = match reading {
        Reading::Deep => Vec::new(),
        _ => (0..vol.values.len()).filter(|&n| is_tissue[n] && depth[n] >= NEAR_PURE_DEPTH_VOXELS * h).map(|n| (depth[n] - 0.5 * h, vol.values[n])).collect(),
    };
    Some(PartialVolume { volume_mm3: sum * vol.voxel_volume_mm3(), tissue_grey, surround_grey, tissue_grey_measured: reading != Reading::Predicted, voxels, near_pure })
}

/// Whether a tissue's grey lies `contrast` from its surround's by more than a percent of the
/// surround's grey: nearer, fractions of the contrast would be noise.
fn apart(contrast: f64, surround_grey: f64) -> bool {
    contrast.abs() > 0.01 * surround_grey.abs().max(1.0)
}

/// The surround's own grey beside a tissue: the median of its voxels in a shell `shell` (mm from
/// the tissue) clear of the band and of other tissues (`clear` mm). Where that shell holds too
/// few (a thin root's dentin on anisotropic voxels: the family's 8-bit premolar's held 19, and
/// the calibration's crown dentin, 2 grey below its root's, put its pulp at −7.6 %), the
/// nearest such voxels beyond the shell's inner side make up the count; `None` when the surround
/// has too few clear voxels at all.
fn surround_reference(vol: &Volume, labels: &LabelVolume, s: u8, to_tissue: &[f32], to_other: &[f32], (shell_in, shell_out): (f32, f32), clear: f32) -> Option<f64> {
    let candidates: Vec<(f32, f32)> = (0..vol.values.len())
        .filter(|&n| labels.labels[n] == s && to_tissue[n] >= shell_in && to_other[n] >= clear)
        .map(|n| (to_tissue[n], vol.values[n]))
        .collect();
    let within = candidates.iter().filter(|(d, _)| *d <= shell_out).count();
    if within >= MIN_REFERENCE_VOXELS {
        return Some(median(candidates.into_iter().filter(|(d, _)| *d <= shell_out).map(|(_, v)| v).collect()));
    }
    if candidates.len() < MIN_NEAR_PURE_VOXELS {
        return None;
    }
    let mut nearest = candidates;
    let take = nearest.len().min(MIN_REFERENCE_VOXELS);
    if take < nearest.len() {
        nearest.select_nth_unstable_by(take - 1, |a, b| a.0.total_cmp(&b.0));
    }
    Some(median(nearest[..take].iter().map(|(_, v)| *v).collect()))
}

/// How a tissue's reference grey was found ([`reference_grey`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reading {
    /// The median of its voxels 3 deep.
    Deep,
    /// Its voxels 2 deep bounding the calibration's prediction.
    Bounded,
    /// The calibration's prediction.
    Predicted,
}

/// The tissue's own grey and how it was found: the median of its voxels at least 3
/// voxels deep (`depth`, mm, from the voxels outside it) when there are enough; else the
/// calibration's `predicted` grey, unless that lies beyond the median of the voxels 2 deep on
/// the surround's side, or beyond them by more than their step from the voxels a little
/// shallower on the other side (then that bound is taken). The scanner's blur can only pull a tissue's deepest voxels toward its
/// surround's grey, never past the tissue's own: a prediction brighter than a dark pulp's
/// deepest voxels is wrong (an extracted canine in water: the fit's line, bent by a low enamel
/// peak, put the pulp at 865 where its voxels 2 deep show 302; the measure read +70 %), and those
/// voxels are the nearer bound. (Taking them always would not do: under a blur of σ ≥ 0.75
/// voxel they still carry a good share of the dentin's grey; the molar phantom's pulp +2…+9 %.)
fn reference_grey(vol: &Volume, is_tissue: &[bool], depth: &[f32], h: f32, predicted: f64, surround: f64) -> (f64, Reading) {
    let at = |d: f32| -> Vec<f32> { (0..vol.values.len()).filter(|&n| is_tissue[n] && depth[n] >= d * h).map(|n| vol.values[n]).collect() };
    let deep = at(PURE_DEPTH_VOXELS);
    if deep.len() >= MIN_REFERENCE_VOXELS {
        return (median(deep), Reading::Deep);
    }
    let near = at(NEAR_PURE_DEPTH_VOXELS);
    if near.len() >= MIN_NEAR_PURE_VOXELS {
        let near = median(near);
        if (predicted - near) * (surround - near) > 0.0 {
            return (near, Reading::Bounded);
        }
        // The blur's share in a voxel falls faster than geometrically with its depth, so the
        // voxels 2 deep are nearer the tissue's own grey than the step from those a little
        // shallower: a prediction farther off than that is wrong too (an extracted premolar in
        // wax: 1207 where the pulp is 1250, its voxels 2 deep 1250 and shallower 1266).
        let shallower: Vec<f32> = (0..vol.values.len())
            .filter(|&n| is_tissue[n] && (SHALLOWER_DEPTH_VOXELS * h..NEAR_PURE_DEPTH_VOXELS * h).contains(&depth[n]))
            .map(|n| vol.values[n])
            .collect();
        if shallower.len() >= MIN_NEAR_PURE_VOXELS {
            let step = median(shallower) - near;
            let farthest = near - step;
            if step * (surround - near) > 0.0 && (predicted - farthest) * (surround - near) < 0.0 {
                return (farthest, Reading::Bounded);
            }
        }
    }
    (predicted, Reading::Predicted)
}

/// The grey value of `tissue` inside `surround` as [`enclosed_volume`] takes it (its deep voxels',
/// else the calibration's), and whether it was measured.
pub fn tissue_grey(vol: &Volume, labels: &LabelVolume, tissue: Label, surround: Label, cal: &Calibration) -> (f64, bool) {
    let h = (vol.spacing.iter().sum::<f64>() / 3.0) as f32;
    let outside: Vec<bool> = labels.labels.iter().map(|&l| l != tissue as u8).collect();
    let inside: Vec<bool> = outside.iter().map(|&b| !b).collect();
    let depth = distance_mm(vol.dims, vol.spacing, &outside);
    let (grey, reading) = reference_grey(vol, &inside, &depth, h, cal.peak(tissue), cal.peak(surround));
    (grey, reading != Reading::Predicted)
}

pub(crate) fn median(mut v: Vec<f32>) -> f64 {
    let m = v.len() / 2;
    f64::from(*v.select_nth_unstable_by(m, |a, b| a.total_cmp(b)).1)
}

/// Euclidean distance (mm) from each voxel centre to the nearest `seed` voxel centre
/// (`f32::INFINITY` without seeds): exact, separable (Felzenszwalb & Huttenlocher), linear cost.
pub fn distance_mm(dims: [usize; 3], spacing: [f64; 3], seed: &[bool]) -> Vec<f32> {
    let [nx, ny, nz] = dims;
    if nx == 0 || ny == 0 || nz == 0 {
        return vec![f32::INFINITY; seed.len()];
    }
    let mut d2: Vec<f64> = seed.par_iter().map(|&s| if s { 0.0 } else { f64::INFINITY }).collect();
    let w = spacing.map(|s| s * s);
    let slab = nx * ny;
    // Along x, the rows in place; along y, each slab's columns; along z, the lines gathered
    // line by line into a buffer, then scattered back slab by slab (every part side by side).
    d2.par_chunks_mut(nx).for_each_init(Envelope::default, |e, row| e.apply(row, w[0]));
    d2.par_chunks_mut(slab).for_each_init(
        || (Envelope::default(), vec![0.0; ny]),
        |(e, line), part| {
            for i in 0..nx {
                line.iter_mut().enumerate().for_each(|(j, v)| *v = part[i + nx * j]);
                e.apply(line, w[1]);
                line.iter().enumerate().for_each(|(j, &v)| part[i + nx * j] = v);
            }
        },
    );
    let mut lines = vec![0.0; d2.len()];
    lines.par_chunks_mut(nz).enumerate().for_each_init(Envelope::default, |e, (l, line)| {
        line.iter_mut().enumerate().for_each(|(k, v)| *v = d2[l + slab * k]);
        e.apply(line, w[2]);
    });
    d2.par_chunks_mut(slab).enumerate().for_each(|(k, part)| part.iter_mut().enumerate().for_each(|(l, v)| *v = lines[l * nz + k]));
    d2.into_par_iter().map(|v| v.sqrt() as f32).collect()
}

/// min over p of f(p) + w·(q − p)² for every q: the lower envelope of parabolas, its buffers
/// kept from line to line.
#[derive(Default)]
struct Envelope {
    f: Vec<f64>,
    v: Vec<usize>,
    z: Vec<f64>,
}

impl Envelope {
    /// Replaces `line` (f) by its envelope; all infinite where no value is finite.
    fn apply(&mut self, line: &mut [f64], w: f64) {
        let Envelope { f, v, z } = self;
        f.clear();
        f.extend_from_slice(line);
        v.clear();
        z.clear();
        z.push(f64::NEG_INFINITY);
        let cross = |p: usize, q: usize| ((f[q] + w * (q * q) as f64) - (f[p] + w * (p * p) as f64)) / (2.0 * w * (q as f64 - p as f64));
        for q in (0..f.len()).filter(|&q| f[q].is_finite()) {
            while let Some(&p) = v.last() {
                if cross(p, q) <= z[v.len() - 1] {
                    v.pop();
                    z.pop();
                } else {
                    break;
                }
            }
            if let Some(&p) = v.last() {
                z.push(cross(p, q));
            }
            v.push(q);
        }
        if v.is_empty() {
            line.fill(f64::INFINITY);
            return;
        }
        z.push(f64::INFINITY);
        let mut k = 0;
        for (q, o) in line.iter_mut().enumerate() {
            while z[k + 1] < q as f64 {
                k += 1;
            }
            let p = v[k];
            *o = f[p] + w * ((q as f64 - p as f64).powi(2));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::SourceInfo;

    /// A canal 1.5 voxels in radius (a capsule) in dentin, voxel-averaged and blurred like a scan:
    /// the midpoint threshold loses a good part of it, the partial-volume measure does not.
    #[test]
    fn a_thin_canal_keeps_its_volume() {
        let (h, r, half_len) = (0.2, 0.3, 2.0);
        let dims = [24, 24, 36];
        let centre = [2.3, 2.4, 3.5];
        let inside = |p: [f64; 3]| {
            let z = (p[2] - centre[2]).clamp(-half_len, half_len);
            (p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2) + (p[2] - centre[2] - z).powi(2) < r * r
        };
        // The canal's volume as the voxels hold it (4³ samples each; within 1 % of π r² (2l + 4r/3)).
        let (vol, labels, cal, truth) = crate::test_scans::pulp_in_dentin(h, dims, 0.75, inside);
        let counted = labels.count(Label::Pulp) as f64 * vol.voxel_volume_mm3();
        let measure = enclosed_volume(&vol, &labels, Label::Pulp, Label::Dentin, &cal).unwrap();
        assert!(!measure.tissue_grey_measured, "no voxel of a 0.3 mm canal is free of the blur");
        assert!(counted / truth - 1.0 < -0.05, "the threshold loses the canal: {counted} vs {truth}");
        assert!((measure.volume_mm3 / truth - 1.0).abs() < 0.005, "{} vs {truth}", measure.volume_mm3);
    }

    /// A pulp 4 voxels wide at 0.4 mm (σ 0.2 mm): no voxel lies 3 deep, so the measure rests on
    /// the calibration's prediction, here 90 grey off; once the blur is known its voxels 2 deep
    /// (2.6 σ inside) give its grey and the volume. Under a blur twice as wide they are not pure
    /// and the measure stays as it was.
    #[test]
    fn a_thin_pulps_grey_is_read_where_the_blur_leaves_it_pure() {
        let (h, r, half_len) = (0.4, 0.8, 4.0);
        let centre = [3.2, 3.2, 6.0];
        let inside = |p: [f64; 3]| {
            let z = (p[2] - centre[2]).clamp(-half_len, half_len);
            (p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2) + (p[2] - centre[2] - z).powi(2) < r * r
        };
        let (vol, labels, _, truth) = crate::test_scans::pulp_in_dentin(h, [16, 16, 30], 0.5, inside);
        let predicted = Calibration::manual(&[(Label::Dentin, 2585.0), (Label::Pulp, 1280.0)]).unwrap();
        let measure = enclosed_volume(&vol, &labels, Label::Pulp, Label::Dentin, &predicted).unwrap();
        assert!(!measure.tissue_grey_measured && measure.volume_mm3 / truth - 1.0 < -0.05, "the prediction's measure: {} ({}) vs {truth}", measure.volume_mm3, measure.tissue_grey);
        let blur = (0.2f64.powi(2) + h * h / 12.0).sqrt();
        let read = measure.clone().with_blur(blur);
        assert!(read.tissue_grey_measured && (read.tissue_grey - 1370.0).abs() < 0.02 * (2585.0 - 1370.0), "grey {}", read.tissue_grey);
        assert!((read.volume_mm3 / truth - 1.0).abs() < 0.01, "{} vs {truth}", read.volume_mm3);
        assert_eq!(measure.clone().with_blur(2.0 * blur), measure);
    }

    /// A thin surround's shell holds too few voxels: its nearest clear voxels beyond make up the
    /// count (the calibration's grey, read elsewhere in the tooth, is not its own); with enough in
    /// the shell, it alone; with too few clear voxels at all, no reference.
    #[test]
    fn a_thin_shell_is_made_up_from_its_nearest_clear_voxels() {
        let s = Label::Dentin as u8;
        // (count, label, mm to the tissue, mm to another tissue, grey)
        let reference = |layout: &[(usize, u8, f32, f32, f32)]| {
            let voxels: Vec<(u8, f32, f32, f32)> = layout.iter().flat_map(|&(count, l, t, o, g)| std::iter::repeat_n((l, t, o, g), count)).collect();
            let vol = Volume { dims: [voxels.len(), 1, 1], spacing: [0.3; 3], origin: [0.0; 3], direction: crate::volume::IDENTITY, values: voxels.iter().map(|v| v.3).collect(), source: SourceInfo::default() };
            let mut labels = vol.label_volume();
            labels.labels = voxels.iter().map(|v| v.0).collect();
            let (to_tissue, to_other): (Vec<f32>, Vec<f32>) = voxels.iter().map(|v| (v.1, v.2)).unzip();
            surround_reference(&vol, &labels, s, &to_tissue, &to_other, (0.9, 1.8), 0.6)
        };
        let (near_other, air) = ((100, s, 1.0, 0.2, 10.0), (1, Label::Air as u8, 9.0, 0.0, 10.0));
        // 40 in the shell, 40 just beyond it, 200 far and darker (another part of the tooth).
        assert_eq!(reference(&[(40, s, 1.0, 3.0, 169.0), (40, s, 2.0, 3.0, 169.0), (200, s, 5.0, 3.0, 150.0), near_other, air]), Some(169.0));
        // 70 in the shell: they alone, however many lie beyond.
        assert_eq!(reference(&[(70, s, 1.0, 3.0, 169.0), (300, s, 2.0, 3.0, 150.0), near_other, air]), Some(169.0));
        // 10 clear voxels in all.
        assert_eq!(reference(&[(10, s, 1.0, 3.0, 169.0), near_other, air]), None);
    }

    #[test]
    fn distances_match_brute_force() {
        let dims = [9, 7, 5];
        let spacing = [0.2, 0.3, 0.25];
        let mut seed = vec![false; 9 * 7 * 5];
        for n in [3, 40, 100, 250, 314] {
            seed[n] = true;
        }
        let d = distance_mm(dims, spacing, &seed);
        let pos = |n: usize| [(n % 9) as f64 * spacing[0], ((n / 9) % 7) as f64 * spacing[1], (n / 63) as f64 * spacing[2]];
        for (n, &dn) in d.iter().enumerate() {
            let brute = (0..seed.len())
                .filter(|&m| seed[m])
                .map(|m| {
                    let (a, b) = (pos(n), pos(m));
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                })
                .fold(f64::INFINITY, f64::min);
            assert!((f64::from(dn) - brute).abs() < 1e-5, "voxel {n}: {dn} vs {brute}");
        }
        assert!(distance_mm(dims, spacing, &vec![false; seed.len()]).iter().all(|v| v.is_infinite()));
    }
}
