//! The store on a simulated NOR flash that loses power mid-operation: a page erase cut
//! short leaves its bytes between old and erased, a write cut short leaves the word
//! being programmed with some of its bits, and the flash refuses to program a word
//! that is not erased (as the G474 does). Copies are also written here by a separate
//! writer of the documented layout, to check the reader against the format itself.

use super::*;
use embedded_storage::nor_flash::{ErrorType, NorFlashErrorKind, ReadNorFlash};
use std::vec;
use std::vec::Vec;

const PAGE: usize = 256;
const WRITE: usize = 8;

/// Which operation a power cut interrupted.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum Cut {
    Erase,
    Write,
}

struct Nor {
    bytes: Vec<u8>,
    /// Steps (a page erased, a word written) left before the power fails.
    steps_left: Option<usize>,
    off: bool,
    cut: Option<Cut>,
    /// Words programmed that were not erased.
    overwrites: usize,
    rng: u64,
}

impl Nor {
    fn new(pages: usize, seed: u64) -> Self {
        Nor {
            bytes: vec![0xFF; pages * PAGE],
            steps_left: None,
            off: false,
            cut: None,
            overwrites: 0,
            rng: seed,
        }
    }

    /// SplitMix64.
    fn next(&mut self) -> u64 {
        self.rng = self.rng.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.rng;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Takes a step; false when the power fails at it.
    fn step(&mut self, what: Cut) -> bool {
        match self.steps_left {
            Some(0) => {
                self.off = true;
                self.cut = Some(what);
                self.steps_left = None;
                false
            }
            Some(n) => {
                self.steps_left = Some(n - 1);
                true
            }
            None => true,
        }
    }
}

impl ErrorType for Nor {
    type Error = NorFlashErrorKind;
}

impl ReadNorFlash for Nor {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        if self.off {
            return Err(NorFlashErrorKind::Other);
        }
        let at = offset as usize;
        let src = self
            .bytes
            .get(at..at + bytes.len())
            .ok_or(NorFlashErrorKind::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.bytes.len()
    }
}

impl NorFlash for Nor {
    const WRITE_SIZE: usize = WRITE;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let (from, to) = (from as usize, to as usize);
        assert!(from % PAGE == 0 && to % PAGE == 0 && to <= self.bytes.len());
        for page in (from..to).step_by(PAGE) {
            if self.off {
                return Err(NorFlashErrorKind::Other);
            }
            if !self.step(Cut::Erase) {
                // Between old and erased: bits go towards 1.
                for b in page..page + PAGE {
                    let r = self.next() as u8;
                    self.bytes[b] |= r;
                }
                return Err(NorFlashErrorKind::Other);
            }
            self.bytes[page..page + PAGE].fill(0xFF);
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let at = offset as usize;
        assert!(
            at % WRITE == 0 && bytes.len() % WRITE == 0,
            "{at} {}",
            bytes.len()
        );
        for (i, word) in bytes.chunks(WRITE).enumerate() {
            if self.off {
                return Err(NorFlashErrorKind::Other);
            }
            let w = at + i * WRITE;
            if self.bytes[w..w + WRITE].iter().any(|&b| b != 0xFF) {
                self.overwrites += 1;
            }
            if !self.step(Cut::Write) {
                // Some of the word's bits programmed (towards 0), not all.
                for (k, &b) in word.iter().enumerate() {
                    let r = self.next() as u8;
                    self.bytes[w + k] &= b | r;
                }
                return Err(NorFlashErrorKind::Other);
            }
            for (k, &b) in word.iter().enumerate() {
                self.bytes[w + k] &= b;
            }
        }
        Ok(())
    }
}

/// Two slots of two pages each, after one unused page.
fn store(nor: Nor) -> SettingsStore<Nor> {
    SettingsStore::new(nor, PAGE as u32, 2 * PAGE as u32).unwrap()
}

/// A copy written straight from the documented layout (not by the store).
fn write_copy(nor: &mut Nor, slot_at: usize, sequence: u32, payload: &[u8]) {
    let mut body = Vec::new();
    body.extend_from_slice(&sequence.to_le_bytes());
    body.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    body.extend_from_slice(payload);
    // CRC-32/ISO-HDLC bit by bit: reflected 0xEDB88320, all ones in and out.
    let mut crc = !0u32;
    for &b in &body {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    let bytes = &mut nor.bytes[slot_at..];
    bytes[..4].copy_from_slice(b"KRFS");
    bytes[4..12].copy_from_slice(&body[..8]);
    bytes[12..16].copy_from_slice(&(!crc).to_le_bytes());
    bytes[16..16 + payload.len()].copy_from_slice(payload);
}

fn loaded(store: &mut SettingsStore<Nor>) -> (Loaded, Vec<u8>) {
    let mut buf = vec![0u8; store.capacity()];
    let got = store.load(&mut buf).unwrap();
    let len = match got {
        Loaded::Saved { len, .. } | Loaded::FellBack { len, .. } => len,
        Loaded::Defaults(_) => 0,
    };
    buf.truncate(len);
    (got, buf)
}

#[test]
fn copies_written_by_the_layout_load_and_the_newest_wins() {
    let mut nor = Nor::new(5, 1);
    write_copy(&mut nor, PAGE, 7, b"older");
    write_copy(&mut nor, 3 * PAGE, 8, b"newer copy");
    let mut s = store(nor);
    assert_eq!(
        loaded(&mut s),
        (
            Loaded::Saved {
                sequence: 8,
                len: 10
            },
            b"newer copy".to_vec()
        )
    );
    // The store's own save goes over the older one, with the next number.
    assert_eq!(s.save(b"third"), Ok(9));
    assert_eq!(
        loaded(&mut s),
        (
            Loaded::Saved {
                sequence: 9,
                len: 5
            },
            b"third".to_vec()
        )
    );
    let nor = s.into_inner();
    assert_eq!(&nor.bytes[PAGE..PAGE + 4], b"KRFS");
    assert_eq!(
        u32::from_le_bytes(nor.bytes[PAGE + 4..PAGE + 8].try_into().unwrap()),
        9
    );
    assert_eq!(nor.overwrites, 0);
}

#[test]
fn the_sequence_number_rolls_over() {
    let mut nor = Nor::new(5, 2);
    write_copy(&mut nor, PAGE, u32::MAX - 1, b"a");
    write_copy(&mut nor, 3 * PAGE, u32::MAX, b"b");
    let mut s = store(nor);
    assert_eq!(s.save(b"c"), Ok(0));
    assert_eq!(
        loaded(&mut s),
        (
            Loaded::Saved {
                sequence: 0,
                len: 1
            },
            b"c".to_vec()
        )
    );
    assert_eq!(s.save(b"d"), Ok(1));
    assert_eq!(loaded(&mut s).1, b"d");
}

#[test]
fn never_saved_damage_and_sizes_are_told() {
    let mut s = store(Nor::new(5, 3));
    assert_eq!(loaded(&mut s).0, Loaded::Defaults(NoCopy::NeverSaved));
    assert_eq!(s.capacity(), 2 * PAGE - HEADER_BYTES);
    let big = vec![1u8; s.capacity() + 1];
    assert_eq!(s.save(&big), Err(StoreError::TooLarge));
    let full = vec![0x5Au8; s.capacity()];
    assert_eq!(s.save(&full), Ok(1));
    assert_eq!(loaded(&mut s).1, full);
    let mut small = [0u8; 8];
    assert_eq!(s.load(&mut small), Err(StoreError::TooLarge));
    assert_eq!(s.save(b"second"), Ok(2));
    // A bit of the newest copy's payload flips: the copy before it, said so.
    let mut nor = s.into_inner();
    nor.bytes[3 * PAGE + HEADER_BYTES + 2] ^= 0x10;
    let mut s = store(nor);
    assert_eq!(
        loaded(&mut s),
        (
            Loaded::FellBack {
                sequence: 1,
                len: full.len()
            },
            full.clone()
        )
    );
    // Both damaged: the defaults, said so.
    let mut nor = s.into_inner();
    nor.bytes[PAGE + 9] ^= 0x01;
    let mut s = store(nor);
    assert_eq!(loaded(&mut s).0, Loaded::Defaults(NoCopy::Damaged));
    // A save after it goes on from nothing.
    assert_eq!(s.save(b"fresh"), Ok(1));
    assert_eq!(
        loaded(&mut s).0,
        Loaded::FellBack {
            sequence: 1,
            len: 5
        }
    );
}

#[test]
fn slots_off_the_pages_or_beyond_the_flash_are_refused() {
    let layout = |base, slot| SettingsStore::new(Nor::new(4, 4), base, slot).err();
    assert_eq!(layout(0, 2 * PAGE as u32), None);
    assert_eq!(layout(8, PAGE as u32), Some(StoreError::Layout));
    assert_eq!(layout(0, PAGE as u32 + 8), Some(StoreError::Layout));
    assert_eq!(
        layout(2 * PAGE as u32, 2 * PAGE as u32),
        Some(StoreError::Layout)
    );
    assert_eq!(
        layout(u32::MAX - 255, PAGE as u32),
        Some(StoreError::Layout)
    );
}

/// A thousand saves, each cut at a random step (a page erased, a word written) or let
/// run to its end, the machine "reset" after each: every load finds the last complete
/// save, or the one just cut if its header made it, never anything else; a cut save
/// is followed by a good one; no word is ever programmed twice.
#[test]
fn a_thousand_power_cuts_lose_no_settings() {
    let mut nor = Nor::new(5, 0x5EED);
    let mut last_good: Option<(u32, Vec<u8>)> = None;
    let (mut cuts, mut erase_cuts, mut write_cuts, mut fell_back) = (0, 0, 0, 0);
    for trial in 0..1000u64 {
        let len = (nor.next() % 200) as usize;
        let payload: Vec<u8> = (0..len).map(|_| nor.next() as u8).collect();
        // A save of `len` bytes takes 4 erases and ⌈len / 8⌉ + 2 writes: cut within
        // them three times in four.
        let steps = 4 + len.div_ceil(WRITE) + 2;
        let at = (nor.next() % (steps as u64 * 4 / 3 + 1)) as usize;
        nor.steps_left = Some(at);
        nor.cut = None;
        let mut s = store(nor);
        let saved = s.save(&payload);
        nor = s.into_inner();
        nor.steps_left = None;
        nor.off = false;
        match nor.cut {
            Some(Cut::Erase) => erase_cuts += 1,
            Some(Cut::Write) => write_cuts += 1,
            None => {}
        }
        // After the reset.
        let mut s = store(nor);
        let (got, bytes) = loaded(&mut s);
        nor = s.into_inner();
        match saved {
            Ok(sequence) => {
                assert_eq!(got, Loaded::Saved { sequence, len }, "trial {trial}");
                assert_eq!(bytes, payload, "trial {trial}");
                last_good = Some((sequence, payload));
            }
            Err(e) => {
                assert_eq!(
                    e,
                    StoreError::Flash(NorFlashErrorKind::Other),
                    "trial {trial}"
                );
                cuts += 1;
                match (&last_good, got) {
                    (
                        Some((sequence, old)),
                        Loaded::FellBack {
                            sequence: s,
                            len: n,
                        },
                    ) => {
                        assert_eq!((s, n), (*sequence, old.len()), "trial {trial}");
                        assert_eq!(&bytes, old, "trial {trial}");
                        fell_back += 1;
                    }
                    // Cut before it touched a byte of the target slot.
                    (Some((sequence, old)), Loaded::Saved { sequence: s, .. }) => {
                        assert_eq!(s, *sequence, "trial {trial}");
                        assert_eq!(&bytes, old, "trial {trial}");
                    }
                    (None, Loaded::Defaults(_)) => {}
                    (expected, got) => panic!("trial {trial}: {got:?} after {expected:?}"),
                }
            }
        }
    }
    assert_eq!(nor.overwrites, 0);
    std::println!(
        "settings store: 1000 saves, {cuts} cut ({erase_cuts} in an erase, {write_cuts} in a write), {fell_back} loads fell back to the copy before"
    );
    // The cuts fell in both phases of a save, often.
    assert!(
        cuts > 600 && erase_cuts > 80 && write_cuts > 400,
        "{cuts} {erase_cuts} {write_cuts}"
    );
    assert!(fell_back > 500, "{fell_back}");
}
