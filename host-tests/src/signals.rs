//! Representative signals for the codec reports: what a master/slave link of a machining
//! robot carries (positions, currents, forces), sampled at [`FS_HZ`].

use hal_mock::noise::Noise;

/// Sample rate of every signal, Hz.
pub const FS_HZ: f64 = 10_000.0;
/// Samples per signal: 64 blocks of 64 (0.41 s).
pub const LEN: usize = 4096;

/// A named test signal.
pub struct Signal {
    /// Short name for report tables.
    pub name: &'static str,
    /// The samples, at [`FS_HZ`].
    pub samples: Vec<f64>,
}

fn make(name: &'static str, f: impl FnMut(usize, f64) -> f64) -> Signal {
    let mut f = f;
    Signal {
        name,
        samples: (0..LEN).map(|i| f(i, i as f64 / FS_HZ)).collect(),
    }
}

/// Second-order low-pass (two cascaded one-pole sections) of seeded white noise.
fn band_limited_noise(seed: u64, cutoff_hz: f64, gain: f64) -> Vec<f64> {
    let a = (-2.0 * core::f64::consts::PI * cutoff_hz / FS_HZ).exp();
    let mut noise = Noise::new(seed);
    let (mut y1, mut y2) = (0.0, 0.0);
    (0..LEN)
        .map(|_| {
            y1 = a * y1 + (1.0 - a) * noise.normal();
            y2 = a * y2 + (1.0 - a) * y1;
            gain * y2
        })
        .collect()
}

/// The report's signal set.
pub fn all() -> Vec<Signal> {
    use core::f64::consts::PI;
    let noise = band_limited_noise(5, 300.0, 4.0);
    let texture_noise = band_limited_noise(9, 2_000.0, 0.3);
    vec![
        // Motion reference: three tones (37 Hz, 210 Hz, 1.13 kHz).
        make("sines", |_, t| {
            0.5 * (2.0 * PI * 37.0 * t).sin()
                + 0.3 * (2.0 * PI * 210.0 * t + 1.0).sin()
                + 0.1 * (2.0 * PI * 1130.0 * t).sin()
        }),
        // Position step off a block boundary.
        make("step", |i, _| if i >= 1000 { 0.8 } else { -0.2 }),
        // Linear chirp 10 Hz → 2 kHz over the record.
        make("chirp", |_, t| {
            let dur = LEN as f64 / FS_HZ;
            0.7 * (2.0 * PI * (10.0 * t + 0.5 * (2000.0 - 10.0) / dur * t * t)).sin()
        }),
        // Gaussian noise low-passed at 300 Hz.
        make("noise300", |i, _| noise[i]),
        // Tool touching the work: free air, a 2 ms half-sine impact of 40 N, then a
        // 150 Hz ring-down onto a 10 N contact force (N).
        make("impact", |_, t| {
            let t0 = 0.1;
            let dt = t - t0;
            if dt < 0.0 {
                0.0
            } else if dt < 0.002 {
                40.0 * (PI * dt / 0.002).sin()
            } else {
                10.0 + 15.0 * (-(dt - 0.002) / 0.01).exp() * (2.0 * PI * 150.0 * (dt - 0.002)).sin()
            }
        }),
        // Grinding texture: 20 N normal force with an amplitude-modulated 800 Hz grit
        // line and broadband vibration (N).
        make("texture", |i, t| {
            20.0 + 0.5 * (1.0 + 0.5 * (2.0 * PI * 7.0 * t).sin()) * (2.0 * PI * 800.0 * t).sin()
                + texture_noise[i]
        }),
    ]
}

/// 10 log10(Σx² / Σ(x − y)²) in dB (`inf` for an exact copy).
pub fn snr_db(x: &[f64], y: &[f64]) -> f64 {
    let signal: f64 = x.iter().map(|v| v * v).sum();
    let noise: f64 = x.iter().zip(y).map(|(a, b)| (a - b) * (a - b)).sum();
    10.0 * (signal / noise).log10()
}
