//! The integration tests: one test binary (MuJoCo is linked once, and `cargo test` builds one
//! executable instead of one per file), one module per subject. Tests that change process-wide
//! state (the interrupt flag) or need their own working directory run in a child process of this
//! binary (`common::in_child_process`).
//!
//! Run one subject with `cargo test --test it cli::`, one test with its full name, e.g.
//! `cargo test --test it -- --exact sweep::grid_plan_is_the_full_product_in_order`.
#![allow(clippy::unwrap_used)]

mod cli;
mod closed_loop;
mod common;
mod config;
mod contact_events;
mod defaults;
mod dying_processes;
mod estimation;
mod guide;
// Planted symlinks, device files, FIFOs, permission bits and signals: Unix only.
#[cfg(unix)]
mod hostile_ends;
mod hostile_files;
#[cfg(unix)]
mod hostile_input;
#[cfg(unix)]
mod hostile_surfaces;
mod impacts;
mod legacy_convert;
mod limits;
mod locomotion;
mod model;
mod oal_bench;
mod parquet;
mod physics;
mod plot;
#[cfg(offscreen_render)]
mod render;
mod rl_env;
mod robustness;
mod ros2_bag;
mod sensors;
mod sliding_contact;
mod step_loop;
mod study;
mod surfaces;
mod surprises;
mod sweep;
mod sweep_interrupt;
mod terrain;
mod thesis_homes;
mod writers;
