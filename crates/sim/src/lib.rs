//! Tissues, burrs and cutting over OpenVDB level sets. Knows nothing of C++.

pub mod bench;
pub mod burr;
pub mod cut;
pub mod dirty;
pub mod error;
pub mod export;
pub mod history;
pub mod mesher;
pub mod model;
pub mod path;
pub mod phantom;
pub mod prepare;
pub mod preparation;
pub mod removal;
pub mod sweep;
pub mod tissue;

pub use error::{Error, Result};
