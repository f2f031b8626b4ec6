//! F/T calibration, bias, local forces and the eccentricity fit against references
//! computed another way (plain loops, nalgebra's LU and SVD, forward models).

use super::*;
use nalgebra::{SMatrix, Vector6 as V6};
use std::vec::Vec;

/// Deterministic pseudo-random numbers in [−1, 1).
struct Noise(u64);

impl Noise {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
    /// Approximately normal (sum of four uniforms, variance 4/3 scaled to 1).
    fn gauss(&mut self) -> f64 {
        (self.next() + self.next() + self.next() + self.next()) * 0.866_025_4
    }
}

const CAL: [[f64; 6]; 6] = FtSensorConfig::ATI_GAMMA_IP60.calibration;

#[test]
fn wrench_matches_a_plain_loop_and_inverts_with_lu() {
    let sensor = FtSensor::<f64>::new(&FtSensorConfig::ATI_GAMMA_IP60).unwrap();
    let bias = FtBias {
        raw_v: [0.12, -0.3, 0.05, 0.4, -0.02, 0.2],
    };
    let raw = [1.5, -2.25, 0.75, 3.0, -0.5, 2.0];
    let w = sensor.wrench(&raw, &bias).unwrap();
    // Reference 1: the product written out.
    let mut want = [0.0f64; 6];
    for i in 0..6 {
        for j in 0..6 {
            want[i] += CAL[i][j] * (raw[j] - bias.raw_v[j]);
        }
    }
    let got: Vec<f64> = w.force_n.iter().chain(&w.torque_n_m).copied().collect();
    for (g, e) in got.iter().zip(&want) {
        assert!((g - e).abs() < 1e-12 * (1.0 + e.abs()), "{g} vs {e}");
    }
    // Reference 2: raw readings for a chosen wrench from CAL⁻¹ (LU), calibrated back.
    let cal = Matrix6::from_fn(|i, j| CAL[i][j]);
    let target = V6::new(7.5, -3.0, 20.0, 0.1, -0.2, 0.015);
    let raw_for = cal.lu().solve(&target).unwrap();
    let raw_arr: [f64; 6] = core::array::from_fn(|k| raw_for[k]);
    let back = sensor
        .wrench(&raw_arr, &FtBias { raw_v: [0.0; 6] })
        .unwrap();
    let back: Vec<f64> = back
        .force_n
        .iter()
        .chain(&back.torque_n_m)
        .copied()
        .collect();
    for (b, t) in back.iter().zip(target.iter()) {
        assert!((b - t).abs() < 1e-9, "{b} vs {t}");
    }
    // f32 against f64: CAL entries ≤ 25, raw ≤ 10: |error| ≤ 6 terms · 250 · 2^-23
    // ≈ 2e-4 N (the matrix itself rounds to 7 digits).
    let s32 = FtSensor::<f32>::new(&FtSensorConfig::ATI_GAMMA_IP60).unwrap();
    let w32 = s32
        .wrench(
            &raw.map(|v| v as f32),
            &FtBias {
                raw_v: bias.raw_v.map(|v| v as f32),
            },
        )
        .unwrap();
    let got32: Vec<f64> = w32
        .force_n
        .iter()
        .chain(&w32.torque_n_m)
        .map(|&v| f64::from(v))
        .collect();
    for (g, e) in got32.iter().zip(&want) {
        assert!((g - e).abs() < 2e-4, "{g} vs {e}");
    }
}

#[test]
fn nan_and_clipped_raw_readings_are_typed_errors() {
    let sensor = FtSensor::<f32>::new(&FtSensorConfig::ATI_GAMMA_IP60).unwrap();
    let zero = FtBias { raw_v: [0.0f32; 6] };
    let mut raw = [0.1f32; 6];
    raw[3] = f32::NAN;
    assert_eq!(
        sensor.wrench(&raw, &zero),
        Err(ForceError::NotFinite { channel: 3 })
    );
    raw[3] = 0.1;
    raw[1] = -9.95;
    assert_eq!(
        sensor.wrench(&raw, &zero),
        Err(ForceError::Saturated { channel: 1 })
    );
    raw[1] = 9.94;
    assert!(sensor.wrench(&raw, &zero).is_ok());
    raw[5] = f32::INFINITY;
    assert_eq!(
        sensor.wrench(&raw, &zero),
        Err(ForceError::NotFinite { channel: 5 })
    );
}

fn capture_config(samples: u32) -> BiasCaptureConfig {
    BiasCaptureConfig {
        samples,
        max_force_spread_n: 1.0,
        max_torque_spread_n_m: 0.05,
    }
}

#[test]
fn bias_at_rest_is_the_mean_and_motion_is_refused() {
    let sensor = FtSensor::<f32>::new(&FtSensorConfig::ATI_GAMMA_IP60).unwrap();
    let truth = [0.21f32, -0.4, 1.1, 0.03, -0.7, 0.5];
    let mut noise = Noise(99);
    let mut capture = BiasCapture::new(&capture_config(500)).unwrap();
    assert_eq!(capture.finish(), Err(ForceError::TooFewSamples));
    let mut sums = [0.0f64; 6];
    for _ in 0..500 {
        // 1 mV noise per gauge: ≈ 0.1 N peak-to-peak after CAL, well inside 1 N.
        let raw: [f32; 6] = core::array::from_fn(|k| truth[k] + (1e-3 * noise.next()) as f32);
        for (s, &r) in sums.iter_mut().zip(&raw) {
            *s += f64::from(r);
        }
        capture.push(&sensor, &raw).unwrap();
    }
    let bias = capture.finish().unwrap();
    // Reference: the mean computed here in f64; f32 keeps 1e-7 relative of ~1 V.
    for (b, s) in bias.raw_v.iter().zip(&sums) {
        assert!((f64::from(*b) - s / 500.0).abs() < 2e-7, "{b}");
    }
    // The bias removes the rest reading: the wrench of the true offset is ≈ 0.
    let w = sensor.wrench(&truth, &bias).unwrap();
    for f in w.force_n {
        // Mean noise 1e-3/√(3·500) V ≈ 2.6e-5 V per gauge, times Σ|CAL row| ≲ 80 N/V.
        assert!(f.abs() < 0.01, "{f}");
    }
    // A sensor that moves (a force ramp of 2 N over the capture) is not at rest.
    let mut moving = BiasCapture::new(&capture_config(200)).unwrap();
    for k in 0..200 {
        let mut raw = truth;
        raw[2] += 0.08 * k as f32 / 200.0; // gauge 2: ≈ 25 N/V on Fz → 2 N
        moving.push(&sensor, &raw).unwrap();
    }
    assert_eq!(moving.finish(), Err(ForceError::NotAtRest { component: 2 }));
    // A NaN during capture is reported at once.
    let mut raw = truth;
    raw[0] = f32::NAN;
    assert_eq!(
        moving.push(&sensor, &raw),
        Err(ForceError::NotFinite { channel: 0 })
    );
}

fn tool(dx_m: f64, dy_m: f64) -> ToolConfig {
    ToolConfig {
        tool_radius_m: 2e-3,
        eccentricity: Eccentricity { dx_m, dy_m },
        noise_n: 0.0,
    }
}

/// Forward model: the tool touches the surface with normal force fn_n along the
/// direction at `angle` and tangential force ft_n perpendicular to it; the sensor
/// sees their sum and a moment Mz = Ft r + Fx Δy + Fy Δx (G eq. 2 solved for Mz).
fn sensed(fn_n: f64, ft_n: f64, angle: f64, c: &ToolConfig) -> Wrench<f64> {
    let (s, co) = angle.sin_cos();
    let fx = fn_n * co - ft_n * s;
    let fy = fn_n * s + ft_n * co;
    let e = c.eccentricity;
    let mz = ft_n * c.tool_radius_m + fx * e.dy_m + fy * e.dx_m;
    Wrench {
        force_n: [fx, fy, 3.0],
        torque_n_m: [0.01, -0.02, mz],
    }
}

#[test]
fn local_forces_recover_the_forward_model() {
    let c = tool(1.3e-3, -0.8e-3);
    let geometry = ToolGeometry::<f64>::new(&c).unwrap();
    let mut noise = Noise(5);
    for _ in 0..1000 {
        let fn_n = 10.0 * (noise.next() + 1.0);
        let ft_n = 4.0 * noise.next();
        let angle = 3.2 * noise.next();
        let got = geometry.local(&sensed(fn_n, ft_n, angle, &c)).unwrap();
        assert!((got.tangential_n - ft_n).abs() < 1e-9, "{got:?}");
        // √ near Fn = 0 amplifies rounding: compare Fn² (1e-9 N²).
        assert!(
            (got.normal_n * got.normal_n - fn_n * fn_n).abs() < 1e-9,
            "{got:?} {fn_n}"
        );
    }
}

#[test]
fn rounding_clamps_to_zero_and_a_real_inconsistency_is_a_fault() {
    // Pure tangential contact (Fn = 0): in f32 the radicand comes out slightly
    // negative for part of the cases; each must clamp to Fn = 0, never NaN.
    let c = tool(1.3e-3, -0.8e-3);
    let g32 = ToolGeometry::<f32>::new(&c).unwrap();
    let mut noise = Noise(17);
    let mut negative = 0;
    for _ in 0..2000 {
        let w = sensed(0.0, 5.0 * noise.next(), 3.2 * noise.next(), &c);
        let w32 = Wrench {
            force_n: w.force_n.map(|v| v as f32),
            torque_n_m: w.torque_n_m.map(|v| v as f32),
        };
        let [fx, fy, _] = w32.force_n;
        let ft = (w32.torque_n_m[2]
            - fx * (c.eccentricity.dy_m as f32)
            - fy * (c.eccentricity.dx_m as f32))
            * (1.0 / c.tool_radius_m as f32);
        if fx * fx + fy * fy - ft * ft < 0.0 {
            negative += 1;
        }
        let got = g32.local(&w32).unwrap();
        // Fn from rounding only: √(32u·(Fx²+Fy²+S²)) with |F| ≤ 5 N, S ≲ 10 N: < 0.02 N.
        assert!(got.normal_n >= 0.0 && got.normal_n < 0.02, "{got:?}");
    }
    assert!(
        negative > 100,
        "{negative}: the test must exercise the clamp"
    );
    // Ft 1 % larger than the planar force: a measurement fault.
    let g = ToolGeometry::<f64>::new(&c).unwrap();
    let mut w = sensed(0.0, 5.0, 0.4, &c);
    w.torque_n_m[2] += 0.01 * 5.0 * c.tool_radius_m;
    match g.local(&w) {
        Err(ForceError::NegativeRadicand { radicand_n2 }) => {
            // 25 − 5.05² = −0.5025 N².
            assert!(
                (f64::from(radicand_n2) + 0.5025).abs() < 1e-4,
                "{radicand_n2}"
            );
        }
        other => panic!("{other:?}"),
    }
    w.force_n[0] = f64::NAN;
    assert_eq!(g.local(&w), Err(ForceError::NotFinite { channel: 0 }));
}

#[test]
fn eccentricity_fit_recovers_a_known_offset_from_noisy_data() {
    // Free spindle (M_s = 0): Mz = Fy Δx + Fx Δy + noise, forces in all directions.
    let (dx, dy) = (1.3e-3, -0.8e-3);
    let sigma = 2e-4; // N·m of moment noise
    let mut noise = Noise(42);
    let mut fit = EccentricityFit::new();
    let mut rows = Vec::new();
    let mut rhs = Vec::new();
    for _ in 0..400 {
        let magnitude = 5.0 + 45.0 * (noise.next() + 1.0) / 2.0;
        let angle = 3.2 * noise.next();
        let (fx, fy) = (magnitude * angle.cos(), magnitude * angle.sin());
        let mz = fy * dx + fx * dy + sigma * noise.gauss();
        fit.push(fx, fy, mz, 0.0).unwrap();
        rows.push([fy, fx]);
        rhs.push(mz);
    }
    let got = fit.solve().unwrap();
    // Reference: the overdetermined system triangularized by Givens rotations (QR,
    // no normal equations), then back substitution. Both in f64 with the condition
    // number near 1: agreement to 1e-12 m.
    let (mut r11, mut r12, mut r22, mut q1, mut q2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (row, &b) in rows.iter().zip(&rhs) {
        let (a1, a2) = (row[0], row[1]);
        let rho = r11.hypot(a1);
        let (c, s) = (r11 / rho, a1 / rho);
        r11 = rho;
        let a2r = -s * r12 + c * a2;
        r12 = c * r12 + s * a2;
        let br = -s * q1 + c * b;
        q1 = c * q1 + s * b;
        let rho2 = r22.hypot(a2r);
        if rho2 == 0.0 {
            continue; // nothing left to rotate (the first row)
        }
        let (c2, s2) = (r22 / rho2, a2r / rho2);
        r22 = rho2;
        q2 = c2 * q2 + s2 * br;
    }
    let x1 = q2 / r22;
    let x0 = (q1 - r12 * x1) / r11;
    assert!(
        (got.dx_m - x0).abs() < 1e-12 && (got.dy_m - x1).abs() < 1e-12,
        "{got:?} {x0} {x1}"
    );
    let a = SMatrix::<f64, 400, 2>::from_fn(|i, j| rows[i][j]);
    // Against the truth: each coordinate's standard deviation is σ/√λ of the normal
    // matrix (forces spread evenly: λ ≈ N·E[F²]/2 ≈ 400·925/2 → σΔ ≈ 5e-7 m); 5σ.
    let lambda_min = (a.transpose() * a).symmetric_eigenvalues().min();
    let bound = 5.0 * sigma / lambda_min.sqrt();
    assert!((got.dx_m - dx).abs() < bound, "{got:?} vs {bound}");
    assert!((got.dy_m - dy).abs() < bound, "{got:?} vs {bound}");
    // With the fitted eccentricity, G eq. 2 gives Ft ≈ 0 for a purely normal load:
    // |δFt| ≤ |F|·|δΔ|/r, |δΔ| < √2·bound.
    let geometry = ToolGeometry::<f64>::new(&tool(got.dx_m, got.dy_m)).unwrap();
    let w = sensed(20.0, 0.0, 0.7, &tool(dx, dy));
    let ft = geometry.local(&w).unwrap().tangential_n;
    assert!(ft.abs() < 20.0 * 1.5 * bound / 2e-3, "{ft}");
}

#[test]
fn known_tangential_load_and_degenerate_data() {
    // With a known moment about the spindle (Ft r), the fit is unbiased too.
    let (dx, dy, r) = (0.5e-3, 0.9e-3, 2e-3);
    let mut fit = EccentricityFit::new();
    for k in 0..8 {
        let angle = k as f64 * 0.8;
        let (fx, fy) = (10.0 * angle.cos(), 10.0 * angle.sin());
        let ft = 3.0;
        fit.push(fx, fy, ft * r + fy * dx + fx * dy, ft * r)
            .unwrap();
    }
    let got = fit.solve().unwrap();
    assert!((got.dx_m - dx).abs() < 1e-15 && (got.dy_m - dy).abs() < 1e-15);
    // All forces along one line: Δ is not observable.
    let mut line = EccentricityFit::new();
    for k in 1..50 {
        let f = k as f64;
        line.push(f, 2.0 * f, 0.01 * f, 0.0).unwrap();
    }
    assert_eq!(line.solve(), Err(ForceError::Degenerate));
    let mut one = EccentricityFit::new();
    one.push(1.0, 0.0, 0.0, 0.0).unwrap();
    assert_eq!(one.solve(), Err(ForceError::Degenerate));
    assert_eq!(
        one.push(f64::NAN, 0.0, 0.0, 0.0),
        Err(ForceError::NotFinite { channel: 0 })
    );
}

#[test]
fn rejects_bad_config() {
    let mut c = FtSensorConfig::ATI_GAMMA_IP60;
    c.calibration[2][4] = f64::NAN;
    assert_eq!(
        FtSensor::<f32>::new(&c).err(),
        Some(ConfigError::not_finite("calibration").indexed(2))
    );
    let c = FtSensorConfig {
        raw_full_scale_v: 0.0,
        ..FtSensorConfig::ATI_GAMMA_IP60
    };
    assert_eq!(
        FtSensor::<f32>::new(&c).err(),
        Some(ConfigError::not_positive("raw_full_scale_v"))
    );
    assert_eq!(
        ToolGeometry::<f32>::new(&ToolConfig {
            tool_radius_m: -1.0,
            ..tool(0.0, 0.0)
        })
        .err(),
        Some(ConfigError::not_positive("tool_radius_m"))
    );
    assert_eq!(
        BiasCapture::<f32>::new(&capture_config(0)).err(),
        Some(ConfigError::not_positive("samples"))
    );
}

/// Out of contact the readings are noise alone: with G's 0.8 N² (σ = 0.89 N on
/// Fx, Fy and on Ft), a radicand within (7σ)² below zero clamps to Fn = 0 — over
/// 10,000 noise samples none faults — while the same readings with σ = 0 declared
/// fault on the first Ft² > Fx² + Fy²; and a reading 10 N² further below still faults.
#[test]
fn noise_out_of_contact_clamps_to_zero() {
    let sigma = 0.8f64.sqrt();
    let noisy = ToolGeometry::<f64>::new(&ToolConfig {
        noise_n: sigma,
        ..tool(0.0, 0.0)
    })
    .unwrap();
    let exact = ToolGeometry::<f64>::new(&tool(0.0, 0.0)).unwrap();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut normal = || {
        // Irwin–Hall: the sum of 12 uniforms minus 6, unit variance.
        (0..12)
            .map(|_| {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                (seed >> 11) as f64 / (1u64 << 53) as f64
            })
            .sum::<f64>()
            - 6.0
    };
    let (mut exact_faults, mut zeros) = (0, 0);
    for _ in 0..10_000 {
        let (fx, fy, ft) = (sigma * normal(), sigma * normal(), sigma * normal());
        let w = Wrench {
            force_n: [fx, fy, 0.0],
            torque_n_m: [0.0, 0.0, ft * 2e-3],
        };
        let local = noisy.local(&w).unwrap();
        if local.normal_n == 0.0 {
            zeros += 1;
        }
        if exact.local(&w).is_err() {
            exact_faults += 1;
        }
    }
    assert!(
        zeros > 2000 && exact_faults == zeros,
        "{zeros} {exact_faults}"
    );
    let far = Wrench {
        force_n: [1.0, 0.0, 0.0],
        torque_n_m: [0.0, 0.0, (1.0f64 + 49.0 * 0.8 + 10.0).sqrt() * 2e-3],
    };
    assert!(matches!(
        noisy.local(&far),
        Err(ForceError::NegativeRadicand { .. })
    ));
}
