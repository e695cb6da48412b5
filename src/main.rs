//! The `simserpent` command line. Exit codes: 0 success, 1 simulation failure, 2 bad input
//! (config, model or robot file, command-line usage).

use anyhow::Context;
use clap::{Parser, Subcommand};
use simserpent::config::{self, Config, ConfigError};
use simserpent::run::{self, RunError, RunOptions};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(name = "simserpent", version, about = "Physics-based snake-robot simulator on MuJoCo 3.17")]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

/// Options shared by every command that reads a config.
#[derive(clap::Args, Debug, Clone, Default)]
struct ConfigArgs {
    /// Config file: SimSerpent TOML, or the original tool's config.json. Default: the embedded
    /// default config (`simserpent init` writes it out).
    config: Option<PathBuf>,
    /// Override one key, e.g. `--set snake.n_links=15` (repeatable; TOML values).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    overrides: Vec<String>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a simulation and record it in a new run folder (the default command).
    Run {
        #[command(flatten)]
        config: ConfigArgs,
        /// Simulate your own robot (MJCF or URDF) in the configured terrain instead of the snake.
        #[arg(long, value_name = "FILE")]
        robot: Option<PathBuf>,
        /// Never show a progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Write the fully commented default config.
    Init {
        /// Where to write it.
        #[arg(default_value = "config.toml")]
        path: PathBuf,
        /// Overwrite an existing file.
        #[arg(long)]
        force: bool,
    },
    /// Write the MJCF model that a config generates (to stdout, or to --output).
    Model {
        #[command(flatten)]
        config: ConfigArgs,
        /// Output file.
        #[arg(long, short)]
        output: Option<PathBuf>,
    },
    /// Check a config and print it fully resolved, without running anything.
    Check {
        #[command(flatten)]
        config: ConfigArgs,
    },
    /// Measure steps per second: bare engine against the full pipeline (see BENCHMARKS.md).
    Bench {
        #[command(flatten)]
        config: ConfigArgs,
        /// Snake sizes to measure.
        #[arg(long, value_delimiter = ',', default_value = "10,30")]
        links: Vec<usize>,
        /// Simulated seconds per measurement.
        #[arg(long, default_value_t = 20.0)]
        duration_secs: f64,
        /// Where the full-pipeline runs are recorded.
        #[arg(long, default_value = "target/bench-runs")]
        output_dir: String,
    },
}

/// An error that has already been given its exit code.
struct Failure {
    code: u8,
    error: anyhow::Error,
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        Self { code: 1, error: e.into() }
    }
}

fn bad_input(e: impl Into<anyhow::Error>) -> Failure {
    Failure { code: 2, error: e.into() }
}

fn load(args: &ConfigArgs) -> Result<(Config, String), Failure> {
    let result: Result<Config, ConfigError> = match &args.config {
        Some(path) => config::load_config(path, &args.overrides),
        None => config::load_config_str(config::DEFAULT_CONFIG_TOML, config::ConfigSource::Toml, &args.overrides),
    };
    let source = args.config.as_ref().map_or("embedded default".to_string(), |p| p.display().to_string());
    result
        .map(|c| (c, source.clone()))
        .map_err(|e| bad_input(anyhow::Error::new(e).context(format!("config {source}"))))
}

fn run_command(args: &ConfigArgs, robot: Option<PathBuf>, quiet: bool) -> Result<(), Failure> {
    let (config, source) = load(args)?;
    let options =
        RunOptions { config_source: source, robot, command_line: std::env::args().collect(), progress: !quiet };
    let summary =
        run::run(&config, &options).map_err(|e: RunError| Failure { code: e.exit_code(), error: e.into() })?;
    println!("run folder:        {}", summary.run_folder.display());
    println!(
        "simulated:         {:.3} s in {} steps",
        summary.simulated_secs,
        (summary.simulated_secs / config.general.timestep_secs).round()
    );
    println!(
        "distance (CoM):    {:.4} m toward {:.1} deg, mean speed {:.4} m/s",
        summary.distance_m, summary.heading_deg, summary.mean_speed_m_per_s
    );
    println!(
        "peak contact force {:.3} N, max penetration {:.3} mm (at recorded steps)",
        summary.peak_contact_force_n,
        summary.max_penetration_m * 1e3
    );
    println!(
        "speed:             {:.0} steps/s, {:.1}x real time",
        summary.steps_per_wall_sec, summary.real_time_factor
    );
    Ok(())
}

fn init(path: &Path, force: bool) -> Result<(), Failure> {
    if path.exists() && !force {
        return Err(bad_input(anyhow::anyhow!("{} exists already; use --force to overwrite it", path.display())));
    }
    std::fs::write(path, config::DEFAULT_CONFIG_TOML).with_context(|| format!("cannot write {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

fn model(args: &ConfigArgs, output: Option<&Path>) -> Result<(), Failure> {
    let (config, _) = load(args)?;
    let generated = simserpent::model::generate(&config).map_err(bad_input)?;
    match output {
        Some(path) => {
            std::fs::write(path, &generated.xml).with_context(|| format!("cannot write {}", path.display()))?;
            eprintln!("wrote {}", path.display());
        }
        None => print!("{}", generated.xml),
    }
    Ok(())
}

fn bench(args: &ConfigArgs, links: &[usize], duration_secs: f64, output_dir: &str) -> Result<(), Failure> {
    let (config, source) = load(args)?;
    let rows = simserpent::bench::run_bench(&config, links, duration_secs, output_dir)
        .map_err(|e| Failure { code: e.exit_code(), error: e.into() })?;
    println!(
        "config: {source}; timestep {} s, integrator {:?}, {} s simulated per row",
        config.general.timestep_secs, config.general.integrator, duration_secs
    );
    println!("| links | mode | steps/s | real-time factor | vs bare still | vs bare gait |");
    println!("|---|---|---|---|---|---|");
    for chunk in rows.chunks(3) {
        let (still, gait) = (chunk[0].steps_per_sec, chunk[1].steps_per_sec);
        for r in chunk {
            println!(
                "| {} | {} | {:.0} | {:.1} | {:.0}% | {:.0}% |",
                r.n_links,
                r.mode,
                r.steps_per_sec,
                r.steps_per_sec * config.general.timestep_secs,
                100.0 * r.steps_per_sec / still,
                100.0 * r.steps_per_sec / gait
            );
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    // MuJoCo's warnings go to the log instead of stdout.
    // SAFETY: called first thing in main, before any thread exists or MuJoCo is used.
    #[allow(unsafe_code)]
    unsafe {
        mujoco_rs::prelude::install_logging_hook();
    }
    let cli = Cli::parse();
    let result = match cli.command {
        None => run_command(&ConfigArgs::default(), None, false),
        Some(Command::Run { config, robot, quiet }) => run_command(&config, robot, quiet),
        Some(Command::Init { path, force }) => init(&path, force),
        Some(Command::Model { config, output }) => model(&config, output.as_deref()),
        Some(Command::Check { config }) => load(&config).map(|(c, _)| print!("{}", c.to_toml_string())),
        Some(Command::Bench { config, links, duration_secs, output_dir }) => {
            bench(&config, &links, duration_secs, &output_dir)
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            eprintln!("error: {:#}", failure.error);
            ExitCode::from(failure.code)
        }
    }
}
