//! Image sharpness: the normalized variance of a window of an 8-bit frame
//! (docs/equations.md §5, T 7.2.2 eq. 155).
//!
//!   S = (1/(H W μ)) Σ (i − μ)²,   μ = (1/(H W)) Σ i,
//!
//! over the H × W pixels i of the window. T chooses it over the plain variance
//! because dividing by the mean intensity evens out the sharpness of successive
//! frames, and because it is unimodal in the focus position at every magnification
//! (T fig. 7.12), which the self-optimizing focus law needs
//! ([`control::autofocus`](crate::control::autofocus)).
//!
//! With n = H W, S1 = Σ i and S2 = Σ i², the sum of squared deviations is
//! S2 − S1²/n, so
//!
//!   S = (n S2 − S1²) / (n S1).
//!
//! [`window_moments`] accumulates S1 and S2 in integers, exactly (a row at a time in
//! `u32`, the frame in `u64`), and the numerator and denominator above are exact
//! `u64` integers for windows of up to 2^24 pixels: S1 < 2^32, S2 < 2^40, n S2 < 2^64.
//! The only rounding is the final conversion and the one division
//! ([`WindowMoments::normalized_variance_f32`], [`WindowMoments::normalized_variance_f64`]):
//! within about 3 ulp of the exact ratio in either precision, for any window,
//! where a floating-point two-pass sum loses accuracy with the window size.
//!
//! The frame is a row-major slice of `u8` with a stride (the frame's width in
//! pixels, at least the window's right edge); its last row may be shorter than the
//! stride, as long as the window fits.

/// A rectangle of pixels inside a frame: origin (column, row) and size.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Window {
    /// Column of the window's left edge, px.
    pub x_px: usize,
    /// Row of the window's top edge, px.
    pub y_px: usize,
    /// Width W, px.
    pub width_px: usize,
    /// Height H, px.
    pub height_px: usize,
}

/// Largest window, pixels: 2^24, so that n S2 fits a `u64` (module docs).
pub const MAX_WINDOW_PIXELS: usize = 1 << 24;

/// Why a window's sharpness could not be computed.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SharpnessError {
    /// The window has no pixels (zero width or height).
    EmptyWindow,
    /// The window reaches past the stride (frame width) or past the end of the slice.
    OutsideFrame,
    /// More than [`MAX_WINDOW_PIXELS`] pixels.
    WindowTooLarge,
    /// Every pixel of the window is 0: the mean μ is zero and S is undefined (a dark
    /// frame, a closed shutter).
    ZeroMean,
}

/// Exact sums over a window: pixel count n, S1 = Σ i and S2 = Σ i².
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct WindowMoments {
    /// n = H W, pixels (≤ 2^24).
    pub pixels: u32,
    /// S1 = Σ i, grey levels.
    pub sum: u32,
    /// S2 = Σ i², grey levels².
    pub sum_of_squares: u64,
}

impl WindowMoments {
    /// Numerator n S2 − S1² (n² times the variance), exact; never negative
    /// (Cauchy–Schwarz), saturating at zero regardless.
    #[inline]
    pub fn variance_numerator(&self) -> u64 {
        let n_s2 = u64::from(self.pixels).saturating_mul(self.sum_of_squares);
        let s1 = u64::from(self.sum);
        n_s2.saturating_sub(s1 * s1)
    }

    /// Denominator n S1 (n² times the mean), exact; zero only for an all-zero window.
    #[inline]
    pub fn mean_denominator(&self) -> u64 {
        u64::from(self.pixels) * u64::from(self.sum)
    }

    /// Mean intensity μ = S1/n, grey levels (zero for an empty value).
    pub fn mean(&self) -> f64 {
        if self.pixels == 0 {
            0.0
        } else {
            f64::from(self.sum) / f64::from(self.pixels)
        }
    }

    /// S = (n S2 − S1²)/(n S1) in `f32`, grey levels: two conversions of exact
    /// integers and one division, each correctly rounded, so within 3 ulp
    /// (relative 1.8e-7) of the exact value.
    #[inline]
    pub fn normalized_variance_f32(&self) -> Result<f32, SharpnessError> {
        let den = self.mean_denominator();
        if den == 0 {
            return Err(SharpnessError::ZeroMean);
        }
        Ok(self.variance_numerator() as f32 / den as f32)
    }

    /// S in `f64`, grey levels: within 3 ulp (relative 7e-16) of the exact value.
    #[inline]
    pub fn normalized_variance_f64(&self) -> Result<f64, SharpnessError> {
        let den = self.mean_denominator();
        if den == 0 {
            return Err(SharpnessError::ZeroMean);
        }
        Ok(self.variance_numerator() as f64 / den as f64)
    }
}

/// Σ i and Σ i² over `window` of `frame` (row-major, `stride_px` pixels per row).
///
/// Errors: [`SharpnessError::EmptyWindow`], [`SharpnessError::WindowTooLarge`],
/// [`SharpnessError::OutsideFrame`] (checked before any pixel is read). An all-zero
/// window is not an error here (its moments are valid); the ratio is
/// ([`SharpnessError::ZeroMean`]).
pub fn window_moments(
    frame: &[u8],
    stride_px: usize,
    window: &Window,
) -> Result<WindowMoments, SharpnessError> {
    let Window {
        x_px,
        y_px,
        width_px,
        height_px,
    } = *window;
    if width_px == 0 || height_px == 0 {
        return Err(SharpnessError::EmptyWindow);
    }
    let pixels = width_px
        .checked_mul(height_px)
        .filter(|&n| n <= MAX_WINDOW_PIXELS)
        .ok_or(SharpnessError::WindowTooLarge)?;
    let right = x_px
        .checked_add(width_px)
        .filter(|&r| r <= stride_px)
        .ok_or(SharpnessError::OutsideFrame)?;
    // One past the window's last pixel: (y + H − 1)·stride + x + W.
    let end = y_px
        .checked_add(height_px - 1)
        .and_then(|last_row| last_row.checked_mul(stride_px))
        .and_then(|start| start.checked_add(right))
        .filter(|&e| e <= frame.len())
        .ok_or(SharpnessError::OutsideFrame)?;
    // y·stride + x ≤ end (checked above), so this is never refused.
    let first = y_px
        .checked_mul(stride_px)
        .and_then(|row| row.checked_add(x_px))
        .ok_or(SharpnessError::OutsideFrame)?;
    let rows = frame.get(first..end).ok_or(SharpnessError::OutsideFrame)?;
    let (mut sum, mut sum_of_squares) = (0u32, 0u64);
    // Each chunk starts at a row of the window; its first W pixels are that row
    // (the last chunk is exactly W long).
    // stride ≥ x + W ≥ 1 (checked above); `max` shows it to the optimiser.
    for chunk in rows.chunks(stride_px.max(1)) {
        let row = chunk.get(..width_px).ok_or(SharpnessError::OutsideFrame)?;
        for part in row.chunks(ROW_PART_PX) {
            let (s1, s2) = row_sums(part);
            // At most 2^24 pixels in all, so S1 < 2^32 (wrapping never happens).
            sum = sum.wrapping_add(s1);
            // Below 2^24 · 255² < 2^40: never wraps either.
            sum_of_squares = sum_of_squares.wrapping_add(u64::from(s2));
        }
    }
    Ok(WindowMoments {
        pixels: pixels as u32,
        sum,
        sum_of_squares,
    })
}

/// Longest run of pixels summed in `u32` (255² · 2^16 < 2^32).
const ROW_PART_PX: usize = 1 << 16;

/// Σ i and Σ i² of at most [`ROW_PART_PX`] pixels in `u32`, exact: the sums never
/// pass 255² · 2^16 < 2^32, so the wrapping adds never wrap (the optimiser cannot see
/// the row's bound; they state that no overflow check is needed).
#[inline]
fn row_sums(row: &[u8]) -> (u32, u32) {
    let (mut s1, mut s2) = (0u32, 0u32);
    // Four pixels per iteration: one loop test per word of the row.
    let mut quads = row.chunks_exact(4);
    for q in &mut quads {
        if let &[a, b, c, d] = q {
            let (a, b, c, d) = (u32::from(a), u32::from(b), u32::from(c), u32::from(d));
            s1 = s1.wrapping_add(a + b + c + d);
            s2 = s2.wrapping_add(a * a + b * b + c * c + d * d);
        }
    }
    for &p in quads.remainder() {
        let p = u32::from(p);
        s1 = s1.wrapping_add(p);
        s2 = s2.wrapping_add(p * p);
    }
    (s1, s2)
}

/// Normalized variance S of `window` in `frame`, grey levels, in `f32`
/// ([`window_moments`], then [`WindowMoments::normalized_variance_f32`]).
pub fn normalized_variance(
    frame: &[u8],
    stride_px: usize,
    window: &Window,
) -> Result<f32, SharpnessError> {
    window_moments(frame, stride_px, window)?.normalized_variance_f32()
}

#[cfg(test)]
mod tests;
