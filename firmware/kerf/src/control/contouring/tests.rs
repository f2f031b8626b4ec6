//! The contouring law against two independent references: the error dynamics it is
//! designed for (integrated in closed loop and compared with their closed-form
//! solution), and the print's joint-space gain matrices built literally.

use super::*;
use crate::kinematics::contour_frame::tests::literal_frame_matrices;
use crate::kinematics::delta::DeltaConfig;
use nalgebra::Matrix3;

/// Bandwidths of the three frame directions, rad/s: different, so that a mix-up of
/// directions shows.
const TANGENTIAL_RAD_S: f64 = 40.0;
const NORMAL_RAD_S: f64 = 60.0;
const VERTICAL_RAD_S: f64 = 30.0;

fn law() -> Contouring<f64> {
    Contouring::new(&ContouringConfig::critically_damped(
        TANGENTIAL_RAD_S,
        NORMAL_RAD_S,
        VERTICAL_RAD_S,
        1e-4,
    ))
    .unwrap()
}

/// A 6 mm circle at 8 mm/s (T's contour size and speed) about `centre`, with a
/// 0.5 mm vertical wobble at three times the turn rate.
fn circle(centre: Vector3<f64>, t: f64) -> TaskReference<f64> {
    let (r, h) = (0.006, 0.0005);
    let w = 0.008 / r;
    let (s, c) = (libm::sin(w * t), libm::cos(w * t));
    let (s3, c3) = (libm::sin(3.0 * w * t), libm::cos(3.0 * w * t));
    TaskReference {
        position: centre + Vector3::new(r * c, r * s, h * s3),
        velocity: Vector3::new(-r * w * s, r * w * c, 3.0 * h * w * c3),
        acceleration: Vector3::new(-r * w * w * c, -r * w * w * s, -9.0 * h * w * w * s3),
        jerk: Vector3::new(
            r * w * w * w * s,
            -r * w * w * w * c,
            -27.0 * h * w * w * w * c3,
        ),
    }
}

/// e(t) of ë + 2ωė + ω²e = 0 from e(0) = e0, ė(0) = 0.
fn critically_damped(e0: f64, w: f64, t: f64) -> f64 {
    e0 * (1.0 + w * t) * libm::exp(-w * t)
}

/// The task state that starts `reference` with frame error e_O = `e0` and ė_O = 0:
/// ė = R (ė_O − ψ̇ R′ᵀ e) in task space.
fn start_with_frame_error(
    reference: &TaskReference<f64>,
    e0: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let frame = ContourFrame::new(
        &reference.velocity,
        &reference.acceleration,
        &reference.jerk,
        1e-4,
    )
    .unwrap();
    let turned = ContourFrame::quarter_turn(e0) * frame.turn_rate_rad_s();
    (
        reference.position - frame.from_frame(e0),
        reference.velocity + frame.from_frame(&turned),
    )
}

/// A double integrator s̈ = `law(t, s, ṡ).0` from (s0, ṡ0), integrated by RK4 at
/// 10 µs over 0.3 s: the largest deviation of the frame error `law(t, s, ṡ).1` from
/// the designed decoupled critically damped responses starting at `e0`.
fn worst_deviation_in_closed_loop(
    e0: &Vector3<f64>,
    (mut s, mut s_dot): (Vector3<f64>, Vector3<f64>),
    law: impl Fn(f64, &Vector3<f64>, &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>),
) -> f64 {
    let acceleration = |t: f64, s: &Vector3<f64>, s_dot: &Vector3<f64>| law(t, s, s_dot).0;
    let dt = 1e-5;
    let mut worst = 0.0f64;
    for k in 0..30_000 {
        let t = k as f64 * dt;
        let (a1, e_o) = law(t, &s, &s_dot);
        let expected = Vector3::new(
            critically_damped(e0.x, TANGENTIAL_RAD_S, t),
            critically_damped(e0.y, NORMAL_RAD_S, t),
            critically_damped(e0.z, VERTICAL_RAD_S, t),
        );
        worst = worst.max((e_o - expected).amax());
        let (s2, v2) = (s + s_dot * (dt / 2.0), s_dot + a1 * (dt / 2.0));
        let a2 = acceleration(t + dt / 2.0, &s2, &v2);
        let (s3, v3) = (s + v2 * (dt / 2.0), s_dot + a2 * (dt / 2.0));
        let a3 = acceleration(t + dt / 2.0, &s3, &v3);
        let (s4, v4) = (s + v3 * dt, s_dot + a3 * dt);
        let a4 = acceleration(t + dt, &s4, &v4);
        s += (s_dot + v2 * 2.0 + v3 * 2.0 + v4) * (dt / 6.0);
        s_dot += (a1 + a2 * 2.0 + a3 * 2.0 + a4) * (dt / 6.0);
    }
    worst
}

/// A point mass driven by the law's task acceleration (no kinematics in the way): its
/// frame errors must follow the designed decoupled responses exactly, however the
/// circle turns. RK4's error at 10 µs is below 1e-12 of the initial error, so 1e-9
/// leaves room only for round-off.
#[test]
fn frame_errors_follow_the_designed_dynamics_in_closed_loop() {
    let law = law();
    let centre = Vector3::new(0.0, 0.0, 0.05);
    let e0 = Vector3::new(0.4e-3, -0.3e-3, 0.2e-3);
    let start = start_with_frame_error(&circle(centre, 0.0), &e0);
    let worst = worst_deviation_in_closed_loop(&e0, start, |t, x, v| {
        law.task_acceleration(&circle(centre, t), x, v).unwrap()
    });
    assert!(
        worst < 1e-9 * e0.amax(),
        "worst frame error deviation {worst:e} m"
    );
}

/// The print's joint-space form (T 4.3.2) with its gain matrices built literally,
/// Kv = Jx⁻¹J̇x + 2Jx⁻¹J_O⁻¹J̇_O Jx + Jx⁻¹J_O⁻¹K_O2 J_O Jx and
/// Kp = Jx⁻¹J_O⁻¹(J̈_O + K_O2 J̇_O + K_O1 J_O), J_O from (ẋ, ẏ)/v and its derivatives
/// from ψ = atan2: on a machine whose Jacobian is a constant matrix A (J̇x = 0,
/// F(q) = A q) the two forms are the same law, so they agree to round-off at any error.
/// (On the delta the print evaluates Jx at the measured q where the task form uses the
/// reference's own velocity: they differ by (Jx(q_ref) − Jx(q)) q̇_ref, first order in
/// the error times the speed; the closed-loop test below checks the delta form.)
#[test]
fn equals_the_print_joint_space_form_on_a_linear_machine() {
    let law = law();
    let a = Matrix3::new(1.0, 0.2, -0.1, 0.3, 0.9, 0.2, -0.2, 0.1, 1.1);
    let a_inv = a.try_inverse().unwrap();
    let centre = Vector3::new(0.01, -0.02, 0.05);
    for k in 0..16 {
        let t = 0.3 * k as f64;
        let reference = circle(centre, t);
        let q = a_inv * (reference.position - Vector3::new(0.3e-3, -0.5e-3, 0.2e-3));
        let q_dot = a_inv * (reference.velocity - Vector3::new(-2e-3, 1e-3, 3e-3));
        let (task, _) = law
            .task_acceleration(&reference, &(a * q), &(a * q_dot))
            .unwrap();
        let ours = a_inv * task;
        let q_ref = a_inv * reference.position;
        let q_ref_dot = a_inv * reference.velocity;
        let q_ref_ddot = a_inv * reference.acceleration;
        // ψ̈ by a central difference of ψ̇ along the circle (independent of the frame's
        // closed form).
        let v = reference.velocity;
        let rate = |t: f64| {
            let r = circle(centre, t);
            (r.velocity.x * r.acceleration.y - r.velocity.y * r.acceleration.x)
                / (r.velocity.x * r.velocity.x + r.velocity.y * r.velocity.y)
        };
        let h = 1e-5;
        let psi_ddot = (rate(t + h) - rate(t - h)) / (2.0 * h);
        let [jo, jo_dot, jo_ddot] = literal_frame_matrices(&v, rate(t), psi_ddot);
        let jo_inv = jo.try_inverse().unwrap();
        let ko1 = Matrix3::from_diagonal(&Vector3::new(
            TANGENTIAL_RAD_S * TANGENTIAL_RAD_S,
            NORMAL_RAD_S * NORMAL_RAD_S,
            VERTICAL_RAD_S * VERTICAL_RAD_S,
        ));
        let ko2 = Matrix3::from_diagonal(&Vector3::new(
            2.0 * TANGENTIAL_RAD_S,
            2.0 * NORMAL_RAD_S,
            2.0 * VERTICAL_RAD_S,
        ));
        let kv = a_inv * jo_inv * jo_dot * a * 2.0 + a_inv * jo_inv * ko2 * jo * a;
        let kp = a_inv * jo_inv * (jo_ddot + ko2 * jo_dot + ko1 * jo);
        let print = q_ref_ddot + kv * (q_ref_dot - q_dot) + kp * (a * q_ref - a * q);
        // The difference quotient's error (h² ψ⁗/6 ≈ 1e-10 rad/s² here) times the
        // 0.6 mm error is far below 1e-9 of the command.
        assert!(
            (ours - print).amax() < 1e-9 * print.amax(),
            "t = {t}: {ours:?} vs {print:?}"
        );
    }
}

/// Through the delta's kinematics: joints driven as double integrators by
/// `joint_acceleration` (each joint's DOB makes it one), the effector's frame errors,
/// from the forward kinematics of the integrated joints, follow the designed decoupled
/// responses as in the point-mass test. Integrated by RK4 at 10 µs over 0.3 s at the
/// middle of the Keops workspace.
#[test]
fn frame_errors_follow_the_designed_dynamics_through_the_delta() {
    let geometry = DeltaGeometry::<f64>::new(&DeltaConfig::SLAVE_KEOPS).unwrap();
    let law = law();
    let centre = geometry.forward(&Vector3::new(0.02, 0.02, 0.02)).unwrap();
    let e0 = Vector3::new(-0.3e-3, 0.4e-3, -0.2e-3);
    let (x0, x0_dot) = start_with_frame_error(&circle(centre, 0.0), &e0);
    let q0 = geometry.inverse(&x0).unwrap();
    let q0_dot = geometry.jacobian_inverse(&q0, &x0).unwrap() * x0_dot;
    let worst = worst_deviation_in_closed_loop(&e0, (q0, q0_dot), |t, q, q_dot| {
        let out = law
            .joint_acceleration(&geometry, &circle(centre, t), q, q_dot)
            .unwrap();
        (out.joint_acceleration, out.frame_error_m)
    });
    assert!(
        worst < 1e-8 * e0.amax(),
        "worst frame error deviation {worst:e} m"
    );
}

#[test]
fn a_reference_at_rest_is_held_in_the_base_frame_and_bad_input_refused() {
    let geometry = DeltaGeometry::<f64>::new(&DeltaConfig::SLAVE_KEOPS).unwrap();
    let law = law();
    let centre = geometry.forward(&Vector3::new(0.02, 0.02, 0.02)).unwrap();
    let q = Vector3::new(0.02, 0.02, 0.02);
    let mut dwell = circle(centre, 0.0);
    dwell.velocity = Vector3::zeros();
    // At rest: ẍ = ẍref + K2 ė + K1 e with the normal gains on x and y, by hand.
    let (kn, dn) = (law.kp.y, law.kd.y);
    let (kz, dz) = (law.kp.z, law.kd.z);
    let x = dwell.position + Vector3::new(1e-5, -2e-5, 3e-6);
    let v = Vector3::new(-1e-3, 2e-4, 5e-4);
    let (a, e) = law.task_acceleration(&dwell, &x, &v).unwrap();
    let expected = dwell.acceleration
        + Vector3::new(
            kn * -1e-5 + dn * 1e-3,
            kn * 2e-5 - dn * 2e-4,
            kz * -3e-6 - dz * 5e-4,
        );
    assert!(
        (a - expected).amax() < 1e-9 * expected.amax(),
        "{a} vs {expected}"
    );
    assert_eq!(e, dwell.position - x);
    let mut nan = dwell;
    nan.velocity.x = f64::NAN;
    assert_eq!(
        law.joint_acceleration(&geometry, &nan, &q, &Vector3::zeros()),
        Err(ContouringError::Frame(ContourFrameError::NotFinite))
    );
    let moving = circle(centre, 0.0);
    let far = Vector3::new(5.0, 0.02, 0.02);
    assert!(matches!(
        law.joint_acceleration(&geometry, &moving, &far, &Vector3::zeros()),
        Err(ContouringError::Kinematics(_))
    ));
    let bad = ContouringConfig {
        min_speed_m_s: 0.0,
        ..ContouringConfig::critically_damped(1.0, 1.0, 1.0, 1e-4)
    };
    assert!(Contouring::<f64>::new(&bad).is_err());
    let bad_normal = ContouringConfig::critically_damped(1.0, f64::NAN, 1.0, 1e-4);
    assert!(Contouring::<f32>::new(&bad_normal).is_err());
}

/// The minimum speed is a coefficient of the scalar: one that underflows f32 (where
/// every reference would count as moving) is refused there, accepted in f64.
#[test]
fn a_minimum_speed_the_scalar_cannot_hold_is_refused() {
    let tiny = ContouringConfig::critically_damped(1.0, 1.0, 1.0, 1e-50);
    assert_eq!(
        Contouring::<f32>::new(&tiny).err(),
        Some(ConfigError::not_representable("min_speed_m_s"))
    );
    assert!(Contouring::<f64>::new(&tiny).is_ok());
}
