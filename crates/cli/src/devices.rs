//! `dentsim devices`: the HID devices plugged in, with what dentsim makes of each.
use anyhow::Result;

#[derive(clap::Args)]
pub struct Args {
    /// List every HID device, not only SpaceMice and foot pedals.
    #[arg(long)]
    all: bool,
}

pub fn run(args: &Args) -> Result<()> {
    let found = dentsim_sim::devices::hid::list()?;
    let shown: Vec<_> = found.iter().filter(|d| args.all || !d.role.is_empty()).collect();
    if shown.is_empty() {
        println!("no SpaceMouse or foot pedal found ({} HID devices in all; on Linux they appear as /dev/hidraw*, which needs a udev rule for non-root users)", found.len());
    }
    for d in shown {
        let role = if d.role.is_empty() { "-" } else { d.role.as_str() };
        println!("{:04x}:{:04x}  {:<40}  {}  {}", d.vendor, d.product, role, d.product_string, d.path);
    }
    println!("OpenIGTLink: --device igtl://HOST:PORT (default 127.0.0.1:18944), not listed here");
    Ok(())
}
