//! A cone-beam scan's shading: the same tissue a few hundred grey values apart across the field
//! of view (cupping toward the axis of rotation, a ramp along it from the cone's angle, scatter),
//! where a CT's HU would be flat. Over one tooth it is smooth, so it is read as a quadratic field
//! in the box's coordinates shared by every tissue: each voxel 0.5 mm deep in a tissue whose grey
//! is uniform (enamel, dentin, pulp, air, soft tissue; not bone, whose grey varies by nature)
//! reads its tissue's grey plus the field. Least squares, reweighted (Tukey's biweight on each
//! tissue's own spread) so mislabelled voxels and lesions do not bend it.

use crate::{Label, LabelVolume, Volume};

/// Tissues whose grey is one value in a scan free of shading.
const UNIFORM: [Label; 5] = [Label::Enamel, Label::Dentin, Label::Pulp, Label::Air, Label::SoftTissue];

/// The field's monomials x^a y^b z^c, 1 ≤ a + b + c ≤ DEGREE, over the box scaled to −1…1.
/// A cubic followed a hump of scatter better in jaw molars but cost the coarse incisors' pulps
/// 8–12 % (19 terms on a narrow box whose thin pulp no voxel reads).
const DEGREE: usize = 2;
/// How many monomials that is: 3 + 6 for a quadratic.
const TERMS: usize = (DEGREE + 1) * (DEGREE + 2) * (DEGREE + 3) / 6 - 1;

/// How deep in its tissue (mm) a voxel is read: a dental scan's blur (σ 0.15–0.25 mm) leaves
/// its neighbour's grey there under a few per cent (on a 0.1 mm grid two voxels deep lay within
/// one σ, and the air by a crown read hundreds brighter).
const DEEP_MM: f64 = 0.5;

/// Fewest voxels per tissue for it to enter the fit.
const MIN_VOXELS: usize = 200;

/// Most voxels per tissue the fit reads.
const SAMPLES_PER_TISSUE: usize = 20_000;

/// The fitted field over one box of voxels.
#[derive(Debug, Clone)]
pub struct Shading {
    dims: [usize; 3],
    coefficients: [f64; TERMS],
    /// The field's mean over the dentin read, so that subtracting it keeps the dentin's grey.
    dentin_mean: f64,
    /// The field's least and greatest over the voxels read: where no tissue held it (bone,
    /// the box's corners) it is kept within them, not carried on.
    held: (f64, f64),
    /// The field's 5th and 95th percentile over the tooth's voxels read (enamel and dentin),
    /// against its mean over the dentin.
    pub tooth_range: (f64, f64),
    /// Each tissue's grey once the field is taken off ([`Shading::corrected`]).
    pub greys: Vec<(Label, f64)>,
}

/// A voxel index's place along an axis of `n` voxels, scaled to −1…1 (beyond them outside).
pub fn box_coordinate(c: f64, n: usize) -> f64 {
    if n > 1 {
        2.0 * c / (n - 1) as f64 - 1.0
    } else {
        0.0
    }
}

fn basis([nx, ny, nz]: [usize; 3], [i, j, k]: [f64; 3]) -> [f64; TERMS] {
    let (x, y, z) = (box_coordinate(i, nx), box_coordinate(j, ny), box_coordinate(k, nz));
    let mut terms = [0.0; TERMS];
    let mut t = 0;
    for degree in 1..=DEGREE as i32 {
        for a in (0..=degree).rev() {
            for b in (0..=degree - a).rev() {
                terms[t] = x.powi(a) * y.powi(b) * z.powi(degree - a - b);
                t += 1;
            }
        }
    }
    terms
}

impl Shading {
    /// The field in `scan` read from the tissues of `labels` (the same box); `None` without
    /// dentin and one other tissue enough to read it.
    pub fn fit(scan: &Volume, labels: &LabelVolume) -> Option<Shading> {
        let dims = scan.dims;
        let [nx, ny, nz] = dims;
        if labels.dims != dims || nx < 5 || ny < 5 || nz < 5 {
            return None;
        }
        // Voxels DEEP_MM (and two voxels at least) deep in their tissue along every axis.
        let reach = [0, 1, 2].map(|c| ((DEEP_MM / scan.spacing[c]).ceil() as usize).max(2));
        let strides = [1usize, nx, nx * ny];
        let mut samples: Vec<(usize, usize, f64)> = Vec::new();
        for k in reach[2]..nz.saturating_sub(reach[2]) {
            for j in reach[1]..ny.saturating_sub(reach[1]) {
                for i in reach[0]..nx.saturating_sub(reach[0]) {
                    let n = scan.index(i, j, k);
                    let label = labels.labels[n];
                    let Some(class) = UNIFORM.iter().position(|&l| l as u8 == label) else { continue };
                    let deep = (0..3).all(|c| (1..=reach[c]).all(|d| labels.labels[n - d * strides[c]] == label && labels.labels[n + d * strides[c]] == label));
                    let grey = f64::from(scan.values[n]);
                    if deep && grey.is_finite() {
                        samples.push((n, class, grey));
                    }
                }
            }
        }
        let mut counts = [0usize; UNIFORM.len()];
        samples.iter().for_each(|s| counts[s.1] += 1);
        let classes: Vec<usize> = (0..UNIFORM.len()).filter(|&c| counts[c] >= MIN_VOXELS).collect();
        let dentin = UNIFORM.iter().position(|&l| l == Label::Dentin)?;
        if !classes.contains(&dentin) || classes.len() < 2 {
            return None;
        }
        // Each tissue thinned to about SAMPLES_PER_TISSUE, scattered by a hash of the voxel's
        // index (every k-th in the grid's order would keep a few columns of each row).
        samples.retain(|s| classes.contains(&s.1));
        let all = samples.clone();
        samples.retain(|s| {
            let every = counts[s.1].div_ceil(SAMPLES_PER_TISSUE) as u64;
            ((s.0 as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) % every == 0
        });
        let unknowns = classes.len() + TERMS;
        let column = |class: usize| classes.iter().position(|&c| c == class).expect("kept classes");
        let at = |n: usize| basis(dims, [n % nx, (n / nx) % ny, n / (nx * ny)].map(|c| c as f64));
        let rows: Vec<(usize, [f64; TERMS])> = samples.iter().map(|s| (column(s.1), at(s.0))).collect();
        let mut weights = vec![1.0f64; samples.len()];
        let mut solution = vec![0.0f64; unknowns];
        for _ in 0..4 {
            let mut normal = vec![0.0f64; unknowns * unknowns];
            let mut rhs = vec![0.0f64; unknowns];
            for ((s, (c, terms)), &w) in samples.iter().zip(&rows).zip(&weights) {
                if w == 0.0 {
                    continue;
                }
                // the row: 1 in the tissue's column, then the field's terms
                let t0 = classes.len();
                normal[c * unknowns + c] += w;
                rhs[*c] += w * s.2;
                for a in 0..TERMS {
                    normal[c * unknowns + t0 + a] += w * terms[a];
                    normal[(t0 + a) * unknowns + c] += w * terms[a];
                    rhs[t0 + a] += w * terms[a] * s.2;
                    for b in 0..TERMS {
                        normal[(t0 + a) * unknowns + t0 + b] += w * terms[a] * terms[b];
                    }
                }
            }
            solution = solve(normal, rhs, unknowns)?;
            // Each tissue's spread about the fit (its median absolute residual), then weights.
            let residuals: Vec<f64> = samples.iter().zip(&rows).map(|(s, (c, terms))| s.2 - solution[*c] - dot(&solution[classes.len()..], terms)).collect();
            let spread: Vec<f64> = (0..classes.len())
                .map(|c| {
                    let mut r: Vec<f64> = residuals.iter().zip(&rows).filter(|(_, row)| row.0 == c).map(|(r, _)| r.abs()).collect();
                    if r.is_empty() {
                        return f64::INFINITY;
                    }
                    let mid = r.len() / 2;
                    r.select_nth_unstable_by(mid, f64::total_cmp);
                    (1.4826 * r[mid]).max(1e-6)
                })
                .collect();
            for ((r, row), w) in residuals.iter().zip(&rows).zip(weights.iter_mut()) {
                let u = r / (4.685 * spread[row.0]);
                *w = if u.abs() < 1.0 { (1.0 - u * u).powi(2) } else { 0.0 };
            }
        }
        let coefficients: [f64; TERMS] = solution[classes.len()..].try_into().ok()?;
        let field = |n: usize| dot(&coefficients, &at(n));
        let on = |l: Label| all.iter().filter(move |s| UNIFORM[s.1] == l).map(|s| field(s.0));
        let dentin_mean = on(Label::Dentin).sum::<f64>() / on(Label::Dentin).count() as f64;
        // Over the tooth's middle 90 %: a quadratic swings at the box's corners, where few voxels hold it.
        let mut tooth: Vec<f64> = on(Label::Dentin).chain(on(Label::Enamel)).map(|f| f - dentin_mean).collect();
        tooth.sort_by(f64::total_cmp);
        let tooth_range = (tooth[tooth.len() / 20], tooth[tooth.len() - 1 - tooth.len() / 20]);
        let greys = classes.iter().map(|&c| (UNIFORM[c], solution[column(c)] + dentin_mean)).collect();
        let held = all.iter().map(|s| field(s.0)).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), f| (lo.min(f), hi.max(f)));
        Some(Shading { dims, coefficients, dentin_mean, held, tooth_range, greys })
    }

    /// How far the field runs over the tooth (its 95th percentile less its 5th, grey values).
    pub fn tooth_span(&self) -> f64 {
        self.tooth_range.1 - self.tooth_range.0
    }

    /// `scan` (the box the field was read in) with the field taken off, its dentin's grey kept.
    pub fn corrected(&self, scan: &Volume) -> Volume {
        self.corrected_around(scan, [0; 3])
    }

    /// As [`Self::corrected`] for a box holding the one the field was read in, whose first
    /// voxel lies at `at` in it (beyond it the field is held within its range).
    pub fn corrected_around(&self, scan: &Volume, at: [usize; 3]) -> Volume {
        let mut out = scan.clone();
        let [nx, ny, _] = scan.dims;
        for (n, v) in out.values.iter_mut().enumerate() {
            let place = [n % nx, (n / nx) % ny, n / (nx * ny)];
            let f = dot(&self.coefficients, &basis(self.dims, [0, 1, 2].map(|c| place[c] as f64 - at[c] as f64))).clamp(self.held.0, self.held.1) - self.dentin_mean;
            *v = (f64::from(*v) - f) as f32;
        }
        out
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The normal equations' solution; `None` when they are singular.
fn solve(a: Vec<f64>, b: Vec<f64>, n: usize) -> Option<Vec<f64>> {
    let x = nalgebra::DMatrix::from_row_slice(n, n, &a).lu().solve(&nalgebra::DVector::from_vec(b))?;
    x.iter().all(|v| v.is_finite()).then(|| x.iter().copied().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::{SourceInfo, IDENTITY};
    use rand::{Rng, SeedableRng};

    const N: [usize; 3] = [40, 40, 60];

    /// A block of dentin under an enamel cap with a pulp inside, in air, 0.3 mm voxels: the
    /// labels, and each voxel's grey (dentin 1800, enamel 2900, pulp 40, air −1000) plus
    /// `shading` at its place and noise of σ 35.
    fn scan(shading: &dyn Fn([f64; 3]) -> f64, mislabelled: f64) -> (Volume, LabelVolume) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let [nx, ny, nz] = N;
        let (mut values, mut labels) = (Vec::new(), Vec::new());
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let inside = (6..34).contains(&i) && (6..34).contains(&j) && (4..52).contains(&k);
                    let label = match () {
                        _ if !inside => Label::Air,
                        _ if k >= 44 || i < 10 || i >= 30 => Label::Enamel,
                        _ if (17..23).contains(&i) && (17..23).contains(&j) && (12..38).contains(&k) => Label::Pulp,
                        _ => Label::Dentin,
                    };
                    let mut grey = match label {
                        Label::Air => -1000.0,
                        Label::Enamel => 2900.0,
                        Label::Pulp => 40.0,
                        _ => 1800.0,
                    };
                    // a share of the dentin in one corner reads as enamel's grey (a lesion, labels gone wrong)
                    if label == Label::Dentin && i < 17 && k < 24 && rng.random::<f64>() < mislabelled {
                        grey = 2900.0;
                    }
                    let at = [i, j, k].map(|c| c as f64 * 0.3);
                    values.push((grey + shading(at) + 35.0 * (rng.random::<f64>() + rng.random::<f64>() + rng.random::<f64>() - 1.5) * 2.0) as f32);
                    labels.push(label as u8);
                }
            }
        }
        let volume = Volume { dims: N, spacing: [0.3; 3], origin: [0.0; 3], direction: IDENTITY, values, source: SourceInfo::default() };
        let labels = LabelVolume { labels, ..volume.label_volume() };
        (volume, labels)
    }

    /// Each tissue's grey spread (standard deviation) in `scan`.
    fn spread(scan: &Volume, labels: &LabelVolume, label: Label) -> f64 {
        let greys: Vec<f64> = scan.values.iter().zip(&labels.labels).filter(|(_, &l)| l == label as u8).map(|(&v, _)| f64::from(v)).collect();
        let mean = greys.iter().sum::<f64>() / greys.len() as f64;
        (greys.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / greys.len() as f64).sqrt()
    }

    #[test]
    fn a_cupping_and_a_ramp_are_read_from_the_tissues_and_taken_off() {
        // 300 from the box's axis to its corner and 200 along it.
        let shading = |[x, y, z]: [f64; 3]| 300.0 * (((x - 6.0).powi(2) + (y - 6.0).powi(2)) / 72.0) + 200.0 * z / 18.0;
        let (scan, labels) = scan(&shading, 0.0);
        let field = Shading::fit(&scan, &labels).expect("dentin and air enough");
        let place = |n: usize| [n % N[0], (n / N[0]) % N[1], n / (N[0] * N[1])].map(|c| c as f64 * 0.3);
        let mut over_tooth: Vec<f64> = (0..scan.len()).filter(|&n| matches!(Label::from_u8(labels.labels[n]), Some(Label::Dentin | Label::Enamel))).map(|n| shading(place(n))).collect();
        over_tooth.sort_by(f64::total_cmp);
        let truth = over_tooth[over_tooth.len() * 19 / 20] - over_tooth[over_tooth.len() / 20];
        // ours over the voxels two deep, the truth's over all: a little narrower
        assert!((0.8 * truth..=1.02 * truth).contains(&field.tooth_span()), "span {:.1}, truth {truth:.1}", field.tooth_span());
        let corrected = field.corrected(&scan);
        for label in [Label::Dentin, Label::Enamel, Label::Air] {
            let (before, after) = (spread(&scan, &labels, label), spread(&corrected, &labels, label));
            // noise alone: σ 35 (the sum of three uniforms, scaled)
            assert!(after < 38.0 && before > 50.0, "{label:?}: spread {before:.1} -> {after:.1}");
        }
        // The dentin's grey is kept, the others are read against it.
        for (label, truth) in [(Label::Dentin, 1800.0), (Label::Enamel, 2900.0), (Label::Air, -1000.0)] {
            let mean_shift: f64 = labels.labels.iter().enumerate().filter(|(_, &l)| l == Label::Dentin as u8).map(|(n, _)| shading(place(n))).sum::<f64>() / labels.count(Label::Dentin) as f64;
            let grey = field.greys.iter().find(|(l, _)| *l == label).expect("read").1;
            assert!((grey - truth - mean_shift).abs() < 20.0, "{label:?} read {grey:.1}, truth {truth} + {mean_shift:.1}");
        }
    }

    #[test]
    fn a_smooth_shading_not_of_the_fits_form_is_mostly_taken_off() {
        // A Gaussian bump off the box's middle, 400 at its peak: no quadratic, but smooth.
        let shading = |[x, y, z]: [f64; 3]| 400.0 * (-((x - 9.0).powi(2) + (y - 4.0).powi(2) + (z - 12.0).powi(2)) / (2.0 * 6.0f64.powi(2))).exp();
        let (scan, labels) = scan(&shading, 0.0);
        let corrected = Shading::fit(&scan, &labels).expect("read").corrected(&scan);
        let noise = 35.0f64;
        for label in [Label::Dentin, Label::Enamel] {
            let excess = |v: &Volume| (spread(v, &labels, label).powi(2) - noise * noise).max(0.0).sqrt();
            let (before, after) = (excess(&scan), excess(&corrected));
            assert!(after < 0.35 * before, "{label:?}: shading's spread {before:.1} -> {after:.1}");
        }
    }

    #[test]
    fn where_no_tissue_holds_the_field_it_is_not_carried_on() {
        // The Gaussian bump, and the box's top 12 slices bone (which the fit does not read), as a
        // jaw's bone fills a tooth box's far side: the quadratic fitted under the bump swings on
        // there. What is taken off the bone stays within what was taken off the tissues read.
        let shading = |[x, y, z]: [f64; 3]| 400.0 * (-((x - 9.0).powi(2) + (y - 4.0).powi(2) + (z - 12.0).powi(2)) / (2.0 * 6.0f64.powi(2))).exp();
        let (mut scan, mut labels) = scan(&shading, 0.0);
        let bone_from = N[0] * N[1] * (N[2] - 12);
        for n in bone_from..scan.len() {
            let at = [n % N[0], (n / N[0]) % N[1], n / (N[0] * N[1])].map(|c| c as f64 * 0.3);
            scan.values[n] = (1100.0 + shading(at)) as f32;
            labels.labels[n] = Label::BoneCortical as u8;
        }
        let field = Shading::fit(&scan, &labels).expect("read");
        let corrected = field.corrected(&scan);
        let taken = |n: usize| f64::from(scan.values[n]) - f64::from(corrected.values[n]);
        let read = (0..bone_from).filter(|&n| labels.labels[n] != Label::BoneCortical as u8).map(taken);
        let (lo, hi) = read.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| (lo.min(t), hi.max(t)));
        let unheld = |n: usize| dot(&field.coefficients, &basis(N, [n % N[0], (n / N[0]) % N[1], n / (N[0] * N[1])].map(|c| c as f64))) - field.dentin_mean;
        assert!((bone_from..scan.len()).any(|n| !(lo - 0.01..=hi + 0.01).contains(&unheld(n))), "the fit does not swing past the tissues here: no test");
        for n in bone_from..scan.len() {
            assert!((lo - 0.01..=hi + 0.01).contains(&taken(n)), "{:.1} taken off the bone, {lo:.1}…{hi:.1} off the tissues", taken(n));
        }
        // the bone's grey against the dentin's, as made without the shading: 700
        let dentin = field.greys.iter().find(|(l, _)| *l == Label::Dentin).expect("read").1;
        let off = |g: f64| (dentin - g - 700.0).abs();
        let worst = (bone_from..scan.len()).map(|n| off(f64::from(corrected.values[n]))).fold(0.0, f64::max);
        let carried = (bone_from..scan.len()).map(|n| off(f64::from(scan.values[n]) - unheld(n))).fold(0.0, f64::max);
        assert!(worst < carried, "the bone up to {worst:.0} off its grey, the field carried on {carried:.0}");
    }

    #[test]
    fn a_field_read_in_a_box_is_taken_off_a_box_around_it_alike() {
        // Read in the inner box (4 voxels in from every face), taken off the whole: the inner
        // box's voxels as taken off the inner box alone, the rest held within the field's range.
        let shading = |[x, y, z]: [f64; 3]| 300.0 * (((x - 6.0).powi(2) + (y - 6.0).powi(2)) / 72.0) + 200.0 * z / 18.0;
        let (scan, labels) = scan(&shading, 0.0);
        let inner = crate::IndexBox { min: [4; 3], max: [0, 1, 2].map(|c| N[c] - 4) };
        let (part, part_labels) = (crate::crop(&scan, &inner).unwrap(), crate::crop_labels(&labels, &inner).unwrap());
        let field = Shading::fit(&part, &part_labels).expect("read");
        let (alone, around) = (field.corrected(&part), field.corrected_around(&scan, inner.min));
        for (n, &v) in alone.values.iter().enumerate() {
            let [i, j, k] = [n % part.dims[0], (n / part.dims[0]) % part.dims[1], n / (part.dims[0] * part.dims[1])];
            assert_eq!(v, around.values[scan.index(i + 4, j + 4, k + 4)], "voxel {i} {j} {k} of the inner box");
        }
        let taken = (0..scan.len()).map(|n| f64::from(scan.values[n] - around.values[n]));
        let (lo, hi) = taken.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| (lo.min(t), hi.max(t)));
        assert!(lo >= field.held.0 - field.dentin_mean - 0.1 && hi <= field.held.1 - field.dentin_mean + 0.1, "{lo:.1}…{hi:.1} taken off");
        // and the whole box's dentin is flat again, its far corners too
        let corrected_spread = spread(&around, &labels, Label::Dentin);
        assert!(corrected_spread < 45.0, "dentin spread {corrected_spread:.1} over the whole box");
    }

    #[test]
    fn a_scan_without_shading_reads_none_and_stray_greys_do_not_make_one() {
        let (scan, labels) = scan(&|_| 0.0, 0.3);
        let field = Shading::fit(&scan, &labels).expect("read");
        // 30 % of a corner's dentin at the enamel's grey: the biweight leaves them out.
        assert!(field.tooth_span() < 10.0, "span {:.1} without shading", field.tooth_span());
    }

    #[test]
    fn without_dentin_enough_there_is_no_field() {
        let (scan, mut labels) = scan(&|_| 0.0, 0.0);
        labels.labels.iter_mut().filter(|l| **l == Label::Dentin as u8).for_each(|l| *l = Label::BoneCortical as u8);
        assert!(Shading::fit(&scan, &labels).is_none());
    }
}
