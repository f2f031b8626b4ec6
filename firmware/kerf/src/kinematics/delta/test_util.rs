//! Helpers shared by the delta tests: the geometries checked, joint grids, the
//! workspace sample and the loop-closure residual.

extern crate std;
use super::{DeltaConfig, DeltaGeometry, DEG};
use crate::scalar::Float;
use nalgebra::Vector3;
use std::vec::Vec;

pub(super) type V = Vector3<f64>;

/// T's frame, θ = 90°/190°/350° (T fig. 6.2 A) on the Keops dimensions.
pub(super) fn asymmetric_keops() -> DeltaConfig {
    let mut c = DeltaConfig::SLAVE_KEOPS;
    for (a, t) in c.actuators.iter_mut().zip([90.0, 190.0, 350.0]) {
        a.theta_rad = t * DEG;
    }
    c
}

/// Asymmetric master: θ = 90°/190°/350° on the horizontal master.
pub(super) fn asymmetric_master() -> DeltaConfig {
    let mut c = DeltaConfig::MASTER_HORIZONTAL;
    for (a, t) in c.actuators.iter_mut().zip([90.0, 190.0, 350.0]) {
        a.theta_rad = t * DEG;
    }
    c
}

/// Unequal αi, li and radii on asymmetric azimuths.
pub(super) fn unequal() -> DeltaConfig {
    let mut c = asymmetric_keops();
    let alpha = [20.0, 30.0, 40.0];
    let arm = [0.066, 0.070, 0.074];
    let rb = [0.084, 0.086, 0.090];
    let re = [0.019, 0.020, 0.022];
    for (i, a) in c.actuators.iter_mut().enumerate() {
        a.alpha_rad = alpha[i] * DEG;
        a.arm_m = arm[i];
        a.base_radius_m = rb[i];
        a.effector_radius_m = re[i];
    }
    c
}

/// Every geometry the checks run on.
pub(super) fn all() -> Vec<(&'static str, DeltaConfig)> {
    std::vec![
        ("master", DeltaConfig::MASTER_HORIZONTAL),
        ("slave", DeltaConfig::SLAVE_KEOPS),
        ("vertical", DeltaConfig::VERTICAL),
        ("asymmetric master", asymmetric_master()),
        ("asymmetric keops", asymmetric_keops()),
        ("unequal", unequal()),
    ]
}

pub(super) fn geometry<T: Float>(c: &DeltaConfig) -> DeltaGeometry<T> {
    DeltaGeometry::new(c).unwrap()
}

/// `n`³ joint grid over the travel box (cell centres, so that rounding at the
/// travel limits cannot turn a round trip into `OutsideTravel`).
pub(super) fn joint_grid(c: &DeltaConfig, n: usize) -> Vec<V> {
    let axis = |i: usize, k: usize| {
        let a = &c.actuators[i];
        a.travel_min_m + (a.travel_max_m - a.travel_min_m) * (k as f64 + 0.5) / n as f64
    };
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                out.push(V::new(axis(0, i), axis(1, j), axis(2, k)));
            }
        }
    }
    out
}

/// Pairs (q, p) of the grid where FK succeeds and the Jacobian is regular.
pub(super) fn workspace(c: &DeltaConfig, n: usize) -> Vec<(V, V)> {
    let g = geometry::<f64>(c);
    joint_grid(c, n)
        .into_iter()
        .filter_map(|q| {
            let p = g.forward(&q).ok()?;
            g.jacobian(&q, &p).ok()?;
            Some((q, p))
        })
        .collect()
}

/// Residual of the loop closure |p + ai| − li of every arm (m).
pub(super) fn loop_residual(c: &DeltaConfig, q: &V, p: &V) -> f64 {
    let g = geometry::<f64>(c);
    (g.actuators.iter().zip(c.actuators.iter()).zip(q.iter()))
        .map(|((a, config), d)| ((p + a.half_sigma(*d)).norm() - config.arm_m).abs())
        .fold(0.0, f64::max)
}

// f64 round trips: rounding is ~1e-16 × 0.3 m, amplified by at most the condition
// number allowed by SINGULAR_SINE (1e3): 1e-9 m leaves four decades of margin.
pub(super) const ROUND_TRIP_M: f64 = 1e-9;

pub(super) fn travel_point(c: &DeltaConfig, u: [f64; 3]) -> V {
    let a = &c.actuators;
    V::from_fn(|i, _| a[i].travel_min_m + u[i] * (a[i].travel_max_m - a[i].travel_min_m))
}
