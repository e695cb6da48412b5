//! What a sweep is: the `--vary` values of each key, how parameter sets are chosen, the shard,
//! and the whole [`SweepSpec`].

use super::{SweepError, argument};
use crate::config::{self, Config, ConfigError, ConfigSource};
use std::path::PathBuf;
use toml::Value;

/// The values one key takes.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// Explicit values (TOML literals).
    List(Vec<Value>),
    /// `lo:hi` or `lo:hi:step`; `integer` when both bounds were written as integers.
    Range {
        /// Lower bound.
        lo: f64,
        /// Upper bound (inclusive).
        hi: f64,
        /// Grid step (needed for grids).
        step: Option<f64>,
        /// Integer values only.
        integer: bool,
    },
}

/// One `--vary key.path=SPEC`.
#[derive(Debug, Clone, PartialEq)]
pub struct Variation {
    /// Dotted config key, as in the config file.
    pub key: String,
    /// Its values.
    pub values: Values,
}

/// A value as `--vary` (and `--set`) reads it: a TOML literal, or a bare word taken as a string.
pub(super) fn parse_value(text: &str) -> Value {
    config::parse_override(&format!("x={text}")).map(|(_, v)| v).unwrap_or_else(|_| Value::String(text.to_string()))
}

/// The number a TOML integer or float holds.
pub(super) fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Integer(i) => Some(*i as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    }
}

impl Variation {
    /// Parses `key.path=5,10,15`, `key.path=0.5:2.0:0.5` or `key.path=0.5:2.0`.
    ///
    /// # Errors
    /// [`SweepError::Argument`] naming the argument.
    pub fn parse(arg: &str) -> Result<Self, SweepError> {
        let Some((key, spec)) = arg.split_once('=') else {
            return Err(argument(arg, "expected `key.path=v1,v2,...`, `key.path=lo:hi:step` or `key.path=lo:hi`"));
        };
        let (key, spec) = (key.trim(), spec.trim());
        // The key syntax is that of `--set`.
        config::parse_override(&format!("{key}=0")).map_err(|e| argument(arg, e.to_string()))?;
        if spec.is_empty() {
            return Err(argument(arg, "no values after `=`"));
        }
        let is_range = spec.contains(':') && !spec.starts_with(['"', '\'', '[', '{']);
        if is_range {
            let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
            if !(2..=3).contains(&parts.len()) {
                return Err(argument(arg, "a range is `lo:hi` or `lo:hi:step`"));
            }
            let values: Vec<Value> = parts.iter().map(|p| parse_value(p)).collect();
            let nums: Option<Vec<f64>> = values.iter().map(number).collect();
            let Some(nums) = nums.filter(|n| n.iter().all(|x| x.is_finite())) else {
                return Err(argument(arg, "range bounds and step must be finite numbers"));
            };
            let (lo, hi) = (nums[0], nums[1]);
            if hi < lo {
                return Err(argument(arg, format!("range {lo}:{hi} has its upper bound below its lower bound")));
            }
            let step = nums.get(2).copied();
            if step.is_some_and(|s| s <= 0.0) {
                return Err(argument(arg, "the step of a range must be > 0"));
            }
            let integer = values[..2].iter().all(|v| matches!(v, Value::Integer(_)))
                && values.get(2).is_none_or(|v| matches!(v, Value::Integer(_)));
            return Ok(Self { key: key.to_string(), values: Values::Range { lo, hi, step, integer } });
        }
        let values: Vec<Value> = split_list(spec).iter().map(|p| parse_value(p)).collect();
        Ok(Self { key: key.to_string(), values: Values::List(values) })
    }

    /// The grid values.
    pub(super) fn grid(&self) -> Result<Vec<Value>, SweepError> {
        match &self.values {
            Values::List(v) => Ok(v.clone()),
            Values::Range { lo, hi, step, integer } => {
                let Some(step) = step else {
                    return Err(argument(
                        &self.key,
                        "a grid needs a step (`lo:hi:step`); `lo:hi` ranges are for --sample random|lhs",
                    ));
                };
                // Counted as a float before any cast: a range of 1e308 over a step of 1e-300
                // has more values than any integer holds.
                let steps = ((hi - lo) / step + 1e-9).floor();
                if steps.is_nan() || steps >= 1_000_000.0 {
                    return Err(argument(&self.key, format!("{:e} values; at most 1000000 per key", steps + 1.0)));
                }
                let n = steps as u64 + 1;
                Ok((0..n).map(|i| make_value(lo + i as f64 * step, *integer)).collect())
            }
        }
    }

    /// The value at unit position `u` in [0, 1).
    pub(super) fn sample(&self, u: f64) -> Value {
        match &self.values {
            Values::List(v) => v[((u * v.len() as f64) as usize).min(v.len().saturating_sub(1))].clone(),
            Values::Range { lo, hi, integer: true, .. } => {
                let x = (lo + u * (hi - lo + 1.0)).floor().min(*hi);
                make_value(x, true)
            }
            Values::Range { lo, hi, .. } => make_value(lo + u * (hi - lo), false),
        }
    }
}

/// Splits `a,b,[1,2],"x,y"` at the commas that are outside brackets and quotes.
fn split_list(spec: &str) -> Vec<String> {
    let (mut out, mut current, mut depth, mut quote) = (Vec::new(), String::new(), 0i32, None::<char>);
    for c in spec.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (None, '"' | '\'') => quote = Some(c),
            (None, '[' | '{') => depth += 1,
            (None, ']' | '}') => depth -= 1,
            (None, ',') if depth == 0 => {
                out.push(current.trim().to_string());
                current.clear();
                continue;
            }
            _ => {}
        }
        current.push(c);
    }
    out.push(current.trim().to_string());
    out.retain(|s| !s.is_empty());
    out
}

pub(super) fn make_value(x: f64, integer: bool) -> Value {
    if integer {
        Value::Integer(x.round() as i64)
    } else {
        // Remove the float noise of lo + i*step (0.30000000000000004).
        let rounded = (x * 1e12).round() / 1e12;
        Value::Float(if rounded.is_finite() { rounded } else { x })
    }
}

/// How the parameter sets are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleMode {
    /// Every combination.
    Grid,
    /// Independent uniform samples.
    Random,
    /// Latin hypercube: each key's range cut into `samples` strata, each stratum used once.
    LatinHypercube,
}

impl std::str::FromStr for SampleMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "grid" => Ok(Self::Grid),
            "random" => Ok(Self::Random),
            "lhs" => Ok(Self::LatinHypercube),
            other => Err(format!("unknown sample mode `{other}`; allowed: grid, random, lhs")),
        }
    }
}

/// `--shard i/n`: this process runs the runs with `index % n == i` (0 <= i < n).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard (0-based).
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let err = || format!("`{s}`: expected `i/n` with 0 <= i < n, e.g. `0/4` (Slurm: $SLURM_ARRAY_TASK_ID/N)");
        let (i, n) = s.split_once('/').ok_or_else(err)?;
        let (index, count): (usize, usize) =
            (i.trim().parse().map_err(|_| err())?, n.trim().parse().map_err(|_| err())?);
        if count == 0 || index >= count {
            return Err(err());
        }
        Ok(Self { index, count })
    }
}

/// A whole sweep.
#[derive(Debug, Clone)]
pub struct SweepSpec {
    /// Base config file (`None`: the embedded default).
    pub config_path: Option<PathBuf>,
    /// `--set` overrides applied to the base before the variations.
    pub overrides: Vec<String>,
    /// The varied keys.
    pub variations: Vec<Variation>,
    /// Grid or sampling.
    pub mode: SampleMode,
    /// Number of samples (random, lhs).
    pub samples: usize,
    /// Seed of the sampling stream.
    pub seed: u64,
    /// The sweep folder (`None`: `<general.output_dir>/sweep-<name>`).
    pub sweep_dir: Option<PathBuf>,
    /// Worker threads (0: all cores).
    pub threads: usize,
    /// Only this shard.
    pub shard: Option<Shard>,
    /// Show a progress bar (only on a terminal).
    pub progress: bool,
}

impl SweepSpec {
    /// The base config with the `--set` overrides, then `extra` (`--set` arguments too).
    pub(crate) fn load_base(&self, extra: &[String]) -> Result<Config, ConfigError> {
        let overrides: Vec<String> = self.overrides.iter().chain(extra).cloned().collect();
        match &self.config_path {
            Some(path) => config::load_config(path, &overrides),
            None => config::load_config_str(config::DEFAULT_CONFIG_TOML, ConfigSource::Toml, &overrides),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_lists_and_ranges() {
        let v = Variation::parse("snake.n_links=5,10,15").expect("list");
        assert_eq!(v.values, Values::List(vec![Value::Integer(5), Value::Integer(10), Value::Integer(15)]));
        let v = Variation::parse("gait.sine_wave.frequency_hz=0.5:2.0:0.5").expect("range");
        let grid = v.grid().expect("grid");
        assert_eq!(grid, [0.5, 1.0, 1.5, 2.0].map(Value::Float).to_vec());
        let v = Variation::parse("general.timestep_secs=0.1:0.3:0.1").expect("range");
        assert_eq!(v.grid().expect("grid"), [0.1, 0.2, 0.3].map(Value::Float).to_vec());
        let v = Variation::parse("control.method=torque,position").expect("words");
        assert_eq!(v.values, Values::List(vec![Value::String("torque".into()), Value::String("position".into())]));
        let v = Variation::parse("snake.torque_range_nm=[-1.0, 1.0],[-2.0, 2.0]").expect("arrays");
        assert!(matches!(&v.values, Values::List(l) if l.len() == 2));
        assert!(Variation::parse("snake.n_links").is_err());
        assert!(Variation::parse("snake.n_links=5:1").is_err());
        assert!(Variation::parse("snake.n_links=1:5:0").is_err());
        assert!(Variation::parse("snake.n_links=1:5").expect("range").grid().is_err());
    }

    #[test]
    fn integer_ranges_sample_integers_within_bounds() {
        let v = Variation::parse("snake.n_links=3:6").expect("range");
        for u in [0.0, 0.24, 0.25, 0.5, 0.99999] {
            let Value::Integer(i) = v.sample(u) else { panic!("not an integer") };
            assert!((3..=6).contains(&i));
        }
        assert_eq!(v.sample(0.0), Value::Integer(3));
        assert_eq!(v.sample(0.99), Value::Integer(6));
    }

    #[test]
    fn shard_syntax() {
        assert_eq!("1/4".parse::<Shard>(), Ok(Shard { index: 1, count: 4 }));
        assert!("4/4".parse::<Shard>().is_err());
        assert!("0/0".parse::<Shard>().is_err());
        assert!("x".parse::<Shard>().is_err());
    }
}
