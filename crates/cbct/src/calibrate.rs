//! Per-scan grey-value calibration. CBCT grey values are not HU and vary per device and scan
//! (REFERENCE.md "Tissue grey values"), and a scan need not hold every tissue (an extracted tooth
//! in air, wax, water or a holder has no bone and no soft tissue). So the histogram's peaks only
//! propose readings; the scan's anatomy decides between them:
//!
//! 1. Peaks of the log-histogram (over the range without a padding value) are proposed as
//!    (dentin, enamel) pairs, with the most frequent lower peak as the medium around the tooth;
//!    three-class Otsu proposes one more. A proposal's grey ratio (enamel − dentin)/(dentin −
//!    medium) must lie where any medium from air to soft tissue puts it (scale and offset cancel).
//! 2. Each proposal is tested on the scan (`layering`): enamel is the crown's outer shell, so
//!    where its voxels touch dentin's, the dentin lies deeper (farther from the medium). Reading
//!    the tooth as "enamel" and wax, water or bone as "dentin" puts the "dentin" outside. The
//!    score is (deeper − shallower contacts) / enamel surface, weighed down where the reading's
//!    dentin shows no bare roots or no bulk (a blurred band read as dentin); rim "dentin" within
//!    0.5 mm of the medium does not count. The best proposal wins.
//! 3. A peak below the dentin is an outside tissue (air, soft tissue, bone) only where its grey
//!    fills a body of the scan (else it is an edge's mix or the storage's rounding; the medium
//!    the scan was taken in always stays). Each such peak is the outside tissue nearest its HU
//!    on the line through the winner's dentin and enamel, peak by peak, so leaving a bump out
//!    moves no other peak to another tissue. The histogram-peak matching to all tissues (grey =
//!    a·HU + b through matched peaks) is kept, for its line, only when it reads the dentin, the
//!    enamel and every outside peak alike.
//! 4. Confidence from the winner's score, its contacts and its lead over a proposal that reads
//!    the tissues otherwise; below [`MIN_CONFIDENCE`], an error says what was found and how to
//!    pass `--thresholds`.
//!
//! Manual peaks override. Cost: one pass to histogram, one to average 2–5³ blocks into a grid of
//! ≥ 0.3 mm, and per proposal a distance transform of that grid (a few proposals).

use crate::Label;
use crate::error::{Error, Result};
use crate::mask;
use crate::volume::Volume;
use serde::{Deserialize, Serialize};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Tissues that make histogram peaks, in increasing grey order.
pub const PEAK_TISSUES: [Label; 6] = [Label::Air, Label::SoftTissue, Label::BoneCancellous, Label::BoneCortical, Label::Dentin, Label::Enamel];

/// The calibration found for (or given to) one scan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// "histogram-peaks+linear-fit", "otsu" or "manual".
    pub method: String,
    /// Grey value per tissue name; measured where a peak was matched, else predicted by the fit.
    pub peaks: BTreeMap<String, f64>,
    /// Which tissues were measured (matched to a histogram peak).
    pub measured: Vec<String>,
    /// grey = hu_scale · HU + hu_offset, fitted through the measured peaks.
    pub hu_scale: f64,
    pub hu_offset: f64,
    /// Class boundaries in increasing grey order: a voxel above `value` is at least `above`.
    pub thresholds: Vec<Threshold>,
    /// 0..1: how sure the reading of dentin and enamel is (1 for manual values).
    #[serde(default = "one")]
    pub confidence: f64,
    /// What the scan showed: the layering test of the reading taken and of the others proposed.
    #[serde(default)]
    pub evidence: Vec<String>,
}

fn one() -> f64 {
    1.0
}

/// The outside about a tooth's surface is read at least this far apart (mm; see
/// [`Calibration::outside_steps`]): a scanner's point spread (σ ≈ 0.2 mm) lifts every voxel
/// within about a σ of the tooth toward its grey, so on a 0.1 mm grid all voxels within 2 of the
/// surface read brighter than the air there (a jaw's crowns at 0.1 mm read as in soft tissue:
/// enamel −3.6…−5.9 %).
pub const OUTSIDE_STEP_MM: f64 = 0.2;

/// Below this confidence, automatic calibration stops with an error instead of guessing.
pub const MIN_CONFIDENCE: f64 = 0.5;

/// The tissues around a tooth that make peaks below the dentin's.
const OUTSIDE: [Label; 4] = [Label::Air, Label::SoftTissue, Label::BoneCancellous, Label::BoneCortical];

/// The three brightest histogram peaks with at least this much of the scan within 3 bins of them
/// are always kept (the tooth's tissues are the scan's brightest). A restoration's blurred rim
/// makes bumps of about 1–2 mm³ between the enamel's grey and the metal's, which took those
/// places (a filled molar in a jaw at 0.2 mm: four of them, and the enamel's peak, over a hundred
/// mm³, crowded out of the nine kept: refused); any tissue the calibration reads is a body of tens
/// of mm³ or more.
pub const MIN_PEAK_MM3: f64 = 5.0;

/// The largest (enamel − dentin) / (dentin − medium) a reading is tried with (see `calibrate`).
const MAX_CONTRAST_RATIO: f64 = 2.0;

/// A peak below the dentin whose grey fills less than this of whole neighbourhoods is no tissue.
const MIN_BODY_MM3: f64 = 5.0;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Threshold {
    pub below: String,
    pub above: String,
    pub value: f64,
}

impl Calibration {
    /// Grey value of a tissue.
    pub fn peak(&self, l: Label) -> f64 {
        self.peaks.get(l.name()).copied().unwrap_or(self.hu_scale * l.typical_hu() + self.hu_offset)
    }

    /// Whether the scan showed the tissue (its grey measured at a peak, or given), not only
    /// predicted by the fit.
    pub fn shows(&self, l: Label) -> bool {
        self.measured.iter().any(|m| m == l.name())
    }

    /// Whether the scan showed bone of either kind.
    pub fn shows_bone(&self) -> bool {
        self.shows(Label::BoneCancellous) || self.shows(Label::BoneCortical)
    }

    /// Midpoint between two tissues' grey values.
    pub fn mid(&self, a: Label, b: Label) -> f64 {
        0.5 * (self.peak(a) + self.peak(b))
    }

    /// Manual override: grey values of at least two of the peak tissues; the rest is predicted
    /// through a linear fit to their typical HU.
    pub fn manual(values: &[(Label, f64)]) -> Result<Calibration> {
        let pts: Vec<(f64, f64)> = values.iter().map(|(l, g)| (l.typical_hu(), *g)).collect();
        let (a, b) = fit(&pts).ok_or_else(|| Error::invalid("manual calibration", "expected at least two tissues with distinct grey values increasing with HU"))?;
        Ok(Self::build("manual", values, a, b))
    }

    fn build(method: &str, measured: &[(Label, f64)], a: f64, b: f64) -> Calibration {
        let mut peaks = BTreeMap::new();
        for l in Label::ALL {
            peaks.insert(l.name().to_string(), a * l.typical_hu() + b);
        }
        for (l, g) in measured {
            peaks.insert(l.name().to_string(), *g);
        }
        let mut cal = Calibration {
            method: method.into(),
            peaks,
            measured: measured.iter().map(|(l, _)| l.name().to_string()).collect(),
            hu_scale: a,
            hu_offset: b,
            thresholds: vec![],
            confidence: 1.0,
            evidence: vec![],
        };
        cal.thresholds = cal.thresholds_between(&PEAK_TISSUES);
        cal
    }

    /// Class boundaries at the midpoints between `classes` (in increasing grey order), then
    /// enamel's against metal.
    fn thresholds_between(&self, classes: &[Label]) -> Vec<Threshold> {
        let mut thresholds: Vec<Threshold> =
            classes.windows(2).map(|w| Threshold { below: w[0].name().into(), above: w[1].name().into(), value: self.mid(w[0], w[1]) }).collect();
        thresholds.push(Threshold { below: "enamel".into(), above: "metal".into(), value: self.mid(Label::Enamel, Label::Metal) });
        thresholds
    }

    /// The same grey values with no bone classes between the medium and the dentin, for a scan
    /// that shows no bone (a tooth alone in air, wax or water). There the grey the fit predicts
    /// for bone is only the blur's mix of the tooth and the medium, and the hard-tissue
    /// threshold at bone's midpoint with the dentin (~85 % of the way from the medium) can
    /// take a thin apical wall, blurred darker, for the outside: the canal then opens to it
    /// and the pulp is lost. Without bone the threshold is the medium's midpoint with the dentin.
    pub fn without_bone(&self) -> Calibration {
        let classes: Vec<Label> = PEAK_TISSUES.into_iter().filter(|l| !matches!(l, Label::BoneCancellous | Label::BoneCortical)).collect();
        let mut cal = self.clone();
        cal.thresholds = self.thresholds_between(&classes);
        cal.evidence.push(format!(
            "read without bone classes (the scan shows no bone): hard tissue above {:.1} instead of {:.1}",
            cal.hard_cut(),
            self.hard_cut()
        ));
        cal
    }

    /// The same reading with the given tissues' grey values measured anew (those the scan
    /// showed; a scan's shading taken off moves them) and the thresholds between the same
    /// classes moved with them; `why` joins the evidence.
    pub fn with_greys(&self, greys: &[(Label, f64)], why: String) -> Calibration {
        let mut cal = self.clone();
        for &(l, g) in greys.iter().filter(|(l, g)| self.shows(*l) && g.is_finite()) {
            cal.peaks.insert(l.name().to_string(), g);
        }
        let steps: Vec<&Threshold> = self.thresholds.iter().filter(|t| t.above != Label::Metal.name()).collect();
        let classes: Vec<Label> = steps.first().and_then(|t| Label::from_name(&t.below)).into_iter().chain(steps.iter().filter_map(|t| Label::from_name(&t.above))).collect();
        cal.thresholds = cal.thresholds_between(&classes);
        cal.evidence.push(why);
        cal
    }

    /// The grey above which a voxel is hard tissue (dentin or enamel): the threshold under the
    /// dentin's class.
    pub fn hard_cut(&self) -> f64 {
        self.thresholds.iter().find(|t| t.above == Label::Dentin.name()).map_or_else(|| self.mid(Label::BoneCortical, Label::Dentin), |t| t.value)
    }

    /// Background class of a grey value (air … enamel, metal) by the thresholds.
    pub fn classify(&self, v: f64) -> Label {
        self.classifier().classify(v)
    }

    /// The class among `among` whose grey is nearest `v` (the first on a tie).
    pub fn nearest(&self, v: f64, among: &[Label]) -> Label {
        *among.iter().min_by(|a, b| (self.peak(**a) - v).abs().total_cmp(&(self.peak(**b) - v).abs())).unwrap_or(&among[0])
    }

    /// The tissue among `among` that lies outside a tooth where `greys` are the outside voxels
    /// about one of its surface voxels (reordered): their median's, except air. The tooth's blur
    /// lifts the outside's grey near it toward the tooth's, so air next to a crown reads as soft
    /// tissue by its median once the blur reaches past the voxels beside the tooth (a point
    /// spread of 0.15–0.2 mm on a 0.15–0.2 mm grid: the family's crowns in the jaw and in wax
    /// 0.02–0.04 mm inside, their enamel −2…−5 %); it never darkens soft tissue to air. So where
    /// the darker fifth reads air, the outside is air. `None` for no voxels.
    pub fn outside_of(&self, greys: &mut [f32], among: &[Label]) -> Option<Label> {
        if greys.is_empty() {
            return None;
        }
        let at = |greys: &mut [f32], k: usize| f64::from(*greys.select_nth_unstable_by(k, f32::total_cmp).1);
        let median = self.nearest(at(greys, greys.len() / 2), among);
        if median == Label::Air || !among.contains(&Label::Air) {
            return Some(median);
        }
        let darker = self.nearest(at(greys, greys.len() / 5), among);
        Some(if darker == Label::Air { Label::Air } else { median })
    }

    /// The grey of a root's partner across its surface where the outside about it is `bone` and
    /// `greys` are those outside voxels (reordered). Roots sit in bone behind a periodontal
    /// ligament (soft tissue, ~0.2 mm), mostly thinner than the scan resolves: the partner is what
    /// lies next to the root, the ligament darkening the bone's first voxels by its share, so its
    /// grey is the darker end of the outside's (its lowest fifth), between soft tissue's (a
    /// ligament the scan shows) and the bone's (a root fused to it, ankylosis). Soft tissue's
    /// for no voxels.
    pub fn root_partner(&self, greys: &mut [f32], bone: Label) -> f64 {
        let (bone, soft) = (self.peak(bone), self.peak(Label::SoftTissue));
        if greys.is_empty() {
            return soft;
        }
        let k = greys.len() / 5;
        let low = f64::from(*greys.select_nth_unstable_by(k, f32::total_cmp).1);
        if low < bone - 0.25 * (bone - soft) {
            soft
        } else {
            low.clamp(soft.min(bone), bone)
        }
    }

    /// The steps (voxels, per axis) of the 5³ lattice about a surface voxel whose outside voxels
    /// [`Self::outside_of`] reads: the voxel, or [`OUTSIDE_STEP_MM`] where the voxel is finer.
    pub fn outside_steps(spacing: [f64; 3]) -> [usize; 3] {
        spacing.map(|s| ((OUTSIDE_STEP_MM / s).round() as usize).max(1))
    }

    /// [`Self::classify`] with the thresholds' names read once, for a scan's every voxel.
    pub fn classifier(&self) -> Classifier {
        Classifier::new(self.thresholds.iter().map(|t| (t.value, Label::from_name(&t.above))).collect())
    }
}

/// The calibration's thresholds as (value, class above it); a name no label has keeps the class
/// below, as [`Calibration::classify`] reads it. Held as the thresholds' values in order and the
/// class between each two: a scan's every voxel is classified (48 M for the bench scan), and a
/// count of values below is a few compares where the thresholds in turn were a branch each.
pub struct Classifier {
    bounds: Vec<f64>,
    /// `classes[i]`: the class above `bounds[..i]` and at or below the rest.
    classes: Vec<Label>,
}

impl Classifier {
    /// From the thresholds in the calibration's order: above each threshold its class, or
    /// (`None`) the class below it; the last threshold a grey is above wins.
    fn new(steps: Vec<(f64, Option<Label>)>) -> Classifier {
        let steps: Vec<(f64, Option<Label>)> = steps.into_iter().filter(|(v, _)| !v.is_nan()).collect();
        let mut bounds: Vec<f64> = steps.iter().map(|s| s.0).collect();
        bounds.sort_by(f64::total_cmp);
        bounds.dedup();
        let between = |above: &[f64]| steps.iter().filter(|(v, _)| above.contains(v)).fold(Label::Air, |l, (_, class)| class.unwrap_or(l));
        let classes = (0..=bounds.len()).map(|i| between(&bounds[..i])).collect();
        Classifier { bounds, classes }
    }

    pub fn classify(&self, v: f64) -> Label {
        self.classes[self.bounds.iter().filter(|&&b| b < v).count()]
    }
}

/// Least-squares line grey = a·hu + b; None unless a > 0.
fn fit(pts: &[(f64, f64)]) -> Option<(f64, f64)> {
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let a = sxy / sxx;
    (a > 0.0 && a.is_finite()).then_some((a, my - a * mx))
}

/// Histogram of the volume's grey values up to `ceiling` in at most `bins` bins over their range
/// without a padding value: a scanner
/// fills the corners outside its round field of view with one value (often the type's minimum,
/// far below air), which would squeeze every tissue into a few bins. Returns the histogram, its
/// range and the padding value left out (if any).
fn histogram(vol: &Volume, bins: usize, ceiling: f64) -> (Vec<f64>, f64, f64, Option<f64>) {
    let (lo, hi) = vol.min_max();
    let (mut lo, mut hi) = (lo as f64, hi as f64);
    if hi > ceiling {
        hi = vol.values.par_iter().map(|&v| v as f64).filter(|&v| v <= ceiling).reduce(|| f64::NEG_INFINITY, f64::max).max(lo);
    }
    let mut padding = None;
    let at_min = vol.values.par_iter().filter(|&&v| v as f64 == lo).count();
    if at_min * 200 >= vol.values.len() {
        let next = vol.values.par_iter().map(|&v| v as f64).filter(|&v| v > lo).reduce(|| f64::INFINITY, f64::min);
        // a value set apart by a gap of over a tenth of the range is padding, not air
        if next.is_finite() && next - lo > 0.1 * (hi - lo) {
            padding = Some(lo);
            lo = next;
        }
    }
    let hi = hi.max(lo + 1e-6);
    // a margin, so a tissue at the very end of the range (clipped air, a scan's top) still
    // makes a peak inside the histogram
    let pad = 0.02 * (hi - lo);
    let (mut lo, mut hi) = (lo - pad, hi + pad);
    let mut bins = bins;
    // Whole grey values (an 8- or 12-bit scan's) in bins of whole steps, each value at the
    // same place in its bin: bins narrower than a step left most of them empty, a comb whose
    // smoothed log put the air of an 8-bit scan 8 steps (270 HU) above its grey.
    if vol.values.par_iter().all(|v| v.fract() == 0.0) {
        let step = ((hi - lo) / bins as f64).ceil().max(1.0);
        lo = lo.floor() - 0.5;
        bins = ((hi - lo) / step).ceil() as usize;
        hi = lo + bins as f64 * step;
    }
    let k = bins as f64 / (hi - lo);
    // Counted in parts side by side: whole counts, so the sum is the same in any order.
    let counts = vol
        .values
        .par_chunks(1 << 16)
        .fold(
            || vec![0u64; bins],
            |mut h, part| {
                for &v in part {
                    let v = v as f64;
                    if v < lo || v > ceiling {
                        continue;
                    }
                    h[(((v - lo) * k) as usize).min(bins - 1)] += 1;
                }
                h
            },
        )
        .reduce(
            || vec![0u64; bins],
            |mut a, b| {
                a.iter_mut().zip(&b).for_each(|(a, b)| *a += b);
                a
            },
        );
    (counts.into_iter().map(|c| c as f64).collect(), lo, hi, padding)
}

fn smooth(h: &[f64], sigma: f64) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as isize;
    let w: Vec<f64> = (-r..=r).map(|d| (-(d * d) as f64 / (2.0 * sigma * sigma)).exp()).collect();
    let n = h.len() as isize;
    (0..n)
        .map(|i| {
            let (mut s, mut ws) = (0.0, 0.0);
            for (q, wq) in w.iter().enumerate() {
                let j = i + q as isize - r;
                if j >= 0 && j < n {
                    s += wq * h[j as usize];
                    ws += wq;
                }
            }
            s / ws
        })
        .collect()
}

/// A peak of the histogram: grey value and how many voxels lie near it.
#[derive(Debug, Clone, Copy)]
struct Peak {
    grey: f64,
    count: f64,
}

/// Prominent peaks of the log-histogram (so small tissues, enamel, still show beside air and
/// bone), at most 9, in grey order; the three brightest with at least `body` voxels about them
/// are always among them (see [`MIN_PEAK_MM3`]).
fn peaks(h: &[f64], lo: f64, bw: f64, body: f64) -> Vec<Peak> {
    let bins = h.len();
    // The log of the smoothed counts, not the smoothed log: a noise-free tissue is one full bin,
    // and the logs of its mixtures' sparse bins beside it outweighed it once smoothed (the
    // family's jaws without noise lost their air, read the cancellous bone as the medium, and
    // one was refused).
    let s: Vec<f64> = smooth(h, 3.0).iter().map(|&c| (1.0 + c).ln()).collect();
    let count = |i: usize| h[i.saturating_sub(3)..(i + 4).min(bins)].iter().sum::<f64>();
    let mut found: Vec<(usize, f64)> = Vec::new();
    for i in 1..bins - 1 {
        if s[i] > s[i - 1] && s[i] >= s[i + 1] && h[i] > 0.0 {
            // prominence: drop to the lowest point before a higher peak on each side
            let left = (0..i).rev().take_while(|&j| s[j] <= s[i]).map(|j| s[j]).fold(s[i], f64::min);
            let right = (i + 1..bins).take_while(|&j| s[j] <= s[i]).map(|j| s[j]).fold(s[i], f64::min);
            let prom = s[i] - left.max(right);
            if prom > 0.15 {
                found.push((i, prom));
            }
        }
    }
    // At most 9, the most prominent, but always the three brightest: the tooth's tissues are
    // the scan's brightest, and a jaw's blurred edges (air–soft tissue–bone mixes) can make more
    // bumps below the dentin than leave room for the enamel (an incisor in a jaw at 0.25 mm:
    // nine prominent peaks up to the dentin, the enamel's tenth; refused at confidence 0).
    // (Of bodies: a restoration's blurred rim spreads a few mm³ thinly over the grey values from
    // the enamel's to the metal's, and the log of those sparse bins makes prominent bumps.)
    found.sort_by_key(|p| (count(p.0) < body, std::cmp::Reverse(p.0)));
    let brightest = found.iter().filter(|p| count(p.0) >= body).count().min(3);
    found[brightest..].sort_by(|a, b| b.1.total_cmp(&a.1));
    found.truncate(9);
    found.sort_by_key(|p| p.0);
    found.iter().map(|&(i, _)| Peak { grey: lo + (i as f64 + 0.5) * bw, count: count(i) }).collect()
}

/// Automatic calibration of one scan (see the module comment); errors when the scan's anatomy
/// does not make the reading sure enough.
pub fn calibrate(vol: &Volume) -> Result<Calibration> {
    calibrate_below(vol, f64::INFINITY)
}

/// As [`calibrate`], the histogram counting grey values up to `ceiling` only. A scan whose
/// restorations' bloom was taken off ([`crate::bloom`]) still holds the metal, whose blurred
/// edge inside its half-way surface spreads over the grey values up to the metal's: its bumps
/// took five of the nine peaks kept and crowded out the outside's (a filled incisor in air then
/// read the 1050 edge mix as bone, and with bone shown its pulp was lost at bone's threshold).
pub fn calibrate_below(vol: &Volume, ceiling: f64) -> Result<Calibration> {
    if vol.values.len() < 1000 {
        return Err(Error::invalid("volume", format!("{} voxels are too few to calibrate from", vol.values.len())));
    }
    let bins = 512;
    let (h, lo, hi, padding) = histogram(vol, bins, ceiling);
    let bw = (hi - lo) / h.len() as f64;
    let found = peaks(&h, lo, bw, MIN_PEAK_MM3 / vol.voxel_volume_mm3());
    let by_order = match_in_order(&h, lo, bw, &found);

    // Proposals: (medium, dentin, enamel) grey values.
    let mut proposals: Vec<[f64; 3]> = Vec::new();
    let medium_below = |d: f64| -> Option<f64> {
        found.iter().filter(|p| p.grey < d).max_by(|a, b| a.count.total_cmp(&b.count)).map(|p| p.grey).or(padding)
    };
    for (i, d) in found.iter().enumerate() {
        for e in &found[i + 1..] {
            if let Some(m) = medium_below(d.grey) {
                proposals.push([m, d.grey, e.grey]);
            }
        }
    }
    for cal in [&by_order, &otsu(&h, lo, bw)].into_iter().flatten() {
        let (d, e) = (cal.peak(Label::Dentin), cal.peak(Label::Enamel));
        if let Some(m) = medium_below(d) {
            proposals.push([m, d, e]);
        }
    }
    // Scale and offset cancel in this ratio; from air to soft tissue around the tooth it is 0.3–0.55
    // in HU, and CBCT's lower enamel–dentin contrast lowers it; with the jaw's bone the medium
    // (its largest peak below the dentin) about 1.6 (2900 − 1800 over 1800 − 1100 HU).
    proposals.retain(|&[m, d, e]| {
        let r = (e - d) / (d - m);
        m < d && d < e && (0.12..=MAX_CONTRAST_RATIO).contains(&r)
    });
    // The same proposal twice (the order's reading is often one of the pairs) is tested once:
    // it would score alike and sort next to itself.
    let mut unique: Vec<[f64; 3]> = Vec::with_capacity(proposals.len());
    for p in proposals {
        if !unique.iter().any(|q| q.map(f64::to_bits) == p.map(f64::to_bits)) {
            unique.push(p);
        }
    }
    let proposals = unique;
    let grid = Coarse::new(vol);
    let mut thresholds: Vec<f64> = proposals.iter().map(|p| 0.5 * (p[0] + p[1])).collect();
    thresholds.sort_by(f64::total_cmp);
    thresholds.dedup();
    let outsides = grid.outsides(&thresholds);
    let mut tested: Vec<([f64; 3], Layering)> = proposals.par_iter().map(|&p| (p, grid.layering(p, &outsides))).collect();
    tested.sort_by(|a, b| b.1.score().total_cmp(&a.1.score()));
    let peaks_text = found.iter().map(|p| format!("{:.0}", p.grey)).collect::<Vec<_>>().join(", ");
    let Some((best, lay)) = tested.first().cloned() else {
        return Err(refusal(vol, &peaks_text, "no pair of peaks can be dentin and enamel", None));
    };
    // The winner says which structures are dentin and enamel; their grey values are measured in
    // them (a proposal's peaks may be partial-volume bumps beside the tissues' own).
    let [m, d, e] = match grid.measure(best, ceiling) {
        Some((d, e)) if best[0] < d && d < e => [best[0], d, e],
        _ => best,
    };
    // The best proposal reading the tissues otherwise: its thresholds do not both fall between
    // the same tissues as the winner's.
    let same = |p: &[f64; 3]| {
        let (t1, t2) = (0.5 * (p[0] + p[1]), 0.5 * (p[1] + p[2]));
        m < t1 && t1 < d && d < t2 && t2 < e
    };
    let rival = tested.iter().skip(1).find(|(p, _)| !same(p));
    let tol = 0.25 * (e - d);
    let rival_score = rival.map_or(0.0, |r| r.1.score().max(0.0));
    let s = lay.score();
    let confidence = ((s / 0.15).clamp(0.0, 1.0) * (lay.deeper as f64 / 100.0).clamp(0.0, 1.0) * ((s - rival_score) / (0.5 * s)).clamp(0.0, 1.0)).max(0.0);
    let mut evidence = vec![format!(
        "reading dentin {d:.0}, enamel {e:.0} (medium {m:.0}): at {} of {} enamel–dentin contacts the dentin lies deeper, at {} shallower, over {} enamel surface voxels; {} contacts of thick dentin with the medium (roots); {:.0} % of the dentin's voxels inner (score {s:.3})",
        lay.deeper,
        lay.deeper + lay.shallower + lay.level,
        lay.shallower,
        lay.surface,
        lay.bare,
        100.0 * lay.dentin_inner as f64 / lay.dentin.max(1) as f64
    )];
    if let Some((p, r)) = rival {
        evidence.push(format!("next reading: dentin {:.0}, enamel {:.0} (medium {:.0}), score {:.3}", p[1], p[2], p[0], r.score()));
    }
    evidence.push(format!("histogram peaks at {peaks_text}{}", padding.map_or(String::new(), |p| format!("; padding value {p:.0} left out"))));
    if confidence < MIN_CONFIDENCE {
        let what = format!("confidence {confidence:.2} is below {MIN_CONFIDENCE}: {}", evidence.join("; "));
        return Err(refusal(vol, &peaks_text, &what, Some((m, d, e))));
    }
    // The outside's peaks (below the dentin) are tissues only where they are bodies. Each is
    // the tissue nearest its grey on the line through the dentin and enamel, peak by peak, so a
    // bump left out moves no other peak to another tissue; the order's reading (which matches
    // all peaks at once, and shifts them a tissue up when one goes) is taken only where it reads
    // every outside peak as that does, for its line through more tissues.
    let found = bodies(&found, d, e, &grid);
    let layered = from_layering(&found, padding, d, e);
    let by_order = match_in_order(&h, lo, bw, &found);
    let outside_of = |c: &Calibration| -> Vec<(Label, f64)> { OUTSIDE.into_iter().filter(|&l| c.shows(l)).map(|l| (l, c.peak(l))).collect() };
    let agrees = by_order.filter(|c| (c.peak(Label::Dentin) - d).abs() <= tol && (c.peak(Label::Enamel) - e).abs() <= tol && outside_of(c) == outside_of(&layered));
    let mut cal = agrees.unwrap_or(layered);
    cal.confidence = confidence;
    cal.evidence = evidence;
    Ok(cal)
}

/// The error for a scan whose tissues cannot be told apart: what was found and how to pass the
/// grey values by hand.
fn refusal(vol: &Volume, peaks: &str, why: &str, guess: Option<(f64, f64, f64)>) -> Error {
    let example = match guess {
        Some((m, d, e)) => format!("soft_tissue={m:.0},dentin={d:.0},enamel={e:.0}"),
        None => "soft_tissue=GREY,dentin=GREY,enamel=GREY".into(),
    };
    Error::invalid(
        format!("{} (calibration)", vol.source.path),
        format!(
            "cannot tell enamel from dentin by the tooth's layering: {why}. Histogram peaks at {peaks}. \
             Give the grey values of the medium around the tooth, dentin and enamel with --thresholds, e.g. --thresholds {example} \
             (the plugin: Thresholds)"
        ),
    )
}

/// The peaks that are tissues. Below the dentin (the outside's: air, soft tissue, bone) a
/// tissue is a body: its grey (between the neighbouring peaks') fills whole neighbourhoods over
/// at least [`MIN_BODY_MM3`]; a peak that fills none is the blur's mix at an edge or the
/// storage's rounding (an 8-bit scan of a tooth in air shows such peaks where bone would be).
/// Only whole neighbourhoods `outside` the tooth count (reached from the border through grey
/// below the dentin's band): the pulp is a body too, enclosed by the dentin, and its grey (300 HU)
/// lies among the outside's, nearer bone's; a scan that resolves it read it as bone.
/// The medium the scan was taken in stays whatever its shape: the most frequent of them, and
/// the lowest where its grey reaches the scan's border (air, or the wax or water a tooth lies in).
fn bodies(found: &[Peak], d: f64, e: f64, grid: &Coarse) -> Vec<Peak> {
    let cut = below_dentin(d, e);
    let below = |p: &Peak| p.grey < cut;
    let lower: Vec<Peak> = found.iter().copied().filter(below).collect();
    let medium = lower.iter().map(|p| p.count).fold(f64::NEG_INFINITY, f64::max);
    // (Its flood is serial: made only when a peak needs it.)
    let outsides = std::cell::OnceCell::new();
    let body = |i: usize| {
        let outside = || outsides.get_or_init(|| grid.outside(cut)).first();
        let p = lower[i];
        let lo = if i == 0 { f64::NEG_INFINITY } else { 0.5 * (lower[i - 1].grey + p.grey) };
        let hi = lower.get(i + 1).map_or(0.5 * (p.grey + d), |q| 0.5 * (p.grey + q.grey));
        p.count >= medium || (i == 0 && grid.reaches_border(lo, hi)) || grid.body_mm3(lo, hi, outside(), MIN_BODY_MM3) >= MIN_BODY_MM3
    };
    let kept: Vec<bool> = (0..lower.len()).map(body).collect();
    let mut lower_kept = kept.into_iter();
    found.iter().copied().filter(|p| !below(p) || lower_kept.next().unwrap_or(true)).collect()
}

/// The grey below the dentin's band (dentin `d`, enamel `e`): peaks under it are the outside's
/// (or the pulp's).
fn below_dentin(d: f64, e: f64) -> f64 {
    d - 0.25 * (e - d)
}

/// A calibration through the dentin and enamel read by layering: grey = a·HU + b through their
/// typical HU; every lower peak is the outside tissue (air, soft tissue, bone) nearest its
/// implied HU (the most frequent peak where two land on one). The lowest is air or soft tissue:
/// a crown stands in air, soft tissue, wax or water, never in bone alone, and a scanner whose
/// enamel–dentin contrast is below the typical one (slope 1.0 where the typical HU give 1.26)
/// puts water's grey at ~420 HU on that line, nearer cancellous bone than soft tissue: read as
/// bone, it made the scan a jaw's (enamel +6.5 %, a 12-bit scan of a molar in water).
fn from_layering(found: &[Peak], padding: Option<f64>, d: f64, e: f64) -> Calibration {
    let a = (e - d) / (Label::Enamel.typical_hu() - Label::Dentin.typical_hu());
    let b = d - a * Label::Dentin.typical_hu();
    let mut taken: Vec<(Label, Peak)> = Vec::new();
    let lower = found.iter().copied().filter(|p| p.grey < below_dentin(d, e)).chain(padding.filter(|_| found.iter().all(|p| p.grey >= below_dentin(d, e))).map(|g| Peak { grey: g, count: 0.0 }));
    let lowest = lower.clone().map(|p| p.grey).fold(f64::INFINITY, f64::min);
    for p in lower {
        let outside: &[Label] = if p.grey == lowest { &OUTSIDE[..2] } else { &OUTSIDE };
        let hu = (p.grey - b) / a;
        let Some(&l) = outside.iter().min_by(|x, y| (x.typical_hu() - hu).abs().total_cmp(&(y.typical_hu() - hu).abs())) else { continue };
        match taken.iter_mut().find(|(t, _)| *t == l) {
            Some(slot) if slot.1.count < p.count => slot.1 = p,
            Some(_) => {}
            None => taken.push((l, p)),
        }
    }
    let mut measured: Vec<(Label, f64)> = taken.into_iter().map(|(l, p)| (l, p.grey)).collect();
    measured.sort_by_key(|(l, _)| *l as u8);
    // keep the order of grey values the thresholds rely on
    let mut last = f64::NEG_INFINITY;
    measured.retain(|(_, g)| {
        let ok = *g > last;
        last = last.max(*g);
        ok
    });
    measured.extend([(Label::Dentin, d), (Label::Enamel, e)]);
    Calibration::build("tooth-layering+linear-fit", &measured, a, b)
}

/// [`Coarse::outside`] at several thresholds: a voxel is outside at `thresholds[l]` where its
/// level is at most `l`.
struct Outsides {
    thresholds: Vec<f64>,
    level: Vec<u8>,
}

impl Outsides {
    fn at(&self, threshold: f64) -> Option<Outside<'_>> {
        self.thresholds.iter().position(|&t| t == threshold).map(|l| Outside { level: &self.level, l: l as u8 })
    }

    /// The first threshold's (of [`Coarse::outside`]'s one).
    fn first(&self) -> Outside<'_> {
        Outside { level: &self.level, l: 0 }
    }
}

/// One threshold's outside of an [`Outsides`].
#[derive(Clone, Copy)]
struct Outside<'a> {
    level: &'a [u8],
    l: u8,
}

impl Outside<'_> {
    fn has(&self, n: usize) -> bool {
        self.level[n] <= self.l
    }
}

/// The scan averaged in blocks of 1–5 voxels per axis to a grid of ≥ 0.3 mm: enough for enamel
/// (1–2.5 mm) to show as a layer, few voxels to test proposals on, and block means for less noise.
struct Coarse {
    dims: [usize; 3],
    spacing: [f64; 3],
    values: Vec<f32>,
}

impl Coarse {
    fn new(vol: &Volume) -> Coarse {
        let step = [0, 1, 2].map(|c| ((0.35 / vol.spacing[c]).round() as usize).clamp(1, 5));
        let dims = [0, 1, 2].map(|c| (vol.dims[c] / step[c]).max(1));
        let spacing = [0, 1, 2].map(|c| vol.spacing[c] * step[c] as f64);
        let [nx, ny, _] = dims;
        let mut values = vec![0f32; dims[0] * dims[1] * dims[2]];
        // Row by row, each cell's sum in the order dz, dy, dx (its cells lie inside the scan:
        // the coarse sides are whole steps of it, or one cell of a scan thinner than a step).
        let step: [usize; 3] = std::array::from_fn(|c| step[c].min(vol.dims[c]).max(1));
        let n = (step[0] * step[1] * step[2]) as f64;
        values.par_chunks_mut(nx * ny).enumerate().for_each(|(k, slab)| {
            let mut acc = vec![0f64; nx];
            for (j, out) in slab.chunks_exact_mut(nx).enumerate() {
                acc.fill(0.0);
                for dk in 0..step[2] {
                    for dj in 0..step[1] {
                        let start = vol.index(0, j * step[1] + dj, k * step[2] + dk);
                        let row = &vol.values[start..start + nx * step[0]];
                        for (a, cell) in acc.iter_mut().zip(row.chunks_exact(step[0])) {
                            for &v in cell {
                                *a += v as f64;
                            }
                        }
                    }
                }
                for (o, a) in out.iter_mut().zip(&acc) {
                    *o = (a / n) as f32;
                }
            }
        });
        Coarse { dims, spacing, values }
    }

    /// Grey values of dentin and enamel as a proposal reads the scan: the median of enamel voxels
    /// inside the enamel (every neighbour enamel) and of dentin voxels inside the dentin within
    /// two voxels of the enamel (the crown's dentin, not bone of dentin's grey). Above `ceiling`
    /// (a restoration's metal, [`calibrate_below`]) is neither: the coarse cells at a filling's
    /// edge, its metal and enamel averaged, put a filled incisor's enamel 50 grey values up (of
    /// 1000) and its enamel volume −6 %. (No bound from the proposal itself: its enamel may be a
    /// partial-volume bump below the enamel's own grey, which this median corrects.)
    fn measure(&self, [m, d, e]: [f64; 3], ceiling: f64) -> Option<(f64, f64)> {
        let (t1, t2) = (0.5 * (m + d), 0.5 * (d + e));
        let [nx, ny, nz] = self.dims;
        let class: Vec<u8> = self
            .values
            .par_iter()
            .map(|&v| match v as f64 {
                v if v <= t1 => 0,
                v if v <= t2 => 1,
                v if v <= ceiling => 2,
                _ => 3,
            })
            .collect();
        let at = |i: isize, j: isize, k: isize| -> Option<u8> {
            (i >= 0 && j >= 0 && k >= 0 && (i as usize) < nx && (j as usize) < ny && (k as usize) < nz).then(|| class[i as usize + nx * (j as usize + ny * k as usize)])
        };
        let inside = |i: isize, j: isize, k: isize, c: u8| [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)].iter().all(|&(a, b, g)| at(i + a, j + b, k + g) == Some(c));
        let near_enamel = |i: isize, j: isize, k: isize| (-2..=2).any(|a| (-2..=2).any(|b| (-2..=2).any(|g| at(i + a, j + b, k + g) == Some(2))));
        // Slab by slab side by side, gathered in the slabs' order.
        let slabs: Vec<(Vec<f32>, Vec<f32>)> = (0..nz as isize)
            .into_par_iter()
            .map(|k| {
                let (mut de, mut dd) = (Vec::new(), Vec::new());
                for j in 0..ny as isize {
                    for i in 0..nx as isize {
                        let n = i as usize + nx * (j as usize + ny * k as usize);
                        match class[n] {
                            2 if inside(i, j, k, 2) => de.push(self.values[n]),
                            1 if inside(i, j, k, 1) && near_enamel(i, j, k) => dd.push(self.values[n]),
                            _ => {}
                        }
                    }
                }
                (de, dd)
            })
            .collect();
        let (mut de, mut dd): (Vec<f32>, Vec<f32>) = (Vec::new(), Vec::new());
        for (e, d) in slabs {
            de.extend(e);
            dd.extend(d);
        }
        if de.len() < 8 || dd.len() < 8 {
            return None;
        }
        let median = |v: &mut Vec<f32>| {
            let h = v.len() / 2;
            *v.select_nth_unstable_by(h, |a, b| a.total_cmp(b)).1 as f64
        };
        Some((median(&mut dd), median(&mut de)))
    }

    /// Volume (mm³) of the voxels with grey in `lo..hi` whose whole 3³ neighbourhood's is too,
    /// counted up to `enough_mm3` (a jaw's bone and soft tissue are bodies of thousands).
    /// (The 6 face neighbours alone let an oblique edge's mix count: a filled incisor's crown in
    /// air at 0.15 mm left 5.05 mm³ of it at the pulp's grey, which was then read as bone.)
    fn body_mm3(&self, lo: f64, hi: f64, outside: Outside, enough_mm3: f64) -> f64 {
        let [nx, ny, nz] = self.dims;
        let within = |n: usize| outside.has(n) && (lo..hi).contains(&f64::from(self.values[n]));
        let whole = |n: usize| {
            let (i, j, k) = ((n % nx) as i64, ((n / nx) % ny) as i64, (n / (nx * ny)) as i64);
            (-1..=1i64).all(|dk| {
                (-1..=1i64).all(|dj| {
                    (-1..=1i64).all(|di| {
                        let (a, b, c) = (i + di, j + dj, k + dk);
                        !(a >= 0 && b >= 0 && c >= 0 && (a as usize) < nx && (b as usize) < ny && (c as usize) < nz) || within(a as usize + nx * (b as usize + ny * c as usize))
                    })
                })
            })
        };
        let cell_mm3 = self.spacing.iter().product::<f64>();
        let enough = (enough_mm3 / cell_mm3).ceil().min(usize::MAX as f64) as usize;
        let count = (0..self.values.len()).into_par_iter().filter(|&n| within(n) && whole(n)).take_any(enough).count();
        count as f64 * cell_mm3
    }

    /// Whether a voxel on the grid's border has grey in `lo..hi` (the six faces only).
    fn reaches_border(&self, lo: f64, hi: f64) -> bool {
        let [nx, ny, nz] = self.dims;
        if self.values.is_empty() {
            return false;
        }
        let within = |i: usize, j: usize, k: usize| (lo..hi).contains(&f64::from(self.values[i + nx * (j + ny * k)]));
        let face = |a: usize, b: usize, f: &dyn Fn(usize, usize) -> bool| (0..a).any(|u| (0..b).any(|v| f(u, v)));
        let (x1, y1, z1) = (nx - 1, ny - 1, nz - 1);
        face(ny, nz, &|j, k| within(0, j, k) || within(x1, j, k))
            || face(nx, nz, &|i, k| within(i, 0, k) || within(i, y1, k))
            || face(nx, ny, &|i, j| within(i, j, 0) || within(i, j, z1))
    }

    /// The medium (grey at most `t1`) around the tooth: reached from the grid's border through
    /// medium at least three voxels wide, then grown back by a voxel. Medium the tooth encloses
    /// (an empty pulp chamber, a canal open at the apex by less than that) is not.
    fn outside(&self, t1: f64) -> Outsides {
        self.outsides(&[t1])
    }

    /// [`Self::outside`] at each of `thresholds` (ascending). The media at rising thresholds are
    /// nested, so one pass serves them all: a voxel's level is the first threshold its grey is
    /// medium under, the floods of every level are filled at once
    /// ([`mask::flood_levels_from_border`]), and each outside is read off the levels (one byte a
    /// voxel for them all).
    fn outsides(&self, thresholds: &[f64]) -> Outsides {
        let levels = thresholds.len().min(usize::from(u8::MAX - 1)) as u8;
        let thresholds = &thresholds[..usize::from(levels)];
        let level: Vec<u8> = self.values.par_iter().map(|&v| thresholds.iter().position(|&t| v as f64 <= t).map_or(levels, |l| l as u8)).collect();
        // Medium at least three wide from a level on: it and its neighbours are medium (past the
        // grid's border counts as medium).
        let wide = mask::neighbour_map(self.dims, &level, 0, |own, near| near.iter().fold(own, |a, &b| a.max(b)));
        let reached = mask::flood_levels_from_border(self.dims, &wide, levels);
        // Reached, or beside a reached voxel (none past the border), and medium.
        let outside = mask::neighbour_map(self.dims, &reached, u8::MAX, |own, near| near.iter().fold(own, |a, &b| a.min(b)));
        let level: Vec<u8> = outside.par_iter().zip(&level).map(|(&r, &l)| r.max(l)).collect();
        Outsides { thresholds: thresholds.to_vec(), level }
    }

    /// Tests a proposal (medium, dentin, enamel): at each 6-neighbour contact of an enamel voxel
    /// with a dentin voxel (not one touching the medium: that is the partial-volume rim where
    /// enamel meets the outside), walks away from the contact on each side along the axis to the
    /// medium (at most 4 mm); the dentin lies deeper when its walk is the longer.
    ///
    /// Read twice, the better reading kept: with every medium voxel as the medium, and with the
    /// medium the tooth encloses (an empty pulp chamber of an extracted tooth: walks from the
    /// dentin would end in it) read as inside. The first alone misreads teeth with an empty
    /// pulp; the second alone misses outside medium walled in by bone in a jaw.
    /// `outsides` holds [`Self::outside`] by its threshold (proposals sharing a medium and a
    /// dentin share it; its flood is serial, so it is made once for each).
    fn layering(&self, proposal: [f64; 3], outsides: &Outsides) -> Layering {
        let t1 = 0.5 * (proposal[0] + proposal[1]);
        let made;
        let outside = match outsides.at(t1) {
            Some(o) => o,
            None => {
                made = self.outside(t1);
                made.first()
            }
        };
        let [a, b] = self.layerings(proposal, outside);
        if b.score() > a.score() {
            b
        } else {
            a
        }
    }

    /// Both readings of [`Self::layering`] in one pass over the grid: every medium voxel as the
    /// medium, and only the `outside` one.
    fn layerings(&self, [m, d, e]: [f64; 3], outside: Outside) -> [Layering; 2] {
        let (t1, t2) = (0.5 * (m + d), 0.5 * (d + e));
        let [nx, ny, nz] = self.dims;
        // The grid with a layer of BEYOND around it, so that walks and neighbours need no bounds
        // test: a walk ends there as at the medium, and it is no tissue and no medium.
        let [px, py, pz] = [nx + 2, ny + 2, nz + 2];
        let stride = [1, px, px * py];
        let padded = |i: usize, j: usize, k: usize| (i + 1) + px * ((j + 1) + py * (k + 1));
        // 0 the medium around the tooth, 1 dentin, 2 enamel, 3 medium enclosed by the tooth:
        // the second reading's walks go on through it, and it is no surface; the first's see
        // medium.
        let mut classes = vec![BEYOND; px * py * pz];
        classes.par_chunks_mut(px * py).skip(1).take(nz).enumerate().for_each(|(k, slab)| {
            for j in 0..ny {
                for i in 0..nx {
                    let n = i + nx * (j + ny * k);
                    let v = f64::from(self.values[n]);
                    slab[(i + 1) + px * (j + 1)] = if v <= t1 {
                        if outside.has(n) {
                            0
                        } else {
                            3
                        }
                    } else if v <= t2 {
                        1
                    } else {
                        2
                    };
                }
            }
        });
        let classes = &classes;
        // The class of a voxel in a reading (0: all medium; 1: the outside only).
        let at = |n: usize, reading: usize| -> u8 {
            match classes[n] {
                3 if reading == 0 => 0,
                c => c,
            }
        };
        let caps = [0, 1, 2].map(|axis| (4.0 / self.spacing[axis]).ceil() as usize);
        let thick_steps = [0, 1, 2].map(|axis| (1.0 / self.spacing[axis]).ceil() as usize);
        let walk = |from: usize, axis: usize, dir: isize, reading: usize| -> f64 {
            let step = dir * stride[axis] as isize;
            let mut p = from;
            for s in 1..=caps[axis] {
                p = p.wrapping_add_signed(step);
                if matches!(at(p, reading), 0 | BEYOND) {
                    return s as f64 * self.spacing[axis];
                }
            }
            f64::INFINITY
        };
        let thick = |from: usize, axis: usize, dir: isize| -> bool {
            let step = dir * stride[axis] as isize;
            let mut p = from;
            (0..thick_steps[axis]).all(|_| {
                p = p.wrapping_add_signed(step);
                at(p, 0) == 1
            })
        };
        let add = |a: [Layering; 2], b: [Layering; 2]| [0, 1].map(|r| a[r].plus(&b[r]));
        (0..nz)
            .into_par_iter()
            .map(|k| {
                let mut out = [Layering::default(); 2];
                for j in 0..ny {
                    for i in 0..nx {
                        let p = padded(i, j, k);
                        let class = classes[p];
                        if class != 1 && class != 2 {
                            continue;
                        }
                        for (reading, l) in out.iter_mut().enumerate() {
                            if class == 1 {
                                l.dentin += 1;
                                l.dentin_inner += usize::from(stride.iter().all(|&s| at(p - s, reading) == 1 && at(p + s, reading) == 1));
                                // dentin facing the medium with ≥ 1 mm of dentin behind it: a root
                                for axis in 0..3 {
                                    for dir in [-1isize, 1] {
                                        let q = p.wrapping_add_signed(dir * stride[axis] as isize);
                                        if at(q, reading) == 0 && thick(p, axis, -dir) {
                                            l.bare += 1;
                                        }
                                    }
                                }
                                continue;
                            }
                            let mut on_surface = false;
                            for axis in 0..3 {
                                for dir in [-1isize, 1] {
                                    let q = p.wrapping_add_signed(dir * stride[axis] as isize);
                                    match at(q, reading) {
                                        2 => {}
                                        1 => {
                                            on_surface = true;
                                            let touches_medium = stride.iter().any(|&s| at(q - s, reading) == 0 || at(q + s, reading) == 0);
                                            if touches_medium {
                                                continue;
                                            }
                                            let (de, dd) = (walk(p, axis, -dir, reading), walk(q, axis, dir, reading));
                                            // (Nor "dentin" within the blur's edge of the medium:
                                            // the same rim, two voxels thick where the grid is
                                            // as fine as the blur.)
                                            if dd <= EDGE_MIX_MM {
                                                continue;
                                            }
                                            let h = 0.5 * self.spacing[axis];
                                            if dd > de + h {
                                                l.deeper += 1;
                                            } else if de > dd + h {
                                                l.shallower += 1;
                                            } else {
                                                l.level += 1;
                                            }
                                        }
                                        _ => on_surface = true,
                                    }
                                }
                            }
                            l.surface += on_surface as usize;
                        }
                    }
                }
                out
            })
            .reduce(|| [Layering::default(); 2], add)
    }
}

/// How far from the medium (mm) "dentin" beside enamel is the partial-volume rim where the
/// enamel meets the outside, not a layer: a blurred edge takes 2.6 σ from 10 to 90 %, 0.5 mm
/// for a point spread of σ 0.2 mm. (Scans at 0.24–0.25 mm, coarse grid unaveraged, showed the
/// rim two voxels thick: its contacts read as dentin lying shallower, 45 % of them, and every
/// such scan was refused.)
const EDGE_MIX_MM: f64 = 0.5;

/// The share of "dentin" voxels with dentin all round below which the reading's dentin is no
/// bulk: its score falls in proportion (a reading of the dentin–enamel blur as dentin: 0.4 mm
/// scans of an incisor whose bone fills the view).
const BULK_SHARE: f64 = 0.2;

/// [`Coarse::layerings`]' class past the grid's border.
const BEYOND: u8 = 4;

/// Contacts of enamel with dentin under one proposal.
#[derive(Debug, Clone, Copy, Default)]
struct Layering {
    /// dentin deeper than the enamel (enamel outside it, as in a crown)
    deeper: usize,
    shallower: usize,
    level: usize,
    /// enamel voxels with a non-enamel neighbour
    surface: usize,
    /// dentin facing the medium with dentin behind it (the roots: enamel covers only the
    /// crown); a reading of the pulp as "dentin" inside a whole tooth read as "enamel" has none
    bare: usize,
    /// "dentin" voxels, and those whose six neighbours are dentin too: dentin is the tooth's
    /// bulk, a blurred band between two tissues has almost no inner voxels
    dentin: usize,
    dentin_inner: usize,
}

impl Layering {
    fn plus(&self, o: &Layering) -> Layering {
        Layering {
            deeper: self.deeper + o.deeper,
            shallower: self.shallower + o.shallower,
            level: self.level + o.level,
            surface: self.surface + o.surface,
            bare: self.bare + o.bare,
            dentin: self.dentin + o.dentin,
            dentin_inner: self.dentin_inner + o.dentin_inner,
        }
    }

    fn score(&self) -> f64 {
        let roots = (self.bare as f64 / (0.1 * self.surface.max(1) as f64)).min(1.0);
        let bulk = (self.dentin_inner as f64 / (BULK_SHARE * self.dentin.max(1) as f64)).min(1.0);
        roots * bulk * (self.deeper as f64 - self.shallower as f64) / self.surface.max(1) as f64
    }
}

/// The reading by histogram-peak order: peaks matched in order to the tissues' typical values
/// (or three-class Otsu when too few peaks show).
fn match_in_order(h: &[f64], lo: f64, bw: f64, found: &[Peak]) -> Option<Calibration> {
    let grey: Vec<f64> = found.iter().map(|p| p.grey).collect();
    let hu: Vec<f64> = PEAK_TISSUES.iter().map(|l| l.typical_hu()).collect();
    // Search ordered matchings peaks ↔ tissues (both increasing); score = fit residual in HU plus
    // a penalty per unmatched tissue, so more matches win unless they distort the line.
    let mut best: Option<(f64, Vec<(usize, usize)>)> = None;
    let mut cur = Vec::new();
    search(&grey, &hu, 0, 0, &mut cur, &mut best);
    let Some((_, m)) = best else {
        return otsu(h, lo, bw);
    };
    let measured: Vec<(Label, f64)> = m.iter().map(|&(p, t)| (PEAK_TISSUES[t], grey[p])).collect();
    let pts: Vec<(f64, f64)> = m.iter().map(|&(p, t)| (hu[t], grey[p])).collect();
    let (a, b) = fit(&pts)?;
    Some(Calibration::build("histogram-peaks+linear-fit", &measured, a, b))
}

fn score(grey: &[f64], hu: &[f64], m: &[(usize, usize)]) -> Option<f64> {
    if m.len() < 3 {
        return None;
    }
    let pts: Vec<(f64, f64)> = m.iter().map(|&(p, t)| (hu[t], grey[p])).collect();
    let (a, b) = fit(&pts)?;
    let rms = (pts.iter().map(|&(x, y)| ((y - b) / a - x).powi(2)).sum::<f64>() / pts.len() as f64).sqrt();
    Some(rms + 120.0 * (PEAK_TISSUES.len() - m.len()) as f64)
}

fn search(grey: &[f64], hu: &[f64], p0: usize, t0: usize, cur: &mut Vec<(usize, usize)>, best: &mut Option<(f64, Vec<(usize, usize)>)>) {
    if let Some(s) = score(grey, hu, cur) {
        if best.as_ref().map(|b| s < b.0).unwrap_or(true) {
            *best = Some((s, cur.clone()));
        }
    }
    for p in p0..grey.len() {
        for t in t0..hu.len() {
            cur.push((p, t));
            search(grey, hu, p + 1, t + 1, cur, best);
            cur.pop();
        }
    }
}

/// Three-threshold Otsu (exhaustive on 64 bins) when too few peaks show: classes taken as air,
/// soft tissue, dentin, enamel.
fn otsu(h: &[f64], lo: f64, bw: f64) -> Option<Calibration> {
    let nb = 64;
    // The bins in nb groups of len/nb bins (bin b in group b·nb/len), each at its middle.
    let per_group = h.len() as f64 / nb as f64;
    let mut hc = vec![0.0; nb];
    for (b, &c) in h.iter().enumerate() {
        hc[b * nb / h.len()] += c;
    }
    let cent = |i: usize| lo + (i as f64 + 0.5) * per_group * bw;
    let (mut w, mut m) = (vec![0.0; nb + 1], vec![0.0; nb + 1]);
    for i in 0..nb {
        w[i + 1] = w[i] + hc[i];
        m[i + 1] = m[i] + hc[i] * cent(i);
    }
    let var = |a: usize, b: usize| {
        let ww = w[b] - w[a];
        if ww > 0.0 {
            (m[b] - m[a]).powi(2) / ww
        } else {
            0.0
        }
    };
    let mut best = (f64::NEG_INFINITY, [0usize; 3]);
    for t1 in 1..nb - 2 {
        for t2 in t1 + 1..nb - 1 {
            for t3 in t2 + 1..nb {
                let v = var(0, t1) + var(t1, t2) + var(t2, t3) + var(t3, nb);
                if v > best.0 {
                    best = (v, [t1, t2, t3]);
                }
            }
        }
    }
    let [t1, t2, t3] = best.1;
    let mean = |a: usize, b: usize| if w[b] > w[a] { (m[b] - m[a]) / (w[b] - w[a]) } else { cent(a) };
    let measured = vec![(Label::Air, mean(0, t1)), (Label::SoftTissue, mean(t1, t2)), (Label::Dentin, mean(t2, t3)), (Label::Enamel, mean(t3, nb))];
    let pts: Vec<(f64, f64)> = measured.iter().map(|(l, g)| (l.typical_hu(), *g)).collect();
    let (a, b) = fit(&pts)?;
    Some(Calibration::build("otsu", &measured, a, b))
}

/// Grey values per tissue from "TISSUE=GREY,..." (what `--thresholds` and the plugin's
/// Thresholds take), for [`Calibration::manual`]; errors name the item.
pub fn parse_thresholds(text: &str) -> Result<Vec<(Label, f64)>> {
    text.split(',')
        .map(str::trim)
        .filter(|item| !item.is_empty())
        .map(|item| {
            let (name, value) = item.split_once('=').ok_or_else(|| Error::invalid("thresholds", format!("'{item}' is not TISSUE=GREY")))?;
            let label = Label::from_name(name.trim()).ok_or_else(|| Error::invalid("thresholds", format!("unknown tissue '{}'", name.trim())))?;
            let grey: f64 = value.trim().parse().map_err(|_| Error::invalid("thresholds", format!("'{}' for {} is not a number", value.trim(), name.trim())))?;
            if !grey.is_finite() {
                return Err(Error::invalid("thresholds", format!("{}={} is not finite", name.trim(), value.trim())));
            }
            Ok((label, grey))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The classifier's table gives what the thresholds read in turn give, for thresholds in
        /// any order (the user's may be unsorted, repeated, or name no label) and any grey.
        #[test]
        fn the_classifier_reads_as_the_thresholds_in_turn(
            steps in prop::collection::vec((prop_oneof![-3.0..3.0f64, Just(0.0), Just(1.0), Just(f64::NAN)], prop::option::of(0..9usize)), 0..10),
            greys in prop::collection::vec(prop_oneof![-4.0..4.0f64, Just(0.0), Just(1.0), Just(-0.0), Just(f64::NAN), Just(f64::INFINITY)], 1..40),
        ) {
            let steps: Vec<(f64, Option<Label>)> = steps.into_iter().map(|(v, l)| (v, l.map(|l| Label::ALL[l]))).collect();
            let classifier = Classifier::new(steps.clone());
            for v in greys {
                let in_turn = steps.iter().fold(Label::Air, |l, &(value, above)| if v > value { above.unwrap_or(l) } else { l });
                prop_assert_eq!(classifier.classify(v), in_turn, "grey {}", v);
            }
        }
    }

    /// The coarse grid's cells are the means of the scan's voxels they cover, in scans thinner
    /// than a cell along an axis too.
    #[test]
    fn a_coarse_cell_is_the_mean_of_its_voxels() {
        use crate::volume::{SourceInfo, IDENTITY};
        for (dims, spacing) in [([9, 7, 5], [0.1, 0.2, 0.35]), ([5, 1, 2], [0.07, 0.1, 0.12]), ([1, 3, 4], [0.5, 0.05, 0.1])] {
            let values: Vec<f32> = (0..dims.iter().product::<usize>()).map(|n| ((n * 7919) % 1013) as f32 * 0.37).collect();
            let vol = Volume { dims, spacing, origin: [0.0; 3], direction: IDENTITY, values, source: SourceInfo::default() };
            let grid = Coarse::new(&vol);
            let step: [usize; 3] = std::array::from_fn(|c| ((0.35 / spacing[c]).round() as usize).clamp(1, 5));
            for (n, &got) in grid.values.iter().enumerate() {
                let at = [n % grid.dims[0], (n / grid.dims[0]) % grid.dims[1], n / (grid.dims[0] * grid.dims[1])];
                let (mut sum, mut count) = (0.0f64, 0usize);
                for z in at[2] * step[2]..((at[2] + 1) * step[2]).min(dims[2]) {
                    for y in at[1] * step[1]..((at[1] + 1) * step[1]).min(dims[1]) {
                        for x in at[0] * step[0]..((at[0] + 1) * step[0]).min(dims[0]) {
                            sum += f64::from(vol.values[vol.index(x, y, z)]);
                            count += 1;
                        }
                    }
                }
                assert_eq!(got, (sum / count as f64) as f32, "{dims:?} cell {at:?}");
            }
        }
    }

    #[test]
    fn the_brightest_peaks_are_kept_however_many_bumps_lie_below() {
        // Ten bumps, the brightest (the enamel's) the least prominent in the log-histogram.
        let mut h = vec![1.0; 600];
        for (centre, height) in (0..9).map(|i| (30 + 55 * i, 5000.0)).chain([(560, 40.0)]) {
            for (b, count) in h.iter_mut().enumerate() {
                *count += height * (-((b as f64 - centre as f64) / 6.0).powi(2) / 2.0).exp();
            }
        }
        let found = peaks(&h, 0.0, 1.0, 0.0);
        assert_eq!(found.len(), 9, "{found:?}");
        assert!((found[8].grey - 560.5).abs() <= 2.0, "the brightest bump dropped: {found:?}");
        assert!((found[7].grey - 470.5).abs() <= 2.0 && (found[6].grey - 415.5).abs() <= 2.0, "{found:?}");
    }

    #[test]
    fn greys_measured_anew_move_the_thresholds_between_the_same_classes() {
        let cal = Calibration::manual(&[(Label::Air, -1000.0), (Label::Dentin, 1800.0), (Label::Enamel, 2900.0)]).unwrap().without_bone();
        let moved = cal.with_greys(&[(Label::Enamel, 2800.0), (Label::Pulp, 100.0), (Label::Air, -1040.0)], "shading".into());
        assert_eq!(moved.peak(Label::Enamel), 2800.0);
        assert_eq!(moved.peak(Label::Air), -1040.0);
        // the pulp's grey was only predicted: not the scan's to move
        assert_eq!(moved.peak(Label::Pulp), cal.peak(Label::Pulp));
        let between = |c: &Calibration| c.thresholds.iter().map(|t| (t.below.clone(), t.above.clone())).collect::<Vec<_>>();
        assert_eq!(between(&moved), between(&cal), "the classes without bone kept");
        assert_eq!(moved.thresholds.iter().find(|t| t.above == "enamel").unwrap().value, 2300.0);
        assert_eq!(moved.evidence.last().map(String::as_str), Some("shading"));
    }

    #[test]
    fn a_noise_free_tissue_is_found_in_its_one_full_bin() {
        // A noise-free scan: every tissue one bin, and above the air a comb of its mixtures
        // with the soft tissue (the counts of the family's noise-free jaw at 0.3 mm), whose
        // smoothed log outweighs the air's one bin.
        let mut h = vec![0.0; 512];
        let comb = [(12, 40.0), (14, 64.0), (16, 114.0), (17, 301.0), (19, 1590.0), (21, 74.0), (23, 60.0), (25, 202.0), (26, 40.0)];
        for (bin, count) in [(9, 201_185.0), (150, 90_000.0), (300, 30_000.0), (420, 4_000.0)].into_iter().chain(comb) {
            h[bin] = count;
        }
        let found = peaks(&h, 0.0, 1.0, 0.0);
        let greys: Vec<f64> = found.iter().map(|p| p.grey).collect();
        for tissue in [9.5, 150.5, 300.5, 420.5] {
            assert!(greys.contains(&tissue), "no peak at {tissue}: {greys:?}");
        }
        assert!(found[0].count >= 201_185.0, "{found:?}");
    }

    #[test]
    fn an_oblique_edges_blurred_mix_is_no_body_and_a_layer_is() {
        use crate::volume::{SourceInfo, IDENTITY};
        // 9 mm at 0.15 mm, blurred by σ 0.2 mm (the coarse grid's cells are 0.3 mm): dentin
        // beyond an oblique plane against air, and a 1.5 mm layer of soft tissue between them.
        const N: usize = 60;
        let h = 0.15;
        let scan = |layer: f64| {
            let mut values: Vec<f32> = (0..N * N * N)
                .map(|n| {
                    let p = [n % N, (n / N) % N, n / (N * N)].map(|v| v as f64 * h);
                    let depth = (p[0] + 0.6 * p[1] + 0.3 * p[2]) / (1.0f64 + 0.36 + 0.09).sqrt();
                    if depth > 6.0 { 1800.0 } else if depth > 6.0 - layer { 40.0 } else { -1000.0 }
                })
                .collect();
            crate::phantom::gaussian_blur(&mut values, [N; 3], [0.2 / h; 3]);
            Coarse::new(&Volume { dims: [N; 3], spacing: [h; 3], origin: [0.0; 3], direction: IDENTITY, values, source: SourceInfo::default() })
        };
        let wedge = || {
            let mut values: Vec<f32> = (0..N * N * N)
                .map(|n| {
                    let p = [n % N, (n / N) % N, n / (N * N)].map(|v| v as f64 * h);
                    if p[0] > 2.0 && (p[2] - 4.5).abs() < (p[0] - 2.0) * 20f64.to_radians().tan() { 1800.0 } else { -1000.0 }
                })
                .collect();
            crate::phantom::gaussian_blur(&mut values, [N; 3], [0.2 / h; 3]);
            Coarse::new(&Volume { dims: [N; 3], spacing: [h; 3], origin: [0.0; 3], direction: IDENTITY, values, source: SourceInfo::default() })
        };
        // Air against dentin: grey half-way between them (a pulp's, 300 HU, lies there) is only
        // the blurred edge's mix, here along a plane and about a 20° wedge's edge (an incisor's
        // incisal edge, whose thin end the blur makes all mix).
        for (grid, what) in [(scan(0.0), "plane"), (wedge(), "wedge")] {
            let outsides = grid.outside(below_dentin(1800.0, 2900.0));
            let mixed = grid.values.iter().filter(|&&v| (-336.0..1065.0).contains(&f64::from(v))).count() as f64 * 0.027;
            let mix = grid.body_mm3(-336.0, 1065.0, outsides.first(), f64::INFINITY);
            assert!(mixed > 20.0 && mix < 0.5, "{what}: {mixed} mm³ of the mix's grey, {mix} mm³ of it a body");
        }
        let grid = scan(1.5);
        let layer = grid.body_mm3(-480.0, 920.0, grid.outside(below_dentin(1800.0, 2900.0)).first(), f64::INFINITY);
        assert!(layer > MIN_BODY_MM3, "the soft tissue layer: {layer} mm³ of body");
    }
}
