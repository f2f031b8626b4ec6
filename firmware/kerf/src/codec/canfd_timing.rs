//! How long a CAN FD frame holds the bus (ISO 11898-1:2015 base format, FDF = 1,
//! BRS = 1, payload ≤ 16 bytes so CRC-17), counted bit by bit with the worst-case
//! dynamic stuffing (docs/drives.md, "Bus timing").
//!
//! Nominal (arbitration) rate: SOF, 11 identifier bits, RRS, IDE, FDF, res, BRS
//! (17 bits; the switch happens at BRS's sample point, so BRS is counted whole at
//! the nominal rate, the slower and so the worse), then the CRC delimiter (the
//! switch back happens at its sample point: counted whole at the nominal rate), ACK
//! slot, ACK delimiter, 7 bits EOF and the 3-bit intermission: 13 bits.
//!
//! Data rate: ESI, 4 DLC bits, the payload, the 4-bit stuff count (3 Gray-coded bits
//! and parity), 17 CRC bits and the CRC field's 6 fixed stuff bits (one before the
//! stuff count, then one after every fourth bit of the 21 bits that follow).
//!
//! Dynamic stuffing (a complemented bit after five equal ones) covers SOF to the end
//! of the data field, 22 + 8n bits for n payload bytes. After the first run of five,
//! each stuff bit starts a new run, so at most one more stuff bit follows every four
//! bits: ⌊(22 + 8n − 1)/4⌋ in all (the classical-CAN bound of Davis et al. applied to
//! the FD frame's stuffed field). The first 17 bits can hold ⌊(17 − 1)/4⌋ = 4 of them
//! (SOF 0 then 0000 1111 0000 1 in the identifier); putting those at the nominal
//! rate and the rest at the data rate is the slowest arrangement.

/// A bus's two bit rates.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FdBitRates {
    /// Arbitration-phase rate, bit/s.
    pub nominal_bps: u32,
    /// Data-phase rate, bit/s.
    pub data_bps: u32,
}

/// A frame's bits in each phase (stuff bits included).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FdFrameBits {
    /// Bits at the nominal rate.
    pub nominal: u32,
    /// Bits at the data rate.
    pub data: u32,
}

/// Bits from SOF to BRS, sent at the nominal rate.
const ARBITRATION_BITS: u32 = 17;
/// Worst-case dynamic stuff bits within them.
const ARBITRATION_STUFF: u32 = (ARBITRATION_BITS - 1) / 4;
/// CRC delimiter, ACK slot and delimiter, EOF, intermission.
const TAIL_BITS: u32 = 1 + 1 + 1 + 7 + 3;
/// ESI and DLC.
const CONTROL_BITS: u32 = 1 + 4;
/// Stuff count, CRC-17 and the CRC field's fixed stuff bits.
const CRC_FIELD_BITS: u32 = 4 + 17 + 6;

/// The bits of a frame with `payload_len` bytes (0–8: the payloads this codec sends;
/// `None` above). Worst-case stuffing.
pub const fn fd_frame_bits(payload_len: u8) -> Option<FdFrameBits> {
    if payload_len > 8 {
        return None;
    }
    let payload = 8 * payload_len as u32;
    let stuffed_field = ARBITRATION_BITS + CONTROL_BITS + payload;
    let stuff = (stuffed_field - 1) / 4;
    Some(FdFrameBits {
        nominal: ARBITRATION_BITS + ARBITRATION_STUFF + TAIL_BITS,
        data: CONTROL_BITS + payload + (stuff - ARBITRATION_STUFF) + CRC_FIELD_BITS,
    })
}

/// `bits` at `bps` (non-zero), ns rounded up.
const fn bits_ns(bits: u32, bps: u32) -> u64 {
    (bits as u64 * 1_000_000_000).div_ceil(bps as u64)
}

impl FdBitRates {
    /// 1 Mbit/s arbitration, 8 Mbit/s data: ARROW's drive buses (docs/drives.md).
    pub const ARROW: Self = Self {
        nominal_bps: 1_000_000,
        data_bps: 8_000_000,
    };

    /// The worst-case duration of a frame with `payload_len` bytes, ns (rounded up);
    /// `None` for a payload over 8 bytes or a zero rate.
    pub const fn frame_ns(&self, payload_len: u8) -> Option<u32> {
        let Some(bits) = fd_frame_bits(payload_len) else {
            return None;
        };
        if self.nominal_bps == 0 || self.data_bps == 0 {
            return None;
        }
        let total = bits_ns(bits.nominal, self.nominal_bps) + bits_ns(bits.data, self.data_bps);
        if total > u32::MAX as u64 {
            None
        } else {
            Some(total as u32)
        }
    }

    /// The bus time of a sequence of frames by payload length, ns (`None` as in
    /// [`Self::frame_ns`]).
    pub fn frames_ns(&self, payload_lens: &[u8]) -> Option<u32> {
        payload_lens.iter().try_fold(0u32, |sum, &len| {
            self.frame_ns(len).and_then(|ns| sum.checked_add(ns))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A SYNC with its counter (one byte, 0x01), id 0x080, counted by hand:
    ///
    /// ```text
    /// nominal rate:
    ///   SOF 0                                   1
    ///   identifier 000 1000 0000               11
    ///   RRS 0, IDE 0, FDF 1, res 0, BRS 1       5   (17)
    ///   worst-case stuff bits in these 17       4   (SOF + 0001: a stuff after the
    ///                                               5th, 9th, 13th, 17th bit at worst)
    ///   CRC delimiter 1, ACK 1, ACK delimiter 1 3
    ///   EOF 7, intermission 3                  10   → 34 bits
    /// data rate:
    ///   ESI 0, DLC 0001                         5
    ///   data 0000 0001                          8
    ///   dynamic stuff in SOF..data (30 bits):   ⌊29/4⌋ = 7, of which 4 above → 3
    ///   stuff count 4, CRC 17                  21
    ///   fixed stuff bits (before the count,
    ///   then after each 4 of the 21)            6   → 43 bits
    /// ```
    ///
    /// 34 bits at 1 Mbit/s + 43 at 8 Mbit/s = 34,000 + 5,375 ns.
    #[test]
    fn a_sync_frame_by_hand() {
        assert_eq!(
            fd_frame_bits(1),
            Some(FdFrameBits {
                nominal: 34,
                data: 43
            })
        );
        assert_eq!(FdBitRates::ARROW.frame_ns(1), Some(39_375));
    }

    /// 8 bytes: 69 data-phase bits of fields, ⌊85/4⌋ − 4 = 17 stuff bits, 27 in the
    /// CRC field: 113. An empty frame: 5 + (⌊21/4⌋ − 4) + 27 = 33.
    #[test]
    fn longest_and_shortest_payloads() {
        assert_eq!(fd_frame_bits(8).map(|b| b.data), Some(113));
        assert_eq!(fd_frame_bits(0).map(|b| b.data), Some(33));
        assert_eq!(fd_frame_bits(9), None);
        let zero = FdBitRates {
            nominal_bps: 0,
            data_bps: 1,
        };
        assert_eq!(zero.frame_ns(1), None);
    }
}
