//! Planning: the full grid, random or Latin hypercube samples, stable run ids, and the sweep
//! manifest `sweep.json`.

use super::spec::{SampleMode, SweepSpec, Values, Variation, make_value};
use super::{SweepError, argument, io_error};
use crate::config::{Config, ConfigError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use toml::Value;

/// One planned run.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedRun {
    /// Position in the full plan (stable for the same arguments).
    pub index: usize,
    /// Stable id: the run folder's name.
    pub id: String,
    /// (key, value) per varied key, in `--vary` order.
    pub params: Vec<(String, Value)>,
}

/// FNV-1a, 64 bit: a hash that is the same on every machine and Rust version.
fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// `key=value` as a `--set` argument (TOML literal).
pub(super) fn set_arg(key: &str, value: &Value) -> String {
    format!("{key}={value}")
}

/// A value for folder names and summaries: strings without quotes.
pub(super) fn plain(value: &Value) -> String {
    match value {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

fn run_id(params: &[(String, Value)], base_fingerprint: u64) -> String {
    let mut canonical: Vec<String> = params.iter().map(|(k, v)| set_arg(k, v)).collect();
    canonical.sort();
    let hash = fnv1a(&format!("{base_fingerprint:016x}\n{}", canonical.join("\n")));
    let mut slug = String::new();
    for (key, value) in params {
        let short = key.rsplit('.').next().unwrap_or(key);
        let _ = write!(slug, "{short}-{}_", plain(value));
    }
    let mut slug: String =
        slug.chars().map(|c| if c.is_ascii_alphanumeric() || matches!(c, '-' | '.' | '_') { c } else { '_' }).collect();
    if slug.len() > 80 {
        slug.truncate(80);
        slug.push('_');
    }
    // FNV's high bits barely change between similar texts: mix them (MurmurHash3's finaliser).
    let mut h = hash;
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^= h >> 33;
    format!("{slug}{h:016x}")
}

/// The full, deterministic list of runs of a sweep, plus the resolved base config.
///
/// # Errors
/// A base config or `--vary` key that is invalid (a misspelt key fails here, before anything
/// runs; a value that is invalid only for some runs fails those runs).
pub fn plan(spec: &SweepSpec) -> Result<(Config, Vec<PlannedRun>), SweepError> {
    let base = spec.load_base(&[])?;
    if spec.variations.is_empty() {
        return Err(argument("--vary", "give at least one `--vary key.path=values`"));
    }
    for v in &spec.variations {
        if spec.variations.iter().filter(|w| w.key == v.key).count() > 1 {
            return Err(argument(&v.key, "varied twice"));
        }
        // A key both varied and set: one of the two would silently win.
        let overlaps = |k: &str| {
            k == v.key
                || v.key.strip_prefix(k).is_some_and(|r| r.starts_with('.'))
                || k.strip_prefix(v.key.as_str()).is_some_and(|r| r.starts_with('.'))
        };
        if let Some(set) = spec.overrides.iter().find(|o| o.split_once('=').is_some_and(|(k, _)| overlaps(k.trim()))) {
            return Err(argument(
                &format!("--vary {}", v.key),
                format!("`--set {set}` sets the same key; vary it or set it, not both"),
            ));
        }
        if let Values::List(list) = &v.values
            && list.is_empty()
        {
            return Err(argument(&v.key, "no values"));
        }
        // The key must exist (unknown keys fail with a did-you-mean); a value that is merely
        // out of range for this base is left to the runs.
        let probe = match &v.values {
            Values::List(list) => list[0].clone(),
            Values::Range { lo, integer, .. } => make_value(*lo, *integer),
        };
        if let Err(e) = spec.load_base(&[set_arg(&v.key, &probe)])
            && !matches!(e, ConfigError::InvalidValue { .. })
        {
            return Err(e.into());
        }
    }
    let fingerprint = fnv1a(&base.to_toml_string());
    // Integer keys (n_links, counts) get integers, float keys floats, whatever the bounds say.
    let base_table: toml::Table = base.to_toml_string().parse().unwrap_or_default();
    let mut variations = spec.variations.clone();
    for v in &mut variations {
        let mut current: Option<&Value> = None;
        for segment in v.key.split('.') {
            current = match current {
                None => base_table.get(segment),
                Some(Value::Table(t)) => t.get(segment),
                Some(_) => None,
            };
        }
        if let (Values::Range { integer, .. }, Some(value)) = (&mut v.values, current) {
            match value {
                Value::Integer(_) => *integer = true,
                Value::Float(_) => *integer = false,
                _ => {}
            }
        }
    }
    let spec = &SweepSpec { variations, ..spec.clone() };
    let keys: Vec<&str> = spec.variations.iter().map(|v| v.key.as_str()).collect();
    let sets: Vec<Vec<Value>> = match spec.mode {
        SampleMode::Grid => {
            let axes = spec.variations.iter().map(Variation::grid).collect::<Result<Vec<_>, _>>()?;
            let total = axes.iter().try_fold(1usize, |acc, a| acc.checked_mul(a.len()));
            match total {
                Some(n) if n <= 1_000_000 => {}
                _ => return Err(argument("--vary", "the grid has more than 1000000 runs")),
            }
            let mut sets = vec![Vec::new()];
            for axis in &axes {
                sets = sets
                    .into_iter()
                    .flat_map(|prefix| {
                        axis.iter().map(move |v| {
                            let mut s = prefix.clone();
                            s.push(v.clone());
                            s
                        })
                    })
                    .collect();
            }
            sets
        }
        SampleMode::Random | SampleMode::LatinHypercube => {
            let n = spec.samples;
            if n == 0 || n > 1_000_000 {
                return Err(argument("--samples", "give 1 to 1000000 samples with --sample random|lhs"));
            }
            let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
            let mut units = vec![vec![0.0; spec.variations.len()]; n];
            if spec.mode == SampleMode::Random {
                for row in &mut units {
                    for u in row.iter_mut() {
                        *u = rng.random::<f64>();
                    }
                }
            } else {
                for k in 0..spec.variations.len() {
                    let mut strata: Vec<usize> = (0..n).collect();
                    for i in (1..n).rev() {
                        strata.swap(i, rng.random_range(0..=i));
                    }
                    for (row, stratum) in units.iter_mut().zip(strata) {
                        row[k] = (stratum as f64 + rng.random::<f64>()) / n as f64;
                    }
                }
            }
            units.iter().map(|row| spec.variations.iter().zip(row).map(|(v, u)| v.sample(*u)).collect()).collect()
        }
    };
    let mut runs = Vec::with_capacity(sets.len());
    let mut seen = std::collections::HashSet::new();
    for values in sets {
        let params: Vec<(String, Value)> = keys.iter().map(|k| k.to_string()).zip(values).collect();
        let id = run_id(&params, fingerprint);
        // Equal parameter sets (e.g. integer samples) are one run.
        if seen.insert(id.clone()) {
            runs.push(PlannedRun { index: runs.len(), id, params });
        }
    }
    Ok((base, runs))
}

/// The default sweep folder: `<general.output_dir>/sweep-<config file stem or "default">`.
pub fn default_sweep_dir(spec: &SweepSpec, base: &Config) -> PathBuf {
    let stem = spec
        .config_path
        .as_ref()
        .and_then(|p| p.file_stem())
        .map_or("default".to_string(), |s| s.to_string_lossy().into_owned());
    Path::new(&base.general.output_dir).join(format!("sweep-{stem}"))
}

/// `sweep.json`: what the sweep is (arguments and every planned run), for people and for merges.
///
/// The fields are in alphabetical order, and so are the parameters of a run: the order the
/// file has always had.
#[derive(Serialize)]
struct SweepManifest<'a> {
    /// The base config file (`null`: the embedded default).
    config: Option<String>,
    /// `Grid`, `Random` or `LatinHypercube`.
    mode: String,
    /// The `--set` overrides.
    overrides: &'a [String],
    /// Every planned run.
    runs: Vec<ManifestRun<'a>>,
    /// Samples asked for (random, lhs).
    samples: usize,
    /// Seed of the sampling stream.
    seed: u64,
    /// SimSerpent version.
    simserpent_version: &'static str,
    /// The varied keys, in `--vary` order.
    vary: Vec<&'a str>,
}

/// One planned run in `sweep.json`.
#[derive(Serialize)]
struct ManifestRun<'a> {
    /// The run's id (its folder's name).
    id: &'a str,
    /// Its place in the plan.
    index: usize,
    /// `key -> value` as in the summary.
    params: BTreeMap<&'a str, String>,
}

/// Writes `sweep.json` into `sweep_dir`.
pub(super) fn write_plan(spec: &SweepSpec, sweep_dir: &Path, runs: &[PlannedRun]) -> Result<(), SweepError> {
    let manifest = SweepManifest {
        config: spec.config_path.as_ref().map(|p| p.display().to_string()),
        mode: format!("{:?}", spec.mode),
        overrides: &spec.overrides,
        runs: runs
            .iter()
            .map(|r| ManifestRun {
                id: &r.id,
                index: r.index,
                params: r.params.iter().map(|(k, v)| (k.as_str(), plain(v))).collect(),
            })
            .collect(),
        samples: spec.samples,
        seed: spec.seed,
        simserpent_version: env!("CARGO_PKG_VERSION"),
        vary: spec.variations.iter().map(|v| v.key.as_str()).collect(),
    };
    let path = sweep_dir.join("sweep.json");
    let text = serde_json::to_string_pretty(&manifest)
        .map_err(|e| SweepError::Io { path: path.clone(), source: std::io::Error::other(e) })?;
    std::fs::write(&path, text + "\n").map_err(io_error(&path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv_is_stable() {
        assert_eq!(fnv1a(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a("a"), 0xaf63_dc4c_8601_ec8c);
    }
}
