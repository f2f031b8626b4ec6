//! A zoom camera on a focus axis, for the self-optimizing autofocus (T 7.2.2).
//!
//! - [`FocusAxis`]: the focus motor behind its disturbance observer, i.e. a double
//!   integrator q̈ = a (the commanded acceleration, held over a period, integrated
//!   exactly) between hard stops that stop it dead.
//! - [`ZoomCamera`]: a 64 × 64 8-bit window of a textured scene, blurred by the
//!   defocus and read with noise. The texture is a fixed pseudo-random sum of
//!   [`GRATINGS`] cosine gratings with integer wave vectors on the 64-pixel window
//!   (so they are orthogonal over it), random orientations and phases, spatial
//!   frequencies log-uniform from 1 to 22 cycles per window and amplitudes falling as
//!   1/f (the spectrum of natural scenes). Defocus blurs with a Gaussian of standard
//!   deviation b = √(b0² + (β m d)²) px, d = q − q_focus(m) the defocus and m the
//!   magnification: b0 is the in-focus blur, and the defocus blur grows with the
//!   magnification (the depth of field b0/(β m) shrinks as it rises). The blur is
//!   applied exactly in the frequency domain: a grating of frequency f is scaled by
//!   e^(−2π² b² f²). The window's variance is then Σ A_k² e^(−4π² b² f_k²)/2, each
//!   term falling with |d|, so the sharpness is unimodal in q at every magnification
//!   (T fig. 7.12); the in-focus contrast grows in proportion to m (so the peak
//!   sharpness grows as m², the quadratic rise of T fig. 7.14), and the focus
//!   position moves with the zoom, q_focus(m) = q1 + k (m − 1).
//! - Noise: per frame, an illumination gain 1 + σ_g·N(0, 1) (lamp flicker, which
//!   scales the sharpness by the same factor), and per pixel N(0, σ_n²) grey levels;
//!   then rounding and clipping to 0–255.

use crate::noise::Noise;
use core::f64::consts::PI;

/// Window side, px.
pub const FRAME_SIDE: usize = 64;
/// Pixels per frame.
pub const FRAME_PIXELS: usize = FRAME_SIDE * FRAME_SIDE;
/// Gratings in the texture.
pub const GRATINGS: usize = 32;

/// A focus motor with an acceleration input between hard stops.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct FocusAxis {
    /// Position q, m.
    pub position_m: f64,
    /// Velocity q̇, m/s.
    pub velocity_m_s: f64,
    /// Hard stops [min, max], m.
    pub stops_m: [f64; 2],
    ts_s: f64,
}

impl FocusAxis {
    /// At rest at `position_m` (clamped to the stops), stepped every `ts_s`.
    pub fn new(position_m: f64, stops_m: [f64; 2], ts_s: f64) -> Self {
        Self {
            position_m: position_m.clamp(stops_m[0], stops_m[1]),
            velocity_m_s: 0.0,
            stops_m,
            ts_s,
        }
    }

    /// One period with the acceleration `a_m_s2` held (a NaN command is taken as zero);
    /// at a stop the axis stops.
    pub fn step(&mut self, a_m_s2: f64) {
        let a = if a_m_s2.is_finite() { a_m_s2 } else { 0.0 };
        let h = self.ts_s;
        self.position_m += self.velocity_m_s * h + 0.5 * a * h * h;
        self.velocity_m_s += a * h;
        let [lo, hi] = self.stops_m;
        if self.position_m < lo || self.position_m > hi {
            self.position_m = self.position_m.clamp(lo, hi);
            self.velocity_m_s = 0.0;
        }
    }
}

/// The camera's optics and noise.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CameraParams {
    /// Mean grey level of the scene.
    pub mean_grey: f64,
    /// Standard deviation of the in-focus texture (before the in-focus blur) at m = 1,
    /// grey levels; proportional to m.
    pub contrast_grey: f64,
    /// b0: in-focus blur, px (standard deviation).
    pub focus_blur_px: f64,
    /// β: defocus blur per metre of defocus at m = 1, px/m.
    pub blur_px_per_m: f64,
    /// q1: focus position at m = 1, m.
    pub focus_at_unit_m: f64,
    /// k: focus shift per unit of magnification, m.
    pub focus_shift_m: f64,
    /// σ_n: pixel noise, grey levels.
    pub pixel_noise_grey: f64,
    /// σ_g: relative illumination flicker per frame.
    pub flicker: f64,
}

impl CameraParams {
    /// An inspection camera with a motorized zoom on a 10 mm focus travel: texture
    /// of standard deviation 20 grey levels about 120 at m = 1, in-focus blur 0.8 px,
    /// 2 px of blur per mm of defocus at m = 1 (depth of field ±0.4 mm at m = 1,
    /// ±0.2 mm at m = 2), focus at 2 mm for m = 1 and 3 mm further per unit of
    /// magnification, pixel noise 2 grey levels, flicker 0.5 %.
    pub const ZOOM_INSPECTION: Self = Self {
        mean_grey: 120.0,
        contrast_grey: 20.0,
        focus_blur_px: 0.8,
        blur_px_per_m: 2.0e3,
        focus_at_unit_m: 2e-3,
        focus_shift_m: 3e-3,
        pixel_noise_grey: 2.0,
        flicker: 0.005,
    };

    /// q_focus(m), m.
    pub fn focus_m(&self, magnification: f64) -> f64 {
        self.focus_at_unit_m + self.focus_shift_m * (magnification - 1.0)
    }

    /// Depth of field ±b0/(β m): the defocus at which the defocus blur equals the
    /// in-focus blur (the blur's variance doubles), m.
    pub fn depth_of_field_m(&self, magnification: f64) -> f64 {
        self.focus_blur_px / (self.blur_px_per_m * magnification)
    }

    /// Blur b (standard deviation), px, at focus position `q_m`.
    pub fn blur_px(&self, q_m: f64, magnification: f64) -> f64 {
        let defocus_px = self.blur_px_per_m * magnification * (q_m - self.focus_m(magnification));
        libm::sqrt(self.focus_blur_px * self.focus_blur_px + defocus_px * defocus_px)
    }
}

/// One grating: integer wave vector (cycles per window), phase, amplitude at m = 1.
#[derive(Copy, Clone, Debug, PartialEq)]
struct Grating {
    kx: i32,
    ky: i32,
    phase_rad: f64,
    amplitude_grey: f64,
}

/// The camera: texture, optics, noise, and the last frame.
#[derive(Clone, Debug)]
pub struct ZoomCamera {
    /// Optics and noise.
    pub params: CameraParams,
    /// Magnification m (set by the zoom motor).
    pub magnification: f64,
    gratings: [Grating; GRATINGS],
    noise: Noise,
}

impl ZoomCamera {
    /// A camera at magnification 1; `seed` draws the texture and the noise.
    pub fn new(params: CameraParams, seed: u64) -> Self {
        let mut noise = Noise::new(seed);
        let mut gratings = [Grating {
            kx: 1,
            ky: 0,
            phase_rad: 0.0,
            amplitude_grey: 0.0,
        }; GRATINGS];
        let mut power = 0.0;
        for k in 0..GRATINGS {
            // Draw until the wave vector is new (and not the opposite of one taken).
            let (kx, ky, f) = loop {
                let f = libm::exp(noise.uniform() * libm::log(22.0));
                let angle = PI * noise.uniform();
                let (kx, ky) = (
                    libm::round(f * libm::cos(angle)) as i32,
                    libm::round(f * libm::sin(angle)) as i32,
                );
                let taken = gratings
                    .iter()
                    .take(k)
                    .any(|g| (g.kx == kx && g.ky == ky) || (g.kx == -kx && g.ky == -ky));
                if (kx, ky) != (0, 0) && !taken {
                    break (kx, ky, libm::sqrt(f64::from(kx * kx + ky * ky)));
                }
            };
            let amplitude = 1.0 / f;
            power += amplitude * amplitude / 2.0;
            gratings[k] = Grating {
                kx,
                ky,
                phase_rad: 2.0 * PI * noise.uniform(),
                amplitude_grey: amplitude,
            };
        }
        let scale = params.contrast_grey / libm::sqrt(power);
        for g in &mut gratings {
            g.amplitude_grey *= scale;
        }
        Self {
            params,
            magnification: 1.0,
            gratings,
            noise,
        }
    }

    /// Variance of the noiseless, unclipped window at focus position `q_m`, grey
    /// levels² (the sum of the module docs).
    pub fn texture_variance(&self, q_m: f64) -> f64 {
        let b = self.params.blur_px(q_m, self.magnification);
        let m = self.magnification;
        self.gratings
            .iter()
            .map(|g| {
                let f = libm::sqrt(f64::from(g.kx * g.kx + g.ky * g.ky)) / FRAME_SIDE as f64;
                let a = g.amplitude_grey * m;
                a * a / 2.0 * libm::exp(-4.0 * PI * PI * b * b * f * f)
            })
            .sum()
    }

    /// The normalized variance of the noiseless window, variance over mean, plus the
    /// pixel noise's σ_n²/μ and rounding's 1/(12 μ): what the measured sharpness
    /// scatters about (clipping aside), grey levels.
    pub fn expected_sharpness(&self, q_m: f64) -> f64 {
        let p = &self.params;
        let noise = p.pixel_noise_grey * p.pixel_noise_grey + 1.0 / 12.0;
        (self.texture_variance(q_m) + noise) / p.mean_grey
    }

    /// Takes a frame at focus position `q_m` into `frame` (row-major, 64 × 64).
    pub fn capture(&mut self, q_m: f64, frame: &mut [u8; FRAME_PIXELS]) {
        let b = self.params.blur_px(q_m, self.magnification);
        let gain = 1.0 + self.params.flicker * self.noise.normal();
        let mut image = [0.0f32; FRAME_PIXELS];
        let step = 2.0 * PI / FRAME_SIDE as f64;
        for g in &self.gratings {
            let f = libm::sqrt(f64::from(g.kx * g.kx + g.ky * g.ky)) / FRAME_SIDE as f64;
            let a = g.amplitude_grey
                * self.magnification
                * gain
                * libm::exp(-2.0 * PI * PI * b * b * f * f);
            // cos(x θx + y θy + φ) = cos(x θx + φ) cos(y θy) − sin(x θx + φ) sin(y θy).
            let mut cx = [0.0f32; FRAME_SIDE];
            let mut sx = [0.0f32; FRAME_SIDE];
            for (x, (c, s)) in cx.iter_mut().zip(sx.iter_mut()).enumerate() {
                let angle = step * f64::from(g.kx) * x as f64 + g.phase_rad;
                *c = (a * libm::cos(angle)) as f32;
                *s = (a * libm::sin(angle)) as f32;
            }
            for (y, row) in image.chunks_exact_mut(FRAME_SIDE).enumerate() {
                let angle = step * f64::from(g.ky) * y as f64;
                let (cy, sy) = (libm::cos(angle) as f32, libm::sin(angle) as f32);
                for ((p, c), s) in row.iter_mut().zip(&cx).zip(&sx) {
                    *p += c * cy - s * sy;
                }
            }
        }
        let mean = self.params.mean_grey * gain;
        for (out, p) in frame.iter_mut().zip(&image) {
            let v = mean + f64::from(*p) + self.params.pixel_noise_grey * self.noise.normal();
            *out = libm::round(v).clamp(0.0, 255.0) as u8;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_integrates_exactly_and_stops_at_the_stops() {
        let mut axis = FocusAxis::new(1e-3, [0.0, 2e-3], 1e-3);
        for _ in 0..10 {
            axis.step(1.0);
        }
        // q = q0 + a t²/2 with t = 10 ms.
        assert!((axis.position_m - 1.05e-3).abs() < 1e-15);
        assert!((axis.velocity_m_s - 0.01).abs() < 1e-15);
        for _ in 0..1000 {
            axis.step(1.0);
        }
        assert_eq!((axis.position_m, axis.velocity_m_s), (2e-3, 0.0));
        axis.step(f64::NAN);
        assert_eq!((axis.position_m, axis.velocity_m_s), (2e-3, 0.0));
    }

    #[test]
    fn sharpness_model_is_unimodal_in_focus_and_moves_with_the_zoom() {
        let mut camera = ZoomCamera::new(CameraParams::ZOOM_INSPECTION, 3);
        for m in [1.0, 1.5, 2.0] {
            camera.magnification = m;
            let focus = camera.params.focus_m(m);
            let s = |q: f64| camera.texture_variance(q);
            for k in 1..200 {
                let d = k as f64 * 5e-5;
                assert!(s(focus + d) < s(focus + d - 5e-5));
                assert!(s(focus - d) < s(focus - d + 5e-5));
            }
        }
    }
}
