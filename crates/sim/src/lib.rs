//! Tissues, burrs and cutting over OpenVDB level sets. Knows nothing of C++.

pub mod bench;
pub mod burr;
pub mod cut;
pub mod error;
pub mod export;
pub mod model;
pub mod phantom;
pub mod preparation;
pub mod tissue;

pub use error::{Error, Result};
