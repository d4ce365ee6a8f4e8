//! A full disk, for real: a small tmpfs mounted under the test's folder (root only; elsewhere the
//! same all-or-nothing path is covered by injected faults in sim/tests/hostile.rs and the atomic
//! crate's tests). Every command fails naming a file in its output folder, and leaves the folder
//! as it was: no partial file, no staging folder, older outputs untouched.
#![cfg(target_os = "linux")]
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;

fn dentsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dentsim")).args(args).env("RUST_BACKTRACE", "0").output().unwrap()
}

/// A tmpfs of `size` at `dir`, unmounted on drop.
struct Tmpfs(PathBuf);

impl Tmpfs {
    fn mount(dir: &Path, size: &str) -> Option<Tmpfs> {
        std::fs::create_dir_all(dir).unwrap();
        let ok = Command::new("mount").args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"]).arg(dir).status().is_ok_and(|s| s.success());
        ok.then(|| Tmpfs(dir.to_owned()))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

fn listing(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap()).map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap_or_default())).collect();
    v.sort();
    v
}

fn is_root() -> bool {
    Command::new("id").arg("-u").output().is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

#[test]
fn a_full_disk_fails_each_command_by_file_name_and_leaves_the_folder_as_it_was() {
    if !is_root() {
        eprintln!("not root: no tmpfs; the injected-fault tests cover this path");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let start = dir.path().join("start.vdb");
    CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap().save(&start).unwrap();
    let csv = dir.path().join("p.csv");
    std::fs::write(&csv, "t,x,y,z,qw,qx,qy,qz,cut\n0,0,0,5.8,1,0,0,0,1\n0.5,0,0,4.0,1,0,0,0,1\n").unwrap();
    let scan = dir.path().join("scan.nii.gz");
    assert!(dentsim(&["phantom", "--format", "nifti", "--out", scan.to_str().unwrap()]).status.success());
    // A session on the ordinary disk, for the replay.
    let session = dir.path().join("session");
    let run = dentsim(&["session", "--tissues", start.to_str().unwrap(), "--out", session.to_str().unwrap(), "--device", "hand:start=0:0:5.6,target=0:0:3,pedal=1,duration=0.3"]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let log = session.join("session.dslog");

    for size in ["1m", "3m"] {
        let mount = dir.path().join(format!("full-{size}"));
        let Some(_fs) = Tmpfs::mount(&mount, size) else { panic!("root, yet mounting a tmpfs failed") };
        let out = mount.join("out");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("prepare.json"), b"an older run's report").unwrap();
        std::fs::write(out.join("notes.txt"), b"the user's own file").unwrap();
        let before = listing(&out);
        let o = out.to_str().unwrap();
        let segmented = out.join("tooth.vdb");
        let commands: Vec<Vec<&str>> = vec![
            vec!["prepare", start.to_str().unwrap(), "--path", csv.to_str().unwrap(), "--burr", "round:1.0", "--out", o],
            vec!["replay", log.to_str().unwrap(), "--tissues", start.to_str().unwrap(), "--out", o],
            vec!["demo", "--out", o, "--voxel", "0.1"],
            vec!["segment", scan.to_str().unwrap(), "--out", segmented.to_str().unwrap()],
            vec!["assess", session.to_str().unwrap(), "--original", start.to_str().unwrap(), "--out", o],
        ];
        for args in commands {
            let run = dentsim(&args);
            let stderr = String::from_utf8_lossy(&run.stderr);
            assert!(!run.status.success(), "{size} {}: succeeded on a full disk", args[0]);
            assert!(stderr.contains(o) && stderr.contains("No space left on device"), "{size} {}: {stderr}", args[0]);
            assert!(!stderr.contains(".dentsim-staging"), "{size} {}: the error names the staged file: {stderr}", args[0]);
            assert_eq!(listing(&out), before, "{size} {}: the folder changed", args[0]);
        }
        // A session keeps its log (the record of the ticks, under its final name) and nothing else.
        let run = dentsim(&["session", "--tissues", start.to_str().unwrap(), "--out", o, "--device", "hand:start=0:0:5.6,target=0:0:3,pedal=1,duration=0.3"]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && stderr.contains(o) && stderr.contains("No space left on device"), "{size} session: {stderr}");
        let mut after = listing(&out);
        after.retain(|(name, _)| name != "session.dslog");
        assert_eq!(after, before, "{size} session: only the log may be added");
    }
}
