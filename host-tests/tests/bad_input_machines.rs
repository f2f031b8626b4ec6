//! The bad-input sweep ([`host_tests::bad_input`]): the machines: the Hall axis,
//! joints, the delta slave and the period clock.

use host_tests::bad_input::{bad_counts, counts, finite, re, refused_or, sweep, Kind, Out, Sweep};
use kerf::app::axis::{AxisConfig, AxisLaw, AxisState, AxisStatus, HallAxis};
use kerf::app::joints::{JointJob, Joints, JointsConfig, Segment};
use kerf::app::supervisor::{Machine, Step};
use kerf::app::PeriodClock;
use kerf::kinematics::delta::DeltaGeometry;
use kerf::machines::delta_slave::{DeltaJob, DeltaSlave, DeltaSlaveConfig, SlaveOutputs};
use kerf::sensing::hall::HallConfig;
use kerf::trajectory::Reference;
use kerf::{Float, Real};
use nalgebra::Vector3;

// ---------------------------------------------------------------------------------
// app

/// A machine's period result: a fault is refused (the supervisor writes the safe
/// outputs), outputs must be finite.
fn machine_step<T: Real, F, const N: usize>(r: Result<Step<[T; N]>, F>) -> Out {
    match r {
        Ok(Step::Continue(o)) | Ok(Step::Done(o)) => finite(o),
        Err(_) => Out::Refused,
    }
}

/// A slave period: forces finite and the laser's duty a number in [0, 1].
fn slave_step<T: Real, F>(r: Result<Step<SlaveOutputs<T>>, F>) -> Out {
    match r {
        Ok(Step::Continue(o)) | Ok(Step::Done(o)) => {
            let duty_ok = o.laser_duty >= T::ZERO && o.laser_duty <= T::from_f64(1.0);
            match finite(o.force_n) {
                Out::Finite if !duty_ok => Out::NonFinite,
                out => out,
            }
        }
        Err(_) => Out::Refused,
    }
}

fn axis_sites<T: Real>(s: &mut Sweep, scalar: &str) {
    const M: &str = "app";
    let law = AxisLaw::<T>::new(&AxisConfig::LM1247_SLAVE, 1e-4).unwrap();
    let sensor = HallAxis::<T>::new(&HallConfig::LM1247_16BIT).unwrap();
    let hold = Reference {
        position: re::<T>(0.004),
        velocity: T::ZERO,
        acceleration: T::ZERO,
    };
    // A step's output: a fault must come with zero force; otherwise all finite.
    let axis_out = |out: kerf::app::axis::AxisOutput<T>| match out.status {
        AxisStatus::Fault(_) if out.force_n == T::ZERO => {
            finite([out.position_m, out.velocity_m_s, out.disturbance_n]).and(Out::Refused)
        }
        AxisStatus::Fault(_) => Out::NonFinite,
        _ => finite([
            out.force_n,
            out.position_m,
            out.velocity_m_s,
            out.disturbance_n,
        ]),
    };
    type Edit = fn(&mut AxisConfig, f64);
    let edits: [(&str, Edit); 6] = [
        ("velocity.bandwidth_rad_s", |c, v| {
            c.velocity.bandwidth_rad_s = v
        }),
        ("pd.kp_per_s2", |c, v| c.pd.kp_per_s2 = v),
        ("pd.kd_per_s", |c, v| c.pd.kd_per_s = v),
        ("dob.nominal_mass_kg", |c, v| c.dob.nominal_mass_kg = v),
        ("dob.bandwidth_rad_s", |c, v| c.dob.bandwidth_rad_s = v),
        ("dob.force_limit_n", |c, v| c.dob.force_limit_n = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("AxisLaw::new({field}) + step"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = AxisConfig::LM1247_SLAVE;
                edit(&mut config, v);
                refused_or(AxisLaw::<T>::new(&config, 1e-4), |law| {
                    let mut state = AxisState::homed_at(re::<T>(0.004));
                    let mut out = Out::Finite;
                    for k in 0..10 {
                        out = out.and(axis_out(law.step(
                            &sensor,
                            &mut state,
                            counts(0.01 * k as f64),
                            &hold,
                        )));
                    }
                    out
                })
            },
        );
    }
    s.site(
        M,
        "AxisLaw::new(period_s) + step",
        scalar,
        Kind::Config,
        |v| {
            refused_or(AxisLaw::<T>::new(&AxisConfig::LM1247_SLAVE, v), |law| {
                let mut state = AxisState::homed_at(re::<T>(0.004));
                axis_out(law.step(&sensor, &mut state, counts(0.0), &hold))
            })
        },
    );
    s.site(
        M,
        "HallAxis::new(pitch_m) + step",
        scalar,
        Kind::Config,
        |v| {
            let config = HallConfig {
                pitch_m: v,
                ..HallConfig::LM1247_16BIT
            };
            refused_or(HallAxis::<T>::new(&config), |sensor| {
                let mut state = AxisState::homed_at(re::<T>(0.004));
                let mut out = Out::Finite;
                for k in 0..10 {
                    out = out.and(axis_out(law.step(
                        &sensor,
                        &mut state,
                        counts(0.3 * k as f64),
                        &hold,
                    )));
                }
                out
            })
        },
    );
    for (name, which) in [
        ("position", 0),
        ("velocity", 1),
        ("acceleration", 2),
        ("home", 3),
    ] {
        s.site(
            M,
            &format!("AxisLaw::step(reference.{name})"),
            scalar,
            Kind::Step,
            |v| {
                let x = re::<T>(v);
                let mut r = hold;
                let home = if which == 3 { x } else { re::<T>(0.004) };
                match which {
                    0 => r.position = x,
                    1 => r.velocity = x,
                    2 => r.acceleration = x,
                    _ => {}
                }
                let mut state = AxisState::homed_at(home);
                let mut out = Out::Finite;
                for k in 0..5 {
                    out = out.and(axis_out(law.step(
                        &sensor,
                        &mut state,
                        counts(0.01 * k as f64),
                        &r,
                    )));
                }
                out
            },
        );
    }
    s.site(
        M,
        "AxisLaw::step/monitor(counts)",
        scalar,
        Kind::Step,
        |v| {
            let mut state = AxisState::homed_at(re::<T>(0.004));
            let a = axis_out(law.step(&sensor, &mut state, counts(0.0), &hold));
            let b = axis_out(law.step(&sensor, &mut state, bad_counts(v), &hold));
            let mut monitored = AxisState::homed_at(re::<T>(0.004));
            let c = match law.monitor(&sensor, &mut monitored, bad_counts(v)) {
                Ok(()) => finite([monitored.position_m(), monitored.velocity_m_s()]),
                Err(_) => Out::Refused,
            };
            a.and(b).and(c)
        },
    );
}

fn joints_sites<T: Real>(s: &mut Sweep, scalar: &str) {
    const M: &str = "app";
    let nominal = JointsConfig::LM1247;
    let here = counts(0.3);
    let job = |target: f64, duration: f64| -> JointJob<1> {
        let mut j = JointJob::new();
        j.push(Segment {
            target_m: [target],
            duration_s: duration,
        })
        .unwrap();
        j
    };
    let run_job = |mut m: Joints<T, 1>, job: JointJob<1>, periods: usize| -> Out {
        let mut out = refused_or(m.monitor(&[here]), |_| Out::Finite);
        if out == Out::Refused {
            return out;
        }
        if m.check_job(&job).is_err() || m.begin_job(&job).is_err() {
            return Out::Refused;
        }
        for _ in 0..periods {
            let r = m.run(&job, &[here]);
            let refused = r.is_err();
            out = out.and(machine_step(r));
            if refused {
                break;
            }
        }
        m.begin_stop();
        for _ in 0..5 {
            out = out.and(machine_step(m.stop(&job, &[here])));
        }
        out
    };
    type Edit = fn(&mut JointsConfig<1>, f64);
    let edits: [(&str, Edit); 6] = [
        ("period_s", |c, v| c.period_s = v),
        ("home_m[0]", |c, v| c.home_m[0] = v),
        ("travel_m[0][0]", |c, v| c.travel_m[0][0] = v),
        ("travel_m[0][1]", |c, v| c.travel_m[0][1] = v),
        ("speed_limit_m_s", |c, v| c.speed_limit_m_s = v),
        ("accel_limit_m_s2", |c, v| c.accel_limit_m_s2 = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("Joints::new({field}) + job"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = nominal;
                edit(&mut config, v);
                refused_or(Joints::<T, 1>::new(&config), |m| {
                    run_job(m, job(0.0053, 0.05), 60)
                })
            },
        );
    }
    s.site(M, "Joints job(target_m)", scalar, Kind::Config, |v| {
        run_job(Joints::<T, 1>::new(&nominal).unwrap(), job(v, 0.05), 60)
    });
    s.site(M, "Joints job(duration_s)", scalar, Kind::Config, |v| {
        run_job(Joints::<T, 1>::new(&nominal).unwrap(), job(0.0053, v), 60)
    });
    s.site(M, "Joints::run(counts mid-job)", scalar, Kind::Step, |v| {
        let mut m = Joints::<T, 1>::new(&nominal).unwrap();
        if m.monitor(&[here]).is_err() {
            return Out::NonFinite;
        }
        let job = job(0.0053, 0.05);
        m.begin_job(&job).unwrap();
        let mut out = machine_step(m.run(&job, &[here]));
        out = out.and(machine_step(m.run(&job, &[bad_counts(v)])));
        out.and(machine_step(m.run(&job, &[here])))
    });
}

fn delta_slave_sites<T: Float>(s: &mut Sweep, scalar: &str) {
    const M: &str = "app";
    let config = DeltaSlaveConfig::KEOPS;
    let geometry = DeltaGeometry::<f64>::new(&config.delta).unwrap();
    let centre = geometry.forward(&Vector3::new(0.01, 0.01, 0.01)).unwrap();
    let here = [counts(0.3); 3];
    let plan = |config: &DeltaSlaveConfig,
                start: [f64; 3],
                approach_s: f64,
                target: [f64; 3],
                duration_s: f64| {
        DeltaJob::plan(
            config,
            start,
            approach_s,
            &[Segment {
                target_m: target,
                duration_s,
            }],
        )
    };
    let start = [centre.x, centre.y, centre.z + 0.002];
    let target = [centre.x + 0.003, centre.y, centre.z + 0.002];
    let run = |config: &DeltaSlaveConfig, job: DeltaJob, periods: usize| -> Out {
        refused_or(DeltaSlave::<T>::new(config), |mut m| {
            if m.monitor(&here).is_err() {
                return Out::Refused;
            }
            if m.check_job(&job).is_err() || m.begin_job(&job).is_err() {
                return Out::Refused;
            }
            let mut out = Out::Finite;
            for _ in 0..periods {
                let r = m.run(&job, &here);
                let refused = r.is_err();
                out = out.and(slave_step(r));
                if refused {
                    break;
                }
            }
            out
        })
    };
    for axis in 0..3 {
        s.site(
            M,
            &format!("DeltaJob::plan(start_m[{axis}]) + run"),
            scalar,
            Kind::Config,
            |v| {
                let mut st = start;
                st[axis] = v;
                refused_or(plan(&config, st, 0.05, target, 0.05), |job| {
                    run(&config, job, 20)
                })
            },
        );
        s.site(
            M,
            &format!("DeltaJob::plan(target_m[{axis}]) + run"),
            scalar,
            Kind::Config,
            |v| {
                let mut t = target;
                t[axis] = v;
                refused_or(plan(&config, start, 0.05, t, 0.05), |job| {
                    run(&config, job, 20)
                })
            },
        );
    }
    s.site(
        M,
        "DeltaJob::plan(approach_s) + run",
        scalar,
        Kind::Config,
        |v| {
            refused_or(plan(&config, start, v, target, 0.05), |job| {
                run(&config, job, 20)
            })
        },
    );
    s.site(
        M,
        "DeltaJob::plan(duration_s) + run",
        scalar,
        Kind::Config,
        |v| {
            refused_or(plan(&config, start, 0.05, target, v), |job| {
                run(&config, job, 20)
            })
        },
    );
    type Edit = fn(&mut DeltaSlaveConfig, f64);
    let edits: [(&str, Edit); 5] = [
        ("delta.actuators[0].arm_m", |c, v| {
            c.delta.actuators[0].arm_m = v
        }),
        ("delta.actuators[2].travel_max_m", |c, v| {
            c.delta.actuators[2].travel_max_m = v
        }),
        ("joints.home_m[1]", |c, v| c.joints.home_m[1] = v),
        ("joints.period_s", |c, v| c.joints.period_s = v),
        ("joints.speed_limit_m_s", |c, v| {
            c.joints.speed_limit_m_s = v
        }),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("DeltaSlave::new({field}) + plan + run"),
            scalar,
            Kind::Config,
            |v| {
                let mut c = config;
                edit(&mut c, v);
                refused_or(plan(&c, start, 0.05, target, 0.05), |job| run(&c, job, 20))
            },
        );
    }
    s.site(
        M,
        "DeltaSlave::run(counts mid-move)",
        scalar,
        Kind::Step,
        |v| {
            // The approach (0.05 s = 500 periods) ends before the bad sample.
            let job = plan(&config, start, 0.05, target, 0.05).unwrap();
            let mut m = DeltaSlave::<T>::new(&config).unwrap();
            m.monitor(&here).unwrap();
            m.begin_job(&job).unwrap();
            let mut out = Out::Finite;
            for k in 0..560 {
                let inputs = if k == 520 {
                    [here[0], bad_counts(v), here[2]]
                } else {
                    here
                };
                let r = m.run(&job, &inputs);
                let refused = r.is_err();
                out = out.and(slave_step(r));
                if refused {
                    break;
                }
            }
            out
        },
    );
}

fn clock_sites(s: &mut Sweep) {
    const M: &str = "app";
    s.site(
        M,
        "PeriodClock::new(period_s) + start",
        "-",
        Kind::Config,
        |v| {
            refused_or(PeriodClock::new(v, 170_000_000), |mut c| {
                c.start(0);
                c.start(u64::MAX);
                c.start(5);
                Out::Finite
            })
        },
    );
    s.site(M, "PeriodClock::new(tick_hz = v)", "-", Kind::Config, |v| {
        refused_or(PeriodClock::new(1e-4, v as u64), |_| Out::Finite)
    });
}

#[test]
fn bad_input_machines() {
    sweep(|s| {
        axis_sites::<f32>(s, "f32");
        axis_sites::<f64>(s, "f64");
        joints_sites::<f32>(s, "f32");
        joints_sites::<f64>(s, "f64");
        delta_slave_sites::<f32>(s, "f32");
        delta_slave_sites::<f64>(s, "f64");
        clock_sites(s);
    });
}
