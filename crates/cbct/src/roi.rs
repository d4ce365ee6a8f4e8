//! Regions of interest: crop a volume to an index box, find a tooth's box from labels, or keep
//! the slab between two planes (seed 001's model reduction). Geometry stays in the patient frame.

use crate::error::{Error, Result};
use crate::volume::{center_of, LabelVolume, Volume};
use crate::{dot, normalize, Label};

/// Valid ISO 3950 tooth number (permanent 11–48, primary 51–85).
pub fn valid_fdi(fdi: u8) -> bool {
    let (q, t) = (fdi / 10, fdi % 10);
    ((1..=4).contains(&q) && (1..=8).contains(&t)) || ((5..=8).contains(&q) && (1..=5).contains(&t))
}

/// Voxel index box, `min` inclusive, `max` exclusive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct IndexBox {
    pub min: [usize; 3],
    pub max: [usize; 3],
}

impl IndexBox {
    pub fn dims(&self) -> [usize; 3] {
        [self.max[0] - self.min[0], self.max[1] - self.min[1], self.max[2] - self.min[2]]
    }

    /// The box grown by `margin_mm` (whole voxels of `spacing`, at least the margin) on every
    /// side, kept within a grid of `dims`.
    pub fn grown(&self, margin_mm: f64, spacing: [f64; 3], dims: [usize; 3]) -> IndexBox {
        let reach = [0, 1, 2].map(|c| (margin_mm.max(0.0) / spacing[c]).ceil() as usize);
        IndexBox { min: [0, 1, 2].map(|c| self.min[c].saturating_sub(reach[c])), max: [0, 1, 2].map(|c| (self.max[c] + reach[c]).min(dims[c])) }
    }
    fn check(&self, dims: [usize; 3]) -> Result<()> {
        if (0..3).any(|c| self.min[c] >= self.max[c] || self.max[c] > dims[c]) {
            return Err(Error::invalid("box", format!("{self:?} is empty or outside dims {dims:?}")));
        }
        Ok(())
    }
}

/// A plane through `point` whose `normal` points into the kept side (LPS mm).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plane {
    pub point: [f64; 3],
    pub normal: [f64; 3],
}

fn crop_vec<T: Copy>(v: &[T], dims: [usize; 3], b: &IndexBox) -> Vec<T> {
    let d = b.dims();
    let mut out = Vec::with_capacity(d[0] * d[1] * d[2]);
    for k in b.min[2]..b.max[2] {
        for j in b.min[1]..b.max[1] {
            let s = b.min[0] + dims[0] * (j + dims[1] * k);
            out.extend_from_slice(&v[s..s + d[0]]);
        }
    }
    out
}

/// `v` (of `dims`) with `low` and `high` samples of `fill` laid beyond each side, and its dims.
fn pad_vec<T: Copy>(v: &[T], dims: [usize; 3], low: [usize; 3], high: [usize; 3], fill: T) -> (Vec<T>, [usize; 3]) {
    let padded: [usize; 3] = std::array::from_fn(|c| dims[c] + low[c] + high[c]);
    let mut out = vec![fill; padded.iter().product()];
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            let (from, to) = (dims[0] * (j + dims[1] * k), low[0] + padded[0] * ((j + low[1]) + padded[1] * (k + low[2])));
            out[to..to + dims[0]].copy_from_slice(&v[from..from + dims[0]]);
        }
    }
    (out, padded)
}

/// The volume grown by `low` and `high` voxels of grey `fill` beyond each side (index axes);
/// its origin moves so that every voxel keeps its place in the patient frame.
pub fn pad(vol: &Volume, low: [usize; 3], high: [usize; 3], fill: f32) -> Volume {
    let (values, dims) = pad_vec(&vol.values, vol.dims, low, high, fill);
    let origin = center_of(vol.spacing, vol.origin, vol.direction, low.map(|l| -(l as f64)));
    Volume { dims, origin, values, spacing: vol.spacing, direction: vol.direction, source: vol.source.clone() }
}

/// [`pad`] for labels, the new voxels labelled `fill`.
pub fn pad_labels(lv: &LabelVolume, low: [usize; 3], high: [usize; 3], fill: Label) -> LabelVolume {
    let (labels, dims) = pad_vec(&lv.labels, lv.dims, low, high, fill as u8);
    let origin = center_of(lv.spacing, lv.origin, lv.direction, low.map(|l| -(l as f64)));
    LabelVolume { dims, origin, labels, spacing: lv.spacing, direction: lv.direction }
}

/// The sub-volume inside the box; its origin moves to the box's first voxel.
pub fn crop(vol: &Volume, b: &IndexBox) -> Result<Volume> {
    b.check(vol.dims)?;
    Ok(Volume {
        dims: b.dims(),
        spacing: vol.spacing,
        origin: vol.voxel_center(b.min[0], b.min[1], b.min[2]),
        direction: vol.direction,
        values: crop_vec(&vol.values, vol.dims, b),
        source: vol.source.clone(),
    })
}

pub fn crop_labels(lv: &LabelVolume, b: &IndexBox) -> Result<LabelVolume> {
    b.check(lv.dims)?;
    Ok(LabelVolume {
        dims: b.dims(),
        spacing: lv.spacing,
        origin: lv.voxel_center(b.min[0], b.min[1], b.min[2]),
        direction: lv.direction,
        labels: crop_vec(&lv.labels, lv.dims, b),
    })
}

/// Box around the tooth tissues (enamel, dentin, pulp, caries) of a one-tooth segmentation,
/// grown by `margin_mm`. With `point`, only tooth voxels within the point's box `(min, max)` count
/// (pass the same point twice for no restriction beyond the margin search). `fdi` is checked as an
/// ISO 3950 number; the labels themselves carry one tooth.
pub fn tooth_box(lv: &LabelVolume, fdi: u8, point_or_box: Option<([f64; 3], [f64; 3])>, margin_mm: f64) -> Result<IndexBox> {
    if !valid_fdi(fdi) {
        return Err(Error::invalid("fdi", format!("{fdi} is not an ISO 3950 tooth number")));
    }
    let tooth = [Label::Enamel as u8, Label::Dentin as u8, Label::Pulp as u8, Label::Caries as u8];
    let limit = match point_or_box {
        Some((a, b)) => {
            let ia = lv.world_to_index(a).ok_or_else(|| Error::invalid("box", "degenerate geometry"))?;
            let ib = lv.world_to_index(b).ok_or_else(|| Error::invalid("box", "degenerate geometry"))?;
            // a point (a == b) gets a generous 15 mm reach, a molar's size
            let reach: Vec<f64> = (0..3).map(|c| if a == b { 15.0 / lv.spacing[c] } else { 0.5 }).collect();
            Some(((0..3).map(|c| ia[c].min(ib[c]) - reach[c]).collect::<Vec<_>>(), (0..3).map(|c| ia[c].max(ib[c]) + reach[c]).collect::<Vec<_>>()))
        }
        None => None,
    };
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    let [nx, ny, _] = lv.dims;
    for (n, l) in lv.labels.iter().enumerate() {
        if !tooth.contains(l) {
            continue;
        }
        let p = [n % nx, (n / nx) % ny, n / (nx * ny)];
        if let Some((a, b)) = &limit {
            if (0..3).any(|c| (p[c] as f64) < a[c] || (p[c] as f64) > b[c]) {
                continue;
            }
        }
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    if lo[0] == usize::MAX {
        return Err(Error::invalid("labels", format!("no tooth tissue found for tooth {fdi}")));
    }
    Ok(IndexBox { min: lo, max: hi.map(|v| v + 1) }.grown(margin_mm, lv.spacing, lv.dims))
}

/// Keeps the slab between two planes (each normal pointing into the slab): the grid is cropped
/// to the slab's voxels and voxels outside it are set to the volume's minimum (air).
pub fn crop_between_planes(vol: &Volume, a: &Plane, b: &Plane) -> Result<Volume> {
    let na = normalize(a.normal).ok_or_else(|| Error::invalid("plane_a.normal", "zero vector"))?.0;
    let nb = normalize(b.normal).ok_or_else(|| Error::invalid("plane_b.normal", "zero vector"))?.0;
    let inside = |p: [f64; 3]| {
        dot([p[0] - a.point[0], p[1] - a.point[1], p[2] - a.point[2]], na) >= 0.0 && dot([p[0] - b.point[0], p[1] - b.point[1], p[2] - b.point[2]], nb) >= 0.0
    };
    let [nx, ny, nz] = vol.dims;
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if inside(vol.voxel_center(i, j, k)) {
                    let p = [i, j, k];
                    for c in 0..3 {
                        lo[c] = lo[c].min(p[c]);
                        hi[c] = hi[c].max(p[c]);
                    }
                }
            }
        }
    }
    if lo[0] == usize::MAX {
        return Err(Error::invalid("planes", "the slab between the planes holds no voxel of the volume"));
    }
    let bx = IndexBox { min: lo, max: [hi[0] + 1, hi[1] + 1, hi[2] + 1] };
    let mut out = crop(vol, &bx)?;
    let air = vol.min_max().0;
    let [cx, cy, cz] = out.dims;
    for k in 0..cz {
        for j in 0..cy {
            for i in 0..cx {
                if !inside(out.voxel_center(i, j, k)) {
                    let n = out.index(i, j, k);
                    out.values[n] = air;
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_padded_volume_keeps_every_voxel_in_its_place() {
        let (c, s) = (0.6f64, 0.8f64);
        let vol = Volume {
            dims: [3, 2, 2],
            spacing: [0.2, 0.3, 0.4],
            origin: [10.0, -5.0, 2.0],
            direction: [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]],
            values: (0..12).map(|v| v as f32).collect(),
            source: Default::default(),
        };
        let (low, high) = ([2, 0, 1], [0, 1, 2]);
        let padded = pad(&vol, low, high, -1.0);
        assert_eq!(padded.dims, [5, 3, 5]);
        for (k, j, i) in (0..2).flat_map(|k| (0..2).flat_map(move |j| (0..3).map(move |i| (k, j, i)))) {
            let (a, b) = (vol.voxel_center(i, j, k), padded.voxel_center(i + 2, j, k + 1));
            assert!((0..3).all(|r| (a[r] - b[r]).abs() < 1e-12), "{a:?} vs {b:?}");
            assert_eq!(padded.value_at(i + 2, j, k + 1), vol.value_at(i, j, k));
        }
        assert_eq!(padded.values.iter().filter(|&&v| v == -1.0).count(), 5 * 3 * 5 - 12);
        let labels = pad_labels(&vol.label_volume(), low, high, Label::Air);
        assert_eq!((labels.dims, labels.origin), (padded.dims, padded.origin));
        assert_eq!(labels.count(Label::Air), labels.labels.len());
    }
}
