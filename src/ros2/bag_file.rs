//! The bag's file on disk: written so that a killed run leaves a bag that can be repaired, and
//! the repair (`simserpent bag-repair RUN_FOLDER`).
//!
//! [`RecordAlignedFile`] hands the file only whole MCAP records (the MCAP writer buffers each
//! chunk and writes it whole: `disable_seeking`): the bytes of a record that is not complete yet
//! stay in memory. So a run killed with SIGKILL leaves `run.mcap` as the magic, the header and
//! complete chunks with their message indexes, without the summary and footer that the end of the
//! run writes; the first chunk holds only the schemas and channels. Readers that need the footer
//! (Python `mcap`'s `iter_messages()`) cannot open such a bag; [`repair_bag`] reads it record by
//! record, checks every chunk, keeps the messages of the whole and valid ones and writes them into
//! a complete bag (summary, indexes, footer) in its place.

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

/// The largest record [`repair_bag`] reads into memory, compressed or not: 256 MiB. A chunk is
/// read and checked whole (SimSerpent writes chunks of about 1 MiB; one message above this size
/// is no sensor data).
pub const MAX_RECORD_BYTES: u64 = 256 << 20;

/// Damage that [`repair_bag`] found and left out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Damage {
    /// Where it starts (byte offset in the file).
    pub offset: u64,
    /// How many bytes were left out.
    pub bytes: u64,
    /// What is wrong: which chunk, its time range by its header, and the check that failed.
    pub what: String,
}

/// What [`repair_bag`] did.
#[derive(Debug, Clone)]
pub struct RepairReport {
    /// The bag rewritten.
    pub path: PathBuf,
    /// The original, kept beside it (`run.damaged.mcap`); `None` when the bag was complete.
    pub original: Option<PathBuf>,
    /// Messages in the repaired bag (or in the complete bag).
    pub messages: u64,
    /// Recorded instants in the repaired bag (its `/clock` messages), as `manifest.json` now
    /// lists them for `run.mcap`.
    pub instants: u64,
    /// Chunks read.
    pub chunks: u64,
    /// Chunks kept (every one whole, its CRC valid).
    pub chunks_kept: u64,
    /// Damaged chunks and unreadable bytes, left out, in file order.
    pub damage: Vec<Damage>,
    /// Messages of whole chunks left out because their channel is defined only in damaged data.
    pub messages_without_channel: u64,
    /// Why reading stopped before the end of the file (the incomplete tail of a killed run), or
    /// `None`.
    pub stopped: Option<String>,
}

/// Errors of [`repair_bag`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RepairError {
    /// The bag or the manifest cannot be read by SimSerpent's reader rule ([`crate::files`]),
    /// or the run folder is held by another process ([`crate::files::FileError::Busy`]).
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// Not a run folder (no `manifest.json`, or one SimSerpent cannot read).
    #[error("{}: not a run folder of SimSerpent: {message}", folder.display())]
    NotARun {
        /// The folder.
        folder: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Not an MCAP file (no magic).
    #[error("{}: {message}", path.display())]
    NotABag {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Not one message could be recovered; the bag is left as it is.
    #[error("{}: nothing recoverable, the bag is left as it is: {message}", path.display())]
    NothingRecoverable {
        /// The file.
        path: PathBuf,
        /// What was found.
        message: String,
    },
    /// SIGINT/SIGTERM stopped the repair (exit code 130): the temporary file is removed, the bag
    /// is left as it is.
    #[error("interrupted by a signal (SIGINT or SIGTERM); the bag is left as it is")]
    Interrupted,
    /// Writing the repaired bag failed (its temporary file is removed; the bag is left as it
    /// is).
    #[error("cannot write {}: {message}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
}

/// Most damaged chunks named one by one in a message (the rest are counted).
const DAMAGE_NAMED: usize = 12;

impl RepairReport {
    /// The damage, one line per chunk or byte range (at most [`DAMAGE_NAMED`], then a count).
    pub fn damage_lines(&self) -> Vec<String> {
        let mut lines: Vec<String> = self
            .damage
            .iter()
            .take(DAMAGE_NAMED)
            .map(|d| format!("bytes {}–{}: {}", d.offset, d.offset + d.bytes, d.what))
            .collect();
        if self.damage.len() > DAMAGE_NAMED {
            lines.push(format!("and {} more damaged places", self.damage.len() - DAMAGE_NAMED));
        }
        lines
    }
}

/// Removes a temporary file when dropped, unless [`TempFile::keep`] was called.
struct TempFile(Option<PathBuf>);

impl TempFile {
    fn keep(&mut self) {
        self.0 = None;
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if let Some(path) = self.0.take() {
            let _ = std::fs::remove_file(path);
        }
    }
}

type RepairWriter = mcap::Writer<std::io::BufWriter<File>>;

/// A schema or channel as read, kept until the end of the file (a few KiB).
type Channels = std::collections::HashMap<u16, std::sync::Arc<mcap::Channel<'static>>>;

/// One pass over the bag (see [`repair_bag`]): reads record by record, at most one record in
/// memory at a time, checks every chunk and hands the messages of the whole ones to `out`.
struct Scan<'a> {
    file: &'a File,
    len: u64,
    body: Vec<u8>,
    schemas: std::collections::HashMap<u16, std::sync::Arc<mcap::Schema<'static>>>,
    channels: Channels,
    clock: Option<u16>,
    report: RepairReport,
    /// Whether the data section ended with a `DataEnd` record (a finished bag).
    data_end: bool,
}

fn read_at(mut file: &File, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    file.seek(SeekFrom::Start(offset))?;
    file.read_exact(buf)
}

/// The opcodes of MCAP records (0x01–0x0F) and private records (0x80 and up).
fn known_opcode(op: u8) -> bool {
    (0x01..=0x0F).contains(&op) || op >= 0x80
}

/// A chunk's records, read and checked whole: decompressed, every record parsed, its
/// `uncompressed_crc` compared; or what is wrong.
fn chunk_records(body: &[u8]) -> Result<(mcap::records::ChunkHeader, Vec<mcap::records::Record<'static>>), String> {
    let record = mcap::parse_record(mcap::records::op::CHUNK, body).map_err(|e| format!("unreadable header ({e})"))?;
    let mcap::records::Record::Chunk { header, data } = record else {
        return Err("not a chunk".into());
    };
    if header.uncompressed_size > MAX_RECORD_BYTES {
        return Err(format!(
            "its header gives {} bytes uncompressed, more than the {MAX_RECORD_BYTES} allowed",
            header.uncompressed_size
        ));
    }
    let reader = mcap::read::ChunkReader::new(header.clone(), &data).map_err(|e| e.to_string())?;
    let mut records = Vec::new();
    for r in reader {
        records.push(r.map_err(|e| e.to_string())?.into_owned());
    }
    Ok((header, records))
}

impl<'a> Scan<'a> {
    fn new(file: &'a File, len: u64, path: PathBuf) -> Self {
        Self {
            file,
            len,
            body: Vec::new(),
            schemas: Default::default(),
            channels: Default::default(),
            clock: None,
            report: RepairReport {
                path,
                original: None,
                messages: 0,
                instants: 0,
                chunks: 0,
                chunks_kept: 0,
                damage: Vec::new(),
                messages_without_channel: 0,
                stopped: None,
            },
            data_end: false,
        }
    }

    /// Reads the body of the record at `offset` (`len` bytes) into `self.body`.
    fn read_body(&mut self, offset: u64, len: u64) -> std::io::Result<()> {
        self.body.clear();
        self.body.resize(len as usize, 0);
        read_at(self.file, offset + 9, &mut self.body)
    }

    /// The opcode and length of the record at `offset`, if it is one that fits in the file.
    fn header_at(&self, offset: u64) -> std::io::Result<Option<(u8, u64)>> {
        if self.len - offset < 9 {
            return Ok(None);
        }
        let mut h = [0u8; 9];
        read_at(self.file, offset, &mut h)?;
        let op = h[0];
        let mut l = [0u8; 8];
        l.copy_from_slice(&h[1..]);
        let len = u64::from_le_bytes(l);
        let fits = len <= MAX_RECORD_BYTES && offset.checked_add(9 + len).is_some_and(|end| end <= self.len);
        Ok((known_opcode(op) && fits).then_some((op, len)))
    }

    /// The first offset at or after `from` where a whole chunk with a valid, non-zero CRC starts
    /// (after damage that broke the record structure), reading the file in blocks.
    fn resync(&mut self, from: u64) -> std::io::Result<Option<u64>> {
        const BLOCK: u64 = 1 << 20;
        let mut block = vec![0u8; BLOCK as usize];
        let mut start = from;
        while start < self.len {
            let n = BLOCK.min(self.len - start) as usize;
            read_at(self.file, start, &mut block[..n])?;
            for (i, &byte) in block.iter().enumerate().take(n) {
                if byte != mcap::records::op::CHUNK {
                    continue;
                }
                let at = start + i as u64;
                let Some((_, len)) = self.header_at(at)? else { continue };
                // Chunk header: times, sizes, CRC, compression name, compressed size.
                if len < 40 {
                    continue;
                }
                self.read_body(at, len)?;
                if let Ok((header, _)) = chunk_records(&self.body)
                    && header.uncompressed_crc != 0
                {
                    return Ok(Some(at));
                }
            }
            start += n as u64;
        }
        Ok(None)
    }

    fn damage(&mut self, offset: u64, bytes: u64, what: String) {
        self.report.damage.push(Damage { offset, bytes, what });
    }

    /// Takes the schemas and channels of a whole chunk (or of the data section); `Err` when one
    /// contradicts an earlier definition of its id.
    fn define(&mut self, records: &[mcap::records::Record<'static>]) -> Result<(), String> {
        use mcap::records::Record;
        for r in records {
            match r {
                Record::Schema { header, data } => {
                    let schema = mcap::Schema {
                        id: header.id,
                        name: header.name.clone(),
                        encoding: header.encoding.clone(),
                        data: data.clone(),
                    };
                    match self.schemas.get(&header.id) {
                        Some(old) if **old != schema => return Err(format!("it redefines schema {}", header.id)),
                        Some(_) => {}
                        None => {
                            self.schemas.insert(header.id, std::sync::Arc::new(schema));
                        }
                    }
                }
                Record::Channel(c) => {
                    let schema = if c.schema_id == 0 {
                        None
                    } else {
                        let Some(s) = self.schemas.get(&c.schema_id) else {
                            return Err(format!("channel {} names schema {}, defined nowhere", c.id, c.schema_id));
                        };
                        Some(std::sync::Arc::clone(s))
                    };
                    let channel = mcap::Channel {
                        id: c.id,
                        topic: c.topic.clone(),
                        schema,
                        message_encoding: c.message_encoding.clone(),
                        metadata: c.metadata.clone(),
                    };
                    match self.channels.get(&c.id) {
                        Some(old) if **old != channel => return Err(format!("it redefines channel {}", c.id)),
                        Some(_) => {}
                        None => {
                            if c.topic == "/clock" {
                                self.clock = Some(c.id);
                            }
                            self.channels.insert(c.id, std::sync::Arc::new(channel));
                        }
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Writes (or only counts, without `out`) the messages among `records`.
    fn messages(
        &mut self,
        records: &[mcap::records::Record<'static>],
        out: &mut Option<&mut RepairWriter>,
    ) -> Result<(), mcap::McapError> {
        for r in records {
            if let mcap::records::Record::Message { header, data } = r {
                let Some(channel) = self.channels.get(&header.channel_id) else {
                    self.report.messages_without_channel += 1;
                    continue;
                };
                if let Some(w) = out.as_deref_mut() {
                    w.write(&mcap::Message {
                        channel: std::sync::Arc::clone(channel),
                        sequence: header.sequence,
                        log_time: header.log_time,
                        publish_time: header.publish_time,
                        data: Cow::Borrowed(&data[..]),
                    })?;
                }
                self.report.messages += 1;
                if Some(header.channel_id) == self.clock {
                    self.report.instants += 1;
                }
            }
        }
        Ok(())
    }

    /// Reads the whole file from after the magic, handing the messages of every whole chunk to
    /// `out`. `Err`: the file cannot be read, or `out` cannot be written.
    fn run(&mut self, mut out: Option<&mut RepairWriter>) -> Result<(), ScanError> {
        use mcap::records::{Record, op};
        let mut pos = MAGIC.len() as u64;
        while pos < self.len && !self.data_end {
            if crate::interrupt::requested() {
                return Err(ScanError::Interrupted);
            }
            let Some((opcode, len)) = self.header_at(pos)? else {
                // A record cut by the end of the file (the last one of a killed run) or bytes
                // that are no record: go on at the next whole chunk, if there is one.
                match self.resync(pos + 1)? {
                    Some(next) => {
                        self.damage(pos, next - pos, format!("no readable record at byte {pos}"));
                        pos = next;
                        continue;
                    }
                    None => {
                        self.report.stopped =
                            Some(format!("the last {} bytes (from byte {pos}) hold no whole record", self.len - pos));
                        break;
                    }
                }
            };
            let end = pos + 9 + len;
            self.read_body(pos, len)?;
            if opcode == op::CHUNK {
                self.report.chunks += 1;
                let n = self.report.chunks;
                let checked = chunk_records(&self.body).and_then(|(header, records)| {
                    self.define(&records)?;
                    Ok((header, records))
                });
                match checked {
                    Ok((_, records)) => {
                        self.messages(&records, &mut out).map_err(ScanError::Write)?;
                        self.report.chunks_kept += 1;
                    }
                    Err(why) => {
                        let times = mcap::parse_record(op::CHUNK, &self.body).ok().and_then(|r| match r {
                            Record::Chunk { header, .. } => Some(format!(
                                " (messages at t = {:.3}–{:.3} s by its header)",
                                header.message_start_time as f64 * 1e-9,
                                header.message_end_time as f64 * 1e-9
                            )),
                            _ => None,
                        });
                        self.damage(pos, 9 + len, format!("chunk {n}{}: {why}", times.unwrap_or_default()));
                    }
                }
                pos = end;
                continue;
            }
            match mcap::parse_record(opcode, &self.body) {
                Ok(record @ (Record::Schema { .. } | Record::Channel(_))) => {
                    let record = record.into_owned();
                    if let Err(why) = self.define(std::slice::from_ref(&record)) {
                        self.damage(pos, 9 + len, why);
                    }
                }
                Ok(record @ Record::Message { .. }) => {
                    let record = record.into_owned();
                    self.messages(std::slice::from_ref(&record), &mut out).map_err(ScanError::Write)?;
                }
                Ok(Record::DataEnd(_)) => self.data_end = true,
                Ok(_) => {}
                Err(e) => match self.resync(pos + 1)? {
                    Some(next) => {
                        self.damage(pos, next - pos, format!("unreadable record at byte {pos} ({e})"));
                        pos = next;
                        continue;
                    }
                    None => {
                        self.report.stopped =
                            Some(format!("unreadable record at byte {pos} ({e}), no whole chunk after it"));
                        break;
                    }
                },
            }
            pos = end;
        }
        Ok(())
    }
}

enum ScanError {
    Read(std::io::Error),
    Write(mcap::McapError),
    Interrupted,
}

impl From<std::io::Error> for ScanError {
    fn from(e: std::io::Error) -> Self {
        Self::Read(e)
    }
}

/// An MCAP error's text; for an I/O error the OS error ("No space left on device").
fn mcap_text(e: &mcap::McapError) -> String {
    match e {
        mcap::McapError::Io(io) => io.to_string(),
        other => other.to_string(),
    }
}

/// Whether the file ends as a finished bag: a footer record and the closing magic.
fn has_footer(file: &File, len: u64) -> std::io::Result<bool> {
    // Footer: opcode, length 20, summary start, summary offset start, summary CRC; then magic.
    let footer_len = 9 + 20 + MAGIC.len() as u64;
    if len < MAGIC.len() as u64 + footer_len {
        return Ok(false);
    }
    let mut tail = [0u8; 37];
    read_at(file, len - footer_len, &mut tail)?;
    Ok(tail[0] == mcap::records::op::FOOTER && tail[1..9] == 20u64.to_le_bytes() && tail[29..] == MAGIC[..])
}

/// Repairs `run.mcap` of `run_folder`: reads the bag record by record (one chunk in memory at a
/// time), checks every chunk (decompression, every record, its `uncompressed_crc`), keeps the
/// messages of every whole and valid chunk, and names the damaged chunks and bytes it leaves out
/// — after damage that breaks the record structure it goes on at the next chunk whose CRC
/// holds. A finished bag whose chunks are all valid is left as it is; otherwise the messages go
/// into a complete bag (summary, indexes, footer) that replaces `run.mcap`, the original is kept
/// as `run.damaged.mcap`, and `manifest.json` lists `run.mcap` with the instants it now holds.
///
/// The run folder's lock ([`crate::files::RunLock`]) is held meanwhile: a run that is still going
/// on is refused, and no run starts into the folder until the repair ends.
///
/// # Errors
/// [`RepairError`]: the folder is not a run folder or is held by another process; the file is
/// not a bag, cannot be read by the reader rule, holds nothing recoverable, or the repaired bag
/// cannot be written (its temporary file is removed; the bag stays as it was).
pub fn repair_bag(run_folder: &Path) -> Result<RepairReport, RepairError> {
    use crate::record::Manifest;
    let not_a_run = |message: String| RepairError::NotARun { folder: run_folder.to_path_buf(), message };
    if !run_folder.is_dir() {
        return Err(not_a_run("it is not a folder (give the run folder that holds run.mcap)".into()));
    }
    let _lock = crate::files::RunLock::try_acquire(run_folder)?;
    let manifest_path = run_folder.join("manifest.json");
    let manifest_text = crate::files::read_text_in(run_folder, &manifest_path, crate::files::SMALL_FILE_CAP_BYTES)
        .map_err(|e| if e.is_missing() { not_a_run("it has no manifest.json".into()) } else { RepairError::File(e) })?;
    let mut manifest: Manifest =
        serde_json::from_str(&manifest_text).map_err(|e| not_a_run(format!("manifest.json: {e}")))?;

    let path = run_folder.join(FILE_NAME);
    let (file, len, path) = crate::files::open_in(run_folder, &path, u64::MAX)?;
    let read_err = |e: std::io::Error| {
        RepairError::File(crate::files::FileError::Io { what: "read", path: path.clone(), source: e })
    };
    let mut magic = [0u8; 8];
    if len < 8 || read_at(&file, 0, &mut magic).is_err() || magic != *MAGIC {
        return Err(RepairError::NotABag {
            path,
            message: "not an MCAP file (it does not start with the MCAP magic)".into(),
        });
    }

    // A finished bag: check every chunk without writing anything.
    if has_footer(&file, len).map_err(read_err)? {
        let mut scan = Scan::new(&file, len, path.clone());
        match scan.run(None) {
            Ok(()) => {}
            Err(ScanError::Read(e)) => return Err(read_err(e)),
            Err(ScanError::Write(e)) => return Err(RepairError::Write { path, message: mcap_text(&e) }),
            Err(ScanError::Interrupted) => return Err(RepairError::Interrupted),
        }
        if scan.data_end && scan.report.damage.is_empty() && scan.report.stopped.is_none() {
            return Ok(scan.report);
        }
    }

    let original = run_folder.join("run.damaged.mcap");
    if std::fs::symlink_metadata(&original).is_ok() {
        return Err(RepairError::Write {
            path: original,
            message: "exists already (a bag repaired before); move it away to repair again".into(),
        });
    }
    let repaired = run_folder.join("run.repaired.mcap.tmp");
    let write_err = |e: &dyn std::fmt::Display| RepairError::Write { path: repaired.clone(), message: e.to_string() };
    let out = crate::files::open_for_writing(&repaired, false)?;
    let mut tmp = TempFile(Some(repaired.clone()));
    let mut writer = mcap::WriteOptions::new()
        .profile("ros2")
        .library(format!("simserpent {} (bag-repair)", env!("CARGO_PKG_VERSION")))
        .compression(Some(mcap::Compression::Zstd))
        .compression_threads(0)
        .create(std::io::BufWriter::new(out))
        .map_err(|e| write_err(&mcap_text(&e)))?;
    let mut scan = Scan::new(&file, len, path.clone());
    match scan.run(Some(&mut writer)) {
        Ok(()) => {}
        Err(ScanError::Read(e)) => return Err(read_err(e)),
        Err(ScanError::Write(e)) => return Err(write_err(&mcap_text(&e))),
        Err(ScanError::Interrupted) => return Err(RepairError::Interrupted),
    }
    let mut report = scan.report;
    if report.messages == 0 {
        let mut message = format!("{} chunks read, {} whole", report.chunks, report.chunks_kept);
        if report.messages_without_channel > 0 {
            message += &format!(
                "; {} messages of whole chunks belong to channels defined only in damaged data",
                report.messages_without_channel
            );
        }
        for line in report.damage_lines() {
            message += "; ";
            message += &line;
        }
        if let Some(s) = &report.stopped {
            message += "; ";
            message += s;
        }
        return Err(RepairError::NothingRecoverable { path, message });
    }
    writer.finish().map_err(|e| write_err(&mcap_text(&e)))?;
    let file_out = writer.into_inner().into_inner().map_err(|e| write_err(&e.error().to_string()))?;
    file_out.sync_all().map_err(|e| write_err(&e))?;
    drop(file_out);
    std::fs::rename(&path, &original).map_err(|e| write_err(&e))?;
    if let Err(e) = std::fs::rename(&repaired, &path) {
        // Put the original back: the folder stays as it was.
        let _ = std::fs::rename(&original, &path);
        return Err(write_err(&e));
    }
    tmp.keep();
    crate::record::sync_folder(run_folder);
    report.original = Some(original);
    if report.stopped.is_none() && !scan.data_end {
        report.stopped = Some("no summary or footer".into());
    }
    // The manifest lists the bag with the instants it now holds.
    match manifest.tables.iter_mut().find(|(name, _)| name == FILE_NAME) {
        Some(entry) => entry.1 = report.instants,
        None => manifest.tables.push((FILE_NAME.to_string(), report.instants)),
    }
    manifest.write(run_folder).map_err(|e| RepairError::Write { path: manifest_path, message: e.to_string() })?;
    Ok(report)
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

    /// (topic, sequence, log time, data) of every message.
    type Messages = Vec<(String, u32, u64, Vec<u8>)>;

    const MESSAGES: u32 = 600;

    /// A bag as a run writes it (definitions, then chunks of about 4 KiB: some 30), of
    /// `/clock` and `/data` messages; `killed`: without its summary and footer, as SIGKILL
    /// leaves it. With `definitions_apart` the schemas and channels are in a chunk of their own
    /// (as [`super::super::bag::BagWriter`] writes them). Returns the messages written.
    fn write_bag(folder: &Path, killed: bool, definitions_apart: bool) -> Messages {
        let path = folder.join(FILE_NAME);
        let file = File::create(&path).unwrap();
        let mut w = mcap::WriteOptions::new()
            .profile("ros2")
            .compression(Some(mcap::Compression::Zstd))
            .chunk_size(Some(4096))
            .disable_seeking(true)
            .create(mcap::write::NoSeek::new(RecordAlignedFile::new(file)))
            .unwrap();
        let schema = w.add_schema("std_msgs/msg/UInt8MultiArray", "ros2msg", b"uint8[] data").unwrap();
        let clock = w.add_channel(schema, "/clock", "cdr", &Default::default()).unwrap();
        let data = w.add_channel(schema, "/data", "cdr", &Default::default()).unwrap();
        if definitions_apart {
            w.flush().unwrap();
        }
        let mut written = Vec::new();
        let mut x = 0x2545_F491_u32;
        for i in 0..MESSAGES {
            let t = u64::from(i / 2) * 1_000_000;
            let (channel, topic) = if i % 2 == 0 { (clock, "/clock") } else { (data, "/data") };
            // Little-compressible bytes, so that chunks hold few messages.
            let payload: Vec<u8> = (0..120)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    (x >> 24) as u8
                })
                .collect();
            let header =
                mcap::records::MessageHeader { channel_id: channel, sequence: i, log_time: t, publish_time: t };
            w.write_to_known_channel(&header, &payload).unwrap();
            written.push((topic.to_string(), i, t, payload));
        }
        if killed {
            w.flush().unwrap();
            let bytes = std::fs::read(&path).unwrap();
            drop(w);
            std::fs::write(&path, bytes).unwrap();
        } else {
            w.finish().unwrap();
            let file = w.into_inner().into_inner().finish().unwrap();
            drop(file);
        }
        let manifest = crate::record::Manifest {
            simserpent_version: String::new(),
            mujoco_version: String::new(),
            mujoco_rs_version: String::new(),
            seed: 0,
            status: crate::record::RunStatus::Incomplete,
            error: None,
            started_utc: String::new(),
            wall_time_secs: 0.0,
            steps: 0,
            simulated_secs: 0.0,
            duration_secs: 1.0,
            record_every_n_steps: 1,
            command_line: Vec::new(),
            config_source: String::new(),
            robot_file: None,
            tables: vec![(FILE_NAME.to_string(), 0)],
            mujoco_warnings: Vec::new(),
            summary: None,
            plots: None,
            ros2: None,
        };
        manifest.write(folder).unwrap();
        written
    }

    /// The messages of a complete bag, read with the `mcap` crate's reader (footer needed).
    fn read_messages(path: &Path) -> Messages {
        let bytes = std::fs::read(path).unwrap();
        assert!(mcap::Summary::read(&bytes).unwrap().is_some(), "a complete bag");
        mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| {
                let m = m.unwrap();
                (m.channel.topic.clone(), m.sequence, m.log_time, m.data.to_vec())
            })
            .collect()
    }

    /// (offset, length) of every chunk record of a bag.
    fn chunks(path: &Path) -> Vec<(usize, usize)> {
        let bytes = std::fs::read(path).unwrap();
        let mut at = 8;
        let mut out = Vec::new();
        while at + 9 <= bytes.len() {
            let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
            if bytes[at] == mcap::records::op::CHUNK {
                out.push((at, 9 + len));
            }
            if bytes[at] == mcap::records::op::DATA_END {
                break;
            }
            at += 9 + len;
        }
        out
    }

    /// The messages of chunk `(offset, length)` (by sequence number, from the undamaged file).
    fn chunk_sequences(path: &Path, chunk: (usize, usize)) -> Vec<u32> {
        let bytes = std::fs::read(path).unwrap();
        let (header, records) = chunk_records(&bytes[chunk.0 + 9..chunk.0 + chunk.1]).unwrap();
        assert!(header.uncompressed_crc != 0);
        records
            .iter()
            .filter_map(|r| match r {
                mcap::records::Record::Message { header, .. } => Some(header.sequence),
                _ => None,
            })
            .collect()
    }

    fn damage(path: &Path, offset: usize, bytes: usize) {
        let mut b = std::fs::read(path).unwrap();
        b[offset..offset + bytes].fill(0);
        std::fs::write(path, b).unwrap();
    }

    fn manifest_instants(folder: &Path) -> u64 {
        let m: crate::record::Manifest =
            serde_json::from_str(&std::fs::read_to_string(folder.join("manifest.json")).unwrap()).unwrap();
        m.tables.iter().find(|(n, _)| n == FILE_NAME).unwrap().1
    }

    /// Zeroes 64 bytes inside the compressed data of chunk `which` of a killed bag, repairs it
    /// and checks: that chunk alone is left out and named, every other message is kept byte for
    /// byte, the manifest lists the instants kept.
    fn damaged_chunk_is_left_out(which: usize) {
        let dir = tempfile::tempdir().unwrap();
        let written = write_bag(dir.path(), true, true);
        let path = dir.path().join(FILE_NAME);
        let all = chunks(&path);
        assert!(all.len() >= 20, "{} chunks", all.len());
        let chunk = all[which];
        let lost = chunk_sequences(&path, chunk);
        assert!(!lost.is_empty());
        damage(&path, chunk.0 + chunk.1 / 2, 64);
        let report = repair_bag(dir.path()).unwrap();
        assert_eq!(report.chunks, all.len() as u64);
        assert_eq!(report.chunks_kept, all.len() as u64 - 1);
        assert_eq!(report.damage.len(), 1, "{:?}", report.damage);
        assert_eq!(report.damage[0].offset, chunk.0 as u64);
        assert!(report.damage[0].what.starts_with(&format!("chunk {}", which + 1)), "{:?}", report.damage);
        let expected: Messages = written.into_iter().filter(|m| !lost.contains(&m.1)).collect();
        assert_eq!(read_messages(&path), expected, "every other message kept, byte for byte");
        assert_eq!(report.messages, expected.len() as u64);
        let clocks = expected.iter().filter(|m| m.0 == "/clock").count() as u64;
        assert_eq!((report.instants, manifest_instants(dir.path())), (clocks, clocks));
        assert!(dir.path().join("run.damaged.mcap").is_file());
        assert!(!dir.path().join("run.repaired.mcap.tmp").exists());
    }

    #[test]
    fn damage_in_a_middle_chunk_leaves_out_that_chunk_only() {
        damaged_chunk_is_left_out(12);
    }

    #[test]
    fn damage_in_the_first_chunk_of_messages_keeps_every_chunk_after_it() {
        // Chunk 0 holds the definitions; chunk 1 the first messages.
        damaged_chunk_is_left_out(1);
    }

    #[test]
    fn damage_in_a_complete_bag_is_found_and_repaired_and_a_sound_one_left_alone() {
        let dir = tempfile::tempdir().unwrap();
        let written = write_bag(dir.path(), false, true);
        let path = dir.path().join(FILE_NAME);
        let before = std::fs::read(&path).unwrap();
        let report = repair_bag(dir.path()).unwrap();
        assert!(report.original.is_none() && report.damage.is_empty());
        assert_eq!(report.messages, written.len() as u64);
        assert_eq!(std::fs::read(&path).unwrap(), before, "left as it is");
        let chunk = chunks(&path)[5];
        let lost = chunk_sequences(&path, chunk);
        damage(&path, chunk.0 + chunk.1 - 40, 16);
        let report = repair_bag(dir.path()).unwrap();
        assert_eq!(report.damage.len(), 1, "{:?}", report.damage);
        assert_eq!(read_messages(&path).len(), written.len() - lost.len());
    }

    #[test]
    fn a_broken_record_header_is_skipped_to_the_next_valid_chunk() {
        let dir = tempfile::tempdir().unwrap();
        let written = write_bag(dir.path(), true, true);
        let path = dir.path().join(FILE_NAME);
        let all = chunks(&path);
        let lost = chunk_sequences(&path, all[7]);
        // The opcode and length of chunk 7: the record structure is lost until chunk 8.
        {
            let mut b = std::fs::read(&path).unwrap();
            b[all[7].0..all[7].0 + 9].fill(0xff);
            std::fs::write(&path, b).unwrap();
        }
        let report = repair_bag(dir.path()).unwrap();
        assert_eq!(report.damage.len(), 1, "{:?}", report.damage);
        assert_eq!(report.damage[0].offset, all[7].0 as u64);
        assert_eq!(report.damage[0].offset + report.damage[0].bytes, all[8].0 as u64, "resumes at chunk 8");
        let expected: Messages = written.into_iter().filter(|m| !lost.contains(&m.1)).collect();
        assert_eq!(read_messages(&path), expected);
    }

    #[test]
    fn nothing_recoverable_leaves_the_bag_alone_and_exits_with_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        write_bag(dir.path(), true, true);
        // Random bytes after the magic.
        let mut x = 88_172_645_463_325_252_u64;
        let mut bytes = MAGIC.to_vec();
        bytes.extend((0..300_000).map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 56) as u8
        }));
        std::fs::write(&path, &bytes).unwrap();
        let e = repair_bag(dir.path()).unwrap_err();
        assert!(matches!(e, RepairError::NothingRecoverable { .. }), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), bytes, "left as it is");
        assert!(!dir.path().join("run.repaired.mcap.tmp").exists() && !dir.path().join("run.damaged.mcap").exists());
        // Random bytes without the magic: not a bag.
        std::fs::write(&path, &bytes[8..]).unwrap();
        assert!(matches!(repair_bag(dir.path()).unwrap_err(), RepairError::NotABag { .. }));
        // The definitions damaged (a bag whose first chunk holds them and the first messages):
        // the messages of every later chunk have no channel.
        let written = write_bag(dir.path(), true, false);
        let first = chunks(&path)[0];
        damage(&path, first.0 + first.1 / 2, 64);
        let e = repair_bag(dir.path()).unwrap_err();
        assert!(
            matches!(e, RepairError::NothingRecoverable { .. }) && e.to_string().contains("defined only in damaged"),
            "{e}"
        );
        assert!(written.len() > 100);
    }

    #[test]
    fn a_run_folder_in_use_or_without_a_manifest_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        write_bag(dir.path(), true, true);
        let before = std::fs::read(dir.path().join(FILE_NAME)).unwrap();
        let held = crate::files::RunLock::try_acquire(dir.path()).unwrap();
        let e = repair_bag(dir.path()).unwrap_err();
        assert!(matches!(e, RepairError::File(crate::files::FileError::Busy { .. })), "{e}");
        assert!(e.to_string().contains("in use by another process"), "{e}");
        assert_eq!(std::fs::read(dir.path().join(FILE_NAME)).unwrap(), before, "not touched");
        drop(held);
        std::fs::remove_file(dir.path().join("manifest.json")).unwrap();
        let e = repair_bag(dir.path()).unwrap_err();
        assert!(matches!(e, RepairError::NotARun { .. }) && e.to_string().contains("no manifest.json"), "{e}");
        let e = repair_bag(&dir.path().join(FILE_NAME)).unwrap_err();
        assert!(matches!(e, RepairError::NotARun { .. }) && e.to_string().contains("not a folder"), "{e}");
    }
}
