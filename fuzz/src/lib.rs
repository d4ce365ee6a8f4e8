//! One function per fuzz target: feeds bytes to a reader and checks what must hold for any
//! input (no panic, an error that is one short line where the reader promises it). The libFuzzer
//! binaries (`src/bin`, feature `libfuzzer`) and the corpus replay test (`tests/corpus.rs`)
//! both call these.
use dentsim_devices::{DeviceSpec, PathLimits, ScriptedPath, ToolPath};
use dentsim_sim::session::SessionLog;
use dentsim_sim::TissueTable;
use dentsim_vdb::ReadLimits;

/// Every target by name, as `scripts/fuzz.sh` and the corpus folders call them.
pub const TARGETS: &[(&str, fn(&[u8]))] = &[
    ("vdb", vdb),
    ("vdb_unguarded", vdb_unguarded),
    ("tissue_toml", tissue_toml),
    ("path_csv", path_csv),
    ("device_spec", device_spec),
    ("session_log", session_log),
    ("scan", scan),
];

/// Limits small enough that a fuzzer's memory cap (2 GiB) is never the first to refuse.
fn vdb_limits() -> ReadLimits {
    ReadLimits { max_bytes: 512 << 20, ..ReadLimits::default() }
}

fn one_line(e: &str) {
    let chars = e.chars().count();
    assert!(!e.contains('\n') && chars <= 301, "error is not one short line ({chars} characters): {e:.300}");
}

/// The guarded reader: OpenVDB's own crashes become errors.
pub fn vdb(data: &[u8]) {
    if let Err(e) = dentsim_vdb::read_bytes(data, &vdb_limits()) {
        one_line(&e);
    }
}

/// OpenVDB's reader and our checks in this process (no child): with the C++ built under
/// AddressSanitizer this finds what the guard exists for. Only inputs the layout check passes
/// reach OpenVDB, as in the guarded reader.
pub fn vdb_unguarded(data: &[u8]) {
    if dentsim_vdb::check_layout(data).is_ok() {
        let _ = dentsim_vdb::read_unguarded(data, &vdb_limits());
    }
}

pub fn tissue_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let _ = TissueTable::parse(text, "fuzz.toml");
    let _ = TissueTable::default().with_overrides(text, "fuzz.toml");
}

pub fn path_csv(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let _ = ToolPath::parse_csv(text, "fuzz.csv", PathLimits::default());
    let _ = ScriptedPath::parse(text, "fuzz.csv");
}

pub fn device_spec(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let _ = DeviceSpec::parse(text);
}

pub fn session_log(data: &[u8]) {
    let _ = SessionLog::parse(data);
}

/// A scan file; the first byte picks the reader (DICOM, NIfTI, gzip NIfTI, MetaImage), the
/// rest is the file.
pub fn scan(data: &[u8]) {
    let Some((&kind, body)) = data.split_first() else { return };
    let ext = ["dcm", "nii", "nii.gz", "mha"][kind as usize % 4];
    let dir = std::env::temp_dir().join(format!("dentsim-fuzz-scan-{}", std::process::id()));
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    let path = dir.join(format!("input.{ext}"));
    if std::fs::write(&path, body).is_err() {
        return;
    }
    let opts = dentsim_cbct::ReadOptions { max_bytes: 256 << 20, ..Default::default() };
    let _ = dentsim_cbct::read(&path, &opts);
}
