//! Numerical functions a user calls, each against an independent reference computed
//! another way: finite differences against analytic derivatives, batch least squares
//! against the recursion, the module docs' closed forms against the implementation.

use hal_mock::delta_plant::{DeltaPlant, DeltaPlantParams};
use hal_mock::drive::DriveParams;
use hal_mock::focus::CameraParams;
use kerf::control::contouring::{Contouring, ContouringConfig, TaskReference};
use kerf::control::identify::{Rls, RlsConfig};
use kerf::control::pid::{Pid, PidConfig, PidState};
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::kinematics::{Matrix3, Vector3};
use kerf::sensing::sharpness::{SharpnessError, WindowMoments};
use kerf::trajectory::spline::KnotTiming;

/// The effector's state from the joints: p = FK(q) and ṗ = Jx q̇ against a central
/// difference of FK along q̇ (step 1e-7 m: truncation ~h²·|FK'''| ≈ 1e-12, rounding
/// ~1e-16/1e-7 = 1e-9 of the speed).
#[test]
fn task_state_is_fk_and_its_derivative_along_the_joint_velocity() {
    let geometry = DeltaGeometry::<f64>::new(&DeltaConfig::SLAVE_KEOPS).unwrap();
    for (q, q_dot) in [
        ([0.02, 0.02, 0.02], [0.01, -0.02, 0.005]),
        ([0.012, 0.025, 0.018], [-0.05, 0.0, 0.03]),
        ([0.03, 0.01, 0.022], [0.0, 0.0, 0.0]),
    ] {
        let (q, q_dot) = (Vector3::from(q), Vector3::from(q_dot));
        let (p, v) = geometry.task_state(&q, &q_dot).unwrap();
        assert_eq!(p, geometry.forward(&q).unwrap());
        let h = 1e-7;
        let ahead = geometry.forward(&(q + q_dot * h)).unwrap();
        let behind = geometry.forward(&(q - q_dot * h)).unwrap();
        let numeric = (ahead - behind) / (2.0 * h);
        let scale = q_dot.amax().max(1e-3);
        assert!((v - numeric).amax() < 1e-7 * scale, "{v:?} {numeric:?}");
    }
}

/// The frame error against the contour frame's definition (module docs of
/// `kinematics::contour_frame`): t = (cos ψ, sin ψ), n = (−sin ψ, cos ψ), e_O =
/// (e·t, e·n, e_z), contour error |e·n|; below the minimum speed the base-frame error
/// and its planar length.
#[test]
fn frame_error_projects_on_the_path_tangent_and_normal() {
    let config = ContouringConfig::critically_damped(200.0, 300.0, 250.0, 1e-3);
    let law = Contouring::<f64>::new(&config).unwrap();
    let position = Vector3::new(0.001, -0.002, 0.05);
    let error = Vector3::new(3e-6, -4e-6, 2e-6);
    for psi in [0.0, 0.7, 2.5, -1.9] {
        let (s, c) = f64::sin_cos(psi);
        let speed = 0.01;
        let reference = TaskReference {
            position: position + error,
            velocity: Vector3::new(speed * c, speed * s, 0.001),
            acceleration: Vector3::new(-0.3 * s, 0.3 * c, 0.0),
            jerk: Vector3::zeros(),
        };
        let (e_o, contour) = law.frame_error(&reference, &position).unwrap();
        // The error as the positions represent it (0.05 m carries ulps of 7e-18 m).
        let error = reference.position - position;
        let expected = Vector3::new(
            error.x * c + error.y * s,
            -error.x * s + error.y * c,
            error.z,
        );
        assert!(
            (e_o - expected).amax() < 1e-19,
            "{psi}: {e_o:?} {expected:?}"
        );
        assert!((contour - expected.y.abs()).abs() < 1e-19);
        // The law acts on the same error.
        let (_, acted) = law
            .task_acceleration(&reference, &position, &Vector3::zeros())
            .unwrap();
        assert!((acted - expected).amax() < 1e-19);
        // At rest there is no frame: base-frame error, planar length.
        let rest = TaskReference {
            velocity: Vector3::zeros(),
            acceleration: Vector3::zeros(),
            ..reference
        };
        let (e, contour) = law.frame_error(&rest, &position).unwrap();
        assert!((e - error).amax() < 1e-19);
        assert!(
            (contour - error.x.hypot(error.y)).abs() < 1e-19,
            "{contour}"
        );
        assert!((contour - 5e-6).abs() < 1e-16);
    }
    let bad = TaskReference {
        position,
        velocity: Vector3::new(f64::NAN, 0.01, 0.0),
        acceleration: Vector3::zeros(),
        jerk: Vector3::zeros(),
    };
    assert!(law.frame_error(&bad, &position).is_err());
}

/// With λ = 1 the recursion is the regularized batch solution (module docs of
/// `control::identify`): P = (I/p₀ + Σ φφᵀ)⁻¹, built here from the regressors and
/// inverted directly.
#[test]
fn covariance_diagonal_is_the_batch_inverse() {
    let config = RlsConfig::PIEZO;
    let mut rls = Rls::<f64>::new(&config).unwrap();
    let (a1, a2, b1) = (-1.949, 0.9503, 0.001_333);
    let (mut y1, mut y2, mut u1) = (0.0f64, 0.0f64, 0.0f64);
    let mut information = Matrix3::identity() / config.initial_covariance;
    for k in 0..400u32 {
        let u = 100.0 * (f64::from(k) * 0.37).sin() + 50.0 * (f64::from(k) * 0.051).cos();
        let y = -a1 * y1 - a2 * y2 + b1 * u1 + 1e-3 * (f64::from(k) * 1.3).sin();
        rls.update(y, u).unwrap();
        if k >= 2 {
            let phi = Vector3::new(-y1, -y2, u1);
            information += phi * phi.transpose();
        }
        (y2, y1, u1) = (y1, y, u);
    }
    let batch = information.try_inverse().unwrap().diagonal();
    let got = rls.covariance_diagonal();
    for (g, b) in got.iter().zip(batch.iter()) {
        assert!((g - b).abs() < 1e-6 * b, "{got:?} {batch:?}");
    }
}

/// The f32 normalized variance against the two-pass variance over the mean in f64
/// from the pixels themselves (within 3 f32 ulp plus the f64 reference's rounding).
#[test]
fn normalized_variance_f32_matches_the_two_pass_reference() {
    let windows: [Vec<u8>; 3] = [
        (0..256u32).map(|i| (i * 37 % 251) as u8).collect(),
        vec![120, 121, 119, 120, 250, 3, 77, 77],
        (0..4096u32).map(|i| (100 + i % 7) as u8).collect(),
    ];
    for pixels in &windows {
        let moments = WindowMoments {
            pixels: pixels.len() as u32,
            sum: pixels.iter().map(|&p| u32::from(p)).sum(),
            sum_of_squares: pixels.iter().map(|&p| u64::from(p) * u64::from(p)).sum(),
        };
        let n = pixels.len() as f64;
        let mean = pixels.iter().map(|&p| f64::from(p)).sum::<f64>() / n;
        let variance = pixels
            .iter()
            .map(|&p| (f64::from(p) - mean).powi(2))
            .sum::<f64>()
            / n;
        let expected = variance / mean;
        let got = f64::from(moments.normalized_variance_f32().unwrap());
        assert!(
            (got - expected).abs() <= 2e-7 * expected,
            "{got} {expected}"
        );
    }
    let dark = WindowMoments {
        pixels: 16,
        sum: 0,
        sum_of_squares: 0,
    };
    assert_eq!(
        dark.normalized_variance_f32(),
        Err(SharpnessError::ZeroMean)
    );
}

/// h = periods per knot × the period.
#[test]
fn knot_period_is_the_periods_per_knot_times_the_period() {
    for (period_s, per_knot, h) in [(1e-4, 1, 1e-4), (1e-4, 25, 2.5e-3), (2.5e-4, 4, 1e-3)] {
        let timing = KnotTiming {
            period_s,
            periods_per_knot: per_knot,
            first_period: 17,
        };
        assert!((timing.knot_period_s() - h).abs() < 1e-19, "{per_knot}");
    }
}

/// The PID's proposal against the recurrence of the module docs of `control::pid`
/// (backward-Euler derivative filter, forward-Euler integrator), unsaturated so that
/// c_k = u_k.
#[test]
fn propose_follows_the_documented_recurrence() {
    let config = PidConfig {
        kp: 2.0,
        ki_per_s: 30.0,
        kd_s: 0.01,
        derivative_filter_s: 5e-4,
        anti_windup_per_s: 0.0,
        limits: None,
        rate_limit_per_s: None,
    };
    let ts = 1e-3;
    let pid = Pid::<f64>::new(&config, ts).unwrap();
    let mut state = PidState::at(0.0);
    let tau = config.derivative_filter_s;
    let (mut d, mut i, mut e_prev) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..50 {
        let e = (f64::from(k) * 0.4).sin() + 0.2;
        d = (tau * d + config.kd_s * (e - e_prev)) / (tau + ts);
        let u = config.kp * e + i + d;
        let got = pid.propose(&mut state, e);
        assert!((got - u).abs() < 1e-12 * u.abs().max(1.0), "{k}: {got} {u}");
        pid.settle(&mut state, got, got);
        i += ts * config.ki_per_s * e;
        e_prev = e;
    }
}

fn keops_plant(params: DeltaPlantParams, substeps: u32) -> DeltaPlant {
    let q = Vector3::new(0.02, 0.015, 0.025);
    DeltaPlant::new(&DeltaConfig::SLAVE_KEOPS, params, 1e-4, substeps, q).unwrap()
}

/// The holding forces are the gradient of the potential energy at rest (virtual
/// work: F = ∂V/∂q), here by central differences of the plant's own energy (step
/// 1e-6 m; V ~ 0.1 J, so rounding ~1e-16·0.1/1e-6 = 1e-11 N); held, the plant stays
/// at rest.
#[test]
fn holding_force_is_the_gradient_of_the_potential() {
    let config = DeltaConfig::SLAVE_KEOPS;
    let params = DeltaPlantParams {
        payload_kg: 0.02,
        arm_mass_kg: 0.01,
        ..DeltaPlantParams::SLAVE
    };
    let plant = keops_plant(params, 4);
    let hold = plant.holding_force_n().unwrap();
    let h = 1e-6;
    for i in 0..3 {
        let mut ahead = plant.clone();
        ahead.q_m[i] += h;
        let mut behind = plant.clone();
        behind.q_m[i] -= h;
        let gradient =
            (ahead.energy_j(&config).unwrap() - behind.energy_j(&config).unwrap()) / (2.0 * h);
        assert!(
            (hold[i] - gradient).abs() < 1e-7,
            "{i}: {hold:?} {gradient}"
        );
    }
    let mut held = plant.clone();
    held.step(hold).unwrap();
    assert!(held.q_dot_m_s.amax() < 1e-12, "{:?}", held.q_dot_m_s);
    let mut dropped = plant.clone();
    dropped.step(Vector3::zeros()).unwrap();
    assert!(dropped.q_dot_m_s.amax() > 1e-5, "{:?}", dropped.q_dot_m_s);
}

/// The current loop's output after a step command from zero: F (1 − e^(−t/τ)) with
/// τ = 1/(2π f) of the drive (`hal_mock::drive`), the command quantized by the DAC;
/// an ideal drive follows at once.
#[test]
fn drive_force_follows_the_first_order_current_loop() {
    let drive = DriveParams::LM1247_DS1103;
    let mut plant = keops_plant(DeltaPlantParams::SLAVE_REALISTIC, 4);
    assert_eq!(plant.drive_force_n(), Vector3::zeros());
    let command = Vector3::new(1.0, -0.5, 2.0);
    let quantized = command.map(|f| drive.quantize_n(f));
    assert!((quantized - command).amax() <= drive.dac_lsb_n());
    let tau = 1.0 / (2.0 * std::f64::consts::PI * drive.current_bandwidth_hz);
    for k in 1..=5 {
        plant.step(command).unwrap();
        let expected = quantized * -(-f64::from(k) * 1e-4 / tau).exp_m1();
        assert!(
            (plant.drive_force_n() - expected).amax() < 1e-12,
            "{k}: {:?} {expected:?}",
            plant.drive_force_n()
        );
    }
    let mut ideal = keops_plant(DeltaPlantParams::SLAVE, 4);
    ideal.step(Vector3::new(1.0, -0.5, 9.0)).unwrap();
    assert_eq!(ideal.drive_force_n(), Vector3::new(1.0, -0.5, 3.6));
}

/// The RK4 substep is the period over the substeps asked for, or over more when the
/// Coulomb law needs them (h·(Fc/vs + b)/mc ≤ 0.5, `MAX_FRICTION_STEP`): 3 for the
/// realistic slave at 10 kHz, (0.08/1e-4 + 0.5)/0.071·1e-4/0.5 = 2.25 rounded up.
#[test]
fn substep_is_the_period_over_the_substeps_in_use() {
    for (params, asked, used) in [
        (DeltaPlantParams::SLAVE, 1, 1.0),
        (DeltaPlantParams::SLAVE, 4, 4.0),
        (DeltaPlantParams::SLAVE_REALISTIC, 1, 3.0),
        (DeltaPlantParams::SLAVE_REALISTIC, 4, 4.0),
    ] {
        let plant = keops_plant(params, asked);
        assert!((plant.substep_s() - 1e-4 / used).abs() < 1e-20, "{asked}");
        assert_eq!(plant.params(), &params);
    }
}

/// Blur: the variances of the in-focus and defocus blur add (b² = b0² + (β m Δq)²,
/// `hal_mock::focus`): b0 at focus, √2 b0 one depth of field away on either side,
/// the excess variance quadratic in the defocus.
#[test]
fn blur_adds_the_defocus_variance_to_the_focus_blur() {
    let camera = CameraParams::ZOOM_INSPECTION;
    for m in [1.0, 2.0, 3.5] {
        let focus = camera.focus_at_unit_m + camera.focus_shift_m * (m - 1.0);
        let b0 = camera.focus_blur_px;
        assert!((camera.blur_px(focus, m) - b0).abs() < 1e-12);
        let dof = camera.depth_of_field_m(m);
        for side in [-1.0, 1.0] {
            let b = camera.blur_px(focus + side * dof, m);
            assert!((b - b0 * 2f64.sqrt()).abs() < 1e-9, "{m} {side}: {b}");
        }
        let excess = |dq: f64| camera.blur_px(focus + dq, m).powi(2) - b0 * b0;
        let ratio = excess(2e-4) / excess(1e-4);
        assert!((ratio - 4.0).abs() < 1e-6, "{m}: {ratio}");
        let beta = camera.blur_px_per_m * m;
        assert!((excess(1e-4) - (beta * 1e-4).powi(2)).abs() < 1e-9);
    }
}
