//! The flash of the emulated machines' settings store: a file of the host, read and
//! written through semihosting, in the directory QEMU runs in (the host tool keeps one
//! per machine image, so that settings saved in one command are there in the next,
//! as on a board). Two slots of [`PAGE`] bytes.

use cortex_m_semihosting::{nr, syscall};
use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashErrorKind, ReadNorFlash};
use kerf::app::settings_store::{SettingsPersist, SettingsStore, EMULATED_FILE};

/// An erase page of the file, bytes.
pub const PAGE: usize = 1024;

/// The file: two slots of one page.
const BYTES: usize = 2 * PAGE;

/// The settings file, open.
pub struct SettingsFile {
    handle: usize,
}

impl SettingsFile {
    /// Opens the settings file, making it (erased) when it is not there yet or has
    /// another size; `None` when the host refuses (no semihosting file access).
    pub fn open() -> Option<Self> {
        // The name NUL-terminated, as the host reads it.
        let mut name = [0u8; 32];
        let len = EMULATED_FILE.len();
        name.get_mut(..len)?
            .copy_from_slice(EMULATED_FILE.as_bytes());
        let open = |mode: usize| {
            // SAFETY: the argument block names a NUL-terminated string and its length.
            let handle = unsafe { syscall!(OPEN, name.as_ptr(), mode, len) };
            (handle != usize::MAX).then_some(SettingsFile { handle })
        };
        if let Some(file) = open(nr::open::RW_BINARY) {
            // SAFETY: a handle the host gave.
            if unsafe { syscall!(FLEN, file.handle) } == BYTES {
                return Some(file);
            }
        }
        let mut file = open(nr::open::RW_TRUNC_BINARY)?;
        file.erase(0, BYTES as u32).ok()?;
        Some(file)
    }

    fn seek(&self, offset: u32) -> Result<(), NorFlashErrorKind> {
        // SAFETY: a handle the host gave; 0 is success.
        match unsafe { syscall!(SEEK, self.handle, offset) } {
            0 => Ok(()),
            _ => Err(NorFlashErrorKind::Other),
        }
    }

    fn put(&mut self, offset: u32, bytes: &[u8]) -> Result<(), NorFlashErrorKind> {
        self.seek(offset)?;
        // SAFETY: the block points into `bytes`; the host returns the bytes not written.
        match unsafe { syscall!(WRITE, self.handle, bytes.as_ptr(), bytes.len()) } {
            0 => Ok(()),
            _ => Err(NorFlashErrorKind::Other),
        }
    }
}

impl ErrorType for SettingsFile {
    type Error = NorFlashErrorKind;
}

impl ReadNorFlash for SettingsFile {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        if offset as usize + bytes.len() > BYTES {
            return Err(NorFlashErrorKind::OutOfBounds);
        }
        self.seek(offset)?;
        // SAFETY: the block points into `bytes`; the host returns the bytes not read.
        match unsafe { syscall!(READ, self.handle, bytes.as_mut_ptr(), bytes.len()) } {
            0 => Ok(()),
            _ => Err(NorFlashErrorKind::Other),
        }
    }

    fn capacity(&self) -> usize {
        BYTES
    }
}

impl NorFlash for SettingsFile {
    const WRITE_SIZE: usize = 8;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let erased = [0xFFu8; 64];
        for at in (from..to).step_by(erased.len()) {
            let n = (to - at).min(erased.len() as u32) as usize;
            self.put(at, erased.get(..n).ok_or(NorFlashErrorKind::OutOfBounds)?)?;
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        // As flash programs: a bit goes from 1 to 0 only.
        let mut word = [0u8; 64];
        for (i, part) in bytes.chunks(word.len()).enumerate() {
            let at = offset + (i * word.len()) as u32;
            let old = word
                .get_mut(..part.len())
                .ok_or(NorFlashErrorKind::OutOfBounds)?;
            self.read(at, old)?;
            old.iter_mut().zip(part).for_each(|(o, p)| *o &= *p);
            self.put(at, old)?;
        }
        Ok(())
    }
}

/// The image's settings store on the settings file, for the link's whole life;
/// `None` when the host gives no file (the machine then keeps no settings).
pub fn store() -> Option<&'static mut (dyn SettingsPersist + Send)> {
    let file = SettingsFile::open()?;
    let store = SettingsStore::new(file, 0, PAGE as u32).ok()?;
    let slot = cortex_m::singleton!(: Option<SettingsStore<SettingsFile>> = None)?;
    Some(slot.insert(store))
}
