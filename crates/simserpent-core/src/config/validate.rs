//! [`Config::validate`]: ranges and consistency of a deserialized config.
//!
//! Checks run section by section in the order of the default file and stop at the first
//! problem, reported as [`ConfigError::InvalidValue`] with the full key path, the value and
//! what is allowed. Array values are reported whole (`snake.ground_friction = [0.5, -1.0,
//! 0.0001]`), the message names the offending element.
//!
//! Every number must be finite (NaN and infinities are rejected everywhere). Rules that tie a
//! section to another one are checked only when the section is in use:
//! - the sine-wave amplitude and offset against `snake.joint_range_deg`: when
//!   `gait.kind = "sine_wave"`;
//! - the form-closure pattern against `snake.joint_range_deg`: when `gait.kind` or
//!   `terrain.kind` is `"form_closure"`;
//! - the corridor width against the snake's thickness: when `terrain.kind = "cylinder_path"`;
//! - the record interval against the duration: when `recording.enabled`;
//! - a contact law's offsets and amplitudes against `snake.joint_range_deg`, its windows against
//!   the number of joints, and what it needs of the gait, the actuators and the estimation: when
//!   `control.controller` selects it.
//!
//! The ranges of every other key are checked whatever is selected. Whether obstacles overlap the
//! snake is checked by model generation, not here.

use super::surfaces::{self, FrictionSource, SurfaceShape};
use super::text::{fmt_a, fmt_f};
use super::{
    Config, ConfigError, ContactSource, ControlMethod, ControllerKind, GaitKind, GroundModel, JointAxes,
    LegacyGeometry, TerrainKind,
};

/// The most surfaces a config may have (`ground.surfaces`).
pub const MAX_SURFACES: usize = 100;

/// The largest magnitude of any number in a config: beyond it MuJoCo's computations overflow
/// (a squared length of 1e154 is infinite) and no simulation means it.
pub const MAX_MAGNITUDE: f64 = 1e12;

/// The smallest value of a key that must be greater than 0 (a size, a duration, a scale, ...).
pub const MIN_POSITIVE: f64 = 1e-12;

/// The most steps one run may take (`general.duration_secs / general.timestep_secs`).
pub const MAX_STEPS_PER_RUN: f64 = 1e9;

/// The shortest timestep (`general.timestep_secs`), s.
pub const MIN_TIMESTEP_SECS: f64 = 1e-7;

/// The most constraint-solver iterations per step (`physics.solver_iterations`).
pub const MAX_SOLVER_ITERATIONS: u32 = 100_000;

/// The thinnest link (`snake.link_radius_m`), m: MuJoCo rejects thinner capsules as massless.
pub const MIN_LINK_RADIUS_M: f64 = 1e-4;

/// The smallest moment of inertia of a link about its own axis, kg·m² (MuJoCo rejects a moving
/// body whose inertia is below 1e-15 kg·m²; this keeps a factor of 10).
pub const MIN_LINK_INERTIA_KG_M2: f64 = 1e-14;

/// The observation layouts this build knows (`env.observation_version`).
pub const OBSERVATION_VERSIONS: [u32; 1] = [1];

type Check = Result<(), ConfigError>;

/// The most elements of a list of the config whose length no other key fixes
/// (`gait.form_closure.pattern_deg`, `render.image_times_secs`, `initial_state.joint_angles_deg`).
pub const MAX_LIST_LEN: usize = 10_000;

fn at_most_list_len(key: &str, values: &[f64]) -> Check {
    ensure(
        values.len() <= MAX_LIST_LEN,
        key,
        fmt_a(values),
        format!("must have at most {MAX_LIST_LEN} elements; it has {}", values.len()),
    )
}

fn fail(key: &str, value: impl std::fmt::Display, allowed: impl Into<String>) -> Check {
    Err(ConfigError::invalid(key, value, allowed))
}

fn ensure(ok: bool, key: &str, value: impl std::fmt::Display, allowed: impl Into<String>) -> Check {
    if ok { Ok(()) } else { fail(key, value, allowed) }
}

fn finite(key: &str, v: f64) -> Check {
    ensure(v.is_finite(), key, fmt_f(v), "must be a finite number (nan and inf are not allowed)")
}

fn positive(key: &str, v: f64) -> Check {
    finite(key, v)?;
    ensure(v > 0.0, key, fmt_f(v), "must be greater than 0")?;
    ensure(
        v >= MIN_POSITIVE,
        key,
        fmt_f(v),
        format!(
            "must be greater than 0 and at least {MIN_POSITIVE:e} (smaller values are no physical size and MuJoCo cannot compute with them)"
        ),
    )
}

/// Why `v` breaks the rule for every number (0 or a normal double — MuJoCo's parser refuses
/// subnormal ones, 0 < |x| < 2.2e-308 — of magnitude at most [`MAX_MAGNITUDE`]), if it does (NaN and infinities are left to the key's own check).
fn number_problem(v: f64) -> Option<&'static str> {
    if !v.is_finite() {
        None
    } else if v != 0.0 && v.abs() < f64::MIN_POSITIVE {
        Some(
            "a subnormal number (0 < |x| < 2.2250738585072014e-308), which MuJoCo's parser refuses; use 0 or a larger value",
        )
    } else if v.abs() > MAX_MAGNITUDE {
        Some(
            "larger in magnitude than 1e12, beyond any simulation (MuJoCo's computations overflow); use a smaller value",
        )
    } else {
        None
    }
}

/// The float of a JSON value that holds one (not an integer: counts have their own bounds).
fn json_float(v: &serde_json::Value) -> Option<f64> {
    match v {
        serde_json::Value::Number(n) if n.is_f64() => n.as_f64(),
        _ => None,
    }
}

/// The rule of [`number_problem`] for every float of `value`, reported with its key path (`prefix`).
fn check_numbers(prefix: &str, value: &serde_json::Value) -> Check {
    match value {
        serde_json::Value::Number(_) => match json_float(value).and_then(|v| number_problem(v).map(|why| (v, why))) {
            Some((v, why)) => fail(prefix, fmt_f(v), format!("is {why}")),
            None => Ok(()),
        },
        serde_json::Value::Array(items) => {
            let floats: Option<Vec<f64>> = items.iter().map(json_float).collect();
            for (k, item) in items.iter().enumerate() {
                match (json_float(item), &floats) {
                    (Some(v), Some(all)) => {
                        if let Some(why) = number_problem(v) {
                            return fail(prefix, fmt_a(all), format!("element {} is {}: {why}", k + 1, fmt_f(v)));
                        }
                    }
                    _ => check_numbers(&format!("{prefix}[{k}]"), item)?,
                }
            }
            Ok(())
        }
        serde_json::Value::Object(t) => {
            for (k, v) in t {
                let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                check_numbers(&key, v)?;
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

fn non_negative(key: &str, v: f64) -> Check {
    finite(key, v)?;
    ensure(v >= 0.0, key, fmt_f(v), "must be at least 0")
}

/// Every element finite.
fn all_finite(key: &str, values: &[f64]) -> Check {
    for (i, v) in values.iter().enumerate() {
        ensure(
            v.is_finite(),
            key,
            fmt_a(values),
            format!(
                "every element must be a finite number (nan and inf are not allowed); element {} is {}",
                i + 1,
                fmt_f(*v)
            ),
        )?;
    }
    Ok(())
}

/// Friction coefficients `[sliding, torsional_m, rolling_m]`: finite and >= 0.
fn friction(key: &str, values: &[f64; 3]) -> Check {
    all_finite(key, values)?;
    for (name, v) in ["sliding", "torsional", "rolling"].into_iter().zip(values) {
        ensure(*v >= 0.0, key, fmt_a(values), format!("the {name} coefficient must be at least 0, not {}", fmt_f(*v)))?;
    }
    Ok(())
}

/// Moment of inertia of a capsule link about its axis (kg·m²), as MuJoCo computes it from the
/// geom: a cylinder of length `length − 2 radius` and two half-spheres, of uniform density.
pub fn link_axial_inertia_kg_m2(mass_kg: f64, radius_m: f64, length_m: f64) -> f64 {
    let cylinder = std::f64::consts::PI * radius_m * radius_m * (length_m - 2.0 * radius_m).max(0.0);
    let sphere = 4.0 / 3.0 * std::f64::consts::PI * radius_m.powi(3);
    let total = cylinder + sphere;
    if total <= 0.0 || !total.is_finite() {
        return 0.0;
    }
    mass_kg * radius_m * radius_m * (cylinder / total * 0.5 + sphere / total * 0.4)
}

impl Config {
    /// Checks ranges and consistency; returns the first problem found.
    ///
    /// # Errors
    /// [`ConfigError::InvalidValue`] naming the key path, its value and what is allowed, e.g.
    /// `snake.n_links = 0: must be at least 1`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.validate_numbers()?;
        self.validate_general()?;
        self.validate_physics()?;
        self.validate_floor_friction()?;
        self.validate_environment_contact()?;
        self.validate_safety()?;
        self.validate_snake()?;
        self.validate_initial_state()?;
        self.validate_robot()?;
        self.validate_ground()?;
        self.validate_sensors()?;
        self.validate_control()?;
        self.validate_gait()?;
        self.validate_terrain()?;
        self.validate_recording()?;
        self.validate_pictures()?;
        self.ros2.validate()?;
        self.validate_env()?;
        self.validate_estimation()?;
        self.validate_path_following()?;
        self.validate_contact_laws()
    }

    /// `[follow_the_leader_reflex]`, `[directional_admittance]`, `[jam_resolution]`, and what the
    /// selected one of them needs of the gait, the actuators and the estimation.
    fn validate_contact_laws(&self) -> Check {
        let r = &self.follow_the_leader_reflex;
        finite("follow_the_leader_reflex.goal_heading_deg", r.goal_heading_deg)?;
        self.validate_heading_hold("follow_the_leader_reflex", r.heading_gain, r.heading_max_offset_deg)?;
        non_negative("follow_the_leader_reflex.propulsive_gain_rad_per_n", r.propulsive_gain_rad_per_n)?;
        non_negative("follow_the_leader_reflex.resisting_gain_rad_per_n", r.resisting_gain_rad_per_n)?;
        non_negative("follow_the_leader_reflex.force_filter_secs", r.force_filter_secs)?;
        positive("follow_the_leader_reflex.max_offset_deg", r.max_offset_deg)?;

        let a = &self.directional_admittance;
        finite("directional_admittance.goal_heading_deg", a.goal_heading_deg)?;
        self.validate_heading_hold("directional_admittance", a.heading_gain, a.heading_max_offset_deg)?;
        ensure(a.windows >= 1, "directional_admittance.windows", a.windows, "must be at least 1")?;
        positive("directional_admittance.window_sigma_joints", a.window_sigma_joints)?;
        positive("directional_admittance.stiffness_nm_per_rad", a.stiffness_nm_per_rad)?;
        positive("directional_admittance.damping_nm_s_per_rad", a.damping_nm_s_per_rad)?;
        non_negative("directional_admittance.min_amplitude_deg", a.min_amplitude_deg)?;
        positive("directional_admittance.max_amplitude_deg", a.max_amplitude_deg)?;
        ensure(
            a.min_amplitude_deg <= a.max_amplitude_deg,
            "directional_admittance.min_amplitude_deg",
            fmt_f(a.min_amplitude_deg),
            format!("must not exceed directional_admittance.max_amplitude_deg ({})", fmt_f(a.max_amplitude_deg)),
        )?;
        positive("directional_admittance.wedge_force_n", a.wedge_force_n)?;
        finite("directional_admittance.wedge_speed_m_per_s", a.wedge_speed_m_per_s)?;
        positive("directional_admittance.wedge_secs", a.wedge_secs)?;
        positive("directional_admittance.filter_secs", a.filter_secs)?;
        positive("directional_admittance.escape_stiffness_ratio", a.escape_stiffness_ratio)?;
        ensure(
            a.escape_stiffness_ratio <= 1.0,
            "directional_admittance.escape_stiffness_ratio",
            fmt_f(a.escape_stiffness_ratio),
            "must be in (0, 1]",
        )?;
        non_negative("directional_admittance.escape_secs", a.escape_secs)?;

        let j = &self.jam_resolution;
        finite("jam_resolution.goal_heading_deg", j.goal_heading_deg)?;
        self.validate_heading_hold("jam_resolution", j.heading_gain, j.heading_max_offset_deg)?;
        positive("jam_resolution.jam_window_secs", j.jam_window_secs)?;
        non_negative("jam_resolution.jam_min_progress_m", j.jam_min_progress_m)?;
        positive("jam_resolution.resolve_secs", j.resolve_secs)?;
        positive("jam_resolution.push_force_n", j.push_force_n)?;
        non_negative("jam_resolution.min_propulsion", j.min_propulsion)?;
        ensure(j.min_propulsion < 1.0, "jam_resolution.min_propulsion", fmt_f(j.min_propulsion), "must be below 1")?;
        positive("jam_resolution.offset_filter_secs", j.offset_filter_secs)?;
        positive("jam_resolution.max_offset_deg", j.max_offset_deg)?;

        // What ties a law to the snake (its joints and their range): when it is selected.
        let (name, contacts) = match self.control.controller {
            ControllerKind::FollowTheLeaderReflex => {
                self.below_joint_range("follow_the_leader_reflex.max_offset_deg", r.max_offset_deg)?;
                ("follow_the_leader_reflex", r.contacts)
            }
            ControllerKind::DirectionalAdmittance => {
                let nj = self.snake.n_joints();
                ensure(
                    a.windows <= nj.max(1),
                    "directional_admittance.windows",
                    a.windows,
                    format!("must be 1 ..= the number of joints ({nj})"),
                )?;
                self.below_joint_range("directional_admittance.max_amplitude_deg", a.max_amplitude_deg)?;
                ("directional_admittance", a.contacts)
            }
            ControllerKind::JamResolution => {
                self.below_joint_range("jam_resolution.max_offset_deg", j.max_offset_deg)?;
                ("jam_resolution", j.contacts)
            }
            _ => return Ok(()),
        };
        ensure(
            self.gait.kind == GaitKind::SineWave,
            "gait.kind",
            format!("{:?}", self.gait.kind),
            format!("control.controller = \"{name}\" shapes the sine wave: it needs gait.kind = \"sine_wave\""),
        )?;
        ensure(
            contacts != ContactSource::Estimated || self.estimation.enabled,
            &format!("{name}.contacts"),
            "\"estimated\"",
            "reads the step loop's contact estimates: set estimation.enabled = true (or contacts = \"true\" or \"true_with_self\")",
        )?;
        let w = &self.gait.sine_wave;
        if self.control.controller == ControllerKind::FollowTheLeaderReflex {
            ensure(
                w.phase_lag_deg > 0.0 && w.frequency_hz > 0.0,
                "gait.sine_wave.phase_lag_deg",
                fmt_f(w.phase_lag_deg),
                "control.controller = \"follow_the_leader_reflex\" passes each joint's offset to the joint behind it as \
                 the wave travels toward the tail: it needs phase_lag_deg > 0 and frequency_hz > 0",
            )?;
        }
        if self.control.controller == ControllerKind::DirectionalAdmittance {
            ensure(
                a.min_amplitude_deg <= w.amplitude_deg && w.amplitude_deg <= a.max_amplitude_deg,
                "gait.sine_wave.amplitude_deg",
                fmt_f(w.amplitude_deg),
                format!(
                    "control.controller = \"directional_admittance\" needs it within directional_admittance's \
                     [min_amplitude_deg, max_amplitude_deg] = [{}, {}]",
                    fmt_f(a.min_amplitude_deg),
                    fmt_f(a.max_amplitude_deg)
                ),
            )?;
        }
        if self.control.controller == ControllerKind::JamResolution {
            ensure(
                self.control.method != ControlMethod::Velocity,
                "control.method",
                "\"velocity\"",
                "control.controller = \"jam_resolution\" turns torque increments into joint offsets through the \
                 servo stiffness: use \"position\", \"torque\" or \"intvelocity\"",
            )?;
        }
        Ok(())
    }

    /// A controller's joint offset (deg) must stay inside the joint's range.
    fn below_joint_range(&self, key: &str, offset_deg: f64) -> Check {
        positive(key, offset_deg)?;
        ensure(
            offset_deg < self.snake.joint_range_deg,
            key,
            fmt_f(offset_deg),
            format!("must be below snake.joint_range_deg ({})", fmt_f(self.snake.joint_range_deg)),
        )
    }

    /// A contact law's heading hold: `<section>.heading_gain` ≥ 0 and its largest offset below
    /// the joint range.
    fn validate_heading_hold(&self, section: &str, gain: f64, max_offset_deg: f64) -> Check {
        non_negative(&format!("{section}.heading_gain"), gain)?;
        self.below_joint_range(&format!("{section}.heading_max_offset_deg"), max_offset_deg)
    }

    fn validate_estimation(&self) -> Check {
        let e = &self.estimation;
        positive("estimation.detection_threshold_n", e.detection_threshold_n)?;
        positive("estimation.min_lateral_force_n", e.min_lateral_force_n)?;
        positive("estimation.sliding_speed_m_per_s", e.sliding_speed_m_per_s)?;
        non_negative("estimation.tilt_gain_per_s", e.tilt_gain_per_s)?;
        non_negative("estimation.contact_point_filter_secs", e.contact_point_filter_secs)?;
        positive("estimation.friction_prior", e.friction_prior)?;
        positive("estimation.friction_window_secs", e.friction_window_secs)?;
        non_negative("estimation.self_contact_margin_m", e.self_contact_margin_m)
    }

    fn validate_path_following(&self) -> Check {
        let p = &self.path_following;
        positive("path_following.lookahead_m", p.lookahead_m)?;
        positive("path_following.heading_gain", p.heading_gain)?;
        positive("path_following.acceptance_radius_m", p.acceptance_radius_m)?;
        self.below_joint_range("path_following.max_offset_deg", p.max_offset_deg)?;
        ensure(
            p.waypoints_m.len() >= 2,
            "path_following.waypoints_m",
            format!("{:?}", p.waypoints_m),
            "needs at least 2 points [x, y]",
        )?;
        for (i, w) in p.waypoints_m.iter().enumerate() {
            all_finite(&format!("path_following.waypoints_m[{i}]"), w)?;
        }
        for (i, pair) in p.waypoints_m.windows(2).enumerate() {
            let d = (pair[1][0] - pair[0][0]).hypot(pair[1][1] - pair[0][1]);
            ensure(
                d > 1e-6,
                &format!("path_following.waypoints_m[{}]", i + 1),
                format!("{:?}", pair[1]),
                "must differ from the point before it (a segment needs a length)",
            )?;
        }
        Ok(())
    }

    /// The rule of [`number_problem`] on every number of the config.
    fn validate_numbers(&self) -> Check {
        // JSON keeps u64 counts above i64::MAX (TOML cannot); NaN and infinities become null and
        // are left to the checks of their keys. If it did not serialize, those checks still run.
        match serde_json::to_value(self) {
            Ok(value) => check_numbers("", &value),
            Err(_) => Ok(()),
        }
    }

    fn validate_general(&self) -> Check {
        let g = &self.general;
        ensure(
            !g.run_name.is_empty()
                && !g.run_name.starts_with('.')
                && g.run_name.len() <= 200
                && g.run_name.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-')),
            "general.run_name",
            format!("{:?}", g.run_name),
            "must be 1 to 200 characters, not start with `.`, and use only letters A-Z a-z, digits 0-9, `.`, `_` and \
             `-` (it becomes part of a folder name)",
        )?;
        ensure(
            !g.output_dir.trim().is_empty(),
            "general.output_dir",
            format!("{:?}", g.output_dir),
            "must not be empty",
        )?;
        positive("general.duration_secs", g.duration_secs)?;
        finite("general.timestep_secs", g.timestep_secs)?;
        ensure(
            g.timestep_secs >= MIN_TIMESTEP_SECS,
            "general.timestep_secs",
            fmt_f(g.timestep_secs),
            format!("must be greater than 0 and at least {MIN_TIMESTEP_SECS:e} s (0.1 microseconds)"),
        )?;
        let steps = g.duration_secs / g.timestep_secs;
        ensure(
            steps <= MAX_STEPS_PER_RUN,
            "general.duration_secs",
            fmt_f(g.duration_secs),
            format!(
                "gives general.duration_secs / general.timestep_secs = {steps:.3e} steps; a run may take at most \
                 {MAX_STEPS_PER_RUN:e} steps (shorten the run or lengthen general.timestep_secs = {})",
                fmt_f(g.timestep_secs)
            ),
        )?;
        ensure(
            g.timestep_secs <= g.duration_secs,
            "general.timestep_secs",
            fmt_f(g.timestep_secs),
            format!("must not be longer than general.duration_secs ({})", fmt_f(g.duration_secs)),
        )?;
        all_finite("general.gravity_m_per_s2", &g.gravity_m_per_s2)
    }

    fn validate_ground(&self) -> Check {
        let g = &self.ground;
        non_negative("ground.axial_friction", g.axial_friction)?;
        non_negative("ground.lateral_friction", g.lateral_friction)?;
        non_negative("ground.backward_friction", g.backward_friction)?;
        non_negative("ground.viscous_tangential_n_s_per_m", g.viscous_tangential_n_s_per_m)?;
        non_negative("ground.viscous_normal_n_s_per_m", g.viscous_normal_n_s_per_m)?;
        self.validate_surfaces()
    }

    /// `[[ground.surfaces]]`: sizes, coefficients, inside the floor, and every coefficient that
    /// `ground.model` needs known. (A shape without its size, or both a preset and a friction,
    /// cannot be deserialized: see [`surfaces::Surface`].)
    fn validate_surfaces(&self) -> Check {
        let surfaces = &self.ground.surfaces;
        ensure(
            surfaces.len() <= MAX_SURFACES,
            "ground.surfaces",
            format!("({} surfaces)", surfaces.len()),
            format!("at most {MAX_SURFACES} surfaces"),
        )?;
        let mu0 = self.snake.ground_friction[0];
        let fs = self.terrain.floor_size_m;
        // The coefficients that the ground model uses, besides the base one.
        let needed: &[&str] = match self.ground.model {
            GroundModel::Isotropic => &[],
            GroundModel::Anisotropic => &["axial_friction", "lateral_friction"],
            GroundModel::Directional => &["axial_friction", "lateral_friction", "backward_friction"],
            GroundModel::Viscous => &["viscous_tangential_n_s_per_m", "viscous_normal_n_s_per_m"],
        };
        for (i, s) in surfaces.iter().enumerate() {
            let key = |k: &str| format!("ground.surfaces[{i}].{k}");
            all_finite(&key("center_m"), &s.center_m)?;
            let (size_key, size_value) = match s.shape {
                SurfaceShape::Rectangle { size_m } => {
                    all_finite(&key("size_m"), &size_m)?;
                    ensure(
                        size_m[0] > 0.0 && size_m[1] > 0.0,
                        &key("size_m"),
                        fmt_a(&size_m),
                        "both side lengths must be greater than 0",
                    )?;
                    ("size_m", fmt_a(&size_m))
                }
                SurfaceShape::Circle { radius_m } => {
                    positive(&key("radius_m"), radius_m)?;
                    ("radius_m", fmt_f(radius_m))
                }
            };
            let [x0, y0, x1, y1] = s.bounds();
            if x0 < -fs || y0 < -fs || x1 > fs || y1 > fs {
                fail(
                    &key(size_key),
                    size_value,
                    format!(
                        "the surface (center_m = {}) spans x {}..{}, y {}..{}; it must lie on the floor, within \
                         terrain.floor_size_m = {} of the origin in x and y",
                        fmt_a(&s.center_m),
                        fmt_f(x0),
                        fmt_f(x1),
                        fmt_f(y0),
                        fmt_f(y1),
                        fmt_f(fs)
                    ),
                )?;
            }
            if let Some(FrictionSource::Coefficient(mu)) = s.base {
                non_negative(&key("friction"), mu)?;
            }
            let explicit = s.explicit.by_key();
            for (k, v) in explicit {
                if let Some(v) = v {
                    non_negative(&key(k), v)?;
                }
            }
            // Every coefficient that the chosen model uses must be known: explicit, or derived
            // from the base coefficient (which, except for the isotropic model, needs mu0 > 0).
            let derived = needed.iter().any(|k| explicit.iter().any(|(e, v)| e == k && v.is_none()));
            if (needed.is_empty() || derived) && s.base.is_none() {
                return fail(
                    &format!("ground.surfaces[{i}]"),
                    "(no preset or friction)",
                    format!(
                        "give preset = one of {} or friction = a sliding coefficient{}",
                        surfaces::preset_names(),
                        if needed.is_empty() {
                            String::new()
                        } else {
                            format!(
                                ", or all of {} (ground.model = {:?})",
                                needed.join(", "),
                                format!("{:?}", self.ground.model).to_lowercase()
                            )
                        }
                    ),
                );
            }
            if derived {
                ensure(
                    mu0 > 0.0,
                    "snake.ground_friction",
                    fmt_a(&self.snake.ground_friction),
                    format!(
                        "ground.surfaces[{i}] scales the [ground] coefficients by its friction / \
                         snake.ground_friction[0], which must then be greater than 0 (or give the surface's \
                         {} explicitly)",
                        needed.join(", ")
                    ),
                )?;
            }
        }
        Ok(())
    }

    fn validate_safety(&self) -> Check {
        let s = &self.safety;
        non_negative("safety.max_kinetic_energy_j_per_kg", s.max_kinetic_energy_j_per_kg)?;
        ensure(s.check_every_n_steps >= 1, "safety.check_every_n_steps", s.check_every_n_steps, "must be at least 1")
    }

    fn validate_physics(&self) -> Check {
        let p = &self.physics;
        let key = "physics.contact_time_constant_secs";
        positive(key, p.contact_time_constant_secs)?;
        let min = 2.0 * self.general.timestep_secs;
        ensure(
            p.contact_time_constant_secs >= min,
            key,
            fmt_f(p.contact_time_constant_secs),
            format!(
                "must be at least 2 x general.timestep_secs = {} (MuJoCo's rule for stable contacts: the contact \
                 time constant must span at least two timesteps)",
                fmt_f(min)
            ),
        )?;
        positive("physics.contact_damping_ratio", p.contact_damping_ratio)?;
        non_negative("physics.contact_stiffness_per_s2", p.contact_stiffness_per_s2)?;
        non_negative("physics.contact_damping_per_s", p.contact_damping_per_s)?;
        let dt = self.general.timestep_secs;
        ensure(
            p.contact_stiffness_per_s2 * dt * dt <= 1.0,
            "physics.contact_stiffness_per_s2",
            fmt_f(p.contact_stiffness_per_s2),
            format!(
                "must be at most 1 / general.timestep_secs^2 = {} (the contact's natural frequency times the \
                 timestep must stay at most 1 for a stable, accurate contact)",
                fmt_f(1.0 / (dt * dt))
            ),
        )?;
        ensure(
            p.contact_damping_per_s == 0.0 || p.contact_stiffness_per_s2 > 0.0,
            "physics.contact_damping_per_s",
            fmt_f(p.contact_damping_per_s),
            "needs physics.contact_stiffness_per_s2 > 0 (direct contact stiffness and damping go together; with \
             stiffness 0 the contact uses contact_time_constant_secs and contact_damping_ratio)",
        )?;
        ensure(p.solver_iterations >= 1, "physics.solver_iterations", p.solver_iterations, "must be at least 1")?;
        ensure(
            p.solver_iterations <= MAX_SOLVER_ITERATIONS,
            "physics.solver_iterations",
            p.solver_iterations,
            format!("must be at most {MAX_SOLVER_ITERATIONS} (MuJoCo's default is 100)"),
        )?;
        self.validate_external_forces()
    }

    /// `[[physics.external_forces]]`: a link of the snake, a direction of non-zero length, finite
    /// non-negative times, ramp and force.
    fn validate_external_forces(&self) -> Check {
        let n = self.snake.n_links;
        for (i, f) in self.physics.external_forces.iter().enumerate() {
            let key = |k: &str| format!("physics.external_forces[{i}].{k}");
            ensure(f.link < n, &key("link"), f.link, format!("must be a link index from 0 (head) to {}", n - 1))?;
            all_finite(&key("direction"), &f.direction)?;
            let d = &f.direction;
            ensure(
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() > 1e-9,
                &key("direction"),
                fmt_a(d),
                "must not be zero (the force's direction in world coordinates, any length)",
            )?;
            non_negative(&key("start_secs"), f.start_secs)?;
            non_negative(&key("ramp_n_per_s"), f.ramp_n_per_s)?;
            non_negative(&key("force_n"), f.force_n)?;
            non_negative(&key("duration_secs"), f.duration_secs)?;
        }
        Ok(())
    }

    fn validate_snake(&self) -> Check {
        let s = &self.snake;
        ensure(s.n_links >= 1, "snake.n_links", s.n_links, "must be at least 1")?;
        ensure(s.n_links <= 200, "snake.n_links", s.n_links, "must be at most 200")?;
        positive("snake.link_length_m", s.link_length_m)?;
        positive("snake.link_radius_m", s.link_radius_m)?;
        ensure(
            self.legacy.geometry == LegacyGeometry::Faithful || s.link_length_m >= 2.0 * s.link_radius_m,
            "snake.link_length_m",
            fmt_f(s.link_length_m),
            format!(
                "must be at least the link diameter 2 x snake.link_radius_m = {}: the link length is the full \
                 capsule length (end caps included) between neighbouring joints, and it must not be shorter than the \
                 diameter or neighbouring links would overlap (equal to it gives spherical links; legacy.geometry = \
                 \"faithful\" allows overlapping links as the original tool had)",
                fmt_f(2.0 * s.link_radius_m)
            ),
        )?;
        ensure(
            s.link_radius_m >= MIN_LINK_RADIUS_M,
            "snake.link_radius_m",
            fmt_f(s.link_radius_m),
            format!("must be at least {MIN_LINK_RADIUS_M} m (MuJoCo rejects thinner links as massless)"),
        )?;
        positive("snake.link_mass_kg", s.link_mass_kg)?;
        let inertia = link_axial_inertia_kg_m2(s.link_mass_kg, s.link_radius_m, self.link_capsule_length_m());
        ensure(
            inertia >= MIN_LINK_INERTIA_KG_M2,
            "snake.link_mass_kg",
            fmt_f(s.link_mass_kg),
            format!(
                "gives a link (radius {} m, length {} m) a moment of inertia about its axis of {inertia:.3e} kg m^2; \
                 it must be at least {MIN_LINK_INERTIA_KG_M2:e} kg m^2 (MuJoCo rejects moving bodies below 1e-15): \
                 raise the mass or the radius",
                fmt_f(s.link_radius_m),
                fmt_f(s.link_length_m)
            ),
        )?;
        positive("snake.joint_range_deg", s.joint_range_deg)?;
        ensure(s.joint_range_deg <= 180.0, "snake.joint_range_deg", fmt_f(s.joint_range_deg), "must be at most 180")?;
        non_negative("snake.joint_damping_nm_s_per_rad", s.joint_damping_nm_s_per_rad)?;
        non_negative("snake.joint_armature_kg_m2", s.joint_armature_kg_m2)?;

        let key = "snake.torque_range_nm";
        let [min, max] = s.torque_range_nm;
        all_finite(key, &s.torque_range_nm)?;
        ensure(min < max, key, fmt_a(&s.torque_range_nm), "must be [min, max] with min < max")?;
        ensure(
            min <= 0.0 && max >= 0.0,
            key,
            fmt_a(&s.torque_range_nm),
            "must include 0 (min <= 0 <= max), so that the actuators can be idle",
        )?;

        // MuJoCo's control range of a torque motor is torque_range_nm / torque_gear.
        let gear = self.control.torque_gear;
        if gear > 0.0 {
            for end in s.torque_range_nm {
                let ctrl = end / gear;
                ensure(
                    end == 0.0 || (ctrl.is_finite() && ctrl.abs() >= f64::MIN_POSITIVE),
                    key,
                    fmt_a(&s.torque_range_nm),
                    format!(
                        "divided by control.torque_gear = {} gives the motors' control range, whose end {} is not a \
                         normal number MuJoCo can read; use a larger torque or a smaller gear",
                        fmt_f(gear),
                        fmt_f(ctrl)
                    ),
                )?;
            }
        }

        friction("snake.ground_friction", &s.ground_friction)?;
        friction("snake.link_friction", &s.link_friction)?;

        let key = "snake.color_rgba";
        all_finite(key, &s.color_rgba)?;
        for (name, c) in ["red", "green", "blue", "alpha"].into_iter().zip(&s.color_rgba) {
            ensure(
                (0.0..=1.0).contains(c),
                key,
                fmt_a(&s.color_rgba),
                format!("every component must be in 0..1; {name} is {}", fmt_f(*c)),
            )?;
            // MuJoCo stores colours in single precision.
            ensure(
                *c == 0.0 || *c >= f64::from(f32::MIN_POSITIVE),
                key,
                fmt_a(&s.color_rgba),
                format!(
                    "every component must be 0 or at least 1.1754944e-38 (MuJoCo stores colours in single precision); \
                     {name} is {}",
                    fmt_f(*c)
                ),
            )?;
        }
        all_finite("snake.head_position_m", &s.head_position_m)?;
        all_finite("snake.head_rotation_deg", &s.head_rotation_deg)
    }

    fn validate_initial_state(&self) -> Check {
        let i = &self.initial_state;
        let key = "initial_state.joint_angles_deg";
        let nj = self.snake.n_joints();
        at_most_list_len(key, &i.joint_angles_deg)?;
        all_finite(key, &i.joint_angles_deg)?;
        ensure(
            i.joint_angles_deg.is_empty() || i.joint_angles_deg.len() == nj,
            key,
            fmt_a(&i.joint_angles_deg),
            format!(
                "either [] (the gait's own start) or one angle per joint: snake.n_links = {} has {nj} joints, \
                 this list has {} values",
                self.snake.n_links,
                i.joint_angles_deg.len()
            ),
        )?;
        let limit = self.snake.joint_range_deg;
        if let Some((j, a)) = i.joint_angles_deg.iter().enumerate().find(|(_, a)| a.abs() > limit) {
            return fail(
                key,
                fmt_a(&i.joint_angles_deg),
                format!(
                    "every angle must be within the joint range +-{} deg (snake.joint_range_deg); joint_{:02} is {} deg",
                    fmt_f(limit),
                    j + 1,
                    fmt_f(*a)
                ),
            );
        }
        all_finite("initial_state.linear_velocity_m_per_s", &i.linear_velocity_m_per_s)?;
        all_finite("initial_state.angular_velocity_rad_per_s", &i.angular_velocity_rad_per_s)
    }

    fn validate_robot(&self) -> Check {
        all_finite("robot.position_m", &self.robot.position_m)?;
        all_finite("robot.rotation_deg", &self.robot.rotation_deg)
    }

    fn validate_sensors(&self) -> Check {
        for (kind, m) in self.sensors.models() {
            non_negative(&format!("sensors.{kind}.std"), m.std)?;
            finite(&format!("sensors.{kind}.bias"), m.bias)?;
            non_negative(&format!("sensors.{kind}.bias_random_walk_per_sqrt_s"), m.bias_random_walk_per_sqrt_s)?;
            non_negative(&format!("sensors.{kind}.resolution"), m.resolution)?;
            non_negative(&format!("sensors.{kind}.rate_hz"), m.rate_hz)?;
        }
        Ok(())
    }

    fn validate_control(&self) -> Check {
        let c = &self.control;
        positive("control.torque_gear", c.torque_gear)?;
        let gains = [
            ("control.position_kp_nm_per_rad", c.position_kp_nm_per_rad),
            ("control.position_kv_nm_s_per_rad", c.position_kv_nm_s_per_rad),
            ("control.velocity_kv_nm_s_per_rad", c.velocity_kv_nm_s_per_rad),
            ("control.intvelocity_kp_nm_per_rad", c.intvelocity_kp_nm_per_rad),
            ("control.pid_kp_nm_per_rad", c.pid_kp_nm_per_rad),
            ("control.pid_ki_nm_per_rad_s", c.pid_ki_nm_per_rad_s),
            ("control.pid_kd_nm_s_per_rad", c.pid_kd_nm_s_per_rad),
        ];
        for (key, v) in gains {
            non_negative(key, v)?;
        }
        Ok(())
    }

    fn validate_gait(&self) -> Check {
        let g = &self.gait;
        let range = self.snake.joint_range_deg;
        non_negative("gait.ramp_secs", g.ramp_secs)?;

        let w = &g.sine_wave;
        non_negative("gait.sine_wave.amplitude_deg", w.amplitude_deg)?;
        non_negative("gait.sine_wave.frequency_hz", w.frequency_hz)?;
        finite("gait.sine_wave.phase_lag_deg", w.phase_lag_deg)?;
        finite("gait.sine_wave.offset_deg", w.offset_deg)?;
        if g.kind == GaitKind::SineWave {
            ensure(
                w.amplitude_deg <= range,
                "gait.sine_wave.amplitude_deg",
                fmt_f(w.amplitude_deg),
                format!("must not exceed snake.joint_range_deg ({})", fmt_f(range)),
            )?;
            ensure(
                w.amplitude_deg + w.offset_deg.abs() <= range,
                "gait.sine_wave.offset_deg",
                fmt_f(w.offset_deg),
                format!(
                    "amplitude_deg + |offset_deg| = {} must not exceed snake.joint_range_deg ({})",
                    fmt_f(w.amplitude_deg + w.offset_deg.abs()),
                    fmt_f(range)
                ),
            )?;
        }

        let sp = &g.serpenoid;
        non_negative("gait.serpenoid.winding_angle_deg", sp.winding_angle_deg)?;
        positive("gait.serpenoid.n_waves", sp.n_waves)?;
        non_negative("gait.serpenoid.frequency_hz", sp.frequency_hz)?;
        finite("gait.serpenoid.offset_deg", sp.offset_deg)?;
        let sw = &g.sidewinding;
        non_negative("gait.sidewinding.yaw_amplitude_deg", sw.yaw_amplitude_deg)?;
        non_negative("gait.sidewinding.pitch_amplitude_deg", sw.pitch_amplitude_deg)?;
        non_negative("gait.sidewinding.frequency_hz", sw.frequency_hz)?;
        finite("gait.sidewinding.phase_lag_deg", sw.phase_lag_deg)?;
        finite("gait.sidewinding.pitch_phase_deg", sw.pitch_phase_deg)?;
        non_negative("gait.rolling.amplitude_deg", g.rolling.amplitude_deg)?;
        non_negative("gait.rolling.frequency_hz", g.rolling.frequency_hz)?;
        if matches!(g.kind, GaitKind::Sidewinding | GaitKind::Rolling) {
            ensure(
                self.snake.joint_axes == JointAxes::Alternating,
                "gait.kind",
                format!("{:?}", g.kind).to_lowercase(),
                "sidewinding and rolling need pitch joints: set snake.joint_axes = \"alternating\"",
            )?;
        }
        let peak = match g.kind {
            GaitKind::Serpenoid => Some((
                "gait.serpenoid.winding_angle_deg",
                2.0 * sp.winding_angle_deg
                    * (std::f64::consts::PI * sp.n_waves / self.snake.n_links.max(1) as f64).sin().abs()
                    + sp.offset_deg.abs(),
            )),
            GaitKind::Sidewinding => {
                Some(("gait.sidewinding.yaw_amplitude_deg", sw.yaw_amplitude_deg.max(sw.pitch_amplitude_deg)))
            }
            GaitKind::Rolling => Some(("gait.rolling.amplitude_deg", g.rolling.amplitude_deg)),
            _ => None,
        };
        if let Some((key, peak)) = peak {
            ensure(
                peak <= range,
                key,
                fmt_f(peak),
                format!("the largest joint angle of the gait must not exceed snake.joint_range_deg ({})", fmt_f(range)),
            )?;
        }

        let f = &g.form_closure;
        let key = "gait.form_closure.pattern_deg";
        ensure(!f.pattern_deg.is_empty(), key, "[]", "must list at least one joint angle")?;
        at_most_list_len(key, &f.pattern_deg)?;
        all_finite(key, &f.pattern_deg)?;
        if g.kind == GaitKind::FormClosure || self.terrain.kind == TerrainKind::FormClosure {
            for (i, a) in f.pattern_deg.iter().enumerate() {
                ensure(
                    a.abs() < range,
                    key,
                    fmt_a(&f.pattern_deg),
                    format!(
                        "every |angle| must be less than snake.joint_range_deg ({}); element {} is {}",
                        fmt_f(range),
                        i + 1,
                        fmt_f(*a)
                    ),
                )?;
            }
        }
        positive("gait.form_closure.shift_period_secs", f.shift_period_secs)
    }

    fn validate_terrain(&self) -> Check {
        let t = &self.terrain;
        friction("terrain.obstacle_friction", &t.obstacle_friction)?;
        positive("terrain.cylinder_height_m", t.cylinder_height_m)?;
        positive("terrain.floor_size_m", t.floor_size_m)?;

        positive("terrain.two_cylinders.distance_m", t.two_cylinders.distance_m)?;
        positive("terrain.two_cylinders.radius_m", t.two_cylinders.radius_m)?;

        let r = &t.random_cylinders;
        let key = "terrain.random_cylinders.radius_range_m";
        all_finite(key, &r.radius_range_m)?;
        ensure(r.radius_range_m[0] > 0.0, key, fmt_a(&r.radius_range_m), "the smallest radius must be greater than 0")?;
        ensure(
            r.radius_range_m[0] <= r.radius_range_m[1],
            key,
            fmt_a(&r.radius_range_m),
            "must be [min, max] with min <= max",
        )?;
        positive("terrain.random_cylinders.half_size_m", r.half_size_m)?;
        non_negative("terrain.random_cylinders.min_gap_m", r.min_gap_m)?;

        let p = &t.cylinder_path;
        ensure(p.n_pairs >= 1, "terrain.cylinder_path.n_pairs", p.n_pairs, "must be at least 1")?;
        positive("terrain.cylinder_path.spacing_m", p.spacing_m)?;
        positive("terrain.cylinder_path.radius_m", p.radius_m)?;
        positive("terrain.cylinder_path.width_m", p.width_m)?;
        ensure(
            p.width_m > 2.0 * p.radius_m,
            "terrain.cylinder_path.width_m",
            fmt_f(p.width_m),
            format!(
                "must be greater than 2 x terrain.cylinder_path.radius_m = {} so that the two rows of pegs do not \
                 touch",
                fmt_f(2.0 * p.radius_m)
            ),
        )?;
        finite("terrain.cylinder_path.start_m", p.start_m)?;
        if t.kind == TerrainKind::CylinderPath {
            let needed = 2.0 * self.snake.link_radius_m + 2.0 * p.radius_m;
            ensure(
                p.width_m > needed,
                "terrain.cylinder_path.width_m",
                fmt_f(p.width_m),
                format!(
                    "must be greater than 2 x snake.link_radius_m + 2 x terrain.cylinder_path.radius_m = {} so that \
                     the snake fits between the rows",
                    fmt_f(needed)
                ),
            )?;
        }

        let f = &t.form_closure;
        ensure(matches!(f.order, 1 | 2), "terrain.form_closure.order", f.order, "must be 1 or 2")?;
        positive("terrain.form_closure.radius_m", f.radius_m)?;
        self.validate_terrain_features()
    }

    /// Walls, mesh obstacles, peg board, channel, slope, heightfield, mesh terrain. Files are
    /// checked (exist, parse) by model generation.
    fn validate_terrain_features(&self) -> Check {
        let t = &self.terrain;
        for (i, w) in t.walls.iter().enumerate() {
            let key = |k: &str| format!("terrain.walls[{i}].{k}");
            all_finite(&key("start_m"), &w.start_m)?;
            all_finite(&key("end_m"), &w.end_m)?;
            let len = (w.end_m[0] - w.start_m[0]).hypot(w.end_m[1] - w.start_m[1]);
            ensure(
                len > 1e-6,
                &key("end_m"),
                fmt_a(&w.end_m),
                format!("must differ from start_m {} (a wall needs a length)", fmt_a(&w.start_m)),
            )?;
            positive(&key("height_m"), w.height_m)?;
            positive(&key("thickness_m"), w.thickness_m)?;
        }
        for (i, m) in t.mesh_obstacles.iter().enumerate() {
            let key = |k: &str| format!("terrain.mesh_obstacles[{i}].{k}");
            ensure(
                !m.file.trim().is_empty(),
                &key("file"),
                "\"\"",
                "must name an STL or OBJ file (remove the entry to have no mesh obstacle)",
            )?;
            all_finite(&key("position_m"), &m.position_m)?;
            all_finite(&key("rotation_deg"), &m.rotation_deg)?;
            positive(&key("scale"), m.scale)?;
        }

        let p = &t.pegboard;
        positive("terrain.pegboard.peg_radius_m", p.peg_radius_m)?;
        positive("terrain.pegboard.peg_height_m", p.peg_height_m)?;
        positive("terrain.pegboard.spacing_m", p.spacing_m)?;
        ensure(
            p.spacing_m > 2.0 * p.peg_radius_m,
            "terrain.pegboard.spacing_m",
            fmt_f(p.spacing_m),
            format!(
                "must be greater than 2 x terrain.pegboard.peg_radius_m = {} so that neighbouring pegs do not touch",
                fmt_f(2.0 * p.peg_radius_m)
            ),
        )?;
        all_finite("terrain.pegboard.region_min_m", &p.region_min_m)?;
        all_finite("terrain.pegboard.region_max_m", &p.region_max_m)?;
        for (axis, k) in ["x", "y"].into_iter().zip(0..2) {
            ensure(
                p.region_max_m[k] >= p.region_min_m[k],
                "terrain.pegboard.region_max_m",
                fmt_a(&p.region_max_m),
                format!(
                    "must be at least terrain.pegboard.region_min_m {} in every axis; {axis} is smaller",
                    fmt_a(&p.region_min_m)
                ),
            )?;
        }
        ensure(
            p.count <= super::MAX_OBSTACLES,
            "terrain.pegboard.count",
            p.count,
            format!("must be at most {}", super::MAX_OBSTACLES),
        )?;

        let c = &t.channel;
        all_finite("terrain.channel.start_m", &c.start_m)?;
        all_finite("terrain.channel.end_m", &c.end_m)?;
        positive("terrain.channel.width_m", c.width_m)?;
        positive("terrain.channel.height_m", c.height_m)?;
        positive("terrain.channel.thickness_m", c.thickness_m)?;
        if c.enabled {
            let len = (c.end_m[0] - c.start_m[0]).hypot(c.end_m[1] - c.start_m[1]);
            ensure(
                len > 1e-6,
                "terrain.channel.end_m",
                fmt_a(&c.end_m),
                format!("must differ from terrain.channel.start_m {} (a channel needs a length)", fmt_a(&c.start_m)),
            )?;
            let needed = 2.0 * self.snake.link_radius_m;
            ensure(
                c.width_m > needed,
                "terrain.channel.width_m",
                fmt_f(c.width_m),
                format!("must be greater than the snake's diameter 2 x snake.link_radius_m = {}", fmt_f(needed)),
            )?;
        }

        let sl = &t.slope;
        finite("terrain.slope.angle_deg", sl.angle_deg)?;
        ensure(
            (0.0..90.0).contains(&sl.angle_deg),
            "terrain.slope.angle_deg",
            fmt_f(sl.angle_deg),
            "must be at least 0 (0 = no slope) and less than 90",
        )?;
        all_finite("terrain.slope.start_m", &sl.start_m)?;
        finite("terrain.slope.direction_deg", sl.direction_deg)?;
        positive("terrain.slope.length_m", sl.length_m)?;
        positive("terrain.slope.width_m", sl.width_m)?;

        let h = &t.heightfield;
        all_finite("terrain.heightfield.center_m", &h.center_m)?;
        positive("terrain.heightfield.size_x_m", h.size_x_m)?;
        positive("terrain.heightfield.size_y_m", h.size_y_m)?;
        positive("terrain.heightfield.height_m", h.height_m)?;
        positive("terrain.heightfield.base_m", h.base_m)?;

        let m = &t.mesh_terrain;
        all_finite("terrain.mesh_terrain.position_m", &m.position_m)?;
        positive("terrain.mesh_terrain.scale", m.scale)?;
        positive("terrain.mesh_terrain.resolution_m", m.resolution_m)?;
        positive("terrain.mesh_terrain.base_m", m.base_m)
    }

    fn validate_recording(&self) -> Check {
        let r = &self.recording;
        ensure(r.every_n_steps >= 1, "recording.every_n_steps", r.every_n_steps, "must be at least 1")?;
        ensure(
            r.parquet_row_group_rows >= 1,
            "recording.parquet_row_group_rows",
            r.parquet_row_group_rows,
            "must be at least 1",
        )?;
        ensure(
            r.parquet_rows_per_file >= 1,
            "recording.parquet_rows_per_file",
            r.parquet_rows_per_file,
            "must be at least 1",
        )?;
        if r.format.parquet() && !cfg!(feature = "parquet") {
            fail(
                "recording.format",
                r.format.to_string(),
                "this build of SimSerpent has no Parquet support (cargo feature `parquet` is off); \
                 use \"csv\" or rebuild with `--features parquet`",
            )?;
        }
        if r.enabled {
            // u64 -> f64 is exact up to 2^53; beyond that the interval is astronomically long anyway.
            let interval = r.every_n_steps as f64 * self.general.timestep_secs;
            ensure(
                interval <= self.general.duration_secs,
                "recording.every_n_steps",
                r.every_n_steps,
                format!(
                    "the record interval every_n_steps x general.timestep_secs = {} s must not be longer than \
                     general.duration_secs ({} s)",
                    fmt_f(interval),
                    fmt_f(self.general.duration_secs)
                ),
            )?;
        }
        Ok(())
    }

    /// `[plot]`, `[render]`, `[video]`.
    fn validate_pictures(&self) -> Check {
        let p = &self.plot;
        for (key, v) in [("plot.width_px", p.width_px), ("plot.height_px", p.height_px)] {
            ensure((200..=8000).contains(&v), key, v, "must be between 200 and 8000 pixels")?;
        }
        let r = &self.render;
        for (key, v) in [("render.width_px", r.width_px), ("render.height_px", r.height_px)] {
            ensure((16..=4096).contains(&v), key, v, "must be between 16 and 4096 pixels")?;
        }
        positive("render.camera_distance_m", r.camera_distance_m)?;
        finite("render.camera_azimuth_deg", r.camera_azimuth_deg)?;
        let e = r.camera_elevation_deg;
        finite("render.camera_elevation_deg", e)?;
        ensure((-90.0..=90.0).contains(&e), "render.camera_elevation_deg", fmt_f(e), "must be between -90 and 90")?;
        all_finite("render.fixed_lookat_m", &r.fixed_lookat_m)?;
        let d = self.general.duration_secs;
        at_most_list_len("render.image_times_secs", &r.image_times_secs)?;
        for t in &r.image_times_secs {
            ensure(
                t.is_finite() && (0.0..=d).contains(t),
                "render.image_times_secs",
                fmt_a(&r.image_times_secs),
                format!("every time must be between 0 and general.duration_secs ({}); {} is not", fmt_f(d), fmt_f(*t)),
            )?;
        }
        ensure(
            r.image_times_secs.is_empty() || !r.image_cameras.is_empty(),
            "render.image_cameras",
            "[]",
            "must name at least one camera (\"follow\", \"top\", \"fixed\") when render.image_times_secs is not empty",
        )?;
        let v = &self.video;
        positive("video.frames_per_sec", v.frames_per_sec)?;
        ensure(v.frames_per_sec <= 240.0, "video.frames_per_sec", fmt_f(v.frames_per_sec), "must be at most 240")?;
        positive("video.playback_speed", v.playback_speed)?;
        ensure(v.playback_speed <= 100.0, "video.playback_speed", fmt_f(v.playback_speed), "must be at most 100")
    }

    /// `[env]`: ranges only. The rule that ties it to `[general]` (a whole number of timesteps
    /// per action) is checked by [`Config::validate_env_use`] when an environment is built.
    fn validate_env(&self) -> Check {
        let e = &self.env;
        ensure(
            OBSERVATION_VERSIONS.contains(&e.observation_version),
            "env.observation_version",
            e.observation_version,
            format!(
                "unknown observation layout; this build knows version{} {}",
                if OBSERVATION_VERSIONS.len() > 1 { "s" } else { "" },
                OBSERVATION_VERSIONS.map(|v| v.to_string()).join(", ")
            ),
        )?;
        positive("env.control_period_secs", e.control_period_secs)?;
        positive("env.max_episode_secs", e.max_episode_secs)?;
        finite("env.reward_forward_weight", e.reward_forward_weight)?;
        non_negative("env.reward_energy_weight", e.reward_energy_weight)?;
        non_negative("env.reward_contact_force_weight", e.reward_contact_force_weight)?;
        non_negative("env.terminate_contact_force_n", e.terminate_contact_force_n)?;
        non_negative("env.reward_ctrl_cost_weight", e.reward_ctrl_cost_weight)?;
        non_negative("env.reset_noise_scale", e.reset_noise_scale)?;
        non_negative("env.reset_heading_noise_rad", e.reset_heading_noise_rad)?;
        ensure(
            e.reset_heading_noise_rad <= std::f64::consts::PI,
            "env.reset_heading_noise_rad",
            fmt_f(e.reset_heading_noise_rad),
            "at most pi (a uniform heading in ±pi is every heading)",
        )
    }

    /// The `[env]` rules that involve other sections, checked when an environment is built
    /// (a config used only for `simserpent run` need not satisfy them).
    ///
    /// # Errors
    /// [`ConfigError::InvalidValue`] naming the `env` key.
    pub fn validate_env_use(&self) -> Result<(), ConfigError> {
        let e = &self.env;
        let dt = self.general.timestep_secs;
        let ratio = e.control_period_secs / dt;
        let n = ratio.round();
        ensure(
            n >= 1.0 && (ratio - n).abs() <= 1e-6 * n.max(1.0),
            "env.control_period_secs",
            fmt_f(e.control_period_secs),
            format!(
                "must be a whole number (at least 1) of general.timestep_secs = {}; it is {} timesteps",
                fmt_f(dt),
                fmt_f(ratio)
            ),
        )?;
        ensure(
            e.max_episode_secs >= e.control_period_secs,
            "env.max_episode_secs",
            fmt_f(e.max_episode_secs),
            format!("must be at least env.control_period_secs ({})", fmt_f(e.control_period_secs)),
        )?;
        ensure(
            !e.observe_contact_estimates || self.estimation.enabled,
            "env.observe_contact_estimates",
            "true",
            "needs estimation.enabled = true (the contact estimator that produces the estimates)",
        )
    }
}
