//! Hostile files: third-party terrains with `<model>` cycles, absolute
//! or colliding asset names and symbolic links out of their folder; devices, FIFOs and huge
//! files where a config, terrain or robot file is expected; and the private scratch folders.
//! Every bad input is rejected before anything is written, with exit code 2 and a message that
//! names the key and the file; no scratch folder is left behind.
use simserpent::config::{self, Config};
use simserpent::model::{self, ModelError};
use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common::{data, exe};

/// Runs the binary in `dir` with `TMPDIR=tmp`, killing it after 60 s (a regression must fail,
/// not hang).
fn cli(dir: &Path, tmp: &Path, args: &[&str]) -> Output {
    let mut child = Command::new(exe())
        .current_dir(dir)
        .env("TMPDIR", tmp)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("simserpent {args:?} did not finish in 60 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

fn write(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

/// A terrain file with `asset` inside `<asset>` and `compiler` attributes.
fn terrain_xml(compiler: &str, asset: &str) -> String {
    let compiler = if compiler.is_empty() { String::new() } else { format!("<compiler {compiler}/>") };
    format!(
        "<mujoco model=\"hostile\">\n{compiler}\n<asset>\n{asset}\n</asset>\n<worldbody>\n<geom name=\"tp_box\" \
         type=\"box\" pos=\"2 0 0.05\" size=\"0.3 0.3 0.05\"/>\n</worldbody>\n</mujoco>\n"
    )
}

/// A short run's config with `include_mjcf` (may be empty).
fn config_with_terrain(include_mjcf: &Path) -> Config {
    let mut c = Config::default();
    c.general.duration_secs = 0.01;
    c.terrain.include_mjcf = include_mjcf.display().to_string();
    c
}

/// The config error of generating the model of `c`; panics when it is accepted or another error.
fn config_error(c: &Config) -> String {
    match model::generate(c) {
        Err(ModelError::Config(e)) => e.to_string(),
        Err(other) => panic!("not a config error: {other}"),
        Ok(_) => panic!("accepted: {c:?}"),
    }
}

/// Checks that `message` contains every needle; returns a problem line otherwise.
fn lacks(case: &str, message: &str, needles: &[&str]) -> Option<String> {
    let missing: Vec<&&str> = needles.iter().filter(|n| !message.contains(**n)).collect();
    (!missing.is_empty()).then(|| format!("{case}: lacks {missing:?}: {message}"))
}

/// Entries of a folder (names), sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = match std::fs::read_dir(dir) {
        Ok(rd) => rd.map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

// --- 1. <model> cycles ---------------------------------------------------------------------

#[test]
fn terrain_model_cycle_is_rejected_not_a_stack_overflow() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(&d.join("self/t.xml"), &terrain_xml("", "<model name=\"me\" file=\"t.xml\"/>"));
    write(&d.join("pair/a.xml"), &terrain_xml("", "<model name=\"b\" file=\"b.xml\"/>"));
    write(&d.join("pair/b.xml"), &terrain_xml("", "<model name=\"a\" file=\"a.xml\"/>"));
    write(&d.join("plain/t.xml"), &terrain_xml("", "<model name=\"other\" file=\"other.xml\"/>"));
    write(&d.join("plain/other.xml"), &terrain_xml("", ""));
    write(&d.join("include/t.xml"), "<mujoco>\n<include file=\"t.xml\"/>\n</mujoco>\n");
    let cases = [
        ("self/t.xml", "<model>"),
        ("pair/a.xml", "<model>"),
        ("plain/t.xml", "<model>"),
        ("include/t.xml", "<include>"),
    ];
    let mut problems = Vec::new();
    for (file, element) in cases {
        let e = config_error(&config_with_terrain(&d.join(file)));
        problems.extend(lacks(file, &e, &["terrain.include_mjcf", file, element, "is not allowed", "line "]));
    }
    // Through the CLI: check, model and run reject it (exit 2), write nothing, leave no scratch folder.
    let tmp = d.join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    write(&d.join("cycle.toml"), "[general]\nduration_secs = 0.01\n[terrain]\ninclude_mjcf = \"self/t.xml\"\n");
    for args in [&["check", "cycle.toml"][..], &["model", "cycle.toml", "-o", "out.xml"], &["run", "cycle.toml"]] {
        let out = cli(d, &tmp, args);
        if out.status.code() != Some(2) {
            problems.push(format!("{args:?}: exit {:?}: {}", out.status.code(), text(&out)));
        }
        problems.extend(lacks(&format!("{args:?}"), &text(&out), &["terrain.include_mjcf", "t.xml", "<model>"]));
    }
    assert!(!d.join("out.xml").exists() && !d.join("runs").exists(), "nothing written");
    assert!(entries(&tmp).is_empty(), "scratch left behind: {:?}", entries(&tmp));
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

// --- 2. scratch folders ----------------------------------------------------------------------

/// Removes the planted symbolic links even when the test fails.
struct Planted(Vec<PathBuf>);
impl Drop for Planted {
    fn drop(&mut self) {
        for p in &self.0 {
            let _ = std::fs::remove_file(p);
        }
    }
}

#[test]
fn planted_symlinks_at_the_old_scratch_names_are_not_followed() {
    // Before the fix, scratch folders were temp_dir()/simserpent-model-<pid>-<k> and
    // simserpent-robot-<pid>, created with create_dir_all (which accepts a planted symbolic link
    // to a folder) and filled with fs::write: another user's link made us write into their target.
    let dir = tempfile::tempdir().unwrap();
    let victim = dir.path().join("victim");
    std::fs::create_dir(&victim).unwrap();
    let pid = std::process::id();
    let tmp = std::env::temp_dir();
    let mut names: Vec<String> = (0..8).map(|k| format!("simserpent-model-{pid}-{k}")).collect();
    names.push(format!("simserpent-robot-{pid}"));
    let planted = Planted(names.iter().map(|n| tmp.join(n)).collect());
    for p in &planted.0 {
        let _ = std::fs::remove_file(p);
        symlink(&victim, p).unwrap();
    }
    let c = config_with_terrain(&data("third_party_terrain/terrain.xml"));
    simserpent::sim::World::from_config(&c).unwrap();
    let options = simserpent::run::RunOptions { robot: Some(data("two_link_arm.xml")), ..Default::default() };
    let mut robot_config = Config::default();
    robot_config.control.method = config::ControlMethod::Position;
    let _ = simserpent::run::build_world(&robot_config, &options);
    assert!(entries(&victim).is_empty(), "written through a planted link: {:?}", entries(&victim));
    for p in &planted.0 {
        assert!(p.symlink_metadata().unwrap().file_type().is_symlink(), "{} untouched", p.display());
    }
}

/// An OBJ sphere of `n` x `n` vertices (2 n (n - 1) triangles): MuJoCo takes seconds to compile it.
fn big_obj(path: &Path, n: usize) {
    use std::fmt::Write as _;
    let mut s = String::new();
    for i in 0..n {
        for j in 0..n {
            let (th, ph) =
                (std::f64::consts::PI * i as f64 / (n - 1) as f64, std::f64::consts::TAU * j as f64 / n as f64);
            writeln!(s, "v {:.6} {:.6} {:.6}", th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()).unwrap();
        }
    }
    for i in 0..n - 1 {
        for j in 0..n {
            let (a, b, c, d) =
                (i * n + j + 1, i * n + (j + 1) % n + 1, (i + 1) * n + j + 1, (i + 1) * n + (j + 1) % n + 1);
            writeln!(s, "f {a} {b} {d}\nf {a} {d} {c}").unwrap();
        }
    }
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, s).unwrap();
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn scratch_folders_are_removed_after_success_failure_and_sigterm() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tmp = d.join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    let terrain = data("third_party_terrain/terrain.xml");
    write(
        &d.join("ok.toml"),
        &format!("[general]\nduration_secs = 0.01\n[terrain]\ninclude_mjcf = {:?}\n", terrain.display().to_string()),
    );
    // MuJoCo rejects it (an undefined material), after the scratch folder was filled.
    write(
        &d.join("rejected/t.xml"),
        "<mujoco>\n<worldbody>\n<geom name=\"tp_box\" type=\"box\" material=\"nowhere\" size=\"1 1 1\"/>\n\
         </worldbody>\n</mujoco>\n",
    );
    write(&d.join("rejected.toml"), "[general]\nduration_secs = 0.01\n[terrain]\ninclude_mjcf = \"rejected/t.xml\"\n");
    let robot = data("two_link_arm.xml").display().to_string();
    let no_actuator = data("robot_no_actuator.xml").display().to_string();
    let mut problems = Vec::new();
    let cases: [(&str, &[&str], bool); 4] = [
        ("third-party terrain, success", &["run", "ok.toml", "--quiet"], true),
        ("third-party terrain MuJoCo rejects", &["run", "rejected.toml", "--quiet"], false),
        (
            "robot, success",
            &[
                "run",
                "--set",
                "general.duration_secs=0.01",
                "--set",
                "control.method=\"position\"",
                "--robot",
                &robot,
                "--quiet",
            ],
            true,
        ),
        ("robot without actuators", &["run", "--robot", &no_actuator, "--quiet"], false),
    ];
    for (case, args, ok) in cases {
        let out = cli(d, &tmp, args);
        if out.status.success() != ok {
            problems.push(format!("{case}: exit {:?}: {}", out.status.code(), text(&out)));
        }
        if !entries(&tmp).is_empty() {
            problems.push(format!("{case}: scratch left behind: {:?}", entries(&tmp)));
        }
    }
    // SIGTERM while MuJoCo compiles a slow terrain: the signal only sets the run's interrupt
    // flag, the compile finishes, the scratch folder is dropped, the run stops (exit 130).
    big_obj(&d.join("slow/big.obj"), 500);
    write(
        &d.join("slow/t.xml"),
        "<mujoco>\n<asset><mesh name=\"big\" file=\"big.obj\"/></asset>\n<worldbody><geom name=\"tp_big\" \
         type=\"mesh\" mesh=\"big\" pos=\"5 5 1\"/></worldbody>\n</mujoco>\n",
    );
    write(&d.join("slow.toml"), "[general]\nduration_secs = 0.01\n[terrain]\ninclude_mjcf = \"slow/t.xml\"\n");
    let mut child = Command::new(exe())
        .current_dir(d)
        .env("TMPDIR", &tmp)
        .args(["run", "slow.toml", "--quiet"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while entries(&tmp).is_empty() && start.elapsed() < Duration::from_secs(30) && child.try_wait().unwrap().is_none() {
        std::thread::sleep(Duration::from_millis(10));
    }
    let saw_scratch = !entries(&tmp).is_empty();
    for name in entries(&tmp) {
        use std::os::unix::fs::PermissionsExt;
        let mode = tmp.join(&name).symlink_metadata().map(|m| m.permissions().mode() & 0o777).unwrap_or(0o700);
        if !name.starts_with("simserpent-model-") || name.len() < "simserpent-model-".len() + 6 || mode != 0o700 {
            problems.push(format!("scratch folder {name} (mode {mode:o}): not a private, random name"));
        }
    }
    Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    let out = child.wait_with_output().unwrap();
    if saw_scratch && out.status.code() != Some(130) {
        problems.push(format!("SIGTERM during the compile: exit {:?}: {}", out.status.code(), text(&out)));
    }
    if !entries(&tmp).is_empty() {
        problems.push(format!("SIGTERM during the compile: scratch left behind: {:?}", entries(&tmp)));
    }
    assert!(saw_scratch, "the scratch folder was never seen: the test did not interrupt a compile");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

// --- 3. asset names that collide with the run folder's own files -----------------------------

#[test]
fn terrain_assets_named_like_run_folder_files_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // (compiler attributes, the asset's file attribute)
    let cases = [
        ("", "config.toml"),
        ("", "model.xml"),
        ("", "scene.xml"),
        ("", "terrain.xml"),
        ("", "robot.xml"),
        ("", "user_terrain.xml"),
        ("", "manifest.json"),
        ("", "manifest.json.tmp"),
        ("", "links.csv"),
        ("", "joints.parquet"),
        ("", "contacts.parquet/part-00000.parquet"),
        ("", "sensors.csv"),
        ("", "state.csv"),
        ("", "report.md"),
        ("", "Config.TOML"),
        ("", "./model.xml"),
        ("", "terrain_sources/heightfield_hf.png"),
        ("", "plots/links.png"),
        ("", "images/follow_0.000s.png"),
        ("", "video_follow.mp4"),
        ("meshdir=\"plots\"", "rock.obj"),
        ("assetdir=\"./images\"", "rock.obj"),
    ];
    let mut problems = Vec::new();
    for (k, (compiler, file)) in cases.iter().enumerate() {
        let path = d.join(format!("t{k}/t.xml"));
        write(&path, &terrain_xml(compiler, &format!("<mesh name=\"m\" file=\"{file}\"/>")));
        let e = config_error(&config_with_terrain(&path));
        problems.extend(lacks(file, &e, &["terrain.include_mjcf", "t.xml", file, "the run folder uses"]));
    }
    assert!(problems.is_empty(), "{} of {} cases:\n{}", problems.len(), cases.len(), problems.join("\n"));
    // The same names one folder down are fine.
    let path = d.join("ok/t.xml");
    write(&path, &terrain_xml("meshdir=\"meshes\"", "<mesh name=\"m\" file=\"config.obj\"/>"));
    std::fs::create_dir_all(d.join("ok/meshes")).unwrap();
    std::fs::copy(data("third_party_terrain/meshes/rock.obj"), d.join("ok/meshes/config.obj")).unwrap();
    let g = model::generate(&config_with_terrain(&path)).unwrap();
    assert!(g.files.copies.iter().any(|c| c.dest == "meshes/config.obj"), "{:?}", g.files.copies);
}

#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn every_file_a_run_writes_has_a_reserved_run_folder_name() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = config_with_terrain(&data("third_party_terrain/terrain.xml"));
    c.general.output_dir = dir.path().join("runs").display().to_string();
    c.general.plot = true;
    c.recording.format = if cfg!(feature = "parquet") { config::TableFormat::Both } else { config::TableFormat::Csv };
    c.render.record_state = true;
    let summary = simserpent::run::run(&c, &simserpent::run::RunOptions::default()).unwrap();
    let copied: Vec<String> =
        summary_copies(&c).into_iter().map(|d| d.split('/').next().unwrap().to_string()).collect();
    for name in entries(&summary.run_folder) {
        assert!(
            copied.contains(&name) || model::files::is_run_folder_name(&name),
            "the run folder's {name} is not in model::files::RUN_FOLDER_NAMES (a terrain asset could overwrite it)"
        );
    }
}

/// The destinations of the copies of `c`'s terrain files.
fn summary_copies(c: &Config) -> Vec<String> {
    model::generate(c).unwrap().files.copies.into_iter().map(|f| f.dest).collect()
}

// --- 4. symbolic links out of the terrain's folder, absolute paths ---------------------------

#[test]
fn terrain_asset_symlinks_out_of_the_folder_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rock = data("third_party_terrain/meshes/rock.obj");
    std::fs::copy(&rock, d.join("outside.obj")).unwrap();
    let mut problems = Vec::new();
    // (case, set-up of folder f, compiler attributes, mesh file, needles)
    type Setup = fn(&Path, &Path);
    let cases: [(&str, Setup, &str, &str, &[&str]); 6] = [
        (
            "file symlink to a file outside",
            |f, d| symlink(d.join("outside.obj"), f.join("rock.obj")).unwrap(),
            "",
            "rock.obj",
            &["symbolic link", "outside the terrain's folder"],
        ),
        (
            "sub-folder symlink to a folder outside",
            |f, d| symlink(d, f.join("meshes")).unwrap(),
            "",
            "meshes/outside.obj",
            &["symbolic link", "outside the terrain's folder"],
        ),
        (
            "symlink to /etc/passwd",
            |f, _| symlink("/etc/passwd", f.join("tex.obj")).unwrap(),
            "",
            "tex.obj",
            &["outside the terrain's folder"],
        ),
        (
            "symlink to /dev/zero",
            |f, _| symlink("/dev/zero", f.join("zero.obj")).unwrap(),
            "",
            "zero.obj",
            &["outside the terrain's folder"],
        ),
        ("`..` in file", |_, _| {}, "", "../outside.obj", &["leaves the terrain file's folder"]),
        ("`..` in meshdir", |_, _| {}, "meshdir=\"../\"", "outside.obj", &["leaves the terrain file's folder"]),
    ];
    for (k, (case, setup, compiler, file, needles)) in cases.iter().enumerate() {
        let f = d.join(format!("t{k}"));
        std::fs::create_dir(&f).unwrap();
        setup(&f, d);
        write(&f.join("t.xml"), &terrain_xml(compiler, &format!("<mesh name=\"m\" file=\"{file}\"/>")));
        let e = config_error(&config_with_terrain(&f.join("t.xml")));
        let mut all = vec!["terrain.include_mjcf", "t.xml", "<mesh file="];
        all.extend(needles.iter());
        problems.extend(lacks(case, &e, &all));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    // A symbolic link that stays inside the folder is fine, and copied as the file it points to.
    let f = d.join("inside");
    std::fs::create_dir_all(f.join("meshes")).unwrap();
    std::fs::copy(&rock, f.join("meshes/rock.obj")).unwrap();
    symlink("meshes/rock.obj", f.join("alias.obj")).unwrap();
    write(&f.join("t.xml"), &terrain_xml("", "<mesh name=\"m\" file=\"alias.obj\"/>"));
    let mut c = config_with_terrain(&f.join("t.xml"));
    c.general.output_dir = d.join("runs").display().to_string();
    let summary = simserpent::run::run(&c, &simserpent::run::RunOptions::default()).unwrap();
    let copy = summary.run_folder.join("alias.obj");
    assert!(!copy.symlink_metadata().unwrap().file_type().is_symlink(), "copied as a regular file");
    assert_eq!(std::fs::read(copy).unwrap(), std::fs::read(&rock).unwrap());
}

#[test]
fn absolute_terrain_asset_paths_are_rejected_naming_the_attribute() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rock = data("third_party_terrain/meshes/rock.obj").display().to_string();
    let folder = data("third_party_terrain/meshes").display().to_string();
    // (case, compiler attributes, asset, needles); the absolute files exist, and are still refused.
    let cases = [
        (
            "texture file",
            String::new(),
            "<texture name=\"t\" type=\"2d\" file=\"/etc/hostname\"/>".to_string(),
            "<texture file=\"/etc/hostname\">",
        ),
        ("mesh file", String::new(), format!("<mesh name=\"m\" file=\"{rock}\"/>"), "<mesh file="),
        (
            "hfield file",
            String::new(),
            "<hfield name=\"h\" file=\"/etc/hostname\" size=\"1 1 1 1\"/>".into(),
            "<hfield file=",
        ),
        (
            "cube texture fileright",
            String::new(),
            "<texture name=\"t\" type=\"cube\" fileright=\"/etc/hostname\"/>".into(),
            "<texture fileright=",
        ),
        (
            "compiler meshdir",
            format!("meshdir=\"{folder}\""),
            "<mesh name=\"m\" file=\"rock.obj\"/>".into(),
            "<compiler meshdir=",
        ),
        (
            "compiler texturedir",
            format!("texturedir=\"{folder}\""),
            "<texture name=\"t\" type=\"2d\" file=\"x.png\"/>".into(),
            "<compiler texturedir=",
        ),
        (
            "compiler assetdir",
            format!("assetdir=\"{folder}\""),
            "<mesh name=\"m\" file=\"rock.obj\"/>".into(),
            "<compiler assetdir=",
        ),
    ];
    let mut problems = Vec::new();
    for (k, (case, compiler, asset, needle)) in cases.iter().enumerate() {
        let path = d.join(format!("t{k}/t.xml"));
        write(&path, &terrain_xml(compiler, asset));
        let e = config_error(&config_with_terrain(&path));
        problems.extend(lacks(case, &e, &["terrain.include_mjcf", "t.xml", needle, "absolute path"]));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

// --- 5. unbounded reads: devices, FIFOs, huge files ------------------------------------------

/// A sparse file of `len` bytes (no disk space used).
fn sparse(path: &Path, len: u64) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::File::create(path).unwrap().set_len(len).unwrap();
}

#[test]
fn devices_fifos_and_huge_files_are_refused_not_read_until_oom() {
    use simserpent::model::files::{MAX_ASSET_BYTES, MAX_CONFIG_BYTES, MAX_MJCF_BYTES};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tmp = d.join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    symlink("/dev/zero", d.join("zero.stl")).unwrap();
    symlink("/dev/zero", d.join("zero.obj")).unwrap();
    symlink("/dev/zero", d.join("zero.toml")).unwrap();
    symlink("/dev/zero", d.join("zero.xml")).unwrap();
    assert!(Command::new("mkfifo").arg(d.join("fifo.toml")).status().unwrap().success());
    assert!(Command::new("mkfifo").arg(d.join("fifo.xml")).status().unwrap().success());
    sparse(&d.join("huge.toml"), MAX_CONFIG_BYTES + 1);
    sparse(&d.join("huge_terrain/t.xml"), MAX_MJCF_BYTES + 1);
    sparse(&d.join("huge.png"), MAX_ASSET_BYTES + 1);
    sparse(&d.join("huge_asset/big.obj"), MAX_ASSET_BYTES + 1);
    write(&d.join("huge_asset/t.xml"), &terrain_xml("", "<mesh name=\"m\" file=\"big.obj\"/>"));
    // A PNG texture that declares 100000 x 100000 pixels (MuJoCo would decode it whole).
    let mut png = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR".to_vec();
    png.extend_from_slice(&100_000u32.to_be_bytes());
    png.extend_from_slice(&100_000u32.to_be_bytes());
    png.extend_from_slice(&[8, 0, 0, 0, 0, 0, 0, 0, 0]);
    write(&d.join("bomb/t.xml"), &terrain_xml("", "<texture name=\"t\" type=\"2d\" file=\"bomb.png\"/>"));
    std::fs::write(d.join("bomb/bomb.png"), png).unwrap();
    let obstacle = |file: &str| {
        format!(
            "[[terrain.mesh_obstacles]]\nfile = {file:?}\nposition_m = [3.0, 3.0, 0.0]\nrotation_deg = [0.0, 0.0, \
             0.0]\nscale = 1.0\n"
        )
    };
    // (case, config text or file, needles); every one through `check` and `run`: exit 2.
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "heightfield /dev/zero",
            "[terrain.heightfield]\nfile = \"/dev/zero\"\n".into(),
            vec!["terrain.heightfield.file", "/dev/zero", "not a regular file"],
        ),
        (
            "include_mjcf /dev/urandom",
            "[terrain]\ninclude_mjcf = \"/dev/urandom\"\n".into(),
            vec!["terrain.include_mjcf", "/dev/urandom", "not a regular file"],
        ),
        (
            "include_mjcf a FIFO",
            "[terrain]\ninclude_mjcf = \"fifo.xml\"\n".into(),
            vec!["terrain.include_mjcf", "fifo.xml", "FIFO"],
        ),
        (
            "include_mjcf symlinked to /dev/zero",
            "[terrain]\ninclude_mjcf = \"zero.xml\"\n".into(),
            vec!["terrain.include_mjcf", "zero.xml", "character device"],
        ),
        (
            "mesh obstacle symlinked to /dev/zero",
            obstacle("zero.stl"),
            vec!["terrain.mesh_obstacles[0].file", "zero.stl", "character device"],
        ),
        (
            "mesh terrain symlinked to /dev/zero",
            "[terrain.mesh_terrain]\nfile = \"zero.obj\"\n".into(),
            vec!["terrain.mesh_terrain.file", "zero.obj", "character device"],
        ),
        (
            "include_mjcf over 64 MiB",
            "[terrain]\ninclude_mjcf = \"huge_terrain/t.xml\"\n".into(),
            vec!["terrain.include_mjcf", "t.xml", "cap of 64 MiB", "67108865 bytes"],
        ),
        (
            "heightfield over 256 MiB",
            "[terrain.heightfield]\nfile = \"huge.png\"\n".into(),
            vec!["terrain.heightfield.file", "huge.png", "cap of 256 MiB", "268435457 bytes"],
        ),
        (
            "terrain asset over 256 MiB",
            "[terrain]\ninclude_mjcf = \"huge_asset/t.xml\"\n".into(),
            vec!["terrain.include_mjcf", "big.obj", "cap of 256 MiB"],
        ),
        (
            "terrain PNG of 10^10 pixels",
            "[terrain]\ninclude_mjcf = \"bomb/t.xml\"\n".into(),
            vec!["terrain.include_mjcf", "bomb.png", "100000 x 100000 pixels"],
        ),
    ];
    let mut problems = Vec::new();
    for (k, (case, toml, needles)) in cases.iter().enumerate() {
        let name = format!("c{k}.toml");
        write(&d.join(&name), toml);
        for command in ["check", "run"] {
            let out = cli(d, &tmp, &[command, &name, "--set", "general.duration_secs=0.01"]);
            if out.status.code() != Some(2) {
                problems.push(format!("{case} ({command}): exit {:?}: {}", out.status.code(), text(&out)));
            }
            problems.extend(lacks(&format!("{case} ({command})"), &text(&out), needles));
        }
    }
    // The config file itself, and the robot file.
    let robot_cases: [(&str, &[&str], &[&str]); 7] = [
        ("config symlinked to /dev/zero", &["check", "zero.toml"], &["zero.toml", "character device"]),
        ("config a FIFO", &["check", "fifo.toml"], &["fifo.toml", "FIFO"]),
        ("config over 16 MiB", &["check", "huge.toml"], &["huge.toml", "cap of 16 MiB", "16777217 bytes"]),
        ("config a folder", &["check", "tmp.toml"], &["tmp.toml", "a folder"]),
        (
            "--robot /dev/null",
            &["run", "--robot", "/dev/null"],
            &["/dev/null", "is not a regular file", "character device"],
        ),
        ("--robot /dev/zero", &["run", "--robot", "/dev/zero"], &["/dev/zero", "is not a regular file"]),
        ("--robot a FIFO", &["run", "--robot", "fifo.xml"], &["fifo.xml", "FIFO"]),
    ];
    std::fs::create_dir(d.join("tmp.toml")).unwrap();
    for (case, args, needles) in robot_cases {
        let out = cli(d, &tmp, args);
        if out.status.code() != Some(2) {
            problems.push(format!("{case}: exit {:?}: {}", out.status.code(), text(&out)));
        }
        problems.extend(lacks(case, &text(&out), needles));
        if text(&out).contains("does not exist") {
            problems.push(format!("{case}: says \"does not exist\": {}", text(&out)));
        }
    }
    assert!(!d.join("runs").exists(), "no run folder for bad input");
    assert!(entries(&tmp).is_empty(), "scratch left behind: {:?}", entries(&tmp));
    assert!(problems.is_empty(), "{} problems:\n{}", problems.len(), problems.join("\n"));
}

#[test]
fn a_terrain_file_that_grows_past_its_cap_after_the_check_is_not_copied() {
    // The copy into the run folder reads the source again, bounded by the same cap: replacing a
    // checked file by a huge or endless one in between is an error of its key, not a full disk.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let c = config_with_terrain(&data("third_party_terrain/terrain.xml"));
    let mut g = model::generate(&c).unwrap();
    let copy = g.files.copies.iter_mut().find(|f| f.dest == "meshes/rock.obj").unwrap();
    sparse(&d.join("grown.obj"), copy.max_bytes + 1);
    copy.source = d.join("grown.obj");
    let out = d.join("out");
    std::fs::create_dir(&out).unwrap();
    let e = simserpent::sim::write_model_folder(&out, &g.xml, &g.files.texts, &g.files.copies).unwrap_err();
    let message = e.to_string();
    assert!(matches!(e, simserpent::sim::SimError::Config(_)), "{message}");
    assert!(
        message.contains("terrain.include_mjcf") && message.contains("grown.obj") && message.contains("cap"),
        "{message}"
    );
    copy_is_gone(&out.join("meshes/rock.obj"));
    let copy = g.files.copies.iter_mut().find(|f| f.dest == "meshes/rock.obj").unwrap();
    copy.source = PathBuf::from("/dev/zero");
    let e = simserpent::sim::write_model_folder(&out, &g.xml, &g.files.texts, &g.files.copies).unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
}

fn copy_is_gone(path: &Path) {
    assert!(!path.exists(), "{} was left half copied", path.display());
}

#[test]
fn config_read_reports_invalid_utf8_with_its_position() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.toml");
    std::fs::write(&path, b"[general]\nrun_name = \"a\xffb\"\n").unwrap();
    let e = config::load_config(&path, &[]).unwrap_err().to_string();
    assert!(e.contains("c.toml") && e.contains("valid UTF-8") && e.contains("line 2"), "{e}");
}
