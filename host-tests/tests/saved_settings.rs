//! Settings that stay, on every machine behind its host link: a store holding one
//! saved value (the value the QEMU smoke run changes on that machine) is attached as
//! the link images attach theirs, and the machine starts from it: the link reads the
//! value back as `Get` gives it, and says the settings are the saved copy. A value the
//! machine does not take is left at its preset and counted.

use kerf::app::host_link::{HostLink, LinkMachine};
use kerf::app::settings_store::{RamFlash, SettingsStore};
use kerf::codec::link::SettingsOrigin;
use kerf::machines::delta_slave::product::JOB_LAPS;
use kerf_sim::linked::with_linked_slave;
use kerf_sim::linked_arrow::with_linked_arrow;
use kerf_sim::linked_autofocus::{with_linked_autofocus, CAMERA_SEED};
use kerf_sim::linked_axis::with_linked_axis;
use kerf_sim::linked_grinding::with_linked_grinding;
use kerf_sim::linked_master::{with_linked_master, SAMPLE_JOB};
use kerf_sim::linked_remote_slave::with_linked_remote_slave;
use kerf_sim::scenario::Scenario;
use miniconf::json_core;

/// Two slots of four pages.
const FLASH: usize = 8 * RamFlash::<0>::PAGE;

/// A store whose copy 1 holds `text`, for the link's whole life.
fn store_with(text: &str) -> &'static mut SettingsStore<RamFlash<FLASH>> {
    let slot = (FLASH / 2) as u32;
    let mut store = SettingsStore::new(RamFlash::erased(), 0, slot).unwrap();
    assert_eq!(store.save(text.as_bytes()), Ok(1));
    Box::leak(Box::new(store))
}

/// Attaches a store saying `path=value` and a line the machine does not take; the
/// link then holds `value` at `path` (as `Get` writes it: `shown`).
fn starts_from_saved<M: LinkMachine, const J: usize>(
    link: &mut HostLink<'_, M, J>,
    path: &str,
    value: &str,
    shown: &str,
) {
    let text = format!("{path}={value}\n/no/such/setting=1\n");
    let origin = link.attach_store(store_with(&text));
    assert_eq!(
        origin,
        SettingsOrigin::Saved {
            sequence: 1,
            skipped: 1
        },
        "{path}"
    );
    let mut out = [0u8; 64];
    let n = json_core::get(link.settings(), path, &mut out).unwrap();
    assert_eq!(std::str::from_utf8(&out[..n]).unwrap(), shown, "{path}");
}

#[test]
fn every_machine_starts_from_its_saved_settings() {
    let keops = kerf_sim::slave::SlaveScenario::square();
    with_linked_slave::<f64, _>(&keops, JOB_LAPS, |m| {
        starts_from_saved(m.link_mut(), "/slave/dob/bandwidth_hz", "120", "120.0")
    })
    .unwrap();
    let arrow = kerf_sim::arrow::ArrowScenario::smoke();
    with_linked_arrow::<f64, _>(&arrow, 2.0, |m| {
        starts_from_saved(m.link_mut(), "/parallel/kd", "9000", "9000.0")
    })
    .unwrap();
    with_linked_grinding::<f64, _>(2.0, |m| {
        starts_from_saved(m.link_mut(), "/pid/kp", "8", "8.0")
    })
    .unwrap();
    with_linked_axis::<f64, _>(&Scenario::TRACKING, 2.0, |m| {
        starts_from_saved(m.link_mut(), "/dob/force_limit_n", "0.6", "0.6")
    })
    .unwrap();
    with_linked_autofocus::<f64, _>(CAMERA_SEED, 2.0, |m| {
        starts_from_saved(m.link_mut(), "/law/max_speed_m_s", "0.002", "0.002")
    })
    .unwrap();
    with_linked_master::<f64, _>(SAMPLE_JOB, 2.0, |m| {
        starts_from_saved(m.link_mut(), "/fixture/normal/reaching_rate", "20", "20.0")
    })
    .unwrap();
    with_linked_remote_slave::<f64, _>(2.0, |m| {
        starts_from_saved(m.link_mut(), "/slave/dob/compensate", "false", "false")
    })
    .unwrap();
}
