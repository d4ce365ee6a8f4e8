//! `dentsim session`: a headless haptic session written to a folder (logic in sim::headless).
use std::path::PathBuf;

use anyhow::Result;
use dentsim_sim::devices::DeviceProfile;
use dentsim_sim::tissues::export::{LOG_NAME, SUMMARY_NAME, TISSUES_NAME};
use dentsim_sim::haptics::filter::FilterSpec;
use dentsim_sim::session::outputs::{run_session_to_dir_with, SessionRequest};

#[derive(clap::Args)]
pub struct Args {
    /// Tissues to work on (.vdb with one level-set grid per tissue, e.g. from `dentsim demo`).
    #[arg(long)]
    tissues: PathBuf,
    /// `scripted:PATH.csv` (t,x,y,z,qw,qx,qy,qz[,rpm][,cut]), `hand:KEY=VAL,...` with keys
    /// start=X:Y:Z, target=X:Y:Z (mm), push (N), stiffness, damping, mass, pedal (0|1), rpm, duration (s),
    /// or `igtl://HOST:PORT?pose=NAME&force=NAME&pedal=1` (an arm bridged over OpenIGTLink; default
    /// 127.0.0.1:18944; runs in real time until the peer closes or Ctrl-C, then writes the outputs),
    /// or `spacemouse[:dead=15,speed=10,turn=45,axes=x:-y:-z,workspace=15,start=X:Y:Z]`; append
    /// `+pedal[:key=b]` for a USB foot pedal as the cut switch. `dentsim devices` lists HID devices.
    #[arg(long, allow_hyphen_values = true)]
    device: String,
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Device profile: touch, omni, desktop, premium15, falcon, omega.
    #[arg(long, default_value = DeviceProfile::DEFAULT_NAME)]
    profile: String,
    /// Force filter: delta, biquad or none.
    #[arg(long, default_value = FilterSpec::DEFAULT_NAME)]
    filter: String,
    /// Tick on the wall clock at 1 kHz (default: ticks back to back, same physics).
    #[arg(long)]
    realtime: bool,
    /// The burr, as `prepare` takes it: a catalogue name (`flame_016`), an ISO 6360 number
    /// (`806 314 001 524 010`) or SHAPE:DIAMETER_MM[:LENGTH_MM] (`cylinder_flat:1.2:4`).
    #[arg(long, default_value = dentsim_sim::haptics::tick::DEFAULT_BURR)]
    burr: String,
    #[command(flatten)]
    memory: crate::args::MemoryArgs,
    #[command(flatten)]
    duration: crate::args::DurationArgs,
}

pub fn run(args: &Args) -> Result<()> {
    let request = SessionRequest {
        tissues: args.tissues.clone(),
        device: args.device.clone(),
        out: args.out.clone(),
        profile: args.profile.clone(),
        filter: args.filter.clone(),
        realtime: args.realtime,
        burr: args.burr.clone(),
    };
    let limits = crate::args::limits(args.memory, Some(args.duration))?;
    // Ctrl-C ends a live device's session in order: the outputs are still written.
    let _ = ctrlc::set_handler(dentsim_sim::devices::igtl::request_stop);
    let bar = crate::progress::bar(100);
    let summary = run_session_to_dir_with(&request, &limits, &mut |step, fraction| {
        bar.set_message(step.to_owned());
        bar.set_position((fraction * 100.0) as u64);
    })?;
    bar.finish_and_clear();
    println!(
        "{} ticks ({:.3} s), {} missed deadlines, max force {:.3} N",
        summary.ticks, summary.duration_s, summary.missed_deadlines, summary.max_force_n
    );
    for t in &summary.tissues {
        println!(
            "{:<8} removed {:>8.4} mm³  contact {:>7.3} s  hash {}",
            t.volumes.name, t.volumes.removed_mm3, t.contact_s, t.content_hash
        );
    }
    for line in summary.guidance.lines() {
        println!("{line}");
    }
    println!("wrote {} ({LOG_NAME}, {TISSUES_NAME}, meshes, {SUMMARY_NAME})", args.out.display());
    Ok(())
}
