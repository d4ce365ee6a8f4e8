//! The session log: binary, versioned, append-only; written by the logger thread under its final
//! name as the session runs, so a killed session leaves every tick flushed before the kill.
//!
//! Layout (little-endian): magic `DSIMLOG\0`, u32 version, u32 header length, the header as JSON
//! ([`LogHeader`]: everything a replay needs besides the tissues), then one fixed-size
//! [`TickRecord`] of [`RECORD_BYTES`] per tick. From version 4 the header JSON is followed by its
//! CRC-32 and each record by the CRC-32 of its bytes, so a flipped byte or appended garbage is
//! an error naming the tick. From version 5 a record ends with the tick's clearance over the pulp
//! (live guidance) and its flags may carry the guidance bits. A crash leaves at worst a partial
//! last record, which the reader reports and drops.
use std::io::{Read, Write};
use std::path::Path;

use glam::{DAffine3, DMat3, DVec3};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::haptics::tick::HapticParams;

pub const MAGIC: [u8; 8] = *b"DSIMLOG\0";
/// 2: records carry the tick's changed voxels, no longer its removed volume (live ticks do not
/// measure it; a replay does).
/// 3: the header's haptic parameters name the burr by its spec (`burr`), not a round burr's
/// diameter.
/// (The oldest version this build still reads; logs are written as [`WRITTEN_VERSION`].)
pub const VERSION: u32 = 3;
/// 4: a CRC-32 after the header and after each record.
pub const CHECKED_VERSION: u32 = 4;
/// 5: each record ends with the tick's clearance over the pulp ([`TickRecord::clearance_mm`]).
pub const WRITTEN_VERSION: u32 = 5;
/// A record of versions 3 and 4.
pub const V4_RECORD_BYTES: usize = 8 + 8 + 8 + 12 * 8 + 4 + 8 + 3 * 8 + 3 * 8 + 3 * 8 + 4 + 4 + 8;
/// A record as written ([`WRITTEN_VERSION`]).
pub const RECORD_BYTES: usize = V4_RECORD_BYTES + 8;
/// A written record and its CRC-32.
pub const CHECKED_RECORD_BYTES: usize = RECORD_BYTES + 4;

/// Flag bits of a record (and [`crate::haptics::guidance::GUIDANCE_FLAGS`]).
pub const FLAG_CUT: u32 = 1;
pub const FLAG_MISSED: u32 = 2;
pub const FLAG_DEVICE_FAULT: u32 = 4;
pub use crate::haptics::guidance::{FLAG_PULP_EXPOSED, FLAG_THIN_DENTIN};

/// What a replay needs to redo the session's ticks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LogHeader {
    pub params: HapticParams,
    pub device: String,
    /// Tissue names in model order (the replay's model must match).
    pub tissues: Vec<String>,
    /// Content hash of each tissue grid at the start.
    pub start_hashes: Vec<u64>,
    pub source: String,
    /// When tick 0 started, seconds since the Unix epoch (0 in logs written before it was kept):
    /// with a record's `wall_s`, when that tick ran, e.g. to measure what a kill lost.
    #[serde(default)]
    pub started_unix_s: f64,
}

/// One tick as logged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickRecord {
    pub tick: u64,
    /// Session time the device was polled at (s; tick × period).
    pub t_s: f64,
    /// When the tick actually started (s since the session start; wall clock).
    pub wall_s: f64,
    pub pose: DAffine3,
    pub buttons: u32,
    pub rpm: f64,
    pub force: DVec3,
    pub torque: DVec3,
    pub proxy: DVec3,
    /// Index of the tissue in contact, −1 for none.
    pub tissue: i32,
    pub flags: u32,
    /// Voxels the tick's cut changed, over all tissues.
    pub changed_voxels: u64,
    /// [`crate::haptics::TickOutput::clearance_mm`]: infinite when far from the pulp, without
    /// guidance, or in logs before version 5.
    pub clearance_mm: f64,
}

impl Default for TickRecord {
    fn default() -> Self {
        TickRecord {
            tick: 0,
            t_s: 0.0,
            wall_s: 0.0,
            pose: DAffine3::default(),
            buttons: 0,
            rpm: 0.0,
            force: DVec3::ZERO,
            torque: DVec3::ZERO,
            proxy: DVec3::ZERO,
            tissue: 0,
            flags: 0,
            changed_voxels: 0,
            clearance_mm: f64::INFINITY,
        }
    }
}

impl TickRecord {
    pub fn encode(&self, out: &mut [u8; RECORD_BYTES]) {
        let mut w = Cursor { buf: out, at: 0 };
        w.u64(self.tick);
        w.f64(self.t_s);
        w.f64(self.wall_s);
        for v in self.pose.matrix3.to_cols_array() {
            w.f64(v);
        }
        for v in self.pose.translation.to_array() {
            w.f64(v);
        }
        w.u32(self.buttons);
        w.f64(self.rpm);
        for v in [self.force, self.torque, self.proxy] {
            for c in v.to_array() {
                w.f64(c);
            }
        }
        w.u32(self.tissue as u32);
        w.u32(self.flags);
        w.u64(self.changed_voxels);
        w.f64(self.clearance_mm);
    }

    /// A record as written; see [`TickRecord::decode_v4`] for older logs.
    pub fn decode(buf: &[u8; RECORD_BYTES]) -> Self {
        let clearance_mm = f64::from_le_bytes(buf[V4_RECORD_BYTES..].try_into().expect("8 bytes"));
        TickRecord { clearance_mm, ..Self::decode_v4(buf[..V4_RECORD_BYTES].try_into().expect("v4 record")) }
    }

    /// A record of a version 3 or 4 log (no clearance: infinite).
    pub fn decode_v4(buf: &[u8; V4_RECORD_BYTES]) -> Self {
        let mut r = Reader { buf, at: 0 };
        let tick = r.u64();
        let t_s = r.f64();
        let wall_s = r.f64();
        let mut m = [0.0; 9];
        m.iter_mut().for_each(|v| *v = r.f64());
        let t = DVec3::new(r.f64(), r.f64(), r.f64());
        let buttons = r.u32();
        let rpm = r.f64();
        let mut v3 = || DVec3::new(r.f64(), r.f64(), r.f64());
        let (force, torque, proxy) = (v3(), v3(), v3());
        TickRecord {
            tick,
            t_s,
            wall_s,
            pose: DAffine3::from_mat3_translation(DMat3::from_cols_array(&m), t),
            buttons,
            rpm,
            force,
            torque,
            proxy,
            tissue: r.u32() as i32,
            flags: r.u32(),
            changed_voxels: r.u64(),
            clearance_mm: f64::INFINITY,
        }
    }
}

struct Cursor<'a> {
    buf: &'a mut [u8; RECORD_BYTES],
    at: usize,
}

impl Cursor<'_> {
    fn put(&mut self, b: &[u8]) {
        self.buf[self.at..self.at + b.len()].copy_from_slice(b);
        self.at += b.len();
    }
    fn u64(&mut self, v: u64) {
        self.put(&v.to_le_bytes())
    }
    fn u32(&mut self, v: u32) {
        self.put(&v.to_le_bytes())
    }
    fn f64(&mut self, v: f64) {
        self.put(&v.to_le_bytes())
    }
}

struct Reader<'a> {
    buf: &'a [u8; V4_RECORD_BYTES],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        out.copy_from_slice(&self.buf[self.at..self.at + N]);
        self.at += N;
        out
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
}

/// Writes the header ([`WRITTEN_VERSION`]); records follow with [`write_record`].
pub fn write_header(out: &mut impl Write, header: &LogHeader) -> std::io::Result<()> {
    let json = serde_json::to_vec(header).map_err(std::io::Error::other)?;
    out.write_all(&MAGIC)?;
    out.write_all(&WRITTEN_VERSION.to_le_bytes())?;
    out.write_all(&(json.len() as u32).to_le_bytes())?;
    out.write_all(&json)?;
    out.write_all(&crc32fast::hash(&json).to_le_bytes())
}

/// One record and its CRC-32.
pub fn write_record(out: &mut impl Write, record: &TickRecord) -> std::io::Result<()> {
    let mut buf = [0u8; CHECKED_RECORD_BYTES];
    let (body, crc) = buf.split_at_mut(RECORD_BYTES);
    record.encode(body.try_into().expect("RECORD_BYTES"));
    crc.copy_from_slice(&crc32fast::hash(body).to_le_bytes());
    out.write_all(&buf)
}

/// A log read back.
#[derive(Clone, Debug)]
pub struct SessionLog {
    /// The format version the file was written in (guidance is logged from 5 on).
    pub version: u32,
    pub header: LogHeader,
    pub records: Vec<TickRecord>,
    /// Bytes of a partial last record that were dropped (a crash while writing).
    pub truncated_bytes: usize,
}

impl SessionLog {
    pub fn read(path: &Path) -> Result<Self> {
        let err = |message: String| Error::File { path: path.to_owned(), message };
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|mut f| f.read_to_end(&mut bytes))
            .map_err(|e| err(e.to_string()))?;
        Self::parse(&bytes).map_err(err)
    }

    /// Checks every record of a version-4 or later log: its CRC, and that ticks increase. Errors name the
    /// tick (the one expected where the decoded one cannot be trusted) and the byte offset.
    pub fn parse(bytes: &[u8]) -> std::result::Result<Self, String> {
        if bytes.is_empty() {
            // The session creates its log, then writes the header once its grids are ready.
            return Err("is empty: the session stopped before its first tick (nothing to replay)".into());
        }
        if bytes.len() < 16 || bytes[..8] != MAGIC {
            return Err("not a dentsim session log (bad magic)".into());
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if !(VERSION..=WRITTEN_VERSION).contains(&version) {
            return Err(format!(
                "log version {version}, this build reads version {VERSION} (unchecked), version {CHECKED_VERSION} and version {WRITTEN_VERSION}"
            ));
        }
        let checked = version >= CHECKED_VERSION;
        let record_bytes = if version >= 5 { RECORD_BYTES } else { V4_RECORD_BYTES };
        let len = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize;
        let body = bytes.get(16..16 + len).ok_or("header runs past the end of the file")?;
        let mut at = 16 + len;
        if checked {
            let crc = bytes.get(at..at + 4).ok_or("header checksum runs past the end of the file")?;
            if crc32fast::hash(body).to_le_bytes() != crc {
                return Err("header checksum mismatch (the file is damaged)".into());
            }
            at += 4;
        }
        let header: LogHeader = serde_json::from_slice(body).map_err(|e| format!("header: {e}"))?;
        let rest = &bytes[at..];
        let size = record_bytes + if checked { 4 } else { 0 };
        let mut records: Vec<TickRecord> = Vec::with_capacity(rest.len() / size);
        for (i, chunk) in rest.chunks_exact(size).enumerate() {
            let record = match chunk[..record_bytes].try_into() {
                Ok(v5) => TickRecord::decode(v5),
                Err(_) => TickRecord::decode_v4(chunk[..record_bytes].try_into().expect("exact chunk")),
            };
            if checked {
                let expected_tick = records.last().map_or(0, |r| r.tick + 1);
                let offset = at + i * size;
                if crc32fast::hash(&chunk[..record_bytes]).to_le_bytes() != chunk[record_bytes..] {
                    return Err(format!(
                        "record {i} (tick {expected_tick} expected, byte {offset}): checksum mismatch: a changed byte or data appended after the last tick"
                    ));
                }
                if record.tick < expected_tick {
                    return Err(format!("record {i} (byte {offset}): tick {} after tick {}, expected increasing ticks", record.tick, expected_tick - 1));
                }
            }
            records.push(record);
        }
        Ok(SessionLog { version, header, records, truncated_bytes: rest.len() % size })
    }

    /// A note on a partial last record (a session killed while writing), naming the last whole tick.
    pub fn truncation_note(&self) -> Option<String> {
        (self.truncated_bytes > 0).then(|| {
            let last = self.records.last().map_or("no tick".to_string(), |r| format!("tick {}", r.tick));
            format!("{} bytes after {last} are not a whole record (a session stopped while writing); dropped", self.truncated_bytes)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    #[test]
    fn records_round_trip_bit_for_bit() {
        let r = TickRecord {
            tick: 42,
            t_s: 0.042,
            wall_s: 0.0421,
            pose: DAffine3::from_rotation_translation(DQuat::from_rotation_y(0.3), DVec3::new(1.0, -2.0, 3.5)),
            buttons: 1,
            rpm: 2e5,
            force: DVec3::new(0.1, 0.2, 1.0 / 3.0),
            torque: DVec3::new(-1.0, 0.0, 7.0),
            proxy: DVec3::new(0.5, 0.25, 0.125),
            tissue: -1,
            flags: FLAG_CUT | FLAG_MISSED | FLAG_THIN_DENTIN,
            changed_voxels: 3047,
            clearance_mm: 0.37,
        };
        let mut buf = [0u8; RECORD_BYTES];
        r.encode(&mut buf);
        assert_eq!(TickRecord::decode(&buf), r);
        let header = test_header(0.0);
        let mut bytes = Vec::new();
        write_header(&mut bytes, &header).unwrap();
        write_record(&mut bytes, &r).unwrap();
        bytes.extend_from_slice(&[1, 2, 3]);
        let log = SessionLog::parse(&bytes).unwrap();
        assert_eq!((log.header, log.records, log.truncated_bytes), (header, vec![r], 3));
        assert!(SessionLog::parse(b"GARBAGE!").unwrap_err().contains("magic"));
    }

    #[test]
    fn an_empty_log_says_the_session_never_ticked_and_a_header_alone_is_zero_ticks() {
        assert!(SessionLog::parse(b"").unwrap_err().contains("before its first tick"));
        let header_only = log_of(0);
        let log = SessionLog::parse(&header_only).unwrap();
        assert_eq!((log.records.len(), log.truncated_bytes), (0, 0));
    }

    fn test_header(started_unix_s: f64) -> LogHeader {
        LogHeader {
            params: HapticParams::default(),
            device: "test".into(),
            tissues: vec!["enamel".into()],
            start_hashes: vec![7],
            source: "unit test".into(),
            started_unix_s,
        }
    }

    fn log_of(ticks: u64) -> Vec<u8> {
        let mut bytes = Vec::new();
        write_header(&mut bytes, &test_header(1.0)).unwrap();
        for tick in 0..ticks {
            let r = TickRecord { tick, t_s: tick as f64 * 1e-3, force: DVec3::new(0.0, 0.0, tick as f64), ..TickRecord::default() };
            write_record(&mut bytes, &r).unwrap();
        }
        bytes
    }

    #[test]
    fn every_flipped_byte_in_a_record_is_an_error_naming_its_tick() {
        let bytes = log_of(5);
        let first = bytes.len() - 5 * CHECKED_RECORD_BYTES;
        assert_eq!(SessionLog::parse(&bytes).unwrap().records.len(), 5);
        for at in first..bytes.len() {
            let mut bad = bytes.clone();
            bad[at] ^= 0x10;
            let e = SessionLog::parse(&bad).unwrap_err();
            let tick = (at - first) / CHECKED_RECORD_BYTES;
            assert!(e.contains(&format!("tick {tick} expected")) && e.contains("checksum"), "byte {at}: {e}");
        }
        // A flipped byte in the header JSON is caught by its own CRC.
        let mut bad = bytes.clone();
        bad[20] ^= 0x01;
        assert!(SessionLog::parse(&bad).unwrap_err().contains("header"), "header");
    }

    #[test]
    fn appended_garbage_is_an_error_and_a_partial_record_a_note() {
        let mut bytes = log_of(3);
        bytes.extend(std::iter::repeat_n(0xAB, CHECKED_RECORD_BYTES + 7));
        let e = SessionLog::parse(&bytes).unwrap_err();
        assert!(e.contains("tick 3 expected") && e.contains("appended"), "{e}");
        let mut cut = log_of(3);
        cut.truncate(cut.len() - 10);
        let log = SessionLog::parse(&cut).unwrap();
        assert_eq!((log.records.len(), log.truncated_bytes), (2, CHECKED_RECORD_BYTES - 10));
        let note = log.truncation_note().unwrap();
        assert!(note.contains("after tick 1"), "{note}");
    }

    #[test]
    fn version_3_logs_still_read() {
        let header = LogHeader {
            params: HapticParams::default(),
            device: "v3".into(),
            tissues: vec!["enamel".into()],
            start_hashes: vec![7],
            source: "unit test".into(),
            started_unix_s: 0.0,
        };
        let json = serde_json::to_vec(&header).unwrap();
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&VERSION.to_le_bytes());
        bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&json);
        let r = TickRecord { tick: 0, rpm: 5.0, ..TickRecord::default() };
        let mut buf = [0u8; RECORD_BYTES];
        r.encode(&mut buf);
        bytes.extend_from_slice(&buf[..V4_RECORD_BYTES]);
        let log = SessionLog::parse(&bytes).unwrap();
        assert_eq!((log.header, log.records), (header, vec![r]));
    }

    #[test]
    fn version_4_logs_still_read_checked_without_clearance() {
        let header = test_header(1.0);
        let json = serde_json::to_vec(&header).unwrap();
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&CHECKED_VERSION.to_le_bytes());
        bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&json);
        bytes.extend_from_slice(&crc32fast::hash(&json).to_le_bytes());
        let records: Vec<TickRecord> = (0..3).map(|tick| TickRecord { tick, rpm: 7.0, clearance_mm: 0.2, ..TickRecord::default() }).collect();
        for r in &records {
            let mut buf = [0u8; RECORD_BYTES];
            r.encode(&mut buf);
            bytes.extend_from_slice(&buf[..V4_RECORD_BYTES]);
            bytes.extend_from_slice(&crc32fast::hash(&buf[..V4_RECORD_BYTES]).to_le_bytes());
        }
        let log = SessionLog::parse(&bytes).unwrap();
        assert_eq!(log.records.len(), 3);
        for (got, want) in log.records.iter().zip(&records) {
            // A version-4 record has no clearance: read as infinite, the rest as written.
            assert_eq!(*got, TickRecord { clearance_mm: f64::INFINITY, ..*want });
        }
        let mut bad = bytes.clone();
        let last = bad.len() - 6;
        bad[last] ^= 1;
        assert!(SessionLog::parse(&bad).unwrap_err().contains("tick 2 expected"));
    }
}
