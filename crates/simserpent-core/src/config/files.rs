//! Reading a file named by a config: the config itself, terrain sources, a third-party terrain
//! and its assets, a user's robot.
//!
//! Every such file must be a regular file after following symbolic links (not a device, FIFO,
//! socket or folder) and no larger than its cap: [`MAX_CONFIG_BYTES`], [`MAX_MJCF_BYTES`],
//! [`MAX_ASSET_BYTES`]. Reads stop at the cap + 1 byte, so a file that grows while it is read is
//! caught too. (`model::files` re-exports all of this beside the terrain file parsers.)

use std::io::Read;
use std::path::{Path, PathBuf};

use super::ConfigError;

/// The largest config file (TOML or JSON): 16 MiB.
pub const MAX_CONFIG_BYTES: u64 = 16 << 20;
/// The largest MJCF file (a third-party terrain, a user's robot): 64 MiB.
pub const MAX_MJCF_BYTES: u64 = 64 << 20;
/// The largest asset file (PNG heightfield or texture, STL/OBJ mesh, any file a third-party
/// terrain refers to): 256 MiB.
pub const MAX_ASSET_BYTES: u64 = 256 << 20;
/// The largest image (width × height, pixels) a third-party terrain's PNG texture or heightfield
/// may declare: 8192 × 8192. MuJoCo decodes it whole, so its size on disk says little.
pub const MAX_ASSET_IMAGE_PIXELS: u64 = 8192 * 8192;

/// Why a file cannot be read: the OS error kept as the source, with the path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReadError {
    /// No file at the path (or a symbolic link to nothing).
    #[error("{} does not exist", path.display())]
    NotFound {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The path is a folder, device, FIFO or socket (after following symbolic links).
    #[error("{} is not a regular file (it is {what})", path.display())]
    NotRegular {
        /// The file.
        path: PathBuf,
        /// What it is ("a folder", "a character device", ...).
        what: &'static str,
    },
    /// The file is larger than the cap (or grew past it while being read).
    #[error("{} is larger than the cap of {} ({cap_bytes} bytes): {}", path.display(), mib(*cap_bytes), size_text(*size_bytes, *cap_bytes))]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size as far as it was read or stat'ed (bytes).
        size_bytes: u64,
        /// The cap (bytes).
        cap_bytes: u64,
    },
    /// Any other OS error (permissions, I/O).
    #[error("cannot read {} ({source})", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

fn mib(bytes: u64) -> String {
    format!("{} MiB", bytes >> 20)
}

fn size_text(size_bytes: u64, cap_bytes: u64) -> String {
    if size_bytes > cap_bytes { format!("it has {size_bytes} bytes") } else { "it grew past the cap while read".into() }
}

impl ReadError {
    /// The error as a config error of `key` (the value shown is `file` as the config gave it).
    pub fn for_key(&self, key: &str, file: &str) -> ConfigError {
        ConfigError::invalid(key, format!("{file:?}"), self.to_string())
    }
}

fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a folder";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Checks that `path` is a regular file (after following symbolic links) of at most
/// `cap_bytes`; returns its size (bytes). Does not open it (a FIFO is never opened).
///
/// # Errors
/// [`ReadError`]: missing, not a regular file, larger than the cap, or unreadable metadata.
pub fn check_regular_file(path: &Path, cap_bytes: u64) -> Result<u64, ReadError> {
    let meta = std::fs::metadata(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => ReadError::NotFound { path: path.to_path_buf(), source },
        _ => ReadError::Io { path: path.to_path_buf(), source },
    })?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular { path: path.to_path_buf(), what: kind_of(&meta) });
    }
    if meta.len() > cap_bytes {
        return Err(ReadError::TooLarge { path: path.to_path_buf(), size_bytes: meta.len(), cap_bytes });
    }
    Ok(meta.len())
}

/// Opens `path` for reading after [`check_regular_file`], checks the opened file again (it may
/// have been replaced in between), and returns a reader that stops after `cap_bytes + 1` bytes:
/// a caller that gets more than `cap_bytes` bytes must fail with [`ReadError::TooLarge`].
///
/// # Errors
/// As [`check_regular_file`]; the OS error of opening.
pub fn open_regular_file(path: &Path, cap_bytes: u64) -> Result<std::io::Take<std::fs::File>, ReadError> {
    check_regular_file(path, cap_bytes)?;
    let io = |source: std::io::Error| ReadError::Io { path: path.to_path_buf(), source };
    let file = std::fs::File::open(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => ReadError::NotFound { path: path.to_path_buf(), source },
        _ => ReadError::Io { path: path.to_path_buf(), source },
    })?;
    let meta = file.metadata().map_err(io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular { path: path.to_path_buf(), what: kind_of(&meta) });
    }
    Ok(file.take(cap_bytes.saturating_add(1)))
}

/// Reads a whole regular file of at most `cap_bytes` (see [`open_regular_file`]).
///
/// # Errors
/// [`ReadError`]: missing, not a regular file, larger than the cap (also when it grows past the
/// cap while read), or an OS error.
pub fn read_regular_file(path: &Path, cap_bytes: u64) -> Result<Vec<u8>, ReadError> {
    let mut reader = open_regular_file(path, cap_bytes)?;
    let mut bytes = Vec::new();
    reader.read_to_end(&mut bytes).map_err(|source| ReadError::Io { path: path.to_path_buf(), source })?;
    if bytes.len() as u64 > cap_bytes {
        return Err(ReadError::TooLarge { path: path.to_path_buf(), size_bytes: bytes.len() as u64, cap_bytes });
    }
    Ok(bytes)
}
