//! Scores one controller or one open-loop wave on many of experiment `hoal`'s peg fields, the
//! way hoal scores its runs (`hoal::field_config` and `hoal::score_run`: the centre of mass's
//! speed along +x after the ramp-in, and jams = 5 s without 2 cm of new progress). The
//! obstacle-aided tables of BENCHMARKS.md are measured with it; hoal itself runs ten fields per density, this runs as many as you ask.
//!
//! ```text
//! cargo run --release --example hoal_eval -- VARIANT SEEDS DURATION_SECS [KEY=VALUE ...]
//! ```
//!
//! - `VARIANT`: `est` (`control.controller = "obstacle_aided"` with the step loop's contact
//!   estimates and default sensor noise), `true` (the same with the simulator's true contacts),
//!   or `open:A:D` (the open-loop sine wave, amplitude A°, phase lag D°).
//! - `SEEDS`: a range such as `100-139` (hoal's own fields are seeds 0–9; tune elsewhere).
//! - `KEY=VALUE`: config overrides as `--set` takes them, applied last, e.g.
//!   `control.controller="rail"` or `obstacle_aided.phase_lag_deg=-75.0`.
//!
//! Prints per density the median speed (mm/s), the jams and every field's speed, then all
//! fields together. Runs on two threads.
use anyhow::{Context, bail};
use simserpent::config::{Config, ConfigSource, ContactSource, ControllerKind, GaitKind, load_config_str};
use simserpent::experiments::hoal::{DENSITIES, field_config, median, score_run};

/// The config of one field for `variant`, with `sets` applied last.
fn field(variant: &str, density: f64, seed: u64, duration_secs: f64, sets: &[String]) -> anyhow::Result<Config> {
    let mut c = field_config(&Config::default(), density, seed);
    c.general.duration_secs = duration_secs;
    if let Some(wave) = variant.strip_prefix("open:") {
        let (a, d) = wave.split_once(':').context("open:A:D needs an amplitude and a phase lag")?;
        c.control.controller = ControllerKind::Gait;
        c.gait.kind = GaitKind::SineWave;
        c.gait.sine_wave.amplitude_deg = a.parse().with_context(|| format!("amplitude {a:?}"))?;
        c.gait.sine_wave.phase_lag_deg = d.parse().with_context(|| format!("phase lag {d:?}"))?;
        c.estimation.enabled = false;
    } else {
        let source = match variant {
            "est" => ContactSource::Estimated,
            "true" => ContactSource::True,
            other => bail!("VARIANT {other:?}: expected est, true or open:A:D"),
        };
        c.control.controller = ControllerKind::ObstacleAided;
        c.obstacle_aided.contacts = source;
        c.rail.contacts = source;
        c.estimation.enabled = source == ContactSource::Estimated;
    }
    if !sets.is_empty() {
        c = load_config_str(&toml::to_string(&c)?, ConfigSource::Toml, sets)?;
    }
    Ok(c)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [variant, seeds, duration, sets @ ..] = args.as_slice() else {
        bail!("usage: hoal_eval VARIANT SEEDS DURATION_SECS [KEY=VALUE ...] (e.g. est 100-139 15)");
    };
    let (first, last) = seeds.split_once('-').unwrap_or((seeds, seeds));
    let (first, last): (u64, u64) =
        (first.parse().context("SEEDS: e.g. 100-139")?, last.parse().context("SEEDS: e.g. 100-139")?);
    let duration_secs: f64 = duration.parse().context("DURATION_SECS: a number of seconds")?;
    let mut jobs = Vec::new();
    for (d, (_, density)) in DENSITIES.iter().enumerate() {
        for seed in first..=last {
            jobs.push((d, field(variant, *density, seed, duration_secs, sets)?));
        }
    }
    let results: Vec<(usize, f64, bool)> = std::thread::scope(|s| {
        let handles: Vec<_> = jobs
            .chunks(jobs.len().div_ceil(2).max(1))
            .map(|chunk| {
                s.spawn(move || {
                    chunk.iter().map(|(d, c)| score_run(c).map(|(v, jam)| (*d, v, jam))).collect::<Result<Vec<_>, _>>()
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("a worker thread panicked")).collect::<Result<Vec<_>, _>>()
    })?
    .into_iter()
    .flatten()
    .collect();
    let report = |name: &str, rows: Vec<&(usize, f64, bool)>| {
        let speeds: Vec<f64> = rows.iter().map(|r| 1000.0 * r.1).collect();
        let jams = rows.iter().filter(|r| r.2).count();
        let each: Vec<String> = speeds.iter().map(|v| format!("{v:.0}")).collect();
        println!(
            "{variant} {name:6}: median {:6.1} mm/s  jams {jams}/{}  mean {:.1}  [{}]",
            median(&speeds),
            speeds.len(),
            speeds.iter().sum::<f64>() / speeds.len().max(1) as f64,
            each.join(" ")
        );
    };
    for (d, (name, _)) in DENSITIES.iter().enumerate() {
        report(name, results.iter().filter(|r| r.0 == d).collect());
    }
    report("ALL", results.iter().collect());
    Ok(())
}
