//! Issue 11's hostile scans: each was read without a word before (or blamed the wrong file);
//! now each is an error naming the file and the field, or (a stray file in a series) a warning
//! naming it while the series is read.

mod common;

use common::{edit, series, small};
use dentsim_cbct::*;
use dicom_core::value::PrimitiveValue;
use dicom_core::{DataElement, VR};
use dicom_dictionary_std::tags;

fn put_ds(tag: dicom_core::Tag, text: &'static str) -> impl FnOnce(&mut dicom_object::DefaultDicomObject) {
    move |o| {
        o.put(DataElement::new(tag, VR::DS, PrimitiveValue::from(text)));
    }
}

#[test]
fn a_stray_empty_or_text_file_is_a_warning_naming_it_and_the_series_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let (out, files) = series(dir.path());
    std::fs::write(out.join("zz_empty.dcm"), b"").unwrap();
    std::fs::write(out.join("README.txt"), b"exported by hand\n").unwrap();
    let v = read(&out, &ReadOptions::default()).unwrap();
    assert_eq!(v.dims[2], files.len());
    let notes = v.source.notes.join("\n");
    assert!(notes.contains("zz_empty.dcm") && notes.contains("zero bytes"), "{notes}");
    assert!(notes.contains("README.txt") && notes.contains("not DICOM"), "{notes}");
}

#[test]
fn rescale_slope_nan_on_every_slice_is_an_error_naming_a_slice_and_the_tag() {
    let dir = tempfile::tempdir().unwrap();
    let (out, files) = series(dir.path());
    for f in &files {
        edit(f, put_ds(tags::RESCALE_SLOPE, "NaN"));
    }
    let e = read(&out, &ReadOptions::default()).unwrap_err();
    let text = e.to_string();
    assert!(matches!(&e, Error::Field { field, .. } if field.contains("RescaleSlope (0028,1053)")), "{e:?}");
    assert!(text.contains("slice_00000.dcm") && text.contains("NaN"), "{text}");
}

#[test]
fn slope_zero_or_a_text_intercept_on_one_slice_names_that_slice() {
    for (tag, value, field) in [
        (tags::RESCALE_SLOPE, "0", "RescaleSlope (0028,1053)"),
        (tags::RESCALE_INTERCEPT, "abc", "RescaleIntercept (0028,1052)"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let (out, files) = series(dir.path());
        edit(&files[7], put_ds(tag, value));
        let e = read(&out, &ReadOptions::default()).unwrap_err();
        assert!(matches!(&e, Error::Field { path, field: f, .. } if path.ends_with("slice_00007.dcm") && f == field), "{value}: {e:?}");
    }
}

#[test]
fn bits_allocated_8_on_one_slice_is_inconsistent_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let (out, files) = series(dir.path());
    edit(&files[5], |o| {
        o.put(DataElement::new(tags::BITS_ALLOCATED, VR::US, PrimitiveValue::from(8u16)));
        o.put(DataElement::new(tags::BITS_STORED, VR::US, PrimitiveValue::from(8u16)));
        o.put(DataElement::new(tags::HIGH_BIT, VR::US, PrimitiveValue::from(7u16)));
    });
    let e = read(&out, &ReadOptions::default()).unwrap_err();
    assert!(
        matches!(&e, Error::Inconsistent { path, field, expected, found } if path.ends_with("slice_00005.dcm") && field.contains("BitsAllocated") && expected.starts_with("16/") && found.starts_with("8/")),
        "{e:?}"
    );
}

#[test]
fn a_zero_byte_or_truncated_slice_is_named_not_its_neighbours() {
    for cut in [0usize, 200] {
        let dir = tempfile::tempdir().unwrap();
        let (out, files) = series(dir.path());
        let bytes = std::fs::read(&files[6]).unwrap();
        std::fs::write(&files[6], &bytes[..cut]).unwrap();
        let e = read(&out, &ReadOptions::default()).unwrap_err();
        match &e {
            Error::BadSlice { path, file_a, file_b, .. } => {
                assert!(path.ends_with("slice_00006.dcm"), "{e}");
                assert!(file_a.ends_with("slice_00005.dcm") && file_b.ends_with("slice_00007.dcm"), "{e}");
            }
            other => panic!("cut at {cut}: expected BadSlice, got {other:?}"),
        }
        assert!(e.to_string().starts_with(&files[6].display().to_string()), "{e}");
    }
}

#[test]
fn a_small_slice_claiming_a_huge_image_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let (_, files) = series(dir.path());
    // 16384² 16-bit pixels (512 MiB) claimed by a file of a few KiB; under the memory cap, so
    // only the size check stands between it and a 1 GiB allocation.
    edit(&files[0], |o| {
        o.put(DataElement::new(tags::ROWS, VR::US, PrimitiveValue::from(16384u16)));
        o.put(DataElement::new(tags::COLUMNS, VR::US, PrimitiveValue::from(16384u16)));
    });
    let e = read(&files[0], &ReadOptions::default()).unwrap_err();
    assert!(
        matches!(&e, Error::Truncated { path, field, expected, .. } if path == &files[0] && field.contains("Pixel Data") && *expected == 16384 * 16384 * 2),
        "{e:?}"
    );
}

#[test]
fn a_gzip_nifti_with_a_wrong_crc_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("scan.nii.gz");
    write_nifti(&small(), &p).unwrap();
    assert!(read(&p, &ReadOptions::default()).is_ok());
    let mut bytes = std::fs::read(&p).unwrap();
    // The trailer is CRC-32 then the length: flip the CRC's first byte.
    let at = bytes.len() - 8;
    bytes[at] ^= 0xFF;
    std::fs::write(&p, &bytes).unwrap();
    let e = read(&p, &ReadOptions::default()).unwrap_err();
    assert!(matches!(&e, Error::Field { path, field, .. } if path == &p && field == "gzip stream"), "{e:?}");
}

#[test]
fn absurd_voxel_sizes_are_refused_by_every_reader() {
    let dir = tempfile::tempdir().unwrap();
    for (spacing, name) in [(1e-11, "tiny.nii.gz"), (1e-11, "tiny.mha"), (500.0, "huge.nii")] {
        let mut v = small();
        v.spacing = [spacing; 3];
        let p = dir.path().join(name);
        if name.ends_with(".mha") { write_metaimage(&v, &p).unwrap() } else { write_nifti(&v, &p).unwrap() }
        let e = read(&p, &ReadOptions::default()).unwrap_err();
        let text = e.to_string();
        assert!(matches!(&e, Error::Field { path, .. } if path == &p) && text.contains("voxel size"), "{name}: {e:?}");
    }
}

#[test]
fn metaimage_ascii_data_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("scan.mha");
    write_metaimage(&small(), &p).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    let text_end = bytes.windows(15).position(|w| w == b"ElementDataFile").unwrap();
    let header = String::from_utf8_lossy(&bytes[..text_end]).replace("BinaryData = True", "BinaryData = False");
    let mut edited = header.into_bytes();
    edited.extend_from_slice(&bytes[text_end..]);
    std::fs::write(&p, &edited).unwrap();
    let e = read(&p, &ReadOptions::default()).unwrap_err();
    assert!(matches!(&e, Error::Field { path, field, .. } if path == &p && field == "BinaryData"), "{e:?}");
}

#[test]
fn a_small_nifti_claiming_a_large_volume_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("claim.nii");
    write_nifti(&small(), &p).unwrap();
    let mut bytes = std::fs::read(&p).unwrap();
    // dim[1..3] = 1024 each: 4 GiB of f32 claimed, under an 8 GiB cap, by a file of a few KB.
    for i in 0..3 {
        bytes[42 + 2 * i..44 + 2 * i].copy_from_slice(&1024i16.to_le_bytes());
    }
    std::fs::write(&p, &bytes).unwrap();
    let e = read(&p, &ReadOptions { max_bytes: 8 << 30, series_uid: None }).unwrap_err();
    assert!(matches!(&e, Error::Truncated { path, field, .. } if path == &p && field == "voxel data"), "{e:?}");
}
