//! Closed-loop scenarios of one LM1247 axis: Hall decode → DOB + PD → simulated plant.

use hal_mock::scenario::{run, Scenario, MAX_ERROR_BOUND_M, RMS_ERROR_BOUND_M};
use kerf::Q32;

fn report(name: &str, o: &hal_mock::scenario::Outcome) {
    println!(
        "{name:>4}: periods {} rms {:.3} um max {:.3} um  peaks: force {:.3} N dist {:.3} N vel {:.3} m/s pos {:.4} m",
        o.periods,
        o.rms_error_m * 1e6,
        o.max_error_m * 1e6,
        o.peak_force_n,
        o.peak_disturbance_n,
        o.peak_velocity_m_s,
        o.peak_position_m
    );
}

#[test]
fn tracking_profile_meets_bounds_in_f64_f32_and_q32() {
    let s = Scenario::TRACKING;
    let r64 = run::<f64>(&s).unwrap();
    let r32 = run::<f32>(&s).unwrap();
    let rq = run::<Q32>(&s).unwrap();
    report("f64", &r64);
    report("f32", &r32);
    report("Q32", &rq);
    for o in [&r64, &r32, &rq] {
        assert_eq!(o.periods, 10_000);
        assert!(o.fault_period.is_none());
        assert!(o.rms_error_m < RMS_ERROR_BOUND_M, "{o:?}");
        assert!(o.max_error_m < MAX_ERROR_BOUND_M, "{o:?}");
    }
}
