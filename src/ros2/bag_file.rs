//! The bag's file on disk: written so that a killed run leaves a bag that can be repaired, and
//! the repair (`simserpent bag-repair RUN_FOLDER`).
//!
//! [`RecordAlignedFile`] hands the file only whole MCAP records (the MCAP writer buffers each
//! chunk and writes it whole: `disable_seeking`): the bytes of a record that is not complete yet
//! stay in memory. So a run killed with SIGKILL leaves `run.mcap` as the magic, the header and
//! complete chunks with their message indexes, without the summary and footer that the end of the
//! run writes. Readers that need the footer (Python `mcap`'s `iter_messages()`) cannot open such
//! a bag; [`repair_bag`] reads every whole record, stops at the first incomplete one, and writes
//! the messages into a complete bag (summary, indexes, footer) in its place.

use std::borrow::Cow;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The bag's file name in the run folder.
pub const FILE_NAME: &str = "run.mcap";

/// The MCAP magic bytes at the start (and end) of every file.
const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// A file that receives only whole MCAP records (see the module doc). `Write` buffers; whole
/// records go to the file as soon as this many bytes are pending, and at [`Write::flush`].
pub struct RecordAlignedFile {
    file: File,
    pending: Vec<u8>,
    /// Bytes at the start of `pending` that are not records (the leading magic).
    skip: usize,
    next_commit: usize,
}

/// Pending bytes that trigger writing the whole records among them.
const COMMIT_BYTES: usize = 256 * 1024;

impl RecordAlignedFile {
    /// Wraps a new, empty file.
    pub fn new(file: File) -> Self {
        Self { file, pending: Vec::with_capacity(2 * COMMIT_BYTES), skip: MAGIC.len(), next_commit: COMMIT_BYTES }
    }

    /// Length of the whole records at the start of `pending` (after `skip`).
    fn whole_records(&self) -> usize {
        let mut at = self.skip;
        while self.pending.len() - at >= 9 {
            let mut len = [0u8; 8];
            len.copy_from_slice(&self.pending[at + 1..at + 9]);
            let Some(end) = usize::try_from(u64::from_le_bytes(len)).ok().and_then(|l| (at + 9).checked_add(l)) else {
                break;
            };
            if end > self.pending.len() {
                break;
            }
            at = end;
        }
        at
    }

    /// Writes the whole records pending to the file.
    fn commit(&mut self) -> std::io::Result<()> {
        let n = self.whole_records();
        if self.pending.len() >= self.skip && n > 0 {
            self.file.write_all(&self.pending[..n])?;
            self.pending.drain(..n);
            self.skip = 0;
        }
        self.next_commit = self.pending.len() + COMMIT_BYTES;
        Ok(())
    }

    /// Writes everything pending (the end of the file: footer and magic) and returns the file.
    ///
    /// # Errors
    /// The OS error of the write.
    pub fn finish(mut self) -> std::io::Result<File> {
        self.file.write_all(&self.pending)?;
        self.pending.clear();
        Ok(self.file)
    }
}

impl Write for RecordAlignedFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.pending.extend_from_slice(buf);
        if self.pending.len() >= self.next_commit {
            self.commit()?;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.commit()
    }
}

/// What [`repair_bag`] did.
#[derive(Debug, Clone)]
pub struct RepairReport {
    /// The bag rewritten.
    pub path: PathBuf,
    /// The original, kept beside it (`run.damaged.mcap`); `None` when the bag was complete.
    pub original: Option<PathBuf>,
    /// Messages in the repaired bag.
    pub messages: u64,
    /// Why reading stopped (the incomplete tail), or `None` when the bag was whole.
    pub stopped: Option<String>,
}

/// Errors of [`repair_bag`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RepairError {
    /// The bag cannot be read by SimSerpent's reader rule ([`crate::files`]).
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// Not an MCAP file (no magic), or nothing recoverable.
    #[error("{}: {message}", path.display())]
    NotABag {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Writing the repaired bag failed.
    #[error("cannot write {}: {message}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
}

/// The most bytes of a bag [`repair_bag`] reads (it holds the whole file in memory): 16 GiB.
pub const MAX_BAG_BYTES: u64 = 16 << 30;

/// Repairs `run.mcap` of `run_folder` after a crash: reads every whole record (stopping at the
/// first incomplete or damaged one), writes the messages as a complete bag in its place and keeps
/// the original as `run.damaged.mcap`. A complete bag is left as it is.
///
/// # Errors
/// [`RepairError`]: the file is not a bag, cannot be read by the reader rule, or the repaired
/// bag cannot be written.
pub fn repair_bag(run_folder: &Path) -> Result<RepairReport, RepairError> {
    let path = run_folder.join(FILE_NAME);
    let bytes = crate::files::read_in(run_folder, &path, MAX_BAG_BYTES)?;
    let not_a_bag = |message: String| RepairError::NotABag { path: path.clone(), message };
    if !bytes.starts_with(MAGIC) {
        return Err(not_a_bag("not an MCAP file (it does not start with the MCAP magic)".into()));
    }
    if mcap::Summary::read(&bytes).ok().flatten().is_some() && bytes.ends_with(MAGIC) {
        let messages = mcap::MessageStream::new(&bytes).map(|s| s.filter(Result::is_ok).count() as u64).unwrap_or(0);
        return Ok(RepairReport { path, original: None, messages, stopped: None });
    }
    let stream = mcap::MessageStream::new_with_options(&bytes, mcap::read::Options::IgnoreEndMagic.into())
        .map_err(|e| not_a_bag(e.to_string()))?;
    let repaired = run_folder.join("run.repaired.mcap.tmp");
    let write_err = |e: &dyn std::fmt::Display| RepairError::Write { path: repaired.clone(), message: e.to_string() };
    let file = crate::files::open_for_writing(&repaired, false)?;
    let mut writer = mcap::WriteOptions::new()
        .profile("ros2")
        .library(format!("simserpent {} (bag-repair)", env!("CARGO_PKG_VERSION")))
        .compression(Some(mcap::Compression::Zstd))
        .compression_threads(0)
        .create(std::io::BufWriter::new(file))
        .map_err(|e| write_err(&e))?;
    let (mut messages, mut stopped) = (0u64, None);
    for message in stream {
        match message {
            Ok(m) => {
                let m = mcap::Message { data: Cow::Borrowed(&m.data[..]), ..m };
                writer.write(&m).map_err(|e| write_err(&e))?;
                messages += 1;
            }
            Err(e) => {
                stopped = Some(e.to_string());
                break;
            }
        }
    }
    writer.finish().map_err(|e| write_err(&e))?;
    let inner = writer.into_inner();
    let file = inner.into_inner().map_err(|e| write_err(&e.error().to_string()))?;
    file.sync_all().map_err(|e| write_err(&e))?;
    drop(file);
    let original = run_folder.join("run.damaged.mcap");
    if std::fs::symlink_metadata(&original).is_ok() {
        let _ = std::fs::remove_file(&repaired);
        return Err(RepairError::Write {
            path: original,
            message: "exists already (a bag repaired before); move it away to repair again".into(),
        });
    }
    std::fs::rename(&path, &original).map_err(|e| write_err(&e))?;
    std::fs::rename(&repaired, &path).map_err(|e| write_err(&e))?;
    Ok(RepairReport {
        path,
        original: Some(original),
        messages,
        stopped: stopped.or(Some("no summary or footer".into())),
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn record_aligned_file_writes_only_whole_records() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        let mut f = RecordAlignedFile::new(File::create(&path).unwrap());
        f.write_all(MAGIC).unwrap();
        // A whole record (opcode, length 3, body) and half of a second.
        f.write_all(&[1, 3, 0, 0, 0, 0, 0, 0, 0, 7, 7, 7]).unwrap();
        f.write_all(&[6, 255, 255, 255, 255, 255, 255, 255, 255, 1]).unwrap();
        f.flush().unwrap();
        assert_eq!(std::fs::read(&path).unwrap().len(), 8 + 12);
        let file = f.finish().unwrap();
        drop(file);
        assert_eq!(std::fs::read(&path).unwrap().len(), 8 + 12 + 10);
    }
}
