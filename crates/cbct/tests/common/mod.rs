//! Shared by the reader tests that break files: a small phantom scan, its DICOM series, and an
//! in-place edit of one slice.
#![allow(dead_code)] // each test crate uses its own part

use dentsim_cbct::*;
use dicom_object::open_file;
use std::path::{Path, PathBuf};

pub fn small() -> Volume {
    Phantom::new(&PhantomSpec { dims: [24, 20, 12], spacing_mm: 0.5, ..Default::default() }).scan()
}

/// The small scan as a DICOM series in `dir/s`, and its slice files in order.
pub fn series(dir: &Path) -> (PathBuf, Vec<PathBuf>) {
    let out = dir.join("s");
    write_dicom_series(&small(), &out).unwrap();
    let mut files: Vec<_> = std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    (out, files)
}

/// Rewrites a DICOM file after `f` changed it.
pub fn edit(file: &Path, f: impl FnOnce(&mut dicom_object::DefaultDicomObject)) {
    let mut o = open_file(file).unwrap();
    f(&mut o);
    o.write_to_file(file).unwrap();
}
