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
//! good share of the pulp's contrast, and darker than its neighbours on both sides across at
//! least two axes (a tube's cross-section; a wall's blurred edge curves across one direction
//! only, and a voxel on it lies beside darker pulp). Such voxels, reached from the labelled pulp
//! through one another (26-connected: a canal a voxel wide runs diagonally through the grid),
//! become pulp. Only voxels whose six neighbours are all dentin or pulp are taken: the root's
//! outer surface, darkened by what lies outside, is no canal.
//! Cost: one distance transform (the pulp's grey) and one linear pass over the cropped tooth.

use crate::calibrate::Calibration;
use crate::partial_volume::tissue_grey;
use crate::volume::{LabelVolume, Volume};
use crate::Label;
use rayon::prelude::*;

/// A canal voxel is darker than the dentin by at least this share of the dentin–pulp contrast.
const MIN_DARKNESS: f64 = 0.3;
/// ... and darker than the mean of its two neighbours along an axis (next ones, or two voxels
/// out) by at least this share, across at least two axes.
const MIN_VALLEY: f64 = 0.12;

/// Relabels dentin voxels on thin root canals (see the module comment) as pulp; returns how
/// many. Does nothing without labelled pulp or when the pulp is not darker than the dentin.
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
    let enclosed = enclosed_by_tooth(vol.dims, l, &hard);
    let tooth = |n: usize| l[n] == d || l[n] == p || enclosed[n];
    let candidate: Vec<bool> = (0..g.len())
        .into_par_iter()
        .map(|n| {
            let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
            if !(l[n] == d || enclosed[n]) || i == 0 || j == 0 || k == 0 || i + 1 >= nx || j + 1 >= ny || k + 1 >= nz {
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
    let neighbours = |n: usize| {
        let (i, j, k) = ((n % nx) as i64, ((n / nx) % ny) as i64, (n / (nx * ny)) as i64);
        (0..27).filter(|&c| c != 13).filter_map(move |c| {
            let (x, y, z) = (i + c % 3 - 1, j + (c / 3) % 3 - 1, k + c / 9 - 1);
            (x >= 0 && y >= 0 && z >= 0 && x < nx as i64 && y < ny as i64 && z < nz as i64).then(|| x as usize + nx * (y as usize + ny * z as usize))
        })
    };
    let mut queue: Vec<usize> = (0..g.len()).filter(|&n| candidate[n] && neighbours(n).any(|m| l[m] == p)).collect();
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
    let mut count = 0;
    for (lab, t) in labels.labels.iter_mut().zip(&taken) {
        if *t {
            *lab = p;
            count += 1;
        }
    }
    count
}

/// Voxels that are not `hard` and that no path of such voxels (6-connected) joins to the box's
/// faces.
fn enclosed_by_tooth(dims: [usize; 3], labels: &[u8], hard: &dyn Fn(u8) -> bool) -> Vec<bool> {
    let [nx, ny, nz] = dims;
    let mut reached = vec![false; labels.len()];
    let mut queue: Vec<usize> = Vec::new();
    for n in 0..labels.len() {
        let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
        let face = i == 0 || j == 0 || k == 0 || i + 1 == nx || j + 1 == ny || k + 1 == nz;
        if face && !hard(labels[n]) {
            reached[n] = true;
            queue.push(n);
        }
    }
    while let Some(n) = queue.pop() {
        let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
        let steps = [(i > 0, n.wrapping_sub(1)), (i + 1 < nx, n + 1), (j > 0, n.wrapping_sub(nx)), (j + 1 < ny, n + nx), (k > 0, n.wrapping_sub(nx * ny)), (k + 1 < nz, n + nx * ny)];
        for (ok, m) in steps {
            if ok && !reached[m] && !hard(labels[m]) {
                reached[m] = true;
                queue.push(m);
            }
        }
    }
    labels.iter().zip(&reached).map(|(&c, &r)| !hard(c) && !r).collect()
}
