//! Loading a config: parse, check keys against the embedded default, merge, override,
//! deserialize with key paths, validate.
//!
//! Every step reports the full key path of the problem (`snake.n_links`), the value as written
//! and what is allowed; misspelt keys get a did-you-mean suggestion.

use super::legacy::LegacyConversion;
use super::text::{join, lookup, suggest};
use super::{Config, ConfigError, DEFAULT_CONFIG_TOML, legacy};
use std::path::Path;
use toml::{Table, Value};

/// Which syntax a config text is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigSource {
    /// SimSerpent's TOML.
    Toml,
    /// The original tool's `config.json` (thesis appendix 12.1).
    LegacyJson,
}

/// Name used in errors when the config text did not come from a file.
const TEXT_NAME: &str = "<config text>";

/// Loads, merges, overrides and validates a config file.
///
/// The syntax is chosen by the file extension: `.toml` is SimSerpent's format, `.json` the
/// original tool's `config.json` (converted, see the `legacy` module). `overrides` are
/// `key.path=value` strings (`--set`), applied in order after the file.
///
/// # Errors
/// [`ConfigError::Io`] when the file cannot be read, [`ConfigError::Syntax`] for an unsupported
/// extension or a parse error, [`ConfigError::UnknownKey`] / [`ConfigError::InvalidValue`] for
/// keys and values.
pub fn load_config(path: &Path, overrides: &[String]) -> Result<Config, ConfigError> {
    let file = path.display().to_string();
    let extension = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    let source = match extension.as_deref() {
        Some("toml") => ConfigSource::Toml,
        Some("json") => ConfigSource::LegacyJson,
        other => {
            let found = match other {
                Some(ext) => format!("extension `.{ext}`"),
                None => "no extension".to_string(),
            };
            return Err(ConfigError::Syntax {
                file,
                message: format!(
                    "unsupported config file type ({found}); allowed: `.toml` (SimSerpent config) \
                     or `.json` (the original tool's config.json)"
                ),
            });
        }
    };
    // A regular file of at most MAX_CONFIG_BYTES (not /dev/zero, a FIFO or a folder).
    let bytes = super::files::read_regular_file(path, super::files::MAX_CONFIG_BYTES)
        .map_err(|e| ConfigError::Io { file: path.to_path_buf(), source: std::io::Error::other(e).into() })?;
    let text = utf8_text(&file, bytes)?;
    let base = path.parent().filter(|p| !p.as_os_str().is_empty());
    load_named(&text, source, overrides, &file, base)
}

/// The text of a config file, or [`ConfigError::Syntax`] naming the first byte that is not
/// UTF-8: its offset, line and column.
pub(crate) fn utf8_text(file: &str, bytes: Vec<u8>) -> Result<String, ConfigError> {
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let at = e.utf8_error().valid_up_to();
        let before = &bytes[..at];
        let line = before.iter().filter(|b| **b == b'\n').count() + 1;
        let line_start = before.iter().rposition(|b| *b == b'\n').map_or(0, |i| i + 1);
        let column = String::from_utf8_lossy(&before[line_start..]).chars().count() + 1;
        let byte = bytes.get(at).map_or_else(String::new, |b| format!(" 0x{b:02X}"));
        ConfigError::Syntax {
            file: file.to_string(),
            message: format!(
                "the file is not valid UTF-8 text: byte{byte} at byte offset {at} (line {line}, column {column}) \
                 is not part of a UTF-8 character; save the file as UTF-8"
            ),
        }
    })
}

/// The config keys that name files (`terrain.…`), with `[]` for every element of an array.
pub const FILE_KEYS: [&str; 4] =
    ["terrain.include_mjcf", "terrain.heightfield.file", "terrain.mesh_terrain.file", "terrain.mesh_obstacles[].file"];

/// Rewrites the relative, non-empty file paths of `user` (a config file's own table) as paths
/// relative to `base`, the config file's folder, so that a config finds its files from anywhere.
fn resolve_file_paths(user: &mut Table, base: &Path) {
    fn fix(value: &mut Value, base: &Path) {
        if let Value::String(s) = value
            && !s.is_empty()
            && Path::new(s.as_str()).is_relative()
        {
            *s = base.join(s.as_str()).display().to_string();
        }
    }
    fn walk(table: &mut Table, segments: &[&str], leaf_in_array: Option<&str>, base: &Path) {
        let Some((first, rest)) = segments.split_first() else { return };
        let Some(value) = table.get_mut(*first) else { return };
        match (rest.is_empty(), value, leaf_in_array) {
            (false, Value::Table(sub), _) => walk(sub, rest, leaf_in_array, base),
            (true, Value::Array(items), Some(leaf)) => {
                for item in items {
                    if let Value::Table(t) = item
                        && let Some(v) = t.get_mut(leaf)
                    {
                        fix(v, base);
                    }
                }
            }
            (true, v, None) => fix(v, base),
            _ => {}
        }
    }
    for key in FILE_KEYS {
        let (path, leaf_in_array) = match key.split_once("[]") {
            Some((array, leaf)) => (array, Some(leaf.trim_start_matches('.'))),
            None => (key, None),
        };
        let segments: Vec<&str> = path.split('.').collect();
        walk(user, &segments, leaf_in_array, base);
    }
}

/// Converts the original tool's `config.json` text (`file` names it in errors) into SimSerpent's
/// layout, with a note per key (see [`LegacyConversion`]); the keys are checked when the table is
/// loaded.
///
/// # Errors
/// [`ConfigError::Syntax`] for invalid JSON, [`ConfigError::UnknownKey`] /
/// [`ConfigError::InvalidValue`] (legacy key names) for keys and values the conversion rejects.
pub fn convert_legacy_text(text: &str, file: &str) -> Result<LegacyConversion, ConfigError> {
    let json: serde_json::Value = serde_json::from_str(text).map_err(|e| legacy::json_error(file, text, &e))?;
    // serde_json keeps the last of two equal keys; a config naming a key twice is refused, as TOML does.
    if let Err(e) = serde_json::from_str::<UniqueKeys>(text) {
        return Err(ConfigError::Syntax {
            file: file.to_string(),
            message: format!("{e}: a JSON config must name each key once (the value would be ambiguous)"),
        });
    }
    legacy::convert(&json, &default_table()?)
}

/// A JSON value whose objects name each key once (deserializing it fails at the second one).
struct UniqueKeys;

impl<'de> serde::Deserialize<'de> for UniqueKeys {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = UniqueKeys;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a JSON value")
            }
            fn visit_bool<E>(self, _: bool) -> Result<UniqueKeys, E> {
                Ok(UniqueKeys)
            }
            fn visit_i64<E>(self, _: i64) -> Result<UniqueKeys, E> {
                Ok(UniqueKeys)
            }
            fn visit_u64<E>(self, _: u64) -> Result<UniqueKeys, E> {
                Ok(UniqueKeys)
            }
            fn visit_f64<E>(self, _: f64) -> Result<UniqueKeys, E> {
                Ok(UniqueKeys)
            }
            fn visit_str<E>(self, _: &str) -> Result<UniqueKeys, E> {
                Ok(UniqueKeys)
            }
            fn visit_unit<E>(self) -> Result<UniqueKeys, E> {
                Ok(UniqueKeys)
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<UniqueKeys, A::Error> {
                while seq.next_element::<UniqueKeys>()?.is_some() {}
                Ok(UniqueKeys)
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<UniqueKeys, A::Error> {
                let mut keys = std::collections::HashSet::new();
                while let Some(key) = map.next_key::<String>()? {
                    if !keys.insert(key.clone()) {
                        return Err(serde::de::Error::custom(format!("duplicate key `{key}`")));
                    }
                    map.next_value::<UniqueKeys>()?;
                }
                Ok(UniqueKeys)
            }
        }
        deserializer.deserialize_any(Visitor)
    }
}

/// Reads the original tool's `config.json` at `path` and converts it (see [`convert_legacy_text`]).
///
/// # Errors
/// As [`load_config`].
pub fn convert_legacy_file(path: &Path) -> Result<LegacyConversion, ConfigError> {
    let file = path.display().to_string();
    let bytes = super::files::read_regular_file(path, super::files::MAX_CONFIG_BYTES)
        .map_err(|e| ConfigError::Io { file: path.to_path_buf(), source: std::io::Error::other(e).into() })?;
    convert_legacy_text(&utf8_text(&file, bytes)?, &file)
}

/// [`load_config`], plus the conversion of a `config.json` (`None` for TOML), for `check` and
/// `run` to say what works differently ([`LegacyConversion::difference_lines`]).
///
/// # Errors
/// As [`load_config`].
pub fn load_config_with_notes(
    path: &Path,
    overrides: &[String],
) -> Result<(Config, Option<LegacyConversion>), ConfigError> {
    let config = load_config(path, overrides)?;
    let is_json = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let conversion = if is_json { Some(convert_legacy_file(path)?) } else { None };
    Ok((config, conversion))
}

/// Same as [`load_config`] on a string; `source` says which syntax it is in.
///
/// # Errors
/// As [`load_config`], without the file-related ones.
pub fn load_config_str(text: &str, source: ConfigSource, overrides: &[String]) -> Result<Config, ConfigError> {
    load_named(text, source, overrides, TEXT_NAME, None)
}

/// Parses a `--set` argument `key.path=value`.
///
/// The value is a TOML value literal (`1`, `0.5`, `true`, `"s"`, `[1, 2]`, `{ a = 1 }`), so
/// its type is kept; a bare word that is not valid TOML (`torque`, `my-run`) is taken as a
/// string. Whitespace around the key and the value is ignored.
///
/// # Errors
/// [`ConfigError::Syntax`] (naming the argument) when there is no `=`, the key is not a dotted
/// path of bare keys, the value is missing, or the value looks like TOML but does not parse.
pub fn parse_override(s: &str) -> Result<(String, Value), ConfigError> {
    let syntax = |message: String| ConfigError::Syntax { file: format!("--set {s}"), message };
    let Some((key, value)) = s.split_once('=') else {
        return Err(syntax("expected `key.path=value`, e.g. `snake.n_links=15`".into()));
    };
    let key = key.trim();
    let value = value.trim();
    if key.is_empty() {
        return Err(syntax("missing key before `=`; expected `key.path=value`".into()));
    }
    for segment in key.split('.') {
        if segment.is_empty() || !segment.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
            return Err(syntax(format!(
                "invalid key `{key}`: expected a dotted path of keys made of letters, digits, `_` and `-`, \
                 e.g. `general.duration_secs`"
            )));
        }
    }
    if value.is_empty() {
        return Err(syntax(format!("missing value after `{key}=`")));
    }
    let parsed = match value.parse::<Value>() {
        Ok(v) => v,
        Err(e) => {
            // Values that start like a TOML string, array or inline table must be valid TOML.
            if value.starts_with(['"', '\'', '[', '{']) {
                return Err(syntax(format!("invalid value `{value}`: {}", e.message().trim())));
            }
            Value::String(value.to_string())
        }
    };
    Ok((key.to_string(), parsed))
}

/// The whole pipeline; `file` names the text in syntax errors.
fn load_named(
    text: &str,
    source: ConfigSource,
    overrides: &[String],
    file: &str,
    base: Option<&Path>,
) -> Result<Config, ConfigError> {
    let syntax =
        |message: String| ConfigError::Syntax { file: file.to_string(), message: message.trim_end().to_string() };
    let defaults = default_table()?;
    let user = match source {
        ConfigSource::Toml => {
            let mut user = text.parse::<Table>().map_err(|e| syntax(e.to_string()))?;
            if let Some(base) = base {
                resolve_file_paths(&mut user, base);
            }
            user
        }
        ConfigSource::LegacyJson => {
            let converted = convert_legacy_text(text, file)?;
            // Errors on converted values also name the config.json key they came from.
            return resolve(converted.table.clone(), &defaults, overrides)
                .map_err(|e| legacy::annotate(e, &converted, overrides));
        }
    };
    resolve(user, &defaults, overrides)
}

/// Merge onto the defaults, apply the overrides, deserialize and validate.
fn resolve(user: Table, defaults: &Table, overrides: &[String]) -> Result<Config, ConfigError> {
    let mut merged = defaults.clone();
    merge_checked(&mut merged, user, defaults, "")?;
    for item in overrides {
        let (key, value) = parse_override(item)?;
        let mut nested = value;
        for segment in key.rsplit('.') {
            let mut table = Table::new();
            table.insert(segment.to_string(), nested);
            nested = Value::Table(table);
        }
        if let Value::Table(table) = nested {
            merge_checked(&mut merged, table, defaults, "")?;
        }
    }
    let as_written = merged.clone();
    ints_to_floats_table(&mut merged, defaults);
    let config: Config = serde_path_to_error::deserialize(Value::Table(merged.clone())).map_err(|e| {
        let key = e.path().to_string();
        // A surface table whose keys are all well typed but do not make a surface: the
        // conversion names the key inside it.
        if let Some(error) = lookup(&merged, &key)
            .filter(|_| names_a_surface(&key))
            .and_then(|value| super::surfaces::conversion_error(&key, value))
        {
            return error;
        }
        let value = lookup(&as_written, &key).map_or_else(|| "(missing)".to_string(), |v| v.to_string());
        ConfigError::InvalidValue { key, value, allowed: expectation(e.inner().message()) }
    })?;
    config.validate()?;
    Ok(config)
}

/// Whether the serde path `key` names one surface table (`ground.surfaces[3]`).
fn names_a_surface(key: &str) -> bool {
    key.strip_prefix("ground.surfaces[")
        .and_then(|rest| rest.strip_suffix(']'))
        .is_some_and(|index| index.parse::<usize>().is_ok())
}

/// The embedded default config as a table.
pub(super) fn default_table() -> Result<Table, ConfigError> {
    DEFAULT_CONFIG_TOML
        .parse::<Table>()
        .map_err(|e| ConfigError::Syntax { file: "embedded default config".into(), message: e.to_string() })
}

/// Checks every key of `user` against `defaults` (the default table at the same path) and
/// deep-merges it into `target`.
fn merge_checked(target: &mut Table, user: Table, defaults: &Table, prefix: &str) -> Result<(), ConfigError> {
    for (key, value) in user {
        let path = join(prefix, &key);
        match defaults.get(&key) {
            None => return Err(unknown_key(&key, prefix, defaults)),
            Some(Value::Table(default_sub)) => match value {
                Value::Table(user_sub) => {
                    let entry = target.entry(key).or_insert_with(|| Value::Table(default_sub.clone()));
                    if !entry.is_table() {
                        *entry = Value::Table(default_sub.clone());
                    }
                    if let Value::Table(target_sub) = entry {
                        merge_checked(target_sub, user_sub, default_sub, &path)?;
                    }
                }
                other => {
                    return Err(ConfigError::invalid(
                        &path,
                        &other,
                        format!("`{path}` is a table (section) with keys: {}", allowed_keys(&path, default_sub)),
                    ));
                }
            },
            Some(_) => {
                if value.is_table() {
                    return Err(ConfigError::invalid(&path, &value, "expected a single value, not a table"));
                }
                target.insert(key, value);
            }
        }
    }
    Ok(())
}

/// The unknown-key error for `key` in the table at `prefix` (whose default is `defaults`).
fn unknown_key(key: &str, prefix: &str, defaults: &Table) -> ConfigError {
    let candidates: Vec<&str> = defaults.keys().map(String::as_str).collect();
    let suggestion = suggest(key, &candidates).map(|s| join(prefix, s)).or_else(|| {
        // The key may exist in another table (e.g. `general.n_links`).
        let mut found = Vec::new();
        if let Ok(root) = default_table() {
            find_key(&root, "", key, &mut found);
        }
        found.into_iter().next()
    });
    ConfigError::UnknownKey { key: join(prefix, key), suggestion, allowed: allowed_keys(prefix, defaults) }
}

/// Full paths of every key named `key` anywhere in `table`.
fn find_key(table: &Table, prefix: &str, key: &str, found: &mut Vec<String>) {
    for (k, v) in table {
        let path = join(prefix, k);
        if k == key {
            found.push(path.clone());
        }
        if let Value::Table(sub) = v {
            find_key(sub, &path, key, found);
        }
    }
}

/// The keys allowed in the table at `prefix`, in the order of the default file.
fn allowed_keys(prefix: &str, defaults: &Table) -> String {
    let mut keys: Vec<String> = defaults.keys().cloned().collect();
    if let Ok(doc) = toml::de::DeTable::parse(DEFAULT_CONFIG_TOML) {
        let mut table = Some(doc.get_ref());
        if !prefix.is_empty() {
            for segment in prefix.split('.') {
                table = table.and_then(|t| {
                    t.iter().find(|(k, _)| k.get_ref() == segment).and_then(|(_, v)| match v.get_ref() {
                        toml::de::DeValue::Table(sub) => Some(sub),
                        _ => None,
                    })
                });
            }
        }
        if let Some(table) = table {
            let mut entries: Vec<(usize, String)> =
                table.iter().map(|(k, _)| (k.span().start, k.get_ref().to_string())).collect();
            entries.sort();
            let ordered: Vec<String> = entries.into_iter().map(|(_, k)| k).collect();
            if ordered.len() == keys.len() {
                keys = ordered;
            }
        }
    }
    keys.join(", ")
}

/// Converts integers to floats wherever the default has a float (also inside arrays).
fn ints_to_floats_table(target: &mut Table, defaults: &Table) {
    for (key, value) in target.iter_mut() {
        if let Some(default) = defaults.get(key) {
            ints_to_floats(value, default);
        }
    }
}

fn ints_to_floats(value: &mut Value, default: &Value) {
    match (value, default) {
        (value @ Value::Integer(_), Value::Float(_)) => {
            if let Value::Integer(i) = *value {
                *value = Value::Float(i as f64);
            }
        }
        (Value::Array(items), Value::Array(default_items)) => {
            if let Some(first) = default_items.first() {
                for item in items.iter_mut() {
                    ints_to_floats(item, first);
                }
            }
        }
        (Value::Table(table), Value::Table(default_table)) => ints_to_floats_table(table, default_table),
        _ => {}
    }
}

/// Serde's expectation from its message (`invalid type: string "ten", expected f64`), in words.
fn expectation(message: &str) -> String {
    let message = message.trim();
    let Some(start) = message.find("expected") else {
        return message.to_string();
    };
    let expected = &message[start..];
    let words = match expected {
        "expected f64" | "expected f32" => "expected a number",
        "expected usize" | "expected u64" | "expected u32" => "expected a non-negative integer",
        "expected u8" => "expected an integer from 0 to 255",
        "expected i64" => "expected an integer",
        other => other,
    };
    words.to_string()
}
