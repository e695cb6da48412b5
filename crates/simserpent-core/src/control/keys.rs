//! Which keys of a config the active controller does not use, so that a run can say so instead
//! of silently ignoring them.
//!
//! Each controller reads part of `[gait]` and its own section:
//!
//! | `control.controller` | reads from `[gait]` | does not use |
//! |---|---|---|
//! | `gait` | `kind`, `ramp_secs`, the section of `kind` | the other kinds' sections; `ramp_secs` with `none` and `form_closure` |
//! | `path_following` (`kind = "sine_wave"`) | `ramp_secs`, `sine_wave.amplitude_deg`, `frequency_hz`, `phase_lag_deg` | `sine_wave.offset_deg` (its heading control sets the offset), the other kinds' sections |
//! | `follow_the_leader_reflex`, `directional_admittance`, `jam_resolution` (`kind = "sine_wave"`) | `ramp_secs`, every `sine_wave` key | the other kinds' sections |
//!
//! `path_following` and the contact laws with any other `gait.kind` run that gait open loop, as
//! `gait` does; their own sections are then unused. Each controller's own section
//! (`[path_following]`, `[follow_the_leader_reflex]`, …) is used only by that controller. A key
//! is reported only when its value differs from the default (a default value changes nothing
//! either way).
//! `tests` in this module check the table against the controllers themselves: for every
//! controller, actuator kind, gait kind and gait key, a key is reported exactly when changing it
//! leaves every command unchanged.

use crate::config::{Config, ControllerKind, GaitKind};

/// A key whose value the active controller does not use.
#[derive(Debug, Clone, PartialEq)]
pub struct UnusedKey {
    /// The key path (`gait.sine_wave.offset_deg`).
    pub key: String,
    /// Its value, as TOML writes it.
    pub value: String,
    /// Why it has no effect.
    pub reason: String,
}

impl std::fmt::Display for UnusedKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Values echoed as errors echo them: at most ECHO_LIMIT characters (a 10,000-element list
        // is not repeated whole).
        use crate::config::shorten;
        write!(f, "{} = {} has no effect: {}", shorten(&self.key), shorten(&self.value), self.reason)
    }
}

/// The gait sections and the kind each belongs to.
const GAIT_SECTIONS: [(&str, GaitKind); 5] = [
    ("gait.sine_wave", GaitKind::SineWave),
    ("gait.serpenoid", GaitKind::Serpenoid),
    ("gait.sidewinding", GaitKind::Sidewinding),
    ("gait.rolling", GaitKind::Rolling),
    ("gait.form_closure", GaitKind::FormClosure),
];

fn kind_name(kind: GaitKind) -> &'static str {
    match kind {
        GaitKind::None => "none",
        GaitKind::SineWave => "sine_wave",
        GaitKind::FormClosure => "form_closure",
        GaitKind::Serpenoid => "serpenoid",
        GaitKind::Sidewinding => "sidewinding",
        GaitKind::Rolling => "rolling",
    }
}

fn controller_name(kind: ControllerKind) -> &'static str {
    match kind {
        ControllerKind::Gait => "gait",
        ControllerKind::PathFollowing => "path_following",
        ControllerKind::FollowTheLeaderReflex => "follow_the_leader_reflex",
        ControllerKind::DirectionalAdmittance => "directional_admittance",
        ControllerKind::JamResolution => "jam_resolution",
    }
}

/// The controller that actually runs for `config` (`path_following` and the contact laws fall
/// back to the open-loop gait without a sine wave; see [`super::controller_from_config`]).
pub fn effective_controller(config: &Config) -> ControllerKind {
    match (config.control.controller, config.gait.kind) {
        (
            ControllerKind::PathFollowing
            | ControllerKind::FollowTheLeaderReflex
            | ControllerKind::DirectionalAdmittance
            | ControllerKind::JamResolution,
            GaitKind::SineWave,
        ) => config.control.controller,
        _ => ControllerKind::Gait,
    }
}

/// The keys (or whole sections: a prefix ending before a `.`) the active controller does not
/// use, each with the reason; whether their values differ from the default is not looked at.
pub fn unused_key_rules(config: &Config) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = Vec::new();
    let chosen = config.control.controller;
    let active = effective_controller(config);
    let kind = config.gait.kind;
    let ctl = format!("control.controller = \"{}\"", controller_name(chosen));
    if active != chosen {
        out.push((
            "control.controller".into(),
            format!(
                "it needs gait.kind = \"sine_wave\"; with gait.kind = \"{}\" the gait runs open loop, as with \
                 control.controller = \"gait\"",
                kind_name(kind)
            ),
        ));
    }
    // The controllers' own sections.
    for (section, owner) in [
        ("path_following", ControllerKind::PathFollowing),
        ("follow_the_leader_reflex", ControllerKind::FollowTheLeaderReflex),
        ("directional_admittance", ControllerKind::DirectionalAdmittance),
        ("jam_resolution", ControllerKind::JamResolution),
    ] {
        if active != owner {
            let why = if chosen == owner {
                format!("{ctl} runs the gait open loop with gait.kind = \"{}\"", kind_name(kind))
            } else {
                format!("[{section}] is used only with control.controller = \"{section}\" ({ctl})")
            };
            out.push((section.into(), why));
        }
    }
    // The gait sections of the kinds not chosen.
    let other_kinds = |out: &mut Vec<(String, String)>, why: &str| {
        for (section, k) in GAIT_SECTIONS {
            if k != kind {
                out.push((section.into(), why.to_string()));
            }
        }
    };
    let kind_is = format!("gait.kind = \"{}\" uses only its own section", kind_name(kind));
    match active {
        // The contact laws shape the whole sine wave (amplitude, frequency, phase lag, offset).
        ControllerKind::FollowTheLeaderReflex
        | ControllerKind::DirectionalAdmittance
        | ControllerKind::JamResolution => {
            other_kinds(&mut out, &kind_is);
        }
        ControllerKind::Gait => {
            other_kinds(&mut out, &kind_is);
            match kind {
                GaitKind::None => out.push((
                    "gait.ramp_secs".into(),
                    "gait.kind = \"none\" holds the joints (no wave to ramp in)".into(),
                )),
                GaitKind::FormClosure => out.push((
                    "gait.ramp_secs".into(),
                    "gait.kind = \"form_closure\" starts in its pattern's shape (it has no ramp-in)".into(),
                )),
                _ => {}
            }
        }
        ControllerKind::PathFollowing => {
            other_kinds(&mut out, &kind_is);
            out.push((
                "gait.sine_wave.offset_deg".into(),
                format!(
                    "{ctl} sets the joint offset itself (its heading control, at most path_following.max_offset_deg = \
                     {}); use control.controller = \"gait\" for an open-loop turn",
                    config.path_following.max_offset_deg
                ),
            ));
        }
    }
    out
}

/// The keys of `config` that differ from the default and that the active controller does not
/// use (see the module documentation); plus `control.controller` itself when a controller the
/// user chose falls back to the open-loop gait.
pub fn unused_keys(config: &Config) -> Vec<UnusedKey> {
    let (Ok(table), Ok(defaults)) = (toml::Table::try_from(config), toml::Table::try_from(Config::default())) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for (prefix, reason) in unused_key_rules(config) {
        if prefix == "control.controller" {
            // Chosen by the user (the default path following falls back as the default config
            // documents, for any gait but a sine wave).
            if config.control.controller != Config::default().control.controller {
                let value = format!("\"{}\"", controller_name(config.control.controller));
                out.push(UnusedKey { key: prefix, value, reason });
            }
            continue;
        }
        let mut leaves = Vec::new();
        match lookup(&table, &prefix) {
            Some(toml::Value::Table(t)) => collect_leaves(t, &prefix, &mut leaves),
            Some(v) => leaves.push((prefix.clone(), v.clone())),
            None => {}
        }
        for (key, value) in leaves {
            if lookup(&defaults, &key) != Some(&value) {
                out.push(UnusedKey { key, value: value.to_string(), reason: reason.clone() });
            }
        }
    }
    out
}

/// One line when nothing will move the snake: the open-loop gait `none` (joints held) and a
/// start at rest, so a run shows a snake lying still (or settling under gravity) for its whole
/// duration; `None` otherwise.
pub fn nothing_moves(config: &Config) -> Option<String> {
    let s = &config.initial_state;
    let at_rest = s.linear_velocity_m_per_s == [0.0; 3] && s.angular_velocity_rad_per_s == [0.0; 3];
    (effective_controller(config) == ControllerKind::Gait && config.gait.kind == GaitKind::None && at_rest).then(|| {
        format!(
            "nothing drives this snake: gait.kind = \"none\" holds every joint at its start angle and the snake \
             starts at rest, so it lies still for the {} s of the run (gait.kind = \"sine_wave\" makes it undulate)",
            config.general.duration_secs
        )
    })
}

fn lookup<'a>(table: &'a toml::Table, path: &str) -> Option<&'a toml::Value> {
    let mut parts = path.split('.');
    let mut v = table.get(parts.next()?)?;
    for p in parts {
        v = v.as_table()?.get(p)?;
    }
    Some(v)
}

fn collect_leaves(table: &toml::Table, prefix: &str, out: &mut Vec<(String, toml::Value)>) {
    for (k, v) in table {
        let key = format!("{prefix}.{k}");
        match v {
            toml::Value::Table(t) => collect_leaves(t, &key, out),
            _ => out.push((key, v.clone())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ControlMethod, JointAxes};
    use crate::control::{Command, Observation, controller_from_config};

    /// Every command of `config`'s controller over 2.5 s of a made-up but moving snake (an update
    /// every 5 ms; the observations do not depend on the commands).
    fn commands(config: &Config) -> Vec<Vec<f64>> {
        let (n_links, n_joints) = (config.snake.n_links, config.snake.n_links - 1);
        let mut ctl = controller_from_config(config, n_joints);
        let mut obs = Observation::new(n_links, n_joints);
        let mut cmd = Command::new(n_joints);
        let mut out = Vec::new();
        for k in 0..500 {
            let t = k as f64 * 5e-3;
            obs.time_secs = t;
            obs.sensor_time_secs = t;
            for j in 0..n_joints {
                obs.joint_angle_rad[j] = 0.4 * (3.0 * t - 0.7 * j as f64).sin();
                obs.joint_velocity_rad_per_s[j] = 1.2 * (3.0 * t - 0.7 * j as f64).cos();
            }
            let yaw = 0.3 * (0.5 * t).sin();
            obs.head_position_m = [0.05 * t, 0.2 * (0.4 * t).sin(), 0.04];
            obs.head_quat = [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()];
            obs.head_velocity_m_per_s = [0.05, 0.08 * (0.4 * t).cos(), 0.0];
            ctl.update(&obs, &mut cmd);
            let mut row = cmd.position_rad.clone();
            row.extend(&cmd.velocity_rad_per_s);
            row.extend(&cmd.intvelocity_rad_per_s);
            row.extend(&cmd.torque_nm);
            out.push(row);
        }
        out
    }

    /// Every leaf key under `[gait]` with a changed value (`gait.kind` to another kind).
    fn gait_keys(config: &Config) -> Vec<(String, toml::Value)> {
        let table = toml::Table::try_from(config).expect("config as TOML");
        let mut leaves = Vec::new();
        collect_leaves(table["gait"].as_table().expect("[gait]"), "gait", &mut leaves);
        leaves
            .into_iter()
            .map(|(key, value)| {
                let changed = match value {
                    toml::Value::Float(x) => toml::Value::Float(x * 1.3 + 0.1),
                    toml::Value::Integer(i) => toml::Value::Integer(i + 1),
                    toml::Value::String(s) => {
                        // Another kind, not the default (a default value is never reported).
                        toml::Value::String(if s == "serpenoid" { "form_closure".into() } else { "serpenoid".into() })
                    }
                    toml::Value::Array(a) => toml::Value::Array(
                        a.into_iter()
                            .map(|x| match x {
                                toml::Value::Float(x) => toml::Value::Float(x * 0.7 + 5.0),
                                other => other,
                            })
                            .collect(),
                    ),
                    other => other,
                };
                (key, changed)
            })
            .collect()
    }

    fn with_key(config: &Config, key: &str, value: &toml::Value) -> Config {
        let mut table = toml::Table::try_from(config).expect("config as TOML");
        let mut parts: Vec<&str> = key.split('.').collect();
        let leaf = parts.pop().expect("a key");
        let mut t = &mut table;
        for p in parts {
            t = t.get_mut(p).and_then(toml::Value::as_table_mut).expect("section");
        }
        t.insert(leaf.into(), value.clone());
        table.try_into().expect("config from TOML")
    }

    /// The controller × actuator kind × gait kind × gait key matrix: a key is reported as unused
    /// exactly when changing it leaves every command of the controller unchanged.
    #[test]
    #[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
    fn unused_gait_keys_are_exactly_the_ones_that_change_no_command() {
        let mut checked = 0;
        let mut mismatches = Vec::new();
        let mut matrix = Vec::new();
        for controller in [
            ControllerKind::Gait,
            ControllerKind::PathFollowing,
            ControllerKind::FollowTheLeaderReflex,
            ControllerKind::DirectionalAdmittance,
            ControllerKind::JamResolution,
        ] {
            // (Integrated velocity takes the same set-points as velocity in every controller.)
            for method in [ControlMethod::Position, ControlMethod::Velocity, ControlMethod::Torque] {
                for kind in [
                    GaitKind::SineWave,
                    GaitKind::Serpenoid,
                    GaitKind::FormClosure,
                    GaitKind::None,
                    GaitKind::Sidewinding,
                    GaitKind::Rolling,
                ] {
                    let mut base = Config::default();
                    base.control.controller = controller;
                    base.control.method = method;
                    base.gait.kind = kind;
                    if matches!(kind, GaitKind::Sidewinding | GaitKind::Rolling) {
                        base.snake.joint_axes = JointAxes::Alternating;
                    }
                    let reference = commands(&base);
                    for (key, value) in gait_keys(&base) {
                        let changed = with_key(&base, &key, &value);
                        let used = commands(&changed) != reference;
                        let reported = unused_keys(&changed).iter().any(|u| u.key == key);
                        checked += 1;
                        if used == reported {
                            mismatches.push(format!(
                                "{} / {method:?} / gait.kind = {}: {key} {} but is {}",
                                controller_name(controller),
                                kind_name(kind),
                                if used { "changes the commands" } else { "changes no command" },
                                if reported { "reported as unused" } else { "not reported" }
                            ));
                        }
                        if !used && method == ControlMethod::Position && kind == GaitKind::SineWave {
                            matrix.push(format!("{}: {key}", controller_name(controller)));
                        }
                    }
                }
            }
        }
        assert!(checked > 1000, "{checked} cases");
        assert!(mismatches.is_empty(), "{} of {checked} cases wrong:\n{}", mismatches.len(), mismatches.join("\n"));
        // The case the module documentation names: the default path following ignores the offset.
        assert!(matrix.contains(&"path_following: gait.sine_wave.offset_deg".to_string()), "{matrix:?}");
    }

    #[test]
    fn a_snake_without_a_gait_at_rest_is_named_as_still() {
        assert_eq!(nothing_moves(&Config::default()), None);
        let mut c = Config::default();
        c.control.controller = ControllerKind::Gait;
        c.gait.kind = GaitKind::None;
        assert!(nothing_moves(&c).is_some_and(|s| s.contains("lies still for the 20 s")));
        c.initial_state.linear_velocity_m_per_s = [1.0, 0.0, 0.0];
        assert_eq!(nothing_moves(&c), None);
    }

    #[test]
    fn defaults_report_nothing_and_a_falling_back_controller_is_reported() {
        assert!(unused_keys(&Config::default()).is_empty(), "{:?}", unused_keys(&Config::default()));
        let mut c = Config::default();
        c.gait.kind = GaitKind::Serpenoid;
        c.path_following.heading_gain = 2.0;
        let unused = unused_keys(&c);
        let keys: Vec<&str> = unused.iter().map(|u| u.key.as_str()).collect();
        // The default controller falls back silently (as the default config says); its keys do not.
        assert_eq!(keys, ["path_following.heading_gain"], "{unused:?}");
        c.control.controller = ControllerKind::JamResolution;
        let unused = unused_keys(&c);
        assert_eq!(unused[0].key, "control.controller", "{unused:?}");
        assert!(unused[0].to_string().contains("needs gait.kind = \"sine_wave\""), "{}", unused[0]);
        let mut c = Config::default();
        c.gait.sine_wave.offset_deg = 10.0;
        assert_eq!(
            unused_keys(&c).iter().map(ToString::to_string).collect::<Vec<_>>(),
            ["gait.sine_wave.offset_deg = 10.0 has no effect: control.controller = \"path_following\" sets the joint \
              offset itself (its heading control, at most path_following.max_offset_deg = 20); use \
              control.controller = \"gait\" for an open-loop turn"]
        );
    }
}
