//! Device frame → scan frame: where a physical device's workspace sits on the scan.
//!
//! A device reports its tool pose in its own frame (mm, origin at its workspace centre for an
//! arm; the start for a SpaceMouse). The session places it on the scan as
//! `p_scan = offset + R · (scale · p_device)`, the tool's orientation turned by `R`; forces and
//! torques go back turned by `R⁻¹` (not scaled: the hand feels the tissue's force as it is).
//! `scale` below 1 makes hand motion finer on the tooth (0.25: 4 mm of hand per mm of burr).
//! Without an `offset` the workspace is centred on the chosen tooth: the device origin goes to
//! the point the session names (1 mm above the top of the tooth's tissues, over the middle of
//! their bounding box), so the neutral stylus position holds the burr just above the crown.
use glam::{DAffine3, DQuat, DVec3, EulerRot};

use crate::{Device, DeviceState, Fault};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Registration {
    pub scale: f64,
    pub rotation: DQuat,
    /// Where the device origin goes (scan mm); `None` for the tooth's workspace centre.
    pub offset: Option<DVec3>,
}

impl Default for Registration {
    fn default() -> Self {
        Registration { scale: 1.0, rotation: DQuat::IDENTITY, offset: None }
    }
}

/// The keys of `+reg:...`, for help texts.
pub const REGISTRATION_KEYS: &str = "scale (> 0, 1), rotate=RX:RY:RZ (degrees about x, then y, then z), \
                                     offset=X:Y:Z (mm; default: centred on the tooth)";

impl Registration {
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut r = Registration::default();
        for pair in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = pair.split_once('=').ok_or_else(|| format!("'{pair}' is not KEY=VALUE"))?;
            let (key, value) = (key.trim(), value.trim());
            let xyz = || -> Result<DVec3, String> {
                let v: Vec<f64> = value.split(':').filter_map(|c| c.trim().parse::<f64>().ok().filter(|v| v.is_finite())).collect();
                <[f64; 3]>::try_from(v).map(DVec3::from_array).map_err(|_| format!("field '{key}': '{value}' is not X:Y:Z"))
            };
            match key {
                "scale" => {
                    r.scale = value.parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0).ok_or_else(|| format!("field 'scale': '{value}', expected > 0"))?
                }
                "rotate" => {
                    let d = xyz()?;
                    r.rotation = DQuat::from_euler(EulerRot::ZYX, d.z.to_radians(), d.y.to_radians(), d.x.to_radians());
                }
                "offset" => r.offset = Some(xyz()?),
                other => return Err(format!("unknown field '{other}' (known: {REGISTRATION_KEYS})")),
            }
        }
        Ok(r)
    }

    /// The device → scan transform with the origin at `centre` when no offset is set.
    pub fn transform(&self, centre: DVec3) -> DAffine3 {
        DAffine3::from_rotation_translation(self.rotation, self.offset.unwrap_or(centre))
    }
}

/// A device whose poses are placed on the scan and whose forces go back into its frame.
pub struct Registered<D: Device> {
    pub inner: D,
    scale: f64,
    to_scan: DAffine3,
    name: String,
}

impl<D: Device> Registered<D> {
    pub fn new(inner: D, registration: &Registration, centre: DVec3) -> Self {
        let to_scan = registration.transform(centre);
        let name = inner.name().to_string();
        Registered { inner, scale: registration.scale, to_scan, name }
    }

    /// Device pose → scan pose (allocation-free).
    pub fn place(&self, pose: DAffine3) -> DAffine3 {
        DAffine3 { matrix3: self.to_scan.matrix3 * pose.matrix3, translation: self.to_scan.transform_point3(pose.translation * self.scale) }
    }
}

impl<D: Device> Device for Registered<D> {
    fn poll(&mut self, t: f64) -> Result<DeviceState, Fault> {
        let s = self.inner.poll(t)?;
        Ok(DeviceState { pose: self.place(s.pose), ..s })
    }

    fn send_force(&mut self, force: DVec3, torque: DVec3) {
        let back = self.to_scan.matrix3.transpose();
        self.inner.send_force(back * force, back * torque)
    }

    fn finished(&self, t: f64) -> bool {
        self.inner.finished(t)
    }

    fn name(&self) -> &str {
        &self.name
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ScriptedPath;

    #[test]
    fn poses_go_onto_the_scan_and_forces_back() {
        let r = Registration::parse("scale=0.5,rotate=0:0:90,offset=10:0:5").unwrap();
        let path = ScriptedPath::parse("t,x,y,z,qw,qx,qy,qz\n0,2,0,0,1,0,0,0\n", "p.csv").unwrap();
        let mut dev = Registered::new(path, &r, DVec3::ZERO);
        let s = dev.poll(0.0).unwrap();
        // 2 mm along device x, halved, turned 90° about z: 1 mm along scan y, from the offset.
        assert!((s.pose.translation - DVec3::new(10.0, 1.0, 5.0)).length() < 1e-12, "{}", s.pose.translation);
        assert!((s.pose.transform_vector3(DVec3::X) - DVec3::Y).length() < 1e-12);
        // A force along scan y is along device x.
        dev.send_force(DVec3::new(0.0, 1.0, 0.0), DVec3::ZERO);
        assert!((dev.inner.last_force.0 - DVec3::X).length() < 1e-12, "{}", dev.inner.last_force.0);
        // Without an offset the device origin goes to the tooth's centre.
        let centred = Registration::parse("").unwrap().transform(DVec3::new(1.0, 2.0, 6.0));
        assert_eq!(centred.translation, DVec3::new(1.0, 2.0, 6.0));
        let e = |t: &str| Registration::parse(t).unwrap_err();
        assert!(e("scale=0").contains("'scale'") && e("rotate=1:2").contains("'rotate'") && e("shear=1").contains("unknown field"));
    }
}
