//! Ground friction models that need work at every step (see `[ground]` in the config).
//!
//! - **anisotropic**: nothing to do at run time — one contact pair per link and floor with
//!   friction `axial lateral` (MuJoCo aligns the first tangent of a capsule–plane contact with
//!   the capsule axis, checked in `tests/it/locomotion.rs`).
//! - **directional**: before every step, each link's sliding direction along its own axis picks
//!   the axial coefficient of its pair: `axial_friction` when it slides forward (toward the head,
//!   the link's +x axis), `backward_friction` when it slides backward. Limits: the switch happens
//!   at step boundaries from the velocity at the start of the step, so within one step friction
//!   cannot change sign of preference; a link at rest (|v_axial| < 1 mm/s) keeps the coefficient
//!   of its last sliding direction, so its static friction limit is that direction's. This is a
//!   model of scales or wheels that grip in one direction, not of a true ratchet.
//! - **viscous** (Liljebäck, Pettersen, Stavdahl and Gravdahl, *Snake Robots: Modelling, Mechatronics, and
//!   Control*, Springer 2013, ch. 2, the viscous ground friction model): before every
//!   step each link gets the force `−c_t·v_t·t − c_n·v_n·n` at its centre of mass, where `t` is
//!   the link's axis and `n` its normal in the horizontal plane and `v_t`, `v_n` the components of
//!   its centre-of-mass velocity; the floor itself is frictionless (it still carries the weight).
//!   The force is held constant over the step (fine at 1 ms against the gait's time scales).
//!
//! **Floor surfaces** (`[[ground.surfaces]]`, see `config::surfaces`): before every step each
//! link's centre of mass (`xipos`, from `mj_kinematics` at the state x_k) is looked up in the
//! [`SurfaceMap`] (later surfaces win, borders belong to the surface); the link's region gives the
//! coefficients of its pair (isotropic `μ μ torsional rolling rolling`, anisotropic
//! `axial lateral`, directional `forward|backward lateral`) or its viscous coefficients. A pair is
//! only rewritten when the link's region (or, directional, its sliding direction) changes. Limits:
//! the whole link meets one region's friction — a link straddling a border switches when its
//! centre crosses it (MuJoCo cannot give the two end contacts of one capsule–plane pair different
//! friction); and the switch happens at step boundaries, so a link sliding at v crosses up to
//! v·dt into a region with the old friction (0.5 mm at 0.5 m/s and 1 ms).
//!
//! Velocities are those of the state at the start of the step: kinematics and centre-of-mass
//! velocities are recomputed first (`mj_kinematics`, `mj_comPos`, `mj_comVel`), because after
//! `mj_step` MuJoCo's derived quantities belong to an integrator stage, not to the new state.

use super::World;
use crate::config::{Config, GroundModel};
use crate::model::{SurfaceMap, names};
use mujoco_rs::prelude::MjtObjBase;

/// Below this axial speed (m/s) a link counts as not sliding (directional model).
const SLIDING_EPSILON_M_PER_S: f64 = 1e-3;

/// Per-step work of the ground friction model.
#[derive(Debug, Clone)]
pub struct Ground {
    model: GroundModel,
    /// Floor surfaces and the coefficients of every region (region 0 = the plain floor).
    map: SurfaceMap,
    /// Torsional and rolling coefficients of the isotropic pairs (`snake.ground_friction[1..]`).
    torsional: f64,
    rolling: f64,
    /// Contact pair id per link (directional, and every Coulomb model with surfaces).
    pairs: Vec<usize>,
    /// Whether each link's pair currently has the forward coefficient.
    forward_now: Vec<bool>,
    /// The region each link's pair (or viscous force) currently uses (0 = plain floor).
    region_now: Vec<usize>,
    /// Body id per link.
    bodies: Vec<usize>,
}

impl Ground {
    /// The ground model of `config` for `world` (pair ids resolved once).
    pub fn new(config: &Config, world: &World) -> Self {
        let g = &config.ground;
        let n = world.n_links();
        let pairs: Vec<usize> =
            (0..n).filter_map(|i| world.model().name_to_id(MjtObjBase::mjOBJ_PAIR, &names::ground_pair(i))).collect();
        let mut map = SurfaceMap::from_config(config);
        // Without its pairs (a user's robot) the directional model and the surfaces have nothing to
        // switch (model generation rejects surfaces with a user's robot).
        let model = match g.model {
            GroundModel::Directional if pairs.len() != n => GroundModel::Isotropic,
            m => m,
        };
        if pairs.len() != n && model != GroundModel::Viscous {
            map = SurfaceMap::default();
        }
        Self {
            model,
            map,
            torsional: config.snake.ground_friction[1],
            rolling: config.snake.ground_friction[2],
            forward_now: vec![true; pairs.len()],
            region_now: vec![0; n],
            pairs,
            bodies: world.index.links.iter().map(|l| l.body).collect(),
        }
    }

    /// Whether this model does anything per step.
    pub fn is_active(&self) -> bool {
        matches!(self.model, GroundModel::Directional | GroundModel::Viscous) || !self.map.is_empty()
    }

    /// The floor surfaces (empty without `[[ground.surfaces]]`).
    pub fn surfaces(&self) -> &SurfaceMap {
        &self.map
    }

    /// The region each link met in the latest prepared step: 0 = plain floor, `k + 1` =
    /// `ground.surfaces[k]` (all 0 without surfaces).
    pub fn link_regions(&self) -> &[usize] {
        &self.region_now
    }

    /// Prepares the coming step: looks up the surface under each link, switches pair friction
    /// (surfaces, directional) or writes the viscous forces into `xfrc_applied`. Does not
    /// allocate.
    pub fn before_step(&mut self, world: &mut World) {
        if !self.is_active() {
            return;
        }
        let needs_velocity = matches!(self.model, GroundModel::Directional | GroundModel::Viscous);
        world.data.kinematics();
        if needs_velocity {
            world.data.com_pos();
            world.data.com_vel();
        }
        let surfaces = !self.map.is_empty();
        for (i, &body) in self.bodies.iter().enumerate() {
            let region = if surfaces {
                let c = world.data.xipos()[body];
                self.map.region_at(c[0], c[1])
            } else {
                0
            };
            let changed = region != self.region_now[i];
            self.region_now[i] = region;
            let f = *self.map.friction(region);
            match self.model {
                GroundModel::Isotropic | GroundModel::Anisotropic => {
                    if changed {
                        let friction = if self.model == GroundModel::Isotropic {
                            [f.sliding, f.sliding, self.torsional, self.rolling, self.rolling]
                        } else {
                            [f.axial, f.lateral, 0.0, 0.0, 0.0]
                        };
                        world.set_pair_friction(self.pairs[i], friction);
                    }
                    continue;
                }
                GroundModel::Directional | GroundModel::Viscous => {}
            }
            let xmat = world.data.xmat()[body];
            // The link's x axis (toward the head) in world coordinates: first column of xmat.
            let axis = [xmat[0], xmat[3], xmat[6]];
            let vel = world.data.object_velocity(MjtObjBase::mjOBJ_BODY, body, false);
            let v = [vel[3], vel[4], vel[5]];
            match self.model {
                GroundModel::Directional => {
                    let v_axial = v[0] * axis[0] + v[1] * axis[1] + v[2] * axis[2];
                    // At rest a link keeps the coefficient of its last sliding direction.
                    let forward =
                        if v_axial.abs() < SLIDING_EPSILON_M_PER_S { self.forward_now[i] } else { v_axial > 0.0 };
                    if forward != self.forward_now[i] || changed {
                        let axial = if forward { f.axial } else { f.backward };
                        world.set_pair_friction(self.pairs[i], [axial, f.lateral, 0.0, 0.0, 0.0]);
                        self.forward_now[i] = forward;
                    }
                }
                GroundModel::Viscous => {
                    let (c_t, c_n) = (f.viscous_tangential, f.viscous_normal);
                    // Horizontal tangent t and normal n of the link.
                    let norm = axis[0].hypot(axis[1]);
                    let force = if norm > 1e-9 {
                        let t = [axis[0] / norm, axis[1] / norm];
                        let nrm = [-t[1], t[0]];
                        let v_t = v[0] * t[0] + v[1] * t[1];
                        let v_n = v[0] * nrm[0] + v[1] * nrm[1];
                        [-c_t * v_t * t[0] - c_n * v_n * nrm[0], -c_t * v_t * t[1] - c_n * v_n * nrm[1]]
                    } else {
                        [-c_t * v[0], -c_t * v[1]]
                    };
                    let slot = &mut world.data.xfrc_applied_mut()[body];
                    *slot = [force[0], force[1], 0.0, 0.0, 0.0, 0.0];
                }
                GroundModel::Isotropic | GroundModel::Anisotropic => {}
            }
        }
    }
}
