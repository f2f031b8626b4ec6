//! GCS codec tests: the bytes of G's commands, every malformed reply's error,
//! and round trips.

use super::reply::*;
use super::*;
use proptest::prelude::*;

fn encoded(command: &Command) -> std::vec::Vec<u8> {
    let mut buf = [0u8; MAX_COMMAND_LEN];
    let len = command.encode(&mut buf).unwrap();
    buf[..len].to_vec()
}

#[test]
fn commands_are_the_bytes_the_seeds_scripts_send() {
    let mut mov = AxisValues::new();
    mov.set(Axis::X, 1.5);
    mov.set(Axis::W, -0.25);
    assert_eq!(encoded(&Command::Mov(mov)), b"MOV X 1.5 W -0.25\n");
    // MOV('X Y Z U V W', nextPoints(:,i)) of G app. D.
    let mut all = AxisValues::new();
    for (k, a) in Axis::ALL.into_iter().enumerate() {
        all.set(a, k as f64 * 0.1 - 0.2);
    }
    assert_eq!(
        encoded(&Command::Mov(all)),
        b"MOV X -0.2 Y -0.1 Z 0 U 0.1 V 0.2 W 0.3\n"
    );
    assert_eq!(encoded(&Command::Vls(1.0)), b"VLS 1\n");
    // SPA('1', 419436800, 0): the trajectory source parameter 0x19001900.
    let spa = Command::Spa {
        item: SpaItem::Number(1),
        parameter: 419_436_800,
        value: 0.0,
    };
    assert_eq!(encoded(&spa), b"SPA 1 0x19001900 0\n");
    assert_eq!(
        encoded(&Command::Hlt(AxisSet::EMPTY.with(Axis::X))),
        b"HLT X\n"
    );
    let xy = AxisSet::EMPTY.with(Axis::Y).with(Axis::X);
    assert_eq!(encoded(&Command::FrfQuery(xy)), b"FRF? X Y\n");
    assert_eq!(encoded(&Command::Frf(AxisSet::EMPTY)), b"FRF\n");
    assert_eq!(encoded(&Command::PosQuery(AxisSet::EMPTY)), b"POS?\n");
    assert_eq!(encoded(&Command::MovQuery(xy)), b"MOV? X Y\n");
    assert_eq!(encoded(&Command::IdnQuery), b"*IDN?\n");
    assert_eq!(encoded(&Command::SaiQuery), b"SAI?\n");
    assert_eq!(encoded(&Command::ErrQuery), b"ERR?\n");
    assert_eq!(encoded(&Command::VlsQuery), b"VLS?\n");
    assert_eq!(encoded(&Command::MotionStatus), [0x05]);
    assert_eq!(encoded(&Command::ControllerReady), [0x07]);
    // The scripts' lower-case axes are read.
    assert_eq!(
        Command::parse(b"HLT x\n"),
        Ok(Command::Hlt(AxisSet::EMPTY.with(Axis::X)))
    );
}

#[test]
fn numbers_are_written_with_six_decimals_at_most() {
    let cases: [(f64, &[u8]); 8] = [
        (0.1, b"0.1"),
        (1e-6, b"0.000001"),
        (4e-7, b"0"),
        (6e-7, b"0.000001"),
        (-1e-9, b"0"),
        (-12.5, b"-12.5"),
        (123_456_789.123_456, b"123456789.123456"),
        (7.0, b"7"),
    ];
    for (value, text) in cases {
        let mut buf = [0u8; 32];
        let len = encode_value(value, &mut buf).unwrap();
        assert_eq!(&buf[..len - 1], text, "{value}");
    }
    let mut buf = [0u8; 32];
    assert_eq!(encode_value(1e9, &mut buf), Err(GcsError::OutOfRange));
    assert_eq!(encode_value(f64::NAN, &mut buf), Err(GcsError::NotFinite));
    assert_eq!(
        Command::Vls(f64::INFINITY).encode(&mut buf),
        Err(GcsError::NotFinite)
    );
    assert_eq!(
        Command::Mov(AxisValues::uniform(AxisSet::ALL, 12.345678)).encode(&mut buf),
        Err(GcsError::BufferTooSmall)
    );
    assert_eq!(
        Command::Mov(AxisValues::new()).encode(&mut buf),
        Err(GcsError::Malformed)
    );
}

#[test]
fn axis_value_replies_and_their_errors() {
    let v = parse_axis_values(b"X=1.5 \ny=-2e-3 \nW=0.000000\n").unwrap();
    assert_eq!(v.get(Axis::X), Some(1.5));
    assert_eq!(v.get(Axis::Y), Some(-2e-3));
    assert_eq!(v.get(Axis::W), Some(0.0));
    assert_eq!(v.get(Axis::Z), None);
    let bad: [(&[u8], GcsError); 13] = [
        (b"X=1 \n", GcsError::Truncated),
        (b"X=1", GcsError::Truncated),
        (b"", GcsError::Truncated),
        (b"X=1\nY=2\n", GcsError::Malformed),
        (b"X1\n", GcsError::Malformed),
        (b"Q=1\n", GcsError::UnknownAxis(b'Q')),
        (b"XY=1\n", GcsError::UnknownAxis(b'X')),
        (b"X=1 \nx=2\n", GcsError::DuplicateAxis(Axis::X)),
        (b"X=1.2.3\n", GcsError::MalformedNumber),
        (b"X=\n", GcsError::MalformedNumber),
        (b"X=nan\n", GcsError::MalformedNumber),
        (b"X=inf\n", GcsError::MalformedNumber),
        (b"X=1e999\n", GcsError::NotFinite),
    ];
    for (reply, error) in bad {
        assert_eq!(
            parse_axis_values(reply),
            Err(error),
            "{:?}",
            core::str::from_utf8(reply)
        );
    }
    let long = [b' '; MAX_REPLY_LEN + 1];
    assert_eq!(parse_axis_values(&long), Err(GcsError::TooLong));
    assert_eq!(
        parse_referenced(b"X=1 \nY=0\n"),
        Ok((
            AxisSet::EMPTY.with(Axis::X).with(Axis::Y),
            AxisSet::EMPTY.with(Axis::X)
        ))
    );
    assert_eq!(parse_referenced(b"X=2\n"), Err(GcsError::MalformedNumber));
}

#[test]
fn single_value_replies() {
    assert_eq!(parse_value(b"0.5\n"), Ok(0.5));
    assert_eq!(parse_value(b"0.5 \n1\n"), Err(GcsError::Malformed));
    assert_eq!(parse_error_code(b"0\n"), Ok(0));
    assert_eq!(parse_error_code(b"-1001\n"), Ok(-1001));
    assert_eq!(
        parse_error_code(b"7\n").map(check_error),
        Ok(Err(GcsError::Controller(7)))
    );
    assert_eq!(parse_error_code(b"7"), Err(GcsError::Truncated));
    assert_eq!(parse_error_code(b"x\n"), Err(GcsError::MalformedNumber));
    assert_eq!(
        parse_error_code(b"99999999999\n"),
        Err(GcsError::MalformedNumber)
    );
    assert_eq!(check_error(0), Ok(()));
    assert_eq!(
        parse_axis_names(b"X \nY \nZ \nU \nV \nW\n"),
        Ok(AxisSet::ALL)
    );
    assert_eq!(
        parse_axis_names(b"X \n1\n"),
        Err(GcsError::UnknownAxis(b'1'))
    );
    let idn = b"kerf hexapod simulator, H-824, 0, 0.1\n";
    assert_eq!(
        parse_identification(idn),
        Ok("kerf hexapod simulator, H-824, 0, 0.1")
    );
    assert_eq!(parse_identification(b"a\x01b\n"), Err(GcsError::Malformed));
    assert_eq!(parse_motion_status(b"0\n"), Ok(AxisSet::EMPTY));
    assert_eq!(parse_motion_status(b"3F\n"), Ok(AxisSet::ALL));
    assert_eq!(
        parse_motion_status(b"5\n"),
        Ok(AxisSet::EMPTY.with(Axis::X).with(Axis::Z))
    );
    assert_eq!(
        parse_motion_status(b"40\n"),
        Err(GcsError::UnknownAxis(0x40))
    );
    assert_eq!(parse_motion_status(b"\n"), Err(GcsError::MalformedNumber));
    assert_eq!(parse_motion_status(b"1"), Err(GcsError::Truncated));
    assert_eq!(parse_ready(&[READY]), Ok(true));
    assert_eq!(parse_ready(&[NOT_READY]), Ok(false));
    assert_eq!(parse_ready(&[READY, b'\n']), Err(GcsError::Malformed));
    assert_eq!(parse_ready(&[]), Err(GcsError::Truncated));
}

#[test]
fn malformed_commands_on_the_controllers_side() {
    let bad: [(&[u8], GcsError); 9] = [
        (b"MOV X\n", GcsError::Malformed),
        (b"MOV\n", GcsError::Malformed),
        (b"MOV X 1 X 2\n", GcsError::DuplicateAxis(Axis::X)),
        (b"MOV Q 1\n", GcsError::UnknownAxis(b'Q')),
        (b"JMP X 1\n", GcsError::UnknownCommand),
        (b"VLS 1 2\n", GcsError::Malformed),
        (b"POS? X", GcsError::Truncated),
        (b"SPA 1 0xZZ 0\n", GcsError::MalformedNumber),
        (b"\n", GcsError::UnknownCommand),
    ];
    for (line, error) in bad {
        assert_eq!(
            Command::parse(line),
            Err(error),
            "{:?}",
            core::str::from_utf8(line)
        );
    }
}

fn axis_values() -> impl Strategy<Value = AxisValues> {
    proptest::collection::vec(proptest::option::of(-1e3f64..1e3), 6).prop_map(|v| {
        let mut values = AxisValues::new();
        for (axis, value) in Axis::ALL.into_iter().zip(v) {
            if let Some(value) = value {
                values.set(axis, value);
            }
        }
        values
    })
}

/// The value as written: rounded to 1e-6 (and back through decimal text).
fn written(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

proptest! {
    #[test]
    fn commands_round_trip(values in axis_values(), bits in 0u8..64, v in 0.0f64..100.0) {
        let axes = AxisSet::from_bits(bits);
        let mut commands = std::vec![
            Command::MovQuery(axes), Command::PosQuery(axes), Command::Hlt(axes),
            Command::Frf(axes), Command::FrfQuery(axes), Command::Vls(written(v)),
            Command::VlsQuery, Command::SaiQuery, Command::IdnQuery, Command::ErrQuery,
            Command::MotionStatus, Command::ControllerReady,
            Command::Spa { item: SpaItem::Axis(Axis::V), parameter: bits.into(), value: written(v) },
        ];
        let mut rounded = AxisValues::new();
        for (a, x) in values.iter() {
            rounded.set(a, written(x));
        }
        if !values.axes().is_empty() {
            commands.push(Command::Mov(rounded));
        }
        for c in commands {
            let bytes = encoded(&c);
            let back = Command::parse(&bytes).unwrap();
            // Written values are multiples of 1e-6 printed exactly; reading them
            // back is correctly rounded, so the round trip is exact.
            prop_assert_eq!(back, c);
        }
    }

    #[test]
    fn axis_value_replies_round_trip(values in axis_values()) {
        let mut buf = [0u8; MAX_REPLY_LEN];
        let len = encode_axis_values(&values, &mut buf).unwrap();
        if values.axes().is_empty() {
            prop_assert_eq!(len, 0);
        } else {
            let back = parse_axis_values(&buf[..len]).unwrap();
            prop_assert_eq!(back.axes(), values.axes());
            for (a, v) in values.iter() {
                // Half a unit of the sixth decimal, plus the rounding of v · 1e6.
                prop_assert!((back.get(a).unwrap() - v).abs() <= 5e-7 + 1e-12);
            }
        }
        let len = encode_axis_names(values.axes(), &mut buf).unwrap();
        if len > 0 {
            prop_assert_eq!(parse_axis_names(&buf[..len]), Ok(values.axes()));
        }
        let len = encode_motion_status(values.axes(), &mut buf).unwrap();
        prop_assert_eq!(parse_motion_status(&buf[..len]), Ok(values.axes()));
    }

    #[test]
    fn error_codes_round_trip(code: i32) {
        let mut buf = [0u8; 16];
        let len = encode_error_code(code, &mut buf).unwrap();
        prop_assert_eq!(parse_error_code(&buf[..len]), Ok(code));
    }

    #[test]
    fn any_bytes_give_finite_values_or_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
        if let Ok(v) = parse_axis_values(&bytes) {
            prop_assert!(v.iter().all(|(_, x)| x.is_finite()));
        }
        if let Ok(v) = parse_value(&bytes) {
            prop_assert!(v.is_finite());
        }
        let _ = (parse_error_code(&bytes), parse_axis_names(&bytes), parse_identification(&bytes));
        let _ = (parse_motion_status(&bytes), parse_ready(&bytes), Command::parse(&bytes));
    }
}
