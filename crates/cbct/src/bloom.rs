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
//! pulps: the share is off at a restoration's corners.)
//!
//! Where the scanner clipped the metal, its grey and its half-way surface cannot be read in its
//! core. They are read from the bloom's tail below the ceiling instead, with the blur measured
//! across the crown's own edges ([`clipped_metal_grey`], [`clipped_depth`]): the metal ends
//! inside the tail's half-way-to-the-ceiling surface by a depth that depends on the metal's grey
//! and the tissue beside it. Within that end the scan is raised to the ceiling, as an unblurred
//! scan would read it, which segmentation's `clean_metal` (a clipped scan's metal is what reaches
//! the ceiling) then keeps whole. For a first calibration of a clipped scan, whose bloom's bumps
//! may crowd its histogram, [`hide_bloom_above`] hides it (an unclipped one's too).

use crate::calibrate::Calibration;
use crate::mask::components;
use crate::partial_volume::{distance_mm, median};
use crate::roi::{crop, IndexBox};
use crate::volume::face_neighbours;
use crate::{Label, Volume};
use rayon::prelude::*;
use serde::Serialize;

/// What [`unbloom`] measured and changed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MetalBloom {
    /// Each restoration's metal grey in its core (the scan's units), the largest first; a
    /// clipped one's as its bloom's tail gives it.
    pub metal_greys: Vec<f64>,
    /// The scan's maximum, where the scanner clipped the metal.
    pub clipped_at: Option<f64>,
    /// The blur across the metal's edge (σ, mm, the voxel's own share included).
    pub blur_mm: f64,
    /// How far out from the metal's half-way surface the bloom was taken off (mm).
    pub reach_mm: f64,
    /// Voxels given the grey beyond the bloom (not counting a clipped metal's own, raised to the
    /// ceiling).
    pub voxels: usize,
    /// The largest measured (unclipped) restoration's cupping.
    pub cupping: Option<Cupping>,
}

/// A restoration's grey at its brightest and in its middle. A metal that hardens the scanner's
/// beam reads darker in its middle than near its edge (its rays' attenuation read short, the more
/// the longer their path through it), and the same error streaks the tissue about it; an
/// unhardened metal's middle is its brightest part.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Cupping {
    /// The median of its brightest tenth (its metal's grey as read).
    pub brightest: f64,
    /// The median of its deepest tenth (its voxels farthest inside it).
    pub middle: f64,
}

impl Cupping {
    /// How far its middle falls below its brightest, as a share of its brightest's lift over
    /// `enamel`.
    pub fn share(&self, enamel: f64) -> f64 {
        (self.brightest - self.middle) / (self.brightest - enamel)
    }
}

/// The fewest metal voxels (a 3³ block) of a restoration worth a look, and the fewest sharing
/// the scan's maximum that make it clipped (as `clean_metal` decides).
const MIN_METAL_VOXELS: usize = 27;

/// The fewest voxels in a restoration's brightest tenth that give its metal's grey.
const MIN_CORE_VOXELS: usize = 8;

/// The fewest edge lines that give the blur.
const MIN_EDGE_LINES: usize = 8;

/// The bloom's least reach in σ: the metal's share of a voxel 2.5 σ out is 0.6 %, under 70 grey
/// values of a 12000 HU filling's lift over dentin, a sixteenth of the enamel–dentin contrast; a
/// brighter metal reaches as far as that sixteenth.
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

/// The least grey that counts as the scan's maximum `top` (a clipped voxel), allowing for the
/// rounding of a stored ceiling.
pub(crate) fn clipped_from(top: f32) -> f32 {
    top - 1e-5 * top.abs().max(1.0)
}

fn saturation(vol: &Volume, metal: &[usize]) -> Option<SaturatedMetal> {
    let top = metal.iter().map(|&m| vol.values[m]).fold(f32::NEG_INFINITY, f32::max);
    let ceiling = clipped_from(top);
    let voxels = metal.iter().filter(|&&m| vol.values[m] >= ceiling).count();
    (voxels >= MIN_METAL_VOXELS).then(|| SaturatedMetal { grey: f64::from(top), voxels })
}

/// How far (mm) from a bright restoration [`hide_bloom_above`] reaches: past the bloom of a blur
/// up to 0.35 mm (a 0.4 mm scan's) beyond the metal's end.
const HIDDEN_MM: f64 = 1.0;

/// The grey levels above which a first calibration that failed may hide a restoration's bloom
/// ([`hide_bloom_above`]), the likeliest first: just under a clipped scan's maximum (at least
/// [`MIN_METAL_VOXELS`] voxels reach it), then a half, a quarter and an eighth of the way from
/// the scan's median grey to its maximum. A restoration's bloom ramps from its metal's grey down
/// to the tissue beside it, and its bumps crowd the histogram's peaks out: a clipped jaw molar's
/// nine were bloom but two, an unclipped 30000 HU filling's in a 0.3 mm incisor all but two.
pub fn bloom_levels(vol: &Volume) -> Vec<f64> {
    let top = vol.values.par_iter().copied().reduce(|| f32::NEG_INFINITY, f32::max);
    if !top.is_finite() {
        return Vec::new();
    }
    let ceiling = clipped_from(top);
    let mut levels = Vec::new();
    if vol.values.par_iter().filter(|&&v| v >= ceiling).count() >= MIN_METAL_VOXELS {
        levels.push(f64::from(ceiling));
    }
    // The median of every 7th voxel: a level's place, not a measure.
    let mut sample: Vec<f32> = vol.values.iter().step_by(7).copied().filter(|v| v.is_finite()).collect();
    if sample.is_empty() {
        return levels;
    }
    let mid = sample.len() / 2;
    let median = f64::from(*sample.select_nth_unstable_by(mid, f32::total_cmp).1);
    levels.extend([0.5, 0.25, 0.125].map(|f| median + f * (f64::from(top) - median)));
    levels
}

/// `vol` with every voxel within [`HIDDEN_MM`] of one at `level` or above set to the scan's
/// maximum, for a calibration counting grey values up to `level` only; `None` unless at least
/// [`MIN_METAL_VOXELS`] voxels reach it.
pub fn hide_bloom_above(vol: &Volume, level: f64) -> Option<Volume> {
    let top = vol.values.par_iter().copied().reduce(|| f32::NEG_INFINITY, f32::max);
    let bright = |m: usize| f64::from(vol.values[m]) >= level;
    if !top.is_finite() || (0..vol.values.len()).into_par_iter().filter(|&m| bright(m)).count() < MIN_METAL_VOXELS {
        return None;
    }
    // A voxel's nearest bright voxel has a face neighbour that is not (one step toward the
    // voxel), so a ball stamped about each such edge voxel covers the reach: no copy of the
    // scan's box and no distance map (a refused 300³ scan of noise peaked at 0.9 GB with them).
    let edge: Vec<usize> = (0..vol.values.len())
        .into_par_iter()
        .filter(|&m| bright(m) && face_neighbours(m, vol.dims).into_iter().any(|q| q.is_some_and(|q| !bright(q))))
        .collect();
    let s = vol.spacing;
    let r = s.map(|a| (HIDDEN_MM / a).floor() as i64);
    let mut ball = Vec::new();
    for k in -r[2]..=r[2] {
        for j in -r[1]..=r[1] {
            for i in -r[0]..=r[0] {
                let d2 = (i as f64 * s[0]).powi(2) + (j as f64 * s[1]).powi(2) + (k as f64 * s[2]).powi(2);
                if d2.sqrt() as f32 <= HIDDEN_MM as f32 {
                    ball.push([i, j, k]);
                }
            }
        }
    }
    let mut out = vol.clone();
    out.values.par_iter_mut().filter(|v| f64::from(**v) >= level).for_each(|v| *v = top);
    let d = vol.dims.map(|v| v as i64);
    for &m in &edge {
        let p = [(m % vol.dims[0]) as i64, ((m / vol.dims[0]) % vol.dims[1]) as i64, (m / (vol.dims[0] * vol.dims[1])) as i64];
        for o in &ball {
            let q = [p[0] + o[0], p[1] + o[1], p[2] + o[2]];
            if (0..3).all(|c| q[c] >= 0 && q[c] < d[c]) {
                out.values[(q[0] + d[0] * (q[1] + d[1] * q[2])) as usize] = top;
            }
        }
    }
    Some(out)
}

/// `vol` with its metal restorations' bloom taken off ([`MetalBloom`]); `None` where the scan
/// shows no metal, or too little of it, or too few clear edges, to measure (the scan is then
/// used as is).
pub fn unbloom(vol: &Volume, cal: &Calibration) -> Option<(Volume, MetalBloom)> {
    let classifier = cal.classifier();
    let metal = metal_voxels(vol, cal);
    if metal.len() < MIN_METAL_VOXELS {
        return None;
    }
    let ceiling = saturation(vol, &metal).map(|s| s.grey);
    // The metal's box, with room for the reach and the lines beyond it.
    let region = padded_box(vol, &metal, 2 + ((MAX_REACH_MM + FAR_MM.1) / vol.min_spacing()).ceil() as usize);
    let part = crop(vol, &region).ok()?;
    let d = part.dims;

    // Each restoration (a component of the metal class) its own metal's grey: the median of its
    // brightest tenth. Its edge and bloom hold most of its class (a 3 mm filling at a 0.2 mm
    // blur: three quarters), so its median is too dark. A core at the scan's clipped maximum
    // is read from the bloom's tail below it instead ([`clipped_metal_grey`]).
    let enamel = cal.peak(Label::Enamel);
    let is_metal: Vec<bool> = part.values.par_iter().map(|&v| classifier.classify(f64::from(v)) == Label::Metal).collect();
    let (component, sizes) = components(d, &is_metal);
    let not_metal: Vec<bool> = is_metal.iter().map(|&m| !m).collect();
    let depth = distance_mm(d, part.spacing, &not_metal);
    let mut members: Vec<Vec<(f32, f32)>> = sizes.iter().map(|&n| Vec::with_capacity(if n >= MIN_METAL_VOXELS { n } else { 0 })).collect();
    for (l, &c) in component.iter().enumerate().filter(|(_, &c)| c != 0 && sizes[c as usize] >= MIN_METAL_VOXELS) {
        members[c as usize].push((part.values[l], depth[l]));
    }
    // Each restoration's middle: the median grey of its deepest tenth.
    let middles: Vec<Option<f64>> = members
        .iter_mut()
        .map(|voxels| {
            voxels.sort_by(|a, b| a.1.total_cmp(&b.1));
            let deepest: Vec<f32> = voxels[voxels.len() * 9 / 10..].iter().map(|v| v.0).collect();
            (deepest.len() >= MIN_CORE_VOXELS).then(|| median(deepest))
        })
        .collect();
    let cores: Vec<Option<Core>> = members
        .into_iter()
        .map(|voxels| {
            let mut greys: Vec<f32> = voxels.into_iter().map(|v| v.0).collect();
            greys.sort_by(f32::total_cmp);
            let brightest = &greys[greys.len() * 9 / 10..];
            let grey = f64::from(*brightest.get(brightest.len() / 2)?);
            if brightest.len() < MIN_CORE_VOXELS {
                return None;
            }
            match ceiling {
                Some(c) if grey >= f64::from(clipped_from(c as f32)) => Some(Core::Clipped(c)),
                _ => (classifier.classify(0.5 * (grey + enamel)) == Label::Metal).then_some(Core::Measured(grey)),
            }
        })
        .collect();
    let metal_grey: Vec<Option<f64>> = cores.iter().map(|c| if let Some(Core::Measured(g)) = c { Some(*g) } else { None }).collect();
    // Where the metal's edge is read: a measured one's grey half-way from the enamel's to its
    // metal's, where the metal ends; a clipped one's half-way from the enamel's to the ceiling,
    // outside its end by the depth its tail gives (infinite elsewhere).
    let edge_level = |core: &Option<Core>| match core {
        Some(Core::Measured(g)) => 0.5 * (g + enamel),
        Some(Core::Clipped(c)) => enamel + 0.5 * (c - enamel),
        None => f64::INFINITY,
    };
    let levels: Vec<f64> = cores.iter().map(edge_level).collect();
    let half_at: Vec<f64> = component.iter().map(|&c| levels[c as usize]).collect();
    let sample = Sampler { values: &part.values, dims: d, spacing: part.spacing };
    // Whether a point (index space) lies within the edge read: its grey past the nearest voxel's level.
    let at_voxel = |p: [f64; 3]| {
        let q = [0, 1, 2].map(|c| (p[c].round().max(0.0) as usize).min(d[c] - 1));
        q[0] + d[0] * (q[1] + d[1] * q[2])
    };
    let in_metal = |p: [f64; 3]| sample.at(p) >= half_at[at_voxel(p)];

    // The lines across the metal's edge: along the grey's gradient through each voxel just
    // outside the edge read.
    let inside: Vec<bool> = part.values.par_iter().zip(&half_at).map(|(&v, &h)| f64::from(v) >= h).collect();
    let edge: Vec<(usize, usize)> = (0..inside.len())
        .filter(|&l| !inside[l])
        .filter_map(|l| face_neighbours(l, d).into_iter().flatten().find(|&q| inside[q]).map(|q| (l, q)))
        .collect();
    let step = 0.25 * part.min_spacing();
    let read_line = |l: usize, level: f64, top: f64| -> Option<EdgeLine> {
        let at = ijk(l, d);
        let out = sample.gradient(at).map(|g| g.map(|v| -v))?;
        EdgeLine::read(|s| sample.at(along(at, out, s, part.spacing)), step, -MAX_REACH_MM, level, top)
    };
    // The blur: on a measured metal's lines, the distance between the crossings of a quarter
    // and three quarters of the way from the tissue beyond to the metal.
    let mut widths: Vec<f64> = edge
        .par_iter()
        .filter_map(|&(l, metal)| {
            let line = read_line(l, half_at[metal], metal_grey[component[metal] as usize]?)?;
            Some((line.s25 - line.s75) / 1.349)
        })
        .collect();
    // With every restoration clipped, the blur is read the same way across the crown's own
    // edges (enamel to what lies beyond it), clear of the metal's bloom.
    if widths.len() < MIN_EDGE_LINES && cores.iter().any(|c| matches!(c, Some(Core::Clipped(_)))) {
        widths = crown_widths(&part, cal, &is_metal, step);
    }
    if widths.len() < MIN_EDGE_LINES {
        return None;
    }
    let mid = widths.len() / 2;
    let blur_mm = *widths.select_nth_unstable_by(mid, f64::total_cmp).1;
    if !(blur_mm.is_finite() && blur_mm > 0.0) {
        return None;
    }

    // Each clipped restoration's metal grey: the median of its lines' tails.
    let mut tails: Vec<Vec<f64>> = vec![Vec::new(); cores.len()];
    let read: Vec<(usize, f64)> = edge
        .par_iter()
        .filter_map(|&(l, metal)| {
            let c = component[metal] as usize;
            let Some(Core::Clipped(top)) = cores[c] else { return None };
            let line = read_line(l, half_at[metal], top)?;
            clipped_metal_grey(&line, top, blur_mm).map(|g| (c, g))
        })
        .collect();
    for (c, g) in read {
        tails[c].push(g);
    }
    let mut found: Vec<(usize, f64)> = metal_grey.iter().enumerate().filter_map(|(c, g)| g.map(|g| (sizes[c], g))).collect();
    // A clipped restoration with too few tails is left as it is.
    let mut clipped_grey: Vec<Option<f64>> = vec![None; cores.len()];
    for (c, t) in tails.iter_mut().enumerate().filter(|(_, t)| t.len() >= MIN_EDGE_LINES) {
        let mid = t.len() / 2;
        let grey = *t.select_nth_unstable_by(mid, f64::total_cmp).1;
        clipped_grey[c] = Some(grey);
        found.push((sizes[c], grey));
    }
    if found.is_empty() {
        return None;
    }
    found.sort_by(|a, b| b.0.cmp(&a.0));
    // The reach: at least REACH_SIGMAS, and as far as the brightest metal's share of the grey
    // stays above a sixteenth of the enamel–dentin contrast over the dentin (a 40000 HU metal's
    // 2.9 σ).
    let brightest = found.iter().map(|&(_, g)| g).fold(f64::NEG_INFINITY, f64::max);
    let (dentin, contrast) = (cal.peak(Label::Dentin), enamel - cal.peak(Label::Dentin));
    let share = contrast / 16.0 / (brightest - dentin);
    let sigmas = if share > 0.0 && share < 0.5 { REACH_SIGMAS.max(-probit(share)) } else { REACH_SIGMAS };
    let reach_mm = (sigmas * blur_mm).min(MAX_REACH_MM);
    // How far inside its edge read each restoration's metal ends, beside a tissue of a grey:
    // not at all for a measured one (its edge read is its end).
    let depth_beside = |c: usize, tissue: f64| -> Option<f64> {
        match cores[c]? {
            Core::Measured(_) => Some(0.0),
            Core::Clipped(_) => Some(clipped_depth(levels[c], tissue, clipped_grey[c]?, blur_mm).min(reach_mm)),
        }
    };
    // A point beside no restoration's edge read takes the largest's.
    let largest = (1..cores.len()).filter(|&c| depth_beside(c, enamel).is_some()).max_by_key(|&c| sizes[c]).unwrap_or(0);

    // Each voxel within the reach of a metal's end: the grey the reach away from it, along the
    // line from the nearest metal through it.
    let max_spacing = part.spacing.iter().fold(0.0f64, |a, &b| a.max(b));
    let distance = distance_mm(d, part.spacing, &inside);
    let dist = Sampler { values: &distance, dims: d, spacing: part.spacing };
    let mut changed: Vec<(usize, f32)> = (0..inside.len())
        .into_par_iter()
        .filter(|&l| !inside[l] && f64::from(distance[l]) <= reach_mm + max_spacing)
        .filter_map(|l| {
            let at = ijk(l, d);
            let out = dist.gradient(at).or_else(|| sample.gradient(at).map(|g| g.map(|v| -v)))?;
            // The edge read behind the voxel, on its line (else, where the line passes beside a
            // rounded edge, as far as the nearest metal voxel), and the metal's end behind that.
            let behind = f64::from(distance[l]);
            let (s, c) = (0..)
                .map(|k| f64::from(k) * step)
                .take_while(|&s| s <= behind + 2.0 * part.min_spacing())
                .find_map(|s| {
                    let p = along(at, out, -s, part.spacing);
                    in_metal(p).then(|| (s, component[at_voxel(p)] as usize))
                })
                .unwrap_or((behind, largest));
            let s = match cores.get(c).copied().flatten() {
                Some(Core::Clipped(_)) => s + depth_beside(c, sample.at(along(at, out, reach_mm - s, part.spacing)))?,
                _ => s,
            };
            (s < reach_mm).then(|| (l, sample.at(along(at, out, reach_mm - s, part.spacing)) as f32))
        })
        .collect();
    // A clipped metal's edge read lies outside its end: the voxels between are bloom too. Those
    // within its end take the ceiling, as an unblurred scan would clip them, so that segmentation's
    // rule for a clipped scan (its metal is what reaches the ceiling) keeps the whole restoration.
    let mut raised: Vec<(usize, f32)> = Vec::new();
    if clipped_grey.iter().any(Option::is_some) {
        let outside: Vec<bool> = inside.iter().map(|&v| !v).collect();
        let within = distance_mm(d, part.spacing, &outside);
        let (bloom, metal): (Vec<_>, Vec<_>) = (0..inside.len()).into_par_iter().filter_map(|l| {
            let c = component[l] as usize;
            let Some(Core::Clipped(ceiling)) = cores[c] else { return None };
            if !inside[l] || clipped_grey[c].is_none() {
                return None;
            }
            let bloom = || {
                let at = ijk(l, d);
                let out = sample.gradient(at).map(|g| g.map(|v| -v))?;
                let to_edge = (0..)
                    .map(|k| f64::from(k) * step)
                    .take_while(|&s| s <= reach_mm + 2.0 * part.min_spacing())
                    .find(|&s| !in_metal(along(at, out, s, part.spacing)))?;
                let s = depth_beside(c, sample.at(along(at, out, to_edge + reach_mm, part.spacing)))? - to_edge;
                (s >= 0.0 && s < reach_mm).then(|| sample.at(along(at, out, reach_mm - s, part.spacing)) as f32)
            };
            let near_edge = f64::from(within[l]) <= reach_mm + max_spacing;
            Some(near_edge.then(bloom).flatten().map_or((l, ceiling as f32, false), |v| (l, v, true)))
        }).partition(|&(_, _, is_bloom)| is_bloom);
        changed.extend(bloom.into_iter().map(|(l, v, _)| (l, v)));
        raised = metal.into_iter().map(|(l, v, _)| (l, v)).collect();
    }
    if changed.is_empty() {
        return None;
    }
    let mut out = vol.clone();
    for &(l, v) in changed.iter().chain(&raised) {
        let p = ijk(l, d);
        let [i, j, k] = [0, 1, 2].map(|c| p[c] as usize + region.min[c]);
        let n = out.index(i, j, k);
        out.values[n] = v;
    }
    let measured = (0..cores.len()).filter(|&c| matches!(cores[c], Some(Core::Measured(_)))).max_by_key(|&c| sizes[c]);
    let cupping = measured.and_then(|c| Some(Cupping { brightest: metal_grey[c]?, middle: middles[c]? }));
    let bloom = MetalBloom { metal_greys: found.into_iter().map(|(_, g)| g).collect(), clipped_at: ceiling.filter(|_| clipped_grey.iter().any(Option::is_some)), blur_mm, reach_mm, voxels: changed.len(), cupping };
    Some((out, bloom))
}

/// A restoration's core: its metal's grey, or the scan's maximum that clips it.
#[derive(Clone, Copy, Debug)]
enum Core {
    Measured(f64),
    Clipped(f64),
}

/// What a line out across an edge from a bright side (`top`) reads.
struct EdgeLine {
    /// Where (mm along the line) it crosses the levels a quarter and three quarters of the way
    /// from the tissue beyond to `top`.
    s25: f64,
    s75: f64,
    /// The tissue beyond: the median grey `FAR_MM` past the edge's crossing, and the spread
    /// (interquartile) of those reads.
    tissue: f64,
    spread: f64,
}

impl EdgeLine {
    /// From `from` (mm, on the bright side) outward; `None` where the line does not start at or
    /// above `level`, or what lies beyond is not darker than it.
    fn read(line: impl Fn(f64) -> f64, step: f64, from: f64, level: f64, top: f64) -> Option<EdgeLine> {
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
        if line(from) < level {
            return None;
        }
        let s_edge = crossing(level, from)?;
        let mut far: Vec<f64> = (0..)
            .map(|k| s_edge + FAR_MM.0 + k as f64 * step)
            .take_while(|&s| s <= s_edge + FAR_MM.1)
            .map(&line)
            .collect();
        far.sort_by(f64::total_cmp);
        let tissue = *far.get(far.len() / 2)?;
        if tissue >= level {
            return None;
        }
        let spread = far[far.len() * 3 / 4] - far[far.len() / 4];
        let s75 = crossing(tissue + 0.75 * (top - tissue), from)?;
        let s25 = crossing(tissue + 0.25 * (top - tissue), s75)?;
        Some(EdgeLine { s25, s75, tissue, spread })
    }
}

/// Φ, the standard normal's distribution function: a blurred step's profile (the bloom's tail
/// here, a root's border behind its ligament in `dentsim_sim`).
pub fn phi(z: f64) -> f64 {
    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
}

/// Φ⁻¹ on (0, 1), by bisection (a few hundred calls a scan).
fn probit(p: f64) -> f64 {
    let (mut lo, mut hi) = (-12.0, 12.0);
    for _ in 0..64 {
        let z = 0.5 * (lo + hi);
        if phi(z) < p { lo = z } else { hi = z }
    }
    0.5 * (lo + hi)
}

/// A clipped metal's grey from one line's tail. Beyond the metal's end the grey is
/// `tissue + (metal − tissue)·Φ(−x/σ)` at `x` mm out; with σ known, the distance between the
/// tail's quarter and three-quarter crossings of the way to the ceiling gives the metal's grey
/// (the higher the metal, the shorter its tail below the ceiling). Fitting σ as well from the
/// tail alone was ill-conditioned.
fn clipped_metal_grey(line: &EdgeLine, ceiling: f64, blur_mm: f64) -> Option<f64> {
    let k = (line.s25 - line.s75) / blur_mm;
    if !(k > 0.0) {
        return None;
    }
    // z: the quarter crossing's place in σ out from the metal's end, where Φ(z + k) = 3 Φ(z).
    // ln Φ(z + k) − ln Φ(z) falls as z rises (Φ is log-concave); at most Φ⁻¹(¼), an unclipped
    // edge's (a wider tail is a metal that barely passes the ceiling).
    let excess = |z: f64| phi(z + k).ln() - phi(z).ln() - 3f64.ln();
    let (mut lo, mut hi) = (-12.0, probit(0.25));
    if excess(hi) >= 0.0 {
        lo = hi;
    }
    for _ in 0..64 {
        let z = 0.5 * (lo + hi);
        if excess(z) > 0.0 { lo = z } else { hi = z }
    }
    let grey = line.tissue + 0.25 * (ceiling - line.tissue) / phi(0.5 * (lo + hi));
    grey.is_finite().then_some(grey)
}

/// How far inside the iso-surface of `level` a metal of grey `metal` ends, beside a tissue of
/// grey `tissue`, at a blur of `blur_mm`: where `tissue + (metal − tissue)·Φ(−x/σ)` = `level`.
fn clipped_depth(level: f64, tissue: f64, metal: f64, blur_mm: f64) -> f64 {
    let share = (level - tissue) / (metal - tissue);
    if share > 0.0 && share < 0.5 { -blur_mm * probit(share) } else { 0.0 }
}

/// The blur (σ, mm) across the crown's own edges: the enamel's against what lies beyond it (the
/// medium outside, or the dentin within), each line's quarter and three-quarter crossings as on
/// a metal's edge. Lines within `CLEAR_OF_METAL_MM` of the metal, or whose tissue beyond is not
/// one plateau (a tenth of the contrast), are left out.
fn crown_widths(part: &Volume, cal: &Calibration, is_metal: &[bool], step: f64) -> Vec<f64> {
    const CLEAR_OF_METAL_MM: f64 = 1.0;
    const ENAMEL_DEPTH_MM: f64 = 0.5;
    let d = part.dims;
    let (enamel, edge_level, top_level) = (cal.peak(Label::Enamel), cal.mid(Label::Dentin, Label::Enamel), cal.mid(Label::Enamel, Label::Metal));
    let is_enamel: Vec<bool> = part.values.par_iter().map(|&v| (edge_level..top_level).contains(&f64::from(v))).collect();
    let from_metal = distance_mm(d, part.spacing, is_metal);
    let sample = Sampler { values: &part.values, dims: d, spacing: part.spacing };
    (0..is_enamel.len())
        .into_par_iter()
        .filter(|&l| f64::from(part.values[l]) < edge_level && f64::from(from_metal[l]) > CLEAR_OF_METAL_MM)
        .filter(|&l| face_neighbours(l, d).into_iter().flatten().any(|q| is_enamel[q]))
        .filter_map(|l| {
            let at = ijk(l, d);
            let out = sample.gradient(at).map(|g| g.map(|v| -v))?;
            let line = EdgeLine::read(|s| sample.at(along(at, out, s, part.spacing)), step, -ENAMEL_DEPTH_MM, edge_level, enamel)?;
            (line.spread < 0.1 * (enamel - line.tissue)).then(|| (line.s25 - line.s75) / 1.349)
        })
        .collect()
}

/// The box of `voxels` (indices into `vol`) grown by `pad` voxels each way, within the scan.
fn padded_box(vol: &Volume, voxels: &[usize], pad: usize) -> IndexBox {
    let [nx, ny, _] = vol.dims;
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    for &m in voxels {
        let p = [m % nx, (m / nx) % ny, m / (nx * ny)];
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    IndexBox { min: lo.map(|v| v.saturating_sub(pad)), max: [0, 1, 2].map(|c| (hi[c] + pad + 1).min(vol.dims[c])) }
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
        // Made without beam hardening: its middle is its brightest part.
        let cupping = bloom.cupping.expect("a measured restoration's cupping");
        assert!(cupping.share(2900.0).abs() < 0.01, "{cupping:?}");
    }

    #[test]
    fn a_metal_darker_in_its_middle_is_read_as_cupped() {
        // A 4 × 4 × 3.5 mm filling read darker the deeper inside it (3000 less 1.5 mm in, 750
        // less 0.75 mm in), as a beam hardened through it reads: its rim brightest, its middle
        // darkest.
        let crown: Filling = ([1.0, 1.0, 0.5], [5.0, 5.0, 4.0], 12000.0);
        let (mut scan, cal) = filled_scan(N, &[crown], f32::INFINITY);
        let (lo, hi, _) = crown;
        for (n, v) in scan.values.iter_mut().enumerate() {
            let p = [n % N, (n / N) % N, n / (N * N)].map(|q| q as f64 * H);
            let depth = (0..3).map(|c| (p[c] - lo[c]).min(hi[c] - p[c])).fold(f64::INFINITY, f64::min);
            *v -= (3000.0 * (depth.max(0.0) / 1.5).powi(2)) as f32;
        }
        let (_, bloom) = unbloom(&scan, &cal).expect("an unclipped filling is measured");
        let cupping = bloom.cupping.expect("a measured restoration's cupping");
        // Read: 10357 in its middle against 11576 at its brightest, 14 % of its lift over the
        // enamel (the unhardened filling's under 1 %).
        assert!(cupping.middle < cupping.brightest - 1000.0 && cupping.share(2900.0) > 0.1, "{cupping:?}");
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
    fn a_clipped_fillings_grey_and_end_are_read_from_its_bloom() {
        // The unclipped filling's metal class is 6.5 mm³ (the test above); clipped, its bloom
        // made it 13.9 mm³. Read from the tail, the metal reads low the more the scan clips (the
        // crown's blur, 0.211 mm, is a little under the metal edge's 0.220), so its end lies a
        // little outside the truth: some tissue beside it is counted metal, none metal tissue.
        for (ceiling, grey_within, metal_mm3_within) in [(8000.0, 0.10, (6.5, 8.6)), (5000.0, 0.25, (6.5, 9.3))] {
            let (scan, cal) = filled_scan(N, &[AMALGAM], ceiling);
            assert!(saturated_metal(&scan, &cal).is_some_and(|s| s.grey == f64::from(ceiling) && s.voxels > 1000));
            let (clean, bloom) = unbloom(&scan, &cal).expect("a clipped filling is measured");
            assert_eq!(bloom.clipped_at, Some(f64::from(ceiling)), "{bloom:?}");
            assert_eq!(bloom.metal_greys.len(), 1, "{bloom:?}");
            assert!((bloom.metal_greys[0] / 12000.0 - 1.0).abs() < grey_within, "{ceiling}: {bloom:?}");
            assert!((0.18..0.26).contains(&bloom.blur_mm), "{bloom:?}");
            let (before, after) = (metal_mm3(&scan, &cal), metal_mm3(&clean, &cal));
            assert!(before > 13.0, "the bloom this test is about: {before} mm³ of metal");
            assert!((metal_mm3_within.0..metal_mm3_within.1).contains(&after), "{ceiling}: {after} mm³ of metal");
            // Within its end the metal reads the ceiling, as segmentation's rule for a clipped scan wants.
            let at_ceiling = clean.values.iter().filter(|&&v| v >= ceiling).count() as f64 * H * H * H;
            assert!((at_ceiling - after).abs() < 0.05 * after, "{ceiling}: {at_ceiling} mm³ at the ceiling, {after} mm³ of metal");
            let (wrong_before, wrong_after, seen) = misread(&scan, &clean, &cal, &[AMALGAM]);
            assert!(wrong_before > seen / 10, "the bloom this test is about: {wrong_before} of {seen} voxels in another class");
            assert_eq!(wrong_after, 0, "{ceiling}: {wrong_after} of {seen} tissue voxels beside the metal in another class");
        }
    }

    #[test]
    fn a_restorations_bloom_is_hidden_for_a_first_calibration() {
        let (scan, _) = filled_scan(N, &[AMALGAM], 5000.0);
        let levels = bloom_levels(&scan);
        // Just under the ceiling first, then down toward the median (the dentin's 1800 here).
        assert!(levels.len() == 4 && levels[0] < 5000.0 && levels[0] > 4999.0, "{levels:?}");
        assert!(levels.windows(2).all(|w| w[1] < w[0]) && (levels[1] - 3400.0).abs() < 100.0, "{levels:?}");
        let hidden = hide_bloom_above(&scan, levels[0]).expect("a clipped scan");
        // Nothing of the bloom (above the enamel's 2900 and under the ceiling) is left, and the
        // tissue clear of the metal (1.2 mm from its box) is as it was.
        let ramp = hidden.values.iter().filter(|&&v| (3400.0..4999.0).contains(&v)).count();
        assert_eq!(ramp, 0, "{ramp} voxels of bloom left");
        let far = (0..scan.values.len()).filter(|&n| {
            let p = [n % N, (n / N) % N, n / (N * N)].map(|v| v as f64 * H);
            (0..3).map(|c| (AMALGAM.0[c] - p[c]).max(p[c] - AMALGAM.1[c])).fold(f64::NEG_INFINITY, f64::max) > 1.2
        });
        assert!(far.clone().count() > 50_000 && far.clone().all(|n| hidden.values[n] == scan.values[n]));
        // An unclipped scan has no ceiling to start from; its metal lies above the first level.
        let (unclipped, _) = filled_scan(N, &[AMALGAM], f32::INFINITY);
        let levels = bloom_levels(&unclipped);
        assert_eq!(levels.len(), 3, "{levels:?}");
        let hidden = hide_bloom_above(&unclipped, levels[0]).expect("its metal reaches the level");
        assert_eq!(hidden.values.iter().filter(|&&v| (3400.0..f32::from(levels[0] as f32)).contains(&v)).count(), 0);
    }

    #[test]
    fn a_scan_without_a_filling_is_left_as_it_is() {
        let (plain, cal) = filled_scan(N, &[], f32::INFINITY);
        assert_eq!(unbloom(&plain, &cal), None);
        assert_eq!(saturated_metal(&plain, &cal), None);
        let (unclipped, cal) = filled_scan(N, &[AMALGAM], f32::INFINITY);
        assert_eq!(saturated_metal(&unclipped, &cal), None);
    }
}
