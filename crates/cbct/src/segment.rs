//! Tissue segmentation of one tooth from a calibrated scan.
//!
//! 1. Background classes by the calibration's thresholds (air … enamel, metal), one pass.
//! 2. Hard tissue core (dentin or enamel class), opened (6-neighbour erode + dilate) to cut thin
//!    bridges to bone and neighbours; the connected component at the seed is the tooth.
//! 3. Enclosed cavities of the tooth (flood fill from outside its box) are pulp (or caries), told
//!    apart from dentin by the pulp's own measured grey value: topology, not grey, finds the pulp.
//! 4. The outer surface is refined voxel by voxel at the midpoint between the inside tissue and
//!    the local outside tissue (air, soft tissue, bone), so partial volume does not bias volumes.
//! Cost: a few linear passes over the volume (or over the selected box).

use crate::calibrate::Calibration;
use crate::error::{Error, Result};
use crate::volume::{LabelVolume, Volume};
use crate::Label;
use rayon::prelude::*;
use std::collections::VecDeque;

/// Which tooth to segment: FDI number (ISO 3950) and a point inside it or a box around it (LPS mm).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ToothSelect {
    pub fdi: u8,
    pub seed: [f64; 3],
    /// Optional LPS box (min, max) the tooth lies in; the search is limited to it.
    pub bounds: Option<([f64; 3], [f64; 3])>,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SegmentOptions {
    pub tooth: Option<ToothSelect>,
    /// Cavities of the tooth smaller than this are dentin (noise), not pulp.
    pub min_component_voxels: usize,
    /// Erode/dilate the core before taking components (cuts 1–2 voxel bridges).
    pub opening: bool,
    /// Label cavities whose grey is closer to demineralised tissue than to pulp as caries.
    pub detect_caries: bool,
}

impl Default for SegmentOptions {
    fn default() -> Self {
        SegmentOptions { tooth: None, min_component_voxels: 20, opening: true, detect_caries: true }
    }
}

/// Valid ISO 3950 tooth number (permanent 11–48, primary 51–85).
pub fn valid_fdi(fdi: u8) -> bool {
    let (q, t) = (fdi / 10, fdi % 10);
    ((1..=4).contains(&q) && (1..=8).contains(&t)) || ((5..=8).contains(&q) && (1..=5).contains(&t))
}

struct Grid {
    d: [usize; 3],
}
impl Grid {
    fn n(&self) -> usize {
        self.d[0] * self.d[1] * self.d[2]
    }
    fn ijk(&self, n: usize) -> [usize; 3] {
        [n % self.d[0], (n / self.d[0]) % self.d[1], n / (self.d[0] * self.d[1])]
    }
    /// 6-neighbours of a linear index.
    fn nb6(&self, n: usize, out: &mut [usize; 6]) -> usize {
        let [i, j, k] = self.ijk(n);
        let (sx, sy) = (1, self.d[0]);
        let sz = self.d[0] * self.d[1];
        let mut c = 0;
        if i > 0 {
            out[c] = n - sx;
            c += 1;
        }
        if i + 1 < self.d[0] {
            out[c] = n + sx;
            c += 1;
        }
        if j > 0 {
            out[c] = n - sy;
            c += 1;
        }
        if j + 1 < self.d[1] {
            out[c] = n + sy;
            c += 1;
        }
        if k > 0 {
            out[c] = n - sz;
            c += 1;
        }
        if k + 1 < self.d[2] {
            out[c] = n + sz;
            c += 1;
        }
        c
    }
}

/// One 6-neighbour erosion (`grow = false`) or dilation (`grow = true`) step.
fn morph(g: &Grid, m: &[bool], grow: bool) -> Vec<bool> {
    let mut out = vec![false; m.len()];
    out.par_iter_mut().enumerate().for_each(|(n, o)| {
        let mut nb = [0usize; 6];
        let c = g.nb6(n, &mut nb);
        *o = if grow { m[n] || nb[..c].iter().any(|&q| m[q]) } else { m[n] && c == 6 && nb.iter().all(|&q| m[q]) };
    });
    out
}

/// Flood fill (6-connected) over `allowed` from `starts`.
fn flood(g: &Grid, allowed: &[bool], starts: impl IntoIterator<Item = usize>) -> Vec<bool> {
    let mut seen = vec![false; allowed.len()];
    let mut q = VecDeque::new();
    for s in starts {
        if allowed[s] && !seen[s] {
            seen[s] = true;
            q.push_back(s);
        }
    }
    let mut nb = [0usize; 6];
    while let Some(n) = q.pop_front() {
        let c = g.nb6(n, &mut nb);
        for &m in &nb[..c] {
            if allowed[m] && !seen[m] {
                seen[m] = true;
                q.push_back(m);
            }
        }
    }
    seen
}

/// Connected components (6-connected) of `m`: component id per voxel (0 = none) and sizes.
fn components(g: &Grid, m: &[bool]) -> (Vec<u32>, Vec<usize>) {
    let mut id = vec![0u32; m.len()];
    let mut sizes = vec![0usize];
    let mut q = VecDeque::new();
    let mut nb = [0usize; 6];
    for s in 0..m.len() {
        if !m[s] || id[s] != 0 {
            continue;
        }
        let c = sizes.len() as u32;
        sizes.push(0);
        id[s] = c;
        q.push_back(s);
        while let Some(n) = q.pop_front() {
            sizes[c as usize] += 1;
            let k = g.nb6(n, &mut nb);
            for &t in &nb[..k] {
                if m[t] && id[t] == 0 {
                    id[t] = c;
                    q.push_back(t);
                }
            }
        }
    }
    (id, sizes)
}

fn median(v: &mut [f32]) -> f32 {
    let m = v.len() / 2;
    *v.select_nth_unstable_by(m, |a, b| a.total_cmp(b)).1
}

fn snap(v: f64, cal: &Calibration, among: &[Label]) -> Label {
    *among.iter().min_by(|a, b| (cal.peak(**a) - v).abs().total_cmp(&(cal.peak(**b) - v).abs())).unwrap_or(&among[0])
}

/// Segments the scan. With `opts.tooth`, only that tooth's enamel, dentin, pulp (and caries) are
/// labelled as such; hard tissue elsewhere (bone, other teeth) is reported as `bone_cortical`.
/// Without it, every tooth-like component is labelled.
pub fn segment(vol: &Volume, cal: &Calibration, opts: &SegmentOptions) -> Result<LabelVolume> {
    let g = Grid { d: vol.dims };
    let n = g.n();
    if n == 0 || vol.values.len() != n {
        return Err(Error::invalid("volume", "empty or inconsistent volume"));
    }
    let mut out = vol.label_volume();
    out.labels.par_iter_mut().zip(vol.values.par_iter()).for_each(|(l, &v)| *l = cal.classify(v as f64) as u8);
    let is_hard = |l: u8| l == Label::Dentin as u8 || l == Label::Enamel as u8;
    let mut core: Vec<bool> = out.labels.par_iter().map(|&l| is_hard(l)).collect();
    // Limit to the selection box.
    let mut lo = [0usize; 3];
    let mut hi = vol.dims;
    if let Some(sel) = &opts.tooth {
        if !valid_fdi(sel.fdi) {
            return Err(Error::invalid("tooth", format!("FDI {} is not an ISO 3950 tooth number", sel.fdi)));
        }
        if let Some((a, b)) = sel.bounds {
            let ia = vol.world_to_index(a).ok_or_else(|| Error::invalid("tooth.bounds", "degenerate geometry"))?;
            let ib = vol.world_to_index(b).ok_or_else(|| Error::invalid("tooth.bounds", "degenerate geometry"))?;
            for c in 0..3 {
                let (x, y) = (ia[c].min(ib[c]), ia[c].max(ib[c]));
                lo[c] = x.floor().clamp(0.0, vol.dims[c] as f64) as usize;
                hi[c] = (y.ceil() as isize + 1).clamp(0, vol.dims[c] as isize) as usize;
            }
            core.par_iter_mut().enumerate().for_each(|(n, c)| {
                let p = [n % g.d[0], (n / g.d[0]) % g.d[1], n / (g.d[0] * g.d[1])];
                if (0..3).any(|a| p[a] < lo[a] || p[a] >= hi[a]) {
                    *c = false;
                }
            });
        }
    }
    // Markers: the core eroded by ~0.6 mm, which separates teeth touching at contact points and
    // roots touching bone; each marker then regrows over the core (multi-source breadth-first),
    // so every core voxel goes to the nearest marker.
    let r = if opts.opening { ((0.6 / vol.spacing.iter().cloned().fold(f64::INFINITY, f64::min)).round() as usize).clamp(1, 4) } else { 0 };
    let mut eroded = core.clone();
    for _ in 0..r {
        eroded = morph(&g, &eroded, false);
    }
    let (mut id, sizes) = components(&g, &eroded);
    // Small markers (thin root walls cut apart by the erosion, noise) would steal parts of a
    // tooth: drop them, and let the big ones regrow over their voxels.
    let vox = vol.spacing[0] * vol.spacing[1] * vol.spacing[2];
    let min_marker = ((3.0 / vox) as usize).max(opts.min_component_voxels);
    id.iter_mut().for_each(|c| {
        if *c != 0 && sizes[*c as usize] < min_marker {
            *c = 0;
        }
    });
    {
        let mut q: VecDeque<usize> = (0..n).filter(|&m| id[m] != 0).collect();
        let mut nb = [0usize; 6];
        while let Some(m) = q.pop_front() {
            let c = g.nb6(m, &mut nb);
            for &t in &nb[..c] {
                if core[t] && id[t] == 0 {
                    id[t] = id[m];
                    q.push_back(t);
                }
            }
        }
    }
    let keep: Vec<bool> = match &opts.tooth {
        Some(sel) => {
            let s = vol.world_to_index(sel.seed).ok_or_else(|| Error::invalid("tooth.seed", "degenerate geometry"))?;
            let si = [s[0].round(), s[1].round(), s[2].round()];
            if (0..3).any(|c| si[c] < 0.0 || si[c] >= vol.dims[c] as f64) {
                return Err(Error::invalid("tooth.seed", format!("{:?} lies outside the scan", sel.seed)));
            }
            let sn = vol.index(si[0] as usize, si[1] as usize, si[2] as usize);
            // component at the seed, else the nearest one (breadth-first from the seed)
            let mut target = id[sn];
            if target == 0 {
                let all = vec![true; n];
                let mut q = VecDeque::from([sn]);
                let mut seen = vec![false; n];
                seen[sn] = true;
                let mut nb = [0usize; 6];
                let mut steps = 0;
                'search: while let Some(m) = q.pop_front() {
                    steps += 1;
                    if steps > 2_000_000 {
                        break;
                    }
                    let c = g.nb6(m, &mut nb);
                    for &t in &nb[..c] {
                        if all[t] && !seen[t] {
                            if id[t] != 0 {
                                target = id[t];
                                break 'search;
                            }
                            seen[t] = true;
                            q.push_back(t);
                        }
                    }
                }
            }
            if target == 0 {
                return Err(Error::invalid("tooth.seed", format!("no tooth (dentin/enamel) found near {:?}", sel.seed)));
            }
            id.iter().map(|&c| c == target).collect()
        }
        None => id.iter().map(|&c| c != 0 && sizes[c as usize] >= opts.min_component_voxels.max(1)).collect(),
    };
    let tooth = keep;
    // Cavities: not reachable from outside the tooth's box.
    let (mut blo, mut bhi) = ([usize::MAX; 3], [0usize; 3]);
    for (m, _) in tooth.iter().enumerate().filter(|(_, t)| **t) {
        let p = g.ijk(m);
        for c in 0..3 {
            blo[c] = blo[c].min(p[c]);
            bhi[c] = bhi[c].max(p[c]);
        }
    }
    if blo[0] == usize::MAX {
        return Ok(out);
    }
    for c in 0..3 {
        blo[c] = blo[c].saturating_sub(2);
        bhi[c] = (bhi[c] + 2).min(vol.dims[c] - 1);
    }
    let in_box = |m: usize| {
        let p = g.ijk(m);
        (0..3).all(|c| p[c] >= blo[c] && p[c] <= bhi[c])
    };
    let on_box_face = |m: usize| {
        let p = g.ijk(m);
        (0..3).any(|c| p[c] == blo[c] || p[c] == bhi[c])
    };
    // Close 1-voxel holes in thin walls (noise, partial volume at root canals) before asking
    // which voxels the outside cannot reach.
    let closed = morph(&g, &morph(&g, &tooth, true), false);
    let open: Vec<bool> = (0..n).map(|m| !(tooth[m] || closed[m]) && in_box(m)).collect();
    let outside = flood(&g, &open, (0..n).filter(|&m| open[m] && on_box_face(m)));
    let cavity: Vec<bool> = (0..n).map(|m| open[m] && !outside[m]).collect();
    let filled: Vec<bool> = (0..n).map(|m| tooth[m] || cavity[m]).collect();

    // Outer surface refinement in a 2-voxel ring on both sides of the filled tooth's surface.
    let near_out = morph(&g, &morph(&g, &filled, true), true);
    let inner = morph(&g, &morph(&g, &filled, false), false);
    let ring: Vec<usize> = (0..n).filter(|&m| near_out[m] && !inner[m] && !cavity[m]).collect();
    let outside_classes = [Label::Air, Label::SoftTissue, Label::BoneCancellous, Label::BoneCortical];
    let hard = [Label::Dentin, Label::Enamel];
    let decisions: Vec<(usize, Option<Label>)> = ring
        .par_iter()
        .map(|&m| {
            let p = g.ijk(m);
            let (mut ins, mut outs) = (Vec::with_capacity(125), Vec::with_capacity(125));
            for dk in -2i64..=2 {
                for dj in -2i64..=2 {
                    for di in -2i64..=2 {
                        let q = [p[0] as i64 + di, p[1] as i64 + dj, p[2] as i64 + dk];
                        if (0..3).any(|c| q[c] < 0 || q[c] >= g.d[c] as i64) {
                            continue;
                        }
                        let t = q[0] as usize + g.d[0] * (q[1] as usize + g.d[1] * q[2] as usize);
                        if inner[t] && tooth[t] {
                            ins.push(vol.values[t]);
                        } else if !filled[t] {
                            outs.push(vol.values[t]);
                        }
                    }
                }
            }
            let mu_in = if ins.is_empty() { Label::Dentin } else { snap(median(&mut ins) as f64, cal, &hard) };
            let mu_out = if outs.is_empty() { Label::SoftTissue } else { snap(median(&mut outs) as f64, cal, &outside_classes) };
            // Roots sit in bone behind a periodontal ligament (soft tissue, ~0.2 mm): the
            // surface there is the dentin/ligament edge, so the ligament is the outside partner.
            let mu_out = if matches!(mu_out, Label::BoneCancellous | Label::BoneCortical) { Label::SoftTissue } else { mu_out };
            let inside = vol.values[m] as f64 > cal.mid(mu_in, mu_out);
            (m, inside.then_some(mu_in))
        })
        .collect();
    let mut refined = filled.clone();
    let mut surface_label = vec![0u8; 0];
    surface_label.resize(n, 0);
    for (m, d) in decisions {
        refined[m] = d.is_some();
        if let Some(l) = d {
            surface_label[m] = l as u8;
        }
    }
    // Cavity components: pulp or caries by their own median grey value.
    let (cid, csizes) = components(&g, &cavity);
    let mut cav_vals: Vec<Vec<f32>> = vec![Vec::new(); csizes.len()];
    let deep = morph(&g, &cavity, false);
    for m in 0..n {
        if cid[m] != 0 {
            cav_vals[cid[m] as usize].push(vol.values[m]);
        }
    }
    let mut deep_vals: Vec<Vec<f32>> = vec![Vec::new(); csizes.len()];
    for m in 0..n {
        if deep[m] && cid[m] != 0 {
            deep_vals[cid[m] as usize].push(vol.values[m]);
        }
    }
    let (pulp_ref, caries_ref, dentin_ref) = (cal.peak(Label::Pulp), cal.peak(Label::Caries), cal.peak(Label::Dentin));
    let cav_class: Vec<(Label, f64)> = (0..csizes.len())
        .map(|c| {
            if c == 0 || csizes[c] < opts.min_component_voxels {
                return (Label::Dentin, 0.0);
            }
            let vals = if deep_vals[c].len() >= 8 { &mut deep_vals[c] } else { &mut cav_vals[c] };
            let med = median(vals) as f64;
            let is_caries = opts.detect_caries && (med - caries_ref).abs() < (med - pulp_ref).abs();
            let class = if is_caries { Label::Caries } else { Label::Pulp };
            // Threshold against dentin at the midpoint of this cavity's measured grey and dentin's.
            (class, 0.5 * (med.min(dentin_ref) + dentin_ref))
        })
        .collect();
    let enamel_cut = cal.mid(Label::Dentin, Label::Enamel);
    for m in 0..n {
        let l = &mut out.labels[m];
        if refined[m] {
            *l = if cid[m] != 0 {
                let (class, thr) = cav_class[cid[m] as usize];
                if class != Label::Dentin && (vol.values[m] as f64) < thr { class } else { Label::Dentin }
            } else if surface_label[m] != 0 {
                if surface_label[m] == Label::Enamel as u8 || (vol.values[m] as f64) <= enamel_cut { Label::from_u8(surface_label[m]).unwrap_or(Label::Dentin) } else { Label::Enamel }
            } else if (vol.values[m] as f64) > enamel_cut {
                Label::Enamel
            } else {
                Label::Dentin
            } as u8;
        } else if is_hard(*l) && opts.tooth.is_some() {
            *l = Label::BoneCortical as u8;
        } else if is_hard(*l) {
            *l = Label::BoneCortical as u8;
        }
    }
    Ok(out)
}

/// Dice overlap of one label between two label volumes (1 = identical; 1 when both lack it).
pub fn dice(a: &LabelVolume, b: &LabelVolume, label: Label) -> f64 {
    let l = label as u8;
    let (mut both, mut na, mut nb) = (0usize, 0usize, 0usize);
    for (x, y) in a.labels.iter().zip(&b.labels) {
        let (p, q) = (*x == l, *y == l);
        na += p as usize;
        nb += q as usize;
        both += (p && q) as usize;
    }
    if na + nb == 0 {
        1.0
    } else {
        2.0 * both as f64 / (na + nb) as f64
    }
}

/// Smooth inside-ness of one tissue on the scan grid: its 0/1 indicator blurred with a Gaussian
/// of σ = 0.8 voxel. Values in 0..1, iso-surface 0.5; trilinear upsampling of this field gives a
/// level set without the scan grid's staircase.
pub fn tissue_field(vol: &Volume, labels: &LabelVolume, label: Label) -> Vec<f32> {
    let l = label as u8;
    let mut f: Vec<f32> = labels.labels.iter().map(|&x| if x == l { 1.0 } else { 0.0 }).collect();
    if f.len() == vol.len() {
        crate::phantom::gaussian_blur(&mut f, vol.dims, [0.8; 3]);
    }
    f
}
