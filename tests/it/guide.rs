//! The user guide (`guide/`): its generated reference pages match the code, and the README stays
//! the short entry point it is meant to be.

use crate::common::{manifest_dir, simserpent};

/// The committed reference pages (configuration keys, output columns, command line) are what
/// `simserpent doc-gen` makes from the code; after changing the default config, the columns or
/// the command line, run `./scripts/guide` (or `simserpent doc-gen guide/src/reference`).
#[test]
fn the_generated_reference_pages_match_the_code() {
    let dir = manifest_dir().join("guide/src/reference");
    let out = simserpent(manifest_dir(), &["doc-gen", "--check", dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// Every key of the default config and every table appear in the generated pages.
#[test]
fn the_reference_pages_cover_every_section_and_table() {
    let dir = manifest_dir().join("guide/src/reference");
    let config = std::fs::read_to_string(dir.join("config.md")).unwrap();
    for section in ["[general]", "[physics]", "[snake]", "[terrain.pegboard]", "[estimation]", "[jam_resolution]"] {
        assert!(config.contains(&format!("## `{section}`")), "config.md lacks {section}");
    }
    let outputs = std::fs::read_to_string(dir.join("outputs.md")).unwrap();
    for table in ["links", "joints", "sensors", "contacts", "estimates"] {
        assert!(outputs.contains(&format!("## `{table}`")), "outputs.md lacks {table}");
    }
    assert!(outputs.contains("| `link_NN_position_x_m` | per link | float | m | `recording.link_position` |"));
    let cli = std::fs::read_to_string(dir.join("cli.md")).unwrap();
    for command in ["run", "init", "sweep", "experiment", "estimate", "bench"] {
        assert!(cli.contains(&format!("## `simserpent {command}`")), "cli.md lacks {command}");
    }
    assert!(!cli.contains("## `simserpent doc-gen`"), "the hidden doc-gen command stays out of the reference");
}

/// The README is the entry point (at most 15 KB); the guide holds the rest.
#[test]
fn the_readme_is_short() {
    let readme = std::fs::read_to_string(manifest_dir().join("README.md")).unwrap();
    assert!(readme.len() <= 15 * 1024, "README.md is {} bytes, more than 15 KB", readme.len());
}

/// The Rust tutorial shows `examples/custom_controller.rs` (which `cargo test` compiles) as it is.
#[test]
fn the_rust_tutorial_shows_the_example_as_it_is() {
    let example = std::fs::read_to_string(manifest_dir().join("examples/custom_controller.rs")).unwrap();
    let code = &example[example.find("use simserpent::config").unwrap()..];
    let page = std::fs::read_to_string(manifest_dir().join("guide/src/tutorials/controller-rust.md")).unwrap();
    assert!(page.contains(code.trim_end()), "copy examples/custom_controller.rs into the tutorial again");
}

/// The Rust tutorial's shown output is what `examples/custom_controller.rs` prints: the example
/// (which `cargo test` builds beside the test binaries) runs in a fresh folder, and its distance
/// is the one shown within 2 %.
#[test]
fn the_rust_tutorial_shows_what_the_example_prints() {
    let page = std::fs::read_to_string(manifest_dir().join("guide/src/tutorials/controller-rust.md")).unwrap();
    let shown = page.lines().find(|l| l.starts_with("recorded in runs/custom_controller-")).expect("the shown output");
    let shown_m: f64 = shown.rsplit("moved ").next().unwrap().trim_end_matches(" m").parse().unwrap();
    // target/<profile>/deps/it-<hash> -> target/<profile>/examples/custom_controller
    let exe = std::env::current_exe().unwrap();
    let example = exe
        .parent()
        .unwrap()
        .parent()
        .unwrap()
        .join("examples")
        .join(format!("custom_controller{}", std::env::consts::EXE_SUFFIX));
    if !example.is_file() {
        assert!(std::env::var_os("CI").is_none(), "{}: not built (cargo test builds the examples)", example.display());
        eprintln!("skipped: {} is not built (`cargo test` without a --test filter builds it)", example.display());
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(&example).current_dir(dir.path()).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let printed = String::from_utf8_lossy(&out.stdout);
    let line = printed.lines().find(|l| l.starts_with("recorded in runs")).expect("the example's line");
    assert!(line.starts_with("recorded in runs/custom_controller-"), "{line}");
    let moved_m: f64 = line.rsplit("moved ").next().unwrap().trim_end_matches(" m").parse().unwrap();
    assert!((moved_m - shown_m).abs() <= 0.02 * shown_m, "printed {line:?}, the tutorial shows {shown:?}");
}

/// The troubleshooting page states the tracking warning's thresholds as the code has them.
#[test]
fn the_troubleshooting_page_states_the_tracking_thresholds_of_the_code() {
    let page = std::fs::read_to_string(manifest_dir().join("guide/src/how-to/troubleshooting.md")).unwrap();
    let page = page.split_whitespace().collect::<Vec<_>>().join(" ");
    let [lo, hi] = simserpent::state::TRACKING_AMPLITUDE_PERCENT;
    let rms = simserpent::state::TRACKING_RMS_ERROR_PERCENT;
    for claim in [
        format!("less than {lo} % or more than {hi} % of the commanded amplitude"),
        format!("its RMS error exceeds {rms} % of it"),
    ] {
        assert!(page.contains(&claim), "troubleshooting.md should say: {claim}");
    }
}
