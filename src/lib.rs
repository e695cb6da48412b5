//! SimSerpent: a physics-based snake-robot simulator on MuJoCo 3.17.
pub mod config;
