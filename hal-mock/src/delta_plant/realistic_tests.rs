//! Friction, payload and drive of the plant against closed forms computed apart from it.

use super::tests::hanging_keops;
use super::*;
use crate::linear_motor::{LinearMotor, LinearMotorParams};
use core::f64::consts::PI;
use std::vec::Vec;

const TS_S: f64 = 1e-4;
const MC: f64 = 0.071;
const FC: f64 = 0.08;
const VS: f64 = 1e-4;
/// Start of the single-axis runs: an asymmetric, regular pose.
const Q0: [f64; 3] = [0.012, 0.006, 0.0];

/// No effector mass and no gravity: the mass matrix is mc I and nothing couples the
/// carriages, so each is the single axis mc q̈ = F − b q̇ − Fc tanh(q̇/vs) (what
/// `LinearMotor` simulates, with true stiction), through the full plant's code.
fn single_axis(coulomb_n: f64, viscous: f64, drive: DriveParams) -> DeltaPlantParams {
    DeltaPlantParams {
        effector_mass_kg: 0.0,
        payload_kg: 0.0,
        gravity_z_m_s2: 0.0,
        viscous_n_s_per_m: viscous,
        coulomb_n,
        coulomb_velocity_m_s: VS,
        drive,
        ..DeltaPlantParams::SLAVE_REALISTIC
    }
}

fn plant(params: DeltaPlantParams, ts_s: f64, substeps: u32) -> DeltaPlant {
    DeltaPlant::new(&hanging_keops(), params, ts_s, substeps, Q0.into()).unwrap()
}

#[test]
fn the_existing_presets_stay_ideal_and_the_realistic_one_is_the_slave_plus_its_extras() {
    for p in [DeltaPlantParams::MASTER, DeltaPlantParams::SLAVE] {
        assert_eq!(p.drive, DriveParams::IDEAL);
        assert_eq!(
            (p.coulomb_n, p.payload_kg, p.viscous_n_s_per_m),
            (0.0, 0.0, 0.0)
        );
    }
    let r = DeltaPlantParams::SLAVE_REALISTIC;
    let back = DeltaPlantParams {
        viscous_n_s_per_m: 0.0,
        coulomb_n: 0.0,
        coulomb_velocity_m_s: 0.0,
        payload_kg: 0.0,
        drive: DriveParams::IDEAL,
        ..r
    };
    assert_eq!(back, DeltaPlantParams::SLAVE);
    // At the 10 kHz loop with SimulatedDelta's 4 substeps the friction's stiffness
    // times the substep is 0.28, as the preset's documentation says.
    let p = plant(r, TS_S, 4);
    let kh = p.substep_s() * (FC / VS + 0.5) / MC;
    assert!((kh - 0.28).abs() < 0.005, "{kh}");
}

#[test]
fn coulomb_friction_lets_a_force_below_it_only_creep() {
    // F = Fc/2 on carriage 0 from rest. With g(v) = Fc tanh(v/vs) + b v the velocity
    // rises monotonically to v* with g(v*) = F; g is concave for v > 0, so
    // g(v*) − g(v) ≥ g'(v*) (v* − v) and v* − v ≤ v* e^(−t/τ), τ = mc/g'(v*). Hence
    //   v* (T − τ) ≤ x(T) ≤ v* T ≤ vs atanh(F/Fc) T,
    // the last being the creep tanh allows without any viscous help.
    let b = 0.5;
    let force = 0.5 * FC;
    let mut p = plant(single_axis(FC, b, DriveParams::IDEAL), TS_S, 4);
    let periods = 1000;
    for _ in 0..periods {
        p.step(Vector3::new(force, 0.0, 0.0)).unwrap();
    }
    let t = f64::from(periods) * TS_S;
    let (mut lo, mut hi) = (0.0, VS * libm::atanh(force / FC));
    for _ in 0..200 {
        let v = 0.5 * (lo + hi);
        if FC * libm::tanh(v / VS) + b * v < force {
            lo = v;
        } else {
            hi = v;
        }
    }
    let v_star = lo;
    let slope = FC / VS * (1.0 - libm::pow(libm::tanh(v_star / VS), 2.0)) + b;
    let tau = MC / slope;
    let x = p.q_m.x - Q0[0];
    std::println!("creep {x:.4e} m in {t} s, v* {v_star:.4e} m/s, τ {tau:.2e} s");
    // RK4 at h k = 0.28 on the creep's approach: error ~1e-5 of v* τ (5e-9 m).
    let tol = 1e-12;
    assert!(
        x >= v_star * (t - tau) - tol && x <= v_star * t + tol,
        "{x}"
    );
    assert!(x <= VS * libm::atanh(0.5) * t, "{x}");
    // Barely moves: under 6 µm in 0.1 s (LinearMotor's stiction would hold it at 0).
    assert!(x < 6e-6, "{x}");
    // Nothing pushes the other carriages.
    assert!((p.q_m.y - Q0[1]).abs() < 1e-15 && (p.q_m.z - Q0[2]).abs() < 1e-15);
}

#[test]
fn coulomb_coast_down_stops_after_v0_squared_m_over_2fc() {
    // m v̇ = −Fc tanh(v/vs) gives x = (m/Fc) ∫₀^v0 v coth(v/vs) dv
    //   = (m/Fc) (v0²/2 + ∫₀^∞ 2v/(e^(2v/vs) − 1) dv) = (m/Fc) (v0²/2 + π² vs²/12)
    // (exponentially small terms in v0/vs dropped): the sharp-Coulomb distance
    // v0² m/(2Fc) plus 7.3e-9 m (1.6e-6 of 4.4 mm), the regularization's whole cost.
    // While |v| > 19 vs, tanh = ±1 in f64 and RK4 is exact on the constant
    // deceleration; only the last ~3 vs, covering (m/Fc)(3vs)²/2 = 4e-8 m, see RK4's
    // error, ≤ (hk)⁵/120 ≈ 2.6e-4 of it per step at hk ≤ 0.5: a few 1e-11 m at most,
    // so 5e-11 m.
    let v0 = [0.1, -0.05, 0.0];
    let expect = |v: f64| v.signum() * (v * v / 2.0 + PI * PI * VS * VS / 12.0) * MC / FC;
    // The 10 kHz loop with 4 substeps, and a 1 kHz loop asking for 1 substep (the plant
    // raises it to 23 so that hk ≤ 0.5).
    for (ts, substeps) in [(TS_S, 4), (1e-3, 1)] {
        let mut p = plant(single_axis(FC, 0.0, DriveParams::IDEAL), ts, substeps);
        assert!(p.substep_s() * (FC / VS) / MC <= MAX_FRICTION_STEP);
        p.q_dot_m_s = v0.into();
        let periods = (0.2 / ts) as usize; // stops after m v0/Fc = 89 ms
        for _ in 0..periods {
            p.step(Vector3::zeros()).unwrap();
        }
        for i in 0..2 {
            let x = p.q_m[i] - Q0[i];
            let sharp = v0[i].signum() * v0[i] * v0[i] * MC / (2.0 * FC);
            std::println!(
                "ts {ts}: carriage {i} {x:.12e} m, sharp {sharp:.12e}, error {:.2e}",
                x - expect(v0[i])
            );
            assert!((x - expect(v0[i])).abs() < 5e-11, "{x}");
            assert!((x - sharp).abs() <= PI * PI * VS * VS * MC / (12.0 * FC) + 5e-11);
            assert!(p.q_dot_m_s[i].abs() < 1e-12);
        }
        assert_eq!(p.q_m.z, Q0[2]);
    }
    // Second reference: the single-axis model with true Coulomb friction and stiction,
    // whose stop is exact to 1e-6 of the distance; the plant differs from it by the
    // regularization's 7.3e-9 m and that.
    let mut lm = LinearMotor::new(
        LinearMotorParams {
            mass_kg: MC,
            coulomb_n: FC,
            viscous_n_s_per_m: 0.0,
            ..LinearMotorParams::LM1247_WITH_PAYLOAD
        },
        TS_S,
        10,
        0.0,
    );
    lm.velocity_m_s = v0[0];
    for _ in 0..2000 {
        lm.step(0.0);
    }
    let sharp = v0[0] * v0[0] * MC / (2.0 * FC);
    assert!(
        (lm.position_m - sharp).abs() < 1e-6 * sharp,
        "{}",
        lm.position_m
    );
    let mut p = plant(single_axis(FC, 0.0, DriveParams::IDEAL), TS_S, 4);
    p.q_dot_m_s = v0.into();
    for _ in 0..2000 {
        p.step(Vector3::zeros()).unwrap();
    }
    let regularization = PI * PI * VS * VS * MC / (12.0 * FC);
    let x = p.q_m.x - Q0[0];
    assert!((x - lm.position_m).abs() < regularization + 1e-6 * sharp);
}

/// Energy after each of `periods` unforced periods from an asymmetric rest on the
/// hanging Keops.
fn unforced_energy(params: DeltaPlantParams, periods: usize) -> (Vec<f64>, f64) {
    let c = hanging_keops();
    let mut p = DeltaPlant::new(&c, params, TS_S, 4, Q0.into()).unwrap();
    let mut energy = std::vec![p.energy_j(&c).unwrap()];
    let mut swing = 0.0f64;
    for _ in 0..periods {
        p.step(Vector3::zeros()).unwrap();
        energy.push(p.energy_j(&c).unwrap());
        swing = swing.max((p.q_m - Vector3::from(Q0)).amax());
    }
    (energy, swing)
}

#[test]
fn friction_only_dissipates_energy() {
    // Zero command: the current loops stay at 0, so the drive leaves only its
    // current-independent ripple, a force of position alone whose potential energy_j
    // includes. Without friction the total is conserved (the payload's mass and
    // gravity enter consistently, the ripple's potential is its own); with the
    // realistic friction it never rises. Tolerance per step: 1e-15 J, two orders
    // above the round-off of a ~0.1 J energy and RK4's (ωh)⁵ E per step.
    let frictionless = DeltaPlantParams {
        viscous_n_s_per_m: 0.0,
        coulomb_n: 0.0,
        ..DeltaPlantParams::SLAVE_REALISTIC
    };
    let (energy, swing) = unforced_energy(frictionless, 20_000);
    let drift = energy
        .iter()
        .map(|e| (e - energy[0]).abs())
        .fold(0.0, f64::max);
    std::println!("frictionless drift {drift:.2e} J, swing {swing:.2e} m");
    assert!(swing > 1e-3, "{swing}");
    assert!(drift < 1e-12, "{drift}");

    let (energy, swing) = unforced_energy(DeltaPlantParams::SLAVE_REALISTIC, 20_000);
    for (k, pair) in energy.windows(2).enumerate() {
        assert!(
            pair[1] <= pair[0] + 1e-15,
            "step {k}: {} → {}",
            pair[0],
            pair[1]
        );
    }
    let lost = energy[0] - energy[energy.len() - 1];
    std::println!("with friction: dissipated {lost:.3e} J, swing {swing:.2e} m");
    // It moved, and friction took a real part of the energy it exchanged.
    assert!(swing > 1e-4 && lost > 1e-5, "{swing} {lost}");
}

#[test]
fn payload_changes_the_holding_force_by_minus_jx_transpose_m_g() {
    let c = hanging_keops();
    let q0 = Vector3::from(Q0);
    let bare = DeltaPlantParams {
        drive: DriveParams::IDEAL,
        ..DeltaPlantParams::SLAVE
    };
    let laden = DeltaPlantParams {
        payload_kg: 0.020,
        ..bare
    };
    let without = DeltaPlant::new(&c, bare, TS_S, 4, q0).unwrap();
    let mut with = DeltaPlant::new(&c, laden, TS_S, 4, q0).unwrap();
    let hold_bare = without.holding_force_n().unwrap();
    let hold = with.holding_force_n().unwrap();
    // −Jxᵀ mp g from the kinematics alone.
    let g = DeltaGeometry::<f64>::new(&c).unwrap();
    let jx = g.jacobian(&q0, &g.forward(&q0).unwrap()).unwrap();
    let expect = -(jx.transpose() * Vector3::new(0.0, 0.0, 0.020 * -9.81));
    let err = (hold - hold_bare - expect).amax();
    assert!(err < 1e-15, "{err}");
    // And the laden plant really is held by it (rounding only), but not by the bare
    // robot's force, which lets the payload sink.
    for _ in 0..1000 {
        with.step(hold).unwrap();
    }
    assert!((with.q_m - q0).amax() < 1e-12, "{}", with.q_m - q0);
    let z0 = with.effector_m().unwrap().z;
    for _ in 0..1000 {
        with.step(hold_bare).unwrap();
    }
    assert!(with.effector_m().unwrap().z < z0 - 1e-5);
}

#[test]
fn the_current_loop_lags_the_command_in_the_plant() {
    // One carriage, no friction, a 1 N step through the 2 kHz loop alone: the rail
    // force is f(t) = 1 − e^(−t/τ), so over the first period its mean is
    // 1 − (τ/T)(1 − e^(−T/τ)) and the velocity v(t) = (t − τ (1 − e^(−t/τ)))/m. RK4
    // integrates f by Simpson's rule over each substep: error (h/2)⁵/(90 τ⁴) e^(−t/τ)
    // per substep, 8e-11 N·s in the first, summing to 2e-10 N·s over the first
    // period (2e-6 N of its mean) and 3e-10 N·s in all (4e-9 m/s of velocity).
    let drive = DriveParams {
        current_bandwidth_hz: 2000.0,
        ..DriveParams::IDEAL
    };
    let tau = drive.current_tau_s();
    let mut p = plant(single_axis(0.0, 0.0, drive), TS_S, 4);
    p.step(Vector3::new(1.0, 0.0, 0.0)).unwrap();
    let mean = 1.0 - tau / TS_S * (1.0 - libm::exp(-TS_S / tau));
    assert!(
        (p.applied_force_n().x - mean).abs() < 1e-5,
        "{}",
        p.applied_force_n()
    );
    assert!((p.drive_force_n().x - (1.0 - libm::exp(-TS_S / tau))).abs() < 1e-15);
    assert_eq!(p.commanded_force_n(), Vector3::new(1.0, 0.0, 0.0));
    for _ in 1..10 {
        p.step(Vector3::new(1.0, 0.0, 0.0)).unwrap();
    }
    let t = 10.0 * TS_S;
    let v = (t - tau * (1.0 - libm::exp(-t / tau))) / MC;
    assert!((p.q_dot_m_s.x - v).abs() < 1e-8, "{} vs {v}", p.q_dot_m_s.x);
    assert_eq!(p.q_dot_m_s.y, 0.0);
}

#[test]
fn ripple_and_dac_act_on_each_carriage_at_its_own_position() {
    // Instantaneous current, so over one period from rest the rail force is the
    // ripple formula at the (barely moving, ≤ 0.5 a T² = 0.25 µm) start position.
    let drive = DriveParams {
        current_bandwidth_hz: f64::INFINITY,
        ..DriveParams::LM1247_DS1103
    };
    let r = &drive.ripple;
    let cmd = [1.0, -0.7, 0.3];
    let lsb = 7.2 / 65536.0;
    for start in [0.0, 0.0041, 0.0107] {
        let q0 = Vector3::new(Q0[0] + start, Q0[1] - start, Q0[2] + 0.5 * start);
        let mut p =
            DeltaPlant::new(&hanging_keops(), single_axis(0.0, 0.0, drive), TS_S, 4, q0).unwrap();
        p.step(cmd.into()).unwrap();
        for i in 0..3 {
            // The DAC's output: the nearest multiple of the LSB.
            let u = libm::round(cmd[i] / lsb) * lsb;
            // Written out per term, not through the drive's code.
            let x = 2.0 * PI * q0[i] / 0.018;
            let expect = u
                + (0.02 * u) * libm::cos(6.0 * x + r[0].phase_rad[i])
                + 0.010 * libm::cos(x + r[1].phase_rad[i])
                + 0.005 * libm::cos(2.0 * x + r[2].phase_rad[i]);
            // Motion within the period shifts the 3 mm ripple by < 0.25 µm: < 2e-6 N.
            let got = p.applied_force_n()[i];
            assert!(
                (got - expect).abs() < 2e-6,
                "{i} at {start}: {got} vs {expect}"
            );
        }
    }
    // The ripple's phases really differ between carriages.
    let d = DriveParams::LM1247_DS1103;
    assert!((d.rail_force_n(0, 1.0, 0.004) - d.rail_force_n(1, 1.0, 0.004)).abs() > 1e-3);
}
