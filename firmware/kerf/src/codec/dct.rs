//! Orthonormal DCT-II and its inverse, the orthonormal DCT-III (docs/codec.md §30,
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
//!   sum of two neighbours): (N/2) log2 N multiplications and about (3N/2) log2 N
//!   additions, against N² multiply-adds for the matrix product. A 16-point block is
//!   the recursion unrolled in registers. A 32- or 64-point block does not fit the 32
//!   FPU registers, so it makes three passes over memory: the top split stage (at
//!   N = 64 the top two, one 4-point butterfly of samples `i, 31−i, 32+i, 63−i` per
//!   row) from the caller's buffer into a stack array whose rows interleave the
//!   16-point blocks; each block through the register kernel and back in place; the
//!   top merge stage (stages) back into the caller's buffer. The orthonormal scales
//!   ride along: at N = 32 the split pass applies s (through the top stage's factors
//!   on the odd half, one multiplication per sum on the even half) and the merge pass
//!   only turns X\[0\]'s s into s_0; at N = 64 the merge pass applies them. A radix-2
//!   loop with one pass per stage and one for the scales makes 2 log2 N − 4 passes
//!   (8 at N = 64). The inverse runs the transposed passes in reverse order.
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
//! error 4.4e-7 / 9.0e-7 / 1.7e-6 / 3.2e-6 at N = 8 / 16 / 32 / 64 (tested bound
//! 2e-6 · √N); Q15 forward and inverse max error ≤ 1.5 LSB (bound √(N/2) + 1), Q15 round
//! trip ≤ 2 LSB (bound 3).

use core::f32::consts::FRAC_1_SQRT_2;

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
    /// At N = 32 the top stage's factors carry the orthonormal scale s as well (see
    /// [`split_rows`]; at N = 64 the scales go with the merge pass, which measured
    /// faster there).
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
        if N == 32 {
            for t in twiddle.iter_mut().skip(N / 2) {
                *t = (f64::from(*t) * s) as f32;
            }
        }
        Ok(Self {
            twiddle,
            scale0: s0 as f32,
            scale: s as f32,
            scale0_q31: libm::round(s0 * 2_147_483_648.0) as i64,
            scale_q31: libm::round(s * 2_147_483_648.0) as i64,
        })
    }

    /// The twiddles of the stage of length 2H (heap slots H..2H), if N has that stage.
    fn stage<const H: usize>(&self) -> Option<&[f32; H]> {
        self.twiddle.get(H..)?.first_chunk()
    }

    /// Twiddles of the 8-point base kernel: L = 8 (4), L = 4 (2), L = 2 (1).
    fn base(&self) -> Base {
        let t = |i: usize| self.twiddle.get(i).copied().unwrap_or(0.0);
        Base {
            t8: [t(4), t(5), t(6), t(7)],
            t4: [t(2), t(3)],
            t2: t(1),
        }
    }

    /// In-place orthonormal DCT-II: `x` holds the samples on entry and c[0..N) on return.
    ///
    /// NaN or ±∞ samples, and samples near `f32::MAX` whose sums overflow, pass through
    /// to the coefficients (a pure kernel: `SdctEncoder::encode` refuses them first).
    pub fn forward(&self, x: &mut [f32; N]) {
        let base = self.base();
        let scale = (self.scale0, self.scale);
        let x: &mut [f32] = x;
        // One branch per N (a constant, so one survives). N ≤ 16 stays in registers;
        // N = 32 and 64 make the three passes of the module docs: split stage(s)
        // into the interleaved rows, the 16-point blocks in place, merge stage(s)
        // with the orthonormal scales back into `x`.
        if let Ok(x) = <&mut [f32; 64]>::try_from(&mut *x) {
            let (Some(t64), Some(t32), Some(t16)) = (self.stage(), self.stage(), self.stage())
            else {
                return;
            };
            let mut q = split2(x, t64, t32);
            for c in 0..4 {
                let y = dct16(&column(&q, c), t16, &base);
                set_column(&mut q, c, &y);
            }
            merge2_scaled(&q, x, scale);
        } else if let Ok(x) = <&mut [f32; 32]>::try_from(&mut *x) {
            let (Some(t32), Some(t16)) = (self.stage(), self.stage()) else {
                return;
            };
            let mut q = split_rows(x, t32, self.scale);
            for c in 0..2 {
                let y = dct16(&column(&q, c), t16, &base);
                set_column(&mut q, c, &y);
            }
            merge_rows(&q, x);
        } else if let Ok(x) = <&mut [f32; 16]>::try_from(&mut *x) {
            let Some(t16) = self.stage() else {
                return;
            };
            let (a, b) = split::<8>(x, t16);
            merge_scaled(&dct8(a, &base), &dct8(b, &base), x, scale);
        } else if let Ok(x) = <&mut [f32; 8]>::try_from(&mut *x) {
            *x = dct8(*x, &base);
            scale_in_place(x, scale);
        }
    }

    /// In-place orthonormal DCT-III (inverse of [`forward`](Self::forward)): `c` holds
    /// the coefficients on entry and the samples on return.
    ///
    /// Non-finite or overflowing coefficients pass through to the samples (a pure
    /// kernel: the packet decoder bounds what reaches it below 2^68).
    pub fn inverse(&self, c: &mut [f32; N]) {
        let base = self.base();
        let scale = (self.scale0, self.scale);
        let c: &mut [f32] = c;
        // The transposed passes of `forward` in reverse order: the top merge
        // stage(s) transposed, with the orthonormal scales applied as the
        // coefficients are read; the 16-point blocks in place; the top split
        // stage(s) transposed, writing the samples back.
        if let Ok(c) = <&mut [f32; 64]>::try_from(&mut *c) {
            let (Some(t64), Some(t32), Some(t16)) = (self.stage(), self.stage(), self.stage())
            else {
                return;
            };
            let mut q = unmerge2_scaled(c, scale);
            for k in 0..4 {
                let y = idct16(&column(&q, k), t16, &base);
                set_column(&mut q, k, &y);
            }
            unsplit2(&q, t64, t32, c);
        } else if let Ok(c) = <&mut [f32; 32]>::try_from(&mut *c) {
            let (Some(t32), Some(t16)) = (self.stage(), self.stage()) else {
                return;
            };
            let mut q = unmerge_rows(c);
            for k in 0..2 {
                let y = idct16(&column(&q, k), t16, &base);
                set_column(&mut q, k, &y);
            }
            unsplit_rows(&q, t32, self.scale, c);
        } else if let Ok(c) = <&mut [f32; 16]>::try_from(&mut *c) {
            let Some(t16) = self.stage() else {
                return;
            };
            let (a, b) = unmerge_scaled::<8>(c, scale);
            unsplit(&idct8(a, &base), &idct8(b, &base), t16, c);
        } else if let Ok(c) = <&mut [f32; 8]>::try_from(&mut *c) {
            scale_in_place(c, scale);
            *c = idct8(*c, &base);
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

/// Twiddles of the 8-point base kernels, by value (they stay in registers).
#[derive(Copy, Clone)]
struct Base {
    t8: [f32; 4],
    t4: [f32; 2],
    t2: f32,
}

/// Multiplies c[0] by s_0 and the rest by s (`scale` = (s_0, s)).
#[inline(always)]
fn scale_in_place(v: &mut [f32], (s0, s): (f32, f32)) {
    if let Some((first, rest)) = v.split_first_mut() {
        *first *= s0;
        for x in rest {
            *x *= s;
        }
    }
}

/// Lee's split of a block of 2H samples `x` (stage L = 2H): the halves
/// a[i] = x[i] + x[L−1−i] (their DCT gives the even outputs) and
/// b[i] = (x[i] − x[L−1−i]) · t[i], t[i] = 1 / (2 cos((2i+1)π/2L)) (the odd ones).
#[inline(always)]
fn split<const H: usize>(x: &[f32], t: &[f32; H]) -> ([f32; H], [f32; H]) {
    let (mut a, mut b) = ([0.0; H], [0.0; H]);
    if let Some((lo, hi)) = x.split_at_checked(H) {
        let pairs = lo.iter().zip(hi.iter().rev()).zip(t);
        for (((&p, &q), &t), (a, b)) in pairs.zip(a.iter_mut().zip(&mut b)) {
            *a = p + q;
            *b = (p - q) * t;
        }
    }
    (a, b)
}

/// Lee's merge of the H-point transforms A = DCT(a), B = DCT(b) of [`split`] into
/// `out` (2H values): X[2k] = A[k], X[2k+1] = B[k] + B[k+1] with B[H] = 0.
#[inline(always)]
fn merge<const H: usize>(a: &[f32; H], b: &[f32; H], out: &mut [f32]) {
    // Backwards, so that B[k+1] is the previous iteration's B[k].
    let mut odd_next = 0.0;
    for (pair, (&a, &b)) in out.chunks_exact_mut(2).zip(a.iter().zip(b)).rev() {
        if let [x0, x1] = pair {
            *x0 = a;
            *x1 = b + odd_next;
            odd_next = b;
        }
    }
}

/// [`merge`] with the orthonormal scales applied to the outputs: X[0]·s_0, X[k]·s.
#[inline(always)]
fn merge_scaled<const H: usize>(a: &[f32; H], b: &[f32; H], out: &mut [f32], (s0, s): (f32, f32)) {
    let mut odd_next = 0.0;
    for (pair, (&a, &b)) in out.chunks_exact_mut(2).zip(a.iter().zip(b)).rev() {
        if let [x0, x1] = pair {
            *x0 = a * s;
            *x1 = (b + odd_next) * s;
            odd_next = b;
        }
    }
    if let (Some(x0), Some(&a0)) = (out.first_mut(), a.first()) {
        *x0 = a0 * s0;
    }
}

/// Transpose of [`merge`]: from 2H coefficients X, A[k] = X[2k] and
/// B[k] = X[2k+1] + X[2k−1] (X[−1] = 0), each times the orthonormal scale of its
/// coefficient (X[0]·s_0, the others ·s), which the stages below leave unchanged.
#[inline(always)]
fn unmerge_scaled<const H: usize>(c: &[f32], (s0, s): (f32, f32)) -> ([f32; H], [f32; H]) {
    let (mut a, mut b) = ([0.0; H], [0.0; H]);
    let mut odd_prev = 0.0;
    for (pair, (a, b)) in c.chunks_exact(2).zip(a.iter_mut().zip(&mut b)) {
        if let [even, odd] = pair {
            *a = even * s;
            *b = (odd + odd_prev) * s;
            odd_prev = *odd;
        }
    }
    if let (Some(a0), Some(&c0)) = (a.first_mut(), c.first()) {
        *a0 = c0 * s0;
    }
    (a, b)
}

/// Transpose of [`merge`] without scales.
#[inline(always)]
fn unmerge<const H: usize>(c: &[f32]) -> ([f32; H], [f32; H]) {
    let (mut a, mut b) = ([0.0; H], [0.0; H]);
    let mut odd_prev = 0.0;
    for (pair, (a, b)) in c.chunks_exact(2).zip(a.iter_mut().zip(&mut b)) {
        if let [even, odd] = pair {
            *a = *even;
            *b = odd + odd_prev;
            odd_prev = *odd;
        }
    }
    (a, b)
}

/// Transpose of [`split`]: x[i] = u[i] + v[i]·t[i], x[L−1−i] = u[i] − v[i]·t[i] into
/// `out` (2H values), from the inverse transforms u, v of the two halves.
#[inline(always)]
fn unsplit<const H: usize>(u: &[f32; H], v: &[f32; H], t: &[f32; H], out: &mut [f32]) {
    if let Some((lo, hi)) = out.split_at_mut_checked(H) {
        let outs = lo.iter_mut().zip(hi.iter_mut().rev());
        for (((&u, &v), &t), (lo, hi)) in u.iter().zip(v).zip(t).zip(outs) {
            let y = v * t;
            *lo = u + y;
            *hi = u - y;
        }
    }
}

/// Lee's split stages L = 64 and L = 32 in one pass over the 64 samples: row i of the
/// result holds entry i of the four 16-point blocks [aa, ab, ba, bb] that the two
/// stages of [`split`] leave (a, b from L = 64, each split again at L = 32). Sample
/// i, 31 − i, 32 + i and 63 − i meet only each other in these two stages.
#[inline(always)]
fn split2(x: &[f32; 64], t64: &[f32; 32], t32: &[f32; 16]) -> [[f32; 4]; 16] {
    let at = |v: &[f32], i: usize| v.get(i).copied().unwrap_or(0.0);
    core::array::from_fn(|i| {
        let j = 31 - i;
        let (lo, hi) = (at(x, i) + at(x, 63 - i), at(x, j) + at(x, 32 + i));
        let b_lo = (at(x, i) - at(x, 63 - i)) * at(t64, i);
        let b_hi = (at(x, j) - at(x, 32 + i)) * at(t64, j);
        let t = at(t32, i);
        [lo + hi, (lo - hi) * t, b_lo + b_hi, (b_lo - b_hi) * t]
    })
}

/// Lee's merge stages L = 32 and L = 64 in one pass, from the four transformed blocks
/// [AA, AB, BA, BB] of [`split2`] (row j holds entry j of each) into `out`, with the
/// orthonormal scales: A = merge(AA, AB), B = merge(BA, BB), X = merge(A, B), so
/// X[4j] = AA[j], X[4j+1] = BA[j] + BB[j] + BB[j+1], X[4j+2] = AB[j] + AB[j+1],
/// X[4j+3] = BB[j] + BB[j+1] + BA[j+1] (entries past 15 are 0).
#[inline(always)]
fn merge2_scaled(q: &[[f32; 4]; 16], out: &mut [f32; 64], (s0, s): (f32, f32)) {
    // Backwards, carrying AB[j+1], BA[j+1] and BB[j+1].
    let (mut ab_next, mut ba_next, mut bb_next) = (0.0, 0.0, 0.0);
    for (x, &[aa, ab, ba, bb]) in out.chunks_exact_mut(4).zip(q).rev() {
        if let [x0, x1, x2, x3] = x {
            let odd = bb + bb_next; // B[2j+1]
            *x0 = aa * s;
            *x1 = (ba + odd) * s;
            *x2 = (ab + ab_next) * s;
            *x3 = (odd + ba_next) * s;
            (ab_next, ba_next, bb_next) = (ab, ba, bb);
        }
    }
    if let (Some(x0), Some(&[aa, ..])) = (out.first_mut(), q.first()) {
        *x0 = aa * s0;
    }
}

/// Transpose of [`merge2_scaled`]: from the 64 coefficients, row j of the result holds
/// entry j of the four blocks [AA, AB, BA, BB] that the transposed merge stages L = 64
/// and L = 32 leave, the orthonormal scales applied: AA[j] = X[4j],
/// AB[j] = X[4j+2] + X[4j−2], BA[j] = X[4j+1] + X[4j−1], BB[j] = B[2j+1] + B[2j−1]
/// with B[2j+1] = X[4j+3] + X[4j+1] (entries before 0 are 0).
#[inline(always)]
fn unmerge2_scaled(c: &[f32; 64], (s0, s): (f32, f32)) -> [[f32; 4]; 16] {
    let at = |i: usize| c.get(i).copied().unwrap_or(0.0);
    let mut q: [[f32; 4]; 16] = core::array::from_fn(|j| {
        let (x1, x2, x3) = (at(4 * j + 1), at(4 * j + 2), at(4 * j + 3));
        // X[4j−1], X[4j−2] and B[2j−1] = X[4j−1] + X[4j−3], zero before the block.
        let (p1, p2, p3) = if j == 0 {
            (0.0, 0.0, 0.0)
        } else {
            (at(4 * j - 3), at(4 * j - 2), at(4 * j - 1))
        };
        [
            at(4 * j) * s,
            (x2 + p2) * s,
            (x1 + p3) * s,
            ((x3 + x1) + (p3 + p1)) * s,
        ]
    });
    if let (Some([aa, ..]), Some(&c0)) = (q.first_mut(), c.first()) {
        *aa = c0 * s0;
    }
    q
}

/// Transpose of [`split2`]: the inverse-transformed blocks [aa, ab, ba, bb] (row i
/// holds entry i of each) through the transposed split stages L = 32 and L = 64 into
/// the 64 samples `out`.
#[inline(always)]
fn unsplit2(q: &[[f32; 4]; 16], t64: &[f32; 32], t32: &[f32; 16], out: &mut [f32; 64]) {
    let Some((lo, hi)) = out.split_at_mut_checked(32) else {
        return;
    };
    let Some((q0, q1)) = lo.split_at_mut_checked(16) else {
        return;
    };
    let Some((q2, q3)) = hi.split_at_mut_checked(16) else {
        return;
    };
    // Row i writes samples i (q0), 31 − i (q1 reversed), 32 + i (q2), 63 − i (q3
    // reversed).
    let outs = q0
        .iter_mut()
        .zip(q1.iter_mut().rev())
        .zip(q2.iter_mut().zip(q3.iter_mut().rev()));
    let tw = t64.iter().zip(t64.iter().rev()).zip(t32);
    for ((&[aa, ab, ba, bb], ((&t_lo, &t_hi), &t)), ((x0, x1), (x2, x3))) in
        q.iter().zip(tw).zip(outs)
    {
        let (y, z) = (ab * t, bb * t);
        let (a_lo, a_hi) = (aa + y, aa - y);
        let (b_lo, b_hi) = ((ba + z) * t_lo, (ba - z) * t_hi);
        *x0 = a_lo + b_lo;
        *x3 = a_lo - b_lo;
        *x1 = a_hi + b_hi;
        *x2 = a_hi - b_hi;
    }
}

/// [`split`] of 32 samples with the halves interleaved (row i holds [a[i], b[i]]),
/// times the orthonormal scale `s`: b through `t32`, which holds
/// s · 1 / (2 cos((2i+1)π/64)), and a by one multiplication.
#[inline(always)]
fn split_rows(x: &[f32; 32], t32: &[f32; 16], s: f32) -> [[f32; 2]; 16] {
    let at = |v: &[f32], i: usize| v.get(i).copied().unwrap_or(0.0);
    core::array::from_fn(|i| {
        let (p, q) = (at(x, i), at(x, 31 - i));
        [(p + q) * s, (p - q) * at(t32, i)]
    })
}

/// [`merge`] from interleaved halves (row k holds [A[k], B[k]]), which carry the scale
/// s from [`split_rows`]; X[0] takes s_0 = s / √2.
#[inline(always)]
fn merge_rows(q: &[[f32; 2]; 16], out: &mut [f32; 32]) {
    let mut odd_next = 0.0;
    for (pair, &[a, b]) in out.chunks_exact_mut(2).zip(q).rev() {
        if let [x0, x1] = pair {
            *x0 = a;
            *x1 = b + odd_next;
            odd_next = b;
        }
    }
    if let Some(x0) = out.first_mut() {
        *x0 *= FRAC_1_SQRT_2;
    }
}

/// Transpose of [`merge_rows`]: row k of the result holds [A[k], B[k]] with
/// A[k] = X[2k] (X[0] / √2) and B[k] = X[2k+1] + X[2k−1]. [`unsplit_rows`] applies
/// the scale s.
#[inline(always)]
fn unmerge_rows(c: &[f32; 32]) -> [[f32; 2]; 16] {
    let at = |i: usize| c.get(i).copied().unwrap_or(0.0);
    let mut q: [[f32; 2]; 16] = core::array::from_fn(|k| {
        let odd_prev = if k == 0 { 0.0 } else { at(2 * k - 1) };
        [at(2 * k), at(2 * k + 1) + odd_prev]
    });
    if let Some([a0, _]) = q.first_mut() {
        *a0 *= FRAC_1_SQRT_2;
    }
    q
}

/// Transpose of [`split_rows`] (row i holds [u[i], v[i]]) into 32 samples:
/// x[i] = s·u[i] + v[i]·t[i], x[31−i] = s·u[i] − v[i]·t[i], `t32` carrying s.
#[inline(always)]
fn unsplit_rows(q: &[[f32; 2]; 16], t32: &[f32; 16], s: f32, out: &mut [f32; 32]) {
    if let Some((lo, hi)) = out.split_at_mut_checked(16) {
        let outs = lo.iter_mut().zip(hi.iter_mut().rev());
        for ((&[u, v], &t), (lo, hi)) in q.iter().zip(t32).zip(outs) {
            let (u, y) = (u * s, v * t);
            *lo = u + y;
            *hi = u - y;
        }
    }
}

/// Column `c` of the interleaved blocks of [`split2`].
#[inline(always)]
fn column<const C: usize>(q: &[[f32; C]; 16], c: usize) -> [f32; 16] {
    core::array::from_fn(|i| q.get(i).and_then(|row| row.get(c)).copied().unwrap_or(0.0))
}

/// Writes `v` into column `c` of the interleaved blocks.
#[inline(always)]
fn set_column<const C: usize>(q: &mut [[f32; C]; 16], c: usize, v: &[f32; 16]) {
    for (row, &v) in q.iter_mut().zip(v) {
        if let Some(slot) = row.get_mut(c) {
            *slot = v;
        }
    }
}

/// Unnormalized 16-point DCT-II: Lee's split into two [`dct8`] and the merge.
#[inline(always)]
fn dct16(x: &[f32; 16], t16: &[f32; 8], base: &Base) -> [f32; 16] {
    let (a, b) = split::<8>(x, t16);
    let mut y = [0.0; 16];
    merge(&dct8(a, base), &dct8(b, base), &mut y);
    y
}

/// Transpose of [`dct16`].
#[inline(always)]
fn idct16(c: &[f32; 16], t16: &[f32; 8], base: &Base) -> [f32; 16] {
    let (a, b) = unmerge::<8>(c);
    let mut y = [0.0; 16];
    unsplit(&idct8(a, base), &idct8(b, base), t16, &mut y);
    y
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
fn dct8(x: [f32; 8], &Base { t8, t4, t2 }: &Base) -> [f32; 8] {
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
fn idct8(c: [f32; 8], &Base { t8, t4, t2 }: &Base) -> [f32; 8] {
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
