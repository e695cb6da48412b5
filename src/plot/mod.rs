//! Plots of a run folder, as PNG and SVG, with an embedded font (no system fonts, no display).
//!
//! [`plot_run_folder`] reads the CSV tables of a run (`links.csv`, `joints.csv`,
//! `contacts.csv`), its `config.toml` and `model.xml` (for the obstacles), and writes one PNG and
//! one SVG per panel into `<run folder>/plots/`:
//!
//! | file | panel |
//! |---|---|
//! | `head_position` | head (link 0) position x, y, z (m) against time (s) |
//! | `head_velocity` | head velocity (m/s) |
//! | `head_acceleration` | head acceleration (m/s²) |
//! | `contact_count` | number of contacts at each recorded step |
//! | `contact_forces` | total and largest contact normal force (N) |
//! | `penetration` | largest penetration (mm) |
//! | `joint_angles` | every joint angle (deg) |
//! | `actuator_torques` | force of every joint's actuator of the configured kind (N·m) |
//! | `top_view` | every link's path in the xy-plane (m) with the obstacles, equal scales |
//! | `overview` | all of the above on one page, three per row |
//!
//! A panel whose columns were not recorded is skipped (and named in the returned list).

use crate::config::Config;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The embedded font: DejaVu Sans (Bitstream Vera licence, see `assets/DejaVuSans.LICENSE`).
const FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";

/// Registers the embedded font with plotters (once per process).
pub fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        if plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_err() {
            log::warn!("the embedded font is invalid; plots will have no text");
        }
    });
}

/// Why a PNG could not be written ([`write_png`]; the caller names the file).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PngError {
    /// Creating or writing the file failed.
    #[error("{0}")]
    Io(#[source] std::io::Error),
    /// The PNG encoder failed.
    #[error("PNG encoder: {0}")]
    Encoder(String),
}

/// Writes a PNG (RGB, 8 bits; the plots' and the rendered pictures' one encoder).
pub fn write_png(path: &Path, rgb: &[u8], width: usize, height: usize) -> Result<(), PngError> {
    let enc = |e: png::EncodingError| PngError::Encoder(e.to_string());
    let file =
        crate::files::open_for_writing(path, false).map_err(|e| PngError::Io(std::io::Error::other(e.to_string())))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width as u32, height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Fast);
    let mut writer = encoder.write_header().map_err(enc)?;
    writer.write_image_data(rgb).map_err(enc)?;
    writer.finish().map_err(enc)
}

/// Errors of plotting; they name the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// A file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A table or file is not what a run folder holds.
    #[error("{path}: {message}")]
    BadFile {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Drawing a plot failed.
    #[error("cannot write {path}: {message}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// The plots folder could not be created.
    #[error("cannot create {}", path.display())]
    Folder {
        /// The folder.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// A PNG could not be written.
    #[error("cannot write {}", path.display())]
    Png {
        /// The file.
        path: PathBuf,
        /// What failed.
        #[source]
        source: PngError,
    },
    /// A file that is not one SimSerpent reads or writes ([`crate::files`]).
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// SIGINT/SIGTERM (with [`crate::interrupt`]'s handler installed, or
    /// [`crate::interrupt::request`]) stopped the plotting between two files.
    #[error("plotting interrupted by a signal (SIGINT or SIGTERM); the plots written so far are in {dir}")]
    Interrupted {
        /// The plot folder.
        dir: PathBuf,
    },
}

/// Stops plotting between files when a stop was requested ([`crate::interrupt`]).
fn check_interrupt(dir: &Path) -> Result<(), PlotError> {
    if crate::interrupt::requested() { Err(PlotError::Interrupted { dir: dir.to_path_buf() }) } else { Ok(()) }
}

/// A CSV table read whole: column name → values (text columns are left out).
#[derive(Debug, Default)]
struct Table {
    columns: HashMap<String, Vec<f64>>,
    order: Vec<String>,
}

impl Table {
    /// Reads `path` by [`crate::files`]' rule (a regular file inside the run folder); a field
    /// that is a number must be finite and at most 1e15 in magnitude (text fields read as NaN).
    fn read(path: &Path) -> Result<Self, PlotError> {
        let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let text = crate::files::read_text_in(folder, path, crate::files::TABLE_CAP_BYTES).map_err(|e| match e {
            crate::files::FileError::Missing { .. } => {
                PlotError::Read { path: path.to_path_buf(), source: std::io::Error::from(std::io::ErrorKind::NotFound) }
            }
            e => PlotError::File(e),
        })?;
        let mut lines = text.lines();
        let header: Vec<String> = lines
            .next()
            .ok_or_else(|| PlotError::BadFile { path: path.to_path_buf(), message: "the file is empty".into() })?
            .split(',')
            .map(|s| s.trim().to_string())
            .collect();
        let mut values: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
        for line in lines {
            let fields: Vec<&str> = line.split(',').collect();
            if fields.len() != header.len() {
                // A half-written last line of an interrupted run.
                continue;
            }
            let row = values.first().map_or(0, Vec::len) + 1;
            for ((col, f), name) in values.iter_mut().zip(fields).zip(&header) {
                col.push(match crate::files::parse_number(f) {
                    Ok(v) => v,
                    Err("is not a number") => f64::NAN,
                    Err(why) => {
                        return Err(PlotError::BadFile {
                            path: path.to_path_buf(),
                            message: format!("row {row}, column `{name}`: {:?} {why}", f.trim()),
                        });
                    }
                });
            }
        }
        let mut columns = HashMap::new();
        for (name, col) in header.iter().zip(values) {
            columns.insert(name.clone(), col);
        }
        Ok(Self { columns, order: header })
    }

    fn get(&self, name: &str) -> Option<&[f64]> {
        self.columns.get(name).map(Vec::as_slice)
    }
}

/// One line of a plot.
struct Series<'a> {
    name: String,
    x: &'a [f64],
    y: Vec<f64>,
}

/// Circles and rectangles of the obstacles, in the xy-plane.
type Obstacle = crate::sim::PlanarShape;

fn obstacles(model_xml: &Path) -> Vec<Obstacle> {
    crate::sim::world_body_shapes(model_xml).unwrap_or_else(|e| {
        log::warn!("{e}; the top view has no obstacles");
        Vec::new()
    })
}

const COLORS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

fn color(i: usize) -> RGBColor {
    COLORS[i % COLORS.len()]
}

/// Range of finite values with a margin; never empty.
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    // Values beyond 1e15 have no place on a chart (and an axis over ±1e308 overflows).
    for v in values.filter(|v| v.is_finite() && v.abs() <= crate::files::MAX_ABS_VALUE) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let span = hi - lo;
    let pad = if span > 0.0 { 0.05 * span } else { 0.5 * lo.abs().max(1e-3) };
    (lo - pad, hi + pad)
}

type DrawResult = Result<(), String>;

fn line_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> DrawResult {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let (x0, x1) = range(series.iter().flat_map(|s| s.x.iter().copied()));
    let (y0, y1) = range(series.iter().flat_map(|s| s.y.iter().copied()));
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FAMILY, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, s) in series.iter().enumerate() {
        let c = color(i);
        chart
            .draw_series(LineSeries::new(
                s.x.iter().copied().zip(s.y.iter().copied()).filter(|(x, y)| x.is_finite() && y.is_finite()),
                c.stroke_width(2),
            ))
            .map_err(|e| e.to_string())?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
    }
    if series.len() > 1 && series.len() <= 12 {
        legend(&mut chart)?;
    }
    Ok(())
}

/// The legend of a chart's labelled series, upper right.
fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> DrawResult {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK.mix(0.3))
        .label_font((FAMILY, 13))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| e.to_string())
}

fn top_view<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    paths: &[Series<'_>],
    obstacles: &[Obstacle],
    size: (u32, u32),
) -> DrawResult {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let (mut x0, mut x1) = range(paths.iter().flat_map(|s| s.x.iter().copied()));
    let (mut y0, mut y1) = range(paths.iter().flat_map(|s| s.y.iter().copied()));
    // Obstacles near the path are drawn too: widen the view by up to 1 m around the path.
    let near = |o: &Obstacle| {
        let (x, y) = match o {
            Obstacle::Circle { x, y, .. } | Obstacle::Rect { x, y, .. } => (*x, *y),
        };
        x > x0 - 1.0 && x < x1 + 1.0 && y > y0 - 1.0 && y < y1 + 1.0
    };
    let shown: Vec<&Obstacle> = obstacles.iter().filter(|o| near(o)).collect();
    for o in &shown {
        let (cx, cy, hx, hy) = match o {
            Obstacle::Circle { x, y, r } => (*x, *y, *r, *r),
            Obstacle::Rect { x, y, hx, hy } => (*x, *y, *hx, *hy),
        };
        x0 = x0.min(cx - hx - 0.05);
        x1 = x1.max(cx + hx + 0.05);
        y0 = y0.min(cy - hy - 0.05);
        y1 = y1.max(cy + hy + 0.05);
    }
    // Equal scales: widen the shorter side to the aspect ratio of the plot area.
    let (pw, ph) = ((size.0 as f64 - 100.0).max(1.0), (size.1 as f64 - 90.0).max(1.0));
    let (w, h) = (x1 - x0, y1 - y0);
    if w / h < pw / ph {
        let extra = (h * pw / ph - w) / 2.0;
        x0 -= extra;
        x1 += extra;
    } else {
        let extra = (w * ph / pw - h) / 2.0;
        y0 -= extra;
        y1 += extra;
    }
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FAMILY, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    let grey = RGBColor(120, 120, 120);
    for o in shown {
        let points: Vec<(f64, f64)> = match o {
            Obstacle::Circle { x, y, r } => (0..48)
                .map(|k| {
                    let a = k as f64 / 48.0 * std::f64::consts::TAU;
                    (x + r * a.cos(), y + r * a.sin())
                })
                .collect(),
            Obstacle::Rect { x, y, hx, hy } => {
                vec![(x - hx, y - hy), (x + hx, y - hy), (x + hx, y + hy), (x - hx, y + hy)]
            }
        };
        chart.draw_series(std::iter::once(Polygon::new(points, grey.mix(0.6).filled()))).map_err(|e| e.to_string())?;
    }
    for (i, s) in paths.iter().enumerate() {
        let c = color(i);
        chart
            .draw_series(LineSeries::new(
                s.x.iter().copied().zip(s.y.iter().copied()).filter(|(x, y)| x.is_finite() && y.is_finite()),
                c.stroke_width(1),
            ))
            .map_err(|e| e.to_string())?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
        // Start (circle) and end (filled) of every path.
        if let (Some(&xs), Some(&ys), Some(&xe), Some(&ye)) = (s.x.first(), s.y.first(), s.x.last(), s.y.last()) {
            chart.draw_series([Circle::new((xs, ys), 3, c.stroke_width(1))]).map_err(|e| e.to_string())?;
            chart.draw_series([Circle::new((xe, ye), 3, c.filled())]).map_err(|e| e.to_string())?;
        }
    }
    // A legend for a few named paths (e.g. the conditions of `experiment oal-bench`); a run's
    // per-link paths (usually more) go without, where it would cover them.
    if paths.len() > 1 && paths.len() <= TOP_VIEW_LEGEND_MAX {
        legend(&mut chart)?;
    }
    Ok(())
}

/// The title of a run's top view (its links' paths).
const TOP_VIEW_TITLE: &str = "Top view: link paths and obstacles";
/// The most paths the top view labels in a legend.
const TOP_VIEW_LEGEND_MAX: usize = 6;

/// Draws one panel into `<dir>/<stem>.png` and `<dir>/<stem>.svg`.
fn both(
    dir: &Path,
    stem: &str,
    size: (u32, u32),
    draw: impl Fn(&dyn AnyArea) -> DrawResult,
) -> Result<Vec<PathBuf>, PlotError> {
    check_interrupt(dir)?;
    // Never through a link planted at a plot's name ([`crate::files`]' writer rule).
    let png = crate::files::check_target_in(dir, Path::new(&format!("{stem}.png")))?;
    let svg = crate::files::check_target_in(dir, Path::new(&format!("{stem}.svg")))?;
    let failed = |path: &Path, message: String| PlotError::Write { path: path.to_path_buf(), message };
    let mut buffer = vec![255u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, size).into_drawing_area();
        draw(&root).map_err(|m| failed(&png, m))?;
    }
    write_png(&png, &buffer, size.0 as usize, size.1 as usize)
        .map_err(|source| PlotError::Png { path: png.clone(), source })?;
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        draw(&root).map_err(|m| failed(&svg, m))?;
    }
    Ok(vec![png, svg])
}

/// What [`plot_run_folder`] wrote and skipped.
#[derive(Debug, Clone, Default)]
pub struct PlotOutput {
    /// The files written (PNG and SVG of every panel).
    pub files: Vec<PathBuf>,
    /// Panels left out, with the reason (e.g. columns not recorded).
    pub skipped: Vec<(String, String)>,
}

/// Draws one time-series chart into `<dir>/<stem>.png` and `<dir>/<stem>.svg`: every
/// `(name, values)` of `series` over `time_s` (for panels of one's own, e.g. the estimation
/// experiment's estimate against truth).
pub fn plot_time_series(
    dir: &Path,
    stem: &str,
    title: &str,
    y_label: &str,
    time_s: &[f64],
    series: &[(String, Vec<f64>)],
) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    let series: Vec<Series<'_>> =
        series.iter().map(|(name, y)| Series { name: name.clone(), x: time_s, y: y.clone() }).collect();
    both(dir, stem, (900, 500), |root: &dyn AnyArea| root.line(title, "time (s)", y_label, &series))
}

/// Draws one line chart with its own x axis into `<dir>/<stem>.png` and `.svg`: every
/// `(name, values)` of `series` over `x` (e.g. a value per seed).
pub fn plot_lines(
    dir: &Path,
    stem: &str,
    title: &str,
    x_label: &str,
    y_label: &str,
    x: &[f64],
    series: &[(String, Vec<f64>)],
) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    let series: Vec<Series<'_>> =
        series.iter().map(|(name, y)| Series { name: name.clone(), x, y: y.clone() }).collect();
    both(dir, stem, (900, 500), |root: &dyn AnyArea| root.line(title, x_label, y_label, &series))
}

/// One labelled value with its interval.
struct Bar<'a> {
    label: &'a str,
    value: f64,
    lo: f64,
    hi: f64,
}

/// Draws one value per label with its interval (a dot and a whisker; one row per label, the
/// values along x) into `<dir>/<stem>.png` and
/// `.svg` (e.g. a success rate per condition with its 90 % bootstrap interval). `values`, `lo` and
/// `hi` are per label.
#[allow(clippy::too_many_arguments)]
pub fn plot_intervals(
    dir: &Path,
    stem: &str,
    title: &str,
    y_label: &str,
    labels: &[String],
    values: &[f64],
    lo: &[f64],
    hi: &[f64],
) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    let bars: Vec<Bar<'_>> = labels
        .iter()
        .zip(values)
        .zip(lo.iter().zip(hi))
        .map(|((label, value), (lo, hi))| Bar { label, value: *value, lo: *lo, hi: *hi })
        .collect();
    let height = 120 + 32 * bars.len() as u32;
    both(dir, stem, (1000, height), |root: &dyn AnyArea| root.intervals(title, y_label, &bars))
}

fn interval_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    value_label: &str,
    bars: &[Bar<'_>],
) -> DrawResult {
    // One row per label (top to bottom), the values along x.
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let (x0, x1) = range(bars.iter().flat_map(|b| [b.value, b.lo, b.hi]));
    let n = bars.len().max(1);
    let row = |k: usize| (n - 1 - k) as f64;
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FAMILY, 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(260)
        .build_cartesian_2d(x0..x1, -0.5..(n as f64 - 0.5))
        .map_err(|e| e.to_string())?;
    let label_of = |y: &f64| {
        let k = y.round();
        if (y - k).abs() < 1e-6 && k >= 0.0 && (k as usize) < n {
            bars[n - 1 - k as usize].label.to_string()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .y_labels(n)
        .y_label_formatter(&label_of)
        .x_desc(value_label)
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    let c = color(0);
    for (k, b) in bars.iter().enumerate() {
        let y = row(k);
        if b.lo.is_finite() && b.hi.is_finite() {
            chart
                .draw_series(std::iter::once(PathElement::new(vec![(b.lo, y), (b.hi, y)], c.stroke_width(2))))
                .map_err(|e| e.to_string())?;
            for x in [b.lo, b.hi] {
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(x, y - 0.15), (x, y + 0.15)],
                        c.stroke_width(2),
                    )))
                    .map_err(|e| e.to_string())?;
            }
        }
        if b.value.is_finite() {
            chart.draw_series(std::iter::once(Circle::new((b.value, y), 5, c.filled()))).map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}

/// Draws paths `(name, x, y)` seen from above over circular obstacles `(centre, radius)` (m)
/// into `<dir>/<stem>.png` and `.svg` under `title` (equal scales; an open circle marks each
/// path's start, a filled one its end; a legend names up to six paths).
pub fn plot_paths_over_circles(
    dir: &Path,
    stem: &str,
    title: &str,
    paths: &[(String, Vec<f64>, Vec<f64>)],
    circles: &[([f64; 2], f64)],
) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    let series: Vec<Series<'_>> =
        paths.iter().map(|(name, x, y)| Series { name: name.clone(), x: x.as_slice(), y: y.clone() }).collect();
    let obstacles: Vec<Obstacle> = circles.iter().map(|(c, r)| Obstacle::Circle { x: c[0], y: c[1], r: *r }).collect();
    let size = (1100, 600);
    both(dir, stem, size, |root: &dyn AnyArea| root.top(title, &series, &obstacles, size))
}

/// Writes the standard panels of a run folder into `<folder>/plots/`.
pub fn plot_run_folder(folder: &Path) -> Result<PlotOutput, PlotError> {
    register_font();
    check_interrupt(&folder.join("plots"))?;
    let config_path = folder.join("config.toml");
    match crate::files::read_in(folder, &config_path, crate::files::SMALL_FILE_CAP_BYTES) {
        Err(crate::files::FileError::Missing { .. }) => {
            return Err(PlotError::BadFile {
                path: folder.to_path_buf(),
                message: "is not a run folder (it has no config.toml)".into(),
            });
        }
        Err(e) => return Err(e.into()),
        Ok(_) => {}
    }
    let config = crate::config::load_config(&config_path, &[])
        .map_err(|e| PlotError::BadFile { path: config_path.clone(), message: e.to_string() })?;
    let links_path = folder.join("links.csv");
    if !links_path.is_file() {
        return Err(PlotError::BadFile {
            path: links_path,
            message: "missing: plots are made from the CSV tables (recording.enabled = true, and a CSV format)".into(),
        });
    }
    let links = Table::read(&links_path)?;
    let joints = match Table::read(&folder.join("joints.csv")) {
        Ok(t) => t,
        Err(PlotError::Read { .. }) => Table::default(),
        Err(e) => return Err(e),
    };
    let contacts = match Table::read(&folder.join("contacts.csv")) {
        Ok(t) => Some(t),
        Err(PlotError::Read { .. }) => None,
        Err(e) => return Err(e),
    };
    let dir = folder.join("plots");
    check_interrupt(&dir)?;
    let dir = crate::files::create_dir_in(folder, Path::new("plots"))?;
    draw_panels(&config, &links, &joints, contacts.as_ref(), &obstacles(&folder.join("model.xml")), &dir)
}

fn draw_panels<'a>(
    config: &Config,
    links: &'a Table,
    joints: &'a Table,
    contacts: Option<&Table>,
    obstacles: &[Obstacle],
    dir: &Path,
) -> Result<PlotOutput, PlotError> {
    let size = (config.plot.width_px, config.plot.height_px);
    let mut out = PlotOutput::default();
    let empty: &'a [f64] = &[];
    let time = links.get("time_s").unwrap_or(empty);
    // The head: the first link that has position columns (link_00 for the generated snake).
    let link_names: Vec<String> =
        links.order.iter().filter_map(|c| c.strip_suffix("_position_x_m").map(str::to_string)).collect();
    let head = link_names.first().cloned().unwrap_or_else(|| crate::model::names::link_body(0));

    let xyz = |quantity: &str, unit: &str, scale: f64| -> Vec<Series<'a>> {
        ["x", "y", "z"]
            .iter()
            .filter_map(|a| {
                links.get(&format!("{head}_{quantity}_{a}_{unit}")).map(|v| Series {
                    name: (*a).to_string(),
                    x: time,
                    y: v.iter().map(|y| y * scale).collect(),
                })
            })
            .collect()
    };
    let mut drawn: Vec<LinePanel<'a>> = Vec::new();
    let mut panel = |stem: &str, title: &str, y_label: &str, series: Vec<Series<'a>>, why: &str| {
        if series.is_empty() {
            out.skipped.push((stem.to_string(), why.to_string()));
            return Ok(());
        }
        let files = both(dir, stem, size, |root: &dyn AnyArea| root.line(title, "time (s)", y_label, &series))?;
        out.files.extend(files);
        drawn.push(LinePanel { title: title.to_string(), y_label: y_label.to_string(), series });
        Ok::<(), PlotError>(())
    };
    panel("head_position", "Head position", "position (m)", xyz("position", "m", 1.0), "link positions not recorded")?;
    panel(
        "head_velocity",
        "Head velocity",
        "velocity (m/s)",
        xyz("velocity", "m_per_s", 1.0),
        "link velocities not recorded",
    )?;
    panel(
        "head_acceleration",
        "Head acceleration",
        "acceleration (m/s²)",
        xyz("acceleration", "m_per_s2", 1.0),
        "link accelerations not recorded",
    )?;

    // Contacts: per recorded time, count, total and largest normal force, largest penetration.
    let per_step = contacts.map(|c| contact_stats(time, c));
    let none = "contacts not recorded (recording.contacts = false)";
    let stats = per_step.as_ref();
    panel(
        "contact_count",
        "Number of contacts",
        "contacts",
        stats.map(|s| vec![Series { name: "contacts".into(), x: time, y: s.count.clone() }]).unwrap_or_default(),
        none,
    )?;
    panel(
        "contact_forces",
        "Contact normal forces",
        "force (N)",
        stats
            .map(|s| {
                vec![
                    Series { name: "sum over contacts".into(), x: time, y: s.total_n.clone() },
                    Series { name: "largest contact".into(), x: time, y: s.peak_n.clone() },
                ]
            })
            .unwrap_or_default(),
        none,
    )?;
    panel(
        "penetration",
        "Largest penetration",
        "penetration (mm)",
        stats
            .map(|s| vec![Series { name: "penetration".into(), x: time, y: s.penetration_mm.clone() }])
            .unwrap_or_default(),
        none,
    )?;

    let jtime = joints.get("time_s").unwrap_or(empty);
    let joint_cols = |suffix: &str, scale: f64| -> Vec<Series<'a>> {
        joints
            .order
            .iter()
            .filter_map(|c| {
                let name = c.strip_suffix(suffix)?;
                Some(Series {
                    name: name.to_string(),
                    x: jtime,
                    y: joints.get(c).unwrap_or(empty).iter().map(|v| v * scale).collect(),
                })
            })
            .collect()
    };
    panel(
        "joint_angles",
        "Joint angles",
        "angle (deg)",
        joint_cols("_angle_rad", 180.0 / std::f64::consts::PI),
        "joint angles not recorded",
    )?;
    let kind = config.control.method.name();
    panel(
        "actuator_torques",
        &format!("Actuator torques ({kind} actuators)"),
        "torque (N·m)",
        joint_cols(&format!("_{kind}_actuator_force_nm"), 1.0),
        "actuator forces of the configured kind not recorded",
    )?;

    let paths: Vec<Series<'_>> = link_names
        .iter()
        .filter_map(|n| {
            Some(Series {
                name: n.clone(),
                x: links.get(&format!("{n}_position_x_m"))?,
                y: links.get(&format!("{n}_position_y_m"))?.to_vec(),
            })
        })
        .collect();
    if paths.is_empty() {
        out.skipped.push(("top_view".into(), "link positions not recorded".into()));
    } else {
        let files =
            both(dir, "top_view", size, |root: &dyn AnyArea| root.top(TOP_VIEW_TITLE, &paths, obstacles, size))?;
        out.files.extend(files);
    }
    // Every panel on one page, three per row.
    let n = drawn.len() + usize::from(!paths.is_empty());
    if n > 0 {
        let (rows, cols) = (n.div_ceil(3), n.min(3));
        let page = (size.0 * cols as u32, size.1 * rows as u32);
        let files =
            both(dir, "overview", page, |root: &dyn AnyArea| root.grid((rows, cols), &drawn, &paths, obstacles, size))?;
        out.files.extend(files);
    }
    Ok(out)
}

/// A time-series panel, kept for the overview page.
struct LinePanel<'a> {
    title: String,
    y_label: String,
    series: Vec<Series<'a>>,
}

/// Per recorded time: number of contacts, total and largest normal force, largest penetration.
struct ContactStats {
    count: Vec<f64>,
    total_n: Vec<f64>,
    peak_n: Vec<f64>,
    penetration_mm: Vec<f64>,
}

fn contact_stats(time: &[f64], c: &Table) -> ContactStats {
    let n = time.len();
    let mut s =
        ContactStats { count: vec![0.0; n], total_n: vec![0.0; n], peak_n: vec![0.0; n], penetration_mm: vec![0.0; n] };
    let empty: &[f64] = &[];
    let (t, f, p) = (
        c.get("time_s").unwrap_or(empty),
        c.get("normal_force_n").unwrap_or(empty),
        c.get("penetration_m").unwrap_or(empty),
    );
    // Both tables are in time order: walk them together.
    let mut k = 0;
    for (i, &ti) in t.iter().enumerate() {
        while k + 1 < n && time[k] < ti - 1e-12 {
            k += 1;
        }
        if n == 0 || (time[k] - ti).abs() > 1e-9 * ti.abs().max(1.0) {
            continue;
        }
        s.count[k] += 1.0;
        let force = f.get(i).copied().unwrap_or(0.0);
        s.total_n[k] += force;
        s.peak_n[k] = s.peak_n[k].max(force);
        s.penetration_mm[k] = s.penetration_mm[k].max(p.get(i).copied().unwrap_or(0.0) * 1e3);
    }
    s
}

/// The two backends behind one object-safe face, so every panel is drawn by one closure.
trait AnyArea {
    fn line(&self, title: &str, x_label: &str, y_label: &str, series: &[Series<'_>]) -> DrawResult;
    fn intervals(&self, title: &str, y_label: &str, bars: &[Bar<'_>]) -> DrawResult;
    fn top(&self, title: &str, paths: &[Series<'_>], obstacles: &[Obstacle], size: (u32, u32)) -> DrawResult;
    fn grid(
        &self,
        shape: (usize, usize),
        lines: &[LinePanel<'_>],
        paths: &[Series<'_>],
        obstacles: &[Obstacle],
        size: (u32, u32),
    ) -> DrawResult;
    fn work_precision(
        &self,
        title: &str,
        x_label: &str,
        y_label: &str,
        series: &[WorkPrecisionSeries],
        levels: &[f64],
    ) -> DrawResult;
}

impl<DB: DrawingBackend> AnyArea for DrawingArea<DB, Shift> {
    fn work_precision(
        &self,
        title: &str,
        x_label: &str,
        y_label: &str,
        series: &[WorkPrecisionSeries],
        levels: &[f64],
    ) -> DrawResult {
        work_precision_chart(self, title, x_label, y_label, series, levels)
    }
    fn line(&self, title: &str, x_label: &str, y_label: &str, series: &[Series<'_>]) -> DrawResult {
        line_chart(self, title, x_label, y_label, series)?;
        self.present().map_err(|e| e.to_string())
    }
    fn intervals(&self, title: &str, y_label: &str, bars: &[Bar<'_>]) -> DrawResult {
        interval_chart(self, title, y_label, bars)?;
        self.present().map_err(|e| e.to_string())
    }
    fn top(&self, title: &str, paths: &[Series<'_>], obstacles: &[Obstacle], size: (u32, u32)) -> DrawResult {
        top_view(self, title, paths, obstacles, size)?;
        self.present().map_err(|e| e.to_string())
    }
    fn grid(
        &self,
        shape: (usize, usize),
        lines: &[LinePanel<'_>],
        paths: &[Series<'_>],
        obstacles: &[Obstacle],
        size: (u32, u32),
    ) -> DrawResult {
        self.fill(&WHITE).map_err(|e| e.to_string())?;
        let areas = self.split_evenly(shape);
        for (area, p) in areas.iter().zip(lines) {
            line_chart(area, &p.title, "time (s)", &p.y_label, &p.series)?;
        }
        if let (false, Some(area)) = (paths.is_empty(), areas.get(lines.len())) {
            top_view(area, TOP_VIEW_TITLE, paths, obstacles, size)?;
        }
        self.present().map_err(|e| e.to_string())
    }
}

/// One series of a work-precision chart: its name and its points (cost, error, label).
pub type WorkPrecisionSeries = (String, Vec<(f64, f64, String)>);

/// Draws a work-precision chart (log–log: cost on x, error on y; one line with labelled points
/// per series, dashed horizontal lines at `levels`) into `<dir>/<stem>.png` and `.svg`
/// (the accuracy study, `simserpent study accuracy`).
pub fn plot_work_precision(
    dir: &Path,
    stem: &str,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[WorkPrecisionSeries],
    levels: &[f64],
) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    std::fs::create_dir_all(dir).map_err(|source| PlotError::Folder { path: dir.to_path_buf(), source })?;
    let size = (1000, 650);
    both(dir, stem, size, |root: &dyn AnyArea| root.work_precision(title, x_label, y_label, series, levels))
}

/// Log range of the positive finite values, widened to whole decades (never empty).
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.1, 10.0);
    }
    let (lo, hi) = (10f64.powf(lo.log10().floor()), 10f64.powf(hi.log10().ceil()));
    if hi > lo { (lo, hi) } else { (lo / 10.0, hi * 10.0) }
}

fn work_precision_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[WorkPrecisionSeries],
    levels: &[f64],
) -> DrawResult {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let (x0, x1) = log_range(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)));
    let (y0, y1) = log_range(series.iter().flat_map(|s| s.1.iter().map(|p| p.1)).chain(levels.iter().copied()));
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FAMILY, 18))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    for level in levels {
        chart
            .draw_series(DashedLineSeries::new(
                [(x0, *level), (x1, *level)],
                6,
                4,
                RGBColor(150, 150, 150).stroke_width(1),
            ))
            .map_err(|e| e.to_string())?;
        chart
            .draw_series([Text::new(format!("{} %", level * 100.0), (x0 * 1.05, *level * 1.08), (FAMILY, 13))])
            .map_err(|e| e.to_string())?;
    }
    for (i, (name, points)) in series.iter().enumerate() {
        let c = color(i);
        let valid: Vec<&(f64, f64, String)> =
            points.iter().filter(|p| p.0.is_finite() && p.1.is_finite() && p.0 > 0.0 && p.1 > 0.0).collect();
        chart
            .draw_series(LineSeries::new(valid.iter().map(|p| (p.0, p.1)), c.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
        chart.draw_series(valid.iter().map(|p| Circle::new((p.0, p.1), 4, c.filled()))).map_err(|e| e.to_string())?;
        chart
            .draw_series(valid.iter().map(|p| Text::new(p.2.clone(), (p.0 * 1.04, p.1 * 1.1), (FAMILY, 12))))
            .map_err(|e| e.to_string())?;
    }
    legend(&mut chart)?;
    root.present().map_err(|e| e.to_string())
}
