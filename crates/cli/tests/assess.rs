//! `dentsim assess` end to end on a groove cut by `dentsim prepare` into the capsule tooth: the
//! figures agree with prepare's, the surface opens in VTK's own reader with its arrays, and a
//! preparation against itself has no over- or under-cut.
mod common;

use std::path::Path;
use std::process::Command;

use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;

use common::{dentsim, GROOVE};

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn a_prepared_groove_is_assessed_against_its_original_and_itself() {
    let dir = tempfile::tempdir().unwrap();
    let original = dir.path().join("tissues.vdb");
    CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap().save(&original).unwrap();
    let csv = dir.path().join("groove.csv");
    std::fs::write(&csv, GROOVE).unwrap();
    let prepared = dir.path().join("prepared");
    let p = |x: &Path| x.to_str().unwrap().to_owned();
    let run = dentsim(&["prepare", &p(&original), "--path", &p(&csv), "--burr", "round:1.0", "--out", &p(&prepared)]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let out = dir.path().join("assessed");
    let run = dentsim(&["assess", &p(&prepared), "--original", &p(&original), "--out", &p(&out)]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let a = json(&out.join("assessment.json"));
    let prep = json(&prepared.join("prepare.json"));
    for name in ["enamel", "dentin", "pulp"] {
        let (ours, theirs) = (a["tissues"][name]["removed_mm3"].as_f64().unwrap(), prep["removed_mm3"][name].as_f64().unwrap());
        assert!((ours - theirs).abs() < 1e-6 * theirs.max(1.0), "{name}: {ours} vs prepare's {theirs}");
    }
    let dentin = a["min_remaining_dentin_mm"].as_f64().unwrap();
    assert!(dentin > 0.5 && dentin < 10.0, "{a}");
    assert_eq!(a["pulp_exposed"], false);
    assert!(a["cut_surface_points"].as_u64().unwrap() > 100, "{a}");
    assert!(std::fs::read(out.join("assessment.png")).unwrap().starts_with(b"\x89PNG"));
    // VTK's own reader: the arrays are there, one value a point, and the groove is cut.
    let script = format!(
        "from vtkmodules.vtkIOXML import vtkXMLPolyDataReader\nr = vtkXMLPolyDataReader()\nr.SetFileName('{}')\nr.Update()\no = r.GetOutput()\nd = o.GetPointData()\nprint(o.GetNumberOfPoints(), d.GetArray('CutDepthMm').GetNumberOfTuples(), d.GetArray('DeviationMm').GetNumberOfTuples(), d.GetArray('CutDepthMm').GetRange()[1])\n",
        out.join("tooth.vtp").display()
    );
    let vtk = Command::new("/usr/bin/python3").args(["-c", &script]).output().unwrap();
    assert!(vtk.status.success(), "{}", String::from_utf8_lossy(&vtk.stderr));
    let fields: Vec<f64> = String::from_utf8_lossy(&vtk.stdout).split_whitespace().map(|v| v.parse().unwrap()).collect();
    assert!(fields[0] > 1000.0 && fields[1] == fields[0] && fields[2] == fields[0], "{fields:?}");
    assert!(fields[3] > 0.5, "deepest cut {} mm", fields[3]);
    // Against itself: nothing over- or under-cut, no deviation.
    let again = dir.path().join("self");
    let run = dentsim(&["assess", &p(&prepared), "--original", &p(&original), "--reference", &p(&prepared), "--out", &p(&again)]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let s = json(&again.join("assessment.json"));
    for name in ["enamel", "dentin", "pulp"] {
        assert!(s["tissues"][name]["overcut_mm3"].as_f64().unwrap() < 1e-3 && s["tissues"][name]["undercut_mm3"].as_f64().unwrap() < 1e-3, "{s}");
    }
    assert!(s["deviation_mm"]["max"].as_f64().unwrap().abs() < 1e-3, "{s}");
}

#[test]
fn an_original_of_another_voxel_size_is_refused_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let (fine, coarse) = (dir.path().join("fine.vdb"), dir.path().join("coarse.vdb"));
    CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap().save(&fine).unwrap();
    CapsuleTooth::default().build(0.1, &TissueTable::default()).unwrap().save(&coarse).unwrap();
    let out = dir.path().join("out");
    let run = dentsim(&["assess", fine.to_str().unwrap(), "--original", coarse.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("original model") && err.contains("voxel size"), "{err}");
    assert!(!out.join("assessment.json").exists());
}
