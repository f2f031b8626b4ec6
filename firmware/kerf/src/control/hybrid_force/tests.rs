//! The hybrid loop with both laws on a contact plant, its limits, the feed identity
//! of G eq. 11 and the safe output.

use super::*;
use crate::control::adrc::AdrcConfig;
use crate::control::pid::PidConfig;

const TS: f64 = 1e-3;

/// Faster rate than G's so that a test reaches contact force in a second.
fn cell() -> HybridForceConfig {
    HybridForceConfig {
        piezo_min_m: 0.0,
        piezo_max_m: 1e-3,
        piezo_rate_m_s: 2e-3,
        feed_m_s: 1e-3,
        increment_unit_m: 1e-6,
    }
}

fn pid_law() -> Pid<f64> {
    Pid::new(
        &PidConfig {
            kp: 2.0,
            ki_per_s: 0.0,
            kd_s: 0.0,
            derivative_filter_s: 0.0,
            anti_windup_per_s: 0.0,
            limits: None,
            rate_limit_per_s: None,
        },
        TS,
    )
    .unwrap()
}

/// Contact at 0.2 mm, stiffness 2e4 N/m: Fn = k·max(0, p − s).
fn contact(piezo_m: f64) -> f64 {
    2e4 * (piezo_m - 2e-4).max(0.0)
}

/// Runs the loop to 7.5 N; checks every period's limits and the feed identity.
fn run<L: ForceLaw<f64>>(
    loop_: &HybridForce<f64, L>,
    law_state: L::State,
    periods: usize,
) -> (f64, usize) {
    let mut state = HybridForceState {
        law: law_state,
        piezo_m: 0.0,
    };
    let c = cell();
    let mut exceeded = 0;
    let mut force = 0.0;
    for _ in 0..periods {
        let before = state.piezo_m;
        let out = loop_.step(&mut state, 7.5, force).unwrap();
        assert!(out.piezo_m >= c.piezo_min_m && out.piezo_m <= c.piezo_max_m);
        // Rate limit: R·Ts = 2 µm per period (plus rounding).
        assert!((out.piezo_m - before).abs() <= c.piezo_rate_m_s * TS * (1.0 + 1e-12));
        // G eq. 11 against hypot: F_R = √(V_hex² + V_pzo²) unless the feed is exceeded.
        if out.feed_exceeded {
            exceeded += 1;
            assert_eq!(out.hexapod_feed_m_s, 0.0);
            assert!(out.piezo_velocity_m_s.abs() > c.feed_m_s);
        } else {
            let total = out.hexapod_feed_m_s.hypot(out.piezo_velocity_m_s);
            assert!((total - c.feed_m_s).abs() < 1e-15, "{out:?}");
        }
        force = contact(out.piezo_m);
    }
    (force, exceeded)
}

#[test]
fn both_laws_regulate_the_force_through_one_implementation() {
    // PID: the approach runs at the rate limit (2 mm/s > the 1 mm/s feed: flagged),
    // then the increment law converges geometrically (Kp·unit·k = 0.04 per period).
    let pid = HybridForce::new(pid_law(), &cell(), TS).unwrap();
    let (force, exceeded) = run(&pid, PidState::at(0.0), 3000);
    assert!((force - 7.5).abs() < 1e-6, "{force}");
    assert!(exceeded > 50, "{exceeded}");
    // ADRC on the same plant: the observer absorbs the model mismatch (a first-order
    // plant against the second-order model); steady state is exact (z3 + b0 u = 0
    // at rest and the state-error feedback drives e1 to zero).
    let adrc = Adrc::new(
        &AdrcConfig {
            td_acceleration: 200.0,
            td_filter_period_s: TS,
            eso_bandwidth_rad_s: 200.0,
            eso_delta: 1.0,
            kp: 400.0,
            kd: 40.0,
            alpha: 0.9,
            delta: 1.0,
            b0: 400.0,
        },
        TS,
    )
    .unwrap();
    let adrc = HybridForce::new(adrc, &cell(), TS).unwrap();
    let (force, _) = run(&adrc, AdrcState::at(0.0, 0.0), 5000);
    assert!((force - 7.5).abs() < 1e-3, "{force}");
}

#[test]
fn saturation_at_the_travel_end_tells_the_law() {
    // No surface in reach: the piezo extends to its end and stays there; with
    // back-calculation the PID integrator stays bounded instead of winding up.
    let law = Pid::new(
        &PidConfig {
            kp: 0.5,
            ki_per_s: 50.0,
            kd_s: 0.0,
            derivative_filter_s: 0.0,
            anti_windup_per_s: 200.0,
            limits: None,
            rate_limit_per_s: None,
        },
        TS,
    )
    .unwrap();
    let loop_ = HybridForce::new(law, &cell(), TS).unwrap();
    let mut state = HybridForceState {
        law: PidState::at(0.0f64),
        piezo_m: 0.0,
    };
    let mut last = None;
    for _ in 0..5000 {
        last = Some(loop_.step(&mut state, 7.5, 0.0).unwrap());
    }
    let last = last.unwrap();
    assert_eq!(last.piezo_m, 1e-3);
    assert!(last.saturated && last.piezo_velocity_m_s == 0.0);
    assert_eq!(last.hexapod_feed_m_s, 1e-3);
    // At the end, applied increment 0: I settles where Kp e + I = 0 is pulled
    // toward, |I| ≤ Kp·e + Ki e/Kaw = 3.75 + 1.9 (without anti-windup: 50·7.5·5 s).
    assert!(state.law.integral.abs() < 6.0, "{}", state.law.integral);
}

#[test]
fn nan_input_retracts_and_stops_the_feed() {
    let loop_ = HybridForce::new(pid_law(), &cell(), TS).unwrap();
    let mut state = HybridForceState {
        law: PidState::at(0.0),
        piezo_m: 5e-4,
    };
    let law_before = state.law;
    let fault = loop_.step(&mut state, 7.5, f64::NAN).unwrap_err();
    assert_eq!(fault.error, HybridForceError::ForceNotFinite);
    // One rate-limited step away from the surface, feed zero, law untouched.
    assert!((fault.output.piezo_m - (5e-4 - 2e-6)).abs() < 1e-18);
    assert!((fault.output.piezo_velocity_m_s + 2e-3).abs() < 1e-12);
    assert_eq!(fault.output.hexapod_feed_m_s, 0.0);
    assert_eq!(state.law, law_before);
    let fault = loop_.step(&mut state, f64::INFINITY, 3.0).unwrap_err();
    assert_eq!(fault.error, HybridForceError::ReferenceNotFinite);
    // Repeated faults end at the retracted end of travel, never below, never NaN.
    for _ in 0..400 {
        let out = loop_
            .step(&mut state, f64::NAN, f64::NAN)
            .unwrap_err()
            .output;
        assert!(out.piezo_m >= 0.0 && !out.piezo_velocity_m_s.is_nan());
    }
    assert_eq!(state.piezo_m, 0.0);
    // A corrupt law state (NaN integrator) is caught at the law's output.
    state.law.integral = f64::NAN;
    state.piezo_m = 1e-4;
    let fault = loop_.step(&mut state, 7.5, 3.0).unwrap_err();
    assert_eq!(fault.error, HybridForceError::CommandNotFinite);
    assert!((fault.output.piezo_m - 0.98e-4).abs() < 1e-15);
}

#[test]
fn f32_loop_matches_f64() {
    // The same PID loop in f32: within 1e-4 N of f64 after convergence (f32 positions
    // near 0.6 mm resolve 6e-11 m, i.e. 1.2e-6 N of contact force per ulp).
    let law32 = Pid::<f32>::new(
        &PidConfig {
            kp: 2.0,
            ki_per_s: 0.0,
            kd_s: 0.0,
            derivative_filter_s: 0.0,
            anti_windup_per_s: 0.0,
            limits: None,
            rate_limit_per_s: None,
        },
        TS,
    )
    .unwrap();
    let loop32 = HybridForce::new(law32, &cell(), TS).unwrap();
    let mut state = HybridForceState {
        law: PidState::at(0.0f32),
        piezo_m: 0.0f32,
    };
    let mut force = 0.0f32;
    for _ in 0..3000 {
        let out = loop32.step(&mut state, 7.5, force).unwrap();
        force = contact(f64::from(out.piezo_m)) as f32;
    }
    let (f64_force, _) = run(
        &HybridForce::new(pid_law(), &cell(), TS).unwrap(),
        PidState::at(0.0),
        3000,
    );
    assert!((f64::from(force) - f64_force).abs() < 1e-4, "{force}");
}

#[test]
fn rejects_bad_config() {
    let err = |c: HybridForceConfig| HybridForce::new(pid_law(), &c, TS).err();
    assert_eq!(
        err(HybridForceConfig {
            piezo_max_m: 0.0,
            ..cell()
        }),
        Some(ConfigError::out_of_range("piezo_max_m"))
    );
    assert_eq!(
        err(HybridForceConfig {
            feed_m_s: 0.0,
            ..cell()
        }),
        Some(ConfigError::not_positive("feed_m_s"))
    );
    assert_eq!(
        err(HybridForceConfig {
            piezo_rate_m_s: f64::NAN,
            ..cell()
        }),
        Some(ConfigError::not_finite("piezo_rate_m_s"))
    );
    assert!(HybridForce::new(pid_law(), &HybridForceConfig::GRINDING_SEED, TS).is_ok());
}
