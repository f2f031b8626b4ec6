//! The peers kerf's benchmark image measures its kernels against, written the way a
//! user would write them with the crates they would otherwise pick:
//!
//! - [`FftDct`]: the orthonormal DCT-II through microfft's N-point real FFT with
//!   Makhoul's reordering (even samples forward, odd samples backward, one complex
//!   rotation per output pair);
//! - [`printer_inverse`]: the vertical-rail (Klipper / Marlin) delta inverse,
//!   carriage = z + √(l² − (x − xt)² − (y − yt)²), with a chosen square root;
//! - [`efd_direct`]: an EFD position and three derivatives summed harmonic by
//!   harmonic, each with its own sine and cosine (kerf's fast [`sin_cos_f32`]);
//! - [`foc`]: the `foc` crate's field-oriented controller (I16F16 fixed point, its
//!   own CORDIC sine and cosine, PI and space-vector PWM), re-exported as it is.
//!
//! Only the benchmark image depends on this crate; the library never does.
#![no_std]

pub use fixed;
pub use foc;
use kerf::scalar::sin_cos_f32;
use kerf::trajectory::curve::CurveSample;
use microfft::Complex32;

/// Orthonormal DCT-II of N = 32 or 64 samples through microfft's real FFT.
///
/// Makhoul (1980): v[n] = x[2n], v[N−1−n] = x[2n+1] for n < N/2; V = FFT(v); then
/// C[k] = s_k·Re(e^{−iπk/2N} V[k]). For 0 < k < N/2 one V[k] = a + ib gives both
/// C[k] = s(c a + s' b) and C[N−k] = s(s' a − c b) with (c, s') = (cos, sin)(πk/2N);
/// C[0] = V[0]/√N and C[N/2] = √(2/N) cos(π/4) V[N/2] (microfft keeps the real
/// V[N/2] in the imaginary part of its first bin).
#[derive(Clone, Debug)]
pub struct FftDct<const N: usize> {
    /// √(2/N)·(cos, sin)(πk/2N) for k < N/2; entry 0 holds (1/√N, √(2/N) cos(π/4)).
    twiddle: [(f32, f32); N],
}

impl<const N: usize> FftDct<N> {
    /// Twiddles in f64, rounded once; `None` unless N is 32 or 64.
    pub fn new() -> Option<Self> {
        if N != 32 && N != 64 {
            return None;
        }
        let n = N as f64;
        let scale = libm::sqrt(2.0 / n);
        let mut twiddle = [(0.0f32, 0.0f32); N];
        for (k, t) in twiddle.iter_mut().enumerate().take(N / 2).skip(1) {
            let angle = core::f64::consts::PI * k as f64 / (2.0 * n);
            *t = (
                (scale * libm::cos(angle)) as f32,
                (scale * libm::sin(angle)) as f32,
            );
        }
        twiddle[0] = (
            (1.0 / libm::sqrt(n)) as f32,
            (scale * core::f64::consts::FRAC_1_SQRT_2) as f32,
        );
        Some(Self { twiddle })
    }

    /// In place, like `kerf::codec::dct::Dct::forward`.
    pub fn forward(&self, x: &mut [f32; N]) {
        let mut v = [0.0f32; N];
        for n in 0..N / 2 {
            v[n] = x[2 * n];
            v[N - 1 - n] = x[2 * n + 1];
        }
        let spectrum = rfft(&mut v);
        let (s0, s_half) = self.twiddle[0];
        x[0] = s0 * spectrum[0].re;
        x[N / 2] = s_half * spectrum[0].im;
        for k in 1..N / 2 {
            let (c, s) = self.twiddle[k];
            let Complex32 { re: a, im: b } = spectrum[k];
            x[k] = c * a + s * b;
            x[N - k] = s * a - c * b;
        }
    }
}

/// microfft's real FFT of N = 32 or 64 as N/2 complex bins (bin 0 holds V[0] and
/// V[N/2]); other N give an empty slice ([`FftDct::new`] refuses them).
#[inline(always)]
fn rfft<const N: usize>(v: &mut [f32; N]) -> &mut [Complex32] {
    let v: &mut [f32] = v;
    match N {
        64 => <&mut [f32; 64]>::try_from(v).map_or(&mut [], |v| microfft::real::rfft_64(v)),
        32 => <&mut [f32; 32]>::try_from(v).map_or(&mut [], |v| microfft::real::rfft_32(v)),
        _ => &mut [],
    }
}

/// One vertical rail of a printer delta: tower (xt, yt) and l², as a printer's
/// firmware precomputes them.
#[derive(Copy, Clone, Debug)]
pub struct Tower {
    /// Tower x, m.
    pub x: f32,
    /// Tower y, m.
    pub y: f32,
    /// Diagonal rod length squared, m².
    pub arm2: f32,
}

/// Carriage heights of a vertical-rail delta at effector position `p` (m):
/// z + √(l² − (x − xt)² − (y − yt)²) per tower; NaN where out of reach.
#[inline(always)]
pub fn printer_inverse(towers: &[Tower; 3], p: [f32; 3], sqrt: impl Fn(f32) -> f32) -> [f32; 3] {
    towers.map(|t| {
        let (dx, dy) = (p[0] - t.x, p[1] - t.y);
        p[2] + sqrt(t.arm2 - dx * dx - dy * dy)
    })
}

/// kerf's EFD sample in [`efd_direct`]'s layout (x, y; then d1, d2, d3), to compare.
pub fn efd_sample_flat(s: &CurveSample<f32>) -> [f32; 8] {
    [
        s.position.x,
        s.position.y,
        s.d1.x,
        s.d1.y,
        s.d2.x,
        s.d2.y,
        s.d3.x,
        s.d3.y,
    ]
}

/// EFD position and its first three θ-derivatives (x, y; then d1, d2, d3), summed
/// harmonic by harmonic with kerf's fast sine and cosine of kθ for each.
pub fn efd_direct(coefficients: &[[f32; 4]], theta: f32) -> [f32; 8] {
    let mut out = [0.0f32; 8];
    let mut k = 0.0f32;
    for [a, b, c, d] in coefficients.iter().copied() {
        k += 1.0;
        let (s, co) = sin_cos_f32(k * theta);
        let (ux, uy) = (a * co + b * s, c * co + d * s);
        let (vx, vy) = (b * co - a * s, d * co - c * s);
        let (k2, k3) = (k * k, k * k * k);
        out[0] += ux;
        out[1] += uy;
        out[2] += k * vx;
        out[3] += k * vy;
        out[4] -= k2 * ux;
        out[5] -= k2 * uy;
        out[6] -= k3 * vx;
        out[7] -= k3 * vy;
    }
    out
}

#[cfg(test)]
mod tests;
