//! Replies as the controller writes them (the simulated hexapod's side; the
//! firmware reads them with the `parse_*` functions of [`super`]).

use super::{AxisSet, AxisValues, GcsError, Out};

/// Writes `AXIS=value` lines for the axes of `values` in order.
pub fn encode_axis_values(values: &AxisValues, buf: &mut [u8]) -> Result<usize, GcsError> {
    let mut out = Out::new(buf);
    let count = values.iter().count();
    for (k, (axis, value)) in values.iter().enumerate() {
        out.byte(axis.name())?;
        out.byte(b'=')?;
        out.decimal(value)?;
        end_line(&mut out, k + 1 < count)?;
    }
    Ok(out.len)
}

/// Writes one axis name per line (SAI?'s reply).
pub fn encode_axis_names(axes: AxisSet, buf: &mut [u8]) -> Result<usize, GcsError> {
    let mut out = Out::new(buf);
    let count = axes.iter().count();
    for (k, axis) in axes.iter().enumerate() {
        out.byte(axis.name())?;
        end_line(&mut out, k + 1 < count)?;
    }
    Ok(out.len)
}

/// Writes one number on one line (VLS?'s reply).
pub fn encode_value(value: f64, buf: &mut [u8]) -> Result<usize, GcsError> {
    let mut out = Out::new(buf);
    out.decimal(value)?;
    out.byte(b'\n')?;
    Ok(out.len)
}

/// Writes an error code on one line (ERR?'s reply).
pub fn encode_error_code(code: i32, buf: &mut [u8]) -> Result<usize, GcsError> {
    let mut out = Out::new(buf);
    if code < 0 {
        out.byte(b'-')?;
    }
    out.unsigned(u64::from(code.unsigned_abs()))?;
    out.byte(b'\n')?;
    Ok(out.len)
}

/// Writes #5's reply for the moving axes.
pub fn encode_motion_status(moving: AxisSet, buf: &mut [u8]) -> Result<usize, GcsError> {
    let mut out = Out::new(buf);
    let bits = moving.bits();
    let hex = |n: u8| if n < 10 { b'0' + n } else { b'A' + n - 10 };
    if bits >= 16 {
        out.byte(hex(bits >> 4))?;
    }
    out.byte(hex(bits & 0xF))?;
    out.byte(b'\n')?;
    Ok(out.len)
}

fn end_line(out: &mut Out<'_>, more: bool) -> Result<(), GcsError> {
    if more {
        out.byte(b' ')?;
    }
    out.byte(b'\n')
}
