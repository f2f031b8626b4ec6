//! The delta slave's planning and joint references, against finite differences of the
//! inverse kinematics (a different computation from the Jacobian route).

use super::*;
use crate::app::joints::{JobError, MAX_SEGMENTS};
use crate::control::laser::LaserMode;
use crate::error::ConfigErrorKind;
use crate::machines::delta_slave::ContourCurve;
use crate::trajectory::efd::Efd;
use std::format;
use std::string::ToString;

/// On the axis of symmetry at the preset's home, in the middle of the workspace.
fn centre() -> [f64; 3] {
    let geometry = DeltaGeometry::<f64>::new(&DeltaConfig::SLAVE_KEOPS).unwrap();
    let p = geometry.forward(&Vector3::new(0.02, 0.02, 0.02)).unwrap();
    [p.x, p.y, p.z]
}

fn shifted(p: [f64; 3], d: [f64; 3]) -> [f64; 3] {
    [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
}

fn square(side_m: f64, duration_s: f64) -> heapless::Vec<Segment<3>, 8> {
    let c = centre();
    let h = side_m / 2.0;
    [[h, -h], [h, h], [-h, h], [-h, -h]]
        .iter()
        .map(|[x, y]| Segment {
            target_m: shifted(c, [*x, *y, 0.0]),
            duration_s,
        })
        .collect()
}

#[test]
fn joint_references_match_finite_differences_of_the_inverse_kinematics() {
    let geometry = DeltaGeometry::<f64>::new(&DeltaConfig::SLAVE_KEOPS).unwrap();
    let c = centre();
    // A diagonal line across the workspace with a height change, 0.2 s.
    let line = Line::<f64>::new(
        shifted(c, [-0.012, -0.010, -0.008]),
        shifted(c, [0.014, 0.011, 0.006]),
        0.2,
    )
    .unwrap();
    let ik = |t: f64| geometry.inverse(&line.at(t).0).unwrap();
    // Central differences with h = 0.1 ms: truncation error h²/6 q⁽³⁾ ≈ 2e-9 · q⁽³⁾,
    // with |q⁽³⁾| ≲ 1e3 m/s³ here: ≲ 2e-6 m/s on q̇; h²/12 q⁽⁴⁾ on q̈ (|q⁽⁴⁾| ≲ 1e5 m/s⁴)
    // ≲ 1e-4 m/s², plus rounding 1e-16 / h² ≈ 1e-8.
    let h = 1e-4;
    let mut peak = (0.0f64, 0.0f64);
    for n in 1..40 {
        let t = 0.005 * f64::from(n);
        let (p, p_dot, p_ddot) = line.at(t);
        let r = joint_references(&geometry, &p, &p_dot, &p_ddot).unwrap();
        let (q_minus, q, q_plus) = (ik(t - h), ik(t), ik(t + h));
        for k in 0..3 {
            let velocity = (q_plus[k] - q_minus[k]) / (2.0 * h);
            let acceleration = (q_plus[k] - 2.0 * q[k] + q_minus[k]) / (h * h);
            assert!((r[k].position - q[k]).abs() < 1e-15, "q{k} at {t}");
            assert!((r[k].velocity - velocity).abs() < 2e-6, "q̇{k} at {t}");
            assert!(
                (r[k].acceleration - acceleration).abs() < 2e-4,
                "q̈{k} at {t}: {} vs {acceleration}",
                r[k].acceleration
            );
            peak = (
                peak.0.max(r[k].velocity.abs()),
                peak.1.max(r[k].acceleration.abs()),
            );
        }
    }
    // The line is fast enough that the check means something.
    assert!(peak.0 > 0.1 && peak.1 > 2.0, "{peak:?}");
}

#[test]
fn a_square_at_the_centre_plans() {
    let config = DeltaSlaveConfig::KEOPS;
    let moves = square(0.02, 0.5);
    let job = DeltaJob::plan(&config, moves[3].target_m, 0.3, &moves).unwrap();
    assert_eq!(job.moves().len(), 4);
    assert!((job.duration_s() - 2.3).abs() < 1e-12);
    let slave = DeltaSlave::<f32>::new(&config).unwrap();
    assert_eq!(slave.check_job(&job), Ok(()));
}

/// A job copied over another in place (how the supervisor loads one) is the job, and
/// the empty default job is refused by every machine.
#[test]
fn a_job_cloned_in_place_replaces_the_old_one_and_the_empty_job_is_refused() {
    let config = DeltaSlaveConfig::KEOPS;
    let four = square(0.02, 0.5);
    let long = DeltaJob::plan(&config, four[3].target_m, 0.3, &four).unwrap();
    let short = DeltaJob::plan(&config, four[3].target_m, 0.2, &four[..1]).unwrap();
    let mut loaded = long.clone();
    assert_eq!(loaded, long);
    loaded.clone_from(&short);
    assert_eq!(loaded, short);
    assert_eq!(loaded.moves().len(), 1);
    let slave = DeltaSlave::<f32>::new(&config).unwrap();
    assert_eq!(
        slave.check_job(&DeltaJob::default()),
        Err(DeltaJobError::OtherMachine)
    );
}

#[test]
fn plans_that_do_not_fit_are_refused_with_the_move_that_fails() {
    let config = DeltaSlaveConfig::KEOPS;
    let c = centre();
    let at = |d: [f64; 3], duration_s: f64| Segment {
        target_m: shifted(c, d),
        duration_s,
    };
    let plan = |moves: &[Segment<3>]| DeltaJob::plan(&config, c, 0.3, moves);
    assert_eq!(plan(&[]), Err(DeltaJobError::Size));
    assert_eq!(
        plan(&[at([0.0; 3], 0.1); MAX_SEGMENTS + 1]),
        Err(DeltaJobError::Size)
    );
    assert_eq!(
        plan(&[at([0.01, 0.0, 0.0], 0.5), at([f64::NAN, 0.0, 0.0], 0.5)]),
        Err(DeltaJobError::NotFinite { segment: 1 })
    );
    assert_eq!(
        plan(&[at([0.01, 0.0, 0.0], 0.0)]),
        Err(DeltaJobError::NotFinite { segment: 0 })
    );
    assert_eq!(
        DeltaJob::plan(&config, c, f64::INFINITY, &[at([0.0; 3], 0.1)]),
        Err(DeltaJobError::NotFinite { segment: 0 })
    );
    // A 6-day dwell: more periods than the counter holds.
    assert_eq!(
        plan(&[at([0.0; 3], 6.0 * 86_400.0)]),
        Err(DeltaJobError::TooLong { segment: 0 })
    );
    // 0.2 m sideways is far out of reach of 70 mm arms; the start point too.
    assert!(matches!(
        plan(&[at([0.01, 0.0, 0.0], 0.5), at([0.2, 0.0, 0.0], 5.0)]),
        Err(DeltaJobError::Unreachable { segment: 1, .. })
    ));
    assert!(matches!(
        DeltaJob::plan(
            &config,
            shifted(c, [0.2, 0.0, 0.0]),
            0.3,
            &[at([0.0; 3], 0.5)]
        ),
        Err(DeltaJobError::Unreachable { segment: 0, .. })
    ));
    // 20 mm in 20 ms: 1.875 · 1 m/s along x needs well over 0.5 m/s of some carriage.
    assert!(matches!(
        plan(&[at([0.02, 0.0, 0.0], 0.02)]),
        Err(DeltaJobError::TooFast { segment: 0, .. })
    ));
}

#[test]
fn a_plan_for_another_machine_is_refused_at_load() {
    let mut other = DeltaSlaveConfig::KEOPS;
    other.joints.speed_limit_m_s = 1.0;
    let moves = square(0.02, 0.5);
    let job = DeltaJob::plan(&other, moves[3].target_m, 0.3, &moves).unwrap();
    let mut slave = DeltaSlave::<f32>::new(&DeltaSlaveConfig::KEOPS).unwrap();
    assert_eq!(slave.check_job(&job), Err(DeltaJobError::OtherMachine));
    assert_eq!(slave.begin_job(&job), Err(DeltaJobError::OtherMachine));
}

#[test]
fn an_approach_too_fast_from_where_the_carriages_are_is_refused_at_start() {
    let config = DeltaSlaveConfig::KEOPS;
    let moves = square(0.02, 0.5);
    // The carriages sit at their 10 mm home; the square's corner needs ~10 mm of each
    // in 1 ms.
    let job = DeltaJob::plan(&config, moves[3].target_m, 1e-3, &moves).unwrap();
    let mut slave = DeltaSlave::<f32>::new(&config).unwrap();
    assert!(matches!(
        slave.begin_job(&job),
        Err(DeltaJobError::Approach(JobError::TooFast { .. }))
    ));
}

#[test]
fn config_errors_name_the_whole_path() {
    let mut config = DeltaSlaveConfig::KEOPS;
    config.delta.actuators[1].theta_rad = f64::NAN;
    let e = DeltaSlave::<f32>::new(&config).unwrap_err();
    assert_eq!(e.to_string(), "delta.actuators[1].theta_rad: not finite");

    let mut config = DeltaSlaveConfig::KEOPS;
    config.joints.axis.dob.bandwidth_rad_s = -1.0;
    let e = DeltaSlave::<f32>::new(&config).unwrap_err();
    assert_eq!(
        format!("{}", e.path),
        "joints.axis.dob.bandwidth_rad_s",
        "{e}"
    );

    // Inside the joints' travel but outside the actuator's.
    let mut config = DeltaSlaveConfig::KEOPS;
    config.joints.travel_m[2] = [0.0, 0.1];
    config.joints.home_m[2] = 0.05;
    let e = DeltaSlave::<f32>::new(&config).unwrap_err();
    assert_eq!(format!("{}", e.path), "joints.home_m[2]", "{e}");

    // A bad sensor is named by its own index, whichever it is.
    for k in 0..3 {
        let mut config = DeltaSlaveConfig::KEOPS;
        config.joints.hall[k].pitch_m = 0.0;
        let e = DeltaSlave::<f32>::new(&config).unwrap_err();
        assert_eq!(
            format!("{}", e.path),
            format!("joints.hall[{k}].pitch_m"),
            "{e}"
        );
    }
}

/// The octagon (±6 mm) about the workspace centre, one lap at 8 mm/s, with `laser`.
fn octagon_plan(config: &DeltaSlaveConfig, laser: LaserMode) -> Result<DeltaJob, DeltaJobError> {
    use crate::trajectory::shapes::octagon;
    let points = octagon().map(|p| [0.6 * p[0], 0.6 * p[1]]);
    let efd = Efd::<f64, CONTOUR_HARMONICS>::from_polygon(&points, 30).unwrap();
    DeltaJob::plan_contour(
        config,
        &ContourPlan {
            curve: ContourCurve::Closed {
                efd: &efd,
                theta0_rad: 0.0,
                laps: 1.0,
            },
            centre_m: centre(),
            speed_m_s: 8e-3,
            accel_m_s2: 0.1,
            jerk_m_s3: 10.0,
            approach_s: 0.3,
            law: ContourLaw::Contouring,
            laser,
        },
    )
}

#[test]
fn a_laser_mode_the_source_cannot_give_is_refused_at_plan_and_another_source_at_load() {
    let keops = DeltaSlaveConfig::KEOPS;
    for (mode, kind) in [
        (
            LaserMode::ConstantPower { power_w: 20.5 },
            ConfigErrorKind::OutOfRange,
        ),
        (
            LaserMode::ConstantPower { power_w: -1.0 },
            ConfigErrorKind::OutOfRange,
        ),
        (
            LaserMode::constant_energy_of(10.0, 0.0),
            ConfigErrorKind::NotFinite,
        ),
    ] {
        assert_eq!(
            octagon_plan(&keops, mode).unwrap_err(),
            DeltaJobError::Laser(kind),
            "{mode:?}"
        );
    }
    // The source's full power is a valid job; planned for a 30 W source, the Keops
    // slave (20 W) refuses it at load.
    let full = LaserMode::ConstantPower { power_w: 20.0 };
    assert!(octagon_plan(&keops, full).is_ok());
    let mut bigger = keops;
    bigger.laser.max_power_w = 30.0;
    let job = octagon_plan(&bigger, LaserMode::ConstantPower { power_w: 25.0 }).unwrap();
    let slave = DeltaSlave::<f32>::new(&keops).unwrap();
    assert_eq!(slave.check_job(&job), Err(DeltaJobError::OtherMachine));
    // A source that is not one is named with its path.
    let mut broken = keops;
    broken.laser.min_speed_m_s = 0.0;
    let e = DeltaSlave::<f32>::new(&broken).unwrap_err();
    assert_eq!(e.to_string(), "laser.min_speed_m_s: not strictly positive");
}

#[test]
fn the_beam_is_off_outside_a_contour_and_in_the_safe_outputs() {
    let config = DeltaSlaveConfig::KEOPS;
    let mut slave = DeltaSlave::<f32>::new(&config).unwrap();
    assert_eq!(slave.safe_outputs().laser_duty, 0.0);
    assert_eq!(slave.safe_outputs().force_n, [0.0; 3]);
    let job = octagon_plan(&config, LaserMode::ConstantPower { power_w: 20.0 }).unwrap();
    slave.begin_job(&job).unwrap();
    // The approach, from wherever the (nominally decoded) carriages are: beam off.
    let inputs = [[32768u16; 3]; 3];
    let _ = slave.monitor(&inputs);
    for _ in 0..10 {
        match slave.run(&job, &inputs) {
            Ok(Step::Continue(o)) | Ok(Step::Done(o)) => assert_eq!(o.laser_duty, 0.0),
            Err(_) => break,
        }
        assert_eq!(slave.telemetry().laser_power_w, 0.0);
    }
}

/// An open path planned like the letters: 2 mm/s, ramps of 0.1 m/s² and 10 m/s³.
fn open_plan(points: &[[f64; 2]], centre_m: [f64; 3]) -> Result<DeltaJob, DeltaJobError> {
    use crate::trajectory::open_path::OpenPath;
    let path =
        OpenPath::<f64, OPEN_PATH_POINTS>::from_points(points).map_err(DeltaJobError::Contour)?;
    DeltaJob::plan_contour(
        &DeltaSlaveConfig::KEOPS,
        &ContourPlan {
            curve: ContourCurve::Open(&path),
            centre_m,
            speed_m_s: 2e-3,
            accel_m_s2: 0.1,
            jerk_m_s3: 10.0,
            approach_s: 0.3,
            law: ContourLaw::Preview,
            laser: LaserMode::Off,
        },
    )
}

#[test]
fn open_paths_plan_and_refuse_what_does_not_fit() {
    use crate::trajectory::shapes::letter_s;
    let c = centre();
    let job = open_plan(&letter_s(), c).unwrap();
    assert_eq!(job.contour_law(), Some(ContourLaw::Preview));
    // The start is the path's first point (relative to the points' centroid).
    let s = letter_s();
    let n = s.len() as f64;
    let centroid = [
        s.iter().map(|p| p[0]).sum::<f64>() / n,
        s.iter().map(|p| p[1]).sum::<f64>() / n,
    ];
    let want = [
        c[0] + s[0][0] - centroid[0],
        c[1] + s[0][1] - centroid[1],
        c[2],
    ];
    let got = job.start_m();
    for k in 0..3 {
        assert!((got[k] - want[k]).abs() < 1e-15, "{got:?} {want:?}");
    }
    // Shorter than the two ramps (2 × 0.03 mm): named.
    let tiny = [[0.0, 0.0], [1e-5, 1e-5], [2e-5, 0.0]];
    match open_plan(&tiny, c) {
        Err(DeltaJobError::Contour(ContourError::Config(e))) => assert_eq!(e.field(), "curve"),
        other => panic!("{other:?}"),
    }
    // Too many points for a job.
    let many: std::vec::Vec<[f64; 2]> = (0..=OPEN_PATH_POINTS)
        .map(|i| [1e-4 * i as f64, 0.0])
        .collect();
    assert_eq!(
        open_plan(&many, c).unwrap_err(),
        DeltaJobError::Contour(ContourError::Capacity)
    );
    // A 'stroke' from the middle of the workspace out past its edge (x ±29 mm): the
    // first point beyond reach is named, and it is past the edge.
    // The centroid is at x = 26 mm, so the stroke runs from x = −26 mm to +44 mm.
    let stroke = [
        [0.0, 0.0],
        [0.010, 0.001],
        [0.020, 0.0],
        [0.030, 0.001],
        [0.070, 0.0],
    ];
    match open_plan(&stroke, c) {
        Err(DeltaJobError::ContourUnreachable { point_m, .. }) => {
            // On the far side, out of reach, and a sample step (72 mm / 512) back
            // along the stroke is in reach.
            let geometry = DeltaGeometry::<f64>::new(&DeltaConfig::SLAVE_KEOPS).unwrap();
            let p = Vector3::from(point_m);
            assert!(p.x - c[0] > 0.020, "{point_m:?}");
            assert!(geometry.inverse(&p).is_err());
            assert!(geometry
                .inverse(&(p - Vector3::new(0.15e-3, 0.0, 0.0)))
                .is_ok());
        }
        other => panic!("{other:?}"),
    }
}

/// The delta's stop ramp is its carriages' own (the joints' ramp, tested on its own in
/// `app::joints`), period for period and force for force, with the beam off from the
/// first period even when the stop comes while the laser is lit.
#[test]
fn the_stop_ramps_the_carriages_with_the_beam_off() {
    let config = DeltaSlaveConfig::KEOPS;
    let mut slave = DeltaSlave::<f64>::new(&config).unwrap();
    let job = octagon_plan(&config, LaserMode::ConstantPower { power_w: 20.0 }).unwrap();
    // Healthy counts of carriages that stand still (the forces need not move them).
    let inputs = config.joints.hall.map(|h| {
        let o = f64::from(h.calibration.offset_counts[0]);
        core::array::from_fn(|k| {
            let phase = 0.3 + 2.0 * core::f64::consts::PI / 3.0 * k as f64;
            libm::round(o + h.amplitude_counts * libm::sin(phase)) as u16
        })
    });
    slave.monitor(&inputs).unwrap();
    slave.begin_job(&job).unwrap();
    // Into the approach, so that the carriages move when the stop comes.
    for _ in 0..200 {
        assert!(matches!(slave.run(&job, &inputs), Ok(Step::Continue(_))));
    }
    slave.laser_power_w = 5.0;
    slave.begin_stop();
    let mut twin = slave.joints().clone();
    let mut periods = 0;
    loop {
        periods += 1;
        let own = twin.ramp_to_rest(&inputs).unwrap();
        let step = slave.ramp_to_rest(&inputs).unwrap();
        assert_eq!(slave.telemetry().laser_power_w, 0.0);
        match (own, step) {
            (Step::Continue(f), Step::Continue(o)) => {
                assert_eq!((o.force_n, o.laser_duty), (f, 0.0))
            }
            (Step::Done(f), Step::Done(o)) => {
                assert_eq!((o.force_n, o.laser_duty), (f, 0.0));
                break;
            }
            (own, step) => panic!("period {periods}: {own:?} against {step:?}"),
        }
    }
    // The carriages were moving: the ramp took more than the one period of a rest.
    assert!(periods > 1, "{periods}");
}

/// A part's cut settings reach the plan through the loader: two passes cut one lap
/// more (the job longer by the lap's length over the speed, to the period the cruise
/// is rounded to), and what the machine cannot do is refused in its own code: a speed
/// not above zero, passes on an open path, an energy per length the source cannot
/// give at the part's speed (1,250 J/m at 20 mm/s is 25 W of a 20 W source; at 15 mm/s
/// it is 18.75 W, accepted by this check).
#[test]
fn a_parts_cut_settings_are_planned_or_refused_in_their_codes() {
    use crate::app::host_link::LinkMachine;
    use crate::codec::job::{with_settings, write_efd, write_points, CutLaser, CutSettings};
    use crate::machines::delta_slave::link::load_codes;
    use crate::machines::delta_slave::product::{contour_defaults, JOB_LAPS};
    let context = contour_defaults(&DeltaSlaveConfig::KEOPS, JOB_LAPS);
    let radius = f64::from(4e-3f32);
    let mut plain = [0u8; 256];
    let n = write_efd([0.0, 0.0], &[[radius, 0.0, 0.0, radius]], &mut plain).unwrap();
    let load = |settings: CutSettings, file: &[u8]| {
        let mut bytes = [0u8; 512];
        let m = with_settings(file, &settings, &mut bytes).unwrap();
        let mut job = DeltaJob::default();
        let read = crate::codec::job::JobFile::read(&bytes[..m]).unwrap();
        let mut context = context.into();
        DeltaSlave::<f32>::load_job(&mut context, &read, &mut job).map(|()| job.duration_s())
    };
    let once = load(CutSettings::MACHINE, &plain[..n]).unwrap();
    let twice = CutSettings {
        passes: Some(2),
        ..CutSettings::MACHINE
    };
    let lap_s = std::f64::consts::TAU * radius / context.speed_m_s;
    let longer = load(twice, &plain[..n]).unwrap() - once;
    assert!(
        (longer - lap_s).abs() <= 2e-4,
        "{longer} s against {lap_s} s"
    );
    let speed = |v: f32, laser| CutSettings {
        speed_m_s: Some(v),
        laser,
        ..CutSettings::MACHINE
    };
    assert_eq!(
        load(speed(-1e-3, None), &plain[..n]),
        Err(load_codes::SPEED)
    );
    let energy = Some(CutLaser::EnergyJPerM(1250.0));
    assert_eq!(
        load(speed(20e-3, energy), &plain[..n]),
        Err(load_codes::ENERGY)
    );
    assert!(load(speed(15e-3, energy), &plain[..n]) != Err(load_codes::ENERGY));
    let too_strong = Some(CutLaser::PowerW(25.0));
    assert_eq!(load(speed(8e-3, too_strong), &plain[..n]), Err(11));
    let path = [[0.0, 0.0], [2e-3, 1e-3], [4e-3, 0.0], [6e-3, 1e-3]];
    let n = write_points(&path, &mut plain).unwrap();
    assert!(load(CutSettings::MACHINE, &plain[..n]).is_ok());
    assert_eq!(load(twice, &plain[..n]), Err(load_codes::PASSES));
}
