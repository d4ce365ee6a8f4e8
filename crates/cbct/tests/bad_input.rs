//! Bad input: each case gives a clear error naming the file and field, never a panic.

mod common;

use common::{edit, series, small};
use dentsim_cbct::*;
use dicom_core::value::PrimitiveValue;
use dicom_core::{DataElement, VR};
use dicom_dictionary_std::tags;
use proptest::prelude::*;

#[test]
fn truncated_files() {
    let dir = tempfile::tempdir().unwrap();
    let v = small();
    for name in ["t.nii", "t.nii.gz", "t.mha"] {
        let p = dir.path().join(name);
        if name.ends_with(".mha") { write_metaimage(&v, &p).unwrap() } else { write_nifti(&v, &p).unwrap() }
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() * 2 / 3]).unwrap();
        let e = read(&p, &ReadOptions::default()).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains(name), "{msg}");
        assert!(matches!(e, Error::Truncated { .. } | Error::Io { .. } | Error::Field { .. }), "{name}: {e:?}");
    }
    let (_, files) = series(dir.path());
    let bytes = std::fs::read(&files[0]).unwrap();
    std::fs::write(&files[0], &bytes[..bytes.len() - 100]).unwrap();
    let e = read(&files[0], &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("slice_00000.dcm"), "{e}");
}

#[test]
fn missing_slice_names_both_neighbours() {
    let dir = tempfile::tempdir().unwrap();
    let (out, files) = series(dir.path());
    std::fs::remove_file(&files[5]).unwrap();
    match read(&out, &ReadOptions::default()) {
        Err(Error::MissingSlice { file_a, file_b, gap, expected, .. }) => {
            assert!(file_a.ends_with("slice_00004.dcm") && file_b.ends_with("slice_00006.dcm"), "{file_a:?} {file_b:?}");
            assert!((gap - 1.0).abs() < 1e-6 && (expected - 0.5).abs() < 1e-6);
        }
        other => panic!("expected MissingSlice, got {other:?}"),
    }
}

#[test]
fn mixed_series_names_both_uids_and_series_uid_picks_one() {
    let dir = tempfile::tempdir().unwrap();
    let (out, files) = series(dir.path());
    let other = dir.path().join("other");
    write_dicom_series(&small(), &other).unwrap();
    let moved = out.join("zz_other.dcm");
    std::fs::copy(other.join("slice_00003.dcm"), &moved).unwrap();
    let e = read(&out, &ReadOptions::default()).unwrap_err();
    let Error::MixedSeries { uid_a, uid_b, .. } = &e else { panic!("{e:?}") };
    assert_ne!(uid_a, uid_b);
    assert!(e.to_string().contains(uid_a.as_str()) && e.to_string().contains(uid_b.as_str()));
    let first_uid = read(&files[0], &ReadOptions::default()).unwrap().source.series_uid.unwrap();
    let v = read(&out, &ReadOptions { series_uid: Some(first_uid), ..Default::default() }).unwrap();
    assert_eq!(v.dims[2], files.len());
}

#[test]
fn inconsistent_spacing_and_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let (out, files) = series(dir.path());
    edit(&files[3], |o| {
        o.put(DataElement::new(tags::PIXEL_SPACING, VR::DS, PrimitiveValue::from("0.6\\0.6")));
    });
    let e = read(&out, &ReadOptions::default()).unwrap_err();
    assert!(matches!(&e, Error::Inconsistent { field, path, .. } if field.contains("PixelSpacing") && path.ends_with("slice_00003.dcm")), "{e:?}");

    let dir = tempfile::tempdir().unwrap();
    let (out, files) = series(dir.path());
    edit(&files[2], |o| {
        o.put(DataElement::new(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, PrimitiveValue::from("1\\0\\0\\0\\0.9\\0.43589")));
    });
    let e = read(&out, &ReadOptions::default()).unwrap_err();
    assert!(matches!(&e, Error::Inconsistent { field, .. } if field.contains("ImageOrientationPatient")), "{e:?}");

    // Irregular slice spacing (within 1.5x, so not a missing slice)
    let dir = tempfile::tempdir().unwrap();
    let (out, files) = series(dir.path());
    let v = small();
    let p = v.voxel_center(0, 0, 4);
    edit(&files[4], |o| {
        o.put(DataElement::new(tags::IMAGE_POSITION_PATIENT, VR::DS, PrimitiveValue::from(format!("{}\\{}\\{}", p[0], p[1], p[2] + 0.2).as_str())));
    });
    let e = read(&out, &ReadOptions::default()).unwrap_err();
    assert!(matches!(&e, Error::Inconsistent { field, .. } if field.contains("slice spacing")), "{e:?}");
}

#[test]
fn non_image_dicom_and_empty_folder() {
    let dir = tempfile::tempdir().unwrap();
    let (_, files) = series(dir.path());
    let f = &files[0];
    edit(f, |o| {
        o.remove_element(tags::PIXEL_DATA);
        o.remove_element(tags::ROWS);
        o.remove_element(tags::COLUMNS);
    });
    assert!(matches!(read(f, &ReadOptions::default()), Err(Error::NonImage { .. })));
    let only = dir.path().join("only");
    std::fs::create_dir(&only).unwrap();
    std::fs::copy(f, only.join("a.dcm")).unwrap();
    std::fs::copy(f, only.join("b.dcm")).unwrap();
    let e = read(&only, &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, Error::NoImage { .. }) && e.to_string().contains("non-image"), "{e}");
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    assert!(matches!(read(&empty, &ReadOptions::default()), Err(Error::EmptyFolder { .. })));
    let junk = dir.path().join("junk");
    std::fs::create_dir(&junk).unwrap();
    std::fs::write(junk.join("a.txt"), b"hello").unwrap();
    assert!(matches!(read(&junk, &ReadOptions::default()), Err(Error::NoImage { .. })));
}

#[test]
fn nan_voxel_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut v = small();
    let n = v.index(3, 4, 5);
    v.values[n] = f32::NAN;
    for name in ["nan.nii", "nan.mha"] {
        let p = dir.path().join(name);
        if name.ends_with(".mha") { write_metaimage(&v, &p).unwrap() } else { write_nifti(&v, &p).unwrap() }
        match read(&p, &ReadOptions::default()) {
            Err(Error::NaN { index, .. }) => assert_eq!(index, [3, 4, 5]),
            other => panic!("{name}: expected NaN error, got {other:?}"),
        }
    }
}

#[test]
fn memory_cap_on_series_and_metaimage() {
    let dir = tempfile::tempdir().unwrap();
    let (out, _) = series(dir.path());
    let cap = ReadOptions { max_bytes: 24 * 20 * 12 * 4 - 1, series_uid: None };
    assert!(matches!(read(&out, &cap), Err(Error::TooLarge { bytes, .. }) if bytes == 24 * 20 * 12 * 4));
    // A header claiming a huge volume is refused before any allocation.
    let p = dir.path().join("huge.mha");
    std::fs::write(&p, "ObjectType = Image\nNDims = 3\nDimSize = 100000 100000 100000\nElementType = MET_SHORT\nElementDataFile = LOCAL\n").unwrap();
    assert!(matches!(read(&p, &ReadOptions::default()), Err(Error::TooLarge { .. })));
}

#[test]
fn writers_leave_nothing_on_failure() {
    let dir = tempfile::tempdir().unwrap();
    let v = small();
    let bad = dir.path().join("no_such_dir").join("x.nii");
    assert!(write_nifti(&v, &bad).is_err());
    assert!(write_metaimage(&v, &dir.path().join("x.txt")).is_err());
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
}

fn garble(bytes: &[u8], cut: usize, flips: &[(usize, u8)]) -> Vec<u8> {
    let mut b = bytes[..cut.min(bytes.len())].to_vec();
    for &(at, x) in flips {
        if !b.is_empty() {
            let n = at % b.len();
            b[n] ^= x;
        }
    }
    b
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    /// Truncated and bit-flipped files of every format: an error or a volume, never a panic.
    #[test]
    fn garbled_files_never_panic(cut in 0usize..20000, flips in proptest::collection::vec((0usize..20000, 1u8..=255), 0..6)) {
        let dir = tempfile::tempdir().unwrap();
        let v = Phantom::new(&PhantomSpec { dims: [12, 10, 6], spacing_mm: 1.0, ..Default::default() }).scan();
        let src = dir.path().join("src");
        std::fs::create_dir(&src).unwrap();
        write_nifti(&v, &src.join("a.nii")).unwrap();
        write_nifti(&v, &src.join("a.nii.gz")).unwrap();
        write_metaimage(&v, &src.join("a.mha")).unwrap();
        write_metaimage_compressed(&v, &src.join("z.mha")).unwrap();
        write_dicom_series(&v, &src.join("d")).unwrap();
        let files = [src.join("a.nii"), src.join("a.nii.gz"), src.join("a.mha"), src.join("z.mha"), src.join("d").join("slice_00002.dcm")];
        for f in files {
            let bytes = std::fs::read(&f).unwrap();
            let g = garble(&bytes, cut, &flips);
            let name = f.file_name().unwrap().to_string_lossy().into_owned();
            let out = dir.path().join(format!("g_{name}"));
            std::fs::write(&out, g).unwrap();
            let r = std::panic::catch_unwind(|| read(&out, &ReadOptions { max_bytes: 64 << 20, series_uid: None }));
            prop_assert!(r.is_ok(), "panic reading garbled {}", name);
        }
    }
}
