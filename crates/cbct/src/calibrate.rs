//! Per-scan grey-value calibration. CBCT grey values are not HU and vary per device and scan
//! (REFERENCE.md "Tissue grey values"), so we find the histogram peaks, match them in order to the
//! tissues' typical values, fit grey = a·HU + b through the matched peaks, and put each threshold
//! midway between neighbouring tissues' grey values. Manual peaks override. Cost: one pass over
//! the voxels plus a search over peak-to-tissue matchings (a few thousand, microseconds).

use crate::Label;
use crate::error::{Error, Result};
use crate::volume::Volume;
use serde::{Deserialize, Serialize};
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
}

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
        };
        cal.thresholds = PEAK_TISSUES
            .windows(2)
            .map(|w| Threshold { below: w[0].name().into(), above: w[1].name().into(), value: cal.mid(w[0], w[1]) })
            .collect();
        cal.thresholds.push(Threshold { below: "enamel".into(), above: "metal".into(), value: cal.mid(Label::Enamel, Label::Metal) });
        cal
    }

    /// Background class of a grey value (air … enamel, metal) by the thresholds.
    pub fn classify(&self, v: f64) -> Label {
        let mut l = Label::Air;
        for t in &self.thresholds {
            if v > t.value {
                l = Label::from_name(&t.above).unwrap_or(l);
            }
        }
        l
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

/// Histogram of the volume over [lo, hi] in `bins` bins.
fn histogram(vol: &Volume, bins: usize) -> (Vec<f64>, f64, f64) {
    let (lo, hi) = vol.min_max();
    let (lo, hi) = (lo as f64, (hi as f64).max(lo as f64 + 1e-6));
    let mut h = vec![0.0; bins];
    let k = bins as f64 / (hi - lo);
    for &v in &vol.values {
        let b = (((v as f64 - lo) * k) as usize).min(bins - 1);
        h[b] += 1.0;
    }
    (h, lo, hi)
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

/// Automatic calibration of one scan.
pub fn calibrate(vol: &Volume) -> Result<Calibration> {
    if vol.values.len() < 1000 {
        return Err(Error::invalid("volume", format!("{} voxels are too few to calibrate from", vol.values.len())));
    }
    let bins = 512;
    let (h, lo, hi) = histogram(vol, bins);
    let bw = (hi - lo) / bins as f64;
    // Log-histogram so small tissues (enamel, pulp-free dentin) still make peaks beside air and bone.
    let logh: Vec<f64> = h.iter().map(|&c| (1.0 + c).ln()).collect();
    let s = smooth(&logh, 3.0);
    let mut peaks: Vec<(usize, f64)> = Vec::new();
    for i in 1..bins - 1 {
        if s[i] > s[i - 1] && s[i] >= s[i + 1] && h[i] > 0.0 {
            // prominence: drop to the lowest point before a higher peak on each side
            let left = (0..i).rev().take_while(|&j| s[j] <= s[i]).map(|j| s[j]).fold(s[i], f64::min);
            let right = (i + 1..bins).take_while(|&j| s[j] <= s[i]).map(|j| s[j]).fold(s[i], f64::min);
            let prom = s[i] - left.max(right);
            if prom > 0.15 {
                peaks.push((i, prom));
            }
        }
    }
    // keep the 9 most prominent, in grey order
    peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
    peaks.truncate(9);
    peaks.sort_by_key(|p| p.0);
    let grey: Vec<f64> = peaks.iter().map(|p| lo + (p.0 as f64 + 0.5) * bw).collect();
    let hu: Vec<f64> = PEAK_TISSUES.iter().map(|l| l.typical_hu()).collect();
    // Search ordered matchings peaks ↔ tissues (both increasing); score = fit residual in HU plus
    // a penalty per unmatched tissue, so more matches win unless they distort the line.
    let mut best: Option<(f64, Vec<(usize, usize)>)> = None;
    let mut cur = Vec::new();
    search(&grey, &hu, 0, 0, &mut cur, &mut best);
    let Some((_, m)) = best else {
        return otsu_fallback(vol, &h, lo, bw);
    };
    let measured: Vec<(Label, f64)> = m.iter().map(|&(p, t)| (PEAK_TISSUES[t], grey[p])).collect();
    let pts: Vec<(f64, f64)> = m.iter().map(|&(p, t)| (hu[t], grey[p])).collect();
    let (a, b) = fit(&pts).ok_or_else(|| Error::invalid("calibration", "peaks do not increase with tissue density"))?;
    Ok(Calibration::build("histogram-peaks+linear-fit", &measured, a, b))
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
fn otsu_fallback(vol: &Volume, h: &[f64], lo: f64, bw: f64) -> Result<Calibration> {
    let nb = 64;
    let f = h.len() / nb;
    let hc: Vec<f64> = (0..nb).map(|i| h[i * f..(i + 1) * f].iter().sum()).collect();
    let cent = |i: usize| lo + ((i * f) as f64 + f as f64 / 2.0) * bw;
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
    let (a, b) = fit(&pts).ok_or_else(|| Error::invalid(vol.source.path.clone(), "calibration: histogram has no usable structure"))?;
    Ok(Calibration::build("otsu", &measured, a, b))
}
