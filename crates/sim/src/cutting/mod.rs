//! Cutting: the burr swept from pose to pose as a patch of distances, subtracted from every
//! tissue; removal rates, the mesh chunks a cut dirtied, the undo journal.
pub mod cutter;
pub mod dirty;
pub mod history;
pub mod removal;
pub mod sweep;

pub use cutter::{Cutter, Handoff, StrokeReport};
pub use dirty::DirtyLeaves;
pub use history::History;
pub use removal::Feed;
