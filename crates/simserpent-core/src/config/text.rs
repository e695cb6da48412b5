//! Small text helpers of the config's messages: key paths, did-you-mean suggestions, TOML
//! numbers, and the value at a key path of a TOML table. The lowest module of `config`: every
//! other one may use it.

use toml::{Table, Value};

/// `prefix.key`, or `key` at the top level.
pub(crate) fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() { key.to_string() } else { format!("{prefix}.{key}") }
}

/// The closest candidate to `word`, if one is reasonably close.
pub(crate) fn suggest<'a>(word: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let word_lower = word.to_ascii_lowercase();
    let mut best: Option<(f64, &'a str)> = None;
    for &candidate in candidates {
        let cand_lower = candidate.to_ascii_lowercase();
        let ndl = strsim::normalized_damerau_levenshtein(&word_lower, &cand_lower);
        let jw = strsim::jaro_winkler(&word_lower, &cand_lower);
        let contains = word_lower.len() >= 3 && (cand_lower.contains(&word_lower) || word_lower.contains(&cand_lower));
        if ndl >= 0.6 || jw >= 0.85 || contains {
            let score = ndl.max(jw);
            if best.is_none_or(|(s, _)| score > s) {
                best = Some((score, candidate));
            }
        }
    }
    best.map(|(_, c)| c)
}

/// The value at a serde path like `snake.torque_range_nm[1]`.
pub(crate) fn lookup<'a>(table: &'a Table, path: &str) -> Option<&'a Value> {
    let mut current: Option<&Value> = None;
    for segment in path.split('.') {
        let (name, indices) = match segment.find('[') {
            Some(i) => (&segment[..i], &segment[i..]),
            None => (segment, ""),
        };
        current = match current {
            None => table.get(name),
            Some(Value::Table(t)) => t.get(name),
            Some(_) => None,
        };
        for index in indices.split('[').filter(|s| !s.is_empty()) {
            let index: usize = index.trim_end_matches(']').parse().ok()?;
            current = current.and_then(|v| v.as_array()).and_then(|a| a.get(index));
        }
        current?;
    }
    current
}

/// A float as TOML writes it (`1.0`, `nan`, `inf`).
pub(crate) fn fmt_f(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{v:?}")
    }
}

/// An array of floats as TOML writes it, for a message: whole up to 8 elements, else its first 8
/// and its length (so a message costs the same for any length, and validating a long list stays
/// linear in its length).
pub(crate) fn fmt_a(values: &[f64]) -> String {
    const SHOWN: usize = 8;
    let head = values.iter().take(SHOWN).map(|v| fmt_f(*v)).collect::<Vec<_>>().join(", ");
    if values.len() > SHOWN { format!("[{head}, … ({} values)]", values.len()) } else { format!("[{head}]") }
}
