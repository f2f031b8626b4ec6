use super::super::test_motor::{Motor, TS};
use super::super::{Foc, FocConfig, MotorWindings};
use super::*;
extern crate std;

/// Runs the measurement on the test motor (three phases integrated one by one, the
/// dead time of the KEOPS stage, a 24 V bus) whose windings are `windings`, its
/// shunts reading `offsets` plus a deterministic ±2 mA of noise; the outcome and
/// the periods it took.
fn measure(windings: MotorWindings, offsets: [f64; 3]) -> (Progress<f64>, u32) {
    let foc = Foc::<f64>::new(&FocConfig::KEOPS).unwrap();
    let mut check = Commissioning::<f64>::new(&CommissioningConfig::LM1247, TS).unwrap();
    let mut motor = Motor {
        currents: [0.0; 3],
        position_m: 0.004,
        speed_m_s: 0.0,
        windings,
        dead_time_s: FocConfig::KEOPS.stage.dead_time_s,
        bus: 24.0,
    };
    let mut duties = [0.5; 3];
    let mut seed = 0x2545_f491u32;
    for period in 0..20_000 {
        let raw: [f64; 3] = core::array::from_fn(|x| {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            motor.currents[x]
                + offsets[x]
                + 0.002 * (f64::from(seed) / f64::from(u32::MAX) - 0.5) * 2.0
        });
        let progress = check.step(raw);
        let next = match progress {
            Progress::Running(Command::BridgeOff) => [0.5; 3],
            Progress::Running(Command::Voltage {
                alpha_beta_v,
                currents_a,
            }) => foc.duties_for(alpha_beta_v, currents_a, 24.0),
            done => return (done, period),
        };
        motor.run(TS / 2.0, duties);
        duties = next;
        motor.run(TS / 2.0, duties);
    }
    panic!("the measurement never ended")
}

/// On the motor it was configured for, the measurement finds the offsets within
/// 0.1 mA (2048 samples of ±2 mA noise average to 0.03 mA), the resistance within
/// 1 % and the inductance within 1 % of the values the motor was built with (the
/// shunts' noise and the resistance's error enter the decay's fit), in 0.50 s.
#[test]
fn the_motor_measures_as_it_was_built() {
    let offsets = [0.02, -0.015, 0.005];
    let built = MotorWindings::LM1247;
    let (outcome, periods) = measure(built, offsets);
    let Progress::Done(m) = outcome else {
        panic!("{outcome:?}")
    };
    std::println!(
        "measured R {:.4} Ω, L {:.4} mH, offsets {:?} in {periods} periods",
        m.resistance_ohm,
        m.inductance_h * 1e3,
        m.offsets_a
    );
    for (got, want) in m.offsets_a.iter().zip(&offsets) {
        assert!((got - want).abs() < 1e-4, "{:?}", m.offsets_a);
    }
    assert!(
        (m.resistance_ohm / built.resistance_ohm - 1.0).abs() < 0.01,
        "{m:?}"
    );
    assert!(
        (m.inductance_h / built.inductance_h - 1.0).abs() < 0.01,
        "{m:?}"
    );
    // And another motor within the range: twice the inductance, 1.5 times R.
    let other = MotorWindings {
        resistance_ohm: 7.9,
        inductance_h: 0.7e-3,
        ..built
    };
    let (outcome, _) = measure(other, [0.0; 3]);
    let Progress::Done(m) = outcome else {
        panic!("{outcome:?}")
    };
    assert!((m.resistance_ohm / 7.9 - 1.0).abs() < 0.01, "{m:?}");
    assert!((m.inductance_h / 0.7e-3 - 1.0).abs() < 0.01, "{m:?}");
}

/// An open phase (no current for the voltage), a shorted winding, a motor of ten
/// times the inductance and a broken current amplifier each stop the measurement
/// with their own error.
#[test]
fn a_motor_that_is_not_the_configured_one_is_refused() {
    let built = MotorWindings::LM1247;
    // Open: 1 kΩ, all a 6 V ceiling can drive is 6 mA (its 10 mH keeps the test's
    // integration step within L/R).
    let open = MotorWindings {
        resistance_ohm: 1e3,
        inductance_h: 10e-3,
        ..built
    };
    assert_eq!(
        measure(open, [0.0; 3]).0,
        Progress::Failed(CommissioningError::OpenPhase)
    );
    let shorted = MotorWindings {
        resistance_ohm: 0.5,
        ..built
    };
    let (outcome, _) = measure(shorted, [0.0; 3]);
    assert!(
        matches!(outcome, Progress::Failed(CommissioningError::Resistance { measured_ohm }) if (measured_ohm - 0.5).abs() < 0.02),
        "{outcome:?}"
    );
    let other = MotorWindings {
        inductance_h: 3.6e-3,
        ..built
    };
    let (outcome, _) = measure(other, [0.0; 3]);
    assert!(
        matches!(outcome, Progress::Failed(CommissioningError::Inductance { measured_h }) if (measured_h / 3.6e-3 - 1.0).abs() < 0.05),
        "{outcome:?}"
    );
    let (outcome, periods) = measure(built, [0.0, 0.3, 0.0]);
    assert!(
        matches!(
            outcome,
            Progress::Failed(CommissioningError::Offset { phase: 1, .. })
        ),
        "{outcome:?}"
    );
    assert_eq!(periods, CommissioningConfig::LM1247.offset_periods - 1);
}

/// A reading that is not finite stops it, and it stays stopped; bad settings are
/// refused naming the field.
#[test]
fn bad_readings_and_settings_are_refused() {
    let mut check = Commissioning::<f32>::new(&CommissioningConfig::LM1247, TS).unwrap();
    assert_eq!(check.step([0.0; 3]), Progress::Running(Command::BridgeOff));
    assert_eq!(
        check.step([f32::NAN, 0.0, 0.0]),
        Progress::Failed(CommissioningError::NotFinite)
    );
    assert_eq!(
        check.step([0.0; 3]),
        Progress::Failed(CommissioningError::NotFinite)
    );
    let mut reversed = CommissioningConfig::LM1247;
    reversed.resistance_range_ohm = (10.0, 2.0);
    let error = Commissioning::<f32>::new(&reversed, TS).unwrap_err();
    assert_eq!(error.field(), "resistance_range_ohm");
    let mut none = CommissioningConfig::LM1247;
    none.inductance_periods = 0;
    assert_eq!(
        Commissioning::<f32>::new(&none, TS).unwrap_err().field(),
        "inductance_periods"
    );
}
