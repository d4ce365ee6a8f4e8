//! Readers on real files shipped by Debian packages (python3-pydicom, python3-nibabel).
//! Expected figures were printed by pydicom 2.3.1 / nibabel 5.0.0 on this machine.

use dentsim_cbct::{read, Error, ReadOptions};
use std::path::{Path, PathBuf};

const PYDICOM: &str = "/usr/lib/python3/dist-packages/pydicom/data/test_files";
const NIBABEL: &str = "/usr/lib/python3/dist-packages/nibabel/tests/data";

fn pkg_file(dir: &str, name: &str, pkg: &str) -> PathBuf {
    let p = Path::new(dir).join(name);
    assert!(p.exists(), "{} is missing: install the Debian package {pkg} (apt-get install {pkg})", p.display());
    p
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn ct_small_dicom_geometry_and_hu() {
    let p = pkg_file(PYDICOM, "CT_small.dcm", "python3-pydicom");
    let v = read(&p, &ReadOptions::default()).unwrap();
    assert_eq!(v.dims, [128, 128, 1]);
    let (lo, hi) = v.min_max();
    assert_eq!((lo, hi), (-896.0, 1167.0));
    // pydicom: pixel_array*1 - 1024 at [row 0, col 0] = -849, [row 10, col 20] = -839
    assert_eq!(v.value_at(0, 0, 0), Some(-849.0));
    assert_eq!(v.value_at(20, 10, 0), Some(-839.0));
    let mean: f64 = v.values.iter().map(|&x| x as f64).sum::<f64>() / v.values.len() as f64;
    assert!(close(mean, -119.0738525390625, 1e-3), "mean {mean}");
    assert!(close(v.spacing[0], 0.661468, 1e-6) && close(v.spacing[1], 0.661468, 1e-6));
    assert!(close(v.spacing[2], 5.0, 1e-9), "single slice takes Slice Thickness");
    assert_eq!(v.origin, [-158.135803, -179.035797, -75.699997]);
    assert_eq!(v.direction, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    assert_eq!(v.source.modality.as_deref(), Some("CT"));
    assert_eq!(v.source.manufacturer.as_deref(), Some("GE MEDICAL SYSTEMS"));
    assert_eq!(v.source.encoding.as_deref(), Some("1.2.840.10008.1.2.1"));
}

#[test]
fn nibabel_anatomical_big_endian_nifti1() {
    // nibabel: shape (33,41,25) >i2, sform [[-2,0,0,32],[0,2,0,-40],[0,0,2,-16]] (RAS)
    let p = pkg_file(NIBABEL, "anatomical.nii", "python3-nibabel");
    let v = read(&p, &ReadOptions::default()).unwrap();
    assert_eq!(v.dims, [33, 41, 25]);
    assert_eq!(v.spacing, [2.0, 2.0, 2.0]);
    assert_eq!(v.origin, [-32.0, 40.0, -16.0]);
    assert_eq!(v.direction, [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]);
    assert_eq!(v.min_max(), (-610.0, 30393.0));
    assert_eq!(v.value_at(1, 2, 3), Some(9798.0));
    let mean: f64 = v.values.iter().map(|&x| x as f64).sum::<f64>() / v.values.len() as f64;
    assert!(close(mean, 8401.066725794532, 1e-6));
    // index_to_world maps voxel (1,2,3) to LPS = -(RAS x,y)
    let m = v.index_to_world();
    let w = [m[0] + 2.0 * m[1] + 3.0 * m[2] + m[3], m[4] + 2.0 * m[5] + 3.0 * m[6] + m[7], m[8] + 2.0 * m[9] + 3.0 * m[10] + m[11]];
    assert_eq!(w, [-30.0, 36.0, -10.0]);
}

#[test]
fn nibabel_standard_gz_sform() {
    // nibabel: shape (4,5,7) uint8, sform_code 2, affine diag(1,3,2), min 0 max 255 mean 54.642857, v[1,2,3]=255
    let p = pkg_file(NIBABEL, "standard.nii.gz", "python3-nibabel");
    let v = read(&p, &ReadOptions::default()).unwrap();
    assert_eq!(v.dims, [4, 5, 7]);
    assert_eq!(v.spacing, [1.0, 3.0, 2.0]);
    assert_eq!(v.origin, [0.0, 0.0, 0.0]);
    assert_eq!(v.direction, [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]);
    assert_eq!(v.min_max(), (0.0, 255.0));
    assert_eq!(v.value_at(1, 2, 3), Some(255.0));
    let mean: f64 = v.values.iter().map(|&x| x as f64).sum::<f64>() / v.values.len() as f64;
    assert!(close(mean, 54.642857142857146, 1e-9));
}

#[test]
fn nibabel_reoriented_float_big_endian() {
    // nibabel: (21,26,22) >f4, affine diag(4,4,4) offset (-35.297897,-47.977585,-27.599409), max 21199.935546875
    let p = pkg_file(NIBABEL, "reoriented_anat_moved.nii", "python3-nibabel");
    let v = read(&p, &ReadOptions::default()).unwrap();
    assert_eq!(v.dims, [21, 26, 22]);
    assert_eq!(v.spacing, [4.0, 4.0, 4.0]);
    assert!(close(v.origin[0], 35.297897, 1e-5) && close(v.origin[1], 47.977585, 1e-5) && close(v.origin[2], -27.599409, 1e-5));
    assert_eq!(v.min_max(), (0.0, 21199.935546875));
}

#[test]
fn four_d_nifti1_and_nifti2_are_refused() {
    for name in ["example4d.nii.gz", "example_nifti2.nii.gz", "functional.nii"] {
        let p = pkg_file(NIBABEL, name, "python3-nibabel");
        match read(&p, &ReadOptions::default()) {
            Err(Error::FourD { path, dims }) => {
                assert_eq!(path, p);
                assert_eq!(dims.len(), 4, "{name}: {dims:?}");
                assert!(dims[3] > 1);
            }
            other => panic!("{name}: expected a 4-D error, got {other:?}"),
        }
    }
}

#[test]
fn memory_cap_is_checked_from_the_header() {
    let p = pkg_file(NIBABEL, "anatomical.nii", "python3-nibabel");
    let opts = ReadOptions { max_bytes: 1000, series_uid: None };
    match read(&p, &opts) {
        Err(Error::TooLarge { bytes, cap, .. }) => {
            assert_eq!(bytes, 33 * 41 * 25 * 4);
            assert_eq!(cap, 1000);
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
    let p = pkg_file(PYDICOM, "CT_small.dcm", "python3-pydicom");
    assert!(matches!(read(&p, &opts), Err(Error::TooLarge { .. })));
}
