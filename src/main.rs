//! The `simserpent` command line. Exit codes: 0 success, 1 simulation failure (divergence,
//! output folder or disk), 2 bad input (config, model or robot file, command-line usage),
//! 130 interrupted by SIGINT/SIGTERM (during set-up: no run folder; during the run: run folder
//! kept, manifest `incomplete`; during plotting: manifest `complete`, `plots` `interrupted`).

use anyhow::Context;
use clap::{Parser, Subcommand};
use simserpent::config::{self, Config, ConfigError};
use simserpent::run::{self, RunError, RunOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set once standard output turned out to be a closed pipe; nothing more is printed to it.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Prints a command's report to standard output.
///
/// A closed pipe (`simserpent check | head -1`, `simserpent run | true`) ends the printing
/// quietly, as Unix tools do, and the exit code stays the command's own: every command prints
/// only after its work is done (a run's tables and manifest are closed before its summary is
/// printed), so a reader that stops reading loses nothing but the text. SIGPIPE keeps Rust's
/// default action (ignored, so a write returns `EPIPE`) instead of being reset to "terminate":
/// the process then never dies in the middle of writing a run folder, nor when a pipe to a
/// child (the video encoder) closes. Any other error of standard output (a full disk behind
/// `> file`) fails the command with exit code 1.
fn say(args: std::fmt::Arguments<'_>) -> Result<(), Failure> {
    if STDOUT_CLOSED.load(Ordering::Relaxed) {
        return Ok(());
    }
    let mut out = std::io::stdout().lock();
    match out.write_fmt(args).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            STDOUT_CLOSED.store(true, Ordering::Relaxed);
            Ok(())
        }
        Err(e) => Err(anyhow::Error::new(e).context("cannot write to standard output").into()),
    }
}

/// `print!` through [`say`] (returns from the function on a real output error).
macro_rules! out {
    ($($arg:tt)*) => { say(format_args!($($arg)*))? };
}

/// `println!` through [`say`].
macro_rules! outln {
    ($($arg:tt)*) => { say(format_args!("{}\n", format_args!($($arg)*)))? };
}

/// `eprintln!` that ignores a closed standard error instead of panicking: the exit code still
/// tells what happened.
macro_rules! errln {
    ($($arg:tt)*) => {{
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

/// `--version`'s long form: the version and whether the live ROS 2 bridge (feature `ros2`) is
/// built in (python/tests/test_ros2_live.py looks for it).
#[cfg(feature = "ros2")]
const LONG_VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), "\nlive ROS 2 bridge (run --ros2): built in");
#[cfg(not(feature = "ros2"))]
const LONG_VERSION: &str =
    concat!(env!("CARGO_PKG_VERSION"), "\nlive ROS 2 bridge (run --ros2): not built (cargo feature ros2)");

#[derive(Parser, Debug)]
#[command(
    name = "simserpent",
    version,
    long_version = LONG_VERSION,
    about = "Physics-based snake-robot simulator on MuJoCo 3.17",
    after_help = "Exit codes: 0 success; 1 the simulation failed (diverged, or the run folder could not be \
                  written; the manifest says why); 2 bad input (config, model or robot file, command line; no run \
                  folder is created); 130 interrupted by Ctrl-C (SIGINT) or SIGTERM (during set-up: no run folder; during \
                  the run: tables flushed, manifest `incomplete`; during plotting: the run is complete, manifest \
                  `plots` says `interrupted`). A second signal quits at once."
)]
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
        /// Record a video of the run (sets video.enabled = true; format, rate, size and camera
        /// from [video] and [render]).
        #[arg(long)]
        video: bool,
        /// Show the run in MuJoCo's interactive viewer (needs a display). Built with
        /// `--features viewer`: live; otherwise the finished run is replayed in Python's
        /// `mujoco.viewer`.
        #[arg(long)]
        viewer: bool,
        /// Live ROS 2 bridge over DDS: publish the run's topics while it simulates and take the
        /// joint commands from ROS 2 ([ros2]: domain, QoS, clock "free" or "lockstep"; user
        /// guide, "ROS 2"). Needs a binary built with `--features ros2`.
        #[arg(long)]
        ros2: bool,
    },
    /// Plot a run folder: the standard panels as PNG and SVG into RUN_FOLDER/plots/.
    Plot {
        /// The run folder.
        run_folder: PathBuf,
    },
    /// Replay a run folder (its state.csv) into a video and/or the configured images.
    Render {
        /// The run folder.
        run_folder: PathBuf,
        /// Make the video (RUN_FOLDER/video_<camera>.mp4 or .gif).
        #[arg(long)]
        video: bool,
        /// Make the images at render.image_times_secs (RUN_FOLDER/images/).
        #[arg(long)]
        images: bool,
        /// Override a key of the run's config.toml, e.g. `--set render.camera="top"`.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        overrides: Vec<String>,
        /// Never show a progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Open MuJoCo's interactive viewer on a config's world, a model file (.xml/.urdf), or a run
    /// folder (replayed at real time). Needs a display.
    View {
        /// Config file, MJCF/URDF model or run folder. Default: the embedded default config.
        path: Option<PathBuf>,
        /// Override a config key (for a config), e.g. `--set snake.n_links=15`.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        overrides: Vec<String>,
    },
    /// Run one of the thesis' experiments with its physics checks: configure, collision,
    /// undulation, form-closure, oal, estimation, bounce (the project assignment's ball drop), oal-bench (the obstacle-aided locomotion benchmark:
    /// contact laws against open loop and passive compliance on paired peg fields). Writes runs/experiment-<name>-<UTC time>/report.md; exits 1
    /// if a check fails.
    Experiment {
        /// Which experiment.
        name: String,
        #[command(flatten)]
        config: ConfigArgs,
        /// Shorter runs (fewer gait cycles), the same checks.
        #[arg(long)]
        quick: bool,
        /// Worker threads for the experiment's cases (independent runs; default: all cores; at
        /// most 256).
        #[arg(long, default_value_t = 0, value_parser = threads_arg)]
        threads: usize,
        /// `estimation`: the seeds of the peg-field runs, scored and checked per seed, e.g.
        /// `300-309` or `3,7,11` (default 0-9; --quick: 0). `oal-bench`: the held-out seeds, one
        /// range A-B (A at least --tuning-fields; default 1000 on). At most 10000 seeds.
        #[arg(long, value_parser = parse_seeds)]
        seeds: Option<SeedList>,
        /// `estimation` only: the peg-field runs on this floor only (default both).
        #[arg(long, value_parser = ["isotropic", "anisotropic"])]
        floor: Option<String>,
        #[command(flatten)]
        oal: Box<OalArgs>,
    },
    /// Run the contact estimator on a recorded run (its config.toml, sensors.csv and links.csv,
    /// CSV, every step recorded: recording.every_n_steps = 1): writes RUN_FOLDER/estimation/ with
    /// estimates.csv (estimates next to the truth), scores.md/.csv (detection, false alarms, force
    /// RMSE, contact points) and plots/.
    Estimate {
        /// The run folder.
        run_folder: PathBuf,
        /// Override a key of the run's config.toml, e.g. `--set estimation.orientation="true"`.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        overrides: Vec<String>,
    },
    /// Write the fully commented default config, or with --preset a robot's config.
    Init {
        /// Where to write it.
        #[arg(default_value = "config.toml")]
        path: PathBuf,
        /// Overwrite an existing file.
        #[arg(long)]
        force: bool,
        /// Write a real robot's config instead (its sources cited in the file): boa.
        #[arg(long, value_name = "NAME")]
        preset: Option<String>,
    },
    /// Write the MJCF model that a config generates (to stdout, or to --output).
    Model {
        #[command(flatten)]
        config: ConfigArgs,
        /// Output file.
        #[arg(long, short)]
        output: Option<PathBuf>,
        /// Also write the model as separate files into this folder: scene.xml (open this one),
        /// terrain.xml, robot.xml, plus model.xml and the copied terrain files.
        #[arg(long)]
        scene_dir: Option<PathBuf>,
    },
    /// Convert the original tool's config.json into an annotated SimSerpent TOML: each converted
    /// key with a comment naming its config.json key, the rule and any difference from the
    /// original tool (user guide, "Use the original tool's config").
    Convert {
        /// The original tool's config.json.
        input: PathBuf,
        /// Where to write the TOML (default: standard output).
        #[arg(long, short)]
        output: Option<PathBuf>,
        /// Overwrite an existing output file.
        #[arg(long)]
        force: bool,
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
        /// Measure each mode this many times (interleaved) and report the fastest (1 to 1000).
        #[arg(long, default_value_t = 1, value_parser = repeats_arg)]
        repeats: usize,
        /// Print the results as one JSON document (settings, steps/s, ratio full pipeline /
        /// bare engine with the same gait) instead of a table.
        #[arg(long)]
        json: bool,
        /// Also measure the full pipeline with the files written on the step-loop thread
        /// (the synchronous path) instead of on writer threads, interleaved with the others.
        #[arg(long)]
        inline_writers: bool,
        /// Also measure the CSV pipeline with writer threads that drop the rows unwritten (a
        /// dummy sink): the step-loop thread's CPU time with and without a busy writer thread.
        #[arg(long)]
        discard_rows: bool,
        /// Regression guard: exit with code 1 when any full-pipeline ratio (full pipeline /
        /// bare engine with the same gait) is below this value, e.g. 0.85.
        #[arg(long, value_name = "RATIO")]
        min_ratio: Option<f64>,
        /// Regression guard on CPU time, which other processes' load does not lower: exit with
        /// code 1 when, for CSV or Parquet, the step-loop thread's CPU time per step of the bare
        /// engine with the same gait and ground model over that of the full pipeline is below
        /// this value, e.g. 0.85.
        #[arg(long, value_name = "RATIO")]
        min_cpu_ratio: Option<f64>,
        /// Regression guard on where the recording's work runs: exit with code 1 when, for CSV,
        /// Parquet or MCAP, the share of the recording's CPU time spent on the step-loop thread
        /// (its CPU time per step above the pipeline without tables, over that plus the writer
        /// threads' CPU time) is above this value, e.g. 0.5. About 0 with writer threads, 1 with
        /// the files written on the step-loop thread.
        #[arg(long, value_name = "SHARE")]
        max_loop_share: Option<f64>,
    },
    /// Accuracy study: every case with RK4, implicitfast and Euler at 0.25 to 10 ms
    /// against RK4 at 0.1 ms; errors, cost, work-precision plots and a recommendation (user
    /// guide, "Run experiments and the accuracy study"). Writes accuracy.md, accuracy.csv and
    /// PNG/SVG plots.
    Study {
        /// Which study: `accuracy`.
        #[arg(value_parser = ["accuracy"])]
        what: String,
        #[command(flatten)]
        config: ConfigArgs,
        /// Two short cases (3 s bare-floor default job, the floor impact) instead of all.
        #[arg(long)]
        quick: bool,
        /// Only these cases (repeatable; names as in the report, e.g. default-bare-floor).
        #[arg(long = "case")]
        cases: Vec<String>,
        /// Where the report, table and plots go.
        #[arg(long, default_value = "runs/study-accuracy")]
        out: PathBuf,
        /// Timed runs per setting (the fastest counts; 1 to 1000).
        #[arg(long, default_value_t = 1, value_parser = repeats_arg)]
        repeats: usize,
        /// Threads for the recorded runs (the timed runs run one at a time); 0 = all cores; at
        /// most 256.
        #[arg(long, default_value_t = 0, value_parser = threads_arg)]
        threads: usize,
    },
    /// Run a parameter sweep in parallel: a grid or random/Latin-hypercube samples of config
    /// keys, one run folder per parameter set, a summary table (user guide, "A parameter sweep").
    Sweep {
        #[command(flatten)]
        config: ConfigArgs,
        /// Vary one key: `key.path=5,10,15` (values), `key.path=lo:hi:step` (grid range) or
        /// `key.path=lo:hi` (range for --sample random|lhs). Repeatable.
        #[arg(long = "vary", value_name = "KEY=VALUES", required = true)]
        vary: Vec<String>,
        /// How parameter sets are chosen: grid (every combination), random or lhs.
        #[arg(long, default_value = "grid")]
        sample: simserpent::sweep::SampleMode,
        /// Number of samples for --sample random|lhs.
        #[arg(long, default_value_t = 10)]
        samples: usize,
        /// Seed of the sampling (the runs keep general.seed unless you vary it).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Sweep folder. Default: <general.output_dir>/sweep-<config name>.
        #[arg(long, value_name = "DIR")]
        sweep_dir: Option<PathBuf>,
        /// Worker threads (default: all cores; at most 256).
        #[arg(long, default_value_t = 0, value_parser = threads_arg)]
        threads: usize,
        /// Run only runs with index % n == i (0 <= i < n) and write summary-shard-i-of-n.csv;
        /// join shards with `simserpent sweep-merge`.
        #[arg(long, value_name = "I/N")]
        shard: Option<simserpent::sweep::Shard>,
        /// Never show a progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Join the shard summaries (summary-shard-*-of-N.csv) of a sweep folder into summary.csv.
    SweepMerge {
        /// The sweep folder.
        sweep_dir: PathBuf,
    },
    /// Repair the ROS 2 bag (run.mcap) of a run that was killed or whose bag is damaged: checks
    /// every chunk (decompression and CRC), keeps every whole and valid one and names those it
    /// leaves out, writes a complete bag (summary, indexes, footer) in its place, keeps the
    /// original beside it as run.damaged.mcap and updates manifest.json. A complete bag whose
    /// chunks are all valid is left as it is; a run still going on is refused. Exit 1 when
    /// nothing is recoverable.
    BagRepair {
        /// The run folder.
        run_folder: PathBuf,
    },
    /// Write the user guide's generated reference pages (configuration keys, output columns,
    /// command line) into DIR; with --check, only compare and exit 1 when a page differs.
    #[command(hide = true)]
    DocGen {
        /// The guide's reference folder (guide/src/reference).
        dir: PathBuf,
        /// Compare instead of writing: exit 1 when a page differs from what would be written.
        #[arg(long)]
        check: bool,
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

/// `--threads`: 0 (one per core) up to [`simserpent::MAX_THREADS`].
/// The options of `experiment oal-bench` (its size, conditions, shards); `--seeds A-B` gives its
/// held-out seeds.
#[derive(clap::Args, Debug, Clone, Default)]
struct OalArgs {
    /// `oal-bench` only: tuning fields per family, seeds 0..N (0–1000; default 10, --quick 1).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(0..=1000))]
    tuning_fields: Option<u64>,
    /// `oal-bench` only: held-out fields per family, seeds 1000.. (1–10000; default 30, --quick
    /// 2); `--seeds A-B` instead gives the held-out seeds themselves.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=10000))]
    fields: Option<u64>,
    /// `oal-bench` only: the layout families, any of lattice, random, row (default lattice,random).
    #[arg(long, value_delimiter = ',', value_parser = ["lattice", "random", "row"])]
    families: Vec<String>,
    /// `oal-bench` only: the floors, any of isotropic, anisotropic (default both).
    #[arg(long, value_delimiter = ',', value_parser = ["isotropic", "anisotropic"])]
    floors: Vec<String>,
    /// `oal-bench` only: time limit of a run, seconds (2–3600; default 60, --quick 6).
    #[arg(long, value_name = "SECS", value_parser = duration_arg)]
    duration: Option<f64>,
    /// `oal-bench` only: the conditions beside `open_loop`, any of passive, matched (the stiff
    /// wave at each passive gain's bare-floor speed), laws (estimated contacts), laws_true,
    /// laws_true_self (the true obstacle and self-contact forces as one), compliance (Wang et
    /// al. 2023's generalised compliance G = 0.25, 0.5, 0.75, 1 swept on the tuning fields)
    /// (default: passive, matched, laws, laws_true).
    #[arg(long, value_delimiter = ',', value_parser = ["passive", "matched", "laws", "laws_true", "laws_true_self", "compliance"])]
    conditions: Vec<String>,
    /// `oal-bench` only: the passive gains swept on the tuning fields, N·m/rad (each 0.01–1000;
    /// default 10,5,2.5, --quick 5).
    #[arg(long, value_delimiter = ',', value_name = "KP", value_parser = gain_arg)]
    passive_kp: Vec<f64>,
    /// `oal-bench` only: each law's gains times each of these on the tuning fields, the best on
    /// the held-out fields (each 0.01–100; default 0.5,1,2, --quick 1).
    #[arg(long, value_delimiter = ',', value_name = "SCALE", value_parser = scale_arg)]
    law_gain_scales: Vec<f64>,
    /// `oal-bench` only: every law steers its mean heading to the goal with this heading-hold
    /// gain (gait offset per radian of heading error, at most 10°; 0–10; default 0 = off), and
    /// the condition open_loop_heading (the open loop with the same term) is their baseline.
    #[arg(long, value_name = "GAIN", value_parser = heading_gain_arg)]
    heading_gain: Option<f64>,
    /// `oal-bench` only: no bare-floor twins of the held-out runs.
    #[arg(long)]
    no_twins: bool,
    /// `oal-bench` only: run shard i of n (every tuning run, the held-out runs with index mod n =
    /// i) into --folder as oal_runs-shard-i-of-n.csv; a Slurm array passes
    /// $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT.
    #[arg(long, value_name = "I/N")]
    shard: Option<simserpent::sweep::Shard>,
    /// `oal-bench` only: join the shards in --folder (run with the shards' other options) into
    /// the tables and report.md of one unsharded run.
    #[arg(long, requires = "folder")]
    merge: bool,
    /// Write into this folder (created if missing) instead of a new
    /// runs/experiment-<name>-<UTC time>/: where the shards of one oal-bench meet.
    #[arg(long, value_name = "DIR")]
    folder: Option<PathBuf>,
}

impl OalArgs {
    /// Whether any option of the benchmark was given.
    fn any(&self) -> bool {
        self.tuning_fields.is_some()
            || self.fields.is_some()
            || !self.families.is_empty()
            || !self.floors.is_empty()
            || self.duration.is_some()
            || !self.conditions.is_empty()
            || !self.passive_kp.is_empty()
            || !self.law_gain_scales.is_empty()
            || self.heading_gain.is_some()
            || self.no_twins
            || self.shard.is_some()
            || self.merge
    }

    /// The bench these options give on top of the quick or full one (`seeds`: the held-out
    /// seeds, a contiguous range).
    fn bench(
        &self,
        quick: bool,
        seeds: Option<&[u64]>,
    ) -> Result<simserpent::experiments::oal_bench::OalOptions, anyhow::Error> {
        use simserpent::experiments::oal_bench::{Bench, Family, Floor, OalOptions};
        let mut b = if quick { Bench::quick() } else { Bench::full() };
        if let Some(n) = self.tuning_fields {
            b.tuning_fields = n;
        }
        if let Some(n) = self.fields {
            b.held_out_fields = n;
        }
        if let Some(seeds) = seeds {
            let contiguous = seeds.windows(2).all(|w| w[1] == w[0] + 1);
            if seeds.is_empty() || !contiguous || self.fields.is_some() {
                anyhow::bail!(
                    "--seeds {seeds:?}: oal-bench takes one range A-B of held-out seeds (and then no --fields)"
                );
            }
            b.first_held_out_seed = seeds[0];
            b.held_out_fields = seeds.len() as u64;
        }
        if !self.families.is_empty() {
            b.families = self.families.iter().filter_map(|f| Family::from_name(f)).collect();
        }
        if !self.floors.is_empty() {
            b.floors = self.floors.iter().filter_map(|f| Floor::from_name(f)).collect();
        }
        if let Some(d) = self.duration {
            b.duration_secs = d;
        }
        if !self.conditions.is_empty() {
            let has = |c: &str| self.conditions.iter().any(|x| x == c);
            if !has("passive") {
                b.passive_kp_nm_per_rad.clear();
            }
            b.speed_matched = has("matched");
            if has("matched") && !has("passive") {
                anyhow::bail!(
                    "--conditions matched: the matched open loop needs `passive` too (it matches a passive gain)"
                );
            }
            if has("compliance") {
                b.compliance = simserpent::experiments::oal_bench::COMPLIANCE_G.to_vec();
            }
            b.laws = has("laws") || has("laws_true") || has("laws_true_self");
            b.true_contacts = has("laws_true");
            b.true_with_self = has("laws_true_self");
            if (has("laws_true") || has("laws_true_self")) && !has("laws") {
                anyhow::bail!(
                    "--conditions laws_true / laws_true_self: give `laws` too (the laws on true contacts pair with estimated ones)"
                );
            }
        }
        if !self.passive_kp.is_empty() {
            b.passive_kp_nm_per_rad = self.passive_kp.clone();
        }
        if !self.law_gain_scales.is_empty() {
            b.law_gain_scales = self.law_gain_scales.clone();
        }
        if let Some(g) = self.heading_gain {
            b.heading_gain = g;
        }
        b.twins = !self.no_twins;
        b.shard = self.shard.map(|s| (s.index, s.count));
        if self.merge && self.shard.is_some() {
            anyhow::bail!("--merge joins the shards: give it without --shard");
        }
        if self.shard.is_some() && self.folder.is_none() {
            anyhow::bail!(
                "--shard {}/{}: give --folder DIR, the folder every shard writes into",
                b.shard.unwrap_or_default().0,
                b.shard.unwrap_or_default().1
            );
        }
        Ok(OalOptions { bench: b, merge: self.merge })
    }
}

/// `--heading-gain`: 0 to 10.
fn heading_gain_arg(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(g) if (0.0..=10.0).contains(&g) => Ok(g),
        _ => Err(format!("`{text}`: a heading-hold gain of 0 (off) to 10 (rad of offset per rad of heading error)")),
    }
}

/// `--duration`: 2 to 3600 s.
fn duration_arg(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(d) if (2.0..=3600.0).contains(&d) => Ok(d),
        _ => Err(format!("`{text}`: a time limit of 2 to 3600 s")),
    }
}

/// `--passive-kp`: 0.01 to 1000 N·m/rad.
fn gain_arg(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(k) if (0.01..=1000.0).contains(&k) => Ok(k),
        _ => Err(format!("`{text}`: a position gain of 0.01 to 1000 N·m/rad")),
    }
}

/// `--law-gain-scales`: 0.01 to 100.
fn scale_arg(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(k) if (0.01..=100.0).contains(&k) => Ok(k),
        _ => Err(format!("`{text}`: a gain scale of 0.01 to 100")),
    }
}

fn threads_arg(text: &str) -> Result<usize, String> {
    let n: usize =
        text.parse().map_err(|_| format!("`{text}` is not a whole number 0 to {}", simserpent::MAX_THREADS))?;
    match simserpent::threads_beyond_cap("", n) {
        Some(message) => Err(message.trim_start().to_string()),
        None => Ok(n),
    }
}

/// Most timed repeats (`study --repeats`, `bench --repeats`).
const MAX_REPEATS: usize = 1000;

/// `--repeats`: 1 up to [`MAX_REPEATS`].
fn repeats_arg(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(n) if (1..=MAX_REPEATS).contains(&n) => Ok(n),
        _ => Err(format!("`{text}`: give a whole number of repeats from 1 to {MAX_REPEATS}")),
    }
}

/// A warning's or note's text as it is printed: every value it quotes at most as long as errors
/// quote them ([`simserpent::config::shorten_words`]).
fn echo(text: &str) -> std::borrow::Cow<'_, str> {
    simserpent::config::shorten_words(text)
}

fn bad_input(e: impl Into<anyhow::Error>) -> Failure {
    Failure { code: 2, error: e.into() }
}

/// The RUN_FOLDER argument of `plot`, `render`, `estimate` and `bag-repair`, checked before the
/// command reads anything: a missing path or one that is not a folder is bad input (exit code 2).
fn run_folder_arg(path: &Path) -> Result<(), Failure> {
    simserpent::files::folder_arg(path).map_err(|e| match e {
        e if e.is_bad_input() => bad_input(anyhow::anyhow!("RUN_FOLDER {e}; give the folder of a run")),
        e => Failure::from(e),
    })
}

/// The documented exit codes (README and user guide, "Exit codes"): 2 for bad input (config, model, robot
/// file, run folder, arguments, no display), 1 for failures while running (divergence, output),
/// 130 for an interrupted run. Decided here, at the binary's edge, not in the library.
trait ExitCodeOf {
    fn exit_code(&self) -> u8;
}

impl ExitCodeOf for RunError {
    fn exit_code(&self) -> u8 {
        use simserpent::sim::SimError;
        match self {
            RunError::Sim(SimError::Config(_) | SimError::RobotFile { .. } | SimError::ModelRejected { .. }) => 2,
            RunError::Render(e) => e.exit_code(),
            RunError::Ros2(simserpent::ros2::Ros2Error::NotBuilt) => 2,
            RunError::Interrupted { .. }
            | RunError::InterruptedSetUp
            | RunError::Sim(SimError::Interrupted { .. })
            | RunError::Plot(simserpent::plot::PlotError::Interrupted { .. }) => 130,
            _ => 1,
        }
    }
}

impl ExitCodeOf for simserpent::render::RenderError {
    fn exit_code(&self) -> u8 {
        use simserpent::render::RenderError;
        match self {
            RenderError::BadFile { .. }
            | RenderError::Config { .. }
            | RenderError::NoViewer(_)
            | RenderError::Read { .. } => 2,
            RenderError::Interrupted => 130,
            RenderError::File(f) if f.is_bad_input() => 2,
            _ => 1,
        }
    }
}

impl ExitCodeOf for simserpent::plot::PlotError {
    fn exit_code(&self) -> u8 {
        match self {
            simserpent::plot::PlotError::Write { .. }
            | simserpent::plot::PlotError::Folder { .. }
            | simserpent::plot::PlotError::Png { .. } => 1,
            simserpent::plot::PlotError::Interrupted { .. } => 130,
            simserpent::plot::PlotError::File(f) if !f.is_bad_input() => 1,
            _ => 2,
        }
    }
}

impl ExitCodeOf for simserpent::experiments::ExperimentError {
    fn exit_code(&self) -> u8 {
        use simserpent::experiments::ExperimentError;
        match self {
            ExperimentError::Unknown(_) | ExperimentError::Option(_) => 2,
            ExperimentError::Run(e) => e.exit_code(),
            ExperimentError::Interrupted { .. } => 130,
            _ => 1,
        }
    }
}

impl ExitCodeOf for simserpent::sweep::SweepError {
    fn exit_code(&self) -> u8 {
        use simserpent::sweep::SweepError;
        match self {
            SweepError::Config(_) | SweepError::Argument { .. } | SweepError::ShardsIncomplete { .. } => 2,
            SweepError::File(f) if f.is_bad_input() => 2,
            _ => 1,
        }
    }
}

/// An error with its exit code.
fn failure<E: ExitCodeOf + Into<anyhow::Error>>(e: E) -> Failure {
    Failure { code: e.exit_code(), error: e.into() }
}

/// Loads the config; for the original tool's config.json, prints the conversion notes to
/// standard error (once: every command loads its config once).
fn load(args: &ConfigArgs) -> Result<(Config, String), Failure> {
    let result: Result<(Config, Option<config::LegacyConversion>), ConfigError> = match &args.config {
        Some(path) => config::load_config_with_notes(path, &args.overrides),
        None => config::load_config_str(config::DEFAULT_CONFIG_TOML, config::ConfigSource::Toml, &args.overrides)
            .map(|c| (c, None)),
    };
    let source = args.config.as_ref().map_or("embedded default".to_string(), |p| p.display().to_string());
    let (config, conversion) =
        result.map_err(|e| bad_input(anyhow::Error::new(e).context(format!("config {source}"))))?;
    if let Some(conversion) = conversion {
        let differences = conversion.difference_lines();
        errln!(
            "note: {source} is the original tool's config.json: {} settings converted, {} of them work differently \
             here (`simserpent convert {source}` writes every setting with its rule; README \"The original tool\"):",
            conversion.notes.len(),
            differences.len()
        );
        for line in &differences {
            errln!("note:   {}", echo(line));
        }
    }
    Ok((config, source))
}

/// Says which keys of a valid config the active controller does not use, and when nothing will
/// move the snake (`check` and `run`, once the config has passed every check).
fn tell_what_does_nothing(config: &Config) {
    for unused in simserpent::control::unused_keys(config) {
        errln!("warning: {}", echo(&unused.to_string()));
    }
    if let Some(still) = simserpent::control::nothing_moves(config) {
        errln!("note: {}", echo(&still));
    }
}

/// Writes a file the user named (`init`, `convert -o`): never through a symbolic link (a
/// dangling one included), and over an existing file only with `--force`.
fn write_new_file(path: &Path, bytes: &[u8], force: bool) -> Result<(), Failure> {
    use simserpent::files::{FileError, open_for_writing};
    use std::io::Write as _;
    let mut file = open_for_writing(path, !force).map_err(|e| match e {
        FileError::Io { ref source, .. } if source.kind() == std::io::ErrorKind::AlreadyExists => {
            bad_input(anyhow::anyhow!("{} exists already; use --force to overwrite it", path.display()))
        }
        e if e.is_bad_input() => bad_input(e),
        e => Failure { code: 1, error: e.into() },
    })?;
    file.write_all(bytes).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// `simserpent convert config.json [-o config.toml]`.
fn convert(input: &Path, output: Option<&Path>, force: bool) -> Result<(), Failure> {
    if !input.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
        return Err(bad_input(anyhow::anyhow!(
            "{}: `convert` reads the original tool's config.json (a `.json` file); a SimSerpent TOML needs no \
             conversion",
            input.display()
        )));
    }
    // The whole pipeline first: a config.json that does not load is not converted.
    config::load_config(input, &[])
        .map_err(|e| bad_input(anyhow::Error::new(e).context(format!("config {}", input.display()))))?;
    let converted = config::convert_legacy_file(input)
        .map_err(|e| bad_input(anyhow::Error::new(e).context(format!("config {}", input.display()))))?;
    let name = input.file_name().map_or_else(|| input.display().to_string(), |n| n.to_string_lossy().into_owned());
    let text = converted.annotated_toml(&name);
    match output {
        Some(path) => {
            write_new_file(path, text.as_bytes(), force)?;
            errln!("wrote {} ({} converted keys)", path.display(), converted.notes.len());
        }
        None => out!("{text}"),
    }
    Ok(())
}

fn run_command(
    args: &ConfigArgs,
    robot: Option<PathBuf>,
    quiet: bool,
    viewer: bool,
    ros2: bool,
) -> Result<(), Failure> {
    let (config, source) = load(args)?;
    if viewer {
        // Before anything is written: no display is bad input (exit code 2, no run folder).
        simserpent::render::viewer::check_display().map_err(bad_input)?;
    }
    let options = RunOptions {
        config_source: source,
        robot,
        command_line: std::env::args().collect(),
        progress: !quiet,
        viewer,
        ros2,
        ..RunOptions::default()
    };
    let summary = run::run(&config, &options).map_err(|e: RunError| {
        let code = e.exit_code();
        // Geometry checks of model generation are config errors too: name the config.
        let config_error = matches!(e, RunError::Sim(simserpent::sim::SimError::Config(_)));
        let error = anyhow::Error::new(e);
        Failure {
            code,
            error: if config_error { error.context(format!("config {}", options.config_source)) } else { error },
        }
    })?;
    tell_what_does_nothing(&config);
    outln!("run folder:        {}", summary.run_folder.display());
    outln!(
        "simulated:         {:.3} s in {} steps",
        summary.simulated_secs,
        (summary.simulated_secs / config.general.timestep_secs).round()
    );
    outln!(
        "distance (CoM):    {:.4} m toward {:.1} deg, mean speed {:.4} m/s",
        summary.distance_m,
        summary.heading_deg,
        summary.mean_speed_m_per_s
    );
    outln!("forward speed:     {:.4} m/s (along the way the head faced at the start)", summary.forward_speed_m_per_s);
    outln!(
        "peak contact force {:.3} N on one link averaged over {:.0} ms ({:.3} N at a single step and contact)",
        summary.peak_contact_force_10ms_n,
        summary.contact_force_window_secs * 1e3,
        summary.peak_contact_force_step_n
    );
    outln!("max penetration    {:.3} mm (at recorded steps)", summary.max_penetration_m * 1e3);
    outln!("actuator energy:   {:.3} J", summary.actuator_energy_j);
    for note in &summary.notes {
        errln!("note: {}", echo(note));
    }
    if let Some(joints) = &summary.tracking {
        let in_ramp_in = run::ended_in_ramp_in(&config, &summary);
        let window =
            if in_ramp_in { "during the ramp-in, which the run ended in: no verdict" } else { "after the ramp-in" };
        outln!("tracking of the commanded joint angles ({window}; error = actual - commanded angle):");
        outln!("  joint        amplitude  reached   RMS error           max error");
        for j in joints {
            outln!(
                "  {:<12} {:>6.2} deg {:>6.0} %   {:.4} rad {:>5.0} %   {:.4} rad {:>5.0} %{}",
                simserpent::config::shorten(&j.joint),
                j.command_amplitude_rad.to_degrees(),
                j.reached_amplitude_percent,
                j.rms_error_rad,
                j.rms_error_percent,
                j.max_error_rad,
                j.max_error_percent,
                if j.tracks() || in_ramp_in { "" } else { "  (not tracked)" }
            );
        }
    }
    if let Some(warning) = run::tracking_warning(&config, &summary) {
        errln!("warning: {}", echo(&warning));
    }
    outln!("speed:             {:.0} steps/s, {:.1}x real time", summary.steps_per_wall_sec, summary.real_time_factor);
    if viewer && !cfg!(feature = "viewer") {
        // Without the in-process viewer, show the finished run in Python's viewer.
        simserpent::render::viewer::replay_run_folder(&summary.run_folder).map_err(failure)?;
    }
    Ok(())
}

/// `simserpent plot RUN_FOLDER`.
fn plot_command(folder: &Path) -> Result<(), Failure> {
    let out = simserpent::plot::plot_run_folder(folder).map_err(failure)?;
    for (panel, why) in &out.skipped {
        errln!("skipped {panel}: {}", echo(why));
    }
    outln!("wrote {} plot files into {}", out.files.len(), folder.join("plots").display());
    Ok(())
}

/// `simserpent render RUN_FOLDER`.
fn render_command(folder: &Path, video: bool, images: bool, overrides: &[String], quiet: bool) -> Result<(), Failure> {
    if !video && !images {
        return Err(bad_input(anyhow::anyhow!("nothing to render: give --video and/or --images")));
    }
    let options = simserpent::render::ReplayOptions { video, images, overrides: overrides.to_vec(), progress: !quiet };
    let files = simserpent::render::render_run_folder(folder, &options).map_err(failure)?;
    for f in files {
        outln!("wrote {}", f.display());
    }
    Ok(())
}

/// `simserpent view [CONFIG|MODEL|RUN_FOLDER]`.
fn view_command(path: Option<&Path>, overrides: &[String]) -> Result<(), Failure> {
    use simserpent::render::viewer;
    let fail = failure::<simserpent::render::RenderError>;
    viewer::check_display().map_err(fail)?;
    let is_model =
        |p: &Path| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml") || e.eq_ignore_ascii_case("urdf"));
    match path {
        Some(p) if p.is_dir() => viewer::replay_run_folder(p).map_err(fail),
        Some(p) if is_model(p) => viewer::view_model_file(p).map_err(fail),
        _ => {
            let args = ConfigArgs { config: path.map(Path::to_path_buf), overrides: overrides.to_vec() };
            let (config, _) = load(&args)?;
            let generated = simserpent::model::generate(&config).map_err(bad_input)?;
            viewer::view_generated(&generated).map_err(fail)
        }
    }
}

/// The seeds of `experiment --seeds`.
#[derive(Debug, Clone)]
struct SeedList(Vec<u64>);

/// `--seeds`: `A-B` (inclusive) or a comma-separated list, of at most
/// [`simserpent::experiments::MAX_SEEDS`] seeds (counted before a range is expanded).
fn parse_seeds(text: &str) -> Result<SeedList, String> {
    use simserpent::config::shorten;
    use simserpent::experiments::MAX_SEEDS;
    let number = |s: &str| {
        s.trim().parse::<u64>().map_err(|_| {
            format!("`{}` is not a seed (a whole number 0 to {}); give A-B or A,B,C", shorten(s), u64::MAX)
        })
    };
    let too_many = |n: u128| format!("`{}`: {n} seeds; give at most {MAX_SEEDS}", shorten(text));
    let seeds = match text.split_once('-') {
        Some((a, b)) => {
            let (a, b) = (number(a)?, number(b)?);
            if a > b {
                return Err(format!("`{}`: the range's first seed is larger than its last", shorten(text)));
            }
            let n = u128::from(b - a) + 1;
            if n > MAX_SEEDS as u128 {
                return Err(too_many(n));
            }
            (a..=b).collect()
        }
        None => {
            let n = text.split(',').count();
            if n > MAX_SEEDS {
                return Err(too_many(n as u128));
            }
            text.split(',').map(number).collect::<Result<Vec<_>, _>>()?
        }
    };
    Ok(SeedList(seeds))
}

fn experiment(
    name: &str,
    args: &ConfigArgs,
    quick: bool,
    threads: usize,
    seeds: Option<Vec<u64>>,
    floor: Option<&str>,
    oal_args: &OalArgs,
) -> Result<(), Failure> {
    let (config, _) = load(args)?;
    let (mut seeds, mut oal) = (seeds, None);
    if name == "oal-bench" {
        oal = Some(oal_args.bench(quick, seeds.as_deref()).map_err(bad_input)?);
        seeds = None;
    } else if oal_args.any() {
        return Err(bad_input(anyhow::anyhow!(
            "--tuning-fields, --fields, --families, --floors, --duration, --conditions, --passive-kp, \
             --law-gain-scales, --no-twins, --shard and --merge are options of `experiment oal-bench`, not of `{name}`"
        )));
    }
    let floor = floor.map(|f| match f {
        "isotropic" => simserpent::config::GroundModel::Isotropic,
        _ => simserpent::config::GroundModel::Anisotropic,
    });
    let options = simserpent::experiments::ExperimentOptions {
        quick,
        threads,
        progress: true,
        seeds,
        floor,
        oal,
        folder: oal_args.folder.clone(),
    };
    let outcome =
        simserpent::experiments::run_experiment_with(name, &config, Path::new(&config.general.output_dir), &options)
            .map_err(failure)?;
    for note in &outcome.notes {
        errln!("note: {}", echo(note));
    }
    let report = &outcome.report;
    for c in report.checks() {
        outln!("{} {}", if c.passed { "pass" } else { "FAIL" }, c.name);
    }
    for c in report.not_observable() {
        outln!("not observable: {}: {}", c.name, c.not_observable.as_deref().unwrap_or_default());
    }
    let passed = report.checks().filter(|c| c.passed).count();
    outln!(
        "{passed} of {} checks passed; report: {}",
        report.checks().count(),
        outcome.folder.join("report.md").display()
    );
    outln!("wall time {:.1} s, cases on {} threads", outcome.wall_secs, outcome.threads);
    if report.all_passed() {
        Ok(())
    } else {
        Err(Failure { code: 1, error: anyhow::anyhow!("some physics checks failed (see the report)") })
    }
}

fn estimate_command(run_folder: &Path, overrides: &[String]) -> Result<(), Failure> {
    use simserpent::estimate::{EstimateError, estimate_run_folder};
    let outcome = estimate_run_folder(run_folder, overrides).map_err(|e| match e {
        EstimateError::Interrupted { .. } => Failure { code: 130, error: e.into() },
        EstimateError::File(ref f) if !f.is_bad_input() => Failure { code: 1, error: e.into() },
        EstimateError::Io { .. } | EstimateError::Plot { .. } => Failure { code: 1, error: e.into() },
        _ => bad_input(anyhow::Error::new(e)),
    })?;
    let t = &outcome.total;
    let pct = |x: f64| if x.is_nan() { "n/a".to_string() } else { format!("{:.1} %", 100.0 * x) };
    outln!(
        "{} rows: obstacle contacts detected {} of {} link-steps, false alarms {}, force RMSE / RMS {}, contact \
         points within 1 cm {} of {}",
        outcome.rows,
        pct(t.detection_rate()),
        t.hits + t.misses,
        pct(t.false_alarm_rate()),
        pct(t.relative_force_rmse()),
        pct(t.point_within_rate()),
        t.points
    );
    outln!(
        "false force: {} of {} link-steps without obstacle contact show more than {:.2} N (one link's weight) of \
         obstacle force, the largest {:.2} N",
        pct(t.false_force_rate()),
        t.free_link_steps,
        t.false_force_threshold_n,
        t.false_force_max_n
    );
    outln!("estimates, scores and plots: {}", outcome.folder.display());
    Ok(())
}

fn study(
    args: &ConfigArgs,
    quick: bool,
    names: &[String],
    out_dir: PathBuf,
    repeats: usize,
    threads: usize,
) -> Result<(), Failure> {
    use simserpent::study;
    // --out before any run: a folder, or one that can be created now (not at the end).
    match std::fs::metadata(&out_dir) {
        Ok(m) if !m.is_dir() => {
            return Err(bad_input(anyhow::anyhow!(
                "--out {}: exists and is not a folder; give a folder for accuracy.md, accuracy.csv and the plots",
                out_dir.display()
            )));
        }
        Ok(_) => {}
        Err(_) => std::fs::create_dir_all(&out_dir)
            .map_err(|e| bad_input(anyhow::anyhow!("--out {}: cannot create the folder: {e}", out_dir.display())))?,
    }
    let probe = out_dir.join(".simserpent-write-check");
    simserpent::files::open_for_writing(&probe, false)
        .map_err(|e| bad_input(anyhow::anyhow!("--out {}: cannot write into it: {e}", out_dir.display())))?;
    let _ = std::fs::remove_file(&probe);
    let (config, _) = load(args)?;
    let mut cases = study::cases(&config, quick);
    if !names.is_empty() {
        let known: Vec<String> = cases.iter().map(|c| c.name.clone()).collect();
        if let Some(bad) = names.iter().find(|n| !known.contains(n)) {
            return Err(bad_input(anyhow::anyhow!("--case {bad}: no such case; the cases are {}", known.join(", "))));
        }
        cases.retain(|c| names.contains(&c.name));
    }
    let options =
        study::StudyOptions { settings: study::all_settings(), reference: study::Setting::REFERENCE, repeats, out_dir };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
    let result = pool.install(|| study::run_study(cases, &options)).map_err(failure)?;
    outln!("{}", result.report);
    outln!("written: {}", result.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>().join(", "));
    Ok(())
}

fn init(path: &Path, force: bool, preset: Option<&str>) -> Result<(), Failure> {
    use simserpent::config::presets;
    let text = match preset {
        None => config::DEFAULT_CONFIG_TOML,
        Some(name) => presets::config_preset(name).ok_or_else(|| {
            bad_input(anyhow::anyhow!(
                "unknown preset `{name}` (--preset); available: {}",
                presets::config_preset_names()
            ))
        })?,
    };
    // A folder that does not exist is a bad argument (exit code 2), not a failure while writing.
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !parent.is_dir() {
        return Err(bad_input(anyhow::anyhow!(
            "cannot write {}: the folder {} does not exist",
            path.display(),
            parent.display()
        )));
    }
    write_new_file(path, text.as_bytes(), force)?;
    outln!("wrote {}", path.display());
    Ok(())
}

/// `simserpent check`: the config and the model it generates (terrain files read and checked as
/// a run would), without MuJoCo; prints the resolved config.
fn check(args: &ConfigArgs) -> Result<(), Failure> {
    let (config, source) = load(args)?;
    simserpent::model::generate(&config)
        .map_err(|e| bad_input(anyhow::Error::new(e).context(format!("config {source}"))))?;
    tell_what_does_nothing(&config);
    say(format_args!("{}", config.to_toml_string()))
}

fn model(args: &ConfigArgs, output: Option<&Path>, scene_dir: Option<&Path>) -> Result<(), Failure> {
    let (config, source) = load(args)?;
    let generated = simserpent::model::generate(&config)
        .map_err(|e| bad_input(anyhow::Error::new(e).context(format!("config {source}"))))?;
    if let Some(dir) = scene_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let f = &generated.files;
        simserpent::sim::write_model_folder(dir, &generated.xml, &f.texts, &f.copies)?;
        errln!("wrote {} (scene.xml, terrain.xml, robot.xml, model.xml)", dir.display());
    }
    // A third-party terrain (terrain.include_mjcf) is included by file name: the written model
    // only loads with that file (and the assets it names) beside it.
    let included: Vec<&simserpent::model::features::FileCopy> = if generated.files.model_needs_files {
        let sources = simserpent::model::features::SOURCES_DIR;
        generated.files.copies.iter().filter(|c| !c.dest.starts_with(sources)).collect()
    } else {
        Vec::new()
    };
    match output {
        Some(path) => {
            std::fs::write(path, &generated.xml).with_context(|| format!("cannot write {}", path.display()))?;
            let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
            for c in &included {
                // Never copy a file onto itself (an asset already where the model looks for it).
                let dest = dir.join(&c.dest);
                let same = matches!((c.source.canonicalize(), dest.canonicalize()), (Ok(a), Ok(b)) if a == b);
                if !same {
                    simserpent::sim::copy_file(dir, c)?;
                }
            }
            if included.is_empty() {
                errln!("wrote {}", path.display());
            } else {
                let names: Vec<&str> = included.iter().map(|c| c.dest.as_str()).collect();
                errln!(
                    "wrote {} and beside it {} (the third-party terrain of terrain.include_mjcf, which the model includes)",
                    path.display(),
                    names.join(", ")
                );
            }
        }
        None => {
            out!("{}", generated.xml);
            if !included.is_empty() {
                errln!(
                    "note: this model includes {} (terrain.include_mjcf), which stdout cannot carry: write it with \
                     `model -o FILE` (the included files are written beside FILE) or --scene-dir DIR",
                    included[0].dest
                );
            }
        }
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn bench(
    args: &ConfigArgs,
    links: &[usize],
    duration_secs: f64,
    output_dir: &str,
    repeats: usize,
    json: bool,
    (min_ratio, min_cpu_ratio, max_loop_share): (Option<f64>, Option<f64>, Option<f64>),
    (inline_writers, discard_rows): (bool, bool),
) -> Result<(), Failure> {
    for (flag, floor) in [("--min-ratio", min_ratio), ("--min-cpu-ratio", min_cpu_ratio)] {
        if let Some(r) = floor.filter(|r| !(r.is_finite() && *r > 0.0)) {
            return Err(bad_input(anyhow::anyhow!("{flag} {r}: must be a number greater than 0 (e.g. 0.85)")));
        }
    }
    if let Some(s) = max_loop_share.filter(|s| !(s.is_finite() && *s > 0.0 && *s < 1.0)) {
        return Err(bad_input(anyhow::anyhow!("--max-loop-share {s}: must be a number between 0 and 1 (e.g. 0.5)")));
    }
    let (config, source) = load(args)?;
    let rows =
        simserpent::bench::run_bench(&config, links, duration_secs, output_dir, repeats, inline_writers, discard_rows)
            .map_err(failure)?;
    let below_of = |ratios: Vec<(usize, &str, f64)>, floor: Option<f64>| -> Vec<String> {
        ratios
            .into_iter()
            .filter(|(_, _, ratio)| floor.is_some_and(|floor| *ratio < floor))
            .map(|(n, mode, ratio)| format!("{n} links, {mode}: {ratio:.3}"))
            .collect()
    };
    let below = below_of(simserpent::bench::pipeline_ratios(&rows), min_ratio);
    let below_cpu = below_of(simserpent::bench::cpu_ratios(&rows, simserpent::bench::BARE_GAIT_GROUND), min_cpu_ratio);
    let shares = simserpent::bench::loop_shares(&rows);
    let above_share: Vec<String> = shares
        .iter()
        .filter(|(_, mode, share)| {
            !simserpent::bench::writers_inline(mode) && max_loop_share.is_some_and(|m| *share > m)
        })
        .map(|(n, mode, share)| format!("{n} links, {mode}: {share:.3}"))
        .collect();
    let guard = || -> Result<(), Failure> {
        let mut failed = Vec::new();
        if let (false, Some(floor)) = (below.is_empty(), min_ratio) {
            failed.push(format!("full pipeline / bare engine below the floor {floor}: {}", below.join("; ")));
        }
        if let (false, Some(floor)) = (below_cpu.is_empty(), min_cpu_ratio) {
            failed.push(format!(
                "step-loop CPU time per step, bare engine (gait + ground) / full pipeline, below the floor {floor}: {}",
                below_cpu.join("; ")
            ));
        }
        if let (false, Some(ceiling)) = (above_share.is_empty(), max_loop_share) {
            failed.push(format!(
                "share of the recording's CPU time on the step-loop thread above {ceiling}: {}",
                above_share.join("; ")
            ));
        }
        if failed.is_empty() {
            return Ok(());
        }
        Err(Failure { code: 1, error: anyhow::anyhow!("{} (see BENCHMARKS.md)", failed.join("; ")) })
    };
    if json {
        let doc = simserpent::bench::to_json(&config, duration_secs, repeats, &rows);
        outln!("{}", serde_json::to_string_pretty(&doc).unwrap_or_default());
        return guard();
    }
    outln!(
        "config: {source}; timestep {} s, integrator {:?}, {} s simulated per row",
        config.general.timestep_secs,
        config.general.integrator,
        duration_secs
    );
    outln!(
        "| links | mode | steps/s | real-time factor | vs bare still | vs bare gait | vs bare gait + ground \
         | wall µs/step | loop CPU µs/step | writers' CPU µs/step | loop CPU: bare gait + ground / this \
         | recording's CPU on the loop | loop waits (s) |"
    );
    outln!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for chunk in rows.chunks(simserpent::bench::modes(inline_writers, discard_rows).len()) {
        let (still, gait, ground) = (chunk[0].steps_per_sec, chunk[1].steps_per_sec, chunk[2].steps_per_sec);
        let ground_cpu = chunk[2].loop_cpu_ns_per_step();
        for r in chunk {
            let (waits, wait_secs) = r.loop_waits();
            let share = shares
                .iter()
                .find(|(n, mode, _)| *n == r.n_links && *mode == r.mode)
                .map_or_else(|| "–".to_string(), |(_, _, s)| format!("{s:.2}"));
            outln!(
                "| {} | {} | {:.0} | {:.1} | {:.0}% | {:.0}% | {:.0}% | {:.1} | {:.1} | {:.1} | {:.3} | {} | {} ({:.3}) |",
                r.n_links,
                r.mode,
                r.steps_per_sec,
                r.steps_per_sec * config.general.timestep_secs,
                100.0 * r.steps_per_sec / still,
                100.0 * r.steps_per_sec / gait,
                100.0 * r.steps_per_sec / ground,
                1e6 / r.steps_per_sec,
                r.loop_cpu_ns_per_step() * 1e-3,
                r.writer_cpu_ns_per_step() * 1e-3,
                ground_cpu / r.loop_cpu_ns_per_step(),
                share,
                waits,
                wait_secs
            );
        }
    }
    outln!(
        "(steps/s: the fastest of {repeats} repeats; CPU times: the least of the repeats; loop waits: for a writer \
         thread, summed over the repeats)"
    );
    guard()
}

#[allow(clippy::too_many_arguments)]
fn sweep(
    args: &ConfigArgs,
    vary: &[String],
    mode: simserpent::sweep::SampleMode,
    samples: usize,
    seed: u64,
    sweep_dir: Option<PathBuf>,
    threads: usize,
    shard: Option<simserpent::sweep::Shard>,
    quiet: bool,
) -> Result<(), Failure> {
    use simserpent::sweep::{self, SweepSpec, Variation};
    let variations = vary.iter().map(|v| Variation::parse(v)).collect::<Result<Vec<_>, _>>().map_err(bad_input)?;
    let spec = SweepSpec {
        config_path: args.config.clone(),
        overrides: args.overrides.clone(),
        variations,
        mode,
        samples,
        seed,
        sweep_dir,
        threads,
        shard,
        progress: !quiet,
    };
    let report = sweep::run_sweep(&spec).map_err(failure)?;
    let (done, skipped, failed) = report.counts();
    outln!("sweep folder: {}", report.sweep_dir.display());
    outln!(
        "runs:         {} ({done} completed now, {skipped} already complete, {failed} failed) in {:.1} s on {} threads",
        report.rows.len(),
        report.wall_secs,
        report.threads
    );
    outln!("summary:      {}", report.summary_csv.display());
    if report.interrupted() > 0 {
        return Err(Failure {
            code: 130,
            error: anyhow::anyhow!(
                "interrupted: {} runs stopped or not started; run the same command again to finish the sweep",
                report.interrupted()
            ),
        });
    }
    if failed > 0 {
        for row in &report.rows {
            if let sweep::RunOutcome::Failed(message) = &row.outcome {
                errln!("failed: {}: {message}", row.run.id);
            }
        }
        return Err(Failure {
            code: 1,
            error: anyhow::anyhow!(
                "{failed} of {} runs failed; run the same command again to retry them",
                report.rows.len()
            ),
        });
    }
    Ok(())
}

fn sweep_merge(dir: &Path) -> Result<(), Failure> {
    if !dir.is_dir() {
        return Err(bad_input(anyhow::anyhow!("sweep folder {} does not exist (or is not a folder)", dir.display())));
    }
    let (table, files) = simserpent::sweep::merge_shards(dir).map_err(failure)?;
    outln!(
        "merged {} shard summaries, {} runs, into {}",
        files.len(),
        table.rows.len(),
        dir.join("summary.csv").display()
    );
    Ok(())
}

fn bag_repair(run_folder: &Path) -> Result<(), Failure> {
    use simserpent::ros2::bag_file::RepairError;
    let report = simserpent::ros2::repair_bag(run_folder).map_err(|e| match e {
        RepairError::Write { .. } | RepairError::NothingRecoverable { .. } => Failure { code: 1, error: e.into() },
        RepairError::Interrupted => Failure { code: 130, error: e.into() },
        RepairError::File(ref f) if !f.is_bad_input() => Failure { code: 1, error: e.into() },
        e => bad_input(e),
    })?;
    let path = report.path.display();
    match &report.original {
        None => outln!(
            "{path}: complete ({} messages in {} chunks, every chunk's CRC valid); nothing to repair",
            report.messages,
            report.chunks
        ),
        Some(original) => {
            outln!(
                "{path}: repaired: {} messages ({} instants) from {} of {} chunks; the original is {}; manifest.json \
                 lists {} instants",
                report.messages,
                report.instants,
                report.chunks_kept,
                report.chunks,
                original.display(),
                report.instants
            );
            if let Some(stopped) = &report.stopped {
                outln!("reading stopped: {stopped}");
            }
            let lost = report.damage_lines();
            if !lost.is_empty() || report.messages_without_channel > 0 {
                errln!("warning: {path}: damaged data left out:");
                for line in lost {
                    errln!("  {line}");
                }
                if report.messages_without_channel > 0 {
                    errln!(
                        "  {} messages of whole chunks whose channel is defined only in damaged data",
                        report.messages_without_channel
                    );
                }
            }
        }
    }
    Ok(())
}

/// The error and its causes, `: `-separated, leaving out a cause whose text the message already
/// contains (our errors name their OS error themselves, e.g. `cannot write X: No space left`).
fn error_text(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let cause = cause.to_string();
        if text.contains(&cause) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&cause);
    }
    text
}

/// The log filter unless `RUST_LOG` sets one: warnings and errors, but from RustDDS (the live
/// ROS 2 bridge's DDS) errors only. Its warnings are per-datagram diagnostics, not problems of the
/// run: "Message size = …" for every datagram above 1500 bytes and, with `ros2.interfaces =
/// ["127.0.0.1"]`, "No locators for RtpsReaderProxy" about its own participant's built-in readers
/// dozens of times a second (over 1 KB each). Nor the error RustDDS logs at exit for leaving a
/// multicast group it never joined (no multicast-capable interface in `ros2.interfaces`: Linux's
/// `lo` has no MULTICAST flag). Its warnings about interfaces stay (an address in
/// `ros2.interfaces` that no interface has: "matched no unicast interfaces"). `RUST_LOG=warn`
/// shows them all.
const DEFAULT_LOG_FILTER: &str = "warn,rustdds=error,rustdds::network::util=warn,rustdds::network::udp_listener=off";

/// `simserpent doc-gen`: the guide's generated reference pages, read and written under the one
/// reader-and-writer rule of `simserpent::files` (regular files only, no links out of DIR or
/// written through, at most 64 MiB read back).
fn doc_gen(dir: &Path, check: bool) -> Result<(), Failure> {
    use clap::CommandFactory;
    use simserpent::files::{self, FileError};
    let file_failure = |e: FileError| if e.is_bad_input() { bad_input(e) } else { Failure::from(e) };
    if !dir.is_dir() {
        return Err(bad_input(anyhow::anyhow!("{}: not a folder (give the guide's reference folder)", dir.display())));
    }
    let mut stale = Vec::new();
    for (name, text) in simserpent::docgen::pages(&Cli::command()) {
        let path = dir.join(name);
        if check {
            match files::read_text_in(dir, Path::new(name), files::SMALL_FILE_CAP_BYTES) {
                Ok(committed) if committed == text => {}
                Ok(_) | Err(FileError::Missing { .. } | FileError::NotText { .. }) => {
                    stale.push(path.display().to_string());
                }
                Err(e) => return Err(file_failure(e)),
            }
        } else {
            files::write_in(dir, Path::new(name), text.as_bytes()).map_err(file_failure)?;
        }
    }
    if !stale.is_empty() {
        return Err(anyhow::anyhow!(
            "generated guide pages differ from the code: {} (run ./scripts/guide to regenerate them)",
            stale.join(", ")
        )
        .into());
    }
    Ok(())
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(DEFAULT_LOG_FILTER)).init();
    // MuJoCo's warnings go to the log instead of stdout; its fatal errors end the run or the
    // set-up the way SimSerpent's own errors do (`sim::fatal`).
    // SAFETY: called first thing in main, before any thread exists or MuJoCo is used.
    #[allow(unsafe_code)]
    unsafe {
        simserpent::sim::fatal::install();
    }
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // Help and version print as clap prints them.
        Err(e) if !e.use_stderr() => e.exit(),
        // A bad argument: clap's message with every echoed value capped as errors cap them (a
        // 5,000-digit seed is not repeated whole); exit code 2.
        Err(e) => {
            errln!("{}", simserpent::config::shorten_words(e.render().to_string().trim_end()));
            return ExitCode::from(2);
        }
    };
    // One signal policy for every long-running command (`simserpent::interrupt`): the first
    // SIGINT/SIGTERM stops cleanly (what was recorded stays readable and marked), the second quits
    // at once; exit code 130 either way.
    let long_running = matches!(
        cli.command,
        None | Some(
            Command::Run { .. }
                | Command::Sweep { .. }
                | Command::Experiment { .. }
                | Command::Study { .. }
                | Command::Estimate { .. }
                | Command::Bench { .. }
                | Command::Plot { .. }
                | Command::Render { .. }
                | Command::BagRepair { .. }
        )
    );
    if long_running && let Err(e) = simserpent::interrupt::install_handler() {
        log::warn!("cannot install the SIGINT/SIGTERM handler ({e}); a signal will end the command abruptly");
    }
    let result = match cli.command {
        None => run_command(&ConfigArgs::default(), None, false, false, false),
        Some(Command::Run { mut config, robot, quiet, video, viewer, ros2 }) => {
            if video {
                config.overrides.push("video.enabled=true".into());
            }
            run_command(&config, robot, quiet, viewer, ros2)
        }
        Some(Command::Plot { run_folder }) => run_folder_arg(&run_folder).and_then(|()| plot_command(&run_folder)),
        Some(Command::Render { run_folder, video, images, overrides, quiet }) => {
            run_folder_arg(&run_folder).and_then(|()| render_command(&run_folder, video, images, &overrides, quiet))
        }
        Some(Command::View { path, overrides }) => view_command(path.as_deref(), &overrides),
        Some(Command::Init { path, force, preset }) => init(&path, force, preset.as_deref()),
        Some(Command::Experiment { name, config, quick, threads, seeds, floor, oal }) => {
            experiment(&name, &config, quick, threads, seeds.map(|s| s.0), floor.as_deref(), &oal)
        }
        Some(Command::Estimate { run_folder, overrides }) => {
            run_folder_arg(&run_folder).and_then(|()| estimate_command(&run_folder, &overrides))
        }
        Some(Command::Model { config, output, scene_dir }) => model(&config, output.as_deref(), scene_dir.as_deref()),
        Some(Command::Check { config }) => check(&config),
        Some(Command::Convert { input, output, force }) => convert(&input, output.as_deref(), force),
        Some(Command::Bench {
            config,
            links,
            duration_secs,
            output_dir,
            repeats,
            json,
            min_ratio,
            min_cpu_ratio,
            max_loop_share,
            inline_writers,
            discard_rows,
        }) => bench(
            &config,
            &links,
            duration_secs,
            &output_dir,
            repeats,
            json,
            (min_ratio, min_cpu_ratio, max_loop_share),
            (inline_writers, discard_rows),
        ),
        Some(Command::Sweep { config, vary, sample, samples, seed, sweep_dir, threads, shard, quiet }) => {
            sweep(&config, &vary, sample, samples, seed, sweep_dir, threads, shard, quiet)
        }
        Some(Command::SweepMerge { sweep_dir }) => sweep_merge(&sweep_dir),
        Some(Command::BagRepair { run_folder }) => run_folder_arg(&run_folder).and_then(|()| bag_repair(&run_folder)),
        Some(Command::DocGen { dir, check }) => doc_gen(&dir, check),
        Some(Command::Study { what: _, config, quick, cases, out, repeats, threads }) => {
            study(&config, quick, &cases, out, repeats, threads)
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            errln!("error: {}", echo(&error_text(&failure.error)));
            ExitCode::from(failure.code)
        }
    }
}
