use std::path::PathBuf;

use anyhow::{Context, Result};
use dentsim_sim::export::{write_atomic, write_stl, write_vtp};
use dentsim_sim::preparation::{PhantomStroke, TissueOutcome};
use serde::Serialize;

#[derive(clap::Args)]
pub struct Args {
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Voxel size of the tissue level sets, mm.
    #[arg(long, allow_negative_numbers = true, default_value_t = PhantomStroke::default().voxel_size_mm)]
    voxel: f64,
    /// Round burr head diameter, mm.
    #[arg(long, allow_negative_numbers = true, default_value_t = PhantomStroke::default().burr_diameter_mm)]
    burr_diameter: f64,
    /// Burr tip at the stroke's start, mm: X,Y,Z [default: -2,0,4.2].
    #[arg(long, allow_hyphen_values = true, value_parser = crate::args::parse_xyz)]
    start: Option<[f64; 3]>,
    /// Burr tip at the stroke's end, mm: X,Y,Z [default: 1,0,2.9].
    #[arg(long, allow_hyphen_values = true, value_parser = crate::args::parse_xyz)]
    end: Option<[f64; 3]>,
    /// Tissue table overrides (TOML).
    #[arg(long)]
    tissues: Option<PathBuf>,
}

#[derive(Serialize)]
struct Summary<'a> {
    dentsim_version: &'static str,
    phantom: &'static str,
    voxel_size_mm: f64,
    burr: String,
    stroke_start_mm: [f64; 3],
    stroke_end_mm: [f64; 3],
    tissues: &'a [TissueOutcome],
    triangles: Vec<(String, usize)>,
}

pub fn run(args: &Args) -> Result<()> {
    let table = crate::args::tissue_table(args.tissues.as_deref())?;
    let defaults = PhantomStroke::default();
    let params = PhantomStroke {
        voxel_size_mm: args.voxel,
        burr_diameter_mm: args.burr_diameter,
        start_mm: args.start.unwrap_or(defaults.start_mm),
        end_mm: args.end.unwrap_or(defaults.end_mm),
    };
    params.validate()?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;

    let bar = crate::progress::bar(100);
    let mut outcome = params.run(&table, &mut |step, fraction| {
        bar.set_message(step.to_owned());
        bar.set_position((fraction * 60.0) as u64);
    })?;
    let mut triangles = Vec::new();
    for t in &outcome.model.tissues {
        bar.set_message(format!("meshing {}", t.props.name));
        let mesh = t.grid.to_mesh();
        write_vtp(&args.out.join(format!("{}.vtp", t.props.name)), &mesh, &t.props)?;
        write_stl(&args.out.join(format!("{}.stl", t.props.name)), &mesh)?;
        triangles.push((t.props.name.clone(), mesh.triangles.len()));
        bar.inc(10);
    }
    bar.set_message("writing tissues.vdb");
    outcome.model.save(&args.out.join("tissues.vdb"))?;
    let summary = Summary {
        dentsim_version: env!("CARGO_PKG_VERSION"),
        phantom: "capsule tooth (enamel, dentin, pulp)",
        voxel_size_mm: params.voxel_size_mm,
        burr: format!("round {} mm", params.burr_diameter_mm),
        stroke_start_mm: params.start_mm,
        stroke_end_mm: params.end_mm,
        tissues: &outcome.tissues,
        triangles,
    };
    let json = serde_json::to_vec_pretty(&summary)?;
    write_atomic(&args.out.join("summary.json"), |w| w.write_all(&json))?;
    bar.finish_with_message("done");
    for t in &outcome.tissues {
        println!(
            "{:<8} before {:>9.3} mm³  after {:>9.3} mm³  removed {:>7.3} mm³",
            t.name, t.volume_before_mm3, t.volume_after_mm3, t.removed_mm3
        );
    }
    println!("wrote {}", args.out.display());
    Ok(())
}
