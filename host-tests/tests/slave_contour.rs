//! The Keops slave cutting the cam contour in simulation: EFD reference at 10 mm/s →
//! delta IK → C² joint spline → three single-axis loops (Hall decode, velocity
//! observer, PD, DOB; f32) → the Lagrangian delta plant with gravity, read back only
//! through each carriage's simulated Hall sensors. The effector's contour error is
//! checked against what the single-axis bounds allow through the Jacobian.

use hal_mock::delta_plant::{DeltaPlant, DeltaPlantParams};
use hal_mock::hall_sensor::{HallSensor, HallSensorParams};
use host_tests::contours::{cam_at_10_mm_s, CUT_Z_M};
use kerf::app::axis::{AxisConfig, AxisLaw, AxisState, AxisStatus, HallAxis};
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::kinematics::Vector3;
use kerf::sensing::hall::HallConfig;
use kerf::trajectory::spline::{JointSpline, KnotTiming};
use kerf::trajectory::Reference;
use kerf_sim::scenario::{MAX_ERROR_BOUND_M, RMS_ERROR_BOUND_M};

#[test]
fn keops_slave_follows_the_cam_contour_through_hall_sensors() {
    const TS_S: f64 = 1e-4;
    const KNOT_S: f64 = 1e-3;
    let config = DeltaConfig::SLAVE_KEOPS;
    let delta = DeltaGeometry::<f64>::new(&config).unwrap();

    // Task reference: cam at 10 mm/s from rest to rest, sampled every millisecond.
    let task: Vec<Vector3<f64>> = cam_at_10_mm_s(KNOT_S, 2.0, 1)
        .iter()
        .map(|r| Vector3::new(r.position.x, r.position.y, CUT_Z_M))
        .collect();
    // Knots every 10 periods; the spline starts when the hold ends.
    const HOLD_S: f64 = 0.2;
    let hold = (HOLD_S / TS_S) as usize;
    let timing = KnotTiming {
        period_s: TS_S,
        periods_per_knot: (KNOT_S / TS_S).round() as u32,
        first_period: hold as u64,
    };
    let spline =
        JointSpline::<f64, 4096>::fit(&task, timing, Vector3::zeros(), Vector3::zeros(), |p| {
            delta.inverse(&p)
        })
        .unwrap();

    // Plant at the first pose; one Hall sensor per carriage, each loop homed there.
    let q0 = delta.inverse(&task[0]).unwrap();
    let mut plant = DeltaPlant::new(&config, DeltaPlantParams::SLAVE, TS_S, 4, q0).unwrap();
    let mut sensors: Vec<HallSensor> = (0..3)
        .map(|k| HallSensor::new(HallSensorParams::LM1247_16BIT, 100 + k))
        .collect();
    // One law for the three joints, one decoder per sensor set, three states.
    let law = AxisLaw::<f32>::new(&AxisConfig::LM1247_SLAVE, TS_S).unwrap();
    let decoders: Vec<HallAxis<f32>> = (0..3)
        .map(|_| HallAxis::new(&HallConfig::LM1247_16BIT).unwrap())
        .collect();
    let mut loops: Vec<AxisState<f32>> =
        (0..3).map(|k| AxisState::homed_at(q0[k] as f32)).collect();

    // The loops first hold the start pose for 0.2 s: gravity loads the carriages from the
    // first period, and the DOB takes that up like a load step before the cut starts.
    let periods = hold + ((task.len() - 1) as f64 * KNOT_S / TS_S) as usize;
    let (mut sum_sq, mut worst, mut worst_gain) = (0.0, 0.0f64, 0.0f64);
    for n in 0..periods {
        let t = (n as f64 * TS_S - HOLD_S).max(0.0);
        let reference = spline.evaluate(n as u64);
        let mut force = Vector3::zeros();
        for k in 0..3 {
            let r = Reference {
                position: reference.q[k] as f32,
                velocity: reference.qd[k] as f32,
                acceleration: reference.qdd[k] as f32,
            };
            let out = law.step(
                &decoders[k],
                &mut loops[k],
                sensors[k].sample(plant.q_m[k]),
                &r,
            );
            assert_eq!(out.status, AxisStatus::Running, "joint {k} at {t} s");
            force[k] = f64::from(out.force_n);
        }
        plant.step(force).unwrap();
        if n < hold {
            continue;
        }
        // Effector error against the task reference at this instant.
        let p_ref = delta.forward(&spline.evaluate(n as u64 + 1).q).unwrap();
        let p = plant.effector_m().unwrap();
        let e = (p - p_ref).norm();
        sum_sq += e * e;
        worst = worst.max(e);
        // ‖Jx‖∞: how much a joint error can move the effector here.
        let jx = delta.jacobian(&plant.q_m, &p).unwrap();
        worst_gain = worst_gain.max((0..3).map(|i| jx.row(i).abs().sum()).fold(0.0, f64::max));
    }
    let rms = (sum_sq / (periods - hold) as f64).sqrt();
    println!(
        "Keops slave, cam at 10 mm/s ({:.1} s): effector error RMS {:.2} µm, max {:.2} µm; max ‖Jx‖∞ {:.2}",
        (periods - hold) as f64 * TS_S,
        rms * 1e6,
        worst * 1e6,
        worst_gain
    );
    // Each joint loop meets the single-axis bounds (at ten times lower speed than that
    // scenario, with the plant's coupling and gravity left to the DOB); a joint error
    // vector e maps to at most ‖Jx‖∞ |e|∞ per effector axis, √3 of that in norm.
    let gain = 3f64.sqrt() * worst_gain;
    assert!(rms < gain * RMS_ERROR_BOUND_M, "{rms}");
    assert!(worst < gain * MAX_ERROR_BOUND_M, "{worst}");
}
