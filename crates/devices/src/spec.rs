//! A device named by one line of text, as the `dentsim` command and the plugin take it:
//! `scripted:PATH.csv` (a tool path), `hand:KEY=VAL,...` (a simulated hand; vectors as X:Y:Z) or
//! `igtl://HOST:PORT?KEY=VAL&...` (a force-feedback arm over OpenIGTLink) or
//! `spacemouse[:KEY=VAL,...]` (a 3Dconnexion SpaceMouse over hidapi); any of them followed by
//! `+pedal[:key=b,device=VID:PID]` takes its cut switch from a USB foot pedal.
//! Parsing happens before a session starts, so every error names the field and what was expected.
use std::path::PathBuf;

use glam::{DQuat, DVec3};

use crate::error::{Error, Result};
use crate::hid::link::{HidLink, HidapiOpener};
use crate::hid::rate::{parse_axes, RateMap};
use crate::hid::reports::{key_usage, pedal_name, spacemouse_name};
use crate::hid::{SpaceMouse, WithPedal};
use crate::igtl::{IgtlDevice, IgtlOptions};
use crate::registration::{Registered, Registration};
use crate::{Device, HandParams, ScriptedPath, SimulatedHand};

/// Which device a session uses, parsed but not yet opened.
#[derive(Clone, Debug, PartialEq)]
pub enum DeviceSpec {
    Scripted(PathBuf),
    Hand(HandParams),
    Igtl(IgtlOptions),
    SpaceMouse(SpaceMouseOptions),
    /// A pose device with a foot pedal as its cut switch.
    WithPedal(Box<DeviceSpec>, PedalOptions),
    /// A live device placed on the scan by an explicit registration.
    Registered(Box<DeviceSpec>, Registration),
}

/// A SpaceMouse's settings: the rate map, where the tool starts (mm), which device.
#[derive(Clone, Debug, PartialEq)]
pub struct SpaceMouseOptions {
    pub map: RateMap,
    pub start: DVec3,
    /// Vendor and product id; `None` takes the first 3Dconnexion 6-DOF device found.
    pub device: Option<(u16, u16)>,
}

/// A foot pedal: the key it types while pressed (HID usage) and which device.
#[derive(Clone, Debug, PartialEq)]
pub struct PedalOptions {
    pub key: u8,
    pub device: Option<(u16, u16)>,
}

/// The SpaceMouse's and the pedal's keys, for help texts.
pub const SPACEMOUSE_KEYS: &str = "dead (counts of ±350, 15), speed (mm/s at full deflection, 10), turn (°/s, 45), \
                                   axes (x:-y:-z), workspace (mm, 15), start=X:Y:Z (mm), device=VID:PID (hex)";
pub const PEDAL_KEYS: &str = "key (a letter, digit or HID usage; b), device=VID:PID (hex)";

/// The simulated hand's keys with their units, for help texts.
pub const HAND_KEYS: &str = "start=X:Y:Z, target=X:Y:Z (mm), push (N), stiffness (N/mm), damping (N·s/mm), \
                             mass (kg), pedal (0|1), rpm, duration (s)";

impl DeviceSpec {
    pub fn parse(text: &str) -> Result<Self> {
        let err = |message: String| Error::Invalid { what: format!("device '{text}'"), message };
        // The suffix written last applies outermost: `DEVICE+pedal:...+reg:...` or the reverse.
        let reg_last = text.rfind("+reg").is_some_and(|r| text.rfind("+pedal").is_none_or(|p| r > p));
        if let Some((base, reg)) = text.rsplit_once("+reg").filter(|_| reg_last) {
            let reg = match reg.strip_prefix(':') {
                Some(rest) => Registration::parse(rest),
                None if reg.trim().is_empty() => Ok(Registration::default()),
                None => Err(format!("'+reg{reg}': expected +reg:KEY=VAL,...")),
            }
            .map_err(err)?;
            let inner = DeviceSpec::parse(base)?;
            if !inner.is_live() {
                return Err(err("+reg places a live device (igtl://, spacemouse) on the scan; scripted paths and the hand are in scan mm already".into()));
            }
            return Ok(DeviceSpec::Registered(Box::new(inner), reg));
        }
        if let Some((base, pedal)) = text.rsplit_once("+pedal") {
            let pedal = match pedal.strip_prefix(':') {
                Some(rest) => parse_pedal(rest),
                None if pedal.trim().is_empty() => parse_pedal(""),
                None => Err(format!("'+pedal{pedal}': expected +pedal or +pedal:KEY=VAL,...")),
            }
            .map_err(err)?;
            return Ok(DeviceSpec::WithPedal(Box::new(DeviceSpec::parse(base)?), pedal));
        }
        if let Some(rest) = text.trim().strip_prefix("spacemouse") {
            let rest = match rest.strip_prefix(':') {
                Some(r) => r,
                None if rest.is_empty() => "",
                None => return Err(err(format!("unknown kind 'spacemouse{rest}'"))),
            };
            return parse_spacemouse(rest).map(DeviceSpec::SpaceMouse).map_err(err);
        }
        if let Some(rest) = text.trim().strip_prefix("igtl://") {
            return IgtlOptions::parse(rest).map(DeviceSpec::Igtl).map_err(err);
        }
        let (kind, rest) = text.split_once(':').ok_or_else(|| err("expected scripted:PATH.csv, hand:KEY=VAL,..., igtl://HOST:PORT or spacemouse".into()))?;
        match kind.trim() {
            "scripted" if !rest.trim().is_empty() => Ok(DeviceSpec::Scripted(PathBuf::from(rest.trim()))),
            "scripted" => Err(err("no path after 'scripted:'".into())),
            "hand" => parse_hand(rest).map(DeviceSpec::Hand).map_err(err),
            other => Err(err(format!("unknown kind '{other}', expected 'scripted', 'hand', 'spacemouse' or igtl://"))),
        }
    }

    /// Opens the device (reads the tool path); errors name the file, row and column. Also
    /// returns how long it will run (s), for progress bars. A live device's workspace is
    /// centred on the scan origin: sessions use [`DeviceSpec::open_on`] with the tooth's centre.
    pub fn open(&self) -> Result<(Box<dyn Device>, f64)> {
        self.open_on(DVec3::ZERO)
    }

    /// Opens the device with a live device's workspace centred on `tooth_centre` (scan mm)
    /// unless its registration gives an offset (see [`Registration`]).
    pub fn open_on(&self, tooth_centre: DVec3) -> Result<(Box<dyn Device>, f64)> {
        Ok(match self {
            DeviceSpec::Registered(inner, reg) => {
                let (device, duration) = inner.open_raw()?;
                (Box::new(Registered::new(device, reg, tooth_centre)), duration)
            }
            live if live.is_live() => {
                let (device, duration) = live.open_raw()?;
                (Box::new(Registered::new(device, &Registration::default(), tooth_centre)), duration)
            }
            other => other.open_raw()?,
        })
    }

    fn open_raw(&self) -> Result<(Box<dyn Device>, f64)> {
        Ok(match self {
            DeviceSpec::Registered(inner, _) => inner.open_raw()?,
            DeviceSpec::Scripted(path) => {
                let p = ScriptedPath::read(path)?;
                let d = p.duration();
                (Box::new(p), d)
            }
            DeviceSpec::Hand(params) => (Box::new(SimulatedHand::new(*params)), params.duration_s),
            // Runs until the peer closes or the session's cap: the caller sets the duration.
            DeviceSpec::Igtl(options) => (Box::new(IgtlDevice::connect(options.clone())?), f64::INFINITY),
            DeviceSpec::SpaceMouse(o) => {
                let wanted = o.device;
                let opener = HidapiOpener::new(move |v, p| match wanted {
                    Some(id) => (v, p) == id,
                    None => spacemouse_name(v, p).is_some(),
                });
                let link = HidLink::start(opener, "spacemouse").ok_or_else(|| Error::Invalid {
                    what: "spacemouse".into(),
                    message: "no SpaceMouse plugged in (`dentsim devices` lists the HID devices; Linux needs read access to /dev/hidraw*)".into(),
                })?;
                (Box::new(SpaceMouse::new(link, o.map, o.start, "SpaceMouse")), f64::INFINITY)
            }
            DeviceSpec::WithPedal(inner, p) => {
                let (device, duration) = inner.open_raw()?;
                let wanted = p.device;
                let opener = HidapiOpener::new(move |v, pr| match wanted {
                    Some(id) => (v, pr) == id,
                    None => pedal_name(v, pr).is_some(),
                });
                let link = HidLink::start(opener, "pedal").ok_or_else(|| Error::Invalid {
                    what: "foot pedal".into(),
                    message: "none plugged in (`dentsim devices` lists the HID devices)".into(),
                })?;
                (Box::new(WithPedal::new(device, link, p.key)), duration)
            }
        })
    }

    /// Where a live device's frame goes on the scan (its explicit `+reg` or the default, centred
    /// on the tooth); `None` for scripted paths and the hand, which are in scan mm already.
    pub fn registration(&self) -> Option<Registration> {
        match self {
            DeviceSpec::Registered(_, r) => Some(*r),
            DeviceSpec::WithPedal(inner, _) => inner.registration(),
            live if live.is_live() => Some(Registration::default()),
            _ => None,
        }
    }

    /// A device a person moves: the session ticks on the wall clock and runs until the device
    /// ends it (or the session cap), so `open`'s duration is infinite.
    pub fn is_live(&self) -> bool {
        match self {
            DeviceSpec::Igtl(_) | DeviceSpec::SpaceMouse(_) => true,
            DeviceSpec::WithPedal(inner, _) | DeviceSpec::Registered(inner, _) => inner.is_live(),
            _ => false,
        }
    }
}

fn key_values(text: &str) -> impl Iterator<Item = std::result::Result<(&str, &str), String>> {
    text.split(',').map(str::trim).filter(|s| !s.is_empty()).map(|pair| {
        pair.split_once('=').map(|(k, v)| (k.trim(), v.trim())).ok_or_else(|| format!("'{pair}' is not KEY=VALUE"))
    })
}

fn parse_usb_id(key: &str, value: &str) -> std::result::Result<(u16, u16), String> {
    let bad = || format!("field '{key}': '{value}', expected VID:PID in hex (e.g. 256f:c635)");
    let (v, p) = value.split_once(':').ok_or_else(bad)?;
    let hex = |s: &str| u16::from_str_radix(s.trim().trim_start_matches("0x"), 16).map_err(|_| bad());
    Ok((hex(v)?, hex(p)?))
}

fn parse_spacemouse(text: &str) -> std::result::Result<SpaceMouseOptions, String> {
    let mut o = SpaceMouseOptions { map: RateMap::default(), start: DVec3::ZERO, device: None };
    for kv in key_values(text) {
        let (key, value) = kv?;
        let number = |lo: f64| -> std::result::Result<f64, String> {
            value.parse::<f64>().ok().filter(|v| v.is_finite() && *v >= lo).ok_or_else(|| format!("field '{key}': '{value}', expected a number >= {lo}"))
        };
        match key {
            "dead" => o.map.dead_zone = number(0.0).and_then(|v| if v < 300.0 { Ok(v) } else { Err(format!("field 'dead': {v}, expected < 300 counts")) })?,
            "speed" => o.map.translate_mm_s = number(0.0)?,
            "turn" => o.map.rotate_deg_s = number(0.0)?,
            "workspace" => o.map.workspace_mm = number(0.0)?,
            "axes" => o.map.axes = parse_axes(&value.replace(':', ",")).ok_or_else(|| format!("field 'axes': '{value}', expected a permutation of x:y:z with signs, e.g. x:-y:-z"))?,
            "start" => {
                let v: Vec<f64> = value.split(':').filter_map(|c| c.trim().parse::<f64>().ok().filter(|v| v.is_finite())).collect();
                o.start = <[f64; 3]>::try_from(v).map(DVec3::from_array).map_err(|_| format!("field 'start': '{value}' is not X:Y:Z in mm"))?;
            }
            "device" => o.device = Some(parse_usb_id(key, value)?),
            other => return Err(format!("unknown field '{other}' (known: {SPACEMOUSE_KEYS})")),
        }
    }
    Ok(o)
}

fn parse_pedal(text: &str) -> std::result::Result<PedalOptions, String> {
    let mut o = PedalOptions { key: 5, device: None };
    for kv in key_values(text) {
        let (key, value) = kv?;
        match key {
            "key" => o.key = key_usage(value).ok_or_else(|| format!("field 'key': '{value}', expected a letter, a digit or a HID usage >= 4"))?,
            "device" => o.device = Some(parse_usb_id(key, value)?),
            other => return Err(format!("unknown field '{other}' (known: {PEDAL_KEYS})")),
        }
    }
    Ok(o)
}

fn parse_hand(text: &str) -> std::result::Result<HandParams, String> {
    let mut p = HandParams::default();
    for pair in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (key, value) = pair.split_once('=').ok_or_else(|| format!("'{pair}' is not KEY=VALUE"))?;
        let (key, value) = (key.trim(), value.trim());
        let number = || -> std::result::Result<f64, String> {
            let v: f64 = value.parse().map_err(|_| format!("field '{key}': '{value}' is not a number"))?;
            if v.is_finite() { Ok(v) } else { Err(format!("field '{key}': {v} is not finite")) }
        };
        let positive = || -> std::result::Result<f64, String> {
            let v = number()?;
            if v > 0.0 { Ok(v) } else { Err(format!("field '{key}': {v}, expected > 0")) }
        };
        let vector = || -> std::result::Result<DVec3, String> {
            let v: Vec<f64> = value
                .split(':')
                .map(|c| c.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
                .collect::<Option<_>>()
                .ok_or_else(|| format!("field '{key}': '{value}' is not X:Y:Z in mm"))?;
            <[f64; 3]>::try_from(v).map(DVec3::from_array).map_err(|_| format!("field '{key}': '{value}' is not X:Y:Z in mm"))
        };
        match key {
            "start" => p.start = vector()?,
            "target" => p.target = vector()?,
            "push" => p.push_n = positive()?,
            "stiffness" => p.stiffness_n_per_mm = positive()?,
            "damping" => {
                p.damping_n_s_per_mm = number()?;
                if p.damping_n_s_per_mm < 0.0 {
                    return Err(format!("field 'damping': {}, expected >= 0", p.damping_n_s_per_mm));
                }
            }
            "mass" => p.mass_kg = positive()?,
            "rpm" => {
                p.rpm = number()?;
                if p.rpm < 0.0 {
                    return Err(format!("field 'rpm': {}, expected >= 0", p.rpm));
                }
            }
            "duration" => p.duration_s = positive()?,
            "pedal" => {
                p.pedal = match value {
                    "0" => false,
                    "1" => true,
                    _ => return Err(format!("field 'pedal': '{value}', expected 0 or 1")),
                }
            }
            other => return Err(format!("unknown field '{other}' (known: {HAND_KEYS})")),
        }
    }
    p.rotation = DQuat::IDENTITY;
    if p.pedal && p.rpm == 0.0 {
        p.rpm = crate::scripted::DEFAULT_RPM;
    }
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_both_kinds_and_names_bad_fields() {
        let s = DeviceSpec::parse("hand:start=0:0:5.6,target=0:0:2.5,push=2,pedal=1,duration=3").unwrap();
        let DeviceSpec::Hand(h) = s else { panic!("hand") };
        assert_eq!((h.start.z, h.target.z, h.push_n, h.pedal, h.duration_s), (5.6, 2.5, 2.0, true, 3.0));
        assert_eq!(h.rpm, crate::scripted::DEFAULT_RPM);
        assert_eq!(DeviceSpec::parse("scripted:a.csv").unwrap(), DeviceSpec::Scripted("a.csv".into()));
        let e = |t: &str| DeviceSpec::parse(t).unwrap_err().to_string();
        assert!(e("hand:push=abc").contains("field 'push'"), "{}", e("hand:push=abc"));
        assert!(e("hand:start=1:2").contains("field 'start'"));
        assert!(e("hand:mass=-1").contains("field 'mass'"));
        assert!(e("hand:colour=red").contains("unknown field 'colour'"));
        assert!(e("joystick:1").contains("unknown kind"));
        assert!(e("nothing").contains("expected scripted"));
        let open = DeviceSpec::parse("scripted:/nonexistent/p.csv").unwrap().open().err().unwrap().to_string();
        let (_, duration) = DeviceSpec::parse("hand:duration=2.5").unwrap().open().unwrap();
        assert_eq!(duration, 2.5);
        assert!(open.contains("/nonexistent/p.csv"), "{open}");
    }
}
