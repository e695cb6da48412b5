//! Frames per second of offscreen rendering (see BENCHMARKS.md):
//! `cargo run --release --example render_fps [-- WIDTH HEIGHT FRAMES fast|medium|full]`.
//!
//! Steps the default snake world and, every 33 ms of simulated time, paints one frame through
//! the EGL offscreen renderer; reports the painting rate alone (render + read-back), with the
//! time overlay, and with GIF encoding and the MP4 pipe to ffmpeg.
#![allow(clippy::unwrap_used)]

#[cfg(offscreen_render)]
fn main() {
    bench::main();
}

/// Offscreen rendering exists only in the Linux build with the `render` feature.
#[cfg(not(offscreen_render))]
fn main() {
    eprintln!("render_fps: this build has no offscreen rendering (Linux with the `render` feature only)");
    std::process::exit(2);
}

#[cfg(offscreen_render)]
mod bench {
    use simserpent::config::{CameraKind, Config, RenderQuality, VideoFormat};
    use simserpent::render::painter::Painter;
    use simserpent::render::{VideoWriter, overlay_time};
    use simserpent::sim::{Simulation, World};
    use std::time::Instant;

    pub fn main() {
        let args: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
        let (w, h, frames) = (
            args.first().copied().unwrap_or(640),
            args.get(1).copied().unwrap_or(480),
            args.get(2).copied().unwrap_or(150),
        );
        let mut config = Config::default();
        config.render.width_px = w as u32;
        config.render.height_px = h as u32;
        config.render.quality = match std::env::args().nth(4).as_deref() {
            Some("medium") => RenderQuality::Medium,
            Some("full") => RenderQuality::Full,
            _ => RenderQuality::Fast,
        };
        let q = format!("{:?}", config.render.quality).to_lowercase();
        let world = World::from_config(&config).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let xml = dir.path().join("model.xml");
        std::fs::write(&xml, &world.mjcf).unwrap();
        let mut sim = Simulation::new(&config, world);
        let mut painter = Painter::new(&xml, &config).unwrap();
        // The states to draw: one every 33 simulated ms.
        let steps_per_frame = (0.033 / config.general.timestep_secs).round() as usize;
        let mut states = Vec::new();
        for _ in 0..frames {
            for _ in 0..steps_per_frame {
                sim.control();
                sim.advance().unwrap();
            }
            states.push(sim.world().data().state(simserpent::render::state::STATE_SPEC));
        }
        let mut frame = vec![0u8; w * h * 3];
        let mut measure = |label: &str, sink: Option<VideoFormat>, overlay: bool| {
            let mut video = sink.map(|f| VideoWriter::create(&dir.path().join(label), f, w, h, 30.0).unwrap());
            let started = Instant::now();
            for state in &states {
                painter.set_state(state).unwrap();
                let rgb = painter.paint(CameraKind::Follow).unwrap();
                frame.copy_from_slice(rgb);
                if overlay {
                    overlay_time(&mut frame, w, h, state[0]);
                }
                if let Some(v) = video.as_mut() {
                    v.push(&frame).unwrap();
                }
            }
            if let Some(v) = video {
                v.finish().unwrap();
            }
            let secs = started.elapsed().as_secs_f64();
            println!(
                "| {w}x{h} | {q} | {label} | {frames} | {:.1} | {:.1} |",
                frames as f64 / secs,
                1e3 * secs / frames as f64
            );
        };
        println!("| size | quality | pipeline | frames | frames/s | ms/frame |");
        println!("|---|---|---|---|---|---|");
        measure("render + read-back", None, false);
        measure("+ time overlay", None, true);
        measure("+ overlay + GIF encode", Some(VideoFormat::Gif), true);
        if simserpent::render::video::ffmpeg_program().is_some() {
            measure("+ overlay + MP4 (ffmpeg libx264)", Some(VideoFormat::Mp4), true);
        }
    }
}
