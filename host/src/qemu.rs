//! The emulated machine: the firmware's QEMU link image (`kerf-app`'s bin `link`, the
//! Keops slave in f32 on its simulated delta) on QEMU's Cortex-M4 (`mps2-an386`),
//! its UART0 connected to a TCP socket this process listens on.
//!
//! QEMU runs with `-icount shift=0`: guest time advances with instructions, not with
//! the host's clock, so a run is the same however busy the host is, and the machine's
//! heartbeat timeout counts control periods, not host seconds.
//!
//! QEMU runs in the machine's state folder ([`state_dir`]), one per image, where the
//! image keeps its saved settings in a file (`kerf-settings.bin`, through
//! semihosting): settings saved in one command are there in the next, as on a board.

use std::ffi::OsString;
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
    /// The machine's state folder could not be made.
    #[error("{0}: cannot make the emulated machine's state folder: {1}")]
    State(PathBuf, String),
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
    image_from(image, &|name| std::env::var_os(name))
}

/// [`image_path`] with the environment read through `var` (a test's own).
fn image_from(image: Option<&Path>, var: &dyn Fn(&str) -> Option<OsString>) -> PathBuf {
    if let Some(p) = image {
        return p.to_owned();
    }
    if let Some(p) = var("KERF_LINK_ELF") {
        return PathBuf::from(p);
    }
    match var("CARGO_TARGET_DIR") {
        Some(dir) => PathBuf::from(dir).join("thumbv7em-none-eabihf/release/link"),
        None => PathBuf::from(DEFAULT_IMAGE),
    }
}

/// The file in [`state_dir`] where an emulated machine keeps its saved settings.
pub const SETTINGS_FILE: &str = kerf::app::settings_store::EMULATED_FILE;

/// The folder the emulated machine of `image` keeps its state in (its saved settings):
/// `$KERF_STATE_DIR`, else `$XDG_STATE_HOME/kerf`, else `$HOME/.local/state/kerf`,
/// else `.kerf-state` here; then the image's file name (`link`, `arrow-link`).
pub fn state_dir(image: &Path) -> PathBuf {
    state_dir_from(image, &|name| std::env::var_os(name))
}

/// [`state_dir`] with the environment read through `var` (a test's own).
fn state_dir_from(image: &Path, var: &dyn Fn(&str) -> Option<OsString>) -> PathBuf {
    let root = var("KERF_STATE_DIR")
        .map(PathBuf::from)
        .or_else(|| var("XDG_STATE_HOME").map(|d| PathBuf::from(d).join("kerf")))
        .or_else(|| var("HOME").map(|d| PathBuf::from(d).join(".local/state/kerf")))
        .unwrap_or_else(|| PathBuf::from(".kerf-state"));
    root.join(image.file_name().unwrap_or(image.as_os_str()))
}

/// Starts QEMU on `image` and returns it with the connected serial socket.
pub fn start(image: &Path) -> Result<(Qemu, TcpStream), QemuError> {
    if !image.is_file() {
        return Err(QemuError::NoImage(image.to_owned()));
    }
    // QEMU runs in the state folder: the image by its full path.
    let image = &std::fs::canonicalize(image)?;
    let state = state_dir(image);
    std::fs::create_dir_all(&state)
        .map_err(|e| QemuError::State(state.clone(), crate::output::io_words(&e)))?;
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
        .current_dir(&state)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The state folder: `$KERF_STATE_DIR`, `$XDG_STATE_HOME/kerf`,
    /// `$HOME/.local/state/kerf` in that order, then the image's name.
    #[test]
    fn each_image_keeps_its_state_in_a_folder_of_its_own() {
        let image = Path::new("/t/release/arrow-link");
        let env = |vars: &'static [(&'static str, &'static str)]| {
            move |name: &str| {
                vars.iter()
                    .find(|v| v.0 == name)
                    .map(|v| OsString::from(v.1))
            }
        };
        let all = env(&[
            ("KERF_STATE_DIR", "/s"),
            ("XDG_STATE_HOME", "/x"),
            ("HOME", "/h"),
        ]);
        assert_eq!(state_dir_from(image, &all), Path::new("/s/arrow-link"));
        let xdg = env(&[("XDG_STATE_HOME", "/x"), ("HOME", "/h")]);
        assert_eq!(state_dir_from(image, &xdg), Path::new("/x/kerf/arrow-link"));
        let home = env(&[("HOME", "/h")]);
        assert_eq!(
            state_dir_from(Path::new("link"), &home),
            Path::new("/h/.local/state/kerf/link")
        );
        assert_eq!(
            state_dir_from(image, &env(&[])),
            Path::new(".kerf-state/arrow-link")
        );
        assert!(state_dir(image).ends_with("arrow-link"));
    }

    /// The order the docs give: the image named, else `$KERF_LINK_ELF`, else the link
    /// image under `$CARGO_TARGET_DIR`, else [`DEFAULT_IMAGE`], which is the same image
    /// under the default `target` (one place for the image in a target folder).
    #[test]
    fn the_image_is_the_one_named_then_the_environments() {
        let named = Path::new("/images/link.elf");
        assert_eq!(image_path(Some(named)), named);
        fn env(
            elf: Option<&'static str>,
            dir: Option<&'static str>,
        ) -> impl Fn(&str) -> Option<OsString> {
            move |name| match name {
                "KERF_LINK_ELF" => elf.map(OsString::from),
                "CARGO_TARGET_DIR" => dir.map(OsString::from),
                _ => None,
            }
        }
        let both = env(Some("/a/link"), Some("/b"));
        assert_eq!(image_from(Some(named), &both), named);
        assert_eq!(image_from(None, &both), Path::new("/a/link"));
        assert_eq!(
            image_from(None, &env(None, Some("/b"))),
            Path::new("/b/thumbv7em-none-eabihf/release/link")
        );
        assert_eq!(image_from(None, &env(None, None)), Path::new(DEFAULT_IMAGE));
        assert_eq!(
            image_from(None, &env(None, Some("target"))),
            Path::new(DEFAULT_IMAGE)
        );
    }
}
