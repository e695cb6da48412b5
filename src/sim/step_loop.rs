//! The step loop: the only place where the simulation steps.
//!
//! [`Simulation::run`] visits the instants k = 0 ..= `plan.steps` of a [`LoopPlan`]. At each:
//!
//! 1. **sense** (skipped for a controller that does not read the sensors): the exact
//!    observation from the state, then the sensor models ([`SensorNoise`]) and the contact
//!    estimator. Each instant is sensed at most once: an instant sensed already (by
//!    [`Simulation::reset`], or by [`Simulation::sense`] at the end of a reinforcement-learning
//!    action) keeps its reading, so the noise is drawn and the estimator's filters are updated
//!    once per physics instant however the loop is cut into runs;
//! 2. **control**: the controller writes a [`Command`], which goes to the actuators; the ground
//!    model prepares the step ([`Ground::before_step`]);
//! 3. **record** (every `plan.record_every_n_steps`-th instant and the last): a forward pass
//!    at x_k with the new controls, read into the [`Snapshot`]; [`Observer::on_record`];
//! 4. [`Observer::on_step`];
//! 5. unless k is the last instant: **step**, then the divergence check and the runaway-energy
//!    guard. The step is a forward pass at x_k (after a recorded instant: the recording's), the
//!    contact forces it found added to the run's peak forces ([`ContactForcePeaks`], every
//!    step), then the rest of `mj_step` ([`World::step_after_forward`]: MuJoCo's checks and the
//!    integrator) — bit for bit `mj_step`, so a recorded step costs one forward pass, not two.
//!
//! Observers see the world read-only, through a [`StepView`]; they cannot change the
//! trajectory. Nothing in the loop allocates (observers are a slice the caller owns; the
//! snapshot is sized once).

use super::external::ExternalForces;
use super::{EnergyGuard, Ground, SensorNoise, SimError, World, WorldState};
use crate::config::{Config, Sensors};
use crate::control::{Command, Controller, Observation};
use crate::estimation::{ContactEstimates, LinkPoses, MotionEstimator, MotionEstimatorState};
use crate::state::{ContactForcePeaks, Snapshot};

/// How many steps one [`Simulation::run`] takes and which instants it records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LoopPlan {
    /// Physics steps to take: instants 0 ..= `steps` are visited, the last without a step
    /// after it.
    pub steps: u64,
    /// Record every n-th instant, and the last one; 0 records nothing (no forward pass).
    pub record_every_n_steps: u64,
}

impl LoopPlan {
    /// Whether instant `k` is recorded.
    pub fn records(&self, k: u64) -> bool {
        self.record_every_n_steps > 0 && (k.is_multiple_of(self.record_every_n_steps) || k == self.steps)
    }
}

/// What an observer sees at one instant: read-only.
pub struct StepView<'a> {
    /// The instant's index in the current [`Simulation::run`] (0 ..= `plan.steps`).
    pub k: u64,
    /// The run's plan.
    pub plan: LoopPlan,
    /// Physics steps taken since the simulation was built or reset.
    pub steps_since_reset: u64,
    /// The world (model, engine state through read-only accessors, index).
    pub world: &'a World,
    /// What the controller saw at this instant (measured; the previous instant's when the
    /// controller does not read the sensors).
    pub observation: &'a Observation,
    /// The same without sensor models.
    pub observation_true: &'a Observation,
    /// The command of the step that starts at this instant.
    pub command: &'a Command,
    /// The ground model's per-step state (floor surfaces, the region under each link).
    pub ground: &'a Ground,
}

impl StepView<'_> {
    /// Simulated time of this instant (s).
    pub fn time_secs(&self) -> f64 {
        self.world.time_secs()
    }

    /// Whether this is the run's last instant (no step follows).
    pub fn is_last(&self) -> bool {
        self.k == self.plan.steps
    }
}

/// Something that watches the step loop: a recorder, the pictures, a run summary, the
/// interrupt poll, a progress bar, an estimator's scorer. Every hook does nothing by default;
/// an error from a hook stops the run with that error. `E` is the caller's error type (the
/// loop's own failures arrive as `E::from(SimError)`).
pub trait Observer<E> {
    /// Once, before the first instant.
    fn on_start(&mut self, _view: &StepView<'_>) -> Result<(), E> {
        Ok(())
    }
    /// At every instant, after control (and recording), before the step.
    fn on_step(&mut self, _view: &StepView<'_>) -> Result<(), E> {
        Ok(())
    }
    /// At recorded instants, with the snapshot of the instant (after its forward pass).
    fn on_record(&mut self, _view: &StepView<'_>, _snapshot: &Snapshot) -> Result<(), E> {
        Ok(())
    }
    /// Once at the end, also when the run stopped early (`completed` false); the view is the
    /// last instant reached.
    fn on_end(&mut self, _view: &StepView<'_>, _completed: bool) -> Result<(), E> {
        Ok(())
    }
}

/// An observer whose `on_step` runs only every n-th instant (n ≥ 1); its other hooks always.
#[derive(Debug)]
pub struct Every<O> {
    /// Period in instants.
    pub n: u64,
    /// The observer.
    pub inner: O,
}

impl<O> Every<O> {
    /// `inner`, stepped every `n` instants.
    pub fn new(n: u64, inner: O) -> Self {
        Self { n: n.max(1), inner }
    }
}

impl<E, O: Observer<E>> Observer<E> for Every<O> {
    fn on_start(&mut self, view: &StepView<'_>) -> Result<(), E> {
        self.inner.on_start(view)
    }
    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), E> {
        if view.k.is_multiple_of(self.n) { self.inner.on_step(view) } else { Ok(()) }
    }
    fn on_record(&mut self, view: &StepView<'_>, snapshot: &Snapshot) -> Result<(), E> {
        self.inner.on_record(view, snapshot)
    }
    fn on_end(&mut self, view: &StepView<'_>, completed: bool) -> Result<(), E> {
        self.inner.on_end(view, completed)
    }
}

/// A saved state of a [`Simulation`] ([`Simulation::save`]).
#[derive(Clone)]
pub struct SimulationState<C> {
    world: WorldState,
    controller: C,
    noise: SensorNoise,
    obs_true: Observation,
    obs: Observation,
    cmd: Command,
    steps: u64,
    ground: Ground,
    energy_guard: EnergyGuard,
    sensed: bool,
    estimation: Option<EstimationState>,
    contact_peaks: ContactForcePeaks,
}

/// The saved part of [`Estimation`]: the estimator's filters and its latest output.
#[derive(Clone)]
struct EstimationState {
    estimator: MotionEstimatorState,
    estimates: ContactEstimates,
}

impl<C> SimulationState<C> {
    /// The saved world.
    pub fn world(&self) -> &WorldState {
        &self.world
    }
}

/// A world with its controller, sensor models and ground model: the step loop.
///
/// `C` is the controller; the default, a boxed trait object, takes any controller chosen at
/// run time.
pub struct Simulation<C: Controller = Box<dyn Controller>> {
    world: World,
    controller: C,
    sensors: Sensors,
    noise: SensorNoise,
    obs_true: Observation,
    obs: Observation,
    cmd: Command,
    steps: u64,
    /// Full state for controllers that ask for it.
    controller_state: Option<Snapshot>,
    /// The snapshot of recorded instants.
    snapshot: Snapshot,
    /// Per-step work of the ground friction model, and its state at the start.
    ground: Ground,
    initial_ground: Ground,
    /// `[[physics.external_forces]]`, into `qfrc_applied` before every step.
    external: ExternalForces,
    /// Runaway-energy check (`[safety]`).
    energy_guard: EnergyGuard,
    /// Contact estimation on the measured sensors (`[estimation]`), part of sensing.
    estimation: Option<Estimation>,
    /// Whether `obs` (and the estimates) were read at the current instant: sensing again
    /// before the next step does nothing.
    sensed: bool,
    /// The peak contact forces since the simulation was built or reset, from every step.
    contact_peaks: ContactForcePeaks,
    /// Per link: the contacts' normal forces of the step being added (sized once).
    link_normal_n: Vec<[f64; 3]>,
}

/// The estimator of the step loop with its output and, for `orientation = "true"`, the
/// simulator's link poses (sized once).
struct Estimation {
    estimator: MotionEstimator,
    estimates: ContactEstimates,
    true_poses: Option<LinkPoses>,
}

impl Estimation {
    fn new(config: &Config, world: &World) -> Option<Self> {
        if !config.estimation.enabled {
            return None;
        }
        let masses: Vec<f64> = world.index.links.iter().map(|l| l.mass_kg).collect();
        let estimator = MotionEstimator::from_config(config, &masses);
        let true_poses = estimator.needs_true_poses().then(|| LinkPoses::new(masses.len()));
        Some(Self { estimator, estimates: ContactEstimates::new(masses.len()), true_poses })
    }
}

impl Simulation<Box<dyn Controller>> {
    /// The world with the built-in controller that `config` describes.
    pub fn new(config: &Config, world: World) -> Self {
        let controller = crate::control::controller_from_config(config, world.n_joints());
        Self::with_typed_controller(config, world, controller)
    }

    /// The world with a controller of your own, chosen at run time.
    pub fn with_controller(config: &Config, world: World, controller: Box<dyn Controller>) -> Self {
        Self::with_typed_controller(config, world, controller)
    }
}

impl<C: Controller> Simulation<C> {
    /// The world with a controller of your own, of a type known at compile time (so the
    /// caller can reach it through [`Simulation::controller_mut`]).
    pub fn with_typed_controller(config: &Config, mut world: World, mut controller: C) -> Self {
        let (nl, nj) = (world.n_links(), world.n_joints());
        controller.reset();
        let controller_state = controller.needs_full_state().then(|| Snapshot::new(nl, nj));
        let mut ground = Ground::new(config, &world);
        if let Some(sink_m) = ground.static_start_sink_m(&mut world) {
            world.set_start_sink_m(sink_m);
        }
        if ground.is_active() {
            // The ground contacts of SimSerpent's contact law are never MuJoCo's: the state's
            // sensors are evaluated again without them (as after every reset).
            ground.detach_own_contacts(&mut world);
            world.forward();
        }
        Self {
            external: ExternalForces::new(config, &world),
            initial_ground: ground.clone(),
            ground,
            energy_guard: EnergyGuard::new(config, &world),
            estimation: Estimation::new(config, &world),
            controller_state,
            snapshot: Snapshot::new(nl, nj),
            sensors: config.sensors.clone(),
            noise: SensorNoise::new(&config.sensors, config.general.seed, nl, nj),
            obs_true: Observation::new(nl, nj),
            obs: Observation::new(nl, nj),
            cmd: Command::new(nj),
            controller,
            contact_peaks: ContactForcePeaks::new(nl, world.timestep_secs()),
            link_normal_n: vec![[0.0; 3]; nl],
            world,
            steps: 0,
            sensed: false,
        }
    }

    /// Back to the initial state: the world (state and contact-pair friction), zero controls,
    /// the ground model, the controller, and the sensor models seeded with `seed`; then the
    /// sensors are read at the initial state.
    pub fn reset(&mut self, seed: u64) -> Result<(), SimError> {
        self.reset_with(seed, |_| {})
    }

    /// [`Simulation::reset`], with `perturb` changing the world's initial state (the reset
    /// noise of an RL environment: write `qpos`/`qvel`) before the forward pass and the first
    /// sensor reading.
    pub fn reset_with(&mut self, seed: u64, perturb: impl FnOnce(&mut World)) -> Result<(), SimError> {
        self.world.reset()?;
        perturb(&mut self.world);
        self.world.ctrl_mut().fill(0.0);
        self.world.forward();
        self.ground.clone_from(&self.initial_ground);
        self.controller.reset();
        self.noise = SensorNoise::new(&self.sensors, seed, self.world.n_links(), self.world.n_joints());
        if let Some(e) = self.estimation.as_mut() {
            e.estimator.reset();
        }
        self.steps = 0;
        self.sensed = false;
        self.contact_peaks.clear();
        self.sense();
        Ok(())
    }

    /// A copy of everything that decides the rest of the trajectory: the engine state, the
    /// controller, the sensor models (their random streams, biases and held samples), the
    /// contact estimator's filters, the ground model, the energy guard and the latest
    /// observations. [`Simulation::restore`] continues bit for bit.
    pub fn save(&self) -> SimulationState<C>
    where
        C: Clone,
    {
        SimulationState {
            world: self.world.save_state(),
            controller: self.controller.clone(),
            noise: self.noise.clone(),
            obs_true: self.obs_true.clone(),
            obs: self.obs.clone(),
            cmd: self.cmd.clone(),
            steps: self.steps,
            ground: self.ground.clone(),
            energy_guard: self.energy_guard,
            sensed: self.sensed,
            estimation: self
                .estimation
                .as_ref()
                .map(|e| EstimationState { estimator: e.estimator.save_state(), estimates: e.estimates.clone() }),
            contact_peaks: self.contact_peaks.clone(),
        }
    }

    /// Goes back to a state saved from this simulation by [`Simulation::save`].
    ///
    /// # Errors
    /// The state was saved from a simulation of another model.
    pub fn restore(&mut self, state: &SimulationState<C>) -> Result<(), SimError>
    where
        C: Clone,
    {
        self.world.restore_state(&state.world)?;
        self.controller.clone_from(&state.controller);
        self.noise.clone_from(&state.noise);
        self.obs_true.clone_from(&state.obs_true);
        self.obs.clone_from(&state.obs);
        self.cmd.clone_from(&state.cmd);
        self.steps = state.steps;
        self.ground.clone_from(&state.ground);
        self.ground.state_changed();
        self.energy_guard = state.energy_guard;
        self.sensed = state.sensed;
        self.contact_peaks.clone_from(&state.contact_peaks);
        match (self.estimation.as_mut(), state.estimation.as_ref()) {
            (Some(e), Some(saved)) => {
                e.estimator.restore_state(&saved.estimator);
                e.estimates.clone_from(&saved.estimates);
            }
            (None, None) => {}
            _ => {
                return Err(SimError::Model(
                    "the state was saved from a simulation with another [estimation] enabled setting".into(),
                ));
            }
        }
        Ok(())
    }

    /// The peak contact forces since the simulation was built or last reset, from every step
    /// ([`ContactForcePeaks`]: each link's normal force averaged over 10 ms, and the largest
    /// single contact's at any step).
    pub fn contact_peaks(&self) -> &ContactForcePeaks {
        &self.contact_peaks
    }

    /// The world, read-only.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The world, for setting initial conditions before a run ([`World::qvel_mut`] …). The
    /// state may change, so the next instant is sensed afresh.
    pub fn world_mut(&mut self) -> &mut World {
        self.sensed = false;
        self.ground.state_changed();
        &mut self.world
    }

    /// The controller.
    pub fn controller(&self) -> &C {
        &self.controller
    }

    /// The controller, to change its settings between runs (an agent's held command …).
    pub fn controller_mut(&mut self) -> &mut C {
        &mut self.controller
    }

    /// Steps taken since the simulation was built or reset.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// What the controller saw at the latest instant (measured values).
    pub fn observation(&self) -> &Observation {
        &self.obs
    }

    /// The noise-free observation at the latest instant.
    pub fn true_observation(&self) -> &Observation {
        &self.obs_true
    }

    /// The controller's command at the latest instant.
    pub fn command(&self) -> &Command {
        &self.cmd
    }

    /// The ground model's per-step state (floor surfaces, the region under each link).
    pub fn ground(&self) -> &Ground {
        &self.ground
    }

    /// Reads the sensors at the current instant: the exact observation, then the sensor models
    /// and the contact estimator. Once per instant: when this instant was sensed already
    /// (since the last step, reset or [`Simulation::world_mut`]) it keeps that reading, so no
    /// noise is drawn twice and the estimator's filters do not see the instant twice.
    pub fn sense(&mut self) {
        if self.sensed {
            return;
        }
        self.sensed = true;
        self.world.observe_true(&mut self.obs_true);
        self.noise.measure(&self.obs_true, &mut self.obs);
        if let Some(e) = self.estimation.as_mut() {
            // Contact estimation is part of sensing: on the measured values, into the
            // observation the controller gets (no allocation once sized).
            if let Some(poses) = e.true_poses.as_mut() {
                self.world.read_link_poses(poses);
            }
            e.estimator.update(&self.obs, e.true_poses.as_ref(), &mut e.estimates);
            self.obs.contacts.copy_from(&e.estimates);
        }
    }

    /// Sense (unless the controller does not read the sensors), run the controller, write the
    /// controls and prepare the ground for the step that starts now. Step 1–2 of the loop;
    /// public so a caller can take the loop apart (tests, a custom read-out).
    pub fn control(&mut self) {
        if self.controller_state.is_some() {
            // The forces of the coming step (they depend on the state only), then fresh sensors
            // for this instant and its whole state.
            self.prepare_step_forces();
            self.ground.forward(&mut self.world);
        }
        if self.controller.reads_sensors() || self.controller_state.is_some() {
            self.sense();
        }
        match self.controller_state.as_mut() {
            Some(state) => {
                let own = self.ground.own_contacts(&self.world);
                self.world.read_snapshot_with(state, &self.obs_true, &self.obs, own);
                self.ground.fill_snapshot(state);
                self.controller.update_with_state(&self.obs, state, &mut self.cmd);
            }
            None => self.controller.update(&self.obs, &mut self.cmd),
        }
        self.world.apply_command(&self.cmd);
        if self.controller_state.is_none() {
            self.prepare_step_forces();
        }
    }

    /// The external forces and the ground model's forces of the coming step: the external ones
    /// first, since the contact law's forward passes see them and its friction holds them.
    fn prepare_step_forces(&mut self) {
        self.external.before_step(&mut self.world, self.ground.external_forces_mut());
        self.ground.before_step(&mut self.world);
    }

    /// Advances the physics by one timestep with the controls already written, then checks
    /// for divergence and runaway energy. Step 5 of the loop.
    pub fn advance(&mut self) -> Result<(), SimError> {
        self.advance_from(false)
    }

    /// [`Simulation::advance`]; with `forward_done`, the forward pass at the current state and
    /// controls has run already (a recorded instant) and is not repeated.
    fn advance_from(&mut self, forward_done: bool) -> Result<(), SimError> {
        let reached_secs = self.world.time_secs() + self.world.timestep_secs();
        // The step's forward pass (unless the recording ran it), then the contact forces it found
        // — the forces at the step's start, as a recorded row shows them — then the rest of
        // `mj_step`: bit for bit `mj_step` (`World::step_after_forward`), at the same cost.
        if !forward_done {
            self.ground.forward(&mut self.world);
        }
        let own = self.ground.own_contacts(&self.world);
        let largest_n = self.world.link_contact_normal_forces(own, &mut self.link_normal_n);
        self.contact_peaks.add_step(reached_secs, &self.link_normal_n, largest_n);
        self.world.step_after_forward();
        self.steps += 1;
        self.sensed = false;
        self.world.check_finite(self.steps, reached_secs)?;
        self.energy_guard.check(&mut self.world, self.steps, reached_secs)
    }

    /// One full step: [`Simulation::control`] then [`Simulation::advance`].
    pub fn step(&mut self) -> Result<(), SimError> {
        self.control();
        self.advance()
    }

    /// Runs MuJoCo's forward pass at the current state and controls, so that positions,
    /// velocities, accelerations, contacts, sensors and constraint forces all describe this
    /// instant, and reads them into `snapshot`.
    pub fn snapshot(&mut self, snapshot: &mut Snapshot) {
        read_instant(&mut self.world, &mut self.ground, &self.obs_true, &self.obs, snapshot);
    }

    fn view(&self, k: u64, plan: LoopPlan) -> StepView<'_> {
        StepView {
            k,
            plan,
            steps_since_reset: self.steps,
            world: &self.world,
            observation: &self.obs,
            observation_true: &self.obs_true,
            command: &self.cmd,
            ground: &self.ground,
        }
    }

    /// The step loop: visits the instants of `plan` (see the module's documentation for the
    /// order of work), calling the observers in the order given. Stops at the first error —
    /// the loop's own (divergence, runaway energy) or an observer's — after calling every
    /// observer's `on_end`.
    pub fn run<E: From<SimError>>(&mut self, plan: LoopPlan, observers: &mut [&mut dyn Observer<E>]) -> Result<(), E> {
        let mut k = 0;
        let mut outcome = self.run_instants(plan, observers, &mut k);
        let view = self.view(k, plan);
        for o in observers.iter_mut() {
            let ended = o.on_end(&view, outcome.is_ok());
            if outcome.is_ok() {
                outcome = ended;
            }
        }
        outcome
    }

    fn run_instants<E: From<SimError>>(
        &mut self,
        plan: LoopPlan,
        observers: &mut [&mut dyn Observer<E>],
        k: &mut u64,
    ) -> Result<(), E> {
        {
            let view = self.view(0, plan);
            for o in observers.iter_mut() {
                o.on_start(&view)?;
            }
        }
        loop {
            // Where a fatal MuJoCo error in this step would stop the run (`fatal`).
            super::fatal::at_step(*k, self.world.time_secs());
            self.control();
            let recorded = plan.records(*k);
            if recorded {
                read_instant(&mut self.world, &mut self.ground, &self.obs_true, &self.obs, &mut self.snapshot);
                let view = self.view(*k, plan);
                for o in observers.iter_mut() {
                    o.on_record(&view, &self.snapshot)?;
                }
            }
            {
                let view = self.view(*k, plan);
                for o in observers.iter_mut() {
                    o.on_step(&view)?;
                }
            }
            if *k >= plan.steps {
                return Ok(());
            }
            // Observers only read: the recording's forward pass still describes x_k.
            self.advance_from(recorded)?;
            *k += 1;
        }
    }
}

/// A forward pass at the current state and controls, read into `snapshot` with the ground
/// model's part (floor regions, SimSerpent's floor friction): everything of one instant.
fn read_instant(
    world: &mut World,
    ground: &mut Ground,
    obs_true: &Observation,
    obs: &Observation,
    snapshot: &mut Snapshot,
) {
    ground.forward(world);
    world.read_snapshot_with(snapshot, obs_true, obs, ground.own_contacts(world));
    ground.fill_snapshot(snapshot);
}
