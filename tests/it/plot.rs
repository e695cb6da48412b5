//! Plots of a run folder: valid PNG and SVG files with the expected panels, titles and axis
//! labels, drawn with the embedded font (no system fonts, no display).

use crate::common::{self, default_config_with, exe, output_dir};
use std::path::{Path, PathBuf};
use std::process::Command;

const PANELS: [(&str, &[&str]); 9] = [
    ("head_position", &["Head position", "time (s)", "position (m)"]),
    ("head_velocity", &["Head velocity", "time (s)", "velocity (m/s)"]),
    ("head_acceleration", &["Head acceleration", "time (s)", "acceleration (m/s²)"]),
    ("contact_count", &["Number of contacts", "time (s)", "contacts"]),
    ("contact_forces", &["Contact normal forces", "time (s)", "force (N)"]),
    ("penetration", &["Largest penetration", "time (s)", "penetration (mm)"]),
    ("joint_angles", &["Joint angles", "time (s)", "angle (deg)"]),
    ("actuator_torques", &["Actuator torques (position actuators)", "time (s)", "torque (N·m)"]),
    ("top_view", &["Top view: link paths and obstacles", "x (m)", "y (m)"]),
];

fn run_folder(out: &Path, extra: &[&str]) -> PathBuf {
    let mut o: Vec<String> = vec![
        output_dir(out),
        "general.duration_secs=0.4".into(),
        "snake.n_links=4".into(),
        "terrain.kind=\"two_cylinders\"".into(),
        "terrain.two_cylinders.distance_m=0.5".into(),
        "plot.width_px=640".into(),
        "plot.height_px=400".into(),
    ];
    o.extend(extra.iter().map(|s| s.to_string()));
    common::run_folder(&default_config_with(&o).unwrap())
}

fn check_panels(folder: &Path) {
    for (stem, texts) in PANELS {
        let png_path = folder.join(format!("plots/{stem}.png"));
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png_path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (640, 400), "{stem}");
        // Something is drawn: not a white page.
        let dark = buf[..info.buffer_size()].chunks_exact(3).filter(|p| p.iter().all(|&c| c < 100)).count();
        assert!(dark > 500, "{stem}: {dark} dark pixels");

        let svg = std::fs::read_to_string(folder.join(format!("plots/{stem}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{stem}: not an SVG document");
        assert!(svg.contains(r#"width="640""#) && svg.contains(r#"height="400""#), "{stem}");
        for text in texts {
            let escaped = text.replace('&', "&amp;");
            assert!(svg.contains(&escaped), "{stem}: the SVG lacks {text:?}");
        }
    }
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn plot_command_writes_every_panel_as_png_and_svg() {
    let dir = tempfile::tempdir().unwrap();
    let folder = run_folder(dir.path(), &[]);
    assert!(!folder.join("plots").exists());
    let out = Command::new(exe()).arg("plot").arg(&folder).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("wrote 20 plot files"));
    check_panels(&folder);
    // One page with all nine panels, three per row.
    let overview = std::fs::read_to_string(folder.join("plots/overview.svg")).unwrap();
    assert!(overview.contains(r#"width="1920""#) && overview.contains(r#"height="1200""#));
    for (_, texts) in PANELS {
        assert!(overview.contains(&texts[0].replace('&', "&amp;")), "overview lacks {}", texts[0]);
    }
    assert!(folder.join("plots/overview.png").is_file());
    // The top view draws the two cylinders (as grey polygons).
    let svg = std::fs::read_to_string(folder.join("plots/top_view.svg")).unwrap();
    assert!(svg.matches("<polygon").count() >= 2, "no obstacles in the top view");
}

#[test]
fn general_plot_true_plots_after_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let folder = run_folder(dir.path(), &["general.plot=true"]);
    check_panels(&folder);
}

#[test]
fn missing_tables_skip_their_panels() {
    let dir = tempfile::tempdir().unwrap();
    let folder = run_folder(dir.path(), &["recording.contacts=false", "recording.link_acceleration=false"]);
    let out = simserpent::plot::plot_run_folder(&folder).unwrap();
    let skipped: Vec<&str> = out.skipped.iter().map(|(p, _)| p.as_str()).collect();
    assert_eq!(skipped, ["head_acceleration", "contact_count", "contact_forces", "penetration"]);
    assert_eq!(out.files.len(), 2 * (5 + 1));
}

#[test]
fn plot_of_a_folder_that_is_not_a_run_is_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(exe()).arg("plot").arg(dir.path()).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("is not a run folder"));
}
