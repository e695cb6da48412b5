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
    pub summary: Option<crate::run::RunSummary>,
    /// Plotting after the run (`general.plot = true`): `null` when not asked for (or not reached),
    /// `"written"`, `"interrupted"` (SIGINT/SIGTERM during plotting: the run itself is complete;
    /// `simserpent plot <run folder>` makes the plots) or `"failed: <reason>"`.
    #[serde(default)]
    pub plots: Option<String>,
    /// The live ROS 2 bridge of `run --ros2` (user guide, "ROS 2"): clock mode, commands accepted and
    /// rejected by reason, why the bridge stopped the run; absent without `--ros2`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ros2: Option<crate::ros2::Ros2Report>,
}

impl Manifest {
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
