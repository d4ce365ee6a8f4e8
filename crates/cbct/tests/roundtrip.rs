//! The phantom written in every format and read back: geometry and values must match.

use dentsim_cbct::dicom::write_dicom_multiframe;
use dentsim_cbct::*;

fn small_phantom() -> Volume {
    let spec = PhantomSpec { dims: [40, 36, 30], spacing_mm: 0.4, ..Default::default() };
    Phantom::new(&spec).scan()
}

fn assert_geometry(a: &Volume, b: &Volume, tol: f64) {
    assert_eq!(a.dims, b.dims);
    for c in 0..3 {
        assert!((a.spacing[c] - b.spacing[c]).abs() < tol, "spacing {:?} vs {:?}", a.spacing, b.spacing);
        assert!((a.origin[c] - b.origin[c]).abs() < tol, "origin {:?} vs {:?}", a.origin, b.origin);
        for r in 0..3 {
            assert!((a.direction[c][r] - b.direction[c][r]).abs() < 1e-6, "direction {:?} vs {:?}", a.direction, b.direction);
        }
    }
}

#[test]
fn nifti_roundtrip_plain_and_gz() {
    let v = small_phantom();
    let dir = tempfile::tempdir().unwrap();
    for name in ["p.nii", "p.nii.gz"] {
        let p = dir.path().join(name);
        write_nifti(&v, &p).unwrap();
        let r = read(&p, &ReadOptions::default()).unwrap();
        assert_geometry(&v, &r, 1e-4);
        assert_eq!(r.values, v.values, "{name}: float32 is exact");
    }
}

#[test]
fn nifti_roundtrip_keeps_an_oblique_direction() {
    let mut v = small_phantom();
    let (s, c) = (0.3f64.sin(), 0.3f64.cos());
    v.direction = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]];
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("o.nii");
    write_nifti(&v, &p).unwrap();
    let r = read(&p, &ReadOptions::default()).unwrap();
    assert_geometry(&v, &r, 1e-4);
}

#[test]
fn metaimage_roundtrip_mha_mhd_zraw() {
    let v = small_phantom();
    let dir = tempfile::tempdir().unwrap();
    let mha = dir.path().join("p.mha");
    write_metaimage(&v, &mha).unwrap();
    let mhd = dir.path().join("p.mhd");
    write_metaimage(&v, &mhd).unwrap();
    assert!(dir.path().join("p.raw").exists());
    let z = dir.path().join("z.mhd");
    write_metaimage_compressed(&v, &z).unwrap();
    assert!(dir.path().join("z.zraw").exists());
    for p in [mha, mhd, z] {
        let r = read(&p, &ReadOptions::default()).unwrap();
        assert_geometry(&v, &r, 1e-9);
        assert_eq!(r.values, v.values);
    }
}

#[test]
fn dicom_series_roundtrip_within_int16_quantisation() {
    let v = small_phantom();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("series");
    write_dicom_series(&v, &out).unwrap();
    let files = std::fs::read_dir(&out).unwrap().count();
    assert_eq!(files, v.dims[2]);
    let r = read(&out, &ReadOptions::default()).unwrap();
    assert_geometry(&v, &r, 1e-4);
    let (lo, hi) = v.min_max();
    let step = (hi - lo) as f64 / 64000.0;
    let worst = v.values.iter().zip(&r.values).map(|(a, b)| (a - b).abs() as f64).fold(0.0, f64::max);
    assert!(worst <= step * 1.01 + 1e-3, "max error {worst} vs quantisation step {step}");
    assert_eq!(r.source.modality.as_deref(), Some("CT"));
    // Writing over a non-empty folder is refused and leaves it untouched.
    assert!(write_dicom_series(&v, &out).is_err());
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), v.dims[2]);
}

#[test]
fn dicom_series_sorted_by_position_not_file_name() {
    let v = small_phantom();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s");
    write_dicom_series(&v, &out).unwrap();
    // Rename so that file-name order is the reverse of the slice order.
    let mut names: Vec<_> = std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().path()).collect();
    names.sort();
    let n = names.len();
    for (k, p) in names.iter().enumerate() {
        std::fs::rename(p, out.join(format!("x{:05}.dcm", n - k))).unwrap();
    }
    std::fs::write(out.join("README.txt"), b"not dicom").unwrap();
    let r = read(&out, &ReadOptions::default()).unwrap();
    assert_geometry(&v, &r, 1e-4);
    assert!(r.source.notes.iter().any(|s| s.contains("README.txt")), "{:?}", r.source.notes);
    let (lo, hi) = v.min_max();
    let step = (hi - lo) as f64 / 64000.0;
    assert!(v.values.iter().zip(&r.values).all(|(a, b)| ((a - b).abs() as f64) <= step * 1.01 + 1e-3));
}

#[test]
fn enhanced_multiframe_roundtrip() {
    let mut v = small_phantom();
    v.values.iter_mut().for_each(|x| *x = x.round());
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("enhanced.dcm");
    write_dicom_multiframe(&v, &p).unwrap();
    let r = read(&p, &ReadOptions::default()).unwrap();
    assert_geometry(&v, &r, 1e-4);
    assert_eq!(r.values, v.values);
}

#[test]
fn index_world_roundtrip() {
    let mut v = small_phantom();
    v.direction = [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    let p = v.voxel_center(3, 7, 11);
    let idx = v.world_to_index(p).unwrap();
    assert!((idx[0] - 3.0).abs() < 1e-9 && (idx[1] - 7.0).abs() < 1e-9 && (idx[2] - 11.0).abs() < 1e-9);
    let m = v.index_to_world();
    let w = [m[0] * 3.0 + m[1] * 7.0 + m[2] * 11.0 + m[3], m[4] * 3.0 + m[5] * 7.0 + m[6] * 11.0 + m[7], m[8] * 3.0 + m[9] * 7.0 + m[10] * 11.0 + m[11]];
    for c in 0..3 {
        assert!((w[c] - p[c]).abs() < 1e-9);
    }
    assert_eq!(v.bytes(), (v.values.len() * 4) as u64);
}
