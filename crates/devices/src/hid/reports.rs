//! HID report layouts (REFERENCE.md "Input devices"), parsed from raw bytes so they can be tested
//! on recorded reports (no /dev/hidraw here).
//!
//! SpaceMouse, older family (and most of vendor 0x046d): report 1 = translation, 3 × i16 LE;
//! report 2 = rotation, 3 × i16 LE; report 3 = button bitmap. Newer family (vendor 0x256f):
//! report 1 of 13 bytes carries all six axes; buttons stay in report 3.
//! Foot pedals present as keyboards: `[01, mods, 00, k1..k6]` (or the same without the report
//! id), a key's usage code while pressed.

/// 3Dconnexion's two USB vendor ids.
pub const VENDOR_LOGITECH_3DCONNEXION: u16 = 0x046d;
pub const VENDOR_3DCONNEXION: u16 = 0x256f;

/// 6-DOF products (spacenavd's list); CadMouse and keyboards (0x256f:c650–c668) are not.
pub const SPACEMOUSE_PRODUCTS: &[(u16, u16, &str)] = &[
    (0x046d, 0xc603, "SpaceMouse Plus XT"),
    (0x046d, 0xc605, "CadMan"),
    (0x046d, 0xc606, "SpaceMouse Classic"),
    (0x046d, 0xc621, "Spaceball 5000"),
    (0x046d, 0xc623, "SpaceTraveller"),
    (0x046d, 0xc625, "SpacePilot"),
    (0x046d, 0xc626, "SpaceNavigator"),
    (0x046d, 0xc627, "SpaceExplorer"),
    (0x046d, 0xc628, "SpaceNavigator for Notebooks"),
    (0x046d, 0xc629, "SpacePilot Pro"),
    (0x046d, 0xc62b, "SpaceMouse Pro"),
    (0x256f, 0xc62e, "SpaceMouse Wireless (cable)"),
    (0x256f, 0xc62f, "SpaceMouse Wireless (receiver)"),
    (0x256f, 0xc631, "SpaceMouse Pro Wireless (cable)"),
    (0x256f, 0xc632, "SpaceMouse Pro Wireless (receiver)"),
    (0x256f, 0xc633, "SpaceMouse Enterprise"),
    (0x256f, 0xc635, "SpaceMouse Compact"),
    (0x256f, 0xc636, "SpaceMouse Module"),
    (0x256f, 0xc638, "SpaceMouse Pro Wireless Bluetooth"),
    (0x256f, 0xc63a, "SpaceMouse Wireless Bluetooth"),
    (0x256f, 0xc652, "3Dconnexion Universal Receiver"),
];

/// USB foot pedals that present as keyboards.
pub const PEDAL_PRODUCTS: &[(u16, u16, &str)] = &[
    (0x1a86, 0xe026, "PCsensor / iKKEGOL foot switch"),
    (0x1a86, 0xe02d, "PCsensor foot switch"),
    (0x0c45, 0x7403, "PCsensor FootSwitch"),
    (0x0c45, 0x7404, "PCsensor FootSwitch"),
    (0x413d, 0x2107, "iKKEGOL foot switch"),
    (0x0426, 0x3011, "Scythe USB foot switch"),
];

pub fn spacemouse_name(vendor: u16, product: u16) -> Option<&'static str> {
    SPACEMOUSE_PRODUCTS.iter().find(|p| p.0 == vendor && p.1 == product).map(|p| p.2)
}

pub fn pedal_name(vendor: u16, product: u16) -> Option<&'static str> {
    PEDAL_PRODUCTS.iter().find(|p| p.0 == vendor && p.1 == product).map(|p| p.2)
}

/// Raw SpaceMouse state: translation and rotation counts (about ±350 full scale) and buttons.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SpaceMouseRaw {
    pub translation: [i16; 3],
    pub rotation: [i16; 3],
    pub buttons: u32,
}

fn i16s<const N: usize>(b: &[u8]) -> [i16; N] {
    let mut out = [0i16; N];
    for (o, c) in out.iter_mut().zip(b.chunks_exact(2)) {
        *o = i16::from_le_bytes([c[0], c[1]]);
    }
    out
}

/// Applies one report to `state`; false for a report this does not know (ignored).
pub fn apply_spacemouse_report(state: &mut SpaceMouseRaw, report: &[u8]) -> bool {
    match (report.first(), report.len()) {
        // Newer family: all six axes in one report.
        (Some(1), 13..) => {
            let v: [i16; 6] = i16s(&report[1..13]);
            state.translation = [v[0], v[1], v[2]];
            state.rotation = [v[3], v[4], v[5]];
            true
        }
        (Some(1), 7..) => {
            state.translation = i16s(&report[1..7]);
            true
        }
        (Some(2), 7..) => {
            state.rotation = i16s(&report[1..7]);
            true
        }
        (Some(3), 2..) => {
            let mut b = [0u8; 4];
            let n = (report.len() - 1).min(4);
            b[..n].copy_from_slice(&report[1..1 + n]);
            state.buttons = u32::from_le_bytes(b);
            true
        }
        _ => false,
    }
}

/// Whether a keyboard report holds `key` (a HID usage, 5 = 'b'): with report id 1 (9 bytes) or
/// without one (8 bytes). Other reports (consumer keys, ...) say nothing: `None`.
pub fn pedal_pressed(report: &[u8], key: u8) -> Option<bool> {
    let keys = match (report.first(), report.len()) {
        (Some(1), 9..) => &report[3..9],
        (_, 8) => &report[2..8],
        _ => return None,
    };
    Some(keys.contains(&key))
}

/// A key's HID usage from a letter or digit (`b` → 5) or a number (`5`, `0x05`).
pub fn key_usage(text: &str) -> Option<u8> {
    let t = text.trim();
    if let Some(hex) = t.strip_prefix("0x") {
        return u8::from_str_radix(hex, 16).ok().filter(|&u| u >= 4);
    }
    let mut chars = t.chars();
    match (chars.next(), chars.next()) {
        (Some(c), None) if c.is_ascii_lowercase() => Some(4 + (c as u8 - b'a')),
        (Some('0'), None) => Some(0x27),
        (Some(c), None) if c.is_ascii_digit() && c != '0' => Some(0x1e + (c as u8 - b'1')),
        _ => t.parse::<u8>().ok().filter(|&u| u >= 4 && t.len() > 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Recorded reports (hex as hidraw gives them): an older SpaceNavigator (046d:c626) pushed
    // right and twisted, a SpaceMouse Compact (256f:c635) pushed down, and PCsensor pedals.
    const OLD_TRANSLATION: [u8; 7] = [0x01, 0x5e, 0x01, 0xf6, 0xff, 0x00, 0x00]; // x=350, y=-10, z=0
    const OLD_ROTATION: [u8; 7] = [0x02, 0x00, 0x00, 0x00, 0x00, 0xa2, 0xfe]; // rz=-350
    const OLD_BUTTONS: [u8; 3] = [0x03, 0x01, 0x00];
    const NEW_AXES: [u8; 13] = [0x01, 0x00, 0x00, 0x00, 0x00, 0x2c, 0x01, 0x05, 0x00, 0x00, 0x00, 0xfb, 0xff]; // z=300, rx=5, rz=-5
    const PEDAL_DOWN: [u8; 9] = [0x01, 0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00];
    const PEDAL_UP: [u8; 9] = [0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00];
    const PEDAL_NO_ID: [u8; 8] = [0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00];

    #[test]
    fn both_spacemouse_layouts_parse() {
        let mut s = SpaceMouseRaw::default();
        assert!(apply_spacemouse_report(&mut s, &OLD_TRANSLATION));
        assert!(apply_spacemouse_report(&mut s, &OLD_ROTATION));
        assert!(apply_spacemouse_report(&mut s, &OLD_BUTTONS));
        assert_eq!(s, SpaceMouseRaw { translation: [350, -10, 0], rotation: [0, 0, -350], buttons: 1 });
        let mut s = SpaceMouseRaw::default();
        assert!(apply_spacemouse_report(&mut s, &NEW_AXES));
        assert_eq!((s.translation, s.rotation), ([0, 0, 300], [5, 0, -5]));
        assert!(!apply_spacemouse_report(&mut s, &[0x17, 1, 2]));
        assert!(!apply_spacemouse_report(&mut s, &[0x01, 1]), "a short report is ignored");
        assert_eq!(spacemouse_name(0x256f, 0xc635), Some("SpaceMouse Compact"));
        assert_eq!(spacemouse_name(0x256f, 0xc652).is_some(), true);
        assert_eq!(spacemouse_name(0x256f, 0xc650), None, "CadMouse is not 6-DOF");
    }

    #[test]
    fn pedal_reports_and_keys() {
        assert_eq!(pedal_pressed(&PEDAL_DOWN, 5), Some(true));
        assert_eq!(pedal_pressed(&PEDAL_UP, 5), Some(false));
        assert_eq!(pedal_pressed(&PEDAL_NO_ID, 5), Some(true));
        assert_eq!(pedal_pressed(&PEDAL_DOWN, 6), Some(false));
        assert_eq!(pedal_pressed(&[0x02, 0x00], 5), None);
        assert_eq!((key_usage("b"), key_usage("a"), key_usage("1"), key_usage("0"), key_usage("0x05"), key_usage("44")), (Some(5), Some(4), Some(0x1e), Some(0x27), Some(5), Some(44)));
        assert_eq!(key_usage("bb"), None);
        assert_eq!(pedal_name(0x1a86, 0xe026).is_some(), true);
    }
}
