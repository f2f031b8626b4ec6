//! The bad-input sweep ([`host_tests::bad_input`]): the Hall decoder, the tracking
//! observer and the delta kinematics.

use host_tests::bad_input::{
    bad_counts, counts, finite, finite_f64, re, refused_or, sweep, to_t, v3, Kind, Out, Sweep,
};
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::sensing::hall::{HallConfig, HallDecoder, HallState};
use kerf::sensing::velocity::{TrackingObserver, TrackingObserverConfig, TrackingObserverState};
use kerf::{Float, Real};
use nalgebra::Vector3;
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------
// sensing

fn hall_sites(s: &mut Sweep) {
    const M: &str = "sensing";
    type Edit = fn(&mut HallConfig, f64);
    let edits: [(&str, Edit); 10] = [
        ("pitch_m", |c, v| c.pitch_m = v),
        ("fault_error_budget_m", |c, v| c.fault_error_budget_m = v),
        ("amplitude_counts", |c, v| c.amplitude_counts = v),
        ("magnitude_band.0", |c, v| c.magnitude_band.0 = v),
        ("magnitude_band.1", |c, v| c.magnitude_band.1 = v),
        ("sum_limit", |c, v| c.sum_limit = v),
        ("calibration.offset_counts[0]", |c, v| {
            c.calibration.offset_counts[0] = v as f32
        }),
        ("calibration.sin_row[1]", |c, v| {
            c.calibration.sin_row[1] = v as f32
        }),
        ("calibration.cos_row[2]", |c, v| {
            c.calibration.cos_row[2] = v as f32
        }),
        ("calibration.sum_row[0]", |c, v| {
            c.calibration.sum_row[0] = v as f32
        }),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("HallDecoder::new({field}) + update"),
            "-",
            Kind::Config,
            |v| {
                let mut config = HallConfig::LM1247_16BIT;
                edit(&mut config, v);
                refused_or(HallDecoder::new(&config), |decoder| {
                    let mut state = HallState::default();
                    let mut out = Out::Finite;
                    for k in 0..8 {
                        let r = decoder.update(&mut state, counts(0.4 * k as f64), 0);
                        out = out.and(refused_or(r, |p| finite_f64([p.position_m(0.018)])));
                    }
                    out
                })
            },
        );
    }
    s.site(
        M,
        "HallDecoder::update(predicted_step)",
        "-",
        Kind::Step,
        |v| {
            let decoder = HallDecoder::new(&HallConfig::LM1247_16BIT).unwrap();
            let mut state = HallState::default();
            let step = (v * 4_294_967_296.0) as i64;
            let mut out = Out::Finite;
            for k in 0..4 {
                let r = decoder.update(&mut state, counts(0.2 * k as f64), step);
                out = out.and(refused_or(r, |p| finite_f64([p.position_m(0.018)])));
            }
            out
        },
    );
    s.site(M, "HallDecoder::update(counts)", "-", Kind::Step, |v| {
        let decoder = HallDecoder::new(&HallConfig::LM1247_16BIT).unwrap();
        let mut state = HallState::default();
        let r = decoder.update(&mut state, bad_counts(v), 0);
        refused_or(r, |p| finite_f64([p.position_m(0.018)]))
    });
    observer_sites::<f32>(s, "f32");
    observer_sites::<f64>(s, "f64");
}

fn observer_sites<T: Real>(s: &mut Sweep, scalar: &str) {
    const M: &str = "sensing";
    let nominal = TrackingObserverConfig {
        bandwidth_rad_s: 2.0 * PI * 600.0,
    };
    let run = |observer: TrackingObserver<T>| {
        let mut state = TrackingObserverState::at_rest(T::ZERO);
        let mut values = Vec::new();
        for k in 0..20 {
            values.push(observer.update(&mut state, re::<T>(1e-5 * k as f64), T::ZERO));
        }
        finite(values)
    };
    s.site(
        M,
        "TrackingObserver::new(bandwidth_rad_s)",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                TrackingObserver::<T>::new(&TrackingObserverConfig { bandwidth_rad_s: v }, 1e-4),
                run,
            )
        },
    );
    s.site(
        M,
        "TrackingObserver::new(ts_s)",
        scalar,
        Kind::Config,
        |v| refused_or(TrackingObserver::<T>::new(&nominal, v), run),
    );
    // The bandwidth scaled with the period (ω·Ts = 0.4 stays valid), so only the
    // period's own extremes matter.
    s.site(
        M,
        "TrackingObserver::new(ts_s, ω·Ts = 0.4)",
        scalar,
        Kind::Config,
        |v| {
            let config = TrackingObserverConfig {
                bandwidth_rad_s: 0.4 / v,
            };
            refused_or(TrackingObserver::<T>::new(&config, v), run)
        },
    );
    let observer = TrackingObserver::<T>::new(&nominal, 1e-4).unwrap();
    s.site(
        M,
        "TrackingObserver::update(measured)",
        scalar,
        Kind::Kernel,
        |v| {
            let mut state = TrackingObserverState::at_rest(T::ZERO);
            finite([
                observer.update(&mut state, re::<T>(v), T::ZERO),
                state.position,
            ])
        },
    );
    s.site(
        M,
        "TrackingObserver::update(acceleration)",
        scalar,
        Kind::Kernel,
        |v| {
            let mut state = TrackingObserverState::at_rest(T::ZERO);
            finite([
                observer.update(&mut state, T::ZERO, re::<T>(v)),
                state.position,
            ])
        },
    );
}

// ---------------------------------------------------------------------------------
// kinematics

fn delta_sites<T: Float>(s: &mut Sweep, scalar: &str) {
    const M: &str = "kinematics";
    let nominal = DeltaConfig::SLAVE_KEOPS;
    let q_mid = Vector3::new(0.02, 0.02, 0.02);
    let probe = |g: &DeltaGeometry<T>| {
        let q = q_mid.map(re::<T>);
        refused_or(g.forward(&q), |p| {
            finite(v3(&p)).and(refused_or(g.inverse(&p), |q| finite(v3(&q))))
        })
    };
    type Edit = fn(&mut DeltaConfig, f64);
    let edits: [(&str, Edit); 7] = [
        ("theta_rad", |c, v| c.actuators[1].theta_rad = v),
        ("alpha_rad", |c, v| c.actuators[1].alpha_rad = v),
        ("arm_m", |c, v| c.actuators[1].arm_m = v),
        ("base_radius_m", |c, v| c.actuators[1].base_radius_m = v),
        ("effector_radius_m", |c, v| {
            c.actuators[1].effector_radius_m = v
        }),
        ("travel_min_m", |c, v| c.actuators[1].travel_min_m = v),
        ("travel_max_m", |c, v| c.actuators[1].travel_max_m = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("DeltaGeometry::new({field}) + FK/IK"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = nominal;
                edit(&mut config, v);
                refused_or(DeltaGeometry::<T>::new(&config), |g| probe(&g))
            },
        );
    }
    // All lengths scaled by v: a robot of any size, up to what the scalar holds.
    s.site(
        M,
        "DeltaGeometry::new(all lengths × v) + FK/IK",
        scalar,
        Kind::Config,
        |v| {
            let mut config = nominal;
            for a in &mut config.actuators {
                a.arm_m *= v;
                a.base_radius_m *= v;
                a.effector_radius_m *= v;
                a.travel_min_m *= v;
                a.travel_max_m *= v;
            }
            refused_or(DeltaGeometry::<T>::new(&config), |g| {
                let q = (q_mid * v).map(re::<T>);
                refused_or(g.forward(&q), |p| {
                    finite(v3(&p)).and(refused_or(g.inverse(&p), |q| finite(v3(&q))))
                })
            })
        },
    );
    let g = DeltaGeometry::<T>::new(&nominal).unwrap();
    let p_mid = g.forward(&q_mid.map(re::<T>)).unwrap();
    for axis in 0..3 {
        s.site(M, &format!("forward(q[{axis}])"), scalar, Kind::Step, |v| {
            let mut q = q_mid.map(re::<T>);
            q[axis] = re::<T>(v);
            refused_or(g.forward(&q), |p| finite(v3(&p)))
        });
        s.site(M, &format!("inverse(p[{axis}])"), scalar, Kind::Step, |v| {
            let mut p = p_mid;
            p[axis] = re::<T>(v);
            refused_or(g.inverse(&p), |q| finite(v3(&q)))
        });
        s.site(
            M,
            &format!("jacobian(q[{axis}]), jacobian(p[{axis}])"),
            scalar,
            Kind::Step,
            |v| {
                let (mut q, mut p) = (q_mid.map(re::<T>), p_mid);
                q[axis] = re::<T>(v);
                let a = refused_or(g.jacobian(&q, &p_mid), |j| finite(j.iter().copied()));
                p[axis] = re::<T>(v);
                let q = q_mid.map(re::<T>);
                a.and(refused_or(g.jacobian(&q, &p), |j| {
                    finite(j.iter().copied())
                }))
            },
        );
        s.site(
            M,
            &format!("jacobian_inverse(p[{axis}])"),
            scalar,
            Kind::Step,
            |v| {
                let mut p = p_mid;
                p[axis] = re::<T>(v);
                let q = q_mid.map(re::<T>);
                refused_or(g.jacobian_inverse(&q, &p), |j| finite(j.iter().copied()))
            },
        );
        s.site(
            M,
            &format!("jacobian_derivative(q_dot[{axis}])"),
            scalar,
            Kind::Step,
            |v| {
                let mut q_dot = Vector3::new(T::ZERO, T::ZERO, T::ZERO);
                q_dot[axis] = re::<T>(v);
                let q = q_mid.map(re::<T>);
                refused_or(g.jacobian_derivative(&q, &p_mid, &q_dot), |j| {
                    finite(j.iter().copied())
                })
            },
        );
    }
    // Geometry: the travel box's corners and beyond, and rays from the workspace
    // centre out past the reach (arms stretched: singular J1, then out of reach).
    let corners: Vec<Vector3<f64>> = (0..27)
        .map(|k| {
            let pick =
                |i: usize| [-0.01, 0.0, 0.04, 0.05][(k / 3usize.pow(i as u32)) % 3 + (k % 2)];
            Vector3::new(pick(0), pick(1), pick(2))
        })
        .collect();
    for (i, q) in corners.iter().enumerate() {
        s.case(
            M,
            "forward/jacobians at travel corners",
            scalar,
            Kind::Step,
            i as f64,
            || {
                let q = q.map(re::<T>);
                refused_or(g.forward(&q), |p| {
                    let j = refused_or(g.jacobian(&q, &p), |j| finite(j.iter().copied()));
                    let ji = refused_or(g.jacobian_inverse(&q, &p), |j| finite(j.iter().copied()));
                    finite(v3(&p)).and(j).and(ji)
                })
            },
        );
    }
    for direction in 0..12 {
        let angle = direction as f64 * PI / 6.0;
        for step in 0..24 {
            let reach = 0.005 * step as f64;
            let elevation = if direction % 2 == 0 { 0.0 } else { reach };
            s.case(
                M,
                "IK/jacobians on rays past the reach",
                scalar,
                Kind::Step,
                reach,
                || {
                    let p = Vector3::new(
                        to_t::<T>(p_mid.x) + reach * angle.cos(),
                        to_t::<T>(p_mid.y) + reach * angle.sin(),
                        to_t::<T>(p_mid.z) + elevation,
                    )
                    .map(re::<T>);
                    refused_or(g.inverse(&p), |q| {
                        let j = refused_or(g.jacobian(&q, &p), |j| finite(j.iter().copied()));
                        let jd = refused_or(
                            g.jacobian_derivative(
                                &q,
                                &p,
                                &Vector3::new(T::one(), T::ZERO, T::ZERO),
                            ),
                            |j| finite(j.iter().copied()),
                        );
                        finite(v3(&q)).and(j).and(jd)
                    })
                },
            );
        }
    }
}

#[test]
fn bad_input_sensing() {
    sweep(|s| {
        hall_sites(s);
        delta_sites::<f32>(s, "f32");
        delta_sites::<f64>(s, "f64");
    });
}
