//! Settings kept across resets by the host link: the settings tree as text, one
//! `path=value` line per leaf (the value as `Get` gives it), written to the machine's
//! store on [`Request::Save`](crate::codec::link::Request::Save) and read back at
//! power-up as `Set` takes them, each value checked with the ones before it as a
//! configuration (a value the machine no longer takes is left at its preset and
//! counted).

use super::{LinkMachine, SettingPath, SETTINGS_DEPTH, VALUE_BYTES};
use crate::app::supervisor::Command;
use heapless::spsc::Producer;
use miniconf::{json_core, NodeIter, TreeSchema};

/// Bytes of the settings as saved: every leaf's path and value as text (the largest
/// tree, ARROW's eleven gains, takes some 330).
pub const SAVED_BYTES: usize = 1008;

/// How a machine's settings are written as text ([`write_text`] of its type).
pub(super) type WriteText<S> = fn(&S, &mut heapless::Vec<u8, SAVED_BYTES>) -> Option<()>;

/// How restored settings go to a machine's supervisor ([`restore`] of its type).
pub(super) type Restore<M> =
    fn(&<M as LinkMachine>::Settings, f64, &mut Producer<'_, Command<M>>) -> bool;

/// Every leaf of `settings` as `path=value\n` into `out`; `None` when they do not
/// fit or a leaf cannot be read.
pub(super) fn write_text<M: LinkMachine>(
    settings: &M::Settings,
    out: &mut heapless::Vec<u8, SAVED_BYTES>,
) -> Option<()> {
    for path in NodeIter::<SettingPath, SETTINGS_DEPTH>::new(M::Settings::SCHEMA) {
        let path = path.ok()?;
        let mut value = [0u8; VALUE_BYTES];
        let n = json_core::get(settings, path.as_ref(), &mut value).ok()?;
        out.extend_from_slice(path.as_ref().as_bytes()).ok()?;
        out.push(b'=').ok()?;
        out.extend_from_slice(value.get(..n)?).ok()?;
        out.push(b'\n').ok()?;
    }
    Some(())
}

/// Applies the lines of `text` to `settings`, each kept only if the settings with it
/// still make coefficients at `period_s`; how many lines were not taken.
pub(super) fn read_text<M: LinkMachine>(
    settings: &mut M::Settings,
    text: &[u8],
    period_s: f64,
) -> u16 {
    let mut skipped = 0u16;
    for line in text.split(|&b| b == b'\n').filter(|l| !l.is_empty()) {
        let mut parts = line.splitn(2, |&b| b == b'=');
        let mut candidate = *settings;
        let taken = match (parts.next().map(core::str::from_utf8), parts.next()) {
            (Some(Ok(path)), Some(value)) => {
                json_core::set(&mut candidate, path, value).is_ok()
                    && M::coefficients(&candidate, period_s).is_ok()
            }
            _ => false,
        };
        if taken {
            *settings = candidate;
        } else {
            skipped = skipped.saturating_add(1);
        }
    }
    skipped
}

/// Sends `settings` (restored, each value checked) to the supervisor as coefficients
/// at `period_s`; whether they are gone (queued, or past sending: they do not make
/// coefficients).
pub(super) fn restore<M: LinkMachine>(
    settings: &M::Settings,
    period_s: f64,
    commands: &mut Producer<'_, Command<M>>,
) -> bool {
    M::coefficients(settings, period_s).map_or(true, |c| {
        commands.enqueue(Command::ChangeSettings(c)).is_ok()
    })
}
