//! What to command: control laws, each a config (immutable) plus state.
//!
//! # Signal formats of the axis loop (and of each slave joint)
//!
//! The single axis (Hall decode → velocity observer → PD → DOB, `app::axis`) and each
//! of the Keops slave's three carriages (the same `AxisLaw` on `Joints<T, 3>`) run in
//! any [`Real`](crate::scalar::Real). For FPU-less cores the scalar is
//! [`Q6_25`](crate::scalar::Q6_25): every signal is an `i32` in SI units with 25
//! fraction bits (±64, step 2^-25 ≈ 2.98e-8), every constant factor a
//! [`Gain`](crate::scalar::Gain) (31-bit mantissa, own shift), and only the products
//! widen to 64 bits. The Hall pipeline is integer to the phase accumulator (`i64`, one
//! pitch = 2^32); the position is that accumulator × pitch, one `Gain` product. The
//! physics the ranges come from: travel 0–0.1 m (`JointsConfig::LM1247`; Keops
//! carriages 0–40 mm), job speed ≤ 0.5 m/s and acceleration ≤ 20 m/s² (the machine's
//! limits), the 3.6 N continuous force of the LM1247 on a 71 g nominal mass.
//!
//! | signal | unit | design range (why) | peak in the scenarios | Q6.25 headroom | Q6.25 step |
//! |---|---|---|---|---|---|
//! | position: measured, reference, observer | m | ±0.1 (travel) | 0.0343 | 640× | 3.0e-8 m (1/6 of the 0.18 µm sensor noise) |
//! | velocity: reference, estimate | m/s | ±2 (4× the 0.5 m/s job limit) | 0.148 | 32× | 3.0e-8 m/s |
//! | acceleration: reference, PD command, applied | m/s² | ±50.7 (3.6 N / 71 g: beyond it the force clamps) | 5.02 | 1.26× | 3.0e-8 m/s² |
//! | force command, disturbance estimate | N | ±3.6 (force limit) | 1.36, 1.23 | 17× | 3.0e-8 N |
//! | time within a move, τ, s(τ) | s, 1 | ≤ 0.4 s move, τ ∈ [0, 1] | 0.4 | 160× | 3.0e-8 s |
//! | Hall position before × pitch | pitches | ±5.6 (0.1 m / 18 mm) | 1.67 | 11× | 2^-25 pitch (0.5 nm) |
//!
//! Constant factors (`Gain`, relative step ≤ 2^-30 for 2^-31 … 2^30): Kp 63 165 s⁻²,
//! Kd 502.7 s⁻¹, Ts 1e-4 s, Ts²/2 5e-9 s², observer α 0.5295 and β/Ts 986.4 s⁻¹, An
//! 0.071 kg and 1/An 14.08 kg⁻¹, g·An 66.92 N·s/m, the DOB's k = 1 − e^(−g Ts)
//! 0.0899 and (1 − k)·g·An 60.90 N·s/m, pitch 0.018 m and 1/pitch 55.56 m⁻¹.
//! A factor outside the `Gain` range is refused with `NotRepresentable`.
//!
//! Headroom is the format's ±64 over the design range; the peaks are the largest of
//! the f64, Q31.32 and Q6.25 runs of the tracking profile, with and without a 1 N
//! load step, a hold with that step, and an open wire mid-move.
//!
//! A Keops carriage has the single axis' design ranges: the same law, force limit and
//! speed and acceleration limits, and its 0–40 mm travel inside the ±0.1 m. Its
//! scenarios (one carriage on the simulated axis, `kerf_sim`'s
//! `Scenario::keops_joint`: its share of the slave's mass and a 0.64 N gravity load;
//! tracking, hold and an open wire mid-move) peak at 0.0343 m, 0.141 m/s, 3.00 m/s²,
//! 0.918 N and 0.837 N (force, disturbance estimate), below the column above.
//!
//! Every operation saturates; the acceleration command is the one signal whose design
//! range comes near the format's: past ±64 m/s² it saturates, where the force has
//! already clamped at ±3.6 N (An × 64 = 4.5 N), so saturation never changes a
//! command. Rounding is to nearest; the two roundings of the observer's position
//! update carry their remainder to the next period (`Real::mul_add_carry`), because a
//! constant rounding error δ per period is, to the observer, a velocity of δ/Ts
//! (1.5e-4 m/s for half a step: 1.2 µm of tracking error through Kd/Kp). The host
//! test `fixed_point_signals_stay_in_their_formats` (host-tests `axis_loop`) records
//! every signal's peak over the tracking, load-step, hold and sensor-fault scenarios
//! in Q6_25, for the single axis and one Keops carriage, and checks them against this
//! table and against the f64 run's.
//!
//! [`Q31_32`](crate::scalar::Q31_32) (Q31.32 in 64 bits, ±2.1e9, step 2.3e-10)
//! holds every signal and gain in one format, with at least 2e4 headroom; it stays as
//! the host-side cross-check of fixed point.
//!
//! Not covered in Q6_25: the calibration mode's settle sums (the force summed over
//! the settle periods, then divided) exceed ±64 N·periods; a fixed-point machine is
//! given its decoder as a stored calibration.

pub mod adrc;
pub mod autofocus;
pub mod bilateral;
pub mod constraint;
pub mod contouring;
pub mod delay_observer;
pub mod dob;
pub mod foc;
pub mod hybrid_force;
pub mod identify;
pub mod laser;
pub mod network_observer;
pub mod pd;
pub mod pid;
pub mod preview;
pub mod redundant_pid;
