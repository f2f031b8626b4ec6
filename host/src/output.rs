//! The files the tool writes (job files, pictures, telemetry), whole or not at all.
//!
//! [`OutputFile::prepare`] checks, before the long work (planning an image, a run on
//! the machine), that the file can be written where the operator asked: a folder that
//! exists and takes new files, a name that is not a folder or a read-only file.
//! [`OutputFile::write`] then writes the bytes to a hidden temporary file beside it,
//! flushes it to the disk and renames it over the target, so that a full disk or any
//! other error leaves the old file (or none) and no half-written one. A target that
//! exists and is not a regular file (`/dev/stdout`, a named pipe, a device) is written
//! in place: it cannot be renamed over.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, ErrorKind, Write};
use std::path::{Path, PathBuf};

/// Why a file could not be read or written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: cannot write the {what} there: {reason}")]
pub struct OutputError {
    /// The file, as the operator named it.
    pub path: String,
    /// What it was to hold ("job file", "picture", "telemetry").
    pub what: &'static str,
    /// Why, in words.
    pub reason: String,
}

/// An I/O error in an operator's words (the system's own text for the rare kinds).
pub fn io_words(e: &io::Error) -> String {
    match e.kind() {
        ErrorKind::NotFound => "no such file or folder".into(),
        ErrorKind::PermissionDenied => "permission denied".into(),
        ErrorKind::StorageFull => "the disk is full".into(),
        ErrorKind::ReadOnlyFilesystem => "the disk is read-only".into(),
        ErrorKind::IsADirectory => "that is a folder, not a file".into(),
        ErrorKind::NotADirectory => "part of the path is a file, not a folder".into(),
        ErrorKind::BrokenPipe => "the reader went away (a closed pipe)".into(),
        _ => e.to_string(),
    }
}

/// A file to be written whole (module docs).
#[derive(Debug)]
pub struct OutputFile {
    /// As the operator named it (for messages).
    shown: String,
    /// Where the bytes go: the named file, or the file a symbolic link names.
    target: PathBuf,
    /// Written in place (not a regular file).
    in_place: bool,
    what: &'static str,
}

impl OutputFile {
    /// Checks that `path` can be written, now; `what` names the file's content in the
    /// messages.
    ///
    /// Errors: an empty name, a folder, a read-only file, a folder that does not
    /// exist or does not take new files.
    pub fn prepare(path: &Path, what: &'static str) -> Result<Self, OutputError> {
        let shown = path.display().to_string();
        let fail = |reason: String| OutputError {
            path: shown.clone(),
            what,
            reason,
        };
        if path.as_os_str().is_empty() {
            return Err(fail("no file name given".into()));
        }
        if path.is_dir() {
            return Err(fail("that is a folder, not a file".into()));
        }
        if path.file_name().is_none() {
            return Err(fail("no file name given".into()));
        }
        // A link is followed: the file it names is replaced, not the link.
        let target = if path.is_symlink() {
            fs::canonicalize(path).map_err(|e| fail(io_words(&e)))?
        } else {
            path.to_owned()
        };
        let mut file = OutputFile {
            shown: shown.clone(),
            target,
            in_place: false,
            what,
        };
        match fs::metadata(&file.target) {
            Ok(m) if m.is_dir() => return Err(fail("that is a folder, not a file".into())),
            Ok(m) if m.is_file() && m.permissions().readonly() => {
                return Err(fail("the file is read-only".into()))
            }
            Ok(m) if !m.is_file() => {
                file.in_place = true;
                return Ok(file);
            }
            _ => {}
        }
        // The folder takes new files: make the temporary file and remove it again.
        let probe = file.temporary();
        File::options()
            .write(true)
            .create_new(true)
            .open(&probe)
            .map_err(|e| fail(io_words(&e)))?;
        fs::remove_file(&probe).map_err(|e| fail(io_words(&e)))?;
        Ok(file)
    }

    /// The file as the operator named it.
    pub fn shown(&self) -> &str {
        &self.shown
    }

    /// The hidden temporary file beside the target, unique to this process.
    fn temporary(&self) -> PathBuf {
        let name = self
            .target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut tmp = self.target.clone();
        tmp.set_file_name(format!(".{name}.kerf-{}.tmp", std::process::id()));
        tmp
    }

    fn error(&self, e: &io::Error) -> OutputError {
        OutputError {
            path: self.shown.clone(),
            what: self.what,
            reason: io_words(e),
        }
    }

    /// Writes the file whole with what `fill` writes (module docs); on an error
    /// nothing is left but the file as it was before.
    pub fn write(
        &self,
        fill: impl FnOnce(&mut dyn Write) -> io::Result<()>,
    ) -> Result<(), OutputError> {
        if self.in_place {
            let file = OpenOptions::new()
                .write(true)
                .truncate(true)
                .open(&self.target)
                .map_err(|e| self.error(&e))?;
            let mut w = BufWriter::new(file);
            return fill(&mut w)
                .and_then(|()| w.flush())
                .map_err(|e| self.error(&e));
        }
        let tmp = self.temporary();
        let written = (|| {
            let file = File::options().write(true).create_new(true).open(&tmp)?;
            let mut w = BufWriter::new(file);
            fill(&mut w)?;
            let file = w.into_inner().map_err(io::IntoInnerError::into_error)?;
            // A full disk can show only when the data reaches it.
            file.sync_all()?;
            fs::rename(&tmp, &self.target)
        })();
        written.map_err(|e| {
            let _ = fs::remove_file(&tmp);
            self.error(&e)
        })
    }

    /// Writes `bytes` as the whole file ([`OutputFile::write`]).
    pub fn write_bytes(&self, bytes: &[u8]) -> Result<(), OutputError> {
        self.write(|w| w.write_all(bytes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("kerf-output-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_file_is_written_whole_or_the_old_one_stays() {
        let d = dir("whole");
        let p = d.join("a.kjob");
        fs::write(&p, b"old").unwrap();
        let out = OutputFile::prepare(&p, "job file").unwrap();
        let e = out
            .write(|w| {
                w.write_all(b"half")?;
                Err(io::Error::from(ErrorKind::StorageFull))
            })
            .unwrap_err();
        assert_eq!(e.reason, "the disk is full");
        assert_eq!(fs::read(&p).unwrap(), b"old");
        assert_eq!(names(&d), ["a.kjob"]);
        out.write_bytes(b"new").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"new");
        assert_eq!(names(&d), ["a.kjob"]);
        fs::remove_dir_all(&d).unwrap();
    }

    /// The kinds an operator meets are in words of their own (each different, none
    /// the system's text); any other kind is the system's own text.
    #[test]
    fn io_errors_are_in_the_operators_words() {
        let kinds = [
            (ErrorKind::NotFound, "no such file or folder"),
            (ErrorKind::PermissionDenied, "permission denied"),
            (ErrorKind::StorageFull, "the disk is full"),
            (ErrorKind::ReadOnlyFilesystem, "the disk is read-only"),
            (ErrorKind::IsADirectory, "that is a folder, not a file"),
            (
                ErrorKind::NotADirectory,
                "part of the path is a file, not a folder",
            ),
            (
                ErrorKind::BrokenPipe,
                "the reader went away (a closed pipe)",
            ),
        ];
        for (kind, words) in kinds {
            assert_eq!(io_words(&io::Error::from(kind)), words, "{kind:?}");
        }
        let other = io::Error::new(ErrorKind::TimedOut, "the link timed out");
        assert_eq!(io_words(&other), "the link timed out");
    }

    /// Messages name the file as the operator did, also when it is a link: `shown`
    /// is the link's name while the bytes go to the file it names.
    #[cfg(unix)]
    #[test]
    fn a_file_is_shown_by_the_name_given_also_through_a_link() {
        let d = dir("shown");
        let real = d.join("real.kjob");
        fs::write(&real, b"old").unwrap();
        let link = d.join("link.kjob");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        for (path, written) in [(&real, &real), (&link, &real)] {
            let out = OutputFile::prepare(path, "job file").unwrap();
            assert_eq!(out.shown(), path.display().to_string());
            out.write_bytes(path.display().to_string().as_bytes())
                .unwrap();
            assert_eq!(
                fs::read(written).unwrap(),
                path.display().to_string().as_bytes()
            );
        }
        assert!(fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn unwritable_places_are_refused_before_any_work() {
        let d = dir("refused");
        let cases = [
            (d.join("missing/a.svg"), "no such file or folder"),
            (d.clone(), "that is a folder, not a file"),
            (PathBuf::new(), "no file name given"),
        ];
        for (p, why) in cases {
            let e = OutputFile::prepare(&p, "picture").unwrap_err();
            assert_eq!(e.reason, why, "{p:?}");
            assert!(e.to_string().contains("cannot write the picture there"));
        }
        let ro = d.join("ro.csv");
        fs::write(&ro, b"x").unwrap();
        let mut perm = fs::metadata(&ro).unwrap().permissions();
        perm.set_readonly(true);
        fs::set_permissions(&ro, perm).unwrap();
        let e = OutputFile::prepare(&ro, "telemetry").unwrap_err();
        assert_eq!(e.reason, "the file is read-only");
        assert_eq!(names(&d), ["ro.csv"]);
        let mut perm = fs::metadata(&ro).unwrap().permissions();
        #[allow(clippy::permissions_set_readonly_false)]
        perm.set_readonly(false);
        fs::set_permissions(&ro, perm).unwrap();
        fs::remove_dir_all(&d).unwrap();
    }
}
