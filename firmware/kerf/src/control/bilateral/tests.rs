//! The task-space law against the print's joint-space form: Ψ1…Ψ5 built as matrices
//! from both machines' Jacobians (T 5.3.1, with the workspace centres), at joint
//! states away from rest.

use super::*;
use crate::kinematics::delta::DeltaConfig;
use nalgebra::Matrix3;
extern crate std;
use std::string::ToString;

const LAMBDA: f64 = 2.0 * core::f64::consts::PI * 30.0;
const K: f64 = 2.0 * core::f64::consts::PI * 50.0;

fn geometries() -> (DeltaGeometry<f64>, DeltaGeometry<f64>) {
    (
        DeltaGeometry::new(&DeltaConfig::MASTER_HORIZONTAL).unwrap(),
        DeltaGeometry::new(&DeltaConfig::SLAVE_KEOPS).unwrap(),
    )
}

/// Workspace centres: FK of the carriages at mid-travel (master 30–110 mm, slave
/// 0–40 mm).
fn centres(master: &DeltaGeometry<f64>, slave: &DeltaGeometry<f64>) -> ([f64; 3], [f64; 3]) {
    (
        master
            .forward(&Vector3::new(0.07, 0.07, 0.07))
            .unwrap()
            .into(),
        slave
            .forward(&Vector3::new(0.02, 0.02, 0.02))
            .unwrap()
            .into(),
    )
}

fn config(scale: f64, cm: [f64; 3], cs: [f64; 3]) -> BilateralConfig {
    BilateralConfig {
        scale,
        master_centre_m: cm,
        slave_centre_m: cs,
        surface_slope_per_s: LAMBDA,
        reaching_rate_per_s: K,
    }
}

#[test]
fn matches_the_prints_joint_space_law() {
    let (gm, gs) = geometries();
    let (cm, cs) = centres(&gm, &gs);
    for scale in [0.5, 2.0 / 3.0, 1.0] {
        let law = Bilateral::<f64>::new(&config(scale, cm, cs)).unwrap();
        for (qm, qs) in [
            ([0.071, 0.068, 0.074], [0.019, 0.022, 0.020]),
            ([0.065, 0.077, 0.070], [0.023, 0.017, 0.021]),
        ] {
            let (qm, qs) = (Vector3::from(qm), Vector3::from(qs));
            let (qm_dot, qm_ddot) = (
                Vector3::new(0.03, -0.02, 0.01),
                Vector3::new(0.4, 0.1, -0.3),
            );
            let qs_dot = Vector3::new(-0.01, 0.02, 0.015);
            // The print's matrices, β = 1/scale, W1 = λ I, W2 = I, Kms = k I.
            let (pm, ps) = (gm.forward(&qm).unwrap(), gs.forward(&qs).unwrap());
            let (jm, js) = (
                gm.jacobian(&qm, &pm).unwrap(),
                gs.jacobian(&qs, &ps).unwrap(),
            );
            let jm_dot = gm.jacobian_derivative(&qm, &pm, &qm_dot).unwrap();
            let js_dot = gs.jacobian_derivative(&qs, &ps, &qs_dot).unwrap();
            let js_inv = js.try_inverse().unwrap();
            let beta = 1.0 / scale;
            let (w1, w2, kms) = (
                Matrix3::identity() * LAMBDA,
                Matrix3::identity(),
                Matrix3::identity() * K,
            );
            let w2_inv = w2.try_inverse().unwrap();
            let psi1 = js_inv / beta * jm;
            let psi2 = js_inv / beta * (jm_dot + w2_inv * w1 * jm + w2_inv * kms * w2 * jm);
            let psi3 = js_inv / beta
                * (js_dot * beta + w2_inv * w1 * js * beta + w2_inv * kms * w2 * js * beta);
            let psi4 = js_inv / beta * w2_inv * kms * w1;
            let psi5 = psi4 * beta;
            let (cm, cs) = (Vector3::from(cm), Vector3::from(cs));
            let want = psi1 * qm_ddot + psi2 * qm_dot - psi3 * qs_dot + psi4 * (pm - cm)
                - psi5 * (ps - cs);
            let master = MasterState {
                position: pm,
                velocity: jm * qm_dot,
                acceleration: jm * qm_ddot + jm_dot * qm_dot,
            };
            let got = law.joint_acceleration(&gs, &master, &qs, &qs_dot).unwrap();
            // Both sides sum terms up to λk·|e| ≈ 6e4 · 5e-3 = 3e2 m/s²: round-off
            // of 1e-16 relative on those, amplified by |Js⁻¹| of a few.
            let err = (got.joint_acceleration - want).amax();
            assert!(
                err < 1e-10 * want.amax().max(1.0),
                "{err} of {}",
                want.amax()
            );
            let e = (pm - cm) * scale - (ps - cs);
            assert!((got.tracking_error_m - e).amax() < 1e-17);
        }
    }
}

#[test]
fn a_slave_on_the_scaled_master_only_follows_its_acceleration() {
    let (gm, gs) = geometries();
    let (cm, cs) = centres(&gm, &gs);
    let scale = 0.5;
    let law = Bilateral::<f64>::new(&config(scale, cm, cs)).unwrap();
    // Master 4 mm off its centre and moving; slave exactly at the scaled state.
    let master = MasterState {
        position: Vector3::from(cm) + Vector3::new(0.004, -0.002, 0.001),
        velocity: Vector3::new(0.01, 0.005, 0.0),
        acceleration: Vector3::new(0.2, -0.1, 0.05),
    };
    let reference = law.slave_reference(&master);
    let qs = gs.inverse(&reference.position).unwrap();
    let qs_dot = gs.jacobian_inverse(&qs, &reference.position).unwrap() * reference.velocity;
    let out = law.joint_acceleration(&gs, &master, &qs, &qs_dot).unwrap();
    assert!(out.tracking_error_m.amax() < 1e-15);
    // Effector acceleration Js q̈ + J̇s q̇ = s ẍm.
    let ps = gs.forward(&qs).unwrap();
    let js = gs.jacobian(&qs, &ps).unwrap();
    let js_dot = gs.jacobian_derivative(&qs, &ps, &qs_dot).unwrap();
    let a = js * out.joint_acceleration + js_dot * qs_dot;
    assert!((a - master.acceleration * scale).amax() < 1e-12, "{a}");
}

#[test]
fn the_tracking_error_settles_with_poles_at_lambda_and_k() {
    // e(t) of ë + (λ + k)ė + λk e = 0 from e(0) = 1 mm, ė(0) = 0, integrated with the
    // law's own acceleration in task space, against the closed form
    // e = e0 (k e^(−λt) − λ e^(−kt)) / (k − λ).
    let law = Bilateral::<f64>::new(&config(1.0, [0.0; 3], [0.0; 3])).unwrap();
    let master = MasterState {
        position: Vector3::new(1e-3, 0.0, 0.0),
        velocity: Vector3::zeros(),
        acceleration: Vector3::zeros(),
    };
    let (mut x, mut v) = (Vector3::<f64>::zeros(), Vector3::<f64>::zeros());
    let h = 1e-6;
    for n in 1..=20_000 {
        // RK2 (midpoint) on the law's task acceleration.
        let acc = |x: Vector3<f64>, v: Vector3<f64>| {
            let r = law.slave_reference(&master);
            r.acceleration + (r.velocity - v) * law.kd + (r.position - x) * law.kp
        };
        let (xm, vm) = (x + v * (h / 2.0), v + acc(x, v) * (h / 2.0));
        let a2 = acc(xm, vm);
        x += vm * h;
        v += a2 * h;
        if n % 5000 == 0 {
            let t = h * f64::from(n);
            let e = 1e-3 * (K * (-LAMBDA * t).exp() - LAMBDA * (-K * t).exp()) / (K - LAMBDA);
            assert!(
                ((1e-3 - x.x) - e).abs() < 1e-9,
                "t = {t}: {} against {e}",
                1e-3 - x.x
            );
        }
    }
}

#[test]
fn bad_settings_are_named() {
    let good = config(0.5, [0.0; 3], [0.0; 3]);
    let field = |c: BilateralConfig| Bilateral::<f32>::new(&c).unwrap_err().to_string();
    assert_eq!(
        field(BilateralConfig { scale: 0.0, ..good }),
        "scale: not strictly positive"
    );
    assert_eq!(
        field(BilateralConfig {
            scale: f64::NAN,
            ..good
        }),
        "scale: not finite"
    );
    let mut c = good;
    c.slave_centre_m[2] = f64::INFINITY;
    assert_eq!(field(c), "slave_centre_m[2]: not finite");
    let mut c = good;
    c.reaching_rate_per_s = -1.0;
    assert_eq!(field(c), "reaching_rate_per_s: not strictly positive");
    let mut c = good;
    c.surface_slope_per_s = 1e30;
    c.reaching_rate_per_s = 1e30;
    assert!(field(c).starts_with("reaching_rate_per_s"));
}
