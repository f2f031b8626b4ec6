//! The fixture against the print's joint-space law (Kq1, Kq2 built as matrices through
//! the master delta's Jacobians), its free direction, J̇φ against finite differences,
//! and a point mass pushed across and moving along a circle.

use super::*;
use crate::kinematics::delta::{DeltaConfig, DeltaGeometry};
use crate::trajectory::constraint::{ConstraintConfig, MotionConstraint};
use crate::trajectory::shapes::ellipse;
use nalgebra::Matrix2x3;
extern crate std;
use std::println;
use std::string::ToString;

const LAMBDA: f64 = 2.0 * core::f64::consts::PI * 20.0;
const K: f64 = 2.0 * core::f64::consts::PI * 40.0;
const RADIUS_M: f64 = 0.02;

fn fixture() -> Fixture<f64> {
    let row = PreviewConfig {
        surface_slope_per_s: LAMBDA,
        reaching_rate_per_s: K,
    };
    Fixture::new(&FixtureConfig {
        normal: row,
        vertical: row,
    })
    .unwrap()
}

/// A 20 mm circle of 128 points about `centre` (x, y).
fn circle(centre: [f64; 2]) -> MotionConstraint<f64, 128> {
    let points: [[f64; 2]; 128] = ellipse(RADIUS_M, RADIUS_M);
    let shifted: [[f64; 2]; 128] = points.map(|p| [p[0] + centre[0], p[1] + centre[1]]);
    MotionConstraint::new(&shifted, &ConstraintConfig::closed_contour()).unwrap()
}

#[test]
fn matches_the_prints_joint_space_law_on_the_master() {
    let geometry = DeltaGeometry::<f64>::new(&DeltaConfig::MASTER_HORIZONTAL).unwrap();
    let centre = geometry.forward(&Vector3::new(0.07, 0.07, 0.07)).unwrap();
    let constraint = circle([centre.x, centre.y]);
    let z_ref = centre.z;
    let law = fixture();
    for (q, q_dot) in [
        ([0.072, 0.066, 0.075], [0.02, -0.01, 0.015]),
        ([0.060, 0.080, 0.071], [-0.03, 0.02, 0.0]),
    ] {
        let (q, q_dot) = (Vector3::from(q), Vector3::from(q_dot));
        let x = geometry.forward(&q).unwrap();
        let jx = geometry.jacobian(&q, &x).unwrap();
        let jx_dot = geometry.jacobian_derivative(&q, &x, &q_dot).unwrap();
        let jx_inv = jx.try_inverse().unwrap();
        let v = jx * q_dot;
        let value = constraint.evaluate(x, z_ref).unwrap();
        // The print's matrices with C2 = I, C1 = λI, K = kI.
        let jphi = value.jacobian;
        let jphi_dot = Matrix2x3::new(
            value.gradient_rate_per_m * v.x,
            value.gradient_rate_per_m * v.y,
            0.0,
            0.0,
            0.0,
            0.0,
        );
        let pinv = jphi.transpose() * (jphi * jphi.transpose()).try_inverse().unwrap();
        let (c1, k) = (Matrix2::identity() * LAMBDA, Matrix2::identity() * K);
        let kq1 = jx_inv * pinv * k * c1;
        let kq2 = jx_inv * jx_dot
            + jx_inv * pinv * jphi_dot * jx
            + jx_inv * pinv * c1 * jphi * jx
            + jx_inv * pinv * k * jphi * jx;
        let q_ddot = -kq2 * q_dot - kq1 * value.phi;
        let want = jx * q_ddot + jx_dot * q_dot;
        let out = law.task_acceleration(&value, &v).unwrap();
        let err = (out.constrained_acceleration - want).amax();
        assert!(
            err < 1e-9 * want.amax().max(1e-3),
            "{err} of {}",
            want.amax()
        );
    }
}

#[test]
fn nothing_acts_along_the_curve() {
    let constraint = circle([0.0, 0.0]);
    let law = fixture();
    for (x, v) in [
        ([0.0203, 0.0011, 0.001], [0.001, 0.03, -0.002]),
        ([-0.0051, -0.0187, -0.0005], [0.02, -0.01, 0.0]),
    ] {
        let (x, v) = (Vector3::from(x), Vector3::from(v));
        let value = constraint.evaluate(x, 0.0).unwrap();
        let out = law.task_acceleration(&value, &v).unwrap();
        let g = value.jacobian.row(0);
        let tangent = Vector3::new(-g[1], g[0], 0.0).normalize();
        assert!((out.projector * tangent).amax() < 1e-15);
        assert!(out.constrained_acceleration.dot(&tangent).abs() < 1e-12);
        // P is a symmetric projector.
        let p = out.projector;
        assert!((p * p - p).amax() < 1e-14 && (p - p.transpose()).amax() < 1e-15);
    }
}

#[test]
fn the_gradient_rate_is_the_derivative_of_the_jacobian() {
    let constraint = circle([0.003, -0.002]);
    let x = Vector3::new(0.003 + 0.0199, -0.002 + 0.0021, 0.0);
    let v = Vector3::new(-0.004, 0.025, 0.0);
    let h = 1e-4;
    let g = |t: f64| {
        constraint
            .evaluate(x + v * t, 0.0)
            .unwrap()
            .jacobian
            .row(0)
            .transpose()
    };
    let derivative = (g(h) - g(-h)) / (2.0 * h);
    let value = constraint.evaluate(x, 0.0).unwrap();
    let got = value.gradient_rate_per_m * (v.x * v.x + v.y * v.y);
    let want = derivative.dot(&v);
    // On a fitted circle (the 128-gon's windows) the rate is s/r of the fit; the
    // central difference errs by h²/6 of the third derivative, far below 1 %.
    assert!(
        (got - want).abs() < 0.01 * want.abs(),
        "{got} against {want}"
    );
}

#[test]
fn a_push_across_settles_at_a_over_lambda_k_and_the_speed_along_is_kept() {
    // A point mass on the circle's left side moving at 10 mm/s along it, pushed
    // outwards with 2 m/s² (a 1 kg effector pushed with 2 N); 1 s at 10 kHz.
    let constraint = circle([0.0, 0.0]);
    let law = fixture();
    let (mut x, mut v) = (
        Vector3::new(RADIUS_M, 0.0, 0.0),
        Vector3::new(0.0, 0.01, 0.0),
    );
    let push = 2.0;
    let h = 1e-4;
    let accel = |x: Vector3<f64>, v: Vector3<f64>| {
        let value = constraint.evaluate(x, 0.0).unwrap();
        let out = law.task_acceleration(&value, &v).unwrap();
        let outward = Vector3::new(x.x, x.y, 0.0).normalize();
        out.constrained_acceleration + outward * push
    };
    for _ in 0..10_000 {
        // RK4.
        let (k1v, k1x) = (accel(x, v), v);
        let (k2v, k2x) = (
            accel(x + k1x * (h / 2.0), v + k1v * (h / 2.0)),
            v + k1v * (h / 2.0),
        );
        let (k3v, k3x) = (
            accel(x + k2x * (h / 2.0), v + k2v * (h / 2.0)),
            v + k2v * (h / 2.0),
        );
        let (k4v, k4x) = (accel(x + k3x * h, v + k3v * h), v + k3v * h);
        x += (k1x + k2x * 2.0 + k3x * 2.0 + k4x) * (h / 6.0);
        v += (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (h / 6.0);
    }
    let radial = Vector3::new(x.x, x.y, 0.0).norm() - RADIUS_M;
    let want = push / (LAMBDA * K);
    // Steady state of φ̈ + (λ + K)φ̇ + λKφ = a; the 128-gon's fitted circles are within
    // 1e-4 of the true radius (0.002 µm on 20 mm).
    assert!(
        (radial - want).abs() < 0.01 * want,
        "{radial} against {want}"
    );
    let speed = Vector3::new(v.x, v.y, 0.0).norm();
    assert!((speed - 0.01).abs() < 1e-4, "{speed}");
    assert!(x.z.abs() < 1e-12);
    println!(
        "fixture stiffness: {:.1} µm per N at 1 kg (λ = 2π·20, K = 2π·40)",
        1e6 * radial / push
    );
}

#[test]
fn bad_rates_are_named() {
    let good = PreviewConfig {
        surface_slope_per_s: 1.0,
        reaching_rate_per_s: 1.0,
    };
    let mut config = FixtureConfig {
        normal: good,
        vertical: good,
    };
    config.vertical.reaching_rate_per_s = 0.0;
    let e = Fixture::<f32>::new(&config).unwrap_err();
    assert_eq!(
        e.to_string(),
        "vertical.reaching_rate_per_s: not strictly positive"
    );
}
