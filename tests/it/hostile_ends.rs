//! Ends that could lose data, tried as an attacker would: MuJoCo's fatal errors during set-up
//! and mid-run, `bag-repair` on damaged bags, on a run that is still going on, on random bytes,
//! on a file instead of a folder and on a full disk. RELIABILITY.md counts the cases
//! (`scripts/red-team bag-repair`, `scripts/red-team engine-errors`).

use crate::common::{KillOnDrop, exe, manifest, run_folders, text};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// `simserpent args…` in `dir`, with `$TMPDIR` = `dir/tmp` (to see what is left there).
fn cli(dir: &Path, args: &[&str]) -> Output {
    let tmp = dir.join("tmp");
    std::fs::create_dir_all(&tmp).unwrap();
    Command::new(exe()).current_dir(dir).env("TMPDIR", &tmp).args(args).output().unwrap()
}

fn leftovers_in_tmp(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir.join("tmp")).map_or_else(|_| Vec::new(), |d| d.map(|e| e.unwrap().path()).collect())
}

/// A robot (MJCF) of a two-link arm on the floor and `boxes` loose boxes whose bottoms are 0.44 m
/// up: they land at t = 0.30 s (free fall), in a model whose memory is `<size memory="400K"/>`.
fn falling_boxes_robot(dir: &Path, boxes: usize) -> PathBuf {
    let mut bodies = String::new();
    for i in 0..boxes {
        let (x, y) = (0.3 + (i % 20) as f64 * 0.07, (i / 20) as f64 * 0.07);
        bodies += &format!(
            "<body name=\"b{i}\" pos=\"{x:.2} {y:.2} 0.47\"><freejoint/><geom type=\"box\" size=\"0.03 0.03 0.03\" \
             mass=\"0.1\"/></body>\n"
        );
    }
    let xml = format!(
        r#"<mujoco model="falling_boxes">
  <size memory="400K"/>
  <worldbody>
    <body name="base" pos="0 0 0.05">
      <freejoint name="root"/>
      <geom type="box" size="0.05 0.05 0.05" mass="1"/>
      <body name="arm" pos="0.1 0 0">
        <joint name="elbow" type="hinge" axis="0 0 1" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.02" mass="0.2"/>
      </body>
    </body>
{bodies}  </worldbody>
  <actuator><position joint="elbow" kp="5" ctrlrange="-1 1"/></actuator>
</mujoco>
"#
    );
    let path = dir.join(format!("falling_boxes_{boxes}.xml"));
    std::fs::write(&path, xml).unwrap();
    path
}

fn run_args<'a>(dir: &Path, robot: &'a Path, extra: &[&'a str]) -> Vec<String> {
    let mut args = vec![
        "run".to_string(),
        "--quiet".into(),
        "--robot".into(),
        robot.display().to_string(),
        "--set".into(),
        format!("general.output_dir=\"{}\"", dir.join("runs").display()),
    ];
    for e in extra {
        args.extend(["--set".to_string(), (*e).to_string()]);
    }
    args
}

fn csv_rows(path: &Path) -> (u64, f64) {
    let text = std::fs::read_to_string(path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let last_time = lines.last().and_then(|l| l.split(',').next()).and_then(|t| t.parse().ok()).unwrap_or(-1.0);
    (lines.len() as u64 - 1, last_time)
}

// --- a fatal MuJoCo error -----------------------------------------------------------------------

/// 180 boxes in 400 KiB: MuJoCo's stack overflows (`mj_stackAlloc`, a fatal `mju_error`) in
/// the step where the contacts of the falling boxes no longer fit, mid-run. The run ends as a
/// divergence does: exit 1, the manifest `failed` naming the error, the step and its simulated
/// time, every table (CSV tables, `state.csv`, the bag) closed with the rows of the same last
/// instant and listed, nothing left in `$TMPDIR`.
#[test]
fn a_fatal_mujoco_error_mid_run_ends_the_run_failed_with_every_table_at_one_instant() {
    let dir = tempfile::tempdir().unwrap();
    let robot = falling_boxes_robot(dir.path(), 180);
    let args = run_args(dir.path(), &robot, &["general.duration_secs=0.5", "recording.format=[\"csv\", \"mcap\"]"]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = cli(dir.path(), &args);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(1), "{all}");
    assert!(
        all.contains("MuJoCo stopped the simulation with a fatal error at t = ") && all.contains("mj_stackAlloc"),
        "{all}"
    );
    let run = run_folders(dir.path()).remove(0);
    let m = manifest(&run);
    assert_eq!(m["status"], "failed", "{m}");
    let error = m["error"].as_str().unwrap();
    let (steps, simulated) = (m["steps"].as_u64().unwrap(), m["simulated_secs"].as_f64().unwrap());
    assert!(
        error.contains(&format!("at t = {simulated:.6} s (step {steps})")) && error.contains("mj_stackAlloc"),
        "{error}"
    );
    // The boxes land at 0.30 s; the stack overflows while they fall into contact, not at the start.
    assert!(steps > 50 && simulated > 0.05 && simulated < 0.5, "{m}");
    let tables = m["tables"].as_array().unwrap();
    let listed: Vec<(String, u64)> =
        tables.iter().map(|t| (t[0].as_str().unwrap().to_string(), t[1].as_u64().unwrap())).collect();
    for name in ["links.csv", "joints.csv", "sensors.csv", "contacts.csv", "run.mcap"] {
        assert!(listed.iter().any(|(n, _)| n == name), "{name} listed: {listed:?}");
    }
    // One instant in every table: the recorded instants up to the failing step (every 10 steps).
    let instants = steps / 10 + 1;
    for (name, n) in &listed {
        if name == "contacts.csv" {
            continue; // one row per contact
        }
        assert_eq!(*n, instants, "{name}: {listed:?}");
        if name.ends_with(".csv") {
            let (rows, last) = csv_rows(&run.join(name));
            assert_eq!(rows, instants, "{name}");
            assert!((simulated - last) < 0.01 + 1e-9 && last <= simulated, "{name}: last row at {last} s");
        }
    }
    assert_eq!(csv_rows(&run.join("state.csv")).0, instants, "state.csv");
    let bag = std::fs::read(run.join("run.mcap")).unwrap();
    let summary = mcap::Summary::read(&bag).unwrap().expect("the bag is complete");
    let clock = summary.channels.values().find(|c| c.topic == "/clock").unwrap().id;
    assert_eq!(summary.stats.unwrap().channel_message_counts[&clock], instants);
    assert!(!run.join(".simserpent-reserve").exists());
    assert!(leftovers_in_tmp(dir.path()).is_empty(), "{:?}", leftovers_in_tmp(dir.path()));
}

/// 320 boxes in 400 KiB: the stack overflows in MuJoCo's broad phase at the first forward pass
/// of set-up: exit 2 naming the robot file, no run folder, no scratch folder left in `$TMPDIR`
/// (the robot is compiled in one).
#[test]
fn a_fatal_mujoco_error_at_set_up_exits_2_naming_the_file_and_leaves_no_scratch() {
    let dir = tempfile::tempdir().unwrap();
    let robot = falling_boxes_robot(dir.path(), 320);
    let args = run_args(dir.path(), &robot, &["general.duration_secs=0.5"]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = cli(dir.path(), &args);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(2), "{all}");
    assert!(
        all.contains(&format!("robot file {}", robot.display())) && all.contains("while setting up the model"),
        "{all}"
    );
    assert!(run_folders(dir.path()).is_empty());
    assert!(leftovers_in_tmp(dir.path()).is_empty(), "{:?}", leftovers_in_tmp(dir.path()));
}

// --- bag-repair -------------------------------------------------------------------------------------

/// A finished run with a bag (CSV and MCAP) of 4 s, recorded every step: about 20 chunks.
fn run_with_bag(dir: &Path) -> PathBuf {
    let out = cli(
        dir,
        &[
            "run",
            "--quiet",
            "--set",
            "general.duration_secs=4",
            "--set",
            "recording.every_n_steps=1",
            "--set",
            "recording.format=\"mcap\"",
            "--set",
            &format!("general.output_dir=\"{}\"", dir.join("runs").display()),
        ],
    );
    assert!(out.status.success(), "{}", text(&out));
    run_folders(dir).remove(0)
}

/// (offset, length) of every chunk record.
fn chunks(bag: &[u8]) -> Vec<(usize, usize)> {
    let mut at = 8;
    let mut out = Vec::new();
    while at + 9 <= bag.len() && bag[at] != mcap::records::op::DATA_END {
        let len = u64::from_le_bytes(bag[at + 1..at + 9].try_into().unwrap()) as usize;
        if bag[at] == mcap::records::op::CHUNK {
            out.push((at, 9 + len));
        }
        at += 9 + len;
    }
    out
}

/// (topic, sequence, log time, data) of every message of a complete bag.
fn messages(bag: &[u8]) -> Vec<(String, u32, u64, Vec<u8>)> {
    mcap::MessageStream::new(bag)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (m.channel.topic.clone(), m.sequence, m.log_time, m.data.to_vec())
        })
        .collect()
}

/// The bag of a finished run, then 64 zeroed bytes inside one chunk (the middle one, then the
/// first chunk of messages — chunk 1 holds only the definitions): `bag-repair` exits 0, names
/// the chunk on stderr, keeps every other message byte for byte (none differs from the
/// undamaged bag: the damaged chunk's are left out, not rewritten with fresh CRCs), and the
/// manifest lists the instants kept.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn bag_repair_leaves_out_a_damaged_chunk_and_keeps_every_other_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let run = run_with_bag(dir.path());
    let sound = std::fs::read(run.join("run.mcap")).unwrap();
    let all = messages(&sound);
    let list = chunks(&sound);
    assert!(list.len() >= 8, "{} chunks", list.len());
    let instants = all.iter().filter(|m| m.0 == "/clock").count();
    for which in [list.len() / 2, 1] {
        let _ = std::fs::remove_file(run.join("run.damaged.mcap"));
        let (at, len) = list[which];
        let mut damaged = sound.clone();
        damaged[at + len / 2..at + len / 2 + 64].fill(0);
        std::fs::write(run.join("run.mcap"), &damaged).unwrap();
        let out = cli(dir.path(), &["bag-repair", run.to_str().unwrap()]);
        let said = text(&out);
        assert!(out.status.success(), "{said}");
        assert!(said.contains(&format!("bytes {at}–{}: chunk {}", at + len, which + 1)), "{said}");
        assert!(said.contains(&format!("from {} of {} chunks", list.len() - 1, list.len())), "{said}");
        let repaired = messages(&std::fs::read(run.join("run.mcap")).unwrap());
        assert!(repaired.len() < all.len() && repaired.len() > all.len() / 2, "{} of {}", repaired.len(), all.len());
        assert!(repaired.iter().all(|m| all.contains(m)), "a kept message differs from the undamaged bag");
        let kept_instants = repaired.iter().filter(|m| m.0 == "/clock").count();
        assert!(kept_instants < instants);
        let m = manifest(&run);
        let listed = m["tables"].as_array().unwrap().iter().find(|t| t[0] == "run.mcap").unwrap()[1].as_u64();
        assert_eq!(listed, Some(kept_instants as u64), "{m}");
        assert_eq!(std::fs::read(run.join("run.damaged.mcap")).unwrap(), damaged, "the original kept");
        assert!(!run.join("run.repaired.mcap.tmp").exists());
    }
}

/// `bag-repair` on a run that is still going on refuses at once (exit 1, "in use") and touches
/// nothing; the run ends `complete` with every instant in its bag. On random bytes: exit 2 (not
/// an MCAP file) or, after the MCAP magic, exit 1 ("nothing recoverable"), the file left as it
/// is. On a file instead of a run folder: exit 2.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn bag_repair_refuses_a_running_run_random_bytes_and_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let runs = dir.path().join("runs");
    let mut guard = KillOnDrop(Some(
        Command::new(exe())
            .current_dir(dir.path())
            .args([
                "run",
                "--quiet",
                "--set",
                "general.duration_secs=6",
                "--set",
                "recording.format=\"mcap\"",
                "--set",
                &format!("general.output_dir=\"{}\"", runs.display()),
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    ));
    let started = Instant::now();
    let run = loop {
        if let Some(run) = run_folders(dir.path()).first()
            && std::fs::metadata(run.join("run.mcap")).is_ok_and(|m| m.len() > 50_000)
        {
            break run.clone();
        }
        assert!(started.elapsed() < Duration::from_secs(120), "no bag after 120 s");
        assert!(guard.0.as_mut().unwrap().try_wait().unwrap().is_none(), "the run ended before the test");
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = cli(dir.path(), &["bag-repair", run.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("in use by another process"), "{}", text(&out));
    assert!(!run.join("run.damaged.mcap").exists());
    assert!(guard.0.as_mut().unwrap().try_wait().unwrap().is_none(), "the run goes on");
    let done = guard.0.take().unwrap().wait_with_output().unwrap();
    assert!(done.status.success(), "{}", text(&done));
    let m = manifest(&run);
    assert_eq!(m["status"], "complete");
    let bag = std::fs::read(run.join("run.mcap")).unwrap();
    let summary = mcap::Summary::read(&bag).unwrap().expect("complete");
    let clock = summary.channels.values().find(|c| c.topic == "/clock").unwrap().id;
    let listed = m["tables"].as_array().unwrap().iter().find(|t| t[0] == "run.mcap").unwrap()[1].as_u64().unwrap();
    assert_eq!(summary.stats.unwrap().channel_message_counts[&clock], listed);

    // Random bytes.
    let mut x = 0x9E37_79B9_7F4A_7C15_u64;
    let random: Vec<u8> = (0..1_000_000)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 56) as u8
        })
        .collect();
    std::fs::write(run.join("run.mcap"), &random).unwrap();
    let out = cli(dir.path(), &["bag-repair", run.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("not an MCAP file"), "{}", text(&out));
    let mut after_magic = b"\x89MCAP0\r\n".to_vec();
    after_magic.extend_from_slice(&random);
    std::fs::write(run.join("run.mcap"), &after_magic).unwrap();
    let out = cli(dir.path(), &["bag-repair", run.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("nothing recoverable"), "{}", text(&out));
    assert_eq!(std::fs::read(run.join("run.mcap")).unwrap(), after_magic, "left as it is");
    assert!(!run.join("run.damaged.mcap").exists() && !run.join("run.repaired.mcap.tmp").exists());

    // A file instead of the run folder.
    let out = cli(dir.path(), &["bag-repair", run.join("run.mcap").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("not a folder"), "{}", text(&out));
}

/// Unmounts a test's tmpfs when the test ends (also when it fails).
struct Unmount(PathBuf);

impl Drop for Unmount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// `bag-repair` of a killed run's bag on a disk without room for the repaired copy (a tmpfs a
/// little larger than the run folder; skipped where this process may not mount one): exit 1
/// naming "No space left", the bag and the folder as they were, no temporary file left.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn bag_repair_on_a_full_disk_fails_cleanly_and_leaves_the_bag_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let run = run_with_bag(dir.path());
    let sound = std::fs::read(run.join("run.mcap")).unwrap();
    // The bag as a killed run leaves it: its chunks without the summary.
    let last = *chunks(&sound).last().unwrap();
    let killed = &sound[..last.0 + last.1];
    let disk = dir.path().join("disk");
    std::fs::create_dir_all(&disk).unwrap();
    let size_kib = killed.len() / 1024 + 64;
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", &format!("size={size_kib}k"), "tmpfs", disk.to_str().unwrap()])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !mounted {
        eprintln!("skipped: cannot mount a tmpfs here (needs root)");
        return;
    }
    let _unmount = Unmount(disk.clone());
    let folder = disk.join("run");
    std::fs::create_dir(&folder).unwrap();
    std::fs::copy(run.join("manifest.json"), folder.join("manifest.json")).unwrap();
    std::fs::write(folder.join("run.mcap"), killed).unwrap();
    let before: Vec<String> = listing(&folder);
    let out = cli(dir.path(), &["bag-repair", folder.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("No space left"), "{}", text(&out));
    assert_eq!(std::fs::read(folder.join("run.mcap")).unwrap(), killed, "the bag as it was");
    assert_eq!(listing(&folder), before, "no temporary file left");
}

fn listing(folder: &Path) -> Vec<String> {
    // The run folder's lock file stays (empty, hidden): it is no data.
    let mut v: Vec<String> = std::fs::read_dir(folder)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != ".simserpent-lock")
        .collect();
    v.sort();
    v
}
