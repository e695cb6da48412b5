//! Offscreen rendering, videos, state replay and the viewer's no-display message.
//!
//! Rendering runs headless through EGL (Mesa's software renderer in CI). MP4 tests need `ffmpeg`
//! and `ffprobe` and say "skipped" on stderr when they are missing; everything else must pass
//! everywhere.

use crate::common::{default_config_with, exe, output_dir};
use simserpent::config::{CameraKind, Config, VideoFormat};
use simserpent::render::{self, ReplayOptions, STATE_FILE};
use simserpent::run::{self, RunOptions};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A short, small run: 6 links, 0.5 s, a fast wave so the snake visibly moves.
fn config(out: &Path, extra: &[&str]) -> Config {
    let mut o: Vec<String> = vec![
        output_dir(out),
        "general.duration_secs=0.5".into(),
        "snake.n_links=6".into(),
        "terrain.kind=\"none\"".into(),
        "gait.ramp_secs=0.0".into(),
        "gait.sine_wave.frequency_hz=2.0".into(),
        "gait.sine_wave.amplitude_deg=45.0".into(),
        "recording.every_n_steps=5".into(),
        "render.width_px=160".into(),
        "render.height_px=120".into(),
        "render.camera=\"fixed\"".into(),
        "render.fixed_lookat_m=[-0.5, 0.0, 0.0]".into(),
        "render.camera_elevation_deg=-60.0".into(),
        "render.time_overlay=false".into(),
    ];
    o.extend(extra.iter().map(|s| s.to_string()));
    default_config_with(&o).unwrap()
}

fn run_folder(config: &Config) -> PathBuf {
    let summary =
        run::run(config, &RunOptions { config_source: "tests/it/render.rs".into(), ..RunOptions::default() }).unwrap();
    summary.run_folder
}

fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// Frames of a GIF: (count, width, height).
fn gif_frames(path: &Path) -> (usize, u16, u16) {
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::Indexed);
    let mut decoder = options.read_info(std::fs::File::open(path).unwrap()).unwrap();
    let (w, h) = (decoder.width(), decoder.height());
    let mut n = 0;
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        assert_eq!((frame.width, frame.height), (w, h));
        n += 1;
    }
    (n, w, h)
}

#[test]
fn frames_are_not_blank_and_change_when_the_snake_moves() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(dir.path(), &["render.image_times_secs=[0.0, 0.5]", "render.image_cameras=[\"fixed\", \"top\"]"]);
    let folder = run_folder(&c);
    for cam in ["fixed", "top"] {
        let (w0, h0, a) = read_png(&folder.join(format!("images/{cam}_0.000s.png")));
        let (w1, h1, b) = read_png(&folder.join(format!("images/{cam}_0.500s.png")));
        assert_eq!((w0, h0, w1, h1), (160, 120, 160, 120));
        // Not blank: many different colours and a wide spread of brightness.
        let mut colours: Vec<[u8; 3]> = a.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
        colours.sort_unstable();
        colours.dedup();
        assert!(colours.len() > 50, "{cam}: only {} colours", colours.len());
        let lum: Vec<f64> = a.chunks_exact(3).map(|p| f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2])).collect();
        let mean = lum.iter().sum::<f64>() / lum.len() as f64;
        let sd = (lum.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / lum.len() as f64).sqrt();
        assert!(sd > 20.0, "{cam}: brightness spread {sd}");
        // The snake is blue (color_rgba = [0, 0.2, 1, 1]): it must be in the picture.
        let blue = a.chunks_exact(3).filter(|p| p[2] > 120 && p[2] as u16 > 2 * p[0] as u16 + 40).count();
        assert!(blue > 30, "{cam}: {blue} blue pixels: is the snake in view?");
        // It moved: a visible share of the pixels changed.
        let changed = a
            .chunks_exact(3)
            .zip(b.chunks_exact(3))
            .filter(|(p, q)| p.iter().zip(*q).any(|(x, y)| x.abs_diff(*y) > 30))
            .count();
        assert!(changed > a.len() / 3 / 200, "{cam}: only {changed} pixels changed");
    }
}

#[test]
fn same_state_gives_the_same_picture() {
    // Determinism of the renderer: the live image at t = 0.5 and the replayed one agree.
    let dir = tempfile::tempdir().unwrap();
    let c = config(dir.path(), &["render.image_times_secs=[0.5]"]);
    let folder = run_folder(&c);
    let live = read_png(&folder.join("images/follow_0.500s.png")).2;
    std::fs::remove_dir_all(folder.join("images")).unwrap();
    let files =
        render::render_run_folder(&folder, &ReplayOptions { images: true, ..ReplayOptions::default() }).unwrap();
    assert_eq!(files, vec![folder.join("images/follow_0.500s.png")]);
    let replayed = read_png(&files[0]).2;
    let differing = live.iter().zip(&replayed).filter(|(a, b)| a.abs_diff(**b) > 8).count();
    assert!(differing < live.len() / 100, "{differing} of {} bytes differ", live.len());
}

#[test]
fn gif_video_during_the_run_and_replayed_has_the_expected_frames() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(
        dir.path(),
        &["video.enabled=true", "video.format=\"gif\"", "video.frames_per_sec=10.0", "render.time_overlay=true"],
    );
    assert_eq!((c.video.format, c.render.camera), (VideoFormat::Gif, CameraKind::Fixed));
    let folder = run_folder(&c);
    let live = folder.join("video_fixed.gif");
    // 0.5 s at 10 frames per second: frames at 0, 0.1, ..., 0.5.
    assert_eq!(gif_frames(&live), (6, 160, 120));

    // Replay from state.csv: same number of frames; playback speed 2 halves it; camera override.
    std::fs::remove_file(&live).unwrap();
    let opts = ReplayOptions { video: true, ..ReplayOptions::default() };
    let files = render::render_run_folder(&folder, &opts).unwrap();
    assert_eq!(files, vec![live.clone()]);
    assert_eq!(gif_frames(&live), (6, 160, 120));
    let opts = ReplayOptions {
        video: true,
        overrides: vec![
            "video.playback_speed=2.0".into(),
            "render.camera=\"top\"".into(),
            "render.width_px=100".into(),
        ],
        ..ReplayOptions::default()
    };
    let files = render::render_run_folder(&folder, &opts).unwrap();
    assert_eq!(files, vec![folder.join("video_top.gif")]);
    assert_eq!(gif_frames(&files[0]), (3, 100, 120));
}

#[test]
fn state_csv_holds_every_recorded_step() {
    let dir = tempfile::tempdir().unwrap();
    let folder = run_folder(&config(dir.path(), &[]));
    let text = std::fs::read_to_string(folder.join(STATE_FILE)).unwrap();
    let links = std::fs::read_to_string(folder.join("links.csv")).unwrap();
    assert_eq!(text.lines().count(), links.lines().count());
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert_eq!(header[0], "time_s");
    // 6 links: free joint (7) + 5 hinges in qpos, 6 + 5 in qvel.
    assert_eq!(header.iter().filter(|h| h.starts_with("qpos_")).count(), 12);
    assert_eq!(header.iter().filter(|h| h.starts_with("qvel_")).count(), 11);
    // Read back; a half-written last line (a killed run) is dropped, a broken middle line is an error.
    let model = mujoco_rs::prelude::MjModel::from_xml(folder.join("model.xml")).unwrap();
    let rows = text.lines().count() - 1;
    let track = render::StateTrack::read(&folder.join(STATE_FILE), &model).unwrap();
    assert_eq!(track.len(), rows);
    assert_eq!(track.index_at(0.25), 50);
    std::fs::write(folder.join(STATE_FILE), format!("{text}0.505,1.5e")).unwrap();
    assert_eq!(render::StateTrack::read(&folder.join(STATE_FILE), &model).unwrap().len(), rows);
    let mut lines: Vec<&str> = text.lines().collect();
    lines[3] = "0.1,2";
    std::fs::write(folder.join(STATE_FILE), lines.join("\n")).unwrap();
    let err = render::StateTrack::read(&folder.join(STATE_FILE), &model).unwrap_err();
    assert!(err.to_string().contains("row 3 has 2 values"), "{err}");
    // Off when asked.
    let dir = tempfile::tempdir().unwrap();
    let folder = run_folder(&config(dir.path(), &["render.record_state=false"]));
    assert!(!folder.join(STATE_FILE).exists());
    let err =
        render::render_run_folder(&folder, &ReplayOptions { video: true, ..ReplayOptions::default() }).unwrap_err();
    assert!(matches!(err, render::RenderError::BadFile { .. }), "bad input (exit code 2): {err}");
    assert!(err.to_string().contains("state.csv") && err.to_string().contains("record_state"), "{err}");
}

fn have(program: &str) -> bool {
    Command::new(program).arg("-version").output().is_ok_and(|o| o.status.success())
}

#[test]
fn mp4_video_through_ffmpeg() {
    if !(have("ffmpeg") && have("ffprobe")) {
        eprintln!("skipped mp4_video_through_ffmpeg: ffmpeg/ffprobe not installed");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let c = config(dir.path(), &["video.enabled=true", "video.format=\"mp4\"", "video.frames_per_sec=20.0"]);
    let folder = run_folder(&c);
    let mp4 = folder.join("video_fixed.mp4");
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
        .args(["-show_entries", "stream=codec_name,width,height,nb_read_frames", "-of", "csv=p=0"])
        .arg(&mp4)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // 0.5 s at 20 frames per second: 11 frames.
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "h264,160,120,11");
}

#[test]
fn mp4_without_ffmpeg_falls_back_to_gif_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(exe())
        .args(["run", "--quiet", "--video"])
        .args(["--set", &format!("general.output_dir={:?}", dir.path().display().to_string())])
        .args(["--set", "general.duration_secs=0.2", "--set", "snake.n_links=3", "--set", "terrain.kind=\"none\""])
        .args(["--set", "render.width_px=64", "--set", "render.height_px=48", "--set", "video.frames_per_sec=10.0"])
        .env("SIMSERPENT_FFMPEG", "none")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("ffmpeg is not installed") && stderr.contains("GIF"), "{stderr}");
    let folder = std::fs::read_dir(dir.path()).unwrap().next().unwrap().unwrap().path();
    assert_eq!(gif_frames(&folder.join("video_follow.gif")), (3, 64, 48));
}

#[test]
fn viewer_without_a_display_is_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    for args in [vec!["view"], vec!["run", "--viewer", "--set", "general.duration_secs=0.1"]] {
        let out = Command::new(exe())
            .args(&args)
            .args(["--set", &format!("general.output_dir={:?}", dir.path().display().to_string())])
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains("DISPLAY") && stderr.contains("WAYLAND_DISPLAY"), "{stderr}");
    }
    // No run folder was created.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn pictures_do_not_change_the_trajectory() {
    let dir = tempfile::tempdir().unwrap();
    let plain = run_folder(&config(dir.path(), &["render.record_state=false"]));
    let dir2 = tempfile::tempdir().unwrap();
    let pictured = run_folder(&config(
        dir2.path(),
        &["video.enabled=true", "video.format=\"gif\"", "video.frames_per_sec=50.0", "render.image_times_secs=[0.25]"],
    ));
    for table in ["links.csv", "joints.csv", "contacts.csv"] {
        let a = std::fs::read_to_string(plain.join(table)).unwrap();
        let b = std::fs::read_to_string(pictured.join(table)).unwrap();
        assert!(a == b, "{table} differs with pictures on");
    }
}

#[test]
fn visual_options_show_in_the_picture() {
    let dir = tempfile::tempdir().unwrap();
    let folder = run_folder(&config(dir.path(), &["render.image_times_secs=[0.5]"]));
    let plain = read_png(&folder.join("images/follow_0.500s.png")).2;
    let opts = ReplayOptions {
        images: true,
        overrides: vec![
            "visual.make_transparent=true".into(),
            "visual.show_contact_forces=true".into(),
            "visual.show_center_of_mass=true".into(),
        ],
        ..ReplayOptions::default()
    };
    let files = render::render_run_folder(&folder, &opts).unwrap();
    let decorated = read_png(&files[0]).2;
    let changed = plain.chunks_exact(3).zip(decorated.chunks_exact(3)).filter(|(a, b)| a != b).count();
    assert!(changed > 100, "only {changed} pixels changed with the visual options on");
}
