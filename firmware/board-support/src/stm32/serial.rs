//! A device on a serial line, exchanged with by polling: the request written whole,
//! the reply read until its framing says it is whole ([`ReplyEnd`]) or the line has
//! been silent for the timeout. For the slower tasks that talk to a cell's devices
//! (`kerf::hal::Transact`); never called from the control period.

use super::clocks::SYSCLK_HZ;
use super::timing;
use crate::reply_framing::ReplyEnd;
use embassy_stm32::mode::Blocking;
use embassy_stm32::usart::Uart;
use embedded_hal_nb::serial::Read;
use kerf::hal::{LinkError, Transact};

/// A polled serial port to one device.
pub struct PolledPort {
    uart: Uart<'static, Blocking>,
    end: ReplyEnd,
    /// Longest silence before or within a reply, core cycles.
    timeout_cycles: u32,
}

impl PolledPort {
    /// `uart` (built from typed pins by the image), replies framed by `end`, a device
    /// silent for `timeout_ms` gives up the exchange (at most 25 s).
    pub fn new(uart: Uart<'static, Blocking>, end: ReplyEnd, timeout_ms: u32) -> Self {
        Self {
            uart,
            end,
            timeout_cycles: timeout_ms.saturating_mul(SYSCLK_HZ / 1000),
        }
    }
}

impl Transact for PolledPort {
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError> {
        // Bytes left from an earlier, timed-out reply are not this one's.
        while self.uart.read().is_ok() {}
        self.uart
            .blocking_write(request)
            .map_err(|_| LinkError::Down)?;
        if reply.is_empty() {
            return Ok(0);
        }
        let capacity = reply.len();
        let mut n = 0;
        let mut last = timing::cycles();
        while timing::cycles().wrapping_sub(last) < self.timeout_cycles {
            match self.uart.read() {
                Ok(byte) => {
                    let Some(slot) = reply.get_mut(n) else {
                        return Err(LinkError::Overrun);
                    };
                    *slot = byte;
                    n += 1;
                    last = timing::cycles();
                    if self.end.complete(reply.get(..n).unwrap_or(&[]), capacity) {
                        return Ok(n);
                    }
                }
                Err(nb::Error::WouldBlock) => {}
                // A framing or noise error: the reply is corrupt; what came is
                // returned, and the device link's checks refuse it.
                Err(nb::Error::Other(_)) => return Ok(n),
            }
        }
        Ok(n)
    }
}
