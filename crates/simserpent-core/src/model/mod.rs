//! World generation: the configuration becomes an MJCF model (thesis appendix 12.2), as text.
//!
//! Pure Rust: nothing here calls MuJoCo; the text is meant for `MjModel::from_xml_string` and can
//! be saved and opened with MuJoCo's own tools.
//!
//! # The model
//! - All lengths SI, `<compiler angle="radian" autolimits="true"/>`.
//! - `<option>`: `general.timestep_secs`, `general.integrator`, `general.gravity_m_per_s2`,
//!   `physics.friction_cone`, `physics.solver_iterations`. Default geom
//!   `solref = "contact_time_constant_secs contact_damping_ratio"` (link–link contacts); floor,
//!   obstacles, terrain and the link–floor pairs get `solref = "τ_env
//!   environment_contact_damping_ratio"` (τ_env = `environment_contact_time_constant_secs`,
//!   `"auto"` = max(2 ms, 2 timesteps)), which their priority makes the contact's. MuJoCo's direct
//!   form `"-contact_stiffness_per_s2 -contact_damping_per_s"` replaces both when the stiffness is > 0.
//! - Snake frame: the head's front tip at the origin, the body along −x, z up (the snake faces +x).
//!   Body `link_00` is placed at `head_position_m + (0, 0, link_radius_m)` with
//!   `euler = head_rotation_deg` (radians, `eulerseq="xyz"`: intrinsic x, then y, then z) and has
//!   the free joint `head_free`. Link `i > 0` is a child of link `i − 1` at `(−L, 0, 0)`, with its
//!   hinge `joint_ii` at its origin (axis z for all joints with `joint_axes = "yaw"`; z, y, z, y, …
//!   for joints 1, 2, 3, 4, … with `"alternating"`), range ±`joint_range_deg`, damping, armature.
//! - Link `i`'s geom spans exactly x ∈ [−L, 0] of its body frame, caps included: a capsule from
//!   (−r, 0, 0) to (−(L − r), 0, 0) with radius r. `L = 2r` (allowed) gives a sphere of radius r at
//!   (−L/2, 0, 0). Mass `link_mass_kg`, colour `color_rgba`.
//! - `legacy.geometry = "faithful"` (the original tool's links, thesis appendix 12.2): link `i`'s
//!   capsule has its core from (0, 0, 0) to (−L, 0, 0) (joint to joint) and radius r, so its caps
//!   reach r beyond both joints (length L + 2r; any r); `link_00` is placed at
//!   `head_position_m + (L, 0, link_radius_m)` with `euler = head_rotation_deg + (0, 0, 180°)`, so
//!   the body extends along the configured +x from the head as in the original.
//! - Sites: `link_ii_imu` at the link centre (−L/2, 0, 0); `joint_jj_site` at the origin of link
//!   `j` (the joint anchor).
//! - Contacts: link geoms contype 1, conaffinity 3 (or 2 without `physics.self_collision`); floor
//!   and obstacles contype 2, conaffinity 1. So the environment never collides with itself and
//!   links collide with each other only with self-collision (MuJoCo already excludes parent–child
//!   pairs). Friction: floor priority 1 with `snake.ground_friction`, obstacles priority 1 with
//!   `terrain.obstacle_friction`, links priority 0 with `snake.link_friction` (MuJoCo takes the
//!   friction of the higher-priority geom, and the maximum for equal priorities). `condim` per geom
//!   from its own friction: 3, 4 if torsional > 0, 6 if rolling > 0.
//! - Actuators, one of each kind per joint, in blocks: all `torque_jj` motors (gear
//!   `torque_gear`, ctrl and force limited to `torque_range_nm / torque_gear`, so the joint torque
//!   is limited to `torque_range_nm` for any gear), all `position_jj` servos (kp, kv, ctrlrange
//!   ±joint range), all `velocity_jj` servos (kv), all `intvelocity_jj` servos (kp, actrange
//!   ±joint range in radians); servos have `forcerange = torque_range_nm`. Only the kind equal to
//!   `control.method` gets its gains; the other servo kinds get kp = kv = 0 (MuJoCo accepts zero
//!   gains, and a servo with zero gains produces exactly zero force, whereas any non-zero gain acts
//!   even at zero command).
//! - Sensors (order): per link `link_ii_vel` (velocimeter), `link_ii_accel` (accelerometer),
//!   `link_ii_gyro` (gyro), `link_ii_pos` (framepos), `link_ii_quat` (framequat), all of site
//!   `link_ii_imu`; then per joint `joint_jj_force`, `joint_jj_torque` (at `joint_jj_site`: the
//!   constraint force between link `j` and its parent, like Boa's force/torque sensors),
//!   `joint_jj_angle` (jointpos), `joint_jj_angvel` (jointvel).
//! - Floor: plane `floor` at z = 0, half-size `terrain.floor_size_m`. Obstacles: see
//!   [`terrain`]. Floor surfaces (`[[ground.surfaces]]`): visual tiles `surface_kk` only (see
//!   [`surfaces`]); with surfaces the isotropic model also gets the link–floor pairs
//!   (`friction = "μ μ torsional rolling rolling"`), whose friction `sim::ground` switches.
//! - Keyframe `initial`: `qpos` = head position, head quaternion, initial joint angles (zero, or
//!   with `gait.kind = "form_closure"` joint j at `pattern_deg[(j − 1) % len]`); `ctrl` = initial
//!   angles for the position servos (zero otherwise); `act` = initial angles for the intvelocity
//!   servos. Reset to it (`mj_resetDataKeyframe`) to start a run.
//!
//! # Checks
//! [`generate`] rejects, with the key path responsible, an obstacle that overlaps the snake at its
//! starting pose (the real capsule, seen from above, where the link's height range meets the
//! cylinder's) and a snake that starts (partly) below the floor (a body-axis point lower than
//! `link_radius_m`). Ranges of single values are
//! checked by `Config::validate`; here only what would make the text invalid or the code panic is
//! rechecked.

pub mod features;
pub mod files;
mod geometry;
mod grid;
pub mod names;
mod snake;
pub mod surfaces;
pub mod terrain;

use std::fmt::{self, Write};

pub use geometry::link_axis_segments_m;
pub use surfaces::SurfaceMap;

use crate::config::{Config, ConfigError, FloorFriction, FrictionCone, GaitKind, GroundModel};
use geometry::{V3, dist_xy_point_segment};

/// A vertical cylinder obstacle standing on the floor.
#[derive(Debug, Clone, PartialEq)]
pub struct Cylinder {
    /// Geom name (`obstacle_kk`, see [`names::obstacle`]).
    pub name: String,
    /// Centre of the cylinder's axis in the xy-plane (world), m.
    pub center_m: [f64; 2],
    /// Radius, m.
    pub radius_m: f64,
    /// Height, m (it spans z ∈ [0, height]).
    pub height_m: f64,
}

/// The generated model and what the rest of the simulator needs to know about it.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedModel {
    /// The MJCF text.
    pub xml: String,
    /// The obstacles, in the order of their names (`obstacle_00`, `obstacle_01`, …).
    pub obstacles: Vec<Cylinder>,
    /// Starting angle of each joint (index `j - 1` for joint `j`), rad; also in the `initial` key.
    pub initial_joint_angles_rad: Vec<f64>,
    /// The same model as separate files joined with `<include>` (see [`SceneFiles`]).
    pub files: SceneFiles,
    /// The terrain features beyond `terrain.kind` (pegs, walls, meshes, slope, heightfields).
    pub features: features::Features,
}

/// The model split into reusable files, written beside `model.xml` into every run folder:
///
/// - `scene.xml`: compiler, options, defaults, sky and light; `<include file="terrain.xml"/>`,
///   `<include file="robot.xml"/>`; the contact pairs between robot and floor; the `initial`
///   keyframe (it spans the whole model's `qpos`).
/// - `terrain.xml`: the floor, the obstacles, the features and their assets (heightfield data
///   and meshes written inline), and `<include file="user_terrain.xml"/>` when
///   `terrain.include_mjcf` is set.
/// - `robot.xml`: the snake's bodies, actuators and sensors (absent with a user's robot, which
///   is included as it is).
///
/// Included files must have a `<mujoco>` root whose children MuJoCo merges into the including
/// file; file references inside them are resolved from the main file's folder. `scene.xml`
/// compiles to the same model as `model.xml` (`tests/it/terrain.rs` checks it).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SceneFiles {
    /// `(file name, text)` of `scene.xml`, `terrain.xml` and (generated snake) `robot.xml`.
    pub texts: Vec<(String, String)>,
    /// Files copied into the run folder: the source images and meshes (for the record), the
    /// third-party terrain and its assets (needed to compile).
    pub copies: Vec<features::FileCopy>,
    /// Whether `model.xml` includes other files, so that it must be compiled from a folder
    /// holding them (a third-party terrain), not from a string.
    pub model_needs_files: bool,
}

/// Scene, terrain and robot file names.
pub const SCENE_FILE: &str = "scene.xml";
/// See [`SCENE_FILE`].
pub const TERRAIN_FILE: &str = "terrain.xml";
/// See [`SCENE_FILE`].
pub const ROBOT_FILE: &str = "robot.xml";

/// Why a model could not be generated.
#[derive(thiserror::Error, Debug)]
#[non_exhaustive]
pub enum ModelError {
    /// The configuration cannot give a valid model (the key path says which setting).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Writing the text failed (cannot happen when writing to a `String`; kept for `?`).
    #[error("cannot write the MJCF text: {0}")]
    Format(#[from] fmt::Error),
}

/// Generates the MJCF model of `cfg`: the snake, the floor, the obstacles of `terrain.kind`, the
/// actuators, the sensors and the `initial` keyframe.
///
/// # Errors
/// [`ModelError::Config`] with the key path when the configuration cannot give a consistent
/// model: an obstacle overlapping the snake at its starting pose, a snake starting below the
/// floor, random cylinders that do not fit, a form-closure terrain without bends, or values that
/// would make invalid MJCF (non-finite numbers, link length below twice the radius, …).
pub fn generate(cfg: &Config) -> Result<GeneratedModel, ModelError> {
    sanity(cfg)?;
    let angles = initial_joint_angles(cfg)?;
    let segments = link_axis_segments_m(cfg, &angles);
    check_above_floor(cfg, &segments)?;
    let placed = terrain::place_obstacles(cfg, &segments)?;
    check_obstacles_clear(cfg, &segments, &placed)?;
    let mut obstacles: Vec<Cylinder> = placed.into_iter().map(|p| p.cylinder).collect();
    let overlap = |c: &Cylinder| cylinder_overlap(cfg, &segments, c);
    let features = features::build(cfg, obstacles.len(), &overlap, &segments)?;
    obstacles.extend(features.pegs.iter().cloned());
    let (xml, files) = write_xml(cfg, Body::Snake(&angles), &obstacles, &features)?;
    Ok(GeneratedModel { xml, obstacles, initial_joint_angles_rad: angles, files, features })
}

/// A scene for a user's robot: the options, floor and obstacles of `cfg`, with the robot's MJCF
/// file (`robot_file`, relative to where the scene file will be written) included unchanged by
/// MuJoCo's `<include>`.
///
/// The robot keeps its own defaults; floor and obstacles get the configured contact `solref`
/// directly. The terrain is laid out as for the configured snake (head tip, heading and straight
/// body from the `snake` keys), since the robot's shape is unknown here; nothing checks that the
/// robot is clear of the obstacles. `terrain.kind = "form_closure"` needs the snake's bent shape
/// and is rejected. `initial_joint_angles_rad` is empty.
///
/// # Errors
/// [`ModelError::Config`] as for [`generate`] (except the overlap and floor checks), and for
/// `terrain.kind = "form_closure"`.
pub fn scene_with_robot(robot_file: &str, cfg: &Config) -> Result<GeneratedModel, ModelError> {
    sanity(cfg)?;
    if cfg.terrain.kind == crate::config::TerrainKind::FormClosure {
        return Err(ConfigError::invalid(
            "terrain.kind",
            "\"form_closure\"",
            "the form-closure pegs are placed around the generated snake's bends; with your own robot use \
             \"none\", \"two_cylinders\", \"random_cylinders\" or \"cylinder_path\"",
        )
        .into());
    }
    if !cfg.ground.surfaces.is_empty() {
        return Err(ConfigError::invalid(
            "ground.surfaces",
            format!("({} surfaces)", cfg.ground.surfaces.len()),
            "surfaces switch the friction of the generated snake's link-floor contact pairs, which a robot of \
             your own does not have; remove them (ground.surfaces = [])",
        )
        .into());
    }
    let segments = link_axis_segments_m(cfg, &[]);
    let placed = terrain::place_obstacles(cfg, &segments)?;
    let mut obstacles: Vec<Cylinder> = placed.into_iter().map(|p| p.cylinder).collect();
    // The robot's shape is unknown: features are not checked against it.
    let features = features::build(cfg, obstacles.len(), &|_| None, &[])?;
    obstacles.extend(features.pegs.iter().cloned());
    let (xml, files) = write_xml(cfg, Body::Include(robot_file), &obstacles, &features)?;
    Ok(GeneratedModel { xml, obstacles, initial_joint_angles_rad: Vec::new(), files, features })
}

/// Unit quaternion (w, x, y, z) of Euler angles in degrees about x, then y, then z (intrinsic,
/// MJCF `euler` with `eulerseq="xyz"`), as `snake.head_rotation_deg` and `robot.rotation_deg`
/// are read.
pub fn euler_xyz_deg_quat(angles_deg: [f64; 3]) -> [f64; 4] {
    geometry::euler_xyz_quat(angles_deg.map(f64::to_radians))
}

/// Starting joint angles (index `j - 1` for joint `j`), rad: `initial_state.joint_angles_deg`
/// when given; otherwise zero, except with
/// `gait.kind = "form_closure"`, where joint `j` starts at `pattern_deg[(j − 1) % len]`, and with
/// a `sine_wave` or `serpenoid` gait without ramp-in (`gait.ramp_secs = 0`), which starts in the
/// wave's shape at t = 0.
pub(crate) fn initial_joint_angles(cfg: &Config) -> Result<Vec<f64>, ConfigError> {
    let nj = cfg.snake.n_joints();
    let given = &cfg.initial_state.joint_angles_deg;
    if !given.is_empty() {
        // Checked by `Config::validate` (length and range); rechecked for a config built in code.
        if given.len() != nj || given.iter().any(|a| !a.is_finite()) {
            return Err(ConfigError::invalid(
                "initial_state.joint_angles_deg",
                format!("{given:?}"),
                format!("[] or {nj} finite angles (one per joint)"),
            ));
        }
        return Ok(given.iter().map(|a| a.to_radians()).collect());
    }
    if nj > 0 && cfg.gait.ramp_secs == 0.0 && matches!(cfg.gait.kind, GaitKind::SineWave | GaitKind::Serpenoid) {
        // Without a ramp-in a planar wave starts at full amplitude: the snake starts in its shape
        // at t = 0, so that it does not jump (and pegs can be placed at its bends).
        let (mut angles, mut velocities) = (vec![0.0; nj], vec![0.0; nj]);
        crate::control::trajectory_from_config(cfg).targets(0.0, &mut angles, &mut velocities);
        return Ok(angles);
    }
    if cfg.gait.kind != GaitKind::FormClosure || nj == 0 {
        return Ok(vec![0.0; nj]);
    }
    let pattern = &cfg.gait.form_closure.pattern_deg;
    let key = "gait.form_closure.pattern_deg";
    if pattern.is_empty() {
        return Err(ConfigError::invalid(key, "[]", "a non-empty list of joint angles (degrees)"));
    }
    let limit = cfg.snake.joint_range_deg;
    if let Some(bad) = pattern.iter().find(|a| !(a.is_finite() && a.abs() <= limit)) {
        return Err(ConfigError::invalid(
            key,
            format!("{pattern:?}"),
            format!("angles within the joint range ±{limit}° (snake.joint_range_deg); {bad} is not"),
        ));
    }
    Ok((0..nj).map(|k| pattern[k % pattern.len()].to_radians()).collect())
}

/// Rejects values that would make the MJCF text invalid or the generator misbehave.
fn sanity(cfg: &Config) -> Result<(), ConfigError> {
    let s = &cfg.snake;
    if s.n_links == 0 || s.n_links > MAX_LINKS {
        return Err(ConfigError::invalid("snake.n_links", s.n_links, format!("1 ..= {MAX_LINKS}")));
    }
    let finite: &[(&str, &[f64])] = &[
        ("general.timestep_secs", &[cfg.general.timestep_secs]),
        ("general.gravity_m_per_s2", &cfg.general.gravity_m_per_s2),
        ("physics.contact_time_constant_secs", &[cfg.physics.contact_time_constant_secs]),
        ("physics.contact_damping_ratio", &[cfg.physics.contact_damping_ratio]),
        ("physics.contact_stiffness_per_s2", &[cfg.physics.contact_stiffness_per_s2]),
        ("physics.contact_damping_per_s", &[cfg.physics.contact_damping_per_s]),
        ("physics.environment_contact_time_constant_secs", &[cfg.environment_contact_time_constant_secs()]),
        ("physics.environment_contact_damping_ratio", &[cfg.physics.environment_contact_damping_ratio]),
        ("snake.link_mass_kg", &[s.link_mass_kg]),
        ("snake.joint_range_deg", &[s.joint_range_deg]),
        ("snake.joint_damping_nm_s_per_rad", &[s.joint_damping_nm_s_per_rad]),
        ("snake.joint_armature_kg_m2", &[s.joint_armature_kg_m2]),
        ("snake.torque_range_nm", &s.torque_range_nm),
        ("snake.ground_friction", &s.ground_friction),
        ("snake.link_friction", &s.link_friction),
        ("snake.color_rgba", &s.color_rgba),
        ("snake.head_position_m", &s.head_position_m),
        ("snake.head_rotation_deg", &s.head_rotation_deg),
        ("terrain.obstacle_friction", &cfg.terrain.obstacle_friction),
        ("terrain.cylinder_height_m", &[cfg.terrain.cylinder_height_m]),
        ("terrain.floor_size_m", &[cfg.terrain.floor_size_m]),
        ("control.torque_gear", &[cfg.control.torque_gear]),
        ("control.position_kp_nm_per_rad", &[cfg.control.position_kp_nm_per_rad]),
        ("control.position_kv_nm_s_per_rad", &[cfg.control.position_kv_nm_s_per_rad]),
        ("control.velocity_kv_nm_s_per_rad", &[cfg.control.velocity_kv_nm_s_per_rad]),
        ("control.intvelocity_kp_nm_per_rad", &[cfg.control.intvelocity_kp_nm_per_rad]),
    ];
    for &(key, values) in finite {
        if let Some(v) = values.iter().find(|v| !v.is_finite()) {
            return Err(ConfigError::invalid(key, v, "finite numbers"));
        }
    }
    let (l, r) = (s.link_length_m, s.link_radius_m);
    if !(r.is_finite() && r > 0.0) {
        return Err(ConfigError::invalid("snake.link_radius_m", r, "a number > 0"));
    }
    if !(l.is_finite() && (l >= 2.0 * r || cfg.legacy.geometry == crate::config::LegacyGeometry::Faithful)) {
        return Err(ConfigError::invalid(
            "snake.link_length_m",
            l,
            format!("at least 2 × link_radius_m = {} (the link is a capsule spanning its full length)", 2.0 * r),
        ));
    }
    if cfg.control.torque_gear == 0.0 {
        return Err(ConfigError::invalid("control.torque_gear", 0.0, "a non-zero number"));
    }
    Ok(())
}

/// The largest snake the generator accepts (MJCF nests one body per link).
pub const MAX_LINKS: usize = 400;

fn check_above_floor(cfg: &Config, segments: &[[V3; 2]]) -> Result<(), ConfigError> {
    let r = cfg.snake.link_radius_m;
    let lowest = |segs: &[[V3; 2]]| segs.iter().flat_map(|s| [s[0][2], s[1][2]]).fold(f64::INFINITY, f64::min);
    let low = lowest(segments);
    if low >= r - 1e-9 {
        return Ok(());
    }
    let straight_low = lowest(&link_axis_segments_m(cfg, &[]));
    if straight_low >= r - 1e-9 {
        return Err(ConfigError::invalid(
            "gait.form_closure.pattern_deg",
            format!("{:?}", cfg.gait.form_closure.pattern_deg),
            format!(
                "the starting shape from this pattern puts part of the snake below the floor (lowest body-axis \
                 point at z = {low} m, needs >= link_radius_m = {r} m); with joint_axes = \"alternating\" the \
                 pattern also bends the pitch joints"
            ),
        ));
    }
    Err(ConfigError::invalid(
        "snake.head_position_m",
        format!("{:?}", cfg.snake.head_position_m),
        format!(
            "the snake must start on or above the floor: its lowest body-axis point would be at z = {low} m, \
             below link_radius_m = {r} m (z = 0 puts a level snake on the floor; check head_position_m[2] and \
             head_rotation_deg)"
        ),
    ))
}

/// Capsule core (segment whose r-neighbourhood is the capsule) of a link axis segment whose ends
/// lie `r` beyond the core (`r` = [`geometry::core_inset_m`]: the radius for
/// `legacy.geometry = "no_overlap"`, 0 for `"faithful"`, whose segment is the core).
pub(crate) fn capsule_core(seg: [V3; 2], r: f64) -> [V3; 2] {
    if r == 0.0 {
        return seg;
    }
    let d = geometry::sub(seg[1], seg[0]);
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if len <= 2.0 * r || len == 0.0 {
        let mid = geometry::scale(geometry::add(seg[0], seg[1]), 0.5);
        return [mid, mid];
    }
    let u = geometry::scale(d, r / len);
    [geometry::add(seg[0], u), geometry::sub(seg[1], u)]
}

/// The first link of the starting snake (axis `segments`) that the vertical cylinder `c`
/// overlaps (the real capsule seen from above, where the link's height range meets the
/// cylinder's), with the xy-distance from the cylinder's axis to the link's capsule core.
pub(crate) fn cylinder_overlap(cfg: &Config, segments: &[[V3; 2]], c: &Cylinder) -> Option<(usize, f64)> {
    let r = cfg.snake.link_radius_m;
    let inset = geometry::core_inset_m(cfg);
    segments.iter().enumerate().find_map(|(i, seg)| {
        let core = capsule_core(*seg, inset);
        let (zlo, zhi) = (core[0][2].min(core[1][2]) - r, core[0][2].max(core[1][2]) + r);
        if zlo >= c.height_m || zhi <= 0.0 {
            return None; // the link passes above the cylinder
        }
        let dist = dist_xy_point_segment(c.center_m, core[0], core[1]);
        (dist < r + c.radius_m).then_some((i, dist))
    })
}

fn check_obstacles_clear(cfg: &Config, segments: &[[V3; 2]], placed: &[terrain::Placed]) -> Result<(), ConfigError> {
    let r = cfg.snake.link_radius_m;
    for p in placed {
        let c = &p.cylinder;
        if let Some((i, dist)) = cylinder_overlap(cfg, segments, c) {
            return Err(ConfigError::invalid(
                p.key,
                &p.value,
                format!(
                    "{} (centre [{}, {}], radius {} m) would overlap {} of the snake at its starting pose: \
                     its centre is {dist} m from the link, needs at least {} m; move the obstacle clear of \
                     the snake",
                    c.name,
                    c.center_m[0],
                    c.center_m[1],
                    c.radius_m,
                    names::link_body(i),
                    r + c.radius_m
                ),
            ));
        }
    }
    Ok(())
}

/// Shortest round-trip decimal text of a number (Rust's `Display` for `f64`), with subnormal
/// numbers (0 < |x| < 2.2e-308, which MuJoCo's parser refuses) written as 0. `Config::validate`
/// rejects subnormal config values; this catches values computed from normal ones (an angle in
/// degrees turned into radians, a range divided by a gear).
pub(crate) fn fmt_num(x: f64) -> String {
    format!("{}", flush_subnormal(x))
}

/// `x`, or 0 when it is subnormal.
pub(crate) fn flush_subnormal(x: f64) -> f64 {
    if x.is_subnormal() { 0.0 } else { x }
}

/// Space-separated numbers.
pub(crate) struct Nums<'a>(pub &'a [f64]);

impl fmt::Display for Nums<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (k, x) in self.0.iter().enumerate() {
            if k > 0 {
                f.write_str(" ")?;
            }
            write!(f, "{}", flush_subnormal(*x))?;
        }
        Ok(())
    }
}

/// What goes into the model besides the common header, floor and obstacles.
enum Body<'a> {
    /// The generated snake with its initial joint angles.
    Snake(&'a [f64]),
    /// A user's robot file, included unchanged.
    Include(&'a str),
}

/// The pieces of the model, put together as `model.xml` (one file) and as
/// `scene.xml` + `terrain.xml` + `robot.xml` (see [`SceneFiles`]).
#[derive(Default)]
struct Pieces {
    /// `<compiler>`, `<option>`, `<default>` (scene).
    header: String,
    /// Sky texture and floor material (scene).
    scene_assets: String,
    /// The light (scene world body).
    light: String,
    /// Heightfield and mesh assets (terrain).
    terrain_assets: String,
    /// Floor, obstacles and features (terrain world body).
    terrain_geoms: String,
    /// Snake bodies (robot world body).
    robot_bodies: String,
    /// Actuators and sensors (robot).
    robot_rest: String,
    /// `<contact>` pairs between links and floor (scene).
    pairs: String,
    /// `<keyframe>` (scene).
    keyframe: String,
}

fn write_xml(
    cfg: &Config,
    body: Body<'_>,
    obstacles: &[Cylinder],
    feats: &features::Features,
) -> Result<(String, SceneFiles), fmt::Error> {
    let n = fmt_num;
    let mut p = Pieces::default();
    let cone = match cfg.physics.friction_cone {
        FrictionCone::Elliptic => "elliptic",
        FrictionCone::Pyramidal => "pyramidal",
    };
    let solref = contact_solref(&cfg.physics);
    p.header.push_str("  <compiler angle=\"radian\" autolimits=\"true\"/>\n");
    writeln!(
        p.header,
        "  <option timestep=\"{}\" integrator=\"{}\" gravity=\"{}\" cone=\"{cone}\" iterations=\"{}\"/>",
        n(cfg.general.timestep_secs),
        cfg.general.integrator.mjcf_name(),
        Nums(&cfg.general.gravity_m_per_s2),
        cfg.physics.solver_iterations,
    )?;
    // With a user's robot its own defaults stay in force. Floor, obstacles and terrain get the
    // environment contact solref directly (their priority 1 makes it the contact's: MuJoCo takes
    // solref and solimp from the geom of higher priority).
    if matches!(body, Body::Snake(_)) {
        writeln!(p.header, "  <default>\n    <geom solref=\"{solref}\"/>\n  </default>")?;
    }
    let env_solref_value = environment_solref(cfg);
    let env_solref = format!(" solref=\"{env_solref_value}\"");
    p.scene_assets.push_str(concat!(
        "    <texture name=\"skybox\" type=\"skybox\" builtin=\"gradient\" rgb1=\"1 1 1\" rgb2=\"0 0 0\" width=\"100\" height=\"100\"/>\n",
        "    <texture name=\"texplane\" type=\"2d\" builtin=\"checker\" rgb1=\"0 0 0\" rgb2=\"0.8 0.8 0.8\" width=\"100\" height=\"100\"/>\n",
        "    <material name=\"MatPlane\" texture=\"texplane\" texuniform=\"true\" texrepeat=\"2 2\" reflectance=\"0.5\" shininess=\"1\" specular=\"1\"/>\n",
    ));
    p.light.push_str("    <light name=\"light\" directional=\"true\" pos=\"0 0 1.3\" dir=\"0 0 -1.3\" diffuse=\"1 1 1\" specular=\"0.1 0.1 0.1\" cutoff=\"100\" exponent=\"1\"/>\n");
    let env_attrs = |friction: [f64; 3]| {
        format!(
            "contype=\"{}\" conaffinity=\"{}\" priority=\"1\" friction=\"{}\" condim=\"{}\"{env_solref}",
            snake::ENV_CONTYPE,
            snake::ENV_CONAFFINITY,
            Nums(&friction),
            snake::condim(friction)
        )
    };
    let fs = cfg.terrain.floor_size_m;
    // The floor's own contacts with the links: isotropic friction, none at all (the viscous model
    // applies its forces itself), or left to the explicit link-floor pairs below.
    // With surfaces the isotropic model also goes through the pairs (their friction is switched
    // by the surface under each link); without surfaces the model is exactly as before.
    // SimSerpent's own floor friction (`physics.floor_friction = "stick_slip"`, generated snake
    // only): frictionless link-ground contacts (condim 1; the floor's priority makes its condim
    // the contact's), `sim::ground` applies the friction.
    let own_friction = matches!(body, Body::Snake(_))
        && cfg.physics.floor_friction == FloorFriction::StickSlip
        && cfg.ground.model != GroundModel::Viscous;
    let frictionless_attrs = format!(
        "contype=\"{}\" conaffinity=\"{}\" priority=\"1\" friction=\"{}\" condim=\"1\"{env_solref}",
        snake::ENV_CONTYPE,
        snake::ENV_CONAFFINITY,
        Nums(&cfg.snake.ground_friction)
    );
    let snake_pairs = matches!(body, Body::Snake(_))
        && !own_friction
        && match cfg.ground.model {
            GroundModel::Anisotropic | GroundModel::Directional => true,
            GroundModel::Isotropic => !cfg.ground.surfaces.is_empty(),
            GroundModel::Viscous => false,
        };
    let floor_attrs = match cfg.ground.model {
        _ if own_friction => frictionless_attrs.clone(),
        GroundModel::Viscous => env_attrs([0.0; 3]),
        _ if snake_pairs => format!(
            "contype=\"0\" conaffinity=\"0\" priority=\"1\" friction=\"{}\"{env_solref}",
            Nums(&cfg.snake.ground_friction)
        ),
        _ => env_attrs(cfg.snake.ground_friction),
    };
    // Ground-like terrain surfaces: isotropic ground friction through the default collision
    // filter (no pairs: a capsule-hfield or capsule-box contact frame does not follow the link).
    let ground_attrs = match cfg.ground.model {
        _ if own_friction => frictionless_attrs,
        GroundModel::Viscous => env_attrs([0.0; 3]),
        _ => env_attrs(cfg.snake.ground_friction),
    };
    writeln!(
        p.terrain_geoms,
        "    <geom name=\"{}\" type=\"plane\" pos=\"0 0 0\" size=\"{} {} 0.1\" material=\"MatPlane\" {floor_attrs}/>",
        names::FLOOR,
        n(fs),
        n(fs),
    )?;
    if matches!(body, Body::Snake(_)) {
        surfaces::write_tiles(&mut p.terrain_geoms, cfg)?;
    }
    let kind_cylinders = obstacles.len() - feats.pegs.len();
    // With SimSerpent's own friction the link-obstacle contacts are frictionless too (condim 1;
    // `sim::ground` applies their friction, `terrain.obstacle_friction[0]`).
    let obstacle_attrs = if own_friction {
        format!(
            "contype=\"{}\" conaffinity=\"{}\" priority=\"1\" friction=\"{}\" condim=\"1\"{env_solref}",
            snake::ENV_CONTYPE,
            snake::ENV_CONAFFINITY,
            Nums(&cfg.terrain.obstacle_friction)
        )
    } else {
        env_attrs(cfg.terrain.obstacle_friction)
    };
    for c in &obstacles[..kind_cylinders] {
        features::write_cylinder(&mut p.terrain_geoms, c, &obstacle_attrs)?;
    }
    features::write_geoms(&mut p.terrain_geoms, feats, &obstacle_attrs, &ground_attrs)?;
    features::write_assets(&mut p.terrain_assets, feats)?;
    if let Body::Snake(angles) = body {
        snake::write_bodies(&mut p.robot_bodies, cfg, 2)?;
        if snake_pairs {
            // One pair per link: MuJoCo aligns a capsule-plane contact frame's first tangent with
            // the capsule axis, so friction = "axial lateral ..." is anisotropic along the link.
            let g = &cfg.ground;
            // Isotropic (only with surfaces): the floor's own coefficients, torsional and
            // rolling included, as the geom friction would give them.
            let (friction, condim) = match g.model {
                GroundModel::Isotropic => {
                    let [s, t, r] = cfg.snake.ground_friction;
                    ([s, s, t, r, r], snake::condim(cfg.snake.ground_friction))
                }
                _ => ([g.axial_friction, g.lateral_friction, 0.0, 0.0, 0.0], 3),
            };
            p.pairs.push_str("  <contact>\n");
            for i in 0..cfg.snake.n_links {
                writeln!(
                    p.pairs,
                    "    <pair name=\"{}\" geom1=\"{}\" geom2=\"{}\" condim=\"{condim}\" friction=\"{}\" solref=\"{env_solref_value}\"/>",
                    names::ground_pair(i),
                    names::FLOOR,
                    names::link_geom(i),
                    Nums(&friction),
                )?;
            }
            p.pairs.push_str("  </contact>\n");
        }
        snake::write_actuators(&mut p.robot_rest, cfg)?;
        snake::write_sensors(&mut p.robot_rest, cfg)?;
        snake::write_keyframe(&mut p.keyframe, cfg, angles)?;
    }
    let robot_include = match body {
        Body::Include(file) => Some(file),
        Body::Snake(_) => None,
    };
    let user = feats.user_terrain.as_deref();
    let version = env!("CARGO_PKG_VERSION");

    // model.xml: everything in one file (only a third-party terrain and a user's robot are included).
    let mut model = String::with_capacity(4096 + 2048 * cfg.snake.n_links + p.terrain_assets.len());
    model.push_str("<mujoco model=\"simserpent\">\n");
    writeln!(model, "  <!-- Generated by SimSerpent {version} from the resolved configuration. -->")?;
    if let Some(file) = robot_include {
        writeln!(model, "  <include file=\"{}\"/>", xml_escape(file))?;
    }
    model.push_str(&p.header);
    writeln!(model, "  <asset>\n{}{}  </asset>", p.scene_assets, p.terrain_assets)?;
    writeln!(model, "  <worldbody>\n{}{}  </worldbody>", p.light, p.terrain_geoms)?;
    if let Some(file) = user {
        writeln!(model, "  <include file=\"{}\"/>", xml_escape(file))?;
    }
    if !p.robot_bodies.is_empty() {
        writeln!(model, "  <worldbody>\n{}  </worldbody>", p.robot_bodies)?;
    }
    model.push_str(&p.pairs);
    model.push_str(&p.robot_rest);
    model.push_str(&p.keyframe);
    model.push_str("</mujoco>\n");

    // terrain.xml
    let mut terrain = String::new();
    terrain.push_str("<mujoco model=\"simserpent-terrain\">\n");
    writeln!(
        terrain,
        "  <!-- Generated by SimSerpent {version}: floor, obstacles and terrain features. Included by {SCENE_FILE}; \
         reusable with another robot (links collide with geoms of conaffinity 1). -->"
    )?;
    if !p.terrain_assets.is_empty() {
        writeln!(terrain, "  <asset>\n{}  </asset>", p.terrain_assets)?;
    }
    writeln!(terrain, "  <worldbody>\n{}  </worldbody>", p.terrain_geoms)?;
    if let Some(file) = user {
        writeln!(terrain, "  <include file=\"{}\"/>", xml_escape(file))?;
    }
    terrain.push_str("</mujoco>\n");

    // scene.xml
    let mut scene = String::new();
    scene.push_str("<mujoco model=\"simserpent\">\n");
    writeln!(scene, "  <!-- Generated by SimSerpent {version}: the scene joins {TERRAIN_FILE} and the robot. -->")?;
    if let Some(file) = robot_include {
        writeln!(scene, "  <include file=\"{}\"/>", xml_escape(file))?;
    }
    scene.push_str(&p.header);
    writeln!(scene, "  <asset>\n{}  </asset>", p.scene_assets)?;
    writeln!(scene, "  <worldbody>\n{}  </worldbody>", p.light)?;
    writeln!(scene, "  <include file=\"{TERRAIN_FILE}\"/>")?;
    if robot_include.is_none() {
        writeln!(scene, "  <include file=\"{ROBOT_FILE}\"/>")?;
    }
    scene.push_str(&p.pairs);
    scene.push_str(&p.keyframe);
    scene.push_str("</mujoco>\n");

    let mut texts = vec![(SCENE_FILE.to_string(), scene), (TERRAIN_FILE.to_string(), terrain)];
    if robot_include.is_none() {
        let mut robot = String::new();
        robot.push_str("<mujoco model=\"simserpent-robot\">\n");
        writeln!(
            robot,
            "  <!-- Generated by SimSerpent {version}: the snake's bodies, actuators and sensors. Included by {SCENE_FILE}, \
             which holds the contact defaults, the link-floor pairs and the starting keyframe. -->"
        )?;
        writeln!(robot, "  <worldbody>\n{}  </worldbody>", p.robot_bodies)?;
        robot.push_str(&p.robot_rest);
        robot.push_str("</mujoco>\n");
        texts.push((ROBOT_FILE.to_string(), robot));
    }
    let files = SceneFiles { texts, copies: feats.copies.clone(), model_needs_files: user.is_some() };
    Ok((model, files))
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The `solref` of the links' contacts with the environment (floor, obstacles, terrain, link–floor
/// pairs): `"τ_env environment_contact_damping_ratio"`, or the direct form of
/// [`contact_solref`] when `physics.contact_stiffness_per_s2 > 0` (a stiffness given directly
/// sets every contact of the snake).
pub fn environment_solref(cfg: &Config) -> String {
    if cfg.physics.contact_stiffness_per_s2 > 0.0 {
        contact_solref(&cfg.physics)
    } else {
        format!(
            "{} {}",
            fmt_num(cfg.environment_contact_time_constant_secs()),
            fmt_num(cfg.physics.environment_contact_damping_ratio)
        )
    }
}

/// The contact `solref` of link–link contacts: `"timeconst dampratio"` (MuJoCo's standard form),
/// or `"-stiffness -damping"` (its direct form) when `physics.contact_stiffness_per_s2 > 0`.
/// Both numbers of the direct form are ≤ 0: MuJoCo replaces a solref of mixed signs by its
/// default (with a warning), so a damping of 0 is written as `0`, not `-0`.
pub fn contact_solref(p: &crate::config::Physics) -> String {
    if p.contact_stiffness_per_s2 > 0.0 {
        let damping = if p.contact_damping_per_s > 0.0 { fmt_num(-p.contact_damping_per_s) } else { "0".into() };
        format!("{} {damping}", fmt_num(-p.contact_stiffness_per_s2))
    } else {
        format!("{} {}", fmt_num(p.contact_time_constant_secs), fmt_num(p.contact_damping_ratio))
    }
}
