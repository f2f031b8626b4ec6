//! The bad-input sweep ([`host_tests::bad_input`]): the DCT, SDCT, packets and the
//! signal stream.

use host_tests::bad_input::{finite, refused_or, sweep, Kind, Out, Sweep};
use kerf::app::stream::SignalSender;
use kerf::codec::dct::Dct;
use kerf::codec::packet::{self, PacketDecoder};
use kerf::codec::sdct::{Block, SdctConfig, SdctDecoder, SdctEncoder, Selection};
use kerf::hal::{FrameLink, LinkBusy};

// ---------------------------------------------------------------------------------
// codec

#[derive(Default)]
struct Loopback {
    frames: std::collections::VecDeque<Vec<u8>>,
}

impl FrameLink for Loopback {
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        self.frames.push_back(frame.to_vec());
        Ok(())
    }
    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        let frame = self.frames.pop_front()?;
        let n = frame.len().min(buf.len());
        buf[..n].copy_from_slice(&frame[..n]);
        Some(n)
    }
}

fn signal(k: usize) -> f32 {
    (0.3 * k as f32).sin() * 0.01
}

fn codec_sites(s: &mut Sweep) {
    const M: &str = "codec";
    let dct = Dct::<32>::new().unwrap();
    s.site(M, "Dct::forward(x[5])", "f32", Kind::Kernel, |v| {
        let mut x: [f32; 32] = core::array::from_fn(signal);
        x[5] = v as f32;
        dct.forward(&mut x);
        finite(x)
    });
    s.site(M, "Dct::inverse(c[7])", "f32", Kind::Kernel, |v| {
        let mut c: [f32; 32] = core::array::from_fn(signal);
        c[7] = v as f32;
        dct.inverse(&mut c);
        finite(c)
    });
    s.site(
        M,
        "Dct::forward_q15/inverse_q15(x[5] saturated)",
        "-",
        Kind::Step,
        |v| {
            let mut x: [i16; 32] = core::array::from_fn(|k| (signal(k) * 3e6) as i16);
            x[5] = v as i16;
            let mut c = [0i32; 32];
            dct.forward_q15(&x, &mut c);
            c[9] = (v * 65536.0) as i32;
            let mut back = [0i16; 32];
            dct.inverse_q15(&c, &mut back);
            Out::Finite
        },
    );
    let encoder = SdctEncoder::<32>::new(&SdctConfig {
        m: 8,
        selection: Selection::Largest,
    })
    .unwrap();
    let decoder = SdctDecoder::<32>::new().unwrap();
    s.site(
        M,
        "SdctEncoder::encode(x[3]) + packet + decode",
        "f32",
        Kind::Step,
        |v| {
            let mut x: [f32; 32] = core::array::from_fn(signal);
            x[3] = v as f32;
            refused_or(encoder.encode(&x), |block| {
                let mut buf = [0u8; 256];
                refused_or(packet::encode(&block, 7, 123, &mut buf), |n| {
                    refused_or(packet::parse(&buf[..n]), |p| {
                        refused_or(p.to_block::<32>(), |b| {
                            let mut out = [0f32; 32];
                            decoder.decode(&b, &mut out);
                            finite(out)
                        })
                    })
                })
            })
        },
    );
    s.site(
        M,
        "packet::encode_parts(coefficient) + parse + decode",
        "f32",
        Kind::Step,
        |v| {
            let mut c: [f32; 32] = core::array::from_fn(signal);
            c[2] = v as f32;
            let mut buf = [0u8; 256];
            refused_or(packet::encode_parts(0b1111_0110, &c, 1, 2, &mut buf), |n| {
                refused_or(packet::parse(&buf[..n]), |p| {
                    refused_or(p.to_block::<32>(), |b| {
                        let mut out = [0f32; 32];
                        decoder.decode(&b, &mut out);
                        finite(out.into_iter().chain((0..32).map(|k| p.coefficient(k))))
                    })
                })
            })
        },
    );
    s.site(
        M,
        "SdctDecoder::decode(Block::from_parts(c[1]))",
        "f32",
        Kind::Kernel,
        |v| {
            let mut c = [0f32; 32];
            c[1] = v as f32;
            c[4] = 0.1;
            let mut out = [0f32; 32];
            decoder.decode(&Block::from_parts(0b10010, c), &mut out);
            finite(out)
        },
    );
    // Every single-byte corruption of a valid packet (by the value's bit pattern).
    let x: [f32; 32] = core::array::from_fn(signal);
    let block = encoder.encode(&x).unwrap();
    let mut valid = [0u8; 256];
    let len = packet::encode(&block, 9, 77, &mut valid).unwrap();
    for byte in 0..len {
        for pattern in [0x00u8, 0xff, 0x80, 0x7f] {
            s.case(
                M,
                "PacketDecoder::decode(one byte changed)",
                "-",
                Kind::Step,
                byte as f64,
                || {
                    let mut bytes = valid[..len].to_vec();
                    bytes[byte] = pattern;
                    let mut d = PacketDecoder::new();
                    refused_or(d.decode(&bytes), |r| {
                        refused_or(r.packet.to_block::<32>(), |b| {
                            let mut out = [0f32; 32];
                            decoder.decode(&b, &mut out);
                            finite(out)
                        })
                    })
                },
            );
        }
    }
    for cut in 0..=len {
        s.case(
            M,
            "packet::parse(truncated)",
            "-",
            Kind::Step,
            cut as f64,
            || {
                refused_or(packet::parse(&valid[..cut]), |p| {
                    finite((0..32).map(|k| p.coefficient(k)))
                })
            },
        );
    }
    s.site(
        M,
        "SignalSender::push(sample) + SignalReceiver::poll",
        "f32",
        Kind::Step,
        |v| {
            let mut sender = SignalSender::<32>::new(&SdctConfig {
                m: 8,
                selection: Selection::Largest,
            })
            .unwrap();
            let mut receiver = kerf::app::stream::SignalReceiver::<32>::new().unwrap();
            let mut link = Loopback::default();
            let mut out = Out::Finite;
            for k in 0..64 {
                let sample = if k == 10 { v as f32 } else { signal(k) };
                out = out.and(refused_or(sender.push(sample, &mut link), |_| Out::Finite));
            }
            let mut buf = [0f32; 32];
            while let Some(r) = receiver.poll(&mut link, &mut buf) {
                out = out.and(refused_or(r, |_| finite(buf)));
            }
            out
        },
    );
}

#[test]
fn bad_input_codec() {
    sweep(|s| {
        codec_sites(s);
    });
}
