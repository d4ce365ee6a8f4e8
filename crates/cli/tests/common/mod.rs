//! Shared by the CLI tests that cut the capsule tooth: the command, and a groove path.
use std::process::{Command, Output};

/// Runs the release `dentsim` with `args` (backtraces off: errors read as users see them).
pub fn dentsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dentsim")).args(args).env("RUST_BACKTRACE", "0").output().unwrap()
}

/// Down into the capsule tooth's occlusal enamel, along x 1.5 mm to 2.9 mm deep, and out (the
/// last row lifts off without cutting).
#[allow(dead_code)]
pub const GROOVE: &str = "t,x,y,z,qw,qx,qy,qz,rpm,cut\n\
0,-2.0,0,5.5,1,0,0,0,200000,1\n\
0.5,-2.0,0,4.0,1,0,0,0,200000,1\n\
1.5,1.0,0,2.9,1,0,0,0,200000,1\n\
2.0,1.0,0,5.5,1,0,0,0,200000,0\n";
