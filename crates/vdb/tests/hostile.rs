//! Hostile .vdb files (truncated, byte-flipped, absurd voxels or boxes, wrong metadata types):
//! each is an error naming the file in one short line, never a crash. The files are made here
//! from valid ones (ours and, where Debian's python3-openvdb is present, OpenVDB's own).
use std::path::{Path, PathBuf};
use std::process::Command;

use dentsim_vdb::{read_file, write_file, LevelSet, MetaValue};
use glam::DVec3;

fn sphere(h: f64, center: DVec3, r: f64) -> LevelSet {
    LevelSet::from_sdf(h, 3.0, center - r, center + r, |p| (p - center).length() - r).unwrap()
}

/// Reads `path`; an error must name it on one line of bounded length.
fn read_cleanly(path: &Path) -> bool {
    match read_file(path) {
        Ok(grids) => {
            assert!(!grids.is_empty());
            true
        }
        Err(e) => {
            let text = e.to_string();
            let name = path.file_name().unwrap().to_str().unwrap();
            assert!(text.contains(name), "{text}");
            let chars = text.chars().count();
            assert!(!text.contains('\n') && chars < 600, "not one short line: {chars} characters: {text:.200}");
            false
        }
    }
}

/// A small xorshift: the same flips on every run.
struct Flips(u64);
impl Flips {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

fn hostile_variants(dir: &Path, stem: &str, bytes: &[u8]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut write = |name: String, data: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, data).unwrap();
        out.push(p);
    };
    let n = bytes.len();
    for cut in (0..n.min(300)).step_by(5).chain((1..30).map(|i| n * i / 30)) {
        write(format!("{stem}_cut{cut}.vdb"), &bytes[..cut]);
    }
    let mut rng = Flips(0x9E37_79B9_7F4A_7C15);
    for i in 0..60 {
        let mut b = bytes.to_vec();
        for _ in 0..1 + rng.next() % 4 {
            let pos = (rng.next() % n as u64) as usize;
            b[pos] ^= (1 + rng.next() % 255) as u8;
        }
        write(format!("{stem}_flip{i}.vdb"), &b);
    }
    out
}

#[test]
fn truncated_and_flipped_files_of_ours_are_errors_not_crashes() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.vdb");
    let mut a = sphere(0.1, DVec3::ZERO, 1.5);
    a.set_name("dentin");
    a.set_meta("stiffness_n_per_mm", &MetaValue::F64(0.5));
    let mut b = sphere(0.1, DVec3::X * 4.0, 1.0);
    b.set_name("pulp");
    write_file(&good, &[&a, &b]).unwrap();
    assert!(read_cleanly(&good));
    let bytes = std::fs::read(&good).unwrap();
    let files = hostile_variants(dir.path(), "ours", &bytes);
    let accepted = files.iter().filter(|p| read_cleanly(p)).count();
    // Every truncation is refused (the layout check); flips in voxel values may read.
    assert!(accepted < 60, "{accepted} of {} hostile files read", files.len());
    for cut in [0, 8, 100, bytes.len() / 2, bytes.len() - 1] {
        let p = dir.path().join(format!("ours_cut_{cut}.vdb"));
        std::fs::write(&p, &bytes[..cut]).unwrap();
        let e = read_file(&p).unwrap_err().to_string();
        assert!(e.contains("truncated") || e.contains("not an OpenVDB file"), "cut at {cut}: {e}");
    }
}

#[test]
fn truncated_and_flipped_files_of_openvdb_are_errors_not_crashes() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("py.vdb");
    let script = format!(
        "import pyopenvdb as v\ng = v.createLevelSetSphere(radius=2.0, center=(0,0,0), voxelSize=0.1)\ng.name = 'dentin'\nv.write('{}', grids=[g])\n",
        good.display()
    );
    // Debian's python3-openvdb works with /usr/bin/python3 only (REFERENCE.md).
    let made = Command::new("/usr/bin/python3").args(["-c", &script]).output().unwrap();
    assert!(made.status.success(), "python3-openvdb: {}", String::from_utf8_lossy(&made.stderr));
    assert!(read_cleanly(&good));
    let bytes = std::fs::read(&good).unwrap();
    for p in hostile_variants(dir.path(), "py", &bytes) {
        read_cleanly(&p);
    }
}

#[test]
fn absurd_voxels_and_boxes_are_refused_before_use() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("tiny_voxels", sphere(0.001, DVec3::ZERO, 0.01), "voxel size"),
        ("huge_voxels", sphere(20.0, DVec3::ZERO, 100.0), "voxel size"),
        ("huge_box", {
            let mut s = sphere(0.05, DVec3::ZERO, 0.3);
            s.csg_union(&sphere(0.05, DVec3::splat(20_000.0), 0.3)).unwrap();
            s
        }, "memory limit"),
    ];
    for (name, grid, expected) in cases {
        let p = dir.path().join(format!("{name}.vdb"));
        write_file(&p, &[&grid]).unwrap();
        let e = read_file(&p).unwrap_err().to_string();
        assert!(e.contains(&format!("{name}.vdb")) && e.contains(expected), "{e}");
    }
}

#[test]
fn metadata_of_another_type_is_replaced_not_an_abort() {
    // A file's string "stiffness_n_per_mm" overwritten by a number (as saving a loaded model
    // does) was an uncaught openvdb::TypeError.
    let mut g = sphere(0.1, DVec3::ZERO, 1.0);
    g.set_meta("stiffness_n_per_mm", &MetaValue::String("hard".into()));
    g.set_meta("stiffness_n_per_mm", &MetaValue::F64(0.7));
    assert_eq!(g.meta("stiffness_n_per_mm").unwrap(), MetaValue::F64(0.7));
    g.set_meta("colour", &MetaValue::F64(1.0));
    g.set_meta("colour", &MetaValue::Vec3(glam::Vec3::ONE));
    g.set_meta("colour", &MetaValue::I64(3));
    assert_eq!(g.meta("colour").unwrap(), MetaValue::I64(3));
}

/// Reads from many threads at once, while others run OpenVDB's threaded CSG and mesher: every
/// read's reader process gets the file back whole, none waits on another's pipe or lock (a read
/// once timed out in a parallel test run while its file was valid).
#[test]
fn reads_from_many_threads_beside_threaded_work_all_succeed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ball.vdb");
    let ball = sphere(0.05, DVec3::ZERO, 1.0);
    write_file(&path, &[&ball]).unwrap();
    let expected = ball.volume();
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                for i in 0..10 {
                    let mut a = sphere(0.05, DVec3::ZERO, 1.0);
                    a.csg_difference(&sphere(0.05, DVec3::new(0.5 + 0.01 * i as f64, 0.0, 0.0), 0.6)).unwrap();
                    assert!(!a.to_mesh().triangles.is_empty());
                }
            });
        }
        let readers: Vec<_> = (0..6)
            .map(|_| {
                s.spawn(|| {
                    (0..15)
                        .map(|_| {
                            let grids = read_file(&path).unwrap_or_else(|e| panic!("{e}"));
                            grids.into_iter().next().unwrap().level_set.expect("a float level set").volume()
                        })
                        .collect::<Vec<f64>>()
                })
            })
            .collect();
        for reader in readers {
            for v in reader.join().unwrap() {
                assert_eq!(v, expected);
            }
        }
    });
}
