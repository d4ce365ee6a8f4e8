//! The scan as one regular grid in the patient LPS frame, and label grids on the same geometry.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Anonymous facts about where a volume came from; deliberately no patient-identifying fields.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SourceInfo {
    /// "dicom", "nifti", "metaimage" or "phantom".
    pub format: String,
    pub path: String,
    pub modality: Option<String>,
    pub manufacturer: Option<String>,
    pub model: Option<String>,
    pub series_uid: Option<String>,
    /// DICOM transfer syntax, NIfTI version, MetaImage element type.
    pub encoding: Option<String>,
    /// Things skipped or assumed while reading (e.g. non-DICOM files in the folder).
    pub notes: Vec<String>,
}

/// A scalar volume. `values[i + nx*(j + ny*k)]`; voxel centres at `origin + Σ_c idx_c*spacing_c*direction[c]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Volume {
    pub dims: [usize; 3],
    /// mm along each index axis.
    pub spacing: [f64; 3],
    /// LPS mm of the centre of voxel (0,0,0).
    pub origin: [f64; 3],
    /// `direction[c]` = unit vector in LPS of index axis c.
    pub direction: [[f64; 3]; 3],
    pub values: Vec<f32>,
    pub source: SourceInfo,
}

/// Ground-truth or segmented labels (`Label as u8`) on a volume's grid.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelVolume {
    pub dims: [usize; 3],
    pub spacing: [f64; 3],
    pub origin: [f64; 3],
    pub direction: [[f64; 3]; 3],
    pub labels: Vec<u8>,
}

pub const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Row-major 4×4 voxel index → LPS mm.
pub fn affine(spacing: [f64; 3], origin: [f64; 3], direction: [[f64; 3]; 3]) -> [f64; 16] {
    let mut m = [0.0; 16];
    for r in 0..3 {
        for c in 0..3 {
            m[r * 4 + c] = direction[c][r] * spacing[c];
        }
        m[r * 4 + 3] = origin[r];
    }
    m[15] = 1.0;
    m
}

/// Inverse of [`affine`] applied to a point; `None` if the axes are degenerate.
pub fn world_to_index_of(spacing: [f64; 3], origin: [f64; 3], direction: [[f64; 3]; 3], p: [f64; 3]) -> Option<[f64; 3]> {
    let m = affine(spacing, origin, direction);
    let a = [[m[0], m[1], m[2]], [m[4], m[5], m[6]], [m[8], m[9], m[10]]];
    let det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    if !det.is_finite() || det.abs() < 1e-12 {
        return None;
    }
    let d = [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]];
    // Cramer's rule: small, exact enough, no dependency.
    let col = |c: usize| [a[0][c], a[1][c], a[2][c]];
    let det3 = |x: [f64; 3], y: [f64; 3], z: [f64; 3]| {
        x[0] * (y[1] * z[2] - y[2] * z[1]) - y[0] * (x[1] * z[2] - x[2] * z[1]) + z[0] * (x[1] * y[2] - x[2] * y[1])
    };
    Some([
        det3(d, col(1), col(2)) / det,
        det3(col(0), d, col(2)) / det,
        det3(col(0), col(1), d) / det,
    ])
}

impl Volume {
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Linear index of voxel (i, j, k); x fastest.
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }
    pub fn index_to_world(&self) -> [f64; 16] {
        affine(self.spacing, self.origin, self.direction)
    }
    /// The finest of the three voxel spacings (mm).
    pub fn min_spacing(&self) -> f64 {
        self.spacing.iter().cloned().fold(f64::INFINITY, f64::min)
    }
    /// Continuous voxel index of an LPS point (voxel centres at integers).
    pub fn world_to_index(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        world_to_index_of(self.spacing, self.origin, self.direction, p)
    }
    /// LPS position of the centre of voxel (i, j, k).
    pub fn voxel_center(&self, i: usize, j: usize, k: usize) -> [f64; 3] {
        center_of(self.spacing, self.origin, self.direction, [i as f64, j as f64, k as f64])
    }
    pub fn value_at(&self, i: usize, j: usize, k: usize) -> Option<f32> {
        if i < self.dims[0] && j < self.dims[1] && k < self.dims[2] {
            self.values.get(self.index(i, j, k)).copied()
        } else {
            None
        }
    }
    /// Memory held by the values.
    pub fn bytes(&self) -> u64 {
        (self.values.len() * std::mem::size_of::<f32>()) as u64
    }
    pub fn voxel_volume_mm3(&self) -> f64 {
        self.spacing[0] * self.spacing[1] * self.spacing[2]
    }
    /// The variance (mm², mean over the axes) a voxel's averaging adds to the scan's blur: its
    /// box's, h²/12.
    pub fn box_variance_mm2(&self) -> f64 {
        self.spacing.iter().map(|h| h * h / 12.0).sum::<f64>() / 3.0
    }
    /// Builds a volume after checking the value count and that no value is NaN.
    pub fn new(dims: [usize; 3], spacing: [f64; 3], origin: [f64; 3], direction: [[f64; 3]; 3], values: Vec<f32>, source: SourceInfo) -> Result<Self> {
        let n = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
        if n != Some(values.len()) {
            return Err(Error::invalid("values", format!("{} values for dims {:?}", values.len(), dims)));
        }
        let v = Volume { dims, spacing, origin, direction, values, source };
        v.check_nan(Path::new(&v.source.path))?;
        Ok(v)
    }
    /// Errors naming the first NaN voxel, since NaN would silently poison histograms and level sets.
    pub fn check_nan(&self, path: &Path) -> Result<()> {
        if let Some(n) = self.values.iter().position(|v| v.is_nan()) {
            let nx = self.dims[0].max(1);
            let ny = self.dims[1].max(1);
            return Err(Error::NaN { path: path.to_path_buf(), index: [n % nx, (n / nx) % ny, n / (nx * ny)] });
        }
        Ok(())
    }
    /// An empty label grid with this geometry.
    pub fn label_volume(&self) -> LabelVolume {
        LabelVolume { dims: self.dims, spacing: self.spacing, origin: self.origin, direction: self.direction, labels: vec![0; self.len()] }
    }
    pub fn min_max(&self) -> (f32, f32) {
        use rayon::prelude::*;
        let none = || (f32::INFINITY, f32::NEG_INFINITY);
        self.values.par_iter().fold(none, |(a, b), &v| (a.min(v), b.max(v))).reduce(none, |(a, b), (c, d)| (a.min(c), b.max(d)))
    }
}

pub(crate) fn center_of(spacing: [f64; 3], origin: [f64; 3], direction: [[f64; 3]; 3], idx: [f64; 3]) -> [f64; 3] {
    let mut p = origin;
    for c in 0..3 {
        for r in 0..3 {
            p[r] += direction[c][r] * spacing[c] * idx[c];
        }
    }
    p
}

impl LabelVolume {
    pub fn len(&self) -> usize {
        self.labels.len()
    }
    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }
    pub fn index_to_world(&self) -> [f64; 16] {
        affine(self.spacing, self.origin, self.direction)
    }
    pub fn world_to_index(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        world_to_index_of(self.spacing, self.origin, self.direction, p)
    }
    pub fn voxel_center(&self, i: usize, j: usize, k: usize) -> [f64; 3] {
        center_of(self.spacing, self.origin, self.direction, [i as f64, j as f64, k as f64])
    }
    pub fn voxel_volume_mm3(&self) -> f64 {
        self.spacing[0] * self.spacing[1] * self.spacing[2]
    }
    pub fn count(&self, label: crate::Label) -> usize {
        let l = label as u8;
        self.labels.iter().filter(|&&v| v == l).count()
    }
    /// Voxel-count volume of one label.
    pub fn volume_mm3(&self, label: crate::Label) -> f64 {
        self.count(label) as f64 * self.voxel_volume_mm3()
    }
}

/// The six face neighbours of voxel `n` (x fastest) in a grid of `dims`, `None` past its edge.
pub fn face_neighbours(n: usize, [nx, ny, nz]: [usize; 3]) -> [Option<usize>; 6] {
    let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
    [
        (i > 0).then(|| n - 1),
        (i + 1 < nx).then(|| n + 1),
        (j > 0).then(|| n - nx),
        (j + 1 < ny).then(|| n + nx),
        (k > 0).then(|| n - nx * ny),
        (k + 1 < nz).then(|| n + nx * ny),
    ]
}
