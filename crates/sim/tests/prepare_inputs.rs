//! What ParaView's "Dental Preparation" builds on: tissues rebuilt from an upstream filter's
//! surfaces, and a cut its caller stops part-way.
use dentsim_sim::plan::path::ToolPath;
use dentsim_sim::plan::prepare::{prepare_until, PathSource, PrepareOptions, PreparationRequest, ABORTED};
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::table::TissueTable;

fn phantom_surfaces(voxel_mm: f64) -> (TissueModel, Vec<(String, dentsim_vdb::TriMesh)>) {
    let model = CapsuleTooth::default().build(voxel_mm, &TissueTable::default()).unwrap();
    let surfaces = model.tissues.iter().map(|t| (t.props.name.clone(), dentsim_sim::tissues::surface::surface(&t.grid).unwrap())).collect();
    (model, surfaces)
}

#[test]
fn tissues_rebuilt_from_their_surfaces_keep_their_volumes_and_properties() {
    let (model, surfaces) = phantom_surfaces(0.1);
    let rebuilt = TissueModel::from_surfaces("Tissues", &surfaces, 0.1, &TissueTable::default()).unwrap();
    let names: Vec<_> = rebuilt.tissues.iter().map(|t| t.props.name.as_str()).collect();
    assert_eq!(names, ["enamel", "dentin", "pulp"]);
    for ((name, before), (_, after)) in model.volumes().into_iter().zip(rebuilt.volumes()) {
        assert!((after / before - 1.0).abs() < 0.02, "{name}: {before} mm³ → {after} mm³");
    }
    assert_eq!(rebuilt.tissues[0].props, model.tissues[0].props);
}

#[test]
fn surfaces_that_are_not_tissues_are_refused_by_name() {
    let (_, mut surfaces) = phantom_surfaces(0.2);
    surfaces[1].0 = "burr".into();
    let err = TissueModel::from_surfaces("Tissues", &surfaces, 0.2, &TissueTable::default()).err().unwrap().to_string();
    assert!(err.contains("Tissues block 'burr'") && err.contains("not a tissue"), "{err}");
    let err = TissueModel::from_surfaces("Tissues", &[], 0.2, &TissueTable::default()).err().unwrap().to_string();
    assert!(err.contains("no tissue surfaces"), "{err}");
    let err = TissueModel::from_surfaces("Tissues", &surfaces[..1], -1.0, &TissueTable::default()).err().unwrap().to_string();
    assert!(err.contains("voxel size"), "{err}");
}

fn groove_csv(dir: &std::path::Path) -> std::path::PathBuf {
    let mut text = String::from("t,x,y,z,qw,qx,qy,qz,cut\n0,-1.5,0,5.6,1,0,0,0,0\n");
    for i in 0..=30 {
        text += &format!("{},{},0,4.0,1,0,0,0,1\n", 0.01 * f64::from(i + 1), -1.5 + 0.1 * f64::from(i));
    }
    let file = dir.join("groove.csv");
    std::fs::write(&file, text).unwrap();
    file
}

#[test]
fn a_preparation_stops_when_its_caller_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let file = groove_csv(dir.path());
    let path = ToolPath::read(&file, Default::default()).unwrap();
    let burr = dentsim_sim::burr::Burr::parse("round:1.0").unwrap();
    let (mut model, _) = phantom_surfaces(0.1);
    let mut calls = Vec::new();
    let err = prepare_until(&mut model, &path, &burr, &PrepareOptions::default(), &mut |f| {
        calls.push(f);
        calls.len() < 5
    })
    .err()
    .unwrap();
    assert!(err.to_string().contains(ABORTED), "{err}");
    assert_eq!(calls.len(), 5, "stopped at the first check that said no");
    assert!(calls.windows(2).all(|w| w[0] <= w[1]) && calls[4] < 1.0, "{calls:?}");
}

#[test]
fn a_request_cuts_a_model_it_is_given_as_it_cuts_the_phantom() {
    let dir = tempfile::tempdir().unwrap();
    let file = groove_csv(dir.path());
    let table = TissueTable::default();
    let request = PreparationRequest { tissues: None, phantom_voxel_mm: 0.1, path: PathSource::Csv(&file), burr: "round:1.0", force_n: 0.0 };
    let on_phantom = request.run(&table).unwrap();
    let (model, _) = phantom_surfaces(0.1);
    let on_given = request.run_until(&table, Some(model), &mut |_| true).unwrap();
    assert_eq!(on_phantom.report, on_given.report);
    assert!(on_given.report.removed_mm3["enamel"] > 1.0, "{:?}", on_given.report.removed_mm3);
}
