//! Where the slave's contour period goes: its stages measured one by one on the same
//! inputs the period sees. Each measured period's Hall counts and axis states (copied
//! before the period runs) go through the same public kernels the period calls: the
//! three decodes with their velocity observers (`AxisLaw::measure`), the contouring law
//! (`Contouring::joint_acceleration`: FK, Jx, the frame, the law, then
//! q̈ = Jx⁻¹(ẍ − J̇x q̇)), FK, Jx and that last map alone (inside the law:
//! `DeltaGeometry::joint_acceleration`, J̇x q̇ and Jx⁻¹ applied as vectors), and the
//! three DOBs (`AxisLaw::actuate`). The task
//! reference the law is given is the period's effector reference with its velocity,
//! acceleration and jerk by differences over the last periods. The reference's stages
//! run on an equivalent follower (the same 10-harmonic octagon, speed, ramps and
//! period, started with the measured periods): one arc-length step with the curve's
//! derivatives and the speed ramp, and the joint references of that sample (IK,
//! Jx⁻¹ṗ, Jx⁻¹(p̈ − J̇x q̇) in one pass: `DeltaGeometry::joint_motion`). What is left of
//! the period is the supervision and the period's own bookkeeping.

use core::hint::black_box;
use kerf::app::axis::{AxisLaw, AxisState, HallAxis};
use kerf::control::contouring::{Contouring, TaskReference};
use kerf::kinematics::delta::DeltaGeometry;
use kerf::kinematics::Vector3;
use kerf::machines::delta_slave::product::CUT_MOTION;
use kerf::machines::delta_slave::DeltaSlaveConfig;
use kerf::trajectory::efd::Efd;
use kerf::trajectory::tangential::{ContourFollower, FollowerConfig, SpeedRampConfig};
use kerf_app::bench::Counter;
use kerf_sim::contour::octagon_efd;

/// Stage names, in the order [`Stages::measure`] times them.
pub const STAGES: [&str; 8] = [
    "EFD reference n=10 (derivatives, arc-length step, ramp)",
    "joint references (IK, Jx⁻¹ṗ, Jx⁻¹(p̈ − J̇x q̇) in one pass)",
    "three Hall decodes + velocity observers",
    "contouring law (FK, Jx, frame, law, Jx⁻¹(ẍ − J̇x q̇))",
    "of which FK",
    "of which Jx",
    "of which Jx⁻¹(ẍ − J̇x q̇) (vector forms)",
    "three DOBs",
];

/// Sums of each stage's instructions over the measured periods.
#[derive(Default)]
pub struct Stages {
    pub totals: [f64; 8],
    /// The equivalent follower (built at the first measured period).
    follower: Option<ContourFollower<f32, 30>>,
    pub periods: u32,
    /// The last four effector references, newest first.
    history: [[f32; 3]; 4],
    filled: usize,
}

/// Keys of the stage rows (the traced run names its loops by them).
pub fn key(stage: &str) -> heapless::String<128> {
    let mut key = heapless::String::new();
    // A name cut short would name its row wrongly: stop the run instead.
    if core::fmt::write(
        &mut key,
        format_args!("machines::delta_slave contour period: {stage}"),
    )
    .is_err()
    {
        panic!("stage name too long for its key: {stage}");
    }
    key
}

impl Stages {
    /// Times the stages of one period on `counts` and `axes` (the states before the
    /// period), with `effector_m` the period's effector reference.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    pub fn measure(
        &mut self,
        counter: &mut Counter,
        law: &AxisLaw<f32>,
        sensor: &HallAxis<f32>,
        geometry: &DeltaGeometry<f32>,
        contouring: &Contouring<f32>,
        counts: &[[u16; 3]; 3],
        axes: &[AxisState<f32>; 3],
        effector_m: [f32; 3],
        ts: f32,
    ) {
        self.history.rotate_right(1);
        self.history[0] = effector_m;
        self.filled += 1;
        if self.filled < 4 {
            return;
        }
        if self.follower.is_none() {
            self.follower = follower(ts);
        }
        let h = self.history.map(|p| Vector3::new(p[0], p[1], p[2]));
        let mut sample = None;
        let reference = match self.follower.as_mut() {
            Some(f) => counter.once(&key(STAGES[0]), &mut || {
                sample = black_box(f.step().ok());
            }),
            None => 0.0,
        };
        let planar = |x: f32, y: f32| Vector3::new(x, y, 0.0);
        let centre = h[0];
        let joint_map = match sample {
            Some(r) => counter.once(&key(STAGES[1]), &mut || {
                black_box(
                    geometry
                        .joint_motion(
                            &(centre + black_box(planar(r.position.x, r.position.y))),
                            &planar(r.velocity.x, r.velocity.y),
                            &planar(r.acceleration.x, r.acceleration.y),
                        )
                        .ok(),
                );
            }),
            None => 0.0,
        };
        let task = TaskReference {
            position: h[0],
            velocity: (h[0] - h[1]) / ts,
            acceleration: (h[0] - 2.0 * h[1] + h[2]) / (ts * ts),
            jerk: (h[0] - 3.0 * h[1] + 3.0 * h[2] - h[3]) / (ts * ts * ts),
        };
        let mut states = *axes;
        let mut velocities = [0.0f32; 3];
        let mut counts_in = *counts;
        let decodes = counter.once(&key(STAGES[2]), &mut || {
            let counts = black_box(&mut counts_in);
            for k in 0..3 {
                velocities[k] = law
                    .measure(sensor, &mut states[k], counts[k])
                    .unwrap_or(0.0);
            }
            black_box(&velocities);
        });
        let q = Vector3::from(states.map(|s| s.position_m()));
        let q_dot = Vector3::from(velocities);
        let mut acceleration = Vector3::zeros();
        let law_stage = counter.once(&key(STAGES[3]), &mut || {
            if let Ok(out) = contouring.joint_acceleration(geometry, &task, black_box(&q), &q_dot) {
                acceleration = out.joint_acceleration;
            }
            black_box(&acceleration);
        });
        let p = geometry.forward(&q).unwrap_or(task.position);
        let fk = counter.once(&key(STAGES[4]), &mut || {
            black_box(geometry.forward(black_box(&q)).ok());
        });
        let jx = counter.once(&key(STAGES[5]), &mut || {
            black_box(geometry.jacobian(black_box(&q), &p).ok());
        });
        let jx_dot = counter.once(&key(STAGES[6]), &mut || {
            black_box(
                geometry
                    .joint_acceleration(black_box(&q), &p, &q_dot, &task.acceleration)
                    .ok(),
            );
        });
        let dobs = counter.once(&key(STAGES[7]), &mut || {
            for k in 0..3 {
                black_box(law.actuate(&mut states[k], acceleration[k], velocities[k]));
            }
        });
        for (total, stage) in self.totals.iter_mut().zip([
            reference, joint_map, decodes, law_stage, fk, jx, jx_dot, dobs,
        ]) {
            *total += stage;
        }
        self.periods += 1;
    }
}

/// The period's reference generator, equivalent to the job's (`kerf_sim::contour`'s
/// octagon in 10 harmonics, its speed and ramps, the Keops limits), at period `ts`,
/// started.
fn follower(ts: f32) -> Option<ContourFollower<f32, 30>> {
    let machine = DeltaSlaveConfig::KEOPS;
    let config = FollowerConfig {
        ramp: SpeedRampConfig {
            ts_s: f64::from(ts),
            ..CUT_MOTION
        },
        accel_limit_m_s2: machine.joints.accel_limit_m_s2,
        newton_steps: machine.contour.newton_steps,
    };
    let efd = Efd::from_f64(&octagon_efd(10).ok()?).ok()?;
    let mut f = ContourFollower::for_checked_curve(efd, &config, 0.0).ok()?;
    f.start();
    Some(f)
}
