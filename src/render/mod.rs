//! Pictures of a run: images at chosen times, videos and the interactive viewer.
//!
//! - [`state`]: `state.csv`, the full engine state on recorded steps, so a run can be replayed;
//! - [`painter`] (cargo feature `render`, Linux only): offscreen rendering on the CPU through EGL;
//! - [`video`]: MP4 through `ffmpeg`, or GIF built in;
//! - [`viewer`]: MuJoCo's interactive viewer (cargo feature `viewer`, else Python's
//!   `mujoco.viewer` from the same 3.17 wheel).
//!
//! During a run, [`RunVisuals`] is called by the step loop ([`crate::run`]): it writes
//! `state.csv` on recorded steps and, when a video or images are configured, paints the frames
//! whose time has come. Afterwards, [`render_run_folder`] replays `state.csv` into the same
//! pictures (`simserpent render RUN_FOLDER`).

#[cfg(offscreen_render)]
pub mod painter;
pub mod state;
pub mod video;
pub mod viewer;

use crate::config::{CameraKind, Config, ConfigError};
use std::path::{Path, PathBuf};

pub use state::{STATE_FILE, StateTrack, StateWriter};
pub use video::VideoWriter;

/// Errors of making pictures; they name the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// Writing a file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// Reading a file failed.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A file of a run folder is not what it should be.
    #[error("{path}: {message}")]
    BadFile {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The config of a run folder (or an override) is invalid.
    #[error("config {file}: {source}")]
    Config {
        /// The file.
        file: PathBuf,
        /// The problem.
        #[source]
        source: ConfigError,
    },
    /// Offscreen rendering is not available (no EGL, or a build without the `render` feature).
    #[error("offscreen rendering is not available: {0}")]
    NoRenderer(String),
    /// The interactive viewer cannot open.
    #[error("{0}")]
    NoViewer(String),
    /// MuJoCo refused a state.
    #[error("engine: {0}")]
    Engine(String),
    /// SIGINT/SIGTERM ([`crate::interrupt`]) stopped the rendering (exit code 130): the images
    /// written so far stay, the video ends at the last frame drawn.
    #[error("rendering interrupted by a signal (SIGINT or SIGTERM); the files written so far are kept")]
    Interrupted,
    /// A file or folder the pictures go into breaks the writer rule of [`crate::files`] (a link
    /// out of the run folder, a FIFO), or cannot be created.
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// A video or image encoder failed.
    #[error("{path}: {message}")]
    Encoder {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
}

impl RenderError {
    pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> RenderError + '_ {
        move |source| RenderError::Io { path: path.to_path_buf(), source }
    }

    pub(crate) fn read(path: &Path) -> impl FnOnce(std::io::Error) -> RenderError + '_ {
        move |source| RenderError::Read { path: path.to_path_buf(), source }
    }
}

/// Writes a PNG (RGB, 8 bits) ([`crate::plot::write_png`], with this module's error).
pub fn write_png(path: &Path, rgb: &[u8], width: usize, height: usize) -> Result<(), RenderError> {
    crate::plot::write_png(path, rgb, width, height).map_err(|e| match e {
        crate::plot::PngError::Io(source) => RenderError::Io { path: path.to_path_buf(), source },
        crate::plot::PngError::Encoder(message) => RenderError::Encoder { path: path.to_path_buf(), message },
    })
}

/// Writes `t = 1.234 s` into the top left corner of an RGB picture.
pub fn overlay_time(rgb: &mut [u8], width: usize, height: usize, time_secs: f64) {
    use plotters::prelude::*;
    crate::plot::register_font();
    if rgb.len() != width * height * 3 {
        return;
    }
    let size = (height as f64 / 20.0).clamp(10.0, 48.0);
    let text = format!("t = {time_secs:.2} s");
    let root = BitMapBackend::with_buffer(rgb, (width as u32, height as u32)).into_drawing_area();
    let pad = (size * 0.3) as i32;
    let box_w = (size * 0.62 * text.len() as f64) as i32 + 2 * pad;
    let box_h = size as i32 + 2 * pad;
    // Drawing into a buffer of the right size cannot fail; a failure only loses the overlay.
    let _ = root.draw(&Rectangle::new([(0, 0), (box_w, box_h)], RGBColor(255, 255, 255).mix(0.75).filled()));
    let _ = root.draw(&Text::new(text, (pad, pad), ("sans-serif", size).into_font().color(&BLACK)));
    let _ = root.present();
}

/// Frame `i` of a video is the state at simulated time `i × playback_speed / frames_per_sec`.
#[cfg(offscreen_render)]
fn frame_interval_secs(config: &Config) -> f64 {
    config.video.playback_speed / config.video.frames_per_sec
}

/// The file stem of a video: `<folder>/video_<camera>`.
pub fn video_stem(folder: &Path, camera: CameraKind) -> PathBuf {
    folder.join(format!("video_{}", camera.name()))
}

/// The folder of a run's images.
pub const IMAGES_DIR: &str = "images";

/// The file of an image: `<folder>/images/<camera>_<time>s.png`.
pub fn image_path(folder: &Path, camera: CameraKind, time_secs: f64) -> PathBuf {
    folder.join(IMAGES_DIR).join(format!("{}_{:.3}s.png", camera.name(), time_secs))
}

/// What the step loop of a run calls: `state.csv` on recorded steps, frames and images on time.
pub struct RunVisuals {
    state: Option<StateWriter>,
    #[cfg(offscreen_render)]
    live: Option<live::Live>,
    #[cfg(feature = "viewer")]
    viewer: Option<viewer::LiveViewer>,
    outputs: Vec<PathBuf>,
}

impl std::fmt::Debug for RunVisuals {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunVisuals").field("state", &self.state.is_some()).finish_non_exhaustive()
    }
}

impl RunVisuals {
    /// What a run in `folder` needs (`model.xml` must already be there), or `None` when nothing
    /// is wanted: no `state.csv` (`render.record_state` off or recording disabled), no video,
    /// no images, no live viewer. `state.csv` is written on a writer thread (`threaded`) or in
    /// the caller's thread.
    pub fn create<M: mujoco_rs::wrappers::mj_model::traits::ModelType>(
        config: &Config,
        folder: &Path,
        data: &mujoco_rs::prelude::MjData<M>,
        live_viewer: bool,
        threaded: bool,
    ) -> Result<Option<Self>, RenderError> {
        let state = if config.render.record_state && config.recording.enabled {
            Some(StateWriter::create(folder, data.model(), threaded)?)
        } else {
            None
        };
        let pictures = config.video.enabled || !config.render.image_times_secs.is_empty();
        #[cfg(offscreen_render)]
        let live = if pictures { Some(live::Live::new(config, folder)?) } else { None };
        #[cfg(not(offscreen_render))]
        if pictures {
            return Err(RenderError::NoRenderer(NO_RENDER_FEATURE.into()));
        }
        #[cfg(feature = "viewer")]
        let viewer = if live_viewer { Some(viewer::LiveViewer::open(data.model())?) } else { None };
        #[cfg(not(feature = "viewer"))]
        if live_viewer {
            viewer::check_display()?;
        }
        let visuals = Self {
            state,
            #[cfg(offscreen_render)]
            live,
            #[cfg(feature = "viewer")]
            viewer,
            outputs: Vec::new(),
        };
        #[cfg(offscreen_render)]
        let any = visuals.state.is_some() || visuals.live.is_some();
        #[cfg(not(offscreen_render))]
        let any = visuals.state.is_some();
        #[cfg(feature = "viewer")]
        let any = any || visuals.viewer.is_some();
        Ok(any.then_some(visuals))
    }

    /// Called on every recorded step, after the snapshot's `mj_forward`.
    pub fn on_recorded_step<M: mujoco_rs::wrappers::mj_model::traits::ModelType>(
        &mut self,
        data: &mujoco_rs::prelude::MjData<M>,
    ) -> Result<(), RenderError> {
        match self.state.as_mut() {
            Some(s) => s.write(data),
            None => Ok(()),
        }
    }

    /// Called at the start of every step (state x_k at time t_k) and once after the last one.
    #[allow(unused_variables)]
    pub fn on_step<M: mujoco_rs::wrappers::mj_model::traits::ModelType>(
        &mut self,
        data: &mujoco_rs::prelude::MjData<M>,
        dt: f64,
    ) -> Result<(), RenderError> {
        #[cfg(offscreen_render)]
        if let Some(live) = self.live.as_mut() {
            live.on_step(data, dt)?;
        }
        #[cfg(feature = "viewer")]
        if let Some(v) = self.viewer.as_mut() {
            v.sync(data);
        }
        Ok(())
    }

    /// Flushes and closes everything; returns the files written (state, video, images).
    pub fn finish(mut self) -> Result<Vec<PathBuf>, RenderError> {
        if let Some(s) = self.state.take() {
            self.outputs.push(s.finish()?.0);
        }
        #[cfg(offscreen_render)]
        if let Some(live) = self.live.take() {
            self.outputs.extend(live.finish()?);
        }
        Ok(self.outputs)
    }
}

#[cfg(offscreen_render)]
mod live {
    //! Pictures while a run goes.
    use super::*;
    use crate::config::Render;
    use mujoco_rs::prelude::MjData;
    use mujoco_rs::wrappers::mj_model::traits::ModelType;
    use painter::Painter;

    pub(super) struct Live {
        painter: Painter,
        settings: Render,
        folder: PathBuf,
        frame: Vec<u8>,
        video: Option<VideoWriter>,
        next_frame: u64,
        interval: f64,
        images: Vec<f64>,
        next_image: usize,
        written: Vec<PathBuf>,
    }

    impl Live {
        pub(super) fn new(config: &Config, folder: &Path) -> Result<Self, RenderError> {
            let painter = Painter::new(&folder.join("model.xml"), config)?;
            let (w, h) = painter.size();
            let video = if config.video.enabled {
                Some(VideoWriter::create(
                    &video_stem(folder, config.render.camera),
                    config.video.format,
                    w,
                    h,
                    config.video.frames_per_sec,
                )?)
            } else {
                None
            };
            let mut images = config.render.image_times_secs.clone();
            images.sort_by(f64::total_cmp);
            if !images.is_empty() {
                crate::files::create_dir_in(folder, Path::new(IMAGES_DIR))?;
            }
            Ok(Self {
                painter,
                settings: config.render.clone(),
                folder: folder.to_path_buf(),
                frame: vec![0; w * h * 3],
                video,
                next_frame: 0,
                interval: frame_interval_secs(config),
                images,
                next_image: 0,
                written: Vec::new(),
            })
        }

        pub(super) fn on_step<M: ModelType>(&mut self, data: &MjData<M>, dt: f64) -> Result<(), RenderError> {
            let t = data.time();
            let half = 0.5 * dt;
            let frame_due = self.video.is_some() && self.next_frame as f64 * self.interval <= t + half;
            let image_due = self.images.get(self.next_image).is_some_and(|&ti| ti <= t + half);
            if !frame_due && !image_due {
                return Ok(());
            }
            self.painter.copy_state_from(data)?;
            let (w, h) = self.painter.size();
            if frame_due {
                let rgb = self.painter.paint(self.settings.camera)?;
                self.frame.copy_from_slice(rgb);
                if self.settings.time_overlay {
                    overlay_time(&mut self.frame, w, h, t);
                }
                if let Some(v) = self.video.as_mut() {
                    // Several frames per step when frames are denser than steps.
                    while self.next_frame as f64 * self.interval <= t + half {
                        v.push(&self.frame)?;
                        self.next_frame += 1;
                    }
                }
            }
            while let Some(&ti) = self.images.get(self.next_image) {
                if ti > t + half {
                    break;
                }
                for cam in self.settings.image_cameras.clone() {
                    let rgb = self.painter.paint(cam)?;
                    self.frame.copy_from_slice(rgb);
                    if self.settings.time_overlay {
                        overlay_time(&mut self.frame, w, h, t);
                    }
                    let path = image_path(&self.folder, cam, ti);
                    crate::files::check_target_in(&self.folder, &path)?;
                    write_png(&path, &self.frame, w, h)?;
                    self.written.push(path);
                }
                self.next_image += 1;
            }
            Ok(())
        }

        pub(super) fn finish(self) -> Result<Vec<PathBuf>, RenderError> {
            let mut out = self.written;
            if let Some(v) = self.video {
                out.push(v.finish()?.0);
            }
            Ok(out)
        }
    }
}

/// What [`render_run_folder`] makes.
#[derive(Debug, Clone, Default)]
pub struct ReplayOptions {
    /// A video (format, rate, camera from the config).
    pub video: bool,
    /// The images at `render.image_times_secs`.
    pub images: bool,
    /// `--set` overrides applied to the run folder's `config.toml` (e.g. `render.camera="top"`).
    pub overrides: Vec<String>,
    /// Show a progress bar (only on a terminal).
    pub progress: bool,
}

/// `--images` with no image times would write nothing and look like success: an error naming
/// the key to set (and how to set it on the command line).
pub fn check_images_wanted(config_path: &Path, config: &Config, options: &ReplayOptions) -> Result<(), RenderError> {
    if options.images && config.render.image_times_secs.is_empty() {
        return Err(RenderError::Config {
            file: config_path.to_path_buf(),
            source: ConfigError::InvalidValue {
                key: "render.image_times_secs".into(),
                value: "[]".into(),
                allowed: "--images renders the times listed in render.image_times_secs (seconds within the run), \
                          and this run's config lists none; give them, e.g. \
                          `--set 'render.image_times_secs=[0.5, 2.0]'`"
                    .into(),
            },
        });
    }
    Ok(())
}

/// Replays a run folder's `state.csv` into a video and/or images; returns the files written.
#[cfg(offscreen_render)]
pub fn render_run_folder(folder: &Path, options: &ReplayOptions) -> Result<Vec<PathBuf>, RenderError> {
    use std::io::IsTerminal;
    let config_path = folder.join("config.toml");
    if !config_path.is_file() {
        return Err(RenderError::BadFile {
            path: folder.to_path_buf(),
            message: "is not a run folder (it has no config.toml)".into(),
        });
    }
    let config = crate::config::load_config(&config_path, &options.overrides)
        .map_err(|source| RenderError::Config { file: config_path.clone(), source })?;
    check_images_wanted(&config_path, &config, options)?;
    if options.images {
        // Before anything is drawn: never through a linked `images/` (the writer rule of
        // `crate::files`).
        crate::files::create_dir_in(folder, Path::new(IMAGES_DIR))?;
    }
    let state_path = folder.join(STATE_FILE);
    if !state_path.is_file() {
        return Err(RenderError::BadFile {
            path: state_path,
            message: "missing: the run did not record its state (render.record_state = true and \
                      recording.enabled = true are needed to replay a run)"
                .into(),
        });
    }
    let mut painter = painter::Painter::new(&folder.join("model.xml"), &config)?;
    let model = mujoco_rs::prelude::MjModel::from_xml(folder.join("model.xml")).map_err(|e| RenderError::BadFile {
        path: folder.join("model.xml"),
        message: format!("MuJoCo cannot load it ({e})"),
    })?;
    let track = StateTrack::read(&state_path, &model)?;
    drop(model);
    let (w, h) = painter.size();
    let mut frame = vec![0u8; w * h * 3];
    let mut written = Vec::new();
    let overlay = config.render.time_overlay;

    if options.images && !config.render.image_times_secs.is_empty() {
        for &t in &config.render.image_times_secs {
            if crate::interrupt::requested() {
                return Err(RenderError::Interrupted);
            }
            painter.set_state(track.row(track.index_at(t)))?;
            for &cam in &config.render.image_cameras {
                frame.copy_from_slice(painter.paint(cam)?);
                if overlay {
                    overlay_time(&mut frame, w, h, painter.time());
                }
                let path = image_path(folder, cam, t);
                crate::files::check_target_in(folder, &path)?;
                write_png(&path, &frame, w, h)?;
                written.push(path);
            }
        }
    }

    if options.video {
        let interval = frame_interval_secs(&config);
        let (t0, t1) = (track.times[0], track.times[track.len() - 1]);
        let n_frames = ((t1 - t0) / interval + 1e-9).floor() as u64 + 1;
        let bar = (options.progress && std::io::stderr().is_terminal()).then(|| {
            let bar = indicatif::ProgressBar::new(n_frames);
            if let Ok(style) = indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames, ETA {eta}") {
                bar.set_style(style);
            }
            bar
        });
        let mut video = VideoWriter::create(
            &video_stem(folder, config.render.camera),
            config.video.format,
            w,
            h,
            config.video.frames_per_sec,
        )?;
        for i in 0..n_frames {
            if crate::interrupt::requested() {
                break;
            }
            let t = t0 + i as f64 * interval;
            painter.set_state(track.row(track.index_at(t)))?;
            frame.copy_from_slice(painter.paint(config.render.camera)?);
            if overlay {
                overlay_time(&mut frame, w, h, t);
            }
            video.push(&frame)?;
            if let Some(b) = &bar {
                b.inc(1);
            }
        }
        if let Some(b) = bar {
            b.finish_and_clear();
        }
        written.push(video.finish()?.0);
        if crate::interrupt::requested() {
            return Err(RenderError::Interrupted);
        }
    }
    Ok(written)
}

/// Why a build without offscreen rendering cannot make pictures.
#[cfg(all(not(offscreen_render), target_os = "linux"))]
const NO_RENDER_FEATURE: &str = "this build has no `render` feature (rebuild with default features)";
#[cfg(all(not(offscreen_render), not(target_os = "linux")))]
const NO_RENDER_FEATURE: &str = "only the Linux build has it (SimSerpent's offscreen renderer goes through EGL, \
     which Windows and macOS lack): make images and videos on Linux (or WSL2) from the run folder with `simserpent \
     render RUN_FOLDER`; plots (`simserpent plot`) work on every platform";

/// Without the `render` feature there is no offscreen rendering.
#[cfg(not(offscreen_render))]
pub fn render_run_folder(_folder: &Path, _options: &ReplayOptions) -> Result<Vec<PathBuf>, RenderError> {
    Err(RenderError::NoRenderer(NO_RENDER_FEATURE.into()))
}
