//! The offscreen painter: a private copy of the run's model and engine state, drawn by MuJoCo's
//! OpenGL renderer through EGL (Mesa's software renderer on machines without a GPU).
//!
//! The painter never touches the simulation's own `MjData`: it copies the state in
//! (`mj_getState`/`mj_setState`), runs `mj_forward` on its copy (so contacts and contact forces
//! are those of that instant) and draws it. Its model is compiled from the run folder's
//! `model.xml` with the offscreen buffer enlarged to the configured picture size.

use super::RenderError;
use super::state::STATE_SPEC;
use crate::config::{CameraKind, Config, Render, RenderQuality, Visual};
use mujoco_rs::prelude::*;
use mujoco_rs::renderer::MjRenderer;
use mujoco_rs::wrappers::mj_model::traits::ModelType;
use std::path::Path;

/// Draws engine states into RGB pictures.
pub struct Painter {
    data: MjData<Box<MjModel>>,
    renderer: MjRenderer,
    settings: Render,
    head_body: usize,
    state: Vec<f64>,
    width: usize,
    height: usize,
}

impl std::fmt::Debug for Painter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Painter").field("width", &self.width).field("height", &self.height).finish_non_exhaustive()
    }
}

impl Painter {
    /// A painter for the model in `model_xml` (a run folder's `model.xml`, or any MJCF/URDF).
    pub fn new(model_xml: &Path, config: &Config) -> Result<Self, RenderError> {
        let mut model = MjModel::from_xml(model_xml).map_err(|e| RenderError::BadFile {
            path: model_xml.to_path_buf(),
            message: format!("MuJoCo cannot load it ({e})"),
        })?;
        let r = &config.render;
        let (width, height) = (r.width_px as usize, r.height_px as usize);
        {
            let global = &mut model.vis_mut().global;
            global.offwidth = global.offwidth.max(r.width_px as i32);
            global.offheight = global.offheight.max(r.height_px as i32);
        }
        set_quality(&mut model, r.quality);
        if config.visual.show_contact_forces {
            scale_force_arrows(&mut model);
        }
        let head_body = model
            .name_to_id(MjtObjBase::mjOBJ_BODY, &crate::model::names::link_body(0))
            .unwrap_or(if model.ffi().nbody > 1 { 1 } else { 0 });
        let renderer = MjRenderer::builder()
            .width(r.width_px)
            .height(r.height_px)
            .rgb(true)
            .depth(false)
            .opts(visual_options(&config.visual))
            .build(&model)
            .map_err(|e| RenderError::NoRenderer(e.to_string()))?;
        let state = vec![0.0; model.state_size(STATE_SPEC)];
        let mut data = MjData::new(Box::new(model));
        data.forward();
        Ok(Self { data, renderer, settings: r.clone(), head_body, state, width, height })
    }

    /// Picture size in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Copies the state of a running simulation (same model) into the painter.
    pub fn copy_state_from<M: ModelType>(&mut self, source: &MjData<M>) -> Result<(), RenderError> {
        source.try_read_state_into(STATE_SPEC, &mut self.state).map_err(|e| RenderError::Engine(e.to_string()))?;
        self.data.set_state(&self.state, STATE_SPEC).map_err(|e| RenderError::Engine(e.to_string()))?;
        self.data.forward();
        Ok(())
    }

    /// Sets a recorded state (a `state.csv` row: time, qpos, qvel, act, ctrl).
    pub fn set_state(&mut self, row: &[f64]) -> Result<(), RenderError> {
        self.data.set_state(row, STATE_SPEC).map_err(|e| RenderError::Engine(e.to_string()))?;
        self.data.forward();
        Ok(())
    }

    /// Simulated time of the state in the painter.
    pub fn time(&self) -> f64 {
        self.data.time()
    }

    /// Draws the current state from `camera`; returns the picture, RGB, rows top to bottom.
    pub fn paint(&mut self, camera: CameraKind) -> Result<&[u8], RenderError> {
        let cam = self.camera(camera);
        self.renderer.set_camera(cam);
        self.renderer.sync_data(&mut self.data).map_err(|e| RenderError::NoRenderer(e.to_string()))?;
        self.renderer.render().map_err(|e| RenderError::NoRenderer(e.to_string()))?;
        self.renderer.rgb_flat().ok_or_else(|| RenderError::NoRenderer("RGB rendering is off".into()))
    }

    fn camera(&self, kind: CameraKind) -> MjvCamera {
        let r = &self.settings;
        let mut cam = match kind {
            CameraKind::Follow | CameraKind::Top => MjvCamera::new_tracking(self.head_body),
            CameraKind::Fixed => {
                let mut c = MjvCamera::new_free(self.data.model());
                c.lookat = r.fixed_lookat_m;
                c
            }
        };
        cam.distance = r.camera_distance_m;
        match kind {
            CameraKind::Top => {
                cam.azimuth = 90.0;
                cam.elevation = -90.0;
            }
            _ => {
                cam.azimuth = r.camera_azimuth_deg;
                cam.elevation = r.camera_elevation_deg;
            }
        }
        cam
    }
}

/// Turns rendering effects down on the painter's own copy of the model (`render.quality`).
fn set_quality(model: &mut MjModel, quality: RenderQuality) {
    if quality == RenderQuality::Full {
        return;
    }
    let q = &mut model.vis_mut().quality;
    q.offsamples = 0;
    q.shadowsize = q.shadowsize.min(1024);
    if quality == RenderQuality::Fast {
        for s in model.light_castshadow_mut() {
            *s = Default::default();
        }
    }
    for r in model.mat_reflectance_mut() {
        *r = 0.0;
    }
}

/// Contact force arrows long enough to see: the robot's whole weight draws an arrow a tenth as long
/// as the model (MuJoCo's default, 5 mm per newton, hides a 3 N arrow inside a link). A scale set
/// in the model (`<visual><map force=…>`) is kept.
fn scale_force_arrows(model: &mut MjModel) {
    let mass: f64 = model.body_mass().iter().sum();
    let g = model.opt().gravity;
    let weight = mass * (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
    let extent = model.stat().extent;
    let map = &mut model.vis_mut().map;
    if (map.force - 0.005).abs() < 1e-9 && weight > 0.0 && extent > 0.0 {
        map.force = (0.1 * extent / weight) as f32;
    }
}

/// MuJoCo's visualisation flags for the `[visual]` options of the config.
pub fn visual_options(v: &Visual) -> MjvOption {
    let mut opt = MjvOption::default();
    for (on, flag) in [
        (v.show_contact_points, MjtVisFlag::mjVIS_CONTACTPOINT),
        (v.show_contact_forces, MjtVisFlag::mjVIS_CONTACTFORCE),
        (v.show_actuators, MjtVisFlag::mjVIS_ACTUATOR),
        (v.show_joints, MjtVisFlag::mjVIS_JOINT),
        (v.show_center_of_mass, MjtVisFlag::mjVIS_COM),
        (v.make_transparent, MjtVisFlag::mjVIS_TRANSPARENT),
    ] {
        opt.flags[flag as usize] = u8::from(on);
    }
    opt
}
