//! Tissues, burrs, cutting, contact and force, the session loop and its log, over OpenVDB level
//! sets. Knows nothing of C++.

pub mod bench;
pub mod burr;
pub mod contact;
pub mod cut;
pub mod demo;
pub mod dirty;
pub mod error;
pub mod export;
pub mod filter;
pub mod force;
pub mod haptics;
pub mod history;
pub mod headless;
pub mod live;
pub mod log;
pub mod mesher;
pub mod model;
pub mod path;
pub mod phantom;
pub mod plot;
pub mod preparation;
pub mod prepare;
pub mod proxy;
pub mod removal;
pub mod replay;
pub mod scan;
pub mod session;
pub mod sweep;
pub mod tissue;
pub mod watchdog;

pub use error::{Error, Result};
/// The devices crate, for the faces (CLI, plugin) that name a device profile or tool path.
pub use dentsim_devices as devices;
