//! Terrain features that come on top of `terrain.kind` and combine freely (pure, no MuJoCo):
//! peg boards, walls, a channel, a slope, a heightfield from a PNG image, a mesh terrain
//! (rasterised into a heightfield), mesh obstacles (convex hulls) and a third-party MJCF terrain.
//!
//! Geometry (xy in the world frame, z up, the floor at z = 0):
//! - Peg board: vertical cylinders `peg_radius_m` × `peg_height_m` standing on the floor.
//!   `square`: centres `region_min_m + (i, j)·spacing_m` inside the region. `hexagonal`: row `j`
//!   at `y = y_min + j·spacing_m·√3/2`, centres `x = x_min + (i + (j mod 2)/2)·spacing_m` inside
//!   the region (each peg `spacing_m` from its six neighbours). `random`: `count` centres uniform
//!   in the region, each at least `spacing_m` from every other (rejection sampling, ChaCha8 seeded
//!   with `general.seed` on stream [`PEG_RNG_STREAM`]). Pegs overlapping the snake's starting
//!   pose are left out (random: drawn again) or, with `skip_pegs_on_snake = false`, rejected with
//!   an error.
//! - Wall: a box whose centre line runs from `start_m` to `end_m`, `thickness_m` across, z from
//!   0 to `height_m`. Channel: two walls parallel to its centre line, their inner faces
//!   `width_m / 2` to each side.
//! - Slope: a box whose top face is the ramp (see `default.toml`), 0.1 m thick, its upper
//!   foot edge on the floor at the foot line.
//! - Heightfield: MuJoCo `<hfield>` with the image's elevation written into the model (no file
//!   reference, so the model compiles from a string and the run folder stays self-contained);
//!   MuJoCo rescales the given elevations to 0..1, so they are written already normalised, with
//!   the hfield's elevation size `height_m·(v_max − v_min)` and the geom at `z = height_m·v_min`:
//!   a pixel of gray value v then stands exactly at `height_m·v`. First row = image top = +y.

use std::fmt::Write;

use rand::SeedableRng;
use rand::distr::{Distribution, Uniform};
use rand_chacha::ChaCha8Rng;

use super::files::{self, MjcfAssets};
use super::geometry::{V3, euler_xyz_matrix, mat_vec};
use super::{Cylinder, Nums, fmt_num as n, names};
use crate::config::{Config, ConfigError, PegLayout};

/// ChaCha stream number of the random peg board ("pegboard" in ASCII, truncated).
pub const PEG_RNG_STREAM: u64 = 0x7065_6762_6f61_7264;
/// Thickness of the slope's box (m).
pub const SLOPE_THICKNESS_M: f64 = 0.1;

/// A box geom in the world body: centre, half sizes, and its x and y axes (world).
#[derive(Debug, Clone, PartialEq)]
pub struct BoxGeom {
    pub name: String,
    pub center_m: V3,
    pub half_m: V3,
    pub x_axis: V3,
    pub y_axis: V3,
}

/// A mesh obstacle: vertices already in world coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshGeom {
    pub name: String,
    pub vertices: Vec<V3>,
    pub triangles: Vec<[usize; 3]>,
}

/// A heightfield geom and its asset.
#[derive(Debug, Clone, PartialEq)]
pub struct HfieldGeom {
    /// Geom and asset name.
    pub name: String,
    pub rows: usize,
    pub cols: usize,
    /// Normalised elevation 0..1, row-major, row 0 at +y.
    pub elevation: Vec<f64>,
    /// MuJoCo size: radius x, radius y, elevation z, base z.
    pub size: [f64; 4],
    pub pos_m: V3,
}

/// A file to copy into the run folder.
#[derive(Debug, Clone, PartialEq)]
pub struct FileCopy {
    /// Where it is now.
    pub source: std::path::PathBuf,
    /// Where it goes, relative to the run folder (`/`-separated).
    pub dest: String,
    /// The config key that names it (directly, or through the third-party terrain), for errors
    /// when it can no longer be copied.
    pub key: String,
    /// Its size cap (bytes): the copy fails when the file has grown past it since it was checked.
    pub max_bytes: u64,
}

/// Everything the features add to the terrain.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Features {
    pub pegs: Vec<Cylinder>,
    pub walls: Vec<BoxGeom>,
    pub meshes: Vec<MeshGeom>,
    pub slope: Option<BoxGeom>,
    pub hfields: Vec<HfieldGeom>,
    /// The third-party MJCF terrain: its file name in the run folder.
    pub user_terrain: Option<String>,
    /// Source files copied into the run folder (images, meshes, the third-party terrain and its
    /// assets).
    pub copies: Vec<FileCopy>,
}

pub use super::files::{SOURCES_DIR, USER_TERRAIN_FILE};

fn base_name(file: &str) -> String {
    std::path::Path::new(file).file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "file".into())
}

/// Overlap test of a vertical cylinder against the snake (see `super::cylinder_overlap`).
type Overlap<'a> = &'a dyn Fn(&Cylinder) -> Option<(usize, f64)>;

/// Builds the features of `cfg`. `first_obstacle` is the number of obstacles already placed by
/// `terrain.kind`; `overlap` tells whether a cylinder overlaps the starting snake (link, distance).
pub(crate) fn build(
    cfg: &Config,
    first_obstacle: usize,
    overlap: Overlap<'_>,
    segments: &[[V3; 2]],
) -> Result<Features, ConfigError> {
    let t = &cfg.terrain;
    let mut f = Features::default();
    let mut next = first_obstacle;
    let mut name = || {
        let s = names::obstacle(next);
        next += 1;
        s
    };

    // Pegs.
    let p = &t.pegboard;
    let centres = peg_centres(cfg)?;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.general.seed);
    rng.set_stream(PEG_RNG_STREAM);
    let make =
        |c: [f64; 2]| Cylinder { name: String::new(), center_m: c, radius_m: p.peg_radius_m, height_m: p.peg_height_m };
    let mut accepted: Vec<[f64; 2]> = Vec::new();
    let check = |c: [f64; 2]| -> Result<bool, ConfigError> {
        match overlap(&make(c)) {
            None => Ok(true),
            Some(_) if p.skip_pegs_on_snake => Ok(false),
            Some((link, dist)) => Err(ConfigError::invalid(
                "terrain.pegboard.skip_pegs_on_snake",
                "false",
                format!(
                    "the peg at [{}, {}] (radius {} m) would overlap {} of the snake at its starting pose (centre {dist} m \
                     from the link's axis, needs at least {} m); set skip_pegs_on_snake = true to leave such pegs out, or \
                     move terrain.pegboard.region_min_m/region_max_m",
                    c[0],
                    c[1],
                    p.peg_radius_m,
                    names::link_body(link),
                    cfg.snake.link_radius_m + p.peg_radius_m
                ),
            )),
        }
    };
    match p.layout {
        PegLayout::Random => {
            let ux = Uniform::new_inclusive(p.region_min_m[0], p.region_max_m[0]);
            let uy = Uniform::new_inclusive(p.region_min_m[1], p.region_max_m[1]);
            let (Ok(ux), Ok(uy)) = (ux, uy) else {
                return Err(ConfigError::invalid(
                    "terrain.pegboard.region_max_m",
                    format!("{:?}", p.region_max_m),
                    "a finite region with region_min_m <= region_max_m",
                ));
            };
            let attempts = p.count.saturating_mul(1000).min(10_000_000);
            // Only pegs less than spacing_m apart conflict: the grid tests exactly those.
            let mut grid = super::grid::PointGrid::new(p.spacing_m);
            for _ in 0..attempts {
                if accepted.len() == p.count {
                    break;
                }
                let c = [ux.sample(&mut rng), uy.sample(&mut rng)];
                if grid.any_near(c, |o, _: &()| (c[0] - o[0]).hypot(c[1] - o[1]) < p.spacing_m) {
                    continue;
                }
                if check(c)? {
                    accepted.push(c);
                    grid.insert(c, ());
                }
            }
            if accepted.len() < p.count {
                return Err(ConfigError::invalid(
                    "terrain.pegboard.count",
                    p.count,
                    format!(
                        "only {} of {} pegs fit in the region {:?} .. {:?} with centres at least spacing_m = {} m apart and \
                         clear of the snake; lower the count or the spacing, or enlarge the region",
                        accepted.len(),
                        p.count,
                        p.region_min_m,
                        p.region_max_m,
                        p.spacing_m
                    ),
                ));
            }
        }
        _ => {
            for c in centres {
                if check(c)? {
                    accepted.push(c);
                }
            }
        }
    }
    for c in accepted {
        let mut cyl = make(c);
        cyl.name = name();
        f.pegs.push(cyl);
    }

    // Walls and the channel.
    let r = cfg.snake.link_radius_m;
    let mut wall = |key: String, value: String, a: [f64; 2], b: [f64; 2], height: f64, thickness: f64| {
        let d = [b[0] - a[0], b[1] - a[1]];
        let len = d[0].hypot(d[1]);
        if !(len > 1e-9 && len.is_finite() && height > 0.0 && thickness > 0.0) {
            return Err(ConfigError::invalid(
                &key,
                value,
                "a wall needs two different finite ends and a positive height and thickness",
            ));
        }
        let u = [d[0] / len, d[1] / len];
        if let Some((i, dist)) = wall_overlap(segments, r, super::geometry::core_inset_m(cfg), a, b, thickness) {
            return Err(ConfigError::invalid(
                &key,
                value,
                format!(
                    "the wall from [{}, {}] to [{}, {}] ({} m thick) would overlap {} of the snake at its starting pose \
                     ({dist} m from the link's axis to the wall's centre line, needs at least {} m); move the wall clear of \
                     the snake",
                    a[0],
                    a[1],
                    b[0],
                    b[1],
                    thickness,
                    names::link_body(i),
                    r + thickness / 2.0
                ),
            ));
        }
        Ok(BoxGeom {
            name: name(),
            center_m: [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0, height / 2.0],
            half_m: [len / 2.0, thickness / 2.0, height / 2.0],
            x_axis: [u[0], u[1], 0.0],
            y_axis: [-u[1], u[0], 0.0],
        })
    };
    for (i, w) in t.walls.iter().enumerate() {
        let b = wall(
            format!("terrain.walls[{i}].start_m"),
            format!("{:?}", w.start_m),
            w.start_m,
            w.end_m,
            w.height_m,
            w.thickness_m,
        )?;
        f.walls.push(b);
    }
    let c = &t.channel;
    if c.enabled {
        let d = [c.end_m[0] - c.start_m[0], c.end_m[1] - c.start_m[1]];
        let len = d[0].hypot(d[1]);
        let left = [-d[1] / len, d[0] / len];
        let off = c.width_m / 2.0 + c.thickness_m / 2.0;
        for side in [1.0, -1.0] {
            let shift = |p: [f64; 2]| [p[0] + side * off * left[0], p[1] + side * off * left[1]];
            let b = wall(
                "terrain.channel.width_m".into(),
                n(c.width_m),
                shift(c.start_m),
                shift(c.end_m),
                c.height_m,
                c.thickness_m,
            )?;
            f.walls.push(b);
        }
    }

    // Mesh obstacles (convex hulls in MuJoCo).
    for (i, m) in t.mesh_obstacles.iter().enumerate() {
        let key = format!("terrain.mesh_obstacles[{i}].file");
        let mesh = files::read_mesh(&key, &m.file)?;
        let rot = euler_xyz_matrix(m.rotation_deg.map(f64::to_radians));
        let vertices = mesh
            .vertices
            .iter()
            .map(|v| {
                let w = mat_vec(&rot, [v[0] * m.scale, v[1] * m.scale, v[2] * m.scale]);
                [w[0] + m.position_m[0], w[1] + m.position_m[1], w[2] + m.position_m[2]]
            })
            .collect();
        let geom = MeshGeom { name: name(), vertices, triangles: mesh.triangles };
        f.copies.push(FileCopy {
            source: m.file.clone().into(),
            dest: format!("{SOURCES_DIR}/{}_{}", geom.name, base_name(&m.file)),
            key,
            max_bytes: files::MAX_ASSET_BYTES,
        });
        f.meshes.push(geom);
    }

    // Slope.
    let s = &t.slope;
    if s.angle_deg > 0.0 {
        let (th, ps) = (s.angle_deg.to_radians(), s.direction_deg.to_radians());
        let u = [ps.cos(), ps.sin()];
        let dir = [u[0] * th.cos(), u[1] * th.cos(), th.sin()]; // up the surface
        let normal = [-u[0] * th.sin(), -u[1] * th.sin(), th.cos()];
        let half = s.length_m / 2.0;
        let tk = SLOPE_THICKNESS_M / 2.0;
        let center = [
            s.start_m[0] + dir[0] * half - normal[0] * tk,
            s.start_m[1] + dir[1] * half - normal[1] * tk,
            dir[2] * half - normal[2] * tk,
        ];
        f.slope = Some(BoxGeom {
            name: names::TERRAIN_SLOPE.into(),
            center_m: center,
            half_m: [half, s.width_m / 2.0, tk],
            x_axis: dir,
            y_axis: [-u[1], u[0], 0.0],
        });
    }

    // Heightfield from a PNG.
    let h = &t.heightfield;
    if !h.file.is_empty() {
        let img = files::read_gray_png("terrain.heightfield.file", &h.file)?;
        f.hfields.push(hfield(
            names::TERRAIN_HEIGHTFIELD,
            img.rows,
            img.cols,
            &img.values,
            min_max(&img.values),
            h.height_m,
            [h.size_x_m / 2.0, h.size_y_m / 2.0],
            h.base_m,
            [h.center_m[0], h.center_m[1], 0.0],
        ));
        f.copies.push(FileCopy {
            source: h.file.clone().into(),
            dest: format!("{SOURCES_DIR}/heightfield_{}", base_name(&h.file)),
            key: "terrain.heightfield.file".into(),
            max_bytes: files::MAX_ASSET_BYTES,
        });
    }

    // Mesh terrain, rasterised.
    let mt = &t.mesh_terrain;
    if !mt.file.is_empty() {
        let key = "terrain.mesh_terrain.file";
        let mut mesh = files::read_mesh(key, &mt.file)?;
        for v in &mut mesh.vertices {
            for (x, offset) in v.iter_mut().zip(mt.position_m) {
                *x = *x * mt.scale + offset;
            }
        }
        let raster = files::rasterise(&mesh, mt.resolution_m).map_err(|why| {
            ConfigError::invalid("terrain.mesh_terrain.resolution_m", n(mt.resolution_m), format!("{}: {why}", mt.file))
        })?;
        f.hfields.push(hfield(
            names::TERRAIN_MESH,
            raster.rows,
            raster.cols,
            &raster.z,
            min_max(&raster.z),
            1.0,
            [(raster.x[1] - raster.x[0]) / 2.0, (raster.y[1] - raster.y[0]) / 2.0],
            mt.base_m,
            [(raster.x[0] + raster.x[1]) / 2.0, (raster.y[0] + raster.y[1]) / 2.0, 0.0],
        ));
        f.copies.push(FileCopy {
            source: mt.file.clone().into(),
            dest: format!("{SOURCES_DIR}/mesh_terrain_{}", base_name(&mt.file)),
            key: key.into(),
            max_bytes: files::MAX_ASSET_BYTES,
        });
    }

    // Third-party MJCF terrain.
    if !t.include_mjcf.is_empty() {
        let key = "terrain.include_mjcf";
        let MjcfAssets { copies } = files::check_mjcf_terrain(key, &t.include_mjcf)?;
        f.copies.push(FileCopy {
            source: t.include_mjcf.clone().into(),
            dest: USER_TERRAIN_FILE.into(),
            key: key.into(),
            max_bytes: files::MAX_MJCF_BYTES,
        });
        for (source, dest) in copies {
            f.copies.push(FileCopy { source, dest, key: key.into(), max_bytes: files::MAX_ASSET_BYTES });
        }
        f.user_terrain = Some(USER_TERRAIN_FILE.into());
    }
    Ok(f)
}

/// A heightfield whose grid values `v` (row 0 at +y) stand at `z0 + scale·v`, over the
/// rectangle of radii `radii` around `centre` (z of `centre` ignored: the height comes from `v`).
#[allow(clippy::too_many_arguments)]
fn hfield(
    name: &str,
    rows: usize,
    cols: usize,
    values: &[f64],
    (lo, hi): (f64, f64),
    scale: f64,
    radii: [f64; 2],
    base: f64,
    centre: V3,
) -> HfieldGeom {
    let span = hi - lo;
    let (elevation, ez) = if span > 1e-12 {
        (values.iter().map(|v| (v - lo) / span).collect(), scale * span)
    } else {
        // Flat: MuJoCo needs a positive elevation size; all-zero data stay at the geom's z.
        (vec![0.0; values.len()], scale.max(1e-3))
    };
    HfieldGeom {
        name: name.into(),
        rows,
        cols,
        elevation,
        size: [radii[0], radii[1], ez, base],
        pos_m: [centre[0], centre[1], scale * lo],
    }
}

/// Peg centres of the square and hexagonal layouts (none for `none` and `random`).
fn peg_centres(cfg: &Config) -> Result<Vec<[f64; 2]>, ConfigError> {
    let p = &cfg.terrain.pegboard;
    let (lo, hi) = (p.region_min_m, p.region_max_m);
    let row_step = match p.layout {
        PegLayout::Square => p.spacing_m,
        PegLayout::Hexagonal => p.spacing_m * 3f64.sqrt() / 2.0,
        _ => return Ok(Vec::new()),
    };
    let eps = 1e-9;
    // `as usize` saturates (a huge region gives usize::MAX), so the + 1 must too.
    let nx = (((hi[0] - lo[0]) / p.spacing_m + eps).floor() as usize).saturating_add(1);
    let ny = (((hi[1] - lo[1]) / row_step + eps).floor() as usize).saturating_add(1);
    if nx.saturating_mul(ny) > crate::config::MAX_OBSTACLES {
        return Err(ConfigError::invalid(
            "terrain.pegboard.spacing_m",
            n(p.spacing_m),
            format!("gives {nx} x {ny} pegs in the region; at most {} obstacles in all", crate::config::MAX_OBSTACLES),
        ));
    }
    let mut out = Vec::new();
    for j in 0..ny {
        let shift = if p.layout == PegLayout::Hexagonal && j % 2 == 1 { p.spacing_m / 2.0 } else { 0.0 };
        for i in 0..nx {
            let x = lo[0] + shift + i as f64 * p.spacing_m;
            if x <= hi[0] + eps {
                out.push([x, lo[1] + j as f64 * row_step]);
            }
        }
    }
    Ok(out)
}

/// xy-distance between segments `a0 a1` and `b0 b1`.
fn seg_seg_dist(a0: [f64; 2], a1: [f64; 2], b0: [f64; 2], b1: [f64; 2]) -> f64 {
    let pt = |p: [f64; 2], s0: [f64; 2], s1: [f64; 2]| {
        let d = [s1[0] - s0[0], s1[1] - s0[1]];
        let l2 = d[0] * d[0] + d[1] * d[1];
        let t = if l2 > 0.0 { (((p[0] - s0[0]) * d[0] + (p[1] - s0[1]) * d[1]) / l2).clamp(0.0, 1.0) } else { 0.0 };
        (p[0] - s0[0] - t * d[0]).hypot(p[1] - s0[1] - t * d[1])
    };
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let (d1, d2) = (cross(b0, b1, a0), cross(b0, b1, a1));
    let (d3, d4) = (cross(a0, a1, b0), cross(a0, a1, b1));
    if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
        return 0.0;
    }
    pt(a0, b0, b1).min(pt(a1, b0, b1)).min(pt(b0, a0, a1)).min(pt(b1, a0, a1))
}

/// First link whose capsule (seen from above) comes closer than `r + thickness/2` to the wall's
/// centre line, with that distance.
fn wall_overlap(
    segments: &[[V3; 2]],
    r: f64,
    inset: f64,
    a: [f64; 2],
    b: [f64; 2],
    thickness: f64,
) -> Option<(usize, f64)> {
    segments.iter().enumerate().find_map(|(i, s)| {
        let core = super::capsule_core(*s, inset);
        let d = seg_seg_dist([core[0][0], core[0][1]], [core[1][0], core[1][1]], a, b);
        (d < r + thickness / 2.0).then_some((i, d))
    })
}

/// Writes the `<asset>` entries of the features (hfields, meshes), indented by 4.
pub(crate) fn write_assets(out: &mut String, f: &Features) -> std::fmt::Result {
    for h in &f.hfields {
        write!(
            out,
            "    <hfield name=\"{}\" nrow=\"{}\" ncol=\"{}\" size=\"{}\" elevation=\"",
            h.name,
            h.rows,
            h.cols,
            Nums(&h.size)
        )?;
        for (k, v) in h.elevation.iter().enumerate() {
            if k > 0 {
                out.push(if k % h.cols == 0 { '\n' } else { ' ' });
            }
            write_unit(out, *v)?;
        }
        out.push_str("\"/>\n");
    }
    for m in &f.meshes {
        write!(out, "    <mesh name=\"{}\" vertex=\"", names::obstacle_mesh(&m.name))?;
        for (k, v) in m.vertices.iter().enumerate() {
            if k > 0 {
                out.push(' ');
            }
            write!(out, "{}", Nums(v))?;
        }
        out.push_str("\" face=\"");
        for (k, t) in m.triangles.iter().enumerate() {
            if k > 0 {
                out.push(' ');
            }
            write!(out, "{} {} {}", t[0], t[1], t[2])?;
        }
        out.push_str("\"/>\n");
    }
    Ok(())
}

/// A value in 0..1 with 6 decimals, trailing zeros trimmed.
fn write_unit(out: &mut String, v: f64) -> std::fmt::Result {
    if v <= 0.0 {
        out.push('0');
        return Ok(());
    }
    if v >= 1.0 {
        out.push('1');
        return Ok(());
    }
    let s = format!("{v:.6}");
    out.push_str(s.trim_end_matches('0').trim_end_matches('.'));
    Ok(())
}

/// Writes the geoms of the features into `<worldbody>`, indented by 4. `obstacle` and `ground`
/// are the contact attributes of obstacles and of ground-like surfaces.
/// The smallest and the largest value.
fn min_max(values: &[f64]) -> (f64, f64) {
    values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)))
}

/// One upright cylinder obstacle standing on the floor (`attrs`: its contact attributes).
pub(crate) fn write_cylinder(out: &mut String, c: &Cylinder, attrs: &str) -> std::fmt::Result {
    writeln!(
        out,
        "    <geom name=\"{}\" type=\"cylinder\" pos=\"{} {} {}\" size=\"{} {}\" rgba=\"0.6 0.6 0.6 1\" {attrs}/>",
        c.name,
        n(c.center_m[0]),
        n(c.center_m[1]),
        n(c.height_m / 2.0),
        n(c.radius_m),
        n(c.height_m / 2.0),
    )
}

pub(crate) fn write_geoms(out: &mut String, f: &Features, obstacle: &str, ground: &str) -> std::fmt::Result {
    for c in &f.pegs {
        write_cylinder(out, c, obstacle)?;
    }
    let boxes = f
        .walls
        .iter()
        .map(|b| (b, "0.55 0.45 0.35 1", obstacle))
        .chain(f.slope.iter().map(|b| (b, "0.4 0.6 0.4 1", ground)));
    for (b, rgba, attrs) in boxes {
        let mut axes = b.x_axis.to_vec();
        axes.extend_from_slice(&b.y_axis);
        writeln!(
            out,
            "    <geom name=\"{}\" type=\"box\" pos=\"{}\" xyaxes=\"{}\" size=\"{}\" rgba=\"{rgba}\" {attrs}/>",
            b.name,
            Nums(&b.center_m),
            Nums(&axes),
            Nums(&b.half_m),
        )?;
    }
    for m in &f.meshes {
        writeln!(
            out,
            "    <geom name=\"{}\" type=\"mesh\" mesh=\"{}\" rgba=\"0.6 0.55 0.5 1\" {obstacle}/>",
            m.name,
            names::obstacle_mesh(&m.name)
        )?;
    }
    for h in &f.hfields {
        writeln!(
            out,
            "    <geom name=\"{}\" type=\"hfield\" hfield=\"{}\" pos=\"{}\" rgba=\"0.5 0.45 0.35 1\" {ground}/>",
            h.name,
            h.name,
            Nums(&h.pos_m)
        )?;
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn segment_distance() {
        assert!((seg_seg_dist([0.0, 0.0], [1.0, 0.0], [0.5, 1.0], [0.5, 2.0]) - 1.0).abs() < 1e-12);
        assert_eq!(seg_seg_dist([0.0, 0.0], [1.0, 1.0], [0.0, 1.0], [1.0, 0.0]), 0.0);
    }

    #[test]
    fn hexagonal_neighbours_are_spacing_apart() {
        let mut c = Config::default();
        c.terrain.pegboard.layout = PegLayout::Hexagonal;
        c.terrain.pegboard.spacing_m = 0.5;
        c.terrain.pegboard.region_min_m = [0.0, 0.0];
        c.terrain.pegboard.region_max_m = [2.0, 2.0];
        let p = peg_centres(&c).unwrap();
        for (i, a) in p.iter().enumerate() {
            let nearest = p
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
                .fold(f64::INFINITY, f64::min);
            assert!((nearest - 0.5).abs() < 1e-9, "{a:?}: nearest {nearest}");
        }
        assert!(p.iter().all(|a| a[0] <= 2.0 + 1e-9 && a[1] <= 2.0 + 1e-9));
    }
}
