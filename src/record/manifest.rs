//! `manifest.json`: what produced a run folder and how the run ended.

use super::{RecordError, io_err};
use serde::{Deserialize, Serialize};
use std::path::Path;

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
    /// Tables and their row counts.
    pub tables: Vec<(String, u64)>,
    /// MuJoCo warnings raised during the run (kind, count).
    pub mujoco_warnings: Vec<(String, i32)>,
    /// Summary metrics.
    pub summary: Option<crate::run::RunSummary>,
}

impl Manifest {
    /// Writes `manifest.json` into `folder` atomically (write to a temporary file, then rename),
    /// so a reader never sees half a manifest. When the temporary file cannot be written (a full
    /// disk), an existing manifest is overwritten in place instead.
    pub fn write(&self, folder: &Path) -> Result<(), RecordError> {
        let path = folder.join("manifest.json");
        let tmp = folder.join("manifest.json.tmp");
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| RecordError::Io { path: path.clone(), source: std::io::Error::other(e) })?;
        let text = text + "\n";
        match std::fs::write(&tmp, &text) {
            Ok(()) => std::fs::rename(&tmp, &path).map_err(io_err(&path)),
            Err(e) => {
                let _ = std::fs::remove_file(&tmp);
                // A full disk has no room for a second file, but the manifest written when the
                // run started has its blocks already: overwrite it in place, so that it still
                // says how the run ended.
                overwrite_in_place(&path, text.as_bytes()).map_err(|_| io_err(&tmp)(e))
            }
        }
    }
}

/// Overwrites an existing file with `bytes` without creating a new one (not atomic).
fn overwrite_in_place(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let mut file = std::fs::OpenOptions::new().write(true).open(path)?;
    file.write_all(bytes)?;
    file.set_len(bytes.len() as u64)?;
    file.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;

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
