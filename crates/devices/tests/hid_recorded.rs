//! SpaceMouse and foot pedal on recorded report bytes (no /dev/hidraw on these machines): both
//! SpaceMouse layouts drive the pose, pulling the device out is a fault on the next poll, and
//! plugging it back in is picked up; a pedal switches cut mode on any pose device.
use std::collections::VecDeque;
use std::time::{Duration, Instant};

use dentsim_devices::hid::link::{HidLink, Recorded};
use dentsim_devices::hid::rate::RateMap;
use dentsim_devices::hid::{SpaceMouse, WithPedal};
use dentsim_devices::{Device, DeviceSpec, Fault, HandParams, SimulatedHand};
use glam::DVec3;

// A SpaceMouse Compact (256f:c635, one 13-byte report): cap pushed down 300 counts, left button.
const NEW_DOWN: [u8; 13] = [0x01, 0x00, 0x00, 0x00, 0x00, 0x2c, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00];
const BUTTON_LEFT: [u8; 3] = [0x03, 0x01, 0x00];
// A SpaceNavigator (046d:c626, three reports): pushed right 350 counts, no twist, no button.
const OLD_RIGHT: [u8; 7] = [0x01, 0x5e, 0x01, 0x00, 0x00, 0x00, 0x00];
const OLD_NO_TWIST: [u8; 7] = [0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00];
const BUTTONS_UP: [u8; 3] = [0x03, 0x00, 0x00];
// PCsensor pedal (1a86:e026) typing 'b' (usage 5) while held.
const PEDAL_DOWN: [u8; 9] = [0x01, 0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x00, 0x00];
const PEDAL_UP: [u8; 9] = [0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00];

fn recorded(plugs: Vec<Vec<&[u8]>>) -> Recorded {
    Recorded { plugs: plugs.into_iter().map(|p| p.into_iter().map(<[u8]>::to_vec).collect()).collect::<VecDeque<_>>(), gap_reads: 3 }
}

/// Polls at 1 ms steps of session time until `until` holds (bounded far above what it needs).
fn poll_until<D: Device>(dev: &mut D, t: &mut f64, mut until: impl FnMut(&Result<dentsim_devices::DeviceState, Fault>) -> bool) -> Result<dentsim_devices::DeviceState, Fault> {
    let start = Instant::now();
    loop {
        *t += 1e-3;
        let s = dev.poll(*t);
        if until(&s) || start.elapsed() > Duration::from_secs(30) {
            return s;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn spacemouse_both_layouts_unplug_and_replug() {
    let link = HidLink::start(recorded(vec![vec![&BUTTON_LEFT, &NEW_DOWN], vec![&BUTTONS_UP, &OLD_NO_TWIST, &OLD_RIGHT]]), "test").unwrap();
    let start = DVec3::new(0.0, 0.0, 10.0);
    let mut dev = SpaceMouse::new(link, RateMap::default(), start, "SpaceMouse");
    let mut t = 0.0;
    // First plug (new layout): the tool goes down with the cut button held.
    let s = poll_until(&mut dev, &mut t, |s| s.as_ref().is_ok_and(|s| s.pose.translation.z < 9.99)).unwrap();
    assert!(s.cutting(), "left button holds cut mode");
    assert_eq!((s.pose.translation.x, s.pose.translation.y), (0.0, 0.0));
    // Pulled out after its reports: a fault on the poll that sees it, the pose held.
    let before = s.pose.translation;
    let e = poll_until(&mut dev, &mut t, |s| s.is_err());
    assert_eq!(e, Err(Fault::Disconnected));
    assert_eq!(dev.unplugs(), 1);
    // Plugged back in (old layout): picked up, moves right from where it was, button released.
    let s = poll_until(&mut dev, &mut t, |s| s.as_ref().is_ok_and(|s| s.pose.translation.x > 0.01)).unwrap();
    assert!(!s.cutting());
    assert!(s.pose.translation.z <= before.z + 1e-12 && s.pose.translation.z < 10.0, "kept its depth: {}", s.pose.translation);
}

#[test]
fn a_pedal_is_the_cut_switch_of_any_pose_device() {
    let hand = SimulatedHand::new(HandParams { duration_s: 100.0, ..Default::default() });
    let link = HidLink::start(recorded(vec![vec![&PEDAL_DOWN, &PEDAL_UP, &PEDAL_DOWN]]), "pedal").unwrap();
    let mut dev = WithPedal::new(hand, link, 5);
    let mut t = 0.0;
    assert!(poll_until(&mut dev, &mut t, |s| s.as_ref().is_ok_and(|s| s.cutting())).unwrap().cutting());
    assert!(!poll_until(&mut dev, &mut t, |s| s.as_ref().is_ok_and(|s| !s.cutting())).unwrap().cutting());
    assert!(poll_until(&mut dev, &mut t, |s| s.as_ref().is_ok_and(|s| s.cutting())).unwrap().cutting());
    // Pulled out while held: released, and the pose device goes on.
    let s = poll_until(&mut dev, &mut t, |s| s.as_ref().is_ok_and(|s| !s.cutting())).unwrap();
    assert!(!s.cutting());
    assert_eq!(dev.name(), "simulated hand + foot pedal");
}

#[test]
fn specs_parse_and_name_bad_fields() {
    let DeviceSpec::SpaceMouse(o) = DeviceSpec::parse("spacemouse:dead=20,speed=5,axes=y:x:-z,start=1:2:3,device=256f:c635").unwrap() else { panic!() };
    assert_eq!((o.map.dead_zone, o.map.translate_mm_s, o.map.axes, o.start, o.device), (20.0, 5.0, [(1, 1.0), (0, 1.0), (2, -1.0)], DVec3::new(1.0, 2.0, 3.0), Some((0x256f, 0xc635))));
    assert!(matches!(DeviceSpec::parse("spacemouse").unwrap(), DeviceSpec::SpaceMouse(_)));
    let DeviceSpec::WithPedal(inner, p) = DeviceSpec::parse("igtl://127.0.0.1:18944?pose=Stylus+pedal:key=c").unwrap() else { panic!() };
    assert!(matches!(*inner, DeviceSpec::Igtl(_)) && p.key == 6);
    assert!(DeviceSpec::parse("spacemouse+pedal").unwrap().is_live());
    assert!(!DeviceSpec::parse("hand:duration=1+pedal").unwrap().is_live());
    let e = |t: &str| DeviceSpec::parse(t).unwrap_err().to_string();
    assert!(e("spacemouse:axes=x:x:z").contains("field 'axes'"));
    assert!(e("spacemouse:device=12").contains("field 'device'"));
    assert!(e("spacemouse:speed=-1").contains("field 'speed'"));
    assert!(e("spacemouse:gain=1").contains("unknown field 'gain'"));
    assert!(e("hand:duration=1+pedal:key=??").contains("field 'key'"));
    assert!(e("spacemousex").contains("unknown kind"));
    // No /dev/hidraw here: opening says what is missing instead of waiting.
    let open = DeviceSpec::parse("spacemouse").unwrap().open().err().unwrap().to_string();
    assert!(open.contains("no SpaceMouse plugged in") && open.contains("dentsim devices"), "{open}");
}
