//! Input devices for dentsim sessions. A device reports the tool pose (tip at the origin, axis
//! +Z toward the handpiece, world mm), buttons and handpiece speed, and takes the force to render.
//! This crate knows nothing of tissues: the session in `dentsim-sim` is generic over [`Device`].

mod error;
mod hand;
pub mod hid;
pub mod igtl;
pub mod path;
mod profile;
pub mod registration;
mod scripted;
mod spec;

pub use error::{Error, Result};
pub use hand::{SimulatedHand, HandParams};
pub use profile::DeviceProfile;
pub use path::{PathLimits, PathSample, PolylineArrays, ToolPath};
pub use scripted::{ScriptedPath, DEFAULT_RPM};
pub use spec::{DeviceSpec, PedalOptions, SpaceMouseOptions, HAND_KEYS, PEDAL_KEYS, SPACEMOUSE_KEYS};

use glam::{DAffine3, DVec3};

/// The haptic loop's period (s): 1 kHz, the rate haptic rendering needs for stiff contact.
pub const HAPTIC_PERIOD_S: f64 = 1e-3;

/// Button bit: the foot pedal / handpiece button that switches touch mode to cut mode.
pub const BUTTON_CUT: u32 = 1;

/// What a device reports at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceState {
    /// Tool frame → world (mm).
    pub pose: DAffine3,
    /// Bit set of `BUTTON_*`.
    pub buttons: u32,
    /// Handpiece speed (rev/min); 0 when the burr stands still.
    pub rpm: f64,
}

impl DeviceState {
    pub fn cutting(&self) -> bool {
        self.buttons & BUTTON_CUT != 0 && self.rpm > 0.0
    }
}

/// Why a device gave no state this tick (Copy so the haptic thread never allocates for it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// The hardware or link stopped answering.
    Disconnected,
}

/// A haptic or input device as the 1 kHz haptic thread sees it.
///
/// `poll` and `send_force` run inside the haptic tick: they must not allocate, lock or block.
pub trait Device: Send {
    /// The device's state at session time `t` (s, from the session start).
    fn poll(&mut self, t: f64) -> std::result::Result<DeviceState, Fault>;
    /// Force (N) and torque (N·mm) for the user, world frame.
    fn send_force(&mut self, force: DVec3, torque: DVec3);
    /// True once a scripted device has played everything it has (`t` in s).
    fn finished(&self, _t: f64) -> bool {
        false
    }
    /// Short name for logs and reports.
    fn name(&self) -> &str;
}

impl<D: Device + ?Sized> Device for Box<D> {
    fn poll(&mut self, t: f64) -> std::result::Result<DeviceState, Fault> {
        (**self).poll(t)
    }
    fn send_force(&mut self, force: DVec3, torque: DVec3) {
        (**self).send_force(force, torque)
    }
    fn finished(&self, t: f64) -> bool {
        (**self).finished(t)
    }
    fn name(&self) -> &str {
        (**self).name()
    }
}
