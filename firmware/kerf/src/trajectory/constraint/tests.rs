use super::*;
use crate::trajectory::shapes;
extern crate std;
use std::println;
use std::vec::Vec as StdVec;

/// Deterministic Gaussian noise (xorshift64* + Box–Muller) for repeatable tests.
struct Noise(u64);
impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        libm::sqrt(-2.0 * libm::log(u)) * libm::cos(2.0 * core::f64::consts::PI * v)
    }
}

#[test]
fn smallest_eigenvector_matches_a_general_eigen_solver() {
    // Reference: nalgebra's symmetric QR eigen-solver, on S = Q diag(λ) Qᵀ with
    // random rotations Q and λ1/λ2 from 1e-9 (a window a circle fits) to 0.9.
    use nalgebra::{Rotation3, SymmetricEigen};
    let mut seed = 7u64;
    let mut next = || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for ratio in [1e-9, 1e-4, 0.1, 0.5, 0.9, 0.95] {
        for _ in 0..200 {
            let q = Rotation3::from_euler_angles(6.3 * next(), 6.3 * next(), 6.3 * next());
            let l2 = 1.0 + next();
            let l = Vector3::new(ratio * l2, l2, l2 * (1.5 + next()));
            let s = q.matrix() * Matrix3::from_diagonal(&l) * q.matrix().transpose();
            let u = smallest_eigenvector(&s).unwrap();
            let eig = SymmetricEigen::new(s);
            let i = eig.eigenvalues.imin();
            let reference = eig.eigenvectors.column(i);
            let error = (u - reference).norm().min((u + reference).norm());
            // 2^k squarings leave the other directions at (λ1/λ2)^(2^k) of the answer.
            let bound = (4.0 * ratio.powi(1 << EIGEN_SQUARINGS)).max(1e-9);
            assert!(error < bound, "λ1/λ2 = {ratio}: {error:e} > {bound:e}");
        }
    }
    // Rank 1 or 0: no smallest direction.
    let a = Vector3::new(1.0, 2.0, 3.0);
    assert!(smallest_eigenvector(&(a * a.transpose())).is_none());
    assert!(smallest_eigenvector(&Matrix3::<f64>::zeros()).is_none());
}

#[test]
fn circle_fit_comparison() {
    // 21 points (k = 10) on arcs of R = 5 mm about (12, −7) mm, Gaussian noise σ on
    // both coordinates, 400 trials per case. Reported: mean signed radius error
    // (bias) and RMS radius and centre errors, all relative to R.
    let (r0, c0, trials) = (5e-3, Vector2::new(12e-3, -7e-3), 400);
    let mut noise = Noise(0x9e37_79b9_7f4a_7c15);
    println!("circle fits, 21 points, R = 5 mm; errors relative to R (bias / RMS r / RMS c)");
    println!(
        "{:>6} {:>6}  {:>26}  {:>26}  {:>26}",
        "arc", "σ µm", "Kåsa", "Taubin", "geometric"
    );
    let mut rows = StdVec::new();
    for sigma in [5e-6, 20e-6] {
        for arc_deg in [10.0f64, 30.0, 90.0, 180.0, 360.0] {
            let mut acc = [[0.0f64; 3]; 3];
            for _ in 0..trials {
                let span = arc_deg.to_radians();
                let n = 21;
                let pts: StdVec<Vector2<f64>> = (0..n)
                    .map(|i| {
                        let den = if arc_deg >= 360.0 { n } else { n - 1 } as f64;
                        let a = 0.3 + span * i as f64 / den;
                        c0 + Vector2::new(r0 * a.cos(), r0 * a.sin())
                            + Vector2::new(noise.gauss(), noise.gauss()) * sigma
                    })
                    .collect();
                let (mean, [a, b, c, d]) = fit_taubin(&pts).unwrap();
                let taubin = (
                    Vector2::new(-b, -c) / (2.0 * a) + mean,
                    (b * b + c * c - 4.0 * a * d).sqrt() / (2.0 * a.abs()),
                );
                let fits = [
                    fit_kasa(&pts).unwrap(),
                    taubin,
                    fit_geometric(&pts, taubin, 20).unwrap_or(taubin),
                ];
                for (m, (c, r)) in fits.iter().enumerate() {
                    acc[m][0] += (r - r0) / r0;
                    acc[m][1] += ((r - r0) / r0).powi(2);
                    acc[m][2] += ((c - c0).norm() / r0).powi(2);
                }
            }
            let t = trials as f64;
            let stats: StdVec<[f64; 3]> = acc
                .iter()
                .map(|a| [a[0] / t, (a[1] / t).sqrt(), (a[2] / t).sqrt()])
                .collect();
            println!(
                "{arc_deg:>5}° {:>6.0}  {:>8.1e} {:>8.1e} {:>8.1e}  {:>8.1e} {:>8.1e} {:>8.1e}  {:>8.1e} {:>8.1e} {:>8.1e}",
                sigma * 1e6,
                stats[0][0], stats[0][1], stats[0][2],
                stats[1][0], stats[1][1], stats[1][2],
                stats[2][0], stats[2][1], stats[2][2],
            );
            rows.push((arc_deg, stats));
        }
    }
    // rows: σ = 5 µm first (5 arcs), then σ = 20 µm.
    for (i, (arc, s)) in rows.iter().enumerate() {
        let determined = i < 5 || *arc > 10.0; // 10° at 20 µm: sagitta 19 µm ≈ σ
                                               // Kåsa's bias is towards small radii, far larger than Taubin's on short arcs.
        if *arc <= 30.0 {
            assert!(
                s[0][0] < 0.0 && s[0][0].abs() > 5.0 * s[1][0].abs().min(1.0) || !determined,
                "{arc}: {s:?}"
            );
        }
        // Taubin and geometric agree within 2% (RMS radius) where the arc is determined.
        if determined {
            assert!((s[2][1] - s[1][1]).abs() <= s[1][1] * 0.02, "{arc}: {s:?}");
        }
    }
}

#[test]
fn fits_are_exact_without_noise_and_in_f32() {
    let c0 = Vector2::new(20e-3, 5e-3);
    let pts: StdVec<Vector2<f64>> = (0..11)
        .map(|i| c0 + Vector2::new(3e-3 * (0.1 * i as f64).cos(), 3e-3 * (0.1 * i as f64).sin()))
        .collect();
    let (c, r) = fit_kasa(&pts).unwrap();
    assert!((c - c0).norm() < 1e-15 && (r - 3e-3).abs() < 1e-15);
    let (c, r) = fit_geometric(&pts, (c + Vector2::new(1e-4, 0.0), r * 1.1), 20).unwrap();
    assert!((c - c0).norm() < 1e-15 && (r - 3e-3).abs() < 1e-15);
    let p32: StdVec<Vector2<f32>> = pts.iter().map(|p| p.map(|v| v as f32)).collect();
    let (mean, [a, b, cc, d]) = fit_taubin(&p32).unwrap();
    let c = Vector2::new(-b, -cc) / (2.0 * a) + mean;
    let r = (b * b + cc * cc - 4.0 * a * d).sqrt() / (2.0 * a.abs());
    // Centred f32 on a 57° arc: relative error a few 1e-6 (ε/sagitta-ratio).
    assert!(((c.x as f64 - c0.x).hypot(c.y as f64 - c0.y)) < 3e-8, "{c}");
    assert!((r as f64 - 3e-3).abs() < 3e-8, "{r}");
    assert!(fit_kasa(&pts[..2]).is_none() && fit_taubin(&pts[..2]).is_none());
}

/// Slides an end effector along `points` (closed) at offset `offset` to the left of
/// the direction, `steps` between data points; returns (max |φ₁ − offset|, max |Δφ₁|,
/// line windows seen).
fn slide(points: &[[f64; 2]], offset: f64, steps: usize, k: usize) -> (f64, f64, usize) {
    let cfg = ConstraintConfig {
        half_window: k,
        ..ConstraintConfig::closed_contour()
    };
    let c = MotionConstraint::<f64, 512>::new(points, &cfg).unwrap();
    let n = points.len();
    let (mut worst, mut jump, mut lines) = (0.0f64, 0.0f64, 0);
    let mut prev: Option<f64> = None;
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        let (a, b) = (Vector2::new(a[0], a[1]), Vector2::new(b[0], b[1]));
        let t = (b - a).normalize();
        for s in 0..steps {
            let p = a + (b - a) * (s as f64 / steps as f64) + Vector2::new(-t.y, t.x) * offset;
            let v = c.evaluate(Vector3::new(p.x, p.y, -0.1), -0.1).unwrap();
            // On a straight side, φ₁ is exactly the offset from the data line.
            worst = worst.max((v.phi.x - offset).abs());
            if let Some(q) = prev {
                jump = jump.max((v.phi.x - q).abs());
            }
            prev = Some(v.phi.x);
            assert_eq!(v.phi.y, 0.0);
            assert_eq!(v.jacobian[(1, 2)], -1.0);
            // Jφ row 1 (gradient of φ₁) points to the left of the direction: the sign
            // convention holds in every window (circle or line, either bending side).
            let g = Vector2::new(v.jacobian[(0, 0)], v.jacobian[(0, 1)]);
            assert!(g.dot(&Vector2::new(-t.y, t.x)) > 0.5, "{g}");
            if matches!(v.fit, Fit::Line { .. }) {
                lines += 1;
            }
        }
    }
    (worst, jump, lines)
}

#[test]
fn phi_is_continuous_sliding_along_gear_cam_and_octagon() {
    // Continuity by refinement: if φ₁ is continuous (Lipschitz) along the path, 4×
    // finer steps shrink the largest step-to-step change about 4×; a jump when the
    // window moves would not shrink at all.
    println!("end effector sliding 20 µm left of the contour");
    for (name, pts, k) in [
        ("gear", shapes::gear().to_vec(), 2),
        ("cam", shapes::cam().to_vec(), 5),
        ("octagon", shapes::octagon().to_vec(), 2),
    ] {
        let (off, jump16, lines) = slide(&pts, 20e-6, 16, k);
        let (_, jump64, _) = slide(&pts, 20e-6, 64, k);
        let (on, _, _) = slide(&pts, 0.0, 16, k);
        println!(
            "{name:>8} k={k}: max |φ₁ − offset| {:7.3} µm (on the contour {:7.3} µm), max |Δφ₁| {:6.3} µm (16 steps/segment) {:6.3} µm (64), line samples {lines}",
            off * 1e6, on * 1e6, jump16 * 1e6, jump64 * 1e6
        );
        // Ideal Lipschitz behaviour is 4×; where the nearest segment switches sides at a
        // concave corner some of the change is not refined away, hence 2.5×.
        assert!(jump64 < jump16 / 2.5, "{name}: {jump16} {jump64}");
        if name == "cam" {
            // Smooth data: the error is the chord sagitta of the data (≈ 4 µm at the
            // 1.5 mm valleys) plus the fit's; no line windows on a cam.
            assert!(off < 10e-6 && lines == 0, "{name}: {off}");
        } else {
            // Straight sides use the line fallback; corners are rounded by the fit.
            assert!(lines > 0, "{name}");
        }
    }
}

#[test]
fn spec_form_is_the_scaled_first_row() {
    let pts: [[f64; 2]; 64] = shapes::ellipse(6e-3, 6e-3);
    let c = MotionConstraint::<f64, 64>::new(&pts, &ConstraintConfig::closed_contour()).unwrap();
    let x = Vector3::new(6.3e-3, 0.2e-3, 0.0);
    let v = c.evaluate(x, 0.0).unwrap();
    let Fit::Circle { radius, .. } = v.fit else {
        panic!("circle expected")
    };
    let (spec, grad) = v
        .fit
        .spec_form(Vector2::new(x.x, x.y) - c.origin())
        .unwrap();
    // Counter-clockwise data: the centre is on the left, outside is φ₁ < 0.
    assert!(v.phi.x < 0.0);
    assert!((spec / (2.0 * radius) + v.phi.x).abs() < 1e-9);
    assert!(
        (grad / (2.0 * radius) + Vector2::new(v.jacobian[(0, 0)], v.jacobian[(0, 1)])).norm()
            < 1e-3
    );
}

#[test]
fn open_contour_with_inflection_keeps_its_sign() {
    // The 's' bends both ways: φ₁ (left of travel) must not flip sign at the inflection.
    let s = crate::trajectory::resample::densify::<512>(&shapes::letter_s(), 2).unwrap();
    let cfg = ConstraintConfig {
        closed: false,
        ..ConstraintConfig::closed_contour()
    };
    let c = MotionConstraint::<f64, 512>::new(&s, &cfg).unwrap();
    for w in s.windows(2).skip(8).take(s.len() - 20) {
        let (a, b) = (
            Vector2::new(w[0][0], w[0][1]),
            Vector2::new(w[1][0], w[1][1]),
        );
        let t = (b - a).normalize();
        let p = (a + b) / 2.0 + Vector2::new(-t.y, t.x) * 30e-6;
        let v = c.evaluate(Vector3::new(p.x, p.y, 0.0), 0.0).unwrap();
        // Sign first; the size within the data's chord sagitta (≈ 4 µm at R = 4 mm,
        // 0.35 mm segments) plus the fit error of windows spanning the inflection.
        assert!(
            v.phi.x > 0.0 && (v.phi.x - 30e-6).abs() < 20e-6,
            "{}",
            v.phi.x
        );
    }
}

#[test]
fn f32_matches_f64_sliding_along_gear_and_cam() {
    // The f32 path against the f64 one on the same data and the same (f32-exact)
    // end-effector positions, so only arithmetic is compared, not the rounding of
    // the caller's input. Expected size, with ε = f32::EPSILON (1.2e-7):
    // - φ₁: the centred data and query carry ε/2 · |q| (|q| ≤ 10 mm from the data
    //   centroid), and the fitted centre (or line point) c carries ε · |c|; φ₁ is
    //   formed from x − c, so |Δφ₁| ≈ a few ε (|q| + |c|) ≈ 1e-9 m for a 10 mm
    //   contour, more only where a flat window's circle has a far centre.
    // - Jφ row 1: each window's normal comes from point differences over its span,
    //   and the blend weight u = (p − a)·d/|d|² from one data segment of length ℓ,
    //   so both carry ε|q|/ℓ (span ≥ ℓ); at a gear corner u multiplies the
    //   difference of two neighbouring windows' gradients (up to ≈ 2: |Jφ| reaches
    //   1.14 in blends there), and a rounding that tips the nearest-segment tie at a
    //   vertex lands on the same scale: 2ε|q|/ℓ.
    // Bounds: 4× those scales (φ₁: 4 ε(|q| + |c|), Jφ: 8 ε|q|/ℓ). The contours are also run 0.36 m off the frame
    // origin (data in image or machine coordinates): centring must keep the same
    // bounds there, which it did not while the query was centred on the f32-rounded
    // origin and the data on the exact one (13.6 ε (|q| + |c|) on the gear).
    let eps = f64::from(f32::EPSILON);
    println!("f32 against f64, sliding on the contour and 20 µm left of it (16 steps/segment)");
    for shift in [[0.0, 0.0], [0.3, 0.2]] {
        for (name, base, k) in [
            ("gear", shapes::gear().to_vec(), 2),
            ("cam", shapes::cam().to_vec(), 5),
        ] {
            let pts: StdVec<[f64; 2]> = base
                .iter()
                .map(|p| [p[0] + shift[0], p[1] + shift[1]])
                .collect();
            let cfg = ConstraintConfig {
                half_window: k,
                ..ConstraintConfig::closed_contour()
            };
            let c64 = MotionConstraint::<f64, 512>::new(&pts, &cfg).unwrap();
            let c32 = MotionConstraint::<f32, 512>::new(&pts, &cfg).unwrap();
            let n = pts.len();
            let (mut phi_abs, mut phi_rel, mut jac_abs, mut jac_rel) =
                (0.0f64, 0.0f64, 0.0f64, 0.0f64);
            for offset in [0.0, 20e-6] {
                for i in 0..n {
                    let (a, b) = (pts[i], pts[(i + 1) % n]);
                    let (a, b) = (Vector2::new(a[0], a[1]), Vector2::new(b[0], b[1]));
                    let ell = (b - a).norm();
                    let t = (b - a) / ell;
                    for s in 0..16 {
                        let p = a + (b - a) * (s as f64 / 16.0) + Vector2::new(-t.y, t.x) * offset;
                        let x32 = Vector3::new(p.x as f32, p.y as f32, -0.1f32);
                        let x64 = x32.map(f64::from);
                        let v = c64.evaluate(x64, -0.1).unwrap();
                        let w = c32.evaluate(x32, -0.1).unwrap();
                        let q = (x64.xy() - c64.origin()).norm();
                        let c = match v.fit {
                            Fit::Circle { centre, .. } => centre.norm(),
                            Fit::Line { point, .. } => point.norm(),
                        };
                        let dphi = (f64::from(w.phi.x) - v.phi.x).abs();
                        let djac = (w.jacobian.map(f64::from) - v.jacobian).abs().max();
                        phi_abs = phi_abs.max(dphi);
                        phi_rel = phi_rel.max(dphi / (eps * (q + c)));
                        jac_abs = jac_abs.max(djac);
                        jac_rel = jac_rel.max(djac / (eps * q / ell));
                        // The second row has no arithmetic: exact in both.
                        assert_eq!(w.phi.y, 0.0);
                    }
                }
            }
            println!(
                "{name:>5} at ({:.2}, {:.2}) m, k={k}: max |Δφ₁| {:.2} nm = {phi_rel:.2} ε(|q| + |c|), max |ΔJφ| {jac_abs:.2e} = {jac_rel:.2} ε|q|/ℓ",
                shift[0], shift[1], phi_abs * 1e9
            );
            assert!(phi_rel < 4.0, "{name} {shift:?}: φ₁ {phi_rel} ε(|q| + |c|)");
            assert!(jac_rel < 8.0, "{name} {shift:?}: Jφ {jac_rel} ε|q|/ℓ");
        }
    }
}

#[test]
fn rejects_bad_input() {
    let cfg = ConstraintConfig::closed_contour();
    type C = MotionConstraint<f32, 64>;
    assert_eq!(
        C::new(&[[0.0, 0.0], [1.0, 0.0]], &cfg).err(),
        Some(ContourError::TooFewPoints)
    );
    assert_eq!(
        C::new(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &cfg).err(),
        Some(ContourError::RepeatedPoint(2))
    );
    // 2k + 1 = 11 points needed.
    let tri: [[f64; 2]; 8] = shapes::ellipse(1e-3, 1e-3);
    assert_eq!(C::new(&tri, &cfg).err(), Some(ContourError::TooFewPoints));
    assert_eq!(
        C::new(&shapes::cam(), &cfg).err(),
        Some(ContourError::Capacity)
    );
    let bad = ConstraintConfig {
        half_window: 0,
        ..cfg
    };
    assert!(C::new(&shapes::octagon(), &bad).is_err());
    let bad = ConstraintConfig {
        line_sagitta_m: 0.0,
        ..cfg
    };
    assert!(C::new(&shapes::octagon(), &bad).is_err());
}

/// Far from the contour in f32 (|p|² overflows), or a non-finite point: a typed
/// error, never a NaN constraint.
#[test]
fn far_or_non_finite_points_are_typed_errors() {
    let pts: [[f64; 2]; 64] = shapes::ellipse(6e-3, 6e-3);
    let c = MotionConstraint::<f32, 64>::new(&pts, &ConstraintConfig::closed_contour()).unwrap();
    assert!(c.evaluate(Vector3::new(6.3e-3, 0.2e-3, 0.0), 0.0).is_ok());
    for x in [
        Vector3::new(1e20f32, 1e20, 0.0),
        Vector3::new(-3e38f32, 0.0, 0.0),
        Vector3::new(f32::NAN, 0.0, 0.0),
        Vector3::new(0.0, 0.0, f32::INFINITY),
    ] {
        assert_eq!(
            c.evaluate(x, 0.0).err(),
            Some(ContourError::FarFromContour),
            "{x:?}"
        );
    }
}
