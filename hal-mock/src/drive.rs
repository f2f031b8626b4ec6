//! The drive between a force command and the force on a carriage's rail: DAC, current
//! loop and the motor's force ripple, one channel per carriage.
//!
//!   command ─▶ DAC (round to the nearest code, clip) ─▶ current loop (first-order lag,
//!   time constant τ) ─▶ motor: F = f + Σk (rk f + ak) cos(2π nk q / τm + φk,i)
//!
//! where f is the current loop's output expressed as force (current × force constant),
//! q the carriage displacement, τm the magnetic pitch and φk,i the phase of term k on
//! carriage i. The relative terms (rk) scale with the current, the absolute ones (ak)
//! do not; all have an integer number nk of cycles per pitch, so over one pitch the
//! ripple averages out and the mean force is f.
//!
//! T's slave (T 7.1.2, 7.1.5) drives three Faulhaber LM1247 linear motors from
//! a dSPACE DS1103 through drive electronics built for the setup; the values of
//! [`DriveParams::LM1247_DS1103`] and their sources are given there.

use core::f64::consts::PI;

/// One periodic term of the motor force along the rail.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RippleTerm {
    /// Cycles per magnetic pitch (a whole number, so the term averages out over one
    /// pitch).
    pub cycles_per_pitch: f64,
    /// Amplitude relative to the current loop's force (commutation ripple scales with
    /// the current).
    pub relative: f64,
    /// Amplitude in N independent of the current (detent, current-offset ripple).
    pub absolute_n: f64,
    /// Phase of the cosine on each carriage in rad (each motor's magnet rod and each
    /// drive's offsets sit differently).
    pub phase_rad: [f64; 3],
}

impl RippleTerm {
    /// No ripple.
    pub const NONE: Self = Self {
        cycles_per_pitch: 1.0,
        relative: 0.0,
        absolute_n: 0.0,
        phase_rad: [0.0; 3],
    };

    fn is_zero(&self) -> bool {
        self.relative == 0.0 && self.absolute_n == 0.0
    }

    /// Angle of the cosine on `carriage` at displacement `q_m`, rad.
    fn angle_rad(&self, carriage: usize, q_m: f64, pitch_m: f64) -> f64 {
        let phase = self.phase_rad.get(carriage).copied().unwrap_or(0.0);
        2.0 * PI * self.cycles_per_pitch * q_m / pitch_m + phase
    }
}

/// DAC, current loop and force ripple of the motor drives (the same for the three
/// carriages except for the ripple phases).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DriveParams {
    /// DAC resolution in bits; 0 passes the command through unquantized.
    pub dac_bits: u8,
    /// Force at DAC full scale in N: codes −2^(b−1) … 2^(b−1) − 1 map to
    /// −full scale … full scale − 1 LSB, LSB = 2 · full scale / 2^b.
    pub dac_full_scale_n: f64,
    /// Closed-loop bandwidth of the current loop in Hz (first-order lag,
    /// τ = 1/(2π f)); infinite for an instantaneous current.
    pub current_bandwidth_hz: f64,
    /// Magnetic pitch of the motors in m (the ripple's period is a fraction of it).
    pub pitch_m: f64,
    /// Force ripple terms.
    pub ripple: [RippleTerm; 3],
}

impl DriveParams {
    /// Exact pass-through: no quantization, instantaneous current, no ripple.
    pub const IDEAL: Self = Self {
        dac_bits: 0,
        dac_full_scale_n: 0.0,
        current_bandwidth_hz: f64::INFINITY,
        pitch_m: 0.018,
        ripple: [RippleTerm::NONE; 3],
    };

    /// An LM1247 on drive electronics fed by a DS1103 D/A channel (the Keops slave,
    /// T 7.1.2 and 7.1.5).
    ///
    /// - DAC 16 bit: T names the board and its 8 D/A channels but not their
    ///   resolution; the DS1103's D/A converters are 16-bit, ±10 V by dSPACE's
    ///   documentation of the board (not stated in T; a 14-bit converter would
    ///   make the LSB 4× coarser, 0.44 mN, still far below friction). Full scale is taken as the 3.6 N continuous force (T 7.1.2; the drive
    ///   gain is an assumption — scaling ±10 V to the ≈3× peak force instead would
    ///   triple the LSB), so one LSB is 7.2 N / 65536 = 0.11 mN, three orders below
    ///   the friction.
    /// - Current loop 2 kHz (τ = 80 µs), an assumption of the right order: a PWM
    ///   current loop closes at up to about a tenth of its 20–40 kHz switching
    ///   frequency, the winding's own L/R of a coreless micro-motor is of order
    ///   0.1 ms, and a current loop slower than T's 2.4 kHz position loop
    ///   (T 7.1.5) would have made that rate pointless.
    /// - Pitch 18 mm (LM1247, as the Hall sensors: `HallSensorParams::LM1247_16BIT`).
    /// - Ripple. The LM1247 is ironless (self-supporting coil, no slots), so there is no
    ///   slot cogging; what remains, all assumptions in size:
    ///   1. commutation ripple, 6 cycles per pitch, 2 % of the force: sinusoidal
    ///      currents against a back-EMF with 5th and 7th harmonics (the magnet rod's
    ///      field, the same field whose harmonics the Hall sensors show at 1–3 %,
    ///      `HallSensorParams::lm1247_worst`);
    ///   2. current-offset ripple, 1 cycle per pitch, 10 mN: a phase-current sensing
    ///      offset of the drive of about 1 mA at the LM12xx class's ≈10 N/A force
    ///      constant, commutated into a force that follows the rotor angle;
    ///   3. detent, 2 cycles per pitch (one per magnet pole), 5 mN: the magnet rod's
    ///      pull on ferromagnetic parts nearby (fixing screws, flange), ≈0.15 % of the
    ///      continuous force — Faulhaber sells the series as free of cogging, so it
    ///      is small but not zero.
    ///
    ///   Phases differ per carriage (arbitrary, spread over the circle).
    pub const LM1247_DS1103: Self = Self {
        dac_bits: 16,
        dac_full_scale_n: 3.6,
        current_bandwidth_hz: 2000.0,
        pitch_m: 0.018,
        ripple: [
            RippleTerm {
                cycles_per_pitch: 6.0,
                relative: 0.02,
                absolute_n: 0.0,
                phase_rad: [0.4, 2.5, -1.9],
            },
            RippleTerm {
                cycles_per_pitch: 1.0,
                relative: 0.0,
                absolute_n: 0.010,
                phase_rad: [1.1, -0.6, 2.9],
            },
            RippleTerm {
                cycles_per_pitch: 2.0,
                relative: 0.0,
                absolute_n: 0.005,
                phase_rad: [0.0, 1.3, -2.2],
            },
        ],
    };

    /// DAC step in N (0 without quantization).
    pub fn dac_lsb_n(&self) -> f64 {
        if self.dac_bits == 0 {
            0.0
        } else {
            2.0 * self.dac_full_scale_n / libm::exp2(f64::from(self.dac_bits))
        }
    }

    /// DAC code for `force_n`: rounded to the nearest code (halves away from zero) and
    /// clipped to −2^(b−1) … 2^(b−1) − 1; a non-finite command gives code 0. Always 0
    /// without quantization.
    pub fn dac_code(&self, force_n: f64) -> i32 {
        let lsb = self.dac_lsb_n();
        if !force_n.is_finite() || lsb <= 0.0 {
            return 0;
        }
        let half = libm::exp2(f64::from(self.dac_bits.min(31) - 1));
        libm::round(force_n / lsb).clamp(-half, half - 1.0) as i32
    }

    /// The force the DAC puts out for `force_n` (code × LSB); passed through unchanged
    /// without quantization, 0 for a non-finite command.
    pub fn quantize_n(&self, force_n: f64) -> f64 {
        if !force_n.is_finite() {
            0.0
        } else if self.dac_bits == 0 {
            force_n
        } else {
            f64::from(self.dac_code(force_n)) * self.dac_lsb_n()
        }
    }

    /// Current-loop time constant τ = 1/(2π f) in s (0 for an instantaneous current).
    pub fn current_tau_s(&self) -> f64 {
        1.0 / (2.0 * PI * self.current_bandwidth_hz)
    }

    /// Current-loop output `t_s` after it was at `from_n` with `command_n` held: the
    /// exact solution of τ ḟ = u − f, u + (f0 − u) e^(−t/τ) (u at once when τ = 0).
    pub fn current_loop_n(&self, from_n: f64, command_n: f64, t_s: f64) -> f64 {
        let tau = self.current_tau_s();
        if tau > 0.0 {
            command_n + (from_n - command_n) * libm::exp(-t_s / tau)
        } else {
            command_n
        }
    }

    /// Whether the rail force always equals the DAC output (instantaneous current and
    /// no ripple).
    pub fn is_instantaneous(&self) -> bool {
        self.current_tau_s() == 0.0 && self.ripple.iter().all(RippleTerm::is_zero)
    }

    /// Motor force along the rail of `carriage` (0..3) at displacement `q_m` for the
    /// current loop's force `force_n`, ripple included.
    pub fn rail_force_n(&self, carriage: usize, force_n: f64, q_m: f64) -> f64 {
        let mut f = force_n;
        for term in self.ripple.iter().filter(|t| !t.is_zero()) {
            let amplitude = term.relative * force_n + term.absolute_n;
            f += amplitude * libm::cos(term.angle_rad(carriage, q_m, self.pitch_m));
        }
        f
    }

    /// Potential energy in J of the current-independent ripple (the absolute terms, a
    /// conservative force of position only) on `carriage` at `q_m`, zero at the
    /// term's zero crossings: V = −Σk ak τm/(2π nk) sin(2π nk q/τm + φk,i), so that
    /// −dV/dq is the ripple force.
    pub fn ripple_potential_j(&self, carriage: usize, q_m: f64) -> f64 {
        let mut v = 0.0;
        for term in self.ripple.iter().filter(|t| t.absolute_n != 0.0) {
            let wavelength_m = self.pitch_m / term.cycles_per_pitch;
            v -= term.absolute_n * wavelength_m / (2.0 * PI)
                * libm::sin(term.angle_rad(carriage, q_m, self.pitch_m));
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3-bit DAC over ±4 N: LSB exactly 1 N, codes −4 … 3, so every expected value
    /// is an exact binary number.
    fn three_bit() -> DriveParams {
        DriveParams {
            dac_bits: 3,
            dac_full_scale_n: 4.0,
            ..DriveParams::IDEAL
        }
    }

    #[test]
    fn dac_rounds_to_the_nearest_code_and_clips() {
        let d = three_bit();
        assert_eq!(d.dac_lsb_n(), 1.0);
        let cases = [
            (0.0, 0),
            (0.49, 0),
            (0.5, 1), // halves away from zero
            (-0.5, -1),
            (0.51, 1),
            (-1.49, -1),
            (2.5, 3),
            (2.9, 3),
            (3.4, 3),
            (3.6, 3), // top code is full scale − 1 LSB
            (100.0, 3),
            (-3.6, -4),
            (-4.0, -4),
            (-4.7, -4),
            (-1e9, -4),
            (f64::NAN, 0),
            (f64::INFINITY, 0),
            (f64::NEG_INFINITY, 0),
        ];
        for (f, code) in cases {
            assert_eq!(d.dac_code(f), code, "{f}");
            assert_eq!(d.quantize_n(f), f64::from(code), "{f}");
        }
        // The 16-bit preset: LSB 7.2 N / 65536, codes −32768 … 32767.
        let r = DriveParams::LM1247_DS1103;
        let lsb = 7.2 / 65536.0;
        assert_eq!(r.dac_lsb_n(), lsb);
        assert_eq!(r.dac_code(1.0), 9102); // 1 / 1.0986e-4 = 9102.2
        assert_eq!(r.dac_code(-1.0), -9102);
        assert_eq!(r.dac_code(3.6), 32767);
        assert_eq!(r.dac_code(-3.6), -32768);
        assert_eq!(r.dac_code(0.6 * lsb), 1);
        assert_eq!(r.dac_code(0.4 * lsb), 0);
        // Quantization error at most half an LSB inside the range.
        for k in 0..1000 {
            let f = -3.5 + 7.0 * f64::from(k) / 1000.0 + 1e-7;
            assert!(
                (r.quantize_n(f) - f).abs() <= 0.5 * lsb * (1.0 + 1e-12),
                "{f}"
            );
        }
    }

    #[test]
    fn ideal_drive_is_an_exact_pass_through() {
        let d = DriveParams::IDEAL;
        assert!(d.is_instantaneous());
        assert_eq!(d.current_tau_s(), 0.0);
        for f in [0.0, -0.0, 1.0 / 3.0, -2.7, 3.6, 1e-300, -123.456] {
            assert_eq!(d.quantize_n(f).to_bits(), f.to_bits());
            assert_eq!(d.current_loop_n(5.0, f, 0.0).to_bits(), f.to_bits());
            for q in [0.0, 0.0071, -0.3] {
                assert_eq!(d.rail_force_n(1, f, q).to_bits(), f.to_bits());
                assert_eq!(d.ripple_potential_j(1, q), 0.0);
            }
        }
        assert_eq!(d.quantize_n(f64::NAN), 0.0);
        assert!(!DriveParams::LM1247_DS1103.is_instantaneous());
    }

    #[test]
    fn current_loop_step_response_is_the_exponential() {
        let d = DriveParams::LM1247_DS1103;
        let tau = d.current_tau_s();
        assert!((tau - 1.0 / (2.0 * PI * 2000.0)).abs() < 1e-18);
        // Stepped in the plant's substeps (the command held), sampled at their ends.
        let h = 2.5e-5;
        let mut f = 0.0;
        for k in 1..=200 {
            f = d.current_loop_n(f, 1.0, h);
            let t = f64::from(k) * h;
            let expect = 1.0 - libm::exp(-t / tau);
            // Round-off: e^(−h/τ) carries a relative error of 1e-16 that compounds k
            // times (≤ 2e-14 at k = 200), plus one rounding per step.
            assert!((f - expect).abs() < 5e-14, "k {k}: {f} vs {expect}");
        }
        // From a nonzero state toward another command: same form.
        let f1 = d.current_loop_n(2.0, -1.0, tau);
        assert!((f1 - (-1.0 + 3.0 * libm::exp(-1.0))).abs() < 1e-15);
    }

    #[test]
    fn current_loop_is_minus_3_db_and_minus_45_degrees_at_its_bandwidth() {
        // Sinusoid at f = bandwidth, command held over steps of τ/2000: the hold adds a
        // delay of h/2, i.e. ωh/2 = 1/4000 rad of phase, and a gain error of (ωh)²/24 —
        // both far inside the tolerances below.
        let d = DriveParams::LM1247_DS1103;
        let tau = d.current_tau_s();
        let w = 1.0 / tau;
        let h = tau / 2000.0;
        let period_steps = (2.0 * PI / (w * h)).round() as usize;
        let h = 2.0 * PI / (w * period_steps as f64); // a whole number of steps per cycle
        let mut f = 0.0;
        let (mut c, mut s) = (0.0, 0.0);
        for k in 0..(12 * period_steps) {
            let t = k as f64 * h;
            // Held value: the sinusoid at the middle of the step (a centred hold, so
            // the hold itself adds no delay).
            f = d.current_loop_n(f, libm::sin(w * (t + 0.5 * h)), h);
            if k >= 10 * period_steps {
                // Last two cycles: the transient (e^(−20π)) is gone.
                let te = t + h;
                c += f * libm::cos(w * te);
                s += f * libm::sin(w * te);
            }
        }
        let n = (2 * period_steps) as f64;
        let (a_sin, a_cos) = (2.0 * s / n, 2.0 * c / n);
        let gain = libm::hypot(a_sin, a_cos);
        let phase_deg = libm::atan2(a_cos, a_sin) * 180.0 / PI;
        assert!(
            (gain - core::f64::consts::FRAC_1_SQRT_2).abs() < 1e-5,
            "{gain}"
        );
        assert!((phase_deg + 45.0).abs() < 1e-3, "{phase_deg}");
    }

    #[test]
    fn ripple_over_one_pitch_matches_its_formula() {
        let d = DriveParams::LM1247_DS1103;
        let n = 720;
        for carriage in 0..3 {
            for force in [0.0, 1.5, -2.0] {
                // Discrete Fourier transform over one pitch (n samples): exact for
                // harmonics below n/2.
                let mut mean = 0.0;
                let mut bins = [(0.0, 0.0); 8];
                for k in 0..n {
                    let q = 0.003 + d.pitch_m * k as f64 / n as f64;
                    let f = d.rail_force_n(carriage, force, q);
                    // Periodic in the pitch.
                    let again = d.rail_force_n(carriage, force, q + d.pitch_m);
                    assert!((f - again).abs() < 1e-12);
                    mean += f / n as f64;
                    let x = 2.0 * PI * (q - 0.003) / d.pitch_m;
                    for (h, bin) in bins.iter_mut().enumerate().skip(1) {
                        bin.0 += 2.0 * f * libm::cos(h as f64 * x) / n as f64;
                        bin.1 += 2.0 * f * libm::sin(h as f64 * x) / n as f64;
                    }
                }
                assert!((mean - force).abs() < 1e-12, "{mean}");
                // Expected: harmonic 6 of 2 % of the force, 1 of 10 mN, 2 of 5 mN, with
                // the carriage's phases (referred to q = 0.003 m, where x = 0).
                let expect = |h: usize| -> (f64, f64) {
                    let (amp, phase) = match h {
                        6 => (0.02 * force, [0.4, 2.5, -1.9][carriage]),
                        1 => (0.010, [1.1, -0.6, 2.9][carriage]),
                        2 => (0.005, [0.0, 1.3, -2.2][carriage]),
                        _ => (0.0, 0.0),
                    };
                    let shift = 2.0 * PI * h as f64 * 0.003 / d.pitch_m + phase;
                    // A cos(x' + φ) = A cos φ cos x' − A sin φ sin x'.
                    (amp * libm::cos(shift), -amp * libm::sin(shift))
                };
                for (h, bin) in bins.iter().enumerate().skip(1) {
                    let (ec, es) = expect(h);
                    assert!(
                        (bin.0 - ec).abs() < 1e-12 && (bin.1 - es).abs() < 1e-12,
                        "carriage {carriage} force {force} harmonic {h}: {bin:?} vs {ec} {es}"
                    );
                }
            }
        }
    }

    #[test]
    fn ripple_potential_is_the_integral_of_the_absolute_ripple() {
        // −dV/dq by central differences equals the ripple at zero current.
        let d = DriveParams::LM1247_DS1103;
        let e = 1e-7;
        for k in 0..50 {
            let q = -0.02 + 0.0011 * f64::from(k);
            let force =
                -(d.ripple_potential_j(2, q + e) - d.ripple_potential_j(2, q - e)) / (2.0 * e);
            assert!((force - d.rail_force_n(2, 0.0, q)).abs() < 1e-9, "{q}");
        }
    }
}
