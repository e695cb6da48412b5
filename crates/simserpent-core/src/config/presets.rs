//! Config presets of real robots (`simserpent init --preset NAME`): partial config files, merged
//! onto the embedded default like any user config, with their sources cited in the file.

/// `(name, one-line description, TOML text)` of every preset.
pub const CONFIG_PRESETS: [(&str, &str, &str); 1] =
    [("boa", "NTNU's planar snake robot Boa (sources and unpublished figures in the file)", BOA_TOML)];

/// The Boa preset.
pub const BOA_TOML: &str = include_str!("presets/boa.toml");

/// The TOML text of preset `name`, if there is one.
pub fn config_preset(name: &str) -> Option<&'static str> {
    CONFIG_PRESETS.iter().find(|(n, _, _)| *n == name).map(|(_, _, text)| *text)
}

/// The preset names, comma-separated (for messages).
pub fn config_preset_names() -> String {
    CONFIG_PRESETS.iter().map(|(n, _, _)| *n).collect::<Vec<_>>().join(", ")
}
