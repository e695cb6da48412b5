//! One reader and one writer rule for the files SimSerpent reads from and writes into a folder it
//! was given (a run folder, a sweep folder, a study's `--out`).
//!
//! Reading ([`read_in`], [`read_text_in`]): only regular files (a FIFO, a device such as
//! `/dev/zero`, a socket or a folder is refused at once — a FIFO is opened without blocking), at
//! most a stated number of bytes (checked before and while reading), and never through a link
//! that leads out of the folder (a link inside it is fine). Numbers in tables go through
//! [`parse_number`]: they must parse, be finite and stay within [`MAX_ABS_VALUE`].
//!
//! Writing ([`create_in`], [`write_in`], [`create_dir_in`], [`check_target_in`]): only inside the
//! folder (no `..`), never through a symbolic link — neither a link at the file's own name (a
//! dangling one included: it is not followed to create its target) nor a linked sub-folder.

use std::fs::File;
use std::io::Read;
#[cfg(unix)]
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::{Component, Path, PathBuf};

/// Most bytes of a table (CSV) read back: 1 GiB.
pub const TABLE_CAP_BYTES: u64 = 1 << 30;
/// Most bytes of a small file read back (config, manifest, `sweep.json`, a summary): 64 MiB.
pub const SMALL_FILE_CAP_BYTES: u64 = 64 << 20;
/// The largest magnitude of a number in a table SimSerpent reads back (1e15). A run never
/// records more (validation bounds every configured magnitude by 1e12 and the divergence and
/// energy guards stop a run that blows up); beyond it plots and estimates lose all meaning.
pub const MAX_ABS_VALUE: f64 = 1e15;

/// Errors of reading or writing a file in a folder; each names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FileError {
    /// No such file.
    #[error("{} is missing", path.display())]
    Missing {
        /// The file.
        path: PathBuf,
    },
    /// Not a regular file.
    #[error("{} is {what}, not a regular file; SimSerpent reads and writes only regular files", path.display())]
    NotRegular {
        /// The file.
        path: PathBuf,
        /// "a FIFO", "a device", "a folder", "a socket".
        what: &'static str,
    },
    /// A link (or `..`) that leads out of the folder.
    #[error(
        "{} leads to {}, outside {}; SimSerpent does not follow links out of the folder it was given",
        path.display(),
        target.display(),
        folder.display()
    )]
    Outside {
        /// The file as named.
        path: PathBuf,
        /// Where it leads.
        target: PathBuf,
        /// The folder.
        folder: PathBuf,
    },
    /// Larger than the cap for its kind.
    #[error("{} has {bytes} bytes, more than the {cap} bytes allowed for this file", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size (at least).
        bytes: u64,
        /// The cap.
        cap: u64,
    },
    /// Another process holds the run folder ([`RunLock`]): a run still going on, or a
    /// `bag-repair` of it.
    #[error(
        "{} is in use by another process (a run still going on, or a bag-repair of it); wait until it ends",
        folder.display()
    )]
    Busy {
        /// The run folder.
        folder: PathBuf,
    },
    /// A folder argument (a run folder, a sweep folder) that is not a folder.
    #[error("{} is {what}, not a folder", path.display())]
    NotAFolder {
        /// The path given.
        path: PathBuf,
        /// "a regular file", "a FIFO", "a device", "a socket".
        what: &'static str,
    },
    /// A symbolic link where SimSerpent writes.
    #[error(
        "{} is a symbolic link; SimSerpent does not write through links (remove it, or give another folder)",
        path.display()
    )]
    Link {
        /// The link.
        path: PathBuf,
    },
    /// Not UTF-8 text.
    #[error("{} is not UTF-8 text (byte {offset})", path.display())]
    NotText {
        /// The file.
        path: PathBuf,
        /// The first invalid byte.
        offset: usize,
    },
    /// The operating system refused.
    #[error("cannot {what} {}: {source}", path.display())]
    Io {
        /// "read", "write", "create".
        what: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

impl FileError {
    /// Whether the file does not exist (optional files are skipped, not refused).
    pub fn is_missing(&self) -> bool {
        matches!(self, FileError::Missing { .. })
    }

    /// Whether the error is the file's fault (bad input, exit code 2) rather than the system's.
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, FileError::Io { .. } | FileError::Busy { .. })
    }
}

fn io<'a>(what: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> FileError + 'a {
    move |source| FileError::Io { what, path: path.to_path_buf(), source }
}

fn kind_of(t: std::fs::FileType) -> Option<&'static str> {
    if t.is_file() {
        None
    } else if t.is_dir() {
        Some("a folder")
    } else {
        special_kind(t)
    }
}

#[cfg(unix)]
fn special_kind(t: std::fs::FileType) -> Option<&'static str> {
    if t.is_fifo() {
        Some("a FIFO")
    } else if t.is_block_device() || t.is_char_device() {
        Some("a device")
    } else if t.is_socket() {
        Some("a socket")
    } else {
        Some("not a regular file")
    }
}

#[cfg(not(unix))]
fn special_kind(_: std::fs::FileType) -> Option<&'static str> {
    Some("not a regular file")
}

/// Open options that never block on a FIFO, never follow a link swapped in at the final name and
/// are not inherited by child processes (Unix); elsewhere the checks before and after opening
/// (the link test and [`kind_of`] on the opened file) do that work.
fn guarded(options: &mut std::fs::OpenOptions) -> &mut std::fs::OpenOptions {
    #[cfg(unix)]
    options.custom_flags(libc::O_NONBLOCK | libc::O_NOFOLLOW | libc::O_CLOEXEC).mode(0o644);
    options
}

/// Whether an open failed because the final name is a symbolic link (`O_NOFOLLOW`).
fn is_link_error(e: &std::io::Error) -> bool {
    #[cfg(unix)]
    return e.raw_os_error() == Some(libc::ELOOP);
    #[cfg(not(unix))]
    return {
        let _ = e;
        false
    };
}

/// Reads `path` (inside `folder`, as a path that starts with `folder` or one relative to it):
/// a regular file of at most `cap_bytes` whose real location is inside the folder.
///
/// # Errors
/// [`FileError`]: missing, not a regular file, a link out of the folder, too large, or I/O.
pub fn read_in(folder: &Path, path: &Path, cap_bytes: u64) -> Result<Vec<u8>, FileError> {
    let (mut file, len, path) = open_in(folder, path, cap_bytes)?;
    let mut bytes = Vec::with_capacity(len as usize);
    (&mut file).take(cap_bytes + 1).read_to_end(&mut bytes).map_err(io("read", &path))?;
    if bytes.len() as u64 > cap_bytes {
        return Err(FileError::TooLarge { path, bytes: bytes.len() as u64, cap: cap_bytes });
    }
    Ok(bytes)
}

/// Opens `path` for reading by [`read_in`]'s rule without reading it (for readers that stream a
/// large file): returns the file, its length when opened and its path. A caller that reads it
/// must not read more than that length.
///
/// # Errors
/// As [`read_in`].
pub fn open_in(folder: &Path, path: &Path, cap_bytes: u64) -> Result<(File, u64, PathBuf), FileError> {
    let path = if path.is_absolute() || path.starts_with(folder) { path.to_path_buf() } else { folder.join(path) };
    match std::fs::symlink_metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Err(FileError::Missing { path }),
        Err(e) => return Err(FileError::Io { what: "read", path, source: e }),
        Ok(_) => {}
    }
    let real_folder = folder.canonicalize().map_err(io("read", folder))?;
    let real = match path.canonicalize() {
        Ok(r) => r,
        // A dangling link.
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Err(FileError::Missing { path }),
        Err(e) => return Err(FileError::Io { what: "read", path, source: e }),
    };
    if !real.starts_with(&real_folder) {
        return Err(FileError::Outside { path, target: real, folder: folder.to_path_buf() });
    }
    // Without blocking (a FIFO opens at once) and without following a link swapped in since.
    let file = guarded(std::fs::OpenOptions::new().read(true)).open(&real).map_err(io("read", &path))?;
    let meta = file.metadata().map_err(io("read", &path))?;
    if let Some(what) = kind_of(meta.file_type()) {
        return Err(FileError::NotRegular { path, what });
    }
    if meta.len() > cap_bytes {
        return Err(FileError::TooLarge { path, bytes: meta.len(), cap: cap_bytes });
    }
    Ok((file, meta.len(), path))
}

/// The lock of a run folder: `.simserpent-lock`, held exclusively (an advisory file lock) by the
/// process that writes the run, from before its first manifest until it ends, and by
/// `bag-repair` while it rewrites the bag. The lock goes with the process (also when it is
/// killed); the empty file stays.
#[derive(Debug)]
pub struct RunLock {
    _file: File,
}

impl RunLock {
    /// The lock file's name in the run folder.
    pub const FILE: &'static str = ".simserpent-lock";

    /// Takes the lock of `folder` without waiting.
    ///
    /// # Errors
    /// [`FileError::Busy`] when another process holds it; [`FileError::Link`] for a link at the
    /// lock's name; I/O.
    pub fn try_acquire(folder: &Path) -> Result<Self, FileError> {
        let path = folder.join(Self::FILE);
        let file = {
            if let Ok(m) = std::fs::symlink_metadata(&path)
                && m.file_type().is_symlink()
            {
                return Err(FileError::Link { path });
            }
            let mut options = std::fs::OpenOptions::new();
            // Not truncated: the file is only a lock.
            guarded(options.write(true).create(true));
            options.open(&path).map_err(|e| {
                if is_link_error(&e) { FileError::Link { path: path.clone() } } else { io("write", &path)(e) }
            })?
        };
        match file.try_lock() {
            Ok(()) => Ok(Self { _file: file }),
            Err(std::fs::TryLockError::WouldBlock) => Err(FileError::Busy { folder: folder.to_path_buf() }),
            Err(std::fs::TryLockError::Error(source)) => Err(FileError::Io { what: "lock", path, source }),
        }
    }
}

/// [`read_in`], as UTF-8 text.
///
/// # Errors
/// As [`read_in`], and [`FileError::NotText`].
pub fn read_text_in(folder: &Path, path: &Path, cap_bytes: u64) -> Result<String, FileError> {
    let bytes = read_in(folder, path, cap_bytes)?;
    String::from_utf8(bytes).map_err(|e| FileError::NotText {
        path: if path.starts_with(folder) { path.to_path_buf() } else { folder.join(path) },
        offset: e.utf8_error().valid_up_to(),
    })
}

/// Checks a folder the user named (a run folder, a sweep folder): it exists and is a folder (a
/// link to one is fine: the user chose it). Commands check it first, so a file given as a run
/// folder is bad input (exit code 2) whatever the command would have read first.
///
/// # Errors
/// [`FileError::Missing`], [`FileError::NotAFolder`], or I/O.
pub fn folder_arg(path: &Path) -> Result<(), FileError> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(m) => Err(FileError::NotAFolder {
            path: path.to_path_buf(),
            what: if m.is_file() { "a regular file" } else { special_kind(m.file_type()).unwrap_or("not a folder") },
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(FileError::Missing { path: path.to_path_buf() }),
        // A path through a regular file (`file/x`).
        Err(e) if e.raw_os_error() == Some(20) => {
            Err(FileError::NotAFolder { path: path.to_path_buf(), what: "inside a regular file" })
        }
        Err(e) => Err(FileError::Io { what: "read", path: path.to_path_buf(), source: e }),
    }
}

/// The path of `path` inside `folder` (joined when relative), refusing `..` components.
fn inside(folder: &Path, path: &Path) -> Result<(PathBuf, PathBuf), FileError> {
    let full = if path.starts_with(folder) { path.to_path_buf() } else { folder.join(path) };
    let rel = full.strip_prefix(folder).map_or_else(|_| path.to_path_buf(), Path::to_path_buf);
    if full.strip_prefix(folder).is_err() || rel.components().any(|c| !matches!(c, Component::Normal(_))) {
        return Err(FileError::Outside { path: full.clone(), target: full, folder: folder.to_path_buf() });
    }
    Ok((full, rel))
}

/// Creates the folder `dir` inside `folder` (and the folders between), none of them through a
/// symbolic link; an existing folder is kept.
///
/// # Errors
/// A link or a non-folder on the way, `..`, or I/O.
pub fn create_dir_in(folder: &Path, dir: &Path) -> Result<PathBuf, FileError> {
    let (full, rel) = inside(folder, dir)?;
    let mut at = folder.to_path_buf();
    for c in rel.components() {
        at.push(c);
        match std::fs::symlink_metadata(&at) {
            Ok(m) if m.file_type().is_symlink() => return Err(FileError::Link { path: at }),
            Ok(m) if m.is_dir() => {}
            Ok(m) => {
                return Err(FileError::NotRegular { path: at, what: kind_of(m.file_type()).unwrap_or("a file") });
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => match std::fs::create_dir(&at) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let m = std::fs::symlink_metadata(&at).map_err(io("create", &at))?;
                    if !m.is_dir() {
                        return Err(FileError::Link { path: at });
                    }
                }
                Err(e) => return Err(FileError::Io { what: "create", path: at, source: e }),
            },
            Err(e) => return Err(FileError::Io { what: "create", path: at, source: e }),
        }
    }
    Ok(full)
}

/// Checks that `path` inside `folder` may be written by a writer that opens it by name (a
/// plotting library): its folders are real folders inside `folder` (created if missing) and the
/// file is absent or a regular file, not a link.
///
/// # Errors
/// As [`create_dir_in`]; [`FileError::Link`] for a link at the file's name.
pub fn check_target_in(folder: &Path, path: &Path) -> Result<PathBuf, FileError> {
    let (full, rel) = inside(folder, path)?;
    if let Some(parent) = rel.parent().filter(|p| !p.as_os_str().is_empty()) {
        create_dir_in(folder, parent)?;
    }
    match std::fs::symlink_metadata(&full) {
        Ok(m) if m.file_type().is_symlink() => Err(FileError::Link { path: full }),
        Ok(m) => match kind_of(m.file_type()) {
            Some(what) => Err(FileError::NotRegular { path: full, what }),
            None => Ok(full),
        },
        Err(_) => Ok(full),
    }
}

/// Creates (or truncates) `path` inside `folder` for writing, by [`check_target_in`]'s rule,
/// opened without following a link swapped in since.
///
/// # Errors
/// As [`check_target_in`], or I/O.
pub fn create_in(folder: &Path, path: &Path) -> Result<File, FileError> {
    let full = check_target_in(folder, path)?;
    open_for_writing(&full, false)
}

/// Opens `path` for writing without following a symbolic link at its name (a dangling link
/// included); with `new_only`, refuses an existing file or link ([`std::io::ErrorKind::AlreadyExists`]).
///
/// # Errors
/// [`FileError::Link`], [`FileError::NotRegular`], or I/O (`AlreadyExists` with `new_only`).
pub fn open_for_writing(path: &Path, new_only: bool) -> Result<File, FileError> {
    if let Ok(m) = std::fs::symlink_metadata(path)
        && m.file_type().is_symlink()
    {
        return Err(FileError::Link { path: path.to_path_buf() });
    }
    let mut options = std::fs::OpenOptions::new();
    guarded(options.write(true));
    if new_only {
        options.create_new(true);
    } else {
        options.create(true).truncate(true);
    }
    let file = options.open(path).map_err(|e| {
        if is_link_error(&e) {
            FileError::Link { path: path.to_path_buf() }
        } else {
            FileError::Io { what: "write", path: path.to_path_buf(), source: e }
        }
    })?;
    let meta = file.metadata().map_err(io("write", path))?;
    if let Some(what) = kind_of(meta.file_type()) {
        return Err(FileError::NotRegular { path: path.to_path_buf(), what });
    }
    Ok(file)
}

/// Writes `bytes` to `path` inside `folder` by [`create_in`]'s rule.
///
/// # Errors
/// As [`create_in`], or I/O.
pub fn write_in(folder: &Path, path: &Path, bytes: &[u8]) -> Result<PathBuf, FileError> {
    use std::io::Write;
    let full = check_target_in(folder, path)?;
    let mut file = open_for_writing(&full, false)?;
    file.write_all(bytes).map_err(io("write", &full))?;
    Ok(full)
}

/// A number of a table: it must parse, be finite and be at most [`MAX_ABS_VALUE`] in magnitude.
/// `Err` says why, for a message that names the file, row and column.
///
/// # Errors
/// Not a number, not finite, or too large.
pub fn parse_number(text: &str) -> Result<f64, &'static str> {
    match text.trim().parse::<f64>() {
        Err(_) => Err("is not a number"),
        Ok(v) if !v.is_finite() => Err("is not finite"),
        Ok(v) if v.abs() > MAX_ABS_VALUE => Err("is beyond 1e15 in magnitude (no run records that)"),
        Ok(v) => Ok(v),
    }
}

#[cfg(all(test, unix))]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn parse_number_refuses_what_no_run_records() {
        assert_eq!(parse_number(" 1.5 "), Ok(1.5));
        for bad in ["NaN", "inf", "-inf", "hello", "", "1e308", "-1e16"] {
            assert!(parse_number(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn reader_refuses_fifo_links_out_and_oversize() {
        let dir = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        std::fs::write(outside.path().join("x.csv"), "a\n1\n").unwrap();
        std::os::unix::fs::symlink(outside.path().join("x.csv"), dir.path().join("out.csv")).unwrap();
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.csv")).unwrap();
        std::fs::write(dir.path().join("in.csv"), "a\n1\n").unwrap();
        std::os::unix::fs::symlink("in.csv", dir.path().join("link_in.csv")).unwrap();
        let fifo = std::ffi::CString::new(dir.path().join("fifo.csv").to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        #[allow(unsafe_code)]
        let made = unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) };
        assert_eq!(made, 0);
        let d = dir.path();
        assert!(matches!(read_in(d, Path::new("out.csv"), 100), Err(FileError::Outside { .. })));
        assert!(matches!(read_in(d, Path::new("zero.csv"), 100), Err(FileError::Outside { .. })));
        assert!(matches!(read_in(d, Path::new("fifo.csv"), 100), Err(FileError::NotRegular { .. })));
        assert!(matches!(read_in(d, Path::new("missing.csv"), 100), Err(FileError::Missing { .. })));
        assert!(matches!(read_in(d, Path::new("in.csv"), 3), Err(FileError::TooLarge { .. })));
        assert_eq!(read_in(d, Path::new("link_in.csv"), 100).unwrap(), b"a\n1\n");
        assert!(matches!(read_in(d, Path::new("."), 100), Err(FileError::NotRegular { .. })));
    }

    #[test]
    fn writer_never_follows_links() {
        let dir = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::os::unix::fs::symlink(outside.path(), d.join("estimation")).unwrap();
        assert!(matches!(write_in(d, Path::new("estimation/a.csv"), b"x"), Err(FileError::Link { .. })));
        std::os::unix::fs::symlink(outside.path().join("dangling"), d.join("b.csv")).unwrap();
        assert!(matches!(write_in(d, Path::new("b.csv"), b"x"), Err(FileError::Link { .. })));
        assert!(!outside.path().join("dangling").exists());
        assert!(matches!(open_for_writing(&d.join("b.csv"), true), Err(FileError::Link { .. })));
        assert!(matches!(write_in(d, Path::new("../c.csv"), b"x"), Err(FileError::Outside { .. })));
        write_in(d, Path::new("sub/c.csv"), b"x").unwrap();
        assert_eq!(std::fs::read(d.join("sub/c.csv")).unwrap(), b"x");
        assert_eq!(std::fs::read_dir(outside.path()).unwrap().count(), 0);
    }
}
