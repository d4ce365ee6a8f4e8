use std::path::PathBuf;

use anyhow::{bail, Context, Result};

#[derive(clap::Args)]
pub struct Args {
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Voxel size of the tissue level sets, mm.
    #[arg(long, allow_negative_numbers = true, default_value_t = dentsim_sim::tissues::model::DEFAULT_VOXEL_MM)]
    voxel: f64,
    /// Tissue table overrides (TOML).
    #[arg(long)]
    tissues: Option<PathBuf>,
}

pub fn run(args: &Args) -> Result<()> {
    let table = crate::args::tissue_table(args.tissues.as_deref())?;
    if !(args.voxel.is_finite() && (0.02..=0.2).contains(&args.voxel)) {
        bail!("--voxel: voxel size {} mm, expected 0.02 to 0.2 mm", args.voxel);
    }
    let bar = crate::progress::bar(100);
    let mut on_step = |step: &str, fraction: f64| {
        bar.set_message(step.to_owned());
        bar.set_position((fraction * 100.0) as u64);
    };
    let (mut model, mut summary) = dentsim_sim::plan::demo::run(args.voxel, &table, &mut on_step)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    dentsim_sim::plan::demo::write(&mut model, &mut summary, &args.out, &mut |step, f| on_step(step, 0.9 + 0.1 * f))?;
    bar.finish_and_clear();
    println!("tooth 36 of the molar phantom, class I cavity (round:1.0, then cylinder_flat:1.0:4)");
    for t in &summary.tissues {
        println!(
            "{:<8} truth {:>8.2}  segmented {:>8.2}  after {:>8.2}  removed {:>6.3} mm³",
            t.volumes.name, t.true_volume_mm3, t.volumes.volume_before_mm3, t.volumes.volume_after_mm3, t.volumes.removed_mm3
        );
    }
    println!("wrote {}", args.out.display());
    Ok(())
}
