//! Selected DCT: keep the m largest-magnitude coefficients of each block
//! (docs/codec.md §30, DCT and Selected DCT; T 7.2.3, Algorithm 4).
//!
//! The encoder transforms N samples with the orthonormal DCT-II and keeps m of the N
//! coefficients; the decoder zero-fills the others and applies the DCT-III. Because the
//! basis is orthonormal, the reconstruction error energy equals the energy of the
//! dropped coefficients (Parseval), so keeping the m largest |c\[k\]| is the best
//! m-term approximation in L2 — a **CORRECTION** of the print (docs/codec.md §30),
//! which sorts by signed value and would drop large negative coefficients.
//! [`Selection::First`] is the conventional DCT codec (c[0..m)), the baseline SDCT is
//! compared against; it needs no indices on the wire, SDCT does (see
//! [`packet`](super::packet)).
//!
//! Ties in magnitude go to the lower index, so the selection is a pure function of the
//! coefficients. Exact ties do occur: an impulse at n = 0 has |c\[0\]| = |c\[N/2\]| =
//! 1/√N, a constant block has N − 1 zero coefficients. The rule applies to the computed
//! f32 magnitudes, where rounding can split a mathematical tie by one ulp.

use super::dct::Dct;
use super::prefix_mask;
use crate::error::ConfigError;

/// Which coefficients a block keeps.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Selection {
    /// SDCT: the m largest |c\[k\]|, ties to the lower index.
    Largest,
    /// Conventional DCT codec: c[0..m).
    First,
}

/// Encoder configuration.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct SdctConfig {
    /// Coefficients kept per block, 1..=N.
    pub m: usize,
    /// How they are chosen.
    pub selection: Selection,
}

/// Why a block could not be encoded.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncodeError {
    /// A sample is NaN or infinite.
    NotFinite,
    /// A coefficient of the finite block exceeds f32's range (samples near
    /// `f32::MAX`: a constant block's first coefficient is √N times its value).
    Overflow,
}

/// One coded block: the index set and the coefficients, zero outside the set.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Block<const N: usize> {
    mask: u64,
    coeffs: [f32; N],
}

impl<const N: usize> Block<N> {
    /// Keeps `coeffs[k]` for the bits k < N set in `mask` and zero-fills the rest.
    pub fn from_parts(mask: u64, mut coeffs: [f32; N]) -> Self {
        let mask = mask & prefix_mask(N);
        for (k, c) in coeffs.iter_mut().enumerate() {
            if mask >> k & 1 == 0 {
                *c = 0.0;
            }
        }
        Self { mask, coeffs }
    }

    /// Bit k is set when coefficient k is kept.
    pub const fn mask(&self) -> u64 {
        self.mask
    }

    /// Number of kept coefficients.
    pub const fn m(&self) -> usize {
        self.mask.count_ones() as usize
    }

    /// All N coefficients in natural order, zero where not kept.
    pub const fn coefficients(&self) -> &[f32; N] {
        &self.coeffs
    }
}

/// Mask of the `m` largest |c\[k\]|, ties to the lower index (the order a stable sort
/// by descending magnitude gives). No allocation and no panic path.
///
/// For non-negative floats the IEEE bit pattern orders like the value, so the
/// selection runs on integers, and mostly on the 8 exponent bits (NaN is rejected
/// before the transform). Three passes over the block, none of them with a branch
/// per value:
///
/// 1. the largest exponent E;
/// 2. a histogram of how many binades below E each magnitude lies (0..=30, and 31 for
///    everything further down: zeros, subnormals, values below 2^−31 of the peak),
///    read from the top until it holds m values: the bucket d* that holds the m-th
///    largest, and r ≥ 1 of its members still wanted;
/// 3. two comparisons per magnitude against the bounds of d*, shifted into two `u32`
///    masks (32 indices at a time, so no 64-bit variable shift per index): the
///    magnitudes above d* are kept, and the members of d* are the candidates.
///
/// When d* holds exactly r values they are all kept. Otherwise the candidates go, in
/// index order, through a sorted buffer of the r largest, each entering after every
/// member at least as large, so an equal later one never displaces an earlier one; one
/// not larger than the buffer's last is appended or dropped at once (ties, such as the
/// zeros of a constant block, and descending runs). A block of DCT coefficients
/// spreads over many binades, so the buffer sees a few values; the worst case (every
/// magnitude in one binade, in ascending order) is N insertions into a buffer of
/// r ≤ m: bounded, with no recursion.
pub fn select_largest<const N: usize>(c: &[f32; N], m: usize) -> u64 {
    if m == 0 {
        return 0;
    }
    if m >= N {
        return prefix_mask(N);
    }
    let exponent = |v: &f32| (v.to_bits() >> 23) & 0xFF;
    let top = c.iter().map(exponent).max().unwrap_or(0);
    // Binades below the top, the last bucket taking everything further down. The top
    // is the largest exponent, so the difference cannot wrap.
    let bucket = |v: &f32| top.wrapping_sub(exponent(v)).min(31) as usize;
    let mut count = [0u8; 32];
    for v in c {
        if let Some(n) = count.get_mut(bucket(v)) {
            *n = n.wrapping_add(1);
        }
    }
    // Down from the top until the m-th value is inside; the last bucket holds the
    // rest of the N > m values, so the loop always stops.
    let (mut above, mut cut) = (0usize, 31usize);
    for (d, &n) in count.iter().enumerate() {
        if above + usize::from(n) >= m {
            cut = d;
            break;
        }
        above += usize::from(n);
    }
    let wanted = m - above;
    // Binade `cut` is the exponent top − cut (the last bucket: everything at or below
    // it). Magnitudes from the next binade up are kept; those from `cut` itself are
    // the candidates.
    let binade = top.saturating_sub(cut as u32);
    let keep_from = (binade + 1) << 23;
    let candidate_from = if cut == 31 { 0 } else { binade << 23 };
    let magnitude = |v: &f32| v.to_bits() & 0x7FFF_FFFF;
    let weight = |k: u32| c.get(k as usize).map_or(0, magnitude);
    let (mut mask, mut candidates) = (0u64, 0u64);
    for (start, chunk) in (0u32..).step_by(32).zip(c.chunks(32)) {
        // Bit i of the chunk enters at the top and moves down one place per sample.
        let (mut keep, mut member) = (0u32, 0u32);
        for v in chunk {
            let b = magnitude(v);
            keep = keep >> 1 | u32::from(b >= keep_from) << 31;
            member = member >> 1 | u32::from(b >= candidate_from) << 31;
        }
        let shift = 32u32.saturating_sub(chunk.len() as u32);
        let keep = keep.checked_shr(shift).unwrap_or(0);
        let member = member.checked_shr(shift).unwrap_or(0) & !keep;
        mask |= u64::from(keep) << start;
        candidates |= u64::from(member) << start;
    }
    if count.get(cut).is_some_and(|&n| usize::from(n) == wanted) {
        // Every member of the binade is wanted.
        return mask | candidates;
    }
    // Indices of the `wanted` largest candidates so far, by descending magnitude, ties
    // in index order, and the magnitude of the last one.
    let mut best = [0u8; N];
    let (mut filled, mut last) = (0usize, 0u32);
    while candidates != 0 {
        let k = candidates.trailing_zeros();
        candidates &= candidates - 1;
        let b = weight(k);
        if filled > 0 && b <= last {
            // Not larger than the last one kept (ties, descending runs): to the end.
            if let Some(slot) = best.get_mut(filled).filter(|_| filled < wanted) {
                *slot = k as u8;
                filled += 1;
                last = b;
            }
            continue;
        }
        // Larger than the last one: in after every entry at least as large, the
        // rest moving down one place, the last dropping out when the buffer is full.
        let at = best
            .iter()
            .take(filled)
            .rposition(|&j| weight(u32::from(j)) >= b)
            .map_or(0, |p| p + 1);
        filled = (filled + 1).min(wanted);
        let mut carry = k as u8;
        for slot in best.iter_mut().take(filled).skip(at) {
            core::mem::swap(slot, &mut carry);
        }
        last = best
            .get(filled.wrapping_sub(1))
            .map_or(0, |&j| weight(u32::from(j)));
    }
    for &k in best.iter().take(filled) {
        mask |= 1u64.checked_shl(u32::from(k)).unwrap_or(0);
    }
    mask
}

/// Mask of the coefficients `selection` keeps out of `c`.
pub fn select<const N: usize>(c: &[f32; N], m: usize, selection: Selection) -> u64 {
    match selection {
        Selection::Largest => select_largest(c, m),
        Selection::First => prefix_mask(m.min(N)),
    }
}

/// Samples below this magnitude (2^64) go through the transform as they are: its
/// sums stay far below f32::MAX (2^128). Larger ones are scaled down by it first
/// ([`SdctEncoder::encode`]); such blocks exceed a packet's range anyway
/// (`codec::packet`'s exponent limit), but the encoder's contract holds alone.
pub const UNSCALED_BELOW: f32 = 18_446_744_073_709_551_616.0;

/// Block encoder: DCT-II then selection.
#[derive(Clone, Debug)]
pub struct SdctEncoder<const N: usize> {
    dct: Dct<N>,
    m: usize,
    selection: Selection,
}

impl<const N: usize> SdctEncoder<N> {
    /// `OutOfRange("N")` unless N is 8, 16, 32 or 64; `OutOfRange("m")` unless
    /// 1 ≤ m ≤ N.
    pub fn new(config: &SdctConfig) -> Result<Self, ConfigError> {
        let dct = Dct::new()?;
        if config.m == 0 || config.m > N {
            return Err(ConfigError::out_of_range("m"));
        }
        Ok(Self {
            dct,
            m: config.m,
            selection: config.selection,
        })
    }

    /// Coefficients kept per block.
    pub const fn m(&self) -> usize {
        self.m
    }

    /// Transforms the N samples `x` (oldest first) and keeps m coefficients.
    ///
    /// Errors: [`EncodeError::NotFinite`] for a NaN or infinite sample;
    /// [`EncodeError::Overflow`] when a coefficient exceeds f32's range. A block with a
    /// sample of [`UNSCALED_BELOW`] or more is transformed scaled down by 2^−64 and
    /// the coefficients scaled back (both exact: powers of two), so the fast kernel's
    /// intermediate sums, which grow with its twiddles (up to 20× at N = 64,
    /// `codec::dct`), cannot overflow; a coefficient is then infinite only when its
    /// true value is beyond f32::MAX, and that block is refused.
    pub fn encode(&self, x: &[f32; N]) -> Result<Block<N>, EncodeError> {
        if x.iter().any(|v| !v.is_finite()) {
            return Err(EncodeError::NotFinite);
        }
        let mut c = *x;
        let large = c.iter().any(|v| v.abs() >= UNSCALED_BELOW);
        if large {
            c.iter_mut().for_each(|v| *v *= 1.0 / UNSCALED_BELOW);
        }
        self.dct.forward(&mut c);
        if large {
            c.iter_mut().for_each(|v| *v *= UNSCALED_BELOW);
        }
        if c.iter().any(|v| !v.is_finite()) {
            return Err(EncodeError::Overflow);
        }
        Ok(Block::from_parts(select(&c, self.m, self.selection), c))
    }
}

/// Block decoder: zero-filled coefficients through the DCT-III.
#[derive(Clone, Debug)]
pub struct SdctDecoder<const N: usize> {
    dct: Dct<N>,
}

impl<const N: usize> SdctDecoder<N> {
    /// `OutOfRange("N")` unless N is 8, 16, 32 or 64.
    pub fn new() -> Result<Self, ConfigError> {
        Ok(Self { dct: Dct::new()? })
    }

    /// Reconstructs the N samples of `block` (oldest first) into `out`.
    ///
    /// A block made with [`Block::from_parts`] from non-finite or overflowing
    /// coefficients decodes to non-finite samples (blocks from a parsed packet cannot).
    pub fn decode(&self, block: &Block<N>, out: &mut [f32; N]) {
        *out = block.coeffs;
        self.dct.inverse(out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::dct::NaiveDct;
    use proptest::prelude::*;

    fn energy(v: &[f32]) -> f64 {
        v.iter().map(|&x| f64::from(x) * f64::from(x)).sum()
    }

    fn error_energy(a: &[f32], b: &[f32]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
            .sum()
    }

    fn round_trip<const N: usize>(
        x: &[f32; N],
        m: usize,
        selection: Selection,
    ) -> ([f32; N], Block<N>) {
        let enc = SdctEncoder::<N>::new(&SdctConfig { m, selection }).unwrap();
        let dec = SdctDecoder::<N>::new().unwrap();
        let block = enc.encode(x).unwrap();
        let mut y = [0.0; N];
        dec.decode(&block, &mut y);
        (y, block)
    }

    #[test]
    fn keeps_largest_magnitudes_with_ties_to_lower_index() {
        let mut c = [0.0f32; 8];
        c[5] = -3.0; // signed sort of the print would drop this one
        c[2] = 2.0;
        c[6] = 2.0; // tie with c[2]
        c[7] = 1.0;
        assert_eq!(select_largest(&c, 1), 1 << 5);
        assert_eq!(select_largest(&c, 2), 1 << 5 | 1 << 2);
        assert_eq!(select_largest(&c, 3), 1 << 5 | 1 << 2 | 1 << 6);
        assert_eq!(select_largest(&c, 8), 0xFF);
        assert_eq!(select_largest(&c, 20), 0xFF);
        assert_eq!(select_largest(&[0.0f32; 8], 3), 0b111); // all tied
        assert_eq!(select(&c, 3, Selection::First), 0b111);
    }

    #[test]
    fn selection_matches_a_stable_sort_on_random_blocks_with_ties() {
        // Reference: indices sorted by descending |c| (stable, so ties keep the lower
        // index), the first m kept. Magnitudes drawn from 6 levels force many ties.
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for _ in 0..2000 {
            let mut c = [0.0f32; 32];
            for v in c.iter_mut() {
                let r = next();
                let level = (r % 6) as f32 * 0.25;
                *v = if r & 64 == 0 { level } else { -level };
            }
            let m = (next() % 33) as usize;
            let mut order: std::vec::Vec<usize> = (0..32).collect();
            order.sort_by(|&a, &b| c[b].abs().total_cmp(&c[a].abs()));
            let expect = order.iter().take(m).fold(0u64, |mask, &k| mask | 1 << k);
            assert_eq!(select_largest(&c, m), expect, "m = {m}, {c:?}");
        }
    }

    /// The binade search against a reference sort, on blocks of 8 and 64 whose
    /// magnitudes spread over many binades or crowd into a few (a binade boundary
    /// between the m-th and (m+1)-th value, or both inside one), with ties and zeros.
    #[test]
    fn selection_matches_a_sort_across_and_within_binades() {
        fn check<const N: usize>(next: &mut impl FnMut() -> u64) {
            for round in 0..3000 {
                let mut c = [0.0f32; N];
                for v in c.iter_mut() {
                    let r = next();
                    let magnitude = match round % 3 {
                        // Anywhere over 2^-20..2^20, with exact zeros.
                        0 if r % 9 == 0 => 0.0,
                        0 => {
                            libm::ldexpf(1.0 + (r >> 40) as f32 / 16777216.0, (r % 41) as i32 - 20)
                        }
                        // Two neighbouring binades, few distinct values (many ties).
                        1 => 1.0 + (r % 12) as f32 * 0.125,
                        // One binade, distinct values.
                        _ => 1.0 + (r >> 41) as f32 / 8388608.0,
                    };
                    *v = if r & 1 == 0 { magnitude } else { -magnitude };
                }
                let m = (next() % (N as u64 + 1)) as usize;
                let mut order: std::vec::Vec<usize> = (0..N).collect();
                order.sort_by(|&a, &b| c[b].abs().total_cmp(&c[a].abs()));
                let expect = order.iter().take(m).fold(0u64, |mask, &k| mask | 1 << k);
                assert_eq!(select_largest(&c, m), expect, "N = {N}, m = {m}, {c:?}");
            }
        }
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        check::<8>(&mut next);
        check::<64>(&mut next);
    }

    #[test]
    fn impulse_keeps_the_largest_not_the_first() {
        // An impulse at n = 0 of a 16-block has c[k] = s_k cos(kπ/32): decreasing for
        // k ≥ 1 and c[0] = 1/4 < c[1..=7], so the 4 largest are 1..=4, not 0..4 (the
        // conventional codec's choice).
        let dct = NaiveDct::<16>::new().unwrap();
        let mut x = [0.0f32; 16];
        x[0] = 1.0;
        let mut c = [0.0; 16];
        dct.forward(&x, &mut c);
        let mask = select_largest(&c, 4);
        assert_eq!(mask.count_ones(), 4);
        assert_eq!(mask, 0b1111 << 1, "{c:?}");
    }

    #[test]
    fn impulse_at_zero_ties_c0_with_c_half_and_keeps_c0() {
        // Impulse at n = 0: c[k] = s_k cos(kπ/2N), decreasing in k ≥ 1, and
        // |c[0]| = 1/√N = √(2/N) cos(π/4) = |c[N/2]| exactly. Cutting m through that
        // tie keeps index 0. In f32 the two come out bit-equal at N = 8 and 32 (at 16
        // and 64 they differ by one ulp, and the larger one wins, as it should).
        fn check<const N: usize>() {
            let enc = SdctEncoder::<N>::new(&SdctConfig {
                m: N / 2,
                selection: Selection::Largest,
            })
            .unwrap();
            let mut x = [0.0f32; N];
            x[0] = 1.0;
            let block = enc.encode(&x).unwrap();
            let mut c = x;
            Dct::<N>::new().unwrap().forward(&mut c);
            assert_eq!(c[0].abs(), c[N / 2].abs(), "N={N}: not an exact tie here");
            assert_eq!(block.mask(), prefix_mask(N / 2), "N={N}");
        }
        check::<8>();
        check::<32>();
    }

    #[test]
    fn config_is_validated() {
        let bad = SdctConfig {
            m: 0,
            selection: Selection::Largest,
        };
        assert_eq!(
            SdctEncoder::<32>::new(&bad).err(),
            Some(ConfigError::out_of_range("m"))
        );
        let bad = SdctConfig {
            m: 33,
            selection: Selection::Largest,
        };
        assert_eq!(
            SdctEncoder::<32>::new(&bad).err(),
            Some(ConfigError::out_of_range("m"))
        );
        let ok = SdctConfig {
            m: 9,
            selection: Selection::First,
        };
        assert_eq!(
            SdctEncoder::<12>::new(&ok).err(),
            Some(ConfigError::out_of_range("N"))
        );
        let enc = SdctEncoder::<8>::new(&SdctConfig {
            m: 2,
            selection: Selection::First,
        })
        .unwrap();
        let mut x = [0.0f32; 8];
        x[3] = f32::NAN;
        assert_eq!(enc.encode(&x), Err(EncodeError::NotFinite));
    }

    /// Slack for comparing an error energy e measured through the f32 transforms with
    /// its exact value: a round-off vector δ changes it by at most 2√e‖δ‖ + ‖δ‖². The
    /// `dct` tests bound the f32 round trip by 2e-6 · √N per sample at unit scale, so
    /// ‖δ‖ ≤ 2e-6 · N · max|x| ≤ 2e-6 · N · ‖x‖; 1e-4 · ‖x‖ covers N ≤ 32 with margin.
    fn slack(x: &[f32], e: f64) -> f64 {
        let d = 1e-4 * energy(x).sqrt() + 1e-12;
        2.0 * e.sqrt() * d + d * d
    }

    /// Reference selection written differently: coefficient k is kept when fewer than m
    /// others outrank it (larger magnitude, or equal magnitude and lower index).
    fn select_by_rank<const N: usize>(c: &[f32; N], m: usize) -> u64 {
        let mut mask = 0;
        for (k, ck) in c.iter().enumerate() {
            let outranked_by = c
                .iter()
                .enumerate()
                .filter(|&(j, cj)| cj.abs() > ck.abs() || (cj.abs() == ck.abs() && j < k))
                .count();
            if outranked_by < m {
                mask |= 1 << k;
            }
        }
        mask
    }

    proptest! {
        #[test]
        fn selection_matches_the_rank_reference_with_many_ties(
            ints in proptest::array::uniform16(-3i8..=3),
            m in 0usize..=20,
        ) {
            // Few distinct magnitudes: ties (and ±equal pairs) on almost every draw.
            let c = ints.map(|v| f32::from(v) * 0.5);
            prop_assert_eq!(select_largest(&c, m), select_by_rank(&c, m));
        }

        #[test]
        fn selection_matches_the_rank_reference(c in proptest::array::uniform32(-1e3f32..1e3), m in 0usize..=32) {
            prop_assert_eq!(select_largest(&c, m), select_by_rank(&c, m));
        }

        #[test]
        fn sdct_never_loses_to_the_baseline_and_obeys_parseval(
            x in proptest::array::uniform32(-100.0f32..100.0),
            m in 1usize..=32,
        ) {
            let (y_s, block_s) = round_trip(&x, m, Selection::Largest);
            let (y_b, _) = round_trip(&x, m, Selection::First);
            let e_s = error_energy(&x, &y_s);
            let e_b = error_energy(&x, &y_b);
            prop_assert!(e_s <= e_b + slack(&x, e_b), "sdct {} baseline {}", e_s, e_b);
            // Error energy = energy of the dropped coefficients.
            let mut full = x;
            Dct::<32>::new().unwrap().forward(&mut full);
            let dropped: f64 = full
                .iter()
                .enumerate()
                .filter(|&(k, _)| block_s.mask() >> k & 1 == 0)
                .map(|(_, &c)| f64::from(c) * f64::from(c))
                .sum();
            prop_assert!((e_s - dropped).abs() <= slack(&x, dropped), "{} vs {}", e_s, dropped);
            prop_assert_eq!(block_s.m(), m);
            if m == 32 {
                prop_assert!(e_s <= slack(&x, 0.0));
            }
        }

        #[test]
        fn keeping_all_coefficients_reconstructs_exactly(x in proptest::array::uniform8(-1.0f32..1.0)) {
            for selection in [Selection::Largest, Selection::First] {
                let (y, block) = round_trip(&x, 8, selection);
                prop_assert_eq!(block.mask(), 0xFF);
                for (a, b) in x.iter().zip(&y) {
                    prop_assert!((a - b).abs() < 1e-5);
                }
            }
        }
    }

    /// The orthonormal DCT-II of `x` in f64, straight from the module's sum
    /// (`codec::dct`): the reference near f32's limit, where f64 has 900 binades to
    /// spare.
    fn dct_f64<const N: usize>(x: &[f32; N]) -> [f64; N] {
        core::array::from_fn(|k| {
            let s = if k == 0 {
                (1.0 / N as f64).sqrt()
            } else {
                (2.0 / N as f64).sqrt()
            };
            s * x
                .iter()
                .enumerate()
                .map(|(n, &v)| {
                    let angle = ((2 * n + 1) * k) as f64 * core::f64::consts::PI / (2 * N) as f64;
                    f64::from(v) * angle.cos()
                })
                .sum::<f64>()
        })
    }

    /// Finite blocks near f32's limit (constant, alternating, ramps, impulses and
    /// random ones, scaled from 2^64 up to f32::MAX): every block whose coefficients
    /// are all below f32::MAX is encoded, each within 2e-6 · √N of the largest
    /// sample of the f64 reference (the fast kernel's tested accuracy, `codec::dct`);
    /// a block with a coefficient beyond f32::MAX is refused with `Overflow`, never
    /// passed on as an infinity or a NaN.
    fn near_the_limit<const N: usize>() {
        let enc = SdctEncoder::<N>::new(&SdctConfig {
            m: N,
            selection: Selection::Largest,
        })
        .unwrap();
        let mut seed = 0x9E37_79B9_7F4A_7C15u64 ^ N as u64;
        let mut uniform = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let shapes: [fn(usize) -> f32; 5] = [
            |_| 1.0,
            |n| if n % 2 == 0 { 1.0 } else { -1.0 },
            |n| n as f32 / 63.0,
            |n| f32::from(u8::from(n == 0)),
            |n| if n < 4 { -1.0 } else { 0.5 },
        ];
        let (mut accepted, mut refused) = (0, 0);
        for scale in [
            f32::MAX,
            0.9 * f32::MAX,
            f32::MAX / 8.0,
            f32::MAX / 64.0,
            1e36,
            2e19,
        ] {
            let mut blocks: std::vec::Vec<[f32; N]> = shapes
                .iter()
                .map(|shape| core::array::from_fn(|n| shape(n) * scale))
                .collect();
            for _ in 0..20 {
                blocks.push(core::array::from_fn(|_| {
                    (uniform() * f64::from(scale)) as f32
                }));
            }
            for x in &blocks {
                let reference = dct_f64(x);
                let peak = reference.iter().fold(0.0f64, |a, c| a.max(c.abs()));
                let largest = x.iter().fold(0.0f64, |a, v| a.max(f64::from(v.abs())));
                match enc.encode(x) {
                    Ok(block) => {
                        accepted += 1;
                        for (k, (&c, &r)) in block.coefficients().iter().zip(&reference).enumerate()
                        {
                            assert!(c.is_finite(), "N {N}, {x:?}: c[{k}] = {c}");
                            let bound = 2e-6 * (N as f64).sqrt() * largest;
                            assert!(
                                (f64::from(c) - r).abs() <= bound,
                                "N {N}: c[{k}] {c} against {r}"
                            );
                        }
                    }
                    Err(e) => {
                        refused += 1;
                        assert_eq!(e, EncodeError::Overflow);
                        // Refused only when the true coefficient overflows (to within
                        // the kernel's accuracy).
                        let tolerance = 2e-6 * (N as f64).sqrt() * largest;
                        assert!(
                            peak + tolerance > f64::from(f32::MAX),
                            "N {N}: {peak} {x:?}"
                        );
                    }
                }
            }
        }
        // Both outcomes occur at every N.
        assert!(accepted > 0 && refused > 0, "{accepted} {refused}");
    }

    #[test]
    fn blocks_near_f32_s_limit_are_encoded_or_refused_never_non_finite() {
        near_the_limit::<8>();
        near_the_limit::<16>();
        near_the_limit::<32>();
        near_the_limit::<64>();
    }
}
