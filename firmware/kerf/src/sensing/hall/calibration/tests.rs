//! The fitted sensor model's own arithmetic against independent forms: the model's
//! prediction against its linear form in the harmonic basis (module docs), the mean
//! amplitude against Pythagorean triples, the linear demodulation against the phase
//! it must return.

use super::*;

/// θ·(1, sin φ, cos φ, sin 3φ, cos 3φ, sin 5φ, cos 5φ): the channel model in the
/// linear form the fit solves for (module docs), evaluated term by term.
fn basis_form(theta: &[f64; BASIS], phi: f64) -> f64 {
    let basis = [
        1.0,
        libm::sin(phi),
        libm::cos(phi),
        libm::sin(3.0 * phi),
        libm::cos(3.0 * phi),
        libm::sin(5.0 * phi),
        libm::cos(5.0 * phi),
    ];
    theta.iter().zip(basis).map(|(t, b)| t * b).sum()
}

/// Three channels' coefficients: offsets, fundamentals 120° apart with gain and
/// phase errors, third and fifth harmonics of their own amplitude and phase.
fn thetas() -> [[f64; BASIS]; 3] {
    [
        [32768.0, 26000.0, 300.0, 500.0, -200.0, 90.0, 60.0],
        [31000.0, -13500.0, 23100.0, -400.0, 350.0, -70.0, 40.0],
        [33500.0, -12600.0, -22400.0, 260.0, 510.0, 30.0, -110.0],
    ]
}

/// Each channel's prediction is its linear form at every phase (f64 sums of terms of
/// 3e4 counts: 1e-9 relative of the amplitude is a thousand times their rounding):
/// the amplitudes and phases `from_coefficients` extracts and `predict` puts back
/// agree with the coefficients, harmonics and their phases included; the axis'
/// prediction is its channels', in order.
#[test]
fn the_prediction_is_the_linear_form_of_the_coefficients() {
    let thetas = thetas();
    let model = SensorModel {
        channels: thetas.map(|t| ChannelModel::from_coefficients(&t)),
    };
    for i in 0..360 {
        let phi = 2.0 * PI * f64::from(i) / 360.0 - 1.0;
        let all = model.predict(phi);
        for (k, theta) in thetas.iter().enumerate() {
            let want = basis_form(theta, phi);
            let tolerance = 1e-9 * model.channels[k].amplitude_counts;
            assert!(
                (model.channels[k].predict(phi) - want).abs() < tolerance,
                "channel {k} at {phi}"
            );
            assert!(
                (all[k] - want).abs() < tolerance,
                "axis, channel {k} at {phi}"
            );
        }
    }
}

/// The mean amplitude of fundamentals (3, 4)·1000, (−6, 8)·1000 and (9, −12)·1000:
/// the triples' hypotenuses 5000, 10000 and 15000, mean 10000 (exact in f64 up to
/// the rounding of a square root).
#[test]
fn the_mean_amplitude_is_the_mean_of_the_fundamentals() {
    let channel =
        |s: f64, c: f64| ChannelModel::from_coefficients(&[100.0, s, c, 700.0, -300.0, 50.0, 20.0]);
    let model = SensorModel {
        channels: [
            channel(3000.0, 4000.0),
            channel(-6000.0, 8000.0),
            channel(9000.0, -12000.0),
        ],
    };
    assert!((model.mean_amplitude_counts() - 10000.0).abs() < 1e-9);
}

/// On sensors with fundamentals only (offsets, gains and phases per channel), the
/// linear rows return sin φ and cos φ at every phase (f32 rows: 6e-8 relative per
/// entry, three entries of 0.7/A against 1.1 A of signal: 1e-6), the health row reads
/// nothing of the fundamentals (f32 entries of order 1 against 3e4 counts: 0.02), the
/// offsets are the model's and the range is the extremes of a brute-force sweep of
/// 10⁵ phases (1e-4 A). Channels all of one phase carry no phase: singular.
#[test]
fn the_linear_rows_demodulate_the_fundamentals() {
    let mut thetas = thetas();
    for t in &mut thetas {
        t[3..].fill(0.0);
    }
    let model = SensorModel {
        channels: thetas.map(|t| ChannelModel::from_coefficients(&t)),
    };
    let linear = model.linear_calibration().unwrap();
    let mut extremes = [[f64::MAX, f64::MIN]; 3];
    for i in 0..100_000 {
        let phi = 2.0 * PI * f64::from(i) / 100_000.0;
        let u = model.predict(phi);
        for ([lo, hi], u) in extremes.iter_mut().zip(u) {
            *lo = lo.min(u);
            *hi = hi.max(u);
        }
        if i % 100 != 0 {
            continue;
        }
        let (s, c) = linear.demodulate_f64(u);
        assert!(
            (s - phi.sin()).abs() < 1e-6 && (c - phi.cos()).abs() < 1e-6,
            "{phi}"
        );
        let health: f64 = (0..3)
            .map(|k| f64::from(linear.sum_row[k]) * (u[k] - thetas[k][0]))
            .sum();
        assert!(health.abs() < 0.02, "{phi}: {health}");
    }
    let amplitude = model.mean_amplitude_counts();
    for k in 0..3 {
        assert_eq!(f64::from(linear.offset_counts[k]), thetas[k][0]);
        for (got, want) in linear.range_counts[k].iter().zip(extremes[k]) {
            assert!((f64::from(*got) - want).abs() < 1e-4 * amplitude, "{k}");
        }
    }
    let same = SensorModel {
        channels: [thetas[0]; 3].map(|t| ChannelModel::from_coefficients(&t)),
    };
    assert_eq!(same.linear_calibration(), Err(CalibrationError::Singular));
}
