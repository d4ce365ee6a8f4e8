//! The session log: binary, versioned, append-only; written by the logger thread.
//!
//! Layout (little-endian): magic `DSIMLOG\0`, u32 version, u32 header length, the header as JSON
//! ([`LogHeader`]: everything a replay needs besides the tissues), then one fixed-size
//! [`TickRecord`] of [`RECORD_BYTES`] per tick. A crash leaves at worst a partial last record,
//! which the reader reports and drops.
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
pub const VERSION: u32 = 3;
pub const RECORD_BYTES: usize = 8 + 8 + 8 + 12 * 8 + 4 + 8 + 3 * 8 + 3 * 8 + 3 * 8 + 4 + 4 + 8;

/// Flag bits of a record.
pub const FLAG_CUT: u32 = 1;
pub const FLAG_MISSED: u32 = 2;
pub const FLAG_DEVICE_FAULT: u32 = 4;

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
}

/// One tick as logged.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
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
    }

    pub fn decode(buf: &[u8; RECORD_BYTES]) -> Self {
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
    buf: &'a [u8; RECORD_BYTES],
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

/// Writes the header; records follow with [`write_record`].
pub fn write_header(out: &mut impl Write, header: &LogHeader) -> std::io::Result<()> {
    let json = serde_json::to_vec(header).map_err(std::io::Error::other)?;
    out.write_all(&MAGIC)?;
    out.write_all(&VERSION.to_le_bytes())?;
    out.write_all(&(json.len() as u32).to_le_bytes())?;
    out.write_all(&json)
}

pub fn write_record(out: &mut impl Write, record: &TickRecord) -> std::io::Result<()> {
    let mut buf = [0u8; RECORD_BYTES];
    record.encode(&mut buf);
    out.write_all(&buf)
}

/// A log read back.
#[derive(Clone, Debug)]
pub struct SessionLog {
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

    pub fn parse(bytes: &[u8]) -> std::result::Result<Self, String> {
        if bytes.len() < 16 || bytes[..8] != MAGIC {
            return Err("not a dentsim session log (bad magic)".into());
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != VERSION {
            return Err(format!("log version {version}, this build reads version {VERSION}"));
        }
        let len = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize;
        let body = bytes.get(16..16 + len).ok_or("header runs past the end of the file")?;
        let header: LogHeader = serde_json::from_slice(body).map_err(|e| format!("header: {e}"))?;
        let rest = &bytes[16 + len..];
        let records = rest
            .chunks_exact(RECORD_BYTES)
            .map(|c| TickRecord::decode(c.try_into().expect("exact chunk")))
            .collect();
        Ok(SessionLog { header, records, truncated_bytes: rest.len() % RECORD_BYTES })
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
            flags: FLAG_CUT | FLAG_MISSED,
            changed_voxels: 3047,
        };
        let mut buf = [0u8; RECORD_BYTES];
        r.encode(&mut buf);
        assert_eq!(TickRecord::decode(&buf), r);
        let header = LogHeader {
            params: HapticParams::default(),
            device: "test".into(),
            tissues: vec!["enamel".into()],
            start_hashes: vec![7],
            source: "unit test".into(),
        };
        let mut bytes = Vec::new();
        write_header(&mut bytes, &header).unwrap();
        write_record(&mut bytes, &r).unwrap();
        bytes.extend_from_slice(&[1, 2, 3]);
        let log = SessionLog::parse(&bytes).unwrap();
        assert_eq!((log.header, log.records, log.truncated_bytes), (header, vec![r], 3));
        assert!(SessionLog::parse(b"GARBAGE!").unwrap_err().contains("magic"));
    }
}
