//! A haptic session cuts a path as strokes that continue one another, each skipping what the
//! previous stroke's end head already removed (`Cutter`'s done head, any burr shape). Random
//! two-stroke paths of random burrs, checked voxel by voxel against the same strokes cut without
//! skipping (a fresh cutter for each, as a stroke cut alone): every value equal within the
//! skip's slack.
use std::sync::OnceLock;

use dentsim_sim::burr::{Burr, Shape};
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::table::TissueTable;
use dentsim_vdb::LevelSet;
use glam::{DAffine3, DQuat, DVec3, IVec3};
use proptest::prelude::*;

const H: f64 = 0.05;
const R: f64 = 1.5;

fn base() -> &'static TissueModel {
    static MODEL: OnceLock<TissueModel> = OnceLock::new();
    MODEL.get_or_init(|| {
        let grid = LevelSet::from_sdf(H, 3.0, DVec3::splat(-R), DVec3::splat(R), |p| p.length() - R).unwrap();
        let mut m = TissueModel::new("ball", None);
        m.push(TissueTable::default().get("dentin").unwrap().clone(), grid).unwrap();
        m
    })
}

fn unit(v: DVec3) -> DVec3 {
    v.try_normalize().unwrap_or(DVec3::Z)
}

fn dense(model: &TissueModel, lo: IVec3, dims: [u32; 3]) -> Vec<f32> {
    let mut v = vec![0f32; dims.iter().map(|d| *d as usize).product()];
    model.tissues[0].grid.read_dense(lo, dims, &mut v).unwrap();
    v
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    #[test]
    fn continuing_strokes_cut_what_the_strokes_cut_alone(
        shape in 0usize..11,
        d in 0.6f64..1.2,
        dir in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        depth in -0.4f64..0.1,
        axis in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        angle in 0.0f64..3.1,
        step in (-0.05f64..0.05, -0.05f64..0.05, -0.05f64..0.05),
        turn in 0.0f64..0.2,
    ) {
        let shape = Shape::ALL[shape];
        let len = match shape { Shape::Wheel => 0.4 * d, Shape::Round => d, _ => (1.2 * d).max(1.0) };
        let burr = Burr::new(shape, d, Some(len)).unwrap();
        let q = DQuat::from_axis_angle(unit(DVec3::new(axis.0, axis.1, axis.2)), angle);
        let tip = unit(DVec3::new(dir.0, dir.1, dir.2)) * (R + depth);
        let s = DVec3::new(step.0, step.1, step.2);
        // Haptic ticks: a first stroke, one continuing it unturned, one turning (no skip there).
        let poses = [
            DAffine3::from_rotation_translation(q, tip),
            DAffine3::from_rotation_translation(q, tip + s),
            DAffine3::from_rotation_translation(q, tip + 2.0 * s),
            DAffine3::from_rotation_translation(DQuat::from_rotation_z(turn) * q, tip + 3.0 * s),
        ];
        let (mut continuing, mut alone) = (base().clone(), base().clone());
        let mut cutter = Cutter::default();
        for w in poses.windows(2) {
            cutter.cut(&mut continuing, &burr, w[0], w[1]).unwrap();
            Cutter::default().cut(&mut alone, &burr, w[0], w[1]).unwrap();
        }
        let reach = burr.bounding_radius() + 0.5;
        let lo = ((tip - reach) / H).floor().as_ivec3();
        let hi = ((tip + 3.0 * s + reach) / H).ceil().as_ivec3().max(((tip - reach) / H).floor().as_ivec3());
        let lo = lo.min(((tip + 3.0 * s - reach) / H).floor().as_ivec3());
        let hi = hi.max(((tip + reach) / H).ceil().as_ivec3());
        let dims = (hi - lo + IVec3::ONE).as_uvec3().to_array();
        let (a, b) = (dense(&continuing, lo, dims), dense(&alone, lo, dims));
        let worst = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0f32, f32::max);
        let signs = a.iter().zip(&b).filter(|(x, y)| (**x < 0.0) != (**y < 0.0)).count();
        prop_assert!(worst <= 2e-5, "{:?}: values differ by up to {} mm", shape, worst);
        prop_assert_eq!(signs, 0, "{:?}: material differs", shape);
    }
}
