//! The phantom family's full sweep through the whole pipeline: each case's volume error, mean
//! surface distance and mean normal error per tissue against the analytic tooth, ✗ where the
//! issue's goals (2 % / 2 % / 5 %, 0.05 mm, 5°) are missed.
//! `cargo run --release -p dentsim-sim --example family_sweep [quick] [ideal]`; `pulp`: the pulp's voxels and partial-volume measure too; `ideal`: every
//! scan without noise, point spread or integer storage (only the voxels' own averaging), what
//! the scan's resolution alone allows; `floor`: the analytic level sets' own figures (the
//! metric's floor); `resolution`: the analytic tissues blurred by each scan's point spread.
//! `quiet`: every scan without noise (point spread and integer storage kept): the noise's share.
//! `regions`: where the enamel's, dentin's and pulp's normal error lies (DEJ, thin cervical
//! enamel, outer surface, root, pulp wall; the pulp's chamber, its thin parts and their apices),
//! ours against the sampled resolution floor's, angle and mean signed distance (with `quiet` or `ideal` as above). `volumes`: where each
//! tissue's volume error lies (mm³ ours holds and the truth not, and the reverse) by the truth's
//! nearest interface (pulp wall, outer surface, DEJ), or past our band, sampled on a 0.025 mm grid.
//! `beside-floor`: each tissue's normal error beside its sampled resolution floor's, and the
//! normal misses counted by whether that floor itself is over 5° (a goal no reading that does not
//! sharpen the scan reaches) or under it (within reach).
//! `json=FILE`: each case's figures written to FILE as JSON too; `against=FILE`: each tissue's
//! figures beside those of an earlier run's FILE, with the change (a change measured, case by case).
#[path = "../tests/family/mod.rs"]
mod family;

fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    if std::env::args().any(|a| a == "floor") {
        for case in dentsim_cbct::phantom::family(false) {
            println!("{:70} analytic level set: {:?}", case.name, family::floor(&case, 0.05));
        }
        return;
    }
    if std::env::args().any(|a| a == "resolution") {
        for case in dentsim_cbct::phantom::family(!quick) {
            let floor = family::resolution_floor(&case, 0.05, std::env::args().any(|a| a == "sampled"));
            let text: Vec<String> = floor.iter().map(|(l, d, a)| format!("{} {d:.3} mm {a:.1}°", l.name())).collect();
            println!("{:70} resolution floor: {}", case.name, text.join(" | "));
        }
        return;
    }
    // `volumes`: where each tissue's volume error lies, by the truth's nearest interface.
    if std::env::args().any(|a| a == "volumes") {
        let only: Vec<String> = std::env::args().filter_map(|a| a.strip_prefix("only=").map(str::to_owned)).collect();
        for case in dentsim_cbct::phantom::family(!quick) {
            if !only.is_empty() && !only.iter().any(|o| case.name.contains(o.as_str())) {
                continue;
            }
            println!("{}", case.name);
            for label in [dentsim_cbct::Label::Enamel, dentsim_cbct::Label::Dentin, dentsim_cbct::Label::Pulp] {
                match family::volume_regions(&case, 0.05, label, 0.025) {
                    Ok(bins) => {
                        let text: Vec<String> = bins.iter().map(|(n, plus, minus)| format!("{n} +{plus:.2}/{minus:.2}")).collect();
                        let total: f64 = bins.iter().map(|(_, p, m)| p + m).sum();
                        println!("  {:7} {total:+.2} mm³: {}", label.name(), text.join(" | "));
                    }
                    Err(e) => println!("  {e}"),
                }
            }
        }
        return;
    }
    // `regions`: where our enamel's, dentin's and pulp's normal error lies against the sampled floor's.
    if std::env::args().any(|a| a == "regions") {
        let only: Vec<String> = std::env::args().filter_map(|a| a.strip_prefix("only=").map(str::to_owned)).collect();
        for mut case in dentsim_cbct::phantom::family(!quick) {
            if std::env::args().any(|a| a == "quiet") {
                case.spec.noise_sigma = 0.0;
            }
            if std::env::args().any(|a| a == "ideal") {
                case.spec.noise_sigma = 0.0;
                case.spec.blur_sigma_mm = 0.0;
                case.spec.integer = None;
            }
            if only.is_empty() || only.iter().any(|o| case.name.contains(o.as_str())) {
                if let Err(e) = family::print_regions(&case, 0.05) {
                    println!("{e}");
                }
            }
        }
        return;
    }
    let (mut met, mut all) = (0, 0);
    let (mut volume, mut surface, mut normal) = (0, 0, 0);
    let ideal = std::env::args().any(|a| a == "ideal");
    // `quiet`: without noise only (point spread and integer storage kept): the noise's share.
    let quiet = std::env::args().any(|a| a == "quiet");
    // `only=TEXT`: the cases whose name holds TEXT.
    let only: Vec<String> = std::env::args().filter_map(|a| a.strip_prefix("only=").map(str::to_owned)).collect();
    let json = std::env::args().find_map(|a| a.strip_prefix("json=").map(std::path::PathBuf::from));
    let against = match std::env::args().find_map(|a| a.strip_prefix("against=").map(std::path::PathBuf::from)) {
        Some(path) => match std::fs::read_to_string(&path).map_err(|e| e.to_string()).and_then(|text| serde_json::from_str::<serde_json::Value>(&text).map_err(|e| e.to_string())) {
            Ok(earlier) => Some(earlier),
            Err(e) => {
                eprintln!("{}: {e}", path.display());
                std::process::exit(2);
            }
        },
        None => None,
    };
    let beside_floor = std::env::args().any(|a| a == "beside-floor");
    // Normal misses whose sampled floor is over the goal, and those under it.
    let (mut past_floor, mut within_reach) = (Vec::new(), Vec::new());
    let mut cases = Vec::new();
    for mut case in dentsim_cbct::phantom::family(!quick) {
        if !only.is_empty() && !only.iter().any(|o| case.name.contains(o.as_str())) {
            continue;
        }
        if ideal {
            case.spec.noise_sigma = 0.0;
            case.spec.blur_sigma_mm = 0.0;
            case.spec.integer = None;
        }
        if quiet {
            case.spec.noise_sigma = 0.0;
        }
        match family::run(&case, 0.05) {
            Ok(r) => {
                family::print(&r);
                if let Some(earlier) = against.as_ref().and_then(|a| a["cases"].as_array()).and_then(|cases| cases.iter().find(|c| c["name"] == r.name.as_str())) {
                    print_against(&r, earlier);
                }
                if beside_floor {
                    let floor = family::resolution_floor(&case, 0.05, true);
                    let mut text = Vec::new();
                    for t in &r.tissues {
                        let Some(&(_, _, floor_deg)) = floor.iter().find(|(l, _, _)| *l == t.label) else { continue };
                        text.push(format!("{} {:.1}° / {:.1}°", t.label.name(), t.normal_deg, floor_deg));
                        if t.normal_deg > 5.0 {
                            let miss = format!("{} {} ({:.1}°, floor {:.1}°)", r.name, t.label.name(), t.normal_deg, floor_deg);
                            if floor_deg > 5.0 { past_floor.push(miss) } else { within_reach.push(miss) }
                        }
                    }
                    println!("    normals, ours / sampled floor: {}", text.join(" | "));
                }
                cases.push(case_json(&r));
                if let (true, Some((truth, voxels, measure, offset))) = (std::env::args().any(|a| a == "pulp"), r.pulp) {
                    println!("    pulp: true {truth:.2} mm³, voxels {voxels:.2} ({:+.1} %), measure {measure:.2} ({:+.1} %), offset {offset:+.3} mm", 100.0 * (voxels / truth - 1.0), 100.0 * (measure / truth - 1.0));
                }
                met += r.tissues.iter().filter(|t| family::meets_goals(t)).count();
                volume += r.tissues.iter().filter(|t| t.volume_error.abs() <= if t.label == dentsim_cbct::Label::Pulp { 0.05 } else { 0.02 }).count();
                surface += r.tissues.iter().filter(|t| t.surface_mm <= 0.05).count();
                normal += r.tissues.iter().filter(|t| t.normal_deg <= 5.0).count();
                all += r.tissues.len();
            }
            Err(e) => println!("{e}"),
        }
    }
    println!("{met} of {all} tissues meet the goals: volume {volume}, mean surface distance {surface}, mean normal error {normal}");
    if beside_floor {
        println!("normal misses whose sampled resolution floor is itself over 5°: {}", past_floor.len());
        past_floor.iter().for_each(|m| println!("    {m}"));
        println!("normal misses whose floor is within 5°: {}", within_reach.len());
        within_reach.iter().for_each(|m| println!("    {m}"));
    }
    if let Some(path) = json {
        let run = serde_json::json!({ "ideal": ideal, "quiet": quiet, "met": met, "of": all, "cases": cases });
        if let Err(e) = std::fs::write(&path, serde_json::to_string_pretty(&run).expect("plain values")) {
            eprintln!("{}: {e}", path.display());
            std::process::exit(2);
        }
    }
}

fn case_json(r: &family::CaseResult) -> serde_json::Value {
    let tissues: Vec<serde_json::Value> = r
        .tissues
        .iter()
        .map(|t| serde_json::json!({ "tissue": t.label.name(), "volume_error": t.volume_error, "surface_mm": t.surface_mm, "normal_deg": t.normal_deg, "meets_goals": family::meets_goals(t) }))
        .collect();
    serde_json::json!({ "name": r.name, "confidence": r.confidence, "seconds": r.seconds, "tissues": tissues })
}

/// Each tissue's volume error, surface distance and normal error, then → now (change).
fn print_against(r: &family::CaseResult, earlier: &serde_json::Value) {
    for t in &r.tissues {
        let Some(e) = earlier["tissues"].as_array().and_then(|ts| ts.iter().find(|e| e["tissue"] == t.label.name())) else { continue };
        let (Some(v), Some(d), Some(a)) = (e["volume_error"].as_f64(), e["surface_mm"].as_f64(), e["normal_deg"].as_f64()) else { continue };
        println!(
            "    {:7} volume {:+.2} → {:+.2} % | surface {:.4} → {:.4} mm | normals {:.2} → {:.2}° ({:+.2}°)",
            t.label.name(),
            100.0 * v,
            100.0 * t.volume_error,
            d,
            t.surface_mm,
            a,
            t.normal_deg,
            t.normal_deg - a
        );
    }
}
