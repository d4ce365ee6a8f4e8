//! The SpaceMouse as a pose device and a foot pedal as the cut switch of any pose device.
use glam::{DAffine3, DVec3};

use super::link::HidLink;
use super::rate::RateMap;
use super::reports::{apply_spacemouse_report, pedal_pressed, SpaceMouseRaw};
use crate::{Device, DeviceState, Fault, BUTTON_CUT, DEFAULT_RPM};

/// A SpaceMouse driving the tool pose by rate (see [`RateMap`] for the defaults).
pub struct SpaceMouse {
    link: HidLink,
    map: RateMap,
    start: DAffine3,
    pose: DAffine3,
    raw: SpaceMouseRaw,
    last_t: Option<f64>,
    generation: u64,
    name: String,
}

impl SpaceMouse {
    pub fn new(link: HidLink, map: RateMap, start: DVec3, name: impl Into<String>) -> Self {
        let start = DAffine3::from_translation(start);
        let generation = link.generation();
        SpaceMouse { link, map, start, pose: start, raw: SpaceMouseRaw::default(), last_t: None, generation, name: name.into() }
    }

    pub fn unplugs(&self) -> u64 {
        self.link.unplugs()
    }
}

impl Device for SpaceMouse {
    fn poll(&mut self, t: f64) -> Result<DeviceState, Fault> {
        let raw = &mut self.raw;
        let connected = self.link.drain(|r| {
            apply_spacemouse_report(raw, r);
        });
        let dt = self.last_t.map_or(0.0, |l| (t - l).clamp(0.0, 0.1));
        self.last_t = Some(t);
        let generation = self.link.generation();
        if !connected || generation != self.generation {
            // Unplugged: no motion and no buttons held; the tool stays where it was, and a
            // re-plugged device starts from rest.
            self.raw = SpaceMouseRaw::default();
            self.generation = generation;
            if !connected {
                return Err(Fault::Disconnected);
            }
        }
        self.pose = self.map.step(self.pose, self.start, &self.raw, dt);
        Ok(DeviceState { pose: self.pose, buttons: self.map.buttons(&self.raw), rpm: DEFAULT_RPM })
    }

    fn send_force(&mut self, _force: DVec3, _torque: DVec3) {}

    fn name(&self) -> &str {
        &self.name
    }
}

/// Any pose device with a USB foot pedal as its cut switch (held = cut). An unplugged pedal is
/// a released one: the session goes on in touch mode.
pub struct WithPedal<D: Device> {
    pub inner: D,
    link: HidLink,
    key: u8,
    pressed: bool,
    name: String,
}

impl<D: Device> WithPedal<D> {
    pub fn new(inner: D, link: HidLink, key: u8) -> Self {
        let name = format!("{} + foot pedal", inner.name());
        WithPedal { inner, link, key, pressed: false, name }
    }
}

impl<D: Device> Device for WithPedal<D> {
    fn poll(&mut self, t: f64) -> Result<DeviceState, Fault> {
        let (key, pressed) = (self.key, &mut self.pressed);
        if !self.link.drain(|r| {
            if let Some(p) = pedal_pressed(r, key) {
                *pressed = p;
            }
        }) {
            self.pressed = false;
        }
        let mut s = self.inner.poll(t)?;
        if self.pressed {
            s.buttons |= BUTTON_CUT;
            if s.rpm == 0.0 {
                s.rpm = DEFAULT_RPM;
            }
        }
        Ok(s)
    }

    fn send_force(&mut self, force: DVec3, torque: DVec3) {
        self.inner.send_force(force, torque)
    }

    fn finished(&self, t: f64) -> bool {
        self.inner.finished(t)
    }

    fn name(&self) -> &str {
        &self.name
    }
}
