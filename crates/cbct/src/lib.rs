//! CBCT in, tissues out: read a scan (DICOM series, NIfTI, MetaImage) into one [`Volume`] in the
//! patient LPS frame, make a realistic tooth [`phantom`], calibrate grey values per scan,
//! segment one tooth's tissues and crop to a region of interest. Pure Rust; knows nothing of C++.

pub mod calibrate;
pub mod bloom;
pub mod canal;
pub mod dicom;
mod dicom_lengths;
pub mod error;
mod mask;
pub mod metaimage;
pub mod nifti;
pub mod partial_volume;
pub mod phantom;
pub mod roi;
pub mod segment;
pub mod shading;
#[cfg(test)]
mod test_scans;
pub mod volume;


pub use dicom::{read_dicom, write_dicom_series};
pub use error::{Error, Result};
pub use metaimage::{read_metaimage, write_metaimage, write_metaimage_compressed};
pub use nifti::{read_nifti, write_nifti};
pub use partial_volume::{enclosed_volume, PartialVolume};
pub use phantom::{Phantom, PhantomSpec};
pub use calibrate::{calibrate, calibrate_below, Calibration};
pub use canal::trace_thin_canals;
pub use mask::within_box;
pub use roi::{crop, crop_between_planes, crop_labels, pad, pad_labels, tooth_box, IndexBox, Plane};
pub use shading::Shading;
pub use segment::{dice, find_teeth, segment, tissue_field, FoundTooth, SegmentOptions, ToothSelect};



pub use volume::{LabelVolume, SourceInfo, Volume};

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Tissue classes. The numeric value is what a [`LabelVolume`] stores.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[repr(u8)]
pub enum Label {
    Air = 0,
    SoftTissue = 1,
    BoneCancellous = 2,
    BoneCortical = 3,
    Dentin = 4,
    Enamel = 5,
    Pulp = 6,
    Caries = 7,
    Metal = 8,
}

impl Label {
    pub const ALL: [Label; 9] = [
        Label::Air,
        Label::SoftTissue,
        Label::BoneCancellous,
        Label::BoneCortical,
        Label::Dentin,
        Label::Enamel,
        Label::Pulp,
        Label::Caries,
        Label::Metal,
    ];
    /// The tissue's name as used in grids, TOML and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Label::Air => "air",
            Label::SoftTissue => "soft_tissue",
            Label::BoneCancellous => "bone_cancellous",
            Label::BoneCortical => "bone_cortical",
            Label::Dentin => "dentin",
            Label::Enamel => "enamel",
            Label::Pulp => "pulp",
            Label::Caries => "caries",
            Label::Metal => "metal",
        }
    }
    pub fn from_name(name: &str) -> Option<Label> {
        Label::ALL.into_iter().find(|l| l.name() == name)
    }
    pub fn from_u8(v: u8) -> Option<Label> {
        Label::ALL.get(v as usize).copied()
    }
    /// Typical CT value (HU) from REFERENCE.md "Tissue grey values" (a value inside each range).
    pub fn typical_hu(self) -> f64 {
        match self {
            Label::Air => -1000.0,
            Label::SoftTissue => 50.0,
            Label::BoneCancellous => 500.0,
            Label::BoneCortical => 1150.0,
            Label::Dentin => 1650.0,
            Label::Enamel => 2500.0,
            Label::Pulp => 300.0,
            Label::Caries => 900.0,
            Label::Metal => 3071.0,
        }
    }
}

/// Limits for reading.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// Refuse volumes whose f32 values would exceed this many bytes (checked from the header).
    pub max_bytes: u64,
    /// Pick one series from a folder holding several.
    pub series_uid: Option<String>,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions { max_bytes: 2 << 30, series_uid: None }
    }
}

/// Reads a scan: a folder is a DICOM series, `.nii`/`.nii.gz` NIfTI, `.mha`/`.mhd` MetaImage,
/// anything else is tried as one DICOM file.
pub fn read(path: impl AsRef<Path>, opts: &ReadOptions) -> Result<Volume> {
    let path = path.as_ref();
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        return dicom::read_dicom(path, opts);
    }
    let name = path.file_name().map(|n| n.to_string_lossy().to_lowercase()).unwrap_or_default();
    let vol = if name.ends_with(".nii") || name.ends_with(".nii.gz") {
        nifti::read_nifti(path, opts)
    } else if name.ends_with(".mha") || name.ends_with(".mhd") {
        metaimage::read_metaimage(path, opts)
    } else {
        dicom::read_dicom(path, opts)
    }?;
    check_spacing(path, &vol)?;
    Ok(vol)
}

/// Voxel sizes a scan may have (mm): micro-CT reaches a few µm, no scan of teeth is coarser than
/// centimetres. Outside them a header is wrong, and sizes derived from it (crops, level sets in
/// mm) would be absurd.
pub const SPACING_RANGE_MM: (f64, f64) = (1e-3, 100.0);

fn check_spacing(path: &Path, vol: &Volume) -> Result<()> {
    let (lo, hi) = SPACING_RANGE_MM;
    if let Some(s) = vol.spacing.iter().find(|s| !(s.is_finite() && (lo..=hi).contains(*s))) {
        let field = match vol.source.format.as_str() {
            "nifti" => "pixdim / srow (voxel size)",
            "metaimage" => "ElementSpacing",
            _ => "PixelSpacing / slice spacing",
        };
        let all: Vec<String> = vol.spacing.iter().map(|v| format!("{v:.3e}")).collect();
        return Err(Error::field(path, field, format!("voxel size {s:.3e} mm (of {}), expected {lo} to {hi} mm", all.join(", "))));
    }
    Ok(())
}

pub(crate) fn check_cap(path: &Path, dims: [u64; 3], opts: &ReadOptions) -> Result<usize> {
    let n = dims[0].checked_mul(dims[1]).and_then(|v| v.checked_mul(dims[2]));
    let bytes = n.and_then(|n| n.checked_mul(4)).unwrap_or(u64::MAX);
    if bytes > opts.max_bytes {
        return Err(Error::TooLarge { path: path.to_path_buf(), bytes, cap: opts.max_bytes });
    }
    usize::try_from(n.unwrap_or(u64::MAX)).map_err(|_| Error::TooLarge { path: path.to_path_buf(), bytes, cap: opts.max_bytes })
}

/// Temporary sibling name for a folder built before it is renamed into place (files go through
/// [`dentsim_atomic::write`]).
pub(crate) fn temp_sibling(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{name}.part{}", std::process::id()))
}

/// Unit vector, or `None` for a zero / non-finite vector.
pub(crate) fn normalize(v: [f64; 3]) -> Option<([f64; 3], f64)> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if n.is_finite() && n > 1e-12 {
        Some(([v[0] / n, v[1] / n, v[2] / n], n))
    } else {
        None
    }
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
