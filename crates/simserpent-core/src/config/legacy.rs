//! Conversion of the original tool's `config.json` (thesis appendix 12.1) into SimSerpent's
//! layout.
//!
//! The result is a partial [`toml::Table`] in the new layout; it then goes through the same
//! key check, merge, overrides and validation as a TOML file. Every legacy key is optional:
//! a missing key keeps SimSerpent's default. Unknown legacy keys are rejected, with a
//! did-you-mean among the legacy keys and the key path in legacy naming
//! (`snake_specifications.nr_of_link`).
//!
//! The conversion table is data: [`LEGACY_RULES`] (one entry per config.json key: the SimSerpent
//! keys it sets, the rule and what differs from the original tool) and [`LEGACY_DEVIATIONS`]
//! (differences that no key shows). The same data gives the notes that `check` and `run`
//! print, the comments of `simserpent convert` ([`LegacyConversion::annotated_toml`]) and the
//! user guide's table ([`legacy_deviation_table`], checked against the guide by a test).
//!
//! The terrain and experiment rules apply only when the section has at least one of its keys;
//! an absent section keeps the defaults. Recording tables the original tool did not have
//! (joint velocities, IMU sensors, contacts, ...) keep their defaults.

use super::ConfigError;
use super::text::{join, lookup, suggest};
use serde_json::{Map, Value as Json};
use toml::{Table, Value};

/// One rule of the conversion: a config.json key, the SimSerpent keys it sets, how, and what
/// differs from the original tool.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LegacyRule {
    /// The config.json key (`section.key`); `visual_options.<other>` stands for the section's
    /// other keys; `(always)` for what every conversion sets.
    pub legacy_key: &'static str,
    /// The SimSerpent keys it sets.
    pub simserpent_keys: &'static str,
    /// How the value is converted.
    pub rule: &'static str,
    /// What differs from the original tool (empty: nothing).
    pub deviation: &'static str,
}

/// A difference from the original tool that no single config.json key shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LegacyDeviation {
    /// What it is about.
    pub topic: &'static str,
    /// The original tool (thesis section or listing).
    pub original: &'static str,
    /// SimSerpent.
    pub simserpent: &'static str,
}

const FROM_TIME: &str = "same value";

/// Every conversion rule, in the order of the thesis' listing (appendix 12.1).
pub const LEGACY_RULES: &[LegacyRule] = &[
    LegacyRule {
        legacy_key: "xml_path",
        simserpent_keys: "(none)",
        rule: "accepted and ignored: SimSerpent generates the model from the config",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "simulation_time",
        simserpent_keys: "general.duration_secs",
        rule: FROM_TIME,
        deviation: "",
    },
    LegacyRule {
        legacy_key: "simulation_timestep",
        simserpent_keys: "general.timestep_secs",
        rule: FROM_TIME,
        deviation: "",
    },
    LegacyRule { legacy_key: "integrator_type", simserpent_keys: "general.integrator", rule: FROM_TIME, deviation: "" },
    LegacyRule {
        legacy_key: "plot_data",
        simserpent_keys: "general.plot",
        rule: FROM_TIME,
        deviation: "SimSerpent's plots are its own standard panels (PNG and SVG in the run folder), not the \
                    original's figures",
    },
    LegacyRule {
        legacy_key: "visual_options.show_contact_force",
        simserpent_keys: "visual.show_contact_forces",
        rule: "same value (the key gets a plural)",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "visual_options.<other>",
        simserpent_keys: "visual.<other>",
        rule: "same name, same value",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "snake_specifications.nr_of_links",
        simserpent_keys: "snake.n_links",
        rule: FROM_TIME,
        deviation: "",
    },
    LegacyRule {
        legacy_key: "snake_specifications.link_mass_in_kg",
        simserpent_keys: "snake.link_mass_kg",
        rule: FROM_TIME,
        deviation: "",
    },
    LegacyRule {
        legacy_key: "snake_specifications.link_lenght_in_m",
        simserpent_keys: "snake.link_length_m",
        rule: "2 x the value: the original used it as the capsule's half length (its core between two joints), \
               and its joints were 2 x that apart",
        deviation: "with legacy.geometry = \"no_overlap\" (the default) each capsule spans only joint to joint, end \
                    caps included (0.20 m instead of the original 0.36 m for 0.10 m and radius 0.08 m; yaw \
                    inertia about the link centre 0.00105 instead of 0.0029 kg m^2), and a radius of at least half \
                    the spacing gives spheres (thesis set C); legacy.geometry = \"faithful\" builds the original \
                    capsules",
    },
    LegacyRule {
        legacy_key: "snake_specifications.link_radius_in_m",
        simserpent_keys: "snake.link_radius_m",
        rule: FROM_TIME,
        deviation: "",
    },
    LegacyRule {
        legacy_key: "snake_specifications.maximum_torque_in_nm",
        simserpent_keys: "snake.torque_range_nm",
        rule: "[min, max] as written; a single number m means [-m, m]",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "snake_specifications.friction",
        simserpent_keys: "snake.ground_friction, snake.link_friction, terrain.obstacle_friction",
        rule: "the sliding coefficient of all three (torsional and rolling keep their defaults, 0: condim 3 as in \
               the original)",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "snake_specifications.joint_damping",
        simserpent_keys: "snake.joint_damping_nm_s_per_rad",
        rule: FROM_TIME,
        deviation: "",
    },
    LegacyRule {
        legacy_key: "snake_specifications.joint_armature",
        simserpent_keys: "snake.joint_armature_kg_m2",
        rule: FROM_TIME,
        deviation: "",
    },
    LegacyRule {
        legacy_key: "snake_specifications.sensor_noise",
        simserpent_keys: "sensors.noise_enabled",
        rule: "\"enable\" / \"disable\" (any case; true / false also accepted)",
        deviation: "the original wrote MuJoCo's sensor `noise` attribute, which MuJoCo 3 does not apply; SimSerpent \
                    adds the noise itself (seeded, per sensor: bias, random walk, noise, resolution, rate)",
    },
    LegacyRule {
        legacy_key: "snake_specifications.sensor_noise_amount",
        simserpent_keys: "sensors.<kind>.std (every kind)",
        rule: "the same standard deviation for every sensor kind, in each kind's unit",
        deviation: "the original had one amount for every sensor; SimSerpent has one model per kind, the other \
                    keys keep their defaults",
    },
    LegacyRule {
        legacy_key: "snake_specifications.snake_color_rgb",
        simserpent_keys: "snake.color_rgba",
        rule: "same value (it holds RGBA; three values get alpha 1)",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "snake_specifications.head_position_xyz",
        simserpent_keys: "snake.head_position_m",
        rule: "same value: the original floor was at z = -radius, SimSerpent's is at z = 0, so z = 0 lies on the \
               floor in both",
        deviation: "with legacy.geometry = \"no_overlap\" it is the head's front tip and the body extends along -x \
                    from it (the snake faces +x); the original (and \"faithful\") put the head's front joint point \
                    at head position + (2 x link_lenght_in_m, 0, 0) (listing 3) with the body along +x (it faces \
                    -x)",
    },
    LegacyRule {
        legacy_key: "snake_specifications.head_rotation_xyz",
        simserpent_keys: "snake.head_rotation_deg",
        rule: "same value (Euler angles about x, y, z in degrees)",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "control_parameters.control_method",
        simserpent_keys: "control.method",
        rule: "lower case: position, torque, velocity, intvelocity (any case accepted)",
        deviation: "only the chosen actuator kind gets non-zero gains (MuJoCo servos act even at zero command)",
    },
    LegacyRule {
        legacy_key: "control_parameters.torque_actuator_KP",
        simserpent_keys: "control.torque_gear",
        rule: FROM_TIME,
        deviation: "",
    },
    LegacyRule {
        legacy_key: "control_parameters.position_actuator_KP",
        simserpent_keys: "control.position_kp_nm_per_rad",
        rule: "same value (the P gain of the position servo)",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "control_parameters.velocity_actuator_KP",
        simserpent_keys: "control.position_kv_nm_s_per_rad, control.velocity_kv_nm_s_per_rad",
        rule: "both: the D gain of the position servo (the original made its PD control from the position servo \
               plus the velocity servo with this gain, thesis 6.2.3 and 11.1) and the gain of the velocity servo \
               (control_method = velocity)",
        deviation: "MuJoCo's position servo applies kp (target - q) - kv q', i.e. the original's velocity servo at \
                    zero command; P and D together are limited to maximum_torque_in_nm, where the original's two \
                    servos had a limit each",
    },
    LegacyRule {
        legacy_key: "control_parameters.IntVelocity_actuator_KP",
        simserpent_keys: "control.intvelocity_kp_nm_per_rad",
        rule: FROM_TIME,
        deviation: "",
    },
    LegacyRule {
        legacy_key: "control_parameters.PID_parameters_Kp_Ki_Kd",
        simserpent_keys: "control.pid_kp_nm_per_rad, control.pid_ki_nm_per_rad_s, control.pid_kd_nm_s_per_rad",
        rule: "[Kp, Ki, Kd] in order (the joint-angle PID of control_method = torque)",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "terrain.generate_two_cylinders",
        simserpent_keys: "terrain.kind",
        rule: "true gives \"two_cylinders\"; at most one generate_* may be true, none true gives \"none\"",
        deviation: "the original's cylinder sizes and places are not published; SimSerpent's layout is in [terrain] \
                    (user guide, \"Build terrains\")",
    },
    LegacyRule {
        legacy_key: "terrain.generate_random_cylinders",
        simserpent_keys: "terrain.kind",
        rule: "true gives \"random_cylinders\"",
        deviation: "SimSerpent's random layout (seeded by general.seed), not the original's",
    },
    LegacyRule {
        legacy_key: "terrain.generate_cylinder_path",
        simserpent_keys: "terrain.kind",
        rule: "true gives \"cylinder_path\"",
        deviation: "SimSerpent's path layout, not the original's",
    },
    LegacyRule {
        legacy_key: "prebuilt_experiments.do_sinus",
        simserpent_keys: "gait.kind",
        rule: "true gives \"sine_wave\"; neither experiment true gives \"none\"",
        deviation: "the original's wave (\"a sine wave from 0 - 180 degrees\" shifted through the position servos, \
                    thesis 8.3) has no published amplitude or frequency; SimSerpent's sine_wave uses [gait.sine_wave] \
                    (30 deg, 0.5 Hz, 40 deg lag, 1 s ramp). With the thesis' exp. III gains (kp 1, kv 0.4, armature \
                    0.2) the joints cannot follow it (user guide, \"Use the original tool's config\")",
    },
    LegacyRule {
        legacy_key: "prebuilt_experiments.form_closure",
        simserpent_keys: "gait.kind, terrain.kind",
        rule: "true gives \"form_closure\" for both (no generate_* terrain may be true as well; both experiments \
               true is an error)",
        deviation: "pegs around the starting shape from [gait.form_closure] and [terrain.form_closure]; the \
                    original's shape and peg places are not published",
    },
    LegacyRule {
        legacy_key: "store_data_to_csv.store_data",
        simserpent_keys: "recording.enabled",
        rule: FROM_TIME,
        deviation: "experiments turn recording on whatever this says (their analysis reads the tables)",
    },
    LegacyRule {
        legacy_key: "store_data_to_csv.<quantity>",
        simserpent_keys: "recording.<table switch>",
        rule: "the [recording] switch of the same quantity: position -> link_position, velocity -> link_velocity, \
               accel -> link_acceleration, angle -> link_orientation, angular_vel -> link_angular_velocity, \
               angular_accel -> link_angular_acceleration; the actuator forces, joint_angles and \
               external_contact_forces keep their names",
        deviation: "the columns go into SimSerpent's tables (links.csv, joints.csv, ...; user guide, \"Read the outputs\"), not \
                    the original's CSV files",
    },
    LegacyRule {
        legacy_key: "(always)",
        simserpent_keys: "ground.model",
        rule: "\"isotropic\": the original tool had only isotropic Coulomb friction with the floor",
        deviation: "",
    },
    LegacyRule {
        legacy_key: "(always)",
        simserpent_keys: "legacy.geometry",
        rule: "\"no_overlap\" (SimSerpent's links); set \"faithful\" for the original tool's capsules and placement",
        deviation: "see snake_specifications.link_lenght_in_m and head_position_xyz",
    },
];

/// Differences from the original tool that no config.json key shows.
pub const LEGACY_DEVIATIONS: &[LegacyDeviation] = &[
    LegacyDeviation {
        topic: "floor height",
        original: "floor plane at z = -link radius (listing 3)",
        simserpent: "floor at z = 0; every height is link radius higher",
    },
    LegacyDeviation {
        topic: "link frames (legacy.geometry = \"faithful\")",
        original: "each link's x axis points toward the tail",
        simserpent: "x points toward the head: link orientations and IMU x, y readings differ by 180 deg about z",
    },
    LegacyDeviation {
        topic: "IMU placement",
        original: "velocimeter, accelerometer and gyro at the link's rear joint (site at 2 x link_lenght_in_m)",
        simserpent: "at the link's centre of mass (site link_ii_imu); joint force/torque sensors at every joint",
    },
    LegacyDeviation {
        topic: "friction cone",
        original: "MuJoCo's default pyramidal cone",
        simserpent: "elliptic (physics.friction_cone): the pyramidal cone makes isotropic friction depend on the \
                     sliding direction (an undulating snake drifted 0.1-0.65 m in 20 s)",
    },
    LegacyDeviation {
        topic: "position servo command range",
        original: "ctrlrange -3 to 3 (rad) on every actuator",
        simserpent: "+/- snake.joint_range_deg (the joint's own range)",
    },
    LegacyDeviation {
        topic: "recorded values",
        original: "read after each step by get_snake_info.py",
        simserpent: "one consistent instant per row (user guide, \"Read the outputs\"); sensors.csv holds the sensor values of \
                     the previous step",
    },
];

/// The user guide's table of every difference from the original tool (Markdown): the rules with a
/// deviation, then [`LEGACY_DEVIATIONS`].
pub fn legacy_deviation_table() -> String {
    let cell = |s: &str| s.replace('|', "\\|");
    let mut out = String::from("| what | the original tool | SimSerpent |\n|---|---|---|\n");
    for r in LEGACY_RULES.iter().filter(|r| !r.deviation.is_empty()) {
        out.push_str(&format!(
            "| `{}` -> `{}` | {} | {} |\n",
            cell(r.legacy_key),
            cell(r.simserpent_keys),
            cell(r.rule),
            cell(r.deviation)
        ));
    }
    for d in LEGACY_DEVIATIONS {
        out.push_str(&format!("| {} | {} | {} |\n", cell(d.topic), cell(d.original), cell(d.simserpent)));
    }
    out
}

/// The whole conversion table (Markdown), one row per rule.
pub fn legacy_rule_table() -> String {
    let cell = |s: &str| s.replace('|', "\\|");
    let mut out = String::from("| config.json key | SimSerpent key | rule |\n|---|---|---|\n");
    for r in LEGACY_RULES {
        out.push_str(&format!("| `{}` | `{}` | {} |\n", cell(r.legacy_key), cell(r.simserpent_keys), cell(r.rule)));
    }
    out
}

/// The rule that sets `key` from `legacy_key` (exact, or the `<other>` / `<quantity>` entry of
/// its section).
fn rule(legacy_key: &str, key: &str) -> &'static LegacyRule {
    let exact = || LEGACY_RULES.iter().filter(|r| r.legacy_key == legacy_key);
    exact()
        .find(|r| r.simserpent_keys.split(", ").any(|k| k == key))
        .or_else(|| exact().next())
        .or_else(|| {
            let section = legacy_key.split('.').next().unwrap_or("");
            LEGACY_RULES.iter().find(|r| r.legacy_key.starts_with(section) && r.legacy_key.ends_with('>'))
        })
        .unwrap_or(&LEGACY_RULES[0])
}

/// What the conversion did to one SimSerpent key.
#[derive(Debug, Clone, PartialEq)]
pub struct LegacyNote {
    /// The config.json key (`(always)` for keys every conversion sets).
    pub legacy_key: String,
    /// Its value as written in config.json (JSON).
    pub legacy_value: String,
    /// The SimSerpent key set.
    pub key: String,
    /// The value set.
    pub value: Value,
    /// The rule applied.
    pub rule: &'static LegacyRule,
}

impl LegacyNote {
    /// `` `legacy` = v -> `key` = v ``.
    pub fn head(&self) -> String {
        let from = if self.legacy_key == "(always)" {
            "(every conversion)".to_string()
        } else {
            format!("`{}` = {}", self.legacy_key, self.legacy_value)
        };
        format!("{from} -> `{}` = {}", self.key, self.value)
    }

    /// One line: `` `legacy` = v -> `key` = v: rule; differs from the original: ... ``.
    pub fn line(&self) -> String {
        let mut line = format!("{}: {}", self.head(), self.rule.rule);
        if !self.rule.deviation.is_empty() {
            line.push_str("; differs from the original: ");
            line.push_str(self.rule.deviation);
        }
        line
    }
}

/// A converted config.json: the partial table in SimSerpent's layout and what was done to
/// every key, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct LegacyConversion {
    /// The converted keys (merge it onto the defaults like a TOML file).
    pub table: Table,
    /// One note per SimSerpent key set (the last one for a key set twice).
    pub notes: Vec<LegacyNote>,
}

impl LegacyConversion {
    /// The note lines that `check` and `run` print: one per config.json key (its SimSerpent keys
    /// together); a rule and its difference from the original are spelt out the first time only.
    pub fn note_lines(&self) -> Vec<String> {
        let mut lines = Vec::new();
        let mut explained: Vec<&'static LegacyRule> = Vec::new();
        let notes = &self.notes;
        let mut i = 0;
        while i < notes.len() {
            let first = &notes[i];
            let same = |n: &LegacyNote| n.legacy_key == first.legacy_key && std::ptr::eq(n.rule, first.rule);
            let group = notes[i..].iter().take_while(|n| same(n)).count().max(1);
            let mut line = first.head();
            for n in &notes[i + 1..i + group] {
                line.push_str(&format!(", `{}` = {}", n.key, n.value));
            }
            if explained.iter().any(|r| std::ptr::eq(*r, first.rule)) {
                line.push_str(" (rule as above)");
            } else {
                explained.push(first.rule);
                line.push_str(": ");
                line.push_str(first.rule.rule);
                if !first.rule.deviation.is_empty() {
                    line.push_str("; differs from the original: ");
                    line.push_str(first.rule.deviation);
                }
            }
            lines.push(line);
            i += group;
        }
        lines
    }

    /// What `check` and `run` print: one line per converted setting that works differently in
    /// SimSerpent (its rule has a difference from the original), as `` `legacy` = v -> `key` = v ``;
    /// settings under the same rule as an earlier line are counted, not repeated. The rules and
    /// the differences themselves are in `simserpent convert`'s annotated TOML.
    pub fn difference_lines(&self) -> Vec<String> {
        let mut lines: Vec<(String, usize)> = Vec::new();
        let mut listed: Vec<&'static LegacyRule> = Vec::new();
        let notes = &self.notes;
        let mut i = 0;
        while i < notes.len() {
            let first = &notes[i];
            let same = |n: &LegacyNote| n.legacy_key == first.legacy_key && std::ptr::eq(n.rule, first.rule);
            let group = notes[i..].iter().take_while(|n| same(n)).count().max(1);
            if !first.rule.deviation.is_empty() {
                match listed.iter().position(|r| std::ptr::eq(*r, first.rule)) {
                    Some(at) => lines[at].1 += 1,
                    None => {
                        let mut line = first.head();
                        for n in &notes[i + 1..i + group] {
                            line.push_str(&format!(", `{}` = {}", n.key, n.value));
                        }
                        listed.push(first.rule);
                        lines.push((line, 0));
                    }
                }
            }
            i += group;
        }
        lines
            .into_iter()
            .map(|(line, more)| if more > 0 { format!("{line} (and {more} more keys alike)") } else { line })
            .collect()
    }

    /// The converted keys as an annotated TOML file: each key with comments naming its
    /// config.json key, the rule and any difference from the original tool; the header lists
    /// the differences no key shows. Loading it gives the same config as the config.json.
    pub fn annotated_toml(&self, source: &str) -> String {
        let mut out = String::new();
        let comment = |out: &mut String, text: &str| {
            for line in wrap(text, 96) {
                out.push_str("# ");
                out.push_str(&line);
                out.push('\n');
            }
        };
        comment(
            &mut out,
            &format!(
                "SimSerpent config converted by `simserpent convert` from {source} (the original tool's config.json, \
                 thesis appendix 12.1). Every key below comes from it; all other keys keep SimSerpent's defaults \
                 (`simserpent init` writes them, with comments). user guide, \"Use the original tool's config\" has the whole table."
            ),
        );
        out.push_str("#\n");
        comment(&mut out, "Differences from the original tool that no key below shows:");
        for d in LEGACY_DEVIATIONS {
            comment(&mut out, &format!("- {}: original {}; SimSerpent {}.", d.topic, d.original, d.simserpent));
        }
        // Group the keys by their table, in order of first appearance.
        let mut tables: Vec<(String, Vec<&LegacyNote>)> = Vec::new();
        for note in &self.notes {
            let (table, _) = note.key.rsplit_once('.').unwrap_or(("", &note.key));
            match tables.iter_mut().find(|(t, _)| t == table) {
                Some((_, notes)) => notes.push(note),
                None => tables.push((table.to_string(), vec![note])),
            }
        }
        for (table, notes) in tables {
            out.push_str(&format!("\n[{table}]\n"));
            for note in notes {
                let leaf = note.key.rsplit_once('.').map_or(note.key.as_str(), |(_, leaf)| leaf);
                let from = if note.legacy_key == "(always)" {
                    "every conversion".to_string()
                } else {
                    format!("config.json `{}` = {}", note.legacy_key, note.legacy_value)
                };
                comment(&mut out, &format!("{from}: {}.", note.rule.rule));
                if !note.rule.deviation.is_empty() {
                    comment(&mut out, &format!("Differs from the original: {}.", note.rule.deviation));
                }
                out.push_str(&format!("{leaf} = {}\n", note.value));
            }
        }
        out
    }
}

/// `text` in lines of at most `width` characters (words are not split).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// The converted table and its notes, built together.
struct Out {
    table: Table,
    notes: Vec<LegacyNote>,
}

impl Out {
    /// Sets `key` (dotted) to `value`, converted from `legacy_key` (whose JSON value is `from`).
    fn set(&mut self, key: &str, value: Value, legacy_key: &str, from: Option<&Json>) {
        set(&mut self.table, key, value.clone());
        self.notes.retain(|n| n.key != key);
        self.notes.push(LegacyNote {
            legacy_key: legacy_key.to_string(),
            legacy_value: from.map_or_else(String::new, Json::to_string),
            key: key.to_string(),
            value,
            rule: rule(legacy_key, key),
        });
    }
}

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

/// Converts a parsed legacy `config.json` into a partial table in SimSerpent's layout, with a
/// note for every key set.
///
/// `defaults` is the embedded default config (for the friction coefficients the original
/// tool did not have and for the list of sensor noise keys).
pub(super) fn convert(json: &Json, defaults: &Table) -> Result<LegacyConversion, ConfigError> {
    let Json::Object(root) = json else {
        return Err(ConfigError::invalid(
            "(top level)",
            kind_of(json),
            "the original tool's config.json must be a JSON object `{ ... }`",
        ));
    };
    check_keys(root)?;
    let mut out = Out { table: Table::new(), notes: Vec::new() };
    // The original tool knew only isotropic Coulomb friction with the floor.
    out.set("ground.model", Value::String("isotropic".into()), "(always)", None);
    out.set("legacy.geometry", Value::String("no_overlap".into()), "(always)", None);

    // Top level.
    for (legacy_key, key) in [
        ("simulation_time", "general.duration_secs"),
        ("simulation_timestep", "general.timestep_secs"),
        ("integrator_type", "general.integrator"),
        ("plot_data", "general.plot"),
    ] {
        if let Some(v) = root.get(legacy_key) {
            out.set(key, to_toml(legacy_key, v)?, legacy_key, Some(v));
        }
    }

    // visual_options: 1:1.
    if let Some(section) = section(root, "visual_options") {
        for (key, v) in section {
            let new_key = if key == "show_contact_force" { "show_contact_forces" } else { key.as_str() };
            let legacy_key = format!("visual_options.{key}");
            out.set(&format!("visual.{new_key}"), to_toml(&legacy_key, v)?, &legacy_key, Some(v));
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
                out.set(&format!("recording.{new_key}"), Value::Boolean(boolean(&key, v)?), &key, Some(v));
            }
        }
    }
    Ok(LegacyConversion { table: out.table, notes: out.notes })
}

/// Rejects unknown legacy keys and sections that are not objects.
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

fn convert_snake(section: &Map<String, Json>, defaults: &Table, out: &mut Out) -> Result<(), ConfigError> {
    const DIRECT: [(&str, &str); 7] = [
        ("nr_of_links", "snake.n_links"),
        ("link_mass_in_kg", "snake.link_mass_kg"),
        ("link_radius_in_m", "snake.link_radius_m"),
        ("joint_damping", "snake.joint_damping_nm_s_per_rad"),
        ("joint_armature", "snake.joint_armature_kg_m2"),
        ("head_position_xyz", "snake.head_position_m"),
        ("head_rotation_xyz", "snake.head_rotation_deg"),
    ];
    let legacy = |key: &str| format!("snake_specifications.{key}");
    for (legacy_key, new_key) in DIRECT {
        if let Some(v) = section.get(legacy_key) {
            let key = legacy(legacy_key);
            out.set(new_key, to_toml(&key, v)?, &key, Some(v));
        }
    }
    if let Some(v) = section.get("link_lenght_in_m") {
        let key = legacy("link_lenght_in_m");
        let half = number(&key, v)?;
        out.set("snake.link_length_m", Value::Float(2.0 * half), &key, Some(v));
    }
    if let Some(v) = section.get("maximum_torque_in_nm") {
        let key = legacy("maximum_torque_in_nm");
        let range = match v {
            Json::Number(_) => {
                let m = number(&key, v)?.abs();
                Value::Array(vec![Value::Float(-m), Value::Float(m)])
            }
            _ => to_toml(&key, v)?,
        };
        out.set("snake.torque_range_nm", range, &key, Some(v));
    }
    if let Some(v) = section.get("friction") {
        let key = legacy("friction");
        let sliding = number(&key, v)?;
        for new_key in ["snake.ground_friction", "snake.link_friction", "terrain.obstacle_friction"] {
            let mut triple = match lookup(defaults, new_key) {
                Some(Value::Array(a)) => a.clone(),
                _ => Vec::new(),
            };
            match triple.first_mut() {
                Some(first) => *first = Value::Float(sliding),
                None => triple.push(Value::Float(sliding)),
            }
            out.set(new_key, Value::Array(triple), &key, Some(v));
        }
    }
    if let Some(v) = section.get("sensor_noise") {
        let key = legacy("sensor_noise");
        let enabled = match v {
            Json::Bool(b) => *b,
            Json::String(s) if s.eq_ignore_ascii_case("enable") => true,
            Json::String(s) if s.eq_ignore_ascii_case("disable") => false,
            _ => {
                return Err(ConfigError::invalid(&key, v, "expected \"enable\" or \"disable\""));
            }
        };
        out.set("sensors.noise_enabled", Value::Boolean(enabled), &key, Some(v));
    }
    if let Some(v) = section.get("sensor_noise_amount") {
        let key = legacy("sensor_noise_amount");
        let amount = number(&key, v)?;
        if let Some(Value::Table(sensors)) = defaults.get("sensors") {
            // Every sensor kind's table (`[sensors.<kind>]`) gets the amount as its std.
            for (kind, _) in sensors.iter().filter(|(_, v)| v.is_table()) {
                out.set(&format!("sensors.{kind}.std"), Value::Float(amount), &key, Some(v));
            }
        }
    }
    if let Some(v) = section.get("snake_color_rgb") {
        let key = legacy("snake_color_rgb");
        let mut color = to_toml(&key, v)?;
        if let Value::Array(items) = &mut color
            && items.len() == 3
        {
            items.push(Value::Float(1.0));
        }
        out.set("snake.color_rgba", color, &key, Some(v));
    }
    Ok(())
}

fn convert_control(section: &Map<String, Json>, out: &mut Out) -> Result<(), ConfigError> {
    // velocity_actuator_KP is both the position servo's D gain (the thesis' PD control) and the
    // velocity servo's gain.
    const DIRECT: [(&str, &str); 5] = [
        ("torque_actuator_KP", "control.torque_gear"),
        ("position_actuator_KP", "control.position_kp_nm_per_rad"),
        ("velocity_actuator_KP", "control.position_kv_nm_s_per_rad"),
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
        out.set("control.method", Value::String(method.into()), key, Some(v));
    }
    for (legacy_key, new_key) in DIRECT {
        if let Some(v) = section.get(legacy_key) {
            let key = format!("control_parameters.{legacy_key}");
            out.set(new_key, to_toml(&key, v)?, &key, Some(v));
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
            out.set(name, Value::Float(gain), key, Some(v));
        }
    }
    Ok(())
}

fn convert_terrain_and_experiments(root: &Map<String, Json>, out: &mut Out) -> Result<(), ConfigError> {
    // terrain: at most one generator. (legacy key that chose it, its JSON value, kind)
    let mut terrain: Option<(String, Option<&Json>, &str)> = None;
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
                terrain = Some((key.clone(), Some(v), kind));
                chosen = Some(key);
            }
        }
        if terrain.is_none()
            && let Some((first, v)) = section.iter().next()
        {
            terrain = Some((format!("terrain.{first}"), Some(v), "none"));
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
            if let Some((terrain_key, _, kind)) = &terrain
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
            terrain = Some((key_fc.to_string(), section.get("form_closure"), "form_closure"));
            Some((key_fc, "form_closure"))
        } else if do_sinus {
            Some((key_sin, "sine_wave"))
        } else {
            None
        };
        match gait {
            Some((key, kind)) => {
                let v = section.get(key.rsplit('.').next().unwrap_or(key));
                out.set("gait.kind", Value::String(kind.into()), key, v);
            }
            None => {
                if let Some((first, v)) = section.iter().next() {
                    let key = if first == "form_closure" { key_fc } else { key_sin };
                    out.set("gait.kind", Value::String("none".into()), key, Some(v));
                }
            }
        }
    }

    if let Some((key, v, kind)) = terrain {
        out.set("terrain.kind", Value::String(kind.into()), &key, v);
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
pub(super) fn annotate(error: ConfigError, converted: &LegacyConversion, overrides: &[String]) -> ConfigError {
    let ConfigError::InvalidValue { key, value, allowed } = error else {
        return error;
    };
    let base = key.split('[').next().unwrap_or(&key);
    let overridden = overrides.iter().any(|o| {
        let k = o.split('=').next().unwrap_or("").trim();
        base == k || base.starts_with(&format!("{k}."))
    });
    let note = converted.notes.iter().find(|n| n.key == base && n.legacy_key != "(always)");
    let allowed = match note {
        Some(note) if !overridden => {
            format!("{allowed} (converted from config.json key `{}`: {})", note.legacy_key, note.rule.rule)
        }
        _ => allowed,
    };
    ConfigError::InvalidValue { key, value, allowed }
}
