//! Settings that stay across resets: the bytes of a machine's settings kept in two
//! slots of flash, so that a power cut in the middle of a save never loses both the
//! old copy and the new one.
//!
//! The store is written only when the operator saves (from the slower context that
//! answers the link, never from the control period: erasing a page of the G474 stalls
//! reads of its bank for some 20 ms). It works on any NOR flash through the
//! `embedded-storage` traits, which the board's HAL implements and the tests simulate.
//!
//! # A slot
//!
//! Each slot is one or more erase pages. A saved copy:
//!
//! | offset | size | field |
//! |-------:|-----:|-------|
//! | 0 | 4 | magic `KRFS` |
//! | 4 | 4 | sequence number (LE), one more than the copy it follows (wrapping) |
//! | 8 | 4 | payload bytes `n` (LE) |
//! | 12 | 4 | CRC-32 (ISO-HDLC) of bytes 4..12 and the payload |
//! | 16 | n | payload, padded with `0xFF` to the flash's write size |
//!
//! A slot is *good* when its magic, length and CRC hold, *blank* when every byte of
//! it reads erased (`0xFF`), and *damaged* otherwise.
//!
//! # Saving
//!
//! A save goes to the slot that does not hold the newest good copy: it is erased, the
//! payload written, and the header last. Until the header is written the slot is not
//! good, and the other slot, untouched, still holds the copy before. A cut during the
//! erase or a write leaves the slot damaged (partly erased, partly written), which
//! the CRC tells apart from a good copy (a false match has a chance of 2⁻³²).
//!
//! # Loading
//!
//! The newest good copy (the larger sequence number, compared with wrapping so that
//! the count may roll over) is loaded, and [`Loaded`] says what was found: the copy
//! last saved; a copy with the other slot damaged (a save was cut short, or the
//! flash decayed): the one before it; or no good copy at all, when the machine runs
//! on its defaults, never saved or with both copies damaged.

use crate::codec::link::CRC32;
use embedded_storage::nor_flash::NorFlash;

/// The file an emulated machine (a QEMU link image) keeps its store in, in the folder
/// QEMU runs in, where the host tool looks for it.
pub const EMULATED_FILE: &str = "kerf-settings.bin";

/// Marks a saved copy.
const MAGIC: [u8; 4] = *b"KRFS";

/// Bytes of a copy's header.
pub const HEADER_BYTES: usize = 16;

/// Bytes read or written at a time (a multiple of every write size the store takes).
const CHUNK: usize = 64;

/// What the store found at load.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Loaded {
    /// The copy last saved, `len` bytes (the other slot blank or an older good copy).
    Saved {
        /// Its sequence number.
        sequence: u32,
        /// Payload bytes.
        len: usize,
    },
    /// The only good copy, the other slot damaged: a save was cut short (or the flash
    /// decayed), so this is the copy before it.
    FellBack {
        /// Its sequence number.
        sequence: u32,
        /// Payload bytes.
        len: usize,
    },
    /// Nothing to load: the machine keeps its defaults.
    Defaults(NoCopy),
}

/// Why there was no good copy.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NoCopy {
    /// Both slots blank: never saved.
    NeverSaved,
    /// A slot is damaged and neither is good.
    Damaged,
}

/// Why the store failed.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoreError<E> {
    /// The slots do not fit the flash: not on erase pages, overlapping, beyond its
    /// capacity, or read and write sizes the store cannot align to (powers of two up
    /// to its 16-byte header).
    Layout,
    /// The payload does not fit a slot (saving), or the caller's buffer (loading).
    TooLarge,
    /// The flash itself refused an operation.
    Flash(E),
}

/// How a slot reads.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum Slot {
    Good { sequence: u32, len: usize },
    Blank,
    Damaged,
}

/// Both slots as read, and which holds the newest good copy.
struct Scanned {
    slots: [Slot; 2],
    newest: Option<usize>,
}

/// Two slots of `flash`, at `base` and `base + slot_bytes`, each `slot_bytes` long.
#[derive(Debug)]
pub struct SettingsStore<F> {
    flash: F,
    base: u32,
    slot_bytes: u32,
}

impl<F: NorFlash> SettingsStore<F> {
    /// The store over `flash`.
    ///
    /// Errors: [`StoreError::Layout`] (see there).
    pub fn new(flash: F, base: u32, slot_bytes: u32) -> Result<Self, StoreError<F::Error>> {
        let page = F::ERASE_SIZE as u32;
        let write = F::WRITE_SIZE;
        let end = slot_bytes.checked_mul(2).and_then(|b| b.checked_add(base));
        let fits = end.is_some_and(|end| end as usize <= flash.capacity());
        let aligned = page > 0 && base % page == 0 && slot_bytes % page == 0;
        // The header is one write, each chunk starts on it: both sizes divide it.
        let read = F::READ_SIZE;
        let writable = write.is_power_of_two()
            && write <= HEADER_BYTES
            && read.is_power_of_two()
            && read <= HEADER_BYTES;
        if !(fits && aligned && writable && slot_bytes as usize > HEADER_BYTES) {
            return Err(StoreError::Layout);
        }
        Ok(Self {
            flash,
            base,
            slot_bytes,
        })
    }

    /// The largest payload a slot holds, bytes.
    pub fn capacity(&self) -> usize {
        self.slot_bytes as usize - HEADER_BYTES
    }

    /// The flash back.
    pub fn into_inner(self) -> F {
        self.flash
    }

    fn slot_offset(&self, k: usize) -> u32 {
        self.base + self.slot_bytes * k as u32
    }

    /// Reads slot `k` from `from` (bytes into the slot) into `out`, a chunk at a time
    /// (each read a multiple of the read size: the slot, pages long, holds it).
    fn read_into(
        &mut self,
        k: usize,
        from: usize,
        out: &mut [u8],
    ) -> Result<(), StoreError<F::Error>> {
        let start = self.slot_offset(k) + from as u32;
        let mut chunk = [0u8; CHUNK];
        for (i, part) in out.chunks_mut(CHUNK).enumerate() {
            let n = part.len().next_multiple_of(F::READ_SIZE).min(CHUNK);
            let read = chunk.get_mut(..n).ok_or(StoreError::Layout)?;
            self.flash
                .read(start + (i * CHUNK) as u32, read)
                .map_err(StoreError::Flash)?;
            part.iter_mut().zip(&chunk).for_each(|(p, c)| *p = *c);
        }
        Ok(())
    }

    /// Classifies slot `k`; with `payload`, a good copy's payload is read into it.
    fn scan(&mut self, k: usize, payload: Option<&mut [u8]>) -> Result<Slot, StoreError<F::Error>> {
        let mut header = [0u8; HEADER_BYTES];
        self.read_into(k, 0, &mut header)?;
        let [m0, m1, m2, m3, s0, s1, s2, s3, l0, l1, l2, l3, c0, c1, c2, c3] = header;
        let (sequence, len) = ([s0, s1, s2, s3], [l0, l1, l2, l3]);
        let n = u32::from_le_bytes(len) as usize;
        if [m0, m1, m2, m3] == MAGIC && n <= self.capacity() {
            let mut digest = CRC32.digest();
            digest.update(&sequence);
            digest.update(&len);
            let mut chunk = [0u8; CHUNK];
            let mut at = 0;
            while at < n {
                let part = chunk
                    .get_mut(..(n - at).min(CHUNK))
                    .ok_or(StoreError::Layout)?;
                self.read_into(k, HEADER_BYTES + at, part)?;
                digest.update(part);
                at += part.len();
            }
            if digest.finalize() == u32::from_le_bytes([c0, c1, c2, c3]) {
                if let Some(out) = payload {
                    let out = out.get_mut(..n).ok_or(StoreError::TooLarge)?;
                    self.read_into(k, HEADER_BYTES, out)?;
                }
                return Ok(Slot::Good {
                    sequence: u32::from_le_bytes(sequence),
                    len: n,
                });
            }
        }
        // Blank only if every byte reads erased.
        let mut chunk = [0u8; CHUNK];
        let mut at = 0;
        while at < self.slot_bytes as usize {
            let part = chunk
                .get_mut(..(self.slot_bytes as usize - at).min(CHUNK))
                .ok_or(StoreError::Layout)?;
            self.read_into(k, at, part)?;
            if part.iter().any(|&b| b != 0xFF) {
                return Ok(Slot::Damaged);
            }
            at += part.len();
        }
        Ok(Slot::Blank)
    }

    /// Both slots, and which of them holds the newest good copy.
    fn newest(&mut self) -> Result<Scanned, StoreError<F::Error>> {
        let slots = [self.scan(0, None)?, self.scan(1, None)?];
        let newest = match slots {
            [Slot::Good { sequence: a, .. }, Slot::Good { sequence: b, .. }] => {
                // Wrapping order: b is newer when it is less than half the count ahead.
                Some(usize::from((b.wrapping_sub(a) as i32) > 0))
            }
            [Slot::Good { .. }, _] => Some(0),
            [_, Slot::Good { .. }] => Some(1),
            _ => None,
        };
        Ok(Scanned { slots, newest })
    }

    /// Loads the newest good copy into `payload` (module docs).
    ///
    /// Errors: the copy is longer than `payload`; the flash.
    pub fn load(&mut self, payload: &mut [u8]) -> Result<Loaded, StoreError<F::Error>> {
        let Scanned { slots, newest } = self.newest()?;
        let Some(k) = newest else {
            return Ok(Loaded::Defaults(if slots == [Slot::Blank; 2] {
                NoCopy::NeverSaved
            } else {
                NoCopy::Damaged
            }));
        };
        let Slot::Good { sequence, len } = self.scan(k, Some(payload))? else {
            // The slot read good a moment ago: the flash changed under the store.
            return Ok(Loaded::Defaults(NoCopy::Damaged));
        };
        let other = slots.get(usize::from(k == 0));
        Ok(if other == Some(&Slot::Damaged) {
            Loaded::FellBack { sequence, len }
        } else {
            Loaded::Saved { sequence, len }
        })
    }

    /// Saves `payload` as the newest copy, in the slot that does not hold the newest
    /// good one (module docs); its sequence number.
    ///
    /// Errors: the payload is larger than [`SettingsStore::capacity`]; the flash.
    pub fn save(&mut self, payload: &[u8]) -> Result<u32, StoreError<F::Error>> {
        let len = u32::try_from(payload.len()).map_err(|_| StoreError::TooLarge)?;
        if payload.len() > self.capacity() {
            return Err(StoreError::TooLarge);
        }
        let Scanned { slots, newest } = self.newest()?;
        let (target, sequence) = match newest.and_then(|k| Some((k, *slots.get(k)?))) {
            Some((k, Slot::Good { sequence, .. })) => {
                (usize::from(k == 0), sequence.wrapping_add(1))
            }
            _ => (0, 1),
        };
        let start = self.slot_offset(target);
        self.flash
            .erase(start, start + self.slot_bytes)
            .map_err(StoreError::Flash)?;
        // The payload in chunks, the last padded with erased bytes to the write size.
        for (i, part) in payload.chunks(CHUNK).enumerate() {
            let mut chunk = [0xFFu8; CHUNK];
            chunk.iter_mut().zip(part).for_each(|(c, p)| *c = *p);
            let padded = part.len().next_multiple_of(F::WRITE_SIZE);
            let at = start + (HEADER_BYTES + i * CHUNK) as u32;
            let bytes = chunk.get(..padded).ok_or(StoreError::Layout)?;
            self.flash.write(at, bytes).map_err(StoreError::Flash)?;
        }
        let [s0, s1, s2, s3] = sequence.to_le_bytes();
        let [l0, l1, l2, l3] = len.to_le_bytes();
        let mut digest = CRC32.digest();
        digest.update(&[s0, s1, s2, s3, l0, l1, l2, l3]);
        digest.update(payload);
        let [c0, c1, c2, c3] = digest.finalize().to_le_bytes();
        let [m0, m1, m2, m3] = MAGIC;
        let header = [
            m0, m1, m2, m3, s0, s1, s2, s3, l0, l1, l2, l3, c0, c1, c2, c3,
        ];
        self.flash
            .write(start, &header)
            .map_err(StoreError::Flash)?;
        Ok(sequence)
    }
}

/// A store of settings bytes as the host link holds it: any flash's
/// [`SettingsStore`], behind one object-safe face.
pub trait SettingsPersist {
    /// [`SettingsStore::save`]; the sequence number, or that it failed.
    fn save(&mut self, payload: &[u8]) -> Option<u32>;
    /// [`SettingsStore::load`]; `None` when the flash failed or the copy does not fit
    /// `payload`.
    fn load(&mut self, payload: &mut [u8]) -> Option<Loaded>;
    /// Whether a save stops the machine's control and restarts it, as on a board,
    /// whose flash stalls every read of its bank while a page is erased (some 20 ms,
    /// two control periods' worth of the watchdog): the link then takes a save only
    /// while the machine is at rest. An emulated machine's store does not.
    fn restarts(&self) -> bool {
        false
    }
}

impl<F: NorFlash> SettingsPersist for SettingsStore<F> {
    fn save(&mut self, payload: &[u8]) -> Option<u32> {
        SettingsStore::save(self, payload).ok()
    }

    fn load(&mut self, payload: &mut [u8]) -> Option<Loaded> {
        SettingsStore::load(self, payload).ok()
    }
}

/// Flash in RAM, `N` bytes in pages of [`RamFlash::PAGE`]: a simulated machine's
/// store. It behaves as NOR flash does where the store relies on it: erased to `0xFF`,
/// programmed a bit at a time towards 0.
#[derive(Clone, Debug)]
pub struct RamFlash<const N: usize> {
    bytes: [u8; N],
}

impl<const N: usize> RamFlash<N> {
    /// Bytes of a page.
    pub const PAGE: usize = 256;

    /// All of it erased.
    pub fn erased() -> Self {
        Self { bytes: [0xFF; N] }
    }
}

impl<const N: usize> embedded_storage::nor_flash::ErrorType for RamFlash<N> {
    type Error = embedded_storage::nor_flash::NorFlashErrorKind;
}

impl<const N: usize> embedded_storage::nor_flash::ReadNorFlash for RamFlash<N> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let at = offset as usize;
        let from = self
            .bytes
            .get(at..at.saturating_add(bytes.len()))
            .ok_or(Self::Error::OutOfBounds)?;
        bytes.copy_from_slice(from);
        Ok(())
    }

    fn capacity(&self) -> usize {
        N
    }
}

impl<const N: usize> NorFlash for RamFlash<N> {
    const WRITE_SIZE: usize = 8;
    const ERASE_SIZE: usize = Self::PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let pages = self
            .bytes
            .get_mut(from as usize..to as usize)
            .ok_or(Self::Error::OutOfBounds)?;
        pages.fill(0xFF);
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let at = offset as usize;
        let to = self
            .bytes
            .get_mut(at..at.saturating_add(bytes.len()))
            .ok_or(Self::Error::OutOfBounds)?;
        to.iter_mut().zip(bytes).for_each(|(b, &new)| *b &= new);
        Ok(())
    }
}

#[cfg(test)]
mod tests;
