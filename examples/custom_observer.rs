//! Watching a simulation step by step with your own observer.
//!
//! Run with: `cargo run --release --example custom_observer`
//!
//! The step loop (`Simulation::run`) calls observers at the start, at every step, at every
//! recorded step (with the full `Snapshot`: link poses, contacts and their forces, joint
//! forces …) and at the end. An observer only reads; it cannot change the trajectory. This one
//! prints the snake's centre of mass every simulated second and the largest obstacle force it
//! has seen; `simserpent run` uses the same mechanism for its tables, pictures and progress bar.

use simserpent::config::{self, ConfigSource};
use simserpent::sim::{LoopPlan, Observer, SimError, Simulation, StepView, World};
use simserpent::state::Snapshot;

#[derive(Default)]
struct Watch {
    peak_obstacle_force_n: f64,
}

impl Observer<SimError> for Watch {
    fn on_record(&mut self, view: &StepView<'_>, snapshot: &Snapshot) -> Result<(), SimError> {
        for f in &snapshot.link_obstacle_force_n {
            self.peak_obstacle_force_n = self.peak_obstacle_force_n.max(f[0].hypot(f[1]).hypot(f[2]));
        }
        let c = snapshot.centre_of_mass_m();
        println!("t = {:5.2} s  centre of mass ({:+.3}, {:+.3}) m", view.time_secs(), c[0], c[1]);
        Ok(())
    }

    fn on_end(&mut self, view: &StepView<'_>, completed: bool) -> Result<(), SimError> {
        let how = if completed { "completed" } else { "stopped early" };
        println!("{how} at t = {:.2} s; largest obstacle force {:.2} N", view.time_secs(), self.peak_obstacle_force_n);
        Ok(())
    }
}

fn main() -> anyhow::Result<()> {
    let config = config::load_config_str(
        config::DEFAULT_CONFIG_TOML,
        ConfigSource::Toml,
        &["general.duration_secs=5".to_string()],
    )?;
    let world = World::from_config(&config)?;
    let mut sim = Simulation::new(&config, world);
    let steps = (config.general.duration_secs / config.general.timestep_secs).round() as u64;
    // Record (forward pass + snapshot) once per simulated second.
    let every = (1.0 / config.general.timestep_secs).round() as u64;
    let mut watch = Watch::default();
    sim.run(LoopPlan { steps, record_every_n_steps: every }, &mut [&mut watch])?;
    Ok(())
}
