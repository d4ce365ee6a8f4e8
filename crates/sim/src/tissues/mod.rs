//! Tissues: the property table, the model (one narrow-band level set per tissue), the analytic
//! capsule phantom, tissues from a CBCT scan, their surfaces (the one mesher) and exports.
pub mod capsule;
pub mod export;
pub mod field;
pub mod from_scan;
pub mod model;
pub mod surface;
pub mod table;

pub use capsule::CapsuleTooth;
pub use export::write_model;
pub use from_scan::{ScanReport, TissuesFromScan};
pub use model::{Tissue, TissueModel, TissueVolumes};
pub use surface::{surface, Mesher, SurfaceFrame};
pub use table::{TissueProps, TissueTable};
