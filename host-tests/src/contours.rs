//! The cam contour as the Keops slave cuts it in the scenario tests.

use kerf::trajectory::efd::Efd;
use kerf::trajectory::shapes;
use kerf::trajectory::tangential::{
    ContourFollower, ContourReference, FollowerConfig, SpeedRampConfig,
};

/// Cutting plane 55 mm above the base, inside the Keops slave's 26.8–81.4 mm z range.
pub const CUT_Z_M: f64 = 0.055;

/// The 30-harmonic cam contour at 10 mm/s, stepped every `ts_s`: from rest, `cruise_s`
/// along the contour, then a stop back to rest; extended at rest until the number of
/// samples is a multiple of `multiple_of` plus one (so a spline with knots every
/// `multiple_of` samples ends on the last one).
pub fn cam_at_10_mm_s(ts_s: f64, cruise_s: f64, multiple_of: usize) -> Vec<ContourReference<f64>> {
    let efd = Efd::<f64, 30>::from_polygon(&shapes::cam(), 30).expect("cam polygon");
    let ramp = SpeedRampConfig {
        speed_m_s: 0.010,
        accel_m_s2: 0.2,
        jerk_m_s3: 20.0,
        ts_s,
    };
    let config = FollowerConfig {
        ramp,
        accel_limit_m_s2: 1.0,
        newton_steps: 2,
    };
    let mut follower = ContourFollower::new(efd, &config, 0.0).expect("follower config");
    follower.start();
    let mut references: Vec<_> = (0..(cruise_s / ts_s) as usize)
        .map(|_| follower.step().expect("cam step"))
        .collect();
    follower.stop();
    while references.len() % multiple_of.max(1) != 1 % multiple_of.max(1)
        || references.last().is_some_and(|r| r.speed > 0.0)
    {
        references.push(follower.step().expect("cam step"));
    }
    references
}
