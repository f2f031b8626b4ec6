//! Settings kept across resets on the board: `kerf::app::settings_store`'s two slots
//! in the last two 2 KiB pages of the G474's flash (the end of bank 2, which the root
//! `memory.x` keeps out of the image), written through embassy's blocking flash driver.
//!
//! Erasing a page stalls every read of its bank for some 20 ms (RM0440, "Flash
//! memory erase"; up to 40 ms in the datasheet), while the control period must run
//! every 100 µs and the watchdog bites after 10 ms. So a save is what a motor
//! controller's save usually is: taken only at rest (the link refuses it while a
//! job runs, [`SettingsPersist::restarts`]), it masks the control interrupts, puts
//! the outputs safe, gives the watchdog 160 ms, writes the copy, and the link
//! task restarts the board once the reply is out ([`restart_due`]). The restart is a
//! plain software reset, which the host is told of as no fault; the settings come
//! back from the copy at power-up.

use super::fault;
use super::period;
use core::sync::atomic::{AtomicBool, Ordering};
use embassy_stm32::flash::{Blocking, Flash};
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::{pac, Peri};
use kerf::app::settings_store::{Loaded, SettingsPersist, SettingsStore};
use static_cell::StaticCell;

/// A flash page in dual-bank mode, bytes (RM0440, "Flash memory organization").
pub const PAGE_BYTES: u32 = 2048;

/// The G474RE's flash, bytes.
const FLASH_BYTES: u32 = 512 * 1024;

/// Where the first slot starts, from the flash's base: the last two pages.
pub const STORE_OFFSET: u32 = FLASH_BYTES - 2 * PAGE_BYTES;

/// The image's store (the link keeps a `'static` reference to it).
pub(super) static STORE: StaticCell<BoardStore> = StaticCell::new();

/// Set by a save: the link task restarts the board after its reply.
static RESTART: AtomicBool = AtomicBool::new(false);

/// The board's settings store.
pub struct BoardStore {
    store: SettingsStore<Flash<'static, Blocking>>,
}

impl BoardStore {
    /// The store over the flash; `None` when the flash is not in dual-bank mode (the
    /// option byte DBANK, set from the factory), whose page layout the slots assume
    /// and embassy's driver requires.
    pub fn new(flash: Peri<'static, FLASH>) -> Option<Self> {
        if !pac::FLASH.optr().read().dbank() {
            return None;
        }
        let flash = Flash::new_blocking(flash);
        SettingsStore::new(flash, STORE_OFFSET, PAGE_BYTES)
            .ok()
            .map(|store| Self { store })
    }
}

impl SettingsPersist for BoardStore {
    fn save(&mut self, payload: &[u8]) -> Option<u32> {
        // The period masked first, so that none runs after the outputs are safe.
        period::halt();
        fault::outputs_safe();
        fault::lengthen_watchdog();
        RESTART.store(true, Ordering::Release);
        self.store.save(payload).ok()
    }

    fn load(&mut self, payload: &mut [u8]) -> Option<Loaded> {
        self.store.load(payload).ok()
    }

    fn restarts(&self) -> bool {
        true
    }
}

/// Whether a save has stopped the control and the board is to restart.
pub fn restart_due() -> bool {
    RESTART.load(Ordering::Acquire)
}
