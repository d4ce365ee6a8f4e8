//! Tissue segmentation of one tooth from a calibrated scan.
//!
//! 1. Background classes by the calibration's thresholds (air … enamel, metal), one pass; the
//!    metal class cleaned of streaks (`clean_metal`).
//! 2. Hard tissue core (dentin or enamel class), opened (6-neighbour erode + dilate) to cut thin
//!    bridges to bone and neighbours; the connected component at the seed is the tooth.
//! 3. Cavities of the tooth: enclosed (flood fill from outside its box), or behind a neck at most
//!    2 voxels wide with a body; and lesions open to the surface, in pockets of the tooth's
//!    outline (`open_lesions`). Topology, not grey, finds them; position and grey tell them apart:
//!    a lesion comes near the crown's surface and its deepest voxels have the lesion's grey,
//!    the pulp lies under the enamel and a dentin wall. The pulp's border against the dentin is
//!    at the midpoint of its measured grey and the dentin's.
//! 4. The outer surface is refined voxel by voxel at the midpoint between the inside tissue and
//!    the local outside tissue (air, soft tissue, bone), so partial volume does not bias volumes.
//! 5. A lesion's border is refined the same way against the enamel, the dentin or the outside
//!    (`refine_lesion_border`).
//!
//! Cost: a few linear passes over the volume for steps 1–2; the rest in the tooth's box (a few
//! distance transforms there) and in the metal's and the lesions' boxes.

use crate::Label;
use crate::calibrate::Calibration;
use crate::error::{Error, Result};
use crate::partial_volume::distance_mm;
use crate::volume::{LabelVolume, Volume};
use rayon::prelude::*;
use crate::mask::{components, flood_from_border, neighbour_map};
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

use crate::roi::valid_fdi;

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
    if grow {
        neighbour_map(g.d, m, false, |own, near| own || near.iter().any(|&v| v))
    } else {
        neighbour_map(g.d, m, false, |own, near| own && near.iter().all(|&v| v))
    }
}

/// One 6-neighbour erosion of `m` inside a box whose outside counts as set: a mask of what lies
/// outside the tooth stays open at the box's faces.
fn erode_in_box(g: &Grid, m: &[bool]) -> Vec<bool> {
    neighbour_map(g.d, m, true, |own, near| own && near.iter().all(|&v| v))
}

/// A box of a grid (inclusive corners) as a grid of its own.
struct BoxGrid {
    g: Grid,
    lo: [usize; 3],
    /// the parent grid's x and y sizes
    stride: [usize; 2],
}

impl BoxGrid {
    fn new(lo: [usize; 3], hi: [usize; 3], whole: &Grid) -> BoxGrid {
        BoxGrid { g: Grid { d: [hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1] }, lo, stride: [whole.d[0], whole.d[1]] }
    }
    /// Index in the parent grid of a box index.
    fn global(&self, l: usize) -> usize {
        let p = self.g.ijk(l);
        (p[0] + self.lo[0]) + self.stride[0] * ((p[1] + self.lo[1]) + self.stride[1] * (p[2] + self.lo[2]))
    }
    fn on_face(&self, l: usize) -> bool {
        let p = self.g.ijk(l);
        (0..3).any(|c| p[c] == 0 || p[c] + 1 == self.g.d[c])
    }
    fn gather<T: Copy>(&self, m: &[T]) -> Vec<T> {
        // Row by row (a search box of 11 M voxels: 57 → a few ms against voxel by voxel).
        let [dx, dy, dz] = self.g.d;
        let mut out = Vec::with_capacity(self.g.n());
        for k in 0..dz {
            for j in 0..dy {
                let start = self.lo[0] + self.stride[0] * ((j + self.lo[1]) + self.stride[1] * (k + self.lo[2]));
                out.extend_from_slice(&m[start..start + dx]);
            }
        }
        out
    }
}

/// With a seed and no box, markers are sought this far (mm) around the seed first: the longest
/// tooth (a canine, ~27 mm) reaches no farther from a point in its crown.
const SEARCH_MM: f64 = 22.0;
/// A tooth found this near (voxels) a side of that search box is sought again in the whole scan.
const SEARCH_MARGIN: usize = 4;

/// Widest mouth (mm) through which a lesion open to the surface is still told from the outside:
/// the radius of the ball that closes the tooth's outline over it. A lesion under a fissure whose
/// roof is thinner than the scan's blur opens ~1.4 mm wide at a 0.25 mm point spread.
const LESION_MOUTH_MM: f64 = 1.0;

/// A cavity found behind a neck or in a pocket of the outline, or a lesion, must have a body:
/// a voxel more than this many voxels from its outside (a ball 5 voxels across). The
/// partial-volume layer where air meets enamel in a fissure is thinner.
const BODY_VOXELS: f32 = 2.0;

/// How near (mm) the crown's surface a cavity must come to be a lesion. Caries starts at the
/// surface of the enamel (occlusal, proximal) or beside a restoration and progresses inward, so a
/// lesion reaches the surface or lies just under it (a hidden lesion under a thin roof); the pulp
/// lies under the enamel and a dentin wall. On the molar phantom at 0.10–0.25 mm of blur the
/// lesion comes within 0.28–0.45 mm, the pulp chamber no nearer than 2.0 mm and the canals, where
/// they pass the cervical enamel, 1.18 mm. The enamel alone would not do: the pulp horns come
/// within 0.6 mm of it.
const LESION_SURFACE_MM: f32 = 0.8;

/// Measures of the components of a cavity mask (index 0 = no component).
struct CavityStats {
    voxels: usize,
    /// Deepest voxel's distance from the component's outside, mm.
    depth: f32,
    /// Median grey of the deepest voxels (within a voxel of `depth`).
    grey: f64,
    /// Nearest approach to the crown's surface, mm.
    to_surface: f32,
    all: Vec<f32>,
}

impl CavityStats {
    fn at_surface(&self) -> bool {
        self.to_surface <= LESION_SURFACE_MM
    }
    fn has_body(&self, h: f32) -> bool {
        self.depth > BODY_VOXELS * h + 1e-3
    }
}

/// Measures of the components `id` (of `mask`) on grid `g`, whose grey values are `vals`.
fn cavity_stats(g: &Grid, id: &[u32], count: usize, mask: &[bool], to_surface: &[f32], vals: &[f32], spacing: [f64; 3]) -> Vec<CavityStats> {
    let depth = distance_mm(g.d, spacing, &mask.iter().map(|&b| !b).collect::<Vec<bool>>());
    let h = spacing.iter().cloned().fold(f64::INFINITY, f64::min) as f32;
    let mut stats: Vec<CavityStats> = (0..count).map(|_| CavityStats { voxels: 0, depth: 0.0, grey: 0.0, to_surface: f32::INFINITY, all: Vec::new() }).collect();
    for l in 0..g.n() {
        let c = id[l] as usize;
        if c == 0 {
            continue;
        }
        let s = &mut stats[c];
        s.voxels += 1;
        s.depth = s.depth.max(depth[l]);
        s.all.push(vals[l]);
        s.to_surface = s.to_surface.min(to_surface[l]);
    }
    let mut core: Vec<Vec<f32>> = vec![Vec::new(); count];
    for l in 0..g.n() {
        let c = id[l] as usize;
        if c != 0 && depth[l] >= stats[c].depth - h {
            core[c].push(vals[l]);
        }
    }
    for (s, mut v) in stats.iter_mut().zip(core) {
        if !v.is_empty() {
            s.grey = median(&mut v) as f64;
        }
    }
    stats
}

/// Voxels within `r` mm of a seed voxel (Euclidean), by stamping a ball at each seed that has a
/// 6-neighbour off the seed mask (the inside is covered by the seeds themselves). Cost ∝ seed
/// surface × ball volume: for a radius of a few voxels, far below a distance transform.
fn within(g: &Grid, seeds: &[bool], r: f64, spacing: [f64; 3]) -> Vec<bool> {
    let reach = [0, 1, 2].map(|c| (r / spacing[c]).floor() as i64);
    let mut ball = Vec::new();
    for dk in -reach[2]..=reach[2] {
        for dj in -reach[1]..=reach[1] {
            for di in -reach[0]..=reach[0] {
                let d2 = (di as f64 * spacing[0]).powi(2) + (dj as f64 * spacing[1]).powi(2) + (dk as f64 * spacing[2]).powi(2);
                if d2 <= r * r * (1.0 + 1e-9) {
                    ball.push([di, dj, dk]);
                }
            }
        }
    }
    let mut out = seeds.to_vec();
    let mut nb = [0usize; 6];
    for s in 0..g.n() {
        if !seeds[s] {
            continue;
        }
        let k = g.nb6(s, &mut nb);
        if k == 6 && nb.iter().all(|&q| seeds[q]) {
            continue;
        }
        let p = g.ijk(s);
        for o in &ball {
            let q = [p[0] as i64 + o[0], p[1] as i64 + o[1], p[2] as i64 + o[2]];
            if (0..3).all(|c| q[c] >= 0 && q[c] < g.d[c] as i64) {
                out[q[0] as usize + g.d[0] * (q[1] as usize + g.d[1] * q[2] as usize)] = true;
            }
        }
    }
    out
}

/// What a cavity of the tooth holds, and for the pulp the grey below which a voxel is pulp.
struct Cavity {
    class: Label,
    threshold: f64,
    /// median grey of its deepest voxels
    grey: f64,
}

/// Linear indices (x fastest) of the voxels within `r` of `p` along every axis, in a grid of
/// dimensions `d`.
fn cube_around(p: [usize; 3], r: i64, d: [usize; 3]) -> impl Iterator<Item = usize> {
    lattice_around(p, r, [1; 3], d)
}

/// Whether the grey rises outward of `body` at `p`: the grey's gradient (differences across the
/// 3³ block about `p`) points away from the body's voxels in the 5³ block about it, whose centre
/// lies a voxel or more away (beside the body's border, not in a hole of it: a canal's open apex,
/// where the grey rises from the canal into the root). Both in voxels: a spacing's stretch of the
/// one is undone in the other, so the sign is the world's on any grid.
fn rises_outward(p: [usize; 3], d: [usize; 3], body: &[bool], grey: &[f32]) -> bool {
    if (0..3).any(|c| p[c] < 2 || p[c] + 2 >= d[c]) {
        return false;
    }
    let offset = |q: usize| -> [f64; 3] {
        let at = [q % d[0], (q / d[0]) % d[1], q / (d[0] * d[1])];
        std::array::from_fn(|c| at[c] as f64 - p[c] as f64)
    };
    let (mut outward, mut count) = ([0.0f64; 3], 0usize);
    for q in lattice_around(p, 2, [1; 3], d).filter(|&q| body[q]) {
        let o = offset(q);
        (0..3).for_each(|c| outward[c] -= o[c]);
        count += 1;
    }
    // Away from the body by a voxel at least: beside its border, not in a hole of it (a canal).
    if count == 0 || outward.iter().map(|o| o * o).sum::<f64>() < (count * count) as f64 {
        return false;
    }
    let mut gradient = [0.0f64; 3];
    for q in cube_around(p, 1, d) {
        let o = offset(q);
        (0..3).for_each(|c| gradient[c] += f64::from(grey[q]) * o[c]);
    }
    (0..3).map(|c| gradient[c] * outward[c]).sum::<f64>() > 0.0
}

/// The (2r+1)³ lattice about `p` with `steps` voxels between its points along each axis, within
/// the grid `d`.
fn lattice_around(p: [usize; 3], r: i64, steps: [usize; 3], d: [usize; 3]) -> impl Iterator<Item = usize> {
    // Each axis's offsets clipped to the grid first (the surface refinement reads 250 per ring
    // voxel: testing each point made it 95 ms of the bench tooth's segmentation).
    let [x, y, z] = [0, 1, 2].map(|c| {
        let (at, s) = (p[c] as i64, steps[c] as i64);
        ((-r).max(-(at / s)), r.min((d[c] as i64 - 1 - at).div_euclid(s)), at, s)
    });
    let (sy, sz) = (d[0] as i64, (d[0] * d[1]) as i64);
    (z.0..=z.1).flat_map(move |dk| {
        (y.0..=y.1).flat_map(move |dj| {
            let row = (z.2 + z.3 * dk) * sz + (y.2 + y.3 * dj) * sy + x.2;
            (x.0..=x.1).map(move |di| (row + x.3 * di) as usize)
        })
    })
}

/// The voxel bounds (inclusive) of `mask` in `bx`, grown by `pad` voxels and kept inside the
/// box; `None` for an empty mask.
fn padded_bounds(bx: &BoxGrid, mask: &[bool], pad: usize) -> Option<([usize; 3], [usize; 3])> {
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    for (l, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
        let p = bx.g.ijk(l);
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    if lo[0] == usize::MAX {
        return None;
    }
    for c in 0..3 {
        lo[c] = lo[c].saturating_sub(pad);
        hi[c] = (hi[c] + pad).min(bx.g.d[c] - 1);
    }
    Some((lo, hi))
}

/// Adds to `solid` (the tooth with its cavities) the lesions open to the surface; returns every
/// pocket of the lesion's grey it looked at. A lesion whose enamel roof is thinner than the scan's
/// blur, or a cavitated one, opens to a fissure through a mouth wider than a neck, yet lies within
/// the tooth's outline: in a pocket of `solid` closed by a ball of LESION_MOUTH_MM, where the grey
/// is the lesion's (`lesion_grey`), with a body (BODY_VOXELS), at the crown's surface
/// (`near_enamel`); opened by the body's ball. Searched only around the enamel, where lesions lie:
/// a sub-box of the enamel's bounds grown by twice the ball (so the box's faces, which count as
/// outside, do not narrow the closing there).
fn open_lesions(bx: &BoxGrid, enamel: &[bool], near_enamel: &[bool], vals: &[f32], spacing: [f64; 3], lesion_grey: &dyn Fn(f64) -> bool, solid: &mut [bool]) -> Vec<bool> {
    let mut pockets = vec![false; bx.g.n()];
    let h = spacing.iter().cloned().fold(f64::INFINITY, f64::min);
    let pad = 2 + (2.0 * LESION_MOUTH_MM / h).ceil() as usize;
    let Some((lo, hi)) = padded_bounds(bx, enamel, pad) else { return pockets };
    let sub = BoxGrid::new(lo, hi, &bx.g);
    let sn = sub.g.n();
    let inside: Vec<bool> = (0..sn).map(|l| solid[sub.global(l)]).collect();
    let r = LESION_MOUTH_MM as f32;
    let grown: Vec<bool> = distance_mm(sub.g.d, spacing, &inside).into_iter().enumerate().map(|(l, d)| d > r || sub.on_face(l)).collect();
    let closed = distance_mm(sub.g.d, spacing, &grown);
    let svals = sub.gather(vals);
    let pocket: Vec<bool> = (0..sn).map(|l| closed[l] > r && !inside[l] && lesion_grey(f64::from(svals[l]))).collect();
    for l in (0..sn).filter(|&l| pocket[l]) {
        pockets[sub.global(l)] = true;
    }
    let (id, sizes) = components(sub.g.d, &pocket);
    let stats = cavity_stats(&sub.g, &id, sizes.len(), &pocket, &sub.gather(near_enamel).into_iter().map(|b| if b { 0.0 } else { f32::INFINITY }).collect::<Vec<f32>>(), &svals, spacing);
    let h = h as f32;
    let lesion: Vec<bool> = (0..sn).map(|l| id[l] != 0 && stats[id[l] as usize].has_body(h) && stats[id[l] as usize].at_surface()).collect();
    // Opened by the body's ball: what is thinner than the body hangs off it into the fissures
    // (partial volume of air and enamel with the lesion's grey), not the lesion.
    let rho = BODY_VOXELS * h + 1e-3;
    let body: Vec<bool> = distance_mm(sub.g.d, spacing, &lesion.iter().map(|&b| !b).collect::<Vec<bool>>()).into_iter().map(|d| d > rho).collect();
    let opened = within(&sub.g, &body, f64::from(rho), spacing);
    for l in (0..sn).filter(|&l| lesion[l] && opened[l]) {
        solid[sub.global(l)] = true;
    }
    pockets
}

/// Radius (mm) of the ball the metal is opened by. Beam hardening draws bright streaks out of a
/// restoration; where one crosses enamel near the metal it can saturate the detector too, in
/// lines under ~0.8 mm wide (a 0.3 mm Gaussian profile). A restoration is thicker than that.
const METAL_OPENING_MM: f64 = 0.4;

/// The metal class cleaned of streaks. Metal saturates a CBCT's detector: where the scan is
/// clipped (at least 27 voxels share its maximum), metal is the metal class at that ceiling, which
/// leaves out the enamel that a bright streak lifts past the metal threshold but not to the
/// ceiling; what remains is opened by a ball of METAL_OPENING_MM, which leaves out the streaks'
/// saturated roots. (An unclipped scan keeps the whole metal class, opened.) A voxel left out
/// takes the most frequent class among its non-metal neighbours within 2 voxels: enamel under a
/// streak stays enamel, air above the restoration air, so no streak becomes a tooth speck.
/// The blur's bloom around the metal stays: under saturation, the metal's grey value, and with
/// it where its partial volume reaches half, is unknown. Works in the box of the metal voxels.
fn clean_metal(g: &Grid, vol: &Volume, labels: &mut [u8]) {
    let metal = Label::Metal as u8;
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    let mut top = f32::NEG_INFINITY;
    for (m, _) in labels.iter().enumerate().filter(|(_, l)| **l == metal) {
        let p = g.ijk(m);
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
        top = top.max(vol.values[m]);
    }
    if lo[0] == usize::MAX {
        return;
    }
    let r = METAL_OPENING_MM;
    let pad = 2 + (r / vol.min_spacing()).ceil() as usize;
    for c in 0..3 {
        lo[c] = lo[c].saturating_sub(pad);
        hi[c] = (hi[c] + pad).min(g.d[c] - 1);
    }
    let bx = BoxGrid::new(lo, hi, g);
    let bn = bx.g.n();
    let class = bx.gather(labels);
    let vals = bx.gather(&vol.values);
    let ceiling = crate::bloom::clipped_from(top);
    let clipped = vals.iter().zip(&class).filter(|(v, l)| **l == metal && **v >= ceiling).count() >= 27;
    let mask: Vec<bool> = (0..bn).map(|l| class[l] == metal && (!clipped || vals[l] >= ceiling)).collect();
    let core: Vec<bool> = distance_mm(bx.g.d, vol.spacing, &mask.iter().map(|&b| !b).collect::<Vec<bool>>()).into_iter().map(|d| f64::from(d) > r).collect();
    let opened = within(&bx.g, &core, r, vol.spacing);
    let d = bx.g.d;
    let relabel: Vec<(usize, u8)> = (0..bn)
        .into_par_iter()
        .filter(|&l| class[l] == metal && !(mask[l] && opened[l]))
        .map(|l| {
            let p = bx.g.ijk(l);
            let mut counts = [0usize; 9];
            for dk in -2i64..=2 {
                for dj in -2i64..=2 {
                    for di in -2i64..=2 {
                        let q = [p[0] as i64 + di, p[1] as i64 + dj, p[2] as i64 + dk];
                        if (0..3).all(|c| q[c] >= 0 && q[c] < d[c] as i64) {
                            let t = class[q[0] as usize + d[0] * (q[1] as usize + d[1] * q[2] as usize)];
                            if t != metal {
                                counts[t as usize] += 1;
                            }
                        }
                    }
                }
            }
            let best = (0..9).max_by_key(|&k| counts[k]).filter(|&k| counts[k] > 0).unwrap_or(Label::Enamel as usize);
            (l, best as u8)
        })
        .collect();
    for (l, x) in relabel {
        labels[bx.global(l)] = x;
    }
}

fn median(v: &mut [f32]) -> f32 {
    let m = v.len() / 2;
    *v.select_nth_unstable_by(m, |a, b| a.total_cmp(b)).1
}

/// How deep (voxels) the outside claims the tooth's darker rim where it touches it: the blur's
/// mix at the outer surface, and the last voxels of a canal at an apex open in the scan.
const CANAL_RIM_VOXELS: usize = 2;

/// Voxels of a thin canal in `tooth` (its hard tissue at the calibration's threshold): darker
/// than the tooth's deep dentin by more than its noise (3 σ, σ from the median absolute
/// deviation; at least a tenth of the way to the pulp's grey), where the outside (`outside`, at
/// the hard-tissue threshold) does not reach them within CANAL_RIM_VOXELS.
///
/// Why: the hard-tissue threshold lies where the tooth meets bone or the medium. A canal
/// narrower than the blur, its grey lifted toward the dentin's, reads as hard tissue there, and
/// a threshold high enough to find it opens a thin apex (the canal joins the outside and is no
/// cavity). So the tooth's outline comes from the one threshold and its canals from the other,
/// the tooth's own dentin and noise, without depending on where bone's grey lands.
fn thin_canals(g: &Grid, tooth: &[bool], vals: &[f32], outside: &[bool], cal: &Calibration) -> Vec<bool> {
    let n = g.n();
    let (hard_cut, enamel_cut) = (cal.hard_cut(), cal.mid(Label::Dentin, Label::Enamel));
    let deep = morph(g, &morph(g, tooth, false), false);
    let mut dentin: Vec<f32> = (0..n).filter(|&l| deep[l] && f64::from(vals[l]) <= enamel_cut).map(|l| vals[l]).collect();
    if dentin.len() < 64 {
        return vec![false; n];
    }
    let m = median(&mut dentin);
    let mut dev: Vec<f32> = dentin.iter().map(|v| (v - m).abs()).collect();
    let sigma = 1.4826 * f64::from(median(&mut dev));
    let m = f64::from(m);
    let cut = (m - (3.0 * sigma).max(0.1 * (m - cal.peak(Label::Pulp)))).max(hard_cut);
    let dark: Vec<bool> = (0..n).map(|l| tooth[l] && f64::from(vals[l]) <= cut).collect();
    let mut claimed = outside.to_vec();
    for _ in 0..CANAL_RIM_VOXELS {
        let grown = morph(g, &claimed, true);
        claimed = (0..n).map(|l| claimed[l] || (grown[l] && dark[l])).collect();
    }
    (0..n).map(|l| dark[l] && !claimed[l]).collect()
}

/// Least depth (mm) of a body of bone grey for it to be bone, not a blurred edge.
const BONE_DEPTH_MM: f64 = 0.4;

/// Each hard-tissue voxel's tooth (0 = none): the core eroded by ~0.6 mm, its components (the
/// small ones dropped) regrown over the core.
fn tooth_markers(g: &Grid, vol: &Volume, core: &[bool], opts: &SegmentOptions) -> (Vec<u32>, Vec<usize>) {
    let n = g.n();
    // Markers: the core eroded by ~0.6 mm, which separates teeth touching at contact points and
    // roots touching bone; each marker then regrows over the core (multi-source breadth-first),
    // so every core voxel goes to the nearest marker.
    let r = if opts.opening { ((0.6 / vol.min_spacing()).round() as usize).clamp(1, 4) } else { 0 };
    let mut eroded = core.to_vec();
    for _ in 0..r {
        eroded = morph(g, &eroded, false);
    }
    let (mut id, sizes) = components(g.d, &eroded);
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
    (id, sizes)
}

/// A tooth found in the scan: its own object, told from the others by the same markers
/// segmentation uses (hard tissue eroded apart at contacts, regrown).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FoundTooth {
    /// An LPS point inside it (a marker voxel nearest the marker's centroid): a seed for
    /// [`segment`].
    pub seed: [f64; 3],
    /// LPS box of its voxels (voxel centres), mm.
    pub min: [f64; 3],
    pub max: [f64; 3],
    /// Hard tissue (dentin and enamel class) and enamel-class volume, mm³ at the scan's grid.
    pub hard_mm3: f64,
    pub enamel_mm3: f64,
    /// It reaches the scan's border: the field of view cuts it.
    pub cut_by_field_of_view: bool,
}

/// Every tooth in the scan, largest first: each hard-tissue object with a crown (at least
/// `MIN_ENAMEL_MM3` of enamel; bone and specks have none).
pub fn find_teeth(vol: &Volume, cal: &Calibration) -> Result<Vec<FoundTooth>> {
    const MIN_ENAMEL_MM3: f64 = 5.0;
    let g = Grid { d: vol.dims };
    let n = g.n();
    if n == 0 || vol.values.len() != n {
        return Err(Error::invalid("volume", "empty or inconsistent volume"));
    }
    let classifier = cal.classifier();
    let mut labels: Vec<u8> = vol.values.par_iter().map(|&v| classifier.classify(v as f64) as u8).collect();
    clean_metal(&g, vol, &mut labels);
    let core: Vec<bool> = labels.par_iter().map(|&l| l == Label::Dentin as u8 || l == Label::Enamel as u8).collect();
    let opts = SegmentOptions::default();
    let (id, _) = tooth_markers(&g, vol, &core, &opts);
    let count = id.iter().copied().max().unwrap_or(0) as usize + 1;
    #[derive(Clone)]
    struct Acc {
        hard: usize,
        enamel: usize,
        lo: [usize; 3],
        hi: [usize; 3],
        sum: [f64; 3],
    }
    let mut acc = vec![Acc { hard: 0, enamel: 0, lo: [usize::MAX; 3], hi: [0; 3], sum: [0.0; 3] }; count];
    for m in 0..n {
        let c = id[m] as usize;
        if c == 0 {
            continue;
        }
        let p = g.ijk(m);
        let a = &mut acc[c];
        a.hard += 1;
        a.enamel += (labels[m] == Label::Enamel as u8) as usize;
        for k in 0..3 {
            a.lo[k] = a.lo[k].min(p[k]);
            a.hi[k] = a.hi[k].max(p[k]);
            a.sum[k] += p[k] as f64;
        }
    }
    let vox = vol.voxel_volume_mm3();
    let crowned = |a: &Acc| a.hard > 0 && (a.enamel as f64) * vox >= MIN_ENAMEL_MM3;
    // Each tooth's voxel nearest its centroid (the first in index order among equals), every
    // tooth in one pass.
    let centroids: Vec<[f64; 3]> = acc.iter().map(|a| a.sum.map(|s| s / a.hard as f64)).collect();
    let mut best = vec![(f64::INFINITY, 0usize); count];
    for m in 0..n {
        let c = id[m] as usize;
        if c == 0 || !crowned(&acc[c]) {
            continue;
        }
        let p = g.ijk(m);
        let d2: f64 = (0..3).map(|k| (p[k] as f64 - centroids[c][k]).powi(2)).sum();
        if d2 < best[c].0 {
            best[c] = (d2, m);
        }
    }
    let mut teeth: Vec<(usize, FoundTooth)> = Vec::new();
    for (c, a) in acc.iter().enumerate().skip(1) {
        if !crowned(a) {
            continue;
        }
        let p = g.ijk(best[c].1);
        let mut min = [f64::INFINITY; 3];
        let mut max = [f64::NEG_INFINITY; 3];
        for corner in 0..8 {
            let q = vol.voxel_center(
                if corner & 1 == 0 { a.lo[0] } else { a.hi[0] },
                if corner & 2 == 0 { a.lo[1] } else { a.hi[1] },
                if corner & 4 == 0 { a.lo[2] } else { a.hi[2] },
            );
            for k in 0..3 {
                min[k] = min[k].min(q[k]);
                max[k] = max[k].max(q[k]);
            }
        }
        let cut = (0..3).any(|k| a.lo[k] == 0 || a.hi[k] + 1 == vol.dims[k]);
        teeth.push((a.hard, FoundTooth { seed: vol.voxel_center(p[0], p[1], p[2]), min, max, hard_mm3: a.hard as f64 * vox, enamel_mm3: a.enamel as f64 * vox, cut_by_field_of_view: cut }));
    }
    teeth.sort_by(|a, b| b.0.cmp(&a.0));
    Ok(teeth.into_iter().map(|(_, t)| t).collect())
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
    let classifier = cal.classifier();
    out.labels.par_iter_mut().zip(vol.values.par_iter()).for_each(|(l, &v)| *l = classifier.classify(v as f64) as u8);
    clean_metal(&g, vol, &mut out.labels);
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
    // Markers and components only in a box: the selection's, or with a seed alone a ball's box
    // around it that any tooth reaches no farther than; a tooth that comes near that box's side
    // is segmented again in the whole scan. (The scan outside is classified above all the same.)
    let seed_index = match &opts.tooth {
        Some(sel) => {
            let s = vol.world_to_index(sel.seed).ok_or_else(|| Error::invalid("tooth.seed", "degenerate geometry"))?;
            let si = [s[0].round(), s[1].round(), s[2].round()];
            if (0..3).any(|c| si[c] < 0.0 || si[c] >= vol.dims[c] as f64) {
                return Err(Error::invalid("tooth.seed", format!("{:?} lies outside the scan", sel.seed)));
            }
            Some(si.map(|v| v as usize))
        }
        None => None,
    };
    let searched = opts.tooth.as_ref().is_some_and(|sel| sel.bounds.is_none());
    let whole = ([0usize; 3], vol.dims);
    let mut region = match seed_index {
        Some(si) if searched => {
            let lo = [0, 1, 2].map(|c| si[c].saturating_sub((SEARCH_MM / vol.spacing[c]).ceil() as usize));
            let hi = [0, 1, 2].map(|c| (si[c] + (SEARCH_MM / vol.spacing[c]).ceil() as usize + 1).min(vol.dims[c]));
            (lo, hi)
        }
        Some(si) if (0..3).all(|c| si[c] >= lo[c] && si[c] < hi[c]) && (0..3).all(|c| lo[c] < hi[c]) => (lo, hi),
        _ => whole,
    };
    let tooth = loop {
        let bx = BoxGrid::new(region.0, region.1.map(|v| v - 1), &g);
        let bcore = bx.gather(&core);
        let (id, sizes) = tooth_markers(&bx.g, vol, &bcore, opts);
        let bn = bx.g.n();
        let keep: Vec<bool> = match (&opts.tooth, seed_index) {
            (Some(sel), Some(si)) => {
                let sn = (si[0] - region.0[0]) + bx.g.d[0] * ((si[1] - region.0[1]) + bx.g.d[1] * (si[2] - region.0[2]));
                // component at the seed, else the nearest one (breadth-first from the seed)
                let mut target = id[sn];
                if target == 0 {
                    let mut q = VecDeque::from([sn]);
                    let mut seen = vec![false; bn];
                    seen[sn] = true;
                    let mut nb = [0usize; 6];
                    let mut steps = 0;
                    'search: while let Some(m) = q.pop_front() {
                        steps += 1;
                        if steps > 2_000_000 {
                            break;
                        }
                        let c = bx.g.nb6(m, &mut nb);
                        for &t in &nb[..c] {
                            if !seen[t] {
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
                    if region != whole && searched {
                        region = whole;
                        continue;
                    }
                    return Err(Error::invalid("tooth.seed", format!("no tooth (dentin/enamel) found near {:?}", sel.seed)));
                }
                id.iter().map(|&c| c == target).collect()
            }
            _ => id.iter().map(|&c| c != 0 && sizes[c as usize] >= opts.min_component_voxels.max(1)).collect(),
        };
        if region != whole && searched {
            // Within SEARCH_MARGIN voxels of a side of the box that is not the scan's: the tooth
            // may go on beyond it.
            let near_side = (0..bn).filter(|&l| keep[l]).any(|l| {
                let p = bx.g.ijk(l);
                (0..3).any(|c| (p[c] < SEARCH_MARGIN && region.0[c] > 0) || (p[c] + SEARCH_MARGIN >= bx.g.d[c] && region.1[c] < vol.dims[c]))
            });
            if near_side {
                region = whole;
                continue;
            }
        }
        if region == whole {
            break keep;
        }
        let mut tooth = vec![false; n];
        for l in (0..bn).filter(|&l| keep[l]) {
            tooth[bx.global(l)] = true;
        }
        break tooth;
    };
    // Cavities, in a box around the tooth with room for the lesion search's closing.
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
    let h = vol.min_spacing();
    let pad = 2 + (LESION_MOUTH_MM / h).ceil() as usize;
    for c in 0..3 {
        blo[c] = blo[c].saturating_sub(pad);
        bhi[c] = (bhi[c] + pad).min(vol.dims[c] - 1);
    }
    let bx = BoxGrid::new(blo, bhi, &g);
    let bn = bx.g.n();
    let btooth = bx.gather(&tooth);
    let bvals = bx.gather(&vol.values);
    let h = h as f32;
    let enamel_cut = cal.mid(Label::Dentin, Label::Enamel);
    // Close 1-voxel holes in thin walls (noise, partial volume at root canals) before asking
    // which voxels the outside cannot reach.
    let closed = morph(&bx.g, &morph(&bx.g, &btooth, true), false);
    // Metal (a restoration) is neither the tooth nor its outside: it keeps its label, walls
    // cavities in like the tooth does, and is no outside partner of the surface refinement.
    let bmetal: Vec<bool> = (0..bn).map(|l| out.labels[bx.global(l)] == Label::Metal as u8).collect();
    let open: Vec<bool> = (0..bn).map(|l| !(btooth[l] || closed[l] || bmetal[l])).collect();
    let mut enclosed = {
        let outside = flood_from_border(bx.g.d, &open);
        (0..bn).map(|l| open[l] && !outside[l]).collect::<Vec<bool>>()
    };
    // The outside also ends at passages at most 2 voxels wide: a canal behind an apical wall
    // thinner than the blur, or a lesion under a fissure's thin enamel roof, opens to the outside
    // in the scan only through such a neck. Behind a neck, only a body (BODY_VOXELS) is a cavity;
    // thinner pockets (the bottoms of fissures) are outside.
    let behind_neck = {
        let core = erode_in_box(&bx.g, &open);
        let reach = flood_from_border(bx.g.d, &core);
        let wide = morph(&bx.g, &reach, true);
        (0..bn).map(|l| open[l] && !wide[l]).collect::<Vec<bool>>()
    };
    // Enamel (and metal, for lesions under a restoration): where lesions start.
    let enamel: Vec<bool> = (0..bn).map(|l| (btooth[l] && f64::from(bvals[l]) > enamel_cut) || out.labels[bx.global(l)] == Label::Metal as u8).collect();
    // The crown's surface: the outside (what it reaches through passages wider than a neck)
    // within 5 voxels of enamel at least 2 voxels thick (the blur moves the enamel's edge inward
    // by up to 1.2 σ, and at the cervical margin, where the enamel thins out, the canals come
    // near the outside).
    let near_enamel = {
        let thick = morph(&bx.g, &morph(&bx.g, &enamel, false), false);
        within(&bx.g, &thick, 5.0 * f64::from(h), vol.spacing)
    };
    let lesion_grey = |v: f64| (v - cal.peak(Label::Caries)).abs() < (v - cal.peak(Label::Pulp)).abs();
    // Canals thinner than the hard-tissue threshold resolves (below).
    let canal = thin_canals(&bx.g, &btooth, &bvals, &(0..bn).map(|l| open[l] && !behind_neck[l]).collect::<Vec<bool>>(), cal);
    // (Only canals that reach a cavity the hard-tissue threshold found, the pulp chamber: a
    // dark sheet of the blur's mix between roots close together joins none.)
    let canal = {
        let (id, sizes) = components(bx.g.d, &(0..bn).map(|l| canal[l] || behind_neck[l]).collect::<Vec<bool>>());
        let mut joins = vec![false; sizes.len()];
        for l in (0..bn).filter(|&l| behind_neck[l]) {
            joins[id[l] as usize] = true;
        }
        (0..bn).map(|l| canal[l] && joins[id[l] as usize]).collect::<Vec<bool>>()
    };
    let mut candidates = behind_neck;
    for l in (0..bn).filter(|&l| canal[l]) {
        candidates[l] = true;
        enclosed[l] = true;
    }
    let pockets = if opts.detect_caries {
        // (Passed with the tooth in: the outline to close is the tooth's with its cavities.)
        let mut solid: Vec<bool> = (0..bn).map(|l| btooth[l] || candidates[l]).collect();
        let hard_cut = cal.hard_cut();
        let pockets = open_lesions(&bx, &enamel, &near_enamel, &bvals, vol.spacing, &|v| lesion_grey(v) && v < hard_cut, &mut solid);
        for l in (0..bn).filter(|&l| solid[l] && !btooth[l]) {
            candidates[l] = true;
        }
        pockets
    } else {
        vec![false; bn]
    };
    // (Pockets of the lesion's grey within the outline are not the outside, whether or not
    // they were taken as a lesion.)
    let to_surface = distance_mm(bx.g.d, vol.spacing, &(0..bn).map(|l| open[l] && !candidates[l] && !pockets[l] && near_enamel[l]).collect::<Vec<bool>>());
    let (bid, nc) = {
        let (id, sizes) = components(bx.g.d, &candidates);
        (id, sizes.len())
    };
    let stats = cavity_stats(&bx.g, &bid, nc, &candidates, &to_surface, &bvals, vol.spacing);
    let mut is_enclosed = vec![false; nc];
    for l in (0..bn).filter(|&l| enclosed[l]) {
        is_enclosed[bid[l] as usize] = true;
    }
    let kept: Vec<bool> = (0..nc).map(|c| c != 0 && (is_enclosed[c] || stats[c].has_body(h))).collect();
    let bcavity: Vec<bool> = (0..bn).map(|l| kept[bid[l] as usize]).collect();
    // Cavity classes. A carious lesion starts at the crown's surface and progresses inward; the
    // pulp lies under the enamel and a dentin wall. So a cavity is caries where it comes within
    // LESION_SURFACE_MM of the crown's surface and the grey of its deepest voxels, the ones least
    // mixed with the hard tissue around by the scan's blur, is nearer the lesion's than the
    // pulp's. (Its median grey would not do: the blur pulls a thin pulp's voxels toward the
    // dentin's.) A cavity at the surface without a body is partial volume, left to the dentin.
    let dentin_ref = cal.peak(Label::Dentin);
    // (A thin canal's lining, darker than the dentin but above the hard-tissue threshold, is
    // left out here: it would lift the pulp's measured grey and with it its border.)
    let hard_cut = cal.hard_cut();
    let deep = morph(&bx.g, &(0..bn).map(|l| bcavity[l] && !(canal[l] && f64::from(bvals[l]) > hard_cut)).collect::<Vec<bool>>(), false);
    let mut deep_vals: Vec<Vec<f32>> = vec![Vec::new(); nc];
    for l in (0..bn).filter(|&l| deep[l]) {
        deep_vals[bid[l] as usize].push(bvals[l]);
    }
    let cav_class: Vec<Cavity> = (0..nc)
        .map(|c| {
            let s = &stats[c];
            let class = if !kept[c] || s.voxels < opts.min_component_voxels {
                Label::Dentin
            } else if !s.at_surface() {
                Label::Pulp
            } else if !s.has_body(h) {
                Label::Dentin
            } else if opts.detect_caries && lesion_grey(s.grey) {
                Label::Caries
            } else {
                Label::Pulp
            };
            // Pulp against dentin at the midpoint of the pulp's grey (its voxels a voxel deep)
            // and dentin's.
            let threshold = if class == Label::Pulp {
                let mut vals = if deep_vals[c].len() >= 8 { std::mem::take(&mut deep_vals[c]) } else { s.all.clone() };
                0.5 * ((median(&mut vals) as f64).min(dentin_ref) + dentin_ref)
            } else {
                0.0
            };
            Cavity { class, threshold, grey: s.grey }
        })
        .collect();
    // The closing's gaps next to the pulp are its wall, darkened by its blur (around a root
    // canal 1–2 voxels wide): the tooth's, not its outside. (A lesion's border has its own
    // refinement.)
    let cavity_of = |class: Label| morph(&bx.g, &(0..bn).map(|l| bcavity[l] && cav_class[bid[l] as usize].class == class).collect::<Vec<bool>>(), true);
    let (by_pulp, by_lesion) = (cavity_of(Label::Pulp), cavity_of(Label::Caries));
    let filled: Vec<bool> = (0..bn).map(|l| btooth[l] || bcavity[l] || (closed[l] && by_pulp[l] && !by_lesion[l] && !bmetal[l])).collect();

    // Outer surface refinement in a 2-voxel ring on both sides of the filled tooth's surface
    // (inside the box: it reaches LESION_MOUTH_MM + 2 voxels beyond the tooth).
    let near_out = morph(&bx.g, &morph(&bx.g, &filled, true), true);
    let inner = morph(&bx.g, &morph(&bx.g, &filled, false), false);
    // Next to metal the grey is the metal's bloom: the topology's answer stands there.
    let by_metal = morph(&bx.g, &bmetal, true);
    let ring: Vec<usize> = (0..bn).filter(|&l| near_out[l] && !inner[l] && !bcavity[l] && !by_metal[l]).collect();
    // Around a tooth alone (no bone), the outside tissues the scan shows: the tooth's blur lifts
    // the grey beside it, and air beside a crown on a fine scan (σ two voxels) read as soft
    // tissue by its median, the surface then moved inward (an incisor in air at 0.1 mm: enamel
    // −6 %). In a jaw all four: soft tissue may have been matched to a bone's name.
    let all_outside = [Label::Air, Label::SoftTissue, Label::BoneCancellous, Label::BoneCortical];
    let outside_classes: Vec<Label> = match all_outside.into_iter().filter(|l| cal.shows(*l)).collect::<Vec<_>>() {
        shown if !shown.is_empty() && !cal.shows_bone() => shown,
        _ => all_outside.to_vec(),
    };
    let hard = [Label::Dentin, Label::Enamel];
    let d = bx.g.d;
    let outside_steps = Calibration::outside_steps(vol.spacing);
    // Bone is a body: grey of bone in a shell thinner than BONE_DEPTH_MM around the tooth is
    // the blur's mix of the tooth and a darker outside (water, air), no bone.
    let bone_near = {
        let not_bone: Vec<bool> = (0..bn).map(|l| filled[l] || !matches!(Label::from_u8(out.labels[bx.global(l)]), Some(Label::BoneCancellous | Label::BoneCortical))).collect();
        let depth = distance_mm(bx.g.d, vol.spacing, &not_bone);
        // (A micron's slack: spacings read from files differ in their last float bits, and
        // both lengths are whole multiples of common voxel sizes.)
        let bulk: Vec<bool> = depth.iter().map(|&d| f64::from(d) >= BONE_DEPTH_MM - 1e-3).collect();
        let reach = BONE_DEPTH_MM + 2.0 * vol.spacing.iter().cloned().fold(0.0, f64::max) + 1e-3;
        within(&bx.g, &bulk, reach, vol.spacing)
    };
    let decisions: Vec<(usize, Option<Label>)> = ring
        .par_iter()
        .map(|&l| {
            let p = bx.g.ijk(l);
            let (mut ins, mut outs) = (Vec::with_capacity(125), Vec::with_capacity(125));
            ins.extend(cube_around(p, 2, d).filter(|&t| inner[t] && btooth[t]).map(|t| bvals[t]));
            outs.extend(lattice_around(p, 2, outside_steps, d).filter(|&t| !filled[t] && !bmetal[t]).map(|t| bvals[t]));
            let mu_in = if ins.is_empty() { Label::Dentin } else { cal.nearest(median(&mut ins) as f64, &hard) };
            let mu_out = cal.outside_of(&mut outs, &outside_classes).unwrap_or(Label::SoftTissue);
            // A root's partner in bone is the ligament or the bone ([`Calibration::root_partner`]).
            // Near the crown, or with no body of bone near, a bone-grey outside is partial volume
            // (air in a blurred fissure, water against the root): soft.
            let in_bone = matches!(mu_out, Label::BoneCancellous | Label::BoneCortical) && !near_enamel[l] && bone_near[l];
            let partner = if !matches!(mu_out, Label::BoneCancellous | Label::BoneCortical) {
                cal.peak(mu_out)
            } else if !in_bone {
                cal.peak(Label::SoftTissue)
            } else {
                cal.root_partner(&mut outs, mu_out)
            };
            // By a root in bone, a voxel outside the tooth the hard tissues' threshold found whose
            // grey rises outward lies past the ligament's dip: bone (a cortex is as bright as a
            // root's blurred edge), however bright.
            let past_dip = || in_bone && !filled[l] && rises_outward(p, d, &filled, &bvals);
            let inside = f64::from(bvals[l]) > 0.5 * (cal.peak(mu_in) + partner) && !past_dip();
            (l, inside.then_some(mu_in))
        })
        .collect();
    let mut refined = filled;
    let mut surface_label = vec![0u8; bn];
    for (l, d) in decisions {
        refined[l] = d.is_some();
        if let Some(x) = d {
            surface_label[l] = x as u8;
        }
    }
    // Hard tissue is this tooth's only where refined; elsewhere (bone, other teeth) it is
    // reported as bone_cortical.
    out.labels.par_iter_mut().for_each(|l| {
        if is_hard(*l) {
            *l = Label::BoneCortical as u8;
        }
    });
    for l in (0..bn).filter(|&l| refined[l]) {
        let v = f64::from(bvals[l]);
        out.labels[bx.global(l)] = if bcavity[l] {
            let cav = &cav_class[bid[l] as usize];
            match cav.class {
                Label::Pulp if v < cav.threshold => Label::Pulp,
                // (a canal's lining that joined a lesion is the dentin it was: the lesion's
                // border is refined below)
                Label::Caries if !(canal[l] && v > hard_cut) => Label::Caries,
                _ => Label::Dentin,
            }
        } else if surface_label[l] != 0 {
            if surface_label[l] == Label::Enamel as u8 || v <= enamel_cut { Label::from_u8(surface_label[l]).unwrap_or(Label::Dentin) } else { Label::Enamel }
        } else if v > enamel_cut {
            Label::Enamel
        } else {
            Label::Dentin
        } as u8;
    }
    let lesion: Vec<bool> = (0..bn).map(|l| bcavity[l] && cav_class[bid[l] as usize].class == Label::Caries).collect();
    if lesion.contains(&true) {
        refine_lesion_border(&bx, &lesion, &bid, &cav_class, &bvals, vol.spacing, cal, &mut out.labels);
    }
    Ok(out)
}

/// Moves a lesion's border to where the grey is midway between the lesion's (its deepest
/// voxels') and the neighbouring tissue's, voxel by voxel, as partial volume puts it: the enamel's
/// against the enamel, the dentin's against the dentin, the outside's at an open mouth. (The
/// cavity that found the lesion ends at the hard tissues' threshold, which lies inside the lesion
/// against the enamel and outside it against the dentin.) Looks two voxels to each side of the
/// border; a voxel's neighbouring tissue is the most frequent label among the voxels within 3
/// voxels of it and 2 or more voxels from the lesion. The lesion grows only into the tooth
/// (enamel, dentin), never into the outside. Works in the lesions' box grown by 6 voxels.
#[allow(clippy::too_many_arguments)]
fn refine_lesion_border(bx: &BoxGrid, lesion: &[bool], id: &[u32], cav: &[Cavity], vals: &[f32], spacing: [f64; 3], cal: &Calibration, labels: &mut [u8]) {
    let Some((lo, hi)) = padded_bounds(bx, lesion, 6) else { return };
    let sub = BoxGrid::new(lo, hi, &bx.g);
    let (lesion, id, vals) = (sub.gather(lesion), sub.gather(id), sub.gather(vals));
    let global = |l: usize| bx.global(sub.global(l));
    let h = spacing.iter().cloned().fold(f64::INFINITY, f64::min) as f32;
    let depth = distance_mm(sub.g.d, spacing, &lesion.iter().map(|&b| !b).collect::<Vec<bool>>());
    let away = distance_mm(sub.g.d, spacing, &lesion);
    let band = 2.0 * h + 1e-3;
    let (enamel, dentin, pulp) = (Label::Enamel as u8, Label::Dentin as u8, Label::Pulp as u8);
    let d = sub.g.d;
    let zone: Vec<usize> = (0..sub.g.n())
        .filter(|&l| if lesion[l] { depth[l] <= band } else { away[l] <= band && [enamel, dentin].contains(&labels[global(l)]) })
        .collect();
    let decisions: Vec<(usize, Option<Label>)> = zone
        .par_iter()
        .map(|&l| {
            let p = sub.g.ijk(l);
            let mut counts = [0usize; 4]; // enamel, dentin, pulp, outside
            let mut outside_grey = Vec::new();
            let mut lesion_id = 0u32;
            for t in cube_around(p, 3, d) {
                if lesion[t] {
                    lesion_id = lesion_id.max(id[t]);
                } else if away[t] >= 2.0 * h - 1e-3 {
                    let lab = labels[global(t)];
                    let k = if lab == enamel { 0 } else if lab == dentin { 1 } else if lab == pulp { 2 } else { 3 };
                    counts[k] += 1;
                    if k == 3 {
                        outside_grey.push(vals[t]);
                    }
                }
            }
            let k = (0..4).max_by_key(|&k| counts[k]).unwrap_or(1);
            if counts[k] == 0 || lesion_id == 0 {
                return (l, None);
            }
            let neighbour = match k {
                0 => Label::Enamel,
                1 => Label::Dentin,
                2 => Label::Pulp,
                _ => cal.outside_of(&mut outside_grey, &[Label::Air, Label::SoftTissue, Label::BoneCancellous, Label::BoneCortical]).unwrap_or(Label::SoftTissue),
            };
            let g = f64::from(vals[l]);
            let is_lesion = (g - cav[lesion_id as usize].grey).abs() < (g - cal.peak(neighbour)).abs();
            let new = if is_lesion {
                Label::Caries
            } else if !lesion[l] {
                return (l, None);
            } else if k < 3 {
                neighbour
            } else {
                cal.classify(g)
            };
            (l, Some(new))
        })
        .collect();
    for (l, new) in decisions {
        if let Some(x) = new {
            labels[global(l)] = x as u8;
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The lattice clipped axis by axis is the lattice's points inside the grid, in its order.
    #[test]
    fn the_lattice_around_a_voxel_is_its_points_inside_the_grid() {
        let d = [7, 5, 9];
        for p in [[0, 0, 0], [6, 4, 8], [3, 2, 4], [1, 4, 0], [5, 0, 7]] {
            for (r, steps) in [(2, [1, 1, 1]), (2, [2, 1, 3]), (3, [1, 1, 1]), (1, [4, 4, 4])] {
                let mut expected = Vec::new();
                for dk in -r..=r {
                    for dj in -r..=r {
                        for di in -r..=r {
                            let q = [p[0] as i64 + steps[0] as i64 * di, p[1] as i64 + steps[1] as i64 * dj, p[2] as i64 + steps[2] as i64 * dk];
                            if (0..3).all(|c| q[c] >= 0 && q[c] < d[c] as i64) {
                                expected.push(q[0] as usize + d[0] * (q[1] as usize + d[1] * q[2] as usize));
                            }
                        }
                    }
                }
                assert_eq!(lattice_around(p, r, steps, d).collect::<Vec<_>>(), expected, "{p:?} r {r} steps {steps:?}");
            }
        }
    }
}
