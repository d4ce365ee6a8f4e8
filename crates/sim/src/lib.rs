//! Tissues, burrs and cutting over OpenVDB level sets. Knows nothing of C++.

pub mod burr;
pub mod cut;
pub mod error;
pub mod export;
pub mod model;
pub mod phantom;
pub mod preparation;
pub mod tissue;

pub use error::{Error, Result};
pub mod contact;
pub mod filter;
pub mod force;
pub mod haptics;
pub mod proxy;
pub mod watchdog;
pub mod log;
pub mod session;
pub mod plot;
pub mod replay;
pub mod bench;
