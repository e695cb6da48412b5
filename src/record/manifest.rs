//! `manifest.json`: what produced a run folder and how the run ended.

use super::{RecordError, io_err};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    /// Still running, or stopped without finishing (crash, signal): the tables hold every row
    /// written up to then.
    Incomplete,
    /// Ran to the configured duration.
    Complete,
    /// Stopped by an error (see `error`).
    Failed,
}

/// The manifest of a run folder (written when the run starts and when it ends; read back by
/// sweeps to skip finished runs).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Manifest {
    /// SimSerpent version.
    pub simserpent_version: String,
    /// MuJoCo library version (as the library reports it).
    pub mujoco_version: String,
    /// mujoco-rs binding version.
    pub mujoco_rs_version: String,
    /// Seed of all random streams.
    pub seed: u64,
    /// Run status.
    pub status: RunStatus,
    /// Why the run failed (status `failed`) or was interrupted (status `incomplete` after SIGINT or
    /// SIGTERM); `null` while running and when complete.
    pub error: Option<String>,
    /// Start time (UTC, `YYYYMMDDTHHMMSSZ`).
    pub started_utc: String,
    /// Wall-clock time of the simulation (s).
    pub wall_time_secs: f64,
    /// Physics steps taken.
    pub steps: u64,
    /// Simulated time reached (s).
    pub simulated_secs: f64,
    /// Configured duration (s).
    pub duration_secs: f64,
    /// Record interval in steps.
    pub record_every_n_steps: u64,
    /// Command line that started the run.
    pub command_line: Vec<String>,
    /// Where the config came from (file path or "embedded default").
    pub config_source: String,
    /// The robot file, if a user's robot was simulated.
    pub robot_file: Option<String>,
    /// The table files of the run folder and the number of rows each holds: whole rows, each
    /// ending in a newline in a CSV file, also when the run failed (a CSV file is cut back to its
    /// last whole row on a write error) or was interrupted. Empty while the run goes on; after a
    /// SIGKILL it stays empty and a CSV file's last line may be cut (no newline).
    pub tables: Vec<(String, u64)>,
    /// MuJoCo warnings raised during the run (kind, count).
    pub mujoco_warnings: Vec<(String, i32)>,
    /// Summary metrics.
    pub summary: Option<RunSummary>,
    /// Plotting after the run (`general.plot = true`): `null` when not asked for (or not reached),
    /// `"written"`, `"interrupted"` (SIGINT/SIGTERM during plotting: the run itself is complete;
    /// `simserpent plot <run folder>` makes the plots) or `"failed: <reason>"`.
    #[serde(default)]
    pub plots: Option<String>,
    /// The live ROS 2 bridge of `run --ros2` (user guide, "ROS 2"): clock mode, commands accepted and
    /// rejected by reason, why the bridge stopped the run; absent without `--ros2`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ros2: Option<Ros2Report>,
}

impl Manifest {
    /// The manifest of the run in `folder` (`manifest.json`, a regular file inside the folder of
    /// at most [`crate::files::SMALL_FILE_CAP_BYTES`]), or `None` when it cannot be read as one.
    pub fn read(folder: &Path) -> Option<Self> {
        let path = folder.join("manifest.json");
        let text = crate::files::read_text_in(folder, &path, crate::files::SMALL_FILE_CAP_BYTES).ok()?;
        serde_json::from_str(&text).ok()
    }

    /// The manifest as written: pretty JSON and a newline.
    pub fn to_text(&self) -> String {
        // A derived Serialize of strings, numbers and plain enums cannot fail.
        serde_json::to_string_pretty(self)
            .map_or_else(|e| serde_json::json!({ "error": e.to_string() }).to_string(), |t| t + "\n")
    }

    /// Writes `manifest.json` into `folder` atomically: the text goes to `.manifest.json.tmp`
    /// in the same folder, which is synced and then renamed over `manifest.json` (and the
    /// folder synced). A reader, or a crash at any moment, sees the old manifest or the new one,
    /// never a mix; when the disk is full, the old one stays, whole. A run keeps disk space for
    /// its last manifest ([`SpaceReserve`]) so that this does not happen at its end.
    pub fn write(&self, folder: &Path) -> Result<(), RecordError> {
        let path = folder.join("manifest.json");
        let tmp = folder.join(".manifest.json.tmp");
        let written = write_synced(&tmp, self.to_text().as_bytes()).map_err(io_err(&tmp));
        let renamed = written.and_then(|()| std::fs::rename(&tmp, &path).map_err(io_err(&path)));
        if renamed.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        renamed?;
        sync_folder(folder);
        Ok(())
    }
}

/// Writes a new file and syncs it to disk.
fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let mut file = std::fs::File::create(path)?;
    file.write_all(bytes)?;
    file.sync_all()
}

/// Syncs a folder, so that renames in it reach the disk (best effort: not every file system
/// syncs folders).
pub(crate) fn sync_folder(folder: &Path) {
    if let Ok(dir) = std::fs::File::open(folder) {
        let _ = dir.sync_all();
    }
}

/// Disk space kept for a run's last manifest: `.simserpent-reserve` in the run folder, a file
/// of zeros written when the run folder is created and deleted just before the manifest that
/// says how the run ended is written (or when this is dropped). On a disk that fills during the
/// run, that manifest then still has room for its temporary file. A process killed with SIGKILL
/// leaves the file behind (about 24 KiB; safe to delete).
#[derive(Debug)]
pub struct SpaceReserve {
    path: Option<PathBuf>,
}

impl SpaceReserve {
    /// The file name in the run folder.
    pub const FILE: &'static str = ".simserpent-reserve";

    /// Reserves room for a manifest about `manifest_len` bytes long (the start manifest; the
    /// last one adds the summary, the table list and an error message): 16 KiB plus four times
    /// that, written as zeros (a sparse file would reserve nothing) and synced.
    pub fn create(folder: &Path, manifest_len: usize) -> Result<Self, RecordError> {
        let path = folder.join(Self::FILE);
        let bytes = vec![0u8; (16 << 10) + 4 * manifest_len];
        match write_synced(&path, &bytes) {
            Ok(()) => Ok(Self { path: Some(path) }),
            Err(e) => {
                let _ = std::fs::remove_file(&path);
                Err(io_err(&path)(e))
            }
        }
    }

    /// Frees the space (deletes the file); does nothing the second time.
    pub fn release(&mut self) {
        if let Some(path) = self.path.take() {
            let _ = std::fs::remove_file(path);
        }
    }
}

impl Drop for SpaceReserve {
    fn drop(&mut self) {
        self.release();
    }
}

#[cfg(test)]
mod tests {
    /// A resumed sweep reads its finished runs' metrics back from their manifests: the values
    /// must be the very floats written (serde_json's `float_roundtrip`), or its summary differs
    /// from a fresh sweep's in the last digits.
    #[test]
    fn manifest_floats_read_back_exactly() {
        let mut state = 0x9E37_79B9_7F4A_7C15_u64;
        let mut next = || {
            // xorshift64*: spread over every exponent and mantissa.
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            f64::from_bits(state.wrapping_mul(0x2545_F491_4F6C_DD1D))
        };
        let mut values: Vec<f64> =
            vec![0.023_099_576_232_632_802, 0.1, 1.0 / 3.0, 5e-324, f64::MAX, 2.225_073_858_507_201e-308];
        values.extend((0..20_000).map(|_| next()).filter(|x| x.is_finite()));
        for x in values {
            let text = serde_json::to_string(&x).expect("finite");
            let back: f64 = serde_json::from_str(&text).expect("a number");
            assert_eq!(back.to_bits(), x.to_bits(), "{x:e} written as {text}");
        }
    }
}

/// The short summary of a run (`run::RunSummary`), printed at the end and stored in the manifest.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RunSummary {
    /// The run folder.
    pub run_folder: PathBuf,
    /// Simulated time (s).
    pub simulated_secs: f64,
    /// Horizontal displacement of the robot's centre of mass from start to end (m).
    pub distance_m: f64,
    /// `distance_m` / simulated time (m/s).
    pub mean_speed_m_per_s: f64,
    /// Direction of that displacement in the xy-plane (degrees from +x).
    pub heading_deg: f64,
    /// Speed along the direction the head faced at the start (its link's +x axis in the
    /// xy-plane): the centre of mass's displacement projected on it, over the simulated time (m/s).
    #[serde(default)]
    pub forward_speed_m_per_s: f64,
    /// Largest contact normal force on one link averaged over 10 ms (N): per link, the normal
    /// impulse of all its contacts over any 10-ms window of steps divided by the window, the
    /// largest over links and windows, from every step (`state::ContactForcePeaks`). Converges as
    /// the timestep shrinks; an impact counts with its whole impulse.
    #[serde(default)]
    pub peak_contact_force_10ms_n: f64,
    /// The window of `peak_contact_force_10ms_n`: 10 ms rounded to whole steps (s).
    #[serde(default)]
    pub contact_force_window_secs: f64,
    /// Largest single contact's normal force at any step (N): the sharpest sampled transient;
    /// depends on the timestep and does not converge under stiff impacts.
    #[serde(default)]
    pub peak_contact_force_step_n: f64,
    /// Largest penetration seen at a recorded step (m).
    pub max_penetration_m: f64,
    /// Work done by the actuators, ∫ Σ_joints |τ·q̇| dt (J), from the joint-space actuator
    /// torques and joint velocities of the recorded steps, each held until the next one.
    #[serde(default)]
    pub actuator_energy_j: f64,
    /// How well each joint followed its commanded angle (the built-in controllers: the open-loop
    /// gait's angle, or a closed-loop controller's position set-point; `null` for a user's
    /// controller, a gait that does not move, or a closed-loop controller on other actuator kinds):
    /// amplitude reached, RMS and largest error, in rad and in % of the command amplitude, from
    /// the end of the gait's ramp-in on.
    #[serde(default)]
    pub tracking: Option<Vec<crate::state::JointTracking>>,
    /// Time during which some link touched an obstacle (s; from the recorded instants, each held
    /// until the next one).
    #[serde(default)]
    pub obstacle_contact_secs: f64,
    /// How far below the model's starting pose (`model.xml`'s keyframe `initial`) the snake
    /// started (m): the depth at which the floor's contact law carries its weight when it starts
    /// at rest lying on level ground (`sim::Ground::static_start_sink_m`), 0 otherwise.
    #[serde(default)]
    pub start_sink_m: f64,
    /// What the user should know about how the run was set up (e.g. joints no actuator drives).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// Steps per second of wall time.
    pub steps_per_wall_sec: f64,
    /// Simulated seconds per wall second.
    pub real_time_factor: f64,
    /// CPU time the step-loop thread used over the same interval as `steps_per_wall_sec`'s
    /// wall time (s; `simserpent bench`; not stored in the manifest: it says nothing about the
    /// run's physics and differs from run to run).
    #[serde(skip)]
    pub loop_cpu_secs: f64,
}

/// The counts of a live ROS 2 run (`ros2::Ros2Report`), for the manifest (`ros2` in `manifest.json`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Ros2Report {
    /// `ros2.clock`: "free" or "lockstep".
    pub clock: String,
    /// DDS domain id.
    pub domain_id: u16,
    /// Valid commands applied.
    pub commands_accepted: u64,
    /// Rejected commands by reason (the last valid command held).
    pub rejected_wrong_length: u64,
    pub rejected_not_finite: u64,
    pub rejected_unknown_joint: u64,
    pub rejected_wrong_interface: u64,
    pub rejected_bad_trajectory: u64,
    pub rejected_undecodable: u64,
    /// Instants at which the state topics were published.
    pub published_instants: u64,
    /// Lockstep: commands waited for (and received).
    pub lockstep_commands: u64,
    /// Lockstep: how often the state of the first command instant was published again because
    /// no command answered it within `ros2::FIRST_STATE_RESEND_SECS` (a peer's reader
    /// that matched the bridge's writer only after the first sample had been sent never gets
    /// that sample; user guide, "ROS 2", "Clock modes").
    #[serde(default)]
    pub lockstep_state_resends: u64,
    /// Lockstep: valid commands that answered a resent copy of the first state after the
    /// first answer had come (applied, counted in `commands_accepted`, but not as the answer
    /// to a later instant).
    #[serde(default)]
    pub lockstep_extra_answers: u64,
    /// Why the bridge stopped the run early (a lockstep peer that went silent), if it did.
    pub stopped: Option<String>,
}
