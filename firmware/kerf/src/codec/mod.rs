//! What crosses a link: the Selected-DCT block codec between master and slave
//! (docs/codec.md §30, T 7.2.3), and the grinding cell's device protocols
//! ([`spindle`]: the spindle converter's frames, G app. B; docs/codec.md §31).
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

pub mod canfd_timing;
pub mod canopen;
pub mod cia402;
pub mod cut_settings;
pub mod dct;
pub mod gcs;
pub mod job;
pub mod link;
pub mod packet;
pub mod sdct;
pub mod spindle;

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
