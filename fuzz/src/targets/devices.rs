//! The grinding cell's device link (`grinding_devices`): the hexapod's GCS replies and
//! the spindle converter's frames as `machines::grinding::devices` reads them, tick by tick.
//! Seeds are the replies of `hal-mock`'s simulated H-824 and converter to the link's
//! own requests.

use crate::input::{Input, Seed};
use hal_mock::hexapod::{HexapodLimits, SimHexapod, REFERENCE_TIME_S};
use hal_mock::spindle::SimSpindle;
use kerf::codec::gcs::{AxisSet, Command};
use kerf::hal::{LinkError, Transact};
use kerf::machines::grinding::devices::{
    DeviceDemand, DeviceFault, DeviceLink, DeviceLinkConfig, DeviceLinkState, HexapodFault,
};
use std::cell::RefCell;

/// A device whose replies come from the fuzz input: per exchange one status byte
/// (7: the link is down, 6: busy, 5: overrun) and a record, the reply.
struct Scripted<'i, 'a> {
    input: &'i RefCell<Input<'a>>,
    requests: Vec<Vec<u8>>,
}

impl Transact for Scripted<'_, '_> {
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError> {
        self.requests.push(request.to_vec());
        let mut input = self.input.borrow_mut();
        let (Some(status), Some(bytes)) = (input.u8(), input.record()) else {
            return Ok(0);
        };
        match status % 8 {
            7 => Err(LinkError::Down),
            6 => Err(LinkError::Busy),
            5 => Err(LinkError::Overrun),
            _ => {
                let n = bytes.len().min(reply.len());
                reply[..n].copy_from_slice(&bytes[..n]);
                Ok(n)
            }
        }
    }
}

/// `grinding_devices`: the device link of G's cell, ticks of a demand (feed
/// f32 m/s, spindle f32 rpm, halt byte) each followed by the devices' replies as the
/// link asks for them (hexapod first, then the spindle). A healthy tick reports a
/// finite position and path; a fault latches (every later tick returns it, and the
/// state holds it); a following error is finite; every GCS command the link writes
/// is one the controller's parser reads. Returns the healthy ticks.
pub fn grinding_devices(data: &[u8]) -> usize {
    let link = DeviceLink::new(&DeviceLinkConfig::PUBLISHED).expect("G's cell");
    let mut state = DeviceLinkState::new();
    let input = RefCell::new(Input::new(data));
    let (mut latched, mut healthy) = (None::<DeviceFault>, 0);
    loop {
        let (feed, rpm, halt) = {
            let mut i = input.borrow_mut();
            match (i.f32(), i.f32(), i.u8()) {
                (Some(feed), Some(rpm), Some(halt)) => (feed, rpm, halt),
                _ => break,
            }
        };
        let demand = DeviceDemand {
            feed_m_s: f64::from(feed),
            spindle_rpm: f64::from(rpm),
            halt: halt & 1 == 1,
        };
        // Both devices read their replies from the one input, in the order asked.
        let mut hexapod = Scripted {
            input: &input,
            requests: Vec::new(),
        };
        let mut spindle = Scripted {
            input: &input,
            requests: Vec::new(),
        };
        let result = link.tick(&mut state, &demand, &mut hexapod, &mut spindle);
        let hexapod_requests = hexapod.requests;
        for request in &hexapod_requests {
            assert!(
                Command::parse(request).is_ok(),
                "{:?}",
                String::from_utf8_lossy(request)
            );
        }
        match (latched, result) {
            (Some(f), r) => assert_eq!(r, Err(f), "a fault stays latched"),
            (None, Ok(report)) => {
                healthy += 1;
                assert!(
                    report.position_mm.is_finite() && report.path_mm.is_finite(),
                    "{report:?}"
                );
                assert_eq!(report.halted, demand.halt);
            }
            (None, Err(fault)) => {
                if let DeviceFault::Hexapod(HexapodFault::Following { error_mm }) = fault {
                    assert!(error_mm.is_finite());
                }
                latched = Some(fault);
            }
        }
        assert_eq!(state.fault(), latched);
    }
    healthy
}

/// The simulated devices answering the link, their replies written down in the
/// harness's layout.
struct Recorded<'s, D> {
    device: D,
    seed: &'s RefCell<Seed>,
}

fn write_reply(seed: &RefCell<Seed>, reply: &[u8]) {
    let s = core::mem::take(&mut *seed.borrow_mut());
    *seed.borrow_mut() = s.u8(0).record(reply);
}

impl Transact for Recorded<'_, SimHexapod> {
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError> {
        let n = self.device.handle(request, reply);
        write_reply(self.seed, &reply[..n]);
        Ok(n)
    }
}

impl Transact for Recorded<'_, SimSpindle> {
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError> {
        // A converter that does not answer sends nothing.
        let answer = self.device.transact(request);
        let answer = answer.as_ref().map_or(&[][..], |a| &a[..]);
        let n = answer.len().min(reply.len());
        reply[..n].copy_from_slice(&answer[..n]);
        write_reply(self.seed, &reply[..n]);
        Ok(n)
    }
}

/// Seeds of [`grinding_devices`]: G's pass (0.1 mm/s, 18 000 rpm) for 30 ticks
/// on the simulated devices, then a halt; and the same with the spindle silenced.
pub fn grinding_devices_seeds() -> Vec<Vec<u8>> {
    let run = |answering: bool| {
        let link = DeviceLink::new(&DeviceLinkConfig::PUBLISHED).unwrap();
        let mut state = DeviceLinkState::new();
        let seed = RefCell::new(Seed::new());
        let mut hexapod = Recorded {
            device: SimHexapod::new(HexapodLimits::H824),
            seed: &seed,
        };
        let mut spindle = Recorded {
            device: SimSpindle::new(),
            seed: &seed,
        };
        spindle.device.answering = answering;
        // Referenced first, as the cell's start-up does.
        let (mut request, mut reply) = ([0u8; 64], [0u8; 64]);
        let n = Command::Frf(AxisSet::EMPTY).encode(&mut request).unwrap();
        hexapod.device.handle(&request[..n], &mut reply);
        hexapod.device.step(REFERENCE_TIME_S + 0.1);
        for k in 0..32 {
            let demand = DeviceDemand {
                feed_m_s: 1e-4,
                spindle_rpm: 18_000.0,
                halt: k >= 30,
            };
            let s = core::mem::take(&mut *seed.borrow_mut());
            *seed.borrow_mut() = s
                .f32(demand.feed_m_s as f32)
                .f32(demand.spindle_rpm as f32)
                .u8(u8::from(demand.halt));
            let _ = link.tick(&mut state, &demand, &mut hexapod, &mut spindle);
            hexapod.device.step(0.01);
            spindle.device.advance(0.01, 0.0);
        }
        seed.into_inner().0
    };
    vec![run(true), run(false)]
}
