//! What crosses the master/slave link: the Selected-DCT block codec
//! (SPEC `codec::sdct`, T 7.2.3).
//!
//! Data flow of one block of N samples (N = 8, 16, 32 or 64):
//!
//! ```text
//! samples ─ dct::Dct::forward ─ sdct::SdctEncoder (keep m of N) ─ packet::encode ─▶ link
//! link ─▶ packet::PacketDecoder ─ Packet::to_block ─ sdct::SdctDecoder (zero-fill, DCT-III) ─ samples
//! ```
//!
//! Latency: a block can only be transformed once its last sample exists, so block coding
//! delays every sample by up to N sample periods (the first sample of a block waits
//! N − 1 periods for the others, plus one period to close the block), on top of the
//! link delay. At 10 kHz, N = 32 adds 3.2 ms and N = 64 adds 6.4 ms.

pub mod dct;
pub mod packet;
pub mod sdct;

/// The largest supported block length; index sets fit one `u64` bit mask.
pub const MAX_N: usize = 64;

/// Block lengths the codec supports (powers of two for the fast transform, at most
/// [`MAX_N`] so that the generated cosine table holds every angle exactly).
pub const SUPPORTED_N: [usize; 4] = [8, 16, 32, 64];

/// True when `n` is one of [`SUPPORTED_N`].
pub const fn is_supported_n(n: usize) -> bool {
    matches!(n, 8 | 16 | 32 | 64)
}

/// Bit mask with the lowest `m` bits set (`m` ≤ 64): the index set of the
/// conventional "first m coefficients" DCT codec.
pub const fn prefix_mask(m: usize) -> u64 {
    if m >= 64 {
        u64::MAX
    } else {
        (1u64 << m) - 1
    }
}

// Benchmark kernels: concrete, non-inlined entry points so that instruction counts per
// call can be measured on the target (all f32, no allocation).
use dct::{Dct, NaiveDct};
use sdct::{Block, EncodeError, SdctDecoder, SdctEncoder};

/// Fast in-place DCT-II, N = 32 ([`Dct::forward`]).
#[inline(never)]
pub fn dct_fast_32(dct: &Dct<32>, x: &mut [f32; 32]) {
    dct.forward(x);
}

/// Fast in-place DCT-II, N = 64 ([`Dct::forward`]).
#[inline(never)]
pub fn dct_fast_64(dct: &Dct<64>, x: &mut [f32; 64]) {
    dct.forward(x);
}

/// Fast in-place DCT-III, N = 64 ([`Dct::inverse`]).
#[inline(never)]
pub fn idct_fast_64(dct: &Dct<64>, c: &mut [f32; 64]) {
    dct.inverse(c);
}

/// Reference matrix-vector DCT-II, N = 32 ([`NaiveDct::forward`]).
#[inline(never)]
pub fn dct_naive_32(dct: &NaiveDct<32>, x: &[f32; 32], c: &mut [f32; 32]) {
    dct.forward(x, c);
}

/// Reference matrix-vector DCT-II, N = 64 ([`NaiveDct::forward`]).
#[inline(never)]
pub fn dct_naive_64(dct: &NaiveDct<64>, x: &[f32; 64], c: &mut [f32; 64]) {
    dct.forward(x, c);
}

/// Reference matrix-vector DCT-III, N = 64 ([`NaiveDct::inverse`]).
#[inline(never)]
pub fn idct_naive_64(dct: &NaiveDct<64>, c: &[f32; 64], x: &mut [f32; 64]) {
    dct.inverse(c, x);
}

/// SDCT encode of one block (transform + selection), N = 32.
#[inline(never)]
pub fn sdct_encode_32(enc: &SdctEncoder<32>, x: &[f32; 32]) -> Result<Block<32>, EncodeError> {
    enc.encode(x)
}

/// SDCT encode of one block (transform + selection), N = 64.
#[inline(never)]
pub fn sdct_encode_64(enc: &SdctEncoder<64>, x: &[f32; 64]) -> Result<Block<64>, EncodeError> {
    enc.encode(x)
}

/// SDCT decode of one block (zero-fill + inverse), N = 32.
#[inline(never)]
pub fn sdct_decode_32(dec: &SdctDecoder<32>, block: &Block<32>, x: &mut [f32; 32]) {
    dec.decode(block, x);
}

/// SDCT decode of one block (zero-fill + inverse), N = 64.
#[inline(never)]
pub fn sdct_decode_64(dec: &SdctDecoder<64>, block: &Block<64>, x: &mut [f32; 64]) {
    dec.decode(block, x);
}
