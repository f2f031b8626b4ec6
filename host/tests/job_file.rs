//! The job file: written, read back (from disk too), and refused with a typed error
//! when damaged.

use kerf::trajectory::efd::Efd;
use kerf_host::job::{
    Job, JobFileError, HEADER_BYTES as HEADER_LEN, JOB_FORMAT_VERSION as FORMAT_VERSION,
};

fn jobs() -> Vec<Job> {
    vec![
        Job::Efd {
            centre_m: [1e-4, -2e-4],
            coefficients: vec![[6e-3, 0.0, 0.0, 6e-3], [1e-4, -2e-5, 3e-5, 4e-4]],
        },
        Job::Path {
            points_m: vec![[0.0, 0.0], [1e-3, 2e-3], [3e-3, 1e-3], [4e-3, 0.0]],
        },
        Job::Gcode {
            text: b"G21 G90\nG0 X0 Y500 Z0\nG1 X10 F600\n".to_vec(),
        },
    ]
}

#[test]
fn every_kind_round_trips_through_a_file() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    for (i, job) in jobs().into_iter().enumerate() {
        let path = dir.join(format!("round_trip_{i}.kjob"));
        std::fs::write(&path, job.to_bytes().unwrap()).unwrap();
        let back = Job::from_bytes(&std::fs::read(&path).unwrap()).unwrap();
        assert_eq!(back, job);
    }
}

#[test]
fn an_efd_job_loads_as_the_firmware_loads_it() {
    let Job::Efd {
        centre_m,
        coefficients,
    } = Job::from_bytes(&jobs()[0].to_bytes().unwrap()).unwrap()
    else {
        panic!("kind");
    };
    let wide: Vec<[f64; 4]> = coefficients.iter().map(|c| c.map(f64::from)).collect();
    let efd = Efd::<f32, 30>::from_coefficients(centre_m.map(f64::from), &wide).unwrap();
    assert_eq!(efd.harmonics(), 2);
}

#[test]
fn a_flipped_byte_anywhere_is_refused_and_in_the_payload_by_the_crc() {
    for job in jobs() {
        let good = job.to_bytes().unwrap();
        for at in 0..good.len() {
            for bit in [0x01u8, 0x80] {
                let mut bad = good.clone();
                bad[at] ^= bit;
                let e = Job::from_bytes(&bad).expect_err("flipped byte accepted");
                if (HEADER_LEN..good.len()).contains(&at) {
                    assert_eq!(e, JobFileError::Crc, "byte {at}");
                }
            }
        }
    }
}

#[test]
fn damaged_headers_get_their_own_errors() {
    let good = jobs()[1].to_bytes().unwrap();
    assert_eq!(Job::from_bytes(&good[..10]), Err(JobFileError::Truncated));
    let mut bad = good.clone();
    bad[0] = b'X';
    assert_eq!(Job::from_bytes(&bad), Err(JobFileError::Magic));
    let mut bad = good.clone();
    bad[4] = FORMAT_VERSION + 1;
    assert_eq!(
        Job::from_bytes(&bad),
        Err(JobFileError::Version(FORMAT_VERSION + 1))
    );
    let e = Job::from_bytes(&good[..good.len() - 1]).unwrap_err();
    assert_eq!(e, JobFileError::Truncated);
    let mut longer = good.clone();
    longer.push(0);
    let e = Job::from_bytes(&longer).unwrap_err();
    assert_eq!(e, JobFileError::TrailingBytes);
}
