use std::path::PathBuf;

use anyhow::Result;
use dentsim_cbct::{Phantom, PhantomSpec};

#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    /// A folder of CT Image Storage files, one per slice.
    Dicom,
    /// .nii or .nii.gz, by the output's name.
    Nifti,
    /// .mha, or .mhd with a .raw beside it, by the output's name.
    Mha,
}

#[derive(clap::Args)]
pub struct Args {
    #[arg(long, value_enum)]
    format: Format,
    /// Output folder (DICOM) or file.
    #[arg(long)]
    out: PathBuf,
    /// Noise seed; the same seed gives the same scan.
    #[arg(long, default_value_t = PhantomSpec::default().seed)]
    seed: u64,
    /// Add an occlusal caries lesion in tooth 36.
    #[arg(long)]
    caries: bool,
    /// Add a metal restoration with streak artefacts in tooth 37.
    #[arg(long)]
    restoration: bool,
}

pub fn run(args: &Args) -> Result<()> {
    let spec = PhantomSpec { seed: args.seed, caries: args.caries, restoration: args.restoration, ..PhantomSpec::default() };
    let bar = crate::progress::bar(0);
    bar.set_message("making the phantom scan");
    let phantom = Phantom::new(&spec);
    let scan = phantom.scan();
    bar.set_message(format!("writing {}", args.out.display()));
    match args.format {
        Format::Dicom => dentsim_cbct::write_dicom_series(&scan, &args.out)?,
        Format::Nifti => dentsim_cbct::write_nifti(&scan, &args.out)?,
        Format::Mha => dentsim_cbct::write_metaimage(&scan, &args.out)?,
    }
    bar.finish_and_clear();
    let seed = phantom.tooth_seed(36).unwrap_or_default();
    println!(
        "wrote {}: {}×{}×{} voxels at {} mm; tooth 36 near {:.1},{:.1},{:.1} mm (LPS)",
        args.out.display(),
        scan.dims[0],
        scan.dims[1],
        scan.dims[2],
        spec.spacing_mm,
        seed[0],
        seed[1],
        seed[2]
    );
    Ok(())
}
