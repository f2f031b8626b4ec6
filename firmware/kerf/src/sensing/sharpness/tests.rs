use super::*;
use std::vec::Vec;

/// Deterministic bytes (xorshift64*), no dependency on hal-mock.
struct Bytes(u64);

impl Bytes {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn byte(&mut self) -> u8 {
        (self.next() >> 56) as u8
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() >> 33) as usize % n
    }
}

/// The independent reference: eq. 155 read literally, two passes in `f64` (the mean,
/// then the squared deviations from it), one row at a time.
fn two_pass(frame: &[u8], stride: usize, w: &Window) -> f64 {
    let pixel = |r: usize, c: usize| f64::from(frame[(w.y_px + r) * stride + w.x_px + c]);
    let n = (w.width_px * w.height_px) as f64;
    let mut mean = 0.0;
    for r in 0..w.height_px {
        for c in 0..w.width_px {
            mean += pixel(r, c);
        }
    }
    mean /= n;
    let mut squares = 0.0;
    for r in 0..w.height_px {
        for c in 0..w.width_px {
            let d = pixel(r, c) - mean;
            squares += d * d;
        }
    }
    squares / (n * mean)
}

/// Random frames, strides, windows and contrasts (from a few grey levels to the full
/// range): the integer kernel agrees with the two-pass reference to f64 rounding
/// (the reference's own rounding is about n·ε relative), and the f32 result is the
/// exact ratio rounded within 3 ulp.
#[test]
fn matches_an_f64_two_pass_reference_on_random_frames() {
    let mut rng = Bytes(0x9e37_79b9_7f4a_7c15);
    let mut worst64 = 0.0f64;
    let mut worst32 = 0.0f64;
    for trial in 0..400 {
        let stride = 1 + rng.below(96);
        let rows = 1 + rng.below(80);
        // A last row shorter than the stride, sometimes.
        let len = stride * rows - if trial % 3 == 0 { rng.below(stride) } else { 0 };
        let (base, span) = (rng.byte() / 2, 1 + rng.below(256));
        let frame: Vec<u8> = (0..len)
            .map(|_| (usize::from(base) + rng.below(span)).min(255) as u8)
            .collect();
        let width = 1 + rng.below(stride);
        let x = rng.below(stride - width + 1);
        let full_rows = len / stride;
        if full_rows == 0 {
            continue;
        }
        let height = 1 + rng.below(full_rows);
        let y = rng.below(full_rows - height + 1);
        let w = Window {
            x_px: x,
            y_px: y,
            width_px: width,
            height_px: height,
        };
        let reference = two_pass(&frame, stride, &w);
        let m = window_moments(&frame, stride, &w).unwrap();
        let got64 = m.normalized_variance_f64().unwrap();
        let got32 = normalized_variance(&frame, stride, &w).unwrap();
        let scale = reference.max(1e-300);
        worst64 = worst64.max((got64 - reference).abs() / scale);
        let exact = m.variance_numerator() as f64 / m.mean_denominator() as f64;
        if exact > 0.0 {
            worst32 = worst32.max((f64::from(got32) - exact).abs() / exact);
        } else {
            assert_eq!(got32, 0.0);
            assert!(reference.abs() < 1e-12, "{reference}");
        }
    }
    assert!(worst64 < 1e-12, "f64: {worst64:e}");
    assert!(
        worst32 < 3.0 * f64::from(f32::EPSILON) / 2.0,
        "f32: {worst32:e}"
    );
}

/// A 64 × 64 window of a 100-pixel-wide frame, full contrast: the known case the
/// benchmark times.
#[test]
fn a_64_by_64_window_of_a_wider_frame() {
    let mut rng = Bytes(42);
    let frame: Vec<u8> = (0..100 * 70).map(|_| rng.byte()).collect();
    let w = Window {
        x_px: 20,
        y_px: 3,
        width_px: 64,
        height_px: 64,
    };
    let m = window_moments(&frame, 100, &w).unwrap();
    assert_eq!(m.pixels, 4096);
    let reference = two_pass(&frame, 100, &w);
    let got = m.normalized_variance_f64().unwrap();
    assert!(
        (got - reference).abs() < 1e-12 * reference,
        "{got} {reference}"
    );
    // Uniform bytes: variance (256² − 1)/12 over the mean 127.5, about 42.8.
    assert!((got - 42.8).abs() < 2.0, "{got}");
}

#[test]
fn constant_windows() {
    let frame = [7u8; 64];
    let w = Window {
        x_px: 0,
        y_px: 0,
        width_px: 8,
        height_px: 8,
    };
    // No texture: zero sharpness, exactly (not an error here).
    assert_eq!(normalized_variance(&frame, 8, &w), Ok(0.0));
    assert_eq!(
        normalized_variance(&[0u8; 64], 8, &w),
        Err(SharpnessError::ZeroMean)
    );
    // Two levels, half each: variance 1, mean 1 → S = 1.
    let halves: Vec<u8> = (0..64).map(|k| if k % 2 == 0 { 0 } else { 2 }).collect();
    assert_eq!(normalized_variance(&halves, 8, &w), Ok(1.0));
}

#[test]
fn bad_windows_are_typed_errors() {
    let frame = [1u8; 100];
    let w = |x_px, y_px, width_px, height_px| Window {
        x_px,
        y_px,
        width_px,
        height_px,
    };
    let s = |win: Window, stride| normalized_variance(&frame, stride, &win);
    assert_eq!(s(w(0, 0, 0, 4), 10), Err(SharpnessError::EmptyWindow));
    assert_eq!(s(w(0, 0, 4, 0), 10), Err(SharpnessError::EmptyWindow));
    // Past the stride, past the last row, past a short last row.
    assert_eq!(s(w(7, 0, 4, 4), 10), Err(SharpnessError::OutsideFrame));
    assert_eq!(s(w(0, 7, 4, 4), 10), Err(SharpnessError::OutsideFrame));
    assert_eq!(s(w(0, 0, 4, 4), 0), Err(SharpnessError::OutsideFrame));
    assert_eq!(
        normalized_variance(&frame[..95], 10, &w(4, 6, 6, 4)),
        Err(SharpnessError::OutsideFrame)
    );
    assert!(normalized_variance(&frame[..95], 10, &w(0, 6, 5, 4)).is_ok());
    // Overflowing arithmetic is an error, not a wrap.
    assert_eq!(
        s(w(usize::MAX, 0, 4, 1), 10),
        Err(SharpnessError::OutsideFrame)
    );
    assert_eq!(
        s(w(0, usize::MAX, 1, 2), 10),
        Err(SharpnessError::OutsideFrame)
    );
    assert_eq!(
        s(w(0, 0, 1 << 13, 1 << 12), 1 << 13),
        Err(SharpnessError::WindowTooLarge)
    );
    assert_eq!(
        s(w(0, 0, usize::MAX, 2), 10),
        Err(SharpnessError::WindowTooLarge)
    );
}

/// A row longer than one `u32` part (2^16 pixels) of full-scale pixels: still exact.
#[test]
fn long_rows_are_summed_in_parts() {
    let len = (1 << 17) + 5;
    let frame: Vec<u8> = (0..len)
        .map(|k| if k % 3 == 0 { 255 } else { 254 })
        .collect();
    let w = Window {
        x_px: 0,
        y_px: 0,
        width_px: len,
        height_px: 1,
    };
    let m = window_moments(&frame, len, &w).unwrap();
    let s1: u64 = frame.iter().map(|&p| u64::from(p)).sum();
    let s2: u64 = frame.iter().map(|&p| u64::from(p) * u64::from(p)).sum();
    assert_eq!((u64::from(m.sum), m.sum_of_squares), (s1, s2));
}
