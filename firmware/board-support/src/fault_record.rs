//! The fault record: four words that survive a reset and say why the board reset.
//!
//! The fault path writes the cause and its detail with a magic word and a check word
//! (`!(magic ^ cause ^ detail)`) into RAM that start-up neither zeroes nor initialises;
//! the next start-up reads it once. A power cycle leaves garbage there, which the magic
//! and check words reject, as they reject a record half written. Which reset happened
//! comes from the reset controller's flags ([`ResetFlags`]): the watchdog's flag wins,
//! a software reset carries the record (or was a plain reset request without one), and
//! the others are a power-on or the reset pin. [`reset_cause`] is that decision.

use kerf::codec::link::{board_fault, BOARD_FAULT};

/// What ended the last run.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Cause {
    /// Power-on or brown-out: nothing went wrong.
    PowerOn = 0,
    /// The reset pin (the probe, the NUCLEO's reset button).
    Pin = 1,
    /// A software reset without a fault record (the probe's reset request, the
    /// restart after a settings save).
    Software = 2,
    /// A HardFault; detail: the stacked program counter's low 16 bits.
    HardFault = board_fault::HARD_FAULT as u8,
    /// A panic; detail: the source line.
    Panic = board_fault::PANIC as u8,
    /// A control period did not finish within its period; detail: its cycles / 16.
    MissedDeadline = board_fault::MISSED_DEADLINE as u8,
    /// The independent watchdog expired (the control interrupt or the link task
    /// stopped running).
    Watchdog = board_fault::WATCHDOG as u8,
    /// The three ADC sequences of a period did not arrive together, or a DMA
    /// transfer error.
    Sampling = board_fault::SAMPLING as u8,
    /// The break input (driver fault, E-stop) switched the outputs off; no reset.
    Break = board_fault::BREAK as u8,
    /// Start-up failed (a peripheral did not come ready); detail: which.
    Startup = board_fault::STARTUP as u8,
}

/// The causes a fault record can hold (the watchdog's is read from the reset flags,
/// and a break does not reset).
const RECORDED: [Cause; 5] = [
    Cause::HardFault,
    Cause::Panic,
    Cause::MissedDeadline,
    Cause::Sampling,
    Cause::Startup,
];

impl Cause {
    /// Whether this cause is a fault the host should hear about.
    pub fn is_fault(self) -> bool {
        !matches!(self, Cause::PowerOn | Cause::Pin | Cause::Software)
    }
}

/// The cause of the last reset and its detail.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ResetCause {
    /// What ended the last run.
    pub cause: Cause,
    /// Its detail (see [`Cause`]).
    pub detail: u32,
}

impl ResetCause {
    /// The host link's fault event code (`BOARD_FAULT | cause`) and detail (its low 16
    /// bits), for a fault; `None` for a clean reset.
    pub fn event(&self) -> Option<(u16, u16)> {
        self.cause
            .is_fault()
            .then_some((BOARD_FAULT | self.cause as u16, self.detail as u16))
    }
}

/// The record as it lies in RAM.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct FaultRecord {
    magic: u32,
    cause: u32,
    detail: u32,
    check: u32,
}

/// "kerf" in ASCII: a record was written by this firmware.
const MAGIC: u32 = 0x6B65_7266;

impl FaultRecord {
    /// No record: what start-up leaves after reading one.
    pub const CLEARED: Self = Self {
        magic: 0,
        cause: 0,
        detail: 0,
        check: 0,
    };

    /// The record of `cause` with `detail`.
    pub const fn new(cause: Cause, detail: u32) -> Self {
        let cause = cause as u32;
        Self {
            magic: MAGIC,
            cause,
            detail,
            check: !(MAGIC ^ cause ^ detail),
        }
    }

    /// The record as four words, as found in RAM after a reset.
    pub const fn from_words(words: [u32; 4]) -> Self {
        let [magic, cause, detail, check] = words;
        Self {
            magic,
            cause,
            detail,
            check,
        }
    }

    /// The recorded cause and detail, if the record is whole and holds a cause a
    /// record can hold.
    pub fn read(&self) -> Option<(Cause, u32)> {
        let whole = self.magic == MAGIC && self.check == !(self.magic ^ self.cause ^ self.detail);
        let cause = RECORDED.into_iter().find(|c| *c as u32 == self.cause)?;
        whole.then_some((cause, self.detail))
    }
}

/// The reset controller's flags of the last reset (RM0440, RCC_CSR).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct ResetFlags {
    /// The independent watchdog (IWDGRSTF).
    pub watchdog: bool,
    /// A software reset (SFTRSTF): the fault path's, or the probe's request.
    pub software: bool,
    /// A brown-out (BORRSTF), set with every power-on.
    pub brown_out: bool,
    /// The reset pin (PINRSTF), set with every reset of any kind.
    pub pin: bool,
}

/// What ended the last run, from the reset flags and the fault record found in RAM.
/// The pin flag is set by every reset, so it is looked at last.
pub fn reset_cause(flags: ResetFlags, record: &FaultRecord) -> ResetCause {
    let (cause, detail) = if flags.watchdog {
        (Cause::Watchdog, 0)
    } else if flags.software {
        record.read().unwrap_or((Cause::Software, 0))
    } else if flags.brown_out {
        (Cause::PowerOn, 0)
    } else if flags.pin {
        (Cause::Pin, 0)
    } else {
        (Cause::PowerOn, 0)
    };
    ResetCause { cause, detail }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SOFTWARE: ResetFlags = ResetFlags {
        watchdog: false,
        software: true,
        brown_out: false,
        pin: true,
    };

    /// Every recordable cause comes back with its detail after a software reset and
    /// reaches the host as `0xB000 | code` with the detail's low 16 bits.
    #[test]
    fn a_recorded_fault_survives_the_reset() {
        for (cause, code) in [
            (Cause::HardFault, 3),
            (Cause::Panic, 4),
            (Cause::MissedDeadline, 5),
            (Cause::Sampling, 7),
            (Cause::Startup, 9),
        ] {
            let record = FaultRecord::new(cause, 0x1_2345);
            let found = reset_cause(SOFTWARE, &record);
            assert_eq!(
                found,
                ResetCause {
                    cause,
                    detail: 0x1_2345
                }
            );
            assert_eq!(found.event(), Some((0xB000 + code, 0x2345)));
            assert!(board_fault::reason(0xB000 + code).is_some());
        }
    }

    /// A record with any one bit flipped is not read (the check word covers magic,
    /// cause and detail; a flipped check bit fails the comparison): a half-written
    /// record or a power-on's garbage is a plain software reset, not an invented fault.
    #[test]
    fn a_damaged_record_is_not_read() {
        let record = FaultRecord::new(Cause::Panic, 812);
        let words = [record.magic, record.cause, record.detail, record.check];
        for word in 0..4 {
            for bit in 0..32 {
                let mut damaged = words;
                damaged[word] ^= 1 << bit;
                let found = reset_cause(SOFTWARE, &FaultRecord::from_words(damaged));
                assert_eq!(found.cause, Cause::Software, "word {word} bit {bit}");
                assert_eq!(found.event(), None);
            }
        }
        assert_eq!(FaultRecord::CLEARED.read(), None);
        // Whole, but of a cause no fault path records (the watchdog's, a break's).
        for cause in [Cause::Watchdog, Cause::Break, Cause::PowerOn] {
            assert_eq!(FaultRecord::new(cause, 1).read(), None, "{cause:?}");
        }
    }

    /// The watchdog's flag wins over a record; without the software flag a record is
    /// stale and ignored; the pin flag alone is the pin; no flag at all is a power-on.
    #[test]
    fn the_flags_decide_which_reset_it_was() {
        let record = FaultRecord::new(Cause::HardFault, 7);
        let watchdog = ResetFlags {
            watchdog: true,
            ..SOFTWARE
        };
        assert_eq!(reset_cause(watchdog, &record).cause, Cause::Watchdog);
        assert_eq!(reset_cause(watchdog, &record).event(), Some((0xB006, 0)));
        let power_on = ResetFlags {
            brown_out: true,
            pin: true,
            ..ResetFlags::default()
        };
        assert_eq!(reset_cause(power_on, &record).cause, Cause::PowerOn);
        let pin = ResetFlags {
            pin: true,
            ..ResetFlags::default()
        };
        assert_eq!(reset_cause(pin, &record).cause, Cause::Pin);
        assert_eq!(reset_cause(pin, &record).event(), None);
        assert_eq!(
            reset_cause(ResetFlags::default(), &record).cause,
            Cause::PowerOn
        );
    }
}
