extern crate std;
use super::*;
use kerf::codec::dct::Dct;
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::kinematics::Vector3;
use kerf::trajectory::efd::Efd;
use kerf::trajectory::shapes;

/// Deterministic test blocks: a two-tone signal, an impulse, a ramp and a
/// pseudo-random block.
fn blocks<const N: usize>() -> [[f32; N]; 4] {
    let mut seed = 0x1234_5678u32;
    [
        core::array::from_fn(|n| {
            let t = n as f32 * 1e-4;
            0.6 * libm::sinf(2.0 * core::f32::consts::PI * 230.0 * t)
                + 0.25 * libm::sinf(2.0 * core::f32::consts::PI * 1700.0 * t + 0.4)
        }),
        core::array::from_fn(|n| if n == 3 { 1.0 } else { 0.0 }),
        core::array::from_fn(|n| n as f32 / N as f32 - 0.5),
        core::array::from_fn(|_| {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        }),
    ]
}

fn fft_dct_matches_kerf<const N: usize>() {
    let (fft, kerf) = (FftDct::<N>::new().unwrap(), Dct::<N>::new().unwrap());
    for x in blocks::<N>() {
        let (mut a, mut b) = (x, x);
        fft.forward(&mut a);
        kerf.forward(&mut b);
        let peak = b.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let worst = a
            .iter()
            .zip(&b)
            .fold(0.0f32, |m, (p, q)| m.max((p - q).abs()));
        assert!(
            worst <= 1e-6 * peak.max(1.0),
            "N={N}: {worst} (peak {peak})"
        );
        // And against the defining sum in f64.
        for (k, got) in a.iter().enumerate() {
            let s = if k == 0 {
                (1.0 / N as f64).sqrt()
            } else {
                (2.0 / N as f64).sqrt()
            };
            let exact: f64 = s * x
                .iter()
                .enumerate()
                .map(|(n, &v)| {
                    f64::from(v)
                        * (core::f64::consts::PI * (2 * n + 1) as f64 * k as f64 / (2 * N) as f64)
                            .cos()
                })
                .sum::<f64>();
            assert!((f64::from(*got) - exact).abs() < 1e-6, "N={N} k={k}");
        }
    }
}

#[test]
fn fft_dct_matches_kerfs_dct_to_1e6() {
    fft_dct_matches_kerf::<32>();
    fft_dct_matches_kerf::<64>();
    assert!(FftDct::<16>::new().is_none());
}

#[test]
fn printer_formula_matches_kerfs_inverse_on_a_printer() {
    let angles = [210.0f64, 330.0, 90.0].map(f64::to_radians);
    let (radius, arm) = (0.1, 0.25);
    let config = DeltaConfig::printer(radius, angles, [arm; 3], (0.0, 1.0));
    let geometry = DeltaGeometry::<f32>::new(&config).unwrap();
    let towers = angles.map(|a| Tower {
        x: (radius * a.cos()) as f32,
        y: (radius * a.sin()) as f32,
        arm2: (arm * arm) as f32,
    });
    for p in [[0.0, 0.0, 0.1], [0.03, -0.02, 0.12], [-0.05, 0.04, 0.08]] {
        let q = printer_inverse(&towers, p, kerf::scalar::sqrt_f32);
        let k = geometry.inverse(&Vector3::new(p[0], p[1], p[2])).unwrap();
        for i in 0..3 {
            assert!((q[i] - k[i]).abs() < 1e-6, "{q:?} vs {k:?}");
        }
    }
}

#[test]
fn direct_efd_sum_matches_kerfs_recurrence() {
    let efd = Efd::<f32, 10>::from_polygon(&shapes::gear(), 10).unwrap();
    for i in 0..64 {
        let theta = 0.1 + 6.2 * i as f32 / 64.0;
        let s = efd.evaluate(theta);
        let d = efd_direct(efd.coefficients(), theta);
        let kerf = efd_sample_flat(&s);
        for (j, (a, b)) in kerf.iter().zip(d).enumerate() {
            assert!(
                (a - b).abs() <= 1e-5 * (1.0 + b.abs()),
                "θ={theta} output {j}: {a} vs {b}"
            );
        }
    }
}
