//! USB HID input devices: a 3Dconnexion SpaceMouse (a rate device mapped to a tool pose) and
//! foot pedals that present as keyboards (the cut switch). Report layouts are in [`reports`];
//! the mapping from counts to motion in [`rate`]. Listing uses hidapi over Debian's
//! libhidapi-dev (hidraw backend).
mod device;
pub mod link;
pub mod rate;
pub mod reports;

pub use device::{SpaceMouse, WithPedal};

/// One HID device found, with what dentsim makes of it.
#[derive(Clone, Debug, PartialEq)]
pub struct HidInfo {
    pub vendor: u16,
    pub product: u16,
    pub path: String,
    pub product_string: String,
    /// "SpaceMouse (…)", "foot pedal (…)" or "" for devices dentsim does not use.
    pub role: String,
}

/// Every HID device hidapi sees (none where no /dev/hidraw exists); an error names hidapi.
pub fn list() -> crate::Result<Vec<HidInfo>> {
    let api = hidapi::HidApi::new().map_err(|e| crate::Error::Invalid { what: "hidapi".into(), message: e.to_string() })?;
    let mut out: Vec<HidInfo> = api
        .device_list()
        .map(|d| {
            let (v, p) = (d.vendor_id(), d.product_id());
            let role = match (reports::spacemouse_name(v, p), reports::pedal_name(v, p)) {
                (Some(n), _) => format!("SpaceMouse ({n})"),
                (_, Some(n)) => format!("foot pedal ({n})"),
                _ => String::new(),
            };
            HidInfo { vendor: v, product: p, path: d.path().to_string_lossy().into_owned(), product_string: d.product_string().unwrap_or("").to_string(), role }
        })
        .collect();
    out.sort_by(|a, b| a.path.cmp(&b.path));
    out.dedup_by(|a, b| a.path == b.path);
    Ok(out)
}
