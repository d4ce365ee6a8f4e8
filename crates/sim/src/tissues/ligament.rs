//! A root's border in its socket: dentin, the periodontal ligament (soft tissue, ~0.2 mm), then
//! bone, all under the scanner's blur. A voxel by the root holds a share of the bone's grey that
//! depends on how far it lies from the root, so its grey read as a two-tissue mix of dentin and
//! soft tissue misplaces the surface by more the further out the voxel is: the roots in bone
//! were the family's dentin's largest normal error beyond the resolution floor.

use dentsim_cbct::bloom::phi;

/// The ligament about the roots, as the roots' edge profile into bone shows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ligament {
    /// The ligament's width (mm).
    pub width_mm: f64,
    /// The blur across the root's border (σ, mm: the scanner's point spread with the voxel's box).
    pub blur_mm: f64,
    /// The bone's grey beyond the ligament, the profile's.
    pub bone_grey: f64,
    /// How far out (mm) the roots' share is read: what the blurs take from a curved root,
    /// which a profile across a flat border does not know ([`Self::root_share`]).
    pub shift_mm: f64,
}

/// The profile's model over the ligament's width `w`, the blur `s` and the offset `delta` of the
/// surface the distances were measured from, without the bone's term (which is linear in the
/// bone's grey): the dentin's part, and the bone's share.
fn parts(d: f64, delta: f64, s: f64, w: f64) -> (f64, f64) {
    (phi(-(d - delta) / s), phi((d - delta - w) / s))
}

impl Ligament {
    /// Fits grey(d) = soft + (dentin − soft)·Φ(−(d − δ)/s) + (bone − soft)·Φ((d − δ − w)/s) to the
    /// roots' edge profile (`samples`: distance from the tooth's surface in mm, outward positive,
    /// and the grey there) by least squares: a search over δ, s and w, coarse to fine, with the
    /// bone's grey solved for each. `None` where the profile shows no bone brighter than soft
    /// tissue by a twentieth of the dentin's contrast, or the fit runs to the edge of what a
    /// ligament and a scanner's blur can be.
    pub fn fit(samples: &[(f64, f64)], soft: f64, dentin: f64, h: f64) -> Option<Ligament> {
        let contrast = dentin - soft;
        if samples.len() < 8 || !(contrast > 0.0) {
            return None;
        }
        // For given δ, s and w: the bone's grey by least squares, and the residual.
        // Σ(r − b·x)² over the samples, with r the grey less soft tissue's and the dentin's part
        // and x the bone's share, is least at b = Σrx/Σx², where it is Σr² − (Σrx)²/Σx².
        let solve = |delta: f64, s: f64, w: f64| -> (f64, f64) {
            let (mut rx, mut xx, mut rr) = (0.0, 0.0, 0.0);
            for &(d, g) in samples {
                let (de, bo) = parts(d, delta, s, w);
                let r = g - soft - contrast * de;
                rx += r * bo;
                xx += bo * bo;
                rr += r * r;
            }
            if xx > 0.0 {
                (soft + rx / xx, rr - rx * rx / xx)
            } else {
                (soft, rr)
            }
        };
        let (s_range, w_range, delta_range) = ((0.02, 1.5 * h + 0.2), (0.0, 1.0), (-0.5 * h, 0.5 * h));
        let (mut best, mut best_residual) = ((0.0, 0.2, 0.2), f64::INFINITY);
        let mut step = (0.1 * h, 0.02, 0.02);
        let mut centre: Option<(f64, f64, f64)> = None;
        for _ in 0..4 {
            let span = |lo: f64, hi: f64, at: Option<f64>, step: f64| -> Vec<f64> {
                let (lo, hi) = match at {
                    Some(c) => ((c - 4.0 * step).max(lo), (c + 4.0 * step).min(hi)),
                    None => (lo, hi),
                };
                let n = ((hi - lo) / step).round() as usize;
                (0..=n).map(|i| lo + (hi - lo) * i as f64 / n.max(1) as f64).collect()
            };
            for &delta in &span(delta_range.0, delta_range.1, centre.map(|c| c.0), step.0) {
                for &s in &span(s_range.0, s_range.1, centre.map(|c| c.1), step.1) {
                    for &w in &span(w_range.0, w_range.1, centre.map(|c| c.2), step.2) {
                        let (_, r) = solve(delta, s, w);
                        if r < best_residual {
                            (best, best_residual) = ((delta, s, w), r);
                        }
                    }
                }
            }
            centre = Some(best);
            step = (step.0 / 4.0, step.1 / 4.0, step.2 / 4.0);
        }
        let (delta, s, w) = best;
        let (bone, _) = solve(delta, s, w);
        let at_edge = |x: f64, (lo, hi): (f64, f64)| x <= lo + 1e-9 || x >= hi - 1e-9;
        (bone - soft > 0.05 * contrast && bone < dentin && w > 0.0 && !at_edge(s, s_range) && !at_edge(w, w_range)).then_some(Ligament { width_mm: w, blur_mm: s, bone_grey: bone, shift_mm: 0.0 })
    }

    /// The root's share of a voxel of grey `grey` by a root in bone of grey `bone` beyond the
    /// ligament: the u with Φ(u) + β·Φ(−u − w/s) = (grey − soft)/(dentin − soft), β the bone's
    /// contrast over soft tissue's as a share of the dentin's, then Φ(u). Where the bone is no
    /// brighter than soft tissue this is the two-tissue mix. The left side rises only from
    /// u = (ln β − a²/2)/a (a = w/s; below it the bone's rise outweighs the root's fall), a
    /// share of 0.05 for the family's jaws: voxels darker than that point read as its share.
    /// The share is read as if the root's surface lay [`Self::shift_mm`] further out.
    pub fn root_share(&self, grey: f64, soft: f64, dentin: f64, bone: f64) -> f64 {
        let contrast = dentin - soft;
        let t = (grey - soft) / contrast;
        let beta = ((bone - soft) / contrast).clamp(0.0, 1.0);
        if beta <= 0.0 || !t.is_finite() {
            return t;
        }
        let a = self.width_mm / self.blur_mm;
        let lowest = if a > 0.0 { ((beta.ln() - 0.5 * a * a) / a).max(-8.0) } else { -8.0 };
        let f = |u: f64| phi(u) + beta * phi(-u - a);
        let (mut lo, mut hi) = (lowest, 8.0);
        let shifted = |u: f64| phi(u + self.shift_mm / self.blur_mm);
        if t <= f(lo) {
            return shifted(lo);
        }
        if t >= f(hi) {
            return 1.0;
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if f(mid) < t {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        shifted(0.5 * (lo + hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SOFT: f64 = 1150.0;
    const DENTIN: f64 = 2580.0;

    fn grey(d: f64, lig: &Ligament) -> f64 {
        let (de, bo) = parts(d, 0.0, lig.blur_mm, lig.width_mm);
        SOFT + (DENTIN - SOFT) * de + (lig.bone_grey - SOFT) * bo
    }

    #[test]
    fn a_ligament_is_read_back_from_its_profile() {
        let made = Ligament { width_mm: 0.2, blur_mm: 0.17, bone_grey: 1550.0, shift_mm: 0.0 };
        let h = 0.3;
        let samples: Vec<(f64, f64)> = (0..30).map(|b| (((b as f64 + 0.5) * 0.25 - 4.0) * h, 0.0)).filter(|&(d, _)| d > -2.0 * h && d < 3.5 * h).map(|(d, _)| (d, grey(d, &made))).collect();
        let read = Ligament::fit(&samples, SOFT, DENTIN, h).expect("a ligament is read");
        assert!((read.width_mm - 0.2).abs() < 0.01, "{read:?}");
        assert!((read.blur_mm - 0.17).abs() < 0.005, "{read:?}");
        assert!((read.bone_grey - 1550.0).abs() < 10.0, "{read:?}");
    }

    #[test]
    fn a_profile_with_no_bone_beyond_reads_no_ligament() {
        let h = 0.3;
        let samples: Vec<(f64, f64)> = (0..24).map(|b| (((b as f64 + 0.5) * 0.25 - 3.0) * h, 0.0)).map(|(d, _)| (d, SOFT + (DENTIN - SOFT) * phi(-d / 0.17))).collect();
        assert_eq!(Ligament::fit(&samples, SOFT, DENTIN, h), None);
    }

    #[test]
    fn the_roots_share_is_read_through_the_bones_blur() {
        let lig = Ligament { width_mm: 0.2, blur_mm: 0.17, bone_grey: 1550.0, shift_mm: 0.0 };
        for d in [-0.2, -0.1, 0.0, 0.05, 0.1, 0.2] {
            let share = lig.root_share(grey(d, &lig), SOFT, DENTIN, lig.bone_grey);
            let truth = phi(-d / lig.blur_mm);
            assert!((share - truth).abs() < 1e-6, "at {d} mm: {share} against {truth}");
            // Read as a two-tissue mix, the voxels out by the bone read more root than they hold.
            let mix = (grey(d, &lig) - SOFT) / (DENTIN - SOFT);
            assert!(d <= 0.0 || mix - truth > 0.02, "at {d} mm the mix reads {mix} against {truth}");
        }
        // Shifted out by 0.02 mm: the share a voxel would hold 0.02 mm further in.
        let shifted = Ligament { shift_mm: 0.02, ..lig };
        let share = shifted.root_share(grey(0.05, &lig), SOFT, DENTIN, lig.bone_grey);
        assert!((share - phi(-(0.05 - 0.02) / lig.blur_mm)).abs() < 1e-6, "{share}");
        // No bone beyond: the two-tissue mix.
        assert!((lig.root_share(1865.0, SOFT, DENTIN, SOFT) - 0.5).abs() < 1e-12);
    }
}
