//! `state.csv`: the full engine state on every recorded step, so that a run can be replayed into
//! pictures afterwards (`simserpent render RUN_FOLDER`).
//!
//! Columns: `time_s`, then `qpos_0 … qpos_{nq-1}`, `qvel_0 …`, `act_0 …`, `ctrl_0 …` in MuJoCo's
//! order (`mj_getState` with `mjSTATE_QPOS | QVEL | ACT | CTRL`). With the model of the same run
//! folder (`model.xml`) and `mj_forward`, a row gives back every position, contact and contact force
//! of that instant.

use super::RenderError;
use crate::record::CsvTable;
use crate::record::RecordError;
use crate::record::offload::{Offload, Sink};
use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_model::traits::ModelType;
use std::path::{Path, PathBuf};

/// The state components of a row, `time_s` first (MuJoCo's `mjtState` bits; `mj_getState` writes
/// them in bit order, which is the column order).
pub const STATE_SPEC: u32 = MjtState::mjSTATE_TIME as u32
    | MjtState::mjSTATE_QPOS as u32
    | MjtState::mjSTATE_QVEL as u32
    | MjtState::mjSTATE_ACT as u32
    | MjtState::mjSTATE_CTRL as u32;

/// The file name inside a run folder.
pub const STATE_FILE: &str = "state.csv";

/// Sizes of the state blocks of a model: `(nq, nv, na, nu)`.
pub fn state_sizes(model: &MjModel) -> (usize, usize, usize, usize) {
    let f = model.ffi();
    (f.nq as usize, f.nv as usize, f.na as usize, f.nu as usize)
}

/// The header of `state.csv` for a model.
pub fn state_header(model: &MjModel) -> Vec<String> {
    let (nq, nv, na, nu) = state_sizes(model);
    let mut h = vec!["time_s".to_string()];
    for (name, n) in [("qpos", nq), ("qvel", nv), ("act", na), ("ctrl", nu)] {
        h.extend((0..n).map(|i| format!("{name}_{i}")));
    }
    h
}

/// Writes `state.csv` as the run goes, on a writer thread of its own
/// ([`crate::record::offload`]): the step loop copies the state into a preallocated row buffer,
/// the writer thread formats and writes it (no allocation per row on either side). The file is
/// byte for byte that of formatting in the loop (`threaded = false`).
pub struct StateWriter {
    out: Offload<StateSink>,
    path: PathBuf,
}

/// One row: the state as `mj_getState` wrote it (its first `len` values).
pub struct StateRow {
    len: usize,
    values: Vec<f64>,
}

/// The file, on the writer thread.
pub struct StateSink {
    table: CsvTable,
}

impl Sink for StateSink {
    type Row = StateRow;
    fn write(&mut self, row: &StateRow) -> Result<(), RecordError> {
        // The path is only copied on error: a recorded step allocates nothing.
        match self.table.nums(&row.values[..row.len]).and_then(|()| self.table.end_row()) {
            Ok(()) => Ok(()),
            Err(e) => Err(crate::record::io_err(self.table.path())(e)),
        }
    }
    fn flush(&mut self) -> Result<(), RecordError> {
        self.table.flush().map_err(crate::record::io_err(self.table.path()))
    }
}

fn render_err(e: RecordError) -> RenderError {
    match e {
        RecordError::Io { path, source } => RenderError::Io { path, source },
    }
}

impl StateWriter {
    /// Creates `<folder>/state.csv` for `model`, written on a writer thread (`threaded`) or in
    /// the caller's thread.
    pub fn create(folder: &Path, model: &MjModel, threaded: bool) -> Result<Self, RenderError> {
        let path = folder.join(STATE_FILE);
        let table = CsvTable::create(&path, &state_header(model)).map_err(RenderError::io(&path))?;
        let size = model.state_size(STATE_SPEC);
        let row = || StateRow { len: 0, values: vec![0.0; size] };
        let out = Offload::new(StateSink { table }, row, path.clone(), threaded).map_err(render_err)?;
        Ok(Self { out, path })
    }

    /// Appends the current state of `data`.
    pub fn write<M: ModelType>(&mut self, data: &MjData<M>) -> Result<(), RenderError> {
        let row = self.out.slot().map_err(render_err)?;
        row.len =
            data.try_read_state_into(STATE_SPEC, &mut row.values).map_err(|e| RenderError::Engine(e.to_string()))?;
        self.out.commit().map_err(render_err)
    }

    /// Flushes and closes the file (also after a write error: it keeps its whole rows); returns
    /// its path and the number of rows.
    pub fn finish(self) -> Result<(PathBuf, u64), RenderError> {
        let (sink, pending) = self.out.finish();
        let Some(sink) = sink else {
            return Err(pending
                .map_err(render_err)
                .err()
                .unwrap_or_else(|| RenderError::io(&self.path)(std::io::Error::other("the writer thread stopped"))));
        };
        let (rows, closed) = sink.table.close();
        pending.map_err(render_err)?;
        closed.map_err(RenderError::io(&self.path))?;
        Ok((self.path, rows))
    }
}

/// A recorded `state.csv`, read back whole: `times[k]` and `row(k)` (the whole row, time first, as
/// [`STATE_SPEC`] lays it out).
#[derive(Debug, Clone)]
pub struct StateTrack {
    /// Simulated time of every row (s).
    pub times: Vec<f64>,
    /// Values per row (with the time).
    pub width: usize,
    values: Vec<f64>,
}

impl StateTrack {
    /// Reads `state.csv`; checks that its columns fit `model`.
    pub fn read(path: &Path, model: &MjModel) -> Result<Self, RenderError> {
        let bad = |message: String| RenderError::BadFile { path: path.to_path_buf(), message };
        // A regular file inside the run folder, at most 1 GiB ([`crate::files`]' reader).
        let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let text = crate::files::read_text_in(folder, path, crate::files::TABLE_CAP_BYTES).map_err(|e| match e {
            crate::files::FileError::Io { source, .. } => RenderError::read(path)(source),
            crate::files::FileError::Missing { .. } => {
                RenderError::read(path)(std::io::Error::from(std::io::ErrorKind::NotFound))
            }
            other => bad(other.to_string()),
        })?;
        let mut lines = text.lines();
        let header = lines.next().ok_or_else(|| bad("the file is empty".into()))?;
        let expected = state_header(model);
        if header.split(',').map(str::trim).ne(expected.iter().map(String::as_str)) {
            return Err(bad(format!(
                "its columns do not fit the run's model.xml (expected {} columns: time_s, qpos_*, qvel_*, act_*, ctrl_*)",
                expected.len()
            )));
        }
        let width = expected.len();
        let mut times = Vec::new();
        let mut values = Vec::new();
        let rows: Vec<&str> = lines.filter(|l| !l.trim().is_empty()).collect();
        for (i, line) in rows.iter().enumerate() {
            let before = values.len();
            let mut parsed = true;
            for f in line.split(',') {
                match crate::files::parse_number(f) {
                    Ok(v) => values.push(v),
                    Err(_) if i + 1 == rows.len() => parsed = false,
                    Err(why) => return Err(bad(format!("row {}: {f:?} {why}", i + 1))),
                }
            }
            if !parsed || values.len() - before != width {
                if i + 1 < rows.len() {
                    return Err(bad(format!("row {} has {} values, expected {width}", i + 1, values.len() - before)));
                }
                // A run that was killed may leave a half-written last line: stop there.
                values.truncate(before);
                break;
            }
            times.push(values[before]);
        }
        if times.is_empty() {
            return Err(bad("it holds no complete row".into()));
        }
        Ok(Self { times, width, values })
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// Whether there are no rows (never true for a track that [`StateTrack::read`] returned).
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    /// Row `k`: time, qpos, qvel, act, ctrl.
    pub fn row(&self, k: usize) -> &[f64] {
        &self.values[k * self.width..(k + 1) * self.width]
    }

    /// The last row at or before time `t` (the first row if `t` is earlier than all).
    pub fn index_at(&self, t: f64) -> usize {
        // Tolerate rounding of the recorded times.
        let eps = 1e-9 * t.abs().max(1.0);
        self.times.partition_point(|&x| x <= t + eps).saturating_sub(1)
    }
}
