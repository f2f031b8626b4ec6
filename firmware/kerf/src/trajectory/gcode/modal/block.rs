//! One line (a block) applied to the modal state, and the points of its move.

use super::{code_x10, g_group, m_group, Line, Motion, Parser, AXES, M_PER_INCH, RAD_PER_DEG};
use crate::trajectory::gcode::arc::{self, Arc};
use crate::trajectory::gcode::diagnostic::GcodeErrorKind as Kind;
use crate::trajectory::gcode::lex::Word;
use crate::trajectory::gcode::{GcodePoint, MoveKind, Spindle};

/// The move a line makes, checked, given out once the line is clean.
pub(super) enum Plan {
    None,
    Line {
        target: [f64; 5],
        kind: MoveKind,
        feed_m_s: f64,
    },
    Arc {
        start: [f64; 5],
        target: [f64; 5],
        arc: Arc,
        chords: u32,
        feed_m_s: f64,
    },
}

/// A word's value × 10 for a message (clamped: the code is unknown anyway).
fn shown_x10(value: f64) -> u32 {
    // Clamped to 0..=99999: the conversion is exact.
    libm::round(value * 10.0).clamp(0.0, 99_999.0) as u32
}

impl Parser {
    /// Sorts the words of a line, reporting the unknown and the repeated.
    fn sort(&self, words: &[Word], report: &mut impl FnMut(u32, Kind)) -> Line {
        let mut l = Line::default();
        for w in words {
            let column = w.column;
            let slot = match w.letter {
                letter @ (b'G' | b'M') => {
                    let code = code_x10(w.value);
                    let group = code.and_then(|c| {
                        if letter == b'G' {
                            g_group(c)
                        } else {
                            m_group(c)
                        }
                    });
                    let (Some(code), Some(group)) = (code, group) else {
                        let code_x10 = shown_x10(w.value);
                        report(column, Kind::Unsupported { letter, code_x10 });
                        continue;
                    };
                    let slots = if letter == b'G' {
                        &mut l.g[..]
                    } else {
                        &mut l.m[..]
                    };
                    match slots.get_mut(usize::from(group)) {
                        Some(slot @ None) => *slot = Some((code, column)),
                        _ => report(
                            column,
                            Kind::ModalConflict {
                                letter,
                                code_x10: code,
                            },
                        ),
                    }
                    continue;
                }
                letter @ (b'X' | b'Y' | b'Z' | b'A' | b'B') => {
                    let i = AXES.iter().position(|&a| a == letter).unwrap_or(0);
                    if !self.config.axes.get(i).copied().unwrap_or(false) {
                        report(column, Kind::AxisNotOnMachine(letter));
                        continue;
                    }
                    l.axes.get_mut(i)
                }
                b'I' => l.center.get_mut(0),
                b'J' => l.center.get_mut(1),
                b'K' => l.center.get_mut(2),
                b'R' => Some(&mut l.r),
                b'P' => Some(&mut l.p),
                b'F' => Some(&mut l.f),
                b'S' => Some(&mut l.s),
                b'T' => Some(&mut l.t),
                b'N' => continue,
                other => {
                    report(column, Kind::UnknownWord(other));
                    continue;
                }
            };
            match slot {
                Some(slot @ None) => *slot = Some((w.value, column)),
                _ => report(column, Kind::DuplicateWord(w.letter)),
            }
        }
        l
    }

    /// Applies one line's words to the state in RS-274's order and returns its move.
    /// Problems go to `report`; the caller keeps the new state only when none is an
    /// error.
    pub(super) fn apply(&mut self, words: &[Word], report: &mut impl FnMut(u32, Kind)) -> Plan {
        let l = self.sort(words, report);
        let g = |group: usize| l.g.get(group).copied().flatten();
        let m = |group: usize| l.m.get(group).copied().flatten();
        let not_read =
            |letter, (code_x10, column): (u32, u32)| (column, Kind::NotRead { letter, code_x10 });
        let ignored =
            |letter, (code_x10, column): (u32, u32)| (column, Kind::Ignored { letter, code_x10 });
        let mut say = |(column, kind): (u32, Kind)| report(column, kind);
        // Feed mode, units (before the feed: `G20 F10` is 10 in/min, as grbl), feed.
        match g(5) {
            Some((930, column)) => {
                self.inverse_time = true;
                say((column, Kind::InverseTimeMode));
            }
            Some((940, _)) => self.inverse_time = false,
            Some(code) => say(not_read(b'G', code)),
            None => {}
        }
        match g(6) {
            Some((200, _)) => self.unit_m = M_PER_INCH,
            Some(_) => self.unit_m = 1e-3,
            None => {}
        }
        if let Some((f, column)) = l.f {
            let f_m_s = f * self.unit_m / 60.0;
            if !f_m_s.is_finite() {
                say((column, Kind::NotFinite));
            } else if f_m_s <= 0.0 {
                say((column, Kind::BadFeed));
            } else {
                self.feed_m_s = Some(f_m_s);
            }
        }
        // Spindle or laser power, tool, coolant.
        if let Some((s, column)) = l.s {
            if s < 0.0 {
                say((column, Kind::BadSpindle));
            } else {
                self.spindle_s = s;
            }
        }
        if let Some((t, column)) = l.t {
            say(ignored(b'T', (shown_x10(t), column)));
        }
        // A tool change is ignored with the words that go with it (`M6 P1` selects a
        // tool on some controllers).
        let tool_change = m(6).is_some();
        if let Some(code) = m(6) {
            say(ignored(b'M', code));
        }
        match m(7) {
            Some((30, _)) => self.spindle = Spindle::Clockwise,
            Some((40, _)) => self.spindle = Spindle::CounterClockwise,
            Some(_) => self.spindle = Spindle::Off,
            None => {}
        }
        if let Some(code) = m(8) {
            say(ignored(b'M', code));
        }
        // Plane, cutter compensation, tool length, coordinate system, blending,
        // distance modes.
        match g(2) {
            Some((180, _)) => self.plane = [2, 0, 1],
            Some((190, _)) => self.plane = [1, 2, 0],
            Some(_) => self.plane = [0, 1, 2],
            None => {}
        }
        match g(7) {
            Some((400, _)) | None => {}
            Some(code) => say(not_read(b'G', code)),
        }
        match g(8) {
            Some((490, _)) | None => {}
            Some(code) => say(ignored(b'G', code)),
        }
        if let Some((code, _)) = g(12) {
            // G54…G59: codes 540…590.
            self.system = usize::try_from((code.saturating_sub(540)) / 10).unwrap_or(0);
        }
        if let Some(code) = g(13) {
            say(ignored(b'G', code));
        }
        match g(3) {
            Some((910, _)) => self.incremental = true,
            Some(_) => self.incremental = false,
            None => {}
        }
        match g(4) {
            Some((901, _)) => self.absolute_centers = true,
            Some(_) => self.absolute_centers = false,
            None => {}
        }
        // Non-modal codes: dwell, offsets, machine coordinates, home.
        let mut p_used = tool_change;
        let mut axes_used = false;
        let mut machine_coordinates = false;
        match g(0) {
            Some((40, column)) => {
                p_used = true;
                match l.p {
                    Some((p, _)) if p >= 0.0 => self.dwell_s += p,
                    _ => say((column, Kind::BadDwell)),
                }
            }
            Some((920, column)) => {
                axes_used = true;
                if let Some((code, column)) = g(1).filter(|_| l.axes.iter().any(Option::is_some)) {
                    say((
                        column,
                        Kind::ModalConflict {
                            letter: b'G',
                            code_x10: code,
                        },
                    ));
                }
                let work = self
                    .config
                    .work_offsets
                    .get(self.system)
                    .copied()
                    .unwrap_or([0.0; 5]);
                for i in 0..5 {
                    let scale = self.scale(i);
                    if let (Some(Some((v, _))), Some(&at), Some(&off), Some(g92)) = (
                        l.axes.get(i),
                        self.position.get(i),
                        work.get(i),
                        self.g92.get_mut(i),
                    ) {
                        *g92 = at - off - v * scale;
                    }
                }
                self.g92_on = true;
                if !self.g92.iter().all(|v| v.is_finite()) {
                    say((column, Kind::NotFinite));
                }
            }
            Some((921, _)) => {
                self.g92 = [0.0; 5];
                self.g92_on = true;
            }
            Some((922, _)) => self.g92_on = false,
            Some((923, _)) => self.g92_on = true,
            Some((530, _)) => machine_coordinates = true,
            Some(code @ (281 | 301, _)) => say(ignored(b'G', code)),
            Some(code) => say(not_read(b'G', code)),
            None => {}
        }
        // Stops (the end acts after the move).
        let mut end = false;
        match m(4) {
            Some((20 | 300, _)) => end = true,
            Some(code @ (10, _)) => say(ignored(b'M', code)),
            Some(code) => say(not_read(b'M', code)),
            None => {}
        }
        // Motion.
        match g(1) {
            Some((0, _)) => self.motion = Some(Motion::Rapid),
            Some((10, _)) => self.motion = Some(Motion::Feed),
            Some((20, _)) => self.motion = Some(Motion::Clockwise),
            Some((30, _)) => self.motion = Some(Motion::CounterClockwise),
            Some((800, _)) => self.motion = None,
            Some(code) => say(not_read(b'G', code)),
            None => {}
        }
        let first_axis = l.axes.iter().flatten().map(|&(_, c)| c).min();
        let mut arc_used = false;
        let plan = match first_axis {
            Some(column) if !axes_used => {
                let plan = self.plan_move(&l, machine_coordinates, column, &mut arc_used, &mut say);
                if let Some(Plan::Arc { .. }) = plan {
                    p_used = true;
                }
                plan.unwrap_or(Plan::None)
            }
            _ => Plan::None,
        };
        if !arc_used {
            for (letter, word) in [
                (b'I', l.center[0]),
                (b'J', l.center[1]),
                (b'K', l.center[2]),
            ]
            .into_iter()
            .chain([(b'R', l.r)])
            {
                if let Some((_, column)) = word {
                    say((column, Kind::UnusedWord(letter)));
                }
            }
        }
        if let (false, Some((_, column))) = (p_used, l.p) {
            say((column, Kind::UnusedWord(b'P')));
        }
        if end {
            self.ended = true;
        }
        plan
    }

    /// Metres (or radians) per unit of axis `i` in the current units.
    fn scale(&self, i: usize) -> f64 {
        if i < 3 {
            self.unit_m
        } else {
            RAD_PER_DEG
        }
    }

    /// The machine position of the program's origin: the work offset, plus the `G92`
    /// offset unless `machine` (`G53`) or suspended.
    fn work_offset(&self, machine: bool) -> [f64; 5] {
        if machine {
            return [0.0; 5];
        }
        let mut offset = self
            .config
            .work_offsets
            .get(self.system)
            .copied()
            .unwrap_or([0.0; 5]);
        if self.g92_on {
            for (o, g) in offset.iter_mut().zip(self.g92) {
                *o += g;
            }
        }
        offset
    }

    /// The move of a line with axis words (first at `column`), checked; `None` after
    /// a reported error.
    fn plan_move(
        &mut self,
        l: &Line,
        machine: bool,
        column: u32,
        arc_used: &mut bool,
        say: &mut impl FnMut((u32, Kind)),
    ) -> Option<Plan> {
        let Some(motion) = self.motion else {
            say((column, Kind::NoMotionMode));
            return None;
        };
        let offset = self.work_offset(machine);
        let start = self.position;
        let mut target = start;
        for (i, t) in target.iter_mut().enumerate() {
            if let (Some(Some((v, column))), Some(&off)) = (l.axes.get(i), offset.get(i)) {
                let v = v * self.scale(i);
                let new = if self.incremental && !machine {
                    *t + v
                } else {
                    v + off
                };
                if !new.is_finite() {
                    say((*column, Kind::NotFinite));
                    return None;
                }
                *t = new;
            }
        }
        let motion_column = l.g.get(1).copied().flatten().map_or(column, |(_, c)| c);
        let feed_m_s = match (motion, self.feed_m_s) {
            (Motion::Rapid, f) => f.unwrap_or(0.0),
            (_, _) if self.inverse_time => {
                say((motion_column, Kind::InverseTimeMove));
                return None;
            }
            (_, None) => {
                say((motion_column, Kind::MissingFeed));
                return None;
            }
            (_, Some(f)) => f,
        };
        self.position = target;
        let clockwise = match motion {
            Motion::Rapid | Motion::Feed => {
                let kind = if motion == Motion::Rapid {
                    MoveKind::Rapid
                } else {
                    MoveKind::Feed
                };
                return Some(Plan::Line {
                    target,
                    kind,
                    feed_m_s,
                });
            }
            Motion::Clockwise => true,
            Motion::CounterClockwise => false,
        };
        *arc_used = true;
        if self.line_by_line {
            say((motion_column, Kind::ArcNotLineByLine));
            return None;
        }
        let [a0, a1, normal] = self.plane;
        let pick = |v: [f64; 5]| {
            [
                v.get(a0).copied().unwrap_or(0.0),
                v.get(a1).copied().unwrap_or(0.0),
            ]
        };
        let in_plane = l.axes.get(a0).copied().flatten().is_some()
            || l.axes.get(a1).copied().flatten().is_some();
        let center_words = [l.center.get(a0), l.center.get(a1)];
        let has_center = center_words.iter().any(|w| matches!(w, Some(Some(_))));
        if let Some(Some((_, column))) = l.center.get(normal) {
            say((
                *column,
                Kind::UnusedWord(b"IJK".get(normal).copied().unwrap_or(b'K')),
            ));
            return None;
        }
        let turns = match l.p {
            None => 1,
            Some((p, _)) if (1.0..=1e6).contains(&p) && libm::trunc(p) == p => p as u32,
            Some((_, column)) => {
                say((column, Kind::MalformedNumber));
                return None;
            }
        };
        if !in_plane || has_center == l.r.is_some() {
            say((motion_column, Kind::ArcUndefined));
            return None;
        }
        let arc = match l.r {
            Some((r, _)) => {
                arc::of_radius(pick(start), pick(target), r * self.unit_m, clockwise, turns)
            }
            None => {
                let mut center = pick(start);
                let off = pick(offset);
                for (k, (c, word)) in center.iter_mut().zip(center_words).enumerate() {
                    let v = word.copied().flatten().map_or(0.0, |(v, _)| v) * self.unit_m;
                    *c = if self.absolute_centers {
                        v + off.get(k).copied().unwrap_or(0.0)
                    } else {
                        *c + v
                    };
                }
                arc::about_center(pick(start), pick(target), center, clockwise, turns)
            }
        };
        let checked = arc.and_then(|arc| Ok((arc, arc.chords(self.config.chord_tolerance_m)?)));
        match checked {
            Ok((arc, chords)) => Some(Plan::Arc {
                start,
                target,
                arc,
                chords,
                feed_m_s,
            }),
            Err(kind) => {
                say((motion_column, kind));
                None
            }
        }
    }

    /// Gives out the points of a clean line's move (the state already after it).
    pub(super) fn emit(
        &mut self,
        line: u32,
        plan: Plan,
        emit: &mut (impl FnMut(&GcodePoint) -> bool + ?Sized),
        report: &mut impl FnMut(u32, Kind),
    ) {
        let (spindle, spindle_s) = (self.spindle, self.spindle_s);
        let point = |p: [f64; 5], kind, feed_m_s, dwell_s| {
            let [x, y, z, a, b] = p;
            GcodePoint {
                position_m: [x, y, z],
                angles_rad: [a, b],
                feed_m_s,
                kind,
                line,
                spindle,
                spindle_s,
                dwell_s,
            }
        };
        let dwell_s = self.dwell_s;
        let mut give = |p: &GcodePoint, full: &mut bool| {
            if *full {
                return false;
            }
            if !emit(p) {
                *full = true;
                report(0, Kind::TooManyPoints);
                return false;
            }
            true
        };
        let mut full = self.full;
        match plan {
            Plan::None => {}
            Plan::Line {
                target,
                kind,
                feed_m_s,
            } => {
                give(&point(target, kind, feed_m_s, dwell_s), &mut full);
                self.dwell_s = 0.0;
            }
            Plan::Arc {
                start,
                target,
                arc,
                chords,
                feed_m_s,
            } => {
                let [a0, a1, _] = self.plane;
                for k in 1..=chords {
                    let u = f64::from(k) / f64::from(chords);
                    let mut p = target;
                    if k < chords {
                        for (q, (s, t)) in p.iter_mut().zip(start.iter().zip(target)) {
                            *q = s + u * (t - s);
                        }
                        let [c0, c1] = arc.at(u);
                        if let Some(q) = p.get_mut(a0) {
                            *q = c0;
                        }
                        if let Some(q) = p.get_mut(a1) {
                            *q = c1;
                        }
                    }
                    let dwell = if k == 1 { dwell_s } else { 0.0 };
                    if !give(&point(p, MoveKind::Feed, feed_m_s, dwell), &mut full) {
                        break;
                    }
                }
                self.dwell_s = 0.0;
            }
        }
        self.full = full;
    }
}
