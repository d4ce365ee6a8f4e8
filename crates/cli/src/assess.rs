//! `dentsim assess`: grade a preparation against its original and a reference (logic in
//! sim::assess).
use std::path::PathBuf;

use anyhow::Result;
use dentsim_sim::assess::Kind;
use dentsim_sim::assess::report::{assess_session_to_dir, assess_to_dir, ASSESSED_SURFACE, ASSESSMENT_JSON, ASSESSMENT_PNG};

#[derive(clap::Args)]
pub struct Args {
    /// The prepared tissues (.vdb), or an output folder of prepare, session or replay.
    prepared: PathBuf,
    /// The tissues before the preparation (.vdb or a folder holding tissues.vdb); for a session's
    /// or replay's folder, by default the tissues it started from.
    #[arg(long)]
    original: Option<PathBuf>,
    /// Assess a session's folder as it stood after this tick (its log replayed that far).
    #[arg(long)]
    tick: Option<u64>,
    /// A reference preparation of the same tooth to compare against (.vdb or folder).
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// What was prepared: a cavity, or a crown (then taper, reductions, margin, undercut).
    #[arg(long, value_enum, default_value = "cavity")]
    kind: PrepKind,
    /// A crown's path of insertion X,Y,Z (default: the tooth's long axis, toward the cut).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::args::parse_xyz)]
    axis: Option<[f64; 3]>,
    /// Tissue table overrides (TOML), for grids without dentsim metadata.
    #[arg(long)]
    tissues_table: Option<PathBuf>,
    #[command(flatten)]
    memory: crate::args::MemoryArgs,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum PrepKind {
    Cavity,
    Crown,
}

pub fn run(args: &Args) -> Result<()> {
    let table = crate::args::tissue_table(args.tissues_table.as_deref())?;
    let kind = match (args.kind, args.axis) {
        (PrepKind::Cavity, None) => Kind::Cavity,
        (PrepKind::Cavity, Some(_)) => anyhow::bail!("--axis: a path of insertion is for --kind crown"),
        (PrepKind::Crown, axis) => Kind::Crown { axis: axis.map(glam::DVec3::from_array) },
    };
    let limits = crate::args::limits(args.memory, None)?;
    let session = dentsim_sim::assess::session::SessionFolder::open(&args.prepared)?.is_some();
    let a = match (&args.original, session) {
        (_, true) => assess_session_to_dir(&args.prepared, args.original.as_deref(), args.reference.as_deref(), args.tick, kind, &table, &limits, &args.out)?,
        (Some(original), false) if args.tick.is_none() => assess_to_dir(&args.prepared, original, args.reference.as_deref(), kind, &table, &limits, &args.out)?,
        (_, false) if args.tick.is_some() => {
            anyhow::bail!("--tick: {} is not a session or replay output folder (no summary.json or replay.json)", args.prepared.display())
        }
        _ => anyhow::bail!("--original is needed: {} is not a session or replay output folder", args.prepared.display()),
    };
    if let Some(p) = &a.session {
        match (p.tick, p.t_s) {
            (Some(tick), Some(t)) => println!("session {} at tick {tick} ({t:.3} s)", p.folder),
            _ => println!("session {} at its end", p.folder),
        }
        for line in p.guidance.lines() {
            println!("{line}");
        }
    }
    for (name, t) in &a.tissues {
        let vs = match (t.overcut_mm3, t.undercut_mm3) {
            (Some(o), Some(u)) => format!("  overcut {o:>8.3} mm³  undercut {u:>8.3} mm³"),
            _ => String::new(),
        };
        println!("{name:<8} removed {:>8.3} mm³{vs}", t.removed_mm3);
    }
    if let Some(d) = &a.deviation_mm {
        println!("deviation from the reference: mean {:+.3} mm, p95 {:+.3} mm, max {:+.3} mm ({} points)", d.mean, d.p95, d.max, d.points);
    }
    match a.min_remaining_dentin_mm {
        Some(d) => println!("thinnest dentin over the pulp {d:.3} mm; pulp exposed: {} ({:.3} mm²)", a.pulp_exposed, a.pulp_exposed_area_mm2),
        None => println!("nothing cut (or no pulp): no remaining dentin to measure"),
    }
    if let Some(c) = &a.crown {
        println!(
            "crown: taper {:.1}°, occlusal reduction {:.2} mm, axial {:.2} mm (min {:.2}), margin {:.2} mm, height/width {:.2}, undercut {}",
            c.taper_deg, c.occlusal_reduction_mm, c.axial_reduction_mean_mm, c.axial_reduction_min_mm, c.margin_width_mm, c.height_to_width, c.undercut
        );
    }
    println!("wrote {} ({ASSESSMENT_JSON}, {ASSESSED_SURFACE}, {ASSESSMENT_PNG})", args.out.display());
    Ok(())
}
