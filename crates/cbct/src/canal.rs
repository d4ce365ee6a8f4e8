//! Root canals thinner than the segmentation's threshold can see.
//!
//! Segmentation labels pulp where a voxel is darker than the midpoint between the pulp's and the
//! dentin's grey. A canal 1–2 voxels wide (0.3–0.4 mm scans, toward the apex) never gets that
//! dark: the voxels' averaging and the scanner's blur mix its grey with the dentin's around it,
//! so it stays dentin and the pulp ends at the canal's entrance (the family's 0.4 mm molar in
//! the jaw: −30 % pulp; the partial-volume fit sums grey only around labelled pulp, so it cannot
//! bring the canal back).
//!
//! A thin canal still shows as a dark valley in the dentin: a voxel darker than the dentin by a
//! good share of the pulp's contrast, darker than its neighbours on both sides across at least
//! two axes (a tube's cross-section), and not on a slope from darker pulp to brighter dentin
//! (the blurred wall of a wider pulp chamber is darker than the dentin and, where the wall
//! curves, darker than its neighbours along it too; but it lies on that slope). Such voxels,
//! reached from the labelled pulp through one another (26-connected: a canal a voxel wide runs
//! diagonally through the grid), become pulp. Only voxels whose six neighbours are all the
//! tooth's are taken: the root's outer surface, darkened by what lies outside, is no canal.
//! Canal voxels whose grey fell in an outside tissue's range (bone) and that the outside cannot
//! reach count as the tooth's; the outside does not reach through a gap a voxel wide in the
//! tooth (a thin wall by the apex, one of its voxels read as bone).
//! Cost: one distance transform (the pulp's grey) and one linear pass over the cropped tooth.

use crate::calibrate::Calibration;
use crate::partial_volume::tissue_grey;
use crate::volume::{LabelVolume, Volume};
use crate::Label;
use rayon::prelude::*;

/// A canal voxel is darker than the dentin by at least this share of the dentin–pulp contrast.
const MIN_DARKNESS: f64 = 0.3;
/// ... and is not on a slope from pulp to dentin: a pulp neighbour darker than it by this share
/// and the opposite neighbour brighter by as much.
const MAX_DARKER_NEIGHBOUR: f64 = 0.15;
/// ... and is darker than the mean of its two neighbours along an axis (next ones, or two voxels
/// out) by at least this share, across at least two axes.
const MIN_VALLEY: f64 = 0.12;

/// Relabels dentin voxels on thin root canals (see the module comment) as pulp, and voxels the
/// tooth encloses as pulp or dentin by the midpoint of their grey values; returns how many
/// became pulp. Does nothing without labelled pulp or when the pulp is not darker than the
/// dentin.
pub fn trace_thin_canals(vol: &Volume, labels: &mut LabelVolume, cal: &Calibration) -> usize {
    let (p, d) = (Label::Pulp as u8, Label::Dentin as u8);
    if labels.labels.len() != vol.values.len() || !labels.labels.contains(&p) {
        return 0;
    }
    let dentin = cal.peak(Label::Dentin);
    let (pulp, _) = tissue_grey(vol, labels, Label::Pulp, Label::Dentin, cal);
    let contrast = dentin - pulp;
    if contrast <= 0.01 * dentin.abs().max(1.0) {
        return 0;
    }
    let [nx, ny, nz] = vol.dims;
    let strides = [1, nx, nx * ny];
    let (g, l) = (&vol.values, &labels.labels);
    // Canal voxels whose grey fell in an outside tissue's range (bone, soft tissue) were given
    // its label by segmentation: inside the tooth, where the outside cannot reach, they count
    // as the tooth's.
    let hard = |c: u8| [d, p, Label::Enamel as u8, Label::Caries as u8, Label::Metal as u8].contains(&c);
    let (enclosed, behind_gap) = enclosed_by_dentin(vol.dims, l, &hard);
    // Behind a gap a voxel wide in the tooth, a canal voxel is one too, reached from the pulp.
    let within = |n: usize| enclosed[n] || behind_gap[n];
    let tooth = |n: usize| l[n] == d || l[n] == p || within(n);
    let candidate: Vec<bool> = (0..g.len())
        .into_par_iter()
        .map(|n| {
            let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
            if !(l[n] == d || within(n)) || i == 0 || j == 0 || k == 0 || i + 1 >= nx || j + 1 >= ny || k + 1 >= nz {
                return false;
            }
            let v = f64::from(g[n]);
            if (dentin - v) < MIN_DARKNESS * contrast {
                return false;
            }
            let mut valleys = 0;
            for s in strides {
                let (a, b) = (n - s, n + s);
                if !tooth(a) || !tooth(b) {
                    return false;
                }
                // On a slope from darker pulp down to brighter dentin: the blurred wall of a
                // wider pulp. (Between two stretches of a canal, the voxel beyond is dark too.)
                let slope = MAX_DARKER_NEIGHBOUR * contrast;
                let (ga, gb) = (f64::from(g[a]), f64::from(g[b]));
                if (l[a] == p && v - ga >= slope && gb - v >= slope) || (l[b] == p && v - gb >= slope && ga - v >= slope) {
                    return false;
                }
                // The valley at two scales: a canal a voxel wide stands out from its next
                // neighbours, one 2–3 voxels wide only from the dentin two voxels out.
                let mut depth = 0.5 * (f64::from(g[a]) + f64::from(g[b])) - v;
                if let (Some(a2), Some(b2)) = (n.checked_sub(2 * s), Some(n + 2 * s).filter(|&b2| b2 < g.len())) {
                    if tooth(a2) && tooth(b2) {
                        depth = depth.max(0.5 * (f64::from(g[a2]) + f64::from(g[b2])) - v);
                    }
                }
                if depth >= MIN_VALLEY * contrast {
                    valleys += 1;
                }
            }
            valleys >= 2
        })
        .collect();
    // Grown from the pulp through the candidates.
    let neighbours = |n: usize| around(n, vol.dims);
    // Seeds within two voxels of the pulp: where a canal leaves the chamber, its first voxel
    // lies on the chamber's slope.
    let near_pulp = |n: usize| neighbours(n).any(|m| l[m] == p || neighbours(m).any(|q| l[q] == p));
    let mut queue: Vec<usize> = (0..g.len()).filter(|&n| candidate[n] && near_pulp(n)).collect();
    let mut taken = vec![false; g.len()];
    for &n in &queue {
        taken[n] = true;
    }
    while let Some(n) = queue.pop() {
        for m in neighbours(n) {
            if candidate[m] && !taken[m] {
                taken[m] = true;
                queue.push(m);
            }
        }
    }
    // The rest of what the tooth encloses is its, as segmentation's threshold reads it: the
    // pulp's where darker than midway to the dentin (the closing that walls canals in had kept
    // these from its cavities), else the dentin's. Left as bone, they were holes in the tooth.
    let mid = 0.5 * (pulp + dentin);
    let mut count = 0;
    for n in 0..g.len() {
        let to = if taken[n] || (enclosed[n] && f64::from(g[n]) < mid) {
            p
        } else if enclosed[n] {
            d
        } else {
            continue;
        };
        labels.labels[n] = to;
        count += usize::from(to == p);
    }
    count
}

/// Voxels that are not `hard`, that no path of such voxels (6-connected) joins to the box's
/// faces, and whose pocket (6-connected) touches the pulp or no enamel: holes in the dentin and
/// the pulp's. A pocket beside the enamel and not the pulp is the crown's surface walled in at the
/// scan's resolution, the bottom of a fissure narrower than the blur (the 3-root molar in air:
/// 26 voxels of air between its cusps taken as pulp, its pulp's surface 0.085 mm off the true
/// one on average); one beside both is a pulp horn under thin dentin (the 0.4 mm jaw molar).
/// Second, the voxels the outside reaches only through a gap a voxel wide in the tooth (the
/// outside's reach: its voxels with no hard face neighbour joined to the box's faces, and a voxel
/// beyond): a canal's wall 1.7 voxels thick by a coarse incisor's apex read one voxel as cortical
/// bone, and the outside's flood ran up the canal, 8.8 mm of it lost.
fn enclosed_by_dentin(dims: [usize; 3], labels: &[u8], hard: &dyn Fn(u8) -> bool) -> (Vec<bool>, Vec<bool>) {
    let open: Vec<bool> = labels.iter().map(|&c| !hard(c)).collect();
    let reached = crate::mask::flood_from_border(dims, &open);
    let enclosed: Vec<bool> = open.iter().zip(&reached).map(|(&o, &r)| o && !r).collect();
    let (id, sizes) = crate::mask::components(dims, &enclosed);
    // Per pocket: whether it touches the enamel, and the pulp.
    let mut touches = vec![[false; 2]; sizes.len()];
    for n in (0..labels.len()).filter(|&n| enclosed[n]) {
        for m in crate::volume::face_neighbours(n, dims).into_iter().flatten() {
            touches[id[n] as usize][0] |= labels[m] == Label::Enamel as u8;
            touches[id[n] as usize][1] |= labels[m] == Label::Pulp as u8;
        }
    }
    let wide = crate::mask::neighbour_map(dims, &open, true, |o, n| o && n.iter().all(|&m| m));
    let wide_reach = crate::mask::flood_from_border(dims, &wide);
    let outside = crate::mask::neighbour_map(dims, &wide_reach, false, |r, n| r || n.iter().any(|&m| m));
    let behind_gap = (0..labels.len()).map(|n| open[n] && reached[n] && !outside[n]).collect();
    ((0..labels.len()).map(|n| enclosed[n] && touches[id[n] as usize] != [true, false]).collect(), behind_gap)
}

/// The 26 voxels about `n`.
fn around(n: usize, [nx, ny, nz]: [usize; 3]) -> impl Iterator<Item = usize> {
    let (i, j, k) = ((n % nx) as i64, ((n / nx) % ny) as i64, (n / (nx * ny)) as i64);
    (0..27).filter(|&c| c != 13).filter_map(move |c| {
        let (x, y, z) = (i + c % 3 - 1, j + (c / 3) % 3 - 1, k + c / 9 - 1);
        (x >= 0 && y >= 0 && z >= 0 && x < nx as i64 && y < ny as i64 && z < nz as i64).then(|| x as usize + nx * (y as usize + ny * z as usize))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dentin with a pulp chamber (a ball) and, when `canal`, a canal 0.4 mm wide running 6 mm
    /// down from it, voxel-averaged (4³ samples) and blurred as a 0.3 mm scan, labelled by the
    /// midpoint threshold; enamel-free, dentin to the box's faces. Returns the volume, labels,
    /// calibration and whether each voxel centre lies within a voxel of the canal's axis.
    fn block(canal: bool) -> (Volume, LabelVolume, Calibration, Vec<bool>) {
        let (h, dims) = (0.3, [24, 24, 40]);
        let (chamber, r_chamber, r_canal) = ([3.5, 3.5, 9.0], 1.5, 0.2);
        let inside = |p: [f64; 3]| {
            let ball = (0..3).map(|c| (p[c] - chamber[c]).powi(2)).sum::<f64>() < r_chamber * r_chamber;
            let tube = canal && p[2] <= chamber[2] && p[2] >= chamber[2] - 7.5 && (p[0] - chamber[0]).powi(2) + (p[1] - chamber[1]).powi(2) < r_canal * r_canal;
            ball || tube
        };
        let near_axis = (0..dims[0] * dims[1] * dims[2])
            .map(|n| {
                let p = [n % dims[0], (n / dims[0]) % dims[1], n / (dims[0] * dims[1])].map(|q| q as f64 * h);
                canal && p[2] <= chamber[2] && ((p[0] - chamber[0]).powi(2) + (p[1] - chamber[1]).powi(2)).sqrt() <= 1.01 * h
            })
            .collect();
        let (vol, labels, cal, _) = crate::test_scans::pulp_in_dentin(h, dims, 0.5, inside);
        (vol, labels, cal, near_axis)
    }

    #[test]
    fn a_canal_below_the_threshold_is_traced_from_the_chamber() {
        let (vol, mut labels, cal, near_axis) = block(true);
        let [nx, ny, _] = vol.dims;
        let slices_with_pulp = |labels: &LabelVolume| (0..=24).filter(|k| (0..nx * ny).any(|m| labels.labels[m + nx * ny * (30 - k)] == Label::Pulp as u8)).count();
        let before = slices_with_pulp(&labels);
        // Part of the canal's grey falls in an outside tissue's range: segmentation labels it so.
        let slice = nx * ny * 15..nx * ny * 16;
        let bone: Vec<usize> = slice.min_by(|&a, &b| vol.values[a].total_cmp(&vol.values[b])).into_iter().collect();
        for &n in &bone {
            labels.labels[n] = Label::BoneCancellous as u8;
        }
        let added = trace_thin_canals(&vol, &mut labels, &cal);
        let after = slices_with_pulp(&labels);
        // The canal runs 25 slices below the chamber's centre (7.5 mm), the chamber 5 of them.
        assert!(before <= 8, "the threshold sees the canal's top only: {before} slices");
        assert!(after >= 24, "traced: {after} of 25 slices hold pulp ({added} voxels)");
        let off_axis = (0..labels.labels.len()).filter(|&n| labels.labels[n] == Label::Pulp as u8 && n / (nx * ny) < 25 && !near_axis[n]).count();
        assert_eq!(off_axis, 0, "pulp taken away from the canal");
        assert!(bone.iter().all(|&n| labels.labels[n] == Label::Pulp as u8), "an enclosed canal voxel with bone's label is the canal");
    }

    /// The canal's lower part labelled bone, and a gap a voxel wide through its wall to bone
    /// outside the tooth: the outside's flood ran up the canal through it, and the canal stopped
    /// where the bone's labels began. The outside's reach now stops a voxel into such a gap.
    #[test]
    fn a_canal_behind_a_gap_in_its_wall_is_still_traced() {
        let (vol, mut labels, cal, near_axis) = block(true);
        let [nx, ny, _] = vol.dims;
        let at = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
        let bone = Label::BoneCancellous as u8;
        // Bone beyond x = 3 voxels, as a root's socket.
        for n in (0..labels.labels.len()).filter(|&n| n % nx < 3) {
            labels.labels[n] = bone;
        }
        // The canal's darkest voxel per slice 8–17 read as bone, and a gap from slice 12's to the bone.
        let darkest: Vec<usize> = (8..18).map(|k| (at(0, 0, k)..at(0, 0, k + 1)).filter(|&n| near_axis[n]).min_by(|&a, &b| vol.values[a].total_cmp(&vol.values[b])).unwrap()).collect();
        for &n in &darkest {
            labels.labels[n] = bone;
        }
        let gap = darkest[4];
        let (gi, gj, gk) = (gap % nx, (gap / nx) % ny, gap / (nx * ny));
        for i in 3..gi {
            labels.labels[at(i, gj, gk)] = Label::BoneCortical as u8;
        }
        trace_thin_canals(&vol, &mut labels, &cal);
        assert!(darkest.iter().all(|&n| labels.labels[n] == Label::Pulp as u8), "the canal behind the gap: {:?}", darkest.iter().map(|&n| labels.labels[n]).collect::<Vec<_>>());
        assert!((0..labels.labels.len()).filter(|&n| n % nx < 3).all(|n| labels.labels[n] == bone), "the bone outside stays bone");
        assert_eq!(labels.labels[at(3, gj, gk)], Label::BoneCortical as u8, "the gap's mouth stays the outside's");
    }

    #[test]
    fn a_chamber_alone_gains_nothing() {
        let (vol, mut labels, cal, _) = block(false);
        let pulp = labels.count(Label::Pulp);
        assert!(pulp > 0);
        // A voxel of dentin's grey labelled bone, walled in by the tooth: a hole in it.
        let hole = 5 + 24 * (5 + 24 * 5);
        labels.labels[hole] = Label::BoneCancellous as u8;
        assert_eq!(trace_thin_canals(&vol, &mut labels, &cal), 0, "the chamber's blurred wall is no canal");
        assert_eq!(labels.count(Label::Pulp), pulp);
        assert_eq!(labels.labels[hole], Label::Dentin as u8, "what the tooth encloses is the tooth's");
    }

    #[test]
    fn a_fissure_walled_in_by_enamel_stays_outside_and_a_pocket_by_the_pulp_is_pulp() {
        let (mut vol, mut labels, cal, _) = block(false);
        let [nx, ny, _] = vol.dims;
        let at = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
        // Enamel over slices 30–34; in it, an air pocket (a fissure's bottom the blur closed)
        // and a bone-grey pocket next to the chamber's pulp.
        for k in 30..35 {
            for n in at(0, 0, k)..at(0, 0, k + 1) {
                labels.labels[n] = Label::Enamel as u8;
            }
        }
        let fissure = [at(10, 10, 32), at(11, 10, 32)];
        for &n in &fissure {
            labels.labels[n] = Label::Air as u8;
            vol.values[n] = 200.0;
        }
        let pulp = (0..labels.labels.len()).find(|&n| labels.labels[n] == Label::Pulp as u8).unwrap();
        let beside = pulp - 1;
        assert_eq!(labels.labels[beside], Label::Dentin as u8);
        labels.labels[beside] = Label::BoneCancellous as u8;
        vol.values[beside] = 1000.0;
        trace_thin_canals(&vol, &mut labels, &cal);
        assert!(fissure.iter().all(|&n| labels.labels[n] == Label::Air as u8), "the fissure is the outside's");
        assert_eq!(labels.labels[beside], Label::Pulp as u8, "a dark pocket by the pulp is the pulp's");
    }
}
