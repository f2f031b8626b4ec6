//! A control period as TIM1 counts it: the timer's counter is 16 bits, so a period
//! longer than 65,536 core cycles (below 2.6 kHz at 170 MHz) needs the prescaler.
//! The period must be a whole number of timer ticks, or the timer's rate would drift
//! from the period the machine's laws were tuned for.

/// TIM1's prescaler and auto-reload for one control period.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimerPeriod {
    /// Core cycles per timer tick (PSC + 1).
    pub cycles_per_tick: u32,
    /// Timer ticks per period (ARR + 1).
    pub ticks: u32,
}

impl TimerPeriod {
    /// The smallest prescale that fits `period_cycles` in 16 bits with an exact
    /// division; `None` when no prescale divides it (a period that is not a whole
    /// number of timer ticks) or the period is 0.
    pub const fn of(period_cycles: u32) -> Option<Self> {
        if period_cycles == 0 {
            return None;
        }
        let mut prescale = period_cycles.div_ceil(1 << 16);
        while prescale <= 1 << 16 {
            if period_cycles % prescale == 0 {
                return Some(Self {
                    cycles_per_tick: prescale,
                    ticks: period_cycles / prescale,
                });
            }
            prescale += 1;
        }
        None
    }

    /// Core cycles per period.
    pub const fn cycles(&self) -> u32 {
        self.cycles_per_tick * self.ticks
    }

    /// PSC register value.
    pub const fn psc(&self) -> u16 {
        (self.cycles_per_tick - 1) as u16
    }

    /// ARR register value.
    pub const fn arr(&self) -> u16 {
        (self.ticks - 1) as u16
    }
}

#[cfg(test)]
mod tests {
    use super::TimerPeriod;

    /// Every image's period at 170 MHz: ticks × prescale gives the period back, the
    /// reload fits 16 bits, and the prescale is the smallest that does.
    #[test]
    fn the_images_periods_fit_exactly() {
        for hz in [10_000u32, 5_000, 1_000, 100] {
            let cycles = 170_000_000 / hz;
            let Some(t) = TimerPeriod::of(cycles) else {
                panic!("{hz} Hz has no exact prescale");
            };
            assert_eq!(t.cycles_per_tick * t.ticks, cycles);
            assert!(t.ticks <= 1 << 16, "{hz} Hz: {} ticks", t.ticks);
            for smaller in 1..t.cycles_per_tick {
                assert!(
                    cycles % smaller != 0 || cycles / smaller > 1 << 16,
                    "{hz} Hz: prescale {smaller} would do"
                );
            }
        }
        // 10 kHz needs no prescale; 1 kHz needs 3 (170,000 = 3 × 56,666.7 is not whole: 4).
        assert_eq!(TimerPeriod::of(17_000).map(|t| t.psc()), Some(0));
        assert_eq!(
            TimerPeriod::of(170_000).map(|t| (t.psc(), t.arr())),
            Some((3, 42_499))
        );
    }

    /// A period of a prime number of cycles beyond 16 bits has no exact prescale.
    #[test]
    fn a_prime_period_is_refused() {
        assert_eq!(TimerPeriod::of(65_537), None);
        assert_eq!(TimerPeriod::of(0), None);
        assert_eq!(TimerPeriod::of(65_536).map(|t| t.psc()), Some(0));
    }
}
