//! MuJoCo's interactive viewer.
//!
//! Two implementations, chosen at build time:
//! - cargo feature `viewer` (off by default: it pulls winit and glutin's window code): the
//!   viewer of mujoco-rs, in this process. `simserpent run --viewer` then shows the run live.
//! - without it: Python's `mujoco.viewer` from the same `mujoco==3.17.0` wheel
//!   (`python3 -m mujoco.viewer --mjcf FILE`), which costs nothing to build. `simserpent run
//!   --viewer` then replays the finished run (its `state.csv`) in Python's passive viewer at
//!   real time.
//!
//! Both need a display: on Linux without `DISPLAY` or `WAYLAND_DISPLAY` the command stops with
//! exit code 2 and says so. On Windows (no `viewer` feature there) Python's viewer runs through
//! `python` with `pip install mujoco==3.17.0`.

use super::RenderError;
use std::path::Path;

/// Fails with a clear message when there is no display to open a window on.
pub fn check_display() -> Result<(), RenderError> {
    // A Windows desktop always has a display.
    if cfg!(windows) {
        return Ok(());
    }
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    if set("DISPLAY") || set("WAYLAND_DISPLAY") {
        Ok(())
    } else {
        Err(RenderError::NoViewer(
            "the interactive viewer needs a display, but neither DISPLAY (X11) nor WAYLAND_DISPLAY (Wayland) \
             is set; on a machine without a screen use `--video`, `simserpent render RUN_FOLDER` or \
             `simserpent plot RUN_FOLDER` instead"
                .into(),
        ))
    }
}

/// Python program that replays a run folder's `state.csv` in `mujoco.viewer.launch_passive`.
#[cfg(not(feature = "viewer"))]
const PYTHON_REPLAY: &str = r#"
import csv, sys, time
import numpy as np
import mujoco, mujoco.viewer
folder = sys.argv[1]
m = mujoco.MjModel.from_xml_path(folder + "/model.xml")
d = mujoco.MjData(m)
S = mujoco.mjtState
spec = int(S.mjSTATE_TIME | S.mjSTATE_QPOS | S.mjSTATE_QVEL | S.mjSTATE_ACT | S.mjSTATE_CTRL)
with open(folder + "/state.csv") as f:
    rows = [np.array([float(x) for x in r]) for r in list(csv.reader(f))[1:] if r]
with mujoco.viewer.launch_passive(m, d) as v:
    start = time.time()
    for r in rows:
        if not v.is_running():
            break
        mujoco.mj_setState(m, d, r, spec)
        mujoco.mj_forward(m, d)
        v.sync()
        delay = (r[0] - rows[0][0]) - (time.time() - start)
        if delay > 0:
            time.sleep(delay)
    while v.is_running():
        time.sleep(0.05)
"#;

#[cfg(not(feature = "viewer"))]
fn python_failed(what: &str, e: impl std::fmt::Display) -> RenderError {
    RenderError::NoViewer(format!(
        "cannot start Python's MuJoCo viewer ({what}: {e}); it needs python3 with `pip install mujoco==3.17.0`, \
         or build SimSerpent with `--features viewer`"
    ))
}

#[cfg(not(feature = "viewer"))]
fn run_python(args: &[&std::ffi::OsStr]) -> Result<(), RenderError> {
    // Python's installer for Windows puts `python` on PATH, not `python3`.
    let python = if cfg!(windows) { "python" } else { "python3" };
    let status = std::process::Command::new(python).args(args).status().map_err(|e| python_failed(python, e))?;
    if status.success() { Ok(()) } else { Err(python_failed(python, format!("exited with {status}"))) }
}

/// Opens the viewer on a model file (MJCF or URDF); the viewer simulates it interactively.
pub fn view_model_file(path: &Path) -> Result<(), RenderError> {
    check_display()?;
    if !path.is_file() {
        return Err(RenderError::BadFile { path: path.to_path_buf(), message: "no such model file".into() });
    }
    #[cfg(feature = "viewer")]
    {
        native::view_model_file(path)
    }
    #[cfg(not(feature = "viewer"))]
    {
        run_python(&["-m".as_ref(), "mujoco.viewer".as_ref(), "--mjcf".as_ref(), path.as_os_str()])
    }
}

/// Opens the viewer on a generated model. Its files (`model.xml`, the scene files, a third-party
/// terrain and its assets) are written into a private scratch folder (random name, created
/// exclusively, mode 0700: see [`crate::sim::scratch_dir`]), removed when the viewer closes.
pub fn view_generated(generated: &crate::model::GeneratedModel) -> Result<(), RenderError> {
    use crate::sim::SimError;
    check_display()?;
    let scratch = crate::sim::scratch_dir("view").map_err(|e| RenderError::BadFile {
        path: std::env::temp_dir(),
        message: format!("cannot create a scratch folder ({e})"),
    })?;
    let f = &generated.files;
    let model =
        crate::sim::write_model_folder(scratch.path(), &generated.xml, &f.texts, &f.copies).map_err(|e| match e {
            SimError::Write { path, source } => RenderError::Io { path, source },
            other => RenderError::BadFile { path: scratch.path().to_path_buf(), message: other.to_string() },
        })?;
    view_model_file(&model)
}

/// Replays a run folder (`model.xml` + `state.csv`) in the viewer at real time.
pub fn replay_run_folder(folder: &Path) -> Result<(), RenderError> {
    check_display()?;
    for file in ["model.xml", super::STATE_FILE] {
        let path = folder.join(file);
        if !path.is_file() {
            return Err(RenderError::BadFile {
                path,
                message: "missing: replaying a run needs model.xml and state.csv (render.record_state = true)".into(),
            });
        }
    }
    #[cfg(feature = "viewer")]
    {
        native::replay_run_folder(folder)
    }
    #[cfg(not(feature = "viewer"))]
    {
        run_python(&["-c".as_ref(), PYTHON_REPLAY.as_ref(), folder.as_os_str()])
    }
}

#[cfg(feature = "viewer")]
pub use native::LiveViewer;

#[cfg(feature = "viewer")]
mod native {
    use super::*;
    use mujoco_rs::prelude::*;
    use mujoco_rs::viewer::MjViewer;
    use mujoco_rs::wrappers::mj_model::traits::ModelType;
    use std::time::{Duration, Instant};

    fn open(model: &MjModel) -> Result<MjViewer, RenderError> {
        MjViewer::launch_passive(model, 0).map_err(|e| RenderError::NoViewer(format!("cannot open the viewer: {e}")))
    }

    pub(super) fn view_model_file(path: &Path) -> Result<(), RenderError> {
        let model = MjModel::from_xml(path).map_err(|e| RenderError::BadFile {
            path: path.to_path_buf(),
            message: format!("MuJoCo cannot load it ({e})"),
        })?;
        let mut viewer = open(&model)?;
        let mut data = MjData::new(&model);
        data.forward();
        let dt = model.opt().timestep;
        let started = Instant::now();
        while viewer.running() {
            while data.time() < started.elapsed().as_secs_f64() {
                data.step();
            }
            viewer.sync_data(&mut data);
            viewer.render().map_err(|e| RenderError::NoViewer(format!("viewer: {e}")))?;
            std::thread::sleep(Duration::from_secs_f64(dt.clamp(0.001, 0.016)));
        }
        Ok(())
    }

    pub(super) fn replay_run_folder(folder: &Path) -> Result<(), RenderError> {
        let path = folder.join("model.xml");
        let model = MjModel::from_xml(&path).map_err(|e| RenderError::BadFile {
            path: path.clone(),
            message: format!("MuJoCo cannot load it ({e})"),
        })?;
        let track = super::super::StateTrack::read(&folder.join(super::super::STATE_FILE), &model)?;
        let mut viewer = open(&model)?;
        let mut data = MjData::new(&model);
        let started = Instant::now();
        let t0 = track.times[0];
        for k in 0..track.len() {
            if !viewer.running() {
                return Ok(());
            }
            data.set_state(track.row(k), super::super::state::STATE_SPEC)
                .map_err(|e| RenderError::Engine(e.to_string()))?;
            data.forward();
            viewer.sync_data(&mut data);
            viewer.render().map_err(|e| RenderError::NoViewer(format!("viewer: {e}")))?;
            let ahead = (track.times[k] - t0) - started.elapsed().as_secs_f64();
            if ahead > 0.0 {
                std::thread::sleep(Duration::from_secs_f64(ahead));
            }
        }
        while viewer.running() {
            viewer.render().map_err(|e| RenderError::NoViewer(format!("viewer: {e}")))?;
            std::thread::sleep(Duration::from_millis(16));
        }
        Ok(())
    }

    /// The viewer showing a run as it goes, paced to real time (at most 60 redraws per second).
    pub struct LiveViewer {
        viewer: MjViewer,
        /// The viewer's own copy of the state: the simulation's is only read, so the viewer
        /// (its mouse perturbations included) never changes the trajectory.
        data: MjData<Box<MjModel>>,
        started: Instant,
        last_draw: Option<Instant>,
    }

    impl LiveViewer {
        /// Opens the viewer on the run's model.
        pub fn open(model: &MjModel) -> Result<Self, RenderError> {
            check_display()?;
            Ok(Self {
                viewer: open(model)?,
                data: MjData::new(Box::new(model.clone())),
                started: Instant::now(),
                last_draw: None,
            })
        }

        /// Shows the state of `data` if a redraw is due; waits so the run goes at real time.
        pub fn sync<M: ModelType>(&mut self, data: &MjData<M>) {
            if !self.viewer.running() {
                return;
            }
            let ahead = data.time() - self.started.elapsed().as_secs_f64();
            if ahead > 0.0 {
                std::thread::sleep(Duration::from_secs_f64(ahead));
            }
            if self.last_draw.is_none_or(|t| t.elapsed() >= Duration::from_millis(16)) {
                let spec = super::super::state::STATE_SPEC;
                if let Err(e) = self.data.set_state(&data.state(spec), spec) {
                    log::warn!("viewer: {e}");
                }
                self.data.forward();
                self.viewer.sync_data(&mut self.data);
                if let Err(e) = self.viewer.render() {
                    log::warn!("viewer: {e}");
                }
                self.last_draw = Some(Instant::now());
            }
        }
    }
}
