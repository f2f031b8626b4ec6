//! The emulated machine: the firmware's QEMU link image (`kerf-app`'s bin `link`, the
//! Keops slave in f32 on its simulated delta) on QEMU's Cortex-M4 (`mps2-an386`),
//! its UART0 connected to a TCP socket this process listens on.
//!
//! QEMU runs with `-icount shift=0`: guest time advances with instructions, not with
//! the host's clock, so a run is the same however busy the host is, and the machine's
//! heartbeat timeout counts control periods, not host seconds.

use std::io;
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Where `cargo build -p kerf-app --release --target thumbv7em-none-eabihf --features
/// qemu --bin link` leaves the image, from the workspace root.
pub const DEFAULT_IMAGE: &str = "target/thumbv7em-none-eabihf/release/link";

/// Why the emulated machine did not start.
#[derive(Debug, thiserror::Error)]
pub enum QemuError {
    /// No image at the path.
    #[error("no firmware image at {0} (build it: cargo build -p kerf-app --release --target thumbv7em-none-eabihf --features qemu --bin link)")]
    NoImage(PathBuf),
    /// QEMU could not be run.
    #[error("cannot run qemu-system-arm: {0} (apt-get install qemu-system-arm)")]
    Spawn(io::Error),
    /// QEMU did not connect its serial port.
    #[error("QEMU did not connect its serial port within {0} s")]
    NoConnection(u64),
    /// The socket failed.
    #[error("socket: {0}")]
    Io(#[from] io::Error),
}

/// A running QEMU; killed when dropped.
pub struct Qemu {
    child: Child,
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The image to run: `image` if given, else `$KERF_LINK_ELF`, else the link image in
/// `$CARGO_TARGET_DIR`, else [`DEFAULT_IMAGE`] (relative to the present directory).
pub fn image_path(image: Option<&Path>) -> PathBuf {
    if let Some(p) = image {
        return p.to_owned();
    }
    if let Some(p) = std::env::var_os("KERF_LINK_ELF") {
        return PathBuf::from(p);
    }
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(dir) => PathBuf::from(dir).join("thumbv7em-none-eabihf/release/link"),
        None => PathBuf::from(DEFAULT_IMAGE),
    }
}

/// Starts QEMU on `image` and returns it with the connected serial socket.
pub fn start(image: &Path) -> Result<(Qemu, TcpStream), QemuError> {
    if !image.is_file() {
        return Err(QemuError::NoImage(image.to_owned()));
    }
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let port = listener.local_addr()?.port();
    let child = Command::new("qemu-system-arm")
        .args(["-cpu", "cortex-m4", "-machine", "mps2-an386"])
        .args(["-nographic", "-monitor", "none"])
        .args(["-serial", &format!("tcp:127.0.0.1:{port}")])
        .args(["-icount", "shift=0,align=off,sleep=off"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-kernel")
        .arg(image)
        .stdin(Stdio::null())
        // The image's own lines (semihosting) go to our standard error.
        .stdout(Stdio::from(io::stderr()))
        .spawn()
        .map_err(QemuError::Spawn)?;
    let qemu = Qemu { child };
    // QEMU connects as it starts; a QEMU that fails to start never does.
    const WAIT_S: u64 = 20;
    listener.set_nonblocking(true)?;
    let deadline = Instant::now() + Duration::from_secs(WAIT_S);
    let stream = loop {
        match listener.accept() {
            Ok((s, _)) => break s,
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                if Instant::now() > deadline {
                    return Err(QemuError::NoConnection(WAIT_S));
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => return Err(e.into()),
        }
    };
    stream.set_nonblocking(false)?;
    stream.set_nodelay(true)?;
    Ok((qemu, stream))
}
