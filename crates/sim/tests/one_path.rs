//! One tool-path file gets the same verdict, and the same words, from `dentsim session`'s
//! scripted device and from `dentsim prepare` (and the plugin's CSV input): both read it with
//! `dentsim_devices::ToolPath`.
use dentsim_devices::DeviceSpec;
use dentsim_sim::plan::prepare::{PathSource, PreparationRequest};
use dentsim_sim::tissues::table::TissueTable;

const HEAD: &str = "t,x,y,z,qw,qx,qy,qz";

/// Paths each face once judged by its own rules: the session's parser refused none of the
/// "jump", "equal time" ones, prepare's refused the equal times only when they went backwards,
/// and neither knew a BOM or a repeated column.
fn cases() -> Vec<(&'static str, String)> {
    vec![
        ("good", format!("{HEAD},rpm,cut\n0,0,0,6,1,0,0,0,200000,1\n0.5,0,0,4.5,1,0,0,0,200000,1\n1,0,0,6,1,0,0,0,200000,0\n")),
        ("bom", format!("\u{feff}{HEAD}\n0,0,0,6,1,0,0,0\n1,0,0,5,1,0,0,0\n")),
        ("quarter_turn", format!("{HEAD}\n0,0,0,6,1,0,0,0\n1,0,0,6,0.7071067811865476,0.7071067811865476,0,0\n")),
        ("jump", format!("{HEAD}\n0,0,0,6,1,0,0,0\n1,0,0,-20,1,0,0,0\n")),
        ("half_turn", format!("{HEAD}\n0,0,0,6,1,0,0,0\n1,0,0,6,0,1,0,0\n")),
        ("same_time", format!("{HEAD}\n0,0,0,6,1,0,0,0\n0,0,0,5.9,1,0,0,0\n")),
        ("backwards", format!("{HEAD}\n1,0,0,6,1,0,0,0\n0.5,0,0,5.9,1,0,0,0\n")),
        ("twice_x", format!("{HEAD},x\n0,0,0,6,1,0,0,0,0\n")),
        ("nan", format!("{HEAD}\n0,0,NaN,6,1,0,0,0\n")),
        ("not_unit", format!("{HEAD}\n0,0,0,6,0.5,0,0,0\n")),
        ("cut_two", format!("{HEAD},cut\n0,0,0,6,1,0,0,0,2\n")),
        ("cut_real", format!("{HEAD},cut\n0,0,0,6,1,0,0,0,1.0\n1,0,0,5,1,0,0,0,0\n")),
        ("rpm_negative", format!("{HEAD},rpm\n0,0,0,6,1,0,0,0,-1\n")),
        ("short_row", format!("{HEAD}\n0,0,0,6,1,0,0\n")),
        ("no_rows", format!("{HEAD}\n")),
        ("empty", String::new()),
    ]
}

#[test]
fn session_and_prepare_give_one_file_the_same_verdict() {
    let dir = tempfile::tempdir().unwrap();
    let table = TissueTable::default();
    let mut accepted = Vec::new();
    for (name, text) in cases() {
        let file = dir.path().join(format!("{name}.csv"));
        std::fs::write(&file, &text).unwrap();
        let session = DeviceSpec::parse(&format!("scripted:{}", file.display())).unwrap().open().map(|_| ()).map_err(|e| e.to_string());
        let request = PreparationRequest { tissues: None, phantom_voxel_mm: 0.1, path: PathSource::Csv(&file), burr: "round:1.0", force_n: 0.0 };
        let prepare = request.run(&table).map(|_| ()).map_err(|e| e.to_string());
        assert_eq!(session, prepare, "{name}: session and prepare disagree");
        if session.is_ok() {
            accepted.push(name);
        }
        if let Err(e) = &session {
            assert!(e.contains(&file.display().to_string()), "{name}: the error names the file: {e}");
        }
    }
    assert_eq!(accepted, ["good", "bom", "quarter_turn", "cut_real"]);
}
