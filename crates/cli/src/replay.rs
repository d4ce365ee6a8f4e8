//! `dentsim replay`: redo a logged session on its starting tissues (logic in sim::headless).
use std::path::PathBuf;

use anyhow::Result;
use dentsim_sim::tissues::export::{FORCES_CSV_NAME, FORCES_PNG_NAME, REPLAY_SUMMARY_NAME, TISSUES_NAME};
use dentsim_sim::session::outputs::replay_to_dir_until;

#[derive(clap::Args)]
pub struct Args {
    /// The session log (session.dslog).
    log: PathBuf,
    /// The tissues the session started from (.vdb).
    #[arg(long)]
    tissues: PathBuf,
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Stop after this tick: the outputs hold the tissues as they were then (e.g. for
    /// `dentsim assess`).
    #[arg(long)]
    until_tick: Option<u64>,
    #[command(flatten)]
    memory: crate::args::MemoryArgs,
}

pub fn run(args: &Args) -> Result<()> {
    let limits = crate::args::limits(args.memory, None)?;
    let bar = crate::progress::bar(100);
    let summary = replay_to_dir_until(&args.log, &args.tissues, &args.out, &limits, args.until_tick, &mut |step, fraction| {
        bar.set_message(step.to_owned());
        bar.set_position((fraction * 100.0) as u64);
    })?;
    bar.finish_and_clear();
    if summary.truncated_log_bytes > 0 {
        println!(
            "note: {} bytes after the last whole tick are not a whole record (the session stopped while writing); dropped",
            summary.truncated_log_bytes
        );
    }
    println!("{} ticks replayed; largest force difference from the log {} N", summary.ticks, summary.max_force_difference_n);
    for t in &summary.tissues {
        println!("{:<8} removed {:>8.4} mm³  hash {}", t.volumes.name, t.volumes.removed_mm3, t.content_hash);
    }
    for line in summary.guidance.lines() {
        println!("{line}");
    }
    match summary.ticks_guided_differently {
        Some(0) => println!("guidance: every replayed tick warned as logged"),
        Some(n) => println!("guidance: {n} replayed ticks warned otherwise than logged"),
        None => println!("guidance: the log predates logged guidance (version < 5): not compared"),
    }
    match (summary.hashes_match_session, args.until_tick) {
        (_, Some(tick)) => println!("stopped after tick {tick}: the outputs hold the tissues as they were then"),
        (Some(true), None) => println!("bit-exact: every tissue's content hash equals the session's (summary.json beside the log)"),
        (Some(false), None) => unreachable!("replay_to_dir reports a mismatch as an error"),
        (None, None) => println!("no summary.json beside the log: content hashes printed above, not compared"),
    }
    println!("wrote {} ({TISSUES_NAME}, meshes, {FORCES_CSV_NAME}, {FORCES_PNG_NAME}, {REPLAY_SUMMARY_NAME})", args.out.display());
    Ok(())
}
