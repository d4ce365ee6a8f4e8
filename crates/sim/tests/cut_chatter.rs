//! Cut-mode force continuity, measured closed-loop: the simulated hand pushes the burr into tissue
//! with the pedal down at 200 k rpm; every tick's contact force (before filter) and contact tissue
//! are recorded and the cutting phase is scored for chatter (ticks without contact or force,
//! tick-to-tick force jumps) and for the removal rate against the rate law.
mod common;

use common::*;
use dentsim_devices::{Device, HandParams, ScriptedPath, SimulatedHand};
use dentsim_sim::haptics::{HapticCore, HapticParams};
use dentsim_sim::model::TissueModel;
use dentsim_sim::phantom::CapsuleTooth;
use dentsim_sim::tissue::TissueTable;
use glam::DVec3;

struct Run {
    /// |raw contact force| per tick (N).
    raw: Vec<f64>,
    /// |rendered force| per tick (N).
    out: Vec<f64>,
    tissue: Vec<Option<u16>>,
    removed: Vec<f64>,
    /// The rate law's volume for the tick (mm³): rate·|F_spring|·(rpm/ref)·dt.
    law: Vec<f64>,
    proxy_z: Vec<f64>,
    proxy: Vec<DVec3>,
    area: Vec<f64>,
    device_z: Vec<f64>,
}

#[derive(Debug)]
struct Score {
    ticks: usize,
    no_contact: usize,
    zero_force: usize,
    mean_force: f64,
    /// p99 and max of |ΔF_raw| / mean |F_raw| over consecutive ticks.
    p99_jump: f64,
    max_jump: f64,
    /// p99 of |ΔF_rendered| (N).
    p99_out_jump: f64,
    removed_mm3: f64,
    law_mm3: f64,
    /// Proxy depth reached (mm, from the first contact).
    advance_mm: f64,
}

fn run(model: &mut TissueModel, params: HapticParams, mut hand: impl Device, ticks: usize) -> Run {
    let mut core = HapticCore::new(params.clone(), model).unwrap();
    let mut r = Run { raw: vec![], out: vec![], tissue: vec![], removed: vec![], law: vec![], proxy_z: vec![], proxy: vec![], area: vec![], device_z: vec![] };
    for k in 0..ticks {
        let state = hand.poll(k as f64 * params.period_s).unwrap();
        let out = core.tick(model, &state, false).unwrap();
        hand.send_force(out.force, out.torque);
        r.raw.push(out.raw.force.length());
        r.out.push(out.force.length());
        r.tissue.push(out.raw.tissue);
        r.removed.push(out.removed_mm3);
        let speed = state.rpm / params.reference_rpm;
        r.law.push(if state.cutting() { out.raw.removal_rate * out.raw.spring.length() * speed * params.period_s } else { 0.0 });
        r.proxy_z.push(out.proxy.z);
        r.proxy.push(out.proxy);
        r.area.push(out.raw.area);
        r.device_z.push(state.pose.translation.z);
    }
    r
}

fn percentile(mut v: Vec<f64>, p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(((v.len() as f64 - 1.0) * p).round() as usize).copied().unwrap_or(0.0)
}

/// Scores the ticks from `settle` ticks after the first contact to the end.
fn score(r: &Run, settle: usize) -> Score {
    let first = r.tissue.iter().position(Option::is_some).expect("the burr never touched");
    let from = first + settle;
    let n = r.raw.len() - from;
    let raw = &r.raw[from..];
    let mean_force = raw.iter().sum::<f64>() / n as f64;
    let jumps: Vec<f64> = raw.windows(2).map(|w| (w[1] - w[0]).abs() / mean_force).collect();
    let out_jumps: Vec<f64> = r.out[from..].windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    Score {
        ticks: n,
        no_contact: r.tissue[from..].iter().filter(|t| t.is_none()).count(),
        zero_force: raw.iter().filter(|f| **f < 1e-9).count(),
        mean_force,
        p99_jump: percentile(jumps.clone(), 0.99),
        max_jump: jumps.iter().copied().fold(0.0, f64::max),
        p99_out_jump: percentile(out_jumps, 0.99),
        removed_mm3: r.removed[from..].iter().sum(),
        law_mm3: r.law[from..].iter().sum(),
        advance_mm: r.proxy_z[first] - r.proxy_z.last().unwrap(),
    }
}

fn hand(start: DVec3, target: DVec3, push_n: f64) -> SimulatedHand {
    SimulatedHand::new(HandParams { start, target, push_n, pedal: true, rpm: 200_000.0, duration_s: 10.0, ..Default::default() })
}

fn report(name: &str, r: &Run, settle: usize) -> Score {
    let s = score(r, settle);
    println!(
        "{name:<28} ticks {:>4}  no contact {:>4}  zero force {:>4}  mean |F| {:.3} N  p99 |dF|/F {:.3}  max {:.3}  p99 |dF_out| {:.4} N  removed {:.4} mm3  law {:.4} mm3  ratio {:.2}  proxy advance {:.3} mm",
        s.ticks, s.no_contact, s.zero_force, s.mean_force, s.p99_jump, s.max_jump, s.p99_out_jump, s.removed_mm3, s.law_mm3, s.removed_mm3 / s.law_mm3, s.advance_mm
    );
    s
}

fn block() -> TissueModel {
    box_model("enamel", DVec3::new(-2.0, -2.0, -3.0), DVec3::new(2.0, 2.0, 0.0))
}

fn interval(n: u32) -> HapticParams {
    HapticParams { cut_interval_ticks: n, ..HapticParams::default() }
}

#[test]
fn measure_cut_chatter() {
    // Flat enamel block (top at z = 0), the hand pushing 1 N straight down.
    for n in [1, 10] {
        let r = run(&mut block(), interval(n), hand(DVec3::new(0.0, 0.0, 0.6), DVec3::new(0.0, 0.0, -3.0), 1.0), 2000);
        report(&format!("block, hand 1 N, interval {n}"), &r, 200);
    }
    // Capsule tooth (top at z = 5), the hand pushing 2 N down through enamel into dentin.
    let mut tooth = CapsuleTooth::default().build(VOXEL, &TissueTable::default()).unwrap();
    let r = run(&mut tooth, HapticParams::default(), hand(DVec3::new(0.0, 0.0, 5.6), DVec3::new(0.0, 0.0, 2.0), 2.0), 3000);
    report("tooth, hand 2 N", &r, 200);
    // Scripted: plunge to 1 mm below the block's top in 0.3 s, then hold (the device does not yield).
    let csv = "t,x,y,z,qw,qx,qy,qz,rpm,cut\n0,0,0,0.6,1,0,0,0,200000,1\n0.3,0,0,-1.0,1,0,0,0,200000,1\n5,0,0,-1.0,1,0,0,0,200000,1\n";
    for n in [1, 10] {
        let r = run(&mut block(), interval(n), ScriptedPath::parse(csv, "plunge.csv").unwrap(), 2000);
        report(&format!("block, scripted plunge, int {n}"), &r, 0);
        if n == 10 { for k in (110..200).step_by(1) { println!("  tick {k}: raw {:.4} tissue {:?} area {:.3} removed {:.2e} proxy {:.5} {:.5} {:.5} device z {:.4}", r.raw[k], r.tissue[k], r.area[k], r.removed[k], r.proxy[k].x, r.proxy[k].y, r.proxy[k].z, r.device_z[k]); } }
    }
}
