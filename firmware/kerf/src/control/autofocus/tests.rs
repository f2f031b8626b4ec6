use super::*;
use std::println;
use std::vec::Vec;

const TS_S: f64 = 1e-3;

/// The host scenario's focus axis and camera, with 0.5 mm kept clear at each end.
const CFG: AutofocusConfig = AutofocusConfig {
    travel_m: [0.5e-3, 9.5e-3],
    ..AutofocusConfig::FOCUS_10MM_100FPS
};

/// Deterministic Gaussian noise (xorshift64* + Box–Muller).
struct Gauss(u64);

impl Gauss {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let r = (-2.0 * self.uniform().ln()).sqrt();
        r * (2.0 * std::f64::consts::PI * self.uniform()).cos()
    }
}

#[test]
fn sigmoid_is_eq_158() {
    let af = Autofocus::<f64, 32>::new(&CFG, TS_S).unwrap();
    let (mu0, alpha) = (CFG.max_speed_m_s, CFG.sigmoid_gain);
    for k in -200..=200 {
        let g = f64::from(k) * 37.0; // 1/m: up to α g = ±7.4
        let got = af.velocity_reference(g);
        // 1 − 2/(1 + e^(−x)) = −tanh(x/2), computed another way.
        let expected = -mu0 * (alpha * g / 2.0).tanh();
        assert!((got - expected).abs() < 1e-15, "{g}: {got} {expected}");
        // Against the gradient of −S: g > 0 (S falls with q) moves toward −q.
        assert!(got * g <= 0.0);
    }
    assert_eq!(af.velocity_reference(1e30), -mu0);
    assert_eq!(af.velocity_reference(-1e30), mu0);
    assert_eq!(af.velocity_reference(f64::NAN), 0.0);
    let af32 = Autofocus::<f32, 32>::new(&CFG, TS_S).unwrap();
    assert!(
        (f64::from(af32.velocity_reference(500.0)) + mu0 * (alpha * 250.0).tanh()).abs() < 1e-9
    );
}

/// The window is the shortest run of newest frames spanning δ, and the gradient is
/// the least-squares slope of −S over it (checked against a slope fitted here in
/// closed form from the frames it should contain); relative divides by the mean.
#[test]
fn gradient_is_the_least_squares_slope_over_the_window_spanning_delta() {
    let af = Autofocus::<f64, 32>::new(&CFG, TS_S).unwrap();
    let mut state = AutofocusState::<f64, 32>::default();
    assert_eq!(af.gradient(&state), None);
    // Frames 22 µm apart on S = 3 + 2e3 q − 4e6 q²: the newest 6 span 110 µm ≥ δ
    // = 100 µm, 5 only 88 µm.
    let s = |q: f64| 3.0 + 2e3 * q - 4e6 * q * q;
    let qs: Vec<f64> = (0..12).map(|k| 1e-3 + 2.2e-5 * f64::from(k)).collect();
    for (k, &q) in qs.iter().enumerate() {
        state.push(q, s(q));
        let expected_frames = if k + 1 >= 6 { 6 } else { 0 };
        match af.gradient(&state) {
            None => assert_eq!(expected_frames, 0, "frame {k}"),
            Some((g, mean)) => {
                assert_eq!(expected_frames, 6, "frame {k}");
                let window = &qs[k + 1 - 6..=k];
                // A quadratic's LS slope over points symmetric about their centroid
                // is its derivative there.
                let centroid = window.iter().sum::<f64>() / 6.0;
                let mean_s = window.iter().map(|&q| s(q)).sum::<f64>() / 6.0;
                let slope = 2e3 - 8e6 * centroid;
                assert!((mean - mean_s).abs() < 1e-12);
                assert!(
                    (g + slope / mean_s).abs() < 1e-9 * slope.abs(),
                    "{g} {slope}"
                );
            }
        }
    }
    // At rest, nothing spans δ: no gradient.
    let mut still = AutofocusState::<f64, 32>::default();
    for _ in 0..40 {
        still.push(2e-3, 4.0);
    }
    assert_eq!(af.gradient(&still), None);
    // Absolute: the slope of −S itself.
    let absolute = Autofocus::<f64, 32>::new(
        &AutofocusConfig {
            gradient_scale: GradientScale::Absolute,
            ..CFG
        },
        TS_S,
    )
    .unwrap();
    let (g_abs, mean) = absolute.gradient(&state).unwrap();
    let (g_rel, _) = af.gradient(&state).unwrap();
    assert!((g_abs - g_rel * mean).abs() < 1e-9 * g_abs.abs());
}

/// A kinematic focus axis (exact double integrator, 1 kHz) on a noisy unimodal
/// surface, two Gaussians in the defocus d (a broad one of σ = 3 mm, the scene's
/// coarse texture, and a narrow one of 0.3 mm, its detail) over a floor, frames at
/// 100 Hz with 0.5 % multiplicative noise: from rest 6 mm away the law searches,
/// tracks and holds near the peak; after the peak jumps 3 mm (a zoom change) it
/// searches again. Returns the largest |q − q*| over the last 2 s before the jump
/// and before the end, and the modes in order.
fn closed_loop<T: Float>() -> (f64, f64, Vec<AutofocusMode<T>>) {
    let af = Autofocus::<T, 32>::new(&CFG, TS_S).unwrap();
    let mut state = AutofocusState::<T, 32>::default();
    let mut noise = Gauss(7);
    let (mut q, mut v) = (8e-3, 0.0f64);
    let mut peak = 2e-3;
    let mut modes: Vec<AutofocusMode<T>> = Vec::new();
    let mut worst = (0.0f64, 0.0f64);
    for k in 0..12_000 {
        let t = k as f64 * TS_S;
        if k == 6000 {
            peak = 5e-3;
        }
        if k % 10 == 0 {
            let d = q - peak;
            let shape = 3.0 * (-d * d / (2.0 * 3e-3f64.powi(2))).exp()
                + 0.5 * (-d * d / (2.0 * 0.3e-3f64.powi(2))).exp()
                + 0.1;
            let s = shape * (1.0 + 0.005 * noise.normal());
            let mode = af.frame(&mut state, lit(q), lit(s)).unwrap();
            let same = modes
                .last()
                .is_some_and(|m| core::mem::discriminant(m) == core::mem::discriminant(&mode));
            if !same {
                modes.push(mode);
            }
        }
        let a = to_f64(af.step(&mut state, lit(q), lit(v)).unwrap());
        assert!(a.abs() <= CFG.max_acceleration_m_s2 * (1.0 + 1e-6));
        q += v * TS_S + 0.5 * a * TS_S * TS_S;
        v += a * TS_S;
        if (4.0..6.0).contains(&t) {
            worst.0 = worst.0.max((q - 2e-3).abs());
        }
        if t >= 10.0 {
            worst.1 = worst.1.max((q - 5e-3).abs());
        }
    }
    (worst.0, worst.1, modes)
}

#[test]
fn closed_loop_finds_and_refinds_the_peak_in_f64_and_f32() {
    // Within a third of the narrow component's σ.
    let w = 0.2e-3;
    let (first, second, modes) = closed_loop::<f64>();
    assert!(
        first < w / 2.0 && second < w / 2.0,
        "{first:e} {second:e} {modes:?}"
    );
    assert!(matches!(modes.first(), Some(AutofocusMode::Search { .. })));
    assert_eq!(modes.len(), 6, "{modes:?}");
    println!("f64: {first:e} m, {second:e} m, {modes:?}");
    // The same run in f32 (the same noise): the same modes, the same residual to
    // well below a micrometre.
    let (first32, second32, modes32) = closed_loop::<f32>();
    println!("f32: {first32:e} m, {second32:e} m, {modes32:?}");
    assert_eq!(modes32.len(), 6, "{modes32:?}");
    assert!((first32 - first).abs() < 1e-7 && (second32 - second).abs() < 1e-7);
}

#[test]
fn search_reverses_at_the_travel_limits_and_never_drives_out() {
    let af = Autofocus::<f64, 32>::new(&CFG, TS_S).unwrap();
    let mut state = AutofocusState::<f64, 32>::default();
    // Below the middle: search upward; at the maximum, downward.
    assert_eq!(
        af.frame(&mut state, 1e-3, 1.0),
        Ok(AutofocusMode::Search { direction: 1 })
    );
    assert!(state.target_velocity_m_s > 0.0);
    let mut at_max = AutofocusState::<f64, 32> {
        mode: AutofocusMode::Search { direction: 1 },
        ..Default::default()
    };
    assert_eq!(
        af.frame(&mut at_max, 9.6e-3, 1.0),
        Ok(AutofocusMode::Search { direction: -1 })
    );
    assert!(at_max.target_velocity_m_s < 0.0);
    // A reference pointing out of the travel is zeroed beyond the limit: the command
    // only brakes.
    let mut out = AutofocusState::<f64, 32> {
        reference_velocity_m_s: 5e-3,
        target_velocity_m_s: 5e-3,
        ..Default::default()
    };
    let a = af.step(&mut out, 9.6e-3, 5e-3).unwrap();
    assert_eq!(out.reference_velocity_m_s, 0.0);
    assert!(a < 0.0);
}

#[test]
fn bad_input_is_a_typed_error_and_the_output_stays_finite() {
    let af = Autofocus::<f32, 32>::new(&CFG, TS_S).unwrap();
    let mut state = AutofocusState::<f32, 32>::default();
    for k in 0..50 {
        let q = 1e-3 + 2e-5 * k as f32;
        af.frame(&mut state, q, 1.0 + q * 100.0).unwrap();
        af.step(&mut state, q, 2e-3).unwrap();
    }
    assert_ne!(state.target_velocity_m_s, 0.0);
    for (q, s) in [(f32::NAN, 1.0), (1e-3, f32::NAN), (f32::INFINITY, 1.0)] {
        assert_eq!(af.frame(&mut state, q, s), Err(AutofocusError::NotFinite));
        assert_eq!(state.target_velocity_m_s, 0.0);
        assert_eq!(state.gradient, None);
    }
    // A textureless frame: S below the threshold (or exactly zero).
    for s in [0.0, 0.04] {
        assert_eq!(
            af.frame(&mut state, 1e-3, s),
            Err(AutofocusError::NoTexture)
        );
    }
    // The reference ramps to zero; the command is finite throughout.
    for _ in 0..20 {
        let a = af.step(&mut state, 1e-3, 0.0).unwrap();
        assert!(a.is_finite());
    }
    assert_eq!(state.reference_velocity_m_s, 0.0);
    for (q, v) in [(f32::NAN, 0.0), (0.0, f32::NAN), (0.0, f32::NEG_INFINITY)] {
        assert_eq!(af.step(&mut state, q, v), Err(AutofocusError::NotFinite));
        assert_eq!(state.reference_velocity_m_s, 0.0);
    }
    // After the fault, valid frames start a new search.
    assert!(matches!(
        af.frame(&mut state, 1e-3, 1.0),
        Ok(AutofocusMode::Search { .. })
    ));
}

#[test]
fn rejects_bad_config() {
    let with = |f: fn(&mut AutofocusConfig)| {
        let mut c = CFG;
        f(&mut c);
        Autofocus::<f32, 32>::new(&c, TS_S)
            .err()
            .map(|e| (e.kind, e.field()))
    };
    use crate::ConfigErrorKind::*;
    assert_eq!(
        with(|c| c.max_speed_m_s = 0.0),
        Some((NotPositive, "max_speed_m_s"))
    );
    assert_eq!(
        with(|c| c.sigmoid_gain = f64::NAN),
        Some((NotFinite, "sigmoid_gain"))
    );
    assert_eq!(
        with(|c| c.tracking_gain_per_s = 2000.0),
        Some((OutOfRange, "tracking_gain_per_s"))
    );
    assert_eq!(
        with(|c| c.travel_m = [1e-3, 1e-3]),
        Some((OutOfRange, "travel_m"))
    );
    assert_eq!(
        with(|c| c.frame_period_s = 1e-4),
        Some((OutOfRange, "frame_period_s"))
    );
    assert_eq!(
        with(|c| c.min_window_frames = 2),
        Some((OutOfRange, "min_window_frames"))
    );
    assert_eq!(
        with(|c| c.min_window_frames = 33),
        Some((OutOfRange, "min_window_frames"))
    );
    assert_eq!(
        with(|c| c.search_speed_m_s = 0.02),
        Some((OutOfRange, "search_speed_m_s"))
    );
    assert_eq!(
        with(|c| c.refocus_change = 1.0),
        Some((OutOfRange, "refocus_change"))
    );
    assert_eq!(
        with(|c| c.min_sharpness = -1.0),
        Some((NotPositive, "min_sharpness"))
    );
    assert_eq!(
        with(|c| c.window_excursion_m = 0.0),
        Some((NotPositive, "window_excursion_m"))
    );
    assert_eq!(with(|_| {}), None);
}
