//! Haptics: burr contact against the tissue level sets, the proxy, the force, its filters, the
//! watchdog, and the tick that joins them at 1 kHz.
pub mod contact;
pub mod filter;
pub mod force;
pub mod guidance;
pub mod proxy;
pub mod tick;
pub mod watchdog;

pub use contact::{BurrSamples, ContactPoint, ContactQuery};
pub use filter::FilterSpec;
pub use guidance::{GuidanceParams, PulpClearance, THIN_DENTIN_MM};
pub use tick::{HapticCore, HapticParams, TickOutput, CUT_TOLERANCE_MM, STROKE_CONTINUES_VOXELS, TOUCH_VOXELS};
pub use watchdog::Deadline;
