//! Planning: tool paths cut into preparations, the phantom stroke, the demo.
pub mod batch;
pub mod demo;
pub mod path;
pub mod phantom_stroke;
pub mod prepare;

pub use path::ToolPath;
pub use phantom_stroke::PhantomStroke;
pub use prepare::{prepare, PrepareOptions, PrepareReport};
