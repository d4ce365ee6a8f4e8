//! A device named by one line of text, as the `dentsim` command and the plugin take it:
//! `scripted:PATH.csv` (a tool path), `hand:KEY=VAL,...` (a simulated hand; vectors as X:Y:Z) or
//! `igtl://HOST:PORT?KEY=VAL&...` (a force-feedback arm over OpenIGTLink).
//! Parsing happens before a session starts, so every error names the field and what was expected.
use std::path::PathBuf;

use glam::{DQuat, DVec3};

use crate::error::{Error, Result};
use crate::igtl::{IgtlDevice, IgtlOptions};
use crate::{Device, HandParams, ScriptedPath, SimulatedHand};

/// Which device a session uses, parsed but not yet opened.
#[derive(Clone, Debug, PartialEq)]
pub enum DeviceSpec {
    Scripted(PathBuf),
    Hand(HandParams),
    Igtl(IgtlOptions),
}

/// The simulated hand's keys with their units, for help texts.
pub const HAND_KEYS: &str = "start=X:Y:Z, target=X:Y:Z (mm), push (N), stiffness (N/mm), damping (N·s/mm), \
                             mass (kg), pedal (0|1), rpm, duration (s)";

impl DeviceSpec {
    pub fn parse(text: &str) -> Result<Self> {
        let err = |message: String| Error::Invalid { what: format!("device '{text}'"), message };
        if let Some(rest) = text.trim().strip_prefix("igtl://") {
            return IgtlOptions::parse(rest).map(DeviceSpec::Igtl).map_err(err);
        }
        let (kind, rest) = text.split_once(':').ok_or_else(|| err("expected scripted:PATH.csv, hand:KEY=VAL,... or igtl://HOST:PORT".into()))?;
        match kind.trim() {
            "scripted" if !rest.trim().is_empty() => Ok(DeviceSpec::Scripted(PathBuf::from(rest.trim()))),
            "scripted" => Err(err("no path after 'scripted:'".into())),
            "hand" => parse_hand(rest).map(DeviceSpec::Hand).map_err(err),
            other => Err(err(format!("unknown kind '{other}', expected 'scripted' or 'hand'"))),
        }
    }

    /// Opens the device (reads the tool path); errors name the file, row and column. Also
    /// returns how long it will run (s), for progress bars.
    pub fn open(&self) -> Result<(Box<dyn Device>, f64)> {
        Ok(match self {
            DeviceSpec::Scripted(path) => {
                let p = ScriptedPath::read(path)?;
                let d = p.duration();
                (Box::new(p), d)
            }
            DeviceSpec::Hand(params) => (Box::new(SimulatedHand::new(*params)), params.duration_s),
            // Runs until the peer closes or the session's cap: the caller sets the duration.
            DeviceSpec::Igtl(options) => (Box::new(IgtlDevice::connect(options.clone())?), f64::INFINITY),
        })
    }

    /// A device a person moves: the session ticks on the wall clock and runs until the device
    /// ends it (or the session cap), so `open`'s duration is infinite.
    pub fn is_live(&self) -> bool {
        matches!(self, DeviceSpec::Igtl(_))
    }
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
