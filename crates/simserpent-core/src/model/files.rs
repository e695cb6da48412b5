//! Terrain input files, read and checked in pure Rust (no MuJoCo): grayscale PNG heightfields,
//! STL/OBJ meshes, and third-party MJCF terrain files.
//!
//! Every error names the file and, where it helps, the config key that named it, so a user
//! never meets a panic or an anonymous "cannot load" from MuJoCo.
//!
//! Every file is read through [`crate::config::files`] (re-exported here): a regular file no
//! larger than its cap.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

use crate::config::ConfigError;
pub use crate::config::files::{
    MAX_ASSET_BYTES, MAX_ASSET_IMAGE_PIXELS, MAX_CONFIG_BYTES, MAX_MJCF_BYTES, ReadError, check_regular_file,
    open_regular_file, read_regular_file,
};

/// File name of the third-party MJCF terrain in the run folder.
pub const USER_TERRAIN_FILE: &str = "user_terrain.xml";
/// Folder (in the run folder) of the copied source files of generated features.
pub const SOURCES_DIR: &str = "terrain_sources";

/// The largest heightfield image side (pixels).
pub const MAX_IMAGE_SIDE_PX: u32 = 2048;
/// The most triangles a mesh file may have.
pub const MAX_TRIANGLES: usize = 2_000_000;
fn file_err(key: &str, file: &str, allowed: impl Into<String>) -> ConfigError {
    ConfigError::invalid(key, format!("{file:?}"), allowed)
}

fn read_bytes(key: &str, file: &str, cap_bytes: u64) -> Result<Vec<u8>, ConfigError> {
    read_regular_file(Path::new(file), cap_bytes).map_err(|e| e.for_key(key, file))
}

/// A grayscale image: `rows × cols` values in 0..=1, row 0 at the top of the image.
#[derive(Debug, Clone, PartialEq)]
pub struct GrayImage {
    pub rows: usize,
    pub cols: usize,
    pub values: Vec<f64>,
}

/// Reads a PNG (gray, gray+alpha, RGB, RGBA or palette; 1 to 16 bits) as gray values in 0..=1:
/// 0.299 R + 0.587 G + 0.114 B for colour images; alpha is ignored.
///
/// # Errors
/// The file does not exist, is not a regular file, is larger than [`MAX_ASSET_BYTES`] or cannot
/// be read, is not a PNG, is smaller than 2 × 2 or larger than
/// [`MAX_IMAGE_SIDE_PX`] on a side; the error names `key` and the file.
pub fn read_gray_png(key: &str, file: &str) -> Result<GrayImage, ConfigError> {
    let bytes = read_bytes(key, file, MAX_ASSET_BYTES)?;
    let bad = |why: String| file_err(key, file, format!("{file} is not a readable PNG image ({why})"));
    let mut decoder = png::Decoder::new(std::io::Cursor::new(&bytes));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| bad(e.to_string()))?;
    let (w, h) = (reader.info().width, reader.info().height);
    if w < 2 || h < 2 || w > MAX_IMAGE_SIDE_PX || h > MAX_IMAGE_SIDE_PX {
        return Err(file_err(
            key,
            file,
            format!(
                "{file} is {w} x {h} pixels; a heightfield image must be 2..={MAX_IMAGE_SIDE_PX} pixels on each side"
            ),
        ));
    }
    let size = reader.output_buffer_size().ok_or_else(|| bad("image too large".into()))?;
    let mut buf = vec![0u8; size];
    let info = reader.next_frame(&mut buf).map_err(|e| bad(e.to_string()))?;
    let (color, depth) = (info.color_type, info.bit_depth);
    let channels = match color {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(bad("palette image was not expanded".into())),
    };
    let (bytes_per, max) = match depth {
        png::BitDepth::Sixteen => (2, 65535.0),
        png::BitDepth::Eight => (1, 255.0),
        other => return Err(bad(format!("unexpected bit depth {other:?} after expansion"))),
    };
    let sample = |k: usize| -> f64 {
        if bytes_per == 2 { f64::from(u16::from_be_bytes([buf[2 * k], buf[2 * k + 1]])) } else { f64::from(buf[k]) }
    };
    let (rows, cols) = (h as usize, w as usize);
    let line = info.line_size / bytes_per;
    let mut values = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            let k = r * line + c * channels;
            let v = if channels >= 3 {
                0.299 * sample(k) + 0.587 * sample(k + 1) + 0.114 * sample(k + 2)
            } else {
                sample(k)
            };
            values.push((v / max).clamp(0.0, 1.0));
        }
    }
    Ok(GrayImage { rows, cols, values })
}

/// A triangle mesh: vertices (file units) and triangles (vertex indices).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    pub vertices: Vec<[f64; 3]>,
    pub triangles: Vec<[usize; 3]>,
}

/// Reads an STL (binary or ASCII) or OBJ (`v` and `f` lines; polygons are fanned into
/// triangles; negative indices count from the end) file, chosen by the extension.
///
/// # Errors
/// Missing, unreadable, not regular or larger than [`MAX_ASSET_BYTES`], an extension other than `.stl`/`.obj`, a malformed file, or one
/// without triangles; the error names `key` and the file (and the line for OBJ).
pub fn read_mesh(key: &str, file: &str) -> Result<Mesh, ConfigError> {
    let ext = Path::new(file).extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    let mesh = match ext.as_deref() {
        Some("stl") => parse_stl(&read_bytes(key, file, MAX_ASSET_BYTES)?),
        Some("obj") => parse_obj(&read_bytes(key, file, MAX_ASSET_BYTES)?),
        _ => {
            return Err(file_err(key, file, format!("{file}: a mesh file must be STL (`.stl`) or OBJ (`.obj`)")));
        }
    }
    .map_err(|why| file_err(key, file, format!("{file} is not a valid mesh file: {why}")))?;
    if mesh.triangles.is_empty() {
        return Err(file_err(key, file, format!("{file} has no triangles")));
    }
    if mesh.vertices.iter().flatten().any(|x| !x.is_finite()) {
        return Err(file_err(key, file, format!("{file} has a vertex that is not a finite number")));
    }
    Ok(mesh)
}

fn parse_stl(bytes: &[u8]) -> Result<Mesh, String> {
    // Binary STL: 80-byte header, u32 count, 50 bytes per triangle. ASCII files start with
    // "solid" but so do some binary ones: trust the size check first.
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        if n > 0 && n <= MAX_TRIANGLES && bytes.len() == 84 + 50 * n {
            let mut mesh = Mesh::default();
            for t in 0..n {
                let base = 84 + 50 * t + 12;
                let mut tri = [0usize; 3];
                for (v, slot) in tri.iter_mut().enumerate() {
                    let mut p = [0.0; 3];
                    for (k, x) in p.iter_mut().enumerate() {
                        let o = base + 12 * v + 4 * k;
                        *x = f64::from(f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]));
                    }
                    *slot = mesh.vertices.len();
                    mesh.vertices.push(p);
                }
                mesh.triangles.push(tri);
            }
            return Ok(mesh);
        }
    }
    let text = std::str::from_utf8(bytes)
        .map_err(|_| "neither a binary STL (size does not match its triangle count) nor ASCII text".to_string())?;
    if !text.trim_start().starts_with("solid") {
        return Err("an ASCII STL must start with `solid` (and a binary STL's size must be 84 + 50 x triangles)".into());
    }
    let mut mesh = Mesh::default();
    let mut corner: Vec<usize> = Vec::new();
    for (no, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("vertex") => {
                let p: Vec<f64> = words
                    .map(str::parse)
                    .collect::<Result<_, _>>()
                    .map_err(|_| format!("line {}: bad vertex", no + 1))?;
                if p.len() != 3 {
                    return Err(format!("line {}: a vertex needs 3 numbers", no + 1));
                }
                corner.push(mesh.vertices.len());
                mesh.vertices.push([p[0], p[1], p[2]]);
            }
            Some("endloop") => {
                if corner.len() != 3 {
                    return Err(format!("line {}: a facet needs exactly 3 vertices, found {}", no + 1, corner.len()));
                }
                mesh.triangles.push([corner[0], corner[1], corner[2]]);
                corner.clear();
            }
            _ => {}
        }
        if mesh.triangles.len() > MAX_TRIANGLES {
            return Err(format!("more than {MAX_TRIANGLES} triangles"));
        }
    }
    Ok(mesh)
}

fn parse_obj(bytes: &[u8]) -> Result<Mesh, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "an OBJ file must be UTF-8 text".to_string())?;
    let mut mesh = Mesh::default();
    for (no, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let p: Vec<f64> = words
                    .take(3)
                    .map(str::parse)
                    .collect::<Result<_, _>>()
                    .map_err(|_| format!("line {}: bad vertex `{line}`", no + 1))?;
                if p.len() != 3 {
                    return Err(format!("line {}: a vertex needs 3 numbers: `{line}`", no + 1));
                }
                mesh.vertices.push([p[0], p[1], p[2]]);
            }
            Some("f") => {
                let mut idx = Vec::new();
                for w in words {
                    let first = w.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| format!("line {}: bad face index `{w}`", no + 1))?;
                    let n = mesh.vertices.len() as i64;
                    let i = if i < 0 { n + i } else { i - 1 };
                    if i < 0 || i >= n {
                        return Err(format!(
                            "line {}: face index `{w}` refers to no vertex (there are {n} so far)",
                            no + 1
                        ));
                    }
                    idx.push(i as usize);
                }
                if idx.len() < 3 {
                    return Err(format!("line {}: a face needs at least 3 vertices", no + 1));
                }
                for k in 1..idx.len() - 1 {
                    mesh.triangles.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
        if mesh.triangles.len() > MAX_TRIANGLES {
            return Err(format!("more than {MAX_TRIANGLES} triangles"));
        }
    }
    Ok(mesh)
}

/// Heights of the top surface of `vertices`/`triangles` (already in world metres) on a grid:
/// `(rows, cols, values, x_min, x_max, y_min, y_max)`, row 0 at `y_max` (as an image), column 0
/// at `x_min`. Each value is the highest triangle above that grid point, or the lowest vertex
/// height where no triangle covers it.
pub(crate) fn rasterise(mesh: &Mesh, resolution: f64) -> Result<Raster, String> {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for v in &mesh.vertices {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    let cols = (((hi[0] - lo[0]) / resolution).ceil() as usize).saturating_add(1);
    let rows = (((hi[1] - lo[1]) / resolution).ceil() as usize).saturating_add(1);
    if !(2..=4096).contains(&cols) || !(2..=4096).contains(&rows) {
        return Err(format!(
            "the grid would be {cols} x {rows} points (mesh {} x {} m at {resolution} m); it must be 2..=4096 on each side",
            hi[0] - lo[0],
            hi[1] - lo[1]
        ));
    }
    let dx = (hi[0] - lo[0]) / (cols - 1) as f64;
    let dy = (hi[1] - lo[1]) / (rows - 1) as f64;
    let mut z = vec![f64::NEG_INFINITY; rows * cols];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i]);
        let det = (b[1] - c[1]) * (a[0] - c[0]) + (c[0] - b[0]) * (a[1] - c[1]);
        if det.abs() < 1e-15 {
            continue; // vertical or degenerate: seen from above it has no area
        }
        let (x0, x1) = (a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0]));
        let (y0, y1) = (a[1].min(b[1]).min(c[1]), a[1].max(b[1]).max(c[1]));
        let c0 = (((x0 - lo[0]) / dx).floor().max(0.0)) as usize;
        let c1 = ((((x1 - lo[0]) / dx).ceil()) as usize).min(cols - 1);
        let r0 = (((y0 - lo[1]) / dy).floor().max(0.0)) as usize;
        let r1 = ((((y1 - lo[1]) / dy).ceil()) as usize).min(rows - 1);
        for gy in r0..=r1 {
            let y = lo[1] + gy as f64 * dy;
            for gx in c0..=c1 {
                let x = lo[0] + gx as f64 * dx;
                let l1 = ((b[1] - c[1]) * (x - c[0]) + (c[0] - b[0]) * (y - c[1])) / det;
                let l2 = ((c[1] - a[1]) * (x - c[0]) + (a[0] - c[0]) * (y - c[1])) / det;
                let l3 = 1.0 - l1 - l2;
                let eps = -1e-9;
                if l1 >= eps && l2 >= eps && l3 >= eps {
                    let h = l1 * a[2] + l2 * b[2] + l3 * c[2];
                    let slot = &mut z[(rows - 1 - gy) * cols + gx];
                    *slot = slot.max(h);
                }
            }
        }
    }
    for v in &mut z {
        if !v.is_finite() {
            *v = lo[2];
        }
    }
    Ok(Raster { rows, cols, z, x: [lo[0], hi[0]], y: [lo[1], hi[1]] })
}

/// A grid of heights (m), row 0 at `y[1]` (top), column 0 at `x[0]`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Raster {
    pub rows: usize,
    pub cols: usize,
    pub z: Vec<f64>,
    pub x: [f64; 2],
    pub y: [f64; 2],
}

/// What a third-party MJCF terrain file needs copied beside it: every relative `file=` path
/// (and a cube texture's `fileright=` …), resolved against the file's folder (and its compiler's
/// meshdir/texturedir/assetdir).
#[derive(Debug, Clone, PartialEq)]
pub struct MjcfAssets {
    /// (source path, symbolic links resolved; destination relative to the folder of the
    /// including scene, `/`-separated).
    pub copies: Vec<(PathBuf, String)>,
}

/// Names the run folder uses for its own files and folders (compared without regard to ASCII
/// case, as a case-insensitive file system would): a third-party terrain's asset may not start
/// with one, or its copy would overwrite (or be overwritten by) a file of the run.
pub const RUN_FOLDER_NAMES: [&str; 13] = [
    "config.toml",
    "model.xml",
    "scene.xml",
    "terrain.xml",
    "robot.xml",
    USER_TERRAIN_FILE,
    SOURCES_DIR,
    "manifest.json",
    "state.csv",
    "report.md",
    "images",
    "plots",
    "MUJOCO_LOG.TXT",
];
/// Stems the run folder uses with any extension (tables as `.csv`, `.parquet` or part folders,
/// the manifest and its temporary copies).
pub const RUN_FOLDER_STEMS: [&str; 6] = ["links", "joints", "sensors", "contacts", "manifest", "state"];
/// Prefixes of run-folder names: videos (`video_<camera>`), and hidden or `_`-prefixed names
/// (temporary files; also what table readers skip).
pub const RUN_FOLDER_PREFIXES: [&str; 3] = ["video_", ".", "_"];

/// Whether `first` (the first component of a path relative to the run folder) is a name the
/// run folder uses for its own files ([`RUN_FOLDER_NAMES`], [`RUN_FOLDER_STEMS`],
/// [`RUN_FOLDER_PREFIXES`]).
pub fn is_run_folder_name(first: &str) -> bool {
    let lower = first.to_ascii_lowercase();
    let stem = lower.split('.').next().unwrap_or("");
    RUN_FOLDER_NAMES.iter().any(|n| n.eq_ignore_ascii_case(&lower))
        || RUN_FOLDER_STEMS.contains(&stem)
        || RUN_FOLDER_PREFIXES.iter().any(|p| lower.starts_with(p))
}

/// The canonical form of `path` (symbolic links resolved), or a [`ReadError`].
fn canonical(path: &Path) -> Result<PathBuf, ReadError> {
    std::fs::canonicalize(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => ReadError::NotFound { path: path.to_path_buf(), source },
        _ => ReadError::Io { path: path.to_path_buf(), source },
    })
}

/// Width and height of a PNG, from its header (`None` when `path` is not a PNG).
fn png_size(path: &Path) -> Option<(u32, u32)> {
    let mut head = [0u8; 24];
    std::fs::File::open(path).ok()?.read_exact(&mut head).ok()?;
    if head[..8] != *b"\x89PNG\r\n\x1a\n" || head[12..16] != *b"IHDR" {
        return None;
    }
    let w = u32::from_be_bytes([head[16], head[17], head[18], head[19]]);
    let h = u32::from_be_bytes([head[20], head[21], head[22], head[23]]);
    Some((w, h))
}

/// Attributes of MJCF and URDF whose values are names, files or keywords, never numbers (a joint
/// may well be named `inf`).
const NAME_ATTRIBUTES: [&str; 30] = [
    "name",
    "class",
    "childclass",
    "type",
    "file",
    "filename",
    "mesh",
    "material",
    "texture",
    "hfield",
    "joint",
    "joint1",
    "joint2",
    "body",
    "body1",
    "body2",
    "link",
    "site",
    "geom",
    "geom1",
    "geom2",
    "tendon",
    "actuator",
    "target",
    "objname",
    "refname",
    "prefix",
    "content_type",
    "key",
    "version",
];

/// A number in an MJCF or URDF file that is not finite (`nan`, `inf`, `1e999`), which MuJoCo
/// would take as it is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NonFiniteNumber {
    /// Line of the element (1-based).
    pub line: usize,
    /// The element, e.g. `limit`.
    pub element: String,
    /// The attribute, e.g. `upper`.
    pub attribute: String,
    /// The attribute's whole value.
    pub value: String,
}

impl std::fmt::Display for NonFiniteNumber {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use crate::config::shorten;
        write!(
            f,
            "line {}: <{} {}=\"{}\">: not a finite number; every number of a robot or terrain file must be finite \
             (NaN and infinities make the simulated state NaN or a limit meaningless)",
            self.line,
            shorten(&self.element),
            shorten(&self.attribute),
            shorten(&self.value)
        )
    }
}

/// The most links on one chain of a robot file (the longest path of bodies from a root, the root
/// counted). MuJoCo writes a robot as nested `<body>` elements and its XML reader stops at 500
/// nested elements (a 1,000-link chain failed after its third compile), and a chain's step cost
/// grows with about the cube of its length (its joint-space mass matrix is dense): 2.5 times the
/// links took 9.6 times the CPU time of a 10-step run (BENCHMARKS.md, "Robot set-up").
pub const MAX_ROBOT_CHAIN_LINKS: usize = 400;

/// The most links of a robot file in all (URDF `<link>` and MJCF `<body>` elements). MuJoCo's
/// set-up grows with about the square of a robot's links even when none is on a long chain (its
/// compiler's tree lists and the first forward pass): a URDF of 2,500 links on one base took 2.0 s
/// of CPU time to set up, 5,000 links 7.5 s and 10,000 links 34 s (BENCHMARKS.md, "Robot set-up").
pub const MAX_ROBOT_LINKS: usize = 2000;

/// What one pass over a robot file (URDF or MJCF) finds.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RobotScan {
    /// The first number that is not finite, if any.
    pub non_finite: Option<NonFiniteNumber>,
    /// Links on the longest chain (URDF: from the joints' parent and child links; MJCF: nested
    /// `<body>` elements).
    pub longest_chain_links: usize,
    /// The last link of that chain (URDF: its name; MJCF: the deepest body's name, or empty).
    pub deepest_link: String,
    /// Links in all (URDF: `<link>` elements; MJCF: `<body>` elements).
    pub links: usize,
}

/// The first attribute of the XML text `bytes` (MJCF or URDF) holding a number that is not
/// finite, if any ([`scan_robot_file`]).
pub fn first_non_finite_number(bytes: &[u8]) -> Option<NonFiniteNumber> {
    scan_robot_file(bytes).non_finite
}

/// One pass over the XML text of a robot or terrain file, linear in its size: the first
/// attribute holding a number that is not finite (every attribute but names and files,
/// [`NAME_ATTRIBUTES`], whose whitespace-separated parts include one that reads as a number and
/// is NaN or infinite), the longest chain of links and the number of links. Malformed XML ends the pass (MuJoCo's
/// loader reports it).
pub fn scan_robot_file(bytes: &[u8]) -> RobotScan {
    use quick_xml::events::Event;
    let mut scan = RobotScan::default();
    let mut reader = quick_xml::Reader::from_reader(bytes);
    let mut buf = Vec::new();
    // Lines counted incrementally up to the reader's position.
    let (mut line, mut counted) = (1usize, 0usize);
    // MJCF: nested bodies. URDF: each joint's (parent, child) links.
    let mut body_depth = 0usize;
    let mut in_joint = false;
    let (mut parent, mut child) = (None::<String>, None::<String>);
    let mut parent_of: std::collections::HashMap<String, String> = std::collections::HashMap::new();
    let mut links: Vec<String> = Vec::new();
    while let Ok(event) = reader.read_event_into(&mut buf) {
        let (start, empty) = match &event {
            Event::Start(s) => (s, false),
            Event::Empty(s) => (s, true),
            Event::End(e) => {
                match e.name().as_ref() {
                    b"body" => body_depth = body_depth.saturating_sub(1),
                    b"joint" if in_joint => {
                        in_joint = false;
                        if let (Some(p), Some(c)) = (parent.take(), child.take()) {
                            parent_of.insert(c, p);
                        }
                    }
                    _ => {}
                }
                buf.clear();
                continue;
            }
            Event::Eof => break,
            _ => {
                buf.clear();
                continue;
            }
        };
        let at = (reader.buffer_position() as usize).min(bytes.len());
        line += bytes[counted.min(at)..at].iter().filter(|&&b| b == b'\n').count();
        counted = at;
        let element = start.name().as_ref().to_vec();
        let attribute = |key: &[u8]| {
            start.attributes().flatten().find(|a| a.key.as_ref() == key).map(|a| {
                a.normalized_value(quick_xml::XmlVersion::Implicit1_0).map(|v| v.into_owned()).unwrap_or_default()
            })
        };
        match element.as_slice() {
            b"body" => {
                scan.links += 1;
                let depth = body_depth + 1;
                if depth > scan.longest_chain_links {
                    scan.longest_chain_links = depth;
                    scan.deepest_link = attribute(b"name").unwrap_or_default();
                }
                if !empty {
                    body_depth = depth;
                }
            }
            b"link" if !in_joint => {
                scan.links += 1;
                links.extend(attribute(b"name"));
            }
            b"joint" if !empty && body_depth == 0 => in_joint = true,
            b"parent" if in_joint => parent = attribute(b"link"),
            b"child" if in_joint => child = attribute(b"link"),
            _ => {}
        }
        if scan.non_finite.is_none() {
            for attr in start.attributes().flatten() {
                let key = attr.key.as_ref();
                if NAME_ATTRIBUTES.iter().any(|n| n.as_bytes() == key) {
                    continue;
                }
                let Ok(value) = attr.normalized_value(quick_xml::XmlVersion::Implicit1_0) else { continue };
                if value.split_whitespace().any(|t| t.parse::<f64>().is_ok_and(|v| !v.is_finite())) {
                    scan.non_finite = Some(NonFiniteNumber {
                        line,
                        element: String::from_utf8_lossy(&element).into_owned(),
                        attribute: String::from_utf8_lossy(key).into_owned(),
                        value: value.into_owned(),
                    });
                    break;
                }
            }
        }
        buf.clear();
    }
    // URDF: each link's chain length, memoised; a cycle (no root) stops at the number of links.
    let mut length: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for link in &links {
        let mut path: Vec<&str> = Vec::new();
        let mut at = link.as_str();
        let base = loop {
            if let Some(&n) = length.get(at) {
                break n;
            }
            path.push(at);
            match parent_of.get(at) {
                Some(p) if path.len() <= links.len() => at = p.as_str(),
                _ => break 0,
            }
        };
        for (i, name) in path.iter().rev().enumerate() {
            length.insert(name, base + i + 1);
        }
        let n = length.get(link.as_str()).copied().unwrap_or(0);
        if n > scan.longest_chain_links {
            scan.longest_chain_links = n;
            scan.deepest_link.clone_from(link);
        }
    }
    scan
}

/// Checks that `file` is well-formed XML with a `<mujoco>` root, and lists the files it refers to.
///
/// A third-party terrain must be one self-contained folder: the file itself (at most
/// [`MAX_MJCF_BYTES`]) and the asset files it names, each a regular file of at most
/// [`MAX_ASSET_BYTES`] inside the terrain file's folder after resolving symbolic links, at a
/// relative path whose first component is not a name of the run folder
/// ([`is_run_folder_name`]), so that every one can be copied into the run folder and the scene
/// rebuilt from there.
///
/// # Errors
/// Missing, unreadable, not regular or too large file; malformed XML (with the position);
/// another root element; an `<include>` or `<model>` element (they pull in other MJCF files, a
/// `<model>` cycle crashes MuJoCo's compiler); an absolute `file=` or compiler
/// `meshdir`/`texturedir`/`assetdir` (it would not be copied); a referenced file that does not
/// exist, is not a regular file, is too large (a PNG of more than [`MAX_ASSET_IMAGE_PIXELS`]),
/// leaves the file's folder (`..` or a symbolic link), or whose name is one the run folder uses.
/// Each error names `key`, the file, the element and the attribute.
pub fn check_mjcf_terrain(key: &str, file: &str) -> Result<MjcfAssets, ConfigError> {
    use quick_xml::events::Event;
    let bytes = read_bytes(key, file, MAX_MJCF_BYTES)?;
    let bad = |why: String| file_err(key, file, format!("{file} is not a usable MJCF terrain file: {why}"));
    if let Some(number) = first_non_finite_number(&bytes) {
        return Err(bad(number.to_string()));
    }
    let line_at = |pos: u64| 1 + bytes[..(pos as usize).min(bytes.len())].iter().filter(|&&b| b == b'\n').count();
    let mut reader = quick_xml::Reader::from_reader(bytes.as_slice());
    reader.config_mut().check_end_names = true;
    let mut buf = Vec::new();
    let mut depth = 0usize;
    let mut root_seen = false;
    // (attribute, value, line) of the compiler's folders.
    let (mut meshdir, mut texturedir, mut assetdir) =
        (None::<(String, usize)>, None::<(String, usize)>, None::<(String, usize)>);
    let mut refs: Vec<(String, String, String, usize)> = Vec::new(); // (element, attribute, file, line)
    loop {
        let event = reader
            .read_event_into(&mut buf)
            .map_err(|e| bad(format!("malformed XML at byte {} ({e})", reader.error_position())))?;
        let line = line_at(reader.buffer_position());
        let (start, empty) = match &event {
            Event::Start(s) => (Some(s.clone()), false),
            Event::Empty(s) => (Some(s.clone()), true),
            Event::End(_) => {
                depth = depth.saturating_sub(1);
                (None, false)
            }
            Event::Eof => break,
            _ => (None, false),
        };
        if let Some(s) = start {
            let name = String::from_utf8_lossy(s.name().as_ref()).into_owned();
            if depth == 0 {
                if root_seen || name != "mujoco" {
                    return Err(bad(format!(
                        "the root element must be <mujoco> (MuJoCo's rule for included files), found <{name}>"
                    )));
                }
                root_seen = true;
            }
            if name == "include" || name == "model" {
                return Err(bad(format!(
                    "line {line}: <{name}> is not allowed in a terrain file: it pulls in other MJCF files (and a \
                     <model> that refers to itself crashes MuJoCo's compiler); a terrain for SimSerpent must be \
                     one file (inline what it includes)"
                )));
            }
            for attr in s.attributes() {
                let attr = attr.map_err(|e| bad(format!("line {line}: malformed attribute in <{name}> ({e})")))?;
                let attr_name = String::from_utf8_lossy(attr.key.as_ref()).into_owned();
                let value = attr
                    .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                    .map_err(|e| bad(format!("line {line}: bad attribute value in <{name}> ({e})")))?
                    .into_owned();
                match (name.as_str(), attr_name.as_str()) {
                    ("compiler", "meshdir") => meshdir = Some((value, line)),
                    ("compiler", "texturedir") => texturedir = Some((value, line)),
                    ("compiler", "assetdir") => assetdir = Some((value, line)),
                    // `file`, and a cube or skybox texture's `fileright`, `fileleft`, `fileup`, ...
                    (_, a) if a.starts_with("file") => refs.push((name.clone(), attr_name.clone(), value, line)),
                    _ => {}
                }
            }
            if !empty {
                depth += 1;
            }
        }
        buf.clear();
    }
    if !root_seen {
        return Err(bad("no <mujoco> root element".into()));
    }
    for (attr, dir) in [("meshdir", &meshdir), ("texturedir", &texturedir), ("assetdir", &assetdir)] {
        if let Some((value, line)) = dir
            && Path::new(value).has_root()
        {
            return Err(bad(format!(
                "line {line}: <compiler {attr}={value:?}> is an absolute path; files outside the terrain's folder \
                 are not copied into the run folder, so the run could not be rebuilt from it: make it relative"
            )));
        }
    }
    let dir = match Path::new(file).parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let folder = canonical(dir).map_err(|e| e.for_key(key, file))?;
    let mut copies: Vec<(PathBuf, String)> = Vec::new();
    for (element, attribute, reference, line) in refs {
        let at = format!("line {line}: <{element} {attribute}={reference:?}>");
        if Path::new(&reference).has_root() {
            return Err(bad(format!(
                "{at} is an absolute path; files outside the terrain's folder are not copied into the run folder, \
                 so the run could not be rebuilt from it: put the file in the terrain's folder and name it relative \
                 to it"
            )));
        }
        let prefix = match element.as_str() {
            "texture" => texturedir.as_ref().or(assetdir.as_ref()),
            _ => meshdir.as_ref().or(assetdir.as_ref()),
        }
        .map(|(value, _)| value.clone())
        .unwrap_or_default();
        let rel: PathBuf =
            Path::new(&prefix).join(&reference).components().filter(|c| !matches!(c, Component::CurDir)).collect();
        if rel.components().any(|c| matches!(c, Component::ParentDir)) {
            return Err(bad(format!(
                "{at} leaves the terrain file's folder (`..`); keep the terrain's files in its folder or below so \
                 they can be copied into the run folder"
            )));
        }
        let first = rel.components().next().map(|c| c.as_os_str().to_string_lossy().into_owned()).unwrap_or_default();
        if is_run_folder_name(&first) {
            return Err(bad(format!(
                "{at}: the name {first:?} is one the run folder uses for its own files (its copy would overwrite \
                 them or be overwritten); rename the file or move it into a sub-folder"
            )));
        }
        let lexical = dir.join(&rel);
        let source = canonical(&lexical).map_err(|e| bad(format!("{at}: {e}")))?;
        if !source.starts_with(&folder) {
            return Err(bad(format!(
                "{at}: {} resolves (through a symbolic link) to {}, outside the terrain's folder {}; keep the \
                 terrain's files in its folder or below",
                lexical.display(),
                source.display(),
                folder.display()
            )));
        }
        check_regular_file(&source, MAX_ASSET_BYTES).map_err(|e| bad(format!("{at}: {e}")))?;
        if let Some((w, h)) = png_size(&source)
            && u64::from(w) * u64::from(h) > MAX_ASSET_IMAGE_PIXELS
        {
            return Err(bad(format!(
                "{at}: the PNG image {} is {w} x {h} pixels, more than the cap of {MAX_ASSET_IMAGE_PIXELS} pixels",
                source.display()
            )));
        }
        let dest = rel.to_string_lossy().replace('\\', "/");
        if !copies.iter().any(|(_, d)| *d == dest) {
            copies.push((source, dest));
        }
    }
    Ok(MjcfAssets { copies })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn read_regular_file_refuses_missing_files_folders_devices_and_files_over_the_cap() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
        let toml = dir.join("Cargo.toml");
        let len = std::fs::metadata(&toml).unwrap().len();
        assert_eq!(read_regular_file(&toml, len).unwrap().len() as u64, len, "exactly the cap is fine");
        let e = read_regular_file(&toml, len - 1).unwrap_err();
        assert!(
            matches!(e, ReadError::TooLarge { size_bytes, cap_bytes, .. } if size_bytes == len && cap_bytes == len - 1)
        );
        assert!(e.to_string().contains("Cargo.toml") && e.to_string().contains("cap of 0 MiB"), "{e}");
        let e = read_regular_file(&dir.join("src"), MAX_CONFIG_BYTES).unwrap_err();
        assert!(matches!(e, ReadError::NotRegular { what: "a folder", .. }), "{e}");
        let e = read_regular_file(&dir.join("no such file"), MAX_CONFIG_BYTES).unwrap_err();
        assert!(matches!(e, ReadError::NotFound { .. }) && e.to_string().contains("does not exist"), "{e}");
        #[cfg(unix)]
        for dev in ["/dev/null", "/dev/zero"] {
            let e = read_regular_file(Path::new(dev), MAX_CONFIG_BYTES).unwrap_err();
            assert!(matches!(e, ReadError::NotRegular { what: "a character device", .. }), "{e}");
            let c = e.for_key("terrain.heightfield.file", dev).to_string();
            assert!(
                c.contains("terrain.heightfield.file") && c.contains(dev) && c.contains("not a regular file"),
                "{c}"
            );
        }
    }

    #[test]
    fn run_folder_names_cover_the_run_files_but_not_ordinary_asset_names() {
        for name in [
            "config.toml",
            "CONFIG.TOML",
            "model.xml",
            "user_terrain.xml",
            "terrain_sources",
            "manifest.json",
            "manifest.json.tmp",
            "links.csv",
            "links.parquet",
            "contacts",
            "state.csv",
            "plots",
            "images",
            "video_follow.gif",
            ".links.parquet.part",
            "_SUCCESS",
        ] {
            assert!(is_run_folder_name(name), "{name}");
        }
        for name in ["rock.obj", "meshes", "textures", "ground.png", "terrain.png", "model.obj", "config"] {
            assert!(!is_run_folder_name(name), "{name}");
        }
    }

    #[test]
    fn obj_fans_polygons_and_rasterises_a_pyramid() {
        let obj = b"v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nv 1 1 1\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\nf 1 2 3 4\n";
        let mesh = parse_obj(obj).unwrap();
        assert_eq!(mesh.triangles.len(), 6);
        let r = rasterise(&mesh, 0.5).unwrap();
        assert_eq!((r.rows, r.cols), (5, 5));
        assert!((r.z[2 * 5 + 2] - 1.0).abs() < 1e-12, "apex at the centre");
        assert!((r.z[2 * 5 + 1] - 0.5).abs() < 1e-12, "half way up");
        assert!(r.z[0].abs() < 1e-12, "corner at the base");
    }

    #[test]
    fn stl_ascii_and_binary_agree() {
        let ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        let a = parse_stl(ascii.as_bytes()).unwrap();
        let mut bin = vec![0u8; 80];
        bin.extend_from_slice(&1u32.to_le_bytes());
        bin.extend_from_slice(&[0u8; 12]);
        for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
            for x in v {
                bin.extend_from_slice(&x.to_le_bytes());
            }
        }
        bin.extend_from_slice(&[0u8; 2]);
        assert_eq!(parse_stl(&bin).unwrap(), a);
        assert!(parse_stl(b"garbage").is_err());
        assert!(parse_obj(b"v 0 0 0\nf 1 2 3\n").unwrap_err().contains("line 2"));
    }
}
