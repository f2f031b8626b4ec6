//! SDCT against the conventional first-m DCT codec over representative signals
//! (docs/codec.md §30, T 7.2.3), through the full wire path: f32 DCT, selection,
//! Q15 block-floating-point packet, CRC, parse, zero-fill, inverse DCT.
//!
//! Prints, per block length N and per kept count m: bytes per packet and compression
//! ratio against N raw 16-bit samples, SNR of SDCT and of the baseline at equal m, and
//! the baseline at equal bytes on the wire (it spends SDCT's index bytes on more
//! coefficients). Run with `cargo test -p host-tests --test codec_report -- --nocapture`.
//!
//! Checked: at equal m SDCT's error energy never exceeds the baseline's (Parseval,
//! on the unquantized coefficients of every block).

use host_tests::signals::{self, snr_db, Signal};
use kerf::codec::packet::{self, PacketDecoder, CRC_LEN, HEADER_LEN, MAX_PACKET_LEN};
use kerf::codec::sdct::{Block, SdctConfig, SdctDecoder, SdctEncoder, Selection};

/// Result of streaming one signal through the codec.
struct Run {
    /// Reconstruction through the wire (Q15 coefficients).
    wire: Vec<f64>,
    /// Mean packet size in bytes.
    bytes_per_packet: f64,
    /// Per-block error energy with unquantized f32 coefficients.
    block_error: Vec<f64>,
}

fn run<const N: usize>(x: &[f64], m: usize, selection: Selection) -> Run {
    let enc = SdctEncoder::<N>::new(&SdctConfig { m, selection }).unwrap();
    let dec = SdctDecoder::<N>::new().unwrap();
    let mut rx = PacketDecoder::new();
    let mut wire = Vec::with_capacity(x.len());
    let mut block_error = Vec::new();
    let mut bytes = 0usize;
    for (seq, chunk) in x.chunks_exact(N).enumerate() {
        let samples: [f32; N] = core::array::from_fn(|i| chunk[i] as f32);
        let block = enc.encode(&samples).unwrap();
        let mut direct = [0.0f32; N];
        dec.decode(&block, &mut direct);
        block_error.push(
            chunk
                .iter()
                .zip(&direct)
                .map(|(a, &b)| (a - f64::from(b)).powi(2))
                .sum(),
        );
        let mut buf = [0u8; MAX_PACKET_LEN];
        let len = packet::encode(&block, seq as u16, (seq * N) as u32, &mut buf).unwrap();
        bytes += len;
        let received = rx.decode(&buf[..len]).unwrap();
        assert_eq!(received.gap, 0);
        let block: Block<N> = received.packet.to_block().unwrap();
        let mut y = [0.0f32; N];
        dec.decode(&block, &mut y);
        wire.extend(y.iter().map(|&v| f64::from(v)));
    }
    Run {
        wire,
        bytes_per_packet: bytes as f64 / (x.len() / N) as f64,
        block_error,
    }
}

/// Baseline packet size for m coefficients: header, values, CRC, no index set.
fn baseline_bytes(m: usize) -> usize {
    HEADER_LEN + 2 * m + CRC_LEN
}

fn report<const N: usize>(signals: &[Signal], ms: &[usize]) {
    println!(
        "\nN = {N}: block coding adds N = {N} sample periods of latency ({:.1} ms at {} kHz)",
        N as f64 / signals::FS_HZ * 1e3,
        signals::FS_HZ / 1e3
    );
    println!("raw block = {} bytes (N 16-bit samples)", 2 * N);
    println!(
        "{:<9} {:>3} | {:>6} {:>5} {:>7} | {:>7} | {:>3} {:>6} {:>7} | at equal bytes",
        "signal", "m", "B/pkt", "ratio", "SDCT", "base@m", "m'", "B/pkt", "base@B",
    );
    for s in signals {
        let x = &s.samples;
        for &m in ms {
            let sdct = run::<N>(x, m, Selection::Largest);
            let base = run::<N>(x, m, Selection::First);
            for (k, (es, eb)) in sdct.block_error.iter().zip(&base.block_error).enumerate() {
                // Parseval: equality up to f32 round-off of the block (see kerf's
                // sdct tests for the bound); 1e-9 of the block energy covers it.
                let energy: f64 = x[k * N..(k + 1) * N].iter().map(|v| v * v).sum();
                assert!(
                    es <= &(eb + 1e-9 * energy + 1e-12),
                    "{} N={N} m={m} block {k}",
                    s.name
                );
            }
            // Largest baseline m' whose packets are no bigger than SDCT's mean packet.
            let m_eq = (0..=N)
                .rev()
                .find(|&mb| baseline_bytes(mb) as f64 <= sdct.bytes_per_packet)
                .unwrap_or(0)
                .max(1);
            let base_eq = run::<N>(x, m_eq, Selection::First);
            let (snr_s, snr_b, snr_beq) = (
                snr_db(x, &sdct.wire),
                snr_db(x, &base.wire),
                snr_db(x, &base_eq.wire),
            );
            let winner = if snr_s >= snr_beq { "SDCT" } else { "baseline" };
            println!(
                "{:<9} {:>3} | {:>6.1} {:>5.2} {:>7.1} | {:>7.1} | {:>3} {:>6} {:>7.1} | {winner} by {:.1} dB",
                s.name,
                m,
                sdct.bytes_per_packet,
                (2 * N) as f64 / sdct.bytes_per_packet,
                snr_s,
                snr_b,
                m_eq,
                baseline_bytes(m_eq),
                snr_beq,
                (snr_s - snr_beq).abs()
            );
        }
    }
}

#[test]
fn sdct_against_first_m_at_equal_m_and_equal_bytes() {
    let signals = signals::all();
    report::<32>(&signals, &[2, 4, 8, 16]);
    report::<64>(&signals, &[4, 8, 16, 32]);
}

/// Bytes of one real packet carrying `mask` out of N coefficients.
fn packet_len<const N: usize>(mask: u64) -> usize {
    let block = Block::<N>::from_parts(mask, [0.5; N]);
    let mut buf = [0u8; MAX_PACKET_LEN];
    packet::encode(&block, 0, 0, &mut buf).unwrap()
}

fn sizes<const N: usize>(ms: &[usize]) {
    for &m in ms {
        // SDCT with a non-prefix index set (the top m indices), baseline with 0..m.
        let top = kerf::codec::prefix_mask(m) << (N - m);
        // (m = N is the prefix set either way.)
        let sdct = packet_len::<N>(top);
        let base = packet_len::<N>(kerf::codec::prefix_mask(m));
        assert_eq!(base, baseline_bytes(m));
        let raw = 2 * N;
        println!(
            "{N:>3} {m:>3} | {sdct:>5} {:>6.2} | {base:>5} {:>6.2} | {raw:>4}",
            raw as f64 / sdct as f64,
            raw as f64 / base as f64
        );
    }
}

#[test]
fn bytes_per_packet_and_compression_ratio() {
    println!(
        "\nbytes per packet (header {HEADER_LEN}, CRC {CRC_LEN}) against N raw 16-bit samples"
    );
    println!("  N   m |  SDCT  ratio | first-m ratio |  raw");
    sizes::<8>(&[1, 2, 4, 8]);
    sizes::<16>(&[2, 4, 8, 16]);
    sizes::<32>(&[2, 4, 8, 16, 32]);
    sizes::<64>(&[4, 8, 16, 32, 64]);
}
