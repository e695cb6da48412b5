//! Video files from RGB frames: MP4 (H.264) through an `ffmpeg` subprocess, or GIF built in.
//!
//! MP4: frames go as raw RGB24 into `ffmpeg -f rawvideo … -c:v libx264 -pix_fmt yuv420p`; the GPL
//! encoder stays outside our binary. The program is `ffmpeg` on `PATH`, or the one that
//! `SIMSERPENT_FFMPEG` names (`SIMSERPENT_FFMPEG=none` acts as if it were missing).
//!
//! GIF: a fixed 6×7×6 colour cube (252 colours), so a frame is quantised with one table look-up
//! per pixel instead of a per-frame palette search: fast, with visible banding on smooth shading.
//! A GIF's frame delay is in hundredths of a second, so the playback rate is 100 / round(100 /
//! fps) frames per second (30 fps plays at 33.3).

use super::RenderError;
use crate::config::VideoFormat;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};

/// The ffmpeg program to use, if there is one that runs.
pub fn ffmpeg_program() -> Option<String> {
    let program = std::env::var("SIMSERPENT_FFMPEG").unwrap_or_else(|_| "ffmpeg".to_string());
    if program.is_empty() || program == "none" {
        return None;
    }
    let ok = Command::new(&program)
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    ok.then_some(program)
}

/// A video file being written.
pub enum VideoWriter {
    /// Animated GIF.
    Gif(Box<GifWriter>),
    /// MP4 through ffmpeg.
    Mp4(Mp4Writer),
}

impl std::fmt::Debug for VideoWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VideoWriter").field("path", &self.path()).finish_non_exhaustive()
    }
}

impl VideoWriter {
    /// Creates `<stem>.mp4` or `<stem>.gif`. MP4 without a working ffmpeg falls back to GIF
    /// with a warning in the log (the command line prints it on stderr).
    pub fn create(
        stem: &Path,
        format: VideoFormat,
        width: usize,
        height: usize,
        fps: f64,
    ) -> Result<Self, RenderError> {
        match format {
            VideoFormat::Mp4 => match ffmpeg_program() {
                Some(program) => {
                    Ok(Self::Mp4(Mp4Writer::create(&program, &stem.with_extension("mp4"), width, height, fps)?))
                }
                None => {
                    let msg = "ffmpeg is not installed (or SIMSERPENT_FFMPEG names no working program): \
                               writing a GIF instead of an MP4 (install ffmpeg, e.g. `apt-get install ffmpeg`)";
                    log::warn!("{msg}");
                    Ok(Self::Gif(Box::new(GifWriter::create(&stem.with_extension("gif"), width, height, fps)?)))
                }
            },
            VideoFormat::Gif => {
                Ok(Self::Gif(Box::new(GifWriter::create(&stem.with_extension("gif"), width, height, fps)?)))
            }
        }
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        match self {
            Self::Gif(g) => &g.path,
            Self::Mp4(m) => &m.path,
        }
    }

    /// Frames written so far.
    pub fn frames(&self) -> u64 {
        match self {
            Self::Gif(g) => g.frames,
            Self::Mp4(m) => m.frames,
        }
    }

    /// Appends one RGB frame (rows top to bottom, `width × height × 3` bytes).
    pub fn push(&mut self, rgb: &[u8]) -> Result<(), RenderError> {
        match self {
            Self::Gif(g) => g.push(rgb),
            Self::Mp4(m) => m.push(rgb),
        }
    }

    /// Finishes the file; returns its path and the number of frames.
    pub fn finish(self) -> Result<(PathBuf, u64), RenderError> {
        match self {
            Self::Gif(g) => (*g).finish(),
            Self::Mp4(m) => m.finish(),
        }
    }
}

/// Levels of the fixed GIF palette per channel (6 × 7 × 6 = 252 colours).
const LEVELS: [u32; 3] = [6, 7, 6];

fn gif_palette() -> Vec<u8> {
    let mut p = Vec::with_capacity(256 * 3);
    for r in 0..LEVELS[0] {
        for g in 0..LEVELS[1] {
            for b in 0..LEVELS[2] {
                for (v, n) in [(r, LEVELS[0]), (g, LEVELS[1]), (b, LEVELS[2])] {
                    p.push((v * 255 / (n - 1)) as u8);
                }
            }
        }
    }
    p.resize(256 * 3, 0);
    p
}

/// Maps a channel value 0..=255 to the nearest of `n` levels.
fn level(v: u8, n: u32) -> u32 {
    (u32::from(v) * (n - 1) + 127) / 255
}

/// An animated GIF being written.
pub struct GifWriter {
    path: PathBuf,
    encoder: gif::Encoder<BufWriter<File>>,
    width: u16,
    height: u16,
    delay_cs: u16,
    indexed: Vec<u8>,
    lut: [[u8; 256]; 3],
    frames: u64,
}

impl GifWriter {
    fn create(path: &Path, width: usize, height: usize, fps: f64) -> Result<Self, RenderError> {
        let enc = |message: String| RenderError::Encoder { path: path.to_path_buf(), message };
        let (w, h) = (
            u16::try_from(width).map_err(|_| enc("too wide for a GIF".into()))?,
            u16::try_from(height).map_err(|_| enc("too high for a GIF".into()))?,
        );
        let file = crate::files::open_for_writing(path, false)?;
        let mut encoder =
            gif::Encoder::new(BufWriter::new(file), w, h, &gif_palette()).map_err(|e| enc(e.to_string()))?;
        encoder.set_repeat(gif::Repeat::Infinite).map_err(|e| enc(e.to_string()))?;
        let mut lut = [[0u8; 256]; 3];
        let strides = [LEVELS[1] * LEVELS[2], LEVELS[2], 1];
        for (c, table) in lut.iter_mut().enumerate() {
            for (v, slot) in table.iter_mut().enumerate() {
                *slot = (level(v as u8, LEVELS[c]) * strides[c]) as u8;
            }
        }
        Ok(Self {
            path: path.to_path_buf(),
            encoder,
            width: w,
            height: h,
            delay_cs: (100.0 / fps).round().clamp(1.0, 65535.0) as u16,
            indexed: vec![0; width * height],
            lut,
            frames: 0,
        })
    }

    fn push(&mut self, rgb: &[u8]) -> Result<(), RenderError> {
        let n = self.indexed.len();
        if rgb.len() != n * 3 {
            return Err(RenderError::Encoder {
                path: self.path.clone(),
                message: format!("frame has {} bytes, expected {}", rgb.len(), n * 3),
            });
        }
        for (dst, px) in self.indexed.iter_mut().zip(rgb.chunks_exact(3)) {
            *dst = self.lut[0][px[0] as usize] + self.lut[1][px[1] as usize] + self.lut[2][px[2] as usize];
        }
        let frame = gif::Frame {
            width: self.width,
            height: self.height,
            delay: self.delay_cs,
            buffer: std::borrow::Cow::Borrowed(&self.indexed),
            ..gif::Frame::default()
        };
        self.encoder
            .write_frame(&frame)
            .map_err(|e| RenderError::Encoder { path: self.path.clone(), message: e.to_string() })?;
        self.frames += 1;
        Ok(())
    }

    fn finish(self) -> Result<(PathBuf, u64), RenderError> {
        let path = self.path;
        let mut out = self
            .encoder
            .into_inner()
            .map_err(|e| RenderError::Encoder { path: path.clone(), message: e.to_string() })?;
        out.flush().map_err(RenderError::io(&path))?;
        Ok((path, self.frames))
    }
}

/// An MP4 being written by an ffmpeg subprocess.
pub struct Mp4Writer {
    path: PathBuf,
    child: Child,
    stdin: Option<BufWriter<ChildStdin>>,
    frame_bytes: usize,
    frames: u64,
}

impl Mp4Writer {
    fn create(program: &str, path: &Path, width: usize, height: usize, fps: f64) -> Result<Self, RenderError> {
        let enc = |message: String| RenderError::Encoder { path: path.to_path_buf(), message };
        // ffmpeg opens the file by name: a link planted there is refused first (the writer rule
        // of `crate::files`), and the file it overwrites is a regular one.
        drop(crate::files::open_for_writing(path, false)?);
        let mut child = Command::new(program)
            .args(["-hide_banner", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s"])
            .arg(format!("{width}x{height}"))
            .arg("-r")
            .arg(format!("{fps}"))
            .args(["-i", "-", "-an", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
            .args(["-c:v", "libx264", "-preset", "veryfast", "-pix_fmt", "yuv420p", "-movflags", "+faststart"])
            .arg(path)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| enc(format!("cannot start {program} ({e})")))?;
        let stdin = child.stdin.take().map(|s| BufWriter::with_capacity(1 << 20, s));
        Ok(Self { path: path.to_path_buf(), child, stdin, frame_bytes: width * height * 3, frames: 0 })
    }

    fn push(&mut self, rgb: &[u8]) -> Result<(), RenderError> {
        if rgb.len() != self.frame_bytes {
            return Err(RenderError::Encoder {
                path: self.path.clone(),
                message: format!("frame has {} bytes, expected {}", rgb.len(), self.frame_bytes),
            });
        }
        let Some(stdin) = self.stdin.as_mut() else {
            return Err(RenderError::Encoder { path: self.path.clone(), message: "ffmpeg's input is closed".into() });
        };
        stdin.write_all(rgb).map_err(|e| RenderError::Encoder {
            path: self.path.clone(),
            message: format!("ffmpeg stopped taking frames ({e})"),
        })?;
        self.frames += 1;
        Ok(())
    }

    fn finish(mut self) -> Result<(PathBuf, u64), RenderError> {
        let flushed = match self.stdin.take() {
            Some(mut s) => s.flush(),
            None => Ok(()),
        };
        // Dropping stdin closes the pipe: ffmpeg finishes the file and exits.
        let output = self
            .child
            .wait_with_output()
            .map_err(|e| RenderError::Encoder { path: self.path.clone(), message: format!("ffmpeg: {e}") })?;
        if !output.status.success() || flushed.is_err() {
            return Err(RenderError::Encoder {
                path: self.path,
                message: format!(
                    "ffmpeg failed ({}): {}",
                    output.status,
                    String::from_utf8_lossy(&output.stderr).trim()
                ),
            });
        }
        Ok((self.path, self.frames))
    }
}
