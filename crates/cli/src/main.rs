//! `dentsim`: batch preparation planning and measurement from the command line.
mod args;
mod assess;
mod batch;
mod bench;
mod demo;
mod devices;
mod phantom;
mod prepare;
mod progress;
mod segment;
mod replay;
mod session;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "dentsim", version, about = "Haptic dental preparation simulator and planner")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build the phantom, cut a stroke, write surfaces, tissues.vdb and summary.json.
    Demo(demo::Args),
    /// Turn a CBCT scan into one tooth's tissue level sets (.vdb) and a report.
    #[command(visible_alias = "tissues-from-scan")]
    Segment(segment::Args),
    /// Cut a tool path with a burr into tissues; write the prepared tissues and prepare.json.
    Prepare(prepare::Args),
    /// Write the built-in molar phantom scan as DICOM, NIfTI or MetaImage.
    Phantom(phantom::Args),
    /// Time dentsim beside its peer (plain OpenVDB and mesh-based ways) in the same run.
    Bench(bench::Args),
    /// Run a headless haptic session; write the log, prepared tissues, meshes and summary.json.
    Session(session::Args),
    /// Replay a session log bit for bit; write tissues, meshes, forces.csv and forces.png.
    Replay(replay::Args),
    /// List the SpaceMice and foot pedals plugged in (HID).
    Devices(devices::Args),
    /// Grade a preparation: removed, over- and under-cut volumes, deviation, dentin over the pulp.
    Assess(assess::Args),
    /// Plan a cohort: every scan × preparation of a manifest, whole or one shard, and one report.
    Batch(batch::Args),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Demo(args) => demo::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Segment(args) => segment::run(&args),
        Command::Phantom(args) => phantom::run(&args),
        Command::Prepare(args) => prepare::run(&args),
        Command::Session(args) => session::run(&args),
        Command::Replay(args) => replay::run(&args),
        Command::Assess(args) => assess::run(&args),
        Command::Batch(args) => batch::run(&args),
        Command::Devices(args) => devices::run(&args),
    }
}
