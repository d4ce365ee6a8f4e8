//! Tool path CSV parsing, its errors (row and column named), and `prepare` along a path.
use dentsim_sim::burr::Burr;
use dentsim_sim::plan::path::{PathLimits, ToolPath};
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::plan::prepare::{prepare, PrepareOptions};
use dentsim_sim::tissues::table::TissueTable;

fn parse(text: &str) -> Result<ToolPath, String> {
    ToolPath::parse_csv(text, "path.csv", PathLimits::default()).map_err(|e| e.to_string())
}

/// A class I-like groove: down into the occlusal enamel, along, and up, burr upright.
fn groove_csv() -> String {
    let mut s = String::from("t,x,y,z,qw,qx,qy,qz,rpm,cut\n");
    let top = CapsuleTooth::default().outer.top();
    let mut t = 0.0;
    let mut row = |x: f64, z: f64, cut: u8, s: &mut String| {
        s.push_str(&format!("{t:.3},{x:.4},0,{z:.4},1,0,0,0,200000,{cut}\n"));
        t += 0.01;
    };
    row(-1.0, top + 0.5, 0, &mut s);
    for i in 0..=10 {
        row(-1.0, top + 0.5 - 0.12 * f64::from(i), 1, &mut s);
    }
    for i in 1..=20 {
        row(-1.0 + 0.1 * f64::from(i), top - 0.7, 1, &mut s);
    }
    row(1.0, top + 0.5, 0, &mut s);
    s
}

#[test]
fn a_path_parses_with_optional_columns() {
    let p = parse(&groove_csv()).unwrap();
    assert_eq!(p.samples.len(), 33);
    assert!(!p.samples[0].cut && p.samples[1].cut);
    assert_eq!(p.samples[3].rpm, Some(200000.0));
    let p = parse("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0.001,0.01,0,0,0.9961947,0.0871557,0,0\n").unwrap();
    assert!(p.samples[1].cut && p.samples[1].rpm.is_none());
    // Columns may come in any order.
    let p = parse("qw,qx,qy,qz,x,y,z,t\n1,0,0,0,1,2,3,0\n").unwrap();
    assert_eq!(p.samples[0].pose.translation.to_array(), [1.0, 2.0, 3.0]);
}

#[test]
fn bad_paths_name_the_row_and_column() {
    let head = "t,x,y,z,qw,qx,qy,qz\n";
    for (body, needles) in [
        ("0,0,0,NaN,1,0,0,0\n", vec!["row 1", "column z"]),
        ("0,0,0,0,1,0,0,0\n0.1,0,abc,0,1,0,0,0\n", vec!["row 2", "column y", "'abc'"]),
        ("0,0,0,0,1,0,0,0\n0.1,0,0,0,0.9,0,0,0\n", vec!["row 2", "qw,qx,qy,qz", "norm"]),
        ("0,0,0,0,1,0,0,0\n-0.1,0,0,0,1,0,0,0\n", vec!["row 2", "column t", "backwards"]),
        ("0,0,0,0,1,0,0,0\n0.1,9,0,0,1,0,0,0\n", vec!["row 2", "x,y,z", "jumps"]),
        ("0,0,0,0,1,0,0,0\n0.1,0,0,0,0,1,0,0\n", vec!["row 2", "turns"]),
        ("0,0,0,0,1,0,0\n", vec!["row 1", "cells"]),
        ("0,0,0,inf,1,0,0,0\n", vec!["row 1", "column z"]),
    ] {
        let e = parse(&format!("{head}{body}")).unwrap_err();
        for n in needles {
            assert!(e.contains(n) && e.contains("path.csv"), "{body:?}: {e}");
        }
    }
    let e = parse("t,x,y,z,qw,qx,qy\n").unwrap_err();
    assert!(e.contains("'qz'"), "{e}");
    let e = parse("t,x,y,z,qw,qx,qy,qz,speed\n").unwrap_err();
    assert!(e.contains("'speed'"), "{e}");
    let e = parse("t,x,y,z,qw,qx,qy,qz,cut\n0,0,0,0,1,0,0,0,2\n").unwrap_err();
    assert!(e.contains("column cut"), "{e}");
    assert!(parse("").is_err());
}

#[test]
fn prepare_cuts_along_the_path_and_reports_per_stroke() {
    let mut model = CapsuleTooth::default().build(0.05, &TissueTable::default()).unwrap();
    let before = model.volumes();
    let path = parse(&groove_csv()).unwrap();
    let burr = Burr::parse("806 314 001 524 010").unwrap();
    let mut fractions = Vec::new();
    let report = dentsim_sim::plan::prepare::prepare_with_progress(&mut model, &path, &burr, &PrepareOptions::default(), &mut |f| fractions.push(f)).unwrap();
    assert_eq!(report.strokes.len(), 1, "{:?}", report.strokes);
    assert_eq!(report.segments, 31);
    assert!(fractions.windows(2).all(|w| w[0] <= w[1]) && *fractions.last().unwrap() == 1.0);
    let enamel = report.removed_mm3["enamel"];
    assert!(enamel > 1.0, "{report:?}");
    for ((name, v0), (_, v1)) in before.iter().zip(model.volumes()) {
        assert!((v0 - v1 - report.removed_mm3[name]).abs() < 1e-6 * v0, "{name}");
    }
    println!("{}", serde_json::to_string(&report).unwrap());
    // Rate-limited at 1 N it removes far less in the same 0.3 s.
    let mut limited = CapsuleTooth::default().build(0.05, &TissueTable::default()).unwrap();
    let opts = PrepareOptions { force_n: Some(1.0), ..Default::default() };
    let r = prepare(&mut limited, &path, &burr, &opts).unwrap();
    assert!(r.removed_mm3["enamel"] < 0.5 * enamel, "{r:?}");
}

#[test]
fn polylines_are_checked_as_csv_paths_and_name_the_point_and_array() {
    use dentsim_sim::plan::path::PolylineArrays;
    let points = [0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.2, 0.0, 0.0];
    let orientation = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
    let ok = PolylineArrays { points: &points, orientation: &orientation, ..Default::default() };
    let p = ToolPath::from_polyline(&ok, "tool path", PathLimits::default()).unwrap();
    assert_eq!(p.samples.len(), 3);
    assert!((p.samples[2].t - 2e-3).abs() < 1e-15 && p.samples[2].cut);
    let from = |a: PolylineArrays| ToolPath::from_polyline(&a, "tool path", PathLimits::default()).unwrap_err().to_string();
    let mut q = orientation;
    q[4] = 0.9;
    let e = from(PolylineArrays { orientation: &q, ..ok });
    assert!(e.contains("tool path point 1 array Orientation") && e.contains("norm"), "{e}");
    let e = from(PolylineArrays { time: &[0.0, 0.2, 0.1], ..ok });
    assert!(e.contains("point 2 array Time") && e.contains("backwards"), "{e}");
    let e = from(PolylineArrays { cut: &[1.0, 2.0, 1.0], ..ok });
    assert!(e.contains("point 1 array Cut"), "{e}");
    let e = from(PolylineArrays { rpm: &[1.0], ..ok });
    assert!(e.contains("array RPM") && e.contains("3 points"), "{e}");
    let mut nan = points;
    nan[5] = f64::NAN;
    let e = from(PolylineArrays { points: &nan, ..ok });
    assert!(e.contains("point 1 coordinate z"), "{e}");
}
