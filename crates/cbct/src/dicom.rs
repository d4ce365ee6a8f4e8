//! DICOM series (a folder, or one file; single- or multi-frame) in, one CT Image Storage file per
//! slice out. Slices are ordered by projecting Image Position Patient onto the slice normal, never
//! by file name or instance number. Pixel data is decoded by dicom-pixeldata (native transfer
//! syntaxes, JPEG baseline/lossless, RLE).

use crate::error::{Error, Result};
use crate::volume::{SourceInfo, Volume};
use crate::{check_cap, cross, dot, normalize, ReadOptions};
use dicom_core::value::{DataSetSequence, PrimitiveValue};
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::tags;
use dicom_object::{FileMetaTableBuilder, InMemDicomObject, OpenFileOptions};
use dicom_pixeldata::{ConvertOptions, ModalityLutOption, PixelDecoder};
use std::path::{Path, PathBuf};

/// One image plane: a file's frame with its geometry.
#[derive(Debug, Clone)]
struct Frame {
    file: PathBuf,
    frame: u32,
    series: String,
    rows: usize,
    cols: usize,
    /// (row spacing, column spacing) as in Pixel Spacing.
    pixel_spacing: [f64; 2],
    iop: [f64; 6],
    ipp: [f64; 3],
    slope: f64,
    intercept: f64,
    thickness: Option<f64>,
    /// (BitsAllocated, BitsStored, PixelRepresentation): how the stored values are read.
    layout: (Option<i64>, Option<i64>, Option<i64>),
    /// Pixel Data stored uncompressed (its size follows from rows, columns and bits).
    native: bool,
}

#[derive(Default)]
struct Facts {
    modality: Option<String>,
    manufacturer: Option<String>,
    model: Option<String>,
    transfer_syntax: Option<String>,
}

fn text(obj: &InMemDicomObject, tag: Tag) -> Option<String> {
    let e = obj.element_opt(tag).ok()??;
    let s = e.to_str().ok()?;
    let s = s.trim_matches(|c: char| c == '\0' || c.is_whitespace()).to_string();
    (!s.is_empty()).then_some(s)
}

fn floats(obj: &InMemDicomObject, tag: Tag) -> Option<Vec<f64>> {
    let e = obj.element_opt(tag).ok()??;
    e.to_multi_float64().ok().filter(|v| !v.is_empty() && v.iter().all(|x| x.is_finite()))
}

/// The element's text when it is present at all (for saying what an unreadable value was).
fn present(obj: &InMemDicomObject, tag: Tag) -> Option<String> {
    let e = obj.element_opt(tag).ok()??;
    Some(e.to_str().map(|s| s.trim_matches(|c: char| c == '\0' || c.is_whitespace()).to_string()).unwrap_or_default())
}

fn int(obj: &InMemDicomObject, tag: Tag) -> Option<i64> {
    obj.element_opt(tag).ok()??.to_int::<i64>().ok()
}

fn first_item(obj: &InMemDicomObject, seq: Tag) -> Option<&InMemDicomObject> {
    obj.element_opt(seq).ok()??.items()?.first()
}

/// Looks an attribute up in an Enhanced object's functional groups (per-frame first, then
/// shared), read by `read`.
fn fg_lookup<T>(obj: &InMemDicomObject, frame: usize, group: Tag, attr: Tag, read: impl Fn(&InMemDicomObject, Tag) -> Option<T>) -> Option<T> {
    let per = obj
        .element_opt(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE)
        .ok()
        .flatten()
        .and_then(|e| e.items())
        .and_then(|items| items.get(frame))
        .and_then(|it| first_item(it, group))
        .and_then(|g| read(g, attr));
    per.or_else(|| first_item(obj, tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE).and_then(|s| first_item(s, group)).and_then(|g| read(g, attr)))
}

fn fg_floats(obj: &InMemDicomObject, frame: usize, group: Tag, attr: Tag) -> Option<Vec<f64>> {
    fg_lookup(obj, frame, group, attr, floats)
}

/// Like [`fg_floats`], the text of an element present in the functional groups.
fn fg_present(obj: &InMemDicomObject, frame: usize, group: Tag, attr: Tag) -> Option<String> {
    fg_lookup(obj, frame, group, attr, present)
}

/// The file's element lengths fit in it (see `dicom_lengths`); a file that cannot be read passes,
/// for dicom-rs to say why.
fn checked_lengths(path: &Path) -> std::result::Result<(), String> {
    match std::fs::read(path) {
        Ok(bytes) => crate::dicom_lengths::check(&bytes),
        Err(_) => Ok(()),
    }
}

fn need<T>(v: Option<T>, path: &Path, field: &str, expected: &str) -> Result<T> {
    v.ok_or_else(|| Error::field(path, field, format!("missing or unreadable; expected {expected}")))
}

/// Frames of one file, or `Ok(None)` for a DICOM file without an image.
/// `native`: the file's transfer syntax stores pixels uncompressed.
fn frames_of(path: &Path, obj: &InMemDicomObject, native: bool) -> Result<Option<Vec<Frame>>> {
    let (Some(rows), Some(cols)) = (int(obj, tags::ROWS), int(obj, tags::COLUMNS)) else {
        return Ok(None);
    };
    if rows < 1 || cols < 1 {
        return Err(Error::field(path, "Rows/Columns", format!("expected positive sizes, found {rows}x{cols}")));
    }
    let nframes = int(obj, tags::NUMBER_OF_FRAMES).unwrap_or(1).max(1);
    if nframes > 100_000 {
        return Err(Error::field(path, "NumberOfFrames", format!("expected at most 100000, found {nframes}")));
    }
    let series = text(obj, tags::SERIES_INSTANCE_UID).unwrap_or_default();
    let enhanced = obj.element_opt(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE).ok().flatten().is_some();
    let mut out = Vec::new();
    for f in 0..nframes as usize {
        let get = |group: Tag, attr: Tag| if enhanced { fg_floats(obj, f, group, attr).or_else(|| floats(obj, attr)) } else { floats(obj, attr) };
        let ps = need(get(tags::PIXEL_MEASURES_SEQUENCE, tags::PIXEL_SPACING).filter(|v| v.len() >= 2), path, "PixelSpacing (0028,0030)", "2 numbers")?;
        let iop = need(get(tags::PLANE_ORIENTATION_SEQUENCE, tags::IMAGE_ORIENTATION_PATIENT).filter(|v| v.len() >= 6), path, "ImageOrientationPatient (0020,0037)", "6 numbers")?;
        let ipp = need(get(tags::PLANE_POSITION_SEQUENCE, tags::IMAGE_POSITION_PATIENT).filter(|v| v.len() >= 3), path, "ImagePositionPatient (0020,0032)", "3 numbers")?;
        // Absent rescale values default (1, 0); present but unreadable ones are errors, not defaults.
        let rescale = |attr: Tag, field: &str, default: f64| -> Result<f64> {
            if let Some(v) = get(tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE, attr).and_then(|v| v.first().copied()) {
                return Ok(v);
            }
            let text = if enhanced { fg_present(obj, f, tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE, attr).or_else(|| present(obj, attr)) } else { present(obj, attr) };
            match text {
                Some(t) if !t.is_empty() => Err(Error::field(path, field, format!("'{t}' is not a finite number"))),
                _ => Ok(default),
            }
        };
        let slope = rescale(tags::RESCALE_SLOPE, "RescaleSlope (0028,1053)", 1.0)?;
        let intercept = rescale(tags::RESCALE_INTERCEPT, "RescaleIntercept (0028,1052)", 0.0)?;
        if slope == 0.0 {
            return Err(Error::field(path, "RescaleSlope (0028,1053)", "0 would map every stored value to the intercept; expected a non-zero number"));
        }
        let thickness = get(tags::PIXEL_MEASURES_SEQUENCE, tags::SLICE_THICKNESS).and_then(|v| v.first().copied());
        if ps[0] <= 0.0 || ps[1] <= 0.0 {
            return Err(Error::field(path, "PixelSpacing (0028,0030)", format!("expected positive values, found {ps:?}")));
        }
        out.push(Frame {
            file: path.to_path_buf(),
            frame: f as u32,
            series: series.clone(),
            rows: rows as usize,
            cols: cols as usize,
            pixel_spacing: [ps[0], ps[1]],
            iop: [iop[0], iop[1], iop[2], iop[3], iop[4], iop[5]],
            ipp: [ipp[0], ipp[1], ipp[2]],
            slope,
            intercept,
            thickness,
            layout: (int(obj, tags::BITS_ALLOCATED), int(obj, tags::BITS_STORED), int(obj, tags::PIXEL_REPRESENTATION)),
            native,
        });
    }
    Ok(Some(out))
}

/// Reads a DICOM series from a folder (or a single DICOM file) into a volume.
pub fn read_dicom(path: &Path, opts: &ReadOptions) -> Result<Volume> {
    let mut files: Vec<PathBuf> = if path.is_dir() {
        let rd = std::fs::read_dir(path).map_err(|e| Error::io(path, e))?;
        let mut v = Vec::new();
        for e in rd {
            let e = e.map_err(|e| Error::io(path, e))?;
            if e.file_type().map(|t| t.is_file()).unwrap_or(false) {
                v.push(e.path());
            }
        }
        v
    } else {
        vec![path.to_path_buf()]
    };
    files.sort();
    if files.is_empty() {
        return Err(Error::EmptyFolder { path: path.to_path_buf() });
    }
    let single = !path.is_dir();
    let mut notes = Vec::new();
    let mut frames: Vec<Frame> = Vec::new();
    let mut facts = Facts::default();
    let mut non_image = Vec::new();
    // Files that were not DICOM at all: named in warnings, and blamed for a gap they sit in.
    let mut skipped: Vec<(PathBuf, String)> = Vec::new();
    for f in &files {
        let obj = match checked_lengths(f).and_then(|()| OpenFileOptions::new().read_until(tags::PIXEL_DATA).open_file(f).map_err(|e| e.to_string())) {
            Ok(o) => o,
            Err(e) => {
                if single {
                    return Err(Error::Dicom { path: f.clone(), message: format!("not a readable DICOM file: {e}") });
                }
                let reason = match std::fs::metadata(f) {
                    Ok(m) if m.len() == 0 => "zero bytes".to_string(),
                    _ => format!("not DICOM ({e})"),
                };
                notes.push(format!("skipped {}: {reason}", f.display()));
                skipped.push((f.clone(), reason));
                continue;
            }
        };
        let native = matches!(
            obj.meta().transfer_syntax().trim_end_matches('\0'),
            "1.2.840.10008.1.2" | "1.2.840.10008.1.2.1" | "1.2.840.10008.1.2.2"
        );
        match frames_of(f, &obj, native)? {
            Some(fr) => {
                if facts.modality.is_none() {
                    facts.modality = text(&obj, tags::MODALITY);
                    facts.manufacturer = text(&obj, tags::MANUFACTURER);
                    facts.model = text(&obj, tags::MANUFACTURER_MODEL_NAME);
                    facts.transfer_syntax = Some(obj.meta().transfer_syntax().trim_end_matches('\0').to_string());
                }
                frames.extend(fr)
            }
            None => {
                notes.push(format!("skipped {}: DICOM without an image (no Rows/Columns)", f.display()));
                non_image.push(f.clone());
            }
        }
    }
    if frames.is_empty() {
        if !non_image.is_empty() && (single || non_image.len() == 1) {
            return Err(Error::NonImage { path: non_image[0].clone() });
        }
        if !non_image.is_empty() {
            return Err(Error::NoImage { path: path.to_path_buf(), notes: format!("non-image DICOM: {}; {}", non_image.len(), notes.join("; ")) });
        }
        return Err(Error::NoImage { path: path.to_path_buf(), notes: notes.join("; ") });
    }
    // One series only.
    if let Some(uid) = &opts.series_uid {
        frames.retain(|f| &f.series == uid);
        if frames.is_empty() {
            return Err(Error::field(path, "SeriesInstanceUID (0020,000E)", format!("expected a series {uid}, none found")));
        }
    } else if let Some(other) = frames.iter().find(|f| f.series != frames[0].series) {
        return Err(Error::MixedSeries {
            folder: path.to_path_buf(),
            uid_a: frames[0].series.clone(),
            file_a: frames[0].file.clone(),
            uid_b: other.series.clone(),
            file_b: other.file.clone(),
        });
    }
    let first = frames[0].clone();
    for f in &frames[1..] {
        if (f.rows, f.cols) != (first.rows, first.cols) {
            return Err(Error::Inconsistent { path: f.file.clone(), field: "Rows/Columns".into(), expected: format!("{}x{}", first.rows, first.cols), found: format!("{}x{}", f.rows, f.cols) });
        }
        if (0..2).any(|i| (f.pixel_spacing[i] - first.pixel_spacing[i]).abs() > 1e-4 * first.pixel_spacing[i].max(1.0)) {
            return Err(Error::Inconsistent { path: f.file.clone(), field: "PixelSpacing (0028,0030)".into(), expected: format!("{:?}", first.pixel_spacing), found: format!("{:?}", f.pixel_spacing) });
        }
        if f.layout != first.layout {
            let show = |l: (Option<i64>, Option<i64>, Option<i64>)| {
                let v = |x: Option<i64>| x.map_or("absent".to_string(), |x| x.to_string());
                format!("{}/{}/{}", v(l.0), v(l.1), v(l.2))
            };
            return Err(Error::Inconsistent {
                path: f.file.clone(),
                field: "BitsAllocated/BitsStored/PixelRepresentation (0028,0100/0101/0103)".into(),
                expected: show(first.layout),
                found: show(f.layout),
            });
        }
        if (0..6).any(|i| (f.iop[i] - first.iop[i]).abs() > 1e-4) {
            return Err(Error::Inconsistent { path: f.file.clone(), field: "ImageOrientationPatient (0020,0037)".into(), expected: format!("{:?}", first.iop), found: format!("{:?}", f.iop) });
        }
    }
    let row_dir = normalize([first.iop[0], first.iop[1], first.iop[2]]);
    let col_dir = normalize([first.iop[3], first.iop[4], first.iop[5]]);
    let (Some((rd, _)), Some((cd, _))) = (row_dir, col_dir) else {
        return Err(Error::field(&first.file, "ImageOrientationPatient (0020,0037)", "expected two unit vectors"));
    };
    if dot(rd, cd).abs() > 1e-3 {
        return Err(Error::field(&first.file, "ImageOrientationPatient (0020,0037)", "expected orthogonal row and column directions"));
    }
    let normal = cross(rd, cd);
    let mut keyed: Vec<(f64, Frame)> = frames.into_iter().map(|f| (dot(f.ipp, normal), f)).collect();
    keyed.sort_by(|a, b| a.0.total_cmp(&b.0));
    let nz = keyed.len();
    let mut slice_spacing = first.thickness.filter(|t| *t > 0.0).unwrap_or(1.0);
    let mut slice_dir = normal;
    if nz > 1 {
        let gaps: Vec<f64> = keyed.windows(2).map(|w| w[1].0 - w[0].0).collect();
        let mut sorted = gaps.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        for (i, &g) in gaps.iter().enumerate() {
            let (a, b) = (&keyed[i], &keyed[i + 1]);
            if g < 1e-4 || median < 1e-4 {
                return Err(Error::Inconsistent { path: b.1.file.clone(), field: "ImagePositionPatient (0020,0032)".into(), expected: "distinct slice positions".into(), found: format!("same position as {} ({:.3} mm)", a.1.file.display(), a.0) });
            }
            if g > 1.5 * median {
                // An unreadable file named between the neighbours is the likely missing slice.
                let (lo, hi) = if a.1.file <= b.1.file { (&a.1.file, &b.1.file) } else { (&b.1.file, &a.1.file) };
                if let Some((bad, reason)) = skipped.iter().find(|(s, _)| s > lo && s < hi) {
                    return Err(Error::BadSlice { path: bad.clone(), reason: reason.clone(), file_a: a.1.file.clone(), file_b: b.1.file.clone() });
                }
                return Err(Error::MissingSlice { folder: path.to_path_buf(), file_a: a.1.file.clone(), file_b: b.1.file.clone(), pos_a: a.0, pos_b: b.0, gap: g, expected: median });
            }
            if (g - median).abs() > 0.1 * median {
                return Err(Error::Inconsistent { path: b.1.file.clone(), field: "slice spacing (from ImagePositionPatient)".into(), expected: format!("{median:.4} mm"), found: format!("{g:.4} mm after {}", a.1.file.display()) });
            }
        }
        let (p0, p1) = (keyed[0].1.ipp, keyed[nz - 1].1.ipp);
        let (dir, len) = normalize([p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]]).ok_or_else(|| Error::field(path, "ImagePositionPatient (0020,0032)", "all slices at one position"))?;
        slice_dir = dir;
        slice_spacing = len / (nz - 1) as f64;
    }
    let dims = [first.cols, first.rows, nz];
    let n = check_cap(path, [dims[0] as u64, dims[1] as u64, dims[2] as u64], opts)?;
    let plane = first.cols * first.rows;
    // Before allocating the volume: an uncompressed file must hold its frames' pixels, so a small
    // file whose header claims a huge image is refused here, by name.
    for (_, f) in keyed.iter().filter(|(_, f)| f.native && f.frame == 0) {
        let frames = keyed.iter().filter(|(_, g)| g.file == f.file).count() as u64;
        let bits = f.layout.0.unwrap_or(16).max(1) as u64;
        let need = (plane as u64).saturating_mul(frames).saturating_mul(bits) / 8;
        let size = std::fs::metadata(&f.file).map_err(|e| Error::io(&f.file, e))?.len();
        if size < need {
            return Err(Error::Truncated { path: f.file.clone(), field: format!("Pixel Data (7FE0,0010) of {}x{}x{frames} at {bits} bits", f.cols, f.rows), expected: need, found: size });
        }
    }
    let mut values = vec![0f32; n];
    // Decode each file once, placing its frames where the sort put them.
    let mut slot: std::collections::HashMap<(PathBuf, u32), usize> = std::collections::HashMap::new();
    for (k, (_, f)) in keyed.iter().enumerate() {
        slot.insert((f.file.clone(), f.frame), k);
    }
    let mut by_file: Vec<PathBuf> = keyed.iter().map(|(_, f)| f.file.clone()).collect();
    by_file.sort();
    by_file.dedup();
    for file in &by_file {
        let obj = checked_lengths(file)
            .and_then(|()| OpenFileOptions::new().open_file(file).map_err(|e| e.to_string()))
            .map_err(|e| Error::Dicom { path: file.clone(), message: format!("cannot read: {e}") })?;
        if obj.element_opt(tags::PIXEL_DATA).ok().flatten().is_none() {
            return Err(Error::NonImage { path: file.clone() });
        }
        let decoded = obj.decode_pixel_data().map_err(|e| Error::Dicom { path: file.clone(), message: format!("Pixel Data (7FE0,0010): cannot decode: {e}") })?;
        if decoded.samples_per_pixel() != 1 {
            return Err(Error::field(file, "SamplesPerPixel (0028,0002)", format!("expected 1, found {}", decoded.samples_per_pixel())));
        }
        let raw_opts = ConvertOptions::new().with_modality_lut(ModalityLutOption::None);
        for (_, f) in keyed.iter().filter(|(_, f)| &f.file == file) {
            let k = slot[&(f.file.clone(), f.frame)];
            let px: Vec<f32> = decoded
                .to_vec_frame_with_options(f.frame, &raw_opts)
                .map_err(|e| Error::Truncated { path: file.clone(), field: format!("Pixel Data frame {} ({e})", f.frame), expected: (plane * 2) as u64, found: 0 })?;
            if px.len() < plane {
                return Err(Error::Truncated { path: file.clone(), field: format!("Pixel Data frame {}", f.frame), expected: plane as u64, found: px.len() as u64 });
            }
            let (s, b) = (f.slope as f32, f.intercept as f32);
            for (dst, &v) in values[k * plane..(k + 1) * plane].iter_mut().zip(&px) {
                *dst = v * s + b;
            }
        }
    }
    let source = SourceInfo {
        format: "dicom".into(),
        path: path.to_string_lossy().into_owned(),
        modality: facts.modality,
        manufacturer: facts.manufacturer,
        model: facts.model,
        series_uid: Some(first.series.clone()),
        encoding: facts.transfer_syntax,
        notes,
    };
    let vol = Volume {
        dims,
        spacing: [first.pixel_spacing[1], first.pixel_spacing[0], slice_spacing],
        origin: keyed[0].1.ipp,
        direction: [rd, cd, slice_dir],
        values,
        source,
    };
    vol.check_nan(path)?;
    Ok(vol)
}

/// A fresh UID under the 2.25 (UUID-derived) root.
pub fn new_uid() -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let t = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let c = COUNTER.fetch_add(1, Ordering::Relaxed) as u128;
    let mut x = t ^ ((std::process::id() as u128) << 96) ^ (c << 64) ^ c.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    // splitmix-style scramble so consecutive UIDs do not share long prefixes
    x ^= x >> 61;
    x = x.wrapping_mul(0x2545_F491_4F6C_DD1D_9E37_79B9_7F4A_7C15);
    x ^= x >> 67;
    format!("2.25.{}", x >> 1)
}

/// A DS value within the 16-character limit.
fn ds(x: f64) -> String {
    for prec in (0..=10).rev() {
        let s = format!("{x:.prec$}");
        let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
        let s = if s == "-0" { "0".to_string() } else { s };
        if s.len() <= 16 {
            return s;
        }
    }
    format!("{x:.3e}")
}

fn ds_multi(v: &[f64]) -> PrimitiveValue {
    PrimitiveValue::Strs(v.iter().map(|&x| ds(x)).collect())
}

fn put_str(obj: &mut InMemDicomObject, tag: Tag, vr: VR, s: &str) {
    obj.put(DataElement::new(tag, vr, PrimitiveValue::from(s)));
}

/// The Image Pixel module of our files: one sample, MONOCHROME2, signed 16-bit, a k-slice's rows
/// and columns.
fn put_image_pixel_module(o: &mut InMemDicomObject, vol: &Volume) {
    o.put(DataElement::new(tags::SAMPLES_PER_PIXEL, VR::US, PrimitiveValue::from(1u16)));
    put_str(o, tags::PHOTOMETRIC_INTERPRETATION, VR::CS, "MONOCHROME2");
    o.put(DataElement::new(tags::ROWS, VR::US, PrimitiveValue::from(vol.dims[1] as u16)));
    o.put(DataElement::new(tags::COLUMNS, VR::US, PrimitiveValue::from(vol.dims[0] as u16)));
    o.put(DataElement::new(tags::BITS_ALLOCATED, VR::US, PrimitiveValue::from(16u16)));
    o.put(DataElement::new(tags::BITS_STORED, VR::US, PrimitiveValue::from(16u16)));
    o.put(DataElement::new(tags::HIGH_BIT, VR::US, PrimitiveValue::from(15u16)));
    o.put(DataElement::new(tags::PIXEL_REPRESENTATION, VR::US, PrimitiveValue::from(1u16)));
}

/// Writes one CT Image Storage file per k-slice (explicit VR little endian, int16 with rescale).
/// The series is built in a temporary folder and renamed into place.
pub fn write_dicom_series(vol: &Volume, dir: &Path) -> Result<()> {
    if vol.dims.iter().any(|&d| d == 0) || vol.dims[0] > u16::MAX as usize || vol.dims[1] > u16::MAX as usize {
        return Err(Error::invalid("volume dims", format!("{:?} cannot be written as DICOM", vol.dims)));
    }
    if dir.exists() {
        let empty = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?.next().is_none();
        if !empty {
            return Err(Error::invalid("output folder", format!("{} exists and is not empty", dir.display())));
        }
    }
    let (lo, hi) = vol.min_max();
    let integral = vol.values.iter().all(|v| v.fract() == 0.0) && lo >= i16::MIN as f32 && hi <= i16::MAX as f32;
    let (slope, intercept) = if integral {
        (1.0f64, 0.0f64)
    } else {
        let mid = ((lo as f64 + hi as f64) / 2.0).round();
        let half = (hi as f64 - mid).max(mid - lo as f64).max(1e-6);
        (half / 32000.0, mid)
    };
    let study = new_uid();
    let series = new_uid();
    let frame_of_ref = new_uid();
    let tmp = crate::temp_sibling(dir);
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).map_err(|e| Error::io(&tmp, e))?;
    let plane = vol.dims[0] * vol.dims[1];
    let write_all = || -> Result<()> {
        for k in 0..vol.dims[2] {
            let sop = new_uid();
            let mut o = InMemDicomObject::new_empty();
            put_str(&mut o, tags::SOP_CLASS_UID, VR::UI, "1.2.840.10008.5.1.4.1.1.2");
            put_str(&mut o, tags::SOP_INSTANCE_UID, VR::UI, &sop);
            put_str(&mut o, tags::STUDY_INSTANCE_UID, VR::UI, &study);
            put_str(&mut o, tags::SERIES_INSTANCE_UID, VR::UI, &series);
            put_str(&mut o, tags::FRAME_OF_REFERENCE_UID, VR::UI, &frame_of_ref);
            put_str(&mut o, tags::MODALITY, VR::CS, "CT");
            put_str(&mut o, tags::MANUFACTURER, VR::LO, "dentsim");
            put_str(&mut o, tags::IMAGE_TYPE, VR::CS, "DERIVED\\SECONDARY\\AXIAL");
            put_str(&mut o, tags::PATIENT_NAME, VR::PN, "");
            put_str(&mut o, tags::PATIENT_ID, VR::LO, "");
            put_str(&mut o, tags::STUDY_DATE, VR::DA, "");
            put_str(&mut o, tags::STUDY_TIME, VR::TM, "");
            put_str(&mut o, tags::SERIES_NUMBER, VR::IS, "1");
            put_str(&mut o, tags::INSTANCE_NUMBER, VR::IS, &(k + 1).to_string());
            let p = vol.voxel_center(0, 0, k);
            o.put(DataElement::new(tags::IMAGE_POSITION_PATIENT, VR::DS, ds_multi(&p)));
            let d = vol.direction;
            o.put(DataElement::new(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, ds_multi(&[d[0][0], d[0][1], d[0][2], d[1][0], d[1][1], d[1][2]])));
            o.put(DataElement::new(tags::PIXEL_SPACING, VR::DS, ds_multi(&[vol.spacing[1], vol.spacing[0]])));
            o.put(DataElement::new(tags::SLICE_THICKNESS, VR::DS, ds_multi(&[vol.spacing[2]])));
            o.put(DataElement::new(tags::SPACING_BETWEEN_SLICES, VR::DS, ds_multi(&[vol.spacing[2]])));
            o.put(DataElement::new(tags::SLICE_LOCATION, VR::DS, ds_multi(&[p[2]])));
            o.put(DataElement::new(tags::RESCALE_INTERCEPT, VR::DS, ds_multi(&[intercept])));
            o.put(DataElement::new(tags::RESCALE_SLOPE, VR::DS, PrimitiveValue::from(format!("{slope:.9e}").as_str())));
            put_str(&mut o, tags::RESCALE_TYPE, VR::LO, "US");
            put_image_pixel_module(&mut o, vol);
            let mut bytes = Vec::with_capacity(plane * 2);
            for &v in &vol.values[k * plane..(k + 1) * plane] {
                let q = ((v as f64 - intercept) / slope).round().clamp(i16::MIN as f64, i16::MAX as f64) as i16;
                bytes.extend_from_slice(&q.to_le_bytes());
            }
            o.put(DataElement::new(tags::PIXEL_DATA, VR::OW, PrimitiveValue::from(bytes)));
            let file = o
                .with_meta(FileMetaTableBuilder::new().transfer_syntax("1.2.840.10008.1.2.1").implementation_class_uid("2.25.1"))
                .map_err(|e| Error::Dicom { path: tmp.clone(), message: format!("file meta: {e}") })?;
            let name = tmp.join(format!("slice_{k:05}.dcm"));
            file.write_to_file(&name).map_err(|e| Error::Dicom { path: name.clone(), message: format!("cannot write: {e}") })?;
        }
        Ok(())
    };
    if let Err(e) = write_all() {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    if dir.exists() {
        let _ = std::fs::remove_dir(dir);
    }
    std::fs::rename(&tmp, dir).map_err(|e| {
        let _ = std::fs::remove_dir_all(&tmp);
        Error::io(dir, e)
    })
}

/// Writes the volume as one Enhanced CT multi-frame file (frames along k, per-frame Plane Position).
/// Mainly so the multi-frame reader is tested on a file that round-trips through dicom-rs.
pub fn write_dicom_multiframe(vol: &Volume, file: &Path) -> Result<()> {
    let plane = vol.dims[0] * vol.dims[1];
    let mut o = InMemDicomObject::new_empty();
    put_str(&mut o, tags::SOP_CLASS_UID, VR::UI, "1.2.840.10008.5.1.4.1.1.2.1");
    put_str(&mut o, tags::SOP_INSTANCE_UID, VR::UI, &new_uid());
    put_str(&mut o, tags::STUDY_INSTANCE_UID, VR::UI, &new_uid());
    put_str(&mut o, tags::SERIES_INSTANCE_UID, VR::UI, &new_uid());
    put_str(&mut o, tags::MODALITY, VR::CS, "CT");
    put_str(&mut o, tags::MANUFACTURER, VR::LO, "dentsim");
    put_str(&mut o, tags::NUMBER_OF_FRAMES, VR::IS, &vol.dims[2].to_string());
    let d = vol.direction;
    let mut shared = InMemDicomObject::new_empty();
    let mut orient = InMemDicomObject::new_empty();
    orient.put(DataElement::new(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, ds_multi(&[d[0][0], d[0][1], d[0][2], d[1][0], d[1][1], d[1][2]])));
    let mut meas = InMemDicomObject::new_empty();
    meas.put(DataElement::new(tags::PIXEL_SPACING, VR::DS, ds_multi(&[vol.spacing[1], vol.spacing[0]])));
    meas.put(DataElement::new(tags::SLICE_THICKNESS, VR::DS, ds_multi(&[vol.spacing[2]])));
    let mut pvt = InMemDicomObject::new_empty();
    pvt.put(DataElement::new(tags::RESCALE_INTERCEPT, VR::DS, ds_multi(&[0.0])));
    pvt.put(DataElement::new(tags::RESCALE_SLOPE, VR::DS, ds_multi(&[1.0])));
    shared.put(DataElement::new(tags::PLANE_ORIENTATION_SEQUENCE, VR::SQ, DataSetSequence::from(vec![orient])));
    shared.put(DataElement::new(tags::PIXEL_MEASURES_SEQUENCE, VR::SQ, DataSetSequence::from(vec![meas])));
    shared.put(DataElement::new(tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE, VR::SQ, DataSetSequence::from(vec![pvt])));
    o.put(DataElement::new(tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE, VR::SQ, DataSetSequence::from(vec![shared])));
    let per: Vec<InMemDicomObject> = (0..vol.dims[2])
        .map(|k| {
            let mut pos = InMemDicomObject::new_empty();
            pos.put(DataElement::new(tags::IMAGE_POSITION_PATIENT, VR::DS, ds_multi(&vol.voxel_center(0, 0, k))));
            let mut item = InMemDicomObject::new_empty();
            item.put(DataElement::new(tags::PLANE_POSITION_SEQUENCE, VR::SQ, DataSetSequence::from(vec![pos])));
            item
        })
        .collect();
    o.put(DataElement::new(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE, VR::SQ, DataSetSequence::from(per)));
    put_image_pixel_module(&mut o, vol);
    let mut bytes = Vec::with_capacity(plane * vol.dims[2] * 2);
    for &v in &vol.values {
        bytes.extend_from_slice(&(v.round().clamp(-32768.0, 32767.0) as i16).to_le_bytes());
    }
    o.put(DataElement::new(tags::PIXEL_DATA, VR::OW, PrimitiveValue::from(bytes)));
    let fo = o
        .with_meta(FileMetaTableBuilder::new().transfer_syntax("1.2.840.10008.1.2.1").implementation_class_uid("2.25.1"))
        .map_err(|e| Error::Dicom { path: file.to_path_buf(), message: format!("file meta: {e}") })?;
    dentsim_atomic::write_via(file, |staged| {
        fo.write_to_file(staged).map_err(|e| Error::Dicom { path: file.to_path_buf(), message: format!("cannot write: {e}") })
    })
}
