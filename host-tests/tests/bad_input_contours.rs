//! The bad-input sweep ([`host_tests::bad_input`]): closed contours: EFD, the contour
//! follower and its speed ramp, the shapes, degenerate geometry.

use host_tests::bad_input::{
    finite, finite_f64, re, refused_or, some_or, sweep, to_t, v2, Kind, Out, Sweep,
};
use kerf::trajectory::constraint::{ConstraintConfig, MotionConstraint};
use kerf::trajectory::efd::Efd;
use kerf::trajectory::resample::{self, ArcResampler};
use kerf::trajectory::shapes;
use kerf::trajectory::tangential::{
    max_speed_m_s, ContourFollower, FollowerConfig, SpeedRamp, SpeedRampConfig,
};
use kerf::Float;
use nalgebra::{Vector2, Vector3};

// ---------------------------------------------------------------------------------
// trajectory

fn follower_config() -> FollowerConfig {
    FollowerConfig {
        ramp: SpeedRampConfig {
            speed_m_s: 0.01,
            accel_m_s2: 0.5,
            jerk_m_s3: 50.0,
            ts_s: 1e-3,
        },
        accel_limit_m_s2: 10.0,
        newton_steps: 2,
    }
}

/// Steps a follower `periods` times: every output finite, and each step's chord at
/// most the arc the ramp commanded (plus rounding): θ must not run away.
fn follow<T: Float, const N: usize>(mut f: ContourFollower<T, N>, periods: usize) -> Out {
    let speed = to_t(f.ramp().speed());
    let ts = follower_ts(&f);
    f.start();
    let mut previous: Option<Vector2<T>> = None;
    for _ in 0..periods {
        let Ok(r) = f.step() else {
            return Out::Refused;
        };
        let out = finite(
            v2(&r.position)
                .into_iter()
                .chain(v2(&r.velocity))
                .chain(v2(&r.acceleration))
                .chain(v2(&r.jerk))
                .chain([r.speed, r.theta]),
        );
        if out != Out::Finite {
            return out;
        }
        if let Some(p) = previous {
            let chord = to_t((r.position - p).norm());
            if chord > 1.5 * speed * ts + 1e-9 {
                return Out::Runaway;
            }
        }
        previous = Some(r.position);
    }
    Out::Finite
}

fn follower_ts<T: Float, const N: usize>(_: &ContourFollower<T, N>) -> f64 {
    1e-3
}

fn efd_probe<T: Float, const N: usize>(efd: &Efd<T, N>) -> Out {
    let mut out =
        finite(efd.coefficients().iter().flatten().copied()).and(finite(v2(&efd.centre())));
    for k in 0..16 {
        let s = efd.evaluate(re::<T>(k as f64 * 0.4));
        out = out.and(finite(
            v2(&s.position)
                .into_iter()
                .chain(v2(&s.d1))
                .chain(v2(&s.d2))
                .chain(v2(&s.d3)),
        ));
    }
    out
}

fn contour_sites<T: Float>(s: &mut Sweep, scalar: &str) {
    const M: &str = "trajectory";
    let octagon = shapes::octagon();
    // Efd
    s.site(
        M,
        "Efd::from_polygon(point[3].x) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let mut p = octagon;
            p[3][0] = v;
            refused_or(Efd::<T, 10>::from_polygon(&p, 10), |e| efd_probe(&e))
        },
    );
    s.site(
        M,
        "Efd::from_polygon(points × v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let p = octagon.map(|[x, y]| [x * v, y * v]);
            refused_or(Efd::<T, 10>::from_polygon(&p, 10), |e| efd_probe(&e))
        },
    );
    s.site(
        M,
        "Efd::from_polygon(points + v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let p = octagon.map(|[x, y]| [x + v, y - v]);
            refused_or(Efd::<T, 10>::from_polygon(&p, 10), |e| efd_probe(&e))
        },
    );
    s.site(
        M,
        "Efd::from_coefficients(b1) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                Efd::<T, 4>::from_coefficients(
                    [0.0, 0.0],
                    &[[0.01, v, 0.0, 0.01], [1e-3, 0.0, 0.0, 0.0]],
                ),
                |e| efd_probe(&e),
            )
        },
    );
    s.site(
        M,
        "Efd::from_coefficients(centre) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                Efd::<T, 4>::from_coefficients([v, 0.0], &[[0.01, 0.0, 0.0, 0.01]]),
                |e| efd_probe(&e),
            )
        },
    );
    let efd = Efd::<T, 10>::from_polygon(&octagon, 10).unwrap();
    s.site(M, "Efd::evaluate(theta)", scalar, Kind::Kernel, |v| {
        let s = efd.evaluate(re::<T>(v));
        finite(
            v2(&s.position)
                .into_iter()
                .chain(v2(&s.d1))
                .chain(v2(&s.d2))
                .chain(v2(&s.d3)),
        )
    });
    s.site(
        M,
        "Efd::arc_length/curvature(theta)",
        scalar,
        Kind::Kernel,
        |v| {
            let t = re::<T>(v);
            finite([efd.arc_length(T::ZERO, t, 8), efd.curvature(t)])
        },
    );
    s.site(M, "max_speed_m_s(accel_limit)", scalar, Kind::Config, |v| {
        refused_or(max_speed_m_s(&efd, v), |speed| finite_f64([speed]))
    });
    // ContourFollower
    type Edit = fn(&mut FollowerConfig, f64);
    let edits: [(&str, Edit); 5] = [
        ("speed_m_s", |c, v| c.ramp.speed_m_s = v),
        ("accel_m_s2", |c, v| c.ramp.accel_m_s2 = v),
        ("jerk_m_s3", |c, v| c.ramp.jerk_m_s3 = v),
        ("ts_s", |c, v| c.ramp.ts_s = v),
        ("accel_limit_m_s2", |c, v| c.accel_limit_m_s2 = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("ContourFollower::new({field}) + step"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = follower_config();
                edit(&mut config, v);
                refused_or(ContourFollower::new(efd, &config, 0.0), |f| {
                    // Only the chord check needs the nominal period.
                    let mut f = f;
                    f.start();
                    let mut out = Out::Finite;
                    for _ in 0..300 {
                        let Ok(r) = f.step() else {
                            return Out::Refused;
                        };
                        out = out.and(finite(
                            v2(&r.position)
                                .into_iter()
                                .chain(v2(&r.velocity))
                                .chain(v2(&r.acceleration))
                                .chain(v2(&r.jerk))
                                .chain([r.speed, r.theta]),
                        ));
                    }
                    out
                })
            },
        );
    }
    s.site(
        M,
        "ContourFollower::new(theta0) + step",
        scalar,
        Kind::Config,
        |v| {
            refused_or(ContourFollower::new(efd, &follower_config(), v), |f| {
                follow(f, 300)
            })
        },
    );
    // SpeedRamp
    type RampEdit = fn(&mut SpeedRampConfig, f64);
    let ramp_edits: [(&str, RampEdit); 4] = [
        ("speed_m_s", |c, v| c.speed_m_s = v),
        ("accel_m_s2", |c, v| c.accel_m_s2 = v),
        ("jerk_m_s3", |c, v| c.jerk_m_s3 = v),
        ("ts_s", |c, v| c.ts_s = v),
    ];
    for (field, edit) in ramp_edits {
        s.site(
            M,
            &format!("SpeedRamp::new({field}) + step"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = follower_config().ramp;
                edit(&mut config, v);
                refused_or(SpeedRamp::<T>::new(&config), |mut r| {
                    r.start();
                    let mut out = Out::Finite;
                    for k in 0..400 {
                        if k == 200 {
                            r.stop();
                        }
                        let p = r.step();
                        out = out.and(finite([p.ds, p.v, p.a, p.j]));
                    }
                    out.and(finite_f64([r.ramp_distance_m()]))
                })
            },
        );
    }
}

/// Shapes are f64 test data (no scalar).
fn shape_sites(s: &mut Sweep) {
    const M: &str = "trajectory";
    s.site(
        M,
        "shapes::regular_polygon(radius_m)",
        "-",
        Kind::Kernel,
        |v| {
            let p: [[f64; 2]; 12] = shapes::regular_polygon(6, v);
            finite_f64(p.iter().flatten().copied())
        },
    );
    s.site(M, "shapes::ellipse(a_m)", "-", Kind::Kernel, |v| {
        let p: [[f64; 2]; 16] = shapes::ellipse(v, 0.01);
        finite_f64(p.iter().flatten().copied())
    });
    s.site(
        M,
        "shapes::regular_polygon(sides = v)",
        "-",
        Kind::Config,
        |v| {
            let p: [[f64; 2]; 12] = shapes::regular_polygon(v as usize, 0.01);
            finite_f64(p.iter().flatten().copied())
        },
    );
}

/// Degenerate closed contours: collinear, nearly collinear (flattened by `v`), a
/// back-and-forth stroke, and a contour whose follower must not run away.
fn degenerate_geometry<T: Float>(s: &mut Sweep, scalar: &str) {
    const M: &str = "trajectory";
    let octagon = shapes::octagon();
    let config = FollowerConfig {
        accel_limit_m_s2: 1e12,
        newton_steps: 2,
        ..follower_config()
    };
    for flatten in [0.0, 1e-15, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4, 1e-2] {
        s.case(
            M,
            "octagon flattened (y × v): Efd + follower",
            scalar,
            Kind::Step,
            flatten,
            || {
                let p = octagon.map(|[x, y]| [x, y * flatten]);
                refused_or(Efd::<T, 30>::from_polygon(&p, 30), |e| {
                    efd_probe(&e).and(refused_or(ContourFollower::new(e, &config, 0.0), |f| {
                        follow(f, 4000)
                    }))
                })
            },
        );
    }
    for offset in [0.0, 1e-15, 1e-12, 1e-9, 1e-6] {
        s.case(
            M,
            "stroke out and back (offset v): Efd + follower",
            scalar,
            Kind::Step,
            offset,
            || {
                let mut p: Vec<[f64; 2]> = (0..16).map(|k| [k as f64 * 1e-3, 0.0]).collect();
                p.extend((1..15).rev().map(|k| [k as f64 * 1e-3, offset]));
                refused_or(Efd::<T, 30>::from_polygon(&p, 30), |e| {
                    efd_probe(&e).and(refused_or(ContourFollower::new(e, &config, 0.0), |f| {
                        follow(f, 4000)
                    }))
                })
            },
        );
    }
    // A figure of eight: σ = |C′| never vanishes but curvature is high near the centre.
    for n in [1usize, 2, 3] {
        s.case(
            M,
            "two-harmonic curve with a cusp (n = v)",
            scalar,
            Kind::Step,
            n as f64,
            || {
                // x = cos θ + cos 2θ / 4 ... chosen so that C′(θ) = 0 at θ = π (a cusp).
                let coefficients = [[0.01, 0.0, 0.0, 0.01], [0.0, 0.0, 0.0, 0.005 * n as f64]];
                refused_or(
                    Efd::<T, 4>::from_coefficients([0.0, 0.0], &coefficients),
                    |e| {
                        efd_probe(&e).and(refused_or(ContourFollower::new(e, &config, 0.0), |f| {
                            follow(f, 8000)
                        }))
                    },
                )
            },
        );
    }
    // Collinear, repeated and coincident open data.
    let cases: [(&str, Vec<[f64; 2]>); 4] = [
        (
            "open: collinear",
            (0..8).map(|k| [k as f64 * 1e-3, 0.0]).collect(),
        ),
        (
            "open: repeated point",
            vec![[0.0, 0.0], [1e-3, 0.0], [1e-3, 0.0], [2e-3, 1e-3]],
        ),
        ("open: all equal", vec![[1e-3, 1e-3]; 5]),
        (
            "open: 1e-40 apart",
            (0..8).map(|k| [k as f64 * 1e-40, 0.0]).collect(),
        ),
    ];
    for (name, p) in cases {
        s.case(M, name, scalar, Kind::Step, 0.0, || {
            let pt: Vec<[T; 2]> = p.iter().map(|q| q.map(re::<T>)).collect();
            let a = refused_or(ArcResampler::new(&pt), |mut walk| {
                some_or(walk.advance(re::<T>(1e-4)), |s| {
                    finite(v2(&s.position).into_iter().chain(v2(&s.direction)))
                })
            });
            let b = refused_or(resample::densify::<256>(&p, 2), |d| {
                finite_f64(d.iter().flatten().copied())
            });
            let c = refused_or(
                MotionConstraint::<T, 64>::new(
                    &p,
                    &ConstraintConfig {
                        half_window: 1,
                        closed: false,
                        ..ConstraintConfig::closed_contour()
                    },
                ),
                |c| {
                    let x = Vector3::new(c.origin().x, c.origin().y + re::<T>(1e-4), T::ZERO);
                    refused_or(c.evaluate(x, T::ZERO), |r| {
                        finite(v2(&r.phi).into_iter().chain(r.jacobian.iter().copied()))
                    })
                },
            );
            a.and(b).and(c)
        });
    }
}

#[test]
fn bad_input_contours() {
    sweep(|s| {
        contour_sites::<f32>(s, "f32");
        contour_sites::<f64>(s, "f64");
        shape_sites(s);
        degenerate_geometry::<f32>(s, "f32");
        degenerate_geometry::<f64>(s, "f64");
    });
}
