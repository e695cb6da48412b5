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
//! **SimSerpent's contact law** (`physics.floor_friction = "stick_slip"`, the default; every
//! ground model but viscous) computes every link–environment contact: the floor, slopes and
//! boxes, heightfields, mesh terrain and the obstacles (`obstacle_*` geoms: cylinders, pegs,
//! walls, mesh obstacles). MuJoCo's step does not act on any of them: planes, boxes and
//! obstacles collide only in this law's own collision detection (their `contype`/`conaffinity`
//! are restored for it, with a detection margin of [`DETECTION_MARGIN_M`], and zeroed again
//! before MuJoCo's step), heightfields and meshes never collide in MuJoCo (the law finds their
//! contacts itself); the compiled model, and the MJCF written to the run folder, keep MuJoCo's
//! contacts. Link–link contacts stay MuJoCo's (normal force and friction from one solve in its
//! elliptic cone: friction bounded by μN of the same step). Before every step, from the state
//! x_k alone:
//! - **Contacts of x_k**: `mj_kinematics`, `mj_comPos`, `mj_comVel` and `mj_collision` at the
//!   state itself (planes, boxes, obstacles), and one contact per link end and heightfield or
//!   mesh: the end's sphere (the capsule's radius about an end of its axis segment) against the
//!   heightfield's surface interpolated bilinearly from the four elevations around it (normal:
//!   that surface's), or against the mesh's nearest triangle ([`closest_point_on_triangle`]).
//!   MuJoCo's own heightfield and mesh collisions give one contact per prism or face, which
//!   appear and vanish between steps; these move smoothly with the link, as a plane's do.
//! - **Ground normal force** of each link–ground contact point: N = max(0, F_s + D), δ the
//!   penetration (−distance), δ̇ its rate (the link point's velocity relative to the ground body,
//!   along the normal). The spring's held force is its energy's change over the penetration's
//!   predicted change in the step, F_s = k·(δ₁⁺² − δ₀⁺²)/(2·(δ₁ − δ₀)) with δ₁ = δ₀ + δ̇·dt + ½·a·dt²
//!   (a: gravity along the normal): k·(δ₀ + δ₁)/2 while the contact lasts the whole step, and the
//!   spring's exact work when it starts or ends within the step. The damper is backward Euler on
//!   the point alone, D = f·c·δ̇/(1 + f·c·dt/m_a), f the part of the step in contact, m_a = s·m_eff
//!   ([`held_normal_force_n`]). k = s·m_eff·ω², c = s·m_eff·b, with m_eff the point's
//!   effective mass along the normal for the link alone, 1/m_eff = 1/m + (r×n)ᵀI⁻¹(r×n), at
//!   most m/2 where two or more of the link's ground points are within the detection margin
//!   (each carries at most its share of the link: the end of a short, thick link moves almost
//!   as its centre does, m_eff near m, and two ends landing flat, each scaled by m_eff, would
//!   push back the whole link twice over in a step), and s = 2/max(2, the link's penetrating
//!   ground points) (a capsule on a plane, a heightfield or a mesh touches with its two caps);
//!   ω = 1/(τ·ζ_env) from
//!   `physics.environment_contact_time_constant_secs` (τ, `"auto"`: max(2 ms, 2 timesteps)) and
//!   `environment_contact_damping_ratio` (ζ_env), MuJoCo's reading of `solref`, or ω² given
//!   directly (`contact_stiffness_per_s2`), at most 1/dt; b the damping whose rebound at this
//!   step is `physics.contact_restitution` for a link landing flat, on average over where in a
//!   step the impact starts ([`DampingByMassRatio`]: each cap carries half the link, q = m/(2·m_eff)
//!   times the mass its law assumes). So a link landing flat rebounds at the configured
//!   restitution at every step (0.3 → 0.285 at 1 ms as the mean over where the impact starts,
//!   0.23–0.38 for one impact; 0.293–0.295 at 0.25 and 0.1 ms; measured in
//!   `tests/it/contact_events.rs`).
//!   Every link of the same shape has the same compliance, so a straight body at rest carries
//!   each link's weight on that link; a capsule lying on the floor sinks about
//!   m·g/(2·m_eff·ω²) − g·dt²/4 (8.4 µm with the defaults). A snake that starts at rest lying
//!   on level ground starts at that depth ([`Ground::static_start_sink_m`]), so the floor
//!   carries its weight from the first step.
//! - **Obstacle normal force** ([`Ground::obstacle_normals`]): on a step where a link touches an
//!   obstacle at x_k, or may within the step, a forward pass at x_k with the step's ground forces
//!   applied gives every link–obstacle contact point its mobility through the whole articulated
//!   body, W = J·M⁻¹·Jᵀ along the normals, and its acceleration toward the obstacle without
//!   obstacle forces, a. Each point's mass m_c is the inverse of its row of W summed over the
//!   touching points (the mass it carries when all push alike: one point, 1/W_ii; a link hitting
//!   flat on both caps, half the link and what its joints add), k = m_c·ω², c = m_c·b with b from
//!   the restitution for this step ([`damping_ratio_for_step`]: the damping whose discrete
//!   rebound is e at ω·dt), the spring by the trapezoidal rule and the damper by backward Euler,
//!   implicit through W ([`normal_force_terms`]): N_i = (num_i − X_i·Σ_{j≠i} W_ij·N_j)/(1 +
//!   X_i·W_ii), N ≥ 0, solved by projected Gauss–Seidel. So an obstacle impact rebounds at `physics.contact_restitution` at any step and
//!   whatever the joints add (0.3 → 0.304–0.314 at 1, 0.25 and 0.1 ms, one link and ten links
//!   hitting a wall flat, `tests/it/contact_events.rs`).
//! - **Friction**, per link: ground slots (slot 0: contact points ahead of the centre of mass
//!   along the link's axis, slot 1: behind; a capsule lying on a plane touches it at both caps),
//!   each an elasto-plastic Coulomb force bounded by μ times the N of the same contacts:
//!   - N, the point and the normal of a slot: Σ N of its contacts, point and normal weighted by N.
//!   - v, the velocity of the contact point at x_k (centre-of-mass velocity + ω × r), tangential.
//!   - An anchor on the ground per slot, with the deflection z of the contact point from it. The
//!     trial force −k_t·(z + v·dt) − c_t·v − f_k (k_t = m_s·ω_s², c_t = 2·m_s·ω_s: critically damped
//!     with ω_s = 1/`floor_stick_time_constant_secs` (`"auto"`: max(5 ms, 5 timesteps)); m_s =
//!     min(N/g, m/2), the mass the slot carries up to half the link's; f_k the tangential part of
//!     the forces on the link known before the step, its weight and its applied external force
//!     (`[[physics.external_forces]]`), each slot taking the part of the link its N carries,
//!     N/(m·|g·n|), at most the whole link over its slots, so a push or a slope is held within
//!     the step it starts in, not after the spring has yielded) is kept if it lies inside
//!     the friction ellipse (F_axial/(μ_axial·N))² + (F_lateral/(μ_lateral·N))² ≤ 1 (stick: z
//!     grows by v·dt), else replaced by its nearest point on the ellipse (slide: the anchor is
//!     dragged, z = −(F + f_k)/k_t). In steady sliding that is μ·N against the sliding direction
//!     (maximum dissipation on the ellipse), while sticking it is whatever holds the link, with
//!     no creep. μ_axial is `axial_friction` for a force toward the tail and
//!     `backward_friction` (directional) toward the head; the coefficients come from the region
//!     under the link. A stick spring springing back along the point's motion gives back the
//!     energy it stored: at most [`STICK_RELEASE_J`] per step and slot (the rest of the force
//!     along v is dropped and the anchor follows), so a coasting snake does not gain energy from
//!     the springs that held it (f_k is a force on the link, not the spring's: it is not capped).
//! - **Obstacle friction**, one slot per link and touching obstacle geom (at most 8 per link),
//!   isotropic with `terrain.obstacle_friction[0]`, the link's axis as the first tangent, solved
//!   jointly over all of them. A second forward pass at x_k (the law's geoms detached, the step's
//!   normal and ground friction forces in `xfrc_applied`) gives
//!   the contact points' accelerations a without obstacle friction and the factorised mass
//!   matrix M. With J the contact points' tangential Jacobians and W = J·M⁻¹·Jᵀ (how a force at
//!   one contact point moves every contact point, through the whole articulated body), the
//!   friction F solves W·F = −(s/dt + a), each slot's force inside its disk |F| ≤ μ·N (projected
//!   Gauss–Seidel over the slots), N the law's normal force of the same step: it stops every
//!   contact point's slip s within the step where μ·N allows, and slides at μ·N otherwise. s is
//!   the point's tangential velocity plus its drift since it stuck over
//!   `floor_stick_time_constant_secs`, so a stuck contact does not creep. The normal force does
//!   not depend on the friction (it is the law's of x_k), so no third pass is needed. A slot
//!   without contact at x_k has no friction.
//! - Normal and friction forces of a link and their moments about its centre of mass go into
//!   `xfrc_applied`, held over the step. [`Ground::own_contacts`] gives a snapshot its
//!   link–ground and link–obstacle contact rows; [`Ground::fill_snapshot`] adds the friction.
//!
//! **Why it is stable** with forces held over an explicit step: the energy-consistent spring alone
//! neither gains nor loses energy, and the ground damper's effective damping c/(1 + c·dt/m_a) stays
//! below m_a/dt, the link-alone mass of its point: joints only add mass to a point, so the damper
//! never reverses a point's motion within a step, whatever the damping the restitution asks for
//! (a cap rocking on the link's pitch carries m_a; a link landing flat, q·m_a). The obstacle
//! law is implicit through the body's real mobility: unconditionally stable for the spring
//! (Newmark's average acceleration) and the damper (backward Euler), whatever c·dt. The stick
//! spring–damper is scaled by at most half the link's mass (c_t·dt/m ≤ 2·dt/τ_s ≤ 0.4). Cost
//! per step: one `mj_collision` (the kinematics and velocities were computed for friction
//! already), a loop over the contacts and, per link end, one heightfield lookup or one pass over
//! a mesh's triangles.
//!
//! **Limits of the law.** At a 1-ms step one floor impact rebounds at 0.23–0.38 for 0.3, with
//! where in the step it starts (the mean over the step is the setting). A link pushed at
//! 0.999·μN along its axis, from t = 0 or once it rests, moves 0.066 mm at μ 0.5 and 0.31 mm at
//! μ 1: the friction that holds the push acts one radius below the centre of mass and pitches
//! the link, whose load moves to its front end only through the rocking of its two caps' springs;
//! at μ 1 the rocking takes the rear cap off the floor for a step and Σ N below the push's μN,
//! the link starts to slide (2 mm/s), and under a push of 0.999·μN it slows at only 0.001·μ·g,
//! so it stops 0.3 s and 0.31 mm later. A 30-link snake of 3-kg links in steady undulation at
//! 1 ms rocks once a gait cycle (the links behind the head off the floor for 10–20 ms, Σ N
//! 0.73–1.43 of its weight; 0.996–1.008 at 0.5 ms): the damper is implicit on each point's mass
//! for its link alone, and a heavy link pressed by its neighbours carries more. A hard sideways
//! hit at μ 1 lifts the snake 33 mm (31 mm at 0.1 ms) where the reference engine lifts it 6–7
//! mm, and the lift rides on the snake's roll: sliding sideways, the floor's friction spins every
//! link about its axis (−33 rad/s before the hit; the yaw joints make it one roll of the whole
//! chain), and the two links that hit a cylinder roll up its face without slipping, at |ω|·r.
//! In the reference engine the friction of the links still on the floor, loaded by the
//! cylinders' downward friction, stops the roll within 8 ms (−3.8 rad/s as the snake leaves the
//! floor, its centre of mass at 0.21 m/s); here the floor's load comes earlier, while those
//! links still slide forward and its friction spins the roll up (2.7 of 4.9 N·s at 1 ms; the
//! reference 1.4 of 7.2), and less of it after (2.2 against 5.8 N·s), so the roll leaves at
//! −37 rad/s (−27 at 0.1 ms), the hitting links climb at 1.3 m/s and the centre of mass rises
//! 21 mm against 4.3. The whole-body solve, with the floor's and the cylinders' contacts in one
//! solve, stops the roll (−1.1 rad/s; the centre of mass rises 7.3 mm). Gravity during a
//! contact (≈ 3 ms) takes about g·t/v off a rebound at speed v.
//! Rolling and torsional friction are not modelled.
//!
//! **Obstacles.** MuJoCo's own friction on the link–obstacle contacts (condim 3) would bound
//! friction by the normal force of the same solve, but its convex contact model turns sliding
//! into separation: a link pushed against a wall with 2 N and sliding along it loses the contact
//! on 488 of 500 steps (its normal velocity grows with μ times the sliding speed), the hop this
//! law removes from the floor. The friction is the one that stops the slip within the step,
//! from the mobility W of the whole body, not a spring scaled by a guessed mass: in an impact N
//! reaches thousands of newtons within a step, and only a force computed from the body's real
//! mobility reaches μ·N when the contact slides and no more than what stops it when it sticks.
//! Solving with W is stable: the force held over the step removes the predicted slip and no
//! more. Cost on steps with an obstacle contact: a forward pass (normal forces) and one from
//! the actuation stage on (friction), one `mj_jac` per contact point and direction, one
//! `mj_solveM` per pass and a handful of Gauss–Seidel sweeps; the step's own forward pass then
//! starts from the actuation stage too ([`Ground::forward`]: kinematics, collision detection,
//! the mass matrix and the velocities are those of the law's pass, at the same state); nothing
//! on the other steps.
//!
//! **Whole-body solve** (`physics.environment_contact_solve = "whole_body"`; the default
//! `"per_link"` is the law above, its floor per link, its obstacles normals-then-friction).
//! Every link–ground contact point (floor, slopes, boxes, heightfields, meshes: the same
//! contacts as above, one per link end) and every link–obstacle contact point gets its normal
//! force and its friction from one projected Gauss–Seidel solve ([`Ground::whole_body_solve`];
//! Moreau, *Unilateral contact and dry friction in finite freedom dynamics*, 1988; Jean, *The
//! non-smooth contact dynamics method*, CMAME 177, 1999), on every step with a contact:
//! - One forward pass at x_k without the law's forces (the external forces of
//!   `[[physics.external_forces]]` applied) gives each point i three rows r ∈ {n, a, l} (its
//!   normal from the ground or obstacle into the link, the link's axis in the contact plane,
//!   across it), their accelerations without contact forces acc_r, and M⁻¹·J_rᵀ (one `mj_jac`
//!   per point, M⁻¹ once). The solve keeps Δq̈ = Σ_r M⁻¹·J_rᵀ·f_r, so a row's acceleration with
//!   the forces f is acc_r + J_r·Δq̈ (O(nv) per row; W_rs = J_r·M⁻¹·J_sᵀ only for each point's
//!   own 3 × 3 block).
//! - Normal: the implicit spring–damper of the obstacle law ([`normal_force_terms`]: trapezoidal
//!   spring, backward-Euler damper), N_i = max(0, (num_i − X_i·(J_n·Δq̈ − W_nn·N_i))/(1 +
//!   X_i·W_nn)), the point's carried mass m_c: a ground point its share of its link (m/2 for a
//!   capsule's two caps, as the per-link law), an obstacle point 1/Σ_j W_ij over the touching
//!   obstacle points. k = m_c·ω², c = m_c·b with b from `physics.contact_restitution` for this
//!   step, averaged over where in the step an impact starts
//!   ([`crate::contact_law::damping_ratio_for_step_averaged`]).
//! - Friction, right after the point's N: the force that stops the point's slip s (tangential
//!   velocity plus its drift since it stuck over `floor_stick_time_constant_secs`) within the
//!   step, W_tt·Δf = −(s/dt + acc_t + J_t·Δq̈), projected onto its ellipse
//!   (f_a/(μ_a·N))² + (f_l/(μ_l·N))² ≤ 1 of the same N in the metric W_tt
//!   ([`project_to_ellipse_in_metric`]: the exact minimiser of the point's sub-problem; μ_a the
//!   forward or backward coefficient by the force's sign along the link, the region's under the
//!   link; obstacles isotropic `terrain.obstacle_friction[0]`). On its ellipse the point slides
//!   (its anchor follows), inside it sticks.
//! - Sweeps until no force changes by more than [`WHOLE_BODY_TOLERANCE`] of the largest normal
//!   term (at most [`WHOLE_BODY_SWEEPS`]), warm started from each point's forces of the step
//!   before (one slot per link, contact geom and place on the link, at most [`OBSTACLE_SLOTS`]
//!   per link).
//! - The forces go into `xfrc_applied`, the contact rows and the per-link floor and obstacle
//!   channels exactly where the per-link law's go.
//!
//! What it changes: the friction and the normal force of a point are solved together through
//! the whole body, so a link's pitch under its friction moves load between its ends within the
//! step (a link pushed at μN breaks away at 1.0001·μN), a run that starts under load holds (a
//! link pushed at 0.999·μN from t = 0 moves 0.007 mm at μ 0.5), and the floor's damping is
//! implicit, so a floor impact rebounds at the configured restitution at any step. Limits: at
//! ω·dt = 1 (the default 1-ms step) one impact rebounds within about ±0.05 of the configured
//! restitution depending on where in the step it starts (0.3: 0.27–0.33; the average is the
//! configured value less what gravity takes); a body at rest is statically indeterminate for
//! the rigid friction, and the solve may leave friction pairs that cancel within it (a straight
//! snake at rest: up to 23 % of μN on a contact, Σ per link zero); a step with a contact on
//! third-party ground of other shapes (MuJoCo's normal force) takes the per-link law; a hard
//! sideways hit at μ 1 lifts the snake 10.9 mm at 1 ms and 16.4 mm at 0.1 ms (the reference
//! engine: 5.03 mm): the cylinders' friction stopping the links' spin drives them into the floor
//! (about 6.6 N·s in 7 ms at 1 ms) and the floor's spring gives the stored energy back; the
//! reference's impulses during the hit are these within 15 %, but its Hunt–Crossley cylinder
//! contact fades out over 6 ms more while the links rise along the cylinder, and its friction
//! there takes 0.86 N·s of upward momentum (the snake leaves at 0.19 against 0.356 m/s). Cost:
//! a forward pass, the Jacobians and the sweeps on every step with a contact (the step's own
//! forward pass then starts from the actuation stage): about 1.7 × the per-link law's
//! step-loop work on the bare floor (BENCHMARKS.md, "Steps among pegs").
//!
//! Velocities are those of the state at the start of the step: kinematics and centre-of-mass
//! velocities are recomputed first, because after `mj_step` MuJoCo's derived quantities belong
//! to an integrator stage, not to the new state.

use super::World;
use crate::config::{Config, EnvironmentContactSolve, FloorFriction, GroundModel, STICK_RELEASE_J};
use crate::contact_law::{
    DampingByMassRatio, NormalLaw, damping_ratio_for_step, damping_ratio_for_step_averaged, held_normal_force_n,
    normal_force_terms,
};
use crate::model::{SurfaceMap, names};
use crate::state::{ContactRow, GeomClass, Snapshot, x_axis};
use mujoco_rs::prelude::{MjData, MjModel, MjtObjBase};
use mujoco_rs::wrappers::mj_model::MjtGeomBase;

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
    /// SimSerpent's own floor friction (`physics.floor_friction = "stick_slip"`), if in use.
    stick_slip: Option<StickSlip>,
    /// [`Ground::fill_snapshot`]'s scratch: the friction slot of every contact row (grows only
    /// with more contacts than ever), and Σ N of the rows of each link's ground slots.
    row_slots: Vec<Option<(usize, usize, f64)>>,
    slot_normal_n: Vec<[f64; SLOTS]>,
    /// Whether the latest [`Ground::before_step`] ended with a full forward pass at the state it
    /// prepared, with the law's geoms detached as in MuJoCo's step: MuJoCo's position and
    /// velocity stages then already describe the step's forward pass ([`Ground::forward`]).
    forward_ready: bool,
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
        // Only where the model generator made the ground frictionless for it (a user's robot
        // keeps MuJoCo's friction).
        let floor_condim =
            world.model().name_to_id(MjtObjBase::mjOBJ_GEOM, names::FLOOR).map(|f| world.model().geom_condim()[f]);
        let own = config.physics.floor_friction == FloorFriction::StickSlip
            && g.model != GroundModel::Viscous
            && floor_condim == Some(1)
            && pairs.is_empty()
            && n > 0;
        let stick_slip = own.then(|| StickSlip::new(config, world));
        let model = if own { g.model } else { model };
        if own {
            map = SurfaceMap::from_config(config);
        }
        Self {
            stick_slip,
            model,
            map,
            torsional: config.snake.ground_friction[1],
            rolling: config.snake.ground_friction[2],
            forward_now: vec![true; pairs.len()],
            region_now: vec![0; n],
            pairs,
            bodies: world.index.links.iter().map(|l| l.body).collect(),
            row_slots: Vec::new(),
            slot_normal_n: vec![[0.0; SLOTS]; n],
            forward_ready: false,
        }
    }

    /// MuJoCo's forward pass at the current state and controls ([`World::forward`]). Right
    /// after a [`Ground::before_step`] whose own forward pass ran at this state (steps with an
    /// obstacle contact, and heightfield or mesh ground), the position and velocity stages
    /// (kinematics, collision, mass matrix, constraints, velocities) are already those of this
    /// pass and only the later stages run: the applied forces and the controls enter there
    /// only, so the result is bit for bit a full pass's.
    pub fn forward(&mut self, world: &mut World) {
        if std::mem::take(&mut self.forward_ready) {
            world.forward_from_actuation();
        } else {
            world.forward();
        }
    }

    /// The state was changed from outside since the latest [`Ground::before_step`]: the next
    /// [`Ground::forward`] is a full pass.
    pub fn state_changed(&mut self) {
        self.forward_ready = false;
    }

    /// Whether this model does anything per step.
    pub fn is_active(&self) -> bool {
        matches!(self.model, GroundModel::Directional | GroundModel::Viscous)
            || !self.map.is_empty()
            || self.stick_slip.is_some()
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

    /// Where the step loop writes each link's applied external force of the coming step (the
    /// friction's stick force holds the part of it, and of gravity, along the ground at once).
    pub fn external_forces_mut(&mut self) -> Option<&mut [[f64; 3]]> {
        self.stick_slip.as_mut().map(|st| st.external_force_n.as_mut_slice())
    }

    /// Prepares the coming step: looks up the surface under each link, switches pair friction
    /// (surfaces, directional) or writes the viscous forces into `xfrc_applied`. Does not
    /// allocate.
    pub fn before_step(&mut self, world: &mut World) {
        self.forward_ready = false;
        if !self.is_active() {
            return;
        }
        if self.stick_slip.is_some() {
            self.forward_ready = self.before_step_stick_slip(world);
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

/// A link–ground or link–obstacle contact of SimSerpent's contact law at one instant: MuJoCo's
/// geometry (geoms, point, normal from geom 1 to geom 2, distance) and the law's normal force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OwnContact {
    pub geom: [usize; 2],
    pub position_m: [f64; 3],
    pub normal: [f64; 3],
    pub distance_m: f64,
    pub normal_force_n: f64,
}

/// How far from a ground geom a link's contacts are looked for (m): a contact whose penetration
/// predicted for the middle of the step is positive acts from that step on (at up to 20 m/s
/// with 1 ms steps).
const DETECTION_MARGIN_M: f64 = 0.01;

/// How far from the ground a resting link's end cap may start and still count as lying on it
/// (m; the rounding of the generated pose): see [`Ground::static_start_sink_m`].
const RESTING_DISTANCE_M: f64 = 1e-9;

/// Slots per link: the front and the back half of its contact (a capsule lying on a plane
/// touches it at both end caps).
const SLOTS: usize = 2;

/// Per-step state of SimSerpent's elasto-plastic floor friction (see the module docs).
#[derive(Debug, Clone)]
struct StickSlip {
    /// For each geom: the link it belongs to, if any.
    link_of_geom: Vec<Option<usize>>,
    /// Whether each geom carries the snake like the floor (floor, slope, heightfield, mesh terrain).
    ground_geom: Vec<bool>,
    /// Whether each ground geom's contacts get this law's normal force (planes, boxes,
    /// heightfields, meshes); the others (ground geoms of a third-party terrain of other shapes) keep MuJoCo's.
    own_ground_geom: Vec<bool>,
    /// Whether each geom is an obstacle (`obstacle_*`: cylinders, pegs, walls, mesh obstacles).
    obstacle_geom: Vec<bool>,
    /// Link–obstacle friction coefficient (`terrain.obstacle_friction[0]`, isotropic).
    obstacle_mu: f64,
    /// `physics.environment_contact_solve = "whole_body"`: every ground and obstacle contact
    /// point in [`Ground::whole_body_solve`].
    whole_body: bool,
    /// The whole-body solve's contact points, their frames for the Jacobians, and the joint-space
    /// velocity change of its forces, M⁻¹·Jᵀ·f·dt/dt (capacity kept between steps).
    solve_points: Vec<SolvePoint>,
    solve_frames: Vec<super::PointFrame>,
    solve_dv: Vec<f64>,
    /// Half of each link's mass (kg): the largest mass a ground slot's stick spring–damper is
    /// scaled for.
    half_link_mass_kg: Vec<f64>,
    /// Obstacle contacts per link, one slot per touching obstacle geom.
    obstacle_slots: Vec<[ObstacleSlot; OBSTACLE_SLOTS]>,
    /// Friction force (N) and moment (N·m) of the obstacle contacts per link (world frame; part
    /// of `force_n`/`torque_nm`).
    obstacle_force_n: Vec<[f64; 3]>,
    obstacle_torque_nm: Vec<[f64; 3]>,
    /// The obstacle friction solve's touching slots, mobility rows (two per slot), buffers and
    /// forces (N, along each slot's tangents); capacity kept between steps.
    active: Vec<ActiveSlot>,
    rows: Vec<(usize, [f64; 3], [f64; 3])>,
    mobility: super::MobilityBuffers,
    solved_n: Vec<[f64; 2]>,
    /// `floor_stick_time_constant_secs`: how fast a stuck obstacle contact takes back its drift.
    stick_time_constant_secs: f64,
    /// Stick spring–damper per unit of supported mass: ω² (1/s²) and 2ω (1/s), ω = 1/τ.
    omega_sq_per_s2: f64,
    two_omega_per_s: f64,
    /// Gravity (m/s², world frame).
    gravity_vector_m_per_s2: [f64; 3],
    /// The applied external force on each link this step (N, world frame; see
    /// [`Ground::external_forces_mut`]).
    external_force_n: Vec<[f64; 3]>,
    /// |gravity| (m/s²; 9.81 without gravity): N / g is the mass a contact supports.
    gravity_m_per_s2: f64,
    timestep_secs: f64,
    /// Each link's mass (kg) and principal moments of inertia (kg·m², in its inertial frame).
    link_mass_kg: Vec<f64>,
    link_inertia_kg_m2: Vec<[f64; 3]>,
    /// Normal law of a contact point: stiffness (1/s²: k = m_eff · this) and damping (1/s:
    /// c = m_eff · this) per kilogram of the point's effective mass.
    normal_stiffness_per_s2: f64,
    normal_damping_per_s: f64,
    /// The whole-body solve's damping per kilogram of effective mass (1/s).
    whole_body_damping_per_s: f64,
    /// The ground contacts' damping per kilogram of effective mass (1/s), by the ratio of a
    /// link's half mass to the point's effective mass.
    ground_damping: DampingByMassRatio,
    /// The part of each ground slot's Σ N from MuJoCo's heightfield and mesh contacts at x_k, and
    /// the same after the step's friction is applied (the check of the second forward pass).
    mujoco_ground_n: Vec<[f64; SLOTS]>,
    mujoco_ground_check_n: Vec<[f64; SLOTS]>,
    /// Per ground slot with heightfield or mesh contacts: the normal force its friction needs
    /// (N: the N at which the force lies on its friction ellipse), and the (load, N) of the
    /// evaluation before (the first: no friction, the N it was bounded by).
    bound_load_n: Vec<[f64; SLOTS]>,
    bound_previous: Vec<[(f64, f64); SLOTS]>,
    /// Penetrating ground contact points of each link at x_k.
    ground_points: Vec<usize>,
    /// Ground contact points of each link at x_k within the detection margin, touching or not:
    /// two or more, and the link may land on them together within the step.
    ground_points_near: Vec<usize>,
    /// Penetrating obstacle contact points of each link at x_k.
    obstacle_points: Vec<usize>,
    /// The link–ground and link–obstacle contacts found at x_k (capacity kept).
    found: Vec<FoundContact>,
    /// The link–obstacle contacts of x_k awaiting their normal force, and their rows of the
    /// whole body's mobility (capacity kept).
    obstacle_candidates: Vec<ObstacleCandidate>,
    obstacle_rows: Vec<(usize, [f64; 3], [f64; 3])>,
    obstacle_terms: Vec<ObstacleTerms>,
    /// Heightfield and mesh ground, whose contacts this law finds itself (one per link end and
    /// surface), and each link's capsule (geom, radius, half-length of its axis segment).
    heightfields: Vec<HeightfieldGround>,
    meshes: Vec<MeshGround>,
    link_capsules: Vec<Option<Capsule>>,
    /// Heightfield and mesh ground geoms with their compiled margin: never part of MuJoCo's
    /// collision detection.
    surface_geoms: Vec<(usize, f64)>,
    /// Whether each geom is such heightfield or mesh ground: its contacts (the link's ends and
    /// a bump under its middle) each carry a full end's share, so that a contact appearing under
    /// the middle starts from zero force instead of taking load off the ends at once.
    surface_geom: Vec<bool>,
    /// Velocity of each link's centre of mass at x_k: [angular; linear] (world frame).
    link_velocity: Vec<[f64; 6]>,
    /// The ground geoms with their collision bits and margin as compiled (geom, contype,
    /// conaffinity, margin): set, with the margin [`DETECTION_MARGIN_M`], for this law's own
    /// collision detection; zero (and the compiled margin) during MuJoCo's step.
    env_geoms: Vec<(usize, i32, i32, f64)>,
    /// The link–ground and link–obstacle contacts of the latest evaluation with their normal
    /// forces, and the time of that evaluation (capacity kept: no allocation once warmed up).
    own_contacts: Vec<OwnContact>,
    evaluated_at_secs: f64,
    /// Elastic energy of the normal springs at x_k (J): Σ ½·k·δ².
    elastic_energy_j: f64,
    /// Normal force (N) and its moment about the centre of mass (N·m) of each link's ground and
    /// obstacle contacts in the latest prepared step (world frame; not part of `force_n`).
    normal_force_n: Vec<[f64; 3]>,
    normal_torque_nm: Vec<[f64; 3]>,
    /// Accumulated contact of this step per link and slot: Σ N, Σ N·point, Σ N·normal.
    normal_n: Vec<[f64; SLOTS]>,
    point_weighted: Vec<[[f64; 3]; SLOTS]>,
    normal_weighted: Vec<[[f64; 3]; SLOTS]>,
    /// Stick deflection per link and slot (m, world frame): how far the contact point has moved
    /// from its anchor on the ground.
    deflection_m: Vec<[[f64; 3]; SLOTS]>,
    /// Friction force (N) and its moment about the centre of mass (N·m) applied to each link in
    /// the latest prepared step (world frame).
    force_n: Vec<[f64; 3]>,
    /// The same force per link and slot (N, world frame): what the contact rows of a snapshot
    /// carry as their friction.
    slot_force_n: Vec<[[f64; 3]; SLOTS]>,
    torque_nm: Vec<[f64; 3]>,
}

/// Obstacle slots per link: a link touching more obstacle geoms at once than this gets no
/// friction from the extra ones (their normal force still acts).
const OBSTACLE_SLOTS: usize = 8;

/// One link's contact with one obstacle geom, with the isotropic coefficient
/// `terrain.obstacle_friction[0]`: its friction is solved with every other obstacle contact's in
/// [`Ground::obstacle_friction`]; its deflection is the contact point's drift since it stuck.
#[derive(Debug, Clone, Copy)]
struct ObstacleSlot {
    /// The obstacle geom, or `usize::MAX` when the slot is free.
    geom: usize,
    /// Where on the link the contact is ([`contact_place`]; always 0 with `"per_link"`, whose
    /// obstacle slots gather every contact with their geom).
    place: usize,
    /// The normal force of the latest prepared step (N; the whole-body solve's warm start).
    last_normal_n: f64,
    /// Whether a contact with `geom` and a positive normal force was seen at x_k.
    seen: bool,
    normal_n: f64,
    point_weighted: [f64; 3],
    normal_weighted: [f64; 3],
    deflection_m: [f64; 3],
    /// The friction force applied in the latest prepared step (N, world frame), its arm from
    /// the link's centre of mass (m).
    force_n: [f64; 3],
    arm_m: [f64; 3],
}

/// A touching obstacle slot of the step being prepared: one 2 × 2 block of the friction solve
/// of [`Ground::obstacle_friction`].
#[derive(Debug, Clone, Copy)]
struct ActiveSlot {
    link: usize,
    /// The index of the link's obstacle slot.
    slot: usize,
    /// The link's axis in the contact plane, and across it (unit, world frame).
    tangents: [[f64; 3]; 2],
    arm_m: [f64; 3],
    /// The contact point's slip to remove in the step (m/s, along the tangents): its tangential
    /// velocity plus the stuck contact's drift over the stick time constant.
    slip_m_per_s: [f64; 2],
    /// The deflection from the anchor if the slot sticks through the step (m, world frame).
    stuck_deflection_m: [f64; 3],
    /// μ·N (N).
    limit_n: f64,
}

/// Projected Gauss–Seidel sweeps of the whole-body solve at most (it stops when no force changes
/// by more than [`WHOLE_BODY_TOLERANCE`] of the largest normal force term).
const WHOLE_BODY_SWEEPS: usize = 300;

/// The whole-body solve stops when no force changes in a sweep by more than this share of the
/// largest normal force term (N).
const WHOLE_BODY_TOLERANCE: f64 = 1e-6;

/// A contact point of [`Ground::whole_body_solve`]: its candidate, its frame (normal, along the
/// link, across), the two terms of its normal law ([`normal_force_terms`]) and its stiffness
/// (N/m), its coefficients (forward, backward, lateral), the slip to remove in the step (m/s,
/// along a and l), its deflection from its anchor and tangential velocity (world frame), its
/// own 3 × 3 mobility block and its forces (N: normal, along, across).
#[derive(Debug, Clone, Copy)]
struct SolvePoint {
    candidate: usize,
    frame: [[f64; 3]; 3],
    numerator: f64,
    implicit: f64,
    stiffness: f64,
    mu: [f64; 3],
    slip: [f64; 2],
    z: [f64; 3],
    v_t: [f64; 3],
    block: [[f64; 3]; 3],
    f: [f64; 3],
}

impl SolvePoint {
    const ZERO: Self = Self {
        candidate: 0,
        frame: [[0.0; 3]; 3],
        numerator: 0.0,
        implicit: 0.0,
        stiffness: 0.0,
        mu: [0.0; 3],
        slip: [0.0; 2],
        z: [0.0; 3],
        v_t: [0.0; 3],
        block: [[0.0; 3]; 3],
        f: [0.0; 3],
    };
}

/// y += s·x.
fn axpy(y: &mut [f64], s: f64, x: &[f64]) {
    for (a, b) in y.iter_mut().zip(x) {
        *a += s * b;
    }
}

/// Projected Gauss–Seidel sweeps of the friction solve at most (it stops when no force changes
/// by more than 1e-9 of the largest limit).
const FRICTION_SOLVER_SWEEPS: usize = 100;

impl ObstacleSlot {
    const FREE: Self = Self {
        geom: usize::MAX,
        place: 0,
        last_normal_n: 0.0,
        seen: false,
        normal_n: 0.0,
        point_weighted: [0.0; 3],
        normal_weighted: [0.0; 3],
        deflection_m: [0.0; 3],
        force_n: [0.0; 3],
        arm_m: [0.0; 3],
    };
}

impl StickSlip {
    /// For a contact between a link's geom and a geom of no link: the link, the other geom, and
    /// the sign that turns MuJoCo's normal (geom 1 → geom 2) into the normal pointing from the
    /// other geom into the link. `None` for any other pair.
    fn link_side(&self, g1: usize, g2: usize) -> Option<(usize, usize, f64)> {
        let of = |g: usize| self.link_of_geom.get(g).copied().flatten();
        match (of(g1), of(g2)) {
            (Some(l), None) => Some((l, g2, -1.0)),
            (None, Some(l)) => Some((l, g1, 1.0)),
            _ => None,
        }
    }

    /// The link–ground and link–obstacle contacts of the state whose kinematics and collision
    /// detection `d` holds, into `found`: MuJoCo's (planes, boxes, obstacles) and the
    /// heightfields' and meshes' own (one per link end and heightfield or mesh), with the
    /// ground points per link counted: within the detection margin (`ground_points_near`) and
    /// penetrating (`ground_points`, `obstacle_points`; a link's two end caps on a plane share its
    /// compliance, more points — a box edge, a mesh — share the same total). Returns whether a
    /// link touches a third-party ground geom (whose normal force is MuJoCo's).
    fn find_contacts(&mut self, d: &MjData<Box<MjModel>>) -> bool {
        let mut mujoco_ground_contact = false;
        self.found.clear();
        for contact in d.contact() {
            let (g1, g2) = (contact.geom[0], contact.geom[1]);
            if g1 < 0 || g2 < 0 || contact.exclude > 1 {
                continue;
            }
            let (g1, g2) = (g1 as usize, g2 as usize);
            let Some((_, other, _)) = self.link_side(g1, g2) else { continue };
            if self.surface_geom[other] {
                continue; // heightfields and meshes: their contacts are this law's own (below)
            }
            if !self.obstacle_geom[other] && !self.own_ground_geom[other] {
                mujoco_ground_contact |= self.ground_geom[other];
                continue;
            }
            self.found.push(FoundContact {
                geom: [g1, g2],
                position_m: contact.pos,
                normal: [contact.frame[0], contact.frame[1], contact.frame[2]],
                distance_m: contact.dist,
            });
        }
        for cap in self.link_capsules.iter().flatten() {
            for hf in &self.heightfields {
                hf.contacts(d, cap, &mut self.found);
            }
            for mesh in &self.meshes {
                mesh.contacts(d, cap, &mut self.found);
            }
        }
        self.ground_points.fill(0);
        self.ground_points_near.fill(0);
        self.obstacle_points.fill(0);
        for contact in &self.found {
            let Some((l, other, _)) = self.link_side(contact.geom[0], contact.geom[1]) else { continue };
            if !self.obstacle_geom[other] {
                self.ground_points_near[l] += 1;
            }
            if contact.distance_m >= 0.0 {
                continue;
            }
            if self.obstacle_geom[other] {
                self.obstacle_points[l] += 1;
            } else if !self.surface_geom[other] {
                self.ground_points[l] += 1;
            }
        }
        mujoco_ground_contact
    }

    /// The per-link law of a ground contact point of `link` at arm `r` (m) from the link's centre
    /// of mass with normal `nrm` (from the ground into the link), the link's inertia frame
    /// `ximat`: a spring–damper on the point's effective mass along the normal for the link
    /// alone, 1/m_eff = 1/m + (r × n)ᵀ I⁻¹ (r × n), shared among the link's penetrating ground
    /// points (at least 2: a capsule lying on a plane rests on its two caps). Uses the point
    /// counts of the latest [`StickSlip::find_contacts`].
    fn ground_point_law(&self, link: usize, r: [f64; 3], nrm: [f64; 3], im: [f64; 9]) -> NormalLaw {
        let mass = self.link_mass_kg[link];
        let rn = cross(r, nrm);
        let inertia = self.link_inertia_kg_m2[link];
        let mut inv_mass = 1.0 / mass;
        for j in 0..3 {
            let u = rn[0] * im[j] + rn[1] * im[3 + j] + rn[2] * im[6 + j];
            if inertia[j] > 0.0 {
                inv_mass += u * u / inertia[j];
            }
        }
        if self.ground_points_near[link] >= 2 {
            // Points that may push one link together carry at most their share of its mass: a
            // short, thick link's end point moves almost as its centre does (m_eff near m), and
            // scaled by that mass two ends landing flat would push back the whole link twice
            // over within a step.
            inv_mass = inv_mass.max(2.0 / mass);
        }
        let share = 2.0 / self.ground_points[link].max(2) as f64;
        NormalLaw {
            stiffness_n_per_m: share * self.normal_stiffness_per_s2 / inv_mass,
            damping_n_s_per_m: share * self.ground_damping.damping_per_s(0.5 * mass * inv_mass) / inv_mass,
            effective_mass_kg: share / inv_mass,
        }
    }

    fn new(config: &Config, world: &World) -> Self {
        let n = world.n_links();
        let body_mass = world.model().body_mass();
        let omega = 1.0 / config.floor_stick_time_constant_secs();
        let g = config.general.gravity_m_per_s2;
        let g_abs = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        // The environment contact's stiffness per unit of carried mass: MuJoCo's direct form
        // when given, else MuJoCo's reading of solref (natural frequency ω = 1/(τ·ζ)), bounded by
        // ω·dt ≤ 1 (the contact resolved over at least π steps).
        let p = &config.physics;
        let dt = config.general.timestep_secs;
        let omega_sq = if p.contact_stiffness_per_s2 > 0.0 {
            p.contact_stiffness_per_s2
        } else {
            let tau = config.environment_contact_time_constant_secs();
            let zeta = p.environment_contact_damping_ratio;
            1.0 / (tau * zeta * tau * zeta)
        };
        // The damping comes from the restitution (the stiffness stays that of the keys above):
        // b = 2·ζ·ω with ζ the damping ratio whose linear spring–damper rebounds at
        // `physics.contact_restitution`. The damping is integrated implicitly (see
        // `normal_force_n`): no bound on b·dt.
        let normal_stiffness_per_s2 = omega_sq.min(1.0 / (dt * dt));
        let omega_normal = normal_stiffness_per_s2.sqrt();
        // Obstacles: the damping ratio whose implicit law rebounds at the restitution at this
        // step (a link hitting a peg with its side: the solve's mass is the link's, ratio 1).
        let normal_damping_per_s =
            2.0 * omega_normal * damping_ratio_for_step(p.contact_restitution, omega_normal * dt, 1.0);
        // The whole-body solve (ground and obstacles): the damping whose implicit law rebounds at
        // the restitution on average over where in a step an impact starts.
        let whole_body_damping_per_s =
            2.0 * omega_normal * damping_ratio_for_step_averaged(p.contact_restitution, omega_normal * dt, 1.0);
        // Ground: the damping whose implicit law rebounds at the restitution at this step, on
        // average over where in a step an impact starts, for a link landing flat (each end cap
        // carries half the link; its solve assumes the cap's effective mass).
        let ground_damping = DampingByMassRatio::new(p.contact_restitution, omega_normal, dt);
        // The ground geoms whose contacts this law computes: planes and boxes (the floor, slopes,
        // steps) through MuJoCo's collision detection, heightfields and meshes through the law's
        // own (one contact per link end: MuJoCo's give one per prism or face, which appear and
        // vanish between steps). Other shapes of a third-party terrain stay MuJoCo's contacts.
        let geom_type = world.model().geom_type();
        let own_ground: Vec<bool> = (0..world.index.geom_class.len())
            .map(|g| {
                world.index.geom_class[g] == GeomClass::Floor
                    && matches!(
                        geom_type[g],
                        MjtGeomBase::mjGEOM_PLANE
                            | MjtGeomBase::mjGEOM_BOX
                            | MjtGeomBase::mjGEOM_HFIELD
                            | MjtGeomBase::mjGEOM_MESH
                    )
            })
            .collect();
        Self {
            link_of_geom: world.index.geom_link.clone(),
            ground_geom: world.index.geom_class.iter().map(|c| *c == GeomClass::Floor).collect(),
            own_ground_geom: own_ground.clone(),
            obstacle_geom: world.index.geom_class.iter().map(|c| *c == GeomClass::Obstacle).collect(),
            obstacle_mu: config.terrain.obstacle_friction[0],
            whole_body: p.environment_contact_solve == EnvironmentContactSolve::WholeBody,
            solve_points: Vec::new(),
            solve_frames: Vec::new(),
            solve_dv: Vec::new(),
            half_link_mass_kg: world.index.links.iter().map(|l| 0.5 * body_mass[l.body]).collect(),
            obstacle_slots: vec![[ObstacleSlot::FREE; OBSTACLE_SLOTS]; n],
            obstacle_force_n: vec![[0.0; 3]; n],
            obstacle_torque_nm: vec![[0.0; 3]; n],
            active: Vec::with_capacity(OBSTACLE_SLOTS * n),
            rows: Vec::with_capacity(2 * OBSTACLE_SLOTS * n),
            mobility: super::MobilityBuffers::default(),
            solved_n: Vec::with_capacity(OBSTACLE_SLOTS * n),
            stick_time_constant_secs: 1.0 / omega,
            omega_sq_per_s2: omega * omega,
            two_omega_per_s: 2.0 * omega,
            external_force_n: vec![[0.0; 3]; n],
            gravity_m_per_s2: if g_abs > 0.1 { g_abs } else { 9.81 },
            gravity_vector_m_per_s2: g,
            timestep_secs: config.general.timestep_secs,
            link_mass_kg: world.index.links.iter().map(|l| body_mass[l.body]).collect(),
            link_inertia_kg_m2: world.index.links.iter().map(|l| world.model().body_inertia()[l.body]).collect(),
            normal_stiffness_per_s2,
            normal_damping_per_s,
            whole_body_damping_per_s,
            ground_damping,
            link_velocity: vec![[0.0; 6]; n],
            ground_points: vec![0; n],
            ground_points_near: vec![0; n],
            obstacle_points: vec![0; n],
            found: Vec::new(),
            obstacle_candidates: Vec::new(),
            obstacle_rows: Vec::new(),
            obstacle_terms: Vec::new(),
            heightfields: (0..geom_type.len())
                .filter(|&g| own_ground[g] && geom_type[g] == MjtGeomBase::mjGEOM_HFIELD)
                .map(|g| HeightfieldGround::new(world.model(), g))
                .collect(),
            meshes: (0..geom_type.len())
                .filter(|&g| own_ground[g] && geom_type[g] == MjtGeomBase::mjGEOM_MESH)
                .map(|g| MeshGround::new(world.model(), g))
                .collect(),
            link_capsules: link_capsules(world),
            surface_geom: (0..geom_type.len())
                .map(|g| own_ground[g] && matches!(geom_type[g], MjtGeomBase::mjGEOM_HFIELD | MjtGeomBase::mjGEOM_MESH))
                .collect(),
            surface_geoms: (0..geom_type.len())
                .filter(|&g| {
                    own_ground[g] && matches!(geom_type[g], MjtGeomBase::mjGEOM_HFIELD | MjtGeomBase::mjGEOM_MESH)
                })
                .map(|g| (g, world.model().geom_margin()[g]))
                .collect(),
            mujoco_ground_n: vec![[0.0; SLOTS]; n],
            mujoco_ground_check_n: vec![[0.0; SLOTS]; n],
            bound_load_n: vec![[0.0; SLOTS]; n],
            bound_previous: vec![[(0.0, 0.0); SLOTS]; n],
            env_geoms: (0..world.index.geom_class.len())
                .filter(|&g| {
                    (own_ground[g] && !matches!(geom_type[g], MjtGeomBase::mjGEOM_HFIELD | MjtGeomBase::mjGEOM_MESH))
                        || world.index.geom_class[g] == GeomClass::Obstacle
                })
                .map(|g| {
                    let m = world.model();
                    (g, m.geom_contype()[g], m.geom_conaffinity()[g], m.geom_margin()[g])
                })
                .collect(),
            own_contacts: Vec::new(),
            evaluated_at_secs: f64::NAN,
            elastic_energy_j: 0.0,
            normal_force_n: vec![[0.0; 3]; n],
            normal_torque_nm: vec![[0.0; 3]; n],
            normal_n: vec![[0.0; SLOTS]; n],
            point_weighted: vec![[[0.0; 3]; SLOTS]; n],
            normal_weighted: vec![[[0.0; 3]; SLOTS]; n],
            deflection_m: vec![[[0.0; 3]; SLOTS]; n],
            force_n: vec![[0.0; 3]; n],
            slot_force_n: vec![[[0.0; 3]; SLOTS]; n],
            torque_nm: vec![[0.0; 3]; n],
        }
    }
}

impl StickSlip {
    /// A law contact point's normal force `n` (N) at x_k: a touching point (`depth > 0` or
    /// `n > 0`) becomes a contact row and adds its elastic energy (stiffness in N/m); a pushing
    /// one (`n > 0`) adds `n` along the contact normal, with its moment about the centre of mass,
    /// to its link's normal channels and its body's `xfrc_applied`, and returns that force.
    fn add_contact_normal(
        &mut self,
        world: &mut World,
        body: usize,
        c: &ObstacleCandidate,
        n: f64,
        stiffness: f64,
    ) -> Option<[f64; 3]> {
        if c.depth <= 0.0 && n <= 0.0 {
            return None; // within the detection margin, not touching
        }
        self.own_contacts.push(OwnContact {
            geom: c.contact.geom,
            position_m: c.contact.position_m,
            normal: c.contact.normal,
            distance_m: c.contact.distance_m,
            normal_force_n: n,
        });
        if c.depth > 0.0 {
            self.elastic_energy_j += 0.5 * stiffness * c.depth * c.depth;
        }
        if n <= 0.0 {
            return None;
        }
        let f = c.nrm.map(|x| n * x);
        let torque = cross(c.arm_m, f);
        self.normal_force_n[c.link] = add(self.normal_force_n[c.link], f);
        self.normal_torque_nm[c.link] = add(self.normal_torque_nm[c.link], torque);
        let x = &mut world.data.xfrc_applied_mut()[body];
        for k in 0..3 {
            x[k] += f[k];
            x[3 + k] += torque[k];
        }
        Some(f)
    }

    /// Adds a friction force (N) and its moment (N·m) to link `i`'s applied friction and to its
    /// body's `xfrc_applied`; with `obstacle`, to its obstacle friction too.
    fn add_friction(
        &mut self,
        world: &mut World,
        body: usize,
        i: usize,
        force: [f64; 3],
        torque: [f64; 3],
        obstacle: bool,
    ) {
        if obstacle {
            self.obstacle_force_n[i] = add(self.obstacle_force_n[i], force);
            self.obstacle_torque_nm[i] = add(self.obstacle_torque_nm[i], torque);
        }
        self.force_n[i] = add(self.force_n[i], force);
        self.torque_nm[i] = add(self.torque_nm[i], torque);
        let x = &mut world.data.xfrc_applied_mut()[body];
        for k in 0..3 {
            x[k] += force[k];
            x[3 + k] += torque[k];
        }
    }

    /// Adds MuJoCo's normal forces of the latest forward pass's link–heightfield and link–mesh
    /// ground contacts to each link's ground slots (Σ N, Σ N·point, Σ N·normal), and keeps that
    /// part of Σ N per slot in `mujoco_ground_n`.
    fn collect_mujoco_ground_normals(&mut self, d: &MjData<Box<MjModel>>, bodies: &[usize]) {
        for v in &mut self.mujoco_ground_n {
            *v = [0.0; SLOTS];
        }
        let (xipos, xmat) = (d.xipos(), d.xmat());
        for (c, contact) in d.contact().iter().enumerate() {
            let Some((link, slot, n, sign)) = self.mujoco_ground_row(d, c, bodies, xipos, xmat) else { continue };
            self.mujoco_ground_n[link][slot] += n;
            self.normal_n[link][slot] += n;
            for k in 0..3 {
                self.point_weighted[link][slot][k] += n * contact.pos[k];
                self.normal_weighted[link][slot][k] += n * sign * contact.frame[k];
            }
        }
    }

    /// For contact `c` of the latest forward pass between a link and heightfield or mesh ground
    /// with a positive normal force: the link, its ground slot, N and the normal's sign.
    fn mujoco_ground_row(
        &self,
        d: &MjData<Box<MjModel>>,
        c: usize,
        bodies: &[usize],
        xipos: &[[f64; 3]],
        xmat: &[[f64; 9]],
    ) -> Option<(usize, usize, f64, f64)> {
        let contact = &d.contact()[c];
        let (g1, g2) = (contact.geom[0], contact.geom[1]);
        if g1 < 0 || g2 < 0 || contact.exclude != 0 {
            return None;
        }
        let (link, geom, sign) = self.link_side(g1 as usize, g2 as usize)?;
        if !self.ground_geom[geom] || self.own_ground_geom[geom] {
            return None;
        }
        let n = d.contact_force(c)[0];
        if n <= 0.0 {
            return None;
        }
        let body = bodies[link];
        let (m, r) = (xmat[body], sub(contact.pos, xipos[body]));
        Some((link, usize::from(r[0] * m[0] + r[1] * m[3] + r[2] * m[6] < 0.0), n, sign))
    }

    /// After a forward pass with the step's friction applied: every ground slot whose friction
    /// needs more normal force than its heightfield or mesh contacts (with its plane contacts)
    /// now carry gets its friction scaled back to the load the normal force can carry (force,
    /// moment, `xfrc_applied` and anchor); whether any was.
    fn rescale_mujoco_ground_slots(&mut self, world: &mut World, bodies: &[usize]) -> bool {
        if self.mujoco_ground_n.iter().all(|s| s.iter().all(|&n| n <= 0.0)) {
            return false;
        }
        let mut changed = false;
        for v in &mut self.mujoco_ground_check_n {
            *v = [0.0; SLOTS];
        }
        {
            let d = &world.data;
            let (xipos, xmat) = (d.xipos(), d.xmat());
            for c in 0..d.contact().len() {
                if let Some((link, slot, n, _)) = self.mujoco_ground_row(d, c, bodies, xipos, xmat) {
                    self.mujoco_ground_check_n[link][slot] += n;
                }
            }
        }
        for (i, &body) in bodies.iter().enumerate() {
            for slot in 0..SLOTS {
                if self.mujoco_ground_n[i][slot] <= 0.0 {
                    continue;
                }
                let n_now =
                    self.normal_n[i][slot] - self.mujoco_ground_n[i][slot] + self.mujoco_ground_check_n[i][slot];
                let load = self.bound_load_n[i][slot];
                let (load_before, n_before) = self.bound_previous[i][slot];
                self.bound_previous[i][slot] = (load, n_now);
                if load <= n_now {
                    continue;
                }
                changed = true;
                // N moves with the friction: taken as linear in the load through this pass and
                // the one before, the load it can carry is where the line meets N = load (at
                // worst this pass's N), 0.1 % inside it.
                let slope = if load != load_before { (n_now - n_before) / (load - load_before) } else { 0.0 };
                let carried = if slope < 1.0 { (n_now - slope * load) / (1.0 - slope) } else { n_now };
                let target = (1.0 - BOUND_MARGIN) * carried.clamp(0.0, load);
                let scale = target / load;
                self.bound_load_n[i][slot] = target;
                let f = self.slot_force_n[i][slot];
                let change = f.map(|x| x * (scale - 1.0));
                let p = self.point_weighted[i][slot].map(|x| x / self.normal_n[i][slot]);
                let torque = cross(sub(p, world.data.xipos()[body]), change);
                self.slot_force_n[i][slot] = f.map(|x| x * scale);
                self.add_friction(world, body, i, change, torque, false);
                let z = &mut self.deflection_m[i][slot];
                *z = z.map(|x| x * scale);
            }
        }
        changed
    }
}

impl Ground {
    /// The friction force (N, world frame) that SimSerpent's floor friction applies to each link
    /// during the coming step (`None` with `physics.floor_friction = "mujoco"`).
    pub fn applied_friction_n(&self) -> Option<&[[f64; 3]]> {
        self.stick_slip.as_ref().map(|s| s.force_n.as_slice())
    }

    /// Elastic energy stored in the normal springs of SimSerpent's contacts at the state of the
    /// latest prepared step (J): Σ ½·k·δ² (0 without them). The stick springs' energy is not
    /// part of it: their stiffness follows the load, so it is no conserved quantity.
    pub fn elastic_energy_j(&self) -> f64 {
        self.stick_slip.as_ref().map_or(0.0, |s| s.elastic_energy_j)
    }

    /// Its moment about each link's centre of mass (N·m, world frame).
    pub fn applied_friction_torque_nm(&self) -> Option<&[[f64; 3]]> {
        self.stick_slip.as_ref().map(|s| s.torque_nm.as_slice())
    }

    /// Fills what the ground model adds to a snapshot read after [`Ground::before_step`]: the
    /// region under each link, and with `physics.floor_friction = "stick_slip"` the friction
    /// force it applies, added to each link's floor (ground slots), obstacle (obstacle slots) and
    /// total contact force and torque (MuJoCo's contacts carry only the normal force then), and
    /// to the contact rows.
    ///
    /// Contact rows: each link–ground or link–obstacle row gets its share of the friction
    /// applied at its slot (ground: its end of the link; obstacle: that obstacle geom), in
    /// proportion to its normal force among the rows of that slot, in its `friction_force_n`
    /// (along the link's axis in the contact plane and across it) and `force_on_geom2_n`; the
    /// rows of a link then add up to the link's recorded floor and obstacle forces (the friction
    /// was computed from the contacts of the same state, so every slot with friction has rows).
    ///
    /// One pass over the rows finds each row's slot and adds up Σ N per ground slot; a second
    /// shares out the friction (no allocation but for more contacts than ever).
    pub fn fill_snapshot(&mut self, s: &mut Snapshot) {
        let Self { stick_slip, region_now, row_slots, slot_normal_n, .. } = self;
        s.link_region.copy_from_slice(region_now);
        let Some(st) = stick_slip.as_ref() else { return };
        for i in 0..st.force_n.len() {
            let (fo, to) = (st.obstacle_force_n[i], st.obstacle_torque_nm[i]);
            let (ff, tf) = (sub(st.force_n[i], fo), sub(st.torque_nm[i], to));
            for k in 0..3 {
                s.link_floor_force_n[i][k] += ff[k];
                s.link_floor_torque_nm[i][k] += tf[k];
                s.link_obstacle_force_n[i][k] += fo[k];
                s.link_obstacle_torque_nm[i][k] += to[k];
                s.link_contact_force_n[i][k] += ff[k] + fo[k];
                s.link_contact_torque_nm[i][k] += tf[k] + to[k];
            }
        }
        // The link of a link–ground or link–obstacle row, which of its friction slots the row
        // belongs to (ground: its end 0/1; obstacle: 2 + the obstacle geom id), and the sign of
        // the force on geom 2.
        let row_slot = |c: &ContactRow| -> Option<(usize, usize, f64)> {
            let (g1, g2) = (c.geom[0], c.geom[1]);
            let ground = |g: usize| st.ground_geom.get(g).copied().unwrap_or(false);
            let obstacle = |g: usize| st.obstacle_geom.get(g).copied().unwrap_or(false);
            let (link, other, sign) = st.link_side(g1, g2)?;
            if obstacle(other) {
                return Some((link, SLOTS + other, sign));
            }
            if !ground(other) {
                return None;
            }
            let along = s.along_link_axis_m(link, c.position_m);
            Some((link, usize::from(along < 0.0), sign))
        };
        // Pass 1: every row's slot, and Σ N over the rows (with N > 0) of each ground slot, in
        // row order (the order of the sums below, so the same bits).
        row_slots.clear();
        row_slots.extend(s.contacts.iter().map(row_slot));
        slot_normal_n.clear();
        slot_normal_n.resize(st.force_n.len(), [0.0; SLOTS]);
        for (c, key) in s.contacts.iter().zip(row_slots.iter()) {
            if let Some((link, slot, _)) = *key
                && slot < SLOTS
                && c.normal_force_n > 0.0
            {
                slot_normal_n[link][slot] += c.normal_force_n;
            }
        }
        for r in 0..s.contacts.len() {
            let Some((link, slot, sign)) = row_slots[r] else { continue };
            let n_row = s.contacts[r].normal_force_n;
            if n_row <= 0.0 {
                continue;
            }
            let applied = if slot < SLOTS {
                st.slot_force_n[link][slot]
            } else {
                // The link's slots with this obstacle geom (one, but for the whole-body solve's
                // per-point slots).
                let mut with_geom = st.obstacle_slots[link].iter().filter(|o| o.geom == slot - SLOTS).peekable();
                if with_geom.peek().is_none() {
                    continue;
                }
                with_geom.fold([0.0; 3], |f, o| add(f, o.force_n))
            };
            // Σ N over the rows of this slot (obstacle slots: a handful of rows, summed here).
            let n_slot: f64 = if slot < SLOTS {
                slot_normal_n[link][slot]
            } else {
                s.contacts
                    .iter()
                    .zip(row_slots.iter())
                    .filter(|(c, key)| c.normal_force_n > 0.0 && key.is_some_and(|(l, k, _)| l == link && k == slot))
                    .map(|(c, _)| c.normal_force_n)
                    .sum()
            };
            let f_on_geom2 = applied.map(|x| sign * x * n_row / n_slot);
            let axis = x_axis(s.link_quat[link]);
            let row = &mut s.contacts[r];
            // Tangent axes: the link's axis in the contact plane, and normal × that (MuJoCo's
            // frame of a capsule–plane contact, whose first tangent follows the capsule axis).
            let t1 = normalized(tangential(axis, row.normal)).unwrap_or_else(|| any_perpendicular(row.normal));
            let t2 = cross(row.normal, t1);
            row.friction_force_n = [dot(f_on_geom2, t1), dot(f_on_geom2, t2)];
            row.force_on_geom2_n = add(row.force_on_geom2_n, f_on_geom2);
        }
    }

    /// The link–ground and link–obstacle contacts of SimSerpent's contact law with their normal
    /// forces, when its latest evaluation is of `world`'s current instant (empty otherwise, and
    /// with `physics.floor_friction = "mujoco"`): MuJoCo's own contact list does not hold them.
    pub fn own_contacts(&self, world: &World) -> &[OwnContact] {
        match self.stick_slip.as_ref() {
            Some(st) if st.evaluated_at_secs == world.time_secs() => &st.own_contacts,
            _ => &[],
        }
    }

    /// Takes the ground geoms whose contacts SimSerpent's contact law computes away from MuJoCo
    /// (their collision bits zero, as during every step), so that every forward pass of the
    /// simulation, from its first, sees the same model. Does nothing without the law.
    pub fn detach_own_contacts(&self, world: &mut World) {
        if let Some(st) = self.stick_slip.as_ref() {
            for &(g, _, _, margin) in &st.env_geoms {
                world.set_geom_collision(g, 0, 0, margin);
            }
            for &(g, margin) in &st.surface_geoms {
                world.set_geom_collision(g, 0, 0, margin);
            }
        }
    }

    /// How far (m) a snake that starts at rest lying on level ground sinks into it before the
    /// per-link law's floor carries its weight. With every link at rest on two ground points
    /// (its end caps) at zero distance ([`RESTING_DISTANCE_M`]) on level ground (a plane, a box,
    /// a heightfield or a mesh), no other contact and no velocity: the depth δ at which Σ N = W,
    /// the snake's weight. Each point's held force at rest is N = k·(δ + g·dt²/4) (the spring by
    /// the trapezoidal rule over the step's predicted penetration, δ₁ = δ + ½·g·dt²), so
    /// δ = (W − Σ k·(d + g·dt²/4)) / Σ k, d each point's depth at the keyframe (0 up to
    /// rounding). Started there, a straight snake carries each link's weight on that link from
    /// the first step, and friction is bounded by μ of the whole weight from the first step (a
    /// link pushed at 0.999·μN from t = 0 moves 0.066 mm at μ 0.5); started at its radius, the
    /// floor carried a quarter of the weight at the first step and the snake fell into it.
    /// `None` for any other start, for the whole-body solve (whose static start is not a
    /// uniform sink) and for ground whose normal force is MuJoCo's.
    pub fn static_start_sink_m(&mut self, world: &mut World) -> Option<f64> {
        let st = self.stick_slip.as_mut().filter(|st| !st.whole_body)?;
        if world.data.qvel().iter().any(|v| *v != 0.0) {
            return None;
        }
        for &(g, contype, conaffinity, margin) in &st.env_geoms {
            world.set_geom_collision(g, contype, conaffinity, margin.max(DETECTION_MARGIN_M));
        }
        world.data.kinematics();
        world.data.com_pos();
        world.data.collision();
        let mujoco_ground_contact = st.find_contacts(&world.data);
        // Back as they were: a new `Ground` reads them from the model.
        for &(g, contype, conaffinity, margin) in &st.env_geoms {
            world.set_geom_collision(g, contype, conaffinity, margin);
        }
        if mujoco_ground_contact {
            return None;
        }
        let g = st.gravity_m_per_s2;
        let up = st.gravity_vector_m_per_s2.map(|x| -x / g);
        let dt = st.timestep_secs;
        let d = &world.data;
        let mut points = vec![0_usize; self.bodies.len()];
        let (mut stiffness_sum, mut held_sum) = (0.0, 0.0);
        for contact in &st.found {
            let (link, other, sign) = st.link_side(contact.geom[0], contact.geom[1])?;
            if contact.distance_m > RESTING_DISTANCE_M {
                continue; // within the detection margin, not touching
            }
            let nrm = contact.normal.map(|x| sign * x);
            let level = dot(nrm, up) >= 1.0 - 1e-9;
            if st.obstacle_geom[other] || contact.distance_m < -RESTING_DISTANCE_M || !level {
                return None;
            }
            points[link] += 1;
            let body = self.bodies[link];
            let law = st.ground_point_law(link, sub(contact.position_m, d.xipos()[body]), nrm, d.ximat()[body]);
            stiffness_sum += law.stiffness_n_per_m;
            held_sum += law.stiffness_n_per_m * (-contact.distance_m + 0.25 * g * dt * dt);
        }
        if points.iter().any(|&p| p != 2) {
            return None;
        }
        let weight_n: f64 = st.link_mass_kg.iter().sum::<f64>() * g;
        let sink_m = (weight_n - held_sum) / stiffness_sum;
        (sink_m > 0.0).then_some(sink_m)
    }

    /// Largest normal force of SimSerpent's contact law among the contacts of its latest
    /// evaluation (N; 0 without them): the part of a peak contact force that MuJoCo's contact
    /// list does not hold.
    pub fn peak_own_normal_force_n(&self) -> f64 {
        self.stick_slip.as_ref().map_or(0.0, |st| st.own_contacts.iter().map(|c| c.normal_force_n).fold(0.0, f64::max))
    }

    /// `physics.floor_friction = "stick_slip"`: the contacts of x_k (collision detection at the
    /// state itself), their normal forces and the friction of every link's ground and obstacle
    /// contacts into `xfrc_applied`.
    /// Returns whether it ended with a full forward pass at x_k (the law's geoms detached).
    fn before_step_stick_slip(&mut self, world: &mut World) -> bool {
        let Some(st) = self.stick_slip.as_mut() else { return false };
        for v in &mut st.normal_n {
            *v = [0.0; SLOTS];
        }
        for v in st.point_weighted.iter_mut().chain(st.normal_weighted.iter_mut()) {
            *v = [[0.0; 3]; SLOTS];
        }
        // Kinematics, centre-of-mass velocities and contacts of the state x_k; the ground geoms
        // collide only here, not in MuJoCo's step.
        for &(g, contype, conaffinity, margin) in &st.env_geoms {
            world.set_geom_collision(g, contype, conaffinity, margin.max(DETECTION_MARGIN_M));
        }
        world.data.kinematics();
        world.data.com_pos();
        world.data.com_vel();
        world.data.collision();
        for (i, &body) in self.bodies.iter().enumerate() {
            st.link_velocity[i] = world.data.object_velocity(MjtObjBase::mjOBJ_BODY, body, false);
        }
        for v in st.normal_force_n.iter_mut().chain(st.normal_torque_nm.iter_mut()) {
            *v = [0.0; 3];
        }
        // Whether a link touches an obstacle, and heightfield or mesh ground, at x_k.
        let mut obstacle_contact = false;
        let mujoco_ground_contact;
        {
            let d = &world.data;
            let xipos = d.xipos();
            let xmat = d.xmat();
            let ximat = d.ximat();
            let geom_body = d.model().geom_bodyid();
            let dt = st.timestep_secs;
            st.evaluated_at_secs = d.time();
            st.own_contacts.clear();
            st.elastic_energy_j = 0.0;
            st.obstacle_candidates.clear();
            mujoco_ground_contact = st.find_contacts(d);
            for slot in st.obstacle_slots.iter_mut().flatten() {
                slot.seen = false;
                slot.normal_n = 0.0;
                slot.point_weighted = [0.0; 3];
                slot.normal_weighted = [0.0; 3];
            }
            for c in 0..st.found.len() {
                let contact = st.found[c];
                let [g1, g2] = contact.geom;
                // The link side, the other geom, whether it is an obstacle, and the sign that
                // turns the contact's normal (geom1 → geom2) into the normal pointing from the
                // obstacle or ground into the link.
                let Some((link, other, sign)) = st.link_side(g1, g2) else { continue };
                let obstacle = st.obstacle_geom[other];
                let body = self.bodies[link];
                let com = xipos[body];
                let nrm = contact.normal.map(|x| sign * x);
                let r = sub(contact.position_m, com);
                let vel = st.link_velocity[link];
                let mut v_point = add([vel[3], vel[4], vel[5]], cross([vel[0], vel[1], vel[2]], r));
                let other_body = geom_body[other].max(0) as usize;
                if other_body != 0 {
                    let vo = d.object_velocity(MjtObjBase::mjOBJ_BODY, other_body, false);
                    let ro = sub(contact.position_m, xipos[other_body]);
                    v_point = sub(v_point, add([vo[3], vo[4], vo[5]], cross([vo[0], vo[1], vo[2]], ro)));
                }
                // Penetration and its rate; the mass the normal force's solve assumes for the
                // point: 1/m + 2·(r × n)ᵀ I⁻¹ (r × n), at most the point's effective mass for the
                // link alone and for the link rocking on two opposite points (its pitch), so the
                // solve is never less implicit than the point's real motion.
                let depth = -contact.distance_m;
                let approach = -dot(v_point, nrm);
                // The whole-body solve takes every contact (a step with a third-party ground
                // contact, whose normal force is MuJoCo's, takes the per-link law).
                let whole_body = st.whole_body && !mujoco_ground_contact;
                if obstacle || whole_body {
                    // Obstacle contacts get their normal force from the whole body's mobility
                    // once the ground's forces are known ([`StickSlip::obstacle_normals`]); with
                    // the whole-body solve every contact does, with its friction.
                    obstacle_contact |= depth > 0.0 || depth + approach * dt > 0.0;
                    let (place, ground_mu) = if whole_body {
                        let m = xmat[body];
                        let along = r[0] * m[0] + r[1] * m[3] + r[2] * m[6];
                        let half = st.link_capsules[link].map_or(0.0, |c| c.half_length_m);
                        let mu = (!obstacle).then(|| {
                            let region = if self.map.is_empty() { 0 } else { self.map.region_at(com[0], com[1]) };
                            friction_coefficients(self.model, self.map.friction(region))
                        });
                        (contact_place(along, half), mu)
                    } else {
                        (0, None)
                    };
                    st.obstacle_candidates.push(ObstacleCandidate {
                        contact,
                        link,
                        other,
                        place,
                        ground_mu,
                        nrm,
                        arm_m: r,
                        depth,
                        approach,
                    });
                    continue;
                }
                // Ground: the per-link law's spring–damper, the spring held explicitly, the
                // damper implicit (see the module docs).
                let law = st.ground_point_law(link, r, nrm, ximat[body]);
                let stiffness = law.stiffness_n_per_m;
                let free_approach = -dot(st.gravity_vector_m_per_s2, nrm);
                let n = held_normal_force_n(law, depth, approach, free_approach, dt);
                if depth <= 0.0 && n <= 0.0 {
                    continue; // within the detection margin, not touching
                }
                st.own_contacts.push(OwnContact {
                    geom: [g1, g2],
                    position_m: contact.position_m,
                    normal: contact.normal,
                    distance_m: contact.distance_m,
                    normal_force_n: n,
                });
                if depth > 0.0 {
                    st.elastic_energy_j += 0.5 * stiffness * depth * depth;
                }
                if n <= 0.0 {
                    continue;
                }
                let f = nrm.map(|x| n * x);
                st.normal_force_n[link] = add(st.normal_force_n[link], f);
                st.normal_torque_nm[link] = add(st.normal_torque_nm[link], cross(r, f));
                let m = xmat[body];
                let along = r[0] * m[0] + r[1] * m[3] + r[2] * m[6];
                let slot = usize::from(along < 0.0);
                st.normal_n[link][slot] += n;
                st.point_weighted[link][slot] = add(st.point_weighted[link][slot], contact.position_m.map(|x| n * x));
                st.normal_weighted[link][slot] = add(st.normal_weighted[link][slot], f);
            }
        }
        for &(g, _, _, margin) in &st.env_geoms {
            world.set_geom_collision(g, 0, 0, margin);
        }
        // Ground of other shapes (a third-party terrain): MuJoCo's normal forces at x_k, from a
        // forward pass with the step's own normal forces applied (the law's geoms detached, as in
        // MuJoCo's step).
        if mujoco_ground_contact {
            for (i, &body) in self.bodies.iter().enumerate() {
                let (f, t) = (st.normal_force_n[i], st.normal_torque_nm[i]);
                world.data.xfrc_applied_mut()[body] = [f[0], f[1], f[2], t[0], t[1], t[2]];
            }
            world.data.forward();
            st.collect_mujoco_ground_normals(&world.data, &self.bodies);
        } else {
            for v in &mut st.mujoco_ground_n {
                *v = [0.0; SLOTS];
            }
        }
        let surfaces = !self.map.is_empty();
        let dt = st.timestep_secs;
        for (i, &body) in self.bodies.iter().enumerate() {
            let com = world.data.xipos()[body];
            let region = if surfaces { self.map.region_at(com[0], com[1]) } else { 0 };
            self.region_now[i] = region;
            let f = *self.map.friction(region);
            let [mu_fwd, mu_back, mu_lat] = friction_coefficients(self.model, &f);
            let xmat = world.data.xmat()[body];
            let axis = [xmat[0], xmat[3], xmat[6]];
            let vel = st.link_velocity[i];
            let (w, v_com) = ([vel[0], vel[1], vel[2]], [vel[3], vel[4], vel[5]]);
            let mut force = [0.0; 3];
            let mut torque = [0.0; 3];
            // The forces on the link known before the step, its weight and its applied external
            // force (on a level plane the weight has no tangential part: f_k is zero and the
            // stick force is the spring's).
            let ext = st.external_force_n[i];
            let known = [0, 1, 2].map(|j| st.link_mass_kg[i] * st.gravity_vector_m_per_s2[j] + ext[j]);
            // Each slot's share: the part of the link's weight its N carries, N / (m·|g·n|), the
            // shares capped at one link in all (joints or an obstacle carry the rest).
            let mut share = [0.0; SLOTS];
            let mut normals = [[0.0, 0.0, 1.0]; SLOTS];
            for ((s, nrm), (&n_force, &weighted)) in
                share.iter_mut().zip(&mut normals).zip(st.normal_n[i].iter().zip(&st.normal_weighted[i]))
            {
                if n_force > 0.0 {
                    *nrm = normalized(weighted).unwrap_or([0.0, 0.0, 1.0]);
                    let weight_n = st.link_mass_kg[i] * dot(st.gravity_vector_m_per_s2, *nrm).abs();
                    *s = if weight_n > 0.0 { n_force / weight_n } else { 0.0 };
                }
            }
            let total: f64 = share.iter().sum();
            if total > 1.0 {
                share = share.map(|s| s / total);
            }
            for (slot, &slot_share) in share.iter().enumerate() {
                let n_force = st.normal_n[i][slot];
                let z = &mut st.deflection_m[i][slot];
                st.slot_force_n[i][slot] = [0.0; 3];
                if n_force <= 0.0 {
                    *z = [0.0; 3];
                    continue;
                }
                let p = st.point_weighted[i][slot].map(|x| x / n_force);
                let nrm = normals[slot];
                let r = sub(p, com);
                let v_point = add(v_com, cross(w, r));
                let v_t = tangential(v_point, nrm);
                // Tangent frame: the link's axis in the contact plane, and across it.
                let a = normalized(tangential(axis, nrm)).unwrap_or_else(|| any_perpendicular(nrm));
                let l = cross(nrm, a);
                // The anchor stays on the ground: the deflection keeps only its tangential part
                // and grows by the contact point's motion over the step.
                let z_now = tangential(*z, nrm);
                let z_pred = add(z_now, v_t.map(|x| x * dt));
                let mass = (n_force / st.gravity_m_per_s2).min(st.half_link_mass_kg[i]);
                let (k, c) = (mass * st.omega_sq_per_s2, mass * st.two_omega_per_s);
                let known_t = tangential(known.map(|x| x * slot_share), nrm);
                let held = known_t != [0.0; 3];
                let trial = [0, 1, 2].map(|j| -k * z_pred[j] - c * v_t[j] - if held { known_t[j] } else { 0.0 });
                // The nearest point of the friction ellipse in the contact's (a, l) frame.
                let onto_ellipse = |f: [f64; 3]| {
                    let (fa, fl) = (dot(f, a), dot(f, l));
                    let mu_a = if fa > 0.0 { mu_back } else { mu_fwd };
                    let (pa, pl) = crate::state::project_to_ellipse(fa, fl, mu_a * n_force, mu_lat * n_force);
                    ((fa, fl), (pa, pl), [0, 1, 2].map(|j| pa * a[j] + pl * l[j]))
                };
                let ((ta, tl), (fa, fl), mut f_world) = onto_ellipse(trial);
                // The spring's part of a friction force (the known forces' part is not the spring's).
                let spring_of = |f: [f64; 3]| if held { add(f, known_t) } else { f };
                // A stick spring springing back along the point's motion gives back the energy
                // it stored: at most STICK_RELEASE_J per step (the rest of the force along the
                // velocity is dropped and the anchor follows). The known forces' part is not the
                // spring's.
                let (power, v_sq) = (dot(spring_of(f_world), v_t), dot(v_t, v_t));
                let pushes = power * dt > STICK_RELEASE_J && v_sq > 0.0;
                if pushes {
                    let excess = power - STICK_RELEASE_J / dt;
                    f_world = sub(f_world, v_t.map(|x| x * excess / v_sq));
                    if held {
                        // Taken from the spring's part, the rest may leave the ellipse: back
                        // onto it.
                        f_world = onto_ellipse(f_world).2;
                    }
                }
                if fa == ta && fl == tl && !pushes {
                    *z = z_pred; // sticks
                } else if k > 0.0 {
                    // Slides: the anchor is dragged along (the spring holds what the known
                    // forces do not).
                    *z = spring_of(f_world).map(|x| -x / k);
                }
                if st.mujoco_ground_n[i][slot] > 0.0 {
                    // The N this force needs: where it lies on its ellipse (see the scale-back).
                    let (fa, fl) = (dot(f_world, a), dot(f_world, l));
                    let along = if fa > 0.0 { mu_back } else { mu_fwd };
                    let need = |f: f64, mu: f64| if mu > 0.0 { f / mu } else { 0.0 };
                    st.bound_load_n[i][slot] = need(fa, along).hypot(need(fl, mu_lat));
                    st.bound_previous[i][slot] = (0.0, n_force);
                }
                st.slot_force_n[i][slot] = f_world;
                force = add(force, f_world);
                torque = add(torque, cross(r, f_world));
            }
            st.force_n[i] = force;
            st.torque_nm[i] = torque;
            st.obstacle_force_n[i] = [0.0; 3];
            st.obstacle_torque_nm[i] = [0.0; 3];
            let force = add(force, st.normal_force_n[i]);
            let torque = add(torque, st.normal_torque_nm[i]);
            let slot = &mut world.data.xfrc_applied_mut()[body];
            *slot = [force[0], force[1], force[2], torque[0], torque[1], torque[2]];
        }
        if obstacle_contact {
            if st.whole_body && !mujoco_ground_contact {
                self.whole_body_solve(world);
            } else {
                self.obstacle_normals(world, mujoco_ground_contact);
                self.obstacle_friction(world, mujoco_ground_contact);
            }
            return true;
        }
        for slot in st.obstacle_slots.iter_mut().flatten() {
            *slot = ObstacleSlot::FREE;
        }
        if mujoco_ground_contact {
            // The friction moves MuJoCo's normal forces: a second forward pass with it applied
            // gives the heightfield and mesh contacts the N the step will have.
            st.settle_friction_bounds(world, &self.bodies);
        }
        mujoco_ground_contact
    }

    /// The normal forces of the links' obstacle contacts at x_k, on a step where a link touches
    /// an obstacle or may within the step: a forward pass at x_k with the step's ground forces in
    /// `xfrc_applied` (the law's geoms detached, as in MuJoCo's step) gives the contact points'
    /// mobility through the whole articulated body along their normals, W = J·M⁻¹·Jᵀ, and their
    /// accelerations toward the obstacles without obstacle forces, a. Each point carries the mass
    /// m_c = 1/Σ_j W_ij over the touching points, on the law's spring–damper k = m_c·ω²,
    /// c = m_c·b, integrated implicitly through W ([`normal_force_terms`]), solved over the
    /// points by projected Gauss–Seidel: a link hitting a peg rebounds at the configured
    /// restitution whatever the step and whatever the joints add to its mass. The forces go into
    /// `xfrc_applied` and the obstacle friction slots.
    fn obstacle_normals(&mut self, world: &mut World, forward_done: bool) {
        let Some(st) = self.stick_slip.as_mut() else { return };
        if forward_done {
            forward_forces(world);
        } else {
            world.data.forward();
        }
        st.obstacle_rows.clear();
        for c in &st.obstacle_candidates {
            st.obstacle_rows.push((self.bodies[c.link], c.contact.position_m, c.nrm));
        }
        world.point_mobility(&st.obstacle_rows, &mut st.mobility);
        let count = st.obstacle_candidates.len();
        let dt = st.timestep_secs;
        let w = &st.mobility.w;
        // Each touching point's mass: the inverse of its row of W summed over the touching
        // points (the positive entries), the mass it carries when every point pushes alike (a
        // link hitting flat on both caps: half the link and what its joints add; one point:
        // 1/W_ii).
        let touching = |c: &ObstacleCandidate| c.depth > 0.0 || c.depth + c.approach * dt > 0.0;
        st.obstacle_terms.clear();
        for (i, c) in st.obstacle_candidates.iter().enumerate() {
            let row_sum: f64 = (0..count)
                .filter(|&j| j == i || touching(&st.obstacle_candidates[j]))
                .map(|j| w[i * count + j].max(0.0))
                .sum();
            let carried = if row_sum > 0.0 { 1.0 / row_sum } else { st.link_mass_kg[c.link] };
            let law = NormalLaw {
                stiffness_n_per_m: carried * st.normal_stiffness_per_s2,
                damping_n_s_per_m: carried * st.normal_damping_per_s,
                effective_mass_kg: carried,
            };
            // The acceleration toward the obstacle (the rows point away from it, into the link).
            let free_approach = -st.mobility.acc[i];
            let (numerator, implicit) = normal_force_terms(law, c.depth, c.approach, free_approach, dt);
            st.obstacle_terms.push(ObstacleTerms { numerator, implicit, stiffness: law.stiffness_n_per_m, n: 0.0 });
        }
        // N_i = (numerator_i − implicit_i·Σ_{j≠i} W_ij·N_j)/(1 + implicit_i·W_ii), N ≥ 0:
        // projected Gauss–Seidel (the points pushing one body share its motion in the step).
        let largest = st.obstacle_terms.iter().map(|t| t.numerator.abs()).fold(0.0, f64::max);
        for _ in 0..FRICTION_SOLVER_SWEEPS {
            let mut change = 0.0_f64;
            for i in 0..count {
                let t = st.obstacle_terms[i];
                if t.implicit == 0.0 && t.numerator <= 0.0 {
                    continue;
                }
                let coupled: f64 =
                    (0..count).filter(|&j| j != i).map(|j| w[i * count + j] * st.obstacle_terms[j].n).sum();
                let n = ((t.numerator - t.implicit * coupled) / (1.0 + t.implicit * w[i * count + i])).max(0.0);
                change = change.max((n - t.n).abs());
                st.obstacle_terms[i].n = n;
            }
            if change <= 1e-9 * (1.0 + largest) {
                break;
            }
        }
        for i in 0..st.obstacle_candidates.len() {
            let c = st.obstacle_candidates[i];
            let ObstacleTerms { stiffness, n, .. } = st.obstacle_terms[i];
            let Some(f) = st.add_contact_normal(world, self.bodies[c.link], &c, n, stiffness) else { continue };
            // One friction slot per link and touching obstacle geom: a slot keeps its geom while
            // the link touches it; a new geom takes a free slot, or one not seen at this state.
            let slots = &mut st.obstacle_slots[c.link];
            let Some(slot) = claim_slot(slots, c.other, c.place) else { continue };
            slot.seen = true;
            slot.normal_n += n;
            slot.point_weighted = add(slot.point_weighted, c.contact.position_m.map(|x| n * x));
            slot.normal_weighted = add(slot.normal_weighted, f);
        }
    }

    /// `physics.environment_contact_solve = "whole_body"`: the normal force and the friction of
    /// every link–ground and link–obstacle contact point of x_k in one projected Gauss–Seidel
    /// solve through the whole body's mobility (see "Whole-body solve" in the module docs). A
    /// forward pass at x_k without the law's forces (the law's geoms detached, as in MuJoCo's
    /// step) gives each point's three rows (normal n, the link's axis in the contact plane a,
    /// across it l), their accelerations without contact forces and M⁻¹·Jᵀ; the solve keeps the
    /// joint-space effect of its forces, Δq̈ = Σ_r M⁻¹·J_rᵀ·f_r, so a row's acceleration is
    /// acc_r + J_r·Δq̈ (O(nv) per row, no dense W). Per point, in turn until no force changes by
    /// more than [`WHOLE_BODY_TOLERANCE`] of the largest: the normal force of the implicit spring–damper
    /// ([`normal_force_terms`]) given the others, then the friction that stops the point's slip
    /// (plus its drift since it stuck over the stick time constant) within the step, projected
    /// onto its ellipse μ·N of this N in the metric of the point's own 2 × 2 mobility block
    /// ([`project_to_ellipse_in_metric`]: the exact minimiser of the block's sub-problem). The
    /// forces go into `xfrc_applied`, the contact rows and the per-link floor and obstacle
    /// channels where the per-link law's go.
    fn whole_body_solve(&mut self, world: &mut World) {
        let Some(st) = self.stick_slip.as_mut() else { return };
        world.data.forward();
        let dt = st.timestep_secs;
        // Only the points that push within the step (the others carry no force).
        let touching = |c: &ObstacleCandidate| c.depth > 0.0 || c.depth + c.approach * dt > 0.0;
        st.solve_points.clear();
        st.solve_frames.clear();
        for (i, c) in st.obstacle_candidates.iter().enumerate() {
            if !touching(c) {
                continue;
            }
            let body = self.bodies[c.link];
            let xmat = world.data.xmat()[body];
            let axis = [xmat[0], xmat[3], xmat[6]];
            let a = normalized(tangential(axis, c.nrm)).unwrap_or_else(|| any_perpendicular(c.nrm));
            let l = cross(c.nrm, a);
            st.solve_frames.push((body, c.contact.position_m, [c.nrm, a, l]));
            st.solve_points.push(SolvePoint { candidate: i, frame: [c.nrm, a, l], ..SolvePoint::ZERO });
        }
        world.point_frame_jacobians(&st.solve_frames, &mut st.mobility);
        let mob = &st.mobility;
        let nv = mob.nv();
        let count = st.solve_points.len();
        // Per point: its normal law, coefficients, slip to remove, own mobility block, and the
        // warm start (the forces of its slot in the step before).
        for p in 0..count {
            let c = st.obstacle_candidates[st.solve_points[p].candidate];
            // The mass the point's spring–damper is scaled for: a ground point, its share of
            // the link (as the per-link law: a capsule lying flat rests on its two caps); an
            // obstacle point, the inverse of its normal row of W summed over the touching
            // obstacle points (one point: 1/W_ii; a link hitting flat on both caps: half the
            // link and what its joints add).
            let carried = if c.ground_mu.is_some() {
                st.link_mass_kg[c.link] / st.ground_points[c.link].max(2) as f64
            } else {
                let row_sum: f64 = (0..count)
                    .filter(|&q| st.obstacle_candidates[st.solve_points[q].candidate].ground_mu.is_none())
                    .map(|q| mob.mobility(3 * p, 3 * q).max(0.0))
                    .sum();
                if row_sum > 0.0 { 1.0 / row_sum } else { st.link_mass_kg[c.link] }
            };
            let law = NormalLaw {
                stiffness_n_per_m: carried * st.normal_stiffness_per_s2,
                damping_n_s_per_m: carried * st.whole_body_damping_per_s,
                effective_mass_kg: carried,
            };
            // The rows point away from the ground or obstacle: the approach acceleration is −acc.
            let (numerator, implicit) = normal_force_terms(law, c.depth, c.approach, -mob.acc[3 * p], dt);
            let vel = st.link_velocity[c.link];
            let v_t = tangential(add([vel[3], vel[4], vel[5]], cross([vel[0], vel[1], vel[2]], c.arm_m)), c.nrm);
            let slot = st.obstacle_slots[c.link].iter().find(|s| s.geom == c.other && s.place == c.place);
            let z = tangential(slot.map_or([0.0; 3], |s| s.deflection_m), c.nrm);
            let slip = add(v_t, z.map(|x| x / st.stick_time_constant_secs));
            let sp = &mut st.solve_points[p];
            let [_, a, l] = sp.frame;
            let mut block = [[0.0; 3]; 3];
            for (j, row) in block.iter_mut().enumerate() {
                for (k, x) in row.iter_mut().enumerate() {
                    *x = mob.mobility(3 * p + j, 3 * p + k);
                }
            }
            sp.block = block;
            sp.numerator = numerator;
            sp.implicit = implicit;
            sp.stiffness = law.stiffness_n_per_m;
            sp.mu = c.ground_mu.unwrap_or([st.obstacle_mu; 3]);
            sp.slip = [dot(slip, a), dot(slip, l)];
            sp.z = z;
            sp.v_t = v_t;
            sp.f = slot.map_or([0.0; 3], |s| [s.last_normal_n, dot(s.force_n, a), dot(s.force_n, l)]);
        }
        // Δq̈ of the warm start.
        st.solve_dv.clear();
        st.solve_dv.resize(nv, 0.0);
        for (p, sp) in st.solve_points.iter().enumerate() {
            for k in 0..3 {
                if sp.f[k] != 0.0 {
                    axpy(&mut st.solve_dv, sp.f[k], mob.response(3 * p + k));
                }
            }
        }
        let largest = st.solve_points.iter().map(|p| p.numerator.abs()).fold(0.0, f64::max);
        for _ in 0..WHOLE_BODY_SWEEPS {
            let mut change = 0.0_f64;
            for (p, sp) in st.solve_points.iter_mut().enumerate() {
                // The three rows' accelerations from the forces so far (one pass over Δq̈).
                let jac = mob.point_jacobians(p);
                let (jn, rest) = jac.split_at(nv);
                let (ja, jl) = rest.split_at(nv);
                let mut g = [0.0; 3];
                for k in 0..nv {
                    let d = st.solve_dv[k];
                    g[0] += jn[k] * d;
                    g[1] += ja[k] * d;
                    g[2] += jl[k] * d;
                }
                let b = &sp.block;
                // Normal, given every other force (this point's friction included).
                let n_old = sp.f[0];
                let others = g[0] - b[0][0] * n_old;
                let n = if sp.implicit == 0.0 && sp.numerator <= 0.0 {
                    0.0
                } else {
                    ((sp.numerator - sp.implicit * others) / (1.0 + sp.implicit * b[0][0])).max(0.0)
                };
                let dn = n - n_old;
                // Friction: the force that ends the step without slip, inside μ·N's ellipse (the
                // rows' accelerations with the new N).
                let old = [sp.f[1], sp.f[2]];
                let ga = sp.slip[0] / dt + mob.acc[3 * p + 1] + g[1] + b[1][0] * dn;
                let gl = sp.slip[1] / dt + mob.acc[3 * p + 2] + g[2] + b[2][0] * dn;
                let (w00, w01, w10, w11) = (b[1][1], b[1][2], b[2][1], b[2][2]);
                let det = w00 * w11 - w01 * w10;
                let (fa, fl) = if det > 0.0 {
                    let trial = [old[0] - (w11 * ga - w01 * gl) / det, old[1] - (w00 * gl - w10 * ga) / det];
                    let mu_a = if trial[0] > 0.0 { sp.mu[1] } else { sp.mu[0] };
                    let metric = [[w00, 0.5 * (w01 + w10)], [0.5 * (w01 + w10), w11]];
                    project_to_ellipse_in_metric(trial, mu_a * n, sp.mu[2] * n, metric)
                } else {
                    (old[0], old[1])
                };
                let (da, dl) = (fa - old[0], fl - old[1]);
                if dn != 0.0 || da != 0.0 || dl != 0.0 {
                    let resp = mob.point_responses(p);
                    let (rn, rest) = resp.split_at(nv);
                    let (ra, rl) = rest.split_at(nv);
                    for k in 0..nv {
                        st.solve_dv[k] += dn * rn[k] + da * ra[k] + dl * rl[k];
                    }
                }
                sp.f = [n, fa, fl];
                change = change.max(dn.abs()).max(da.abs()).max(dl.abs());
            }
            if change <= WHOLE_BODY_TOLERANCE * (1.0 + largest) {
                break;
            }
        }
        // The forces into xfrc_applied, the contact rows and the per-link channels.
        for o in st.obstacle_force_n.iter_mut().chain(st.obstacle_torque_nm.iter_mut()) {
            *o = [0.0; 3];
        }
        for slot in st.obstacle_slots.iter_mut().flatten() {
            slot.seen = false;
        }
        for p in 0..count {
            let sp = st.solve_points[p];
            let c = st.obstacle_candidates[sp.candidate];
            let n = sp.f[0];
            let body = self.bodies[c.link];
            if st.add_contact_normal(world, body, &c, n, sp.stiffness).is_none() {
                continue;
            }
            let [_, a, l] = sp.frame;
            let (fa, fl) = (sp.f[1], sp.f[2]);
            let f_world = [0, 1, 2].map(|j| fa * a[j] + fl * l[j]);
            // On its ellipse the point slides (its anchor follows it), inside it sticks.
            let mu_a = if fa > 0.0 { sp.mu[1] } else { sp.mu[0] };
            let on_ellipse = |f: f64, limit: f64| if limit > 0.0 { (f / limit).powi(2) } else { 1.0 };
            let sliding = on_ellipse(fa, mu_a * n) + on_ellipse(fl, sp.mu[2] * n) >= 1.0 - 1e-9;
            if let Some(slot) = claim_slot(&mut st.obstacle_slots[c.link], c.other, c.place) {
                slot.seen = true;
                slot.last_normal_n = n;
                slot.normal_n = n;
                slot.deflection_m = if sliding { [0.0; 3] } else { add(sp.z, sp.v_t.map(|x| x * dt)) };
                slot.force_n = f_world;
                slot.arm_m = c.arm_m;
            }
            if c.ground_mu.is_some() {
                // The ground rows of a snapshot share their link end's friction.
                let m = world.data.xmat()[body];
                let end = usize::from(c.arm_m[0] * m[0] + c.arm_m[1] * m[3] + c.arm_m[2] * m[6] < 0.0);
                st.slot_force_n[c.link][end] = add(st.slot_force_n[c.link][end], f_world);
            }
            st.add_friction(world, body, c.link, f_world, cross(c.arm_m, f_world), c.ground_mu.is_none());
        }
        for slot in st.obstacle_slots.iter_mut().flatten() {
            if !slot.seen {
                *slot = ObstacleSlot::FREE;
            }
        }
    }

    /// The friction of the links' obstacle contacts at x_k, on a step where a link touches an
    /// obstacle: a forward pass at x_k from the acceleration stage on, with the step's ground and
    /// obstacle normal forces in `xfrc_applied` ([`Ground::obstacle_normals`] gave each contact its
    /// N_k), gives the contact points' accelerations without obstacle friction and the factorised
    /// mass matrix; the friction that stops every obstacle contact point's slip within the step,
    /// each slot's force inside its disk μ·N_k, is solved over all slots at once and added to
    /// `xfrc_applied`. See "Obstacles" in the module docs.
    fn obstacle_friction(&mut self, world: &mut World, mujoco_ground_contact: bool) {
        let Some(st) = self.stick_slip.as_mut() else { return };
        // The obstacle normal forces' pass ran the kinematics and collision of x_k already.
        forward_forces(world);
        let dt = st.timestep_secs;
        let mu = st.obstacle_mu;
        // Every touching obstacle slot: its contact point, normal and tangent frame (the link's
        // axis in the contact plane, and across it), and two rows of the mobility problem.
        st.active.clear();
        st.rows.clear();
        for (i, &body) in self.bodies.iter().enumerate() {
            let com = world.data.xipos()[body];
            let xmat = world.data.xmat()[body];
            let axis = [xmat[0], xmat[3], xmat[6]];
            let vel = st.link_velocity[i];
            let (w, v_com) = ([vel[0], vel[1], vel[2]], [vel[3], vel[4], vel[5]]);
            for (k, slot) in st.obstacle_slots[i].iter_mut().enumerate() {
                if !slot.seen {
                    *slot = ObstacleSlot::FREE;
                    continue;
                }
                let n_force = slot.normal_n;
                let p = slot.point_weighted.map(|x| x / n_force);
                let nrm = normalized(slot.normal_weighted).unwrap_or([0.0, 0.0, 1.0]);
                let r = sub(p, com);
                let v_t = tangential(add(v_com, cross(w, r)), nrm);
                let a = normalized(tangential(axis, nrm)).unwrap_or_else(|| any_perpendicular(nrm));
                let l = cross(nrm, a);
                // The slip the step should end with: none, less the drift since the contact
                // stuck, taken back over the stick time constant.
                let z = tangential(slot.deflection_m, nrm);
                let slip = add(v_t, z.map(|x| x / st.stick_time_constant_secs));
                st.active.push(ActiveSlot {
                    link: i,
                    slot: k,
                    tangents: [a, l],
                    arm_m: r,
                    slip_m_per_s: [dot(slip, a), dot(slip, l)],
                    stuck_deflection_m: add(z, v_t.map(|x| x * dt)),
                    limit_n: mu * n_force,
                });
                st.rows.push((body, p, a));
                st.rows.push((body, p, l));
            }
        }
        // W·F = −b with b = slip/dt + the points' accelerations without obstacle friction, each
        // slot's force inside its disk: projected Gauss–Seidel over the slots (2 × 2 blocks).
        world.point_mobility(&st.rows, &mut st.mobility);
        let m = st.active.len();
        let nr = 2 * m;
        let (wm, acc) = (&st.mobility.w, &st.mobility.acc);
        st.solved_n.clear();
        st.solved_n.resize(m, [0.0; 2]);
        let largest_limit = st.active.iter().map(|a| a.limit_n).fold(0.0, f64::max);
        for _ in 0..FRICTION_SOLVER_SWEEPS {
            let mut change = 0.0_f64;
            for (s, slot) in st.active.iter().enumerate() {
                let (r0, r1) = (2 * s, 2 * s + 1);
                let mut g = [slot.slip_m_per_s[0] / dt + acc[r0], slot.slip_m_per_s[1] / dt + acc[r1]];
                for (t, f) in st.solved_n.iter().enumerate() {
                    g[0] += wm[r0 * nr + 2 * t] * f[0] + wm[r0 * nr + 2 * t + 1] * f[1];
                    g[1] += wm[r1 * nr + 2 * t] * f[0] + wm[r1 * nr + 2 * t + 1] * f[1];
                }
                let (w00, w01, w10, w11) = (wm[r0 * nr + r0], wm[r0 * nr + r1], wm[r1 * nr + r0], wm[r1 * nr + r1]);
                let det = w00 * w11 - w01 * w10;
                if det <= 0.0 {
                    continue;
                }
                let f = st.solved_n[s];
                let trial = [f[0] - (w11 * g[0] - w01 * g[1]) / det, f[1] - (w00 * g[1] - w10 * g[0]) / det];
                let size = (trial[0] * trial[0] + trial[1] * trial[1]).sqrt();
                let scale = if size > slot.limit_n { slot.limit_n / size } else { 1.0 };
                let (fa, fl) = (trial[0] * scale, trial[1] * scale);
                change = change.max((fa - f[0]).abs()).max((fl - f[1]).abs());
                st.solved_n[s] = [fa, fl];
            }
            if change <= 1e-9 * (1.0 + largest_limit) {
                break;
            }
        }
        for o in &mut st.obstacle_force_n {
            *o = [0.0; 3];
        }
        for o in &mut st.obstacle_torque_nm {
            *o = [0.0; 3];
        }
        for s in 0..st.active.len() {
            let (a, f) = (st.active[s], st.solved_n[s]);
            let [t1, t2] = a.tangents;
            let f_world = [0, 1, 2].map(|j| f[0] * t1[j] + f[1] * t2[j]);
            let sliding = (f[0] * f[0] + f[1] * f[1]).sqrt() >= a.limit_n * (1.0 - 1e-9);
            let torque = cross(a.arm_m, f_world);
            let slot = &mut st.obstacle_slots[a.link][a.slot];
            // Sliding, the anchor moves with the contact point.
            slot.deflection_m = if sliding { [0.0; 3] } else { a.stuck_deflection_m };
            slot.force_n = f_world;
            slot.arm_m = a.arm_m;
            st.add_friction(world, self.bodies[a.link], a.link, f_world, torque, true);
        }
        // The obstacle contacts' normal forces are the law's of x_k (the friction does not move
        // them); heightfield and mesh ground contacts get MuJoCo's, moved by the friction.
        if mujoco_ground_contact {
            st.settle_friction_bounds(world, &self.bodies);
        }
    }
}

/// Forward passes at most after the step's friction is applied, each followed by a scale-back of
/// the slots above μ times the normal force it found, until none is above.
const BOUND_PASSES: usize = 4;

/// How far inside μ·N a heightfield or mesh ground slot is scaled back to (a share of μ·N).
const BOUND_MARGIN: f64 = 1e-3;

impl StickSlip {
    /// Forward passes at x_k with the step's friction applied, each scaling back every
    /// heightfield or mesh ground slot whose friction exceeds μ times the normal force that pass
    /// found, until a pass scales none back (at most [`BOUND_PASSES`]). Scaling friction back
    /// changes MuJoCo's normal forces again, usually giving back normal force that friction took.
    fn settle_friction_bounds(&mut self, world: &mut World, bodies: &[usize]) {
        for _ in 0..BOUND_PASSES {
            forward_forces(world);
            if !self.rescale_mujoco_ground_slots(world, bodies) {
                break;
            }
        }
    }
}

/// MuJoCo's forward pass from the acceleration stage on (actuation, applied forces, constraint
/// solve), without sensors: for a forward pass at the same state and contacts as the latest
/// full one, with other applied forces. Its results equal a full pass's, without repeating
/// kinematics, collision detection and the velocity stage.
fn forward_forces(world: &mut World) {
    world.data.forward_skip(mujoco_rs::prelude::MjtStage::mjSTAGE_VEL, true);
}

/// A ground region's Coulomb coefficients under `model`: forward (friction force toward the
/// tail), backward (toward the head), lateral.
fn friction_coefficients(model: GroundModel, f: &crate::config::SurfaceFriction) -> [f64; 3] {
    match model {
        GroundModel::Isotropic => [f.sliding, f.sliding, f.sliding],
        GroundModel::Anisotropic => [f.axial, f.axial, f.lateral],
        GroundModel::Directional => [f.axial, f.backward, f.lateral],
        GroundModel::Viscous => [0.0; 3],
    }
}

/// The slot of `slots` for a contact with `geom` at `place`: the one it had (a slot keeps its
/// contact while the link touches it), else a free one, else one not seen at this state (reset).
fn claim_slot(slots: &mut [ObstacleSlot; OBSTACLE_SLOTS], geom: usize, place: usize) -> Option<&mut ObstacleSlot> {
    let k = slots
        .iter()
        .position(|s| s.geom == geom && s.place == place)
        .or_else(|| slots.iter().position(|s| s.geom == usize::MAX))
        .or_else(|| slots.iter().position(|s| !s.seen))?;
    let slot = &mut slots[k];
    if slot.geom != geom || slot.place != place {
        *slot = ObstacleSlot { geom, place, ..ObstacleSlot::FREE };
    }
    Some(slot)
}

/// Where on a link a contact point lies, for the whole-body solve's per-point friction state:
/// 0 ahead of the middle half of the capsule's axis segment (`half_length_m` from the centre of
/// mass each way), 1 behind it, 2 within it (a heightfield bump under the middle).
fn contact_place(along_m: f64, half_length_m: f64) -> usize {
    if along_m > 0.5 * half_length_m {
        0
    } else if along_m < -0.5 * half_length_m {
        1
    } else {
        2
    }
}

/// A link–ground or link–obstacle contact of x_k before its normal force: the geoms (one of them
/// a link's), the point, the normal from geom 1 to geom 2 and the distance (negative: penetrating).
#[derive(Debug, Clone, Copy)]
struct FoundContact {
    geom: [usize; 2],
    position_m: [f64; 3],
    normal: [f64; 3],
    distance_m: f64,
}

/// A link–obstacle contact of x_k before its normal force: the contact, the link, the obstacle
/// geom, the normal from the obstacle into the link, the contact point's arm from the link's
/// centre of mass (m), the penetration (m) and its rate (m/s).
#[derive(Debug, Clone, Copy)]
struct ObstacleCandidate {
    contact: FoundContact,
    link: usize,
    other: usize,
    /// Where on the link ([`contact_place`]; 0 with `"per_link"`).
    place: usize,
    /// Ground contacts of the whole-body solve: their friction coefficients (forward, backward,
    /// lateral); `None` for obstacle contacts.
    ground_mu: Option<[f64; 3]>,
    nrm: [f64; 3],
    arm_m: [f64; 3],
    depth: f64,
    approach: f64,
}

/// An obstacle contact point's terms of the coupled normal-force solve: the two terms of
/// [`normal_force_terms`], its stiffness (N/m) and its normal force (N).
#[derive(Debug, Clone, Copy)]
struct ObstacleTerms {
    numerator: f64,
    implicit: f64,
    stiffness: f64,
    n: f64,
}

/// A link's capsule: its geom, radius and the half-length of its axis segment (m).
#[derive(Debug, Clone, Copy)]
struct Capsule {
    geom: usize,
    radius_m: f64,
    half_length_m: f64,
}

/// The capsule geom of each link (`None` for a link without one: a user's robot).
fn link_capsules(world: &World) -> Vec<Option<Capsule>> {
    let m = world.model();
    let (types, sizes) = (m.geom_type(), m.geom_size());
    let mut out = vec![None; world.n_links()];
    for (g, link) in world.index.geom_link.iter().enumerate() {
        if let Some(l) = *link
            && types[g] == MjtGeomBase::mjGEOM_CAPSULE
            && out[l].is_none()
        {
            out[l] = Some(Capsule { geom: g, radius_m: sizes[g][0], half_length_m: sizes[g][1] });
        }
    }
    out
}

/// The two ends of a capsule's axis segment (world frame) at the latest kinematics.
fn capsule_ends(d: &MjData<Box<MjModel>>, cap: &Capsule) -> [[f64; 3]; 2] {
    let (p, r) = (d.geom_xpos()[cap.geom], d.geom_xmat()[cap.geom]);
    let axis = [r[2], r[5], r[8]];
    let h = cap.half_length_m;
    [add(p, axis.map(|x| h * x)), sub(p, axis.map(|x| h * x))]
}

/// `w` (world frame) in the frame of a geom with rotation `r` (row-major) at `p`.
fn to_local(r: &[f64; 9], p: [f64; 3], w: [f64; 3]) -> [f64; 3] {
    let v = sub(w, p);
    [0, 1, 2].map(|j| r[j] * v[0] + r[3 + j] * v[1] + r[6 + j] * v[2])
}

/// `v` (a direction in a geom's frame with rotation `r`) in the world frame.
fn to_world(r: &[f64; 9], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| r[3 * i] * v[0] + r[3 * i + 1] * v[1] + r[3 * i + 2] * v[2])
}

/// A contact of a capsule end (a sphere of the capsule's radius at `center`, world frame) with a
/// surface whose nearest point is `surface` and outward normal `normal` (world frame), found
/// within [`DETECTION_MARGIN_M`]: the point halfway between the surfaces, as MuJoCo places it.
fn push_surface_contact(
    out: &mut Vec<FoundContact>,
    geoms: [usize; 2],
    center: [f64; 3],
    surface: [f64; 3],
    normal: [f64; 3],
    radius_m: f64,
) {
    let distance_m = dot(sub(center, surface), normal) - radius_m;
    if distance_m >= DETECTION_MARGIN_M {
        return;
    }
    let position_m = sub(center, normal.map(|x| x * (radius_m + 0.5 * distance_m)));
    out.push(FoundContact { geom: geoms, position_m, normal, distance_m });
}

/// Heightfield ground: its grid of elevations (m, row-major, rows along y), half-sizes along x
/// and y (m) and geom. A link end over it touches the surface interpolated bilinearly from the
/// four elevations around it, with the normal of that surface: one contact per link end, which
/// moves smoothly as the link does (MuJoCo's own collision gives one per prism it overlaps).
#[derive(Debug, Clone)]
struct HeightfieldGround {
    geom: usize,
    half_size_m: [f64; 2],
    rows: usize,
    cols: usize,
    elevation_m: Vec<f64>,
}

impl HeightfieldGround {
    fn new(m: &MjModel, geom: usize) -> Self {
        let id = m.geom_dataid()[geom].max(0) as usize;
        let size = m.hfield_size()[id];
        let (rows, cols) = (m.hfield_nrow()[id] as usize, m.hfield_ncol()[id] as usize);
        let adr = m.hfield_adr()[id] as usize;
        let elevation_m = m.hfield_data()[adr..adr + rows * cols].iter().map(|&h| f64::from(h) * size[2]).collect();
        Self { geom, half_size_m: [size[0], size[1]], rows, cols, elevation_m }
    }

    /// The surface under `local` (a point in the heightfield's frame): its height (m) and
    /// outward unit normal (heightfield frame), interpolated bilinearly from the four elevations
    /// around it; `None` off the grid.
    fn surface_at(&self, local: [f64; 3]) -> Option<(f64, [f64; 3])> {
        let [sx, sy] = self.half_size_m;
        let (dx, dy) = (2.0 * sx / (self.cols - 1) as f64, 2.0 * sy / (self.rows - 1) as f64);
        let (fx, fy) = ((local[0] + sx) / dx, (local[1] + sy) / dy);
        if !(0.0..=(self.cols - 1) as f64).contains(&fx) || !(0.0..=(self.rows - 1) as f64).contains(&fy) {
            return None;
        }
        let (i, j) = ((fx as usize).min(self.cols - 2), (fy as usize).min(self.rows - 2));
        let (tx, ty) = (fx - i as f64, fy - j as f64);
        let h = |ii: usize, jj: usize| self.elevation_m[jj * self.cols + ii];
        let (h00, h10, h01, h11) = (h(i, j), h(i + 1, j), h(i, j + 1), h(i + 1, j + 1));
        let height = (1.0 - ty) * ((1.0 - tx) * h00 + tx * h10) + ty * ((1.0 - tx) * h01 + tx * h11);
        let slope_x = ((1.0 - ty) * (h10 - h00) + ty * (h11 - h01)) / dx;
        let slope_y = ((1.0 - tx) * (h01 - h00) + tx * (h11 - h10)) / dy;
        Some((height, normalized([-slope_x, -slope_y, 1.0])?))
    }

    /// The contacts of `cap` with this heightfield into `out` (none off its grid): one per end of
    /// its axis segment, and one where the surface rises above the line between the ends (a bump
    /// under the link's middle): the interior point, sampled at the grid's spacing along the
    /// segment, whose gap lies furthest below the gaps of the ends interpolated to it. On a plane
    /// no interior point does, so a flat heightfield gives the two contacts a plane gives.
    fn contacts(&self, d: &MjData<Box<MjModel>>, cap: &Capsule, out: &mut Vec<FoundContact>) {
        if self.rows < 2 || self.cols < 2 {
            return;
        }
        let (p, r) = (d.geom_xpos()[self.geom], d.geom_xmat()[self.geom]);
        let contact_at = |center: [f64; 3]| -> Option<([f64; 3], [f64; 3], f64)> {
            let local = to_local(&r, p, center);
            let (height, n_local) = self.surface_at(local)?;
            let surface = add(p, to_world(&r, [local[0], local[1], height]));
            let normal = to_world(&r, n_local);
            Some((surface, normal, dot(sub(center, surface), normal) - cap.radius_m))
        };
        let ends = capsule_ends(d, cap);
        let mut gaps = [None; 2];
        for (k, center) in ends.into_iter().enumerate() {
            if let Some((surface, normal, gap)) = contact_at(center) {
                gaps[k] = Some(gap);
                push_surface_contact(out, [self.geom, cap.geom], center, surface, normal, cap.radius_m);
            }
        }
        let (Some(g0), Some(g1)) = (gaps[0], gaps[1]) else { return };
        let [sx, sy] = self.half_size_m;
        let spacing = (2.0 * sx / (self.cols - 1) as f64).min(2.0 * sy / (self.rows - 1) as f64);
        let span = sub(ends[1], ends[0]);
        // From the capsule's own length, not the span between its ends' world positions: that
        // differs from it by rounding, and a ratio near a whole number would switch the count.
        let samples = ((2.0 * cap.half_length_m / spacing).ceil() as usize).clamp(1, INTERIOR_SAMPLES);
        // How far the gap at t (0 … 1 along the segment) lies below the ends' gaps interpolated.
        let below = |t: f64| {
            let center = add(ends[0], span.map(|x| t * x));
            contact_at(center).map(|(_, _, gap)| gap - (g0 + t * (g1 - g0)))
        };
        let mut deepest: Option<(usize, f64)> = None;
        for k in 1..samples {
            let Some(b) = below(k as f64 / samples as f64) else { continue };
            if b < -INTERIOR_RISE_M && deepest.is_none_or(|(_, d)| b < d) {
                deepest = Some((k, b));
            }
        }
        let Some((k, b)) = deepest else { return };
        // The lowest point between the samples beside the deepest (a parabola through the three),
        // so that the contact moves smoothly along the link as the link moves over the bump.
        let step = 1.0 / samples as f64;
        let t_mid = k as f64 * step;
        let (left, right) = (below(t_mid - step).unwrap_or(b), below(t_mid + step).unwrap_or(b));
        let curvature = left - 2.0 * b + right;
        let shift = if curvature > 0.0 { (0.5 * (left - right) / curvature).clamp(-0.5, 0.5) } else { 0.0 };
        let center = add(ends[0], span.map(|x| (t_mid + shift * step) * x));
        if let Some((surface, normal, _)) = contact_at(center) {
            push_surface_contact(out, [self.geom, cap.geom], center, surface, normal, cap.radius_m);
        }
    }
}

/// Interior points sampled along a link's axis segment over a heightfield at most.
const INTERIOR_SAMPLES: usize = 32;

/// How far (m) the surface must rise above the line between a link's end contacts before an
/// interior point gets a contact of its own (rounding on a flat surface stays far below it).
const INTERIOR_RISE_M: f64 = 1e-6;

/// Mesh ground: its triangles in the geom's frame (m) with their outward unit normals. A link
/// end touches the nearest point of the nearest triangle: one contact per link end.
#[derive(Debug, Clone)]
struct MeshGround {
    geom: usize,
    triangles: Vec<([[f64; 3]; 3], [f64; 3])>,
}

impl MeshGround {
    fn new(m: &MjModel, geom: usize) -> Self {
        let id = m.geom_dataid()[geom].max(0) as usize;
        let (vadr, fadr, fnum) =
            (m.mesh_vertadr()[id] as usize, m.mesh_faceadr()[id] as usize, m.mesh_facenum()[id] as usize);
        let verts = m.mesh_vert();
        let triangles = m.mesh_face()[fadr..fadr + fnum]
            .iter()
            .filter_map(|f| {
                let v = f.map(|k| verts[vadr + k as usize].map(f64::from));
                let n = normalized(cross(sub(v[1], v[0]), sub(v[2], v[0])))?;
                Some((v, n))
            })
            .collect();
        Self { geom, triangles }
    }

    /// The contacts of both ends of `cap` with this mesh into `out`: for each end, the triangle
    /// nearest to it; outside the mesh the normal points from that nearest point to the end's
    /// centre, inside (penetrating) it is the triangle's.
    fn contacts(&self, d: &MjData<Box<MjModel>>, cap: &Capsule, out: &mut Vec<FoundContact>) {
        let (p, r) = (d.geom_xpos()[self.geom], d.geom_xmat()[self.geom]);
        for center in capsule_ends(d, cap) {
            let local = to_local(&r, p, center);
            let mut best: Option<(f64, [f64; 3], [f64; 3])> = None;
            for (tri, n) in &self.triangles {
                let q = closest_point_on_triangle(local, tri);
                let gap = sub(local, q);
                let dist_sq = dot(gap, gap);
                if best.is_none_or(|(b, _, _)| dist_sq < b) {
                    best = Some((dist_sq, q, *n));
                }
            }
            let Some((dist_sq, q, face_normal)) = best else { continue };
            if dist_sq.sqrt() > cap.radius_m + DETECTION_MARGIN_M && dot(sub(local, q), face_normal) > 0.0 {
                continue;
            }
            let gap = sub(local, q);
            let n_local =
                if dot(gap, face_normal) > 0.0 { normalized(gap).unwrap_or(face_normal) } else { face_normal };
            let surface = add(p, to_world(&r, q));
            push_surface_contact(out, [self.geom, cap.geom], center, surface, to_world(&r, n_local), cap.radius_m);
        }
    }
}

/// The point of triangle `t` nearest to `p` (Ericson, *Real-Time Collision Detection*, 2005,
/// §5.1.5).
fn closest_point_on_triangle(p: [f64; 3], t: &[[f64; 3]; 3]) -> [f64; 3] {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return add(a, ab.map(|x| v * x));
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return add(a, ac.map(|x| w * x));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return add(b, sub(c, b).map(|x| w * x));
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    add(a, add(ab.map(|x| v * x), ac.map(|x| w * x)))
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
/// The part of `v` in the plane with unit normal `n`.
fn tangential(v: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    let s = dot(v, n);
    [v[0] - s * n[0], v[1] - s * n[1], v[2] - s * n[2]]
}
fn normalized(v: [f64; 3]) -> Option<[f64; 3]> {
    let len = dot(v, v).sqrt();
    (len > 1e-9).then(|| v.map(|x| x / len))
}
/// A unit vector perpendicular to the unit vector `n`.
fn any_perpendicular(n: [f64; 3]) -> [f64; 3] {
    let e = if n[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    normalized(tangential(e, n)).unwrap_or([1.0, 0.0, 0.0])
}

/// The point of the ellipse (f_a/A)² + (f_l/L)² ≤ 1 nearest to `t` in the metric `b` (symmetric
/// positive definite): argmin (f − t)ᵀ·b·(f − t), the exact solve of one 2 × 2 block of a
/// projected Gauss–Seidel sweep. With u = (f_a/A, f_l/L) it is the unit disk in the metric
/// M = D·b·D, D = diag(A, L); in M's eigenvectors that is an ellipse projection.
fn project_to_ellipse_in_metric(t: [f64; 2], a_n: f64, l_n: f64, b: [[f64; 2]; 2]) -> (f64, f64) {
    if a_n <= 0.0 || l_n <= 0.0 {
        return crate::state::project_to_ellipse(t[0], t[1], a_n, l_n);
    }
    let u0 = [t[0] / a_n, t[1] / l_n];
    if u0[0] * u0[0] + u0[1] * u0[1] <= 1.0 {
        return (t[0], t[1]);
    }
    let m = [[a_n * a_n * b[0][0], a_n * l_n * b[0][1]], [a_n * l_n * b[1][0], l_n * l_n * b[1][1]]];
    // Eigen-decomposition of the symmetric 2 × 2 M.
    let (p, q, r) = (m[0][0], m[0][1], m[1][1]);
    let mean = 0.5 * (p + r);
    let rad = (0.25 * (p - r) * (p - r) + q * q).sqrt();
    let (l1, l2) = ((mean + rad).max(0.0), (mean - rad).max(0.0));
    // The eigenvector of l1, (c, s): (l1 − r, q) or (q, l1 − p), whichever is longer.
    let (e0, e1) = if p >= r { (l1 - r, q) } else { (q, l1 - p) };
    let size = e0.hypot(e1);
    let (c, s) = if size > 0.0 { (e0 / size, e1 / size) } else { (1.0, 0.0) };
    // v0 = Qᵀ·u0, Q = [[c, −s], [s, c]].
    let v0 = [c * u0[0] + s * u0[1], -s * u0[0] + c * u0[1]];
    let (ea, eb) = (l1.sqrt(), l2.sqrt());
    let v = if ea > 0.0 && eb > 0.0 {
        let (x, y) = crate::state::project_to_ellipse(ea * v0[0], eb * v0[1], ea, eb);
        [x / ea, y / eb]
    } else {
        let n = (v0[0] * v0[0] + v0[1] * v0[1]).sqrt();
        [v0[0] / n, v0[1] / n]
    };
    let u = [c * v[0] - s * v[1], s * v[0] + c * v[1]];
    (u[0] * a_n, u[1] * l_n)
}

#[cfg(test)]
mod tests {
    use super::project_to_ellipse_in_metric;
    use crate::state::project_to_ellipse;

    #[test]
    fn projection_onto_the_friction_ellipse() {
        assert_eq!(project_to_ellipse(0.1, 0.2, 1.0, 1.0), (0.1, 0.2));
        let (x, y) = project_to_ellipse(3.0, 4.0, 1.0, 1.0);
        assert!((x - 0.6).abs() < 1e-9 && (y - 0.8).abs() < 1e-9);
        let (x, y) = project_to_ellipse(2.0, 0.0, 0.5, 1.0);
        assert!((x - 0.5).abs() < 1e-12 && y == 0.0);
        // The residual is along the ellipse's normal (nearest point).
        let (x, y) = project_to_ellipse(1.0, 3.0, 0.1, 1.0);
        let (nx, ny) = (x / 0.01, y / 1.0);
        assert!(((1.0 - x) * ny - (3.0 - y) * nx).abs() < 1e-6 * nx.hypot(ny));
        assert_eq!(project_to_ellipse(1.0, 1.0, 0.0, 0.5), (0.0, 0.5));
    }

    /// The projection in a metric b is the minimiser of (f − t)ᵀ·b·(f − t) over the ellipse
    /// (f_a/A)² + (f_l/L)² ≤ 1: a point inside is kept; from outside, the result lies on the
    /// ellipse and its KKT condition holds, b·(t − f) = λ·∇g(f) with λ ≥ 0 and ∇g =
    /// (f_a/A², f_l/L²) the ellipse's outward normal; and no point of the ellipse is nearer in b.
    #[test]
    fn the_projection_in_a_metric_meets_its_optimality_conditions() {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        assert_eq!(project_to_ellipse_in_metric([0.1, -0.2], 1.0, 0.5, [[2.0, 0.3], [0.3, 1.0]]), (0.1, -0.2));
        for _ in 0..2000 {
            let (a, l) = (0.1 + 2.0 * next(), 0.1 + 2.0 * next());
            // A symmetric positive definite metric, up to 1:100 between its eigenvalues.
            let (p, r, angle) = (0.01 + next(), 0.01 + next(), std::f64::consts::PI * next());
            let (c, s) = (angle.cos(), angle.sin());
            let b = [[p * c * c + r * s * s, (p - r) * c * s], [(p - r) * c * s, p * s * s + r * c * c]];
            let t = [6.0 * (next() - 0.5) * a, 6.0 * (next() - 0.5) * l];
            let (fa, fl) = project_to_ellipse_in_metric(t, a, l, b);
            let g = (fa / a).powi(2) + (fl / l).powi(2);
            if (t[0] / a).powi(2) + (t[1] / l).powi(2) <= 1.0 {
                assert_eq!((fa, fl), (t[0], t[1]));
                continue;
            }
            assert!((g - 1.0).abs() < 1e-9, "not on the ellipse: {g}");
            let d = [t[0] - fa, t[1] - fl];
            let bd = [b[0][0] * d[0] + b[0][1] * d[1], b[1][0] * d[0] + b[1][1] * d[1]];
            let normal = [fa / (a * a), fl / (l * l)];
            let (bd_size, n_size) = (bd[0].hypot(bd[1]), normal[0].hypot(normal[1]));
            let across = (bd[0] * normal[1] - bd[1] * normal[0]) / (bd_size * n_size);
            let along = (bd[0] * normal[0] + bd[1] * normal[1]) / (bd_size * n_size);
            assert!(across.abs() < 1e-6 && along > 0.0, "b·(t − f) not along the outward normal: {across}, {along}");
            // No point of the ellipse is nearer in the metric.
            let dist = |f: [f64; 2]| {
                let e = [t[0] - f[0], t[1] - f[1]];
                e[0] * (b[0][0] * e[0] + b[0][1] * e[1]) + e[1] * (b[1][0] * e[0] + b[1][1] * e[1])
            };
            let best = dist([fa, fl]);
            for k in 0..360 {
                let phi = k as f64 * std::f64::consts::PI / 180.0;
                assert!(dist([a * phi.cos(), l * phi.sin()]) >= best * (1.0 - 1e-9) - 1e-12);
            }
        }
    }
}
