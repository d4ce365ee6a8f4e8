//! `dentsim prepare` end to end: our tissues and OpenVDB's own files, good and bad paths.
mod common;

use std::path::Path;
use std::process::Command;

use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;

use common::{dentsim, GROOVE};

fn capsule_vdb(dir: &Path) -> String {
    let path = dir.join("tissues.vdb");
    CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap().save(&path).unwrap();
    path.to_str().unwrap().to_owned()
}

#[test]
fn a_groove_is_cut_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let tissues = capsule_vdb(dir.path());
    let csv = dir.path().join("groove.csv");
    std::fs::write(&csv, GROOVE).unwrap();
    let out = dir.path().join("out");
    let run = dentsim(&["prepare", &tissues, "--path", csv.to_str().unwrap(), "--burr", "round:1.0", "--out", out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("prepare.json")).unwrap()).unwrap();
    let removed = &json["removed_mm3"];
    assert!(removed["enamel"].as_f64().unwrap() > 1.0, "{removed}");
    assert!(removed["dentin"].as_f64().unwrap() > 0.0, "{removed}");
    assert_eq!(removed["pulp"].as_f64().unwrap(), 0.0);
    assert_eq!(json["strokes"].as_array().unwrap().len(), 1, "one cutting stroke (the last row lifts off)");
    for t in json["tissues"].as_array().unwrap() {
        let (before, after) = (t["volume_before_mm3"].as_f64().unwrap(), t["volume_after_mm3"].as_f64().unwrap());
        let cut = removed[t["name"].as_str().unwrap()].as_f64().unwrap();
        assert!((before - after - cut).abs() < 1e-3 * before.max(1.0), "{t}: removed {cut}");
    }
    for name in ["enamel", "dentin", "pulp"] {
        assert!(out.join(format!("{name}.vtp")).exists() && out.join(format!("{name}.stl")).exists());
    }
    // The prepared tissues load again and are smaller.
    let again = dentsim_sim::tissues::model::TissueModel::load(&out.join("tissues.vdb"), &TissueTable::default()).unwrap();
    let enamel = json["tissues"].as_array().unwrap().iter().find(|t| t["name"] == "enamel").unwrap();
    let reloaded = again.get("enamel").unwrap().grid.volume();
    assert!((reloaded - enamel["volume_after_mm3"].as_f64().unwrap()).abs() < 1e-9, "{enamel}");
    assert!(reloaded < enamel["volume_before_mm3"].as_f64().unwrap());
}

#[test]
fn grids_written_by_openvdb_tools_take_the_tables_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let vdb = dir.path().join("openvdb.vdb");
    let script = format!(
        "import pyopenvdb as v\ng = v.createLevelSetSphere(radius=3.0, center=(0,0,0), voxelSize=0.08)\ng.name = 'dentin'\nv.write('{}', grids=[g])\n",
        vdb.display()
    );
    // Debian's python3-openvdb works with /usr/bin/python3 only (REFERENCE.md).
    let made = Command::new("/usr/bin/python3").args(["-c", &script]).output().unwrap();
    assert!(made.status.success(), "python3-openvdb: {}", String::from_utf8_lossy(&made.stderr));
    let csv = dir.path().join("plunge.csv");
    std::fs::write(&csv, "t,x,y,z,qw,qx,qy,qz\n0,0,0,4,1,0,0,0\n1,0,0,2,1,0,0,0\n").unwrap();
    let out = dir.path().join("out");
    let run = dentsim(&["prepare", vdb.to_str().unwrap(), "--path", csv.to_str().unwrap(), "--burr", "round:1.0", "--out", out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("prepare.json")).unwrap()).unwrap();
    // A 1.0 mm ball plunged 1 mm deep into a 3 mm sphere: a capsule of length ~1 mm inside.
    let removed = json["removed_mm3"]["dentin"].as_f64().unwrap();
    assert!(removed > 0.5 && removed < 1.2, "{removed}");
    // The surface of a grid OpenVDB wrote, cut by us, is closed as VTK's own reader and
    // vtkFeatureEdges see it (python3-paraview's VTK).
    let script = "import sys\n\
from vtkmodules.vtkIOXML import vtkXMLPolyDataReader\n\
from vtkmodules.vtkFiltersCore import vtkFeatureEdges\n\
r = vtkXMLPolyDataReader(); r.SetFileName(sys.argv[1]); r.Update()\n\
f = vtkFeatureEdges(); f.SetInputConnection(r.GetOutputPort())\n\
f.BoundaryEdgesOn(); f.NonManifoldEdgesOff(); f.FeatureEdgesOff(); f.ManifoldEdgesOff(); f.Update()\n\
print(r.GetOutput().GetNumberOfPolys(), f.GetOutput().GetNumberOfLines())\n";
    let vtp = out.join("dentin.vtp");
    let checked = Command::new("/usr/bin/python3").args(["-c", script, vtp.to_str().unwrap()]).output().unwrap();
    assert!(checked.status.success(), "VTK: {}", String::from_utf8_lossy(&checked.stderr));
    let counts: Vec<u64> = String::from_utf8_lossy(&checked.stdout).split_whitespace().map(|n| n.parse().unwrap()).collect();
    assert!(counts[0] > 1000, "VTK read {} triangles", counts[0]);
    assert_eq!(counts[1], 0, "VTK finds {} boundary edges on the exported surface", counts[1]);
}

#[test]
fn bad_paths_and_burrs_name_the_row_and_field_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let tissues = capsule_vdb(dir.path());
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_owned()
    };
    let good = write("good.csv", GROOVE);
    let nan = write("nan.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,5,1,0,0,0\n1,0,NaN,4,1,0,0,0\n");
    let quat = write("quat.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,5,1,0,0,0\n1,0,0,4,0.5,0,0,0\n");
    let back = write("back.csv", "t,x,y,z,qw,qx,qy,qz\n1,0,0,5,1,0,0,0\n0.5,0,0,4,1,0,0,0\n");
    let jump = write("jump.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,5,1,0,0,0\n1,0,0,-20,1,0,0,0\n");
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (vec!["prepare", &tissues, "--path", &nan, "--burr", "round:1.0", "--out", o], vec!["nan.csv", "row 2", "y"]),
        (vec!["prepare", &tissues, "--path", &quat, "--burr", "round:1.0", "--out", o], vec!["quat.csv", "row 2"]),
        (vec!["prepare", &tissues, "--path", &back, "--burr", "round:1.0", "--out", o], vec!["back.csv", "row 2"]),
        (vec!["prepare", &tissues, "--path", &jump, "--burr", "round:1.0", "--out", o], vec!["jump.csv", "row 2"]),
        (vec!["prepare", &tissues, "--path", &good, "--burr", "806 314 999 524 010", "--out", o], vec!["999"]),
        (vec!["prepare", &tissues, "--path", &good, "--burr", "spoon:1.0", "--out", o], vec!["spoon"]),
        (vec!["prepare", &good, "--path", &good, "--burr", "round:1.0", "--out", o], vec!["good.csv"]),
    ];
    for (args, expected) in cases {
        let run = dentsim(&args);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?} accepted");
        for e in expected {
            assert!(stderr.contains(e), "{args:?}: '{e}' not in {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!out.exists(), "nothing written for {args:?}");
    }
}
