//! Job files (`KRFJ`, [`kerf::codec::job`]) as the machine reads them (`job_file`) and
//! as the host reads them (`host_job`), and G-code programs as ARROW loads them
//! (`arrow_gcode`). Seeds are files of the codec's own writer.

use crate::input::same_bits;
use crate::targets::link::octagon_job;
use kerf::codec::job::{
    with_settings, write_efd, write_gcode, write_moves, write_points, write_recording,
    write_schedule, Continuity, CutLaser, CutSettings, JobFile, HEADER_BYTES,
};
use kerf::codec::link::crc32;
use kerf::kinematics::arrow::{ArrowConfig, ArrowGeometry};
use kerf::machines::arrow::job::ArrowJobConfig;
use kerf::machines::arrow::product::{Job as ArrowJob, PROGRAM_POINTS};
use kerf::trajectory::gcode::GcodePoint;
use kerf_host::job::Job as HostJob;

/// The file of an input: one flag byte, then the file. With bit 0 of the flag set the
/// last four bytes are overwritten with the CRC-32 of the bytes before them, so that
/// mutations reach the reserved-byte, count and finiteness checks.
fn file_of(data: &[u8]) -> Option<Vec<u8>> {
    let (flags, file) = data.split_first()?;
    let mut file = file.to_vec();
    if flags & 1 == 1 && file.len() >= 4 {
        let n = file.len() - 4;
        let crc = crc32(&file[..n]);
        file[n..].copy_from_slice(&crc.to_le_bytes());
    }
    Some(file)
}

/// `job_file`: the machine's reader. A file read has the length its kind and count
/// (and its version's cut settings) say, only finite numbers, nothing past its count,
/// and writing its numbers and settings again with the codec's writers gives the same
/// bytes (a version 2 file whose settings are all the machine's is written as version
/// 1, the same file without its block). Returns 1 for a file read.
pub fn job_file(data: &[u8]) -> usize {
    let Some(bytes) = file_of(data) else {
        return 0;
    };
    let Ok(file) = JobFile::read(&bytes) else {
        return 0;
    };
    let n = file.count();
    let mut out = vec![0u8; bytes.len()];
    let (body, written) = match file {
        JobFile::Efd { centre_m, .. } => {
            let harmonics: Vec<[f32; 4]> = (0..n).map(|k| file.harmonic(k).unwrap()).collect();
            assert!(file.harmonic(n).is_none());
            let numbers: Vec<f32> = centre_m
                .iter()
                .chain(harmonics.iter().flatten())
                .copied()
                .collect();
            assert!(numbers.iter().all(|v| v.is_finite()), "{numbers:?}");
            let wide: Vec<[f64; 4]> = harmonics.iter().map(|h| h.map(f64::from)).collect();
            (
                8 + 16 * n,
                write_efd(centre_m.map(f64::from), &wide, &mut out),
            )
        }
        JobFile::Points { .. } => {
            let points: Vec<[f32; 2]> = (0..n).map(|k| file.point(k).unwrap()).collect();
            assert!(file.point(n).is_none());
            assert!(points.iter().flatten().all(|v| v.is_finite()), "{points:?}");
            let wide: Vec<[f64; 2]> = points.iter().map(|p| p.map(f64::from)).collect();
            (8 * n, write_points(&wide, &mut out))
        }
        JobFile::Gcode { text } => (text.len(), write_gcode(text, &mut out)),
        JobFile::Recording { bytes } => (bytes.len(), write_recording(bytes, &mut out)),
        JobFile::Schedule { .. } => {
            let steps: Vec<[f32; 2]> = (0..n).map(|k| file.step(k).unwrap()).collect();
            assert!(file.step(n).is_none());
            assert!(steps.iter().flatten().all(|v| v.is_finite()), "{steps:?}");
            let wide: Vec<[f64; 2]> = steps.iter().map(|p| p.map(f64::from)).collect();
            (8 * n, write_schedule(&wide, &mut out))
        }
        JobFile::Moves { .. } => {
            let points: Vec<[f32; 3]> = (0..n).map(|k| file.move_point(k).unwrap()).collect();
            assert!(file.move_point(n).is_none());
            assert!(points.iter().flatten().all(|v| v.is_finite()), "{points:?}");
            let wide: Vec<[f64; 3]> = points.iter().map(|p| p.map(f64::from)).collect();
            (12 * n, write_moves(&wide, &mut out))
        }
    };
    let settings = file.settings();
    let block = match bytes[4] {
        1 => 0,
        _ => 12,
    };
    assert_eq!(bytes.len(), HEADER_BYTES + block + body + 4);
    let v1 = written.expect("a file read is written");
    assert_eq!(v1, bytes.len() - block);
    if settings == CutSettings::MACHINE && block == 0 {
        assert_eq!(out[..v1], bytes[..], "the file written again differs");
        return 1;
    }
    if settings == CutSettings::MACHINE {
        // Version 1 again: the same header but its version, the same body.
        assert_eq!((&out[..4], &out[5..12]), (&bytes[..4], &bytes[5..12]));
        assert_eq!(out[12..v1 - 4], bytes[24..bytes.len() - 4]);
        return 1;
    }
    let mut again = vec![0u8; bytes.len()];
    let n = with_settings(&out[..v1], &settings, &mut again).expect("settings read are written");
    assert_eq!(again[..n], bytes[..], "the file written again differs");
    1
}

/// `host_job`: the host's reader. A job read writes back to the same bytes, with its
/// numbers bit for bit; the file twice over reads as two parts that are its bytes
/// again; the machine's check on the host (`kerf check`) answers any file without a
/// panic, and an accepted job's duration is finite. Returns 1 for a job read.
pub fn host_job(data: &[u8]) -> usize {
    let Some(bytes) = file_of(data) else {
        return 0;
    };
    if let Ok(checked) = kerf_host::check::check(&bytes, None) {
        assert!(checked.duration_s.is_finite() && checked.duration_s > 0.0);
    }
    let Ok(job) = HostJob::from_bytes(&bytes) else {
        return 0;
    };
    let twice = [bytes.as_slice(), bytes.as_slice()].concat();
    let parts = kerf_host::job::split(&twice).expect("a job file twice over is two parts");
    assert_eq!(parts, [bytes.as_slice(), bytes.as_slice()]);
    // The host's job holds the geometry; the settings ride in the file.
    let settings = JobFile::read(&bytes).expect("read above").settings();
    let again =
        kerf_host::job::with_settings(&job.to_bytes().expect("a job read is written"), &settings)
            .expect("settings read are written");
    if bytes[4] == 1 || settings != CutSettings::MACHINE {
        assert_eq!(again, bytes);
    }
    let back = HostJob::from_bytes(&again).expect("and read again");
    assert_eq!(back.kind(), job.kind());
    match (&job, &back) {
        (
            HostJob::Efd {
                centre_m: a,
                coefficients: ca,
            },
            HostJob::Efd {
                centre_m: b,
                coefficients: cb,
            },
        ) => {
            assert!(same_bits(a, b));
            assert!(same_bits(ca.as_flattened(), cb.as_flattened()));
        }
        (HostJob::Path { points_m: a }, HostJob::Path { points_m: b }) => {
            assert!(same_bits(a.as_flattened(), b.as_flattened()));
        }
        (HostJob::Gcode { text: a }, HostJob::Gcode { text: b }) => assert_eq!(a, b),
        (HostJob::Recording { bytes: a }, HostJob::Recording { bytes: b }) => assert_eq!(a, b),
        (HostJob::Schedule { steps: a }, HostJob::Schedule { steps: b }) => {
            assert!(same_bits(a.as_flattened(), b.as_flattened()));
        }
        (HostJob::Moves { points: a }, HostJob::Moves { points: b }) => {
            assert!(same_bits(a.as_flattened(), b.as_flattened()));
        }
        _ => unreachable!("the kinds agree"),
    }
    1
}

/// Seeds of [`job_file`] and [`host_job`]: a file of each kind, as written (flag 0)
/// and for the CRC patch (flag 1).
pub fn job_file_seeds() -> Vec<Vec<u8>> {
    let mut files = vec![octagon_job()];
    let mut out = vec![0u8; 2048];
    let points = [[0.0, 0.0], [1e-3, 2e-3], [4e-3, -1e-3], [6e-3, 0.0]];
    let n = write_points(&points, &mut out).unwrap();
    files.push(out[..n].to_vec());
    // The octagon with cut settings (version 2).
    let settings = CutSettings {
        speed_m_s: Some(5e-3),
        laser: Some(CutLaser::EnergyJPerM(800.0)),
        passes: Some(2),
        ..CutSettings::MACHINE
    };
    let n = with_settings(&octagon_job(), &settings, &mut out).unwrap();
    files.push(out[..n].to_vec());
    let n = write_gcode(super::codec::GCODE_SEEDS[1].as_bytes(), &mut out).unwrap();
    files.push(out[..n].to_vec());
    let n = write_recording(b"KRFR\x01\x00", &mut out).unwrap();
    files.push(out[..n].to_vec());
    let n = write_schedule(&[[1.0, 6.0], [2.0, 4.0], [1.5, 4.0]], &mut out).unwrap();
    files.push(out[..n].to_vec());
    // A square of moves, with a pass more (version 2).
    let square = [
        [-2e-3, -2e-3, 0.0],
        [2e-3, -2e-3, 8e-3],
        [2e-3, 2e-3, 4e-3],
        [-2e-3, 2e-3, 8e-3],
        [-2e-3, -2e-3, 8e-3],
    ];
    let n = write_moves(&square, &mut out).unwrap();
    let moves = out[..n].to_vec();
    let n = with_settings(&moves, &settings, &mut out).unwrap();
    files.push(out[..n].to_vec());
    // The square as a part of a streamed run: its last two points ahead, continuing
    // the part before.
    let streamed = CutSettings {
        continuity: Continuity {
            lookahead_points: 2,
            continues: true,
        },
        ..CutSettings::MACHINE
    };
    let n = with_settings(&moves, &streamed, &mut out).unwrap();
    files.push(moves);
    files.push(out[..n].to_vec());
    files
        .iter()
        .flat_map(|f| [0u8, 1].map(|flag| [&[flag][..], f].concat()))
        .collect()
}

/// `arrow_gcode`: `ArrowJob::from_gcode` on ARROW's preset (in f32, the machine's
/// scalar). A job has at least one move, each with a finite positive length and
/// speed, at least one period, a finite duration and a line of the program; the
/// start's joints are finite. A refusal names a line of the program (0 for none).
/// Returns the moves of a job.
pub fn arrow_gcode(data: &[u8]) -> usize {
    let geometry = ArrowGeometry::<f64>::new(&ArrowConfig::ARROW).expect("ARROW's preset");
    let lines = data.split(|&b| b == b'\n').count() as u32;
    let mut points = Box::new(heapless::Vec::<GcodePoint, PROGRAM_POINTS>::new());
    let mut job = Box::<ArrowJob<f32>>::default();
    match ArrowJob::<f32>::from_gcode(data, &mut points, &geometry, &ArrowJobConfig::ARROW) {
        Ok(j) => *job = j,
        Err(e) => {
            assert!(e.line <= lines, "{e:?}");
            return 0;
        }
    }
    let moves = job.moves();
    assert!(!moves.is_empty());
    assert_eq!(job.period_s(), ArrowJobConfig::ARROW.period_s);
    assert!(job.start_joints_m().iter().all(|q| q.is_finite()));
    for m in moves {
        let plan = &m.plan;
        assert!(plan.length_m.is_finite() && plan.length_m > 0.0, "{plan:?}");
        assert!(
            plan.speed_m_s.is_finite() && plan.speed_m_s > 0.0,
            "{plan:?}"
        );
        assert!(
            plan.periods() > 0 && plan.duration_s().is_finite(),
            "{plan:?}"
        );
        assert!(m.line >= 1 && m.line <= lines, "line {}", m.line);
        assert!(m.spline.points() >= 2);
    }
    moves.len()
}

/// Seeds of [`arrow_gcode`]: the G-code seeds that make ARROW jobs.
pub fn arrow_gcode_seeds() -> Vec<Vec<u8>> {
    let mut seeds = super::codec::gcode_parse_seeds();
    seeds.retain(|s| arrow_gcode(s) > 0);
    seeds
}
