//! QEMU smoke run on a Cortex-M0 (`microbit`: nRF51822, 256 KiB flash, 16 KiB RAM):
//! the single axis' law (Hall decode → velocity observer → PD → DOB) in 32-bit fixed
//! point ([`Q6_25`]) against the simulated LM1247 axis, following the 1 s tracking
//! profile.
//!
//! Not the whole machine: the supervisor's commands carry a Hall decoder by value
//! (1.7 KB with its tables) and the scenario's rig and operator hold the simulated
//! plant, the queues and the calibration buffers, which together need more stack than
//! the part has (the Cortex-M3 image measures its run). Here the law is stepped
//! directly, as a board's control interrupt would step `AxisLaw::step` after its ADC
//! conversion: homed at the profile's start, the reference sampled from the profile
//! each period. The run prints its tracking summary and exits non-zero past the
//! scenario's bounds (`kerf_sim::scenario`), or when the axis faults.
#![no_std]
#![no_main]

use cortex_m_semihosting::hprintln;
use hal_mock::axis::SimulatedAxis;
use kerf::app::axis::{AxisConfig, AxisLaw, AxisState, AxisStatus, HallAxis};
use kerf::hal::SampleInputs;
use kerf::trajectory::Reference;
use kerf::{Real, Q6_25};
use kerf_app::exit;
use kerf_app::stack::Painted;
use kerf_sim::scenario::{profile, Scenario, MAX_ERROR_BOUND_M, RMS_ERROR_BOUND_M, START_M, TS_S};

/// Stack painted below `main` to measure the run's depth, bytes (of the 16 KiB).
const STACK_PAINT: usize = 12 * 1024;

#[cortex_m_rt::entry]
fn main() -> ! {
    let painted = Painted::below_sp(STACK_PAINT);
    let outcome = run();
    let stack = painted.used();
    let Some((rms, max, periods)) = outcome else {
        hprintln!("kerf axis-m0: the law faulted or was refused -> FAIL");
        exit(false)
    };
    let ok = rms < RMS_ERROR_BOUND_M && max < MAX_ERROR_BOUND_M;
    hprintln!(
        "kerf axis-m0 (Q6_25 law on a Cortex-M0): periods {} rms error {:.3} um (bound {:.1}) max error {:.3} um (bound {:.1}), stack {:?} bytes -> {}",
        periods,
        rms * 1e6,
        RMS_ERROR_BOUND_M * 1e6,
        max * 1e6,
        MAX_ERROR_BOUND_M * 1e6,
        stack,
        if ok { "PASS" } else { "FAIL" }
    );
    exit(ok)
}

/// The profile's periods with the law in Q6_25; RMS and maximum error of the true
/// plant position against the reference, and the periods run.
#[inline(never)]
fn run() -> Option<(f64, f64, u32)> {
    #[allow(unused_mut)]
    let mut config: AxisConfig = Scenario::TRACKING.machine.axis;
    #[cfg(feature = "break-gain")]
    {
        // Deliberately detuned: 1 % of the position gain must miss the bounds.
        config.pd.kp_per_s2 *= 0.01;
    }
    let scenario = Scenario::TRACKING;
    let law = AxisLaw::<Q6_25>::new(&config, TS_S).ok()?;
    let sensor = HallAxis::<Q6_25>::new(scenario.machine.hall.first()?).ok()?;
    let mut state = AxisState::homed_at(Q6_25::from_f64(START_M));
    let mut plant = SimulatedAxis::new(
        scenario.motor,
        scenario.sensor,
        TS_S,
        scenario.seed,
        START_M,
    );
    let (mut sum_sq, mut max) = (0.0, 0.0f64);
    for k in 0..scenario.periods {
        let t = f64::from(k) * TS_S;
        let r = profile(t);
        let error = r.position - plant.motor.position_m;
        sum_sq += error * error;
        max = max.max(libm::fabs(error));
        let [counts] = plant.sample();
        let reference = Reference {
            position: Q6_25::from_f64(r.position),
            velocity: Q6_25::from_f64(r.velocity),
            acceleration: Q6_25::from_f64(r.acceleration),
        };
        let out = law.step(&sensor, &mut state, counts, &reference);
        if let AxisStatus::Fault(_) = out.status {
            return None;
        }
        plant.apply_force(out.force_n.to_f64());
    }
    let periods = scenario.periods;
    Some((libm::sqrt(sum_sq / f64::from(periods)), max, periods))
}
