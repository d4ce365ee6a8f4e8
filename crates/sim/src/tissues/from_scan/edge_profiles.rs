//! The grey's profiles across the tooth's outer surface ([`NestedBuilder::edge_profiles`]): the
//! scanner's blur they show, the enamel the outside's grey hides, and whether the roots meet
//! their bone through a ligament. Read once the tooth's field is made; the core's labels, the
//! pulp's fit and the roots' placement wait for them.
use super::*;

/// The blur (σ, mm) of an edge profile: the tooth's share in bins of [`PROFILE_BIN_VOXELS`] from
/// [`PROFILE_VOXELS`] inside to as far outside, falling outward. A Gaussian-blurred step falls from
/// 3/4 to 1/4 over 1.349 σ; read between bins linearly. `None` where the profile does not cross.
fn profile_blur(profile: &[Option<f64>], h: f64) -> Option<f64> {
    let read: Vec<(f64, f64)> = profile.iter().enumerate().filter_map(|(b, t)| t.map(|t| (((b as f64 + 0.5) * PROFILE_BIN_VOXELS - PROFILE_VOXELS) * h, t))).collect();
    let crossing = |level: f64| read.windows(2).find(|w| w[0].1 >= level && w[1].1 < level).map(|w| w[0].0 + (w[1].0 - w[0].0) * (w[0].1 - level) / (w[0].1 - w[1].1));
    let sigma = (crossing(0.25)? - crossing(0.75)?) / 1.349;
    (sigma.is_finite() && sigma > 0.0).then_some(sigma)
}

/// Each bin's median, where it holds at least [`MIN_PROFILE_SAMPLES`] (reordered).
fn binned_medians(samples: &mut [Vec<f32>]) -> Vec<Option<f64>> {
    samples
        .iter_mut()
        .map(|v| {
            (v.len() >= MIN_PROFILE_SAMPLES).then(|| {
                let k = v.len() / 2;
                f64::from(*v.select_nth_unstable_by(k, f32::total_cmp).1)
            })
        })
        .collect()
}

/// Each run of empty bins with read bins on both sides, filled along the line between them.
fn fill_between(profile: &mut [Option<f64>]) {
    let mut last: Option<(usize, f64)> = None;
    for b in 0..profile.len() {
        let Some(v) = profile[b] else { continue };
        if let Some((a, u)) = last.filter(|(a, _)| b > a + 1) {
            for (i, p) in profile.iter_mut().enumerate().take(b).skip(a + 1) {
                *p = Some(u + (v - u) * (i - a) as f64 / (b - a) as f64);
            }
        }
        last = Some((b, v));
    }
}

/// Whether the roots' edge profile into bone (grey medians in [`PROFILE_BIN_VOXELS`] bins from
/// [`PROFILE_VOXELS`] inside to as far outside) shows a periodontal ligament: the grey within two
/// voxels outside the surface dips below the bone's further out by more than
/// [`LIGAMENT_DIP`] of the bone/soft-tissue contrast. A root fused to its bone (ankylosis, or a
/// scan's model with no ligament) falls straight from the dentin's grey to the bone's; a 0.2 mm
/// ligament dips 10–22 % at 0.15–0.4 mm voxels (the family's jaws), a fused root −1…+1 %
/// (`foreign_tooth.py`'s jaws). A ligament the blur hides (half a voxel wide under a point
/// spread of a voxel's σ dips 4.5 %) is read as fused: the scan shows bone beside the root.
/// `None` where the profile or its bone is not read.
pub(super) fn root_ligament_seen(profile: &[Option<f64>], g_soft: f64) -> Option<bool> {
    let per_voxel = (1.0 / PROFILE_BIN_VOXELS).round() as usize;
    let surface = profile.len() / 2;
    let near = profile.get(surface..surface + 2 * per_voxel)?;
    let mut far: Vec<f64> = profile.get(surface + 2 * per_voxel..surface + 7 * per_voxel / 2)?.iter().flatten().copied().collect();
    if near.iter().any(Option::is_none) || far.len() < 3 {
        return None;
    }
    far.sort_by(f64::total_cmp);
    let bone = far[far.len() / 2];
    let low = near.iter().flatten().copied().fold(f64::INFINITY, f64::min);
    (bone - g_soft > 0.0).then(|| (bone - low) / (bone - g_soft) > LIGAMENT_DIP)
}

/// See [`root_ligament_seen`]: between a fused root's and a 0.2 mm ligament's dip.
const LIGAMENT_DIP: f64 = 0.05;
/// The roots' profile is fitted from this far inside to this far outside (voxels): further out
/// it reaches other roots and the jaw's cortex.
const LIGAMENT_FIT_VOXELS: (f64, f64) = (2.0, 3.0);

/// The outer surface's edge profile ([`NestedBuilder::edge_profiles`]) is read this
/// far (the scan's finest voxels) on each side, in bins this wide, each from at least this many
/// voxels.
const PROFILE_VOXELS: f64 = 4.0;
const PROFILE_BIN_VOXELS: f64 = 0.25;
const MIN_PROFILE_SAMPLES: usize = 16;
/// The edge profile's bins deeper than one reading this much are whole (1).
const WHOLE_TOOTH_SHARE: f64 = 0.97;

/// The enamel under the outside's grey that the crown's edge profile shows ([`NestedBuilder::edge_profiles`]).
pub(super) struct SeenUnderTheOutside {
    /// The labels with the enamel the outside's grey hid, and the dentin's share per voxel.
    pub(super) labels: dentsim_cbct::LabelVolume,
    pub(super) dentin_share: Vec<f32>,
    /// The scan's blur across the outer surface (σ, mm), where the profile shows it.
    pub(super) edge_blur_mm: Option<f64>,
    /// Voxels within the profile's reach of bone, whose blur brightens the root's edge.
    pub(super) beside_bone: Vec<bool>,
}

/// What the grey's profiles across the tooth's outer surface show
/// ([`NestedBuilder::edge_profiles`]).
pub(super) struct EdgeProfiles {
    /// The enamel under the outside's grey, where the crown's profile is read.
    pub(super) seen: Option<SeenUnderTheOutside>,
    /// What the roots' profile into bone shows.
    pub(super) roots: RootBorder,
}

/// What a root's border in bone is, as the roots' edge profile shows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum RootBorder {
    /// Not read: no bone beside the roots, or too little of the profile.
    Unread,
    /// No ligament ([`root_ligament_seen`]): a root's partner in bone is the bone.
    Fused,
    /// A ligament of this width, then bone: a voxel by the root holds the bone's blur too.
    Ligament(Ligament),
}

impl NestedBuilder<'_> {
    /// Enamel that the outside's grey hides. Near the outer surface a voxel's grey mixes three
    /// tissues, the outside's darkening the enamel toward the dentin's grey: the labels' two-tissue
    /// midpoint reads enamel thinner than about a voxel and the blur (the cervical third) as
    /// dentin, and the core's surface runs out to the tooth's surface there (family, dentin
    /// triangles within 0.6 mm of the outer surface: 0.1–0.26 mm outside the true DEJ, 10–40°
    /// off). With the tooth's share T of a voxel known, its dentin share is
    /// D = (g_out + (g_en − g_out)·T − g) / (g_en − g_de). T is read from the scan itself: the
    /// grey's edge profile across the outer surface where only one hard tissue is within reach,
    /// t = (g − g_out) / (g_in − g_out) against the voxel centre's signed distance from the tooth's
    /// surface (binned medians, so the scanner's blur and the voxel's averaging need no model).
    /// Returns the labels with the dentin voxels whose D is under half, grown from the enamel,
    /// made enamel, and D per voxel (NaN where not read: deep voxels, where T = 1 makes D the
    /// two-tissue fraction [`Self::place_by_grey`] takes), with the blur the profile shows and
    /// where bone is near; none when the scan shows too little of the profile. Also whether the
    /// roots' profile into bone shows a ligament ([`root_ligament_seen`]), the crown's read or not.
    pub(super) fn edge_profiles(&self, tooth_field: &[f32]) -> Result<EdgeProfiles> {
        let none = EdgeProfiles { seen: None, roots: RootBorder::Unread };
        let dims = self.scan.dims;
        let [nx, ny, _] = dims;
        let labels = &self.labels.labels;
        let len = labels.len();
        let cal = self.calibration;
        let (g_en, g_de) = (cal.peak(Label::Enamel), cal.peak(Label::Dentin));
        let (g_air, g_soft, g_bone) = (cal.peak(Label::Air), cal.peak(Label::SoftTissue), cal.peak(Label::BoneCancellous));
        if !(g_en - g_de > 0.0 && g_de > g_soft.max(g_air)) || !self.present(Label::Enamel) || !self.present(Label::Dentin) {
            return Ok(none);
        }
        let h = self.scan.min_spacing();
        let reach = PROFILE_VOXELS.ceil() as u32;
        let code = |c: u8| Label::from_u8(c);
        let tooth = |c: u8| matches!(code(c), Some(Label::Dentin | Label::Enamel | Label::Pulp | Label::Caries));
        let outside = |c: u8| c <= Label::BoneCortical as u8;
        // Voxels within `reach` steps of the border between the tooth and the outside.
        let mut steps = vec![u32::MAX; len];
        let mut queue = std::collections::VecDeque::new();
        for n in 0..len {
            let (t, o) = (tooth(labels[n]), outside(labels[n]));
            if (t || o) && face_neighbours(n, dims).into_iter().flatten().any(|m| if t { outside(labels[m]) } else { tooth(labels[m]) }) {
                steps[n] = 0;
                queue.push_back(n);
            }
        }
        while let Some(n) = queue.pop_front() {
            if steps[n] >= reach {
                continue;
            }
            for m in face_neighbours(n, dims).into_iter().flatten() {
                if steps[m] == u32::MAX && (tooth(labels[m]) || outside(labels[m])) {
                    steps[m] = steps[n] + 1;
                    queue.push_back(m);
                }
            }
        }
        let near: Vec<usize> = (0..len).filter(|&n| steps[n] != u32::MAX).collect();
        if near.is_empty() {
            return Ok(none);
        }
        // The outside at each voxel: the nearest outside voxel not touching the tooth (those that
        // do carry its blur), carried inward step by step; it is air where the outside voxels
        // about it read air (`Calibration::outside_of`: the tooth's blur reaches past the
        // voxels beside it on a fine grid).
        const NONE: u32 = u32::MAX;
        let clear = |n: usize| outside(labels[n]) && steps[n] != u32::MAX && steps[n] >= 1;
        let mut source = vec![NONE; len];
        for &n in &near {
            if clear(n) {
                source[n] = n as u32;
                queue.push_back(n);
            }
        }
        while let Some(n) = queue.pop_front() {
            for m in face_neighbours(n, dims).into_iter().flatten() {
                if steps[m] != u32::MAX && source[m] == NONE {
                    source[m] = source[n];
                    queue.push_back(m);
                }
            }
        }
        let air: Vec<bool> = {
            use rayon::prelude::*;
            (0..len)
                .into_par_iter()
                .map(|n| {
                    if !clear(n) {
                        return false;
                    }
                    outside_about(self.scan, cal, n, &clear) == Some(Label::Air)
                })
                .collect()
        };
        // Signed distances (mm, negative inside) of the voxels' centres from the tooth's surface.
        let values = field::GridField { dims, index_to_world: self.scan.index_to_world(), values: tooth_field };
        let surface = field::level_set_from_field_with(&values, field::Kernel::CubicBSpline, 0.5, h, PROFILE_VOXELS + 1.0)?;
        let m = self.scan.index_to_world();
        let xyz: Vec<f32> = near
            .iter()
            .flat_map(|&n| {
                let ijk = [(n % nx) as f64, ((n / nx) % ny) as f64, (n / (nx * ny)) as f64];
                [0, 1, 2].map(|r| (m[4 * r] * ijk[0] + m[4 * r + 1] * ijk[1] + m[4 * r + 2] * ijk[2] + m[4 * r + 3]) as f32)
            })
            .collect();
        let mut distance = vec![0f32; near.len()];
        surface.sample_values(&xyz, &mut distance);
        // Which tissues lie within two voxels of each voxel (the reach of the outside's grey
        // need not be clear of the other tissue: the profile's medians hold).
        let marked = |mark: &dyn Fn(u8) -> bool| -> Vec<bool> { labels.iter().map(|&c| mark(c)).collect() };
        let by_enamel = within_box(marked(&|c| c == Label::Enamel as u8), dims, 2);
        let by_dentin = within_box(marked(&|c| c == Label::Dentin as u8), dims, 2);
        let by_other = within_box(marked(&|c| matches!(code(c), Some(Label::Pulp | Label::Caries | Label::Metal))), dims, 2);
        // Bone within the reach (outside voxels of bone's grey, clear of the tooth's blur): its
        // grey and its ligament's are no outside the profile holds (the jaw's roots' dentin was
        // read as enamel). Only where the calibration found bone: on a fine scan the tooth's
        // blur brightens the outside past the second voxel toward the grey predicted for bone.
        let bone_measured = cal.shows_bone();
        let bone_grey: Vec<bool> = (0..len)
            .map(|n| {
                let g = f64::from(self.scan.values[n]);
                bone_measured && outside(labels[n]) && steps[n] != u32::MAX && steps[n] >= 2 && (g - g_bone).abs() < (g - g_soft).abs()
            })
            .collect();
        let beside_bone = within_box(bone_grey, dims, reach as usize);
        // The profiles' bins: a voxel's distance from the tooth's surface, in PROFILE_BIN_VOXELS.
        let bins = (2.0 * PROFILE_VOXELS / PROFILE_BIN_VOXELS).round() as usize;
        let bin_of = |d: f32| -> Option<usize> {
            let b = ((f64::from(d) / h + PROFILE_VOXELS) / PROFILE_BIN_VOXELS).floor();
            (b >= 0.0 && (b as usize) < bins).then_some(b as usize)
        };
        // The roots' edge profile into bone, from the dentin with nothing else near.
        let root_profile = {
            let mut samples: Vec<Vec<f32>> = vec![Vec::new(); bins];
            for (i, &n) in near.iter().enumerate() {
                let Some(b) = bin_of(distance[i]) else { continue };
                if beside_bone[n] && by_dentin[n] && !by_enamel[n] && !by_other[n] {
                    samples[b].push(self.scan.values[n]);
                }
            }
            binned_medians(&mut samples)
        };
        let roots = match root_ligament_seen(&root_profile, g_soft) {
            Some(false) => RootBorder::Fused,
            Some(true) => {
                let samples: Vec<(f64, f64)> = root_profile
                    .iter()
                    .enumerate()
                    .filter_map(|(b, g)| Some((((b as f64 + 0.5) * PROFILE_BIN_VOXELS - PROFILE_VOXELS) * h, (*g)?)))
                    .filter(|&(d, _)| d > -LIGAMENT_FIT_VOXELS.0 * h && d < LIGAMENT_FIT_VOXELS.1 * h)
                    .collect();
                match Ligament::fit(&samples, g_soft, g_de, h) {
                    Some(ligament) => {
                        // The blurs take σ²·H from a curved root (see `settle`), the scan's
                        // across the root (the fit's) and the field's own: read over the roots
                        // beside bone, where the profile was read, as their mean.
                        let root = |n: usize| beside_bone[n] && by_dentin[n] && !by_enamel[n] && !by_other[n];
                        let mean_curvature = self.mean_curvature_where(&crate::tissues::surface::surface(&surface)?, root);
                        RootBorder::Ligament(Ligament { shift_mm: (ligament.blur_mm.powi(2) + self.grey_blur_variance()) * mean_curvature, ..ligament })
                    }
                    None => RootBorder::Unread,
                }
            }
            None => RootBorder::Unread,
        };
        let outside_grey = |n: usize| -> Option<(f64, bool)> {
            let s = source[n];
            if s == NONE {
                return None;
            }
            let g = f64::from(self.scan.values[s as usize]);
            // Bone beside the tooth is no outside the profile holds (its ligament is unknown).
            let bone = bone_measured && (g - g_bone).abs() < (g - g_soft).abs();
            Some((if air[s as usize] { g_air } else { g_soft }, bone))
        };
        // The edge profile: the tooth's share against the distance, where one hard tissue is near.
        let mut samples: Vec<Vec<f32>> = vec![Vec::new(); bins];
        for (i, &n) in near.iter().enumerate() {
            let (Some(b), Some((g_out, false))) = (bin_of(distance[i]), outside_grey(n)) else { continue };
            if by_other[n] || beside_bone[n] || by_enamel[n] == by_dentin[n] {
                continue;
            }
            let g_in = if by_enamel[n] { g_en } else { g_de };
            samples[b].push(((f64::from(self.scan.values[n]) - g_out) / (g_in - g_out)) as f32);
        }
        let mut profile = binned_medians(&mut samples);
        // An empty bin on the tooth's side between two read ones takes their line: few voxels lie
        // clear of the other tissues at some depths (a 0.4 mm incisor in a jaw, its canal traced
        // to the apex: bins 10–11 of 15 empty between 1.01 and 0.94, and the profile was lost).
        fill_between(&mut profile[..bins / 2 + 1]);
        // On the tooth's side the bins must be read until the share is whole (deeper bins
        // without voxels clear of the other tissue are whole); the share only falls outward
        // (bins run from inside to outside; a few deep voxels by the DEJ or the pulp read low,
        // so the deeper bins are held to the shallower ones, not the reverse).
        if let Some(deepest) = profile[..bins / 2].iter().rposition(Option::is_none) {
            if profile.get(deepest + 1).copied().flatten().is_some_and(|t| t >= WHOLE_TOOTH_SHARE) {
                profile[..=deepest].iter_mut().for_each(|p| *p = Some(1.0));
            }
        }
        if profile[..bins / 2].iter().any(Option::is_none) {
            return Ok(EdgeProfiles { seen: None, roots });
        }
        let mut last = 0.0f64;
        for p in profile.iter_mut().rev().flatten() {
            *p = p.clamp(last, 1.0);
            last = *p;
        }
        let edge_blur_mm = profile_blur(&profile, h);
        let share_at = |d: f32| -> Option<f64> {
            let x = (f64::from(d) / h + PROFILE_VOXELS) / PROFILE_BIN_VOXELS - 0.5;
            if x <= 0.0 {
                return profile[0];
            }
            let b = x.floor() as usize;
            let (a, c) = (profile.get(b).copied().flatten()?, profile.get(b + 1).copied().flatten()?);
            Some(a + (c - a) * (x - b as f64))
        };
        // The dentin's share where the tooth holds a voxel mostly. Every such voxel is read,
        // the outermost too, though the share's error there is about four times the tooth
        // share's (the enamel/outside contrast against the enamel/dentin one): left out, the
        // crown's blurred rim, read as dentin by the labels' midpoint, stays the core's, a skin of
        // dentin over the enamel with sheets into it (an unseen incisor in air at 0.1 mm, the
        // blur two voxels wide: the core's surface 342 mm² against 296, dentin +4.0 %, enamel
        // −2.2 %; read down to half: +0.1 %, +0.1 %, and the family's normals 0.1° better on
        // average). Bone near is no reason to leave a voxel out, only bone as its outside
        // (`outside_grey`): in a jaw the crown's cervical enamel lies within the profile's reach of
        // the alveolar crest, its outside the gum (the tilted jaw incisor's dentin under enamel
        // thinner than 0.3 mm lay 0.080 mm out, its enamel 5.2° and dentin 5.0° off; read: 4.5°, 4.7°).
        let mut dentin = vec![f32::NAN; len];
        for (i, &n) in near.iter().enumerate() {
            let c = labels[n];
            if (c != Label::Enamel as u8 && c != Label::Dentin as u8) || by_other[n] {
                continue;
            }
            let (Some(t), Some((g_out, false))) = (share_at(distance[i]), outside_grey(n)) else { continue };
            if t < 0.5 {
                continue;
            }
            dentin[n] = ((g_out + (g_en - g_out) * t - f64::from(self.scan.values[n])) / (g_en - g_de)) as f32;
        }
        // Dentin voxels with less than half dentin become enamel, grown from the enamel (the
        // enamel hidden under the outside's grey is the crown's, thinning out).
        let mut seen = self.labels.clone();
        let hidden = |n: usize, l: &[u8]| l[n] == Label::Dentin as u8 && dentin[n] < 0.5;
        let mut grow: std::collections::VecDeque<usize> = (0..len)
            .filter(|&n| hidden(n, &seen.labels) && face_neighbours(n, dims).into_iter().flatten().any(|m| seen.labels[m] == Label::Enamel as u8))
            .collect();
        while let Some(n) = grow.pop_front() {
            if !hidden(n, &seen.labels) {
                continue;
            }
            seen.labels[n] = Label::Enamel as u8;
            for m in face_neighbours(n, dims).into_iter().flatten() {
                if hidden(m, &seen.labels) {
                    grow.push_back(m);
                }
            }
        }
        Ok(EdgeProfiles { seen: Some(SeenUnderTheOutside { labels: seen, dentin_share: dentin, edge_blur_mm, beside_bone }), roots })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Empty bins between read ones take their line; those with no read bin on one side stay empty.
    #[test]
    fn an_empty_bin_between_read_ones_takes_their_line() {
        let mut profile = vec![None, Some(1.0), None, None, Some(0.94), Some(0.5), None];
        fill_between(&mut profile);
        let want = [None, Some(1.0), Some(0.98), Some(0.96), Some(0.94), Some(0.5), None];
        for (got, want) in profile.iter().zip(want) {
            assert!(got.is_some() == want.is_some() && (got.unwrap_or(0.0) - want.unwrap_or(0.0)).abs() < 1e-12, "{profile:?}");
        }
    }

    /// A root's edge profile into bone as the scan's point spread (σ in voxels) makes it, in the
    /// bins [`root_ligament_seen`] reads: dentin, then `ligament` voxels of soft tissue, then bone.
    fn root_profile(ligament: f64, sigma: f64) -> Vec<Option<f64>> {
        let (dentin, soft, bone) = (1800.0, 40.0, 1100.0);
        let bins = (2.0 * PROFILE_VOXELS / PROFILE_BIN_VOXELS).round() as usize;
        (0..bins)
            .map(|b| {
                let s = (b as f64 + 0.5) * PROFILE_BIN_VOXELS - PROFILE_VOXELS;
                let (mut sum, mut weight) = (0.0, 0.0);
                for i in -800..=800 {
                    let u = s + f64::from(i) * 0.01;
                    let w = (-0.5 * ((u - s) / sigma).powi(2)).exp();
                    sum += w * if u < 0.0 { dentin } else if u < ligament { soft } else { bone };
                    weight += w;
                }
                Some(sum / weight)
            })
            .collect()
    }

    #[test]
    fn a_ligament_is_told_from_a_root_fused_to_its_bone_by_the_dip_in_its_edge_profile() {
        // A 0.2 mm ligament at 0.2–0.4 mm voxels (0.5–1 voxel), blurred by 0.5–1 voxel (the
        // family's jaws: a point spread of 0.15 mm and the voxel's box). Dips 11–36 %.
        for (ligament, sigma) in [(1.0, 0.75), (1.0, 1.0), (0.5, 0.5), (0.5, 0.75), (0.75, 1.0)] {
            assert_eq!(root_ligament_seen(&root_profile(ligament, sigma), 40.0), Some(true), "ligament {ligament}, σ {sigma}");
        }
        for sigma in [0.5, 1.0, 1.5] {
            assert_eq!(root_ligament_seen(&root_profile(0.0, sigma), 40.0), Some(false), "fused, σ {sigma}");
        }
        // Not read where a bin near the surface holds too few voxels, or the far side is no
        // brighter than soft tissue.
        let mut holed = root_profile(0.0, 1.0);
        let near_surface = holed.len() / 2 + 1;
        holed[near_surface] = None;
        assert_eq!(root_ligament_seen(&holed, 40.0), None);
        assert_eq!(root_ligament_seen(&root_profile(0.0, 1.0), 1500.0), None);
    }

    /// A Gaussian-blurred step's profile, binned as the edge profile is, gives back its σ, on
    /// any voxel; a profile that never crosses a half gives none.
    #[test]
    fn an_edge_profiles_blur_is_read_back() {
        let bins = (2.0 * PROFILE_VOXELS / PROFILE_BIN_VOXELS).round() as usize;
        let phi = |x: f64| 0.5 * (1.0 + libm::erf(x / std::f64::consts::SQRT_2));
        for (h, sigma) in [(0.3, 0.17), (0.2, 0.15), (0.4, 0.25), (0.1, 0.12)] {
            let profile: Vec<Option<f64>> = (0..bins).map(|b| Some(phi(-((b as f64 + 0.5) * PROFILE_BIN_VOXELS - PROFILE_VOXELS) * h / sigma))).collect();
            let read = profile_blur(&profile, h).unwrap();
            assert!((read / sigma - 1.0).abs() < 0.02, "voxel {h}: σ {sigma} read {read}");
        }
        assert_eq!(profile_blur(&vec![Some(1.0); bins], 0.3), None);
    }
}
