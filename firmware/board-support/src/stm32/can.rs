//! A CAN FD bus carrying kerf's frames (`kerf::codec::canopen::CanFrame`: 11-bit
//! identifiers, at most 8 bytes, sent as FD frames with bit-rate switch) on one of the
//! G474's FDCANs, read and written by the control interrupt itself, in the FDCAN's
//! message RAM: no waiting, no queue between, no interrupt of the bus's own, and only
//! direct calls (the control interrupt's stack is bounded statically).
//!
//! embassy's configurator sets the bit timing, the FD data phase with transceiver
//! delay compensation, and the global filter (every standard identifier into receive
//! FIFO 0); its driver is then kept but not used, with its interrupts masked. The
//! element layout is [`crate::can_element`]'s.
//!
//! Receive FIFO 0 holds 3 frames: the bus is drained at the period's start and before
//! the step, and a period brings two TPDOs a bus (docs/drives.md). A frame that
//! finds the FIFO full is lost and counted ([`FdBus::dropped`]), as is a frame the
//! transmit queue (3 buffers) cannot take.

use crate::can_element::{received_frame, transmit_element};
use embassy_stm32::can::{self, Can};
use embassy_stm32::interrupt::typelevel::{Binding, Interrupt};
use embassy_stm32::{pac, Peri};
use kerf::codec::canopen::CanFrame;

/// Elements of receive FIFO 0 and of the transmit queue (the G474's fixed layout).
const ELEMENTS: u8 = 3;
/// Words of one element (2 header words, 16 data words).
const ELEMENT_WORDS: usize = 18;

/// One bus, open.
pub struct FdBus {
    _driver: Can<'static>,
    regs: pac::can::Fdcan,
    ram: pac::fdcanram::Fdcanram,
    /// Frames lost: refused by a full transmit queue, lost to a full receive FIFO,
    /// or received and not carried (extended identifiers, remote frames, more than 8
    /// bytes).
    pub dropped: u32,
}

impl FdBus {
    /// FDCAN `peri` (its registers `regs`, its message RAM `ram`) on typed pins at
    /// `nominal_bps`, with an FD data phase at `data_bps` (transceiver delay
    /// compensation on, as above 1 Mbit/s it must be), in normal mode, accepting every
    /// standard identifier.
    pub fn open<T: can::Instance>(
        peri: Peri<'static, T>,
        rx: Peri<'static, impl can::RxPin<T>>,
        tx: Peri<'static, impl can::TxPin<T>>,
        irqs: impl Binding<T::IT0Interrupt, can::IT0InterruptHandler<T>>
            + Binding<T::IT1Interrupt, can::IT1InterruptHandler<T>>
            + 'static,
        (regs, ram): (pac::can::Fdcan, pac::fdcanram::Fdcanram),
        nominal_bps: u32,
        data_bps: u32,
    ) -> Self {
        let mut config = can::CanConfigurator::new(peri, rx, tx, irqs);
        config.set_bitrate(nominal_bps);
        config.set_fd_data_bitrate(data_bps, true);
        let driver = config.into_normal_mode();
        // The control interrupt reads and writes the message RAM; the driver's
        // handlers would race it for the FIFO.
        T::IT0Interrupt::disable();
        T::IT1Interrupt::disable();
        Self {
            _driver: driver,
            regs,
            ram,
            dropped: 0,
        }
    }

    fn count_dropped(&mut self) {
        self.dropped = self.dropped.saturating_add(1);
    }

    /// Queues `frame` for sending; false (and counted) when the transmit queue is
    /// full or the frame cannot be sent.
    pub fn transmit(&mut self, frame: &CanFrame) -> bool {
        let status = self.regs.txfqs().read();
        let put = usize::from(status.tfqpi());
        let words = match transmit_element(frame) {
            Some(words) if !status.tfqf() && put < usize::from(ELEMENTS) => words,
            _ => {
                self.count_dropped();
                return false;
            }
        };
        let base = put * ELEMENT_WORDS;
        for (k, word) in words.into_iter().enumerate() {
            self.ram.txbuf(base + k).write_value(word);
        }
        // Writing 1 adds the request; the other buffers' bits are left as they are.
        // (The register's value written whole: `put` is below 3, checked above.)
        self.regs
            .txbar()
            .write_value(pac::can::regs::Txbar(1 << put));
        true
    }

    /// Hands every received frame to `f`, in order of arrival (at most the FIFO's
    /// three).
    pub fn drain(&mut self, mut f: impl FnMut(&CanFrame)) {
        if self.regs.ir().read().rfl(0) {
            // Receive FIFO 0 was full when a frame came: that frame is lost.
            self.regs.ir().write(|w| w.set_rfl(0, true));
            self.count_dropped();
        }
        for _ in 0..ELEMENTS {
            let status = self.regs.rxfs(0).read();
            let get = status.fgi();
            // The element's first word, one of three (a match, so that every word
            // index below is known to be in the FIFO's range).
            let base = match get {
                0 => 0,
                1 => ELEMENT_WORDS,
                2 => 2 * ELEMENT_WORDS,
                _ => break,
            };
            if status.ffl() == 0 {
                break;
            }
            let words = [
                self.ram.rxfifo0(base).read(),
                self.ram.rxfifo0(base + 1).read(),
                self.ram.rxfifo0(base + 2).read(),
                self.ram.rxfifo0(base + 3).read(),
            ];
            // Acknowledged before it is handed on: the element is free again.
            self.regs.rxfa(0).write(|w| w.set_fai(get));
            match received_frame(&words) {
                Ok(frame) => f(&frame),
                Err(_) => self.count_dropped(),
            }
        }
    }
}
