//! `dentsim session --device scripted:FILE` and `dentsim prepare --path FILE` judge one file
//! alike: both accept it, or both refuse it naming the same file, row and column.
use std::path::Path;
use std::process::{Command, Output};

use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;

fn dentsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dentsim")).args(args).env("RUST_BACKTRACE", "0").output().unwrap()
}

/// The part of stderr that names the problem (after the file's path).
fn problem(run: &Output, file: &Path) -> Option<String> {
    if run.status.success() {
        return None;
    }
    let stderr = String::from_utf8_lossy(&run.stderr);
    let name = file.display().to_string();
    let at = stderr.find(&name).unwrap_or_else(|| panic!("{name} not named in {stderr}"));
    Some(stderr[at..].lines().next().unwrap().to_owned())
}

#[test]
fn session_and_prepare_accept_and_refuse_the_same_files_with_the_same_words() {
    let dir = tempfile::tempdir().unwrap();
    let tissues = dir.path().join("tissues.vdb");
    CapsuleTooth::default().build(0.1, &TissueTable::default()).unwrap().save(&tissues).unwrap();
    let head = "t,x,y,z,qw,qx,qy,qz,cut";
    let cases = [
        ("plunge", format!("{head}\n0,0,0,5.8,1,0,0,0,1\n0.2,0,0,4.8,1,0,0,0,1\n0.3,0,0,5.8,1,0,0,0,0\n"), true),
        // Once refused by prepare only (equal times, a 180° turn) or by neither (a repeated column).
        ("same_time", format!("{head}\n0,0,0,5.8,1,0,0,0,1\n0,0,0,5.7,1,0,0,0,1\n"), false),
        ("half_turn", format!("{head}\n0,0,0,5.8,1,0,0,0,1\n0.2,0,0,5.8,0,1,0,0,1\n"), false),
        ("twice", format!("{head},t\n0,0,0,5.8,1,0,0,0,1,0\n"), false),
        // Once refused by the session only (cut written 1.0 by a spreadsheet is fine for both).
        ("real_cut", format!("{head}\n0,0,0,5.8,1,0,0,0,1.0\n0.2,0,0,5.7,1,0,0,0,0.0\n"), true),
    ];
    for (name, text, good) in cases {
        let file = dir.path().join(format!("{name}.csv"));
        std::fs::write(&file, text).unwrap();
        let f = file.to_str().unwrap();
        let (s_out, p_out) = (dir.path().join(format!("{name}_session")), dir.path().join(format!("{name}_prepare")));
        let device = format!("scripted:{f}");
        let session = dentsim(&["session", "--tissues", tissues.to_str().unwrap(), "--device", &device, "--out", s_out.to_str().unwrap()]);
        let prepare = dentsim(&["prepare", tissues.to_str().unwrap(), "--path", f, "--burr", "round:1.0", "--out", p_out.to_str().unwrap()]);
        let (s, p) = (problem(&session, &file), problem(&prepare, &file));
        assert_eq!(s, p, "{name}: session {s:?}, prepare {p:?}");
        assert_eq!(s.is_none(), good, "{name}: {s:?}");
        assert_eq!(s_out.exists(), good, "{name}: a refused file writes nothing");
    }
}
