//! Bounds on what one command may take, checked before the work allocates or starts: one
//! definition for segment, prepare, session and replay (the CLI's `--max-memory-gib` and
//! `--max-duration-s`).
use crate::error::{invalid, Result};

/// Default memory cap (GiB): a tooth at 0.05 mm needs well under 1 GiB; a wrong voxel size or a
/// forged header asks for tens.
pub const DEFAULT_MAX_MEMORY_GIB: f64 = 4.0;
/// Default longest session (s, session time): an hour of hand-held preparation at 1 kHz.
pub const DEFAULT_MAX_SESSION_S: f64 = 3600.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub max_memory_bytes: u64,
    pub max_session_s: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { max_memory_bytes: gib_to_bytes(DEFAULT_MAX_MEMORY_GIB), max_session_s: DEFAULT_MAX_SESSION_S }
    }
}

impl Limits {
    /// From the CLI's units; errors name the option.
    pub fn new(max_memory_gib: f64, max_session_s: f64) -> Result<Self> {
        if !(max_memory_gib.is_finite() && max_memory_gib > 0.0) {
            return Err(invalid("--max-memory-gib", format!("{max_memory_gib} is not a positive size")));
        }
        if !(max_session_s.is_finite() && max_session_s > 0.0) {
            return Err(invalid("--max-duration-s", format!("{max_session_s} is not a positive duration")));
        }
        Ok(Limits { max_memory_bytes: gib_to_bytes(max_memory_gib), max_session_s })
    }

    /// An error unless `bytes` fit the memory cap; `what` names the input and the reason.
    pub fn check_memory(&self, what: &str, bytes: u64) -> Result<()> {
        if bytes > self.max_memory_bytes {
            return Err(invalid(
                what,
                format!(
                    "would need about {:.2} GiB, over the memory cap of {:.2} GiB (--max-memory-gib)",
                    bytes as f64 / (1u64 << 30) as f64,
                    self.max_memory_bytes as f64 / (1u64 << 30) as f64
                ),
            ));
        }
        Ok(())
    }

    /// An error unless a device running `duration_s` fits the session cap.
    pub fn check_session(&self, device: &str, duration_s: f64) -> Result<()> {
        if !(duration_s.is_finite() && duration_s <= self.max_session_s) {
            return Err(invalid(
                format!("device '{device}'"),
                format!("runs {duration_s} s, longer than the session cap of {} s (--max-duration-s)", self.max_session_s),
            ));
        }
        Ok(())
    }
}

fn gib_to_bytes(gib: f64) -> u64 {
    (gib * (1u64 << 30) as f64).min(u64::MAX as f64) as u64
}
