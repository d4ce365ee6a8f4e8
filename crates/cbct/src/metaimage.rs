//! MetaImage (`.mha` with LOCAL data, `.mhd` + `.raw`/`.zraw`). ITK's convention: the header's
//! Offset and TransformMatrix are in LPS, and TransformMatrix row c is the direction of index axis c.

use crate::error::{Error, Result};
use crate::nifti::{convert, read_full};
use crate::volume::{SourceInfo, Volume};
use crate::{check_cap, normalize, ReadOptions};
use std::collections::HashMap;
use std::io::{BufRead, Read, Seek, SeekFrom};
use std::path::Path;

fn nums(path: &Path, key: &str, v: &str, n: usize) -> Result<Vec<f64>> {
    let out: std::result::Result<Vec<f64>, _> = v.split_whitespace().map(|s| s.parse::<f64>()).collect();
    match out {
        Ok(o) if o.len() >= n && o.iter().all(|x| x.is_finite()) => Ok(o),
        _ => Err(Error::field(path, key, format!("expected {n} finite numbers, found \"{v}\""))),
    }
}

/// Reads a MetaImage volume (scalar, 2-D or 3-D).
pub fn read_metaimage(path: &Path, opts: &ReadOptions) -> Result<Volume> {
    let io = |e| Error::io(path, e);
    let file = std::fs::File::open(path).map_err(io)?;
    let total = file.metadata().map_err(io)?.len();
    let mut r = std::io::BufReader::new(file);
    let mut keys: HashMap<String, String> = HashMap::new();
    let mut header_len = 0u64;
    let mut line = Vec::new();
    loop {
        line.clear();
        let n = (&mut r).take(4096).read_until(b'\n', &mut line).map_err(io)?;
        if n == 0 {
            return Err(Error::field(path, "ElementDataFile", "header ended without ElementDataFile (expected as the last header line)"));
        }
        header_len += n as u64;
        let text = String::from_utf8_lossy(&line);
        let Some((k, v)) = text.split_once('=') else {
            if text.trim().is_empty() {
                continue;
            }
            return Err(Error::field(path, "header", format!("expected \"Key = Value\", found \"{}\"", text.trim())));
        };
        let (k, v) = (k.trim().to_string(), v.trim().to_string());
        let last = k == "ElementDataFile";
        keys.insert(k, v);
        if last {
            break;
        }
        if keys.len() > 200 {
            return Err(Error::field(path, "header", "more than 200 keys; not a MetaImage header"));
        }
    }
    let get = |k: &str| keys.get(k).map(|s| s.as_str());
    if let Some(t) = get("ObjectType") {
        if !t.eq_ignore_ascii_case("image") {
            return Err(Error::field(path, "ObjectType", format!("expected Image, found {t}")));
        }
    }
    let nd = get("NDims").ok_or_else(|| Error::field(path, "NDims", "missing"))?;
    let nd: usize = nd.parse().map_err(|_| Error::field(path, "NDims", format!("expected 2 or 3, found {nd}")))?;
    if nd == 4 {
        return Err(Error::FourD { path: path.into(), dims: vec![4] });
    }
    if !(2..=3).contains(&nd) {
        return Err(Error::field(path, "NDims", format!("expected 2 or 3, found {nd}")));
    }
    let ds = nums(path, "DimSize", get("DimSize").unwrap_or(""), nd)?;
    if ds.iter().any(|&d| d < 1.0 || d.fract() != 0.0) {
        return Err(Error::field(path, "DimSize", format!("expected positive integers, found {ds:?}")));
    }
    let dims = [ds[0] as usize, ds[1] as usize, if nd == 3 { ds[2] as usize } else { 1 }];
    let channels = get("ElementNumberOfChannels").unwrap_or("1");
    if channels != "1" {
        return Err(Error::field(path, "ElementNumberOfChannels", format!("expected 1, found {channels}")));
    }
    let mut spacing = [1.0; 3];
    if let Some(s) = get("ElementSpacing").or(get("ElementSize")) {
        let s = nums(path, "ElementSpacing", s, nd)?;
        spacing[..nd].copy_from_slice(&s[..nd]);
    }
    if spacing.iter().any(|&s| s <= 0.0) {
        return Err(Error::field(path, "ElementSpacing", format!("expected positive values, found {spacing:?}")));
    }
    let mut origin = [0.0; 3];
    for k in ["Offset", "Position", "Origin"] {
        if let Some(s) = get(k) {
            let o = nums(path, k, s, nd)?;
            origin[..nd].copy_from_slice(&o[..nd]);
            break;
        }
    }
    let mut direction = crate::volume::IDENTITY;
    for k in ["TransformMatrix", "Rotation", "Orientation"] {
        if let Some(s) = get(k) {
            let m = nums(path, k, s, nd * nd)?;
            for c in 0..nd {
                let mut v = [0.0; 3];
                v[..nd].copy_from_slice(&m[c * nd..c * nd + nd]);
                direction[c] = normalize(v).ok_or_else(|| Error::field(path, k, format!("axis {c} is a zero vector")))?.0;
            }
            break;
        }
    }
    let et = get("ElementType").ok_or_else(|| Error::field(path, "ElementType", "missing"))?;
    let (esize, kind) = match et {
        "MET_UCHAR" => (1, "uint8"),
        "MET_CHAR" => (1, "int8"),
        "MET_SHORT" => (2, "int16"),
        "MET_USHORT" => (2, "uint16"),
        "MET_INT" | "MET_LONG" => (4, "int32"),
        "MET_UINT" | "MET_ULONG" => (4, "uint32"),
        "MET_FLOAT" => (4, "float32"),
        "MET_DOUBLE" => (8, "float64"),
        "MET_LONG_LONG" => (8, "int64"),
        "MET_ULONG_LONG" => (8, "uint64"),
        _ => return Err(Error::field(path, "ElementType", format!("expected MET_UCHAR/CHAR/SHORT/USHORT/INT/UINT/FLOAT/DOUBLE, found {et}"))),
    };
    let truthy = |k: &str| get(k).map(|v| v.eq_ignore_ascii_case("true") || v == "1").unwrap_or(false);
    let msb = truthy("BinaryDataByteOrderMSB") || truthy("ElementByteOrderMSB");
    let compressed = truthy("CompressedData");
    if let Some(b) = get("BinaryData") {
        if !(b.eq_ignore_ascii_case("true") || b == "1") {
            return Err(Error::field(path, "BinaryData", format!("is \"{b}\": ASCII voxel values are not supported; expected True (binary)")));
        }
    }
    let n = check_cap(path, [dims[0] as u64, dims[1] as u64, dims[2] as u64], opts)?;
    let need = (n * esize) as u64;
    let edf = get("ElementDataFile").unwrap_or("");
    let header_size: i64 = get("HeaderSize").and_then(|s| s.parse().ok()).unwrap_or(0);
    let (mut data, data_path, data_len): (Box<dyn Read>, std::path::PathBuf, u64) = if edf.eq_ignore_ascii_case("LOCAL") {
        (Box::new(r), path.to_path_buf(), total - header_len)
    } else if edf.eq_ignore_ascii_case("LIST") || edf.contains('%') {
        return Err(Error::field(path, "ElementDataFile", format!("expected LOCAL or one file name, found \"{edf}\" (file lists are not supported)")));
    } else {
        let dp = path.parent().unwrap_or(Path::new(".")).join(edf);
        let mut f = std::fs::File::open(&dp).map_err(|e| Error::io(&dp, e))?;
        let len = f.metadata().map_err(|e| Error::io(&dp, e))?.len();
        let skip = if header_size == -1 && !compressed { len.saturating_sub(need) } else { header_size.max(0) as u64 };
        f.seek(SeekFrom::Start(skip)).map_err(|e| Error::io(&dp, e))?;
        (Box::new(std::io::BufReader::new(f)), dp, len.saturating_sub(skip))
    };
    if compressed {
        data = Box::new(flate2::read::ZlibDecoder::new(data));
    } else if data_len < need {
        return Err(Error::Truncated { path: data_path, field: "element data".into(), expected: need, found: data_len });
    }
    let mut values = Vec::with_capacity(n);
    let mut chunk = vec![0u8; (1 << 20) / esize * esize];
    let mut done = 0u64;
    while done < need {
        let want = (chunk.len() as u64).min(need - done) as usize;
        let got = read_full(&mut *data, &mut chunk[..want]).map_err(|e| Error::field(&data_path, "element data", format!("cannot decode: {e}")))?;
        convert(kind, msb, &chunk[..got - got % esize], &mut values);
        done += got as u64;
        if got < want {
            return Err(Error::Truncated { path: data_path, field: "element data".into(), expected: need, found: done });
        }
    }
    let source = SourceInfo {
        format: "metaimage".into(),
        path: path.to_string_lossy().into_owned(),
        modality: get("Modality").map(|s| s.to_string()),
        encoding: Some(format!("{et}{}{}", if msb { " MSB" } else { "" }, if compressed { " zlib" } else { "" })),
        ..Default::default()
    };
    let vol = Volume { dims, spacing, origin, direction, values, source };
    vol.check_nan(path)?;
    Ok(vol)
}

fn header_text(vol: &Volume, data_file: &str, compressed: Option<usize>) -> String {
    let d = &vol.direction;
    let f = |v: &[f64]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" ");
    let mut s = String::new();
    s += "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n";
    match compressed {
        Some(n) => s += &format!("CompressedData = True\nCompressedDataSize = {n}\n"),
        None => s += "CompressedData = False\n",
    }
    s += &format!("TransformMatrix = {}\n", f(&[d[0][0], d[0][1], d[0][2], d[1][0], d[1][1], d[1][2], d[2][0], d[2][1], d[2][2]]));
    s += &format!("Offset = {}\nCenterOfRotation = 0 0 0\nAnatomicalOrientation = RAI\n", f(&vol.origin));
    s += &format!("ElementSpacing = {}\nDimSize = {} {} {}\n", f(&vol.spacing), vol.dims[0], vol.dims[1], vol.dims[2]);
    s += &format!("ElementType = MET_FLOAT\nElementDataFile = {data_file}\n");
    s
}

fn payload(vol: &Volume, compress: bool) -> std::io::Result<Vec<u8>> {
    let mut raw = Vec::with_capacity(vol.values.len() * 4);
    vol.values.iter().for_each(|v| raw.extend_from_slice(&v.to_le_bytes()));
    if !compress {
        return Ok(raw);
    }
    let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut enc, &raw)?;
    enc.finish()
}

/// Writes MET_FLOAT, uncompressed: `.mha` (one file) or `.mhd` + `.raw`.
pub fn write_metaimage(vol: &Volume, path: &Path) -> Result<()> {
    write_metaimage_with(vol, path, false)
}

/// Same as [`write_metaimage`] with zlib-compressed data (`.mhd` gets a `.zraw` beside it).
pub fn write_metaimage_compressed(vol: &Volume, path: &Path) -> Result<()> {
    write_metaimage_with(vol, path, true)
}

fn write_metaimage_with(vol: &Volume, path: &Path, compress: bool) -> Result<()> {
    let data = payload(vol, compress).map_err(|e| Error::io(path, e))?;
    let clen = compress.then_some(data.len());
    let lower = path.to_string_lossy().to_lowercase();
    if lower.ends_with(".mha") {
        let head = header_text(vol, "LOCAL", clen);
        Ok(dentsim_atomic::write(path, |w| {
            w.write_all(head.as_bytes())?;
            w.write_all(&data)
        })?)
    } else if lower.ends_with(".mhd") {
        let raw_path = path.with_extension(if compress { "zraw" } else { "raw" });
        let raw_name = raw_path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        dentsim_atomic::write(&raw_path, |w| w.write_all(&data))?;
        let head = header_text(vol, &raw_name, clen);
        Ok(dentsim_atomic::write(path, |w| w.write_all(head.as_bytes())).inspect_err(|_| {
            let _ = std::fs::remove_file(&raw_path);
        })?)
    } else {
        Err(Error::invalid("path", format!("{}: expected .mha or .mhd", path.display())))
    }
}
