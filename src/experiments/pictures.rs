//! Pictures for a report: a run folder's state at t = 0 drawn offscreen (MuJoCo's renderer, as
//! `simserpent render RUN --images` does) and copied next to `report.md`.

use crate::render::{self, ReplayOptions};
use std::path::{Path, PathBuf};

/// Where a fixed camera stands: the point it looks at, its distance, azimuth and elevation.
#[derive(Debug, Clone, Copy)]
pub struct View {
    /// The point looked at (world, m).
    pub lookat_m: [f64; 3],
    /// Distance from the point (m).
    pub distance_m: f64,
    /// Azimuth (degrees, MuJoCo's convention: 90 looks along +y).
    pub azimuth_deg: f64,
    /// Elevation (degrees, −90 looks straight down).
    pub elevation_deg: f64,
}

/// Draws the run folder `run` at t = 0 from `view` (joints and actuators drawn, as in the
/// thesis' figures 22–24) and copies the picture to `report_folder/file_name`. Returns the copy,
/// or why no picture could be made (no offscreen renderer, no `state.csv`, …).
pub fn picture_at_start(run: &Path, view: View, report_folder: &Path, file_name: &str) -> Result<PathBuf, String> {
    let [x, y, z] = view.lookat_m;
    let options = ReplayOptions {
        video: false,
        images: true,
        overrides: vec![
            "render.camera=\"fixed\"".into(),
            "render.image_cameras=[\"fixed\"]".into(),
            "render.image_times_secs=[0.0]".into(),
            format!("render.fixed_lookat_m=[{x:?}, {y:?}, {z:?}]"),
            format!("render.camera_distance_m={:?}", view.distance_m),
            format!("render.camera_azimuth_deg={:?}", view.azimuth_deg),
            format!("render.camera_elevation_deg={:?}", view.elevation_deg),
            "render.quality=\"medium\"".into(),
            "render.time_overlay=false".into(),
            "visual.show_actuators=true".into(),
            "visual.show_joints=true".into(),
        ],
        progress: false,
    };
    let written = render::render_run_folder(run, &options).map_err(|e| e.to_string())?;
    let image = written
        .iter()
        .find(|p| p.extension().is_some_and(|e| e == "png"))
        .ok_or_else(|| format!("{}: the renderer wrote no picture", run.display()))?;
    let copy = report_folder.join(file_name);
    std::fs::copy(image, &copy).map_err(|e| format!("cannot copy {} to {}: {e}", image.display(), copy.display()))?;
    Ok(copy)
}

/// Pixels of an RGB PNG whose colour is within 60 (of 255) per channel of `rgb` (0..1) or of
/// its shaded version 0.6·`rgb`: how much of a picture shows a body of that colour.
pub fn pixels_of_colour(path: &Path, rgb: [f64; 3]) -> Result<usize, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let mut reader =
        png::Decoder::new(std::io::BufReader::new(file)).read_info().map_err(|e| format!("{}: {e}", path.display()))?;
    let size = reader.output_buffer_size().ok_or_else(|| format!("{}: picture too large", path.display()))?;
    let mut buf = vec![0; size];
    let info = reader.next_frame(&mut buf).map_err(|e| format!("{}: {e}", path.display()))?;
    if info.color_type != png::ColorType::Rgb {
        return Err(format!("{}: not an RGB picture", path.display()));
    }
    buf.truncate(info.buffer_size());
    let near = |p: &[u8], shade: f64| (0..3).all(|k| (f64::from(p[k]) - 255.0 * shade * rgb[k]).abs() < 60.0);
    Ok(buf.chunks(3).filter(|p| near(p, 1.0) || near(p, 0.6)).count())
}
