//! A metal restoration's bloom. The scanner's blur spreads an unclipped filling's grey (four
//! times the enamel's or more) over the tissue about it: at the calibration's metal threshold
//! the filling reads about 1.5 σ too large, the dentin beside it reads as enamel, the air above
//! it as tooth, and the bloom's grey values between the enamel's and the metal's move the
//! enamel's histogram peak. On the foreign sweep's filled incisors that was 4–10 % of the enamel,
//! silently.
//!
//! [`unbloom`] measures each restoration's metal grey in its core and the scan's blur across
//! their edges, takes a metal to end where its grey falls half-way to the enamel's, and gives
//! each voxel within the bloom's reach of that surface the grey found the reach away from it,
//! along the line from the metal through the voxel: the tissue the filling sits in, read beyond
//! its bloom. (Un-mixing each voxel's grey by the metal's share a Gaussian edge would give it
//! instead read the jaw molars' enamel 0.3–1.3 % further from the truth and lost two incisors'
//! pulps: the share is off at a restoration's corners.) Where the scan is clipped the metal's
//! grey, and with it the half-way surface, is unknown; such scans are left as they are
//! (segmentation's `clean_metal` handles their streaks).

use crate::calibrate::Calibration;
use crate::mask::components;
use crate::partial_volume::distance_mm;
use crate::roi::{crop, IndexBox};
use crate::volume::face_neighbours;
use crate::{Label, Volume};
use rayon::prelude::*;
use serde::Serialize;

/// What [`unbloom`] measured and changed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MetalBloom {
    /// Each restoration's metal grey in its core (the scan's units), the largest first.
    pub metal_greys: Vec<f64>,
    /// The blur across the metal's edge (σ, mm, the voxel's own share included).
    pub blur_mm: f64,
    /// How far out from the metal's half-way surface the bloom was taken off (mm).
    pub reach_mm: f64,
    /// Voxels given the grey beyond the bloom.
    pub voxels: usize,
}

/// The fewest metal voxels (a 3³ block) of a restoration worth a look, and the fewest sharing
/// the scan's maximum that make it clipped (as `clean_metal` decides).
const MIN_METAL_VOXELS: usize = 27;

/// The fewest voxels in a restoration's brightest tenth that give its metal's grey.
const MIN_CORE_VOXELS: usize = 8;

/// The fewest edge lines that give the blur.
const MIN_EDGE_LINES: usize = 8;

/// The bloom's reach in σ: the metal's share of a voxel 2.5 σ out is 0.6 %, under 70 grey
/// values of a 12000 HU filling's lift over dentin, a twentieth of the enamel–dentin contrast.
const REACH_SIGMAS: f64 = 2.5;

/// The farthest reach (mm): a blur of 0.6 mm is beyond any dental CBCT's.
const MAX_REACH_MM: f64 = 1.5;

/// How far (mm) an edge line runs past its half-way point to read the tissue beyond.
const FAR_MM: (f64, f64) = (1.0, 1.5);

/// A metal restoration the scanner clipped: its grey (the scan's maximum) and how many voxels
/// reach it. Its own grey, and with it the half-way surface and the bloom's reach, is unknown.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SaturatedMetal {
    pub grey: f64,
    pub voxels: usize,
}

/// The scan's metal if the scanner clipped it (at least [`MIN_METAL_VOXELS`] metal voxels share
/// the scan's maximum grey, as `clean_metal` decides).
pub fn saturated_metal(vol: &Volume, cal: &Calibration) -> Option<SaturatedMetal> {
    saturation(vol, &metal_voxels(vol, cal))
}

fn metal_voxels(vol: &Volume, cal: &Calibration) -> Vec<usize> {
    let classifier = cal.classifier();
    (0..vol.values.len()).into_par_iter().filter(|&m| classifier.classify(f64::from(vol.values[m])) == Label::Metal).collect()
}

fn saturation(vol: &Volume, metal: &[usize]) -> Option<SaturatedMetal> {
    let top = metal.iter().map(|&m| vol.values[m]).fold(f32::NEG_INFINITY, f32::max);
    let ceiling = top - 1e-5 * top.abs().max(1.0);
    let voxels = metal.iter().filter(|&&m| vol.values[m] >= ceiling).count();
    (voxels >= MIN_METAL_VOXELS).then(|| SaturatedMetal { grey: f64::from(top), voxels })
}

/// `vol` with an unclipped metal restoration's bloom taken off ([`MetalBloom`]); `None` where the
/// scan shows no metal, clips it, or too little of it to measure (the scan is then used as is).
pub fn unbloom(vol: &Volume, cal: &Calibration) -> Option<(Volume, MetalBloom)> {
    let classifier = cal.classifier();
    let metal = metal_voxels(vol, cal);
    if metal.len() < MIN_METAL_VOXELS || saturation(vol, &metal).is_some() {
        return None;
    }
    // The metal's box, with room for the reach and the lines beyond it.
    let [nx, ny, _] = vol.dims;
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    for &m in &metal {
        let p = [m % nx, (m / nx) % ny, m / (nx * ny)];
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let pad = 2 + ((MAX_REACH_MM + FAR_MM.1) / vol.min_spacing()).ceil() as usize;
    let region = IndexBox { min: lo.map(|v| v.saturating_sub(pad)), max: [0, 1, 2].map(|c| (hi[c] + pad + 1).min(vol.dims[c])) };
    let part = crop(vol, &region).ok()?;
    let d = part.dims;

    // Each restoration (a component of the metal class) its own metal's grey: the median of its
    // brightest tenth. Its edge and bloom hold most of its class (a 3 mm filling at a 0.2 mm
    // blur: three quarters), so its median is too dark.
    let enamel = cal.peak(Label::Enamel);
    let is_metal: Vec<bool> = part.values.par_iter().map(|&v| classifier.classify(f64::from(v)) == Label::Metal).collect();
    let (component, sizes) = components(d, &is_metal);
    let mut members: Vec<Vec<f32>> = sizes.iter().map(|&n| Vec::with_capacity(if n >= MIN_METAL_VOXELS { n } else { 0 })).collect();
    for (l, &c) in component.iter().enumerate().filter(|(_, &c)| c != 0 && sizes[c as usize] >= MIN_METAL_VOXELS) {
        members[c as usize].push(part.values[l]);
    }
    let metal_grey: Vec<Option<f64>> = members
        .into_iter()
        .map(|mut greys| {
            greys.sort_by(f32::total_cmp);
            let brightest = &greys[greys.len() * 9 / 10..];
            let grey = f64::from(*brightest.get(brightest.len() / 2)?);
            (brightest.len() >= MIN_CORE_VOXELS && classifier.classify(0.5 * (grey + enamel)) == Label::Metal).then_some(grey)
        })
        .collect();
    let mut metal_greys: Vec<(usize, f64)> = metal_grey.iter().enumerate().filter_map(|(c, g)| g.map(|g| (sizes[c], g))).collect();
    if metal_greys.is_empty() {
        return None;
    }
    metal_greys.sort_by(|a, b| b.0.cmp(&a.0));
    // Where the metal ends: each voxel of a measured restoration the grey half-way from the
    // enamel's to its metal's (infinite elsewhere).
    let half_at: Vec<f64> = component.iter().map(|&c| metal_grey[c as usize].map_or(f64::INFINITY, |g| 0.5 * (g + enamel))).collect();
    let metal_at = |l: usize| metal_grey[component[l] as usize];
    let sample = Sampler { values: &part.values, dims: d, spacing: part.spacing };
    // Whether a point (index space) lies in the metal: its grey past the nearest voxel's half-way.
    let in_metal = |p: [f64; 3]| {
        let q = [0, 1, 2].map(|c| (p[c].round().max(0.0) as usize).min(d[c] - 1));
        sample.at(p) >= half_at[q[0] + d[0] * (q[1] + d[1] * q[2])]
    };

    // The blur: along the grey's gradient through each voxel just outside the half-way surface,
    // the distance between the crossings of a quarter and three quarters of the way from the
    // tissue beyond (read FAR_MM past the half-way point) to the metal.
    let inside: Vec<bool> = part.values.par_iter().zip(&half_at).map(|(&v, &h)| f64::from(v) >= h).collect();
    let edge: Vec<(usize, usize)> = (0..inside.len())
        .filter(|&l| !inside[l])
        .filter_map(|l| face_neighbours(l, d).into_iter().flatten().find(|&q| inside[q]).map(|q| (l, q)))
        .collect();
    let step = 0.25 * part.min_spacing();
    let mut widths: Vec<f64> = edge
        .par_iter()
        .filter_map(|&(l, metal)| {
            let (half, metal_grey) = (half_at[metal], metal_at(metal)?);
            let at = ijk(l, d);
            let out = sample.gradient(at).map(|g| g.map(|v| -v))?;
            let line = |s: f64| sample.at(along(at, out, s, part.spacing));
            let from = -MAX_REACH_MM;
            let crossing = |level: f64, start: f64| -> Option<f64> {
                let mut s = start;
                let mut before = line(s);
                while s < MAX_REACH_MM + FAR_MM.1 {
                    let next = line(s + step);
                    if before >= level && next < level {
                        return Some(s + step * (before - level) / (before - next));
                    }
                    (s, before) = (s + step, next);
                }
                None
            };
            if line(from) < half {
                return None;
            }
            let s_half = crossing(half, from)?;
            let mut far: Vec<f64> = (0..)
                .map(|k| s_half + FAR_MM.0 + k as f64 * step)
                .take_while(|&s| s <= s_half + FAR_MM.1)
                .map(line)
                .collect();
            far.sort_by(f64::total_cmp);
            let tissue = *far.get(far.len() / 2)?;
            if tissue >= half {
                return None;
            }
            let s75 = crossing(tissue + 0.75 * (metal_grey - tissue), from)?;
            let s25 = crossing(tissue + 0.25 * (metal_grey - tissue), s75)?;
            Some((s25 - s75) / 1.349)
        })
        .collect();
    if widths.len() < MIN_EDGE_LINES {
        return None;
    }
    let mid = widths.len() / 2;
    let blur_mm = *widths.select_nth_unstable_by(mid, f64::total_cmp).1;
    if !(blur_mm.is_finite() && blur_mm > 0.0) {
        return None;
    }
    let reach_mm = (REACH_SIGMAS * blur_mm).min(MAX_REACH_MM);

    // Each voxel within the reach: the grey the reach away from the half-way surface, along the
    // line from the nearest metal through it.
    let distance = distance_mm(d, part.spacing, &inside);
    let dist = Sampler { values: &distance, dims: d, spacing: part.spacing };
    let changed: Vec<(usize, f32)> = (0..inside.len())
        .into_par_iter()
        .filter(|&l| !inside[l] && f64::from(distance[l]) <= reach_mm + part.spacing.iter().fold(0.0f64, |a, &b| a.max(b)))
        .filter_map(|l| {
            let at = ijk(l, d);
            let out = dist.gradient(at).or_else(|| sample.gradient(at).map(|g| g.map(|v| -v)))?;
            // The half-way point behind the voxel, on its line (else, where the line passes
            // beside a rounded edge, as far as the nearest metal voxel).
            let behind = f64::from(distance[l]);
            let s = (0..)
                .map(|k| f64::from(k) * step)
                .take_while(|&s| s <= behind + 2.0 * part.min_spacing())
                .find(|&s| in_metal(along(at, out, -s, part.spacing)))
                .unwrap_or(behind);
            (s < reach_mm).then(|| (l, sample.at(along(at, out, reach_mm - s, part.spacing)) as f32))
        })
        .collect();
    if changed.is_empty() {
        return None;
    }
    let mut out = vol.clone();
    for &(l, v) in &changed {
        let p = ijk(l, d);
        let [i, j, k] = [0, 1, 2].map(|c| p[c] as usize + region.min[c]);
        let n = out.index(i, j, k);
        out.values[n] = v;
    }
    Some((out, MetalBloom { metal_greys: metal_greys.into_iter().map(|(_, g)| g).collect(), blur_mm, reach_mm, voxels: changed.len() }))
}

fn ijk(l: usize, d: [usize; 3]) -> [f64; 3] {
    [(l % d[0]) as f64, ((l / d[0]) % d[1]) as f64, (l / (d[0] * d[1])) as f64]
}

/// The index-space point `s` mm from `at` along the unit direction `dir` (mm axes).
fn along(at: [f64; 3], dir: [f64; 3], s: f64, spacing: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|c| at[c] + s * dir[c] / spacing[c])
}

/// Trilinear reads of a volume in index space, clamped to its grid.
struct Sampler<'a> {
    values: &'a [f32],
    dims: [usize; 3],
    spacing: [f64; 3],
}

impl Sampler<'_> {
    fn at(&self, p: [f64; 3]) -> f64 {
        let d = self.dims;
        let mut base = [0usize; 3];
        let mut w = [0f64; 3];
        for c in 0..3 {
            let x = p[c].clamp(0.0, (d[c] - 1) as f64);
            base[c] = (x.floor() as usize).min(d[c].saturating_sub(2));
            w[c] = if d[c] > 1 { x - base[c] as f64 } else { 0.0 };
        }
        let mut sum = 0.0;
        for corner in 0..8 {
            let o = [corner & 1, (corner >> 1) & 1, corner >> 2];
            let q = [0, 1, 2].map(|c| (base[c] + o[c]).min(d[c] - 1));
            let weight: f64 = (0..3).map(|c| if o[c] == 1 { w[c] } else { 1.0 - w[c] }).product();
            sum += weight * f64::from(self.values[q[0] + d[0] * (q[1] + d[1] * q[2])]);
        }
        sum
    }

    /// The unit gradient (mm axes) at a voxel by central differences; `None` where flat.
    fn gradient(&self, at: [f64; 3]) -> Option<[f64; 3]> {
        let s = self.spacing;
        let g = [0, 1, 2].map(|c| {
            let (mut a, mut b) = (at, at);
            a[c] += 1.0;
            b[c] -= 1.0;
            (self.at(a) - self.at(b)) / (2.0 * s[c])
        });
        let n = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        (n.is_finite() && n > 0.0).then(|| g.map(|v| v / n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::gaussian_blur;
    use crate::volume::{SourceInfo, IDENTITY};

    const H: f64 = 0.1;
    const N: usize = 60;

    /// A metal box (its corners in mm) and its grey.
    type Filling = ([f64; 3], [f64; 3], f32);

    /// A 2 mm amalgam box (x, y 2–4 mm, z 2–4 mm) through the enamel into the dentin, flush with
    /// the enamel's top.
    const AMALGAM: Filling = ([2.0; 3], [4.0; 3], 12000.0);

    /// Dentin below z 2.5 mm, enamel to 4 mm, air above, and the fillings.
    fn tissue(p: [f64; 3], fillings: &[Filling]) -> f32 {
        if let Some(&(_, _, grey)) = fillings.iter().find(|(lo, hi, _)| (0..3).all(|c| (lo[c]..hi[c]).contains(&p[c]))) {
            return grey;
        }
        match () {
            _ if p[2] < 2.5 => 1800.0,
            _ if p[2] < 4.0 => 2900.0,
            _ => -1000.0,
        }
    }

    /// `nx` × 60 × 60 voxels of 0.1 mm, each its tissues' share of 4³ samples, blurred by σ 0.2
    /// mm, with noise, clipped at `ceiling`; and a calibration from the tissues' grey values.
    fn filled_scan(nx: usize, fillings: &[Filling], ceiling: f32) -> (Volume, Calibration) {
        let dims = [nx, N, N];
        let mut values: Vec<f32> = (0..nx * N * N)
            .map(|n| {
                let ijk = [n % nx, (n / nx) % N, n / (nx * N)];
                (0..64)
                    .map(|s| {
                        let sub = [s % 4, (s / 4) % 4, s / 16].map(|q| (q as f64 + 0.5) / 4.0 - 0.5);
                        tissue([0, 1, 2].map(|c| (ijk[c] as f64 + sub[c]) * H), fillings)
                    })
                    .sum::<f32>()
                    / 64.0
            })
            .collect();
        gaussian_blur(&mut values, dims, [0.2 / H; 3]);
        // Noise (uniform, ±50): without it the metal's core is one grey, as a clipped scan's.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for v in values.iter_mut() {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            *v = (*v + ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 100.0).min(ceiling);
        }
        let vol = Volume { dims, spacing: [H; 3], origin: [0.0; 3], direction: IDENTITY, values, source: SourceInfo::default() };
        let cal = Calibration::manual(&[(Label::Air, -1000.0), (Label::Dentin, 1800.0), (Label::Enamel, 2900.0)]).unwrap();
        (vol, cal)
    }

    fn metal_mm3(vol: &Volume, cal: &Calibration) -> f64 {
        let classifier = cal.classifier();
        vol.values.iter().filter(|&&v| classifier.classify(f64::from(v)) == Label::Metal).count() as f64 * H * H * H
    }

    /// Of the tissue voxels 0.15–0.6 mm from a filling and 0.4 mm clear of the tissues' own
    /// edges: how many `scan` and `clean` put in another class than their tissue's, of how many.
    fn misread(scan: &Volume, clean: &Volume, cal: &Calibration, fillings: &[Filling]) -> (usize, usize, usize) {
        let classifier = cal.classifier();
        let (mut before, mut after, mut seen) = (0, 0, 0);
        for n in 0..scan.values.len() {
            let p = [n % scan.dims[0], (n / scan.dims[0]) % N, n / (scan.dims[0] * N)].map(|v| v as f64 * H);
            let gap = fillings
                .iter()
                .map(|(lo, hi, _)| (0..3).map(|c| (lo[c] - p[c]).max(p[c] - hi[c])).fold(f64::NEG_INFINITY, f64::max))
                .fold(f64::INFINITY, f64::min);
            let clear = (p[2] - 2.5).abs() > 0.4 && (p[2] - 4.0).abs() > 0.4 && (0..3).all(|c| p[c] > 0.5 && p[c] < scan.dims[c] as f64 * H - 0.6);
            if (0.15..0.6).contains(&gap) && clear {
                let truth = classifier.classify(f64::from(tissue(p, fillings)));
                seen += 1;
                before += usize::from(classifier.classify(f64::from(scan.values[n])) != truth);
                after += usize::from(classifier.classify(f64::from(clean.values[n])) != truth);
            }
        }
        (before, after, seen)
    }

    #[test]
    fn a_fillings_bloom_is_taken_off_and_the_tissue_beside_it_read_again() {
        let (scan, cal) = filled_scan(N, &[AMALGAM], f32::INFINITY);
        let (clean, bloom) = unbloom(&scan, &cal).expect("an unclipped filling is measured");
        assert_eq!(bloom.metal_greys.len(), 1, "{bloom:?}");
        assert!((bloom.metal_greys[0] - 12000.0).abs() < 120.0, "{bloom:?}");
        // σ 0.2 mm and the voxel's box (0.03 mm) and the reads' trilinear spread.
        assert!((0.18..0.26).contains(&bloom.blur_mm), "{bloom:?}");
        // The metal class is the half-way surface's: for this blurred 2 mm box 6.5 mm³ (its 8 mm³
        // with the edges and corners the blur rounds; numpy's ndimage on the same construction),
        // where the bloom had made it 1.5 σ larger all round.
        let (before, after) = (metal_mm3(&scan, &cal), metal_mm3(&clean, &cal));
        assert!(before > 11.0, "the bloom this test is about: {before} mm³ of metal");
        assert!((after - 6.5).abs() < 0.4, "{after} mm³ of metal against 6.5");
        // The tissue beside it is its tissue's class again (the bloom made dentin enamel and air
        // tooth). What lift remains is largest at the box's corners, where the half-way surface
        // is rounded inside them: 250 grey values over the dentin, a fifth of the enamel–dentin
        // contrast.
        let (wrong_before, wrong_after, seen) = misread(&scan, &clean, &cal, &[AMALGAM]);
        assert!(wrong_before > seen / 10, "the bloom this test is about: {wrong_before} of {seen} voxels in another class");
        assert_eq!(wrong_after, 0, "{wrong_after} of {seen} tissue voxels beside the metal in another class");
    }

    #[test]
    fn two_restorations_of_different_metals_are_each_measured() {
        let fillings = [AMALGAM, ([5.0, 2.0, 2.5], [6.5, 4.0, 4.0], 7000.0)];
        let (scan, cal) = filled_scan(90, &fillings, f32::INFINITY);
        let (clean, bloom) = unbloom(&scan, &cal).expect("unclipped fillings are measured");
        assert_eq!(bloom.metal_greys.len(), 2, "{bloom:?}");
        // Within 1.5 %: the smaller box's brightest tenth reaches into its edge.
        assert!((bloom.metal_greys[0] - 12000.0).abs() < 180.0 && (bloom.metal_greys[1] - 7000.0).abs() < 105.0, "{bloom:?}");
        let (wrong_before, wrong_after, seen) = misread(&scan, &clean, &cal, &fillings);
        assert!(wrong_before > seen / 10, "the bloom this test is about: {wrong_before} of {seen} voxels in another class");
        assert_eq!(wrong_after, 0, "{wrong_after} of {seen} tissue voxels beside the metals in another class");
    }

    #[test]
    fn a_clipped_filling_and_a_scan_without_one_are_left_as_they_are() {
        let (clipped, cal) = filled_scan(N, &[AMALGAM], 5000.0);
        assert_eq!(unbloom(&clipped, &cal), None);
        assert!(saturated_metal(&clipped, &cal).is_some_and(|s| s.grey == 5000.0 && s.voxels > 1000));
        let (plain, cal) = filled_scan(N, &[], f32::INFINITY);
        assert_eq!(unbloom(&plain, &cal), None);
        assert_eq!(saturated_metal(&plain, &cal), None);
        let (unclipped, cal) = filled_scan(N, &[AMALGAM], f32::INFINITY);
        assert_eq!(saturated_metal(&unclipped, &cal), None);
    }
}
