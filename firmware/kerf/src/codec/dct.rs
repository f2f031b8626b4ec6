//! Orthonormal DCT-II and its inverse, the orthonormal DCT-III (SPEC `codec::sdct`,
//! T 7.2.3 eq. 162/164), for N = 8, 16, 32, 64.
//!
//! ```text
//! c[k] = s_k Σn x[n] cos((2n+1)kπ/2N),   x[n] = Σk s_k c[k] cos((2n+1)kπ/2N),
//! s_0 = √(1/N), s_k = √(2/N) for k ≥ 1   (that is √(2/N)·C(k), C(0) = 1/√2)
//! ```
//!
//! Three kernels share the generated cosine table (`build.rs`, one period of 256
//! entries, so every angle (2n+1)kπ/2N with N | 64 is an exact entry):
//!
//! * [`Dct::forward`] / [`Dct::inverse`]: f32, fast. B. G. Lee's decomposition
//!   (IEEE TASSP 1984): an N-point DCT is an N/2-point DCT of `x[n] + x[N−1−n]` (even
//!   outputs) and one of `(x[n] − x[N−1−n]) / (2 cos((2n+1)π/2N))` (odd outputs, each the
//!   sum of two neighbours). Done iteratively, stage by stage, between the caller's
//!   buffer and one stack scratch buffer, with the last three levels (8 points)
//!   unrolled in registers: (N/2) log2 N multiplications and about (3N/2) log2 N
//!   additions, against N² multiply-adds for the matrix product. The inverse runs the
//!   transposed stages in reverse order.
//! * [`Dct::forward_q15`] / [`Dct::inverse_q15`]: integer, for Q15 data. A direct
//!   O(N²) product with the Q15 cosine table and a 64-bit accumulator, chosen by
//!   measurement (tests below, 99 blocks of uniform full-scale input per N):
//!   - SNR against the f64 double sum: forward 93.9 / 94.4 / 94.3 / 94.5 dB and inverse
//!     94.6 / 95.2 / 95.2 / 95.2 dB at N = 8 / 16 / 32 / 64 — within 2 dB of the
//!     ≈ 96 dB that rounding the result to Q15 allows, so nothing else is lost.
//!   - A 32-bit accumulator overflows at every N: a Q15 × Q15 product is Q30 and N
//!     full-scale products sum to N · 2^30 ≥ 2^33 (tested: a −1.0 block wraps).
//!     Pre-shifting each product by log2 N bits avoids that and measures the same SNR
//!     (a Q30 product has 15 bits below the Q15 output), but then the inverse, which
//!     takes coefficients from the wire, needs its own range analysis; with 64 bits it
//!     only clamps absurd inputs. On the Cortex-M4 `SMLAL` (32 × 32 + 64) takes the
//!     same single cycle as `MLA`, so the wider accumulator costs nothing per term.
//!   - A fixed-point fast transform halves its data at each of its log2 N split stages
//!     to stay in range, and each halving rounds a bit away. Measured with the f32
//!     path's Lee butterflies in fixed point (test
//!     `direct_q15_product_beats_a_scaled_fast_transform`: Q15 data in `i32`, Q26
//!     twiddles, a rounded shift by 1 per split, same blocks): forward SNR
//!     78.7 / 72.8 / 66.9 / 60.8 dB at N = 8 / 16 / 32 / 64, 15.1 / 21.6 / 27.3 /
//!     33.6 dB (2.5 / 3.6 / 4.5 / 5.6 bits) below this path, about one bit per doubling
//!     of N. With the growth kept in the `i32` instead (no shifts) the same
//!     butterflies measure 92 dB, so the loss is the scaling. Even halved, Lee's odd branch (twiddles up to 20.4 at N = 64) peaks at
//!     2.3× full scale at N = 8 and 17× at N = 64, so a kernel with 16-bit storage
//!     would need more headroom and lose more. The O(N²) product keeps every bit until
//!     the single final rounding. It costs N² multiply-adds, which is the price for
//!     parts without an FPU; with an FPU use the f32 path.
//! * [`NaiveDct`]: the N × N basis matrix precomputed at construction and a plain
//!   matrix-vector product — the reference kernel the fast one is benchmarked against.
//!
//! Accuracy against the f64 double sum (tests below, inputs uniform in [−1, 1]):
//! f32 fast forward max error 4.1e-7 / 6.3e-7 / 1.1e-6 / 1.5e-6 and f32 round-trip max
//! error 4.4e-7 / 9.0e-7 / 1.7e-6 / 3.5e-6 at N = 8 / 16 / 32 / 64 (tested bound
//! 2e-6 · √N); Q15 forward and inverse max error ≤ 1.5 LSB (bound √(N/2) + 1), Q15 round
//! trip ≤ 2 LSB (bound 3).

use core::mem::swap;

use crate::error::ConfigError;

mod tables {
    include!(concat!(env!("OUT_DIR"), "/cos_tables.rs"));
}
use tables::{COS_F32, COS_PERIOD, COS_Q15};

// The twiddle table steps by shifts of COS_PERIOD (`Dct::new`).
const _: () = assert!(COS_PERIOD.is_power_of_two());

/// cos(2πj/256), f32. `j % COS_PERIOD` is always in the table.
#[inline(always)]
fn cos_f32(j: usize) -> f32 {
    COS_F32.get(j % COS_PERIOD).copied().unwrap_or(0.0)
}

/// cos(2πj/256), Q15 (cos 0 = 32768). `j % COS_PERIOD` is always in the table.
#[inline(always)]
fn cos_q15(j: usize) -> i64 {
    COS_Q15.get(j % COS_PERIOD).map_or(0, |&c| i64::from(c))
}

/// Table steps per unit of (2n+1)k for block length N: the angle (2n+1)kπ/2N is entry
/// (2n+1)k · 64/N of the 256-entry period.
const fn stride(n: usize) -> usize {
    COS_PERIOD / (4 * n)
}

fn check_n(n: usize) -> Result<(), ConfigError> {
    if super::is_supported_n(n) {
        Ok(())
    } else {
        Err(ConfigError::out_of_range("N"))
    }
}

/// Orthonormal scale factors s_0 = √(1/N), s_k = √(2/N).
fn scales(n: usize) -> (f64, f64) {
    let n = n as f64;
    (libm::sqrt(1.0 / n), libm::sqrt(2.0 / n))
}

/// Rounds `v / 2^shift` to nearest (ties up).
#[inline(always)]
const fn round_shift(v: i64, shift: u32) -> i64 {
    (v + (1 << (shift - 1))) >> shift
}

/// Fast DCT-II / DCT-III of N samples, plus the integer Q15 path.
#[derive(Clone, Debug)]
pub struct Dct<const N: usize> {
    /// Lee's butterfly factors 1 / (2 cos((2i+1)π/2L)) for the stage of length L at
    /// indices L/2..L (heap layout: L = N, N/2, …, 2 fill N/2..N, N/4..N/2, …, 1..2).
    twiddle: [f32; N],
    scale0: f32,
    scale: f32,
    /// s_0 and s_k in Q31 for the integer path.
    scale0_q31: i64,
    scale_q31: i64,
}

impl<const N: usize> Dct<N> {
    /// Builds the twiddle factors from the generated cosine table;
    /// `OutOfRange("N")` unless N is 8, 16, 32 or 64.
    pub fn new() -> Result<Self, ConfigError> {
        check_n(N)?;
        let mut twiddle = [0.0f32; N];
        for (i, t) in twiddle.iter_mut().enumerate().skip(1) {
            // Slot i belongs to the stage with L/2 ≤ i < L, as its entry i − L/2.
            // len = 2^(log2 half + 1), so the table step COS_PERIOD / (4·len) is a shift
            // (COS_PERIOD = 256), which has no division by zero to check.
            let half_log2 = i.ilog2();
            let half = 1usize << half_log2;
            let step = COS_PERIOD.checked_shr(half_log2 + 3).unwrap_or(0);
            let j = (2 * (i - half) + 1) * step;
            *t = 0.5 / cos_f32(j);
        }
        let (s0, s) = scales(N);
        Ok(Self {
            twiddle,
            scale0: s0 as f32,
            scale: s as f32,
            scale0_q31: libm::round(s0 * 2_147_483_648.0) as i64,
            scale_q31: libm::round(s * 2_147_483_648.0) as i64,
        })
    }

    fn stage_twiddles(&self, len: usize) -> &[f32] {
        self.twiddle.get(len / 2..len).unwrap_or(&[])
    }

    /// Applies the orthonormal scales C(k)·√(2/N) in place.
    fn orthonormal_scale(&self, v: &mut [f32]) {
        for (k, x) in v.iter_mut().enumerate() {
            *x *= if k == 0 { self.scale0 } else { self.scale };
        }
    }

    /// Runs the 8-point base `kernel` (the last three levels, in registers) on every
    /// block of 8 of `v`, in place.
    #[inline(always)]
    fn base_blocks<K>(&self, v: &mut [f32], kernel: K)
    where
        K: Fn([f32; 8], [f32; 4], [f32; 2], f32) -> [f32; 8],
    {
        let (t8, t4, t2) = self.base_twiddles();
        for chunk in v.chunks_exact_mut(8) {
            if let Ok(block) = <&mut [f32; 8]>::try_from(chunk) {
                *block = kernel(*block, t8, t4, t2);
            }
        }
    }

    /// Twiddles of the 8-point base kernel: L = 8 (4), L = 4 (2), L = 2 (1).
    fn base_twiddles(&self) -> ([f32; 4], [f32; 2], f32) {
        let t = |i: usize| self.twiddle.get(i).copied().unwrap_or(0.0);
        ([t(4), t(5), t(6), t(7)], [t(2), t(3)], t(1))
    }

    /// In-place orthonormal DCT-II: `x` holds the samples on entry and c[0..N) on return.
    ///
    /// NaN or ±∞ samples, and samples near `f32::MAX` whose sums overflow, pass through
    /// to the coefficients (a pure kernel: `SdctEncoder::encode` refuses them first).
    pub fn forward(&self, x: &mut [f32; N]) {
        let mut scratch = [0.0f32; N];
        let (mut src, mut dst): (&mut [f32], &mut [f32]) = (x, &mut scratch);
        // Split stages, L = N, N/2, …, 16: [a | b] with a[i] = x[i] + x[L−1−i] and
        // b[i] = (x[i] − x[L−1−i]) / (2 cos((2i+1)π/2L)).
        let mut len = N;
        while len > 8 {
            let tw = self.stage_twiddles(len);
            for ((s_lo, s_hi), (d_lo, d_hi)) in halved_blocks(src, dst, len) {
                let pairs = s_lo.iter().zip(s_hi.iter().rev());
                for (((&p, &q), (lo, hi)), &t) in pairs.zip(d_lo.iter_mut().zip(d_hi)).zip(tw) {
                    *lo = p + q;
                    *hi = (p - q) * t;
                }
            }
            swap(&mut src, &mut dst);
            len /= 2;
        }
        // The last three levels (L = 8, 4, 2) in registers, in place.
        self.base_blocks(src, dct8);
        // Merge stages, L = 16, 32, …, N: from A = DCT(a), B = DCT(b),
        // X[2k] = A[k], X[2k+1] = B[k] + B[k+1] with B[L/2] = 0.
        let mut len = 16;
        while len <= N {
            for (s, d) in src.chunks_exact(len).zip(dst.chunks_exact_mut(len)) {
                let Some((even, odd)) = s.split_at_checked(len / 2) else {
                    continue;
                };
                // Walk backwards so B[k+1] is the previous iteration's B[k].
                let mut odd_next = 0.0;
                for (pair, (&a, &b)) in d.chunks_exact_mut(2).zip(even.iter().zip(odd)).rev() {
                    if let [x0, x1] = pair {
                        *x0 = a;
                        *x1 = b + odd_next;
                        odd_next = b;
                    }
                }
            }
            swap(&mut src, &mut dst);
            len *= 2;
        }
        // 2 (log2 N − 3) swaps: the result is back in the caller's buffer.
        self.orthonormal_scale(src);
    }

    /// In-place orthonormal DCT-III (inverse of [`forward`](Self::forward)): `c` holds
    /// the coefficients on entry and the samples on return.
    ///
    /// Non-finite or overflowing coefficients pass through to the samples (a pure
    /// kernel: the packet decoder bounds what reaches it below 2^68).
    pub fn inverse(&self, c: &mut [f32; N]) {
        // The stages below compute the plain sum Σk X[k] cos(…); fold the orthonormal
        // scales into X first.
        self.orthonormal_scale(c);
        let mut scratch = [0.0f32; N];
        let (mut src, mut dst): (&mut [f32], &mut [f32]) = (c, &mut scratch);
        // Transpose of the merge stages, L = N, …, 16: even coefficients to the first
        // half, odd ones summed with their predecessor to the second half.
        let mut len = N;
        while len > 8 {
            for (s, d) in src.chunks_exact(len).zip(dst.chunks_exact_mut(len)) {
                let Some((d_lo, d_hi)) = d.split_at_mut_checked(len / 2) else {
                    continue;
                };
                let mut odd_prev = 0.0;
                for ((pair, lo), hi) in s.chunks_exact(2).zip(d_lo).zip(d_hi) {
                    if let [even, odd] = pair {
                        *lo = *even;
                        *hi = odd + odd_prev;
                        odd_prev = *odd;
                    }
                }
            }
            swap(&mut src, &mut dst);
            len /= 2;
        }
        self.base_blocks(src, idct8);
        // Transpose of the split stages, L = 16, …, N: x[i] = u + v·t, x[L−1−i] = u − v·t.
        let mut len = 16;
        while len <= N {
            let tw = self.stage_twiddles(len);
            for ((s_lo, s_hi), (d_lo, d_hi)) in halved_blocks(src, dst, len) {
                let outs = d_lo.iter_mut().zip(d_hi.iter_mut().rev());
                for (((&u, &v), &t), (lo, hi)) in s_lo.iter().zip(s_hi).zip(tw).zip(outs) {
                    let y = v * t;
                    *lo = u + y;
                    *hi = u - y;
                }
            }
            swap(&mut src, &mut dst);
            len *= 2;
        }
    }

    /// Orthonormal DCT-II of Q15 samples; coefficients in Q15 (they can exceed ±1:
    /// |c\[k\]| ≤ √N · full scale, so they are `i32`). Rounded to nearest.
    pub fn forward_q15(&self, x: &[i16; N], out: &mut [i32; N]) {
        let stride = stride(N);
        for (k, o) in out.iter_mut().enumerate() {
            // Angle index (2n+1)k·stride, advanced by 2k·stride per sample.
            let (mut j, step) = (k * stride, 2 * k * stride);
            let mut acc = 0i64; // Q30, |acc| ≤ N · 2^30
            for &v in x {
                acc += i64::from(v) * cos_q15(j);
                j += step;
            }
            let s = if k == 0 {
                self.scale0_q31
            } else {
                self.scale_q31
            };
            // Q30 → Q22 (≤ 2^28) so that × Q31 (≤ 2^31) stays below 2^63; → Q15.
            *o = round_shift((acc >> 8) * s, 38) as i32;
        }
    }

    /// Orthonormal DCT-III of Q15 coefficients back to Q15 samples, rounded to nearest
    /// and saturated to `i16`. Coefficients are clamped to ±2^24 (far beyond the ±2^18
    /// a full-scale block can produce) so that no sum can overflow.
    pub fn inverse_q15(&self, c: &[i32; N], out: &mut [i16; N]) {
        const LIMIT: i32 = 1 << 24;
        let stride = stride(N);
        // d[k] = s_k c[k] in Q30: Q15 × Q31 = Q46, ≤ 2^54, shifted down by 16.
        let mut d = [0i64; N];
        for (k, (dk, &ck)) in d.iter_mut().zip(c).enumerate() {
            let s = if k == 0 {
                self.scale0_q31
            } else {
                self.scale_q31
            };
            *dk = round_shift(i64::from(ck.clamp(-LIMIT, LIMIT)) * s, 16);
        }
        for (n, o) in out.iter_mut().enumerate() {
            let (mut j, step) = (0usize, (2 * n + 1) * stride);
            let mut acc = 0i64; // Q45, |acc| ≤ N · 2^38 · 2^15 ≤ 2^59
            for &dk in &d {
                acc += dk * cos_q15(j);
                j += step;
            }
            *o = round_shift(acc, 30).clamp(i16::MIN.into(), i16::MAX.into()) as i16;
        }
    }
}

/// A block of the source and of the destination, each as (first half, second half).
type HalvedBlock<'a> = ((&'a [f32], &'a [f32]), (&'a mut [f32], &'a mut [f32]));

/// The blocks of length `len` of `src` and `dst`, each split into its two halves.
#[inline(always)]
fn halved_blocks<'a>(
    src: &'a [f32],
    dst: &'a mut [f32],
    len: usize,
) -> impl Iterator<Item = HalvedBlock<'a>> {
    src.chunks_exact(len)
        .zip(dst.chunks_exact_mut(len))
        .filter_map(move |(s, d)| {
            Some((
                s.split_at_checked(len / 2)?,
                d.split_at_mut_checked(len / 2)?,
            ))
        })
}

/// Unnormalized 2-point DCT-II (Lee's split with L = 2; the merge is the identity).
#[inline(always)]
fn dct2([p, q]: [f32; 2], t2: f32) -> [f32; 2] {
    [p + q, (p - q) * t2]
}

/// Unnormalized 4-point DCT-II: one split and merge around two [`dct2`].
#[inline(always)]
fn dct4([y0, y1, y2, y3]: [f32; 4], [ta, tb]: [f32; 2], t2: f32) -> [f32; 4] {
    let [a0, a1] = dct2([y0 + y3, y1 + y2], t2);
    let [b0, b1] = dct2([(y0 - y3) * ta, (y1 - y2) * tb], t2);
    [a0, b0 + b1, a1, b1]
}

/// Unnormalized 8-point DCT-II, Σn x[n] cos((2n+1)kπ/16): the last three levels of
/// Lee's recursion unrolled so they run in registers.
#[inline(always)]
fn dct8(x: [f32; 8], t8: [f32; 4], t4: [f32; 2], t2: f32) -> [f32; 8] {
    let [x0, x1, x2, x3, x4, x5, x6, x7] = x;
    let [ta, tb, tc, td] = t8;
    let a = [x0 + x7, x1 + x6, x2 + x5, x3 + x4];
    let b = [
        (x0 - x7) * ta,
        (x1 - x6) * tb,
        (x2 - x5) * tc,
        (x3 - x4) * td,
    ];
    let [a0, a1, a2, a3] = dct4(a, t4, t2);
    let [b0, b1, b2, b3] = dct4(b, t4, t2);
    [a0, b0 + b1, a1, b1 + b2, a2, b2 + b3, a3, b3]
}

/// Transpose of [`dct2`]: Σk X[k] cos((2n+1)kπ/4).
#[inline(always)]
fn idct2([u, v]: [f32; 2], t2: f32) -> [f32; 2] {
    let y = v * t2;
    [u + y, u - y]
}

/// Transpose of [`dct4`].
#[inline(always)]
fn idct4([y0, y1, y2, y3]: [f32; 4], [ta, tb]: [f32; 2], t2: f32) -> [f32; 4] {
    let [u0, u1] = idct2([y0, y2], t2);
    let [v0, v1] = idct2([y1, y1 + y3], t2);
    let (v0, v1) = (v0 * ta, v1 * tb);
    [u0 + v0, u1 + v1, u1 - v1, u0 - v0]
}

/// Transpose of [`dct8`]: Σk X[k] cos((2n+1)kπ/16).
#[inline(always)]
fn idct8(c: [f32; 8], t8: [f32; 4], t4: [f32; 2], t2: f32) -> [f32; 8] {
    let [c0, c1, c2, c3, c4, c5, c6, c7] = c;
    let [ta, tb, tc, td] = t8;
    let [u0, u1, u2, u3] = idct4([c0, c2, c4, c6], t4, t2);
    let [v0, v1, v2, v3] = idct4([c1, c1 + c3, c3 + c5, c5 + c7], t4, t2);
    let (w0, w1, w2, w3) = (v0 * ta, v1 * tb, v2 * tc, v3 * td);
    [
        u0 + w0,
        u1 + w1,
        u2 + w2,
        u3 + w3,
        u3 - w3,
        u2 - w2,
        u1 - w1,
        u0 - w0,
    ]
}

/// Reference kernel: the orthonormal DCT as a matrix-vector product with the N × N
/// basis s_k cos((2n+1)kπ/2N) precomputed at construction (N² multiply-adds per call,
/// 4N² bytes of matrix). Used to benchmark [`Dct`] and as a second opinion in tests.
#[derive(Clone, Debug)]
pub struct NaiveDct<const N: usize> {
    basis: [[f32; N]; N],
}

impl<const N: usize> NaiveDct<N> {
    /// Fills the basis from the generated cosine table; `OutOfRange("N")` unless N is
    /// 8, 16, 32 or 64.
    pub fn new() -> Result<Self, ConfigError> {
        check_n(N)?;
        let (s0, s) = scales(N);
        let mut basis = [[0.0f32; N]; N];
        for (k, row) in basis.iter_mut().enumerate() {
            let scale = if k == 0 { s0 } else { s } as f32;
            for (n, b) in row.iter_mut().enumerate() {
                *b = scale * cos_f32((2 * n + 1) * k * stride(N));
            }
        }
        Ok(Self { basis })
    }

    /// c = B x (DCT-II).
    pub fn forward(&self, x: &[f32; N], c: &mut [f32; N]) {
        for (ck, row) in c.iter_mut().zip(&self.basis) {
            *ck = row.iter().zip(x).fold(0.0, |acc, (b, v)| acc + b * v);
        }
    }

    /// x = Bᵀ c (DCT-III), accumulated row by row so the matrix is read in order.
    pub fn inverse(&self, c: &[f32; N], x: &mut [f32; N]) {
        x.fill(0.0);
        for (row, &ck) in self.basis.iter().zip(c) {
            for (xn, b) in x.iter_mut().zip(row) {
                *xn += b * ck;
            }
        }
    }
}

#[cfg(test)]
mod tests;
