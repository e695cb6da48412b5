//! Conversion of the original tool's `config.json` (thesis appendix 12.1) into SimSerpent's
//! layout.
//!
//! The result is a partial [`toml::Table`] in the new layout; it then goes through the same
//! key check, merge, overrides and validation as a TOML file. Every legacy key is optional:
//! a missing key keeps SimSerpent's default. Unknown legacy keys are rejected, with a
//! did-you-mean among the legacy keys and the key path in legacy naming
//! (`snake_specifications.nr_of_link`).
//!
//! | legacy key (config.json)                      | SimSerpent key                                   |
//! |-----------------------------------------------|--------------------------------------------------|
//! | `xml_path`                                    | accepted and ignored (the model is generated)    |
//! | `simulation_time`                             | `general.duration_secs`                          |
//! | `simulation_timestep`                         | `general.timestep_secs`                          |
//! | `integrator_type`                             | `general.integrator`                             |
//! | `plot_data`                                   | `general.plot`                                   |
//! | `visual_options.show_contact_force`           | `visual.show_contact_forces`                     |
//! | `visual_options.<other>`                      | `visual.<other>` (same name)                     |
//! | `snake_specifications.nr_of_links`            | `snake.n_links`                                  |
//! | `snake_specifications.link_mass_in_kg`        | `snake.link_mass_kg`                             |
//! | `snake_specifications.link_lenght_in_m` (sic) | `snake.link_length_m` = **2 ×** value (the original used it as the capsule's half length; links were 2× that apart) |
//! | `snake_specifications.link_radius_in_m`       | `snake.link_radius_m`                            |
//! | `snake_specifications.maximum_torque_in_nm`   | `snake.torque_range_nm` (`[min, max]`; a single number `m` means `[-m, m]`) |
//! | `snake_specifications.friction`               | sliding coefficient of `snake.ground_friction`, `snake.link_friction` and `terrain.obstacle_friction` (torsional and rolling keep their defaults) |
//! | (always)                                      | `ground.model = "isotropic"`: the original tool had only isotropic friction |
//! | `snake_specifications.joint_damping`          | `snake.joint_damping_nm_s_per_rad`               |
//! | `snake_specifications.joint_armature`         | `snake.joint_armature_kg_m2`                     |
//! | `snake_specifications.sensor_noise`           | `sensors.noise_enabled` (`"enable"` / `"disable"`, any case; `true` / `false` also accepted) |
//! | `snake_specifications.sensor_noise_amount`    | every `sensors.<kind>.std` value                 |
//! | `snake_specifications.snake_color_rgb`        | `snake.color_rgba` (it holds RGBA; three values get alpha 1) |
//! | `snake_specifications.head_position_xyz`      | `snake.head_position_m` (same meaning: the original floor was at z = −radius, z = 0 lies on the floor) |
//! | `snake_specifications.head_rotation_xyz`      | `snake.head_rotation_deg`                        |
//! | `control_parameters.control_method`           | `control.method` (any case: `position`, `torque`, `velocity`, `IntVelocity`) |
//! | `control_parameters.torque_actuator_KP`       | `control.torque_gear`                            |
//! | `control_parameters.position_actuator_KP`     | `control.position_kp_nm_per_rad`                 |
//! | `control_parameters.velocity_actuator_KP`     | `control.velocity_kv_nm_s_per_rad`               |
//! | `control_parameters.IntVelocity_actuator_KP`  | `control.intvelocity_kp_nm_per_rad`              |
//! | `control_parameters.PID_parameters_Kp_Ki_Kd`  | `control.pid_kp_nm_per_rad`, `control.pid_ki_nm_per_rad_s`, `control.pid_kd_nm_s_per_rad` |
//! | `terrain.generate_two_cylinders`              | `terrain.kind = "two_cylinders"`                 |
//! | `terrain.generate_random_cylinders`           | `terrain.kind = "random_cylinders"`              |
//! | `terrain.generate_cylinder_path`              | `terrain.kind = "cylinder_path"`; at most one `generate_*` may be true, none true gives `terrain.kind = "none"` |
//! | `prebuilt_experiments.do_sinus`               | `gait.kind = "sine_wave"`                        |
//! | `prebuilt_experiments.form_closure`           | `gait.kind = "form_closure"` and `terrain.kind = "form_closure"` (cannot be combined with a `generate_*` terrain); both true is an error, neither gives `gait.kind = "none"` |
//! | `store_data_to_csv.store_data`                | `recording.enabled`                              |
//! | `store_data_to_csv.position`                  | `recording.link_position`                        |
//! | `store_data_to_csv.velocity`                  | `recording.link_velocity`                        |
//! | `store_data_to_csv.accel`                     | `recording.link_acceleration`                    |
//! | `store_data_to_csv.angle`                     | `recording.link_orientation`                     |
//! | `store_data_to_csv.angular_vel`               | `recording.link_angular_velocity`                |
//! | `store_data_to_csv.angular_accel`             | `recording.link_angular_acceleration`            |
//! | `store_data_to_csv.torque_actuator_forces`    | `recording.torque_actuator_forces`               |
//! | `store_data_to_csv.position_actuator_forces`  | `recording.position_actuator_forces`             |
//! | `store_data_to_csv.velocity_actuator_forces`  | `recording.velocity_actuator_forces`             |
//! | `store_data_to_csv.joint_angles`              | `recording.joint_angles`                         |
//! | `store_data_to_csv.external_contact_forces`   | `recording.external_contact_forces`              |
//!
//! The terrain and experiment rules apply only when the section has at least one of its keys;
//! an absent section keeps the defaults. Recording tables the original tool did not have
//! (joint velocities, IMU sensors, contacts, ...) keep their defaults.

use super::ConfigError;
use super::load::{join, lookup, suggest};
use serde_json::{Map, Value as Json};
use toml::{Table, Value};

/// Top-level legacy keys that are single values.
const TOP_VALUES: [&str; 5] = ["xml_path", "simulation_time", "simulation_timestep", "integrator_type", "plot_data"];

/// Legacy sections and their keys, in the order of the thesis listing.
const SECTIONS: &[(&str, &[&str])] = &[
    (
        "visual_options",
        &[
            "show_contact_force",
            "show_contact_points",
            "show_actuators",
            "show_joints",
            "show_center_of_mass",
            "make_transparent",
        ],
    ),
    (
        "snake_specifications",
        &[
            "nr_of_links",
            "link_mass_in_kg",
            "link_lenght_in_m",
            "link_radius_in_m",
            "maximum_torque_in_nm",
            "friction",
            "joint_damping",
            "joint_armature",
            "sensor_noise",
            "sensor_noise_amount",
            "snake_color_rgb",
            "head_position_xyz",
            "head_rotation_xyz",
        ],
    ),
    (
        "control_parameters",
        &[
            "control_method",
            "torque_actuator_KP",
            "position_actuator_KP",
            "velocity_actuator_KP",
            "IntVelocity_actuator_KP",
            "PID_parameters_Kp_Ki_Kd",
        ],
    ),
    ("terrain", &["generate_two_cylinders", "generate_random_cylinders", "generate_cylinder_path"]),
    ("prebuilt_experiments", &["form_closure", "do_sinus"]),
    (
        "store_data_to_csv",
        &[
            "store_data",
            "position",
            "velocity",
            "accel",
            "angle",
            "angular_vel",
            "angular_accel",
            "torque_actuator_forces",
            "position_actuator_forces",
            "velocity_actuator_forces",
            "joint_angles",
            "external_contact_forces",
        ],
    ),
];

/// `terrain.generate_*` keys and the terrain kind each selects.
const TERRAIN_KINDS: [(&str, &str); 3] = [
    ("generate_two_cylinders", "two_cylinders"),
    ("generate_random_cylinders", "random_cylinders"),
    ("generate_cylinder_path", "cylinder_path"),
];

/// `store_data_to_csv` keys and the `[recording]` keys they set.
const RECORDING: [(&str, &str); 12] = [
    ("store_data", "enabled"),
    ("position", "link_position"),
    ("velocity", "link_velocity"),
    ("accel", "link_acceleration"),
    ("angle", "link_orientation"),
    ("angular_vel", "link_angular_velocity"),
    ("angular_accel", "link_angular_acceleration"),
    ("torque_actuator_forces", "torque_actuator_forces"),
    ("position_actuator_forces", "position_actuator_forces"),
    ("velocity_actuator_forces", "velocity_actuator_forces"),
    ("joint_angles", "joint_angles"),
    ("external_contact_forces", "external_contact_forces"),
];

/// Converts a parsed legacy `config.json` into a partial table in SimSerpent's layout.
///
/// `defaults` is the embedded default config (for the friction coefficients the original
/// tool did not have and for the list of sensor noise keys).
pub(super) fn convert(json: &Json, defaults: &Table) -> Result<Table, ConfigError> {
    let Json::Object(root) = json else {
        return Err(ConfigError::invalid(
            "(top level)",
            kind_of(json),
            "the original tool's config.json must be a JSON object `{ ... }`",
        ));
    };
    check_keys(root)?;
    let mut out = Table::new();
    // The original tool knew only isotropic Coulomb friction with the floor.
    set(&mut out, "ground.model", Value::String("isotropic".into()));

    // Top level.
    if let Some(v) = root.get("simulation_time") {
        set(&mut out, "general.duration_secs", to_toml("simulation_time", v)?);
    }
    if let Some(v) = root.get("simulation_timestep") {
        set(&mut out, "general.timestep_secs", to_toml("simulation_timestep", v)?);
    }
    if let Some(v) = root.get("integrator_type") {
        set(&mut out, "general.integrator", to_toml("integrator_type", v)?);
    }
    if let Some(v) = root.get("plot_data") {
        set(&mut out, "general.plot", to_toml("plot_data", v)?);
    }

    // visual_options: 1:1.
    if let Some(section) = section(root, "visual_options") {
        for (key, v) in section {
            let new_key = if key == "show_contact_force" { "show_contact_forces" } else { key.as_str() };
            set(&mut out, &format!("visual.{new_key}"), to_toml(&format!("visual_options.{key}"), v)?);
        }
    }

    // snake_specifications.
    if let Some(section) = section(root, "snake_specifications") {
        convert_snake(section, defaults, &mut out)?;
    }

    // control_parameters.
    if let Some(section) = section(root, "control_parameters") {
        convert_control(section, &mut out)?;
    }

    // terrain and prebuilt_experiments.
    convert_terrain_and_experiments(root, &mut out)?;

    // store_data_to_csv.
    if let Some(section) = section(root, "store_data_to_csv") {
        for (legacy_key, new_key) in RECORDING {
            if let Some(v) = section.get(legacy_key) {
                let key = format!("store_data_to_csv.{legacy_key}");
                set(&mut out, &format!("recording.{new_key}"), Value::Boolean(boolean(&key, v)?));
            }
        }
    }
    Ok(out)
}

/// Rejects unknown legacy keys and sections that are not objects.
/// A `config.json` parse error as a [`ConfigError`]: a number out of range (`1e999`) names its
/// key path besides the line and column; other errors are [`ConfigError::Syntax`].
pub(super) fn json_error(file: &str, text: &str, e: &serde_json::Error) -> ConfigError {
    let message = e.to_string();
    let syntax = || ConfigError::Syntax { file: file.to_string(), message: message.trim_end().to_string() };
    if !message.starts_with("number out of range") {
        return syntax();
    }
    let Some(at) = byte_offset(text, e.line(), e.column()) else { return syntax() };
    // The number token around the reported position.
    let is_num = |b: u8| b.is_ascii_digit() || matches!(b, b'e' | b'E' | b'+' | b'-' | b'.');
    let bytes = text.as_bytes();
    let mut start = at.min(bytes.len());
    while start > 0 && is_num(bytes[start - 1]) {
        start -= 1;
    }
    let mut end = at.min(bytes.len());
    while end < bytes.len() && is_num(bytes[end]) {
        end += 1;
    }
    if start == end {
        return syntax();
    }
    const MARK: &str = "\u{1}simserpent-out-of-range\u{1}";
    let patched = format!("{}{}{}", &text[..start], serde_json::to_string(MARK).unwrap_or_default(), &text[end..]);
    let Ok(value) = serde_json::from_str::<Json>(&patched) else { return syntax() };
    fn find(v: &Json, prefix: &str) -> Option<String> {
        match v {
            Json::String(s) if s == MARK => Some(prefix.to_string()),
            Json::Object(map) => map.iter().find_map(|(k, v)| find(v, &join(prefix, k))),
            Json::Array(items) => items.iter().enumerate().find_map(|(i, v)| find(v, &format!("{prefix}[{i}]"))),
            _ => None,
        }
    }
    match find(&value, "") {
        Some(key) => ConfigError::invalid(
            &key,
            &text[start..end],
            format!(
                "the number is out of range at line {}, column {} (a number must be finite: at most about 1.8e308 in \
                 magnitude)",
                e.line(),
                e.column()
            ),
        ),
        None => syntax(),
    }
}

/// The byte offset of 1-based `line` and `column` (serde_json counts columns in bytes).
fn byte_offset(text: &str, line: usize, column: usize) -> Option<usize> {
    let mut offset = 0;
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i + 1 == line {
            return Some(offset + column.saturating_sub(1).min(l.len()));
        }
        offset += l.len();
    }
    None
}

fn check_keys(root: &Map<String, Json>) -> Result<(), ConfigError> {
    let top: Vec<&str> = TOP_VALUES.iter().copied().chain(SECTIONS.iter().map(|(name, _)| *name)).collect();
    for (key, value) in root {
        if let Some((name, keys)) = SECTIONS.iter().find(|(name, _)| name == key) {
            let Json::Object(section) = value else {
                return Err(ConfigError::invalid(
                    name,
                    value,
                    format!("`{name}` must be an object with keys: {}", keys.join(", ")),
                ));
            };
            for sub in section.keys() {
                if !keys.contains(&sub.as_str()) {
                    return Err(ConfigError::UnknownKey {
                        key: join(name, sub),
                        suggestion: suggest(sub, keys).map(|s| join(name, s)),
                        allowed: keys.join(", "),
                    });
                }
            }
        } else if !TOP_VALUES.contains(&key.as_str()) {
            return Err(ConfigError::UnknownKey {
                key: key.clone(),
                suggestion: suggest(key, &top).map(str::to_string),
                allowed: top.join(", "),
            });
        } else if value.is_object() {
            return Err(ConfigError::invalid(key, value, "expected a single value, not an object"));
        }
    }
    Ok(())
}

fn convert_snake(section: &Map<String, Json>, defaults: &Table, out: &mut Table) -> Result<(), ConfigError> {
    const DIRECT: [(&str, &str); 7] = [
        ("nr_of_links", "snake.n_links"),
        ("link_mass_in_kg", "snake.link_mass_kg"),
        ("link_radius_in_m", "snake.link_radius_m"),
        ("joint_damping", "snake.joint_damping_nm_s_per_rad"),
        ("joint_armature", "snake.joint_armature_kg_m2"),
        ("head_position_xyz", "snake.head_position_m"),
        ("head_rotation_xyz", "snake.head_rotation_deg"),
    ];
    for (legacy_key, new_key) in DIRECT {
        if let Some(v) = section.get(legacy_key) {
            set(out, new_key, to_toml(&format!("snake_specifications.{legacy_key}"), v)?);
        }
    }
    if let Some(v) = section.get("link_lenght_in_m") {
        let half = number("snake_specifications.link_lenght_in_m", v)?;
        set(out, "snake.link_length_m", Value::Float(2.0 * half));
    }
    if let Some(v) = section.get("maximum_torque_in_nm") {
        let key = "snake_specifications.maximum_torque_in_nm";
        let range = match v {
            Json::Number(_) => {
                let m = number(key, v)?.abs();
                Value::Array(vec![Value::Float(-m), Value::Float(m)])
            }
            _ => to_toml(key, v)?,
        };
        set(out, "snake.torque_range_nm", range);
    }
    if let Some(v) = section.get("friction") {
        let sliding = number("snake_specifications.friction", v)?;
        for key in ["snake.ground_friction", "snake.link_friction", "terrain.obstacle_friction"] {
            let mut triple = match lookup(defaults, key) {
                Some(Value::Array(a)) => a.clone(),
                _ => Vec::new(),
            };
            match triple.first_mut() {
                Some(first) => *first = Value::Float(sliding),
                None => triple.push(Value::Float(sliding)),
            }
            set(out, key, Value::Array(triple));
        }
    }
    if let Some(v) = section.get("sensor_noise") {
        let key = "snake_specifications.sensor_noise";
        let enabled = match v {
            Json::Bool(b) => *b,
            Json::String(s) if s.eq_ignore_ascii_case("enable") => true,
            Json::String(s) if s.eq_ignore_ascii_case("disable") => false,
            _ => {
                return Err(ConfigError::invalid(key, v, "expected \"enable\" or \"disable\""));
            }
        };
        set(out, "sensors.noise_enabled", Value::Boolean(enabled));
    }
    if let Some(v) = section.get("sensor_noise_amount") {
        let amount = number("snake_specifications.sensor_noise_amount", v)?;
        if let Some(Value::Table(sensors)) = defaults.get("sensors") {
            // Every sensor kind's table (`[sensors.<kind>]`) gets the amount as its std.
            for (kind, _) in sensors.iter().filter(|(_, v)| v.is_table()) {
                set(out, &format!("sensors.{kind}.std"), Value::Float(amount));
            }
        }
    }
    if let Some(v) = section.get("snake_color_rgb") {
        let key = "snake_specifications.snake_color_rgb";
        let mut color = to_toml(key, v)?;
        if let Value::Array(items) = &mut color
            && items.len() == 3
        {
            items.push(Value::Float(1.0));
        }
        set(out, "snake.color_rgba", color);
    }
    Ok(())
}

fn convert_control(section: &Map<String, Json>, out: &mut Table) -> Result<(), ConfigError> {
    const DIRECT: [(&str, &str); 4] = [
        ("torque_actuator_KP", "control.torque_gear"),
        ("position_actuator_KP", "control.position_kp_nm_per_rad"),
        ("velocity_actuator_KP", "control.velocity_kv_nm_s_per_rad"),
        ("IntVelocity_actuator_KP", "control.intvelocity_kp_nm_per_rad"),
    ];
    if let Some(v) = section.get("control_method") {
        let key = "control_parameters.control_method";
        let allowed = "expected one of \"position\", \"torque\", \"velocity\", \"IntVelocity\" (any case)";
        let Json::String(s) = v else {
            return Err(ConfigError::invalid(key, v, allowed));
        };
        let method = match s.to_ascii_lowercase().as_str() {
            "position" => "position",
            "torque" => "torque",
            "velocity" => "velocity",
            "intvelocity" => "intvelocity",
            _ => return Err(ConfigError::invalid(key, v, allowed)),
        };
        set(out, "control.method", Value::String(method.into()));
    }
    for (legacy_key, new_key) in DIRECT {
        if let Some(v) = section.get(legacy_key) {
            set(out, new_key, to_toml(&format!("control_parameters.{legacy_key}"), v)?);
        }
    }
    if let Some(v) = section.get("PID_parameters_Kp_Ki_Kd") {
        let key = "control_parameters.PID_parameters_Kp_Ki_Kd";
        let allowed = "expected a list of three numbers [Kp, Ki, Kd]";
        let Json::Array(items) = v else {
            return Err(ConfigError::invalid(key, v, allowed));
        };
        if items.len() != 3 {
            return Err(ConfigError::invalid(key, v, allowed));
        }
        let names = ["control.pid_kp_nm_per_rad", "control.pid_ki_nm_per_rad_s", "control.pid_kd_nm_s_per_rad"];
        for (name, item) in names.into_iter().zip(items) {
            let gain = item.as_f64().ok_or_else(|| ConfigError::invalid(key, v, allowed))?;
            set(out, name, Value::Float(gain));
        }
    }
    Ok(())
}

fn convert_terrain_and_experiments(root: &Map<String, Json>, out: &mut Table) -> Result<(), ConfigError> {
    // terrain: at most one generator.
    let mut terrain: Option<(String, &str)> = None; // (legacy key that chose it, kind)
    if let Some(section) = section(root, "terrain") {
        let mut chosen: Option<String> = None;
        for (legacy_key, kind) in TERRAIN_KINDS {
            let Some(v) = section.get(legacy_key) else {
                continue;
            };
            let key = format!("terrain.{legacy_key}");
            if boolean(&key, v)? {
                if let Some(first) = &chosen {
                    return Err(ConfigError::invalid(
                        &key,
                        "true",
                        format!("at most one terrain generator may be true, but `{first}` is true as well"),
                    ));
                }
                terrain = Some((key.clone(), kind));
                chosen = Some(key);
            }
        }
        if terrain.is_none() && !section.is_empty() {
            terrain = Some((String::new(), "none"));
        }
    }

    // prebuilt_experiments: at most one.
    if let Some(section) = section(root, "prebuilt_experiments") {
        let key_fc = "prebuilt_experiments.form_closure";
        let key_sin = "prebuilt_experiments.do_sinus";
        let form_closure = section.get("form_closure").map(|v| boolean(key_fc, v)).transpose()?.unwrap_or(false);
        let do_sinus = section.get("do_sinus").map(|v| boolean(key_sin, v)).transpose()?.unwrap_or(false);
        if form_closure && do_sinus {
            return Err(ConfigError::invalid(
                key_fc,
                "true",
                format!("at most one prebuilt experiment may be true, but `{key_sin}` is true as well"),
            ));
        }
        let gait = if form_closure {
            if let Some((terrain_key, kind)) = &terrain
                && *kind != "none"
            {
                return Err(ConfigError::invalid(
                    key_fc,
                    "true",
                    format!(
                        "the form closure experiment generates its own terrain, so `{terrain_key}` must not be \
                         true as well"
                    ),
                ));
            }
            terrain = Some((key_fc.to_string(), "form_closure"));
            "form_closure"
        } else if do_sinus {
            "sine_wave"
        } else {
            "none"
        };
        if !section.is_empty() {
            set(out, "gait.kind", Value::String(gait.into()));
        }
    }

    if let Some((_, kind)) = terrain {
        set(out, "terrain.kind", Value::String(kind.into()));
    }
    Ok(())
}

/// The legacy section `name`, if present (its type was checked by [`check_keys`]).
fn section<'a>(root: &'a Map<String, Json>, name: &str) -> Option<&'a Map<String, Json>> {
    root.get(name).and_then(Json::as_object)
}

/// Sets `path` (dotted) in `out`, creating tables on the way.
fn set(out: &mut Table, path: &str, value: Value) {
    let mut table = out;
    let mut segments = path.split('.').peekable();
    while let Some(segment) = segments.next() {
        if segments.peek().is_none() {
            table.insert(segment.to_string(), value);
            return;
        }
        let entry = table.entry(segment.to_string()).or_insert_with(|| Value::Table(Table::new()));
        if !entry.is_table() {
            *entry = Value::Table(Table::new());
        }
        match entry {
            Value::Table(sub) => table = sub,
            _ => return,
        }
    }
}

/// A JSON value as a TOML value (the type is checked later, under the new key).
fn to_toml(key: &str, v: &Json) -> Result<Value, ConfigError> {
    Ok(match v {
        Json::Null => {
            return Err(ConfigError::invalid(
                key,
                "null",
                "null is not allowed; leave the key out to keep the default",
            ));
        }
        Json::Bool(b) => Value::Boolean(*b),
        Json::Number(n) => match n.as_i64() {
            Some(i) => Value::Integer(i),
            None => Value::Float(n.as_f64().unwrap_or(f64::NAN)),
        },
        Json::String(s) => Value::String(s.clone()),
        Json::Array(items) => Value::Array(items.iter().map(|item| to_toml(key, item)).collect::<Result<_, _>>()?),
        Json::Object(_) => {
            return Err(ConfigError::invalid(key, v, "expected a single value, not an object"));
        }
    })
}

fn number(key: &str, v: &Json) -> Result<f64, ConfigError> {
    v.as_f64().ok_or_else(|| ConfigError::invalid(key, v, "expected a number"))
}

fn boolean(key: &str, v: &Json) -> Result<bool, ConfigError> {
    v.as_bool().ok_or_else(|| ConfigError::invalid(key, v, "expected true or false"))
}

/// A short description of a JSON value's kind.
fn kind_of(v: &Json) -> &'static str {
    match v {
        Json::Null => "null",
        Json::Bool(_) => "a boolean",
        Json::Number(_) => "a number",
        Json::String(_) => "a string",
        Json::Array(_) => "an array",
        Json::Object(_) => "an object",
    }
}

/// Adds the config.json key a SimSerpent key was converted from to an [`ConfigError::InvalidValue`]
/// about a converted value (unless a `--set` override set that key).
pub(super) fn annotate(error: ConfigError, converted: &Table, overrides: &[String]) -> ConfigError {
    let ConfigError::InvalidValue { key, value, allowed } = error else {
        return error;
    };
    let base = key.split('[').next().unwrap_or(&key);
    let overridden = overrides.iter().any(|o| {
        let k = o.split('=').next().unwrap_or("").trim();
        base == k || base.starts_with(&format!("{k}."))
    });
    let allowed = match legacy_source(base) {
        Some(note) if !overridden && lookup(converted, base).is_some() => {
            format!("{allowed} ({note})")
        }
        _ => allowed,
    };
    ConfigError::InvalidValue { key, value, allowed }
}

/// Which config.json key a SimSerpent key is converted from, as a note for error messages.
fn legacy_source(key: &str) -> Option<String> {
    let from = |legacy: &str| Some(format!("converted from config.json key `{legacy}`"));
    match key {
        "general.duration_secs" => from("simulation_time"),
        "general.timestep_secs" => from("simulation_timestep"),
        "general.integrator" => from("integrator_type"),
        "general.plot" => from("plot_data"),
        "visual.show_contact_forces" => from("visual_options.show_contact_force"),
        "snake.n_links" => from("snake_specifications.nr_of_links"),
        "snake.link_mass_kg" => from("snake_specifications.link_mass_in_kg"),
        "snake.link_length_m" => Some(
            "converted from config.json key `snake_specifications.link_lenght_in_m`, the capsule's half length: \
             link_length_m = 2 x link_lenght_in_m"
                .into(),
        ),
        "snake.link_radius_m" => from("snake_specifications.link_radius_in_m"),
        "snake.torque_range_nm" => from("snake_specifications.maximum_torque_in_nm"),
        "snake.ground_friction" | "snake.link_friction" | "terrain.obstacle_friction" => {
            from("snake_specifications.friction")
        }
        "snake.joint_damping_nm_s_per_rad" => from("snake_specifications.joint_damping"),
        "snake.joint_armature_kg_m2" => from("snake_specifications.joint_armature"),
        "snake.color_rgba" => from("snake_specifications.snake_color_rgb"),
        "snake.head_position_m" => from("snake_specifications.head_position_xyz"),
        "snake.head_rotation_deg" => from("snake_specifications.head_rotation_xyz"),
        "control.torque_gear" => from("control_parameters.torque_actuator_KP"),
        "control.position_kp_nm_per_rad" => from("control_parameters.position_actuator_KP"),
        "control.velocity_kv_nm_s_per_rad" => from("control_parameters.velocity_actuator_KP"),
        "control.intvelocity_kp_nm_per_rad" => from("control_parameters.IntVelocity_actuator_KP"),
        "control.pid_kp_nm_per_rad" | "control.pid_ki_nm_per_rad_s" | "control.pid_kd_nm_s_per_rad" => {
            from("control_parameters.PID_parameters_Kp_Ki_Kd")
        }
        k if k.starts_with("sensors.") && k.ends_with(".std") => from("snake_specifications.sensor_noise_amount"),
        k => {
            if let Some(rest) = k.strip_prefix("visual.") {
                return from(&format!("visual_options.{rest}"));
            }
            let rest = k.strip_prefix("recording.")?;
            let (legacy, _) = RECORDING.iter().find(|(_, new)| *new == rest)?;
            from(&format!("store_data_to_csv.{legacy}"))
        }
    }
}
