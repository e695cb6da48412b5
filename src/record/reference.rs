//! The user guide's reference of the output tables, generated from the column specification
//! ([`super::columns`]), so that it lists exactly what a run writes.
//!
//! Which `[recording]` switch a group of columns depends on is found by asking the group itself:
//! with every switch on, each boolean switch in turn is turned off, and a group that disappears
//! depends on it.

use super::ColumnKind;
use super::columns::{Group, Per, Rows, TABLES, TableSpec, Wanted};
use crate::config::Recording;
use std::fmt::Write as _;

/// Every boolean switch of `[recording]`, by name, and a `Recording` with all of them on.
fn switches() -> (Recording, Vec<(String, Recording)>) {
    let base = crate::config::Config::default().recording;
    let mut value = toml::Value::try_from(&base).expect("[recording] serialises");
    let table = value.as_table_mut().expect("[recording] is a table");
    let names: Vec<String> = table.iter().filter(|(_, v)| v.is_bool()).map(|(k, _)| k.clone()).collect();
    for name in &names {
        table.insert(name.clone(), toml::Value::Boolean(true));
    }
    let all_on: Recording = value.clone().try_into().expect("[recording] deserialises");
    let off = names
        .into_iter()
        .map(|name| {
            let mut v = value.clone();
            v.as_table_mut().expect("table").insert(name.clone(), toml::Value::Boolean(false));
            let r: Recording = v.try_into().expect("[recording] deserialises");
            (name, r)
        })
        .collect();
    (all_on, off)
}

/// When `on` holds, in words: the switches it needs (besides `recording.enabled`).
fn condition(on: fn(Wanted<'_>) -> bool, all_on: &Recording, off: &[(String, Recording)]) -> String {
    let full = Wanted { flags: all_on, surfaces: true, estimation: true };
    if !on(full) {
        return "never".into();
    }
    let mut needs: Vec<String> = off
        .iter()
        .filter(|(name, _)| name != "enabled")
        .filter(|(_, flags)| !on(Wanted { flags, surfaces: true, estimation: true }))
        .map(|(name, _)| format!("`recording.{name}`"))
        .collect();
    if !on(Wanted { flags: all_on, surfaces: false, estimation: true }) {
        needs.push("floor surfaces (`[[ground.surfaces]]`)".into());
    }
    if !on(Wanted { flags: all_on, surfaces: true, estimation: false }) {
        needs.push("`estimation.enabled`".into());
    }
    if needs.is_empty() { "always".into() } else { needs.join(", ") }
}

/// The unit a column name ends with, in words.
fn unit(name: &str) -> &'static str {
    const UNITS: [(&str, &str); 12] = [
        ("_m_per_s2", "m/s²"),
        ("_rad_per_s2", "rad/s²"),
        ("_m_per_s", "m/s"),
        ("_rad_per_s", "rad/s"),
        ("_nm", "N·m"),
        ("_n", "N"),
        ("_rad", "rad"),
        ("_m", "m"),
        ("_s", "s"),
        ("_qw", "1 (quaternion)"),
        ("_qx", "1 (quaternion)"),
        ("_qy", "1 (quaternion)"),
    ];
    if name.ends_with("_qz") {
        return "1 (quaternion)";
    }
    UNITS.iter().find(|(suffix, _)| name.ends_with(suffix)).map_or("", |(_, u)| u)
}

fn kind(kind: ColumnKind) -> &'static str {
    match kind {
        ColumnKind::Float => "float",
        ColumnKind::Int => "integer",
        ColumnKind::Text => "text",
    }
}

/// The names of a group, with the placeholder prefix of its section.
fn names(group: &Group, per: Per) -> Vec<String> {
    let prefix = match per {
        Per::Row => "",
        Per::Link => "link_NN",
        Per::Joint => "joint_NN",
    };
    let mut out = Vec::new();
    group.names.push_to(prefix, &mut out);
    out
}

fn table_section(out: &mut String, spec: &TableSpec, all_on: &Recording, off: &[(String, Recording)]) {
    let _ = writeln!(out, "## `{}`\n", spec.name);
    let rows = match spec.rows {
        Rows::One => "one row per recorded step",
        Rows::PerContact => "one row per contact per recorded step",
    };
    let _ = writeln!(
        out,
        "File `{name}.csv` (and `{name}.parquet/` with `recording.format` `\"parquet\"` or `\"both\"`): {rows}; \
         written {when}.\n",
        name = spec.name,
        when = match condition(spec.on, all_on, off).as_str() {
            "always" => "by every recorded run".to_string(),
            c => format!("when {c}"),
        }
    );
    let _ = writeln!(out, "| column | repeats | type | unit | recorded |");
    let _ = writeln!(out, "|---|---|---|---|---|");
    for section in spec.sections {
        let repeats = match section.per {
            Per::Row => "",
            Per::Link => "per link",
            Per::Joint => "per joint",
        };
        for group in section.groups {
            let when = condition(group.on, all_on, off);
            for name in names(group, section.per) {
                let _ = writeln!(out, "| `{name}` | {repeats} | {} | {} | {when} |", kind(group.kind), unit(&name));
            }
        }
    }
    out.push('\n');
}

/// The output reference page (Markdown): every table a run writes and every column, with the
/// switches that record it.
pub fn columns_markdown() -> String {
    let (all_on, off) = switches();
    let mut out = String::from(
        "# Output tables and columns\n\n\
         <!-- Generated by `simserpent doc-gen` from src/record/columns.rs: do not edit (./scripts/guide). -->\n\n\
         Every table of a run folder, column by column, in the order they are written. Units are part of \
         the names. `link_NN` is `link_00` (the head) … and `joint_NN` is `joint_01` … (joint i connects \
         link i−1 and link i). The *recorded* column names the `[recording]` switches a column needs \
         (besides `recording.enabled`); what the tables mean and how to join them: \
         [Read the outputs](../how-to/outputs.md).\n\n",
    );
    for spec in TABLES {
        table_section(&mut out, spec, &all_on, &off);
    }
    out
}
