//! Self-optimizing autofocus on the simulated zoom camera (T 7.2.2, T 8.5;
//! docs/control.md §24, Autofocus). The firmware's parts run as on the MCU, in `f32`: the
//! integer sharpness kernel on each 64 × 64 frame, the gradient window and the
//! sigmoid velocity reference once per frame, the acceleration-level tracking law
//! every 1 ms period; the focus axis is the DOB-compensated double integrator of
//! `hal_mock::focus` with hard stops at 0 and 10 mm.
//!
//! T 8.5's two experiments: from a defocused cold start the loop finds focus, then
//! the magnification changes (the zoom motor ramps m from 1 to 2 in 0.5 s, moving the
//! focus from 2 to 5 mm and halving the depth of field) and it finds the new focus.
//!
//! Camera timing: 100 frames/s; a frame's sharpness reaches the law one frame after
//! its exposure, paired with the position the axis had at the exposure.

use hal_mock::focus::{CameraParams, FocusAxis, ZoomCamera, FRAME_PIXELS, FRAME_SIDE};
use host_tests::plot::{line_plot, plots_dir, time_series, Series};
use kerf::control::autofocus::{
    Autofocus, AutofocusConfig, AutofocusError, AutofocusMode, AutofocusState,
};
use kerf::sensing::sharpness::{normalized_variance, SharpnessError, Window};

const TS_S: f64 = 1e-3;
/// Control periods per camera frame (100 frames/s).
const PERIODS_PER_FRAME: usize = 10;
/// Frames in the gradient window's ring.
const RING: usize = 32;
/// The zoom change: m from 1 to 2, starting at this time, over `ZOOM_RAMP_S`.
const ZOOM_AT_S: f64 = 8.0;
const ZOOM_RAMP_S: f64 = 0.5;
const END_S: f64 = 16.0;
const START_M: f64 = 9e-3;

/// The whole frame is the window.
const WINDOW: Window = Window {
    x_px: 0,
    y_px: 0,
    width_px: FRAME_SIDE,
    height_px: FRAME_SIDE,
};

/// The law's settings for this camera (the preset's docs say why; see the report at
/// the end of the scenario for what they give).
const CONFIG: AutofocusConfig = AutofocusConfig::FOCUS_10MM_100FPS;

/// One period's record.
#[derive(Copy, Clone, Debug)]
struct Sample {
    t_s: f64,
    q_m: f64,
    focus_m: f64,
    depth_of_field_m: f64,
    sharpness: f64,
    acceleration_m_s2: f64,
}

struct Run {
    samples: Vec<Sample>,
    modes: Vec<(f64, AutofocusMode<f32>)>,
}

fn magnification_at(t_s: f64) -> f64 {
    1.0 + ((t_s - ZOOM_AT_S) / ZOOM_RAMP_S).clamp(0.0, 1.0)
}

fn run(seed: u64) -> Run {
    let law = Autofocus::<f32, RING>::new(&CONFIG, TS_S).unwrap();
    let mut state = AutofocusState::<f32, RING>::default();
    let mut camera = ZoomCamera::new(CameraParams::ZOOM_INSPECTION, seed);
    let mut axis = FocusAxis::new(START_M, [0.0, 10e-3], TS_S);
    let mut frame = [0u8; FRAME_PIXELS];
    // The frame being read out: its exposure position and sharpness.
    let mut pending: Option<(f64, f32)> = None;
    let mut sharpness = f64::NAN;
    let mut samples = Vec::new();
    let mut modes: Vec<(f64, AutofocusMode<f32>)> = Vec::new();
    let periods = (END_S / TS_S) as usize;
    for k in 0..periods {
        let t = k as f64 * TS_S;
        camera.magnification = magnification_at(t);
        if k % PERIODS_PER_FRAME == 0 {
            if let Some((q_exposure, s)) = pending.take() {
                let mode = law.frame(&mut state, q_exposure as f32, s).unwrap();
                if modes.last().map(|(_, m)| std::mem::discriminant(m))
                    != Some(std::mem::discriminant(&mode))
                {
                    modes.push((t, mode));
                }
            }
            camera.capture(axis.position_m, &mut frame);
            let s = normalized_variance(&frame, FRAME_SIDE, &WINDOW).unwrap();
            sharpness = f64::from(s);
            pending = Some((axis.position_m, s));
        }
        let a = law
            .step(&mut state, axis.position_m as f32, axis.velocity_m_s as f32)
            .unwrap();
        axis.step(f64::from(a));
        let m = camera.magnification;
        samples.push(Sample {
            t_s: t,
            q_m: axis.position_m,
            focus_m: camera.params.focus_m(m),
            depth_of_field_m: camera.params.depth_of_field_m(m),
            sharpness,
            acceleration_m_s2: f64::from(a),
        });
    }
    Run { samples, modes }
}

/// Time from `from_s` until |q − q_focus| stays within `fraction` of the depth of
/// field w up to `to_s` (`None`: it never does), and the largest defocus over the
/// last second before `to_s`, in units of w.
fn focus_figures(run: &Run, from_s: f64, to_s: f64, fraction: f64) -> (Option<f64>, f64) {
    let phase: Vec<&Sample> = run
        .samples
        .iter()
        .filter(|s| s.t_s >= from_s && s.t_s < to_s)
        .collect();
    let defocus = |s: &Sample| (s.q_m - s.focus_m).abs() / s.depth_of_field_m;
    let last_out = phase.iter().rposition(|s| defocus(s) > fraction);
    let time = match last_out {
        None => Some(0.0),
        Some(i) if i + 1 < phase.len() => Some(phase[i + 1].t_s - from_s),
        Some(_) => None,
    };
    let residual = phase
        .iter()
        .filter(|s| s.t_s >= to_s - 1.0)
        .map(|s| defocus(s))
        .fold(0.0, f64::max);
    (time, residual)
}

fn plots(run: &Run, camera: &ZoomCamera) {
    let dir = plots_dir().unwrap();
    let q: Vec<(f64, f64)> = run.samples.iter().map(|s| (s.t_s, s.q_m * 1e3)).collect();
    let focus: Vec<(f64, f64)> = run
        .samples
        .iter()
        .map(|s| (s.t_s, s.focus_m * 1e3))
        .collect();
    time_series(
        &dir.join("autofocus_position.svg"),
        "Autofocus: focus position (cold start at m = 1, zoom to m = 2 at 8 s)",
        "focus position (mm)",
        &[
            Series::new("q", &q, 0),
            Series::new("q_focus(m)", &focus, 1),
        ],
    )
    .unwrap();
    let s: Vec<(f64, f64)> = run.samples.iter().map(|s| (s.t_s, s.sharpness)).collect();
    time_series(
        &dir.join("autofocus_sharpness.svg"),
        "Autofocus: measured sharpness (normalized variance)",
        "sharpness (grey levels)",
        &[Series::new("S", &s, 0)],
    )
    .unwrap();
    // The surface the law climbs: S(q) at both magnifications (T fig. 7.13 B).
    let mut camera = camera.clone();
    let mut curves = Vec::new();
    for m in [1.0, 1.5, 2.0] {
        camera.magnification = m;
        curves.push(
            (0..=400)
                .map(|k| {
                    let q = k as f64 * 2.5e-5;
                    (q * 1e3, camera.expected_sharpness(q))
                })
                .collect::<Vec<_>>(),
        );
    }
    line_plot(
        &dir.join("autofocus_surface.svg"),
        "Sharpness against focus position at m = 1, 1.5, 2 (simulated camera)",
        "focus position (mm)",
        "sharpness (grey levels)",
        &[
            Series::new("m = 1", &curves[0], 0),
            Series::new("m = 1.5", &curves[1], 1),
            Series::new("m = 2", &curves[2], 2),
        ],
    )
    .unwrap();
}

/// Eight textures (camera seeds), each a different scene: time to focus and the
/// residual defocus, in units of the depth of field ±w (w = b0/(β m): 0.4 mm at
/// m = 1, 0.2 mm at m = 2).
///
/// Bounds:
/// - In focus means |q − q_focus| ≤ w/2. The residual is noise-limited: the
///   measured sharpness scatters by about 0.6 % per frame (0.5 % flicker, the rest
///   pixel noise; printed below), so a 32-frame window spanning δ = 0.1 mm gives the
///   relative gradient to 0.006·√(12/32)/δ ≈ 37 m⁻¹ (one standard deviation); at
///   m = 1 the relative curvature at the peak is about 5e5 m⁻², so the gradient's
///   zero is found to about 0.07 mm = 0.2 w, and the axis stops within w/2 (2.5
///   standard deviations) on every texture.
/// - Cold start, 7 mm (17 w) from focus: on the flank the relative gradient is at
///   least about 300 m⁻¹ (the surface plot), so the speed is at least
///   μ0 tanh(α g/2) = 2.7 mm/s: 2.6 s, plus the search's first 0.1 s and the final
///   linear approach (time constant 0.2 s): within 4 s.
/// - Zoom: the focus moves 3 mm (15 w at m = 2) during the 0.5 s ramp; the held
///   sharpness changes by 5 % within 0.1 s of the ramp's start, and at m = 2 the
///   relative gradient is at least about 900 m⁻¹ on the flank (speed ≥ 4.6 mm/s):
///   about 1.3 s after the zoom starts; within 2.5 s.
#[test]
fn finds_focus_from_a_cold_start_and_after_a_zoom_change() {
    let tolerance = 0.5;
    let mut worst: [f64; 4] = [0.0; 4];
    println!(
        "seed | cold start: s to |d| < w/2, residual/w | zoom: s, residual/w | S scatter at rest"
    );
    for seed in 1..=8 {
        let run = run(seed);
        let (cold_time, cold_residual) = focus_figures(&run, 0.0, ZOOM_AT_S, tolerance);
        let (zoom_time, zoom_residual) = focus_figures(&run, ZOOM_AT_S, END_S, tolerance);
        let scatter = relative_scatter(&run, ZOOM_AT_S - 2.0, ZOOM_AT_S);
        println!(
            "{seed:4} | {:5.2} {:5.3} | {:5.2} {:5.3} | {:.2} %",
            cold_time.unwrap_or(f64::NAN),
            cold_residual,
            zoom_time.unwrap_or(f64::NAN),
            zoom_residual,
            scatter * 100.0
        );
        let (Some(cold_time), Some(zoom_time)) = (cold_time, zoom_time) else {
            panic!(
                "seed {seed}: not in focus at the end of a phase: {:?}",
                run.modes
            );
        };
        for (k, v) in [cold_time, cold_residual, zoom_time, zoom_residual]
            .into_iter()
            .enumerate()
        {
            worst[k] = worst[k].max(v);
        }
        // Search, track, hold; then again after the zoom.
        assert_eq!(run.modes.len(), 6, "seed {seed}: {:?}", run.modes);
        assert!(run.samples.iter().all(|s| s.acceleration_m_s2.abs() <= 0.5));
        if seed == 11 {
            plots(&run, &ZoomCamera::new(CameraParams::ZOOM_INSPECTION, seed));
        }
    }
    println!(
        "worst: cold start {:.2} s, residual {:.3} w; zoom {:.2} s, residual {:.3} w",
        worst[0], worst[1], worst[2], worst[3]
    );
    assert!(worst[0] < 4.0 && worst[2] < 2.5, "{worst:?}");
    assert!(worst[1] < tolerance && worst[3] < tolerance, "{worst:?}");
}

/// Relative standard deviation of the measured sharpness between `from_s` and
/// `to_s` (one value per frame), the axis at rest.
fn relative_scatter(run: &Run, from_s: f64, to_s: f64) -> f64 {
    let s: Vec<f64> = run
        .samples
        .iter()
        .filter(|s| s.t_s >= from_s && s.t_s < to_s)
        .step_by(PERIODS_PER_FRAME)
        .map(|s| s.sharpness)
        .collect();
    let n = s.len() as f64;
    let mean = s.iter().sum::<f64>() / n;
    (s.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() / mean
}

/// A textureless scene (a flat frame: S = 0) and NaN inputs: typed errors, and the
/// axis is braked, never driven by a NaN.
#[test]
fn flat_frames_and_nan_are_typed_errors_and_the_axis_stays_still() {
    let law = Autofocus::<f32, RING>::new(&CONFIG, TS_S).unwrap();
    let mut state = AutofocusState::<f32, RING>::default();
    let mut axis = FocusAxis::new(START_M, [0.0, 10e-3], TS_S);
    let flat = [128u8; FRAME_PIXELS];
    let s = normalized_variance(&flat, FRAME_SIDE, &WINDOW).unwrap();
    assert_eq!(s, 0.0);
    assert_eq!(
        normalized_variance(&[0u8; FRAME_PIXELS], FRAME_SIDE, &WINDOW),
        Err(SharpnessError::ZeroMean)
    );
    for k in 0..2000 {
        if k % PERIODS_PER_FRAME == 0 {
            assert_eq!(
                law.frame(&mut state, axis.position_m as f32, s),
                Err(AutofocusError::NoTexture)
            );
        }
        let a = law
            .step(&mut state, axis.position_m as f32, axis.velocity_m_s as f32)
            .unwrap();
        assert_eq!(a, 0.0);
        axis.step(f64::from(a));
    }
    assert_eq!(axis.position_m, START_M);
    // NaN sharpness, NaN position, NaN velocity: errors; the caller applies zero.
    assert_eq!(
        law.frame(&mut state, axis.position_m as f32, f32::NAN),
        Err(AutofocusError::NotFinite)
    );
    assert_eq!(
        law.frame(&mut state, f32::NAN, 1.0),
        Err(AutofocusError::NotFinite)
    );
    let a = law
        .step(&mut state, axis.position_m as f32, f32::NAN)
        .unwrap_or(0.0);
    assert_eq!(a, 0.0);
    axis.step(f64::from(a));
    assert_eq!(axis.position_m, START_M);
    assert!(axis.velocity_m_s == 0.0);
}
