//! The phase-error table: what the linear decoder still gets wrong as a function of
//! phase, subtracted after the atan2, either derived from a self-calibration's channel
//! model or learnt against a reference encoder.

use super::{CalibrationError, HallDecoder};

/// Entries of the phase-error table over one pitch.
pub const CORRECTION_ENTRIES: usize = 256;

/// Phase-error table over one pitch, subtracted from the decoded phase with linear
/// interpolation: the residual that the channel model cannot describe (harmonics that
/// differ between channels, magnet pitch errors), learnt against a reference encoder.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HallCorrection {
    /// Error at phase k/256 pitch in units of 2^-32 pitch.
    pub error_q32: [i32; CORRECTION_ENTRIES],
}

impl HallCorrection {
    /// Corrected phase word.
    #[inline]
    pub fn apply(&self, phase: u32) -> u32 {
        let index = (phase >> 24) as usize;
        let fraction = i64::from(phase & 0x00FF_FFFF);
        let entry = |i: usize| {
            i64::from(
                self.error_q32
                    .get(i % CORRECTION_ENTRIES)
                    .copied()
                    .unwrap_or(0),
            )
        };
        let (here, next) = (entry(index), entry(index + 1));
        let error = here + (((next - here) * fraction) >> 24);
        phase.wrapping_sub(error as i32 as u32)
    }
}

/// Learns a [`HallCorrection`] from pairs of decoded and reference phases.
#[derive(Clone, Debug)]
pub struct CorrectionLearner {
    sum: [i64; CORRECTION_ENTRIES],
    count: [u32; CORRECTION_ENTRIES],
    offset: Option<u32>,
}

impl Default for CorrectionLearner {
    fn default() -> Self {
        Self {
            sum: [0; CORRECTION_ENTRIES],
            count: [0; CORRECTION_ENTRIES],
            offset: None,
        }
    }
}

impl CorrectionLearner {
    /// Adds one sample: the decoder's phase (without correction) and the reference
    /// encoder's position as a phase word (any constant offset between the two is
    /// removed when the table is made).
    pub fn add(&mut self, decoded_phase: u32, reference_phase: u32) {
        // Each sample goes to the nearest table entry (bins centred on the entries).
        let index = (decoded_phase.wrapping_add(1 << 23) >> 24) as usize % CORRECTION_ENTRIES;
        // Differences are taken relative to the first one, so that a constant offset
        // near half a pitch cannot wrap individual samples to the other side.
        let difference = decoded_phase.wrapping_sub(reference_phase);
        let offset = *self.offset.get_or_insert(difference);
        // A full entry stops learning: 2^32 samples of at most 2^31 each still fit the
        // i64 sum, and the mean is long settled.
        if let (Some(sum), Some(count)) = (self.sum.get_mut(index), self.count.get_mut(index)) {
            if *count < u32::MAX {
                *sum += i64::from(difference.wrapping_sub(offset) as i32);
                *count += 1;
            }
        }
    }

    /// Averages each entry and removes the mean (a constant offset is homing's job).
    pub fn finish(&self) -> Result<HallCorrection, CalibrationError> {
        let mut error_q32 = [0i32; CORRECTION_ENTRIES];
        for ((entry, &sum), &count) in error_q32.iter_mut().zip(&self.sum).zip(&self.count) {
            if count == 0 {
                return Err(CalibrationError::NotEnoughMotion);
            }
            *entry = (sum / i64::from(count)) as i32;
        }
        let mean = error_q32.iter().map(|&e| i64::from(e)).sum::<i64>() / CORRECTION_ENTRIES as i64;
        // Phase errors are modulo one pitch (applied with wrapping arithmetic), so the
        // removal of the mean wraps too.
        for e in &mut error_q32 {
            *e = e.wrapping_sub(mean as i32);
        }
        Ok(HallCorrection { error_q32 })
    }
}

impl HallDecoder {
    /// Phase word of a raw sample with the decoder's calibration and no unwrapping,
    /// for learning a correction table (`None` on a fault).
    pub fn raw_phase(&self, raw: [u16; 3]) -> Option<u32> {
        self.phase(&mut [0; 3], raw).ok()
    }
}
