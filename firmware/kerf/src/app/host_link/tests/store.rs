//! Saved settings through the link: `Save` writes them to the store, a reset with the
//! same flash reads them back (as `Set`s would be), sends them to the supervisor at
//! the first tick, and `Status` says where they came from.

use super::*;
use crate::app::settings_store::{Loaded, SettingsPersist, SettingsStore};
use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashErrorKind, ReadNorFlash};
use std::boxed::Box;
use std::sync::{Arc, Mutex};

/// Flash in RAM that two stores can share (the machine before and after a reset).
#[derive(Clone)]
struct SharedRam(Arc<Mutex<Vec<u8>>>);

impl ErrorType for SharedRam {
    type Error = NorFlashErrorKind;
}

impl ReadNorFlash for SharedRam {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let at = offset as usize;
        let ram = self.0.lock().unwrap();
        bytes.copy_from_slice(
            ram.get(at..at + bytes.len())
                .ok_or(NorFlashErrorKind::OutOfBounds)?,
        );
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.0.lock().unwrap().len()
    }
}

impl NorFlash for SharedRam {
    const WRITE_SIZE: usize = 8;
    const ERASE_SIZE: usize = 32;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        self.0.lock().unwrap()[from as usize..to as usize].fill(0xFF);
        Ok(())
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let at = offset as usize;
        for (b, &new) in self.0.lock().unwrap()[at..at + bytes.len()]
            .iter_mut()
            .zip(bytes)
        {
            *b &= new;
        }
        Ok(())
    }
}

/// A store over `ram` that lives as long as any link (a board keeps it in a static).
fn store(ram: &SharedRam) -> &'static mut SettingsStore<SharedRam> {
    Box::leak(Box::new(SettingsStore::new(ram.clone(), 0, 1024).unwrap()))
}

fn status(rig: &mut Rig<'_>, seq: u16) -> std::string::String {
    match rig.exchange(&frame(seq, Request::Status), 0).as_slice() {
        [Got::Reply(_, text)] => text.clone(),
        other => panic!("{other:?}"),
    }
}

#[test]
fn saved_settings_come_back_after_a_reset_and_reach_the_machine() {
    let ram = SharedRam(Arc::new(Mutex::new(std::vec![0xFF; 2048])));
    with_rig(|rig| {
        assert_eq!(rig.link.attach_store(store(&ram)), SettingsOrigin::Presets);
        assert!(status(rig, 1).contains("settings: Presets"));
        let set = Request::Set {
            path: "/gain",
            value: b"3.5",
        };
        assert_eq!(rig.exchange(&frame(2, set), 2), [reply(2, "Ack")]);
        assert_eq!(rig.exchange(&frame(3, Request::Save), 0), [reply(3, "Ack")]);
        // Saved again with another value: the newest copy is the one read back.
        let set = Request::Set {
            path: "/limits/speed_m_s",
            value: b"0.02",
        };
        assert_eq!(rig.exchange(&frame(4, set), 2), [reply(4, "Ack")]);
        assert_eq!(rig.exchange(&frame(5, Request::Save), 0), [reply(5, "Ack")]);
    });
    // After the reset: the presets, until the store is attached.
    with_rig(|rig| {
        assert_eq!(rig.supervisor.machine().gain, 0.0);
        let origin = rig.link.attach_store(store(&ram));
        assert_eq!(
            origin,
            SettingsOrigin::Saved {
                sequence: 2,
                skipped: 0
            }
        );
        assert_eq!(rig.link.settings().gain, 3.5);
        assert_eq!(rig.link.settings().limits.speed_m_s, 0.02);
        // The first tick sends them to the machine; the report answers no request.
        let heard = rig.exchange(&[], 2);
        assert!(
            heard.iter().all(|g| matches!(g, Got::Telemetry(_))),
            "{heard:?}"
        );
        assert_eq!(rig.supervisor.machine().gain, 3.5);
        assert!(status(rig, 1).contains("settings: Saved { sequence: 2, skipped: 0 }"));
        let get = Request::Get {
            path: "/limits/speed_m_s",
        };
        assert_eq!(
            rig.exchange(&frame(2, get), 0),
            [reply(2, "Value { value: [48, 46, 48, 50] }")]
        );
    });
}

#[test]
fn a_saved_value_the_machine_no_longer_takes_keeps_its_preset() {
    let ram = SharedRam(Arc::new(Mutex::new(std::vec![0xFF; 2048])));
    // A copy from an older image: a path it no longer has, a value out of range now,
    // a line that is not one.
    let text = b"/gain=4\n/old/path=1\n/limits/speed_m_s=-1\nnot a setting\n";
    SettingsStore::new(ram.clone(), 0, 1024)
        .unwrap()
        .save(text)
        .unwrap();
    with_rig(|rig| {
        let origin = rig.link.attach_store(store(&ram));
        assert_eq!(
            origin,
            SettingsOrigin::Saved {
                sequence: 1,
                skipped: 3
            }
        );
        assert_eq!(rig.link.settings().gain, 4.0);
        assert_eq!(
            rig.link.settings().limits.speed_m_s,
            SETTINGS.limits.speed_m_s
        );
    });
}

#[test]
fn without_a_store_save_is_refused_and_status_says_so() {
    with_rig(|rig| {
        assert_eq!(
            rig.exchange(&frame(1, Request::Save), 0),
            [reply(1, "Refused(NoStore)")]
        );
        assert!(status(rig, 2).contains("settings: NoStore"));
    });
}

#[test]
fn settings_too_large_for_the_store_are_refused_and_the_copy_before_kept() {
    // Two slots of 32 bytes: 16 for the text, which holds `/gain=4` and not the
    // toy's two settings.
    let ram = SharedRam(Arc::new(Mutex::new(std::vec![0xFF; 64])));
    SettingsStore::new(ram.clone(), 0, 32)
        .unwrap()
        .save(b"/gain=4\n")
        .unwrap();
    let tiny = || Box::leak(Box::new(SettingsStore::new(ram.clone(), 0, 32).unwrap()));
    with_rig(|rig| {
        let origin = rig.link.attach_store(tiny());
        assert_eq!(
            origin,
            SettingsOrigin::Saved {
                sequence: 1,
                skipped: 0
            }
        );
        assert_eq!(
            rig.exchange(&frame(1, Request::Save), 0),
            [reply(1, "Refused(StoreFailed)")]
        );
    });
    with_rig(|rig| {
        let origin = rig.link.attach_store(tiny());
        assert_eq!(
            origin,
            SettingsOrigin::Saved {
                sequence: 1,
                skipped: 0
            }
        );
        assert_eq!(rig.link.settings().gain, 4.0);
    });
}

/// A store whose save restarts the machine (a board's), over `ram`.
struct Restarting(SettingsStore<SharedRam>);

impl SettingsPersist for Restarting {
    fn save(&mut self, payload: &[u8]) -> Option<u32> {
        self.0.save(payload).ok()
    }
    fn load(&mut self, payload: &mut [u8]) -> Option<Loaded> {
        self.0.load(payload).ok()
    }
    fn restarts(&self) -> bool {
        true
    }
}

/// A board's save stops the control period: refused while a job runs, taken at rest;
/// an emulated machine's store saves in any mode.
#[test]
fn a_save_that_restarts_the_machine_waits_until_it_is_at_rest() {
    for restarts in [true, false] {
        let ram = SharedRam(Arc::new(Mutex::new(std::vec![0xFF; 2048])));
        with_rig(|rig| {
            let plain = SettingsStore::new(ram.clone(), 0, 1024).unwrap();
            let attached: &'static mut (dyn SettingsPersist + Send) = if restarts {
                Box::leak(Box::new(Restarting(plain)))
            } else {
                Box::leak(Box::new(plain))
            };
            rig.link.attach_store(attached);
            upload(rig, &points_job(150), 10);
            rig.exchange(&frame(30, Request::JobCommit), 1);
            let run = rig.exchange(&frame(31, Request::Start), 5);
            assert!(run.contains(&reply(31, "Ack")), "{run:?}");
            let during = rig.exchange(&frame(32, Request::Save), 0);
            let expected = if restarts {
                "Refused(InvalidInMode)"
            } else {
                "Ack"
            };
            assert_eq!(during, [reply(32, expected)], "restarts: {restarts}");
            let stop = rig.exchange(&frame(33, Request::Stop), 5);
            assert!(stop.contains(&reply(33, "Ack")), "{stop:?}");
            let after = rig.exchange(&frame(34, Request::Save), 0);
            assert_eq!(after, [reply(34, "Ack")], "restarts: {restarts}");
        });
    }
}
