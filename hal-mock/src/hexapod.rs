//! The simulated hexapod controller: a rate-limited 6-DOF positioner that speaks the
//! PI GCS subset of `kerf::codec::gcs`, so the firmware drives it with the bytes it
//! would send G's PI controller (G app. D).
//!
//! Model: the platform pose (X, Y, Z in mm; U, V, W in deg) moves in a straight line
//! of the six coordinates toward its target at the system velocity set by VLS (the
//! 6-D path length counts a degree as a millimetre: every axis arrives together).
//! Travel limits are the H-824's of G app. A. Like the real controller it must be
//! referenced first (FRF, any axes: the hexapod references as a whole, taking
//! [`REFERENCE_TIME_S`], after which it stands at the origin); until then MOV fails
//! with error 5. Commands without '?' are not answered; a failure sets the error code
//! ERR? reads and clears (PI's numbering, `gcs::code`): a target out of travel (7,
//! the whole MOV is refused), a velocity outside (0, max] (8), HLT (10: it stops where
//! it is), an unknown command (2), a bad axis (15), anything else malformed (1).
//! #5 answers the moving axes, #7 0xB0 during the reference move and 0xB1 otherwise.

use kerf::codec::gcs::{
    code, reply, Axis, AxisSet, AxisValues, Command, GcsError, SpaItem, NOT_READY, READY,
};

/// Duration of the simulated reference move, s.
pub const REFERENCE_TIME_S: f64 = 2.0;

/// Travel and velocity limits (mm for X, Y, Z; deg for U, V, W).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HexapodLimits {
    /// Largest |coordinate| per axis, X … W.
    pub travel: [f64; 6],
    /// Largest VLS, units/s.
    pub max_velocity: f64,
    /// VLS at power-up, units/s.
    pub initial_velocity: f64,
}

impl HexapodLimits {
    /// PI H-824 (G app. A, table 5): X, Y ±22.5 mm, Z ±12.5 mm, θx, θy ±7.5°,
    /// θz ±12.5°; 1 mm/s at most (the table's typical 0.5 mm/s is the start value).
    pub const H824: Self = Self {
        travel: [22.5, 22.5, 12.5, 7.5, 7.5, 12.5],
        max_velocity: 1.0,
        initial_velocity: 0.5,
    };
}

/// The simulated controller and platform.
#[derive(Clone, Debug)]
pub struct SimHexapod {
    limits: HexapodLimits,
    position: [f64; 6],
    target: [f64; 6],
    velocity: f64,
    referenced: bool,
    /// Time left of a reference move in progress, s.
    referencing_s: Option<f64>,
    error: i32,
    /// The last SPA: (parameter, value).
    last_parameter: Option<(u32, f64)>,
}

impl SimHexapod {
    /// A controller at power-up: unreferenced, at the origin.
    pub fn new(limits: HexapodLimits) -> Self {
        Self {
            limits,
            position: [0.0; 6],
            target: [0.0; 6],
            velocity: limits.initial_velocity,
            referenced: false,
            referencing_s: None,
            error: code::NO_ERROR,
            last_parameter: None,
        }
    }

    /// The platform's pose, X … W (mm, deg).
    pub fn position(&self) -> [f64; 6] {
        self.position
    }

    /// The last parameter set by SPA.
    pub fn last_parameter(&self) -> Option<(u32, f64)> {
        self.last_parameter
    }

    /// Advances the platform by `dt_s`.
    pub fn step(&mut self, dt_s: f64) {
        if let Some(left) = self.referencing_s {
            if left <= dt_s {
                self.referencing_s = None;
                self.referenced = true;
                self.position = [0.0; 6];
                self.target = [0.0; 6];
            } else {
                self.referencing_s = Some(left - dt_s);
            }
            return;
        }
        let delta: [f64; 6] = core::array::from_fn(|k| self.target[k] - self.position[k]);
        let distance = libm::sqrt(delta.iter().map(|d| d * d).sum::<f64>());
        let reach = self.velocity * dt_s;
        if distance <= reach {
            self.position = self.target;
        } else {
            for (p, d) in self.position.iter_mut().zip(delta) {
                *p += d * reach / distance;
            }
        }
    }

    fn moving(&self) -> AxisSet {
        if self.referencing_s.is_some() {
            return AxisSet::ALL;
        }
        Axis::ALL
            .into_iter()
            .filter(|a| self.position[a.index()] != self.target[a.index()])
            .fold(AxisSet::EMPTY, AxisSet::with)
    }

    fn fail(&mut self, code: i32) -> usize {
        self.error = code;
        0
    }

    /// Takes one command (a line with its LF, or the byte of #5 or #7) and writes
    /// the reply into `out`; returns the reply's length (0: no reply, as for
    /// commands without '?', or `out` too small).
    pub fn handle(&mut self, command: &[u8], out: &mut [u8]) -> usize {
        let command = match Command::parse(command) {
            Ok(c) => c,
            Err(e) => {
                return self.fail(match e {
                    GcsError::UnknownCommand => code::UNKNOWN_COMMAND,
                    GcsError::UnknownAxis(_) | GcsError::DuplicateAxis(_) => code::INVALID_AXIS,
                    GcsError::TooLong => code::COMMAND_TOO_LONG,
                    _ => code::PARAM_SYNTAX,
                })
            }
        };
        let all_if_empty = |axes: AxisSet| if axes.is_empty() { AxisSet::ALL } else { axes };
        let values_of = |axes: AxisSet, source: &[f64; 6]| {
            let mut v = AxisValues::new();
            for a in all_if_empty(axes).iter() {
                v.set(a, source[a.index()]);
            }
            v
        };
        let written = match command {
            Command::Mov(values) => {
                if !self.referenced || self.referencing_s.is_some() {
                    return self.fail(code::MOVE_WITHOUT_REFERENCE);
                }
                if values
                    .iter()
                    .any(|(a, v)| libm::fabs(v) > self.limits.travel[a.index()])
                {
                    return self.fail(code::POS_OUT_OF_LIMITS);
                }
                for (a, v) in values.iter() {
                    self.target[a.index()] = v;
                }
                return 0;
            }
            Command::Vls(v) => {
                if v <= 0.0 || v > self.limits.max_velocity {
                    return self.fail(code::VEL_OUT_OF_LIMITS);
                }
                self.velocity = v;
                return 0;
            }
            Command::Spa {
                item,
                parameter,
                value,
            } => {
                if !matches!(item, SpaItem::Number(1)) {
                    return self.fail(code::INVALID_AXIS);
                }
                self.last_parameter = Some((parameter, value));
                return 0;
            }
            Command::Hlt(_) => {
                self.target = self.position;
                self.referencing_s = None;
                return self.fail(code::STOPPED);
            }
            Command::Frf(_) => {
                self.referencing_s = Some(REFERENCE_TIME_S);
                return 0;
            }
            Command::MovQuery(axes) => {
                reply::encode_axis_values(&values_of(axes, &self.target), out)
            }
            Command::PosQuery(axes) => {
                reply::encode_axis_values(&values_of(axes, &self.position), out)
            }
            Command::FrfQuery(axes) => {
                let flag = if self.referenced { 1.0 } else { 0.0 };
                reply::encode_axis_values(&AxisValues::uniform(all_if_empty(axes), flag), out)
            }
            Command::VlsQuery => reply::encode_value(self.velocity, out),
            Command::SaiQuery => reply::encode_axis_names(AxisSet::ALL, out),
            Command::IdnQuery => {
                let text = b"kerf simulated hexapod controller, H-824 model, 0, 0.1\n";
                match out.get_mut(..text.len()) {
                    Some(slot) => {
                        slot.copy_from_slice(text);
                        Ok(text.len())
                    }
                    None => Err(GcsError::BufferTooSmall),
                }
            }
            Command::ErrQuery => {
                let error = core::mem::replace(&mut self.error, code::NO_ERROR);
                reply::encode_error_code(error, out)
            }
            Command::MotionStatus => reply::encode_motion_status(self.moving(), out),
            Command::ControllerReady => match out.first_mut() {
                Some(slot) => {
                    *slot = if self.referencing_s.is_some() {
                        NOT_READY
                    } else {
                        READY
                    };
                    Ok(1)
                }
                None => Err(GcsError::BufferTooSmall),
            },
        };
        written.unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kerf::codec::gcs::{
        check_error, parse_axis_names, parse_axis_values, parse_error_code, parse_identification,
        parse_motion_status, parse_ready, parse_referenced, parse_value, MAX_COMMAND_LEN,
        MAX_REPLY_LEN,
    };

    /// The firmware's side of the link: encode with kerf, hand the bytes over, read
    /// the reply bytes back.
    struct Host {
        hexapod: SimHexapod,
        reply: [u8; MAX_REPLY_LEN],
        len: usize,
    }

    impl Host {
        fn send(&mut self, command: Command) -> &[u8] {
            let mut buf = [0u8; MAX_COMMAND_LEN];
            let n = command.encode(&mut buf).unwrap();
            self.len = self.hexapod.handle(&buf[..n], &mut self.reply);
            &self.reply[..self.len]
        }
        fn error(&mut self) -> i32 {
            parse_error_code(self.send(Command::ErrQuery)).unwrap()
        }
        fn position(&mut self) -> AxisValues {
            parse_axis_values(self.send(Command::PosQuery(AxisSet::EMPTY))).unwrap()
        }
    }

    fn host() -> Host {
        Host {
            hexapod: SimHexapod::new(HexapodLimits::H824),
            reply: [0; MAX_REPLY_LEN],
            len: 0,
        }
    }

    fn moves(x: f64, y: f64) -> Command {
        let mut v = AxisValues::new();
        v.set(Axis::X, x);
        v.set(Axis::Y, y);
        Command::Mov(v)
    }

    #[test]
    fn reference_then_move_at_the_set_velocity() {
        let mut h = host();
        let idn = h.send(Command::IdnQuery).to_vec();
        assert!(parse_identification(&idn).unwrap().contains("H-824"));
        assert_eq!(
            parse_axis_names(h.send(Command::SaiQuery)),
            Ok(AxisSet::ALL)
        );
        // Unreferenced: the move is refused with error 5 and nothing moves.
        assert_eq!(h.send(moves(1.0, 0.0)), b"");
        assert_eq!(check_error(h.error()), Err(GcsError::Controller(5)));
        let (all, referenced) =
            parse_referenced(h.send(Command::FrfQuery(AxisSet::EMPTY))).unwrap();
        assert_eq!((all, referenced), (AxisSet::ALL, AxisSet::EMPTY));

        // G's sequence: FRF, then wait on #7 (IsControllerReady).
        h.send(Command::Frf(AxisSet::EMPTY.with(Axis::X)));
        let mut waited_s = 0.0;
        while !parse_ready(h.send(Command::ControllerReady)).unwrap() {
            h.hexapod.step(0.1);
            waited_s += 0.1;
            assert!(waited_s < 10.0);
        }
        assert!((waited_s - REFERENCE_TIME_S).abs() < 0.11, "{waited_s}");
        assert_eq!(h.error(), 0);

        // VLS 0.5, MOV X 3 Y -4: 5 mm at 0.5 mm/s, POS? polled every 0.1 s as
        // G's GUI does, each read on the line from the start at v·t.
        h.send(Command::Vls(0.5));
        assert_eq!(parse_value(h.send(Command::VlsQuery)), Ok(0.5));
        h.send(moves(3.0, -4.0));
        assert_eq!(h.error(), 0);
        let dt = 0.1;
        let mut t = 0.0;
        loop {
            let moving = parse_motion_status(h.send(Command::MotionStatus)).unwrap();
            if moving.is_empty() {
                break;
            }
            assert_eq!(moving, AxisSet::EMPTY.with(Axis::X).with(Axis::Y));
            h.hexapod.step(dt);
            t += dt;
            let p = h.position();
            let travelled = (0.5 * t).min(5.0);
            // Positions are written to 1e-6 mm.
            assert!((p.get(Axis::X).unwrap() - 0.6 * travelled).abs() < 1e-6);
            assert!((p.get(Axis::Y).unwrap() + 0.8 * travelled).abs() < 1e-6);
            assert!(t < 20.0);
        }
        // 5 mm at 0.5 mm/s: 10 s, to one step.
        assert!((t - 10.0).abs() < dt + 1e-9, "{t}");
        let targets = parse_axis_values(h.send(Command::MovQuery(AxisSet::EMPTY.with(Axis::X))));
        assert_eq!(targets.unwrap().get(Axis::X), Some(3.0));
    }

    #[test]
    fn errors_a_controller_reports() {
        let mut h = host();
        h.send(Command::Frf(AxisSet::EMPTY));
        h.hexapod.step(REFERENCE_TIME_S + 0.01);
        // Out of travel: Z ±12.5 mm; the whole MOV is refused.
        let mut v = AxisValues::new();
        v.set(Axis::X, 1.0);
        v.set(Axis::Z, 20.0);
        h.send(Command::Mov(v));
        assert_eq!(h.error(), code::POS_OUT_OF_LIMITS);
        assert_eq!(h.error(), 0); // read clears it
        h.hexapod.step(1.0);
        assert_eq!(h.position().get(Axis::X), Some(0.0));
        // VLS above the H-824's 1 mm/s.
        h.send(Command::Vls(5.0));
        assert_eq!(h.error(), code::VEL_OUT_OF_LIMITS);
        // HLT in the middle of a move stops it where it is.
        h.send(moves(2.0, 0.0));
        h.hexapod.step(1.0);
        h.send(Command::Hlt(AxisSet::EMPTY));
        assert_eq!(h.error(), code::STOPPED);
        h.hexapod.step(1.0);
        let x = h.position().get(Axis::X).unwrap();
        assert!((x - 0.5).abs() < 1e-9, "{x}");
        // Bytes that are no command, or a bad axis.
        assert_eq!(h.hexapod.handle(b"JMP 1\n", &mut [0u8; 8]), 0);
        assert_eq!(h.error(), code::UNKNOWN_COMMAND);
        h.hexapod.handle(b"MOV Q 1\n", &mut [0u8; 8]);
        assert_eq!(h.error(), code::INVALID_AXIS);
        h.hexapod.handle(b"MOV X abc\n", &mut [0u8; 8]);
        assert_eq!(h.error(), code::PARAM_SYNTAX);
        // SPA as G sends it is taken.
        h.send(Command::Spa {
            item: SpaItem::Number(1),
            parameter: 0x1900_1900,
            value: 0.0,
        });
        assert_eq!(h.error(), 0);
        assert_eq!(h.hexapod.last_parameter(), Some((0x1900_1900, 0.0)));
    }
}
