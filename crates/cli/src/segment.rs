use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use dentsim_cbct::{Label, ReadOptions};
use dentsim_sim::tissues::from_scan::TissuesFromScan;

#[derive(clap::Args)]
pub struct Args {
    /// A DICOM series folder, a .nii/.nii.gz or a .mha/.mhd file.
    input: PathBuf,
    /// The tissues .vdb to write; its report goes beside it as <out>.json.
    #[arg(long)]
    out: PathBuf,
    /// Voxel size of the tissue level sets, mm (finer than the scan's).
    #[arg(long, default_value_t = dentsim_sim::tissues::model::DEFAULT_VOXEL_MM)]
    voxel: f64,
    /// FDI (ISO 3950) number of the tooth.
    #[arg(long, default_value_t = 36)]
    tooth: u8,
    /// Every tooth in the scan, each its own object, written as <out stem>_tooth<N>.vdb (N by
    /// size, 1 the largest) with its report; --tooth and --point are not used.
    #[arg(long, conflicts_with_all = ["point"])]
    all_teeth: bool,
    /// A point in the tooth, LPS mm: X,Y,Z [default: the scan's centre, nearest tooth].
    #[arg(long, allow_hyphen_values = true, value_parser = crate::args::parse_xyz)]
    point: Option<[f64; 3]>,
    /// Tissue table overrides (TOML).
    #[arg(long)]
    tissues: Option<PathBuf>,
    /// Grey values overriding the automatic calibration, e.g. soft_tissue=1150,dentin=2580,enamel=3350
    /// (needed where the scan's layering does not tell enamel from dentin: the error says so).
    #[arg(long, value_delimiter = ',')]
    thresholds: Vec<String>,
    /// Leave a cone-beam scanner's shading on the grey values (it is still measured and said):
    /// by default a smooth field found drifting over the tooth is taken off before it is read.
    #[arg(long)]
    keep_shading: bool,
    #[command(flatten)]
    memory: crate::args::MemoryArgs,
}

pub fn run(args: &Args) -> Result<()> {
    let table = crate::args::tissue_table(args.tissues.as_deref())?;
    let thresholds = parse_thresholds(&args.thresholds)?;
    let request = TissuesFromScan {
        voxel_size_mm: args.voxel,
        fdi: args.tooth,
        seed_mm: args.point,
        thresholds,
        keep_shading: args.keep_shading,
        ..TissuesFromScan::default()
    };
    request.validate()?;
    let limits = crate::args::limits(args.memory, None)?;
    let options = ReadOptions { max_bytes: limits.max_memory_bytes, series_uid: None };

    let bar = crate::progress::bar(100);
    bar.set_message(format!("reading {}", args.input.display()));
    let scan = dentsim_cbct::read(&args.input, &options)?;
    for note in &scan.source.notes {
        bar.suspend(|| eprintln!("warning: {note}"));
    }
    if args.all_teeth {
        let mut teeth = request.run_all(&scan, &table, &mut |step, fraction| {
            bar.set_message(step.to_owned());
            bar.set_position((fraction * 95.0) as u64);
        })?;
        bar.set_message(format!("writing beside {}", args.out.display()));
        let paths = dentsim_sim::tissues::from_scan::write_all_segmentations(&mut teeth, &args.out)?;
        bar.finish_and_clear();
        println!("{}", dentsim_sim::tissues::from_scan::ALL_TEETH_NOTE);
        if let Some((_, report)) = teeth.first() {
            print_calibration(report);
        }
        for ((_, report), path) in teeth.iter().zip(&paths) {
            let Some((n, found)) = &report.found else { continue };
            let volumes: Vec<String> = report.tissues.iter().map(|t| format!("{} {:.2} mm³", t.name, t.volume_mm3)).collect();
            let cut = if found.cut_by_field_of_view { " (cut by the field of view)" } else { "" };
            println!(
                "tooth {n} near {:.2},{:.2},{:.2} mm{cut}: {} -> {}",
                found.seed[0],
                found.seed[1],
                found.seed[2],
                volumes.join(", "),
                path.display()
            );
            for w in &report.warnings {
                eprintln!("warning: tooth {n}: {w}");
            }
        }
        return Ok(());
    }
    let (mut model, report) = request.run(&scan, &table, &mut |step, fraction| {
        bar.set_message(step.to_owned());
        bar.set_position((fraction * 95.0) as u64);
    })?;
    bar.set_message(format!("writing {}", args.out.display()));
    let report_path = dentsim_sim::tissues::from_scan::write_segmentation(&mut model, &report, &args.out)?;
    bar.finish_and_clear();
    println!("{}", report.fdi_note);
    print_calibration(&report);
    for t in &report.tissues {
        println!("{:<8} {:>9.2} mm³", t.name, t.volume_mm3);
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    println!("wrote {} and {}", args.out.display(), report_path.display());
    Ok(())
}

fn print_calibration(report: &dentsim_sim::tissues::from_scan::ScanReport) {
    println!(
        "calibration: {} (grey = {:.3} HU + {:.1}), confidence {:.2}",
        report.calibration.method, report.calibration.hu_scale, report.calibration.hu_offset, report.calibration.confidence
    );
    for line in &report.calibration.evidence {
        println!("  {line}");
    }
    if let Some(b) = &report.metal_bloom {
        let greys: Vec<String> = b.metal_greys.iter().map(|g| format!("{g:.0}")).collect();
        let clipped = b.clipped_at.map_or(String::new(), |c| format!("; clipped at {c:.0}, read from the bloom's tail"));
        println!(
            "metal restorations (grey {}{clipped}): their blur (σ {:.2} mm) taken off {} voxels within {:.2} mm before calibrating again",
            greys.join(", "),
            b.blur_mm,
            b.voxels,
            b.reach_mm
        );
    }
}

fn parse_thresholds(items: &[String]) -> Result<Option<Vec<(Label, f64)>>> {
    if items.is_empty() {
        return Ok(None);
    }
    let mut out = Vec::new();
    for item in items {
        let (name, value) = item.split_once('=').with_context(|| format!("--thresholds: '{item}' is not TISSUE=GREY"))?;
        let label = Label::from_name(name.trim()).with_context(|| format!("--thresholds: unknown tissue '{name}'"))?;
        let grey: f64 = value.trim().parse().with_context(|| format!("--thresholds: '{value}' for {name} is not a number"))?;
        if !grey.is_finite() {
            bail!("--thresholds: {name}={value} is not finite");
        }
        out.push((label, grey));
    }
    Ok(Some(out))
}
