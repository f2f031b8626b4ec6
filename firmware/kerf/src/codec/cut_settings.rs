//! A laser part's cut settings, carried by version 2 job files of contour kinds (EFD
//! and points) between the header and the body ([`crate::codec::job`]): what a part
//! asks of the machine where its presets will not do. Every field may say "the
//! machine's own", so a file says only what its part needs.
//!
//! The block, 12 bytes, little-endian:
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 4 | speed along the path, m/s, f32 (0: the machine's) |
//! | 4 | 4 | the laser's value, f32: W (power) or J/m (energy per length) |
//! | 8 | 1 | the laser: 0 the machine's, 1 off, 2 constant power, 3 constant energy per length |
//! | 9 | 1 | passes: times a closed contour is cut (0: the machine's, one) |
//! | 10 | 1 | look-ahead: of a program of moves cut as several parts, the last points that are the next part's first, room to stop in (0: none, the part ends at rest) |
//! | 11 | 1 | bit 0: the part continues the one before without a stop (its join); bits 1–7 reserved, 0 |
//!
//! The reader checks the form only (finite numbers, a known laser byte, zero reserved
//! bits, one block for each setting: a zero value where the laser has none, and
//! "the machine's" speed as +0 alone); whether a machine can cut at that speed, power or number of passes is the
//! machine's own check when it loads the part.

/// Bytes of the block.
pub const CUT_SETTINGS_BYTES: usize = 12;

/// What the beam does along a part.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CutLaser {
    /// Off (a dry run along the path).
    Off,
    /// Constant power, W, whatever the speed (grbl's `M3`).
    PowerW(f32),
    /// Constant energy per length, J/m: the power follows the speed (grbl's `M4`,
    /// the same depth through the ramps and corners).
    EnergyJPerM(f32),
}

/// A part's place in a program of moves cut as several parts without a stop: the
/// machine plans each part with room to stop at its end (the look-ahead), and goes on
/// into the next part there when it has it in time.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Continuity {
    /// Of the part's points, the last this many are the next part's first: room to
    /// stop in, not cut (0: the part ends at rest at its last point).
    pub lookahead_points: u8,
    /// Whether the part continues the one before at its join (it then starts moving).
    pub continues: bool,
}

impl Continuity {
    /// A part on its own: it starts and ends at rest.
    pub const NONE: Self = Self {
        lookahead_points: 0,
        continues: false,
    };
}

/// A part's cut settings; `None` where the machine's own apply.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CutSettings {
    /// Speed along the path, m/s.
    pub speed_m_s: Option<f32>,
    /// The beam.
    pub laser: Option<CutLaser>,
    /// Times a closed contour is cut, one after the other without a stop.
    pub passes: Option<u8>,
    /// Its place in a program cut as several parts.
    pub continuity: Continuity,
}

/// Why a settings block does not read.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum BlockError {
    /// A number is NaN or infinite.
    NotFinite,
    /// A laser byte past the last, or reserved bytes that are not zero.
    Unknown,
}

impl CutSettings {
    /// The machine's own settings in every field.
    pub const MACHINE: Self = Self {
        speed_m_s: None,
        laser: None,
        passes: None,
        continuity: Continuity::NONE,
    };

    /// Reads the block at the start of `bytes` (`None`: shorter than a block).
    pub(crate) fn read(bytes: &[u8]) -> Option<Result<Self, BlockError>> {
        let block: &[u8; CUT_SETTINGS_BYTES] = bytes.get(..CUT_SETTINGS_BYTES)?.try_into().ok()?;
        let [s0, s1, s2, s3, v0, v1, v2, v3, laser, passes, lookahead, flags] = *block;
        let speed = f32::from_le_bytes([s0, s1, s2, s3]);
        let value = f32::from_le_bytes([v0, v1, v2, v3]);
        if !speed.is_finite() || !value.is_finite() {
            return Some(Err(BlockError::NotFinite));
        }
        // One block for each setting: "the machine's" is +0 alone, and a laser without
        // a value has a zero one.
        let laser = match (laser, value.to_bits()) {
            (0, 0) => None,
            (1, 0) => Some(CutLaser::Off),
            (2, _) => Some(CutLaser::PowerW(value)),
            (3, _) => Some(CutLaser::EnergyJPerM(value)),
            _ => return Some(Err(BlockError::Unknown)),
        };
        if flags & !1 != 0 || (speed == 0.0 && speed.to_bits() != 0) {
            return Some(Err(BlockError::Unknown));
        }
        Some(Ok(Self {
            speed_m_s: (speed != 0.0).then_some(speed),
            laser,
            passes: (passes != 0).then_some(passes),
            continuity: Continuity {
                lookahead_points: lookahead,
                continues: flags & 1 != 0,
            },
        }))
    }

    /// The block of these settings; `None` where a number is not finite, a speed is
    /// zero (the block's "the machine's") or a pass count is zero.
    pub(crate) fn block(&self) -> Option<[u8; CUT_SETTINGS_BYTES]> {
        let speed = match self.speed_m_s {
            None => 0.0,
            Some(v) if v != 0.0 && v.is_finite() => v,
            Some(_) => return None,
        };
        let (laser, value) = match self.laser {
            None => (0, 0.0),
            Some(CutLaser::Off) => (1, 0.0),
            Some(CutLaser::PowerW(w)) => (2, w),
            Some(CutLaser::EnergyJPerM(e)) => (3, e),
        };
        let passes = match self.passes {
            None => 0,
            Some(0) => return None,
            Some(n) => n,
        };
        if !value.is_finite() {
            return None;
        }
        let [s0, s1, s2, s3] = speed.to_le_bytes();
        let [v0, v1, v2, v3] = value.to_le_bytes();
        let c = self.continuity;
        let flags = u8::from(c.continues);
        Some([
            s0,
            s1,
            s2,
            s3,
            v0,
            v1,
            v2,
            v3,
            laser,
            passes,
            c.lookahead_points,
            flags,
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every setting round-trips through its block, written out by hand from the
    /// table in the module docs.
    #[test]
    fn the_block_is_the_table_of_the_docs() {
        let settings = CutSettings {
            speed_m_s: Some(4e-3),
            laser: Some(CutLaser::EnergyJPerM(1250.0)),
            passes: Some(3),
            continuity: Continuity {
                lookahead_points: 7,
                continues: true,
            },
        };
        let block = settings.block().unwrap();
        let mut by_hand = [0u8; 12];
        by_hand[..4].copy_from_slice(&4e-3f32.to_le_bytes());
        by_hand[4..8].copy_from_slice(&1250.0f32.to_le_bytes());
        by_hand[8] = 3;
        by_hand[9] = 3;
        by_hand[10] = 7;
        by_hand[11] = 1;
        assert_eq!(block, by_hand);
        assert_eq!(CutSettings::read(&block), Some(Ok(settings)));
        assert_eq!(CutSettings::MACHINE.block(), Some([0; 12]));
        assert_eq!(CutSettings::read(&[0; 12]), Some(Ok(CutSettings::MACHINE)));
        for laser in [CutLaser::Off, CutLaser::PowerW(7.5)] {
            let s = CutSettings {
                laser: Some(laser),
                ..CutSettings::MACHINE
            };
            assert_eq!(CutSettings::read(&s.block().unwrap()), Some(Ok(s)));
        }
    }

    /// What the block cannot say is not written, and what is not a block is not read.
    #[test]
    fn bad_blocks_are_refused_each_for_its_reason() {
        let with = |speed, laser, passes| CutSettings {
            speed_m_s: speed,
            laser,
            passes,
            continuity: Continuity::NONE,
        };
        assert_eq!(with(Some(0.0), None, None).block(), None);
        assert_eq!(with(Some(f32::NAN), None, None).block(), None);
        assert_eq!(with(None, None, Some(0)).block(), None);
        let infinite = Some(CutLaser::PowerW(f32::INFINITY));
        assert_eq!(with(None, infinite, None).block(), None);
        let good = with(Some(1e-3), Some(CutLaser::PowerW(2.0)), Some(2))
            .block()
            .unwrap();
        assert_eq!(CutSettings::read(&good[..11]), None);
        let mut bad = good;
        bad[8] = 4;
        assert_eq!(CutSettings::read(&bad), Some(Err(BlockError::Unknown)));
        bad = good;
        bad[11] = 2;
        assert_eq!(CutSettings::read(&bad), Some(Err(BlockError::Unknown)));
        // A value beside the machine's laser or the beam off, and a speed of −0, would
        // be a second block for the same settings.
        for laser in [0, 1] {
            bad = good;
            bad[8] = laser;
            assert_eq!(CutSettings::read(&bad), Some(Err(BlockError::Unknown)));
        }
        bad = good;
        bad[..4].copy_from_slice(&(-0.0f32).to_le_bytes());
        assert_eq!(CutSettings::read(&bad), Some(Err(BlockError::Unknown)));
        bad = good;
        bad[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(CutSettings::read(&bad), Some(Err(BlockError::NotFinite)));
    }
}
