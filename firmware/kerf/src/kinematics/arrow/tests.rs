use super::velocity::{ForwardJacobian, InverseJacobian};
use super::*;
use core::f64::consts::PI;
use std::vec::Vec;

fn geometry() -> ArrowGeometry<f64> {
    ArrowGeometry::new(&ArrowConfig::ARROW).unwrap()
}

/// Poses over eq. 25's workspace: a 5 × 5 × 5 × 5 grid including every corner.
fn workspace_poses() -> Vec<Pose<f64>> {
    let w = ArrowConfig::ARROW.workspace;
    // The ends a hair inside eq. 25's bounds, which rounding could cross.
    let steps = [-0.999, -0.5, 0.0, 0.5, 0.999];
    let mut poses = Vec::new();
    for sx in steps {
        for sy in steps {
            for sz in steps {
                for st in steps {
                    poses.push(Pose::new(
                        0.5 * sx,
                        w.y0_m + w.y_half_m * sy,
                        w.z_half_m * sz,
                        w.theta_z_half_rad * st,
                    ));
                }
            }
        }
    }
    poses
}

/// The mechanism rebuilt from the joints the inverse model returns, constraint by
/// constraint (A fig. 9), with none of its formulas: each arm's rigid length, the two
/// offsets, the right angle at C, A†, B, C collinear, B, C, D in one horizontal plane,
/// and the assembly mode of eq. 2. Every pose of eq. 25's grid closes to 1e-12 m.
#[test]
fn inverse_kinematics_closes_every_chain() {
    let g = geometry();
    let config = ArrowConfig::ARROW;
    for pose in workspace_poses() {
        let q = g.inverse(&pose).unwrap();
        let (s, c) = (pose.w.sin(), pose.w.cos());
        for (i, arm) in config.arms.iter().enumerate() {
            let p = arm.plate_m;
            let d = Vector3::new(
                pose.x + c * p[0] - s * p[1],
                pose.y + s * p[0] + c * p[1],
                pose.z + p[2],
            );
            let a = Vector3::new(q[i], arm.rail_y_m, arm.rail_z_m);
            // Search C on the circle of radius r′ around D in D's plane for the point
            // where CD ⊥ A†C (two solutions; the one on the left of the arm, as built),
            // by sampling the angle finely and bisecting the sign change.
            let a_dagger = Vector3::new(a.x, a.y, d.z);
            let f = |phi: f64| {
                let cpt = d + Vector3::new(phi.cos(), phi.sin(), 0.0) * arm.cd_m;
                (cpt - a_dagger).dot(&(d - cpt))
            };
            let mut found = Vec::new();
            let n = 3600;
            for k in 0..n {
                let (mut lo, mut hi) = (
                    2.0 * PI * k as f64 / n as f64,
                    2.0 * PI * (k + 1) as f64 / n as f64,
                );
                if f(lo).signum() == f(hi).signum() {
                    continue;
                }
                for _ in 0..80 {
                    let mid = 0.5 * (lo + hi);
                    if f(lo).signum() == f(mid).signum() {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                found.push(d + Vector3::new(lo.cos(), lo.sin(), 0.0) * arm.cd_m);
            }
            // Of the two, the C whose A†C has D on its left: (A†C × CD)_z > 0.
            let cpt = found
                .into_iter()
                .find(|cpt| (cpt - a_dagger).cross(&(d - cpt)).z > 0.0)
                .unwrap();
            let u = (cpt - a_dagger).normalize();
            let b = cpt - u * arm.bc_m;
            assert!(
                ((b - a).norm() - arm.length_m).abs() < 1e-12,
                "arm {i}: |AB|"
            );
            assert!(
                ((b - a_dagger).cross(&u)).norm() < 1e-12,
                "arm {i}: collinear"
            );
            assert!((b - a_dagger).dot(&u) > 0.0, "arm {i}: B beyond A†");
            assert!((b.z - d.z).abs() < 1e-15);
            let side = if i % 2 == 0 { q[i] <= d.x } else { q[i] >= d.x };
            assert!(side, "arm {i}: assembly mode of eq. 2");
        }
    }
}

/// Jm (eq. 13, through Jq and Jx as printed) against central differences of the
/// inverse model over the workspace grid. Step 1e-6 (m, rad): truncation ~h²·q‴ and
/// rounding ~1e-16/h, both below 1e-8 here.
#[test]
fn jacobian_is_the_derivative_of_the_inverse_model() {
    let g = geometry();
    let h = 1e-6;
    for pose in workspace_poses() {
        let (q, jm) = g.jacobian(&pose).unwrap();
        assert_eq!(q, g.inverse(&pose).unwrap());
        for k in 0..4 {
            let mut e = Pose::zeros();
            e[k] = h;
            let fd =
                (g.inverse(&(pose + e)).unwrap() - g.inverse(&(pose - e)).unwrap()) / (2.0 * h);
            for i in 0..6 {
                assert!(
                    (jm[(i, k)] - fd[i]).abs() < 1e-7,
                    "{pose:?} ({i},{k}): {} vs {}",
                    jm[(i, k)],
                    fd[i]
                );
            }
        }
        // Eq. 14: the pseudo-inverse is a left inverse.
        let pinv = ArrowGeometry::pseudo_inverse(&jm).unwrap();
        assert!((pinv * jm - nalgebra::Matrix4::identity()).amax() < 1e-12);
    }
}

/// J̇m against central differences of Jm along a motion X(t) = X0 + V t.
#[test]
fn jacobian_rate_is_the_time_derivative() {
    let g = geometry();
    let h = 1e-6;
    let rate = Pose::new(0.3, -0.2, 0.15, 0.8);
    for pose in workspace_poses().into_iter().step_by(7) {
        let jm_dot = g.jacobian_rate(&pose, &rate).unwrap();
        let jm = |p: Pose<f64>| -> InverseJacobian<f64> { g.jacobian(&p).unwrap().1 };
        let fd = (jm(pose + rate * h) - jm(pose - rate * h)) / (2.0 * h);
        assert!(
            (jm_dot - fd).amax() < 1e-6,
            "{pose:?}: {}",
            (jm_dot - fd).amax()
        );
        assert!(fd.column(0).amax() < 1e-9);
    }
}

/// The forward solve recovers every grid pose from its joints, from a guess 5 mm and
/// 3° off, to 1e-9. A slipped joint is refused exactly when no rigid pose explains it:
/// the residual a slip δq leaves is its part outside Jm's column space, computed here
/// by an SVD (not the solver's normal equations); beyond twice the tolerance the solve
/// must refuse, below half of it accept (a slip along Jm's columns looks like motion
/// and no six joints can tell).
#[test]
fn forward_solve_recovers_poses_and_refuses_inconsistent_joints() {
    let g = geometry();
    let config = ForwardConfig::MONITOR;
    let offset = Pose::new(5e-3, -5e-3, 5e-3, 3.0 * PI / 180.0);
    let (mut refused, mut accepted) = (0, 0);
    for pose in workspace_poses() {
        let q = g.inverse(&pose).unwrap();
        let found = g.forward(&q, &(pose + offset), &config).unwrap();
        assert!((found - pose).amax() < 1e-9, "{pose:?}: {found:?}");
        let (_, jm) = g.jacobian(&pose).unwrap();
        let svd = jm.svd(true, false);
        let u = svd.u.unwrap();
        for joint in 0..6 {
            let mut slip = ActuatorVector::zeros();
            slip[joint] = 1e-3;
            let mut inside = ActuatorVector::zeros();
            for k in 0..4 {
                inside += u.column(k) * u.column(k).dot(&slip);
            }
            let residual = (slip - inside).amax();
            let result = g.forward(&(q + slip), &pose, &config);
            if residual > 2.0 * config.residual_tolerance_m {
                assert_eq!(
                    result,
                    Err(ArrowError::InconsistentJoints),
                    "{pose:?} {joint}"
                );
                refused += 1;
            } else if residual < 0.5 * config.residual_tolerance_m {
                assert!(result.is_ok(), "{pose:?} {joint}: {result:?}");
                accepted += 1;
            }
        }
    }
    assert!(
        refused > 1000 && accepted > 0,
        "{refused} refused, {accepted} accepted"
    );
    let mut q = g.inverse(&Pose::new(0.0, 0.5, 0.0, 0.0)).unwrap();
    q[4] = f64::NAN;
    assert_eq!(
        g.forward(&q, &Pose::new(0.0, 0.5, 0.0, 0.0), &config),
        Err(ArrowError::NotFinite)
    );
}

/// Eq. 25's workspace is inside the preset's reach with margin to every singularity,
/// and the axes outside it are named.
#[test]
fn workspace_is_reachable_and_checked() {
    let g = geometry();
    let mut nearest = SingularityDistance::<f64> {
        across_rails: 1.0,
        vertical: 1.0,
        plate: 1.0,
    };
    for pose in workspace_poses() {
        g.check_workspace(&pose, PI / 4.0).unwrap();
        let d = g.singularity_distance(&pose).unwrap();
        nearest.across_rails = nearest.across_rails.min(d.across_rails);
        nearest.vertical = nearest.vertical.min(d.vertical);
        nearest.plate = nearest.plate.min(d.plate);
    }
    // Stated in ArrowConfig::ARROW's docs.
    assert!(nearest.across_rails > 0.28, "{nearest:?}");
    assert!(nearest.vertical > 0.94, "{nearest:?}");
    assert!(nearest.plate > 0.15, "{nearest:?}");
    let centre = Pose::new(0.0, 0.5, 0.0, 0.0);
    let out = |p: Pose<f64>, tx: f64| g.check_workspace(&p, tx);
    assert_eq!(
        out(centre + Pose::new(0.0, 0.16, 0.0, 0.0), 0.0),
        Err(ArrowError::OutsideWorkspace(1))
    );
    assert_eq!(
        out(centre + Pose::new(0.0, 0.0, -0.16, 0.0), 0.0),
        Err(ArrowError::OutsideWorkspace(2))
    );
    assert_eq!(
        out(centre + Pose::new(0.0, 0.0, 0.0, 0.8), 0.0),
        Err(ArrowError::OutsideWorkspace(3))
    );
    assert_eq!(out(centre, -0.8), Err(ArrowError::OutsideWorkspace(4)));
    assert_eq!(
        out(centre + Pose::new(1.2, 0.0, 0.0, 0.0), 0.0),
        Err(ArrowError::OutsideWorkspace(0))
    );
    assert_eq!(out(centre, f64::NAN), Err(ArrowError::NotFinite));
    assert_eq!(ArrowGeometry::<f64>::turntable(0.3), [0.3, -0.3]);
}

/// The singularities of eq. 30 as typed errors, at poses built to sit on them: a
/// parallelogram whose reach lies along the wall's normal, a parallelogram standing
/// (nearly) vertical; and a plate point out of reach.
#[test]
fn singular_and_unreachable_poses_are_typed_errors() {
    let g = geometry();
    let arm = ArrowConfig::ARROW.arms[2];
    // Across the rails: |m_x| = 1e-4 m of a 0.66 m reach (sine 1.5e-4).
    let reach_sq = (arm.length_m + arm.bc_m).powi(2) + arm.cd_m.powi(2);
    let y_d = (reach_sq - 1e-8).sqrt();
    let across = Pose::new(0.0, y_d - arm.plate_m[1], 0.0, 0.0);
    assert_eq!(
        g.jacobian(&across).map(|_| ()),
        Err(ArrowError::ArmAcrossRails(2))
    );
    // Vertical: ℓ/L = √1e-7 ≈ 3e-4.
    let z = arm.length_m * (1.0f64 - 1e-7).sqrt();
    let vertical = Pose::new(0.0, 0.08, z, 0.0);
    assert_eq!(
        g.jacobian(&vertical).map(|_| ()),
        Err(ArrowError::ArmVertical(2))
    );
    // Beyond reach.
    assert_eq!(
        g.inverse(&Pose::new(0.0, 0.9, 0.0, 0.0)),
        Err(ArrowError::OutOfReach(2))
    );
    assert_eq!(
        g.inverse(&Pose::new(0.0, 0.55, 0.7, 0.0)),
        Err(ArrowError::OutOfReach(2))
    );
    assert_eq!(
        g.inverse(&Pose::new(f64::INFINITY, 0.55, 0.0, 0.0)),
        Err(ArrowError::NotFinite)
    );
}

/// f32 against f64 over the workspace: the inverse model within 2 µm (f32's 6e-8
/// relative on 1.5 m rails and the square roots' cancellation near the reach).
#[test]
fn f32_inverse_kinematics_is_within_micrometres() {
    let g64 = geometry();
    let g32 = ArrowGeometry::<f32>::new(&ArrowConfig::ARROW).unwrap();
    let mut worst: f64 = 0.0;
    for pose in workspace_poses() {
        let q64 = g64.inverse(&pose).unwrap();
        let q32 = g32.inverse(&pose.map(|v| v as f32)).unwrap();
        for (a, b) in q64.iter().zip(q32.iter()) {
            worst = worst.max((a - f64::from(*b)).abs());
        }
    }
    assert!(worst < 2e-6, "{worst}");
}

/// Bad configurations name their field.
#[test]
fn bad_configurations_are_refused() {
    let mut c = ArrowConfig::ARROW;
    c.arms[3].length_m = -0.61;
    let e = ArrowGeometry::<f64>::new(&c).unwrap_err();
    assert_eq!(e.field(), "length_m");
    let mut c = ArrowConfig::ARROW;
    c.arms[1].plate_m[0] = 0.01;
    assert!(ArrowGeometry::<f64>::new(&c).is_err());
    let mut c = ArrowConfig::ARROW;
    c.workspace.theta_x_half_rad = f64::NAN;
    assert!(ArrowGeometry::<f64>::new(&c).is_err());
}

/// Jm⁺ by the Cholesky factor of JmᵀJm (eq. 14) against nalgebra's SVD pseudo-inverse
/// (which never forms the normal matrix) over the workspace grid. Jm's condition
/// number stays below 100 there (73 at worst), so the normal equations' error bound
/// κ(Jm)² ε is 2.2e-12 relative in f64: asserted 1e-12 (measured 2e-14). In f32,
/// against the f64 SVD of the same f32 Jm: within 1e-5 relative (measured 2.4e-6,
/// against κ² ε = 1.2e-3 as the bound) and no worse than the explicit 4×4 inverse
/// (cofactors, nalgebra's `try_inverse`) it replaces (1.4e-5).
#[test]
fn pseudo_inverse_matches_the_svd() {
    let g = geometry();
    let g32 = ArrowGeometry::<f32>::new(&ArrowConfig::ARROW).unwrap();
    let relative = |a: &ForwardJacobian<f64>, b: &ForwardJacobian<f64>| (a - b).amax() / b.amax();
    let (mut worst32, mut worst_inverse32): (f64, f64) = (0.0, 0.0);
    for pose in workspace_poses() {
        let (_, jm) = g.jacobian(&pose).unwrap();
        let s = jm.svd(false, false).singular_values;
        assert!(s.max() / s.min() < 100.0, "{pose:?}: {s:?}");
        let reference = jm.pseudo_inverse(1e-14).unwrap();
        let pinv = ArrowGeometry::pseudo_inverse(&jm).unwrap();
        assert!(relative(&pinv, &reference) < 1e-12, "{pose:?}");
        let (_, j32) = g32.jacobian(&pose.map(|v| v as f32)).unwrap();
        let reference = j32.map(f64::from).pseudo_inverse(1e-14).unwrap();
        let pinv = ArrowGeometry::pseudo_inverse(&j32).unwrap().map(f64::from);
        worst32 = worst32.max(relative(&pinv, &reference));
        let inverse = (j32.transpose() * j32).try_inverse().unwrap() * j32.transpose();
        worst_inverse32 = worst_inverse32.max(relative(&inverse.map(f64::from), &reference));
    }
    assert!(
        worst32 < 1e-5 && worst32 <= worst_inverse32,
        "{worst32} against {worst_inverse32}"
    );
    // Rank-deficient (two equal columns) and NaN: refused.
    let mut jm = g.jacobian(&Pose::new(0.0, 0.5, 0.0, 0.0)).unwrap().1;
    let first = jm.column(0).into_owned();
    jm.set_column(1, &first);
    assert_eq!(
        ArrowGeometry::pseudo_inverse(&jm),
        Err(ArrowError::PlateSingular)
    );
    jm[(2, 3)] = f64::NAN;
    assert_eq!(
        ArrowGeometry::pseudo_inverse(&jm),
        Err(ArrowError::PlateSingular)
    );
}
