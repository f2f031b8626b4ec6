//! QEMU smoke run on an FPU-less core: the single-axis machine (Hall decode → velocity
//! observer → PD → DOB) in 32-bit fixed point ([`Q6_25`]) against the simulated
//! LM1247 axis, on QEMU's Cortex-M3 (`mps2-an385`, the an386's memory map).
//!
//! The scenario is the host's `Scenario::TRACKING` (ideal sensors, the 1 s profile),
//! run to its end by the same lockstep driver the host tests use
//! (`kerf_sim::scenario::run`): the operator loads and starts the job through the
//! command queue after every period. The image runs it three times: in `Q6_25`, in
//! `f32` (software floating point here) and in `f64` (the reference), and prints one
//! summary line per scalar. It exits non-zero when the fixed-point run faults or
//! misses the scenario's bounds, or when its RMS tracking error is more than 10 % away
//! from the f64 run's (the host's `fixed_point_errors` test reports
//! the same comparison per scenario). The `break-gain` feature detunes the position
//! gain to 1 %, which must fail (scripts/smoke checks that it does).
#![no_std]
#![no_main]

use cortex_m_semihosting::hprintln;
use kerf::{Real, Q6_25};
use kerf_app::exit;
use kerf_app::stack::Painted;
use kerf_sim::scenario::{run, Outcome, Scenario, MAX_ERROR_BOUND_M, RMS_ERROR_BOUND_M};

/// The fixed-point run's RMS error may differ from the f64 run's by this fraction.
const RMS_TOLERANCE: f64 = 0.10;
/// Stack painted below `main` to measure the fixed-point run's depth, bytes.
const STACK_PAINT: usize = 128 * 1024;

fn summary<T: Real>(name: &str, scenario: &Scenario) -> Option<Outcome> {
    match run::<T>(scenario) {
        Ok(o) => {
            hprintln!(
                "kerf axis-m3 ({}): periods {} rms error {:.3} um max error {:.3} um peak force {:.3} N fault {}",
                name,
                o.periods,
                o.rms_error_m * 1e6,
                o.max_error_m * 1e6,
                o.peak_force_n,
                o.fault_period.is_some()
            );
            Some(o)
        }
        Err(e) => {
            hprintln!("kerf axis-m3 ({}): scenario failed: {:?}", name, e);
            None
        }
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    #[allow(unused_mut)]
    let mut scenario = Scenario::TRACKING;
    #[cfg(feature = "break-gain")]
    {
        // Deliberately detuned: 1 % of the position gain must miss the bounds.
        scenario.machine.axis.pd.kp_per_s2 *= 0.01;
    }
    let painted = Painted::below_sp(STACK_PAINT);
    let fixed = summary::<Q6_25>("Q6_25", &scenario);
    match painted.used() {
        Some(bytes) => hprintln!(
            "kerf axis-m3: the Q6_25 run (machine, simulated axis, operator, queues) used {} bytes of stack",
            bytes
        ),
        None => hprintln!(
            "kerf axis-m3: the Q6_25 run used more than the {} bytes of stack painted",
            STACK_PAINT
        ),
    }
    let soft = summary::<f32>("f32, software float", &scenario);
    let reference = summary::<f64>("f64, reference", &scenario);
    let ok = match (fixed, soft, reference) {
        (Some(q), Some(_), Some(r)) => {
            let relative = (q.rms_error_m / r.rms_error_m - 1.0).abs();
            let pass = q.fault_period.is_none()
                && q.periods == scenario.periods
                && q.rms_error_m < RMS_ERROR_BOUND_M
                && q.max_error_m < MAX_ERROR_BOUND_M
                && relative <= RMS_TOLERANCE;
            hprintln!(
                "kerf axis-m3: Q6_25 rms {:.3} um (bound {:.1}) max {:.3} um (bound {:.1}), rms {:.1} % from f64 (bound {:.0} %) -> {}",
                q.rms_error_m * 1e6,
                RMS_ERROR_BOUND_M * 1e6,
                q.max_error_m * 1e6,
                MAX_ERROR_BOUND_M * 1e6,
                relative * 100.0,
                RMS_TOLERANCE * 100.0,
                if pass { "PASS" } else { "FAIL" }
            );
            pass
        }
        _ => false,
    };
    exit(ok)
}
