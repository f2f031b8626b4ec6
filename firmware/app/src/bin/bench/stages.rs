//! Where the slave's contour period goes: its stages measured one by one on the same
//! inputs the period sees. Each measured period's Hall counts and axis states (copied
//! before the period runs) go through the same public kernels the period calls: the
//! three decodes with their velocity observers (`AxisLaw::measure`), the contouring law
//! (`Contouring::joint_acceleration`: FK, Jx, the frame, the law, Jx⁻¹ and J̇x), FK, Jx
//! and J̇x alone (inside the law), and the three DOBs (`AxisLaw::actuate`). The task
//! reference the law is given is the period's effector reference with its velocity,
//! acceleration and jerk by differences over the last periods. What is left of the
//! period is the EFD reference (evaluation with derivatives, arc-length stepping,
//! speed ramp), its joint references (IK, Jx⁻¹ṗ, J̇x) and the supervision.

use core::hint::black_box;
use kerf::app::axis::{AxisLaw, AxisState, HallAxis};
use kerf::control::contouring::{Contouring, TaskReference};
use kerf::kinematics::delta::DeltaGeometry;
use kerf::kinematics::Vector3;
use kerf_app::bench::Counter;

/// Stage names, in the order [`Stages::measure`] times them.
pub const STAGES: [&str; 6] = [
    "three Hall decodes + velocity observers",
    "contouring law (FK, Jx, frame, law, Jx⁻¹, J̇x)",
    "of which FK",
    "of which Jx",
    "of which J̇x",
    "three DOBs",
];

/// Sums of each stage's instructions over the measured periods.
#[derive(Default)]
pub struct Stages {
    pub totals: [f64; 6],
    pub periods: u32,
    /// The last four effector references, newest first.
    history: [[f32; 3]; 4],
    filled: usize,
}

/// Keys of the stage rows (the traced run names its loops by them).
pub fn key(stage: &str) -> heapless::String<96> {
    let mut key = heapless::String::new();
    let _ = core::fmt::write(
        &mut key,
        format_args!("app::delta_slave contour period: {stage}"),
    );
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
        let h = self.history.map(|p| Vector3::new(p[0], p[1], p[2]));
        let task = TaskReference {
            position: h[0],
            velocity: (h[0] - h[1]) / ts,
            acceleration: (h[0] - 2.0 * h[1] + h[2]) / (ts * ts),
            jerk: (h[0] - 3.0 * h[1] + 3.0 * h[2] - h[3]) / (ts * ts * ts),
        };
        let mut states = *axes;
        let mut velocities = [0.0f32; 3];
        let mut counts_in = *counts;
        let decodes = counter.once(&key(STAGES[0]), &mut || {
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
        let law_stage = counter.once(&key(STAGES[1]), &mut || {
            if let Ok(out) = contouring.joint_acceleration(geometry, &task, black_box(&q), &q_dot) {
                acceleration = out.joint_acceleration;
            }
            black_box(&acceleration);
        });
        let p = geometry.forward(&q).unwrap_or(task.position);
        let fk = counter.once(&key(STAGES[2]), &mut || {
            black_box(geometry.forward(black_box(&q)).ok());
        });
        let jx = counter.once(&key(STAGES[3]), &mut || {
            black_box(geometry.jacobian(black_box(&q), &p).ok());
        });
        let jx_dot = counter.once(&key(STAGES[4]), &mut || {
            black_box(geometry.jacobian_derivative(black_box(&q), &p, &q_dot).ok());
        });
        let dobs = counter.once(&key(STAGES[5]), &mut || {
            for k in 0..3 {
                black_box(law.actuate(&mut states[k], acceleration[k], velocities[k]));
            }
        });
        for (total, stage) in self
            .totals
            .iter_mut()
            .zip([decodes, law_stage, fk, jx, jx_dot, dobs])
        {
            *total += stage;
        }
        self.periods += 1;
    }
}
