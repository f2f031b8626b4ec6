//! The mps2-an386's UART0 (Arm CMSDK APB UART), polled: the emulated machine's serial
//! port, which QEMU connects to a host socket (`-serial tcp:…`). A board uses its own
//! UART with DMA instead.

/// UART0's base address on the MPS2 boards.
pub const UART0_BASE: usize = 0x4000_4000;

const DATA: usize = 0x000;
const STATE: usize = 0x004;
const CTRL: usize = 0x008;
const BAUDDIV: usize = 0x010;
const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const CTRL_TX_RX_ENABLE: u32 = 0b11;

/// A CMSDK APB UART at a fixed address.
pub struct CmsdkUart {
    base: usize,
}

impl CmsdkUart {
    /// Enables transmit and receive of the UART at `base`.
    ///
    /// # Safety
    ///
    /// `base` must be a CMSDK APB UART that nothing else uses.
    pub unsafe fn new(base: usize) -> Self {
        let uart = Self { base };
        // The smallest divider the UART accepts; the emulated line has no baud rate.
        uart.write_reg(BAUDDIV, 16);
        uart.write_reg(CTRL, CTRL_TX_RX_ENABLE);
        uart
    }

    fn read_reg(&self, offset: usize) -> u32 {
        // SAFETY: a register of the UART `new` was given.
        unsafe { core::ptr::read_volatile((self.base + offset) as *const u32) }
    }

    fn write_reg(&self, offset: usize, value: u32) {
        // SAFETY: as above.
        unsafe { core::ptr::write_volatile((self.base + offset) as *mut u32, value) }
    }

    /// The next received byte, if one is waiting.
    pub fn read(&mut self) -> Option<u8> {
        if self.read_reg(STATE) & STATE_RX_FULL != 0 {
            Some(self.read_reg(DATA) as u8)
        } else {
            None
        }
    }

    /// Sends `bytes`, waiting while the transmitter is full.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            while self.read_reg(STATE) & STATE_TX_FULL != 0 {}
            self.write_reg(DATA, u32::from(b));
        }
    }
}

/// Runs a machine behind the host link on this UART, one control period per turn:
/// the bytes received since the last period go to `period` with a sender of frames,
/// until `period` fails; returns its error. What every QEMU link image does.
pub fn serve_link<E>(
    uart: &mut CmsdkUart,
    mut period: impl FnMut(&[u8], &mut dyn FnMut(&[u8]) -> bool) -> Result<(), E>,
) -> E {
    let mut rx = [0u8; 64];
    loop {
        let mut n = 0;
        while let Some(slot) = rx.get_mut(n) {
            match uart.read() {
                Some(b) => *slot = b,
                None => break,
            }
            n += 1;
        }
        let mut send = |frame: &[u8]| {
            uart.write(frame);
            true
        };
        if let Err(e) = period(rx.get(..n).unwrap_or(&[]), &mut send) {
            return e;
        }
    }
}
