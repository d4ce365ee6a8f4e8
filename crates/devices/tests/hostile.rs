//! Issue 11's hostile device inputs: each an error naming the file or field, never a hang or an
//! endless read.
use dentsim_devices::{DeviceSpec, PathLimits, ToolPath};

const ROWS: &str = "0,0,0,6,1,0,0,0,200000,1\n0.5,0,0,4.5,1,0,0,0,200000,1\n";

#[test]
fn negative_hand_damping_is_refused_by_name() {
    let e = DeviceSpec::parse("hand:start=0:0:5,target=0:0:2,damping=-5").unwrap_err().to_string();
    assert!(e.contains("field 'damping'") && e.contains("-5") && e.contains(">= 0"), "{e}");
    let DeviceSpec::Hand(h) = DeviceSpec::parse("hand:damping=0").unwrap() else { panic!("hand") };
    assert_eq!(h.damping_n_s_per_mm, 0.0);
}

#[test]
fn a_bom_is_accepted_and_a_duplicate_column_refused_in_files() {
    let dir = tempfile::tempdir().unwrap();
    let bom = dir.path().join("bom.csv");
    std::fs::write(&bom, format!("\u{feff}t,x,y,z,qw,qx,qy,qz,rpm,cut\n{ROWS}")).unwrap();
    assert_eq!(ToolPath::read(&bom, PathLimits::default()).unwrap().samples.len(), 2);
    let dup = dir.path().join("dup.csv");
    std::fs::write(&dup, format!("t,x,y,z,qw,qx,qy,qz,rpm,x\n{ROWS}")).unwrap();
    let e = ToolPath::read(&dup, PathLimits::default()).unwrap_err().to_string();
    assert!(e.contains("dup.csv") && e.contains("'x' appears twice"), "{e}");
}

#[cfg(unix)]
#[test]
fn an_endless_stream_as_a_tool_path_is_refused_after_the_size_cap() {
    let e = ToolPath::read(std::path::Path::new("/dev/zero"), PathLimits::default()).unwrap_err().to_string();
    assert!(e.contains("/dev/zero") && e.contains("MiB"), "{e}");
}

#[test]
fn a_path_that_is_not_text_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("bin.csv");
    std::fs::write(&bin, [0xff, 0xfe, 0x00, 0x80]).unwrap();
    let e = ToolPath::read(&bin, PathLimits::default()).unwrap_err().to_string();
    assert!(e.contains("bin.csv") && e.contains("UTF-8"), "{e}");
}
