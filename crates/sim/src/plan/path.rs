//! Tool paths live in `dentsim-devices` (they know nothing of tissues): one type and one parser
//! for the scripted device, `prepare`, the demo and the plugin's polyline input.
pub use dentsim_devices::path::*;
