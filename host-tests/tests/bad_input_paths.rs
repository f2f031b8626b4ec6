//! The bad-input sweep ([`host_tests::bad_input`]): paths: quintic moves, arc
//! resampling, joint splines, the motion constraint and the circle fits.

use host_tests::bad_input::{
    finite, finite_f64, re, reference_values, refused_or, some_or, sweep, v2, v3, Kind, Out, Sweep,
};
use kerf::trajectory::constraint::{
    fit_geometric, fit_kasa, fit_taubin, ConstraintConfig, MotionConstraint,
};
use kerf::trajectory::quintic::Quintic;
use kerf::trajectory::resample::{self, ArcResampler};
use kerf::trajectory::shapes;
use kerf::trajectory::spline::{JointSpline, KnotTiming};
use kerf::Float;
use nalgebra::{Vector2, Vector3};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------
// trajectory

fn path_sites<T: Float>(s: &mut Sweep, scalar: &str) {
    const M: &str = "trajectory";
    // Quintic
    type QuinticArgs = fn(f64) -> (f64, f64, f64);
    let quintic_args: [(&str, QuinticArgs); 3] = [
        ("start_m", |v| (v, 0.03, 0.4)),
        ("distance_m", |v| (0.0, v, 0.4)),
        ("duration_s", |v| (0.0, 0.03, v)),
    ];
    for (field, args) in quintic_args {
        s.site(
            M,
            &format!("Quintic::new({field}) + sample"),
            scalar,
            Kind::Config,
            |v| {
                let (start, distance, duration) = args(v);
                refused_or(Quintic::<T>::new(start, distance, duration), |q| {
                    let mut out = Out::Finite;
                    for k in 0..=10 {
                        let t = re::<T>(0.1 * k as f64) * re::<T>(duration.abs().min(1e30));
                        out = out.and(finite(reference_values(&q.sample(t))));
                    }
                    out
                })
            },
        );
    }
    let quintic = Quintic::<T>::new(0.0, 0.03, 0.4).unwrap();
    s.site(M, "Quintic::sample(t_s)", scalar, Kind::Kernel, |v| {
        finite(reference_values(&quintic.sample(re::<T>(v))))
    });
    // ArcResampler, resample, densify
    let open: Vec<[f64; 2]> = shapes::letter_s().to_vec();
    s.site(
        M,
        "ArcResampler::new(point[4].y) + advance",
        scalar,
        Kind::Config,
        |v| {
            let mut p: Vec<[T; 2]> = open.iter().map(|q| q.map(re::<T>)).collect();
            p[4][1] = re::<T>(v);
            refused_or(ArcResampler::new(&p), |mut walk| {
                let mut out = Out::Finite;
                for _ in 0..50 {
                    if let Some(s) = walk.advance(re::<T>(1e-3)) {
                        out = out.and(finite(v2(&s.position).into_iter().chain(v2(&s.direction))));
                    }
                }
                out
            })
        },
    );
    s.site(
        M,
        "ArcResampler::new(points × v) + advance",
        scalar,
        Kind::Config,
        |v| {
            let p: Vec<[T; 2]> = open.iter().map(|q| q.map(|c| re::<T>(c * v))).collect();
            refused_or(ArcResampler::new(&p), |mut walk| {
                let mut out = Out::Finite;
                for _ in 0..50 {
                    if let Some(s) = walk.advance(re::<T>(1e-3 * v.abs().min(1e30))) {
                        out = out.and(finite(v2(&s.position).into_iter().chain(v2(&s.direction))));
                    }
                }
                out
            })
        },
    );
    let open_t: Vec<[T; 2]> = open.iter().map(|q| q.map(re::<T>)).collect();
    s.site(M, "ArcResampler::advance(ds)", scalar, Kind::Step, |v| {
        let mut walk = ArcResampler::new(&open_t).unwrap();
        walk.advance(re::<T>(1e-3));
        let a = some_or(walk.advance(re::<T>(v)), |s| {
            finite(v2(&s.position).into_iter().chain(v2(&s.direction)))
        });
        let b = some_or(walk.current(), |s| {
            finite(v2(&s.position).into_iter().chain(v2(&s.direction)))
        });
        a.and(b)
    });
    s.site(M, "resample(step_m)", scalar, Kind::Config, |v| {
        refused_or(resample::resample::<T, 4096>(&open_t, v), |pts| {
            finite(pts.iter().flat_map(v2))
        })
    });
    s.site(M, "densify(point[2].x)", "-", Kind::Config, |v| {
        let mut p = open.clone();
        p[2][0] = v;
        refused_or(resample::densify::<4096>(&p, 3), |pts| {
            finite_f64(pts.iter().flatten().copied())
        })
    });
    // JointSpline
    let task: Vec<Vector3<f64>> = (0..12)
        .map(|k| Vector3::new(1e-3 * k as f64, 2e-3 * (k as f64 * 0.3).sin(), 0.05))
        .collect();
    let evaluate_all = |sp: &JointSpline<T, 32>| {
        let mut out = Out::Finite;
        for k in 0..=40 {
            let r = sp.evaluate(sp.periods() * k / 40);
            out = out.and(finite(
                v3(&r.q)
                    .into_iter()
                    .chain(v3(&r.qd))
                    .chain(v3(&r.qdd))
                    .chain(v3(&r.qddd)),
            ));
        }
        out
    };
    let id = |p: Vector3<f64>| Ok::<_, ()>(p);
    let z = Vector3::zeros();
    s.site(
        M,
        "JointSpline::fit(sample[5].y) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let mut t = task.clone();
            t[5].y = v;
            refused_or(
                JointSpline::<T, 32>::fit(&t, timing(1e-3), z, z, id),
                |sp| evaluate_all(&sp),
            )
        },
    );
    s.site(
        M,
        "JointSpline::fit(samples × v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let t: Vec<_> = task.iter().map(|p| p * v).collect();
            refused_or(
                JointSpline::<T, 32>::fit(&t, timing(1e-3), z, z, id),
                |sp| evaluate_all(&sp),
            )
        },
    );
    s.site(
        M,
        "JointSpline::fit(timing.period_s) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                JointSpline::<T, 32>::fit(&task, timing(v), z, z, id),
                |sp| evaluate_all(&sp),
            )
        },
    );
    s.site(
        M,
        "JointSpline::fit(start_velocity.x) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                JointSpline::<T, 32>::fit(&task, timing(1e-3), Vector3::new(v, 0.0, 0.0), z, id),
                |sp| evaluate_all(&sp),
            )
        },
    );
    s.site(
        M,
        "JointSpline::fit(joint map returns v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let map = |p: Vector3<f64>| Ok::<_, ()>(Vector3::new(p.x, v, p.z));
            refused_or(
                JointSpline::<T, 32>::fit(&task, timing(1e-3), z, z, map),
                |sp| evaluate_all(&sp),
            )
        },
    );
    let spline = JointSpline::<T, 32>::fit(&task, timing(1e-3), z, z, id).unwrap();
    s.site(
        M,
        "JointSpline::evaluate(period = v)",
        scalar,
        Kind::Step,
        |v| {
            let r = spline.evaluate(v as u64);
            finite(
                v3(&r.q)
                    .into_iter()
                    .chain(v3(&r.qd))
                    .chain(v3(&r.qdd))
                    .chain(v3(&r.qddd)),
            )
        },
    );
    s.site(
        M,
        "JointSpline::evaluate_at(knot 3, offset_s)",
        scalar,
        Kind::Step,
        |v| {
            let r = spline.evaluate_at(3, re::<T>(v));
            finite(
                v3(&r.q)
                    .into_iter()
                    .chain(v3(&r.qd))
                    .chain(v3(&r.qdd))
                    .chain(v3(&r.qddd)),
            )
        },
    );
    // MotionConstraint and the circle fits
    let cam = shapes::cam();
    let constraint_probe = |c: MotionConstraint<T, 512>, scale: f64| {
        let mut out = Out::Finite;
        for k in 0..8 {
            let a = k as f64 * PI / 4.0;
            let x = Vector3::new(0.01 * a.cos() * scale, 0.01 * a.sin() * scale, 0.0).map(re::<T>);
            let x = x + Vector3::new(c.origin().x, c.origin().y, T::ZERO);
            out = out.and(refused_or(c.evaluate(x, T::ZERO), |r| {
                finite(v2(&r.phi).into_iter().chain(r.jacobian.iter().copied()))
            }));
        }
        out
    };
    s.site(
        M,
        "MotionConstraint::new(point[7].x) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let mut p = cam;
            p[7][0] = v;
            refused_or(
                MotionConstraint::<T, 512>::new(&p, &ConstraintConfig::closed_contour()),
                |c| constraint_probe(c, 1.0),
            )
        },
    );
    s.site(
        M,
        "MotionConstraint::new(points × v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let p = cam.map(|[x, y]| [x * v, y * v]);
            refused_or(
                MotionConstraint::<T, 512>::new(&p, &ConstraintConfig::closed_contour()),
                |c| constraint_probe(c, v.abs().min(1e30)),
            )
        },
    );
    s.site(
        M,
        "MotionConstraint::new(line_sagitta_m) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let config = ConstraintConfig {
                line_sagitta_m: v,
                ..ConstraintConfig::closed_contour()
            };
            refused_or(MotionConstraint::<T, 512>::new(&cam, &config), |c| {
                constraint_probe(c, 1.0)
            })
        },
    );
    let constraint =
        MotionConstraint::<T, 512>::new(&cam, &ConstraintConfig::closed_contour()).unwrap();
    for axis in 0..3 {
        s.site(
            M,
            &format!("MotionConstraint::evaluate(x[{axis}])"),
            scalar,
            Kind::Step,
            |v| {
                let mut x = Vector3::new(constraint.origin().x, constraint.origin().y, T::ZERO);
                x[axis] = re::<T>(v);
                refused_or(constraint.evaluate(x, T::ZERO), |r| {
                    finite(v2(&r.phi).into_iter().chain(r.jacobian.iter().copied()))
                })
            },
        );
    }
    s.site(
        M,
        "MotionConstraint::evaluate(z_ref)",
        scalar,
        Kind::Step,
        |v| {
            let x = Vector3::new(constraint.origin().x, constraint.origin().y, T::ZERO);
            refused_or(constraint.evaluate(x, re::<T>(v)), |r| {
                finite(v2(&r.phi).into_iter().chain(r.jacobian.iter().copied()))
            })
        },
    );
    let arc: Vec<Vector2<f64>> = (0..11)
        .map(|k| {
            let a = 0.1 * k as f64;
            Vector2::new(0.01 * a.cos(), 0.01 * a.sin())
        })
        .collect();
    s.site(
        M,
        "fit_kasa/taubin/geometric(point[3].x)",
        scalar,
        Kind::Step,
        |v| {
            let mut p: Vec<Vector2<T>> = arc.iter().map(|q| q.map(re::<T>)).collect();
            p[3].x = re::<T>(v);
            let a = some_or(fit_kasa(&p), |(c, r)| finite(v2(&c).into_iter().chain([r])));
            let b = some_or(fit_taubin(&p), |(c, e)| finite(v2(&c).into_iter().chain(e)));
            let start = (Vector2::new(T::ZERO, T::ZERO), re::<T>(0.01));
            let c = some_or(fit_geometric(&p, start, 10), |(c, r)| {
                finite(v2(&c).into_iter().chain([r]))
            });
            a.and(b).and(c)
        },
    );
    s.site(
        M,
        "fit_kasa/taubin/geometric(points × v)",
        scalar,
        Kind::Step,
        |v| {
            let p: Vec<Vector2<T>> = arc.iter().map(|q| (q * v).map(re::<T>)).collect();
            let a = some_or(fit_kasa(&p), |(c, r)| finite(v2(&c).into_iter().chain([r])));
            let b = some_or(fit_taubin(&p), |(c, e)| finite(v2(&c).into_iter().chain(e)));
            let start = (Vector2::new(T::ZERO, T::ZERO), re::<T>(0.01 * v));
            let c = some_or(fit_geometric(&p, start, 10), |(c, r)| {
                finite(v2(&c).into_iter().chain([r]))
            });
            a.and(b).and(c)
        },
    );
}

/// Knots every 10 control periods of `period_s`, from period 0.
fn timing(period_s: f64) -> KnotTiming {
    KnotTiming {
        period_s,
        periods_per_knot: 10,
        first_period: 0,
    }
}

#[test]
fn bad_input_paths() {
    sweep(|s| {
        path_sites::<f32>(s, "f32");
        path_sites::<f64>(s, "f64");
    });
}
