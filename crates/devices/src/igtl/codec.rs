//! The OpenIGTLink wire format (REFERENCE.md "Input devices"): the 58-byte big-endian header,
//! the version-2/3 extended header and metadata around the content, and the three bodies a
//! haptic bridge needs (TRANSFORM and POSITION in, SENSOR out). Decoding checks sizes before it
//! reads and never allocates; everything a peer sends is untrusted.
use glam::{DAffine3, DMat3, DQuat, DVec3};

/// Header bytes before every body.
pub const HEADER_SIZE: usize = 58;
/// Size of the version-2 extended header at the start of the body.
pub const EXT_HEADER_SIZE: usize = 12;
/// OpenIGTLink's registered port.
pub const DEFAULT_PORT: u16 = 18944;

/// CRC-64/ECMA-182 (polynomial 0x42F0E1EBA9EA3693, init 0, not reflected, no final xor), as
/// igtl_util.c computes it over the body.
pub const CRC64: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_ECMA_182);

pub fn crc64(bytes: &[u8]) -> u64 {
    CRC64.checksum(bytes)
}

/// A parsed message header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// 1 for protocols 1 and 2, 2 for protocol 3 (body starts with the extended header).
    pub version: u16,
    pub type_name: [u8; 12],
    pub device_name: [u8; 20],
    pub timestamp: u64,
    pub body_size: u64,
    pub crc: u64,
}

/// Why a message was refused (Copy: counted, never stored).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Malformed {
    Version(u16),
    Crc,
    /// The extended header or metadata sizes do not fit the body.
    Layout,
    /// The content is not a size this message type can have.
    Size,
    /// NaN/inf values or a rotation that is not one.
    Values,
}

impl Header {
    pub fn parse(b: &[u8; HEADER_SIZE]) -> Header {
        let u64_at = |i: usize| u64::from_be_bytes(b[i..i + 8].try_into().unwrap_or_default());
        let mut type_name = [0u8; 12];
        type_name.copy_from_slice(&b[2..14]);
        let mut device_name = [0u8; 20];
        device_name.copy_from_slice(&b[14..34]);
        Header {
            version: u16::from_be_bytes([b[0], b[1]]),
            type_name,
            device_name,
            timestamp: u64_at(34),
            body_size: u64_at(42),
            crc: u64_at(50),
        }
    }

    pub fn write(&self, out: &mut [u8; HEADER_SIZE]) {
        out[0..2].copy_from_slice(&self.version.to_be_bytes());
        out[2..14].copy_from_slice(&self.type_name);
        out[14..34].copy_from_slice(&self.device_name);
        out[34..42].copy_from_slice(&self.timestamp.to_be_bytes());
        out[42..50].copy_from_slice(&self.body_size.to_be_bytes());
        out[50..58].copy_from_slice(&self.crc.to_be_bytes());
    }

    /// The type ("TRANSFORM", ...), up to its first NUL.
    pub fn type_str(&self) -> &str {
        c_str(&self.type_name)
    }

    pub fn device_str(&self) -> &str {
        c_str(&self.device_name)
    }

    /// Versions this client reads: 1 (protocols 1 and 2) and 2 (protocol 3; 3 is accepted too,
    /// as the C++ library's newest headers may say).
    pub fn check_version(&self) -> Result<(), Malformed> {
        match self.version {
            1..=3 => Ok(()),
            v => Err(Malformed::Version(v)),
        }
    }
}

fn c_str(bytes: &[u8]) -> &str {
    let end = bytes.iter().position(|&c| c == 0).unwrap_or(bytes.len());
    std::str::from_utf8(&bytes[..end]).unwrap_or("")
}

/// A fixed-size NUL-padded name (longer names are cut, as the C++ library does).
pub fn name_field<const N: usize>(name: &str) -> [u8; N] {
    let mut out = [0u8; N];
    let n = name.len().min(N);
    out[..n].copy_from_slice(&name.as_bytes()[..n]);
    out
}

/// The message content inside `body` after checking the CRC: for version ≥ 2 what lies between
/// the extended header and the metadata.
pub fn content<'a>(header: &Header, body: &'a [u8]) -> Result<&'a [u8], Malformed> {
    header.check_version()?;
    if crc64(body) != header.crc {
        return Err(Malformed::Crc);
    }
    if header.version < 2 {
        return Ok(body);
    }
    if body.len() < EXT_HEADER_SIZE {
        return Err(Malformed::Layout);
    }
    let ext = usize::from(u16::from_be_bytes([body[0], body[1]]));
    let meta_header = usize::from(u16::from_be_bytes([body[2], body[3]]));
    let meta = u32::from_be_bytes([body[4], body[5], body[6], body[7]]) as usize;
    let end = body.len().checked_sub(meta_header).and_then(|e| e.checked_sub(meta)).ok_or(Malformed::Layout)?;
    if ext < EXT_HEADER_SIZE || ext > end {
        return Err(Malformed::Layout);
    }
    Ok(&body[ext..end])
}

fn f32s<const N: usize>(bytes: &[u8]) -> [f64; N] {
    let mut out = [0.0; N];
    for (o, c) in out.iter_mut().zip(bytes.chunks_exact(4)) {
        *o = f64::from(f32::from_be_bytes([c[0], c[1], c[2], c[3]]));
    }
    out
}

/// Rotations sent as f32 are orthonormal to ~1e-6; this admits what a tracker's rounding gives
/// and refuses scaled or sheared matrices.
const ROTATION_TOLERANCE: f64 = 1e-3;

/// TRANSFORM content: 12 × f32, the rotation's columns then the translation (mm).
pub fn parse_transform(content: &[u8]) -> Result<DAffine3, Malformed> {
    if content.len() != 48 {
        return Err(Malformed::Size);
    }
    let v: [f64; 12] = f32s(content);
    if v.iter().any(|x| !x.is_finite()) {
        return Err(Malformed::Values);
    }
    let m = DMat3::from_cols(DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5]), DVec3::new(v[6], v[7], v[8]));
    let off = (m.transpose() * m - DMat3::IDENTITY).to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs()));
    if off > ROTATION_TOLERANCE || m.determinant() <= 0.0 {
        return Err(Malformed::Values);
    }
    let q = DQuat::from_mat3(&m).normalize();
    Ok(DAffine3::from_rotation_translation(q, DVec3::new(v[9], v[10], v[11])))
}

/// POSITION content: x y z (mm) and the quaternion qx qy qz qw; the protocol also allows only
/// the position (12 bytes) or qx qy qz with qw implied ≥ 0 (24 bytes).
pub fn parse_position(content: &[u8]) -> Result<DAffine3, Malformed> {
    let (p, q) = match content.len() {
        12 => (f32s::<3>(content), [0.0, 0.0, 0.0, 1.0]),
        24 => {
            let v: [f64; 6] = f32s(content);
            let w2 = 1.0 - (v[3] * v[3] + v[4] * v[4] + v[5] * v[5]);
            if w2 < -ROTATION_TOLERANCE {
                return Err(Malformed::Values);
            }
            ([v[0], v[1], v[2]], [v[3], v[4], v[5], w2.max(0.0).sqrt()])
        }
        28 => {
            let v: [f64; 7] = f32s(content);
            ([v[0], v[1], v[2]], [v[3], v[4], v[5], v[6]])
        }
        _ => return Err(Malformed::Size),
    };
    if p.iter().chain(&q).any(|x| !x.is_finite()) {
        return Err(Malformed::Values);
    }
    let q = DQuat::from_xyzw(q[0], q[1], q[2], q[3]);
    if (q.length() - 1.0).abs() > ROTATION_TOLERANCE {
        return Err(Malformed::Values);
    }
    Ok(DAffine3::from_rotation_translation(q.normalize(), DVec3::from_array(p)))
}

/// A SENSOR message of six values (fx fy fz tx ty tz) ready to send.
pub const SENSOR_VALUES: usize = 6;
const SENSOR_CONTENT: usize = 10 + 8 * SENSOR_VALUES;
/// Largest SENSOR message this writes: header, extended header, content, empty metadata header.
pub const SENSOR_MESSAGE_MAX: usize = HEADER_SIZE + EXT_HEADER_SIZE + SENSOR_CONTENT + 2;

/// Writes a SENSOR message into `out` and returns its length. `version` 1 writes the plain
/// body; 2 or more adds the extended header and an empty metadata index, as protocol 3 peers
/// expect. `unit` is 0 (the values are N and N·mm, documented rather than encoded).
pub fn write_sensor(out: &mut [u8; SENSOR_MESSAGE_MAX], version: u16, device: &str, values: &[f64; SENSOR_VALUES], timestamp: u64, message_id: u32) -> usize {
    let mut body = [0u8; SENSOR_MESSAGE_MAX - HEADER_SIZE];
    let mut n = 0;
    if version >= 2 {
        body[0..2].copy_from_slice(&(EXT_HEADER_SIZE as u16).to_be_bytes());
        body[2..4].copy_from_slice(&2u16.to_be_bytes());
        body[4..8].copy_from_slice(&0u32.to_be_bytes());
        body[8..12].copy_from_slice(&message_id.to_be_bytes());
        n = EXT_HEADER_SIZE;
    }
    body[n] = SENSOR_VALUES as u8;
    body[n + 1] = 0;
    body[n + 2..n + 10].copy_from_slice(&0u64.to_be_bytes());
    n += 10;
    for v in values {
        body[n..n + 8].copy_from_slice(&v.to_be_bytes());
        n += 8;
    }
    if version >= 2 {
        body[n..n + 2].copy_from_slice(&0u16.to_be_bytes());
        n += 2;
    }
    let header = Header {
        version: if version >= 2 { 2 } else { 1 },
        type_name: name_field("SENSOR"),
        device_name: name_field(device),
        timestamp,
        body_size: n as u64,
        crc: crc64(&body[..n]),
    };
    let mut h = [0u8; HEADER_SIZE];
    header.write(&mut h);
    out[..HEADER_SIZE].copy_from_slice(&h);
    out[HEADER_SIZE..HEADER_SIZE + n].copy_from_slice(&body[..n]);
    HEADER_SIZE + n
}

/// SENSOR content: count, status, unit, then count × f64.
pub fn parse_sensor(content: &[u8]) -> Result<(u8, &[u8]), Malformed> {
    let count = *content.first().ok_or(Malformed::Size)?;
    if content.len() != 10 + 8 * usize::from(count) {
        return Err(Malformed::Size);
    }
    Ok((count, &content[10..]))
}

/// Builds a whole message (tests, benches and the recorded peers): header plus `body` as given.
pub fn message(version: u16, type_name: &str, device: &str, body: &[u8]) -> Vec<u8> {
    let header = Header {
        version,
        type_name: name_field(type_name),
        device_name: name_field(device),
        timestamp: 0,
        body_size: body.len() as u64,
        crc: crc64(body),
    };
    let mut h = [0u8; HEADER_SIZE];
    header.write(&mut h);
    let mut out = h.to_vec();
    out.extend_from_slice(body);
    out
}

/// TRANSFORM content for `pose` (f32, as on the wire).
pub fn transform_content(pose: &DAffine3) -> [u8; 48] {
    let m = pose.matrix3.to_cols_array();
    let t = pose.translation.to_array();
    let mut out = [0u8; 48];
    for (i, v) in m.iter().chain(&t).enumerate() {
        out[4 * i..4 * i + 4].copy_from_slice(&(*v as f32).to_be_bytes());
    }
    out
}

/// The IGTL timestamp now: seconds since 1970 in the high 32 bits, the fraction in the low.
pub fn timestamp_now() -> u64 {
    let d = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    let frac = ((u64::from(d.subsec_nanos()) << 32) / 1_000_000_000) & 0xFFFF_FFFF;
    ((d.as_secs() & 0xFFFF_FFFF) << 32) | frac
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_is_ecma_182_as_the_reference_computes_it() {
        assert_eq!(crc64(b"123456789"), 0x6C40DF5F0B497347);
    }

    #[test]
    fn transform_round_trips_and_bad_rotations_are_refused() {
        let pose = DAffine3::from_rotation_translation(DQuat::from_rotation_x(0.3), DVec3::new(1.0, -2.0, 3.5));
        let msg = message(1, "TRANSFORM", "Stylus", &transform_content(&pose));
        let h = Header::parse(msg[..HEADER_SIZE].try_into().unwrap());
        assert_eq!((h.type_str(), h.device_str(), h.body_size), ("TRANSFORM", "Stylus", 48));
        let back = parse_transform(content(&h, &msg[HEADER_SIZE..]).unwrap()).unwrap();
        assert!((back.translation - pose.translation).length() < 1e-6);
        assert!(back.matrix3.abs_diff_eq(pose.matrix3, 1e-6));
        let scaled = DAffine3::from_scale_rotation_translation(DVec3::splat(2.0), DQuat::IDENTITY, DVec3::ZERO);
        assert_eq!(parse_transform(&transform_content(&scaled)), Err(Malformed::Values));
        let mut nan = transform_content(&pose);
        nan[44..48].copy_from_slice(&f32::NAN.to_be_bytes());
        assert_eq!(parse_transform(&nan), Err(Malformed::Values));
        let mut bad_crc = msg.clone();
        bad_crc[HEADER_SIZE] ^= 1;
        assert_eq!(content(&h, &bad_crc[HEADER_SIZE..]), Err(Malformed::Crc));
    }

    #[test]
    fn version_2_content_excludes_extended_header_and_metadata() {
        let mut body = Vec::new();
        body.extend_from_slice(&12u16.to_be_bytes());
        let meta_header = [0u8, 1, 0, 3, 0, 3, 0, 0, 0, 2];
        body.extend_from_slice(&(meta_header.len() as u16).to_be_bytes());
        body.extend_from_slice(&5u32.to_be_bytes());
        body.extend_from_slice(&7u32.to_be_bytes());
        body.extend_from_slice(b"CONTENT");
        body.extend_from_slice(&meta_header);
        body.extend_from_slice(b"keyvv");
        let msg = message(2, "STRING", "x", &body);
        let h = Header::parse(msg[..HEADER_SIZE].try_into().unwrap());
        assert_eq!(content(&h, &msg[HEADER_SIZE..]).unwrap(), b"CONTENT");
        // Metadata sizes larger than the body are refused, not read past.
        let mut lying = body.clone();
        lying[4..8].copy_from_slice(&1000u32.to_be_bytes());
        let msg = message(2, "STRING", "x", &lying);
        let h = Header::parse(msg[..HEADER_SIZE].try_into().unwrap());
        assert_eq!(content(&h, &msg[HEADER_SIZE..]), Err(Malformed::Layout));
        let msg = message(7, "STRING", "x", b"");
        let h = Header::parse(msg[..HEADER_SIZE].try_into().unwrap());
        assert_eq!(content(&h, &msg[HEADER_SIZE..]), Err(Malformed::Version(7)));
    }

    #[test]
    fn position_forms_and_sensor_round_trip() {
        let mut c = Vec::new();
        for v in [1.0f32, 2.0, 3.0, 0.0, 0.0, std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2] {
            c.extend_from_slice(&v.to_be_bytes());
        }
        let p = parse_position(&c).unwrap();
        assert!((p.transform_vector3(DVec3::X) - DVec3::Y).length() < 1e-6);
        assert_eq!(parse_position(&c[..12]).unwrap().translation, DVec3::new(1.0, 2.0, 3.0));
        let p24 = parse_position(&c[..24]).unwrap();
        assert!((p24.transform_vector3(DVec3::X) - DVec3::Y).length() < 1e-6);
        assert_eq!(parse_position(&c[..20]), Err(Malformed::Size));
        for version in [1, 2] {
            let mut out = [0u8; SENSOR_MESSAGE_MAX];
            let n = write_sensor(&mut out, version, "Force", &[1.0, -2.0, 3.0, 0.5, 0.0, -0.25], 0, 9);
            let h = Header::parse(out[..HEADER_SIZE].try_into().unwrap());
            assert_eq!((h.type_str(), h.device_str(), h.body_size as usize + HEADER_SIZE), ("SENSOR", "Force", n));
            let (count, values) = parse_sensor(content(&h, &out[HEADER_SIZE..n]).unwrap()).unwrap();
            assert_eq!(count, 6);
            assert_eq!(f64::from_be_bytes(values[8..16].try_into().unwrap()), -2.0);
        }
    }
}
