//! Self-optimizing autofocus (docs/control.md §24, T 7.2.2 eq. 156–161).
//!
//! The focus motor's position q is driven to the maximum of the image sharpness S(q)
//! ([`sensing::sharpness`](crate::sensing::sharpness)), which is unimodal in q at
//! every magnification (T fig. 7.12) but whose peak position moves with the zoom and
//! whose level depends on the scene (T fig. 7.14). The law minimizes f = −S:
//!
//! - gradient g of f with respect to q, estimated over a window of the latest
//!   frames (eq. 157, see below);
//! - velocity reference q̇ref = μ0 (1 − 2/(1 + e^(−α g))) (eq. 158): a sigmoid
//!   boundary layer of amplitude μ0 that moves against the gradient and vanishes
//!   only where g = 0;
//! - acceleration-level tracking (eq. 159–161): with ε = q̇ref − q̇ and ε̇ + C ε = 0,
//!   q̈des = q̈ref + C (q̇ref − q̇), for an axis that follows acceleration commands
//!   (the DOB loop of T 4.1.2).
//!
//! # Gradient estimate
//!
//! Eq. 157 takes the difference of f over a window of width δ in q, "selected based
//! on the structure of existing noise". Here the window is the shortest run of the
//! latest frames (at least `min_window_frames`, at most the state's capacity N) whose
//! positions span δ (max − min ≥ δ), and g is the least-squares slope of f against q
//! over that run: Σ (q − q̄)(f − f̄) / Σ (q − q̄)². Compared with the two-point
//! difference, the slope uses every frame in the window (for independent frame noise
//! of standard deviation σ it is the minimum-variance unbiased linear estimate, with
//! variance σ²/Σ (q − q̄)² against 2σ²/δ² for two frames δ apart), and it is exact for
//! a locally quadratic S at the window's centroid. Defining the window by its extent
//! in q rather than by a frame count keeps the estimate's lag near δ/2 in position
//! at any speed: at speed the window is a few frames, near rest it grows to N.
//! Once N frames no longer span δ (the axis has nearly stopped), the gradient is not
//! observable: motion is what excites it (T 8.5: "when there is no excitation in the
//! system, it does not start working").
//!
//! Choosing δ: with a relative frame-to-frame scatter σ of the sharpness, a window
//! of k frames spread evenly over δ gives the slope to σ √(12/k)/δ (relative), which
//! should stay well below the relative gradient on the flanks of S(q) for the
//! fewest frames allowed (`min_window_frames`), as at full speed; the focus found
//! scatters by about that noise over the relative curvature of S at its peak.
//!
//! With [`GradientScale::Relative`], g is divided by the window's mean sharpness:
//! the gradient of −ln S, which has the same zero and sign but no longer scales with
//! the scene's contrast or the magnification's peak sharpness (T fig. 7.14), so one α
//! serves every scene. [`GradientScale::Absolute`] is eq. 157 as printed.
//!
//! # Search, track, hold
//!
//! Eq. 158 needs motion to see a gradient, so the law runs in three modes
//! ([`AutofocusMode`]):
//! - `Search`: from rest (a cold start, or a changed scene), move at the search
//!   speed toward the farther end of the travel (reversing at a travel limit) until
//!   the window spans δ;
//! - `Track`: eq. 158 on the window's gradient;
//! - `Hold`: once the window no longer spans δ (the sigmoid has brought the axis
//!   nearly to rest at the peak), stop, and keep watching the mean sharpness of the
//!   latest `min_window_frames` frames; a relative change beyond `refocus_change` (a
//!   zoom change, a new part under the camera: up or down, as a zoom-in can raise
//!   the sharpness while defocusing) starts a new search.
//!
//! # Timing
//!
//! [`Autofocus::frame`] runs once per camera frame (position at exposure and the
//! frame's sharpness) and sets the velocity target; [`Autofocus::step`] runs every
//! control period and ramps q̇ref linearly to the target over one frame period, so
//! q̈ref is that ramp's slope (bounded by the speed change per frame over the frame
//! period) and the command has no steps at frame rate.
//!
//! Limits: |q̇ref| ≤ μ0, |q̈des| ≤ `max_acceleration_m_s2`, and a reference velocity
//! pointing out of the travel is zero beyond its limits (the axis then overshoots a
//! limit by about q̇/C). The exponential is `libm::exp` in `f64`, within 1 ulp
//! (musl's implementation), once per frame.
//!
//! Bad input: a NaN or infinite position, velocity or sharpness, or a sharpness below
//! `min_sharpness` (a textureless or dark scene, whose gradient is only noise), is a
//! typed error ([`AutofocusError`]); the velocity reference is then set to zero, the
//! window emptied and the search restarted with the next valid frame, and `step`
//! returns the error for the caller to apply zero acceleration. No NaN comes out.

use crate::error::{coefficient, in_range, positive, representable, ConfigError};
use crate::scalar::{lit, to_f64, Float};

/// How the sharpness gradient enters the sigmoid.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum GradientScale {
    /// g = d(−S)/dq (eq. 157 as printed): α in m per grey level.
    Absolute,
    /// g = d(−S)/dq / S̄ = d(−ln S)/dq: α in m, independent of the scene's contrast.
    Relative,
}

/// Autofocus settings, SI units (positions and speeds of the focus axis).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AutofocusConfig {
    /// μ0 of eq. 158: the largest reference speed, m/s.
    pub max_speed_m_s: f64,
    /// α of eq. 158 (the boundary layer's steepness): m per unit of g (see
    /// [`GradientScale`]).
    pub sigmoid_gain: f64,
    /// What g is.
    pub gradient_scale: GradientScale,
    /// C of eq. 160–161, 1/s (velocity tracking time constant 1/C; C·Ts ≤ 1).
    pub tracking_gain_per_s: f64,
    /// |q̈des| limit, m/s².
    pub max_acceleration_m_s2: f64,
    /// Soft travel limits [min, max], m: no reference velocity out of them.
    pub travel_m: [f64; 2],
    /// Camera frame period, s (at least the control period).
    pub frame_period_s: f64,
    /// δ of eq. 157: the extent in q the gradient window must span, m.
    pub window_excursion_m: f64,
    /// Fewest frames in the gradient window (≥ 3), and the frames averaged by the
    /// hold mode's change watch.
    pub min_window_frames: usize,
    /// Speed of the search from rest, m/s (≤ μ0).
    pub search_speed_m_s: f64,
    /// Relative change of the mean sharpness, in hold, that starts a new search
    /// (0 < r < 1).
    pub refocus_change: f64,
    /// Smallest sharpness that counts as a textured scene, grey levels.
    pub min_sharpness: f64,
}

impl AutofocusConfig {
    /// A focus axis of 10 mm travel (0.2–9.8 mm usable) under a 100 frame/s camera,
    /// the simulated microscope of `hal_mock::focus` (T fig. 7.12: unimodal sharpness
    /// per magnification, depth of field ±0.4 mm at m = 1):
    /// - μ0 = 5 mm/s, α = 4 mm on the relative gradient (the gradient of −ln S): over
    ///   most of the travel the relative gradient is 300–1200 m⁻¹ (α g/2 = 0.6–2.4, so
    ///   55–98 % of μ0); near the peak the law is linear with a rate μ0 α κ/2 of
    ///   5 s⁻¹ at m = 1 (κ ≈ 5e5 m⁻², the relative curvature of S at the peak) and
    ///   about four times that at m = 2, slow enough for the frame latency (10–20 ms)
    ///   and the velocity loop's 1/C = 20 ms.
    /// - δ = 0.1 mm (a quarter of the depth of field at m = 1, half of it at m = 2):
    ///   the window of 4 to 32 frames whose least-squares slope sees the gradient
    ///   through the frame noise (0.5 % flicker, pixel noise).
    /// - Search at 1 mm/s: the window spans δ within 10 frames of starting.
    /// - A 5 % change of the held sharpness restarts the search (the frame-to-frame
    ///   scatter of a 4-frame mean is about 0.4 %).
    /// - 0.05 grey levels of sharpness at least: the pixel noise alone gives
    ///   σ²/μ = 0.034.
    pub const FOCUS_10MM_100FPS: Self = Self {
        max_speed_m_s: 5e-3,
        sigmoid_gain: 4e-3,
        gradient_scale: GradientScale::Relative,
        tracking_gain_per_s: 50.0,
        max_acceleration_m_s2: 0.5,
        travel_m: [0.2e-3, 9.8e-3],
        frame_period_s: 0.01,
        window_excursion_m: 0.1e-3,
        min_window_frames: 4,
        search_speed_m_s: 1e-3,
        refocus_change: 0.05,
        min_sharpness: 0.05,
    };
}

/// Why a frame or a period was rejected.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AutofocusError {
    /// A position, velocity or sharpness is NaN or infinite.
    NotFinite,
    /// The sharpness is below `min_sharpness`: no texture to focus on.
    NoTexture,
}

/// What the law is doing (module docs).
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum AutofocusMode<T> {
    /// Moving at the search speed in `direction` (+1 or −1) until the window spans δ.
    Search {
        /// +1 toward the travel's maximum, −1 toward its minimum.
        direction: i8,
    },
    /// Following eq. 158.
    Track,
    /// At rest at the peak found; `sharpness` is the mean sharpness there.
    Hold {
        /// Mean sharpness when the axis stopped, grey levels.
        sharpness: T,
    },
}

/// Autofocus coefficients in the scalar `T`; one set drives any number of
/// [`AutofocusState`]s of capacity `N` frames.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Autofocus<T, const N: usize> {
    max_speed: T,
    sigmoid_gain: T,
    relative: bool,
    tracking_gain: T,
    max_acceleration: T,
    travel_min: T,
    travel_max: T,
    travel_mid: T,
    inv_frame_period: T,
    ts: T,
    inv_ts: T,
    excursion: T,
    min_frames: usize,
    search_speed: T,
    refocus_change: T,
    min_sharpness: T,
}

/// One focus axis' autofocus state: the gradient window (a ring of the latest `N`
/// frames' positions and sharpness) and the velocity reference.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct AutofocusState<T, const N: usize> {
    positions_m: [T; N],
    sharpness: [T; N],
    /// Slot of the next frame.
    head: usize,
    /// Frames in the ring (≤ N).
    len: usize,
    /// Current mode.
    pub mode: AutofocusMode<T>,
    /// Velocity the reference ramps to, m/s (set per frame).
    pub target_velocity_m_s: T,
    /// Reference velocity q̇ref of this period, m/s.
    pub reference_velocity_m_s: T,
    /// Ramp slope toward the target, m/s² (q̈ref while ramping).
    pub ramp_m_s2: T,
    /// Last gradient estimate g (see [`GradientScale`]), if the window spanned δ.
    pub gradient: Option<T>,
}

impl<T: Float, const N: usize> Default for AutofocusState<T, N> {
    /// At rest, no frames: the first valid frame starts a search.
    fn default() -> Self {
        Self {
            positions_m: [T::ZERO; N],
            sharpness: [T::ZERO; N],
            head: 0,
            len: 0,
            mode: AutofocusMode::Search { direction: 0 },
            target_velocity_m_s: T::ZERO,
            reference_velocity_m_s: T::ZERO,
            ramp_m_s2: T::ZERO,
            gradient: None,
        }
    }
}

impl<T: Float, const N: usize> AutofocusState<T, N> {
    /// The frames in the window, newest first: (position m, sharpness).
    pub fn frames(&self) -> impl Iterator<Item = (T, T)> + '_ {
        (1..=self.len).filter_map(move |back| {
            let slot = (self.head + N - back) % N;
            Some((*self.positions_m.get(slot)?, *self.sharpness.get(slot)?))
        })
    }

    fn push(&mut self, position: T, sharpness: T) {
        if let (Some(q), Some(s)) = (
            self.positions_m.get_mut(self.head),
            self.sharpness.get_mut(self.head),
        ) {
            *q = position;
            *s = sharpness;
            self.head = (self.head + 1) % N;
            self.len = (self.len + 1).min(N);
        }
    }

    fn clear(&mut self) {
        self.len = 0;
        self.gradient = None;
    }

    /// Mean sharpness of the newest `count` frames (`None` before there are that many).
    fn recent_mean(&self, count: usize) -> Option<T> {
        if self.len < count || count == 0 {
            return None;
        }
        let sum = self.frames().take(count).fold(T::ZERO, |a, (_, s)| a + s);
        Some(sum / lit(count as f64))
    }
}

impl<T: Float, const N: usize> Autofocus<T, N> {
    /// Validates the configuration for the control period `ts_s`: positive speeds,
    /// gains and limits, C·Ts ≤ 1, a travel range with min < max, a frame period of at
    /// least Ts, 3 ≤ `min_window_frames` ≤ N, search speed ≤ μ0, 0 < `refocus_change`
    /// < 1; every coefficient representable in `T`.
    pub fn new(config: &AutofocusConfig, ts_s: f64) -> Result<Self, ConfigError> {
        let ts = positive("period_s", ts_s)?;
        let mu0 = positive("max_speed_m_s", config.max_speed_m_s)?;
        let alpha = positive("sigmoid_gain", config.sigmoid_gain)?;
        let c = in_range(
            "tracking_gain_per_s",
            positive("tracking_gain_per_s", config.tracking_gain_per_s)?,
            0.0,
            1.0 / ts,
        )?;
        let a_max = positive("max_acceleration_m_s2", config.max_acceleration_m_s2)?;
        let [lo, hi] = config.travel_m;
        let travel_min = representable::<T>("travel_m", lo)?;
        let travel_max = representable::<T>("travel_m", hi)?;
        if hi <= lo {
            return Err(ConfigError::out_of_range("travel_m"));
        }
        let frame = positive("frame_period_s", config.frame_period_s)?;
        if frame < ts {
            return Err(ConfigError::out_of_range("frame_period_s"));
        }
        let delta = positive("window_excursion_m", config.window_excursion_m)?;
        if config.min_window_frames < 3 || config.min_window_frames > N {
            return Err(ConfigError::out_of_range("min_window_frames"));
        }
        let search = in_range(
            "search_speed_m_s",
            positive("search_speed_m_s", config.search_speed_m_s)?,
            0.0,
            mu0,
        )?;
        let change = positive("refocus_change", config.refocus_change)?;
        if change >= 1.0 {
            return Err(ConfigError::out_of_range("refocus_change"));
        }
        let min_sharpness = positive("min_sharpness", config.min_sharpness)?;
        Ok(Self {
            max_speed: coefficient("max_speed_m_s", mu0)?,
            sigmoid_gain: coefficient("sigmoid_gain", alpha)?,
            relative: config.gradient_scale == GradientScale::Relative,
            tracking_gain: coefficient("tracking_gain_per_s", c)?,
            max_acceleration: coefficient("max_acceleration_m_s2", a_max)?,
            travel_min,
            travel_max,
            travel_mid: representable("travel_m", 0.5 * (lo + hi))?,
            inv_frame_period: coefficient("frame_period_s", 1.0 / frame)?,
            ts: coefficient("period_s", ts)?,
            inv_ts: coefficient("period_s", 1.0 / ts)?,
            excursion: coefficient("window_excursion_m", delta)?,
            min_frames: config.min_window_frames,
            search_speed: coefficient("search_speed_m_s", search)?,
            refocus_change: coefficient("refocus_change", change)?,
            min_sharpness: coefficient("min_sharpness", min_sharpness)?,
        })
    }

    /// Eq. 158: q̇ref = μ0 (1 − 2/(1 + e^(−α g))), m/s, for the gradient `g` of −S
    /// (or of −ln S). α g is clamped to ±50 (where the sigmoid is ±1 to 4e-22) before
    /// the exponential; NaN gives zero.
    pub fn velocity_reference(&self, gradient: T) -> T {
        let x = to_f64(self.sigmoid_gain * gradient);
        if x.is_nan() {
            return T::ZERO;
        }
        let x = x.clamp(-50.0, 50.0);
        let shape = 1.0 - 2.0 / (1.0 + libm::exp(-x));
        self.max_speed * lit(shape)
    }

    /// The gradient g of −S (or −ln S) over the window and the window's mean
    /// sharpness, or `None` when the latest N frames do not span δ (module docs).
    pub fn gradient(&self, state: &AutofocusState<T, N>) -> Option<(T, T)> {
        // The shortest run of newest frames (≥ min_frames) spanning δ.
        let mut lo = T::ZERO;
        let mut hi = T::ZERO;
        let mut count = 0;
        for (k, (q, _)) in state.frames().enumerate() {
            if k == 0 {
                (lo, hi) = (q, q);
            } else if q < lo {
                lo = q;
            } else if q > hi {
                hi = q;
            }
            if k + 1 >= self.min_frames && hi - lo >= self.excursion {
                count = k + 1;
                break;
            }
        }
        if count == 0 {
            return None;
        }
        let n = lit::<T>(count as f64);
        let (sq, ss) = state
            .frames()
            .take(count)
            .fold((T::ZERO, T::ZERO), |(a, b), (q, s)| (a + q, b + s));
        let (q_mean, s_mean) = (sq / n, ss / n);
        let (sqs, sqq) = state
            .frames()
            .take(count)
            .fold((T::ZERO, T::ZERO), |(a, b), (q, s)| {
                let dq = q - q_mean;
                (a + dq * (s - s_mean), b + dq * dq)
            });
        if sqq <= T::ZERO {
            return None;
        }
        // Slope of f = −S.
        let slope = -(sqs / sqq);
        let g = if self.relative { slope / s_mean } else { slope };
        g.is_finite().then_some((g, s_mean))
    }

    /// One camera frame: the focus position at its exposure, m, and its sharpness
    /// (grey levels, [`sensing::sharpness`](crate::sensing::sharpness)). Updates the
    /// window and the mode, and sets the velocity the reference ramps to over the
    /// next frame period. Returns the mode after the frame.
    pub fn frame(
        &self,
        state: &mut AutofocusState<T, N>,
        position_m: T,
        sharpness: T,
    ) -> Result<AutofocusMode<T>, AutofocusError> {
        if !(position_m.is_finite() && sharpness.is_finite()) {
            self.stop(state, position_m.is_finite().then_some(position_m));
            return Err(AutofocusError::NotFinite);
        }
        if sharpness < self.min_sharpness {
            self.stop(state, Some(position_m));
            return Err(AutofocusError::NoTexture);
        }
        state.push(position_m, sharpness);
        let estimate = self.gradient(state);
        state.gradient = estimate.map(|(g, _)| g);
        let mut target = T::ZERO;
        match state.mode {
            AutofocusMode::Search { direction } => {
                let mut direction = match direction {
                    0 => self.direction_to_farther_end(position_m),
                    d => d,
                };
                if let Some((g, _)) = estimate {
                    state.mode = AutofocusMode::Track;
                    target = self.velocity_reference(g);
                } else {
                    if (direction > 0 && position_m >= self.travel_max)
                        || (direction < 0 && position_m <= self.travel_min)
                    {
                        direction = -direction;
                    }
                    state.mode = AutofocusMode::Search { direction };
                    target = if direction > 0 {
                        self.search_speed
                    } else {
                        -self.search_speed
                    };
                }
            }
            AutofocusMode::Track => {
                if let Some((g, _)) = estimate {
                    target = self.velocity_reference(g);
                } else {
                    let sharpness = state.recent_mean(self.min_frames).unwrap_or(sharpness);
                    state.mode = AutofocusMode::Hold { sharpness };
                }
            }
            AutofocusMode::Hold { sharpness: held } => {
                if let Some(now) = state.recent_mean(self.min_frames) {
                    let (change, allowed) = (now - held, self.refocus_change * held);
                    if change > allowed || change < -allowed {
                        state.clear();
                        state.push(position_m, sharpness);
                        let direction = self.direction_to_farther_end(position_m);
                        state.mode = AutofocusMode::Search { direction };
                        target = if direction > 0 {
                            self.search_speed
                        } else {
                            -self.search_speed
                        };
                    }
                }
            }
        }
        target = self.inside_travel(position_m, target);
        state.target_velocity_m_s = target;
        state.ramp_m_s2 = (target - state.reference_velocity_m_s) * self.inv_frame_period;
        Ok(state.mode)
    }

    /// One control period: the desired acceleration q̈des = q̈ref + C (q̇ref − q̇),
    /// m/s², clamped to the acceleration limit, for the measured position (m) and
    /// velocity (m/s). A NaN or infinite input stops the reference and returns
    /// [`AutofocusError::NotFinite`]: apply zero acceleration.
    pub fn step(
        &self,
        state: &mut AutofocusState<T, N>,
        position_m: T,
        velocity_m_s: T,
    ) -> Result<T, AutofocusError> {
        if !(position_m.is_finite() && velocity_m_s.is_finite()) {
            self.stop(state, None);
            state.reference_velocity_m_s = T::ZERO;
            state.ramp_m_s2 = T::ZERO;
            return Err(AutofocusError::NotFinite);
        }
        let v = state.reference_velocity_m_s;
        let target = state.target_velocity_m_s;
        let next = v + state.ramp_m_s2 * self.ts;
        let next = if (state.ramp_m_s2 > T::ZERO && next > target)
            || (state.ramp_m_s2 < T::ZERO && next < target)
        {
            target
        } else {
            next
        };
        let next = self.inside_travel(position_m, next);
        let acceleration_ref = (next - v) * self.inv_ts;
        state.reference_velocity_m_s = next;
        let command = acceleration_ref + self.tracking_gain * (next - velocity_m_s);
        Ok(command.clamp_abs(self.max_acceleration))
    }

    /// Zero reference, empty window, search again with the next valid frame.
    fn stop(&self, state: &mut AutofocusState<T, N>, position_m: Option<T>) {
        state.clear();
        state.mode = AutofocusMode::Search {
            direction: position_m.map_or(0, |q| self.direction_to_farther_end(q)),
        };
        state.target_velocity_m_s = T::ZERO;
        state.ramp_m_s2 = (T::ZERO - state.reference_velocity_m_s) * self.inv_frame_period;
        if !state.ramp_m_s2.is_finite() {
            state.reference_velocity_m_s = T::ZERO;
            state.ramp_m_s2 = T::ZERO;
        }
    }

    fn direction_to_farther_end(&self, position_m: T) -> i8 {
        if position_m < self.travel_mid {
            1
        } else {
            -1
        }
    }

    /// `velocity` with its outward part removed at or beyond a travel limit.
    fn inside_travel(&self, position_m: T, velocity: T) -> T {
        if (position_m >= self.travel_max && velocity > T::ZERO)
            || (position_m <= self.travel_min && velocity < T::ZERO)
        {
            T::ZERO
        } else {
            velocity
        }
    }
}

#[cfg(test)]
mod tests;
