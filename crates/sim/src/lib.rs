//! The dentsim core over OpenVDB level sets; knows nothing of C++. Its rooms, each a folder whose
//! `mod.rs` names what it offers, from the ground up (a room touches only rooms below it):
//!
//! - [`tissues`]: the tissue table, the model (one level set per tissue), the capsule phantom,
//!   tissues from a scan, surfaces (the one mesher), exports.
//! - [`burr`]: ISO 6360 heads as exact signed distance functions, specs, the catalogue.
//! - [`cutting`]: the swept burr, the cut, removal rates, dirty chunks, undo.
//! - [`haptics`]: contact, proxy, force, filters, watchdog, the 1 kHz tick.
//! - [`plan`]: tool paths into preparations, the phantom stroke, the demo.
//! - [`session`]: the threads, log, live display, replay, outputs in a folder, force plot.
//!
//! The types most callers need are re-exported here.
pub mod assess;
pub mod burr;
pub mod cutting;
pub mod error;
pub mod haptics;
pub mod limits;
pub mod plan;
pub mod session;
pub mod tissues;

/// The devices crate, for the faces (CLI, plugin) that name a device profile or tool path.
/// Uniform numbers in [0, 1) from a fixed seed (xorshift64): tests' random cases, the same every run.
#[cfg(test)]
pub(crate) fn unit_random(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

pub use dentsim_devices as devices;
pub use error::{Error, Result};
pub use limits::Limits;

pub use burr::{Burr, Shape, DEFAULT_BURR};
pub use cutting::{Cutter, Feed, Handoff, StrokeReport};
pub use haptics::{HapticCore, HapticParams, TickOutput};
pub use plan::{prepare, PhantomStroke, PrepareOptions, PrepareReport, ToolPath};
pub use session::{replay, run_session, LiveSession, Session, SessionLog, SessionOptions, SessionOutcome};
pub use tissues::{surface, CapsuleTooth, Mesher, TissueModel, TissueProps, TissueTable, TissueVolumes, TissuesFromScan};
