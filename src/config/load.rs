//! Placeholder: being rewritten (merge onto default, overrides, unknown keys, legacy JSON).
use super::{Config, ConfigError, DEFAULT_CONFIG_TOML};
use std::path::Path;

/// Which syntax a config text is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigSource {
    /// SimSerpent's TOML.
    Toml,
    /// The original tool's `config.json` (thesis appendix 12.1).
    LegacyJson,
}

/// Loads, merges, overrides and validates a config file.
pub fn load_config(path: &Path, overrides: &[String]) -> Result<Config, ConfigError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ConfigError::Io { file: path.display().to_string(), message: e.to_string() })?;
    load_config_str(&text, ConfigSource::Toml, overrides)
}

/// Same as [`load_config`] on a string.
pub fn load_config_str(text: &str, _source: ConfigSource, _overrides: &[String]) -> Result<Config, ConfigError> {
    let _ = text;
    toml::from_str(DEFAULT_CONFIG_TOML).map_err(|e| ConfigError::Syntax { file: "default".into(), message: e.to_string() })
}

/// Parses `key.path=value`.
pub fn parse_override(s: &str) -> Result<(String, toml::Value), ConfigError> {
    Err(ConfigError::Syntax { file: s.into(), message: "todo".into() })
}
