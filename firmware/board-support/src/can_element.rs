//! A CAN frame of kerf's (`kerf::codec::canopen::CanFrame`: an 11-bit identifier and
//! at most 8 bytes) as the G474's FDCAN keeps it in its message RAM: the first four
//! words of a transmit buffer or receive FIFO element (the Bosch M_CAN element
//! layout, STM32G4 reference manual RM0440, FDCAN message RAM):
//!
//! | word | bits | transmit element (T0, T1) | receive element (R0, R1) |
//! |---|---|---|---|
//! | 0 | 28:18 | standard identifier | standard identifier |
//! | 0 | 29, 30 | RTR = 0, XTD = 0 (a data frame, 11-bit identifier) | RTR, XTD |
//! | 1 | 19:16 | DLC (= the length, 0 to 8) | DLC |
//! | 1 | 20, 21 | BRS = 1, FDF = 1 (FD frame, data phase at the fast rate) | BRS, FDF |
//! | 2, 3 | | data bytes 0–3, 4–7, little-endian | data bytes |
//!
//! A received frame kerf cannot carry (an extended identifier, a remote frame, more
//! than 8 bytes) is refused, and the bus counts it.

use kerf::codec::canopen::CanFrame;

/// Words of an element that carry a frame of at most 8 bytes.
pub const FRAME_WORDS: usize = 4;

const ID_SHIFT: u32 = 18;
const ID_MASK: u32 = 0x7FF;
const RTR: u32 = 1 << 29;
const XTD: u32 = 1 << 30;
const DLC_SHIFT: u32 = 16;
const DLC_MASK: u32 = 0xF;
const BRS: u32 = 1 << 20;
const FDF: u32 = 1 << 21;

/// Why a received element is not a frame kerf carries.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Refused {
    /// A 29-bit identifier.
    Extended,
    /// A remote frame.
    Remote,
    /// A data length code past 8 bytes (an FD frame of 12 to 64 bytes).
    TooLong,
}

/// The transmit element of `frame`, sent as an FD frame with bit-rate switch; `None`
/// when its identifier is past 11 bits or its length past 8.
pub fn transmit_element(frame: &CanFrame) -> Option<[u32; FRAME_WORDS]> {
    if u32::from(frame.id) > ID_MASK || frame.len > 8 {
        return None;
    }
    let [a, b] = data_words(&frame.data);
    Some([
        u32::from(frame.id) << ID_SHIFT,
        (u32::from(frame.len) << DLC_SHIFT) | BRS | FDF,
        a,
        b,
    ])
}

/// The frame of a received element (bytes past its length are zero).
pub fn received_frame(words: &[u32; FRAME_WORDS]) -> Result<CanFrame, Refused> {
    let [r0, r1, a, b] = *words;
    if r0 & XTD != 0 {
        return Err(Refused::Extended);
    }
    if r0 & RTR != 0 {
        return Err(Refused::Remote);
    }
    let len = (r1 >> DLC_SHIFT) & DLC_MASK;
    if len > 8 {
        return Err(Refused::TooLong);
    }
    let mut data = [0u8; 8];
    for (i, (byte, word)) in data.iter_mut().zip([a, a, a, a, b, b, b, b]).enumerate() {
        if (i as u32) < len {
            *byte = (word >> (8 * (i % 4))) as u8;
        }
    }
    Ok(CanFrame {
        id: ((r0 >> ID_SHIFT) & ID_MASK) as u16,
        len: len as u8,
        data,
    })
}

fn data_words(data: &[u8; 8]) -> [u32; 2] {
    let [b0, b1, b2, b3, b4, b5, b6, b7] = *data;
    [
        u32::from_le_bytes([b0, b1, b2, b3]),
        u32::from_le_bytes([b4, b5, b6, b7]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec;

    fn frame(id: u16, bytes: &[u8]) -> CanFrame {
        let mut data = [0u8; 8];
        data[..bytes.len()].copy_from_slice(bytes);
        CanFrame {
            id,
            len: bytes.len() as u8,
            data,
        }
    }

    /// A TPDO of drive 5 (0x185, 8 bytes) as the reference manual's element layout
    /// puts it, written out bit by bit: ID 0x185 at bits 28:18, DLC 8 at 19:16 with
    /// BRS and FDF, data little-endian.
    #[test]
    fn a_frame_is_laid_out_as_the_element_format_says() {
        let f = frame(0x185, &[0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08]);
        let words = transmit_element(&f).unwrap();
        assert_eq!(words[0], 0x185 * 262_144);
        assert_eq!(words[1], 8 * 65_536 + 1_048_576 + 2_097_152);
        assert_eq!(words[2], 0x0403_0201);
        assert_eq!(words[3], 0x0807_0605);
    }

    /// Every length and the identifiers' edges come back as they went (a receive
    /// element has the transmit element's first four words' layout); the bytes past
    /// the length are zero even when the element held others.
    #[test]
    fn frames_round_trip_and_bytes_past_the_length_are_dropped() {
        for id in [0u16, 0x080, 0x185, 0x601, 0x7FF] {
            for len in 0..=8usize {
                let bytes: Vec<u8> = (0..len as u8).map(|i| 0xA0 + i).collect();
                let f = frame(id, &bytes);
                let mut words = transmit_element(&f).unwrap();
                // Stale bytes in the element past the length.
                words[2] |= if len < 4 { 0xFFFF_FFFF << (8 * len) } else { 0 };
                words[3] |= if len < 8 {
                    0xFFFF_FFFF << (8 * len.saturating_sub(4))
                } else {
                    0
                };
                assert_eq!(received_frame(&words), Ok(f), "id {id:#x} len {len}");
            }
        }
    }

    #[test]
    fn frames_kerf_cannot_carry_are_refused() {
        let mut too_long = frame(0x100, &[]);
        too_long.len = 9;
        assert_eq!(transmit_element(&too_long), None);
        assert_eq!(
            transmit_element(&CanFrame {
                id: 0x800,
                ..frame(0, &[])
            }),
            None
        );
        let good = transmit_element(&frame(0x181, &[1, 2])).unwrap();
        assert_eq!(
            received_frame(&[good[0] | XTD, good[1], 0, 0]),
            Err(Refused::Extended)
        );
        assert_eq!(
            received_frame(&[good[0] | RTR, good[1], 0, 0]),
            Err(Refused::Remote)
        );
        for dlc in 9..=15u32 {
            let r1 = (good[1] & !(DLC_MASK << DLC_SHIFT)) | (dlc << DLC_SHIFT);
            assert_eq!(received_frame(&[good[0], r1, 0, 0]), Err(Refused::TooLong));
        }
    }
}
