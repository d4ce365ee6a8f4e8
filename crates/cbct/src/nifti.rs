//! NIfTI-1 and NIfTI-2 (`.nii`, `.nii.gz`), read and written here rather than through the `nifti`
//! crate: that crate reads NIfTI-1 only (nibabel ships NIfTI-2 examples) and allocates the volume
//! before we could check the memory cap. Cost: one streaming pass over the file.

use crate::error::{Error, Result};
use crate::volume::{SourceInfo, Volume};
use crate::{check_cap, normalize, ReadOptions};
use flate2::read::GzDecoder;
use std::io::Read;
use std::path::Path;

struct Header {
    version: u8,
    big_endian: bool,
    dims: Vec<i64>,
    datatype: i16,
    pixdim: [f64; 8],
    vox_offset: u64,
    scl_slope: f64,
    scl_inter: f64,
    xyzt_units: i32,
    qform_code: i32,
    sform_code: i32,
    quatern: [f64; 3],
    qoffset: [f64; 3],
    srow: [[f64; 4]; 3],
}

struct Bytes<'a> {
    b: &'a [u8],
    be: bool,
}
impl Bytes<'_> {
    fn arr<const N: usize>(&self, at: usize) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&self.b[at..at + N]);
        if self.be {
            a.reverse();
        }
        a
    }
    fn i16(&self, at: usize) -> i16 {
        i16::from_le_bytes(self.arr(at))
    }
    fn i32(&self, at: usize) -> i32 {
        i32::from_le_bytes(self.arr(at))
    }
    fn i64(&self, at: usize) -> i64 {
        i64::from_le_bytes(self.arr(at))
    }
    fn f32(&self, at: usize) -> f64 {
        f32::from_le_bytes(self.arr(at)) as f64
    }
    fn f64(&self, at: usize) -> f64 {
        f64::from_le_bytes(self.arr(at))
    }
}

fn parse_header(path: &Path, b: &[u8]) -> Result<Header> {
    let le = |o: usize| i32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
    let be = |o: usize| i32::from_be_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
    let (version, big_endian) = match (le(0), be(0)) {
        (348, _) => (1, false),
        (_, 348) => (1, true),
        (540, _) => (2, false),
        (_, 540) => (2, true),
        (v, _) => return Err(Error::field(path, "sizeof_hdr", format!("expected 348 (NIfTI-1) or 540 (NIfTI-2), found {v}"))),
    };
    let r = Bytes { b, be: big_endian };
    let h = if version == 1 {
        if &b[344..346] != b"n+" && &b[344..346] != b"ni" {
            return Err(Error::field(path, "magic", "expected \"n+1\" or \"ni1\""));
        }
        let mut pixdim = [0.0; 8];
        for (i, p) in pixdim.iter_mut().enumerate() {
            *p = r.f32(76 + 4 * i);
        }
        let mut srow = [[0.0; 4]; 3];
        for (row, s) in srow.iter_mut().enumerate() {
            for (c, v) in s.iter_mut().enumerate() {
                *v = r.f32(280 + 16 * row + 4 * c);
            }
        }
        Header {
            version,
            big_endian,
            dims: (0..8).map(|i| r.i16(40 + 2 * i) as i64).collect(),
            datatype: r.i16(70),
            pixdim,
            vox_offset: r.f32(108).max(0.0) as u64,
            scl_slope: r.f32(112),
            scl_inter: r.f32(116),
            xyzt_units: b[123] as i32,
            qform_code: r.i16(252) as i32,
            sform_code: r.i16(254) as i32,
            quatern: [r.f32(256), r.f32(260), r.f32(264)],
            qoffset: [r.f32(268), r.f32(272), r.f32(276)],
            srow,
        }
    } else {
        let mut pixdim = [0.0; 8];
        for (i, p) in pixdim.iter_mut().enumerate() {
            *p = r.f64(104 + 8 * i);
        }
        let mut srow = [[0.0; 4]; 3];
        for (row, s) in srow.iter_mut().enumerate() {
            for (c, v) in s.iter_mut().enumerate() {
                *v = r.f64(400 + 32 * row + 8 * c);
            }
        }
        Header {
            version,
            big_endian,
            dims: (0..8).map(|i| r.i64(16 + 8 * i)).collect(),
            datatype: r.i16(12),
            pixdim,
            vox_offset: r.i64(168).max(0) as u64,
            scl_slope: r.f64(176),
            scl_inter: r.f64(184),
            xyzt_units: r.i32(500),
            qform_code: r.i32(344),
            sform_code: r.i32(348),
            quatern: [r.f64(352), r.f64(360), r.f64(368)],
            qoffset: [r.f64(376), r.f64(384), r.f64(392)],
            srow,
        }
    };
    Ok(h)
}

/// Bytes per element and a converter to f32 for a NIfTI datatype code.
fn element(path: &Path, datatype: i16) -> Result<(usize, &'static str)> {
    Ok(match datatype {
        2 => (1, "uint8"),
        256 => (1, "int8"),
        4 => (2, "int16"),
        512 => (2, "uint16"),
        8 => (4, "int32"),
        768 => (4, "uint32"),
        16 => (4, "float32"),
        64 => (8, "float64"),
        1024 => (8, "int64"),
        1280 => (8, "uint64"),
        d => return Err(Error::field(path, "datatype", format!("expected a real scalar type (2,4,8,16,64,256,512,768,1024,1280), found {d}"))),
    })
}

pub(crate) fn convert(kind: &str, big_endian: bool, raw: &[u8], out: &mut Vec<f32>) {
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            out.extend(raw.chunks_exact($n).map(|c| {
                let mut a = [0u8; $n];
                a.copy_from_slice(c);
                (if big_endian { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }) as f32
            }))
        };
    }
    match kind {
        "uint8" => out.extend(raw.iter().map(|&v| v as f32)),
        "int8" => out.extend(raw.iter().map(|&v| v as i8 as f32)),
        "int16" => conv!(i16, 2),
        "uint16" => conv!(u16, 2),
        "int32" => conv!(i32, 4),
        "uint32" => conv!(u32, 4),
        "float32" => conv!(f32, 4),
        "float64" => conv!(f64, 8),
        "int64" => conv!(i64, 8),
        "uint64" => conv!(u64, 8),
        _ => {}
    }
}

/// Reads until `buf` is full or the stream ends; returns how many bytes were read.
pub(crate) fn read_full(r: &mut dyn Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// Reads a NIfTI-1/2 volume, applying scl_slope/inter and the sform (or qform), converted RAS → LPS.
pub fn read_nifti(path: &Path, opts: &ReadOptions) -> Result<Volume> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let gz = path.to_string_lossy().to_lowercase().ends_with(".gz");
    let mut r: Box<dyn Read> = if gz { Box::new(GzDecoder::new(std::io::BufReader::new(file))) } else { Box::new(std::io::BufReader::new(file)) };
    let io = |e| Error::io(path, e);
    let mut hb = vec![0u8; 540];
    let got = read_full(&mut *r, &mut hb[..348]).map_err(io)?;
    if got < 348 {
        return Err(Error::Truncated { path: path.into(), field: "header".into(), expected: 348, found: got as u64 });
    }
    let is2 = i32::from_le_bytes([hb[0], hb[1], hb[2], hb[3]]) == 540 || i32::from_be_bytes([hb[0], hb[1], hb[2], hb[3]]) == 540;
    let mut consumed = 348u64;
    if is2 {
        let got = read_full(&mut *r, &mut hb[348..540]).map_err(io)?;
        consumed += got as u64;
        if got < 192 {
            return Err(Error::Truncated { path: path.into(), field: "header".into(), expected: 540, found: consumed });
        }
    }
    let h = parse_header(path, &hb)?;
    let nd = h.dims[0];
    if !(1..=7).contains(&nd) {
        return Err(Error::field(path, "dim[0]", format!("expected 1..7 dimensions, found {nd}")));
    }
    let d: Vec<i64> = (1..=7).map(|i| if i as i64 <= nd { h.dims[i] } else { 1 }).collect();
    if d.iter().any(|&v| v < 1) {
        return Err(Error::field(path, "dim", format!("expected positive sizes, found {:?}", &h.dims[1..=nd as usize])));
    }
    if d[3..].iter().any(|&v| v > 1) {
        return Err(Error::FourD { path: path.into(), dims: h.dims[1..=nd as usize].to_vec() });
    }
    let dims = [d[0] as usize, d[1] as usize, d[2] as usize];
    let n = check_cap(path, [d[0] as u64, d[1] as u64, d[2] as u64], opts)?;
    let (esize, kind) = element(path, h.datatype)?;
    if h.vox_offset < consumed {
        return Err(Error::field(path, "vox_offset", format!("expected at least {consumed}, found {}", h.vox_offset)));
    }
    // Skip extensions up to vox_offset.
    let skip = h.vox_offset - consumed;
    let skipped = std::io::copy(&mut (&mut *r).take(skip), &mut std::io::sink()).map_err(io)?;
    if skipped < skip {
        return Err(Error::Truncated { path: path.into(), field: "extensions before vox_offset".into(), expected: h.vox_offset, found: consumed + skipped });
    }
    let need = n * esize;
    if !gz {
        // Before allocating: an uncompressed file must hold the voxels its header claims.
        let size = std::fs::metadata(path).map_err(io)?.len();
        if size < h.vox_offset + need as u64 {
            return Err(Error::Truncated { path: path.into(), field: "voxel data".into(), expected: h.vox_offset + need as u64, found: size });
        }
    }
    let mut values = Vec::with_capacity(n);
    let mut chunk = vec![0u8; (1 << 20) / esize * esize];
    let mut done = 0usize;
    while done < need {
        let want = chunk.len().min(need - done);
        let got = read_full(&mut *r, &mut chunk[..want]).map_err(io)?;
        convert(kind, h.big_endian, &chunk[..got - got % esize], &mut values);
        done += got;
        if got < want {
            return Err(Error::Truncated { path: path.into(), field: "voxel data".into(), expected: h.vox_offset + need as u64, found: h.vox_offset + done as u64 });
        }
    }
    if gz {
        // gzip's CRC and length are checked only at the end of the stream: read to it. A little
        // trailing data is tolerated; an endless stream is not.
        const MAX_TRAILING: u64 = 64 << 20;
        let trailing = std::io::copy(&mut (&mut *r).take(MAX_TRAILING + 1), &mut std::io::sink())
            .map_err(|e| Error::field(path, "gzip stream", format!("corrupt after the voxel data: {e}")))?;
        if trailing > MAX_TRAILING {
            return Err(Error::field(path, "gzip stream", format!("more than {MAX_TRAILING} bytes after the voxel data")));
        }
    }
    if h.scl_slope.is_finite() && h.scl_slope != 0.0 {
        let (s, i) = (h.scl_slope as f32, if h.scl_inter.is_finite() { h.scl_inter as f32 } else { 0.0 });
        if s != 1.0 || i != 0.0 {
            values.iter_mut().for_each(|v| *v = *v * s + i);
        }
    }
    // Affine in RAS (NIfTI), then LPS = diag(-1,-1,1) · RAS.
    let unit = match h.xyzt_units & 7 {
        1 => 1000.0,
        3 => 0.001,
        _ => 1.0,
    };
    let mut m = [[0.0f64; 4]; 3];
    if h.sform_code > 0 {
        m = h.srow;
    } else if h.qform_code > 0 {
        let [b, c, dq] = h.quatern;
        let a = (1.0 - (b * b + c * c + dq * dq)).max(0.0).sqrt();
        let rot = [
            [a * a + b * b - c * c - dq * dq, 2.0 * (b * c - a * dq), 2.0 * (b * dq + a * c)],
            [2.0 * (b * c + a * dq), a * a + c * c - b * b - dq * dq, 2.0 * (c * dq - a * b)],
            [2.0 * (b * dq - a * c), 2.0 * (c * dq + a * b), a * a + dq * dq - c * c - b * b],
        ];
        let qfac = if h.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
        let sc = [h.pixdim[1], h.pixdim[2], h.pixdim[3] * qfac];
        for r in 0..3 {
            for c in 0..3 {
                m[r][c] = rot[r][c] * sc[c];
            }
            m[r][3] = h.qoffset[r];
        }
    } else {
        for c in 0..3 {
            m[c][c] = if h.pixdim[c + 1] > 0.0 { h.pixdim[c + 1] } else { 1.0 };
        }
    }
    let mut spacing = [0.0; 3];
    let mut direction = [[0.0; 3]; 3];
    for c in 0..3 {
        let col = [-m[0][c] * unit, -m[1][c] * unit, m[2][c] * unit];
        let (u, len) = normalize(col).ok_or_else(|| {
            Error::field(path, if h.sform_code > 0 { "srow" } else { "pixdim/quatern" }, format!("axis {c} has zero or non-finite length"))
        })?;
        spacing[c] = len;
        direction[c] = u;
    }
    let origin = [-m[0][3] * unit, -m[1][3] * unit, m[2][3] * unit];
    if origin.iter().any(|v| !v.is_finite()) {
        return Err(Error::field(path, "offset", "expected finite values"));
    }
    let source = SourceInfo {
        format: "nifti".into(),
        path: path.to_string_lossy().into_owned(),
        encoding: Some(format!("NIfTI-{} {kind}{}", h.version, if h.big_endian { " big-endian" } else { "" })),
        ..Default::default()
    };
    let vol = Volume { dims, spacing, origin, direction, values, source };
    vol.check_nan(path)?;
    Ok(vol)
}

/// Rotation matrix (columns = axes) to NIfTI quaternion (b, c, d) and qfac.
fn quaternion(mut r: [[f64; 3]; 3]) -> ([f64; 3], f64) {
    let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    let qfac = if det < 0.0 { -1.0 } else { 1.0 };
    if qfac < 0.0 {
        for row in r.iter_mut() {
            row[2] = -row[2];
        }
    }
    let tr = r[0][0] + r[1][1] + r[2][2];
    let (a, b, c, d);
    if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        a = 0.25 * s;
        b = (r[2][1] - r[1][2]) / s;
        c = (r[0][2] - r[2][0]) / s;
        d = (r[1][0] - r[0][1]) / s;
    } else if r[0][0] > r[1][1] && r[0][0] > r[2][2] {
        let s = (1.0 + r[0][0] - r[1][1] - r[2][2]).sqrt() * 2.0;
        a = (r[2][1] - r[1][2]) / s;
        b = 0.25 * s;
        c = (r[0][1] + r[1][0]) / s;
        d = (r[0][2] + r[2][0]) / s;
    } else if r[1][1] > r[2][2] {
        let s = (1.0 + r[1][1] - r[0][0] - r[2][2]).sqrt() * 2.0;
        a = (r[0][2] - r[2][0]) / s;
        b = (r[0][1] + r[1][0]) / s;
        c = 0.25 * s;
        d = (r[1][2] + r[2][1]) / s;
    } else {
        let s = (1.0 + r[2][2] - r[0][0] - r[1][1]).sqrt() * 2.0;
        a = (r[1][0] - r[0][1]) / s;
        b = (r[0][2] + r[2][0]) / s;
        c = (r[1][2] + r[2][1]) / s;
        d = 0.25 * s;
    }
    let sign = if a < 0.0 { -1.0 } else { 1.0 };
    ([b * sign, c * sign, d * sign], qfac)
}

/// Writes NIfTI-1 float32 (`.nii`, or gzip for `.nii.gz`), sform and qform both set (code 1, scanner).
pub fn write_nifti(vol: &Volume, path: &Path) -> Result<()> {
    let mut h = vec![0u8; 352];
    let put = |h: &mut Vec<u8>, at: usize, b: &[u8]| h[at..at + b.len()].copy_from_slice(b);
    put(&mut h, 0, &348i32.to_le_bytes());
    put(&mut h, 38, b"r");
    let dims = [3i16, vol.dims[0] as i16, vol.dims[1] as i16, vol.dims[2] as i16, 1, 1, 1, 1];
    if vol.dims.iter().any(|&d| d > i16::MAX as usize) {
        return Err(Error::invalid("volume dims", format!("{:?} exceed NIfTI-1's 32767", vol.dims)));
    }
    for (i, d) in dims.iter().enumerate() {
        put(&mut h, 40 + 2 * i, &d.to_le_bytes());
    }
    put(&mut h, 70, &16i16.to_le_bytes());
    put(&mut h, 72, &32i16.to_le_bytes());
    // RAS affine columns.
    let ras = |v: [f64; 3]| [-v[0], -v[1], v[2]];
    let rot = [ras(vol.direction[0]), ras(vol.direction[1]), ras(vol.direction[2])];
    let rm = [[rot[0][0], rot[1][0], rot[2][0]], [rot[0][1], rot[1][1], rot[2][1]], [rot[0][2], rot[1][2], rot[2][2]]];
    let (q, qfac) = quaternion(rm);
    let pixdim = [qfac, vol.spacing[0], vol.spacing[1], vol.spacing[2], 1.0, 1.0, 1.0, 1.0];
    for (i, p) in pixdim.iter().enumerate() {
        put(&mut h, 76 + 4 * i, &(*p as f32).to_le_bytes());
    }
    put(&mut h, 108, &352f32.to_le_bytes());
    put(&mut h, 112, &1f32.to_le_bytes());
    h[123] = 2 | 8; // mm, seconds
    put(&mut h, 148, b"dentsim");
    put(&mut h, 252, &1i16.to_le_bytes());
    put(&mut h, 254, &1i16.to_le_bytes());
    let o = ras(vol.origin);
    for i in 0..3 {
        put(&mut h, 256 + 4 * i, &(q[i] as f32).to_le_bytes());
        put(&mut h, 268 + 4 * i, &(o[i] as f32).to_le_bytes());
    }
    for r in 0..3 {
        for c in 0..3 {
            put(&mut h, 280 + 16 * r + 4 * c, &((rm[r][c] * vol.spacing[c]) as f32).to_le_bytes());
        }
        put(&mut h, 280 + 16 * r + 12, &(o[r] as f32).to_le_bytes());
    }
    put(&mut h, 344, b"n+1\0");
    let gz = path.to_string_lossy().to_lowercase().ends_with(".gz");
    Ok(dentsim_atomic::write(path, |w| {
        let body = |w: &mut dyn std::io::Write| -> std::io::Result<()> {
            w.write_all(&h)?;
            let mut buf = Vec::with_capacity(1 << 20);
            for chunk in vol.values.chunks(1 << 18) {
                buf.clear();
                chunk.iter().for_each(|v| buf.extend_from_slice(&v.to_le_bytes()));
                w.write_all(&buf)?;
            }
            Ok(())
        };
        if gz {
            let mut enc = flate2::write::GzEncoder::new(w, flate2::Compression::fast());
            body(&mut enc)?;
            enc.finish()?;
            Ok(())
        } else {
            body(w)
        }
    })?)
}
