"""Contact estimation from Python: the per-step estimates on World, in the
environment's observation and in a Python controller's observation, and ``simserpent.estimate``
(the CLI's ``simserpent estimate RUN_FOLDER``)."""

import filecmp
import importlib.util
import shutil
import subprocess

import mujoco
import numpy as np
import pytest
from conftest import REPO, SMALL, cli

import simserpent

#: The 5-link snake on the bare floor, estimation on, a quiet start.
RESTING = {**SMALL, "estimation.enabled": True, "env.reset_noise_scale": 0.0, "env.reset_heading_noise_rad": 0.0}


def load_force_feedback_example():
    """python/examples/force_feedback.py as a module (its scene and its controller)."""
    spec = importlib.util.spec_from_file_location("force_feedback", REPO / "python/examples/force_feedback.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    return example


#: The example's 12 random pegs around the 10-link snake's starting place: it touches some
#: within 1.5 s.
PEGS = {k: v for k, v in load_force_feedback_example().OVERRIDES.items() if k.startswith("terrain.")}

#: What `simserpent estimate` needs: CSV with the sensors and the link columns, every step.
RECORD_FOR_ESTIMATE = {
    "recording.format": "csv",
    "recording.every_n_steps": 1,
    "recording.imu_sensors": True,
    "general.duration_secs": 1.5,
    "control.controller": "gait",
}


def total_mass_kg(world):
    m = mujoco.MjModel.from_xml_string(world.mjcf)
    return float(sum(m.body_mass))


def test_resting_snake_floor_carries_the_weight_and_no_obstacle_is_felt():
    """At rest on a bare floor (no obstacles) the estimated floor support is the weight m g
    (the measured joint force/torque sensors through Newton-Euler), the obstacle force ~0, no
    contact flag; with estimation off the estimates are inactive."""
    w = simserpent.World(simserpent.load_config(overrides=RESTING))
    w.reset(0)
    zero = np.zeros(w.action_size)
    for _ in range(25):  # 0.5 s: settled on the floor
        w.step(zero)
    c = w.contact_estimates()
    n = 5
    assert c["active"] is True
    assert c["obstacle_force_n"].shape == (n, 3) and c["floor_force_n"].shape == (n, 3)
    assert c["contact"].dtype == bool and c["contact"].shape == (n,)
    weight_n = total_mass_kg(w) * 9.81
    assert c["floor_force_n"][:, 2].sum() == pytest.approx(weight_n, rel=0.01)
    assert c["external_force_n"][:, 2].sum() == pytest.approx(weight_n, rel=0.01)
    assert np.abs(c["obstacle_force_n"]).max() < 0.05 * weight_n / n
    assert not c["contact"].any()
    assert np.isnan(c["contact_point_along_m"]).all()
    # Off: inactive, zeros.
    off = simserpent.World(simserpent.load_config(overrides={**RESTING, "estimation.enabled": False}))
    off.reset(0)
    off.step(zero)
    e = off.contact_estimates()
    assert e["active"] is False and not e["obstacle_force_n"].any()


def test_estimates_in_the_observation():
    """`env.observe_contact_estimates` appends per link obstacle force x, y, flag, point: the
    same numbers as World.contact_estimates(); it needs estimation on (a clear error)."""
    sets = {**PEGS, "snake.n_links": 10, "estimation.enabled": True, "env.observe_contact_estimates": True}
    cfg = simserpent.load_config(overrides=sets)
    w = simserpent.World(cfg)
    base = simserpent.World(simserpent.load_config(overrides={**sets, "env.observe_contact_estimates": False}))
    names = w.observation_names
    assert len(names) == base.observation_size + 4 * 10 == w.observation_size
    assert names[-4:] == [
        "link_09_obstacle_force_x_n",
        "link_09_obstacle_force_y_n",
        "link_09_obstacle_contact",
        "link_09_obstacle_contact_point_along_m",
    ]
    w.reset(3)
    gait = simserpent.Gait(cfg)
    seen = 0
    for k in range(150):  # 3 s of the reference gait among the pegs
        obs, *_ = w.step(gait.action(k * 0.02))
        c = w.contact_estimates()
        tail = obs[base.observation_size :].reshape(10, 4)
        np.testing.assert_array_equal(tail[:, 0:2], c["obstacle_force_n"][:, 0:2])
        np.testing.assert_array_equal(tail[:, 2], c["contact"].astype(float))
        np.testing.assert_array_equal(tail[:, 3], np.nan_to_num(c["contact_point_along_m"], nan=0.0))
        seen += int(c["contact"].sum())
    assert seen > 0, "no contact flag in 3 s among the pegs"
    with pytest.raises(simserpent.ConfigError, match=r"env\.observe_contact_estimates.*estimation\.enabled = true"):
        simserpent.World(simserpent.load_config(overrides={"env.observe_contact_estimates": True}))


def test_python_controller_gets_the_estimates_and_the_example_runs(tmp_path):
    """python/examples/force_feedback.py: a Python controller reads obs["contacts"] (the step
    loop's estimates), records a normal run folder whose estimates table holds the same flags."""
    example = load_force_feedback_example()
    summary, log = example.main(duration_secs=2.0, run_folder=tmp_path / "ff")
    run = simserpent.open_run(summary["run_folder"])
    assert run.status == "complete"
    assert len(log) == 2001  # every instant, 0 ..= 2000 ms
    touching = [n for _, n, _ in log if n > 0]
    assert touching, "no obstacle contact estimated in 2 s among the pegs"
    assert max(o for _, _, o in log) > 0.0  # the compliance term acted
    est = run["estimates"]
    flags = est[[c for c in est.columns if c.endswith("_estimated_contact")]].to_numpy()
    # The table (every 10th step) saw contacts too, and never more than the links.
    assert flags.shape[1] == 10 and flags.sum() > 0 and flags.max() <= 1
    # Without estimation the controller's observation has no contacts entry.
    seen = []
    simserpent.run(
        overrides={**SMALL, "general.duration_secs": 0.05},
        run_folder=tmp_path / "plain",
        controller=lambda obs: seen.append("contacts" in obs) or [0.0] * 4,
    )
    assert seen and not any(seen)


@pytest.fixture(scope="module")
def recorded_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("estimate") / "run"
    simserpent.run(overrides={**PEGS, "snake.n_links": 10, **RECORD_FOR_ESTIMATE}, run_folder=folder)
    return folder


def test_estimate_a_run_folder_as_the_cli_does(recorded_run, tmp_path):
    """simserpent.estimate(run_folder) runs the CLI's tool: the same files, the scores as a
    dict that agrees with scores.csv, and (when the CLI is built) byte-identical output."""
    out = simserpent.estimate(recorded_run)
    assert out["rows"] == 1501  # 1.5 s, every step
    for key in ["estimates_csv", "scores_csv", "scores_md"]:
        assert (recorded_run / "estimation").joinpath(out[key].rsplit("/", 1)[-1]).is_file()
    total, per_link = out["total"], out["per_link"]
    assert len(per_link) == 10
    # Every link-step is one of hit / miss / false alarm / correct rejection.
    counted = total["hits"] + total["misses"] + total["false_alarms"] + total["correct_rejections"]
    assert counted == sum(
        s["hits"] + s["misses"] + s["false_alarms"] + s["correct_rejections"] for s in per_link
    )
    assert counted >= 10 * (out["rows"] - 2)
    assert total["hits"] > 0  # the snake touched pegs (its tail, in the first 1.5 s)
    assert total["hits"] + total["misses"] == sum(s["hits"] + s["misses"] for s in per_link)
    if total["hits"] + total["misses"]:
        assert total["detection_rate"] == pytest.approx(total["hits"] / (total["hits"] + total["misses"]))
    # The estimate from the true orientations (an override for this estimate only).
    true_o = simserpent.estimate(recorded_run, overrides={"estimation.orientation": "true"})
    assert true_o["rows"] == out["rows"]
    exe = cli()
    if exe is None:
        pytest.skip("the CLI is not built")
    copy = tmp_path / "copy"
    shutil.copytree(recorded_run, copy, ignore=shutil.ignore_patterns("estimation"))
    simserpent.estimate(recorded_run)  # the default orientation again
    res = subprocess.run([str(exe), "estimate", str(copy)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    for name in ["estimates.csv", "scores.csv"]:
        assert filecmp.cmp(recorded_run / "estimation" / name, copy / "estimation" / name, shallow=False), name


def test_estimate_errors_name_the_file(tmp_path, recorded_run):
    with pytest.raises(simserpent.EstimateError, match=r"config\.toml is missing: not a run folder"):
        simserpent.estimate(tmp_path)
    broken = tmp_path / "broken"
    shutil.copytree(recorded_run, broken, ignore=shutil.ignore_patterns("estimation", "sensors.csv"))
    with pytest.raises(simserpent.EstimateError, match=r"sensors\.csv is missing"):
        simserpent.estimate(broken)
    with pytest.raises(simserpent.ConfigError, match=r"estimation\.orientation"):
        simserpent.estimate(recorded_run, overrides={"estimation.orientation": "gps"})


def test_gymnasium_env_info_and_vector_env_observation():
    """SimSerpent-v0 puts the estimates into info (estimation on) and not otherwise; the Rust
    vector env's observation carries them like World's."""
    import gymnasium as gym

    from simserpent.envs import SimSerpentVectorEnv

    sets = {**RESTING, "env.observe_contact_estimates": True}
    env = gym.make("SimSerpent-v0", overrides=sets)
    obs, _ = env.reset(seed=1)
    obs, _, _, _, info = env.step(np.zeros(4, dtype=np.float32))
    c = info["contact_estimates"]
    assert c["active"] and c["floor_force_n"].shape == (5, 3)
    np.testing.assert_array_equal(obs[-20:].reshape(5, 4)[:, 0:2], c["obstacle_force_n"][:, 0:2])
    plain = gym.make("SimSerpent-v0", overrides=SMALL)
    plain.reset(seed=1)
    assert "contact_estimates" not in plain.step(np.zeros(4, dtype=np.float32))[4]
    vec = SimSerpentVectorEnv(num_envs=2, overrides=sets, threads=1)
    vobs, _ = vec.reset(seed=1)
    assert vobs.shape == (2, obs.shape[0])
    vobs, *_ = vec.step(np.zeros((2, 4), dtype=np.float32))
    single = simserpent.World(simserpent.load_config(overrides=sets))
    assert single.observation_names[-4:] == [f"link_04_{n}" for n in (
        "obstacle_force_x_n", "obstacle_force_y_n", "obstacle_contact", "obstacle_contact_point_along_m")]


# ------------------------------------------------- the estimator in the RL loop

#: Estimation on (friction identified online: the estimator's longest memory), every sensor noisy
#: with a random-walk bias, a quiet start, physical actions (target angles in rad).
IN_THE_LOOP = {
    **RESTING,
    "general.seed": 5,
    "estimation.friction": "identify",
    "sensors.noise_enabled": True,
    "sensors.joint_angle.std": 0.01,
    "sensors.joint_angle.bias_random_walk_per_sqrt_s": 0.01,
    "sensors.gyro.bias_random_walk_per_sqrt_s": 0.01,
    "sensors.accelerometer.bias_random_walk_per_sqrt_s": 0.05,
    "env.normalize_action": False,
    "env.observe_contact_estimates": True,
    "env.max_episode_secs": 10.0,
}


def wave_action(a, n=4):
    """Action number ``a``: joint target angles (rad) of a travelling wave."""
    return 0.6 * np.sin(0.35 * a - 0.9 * np.arange(n))


def assert_estimates_equal(x, y, what):
    assert x.keys() == y.keys(), what
    for key in x:
        np.testing.assert_array_equal(x[key], y[key], err_msg=f"{what}: {key}")


def test_set_state_with_estimation_and_noise_continues_bit_for_bit():
    """get_state/set_state carry the estimator's filters and the sensor models' state: a
    branch restored mid-episode gives the same observations and estimates bit for bit, in the
    same world, in a second world and through the Gymnasium env (whose info is restored too)."""
    cfg = simserpent.load_config(overrides=IN_THE_LOOP)
    w = simserpent.World(cfg)
    w.reset(3)
    for a in range(8):
        w.step(wave_action(a))
    state = w.get_state()

    def branch(world):
        out = []
        for a in range(8, 20):
            obs, r, term, trunc, info = world.step(wave_action(a))
            assert not term
            out.append((obs, r, world.contact_estimates()))
        return out

    first = branch(w)
    for a in range(30, 37):  # elsewhere
        w.step(wave_action(a))
    w.set_state(state)
    second = branch(w)
    other = simserpent.World(cfg)
    other.reset(77)
    for a in range(5):
        other.step(wave_action(a))
    other.set_state(state)
    third = branch(other)
    for k, (x, y, z) in enumerate(zip(first, second, third)):
        for i in range(2):
            np.testing.assert_array_equal(x[i], y[i], err_msg=f"action {k}")
            np.testing.assert_array_equal(x[i], z[i], err_msg=f"action {k}")
        assert_estimates_equal(x[2], y[2], f"action {k}")
        assert_estimates_equal(x[2], z[2], f"action {k}")
    # The floor carries the weight: on average over the branch (links lift and land while the
    # gait starts, so one instant's estimated support swings).
    assert np.mean([x[2]["floor_force_n"][:, 2].sum() for x in first]) > 1.0

    # The Gymnasium env: its info (distance from the episode's start, the estimates) too.
    from simserpent.envs import SimSerpentEnv

    env = SimSerpentEnv(config=cfg)
    env.reset(seed=4)
    for a in range(6):
        env.step(wave_action(a))
    saved = env.get_state()
    one = [env.step(wave_action(a)) for a in range(6, 12)]
    env.reset(seed=9)
    env.set_state(saved)
    two = [env.step(wave_action(a)) for a in range(6, 12)]
    for x, y in zip(one, two):
        np.testing.assert_array_equal(x[0], y[0])
        assert x[1] == y[1]
        assert x[4]["distance_from_origin"] == y[4]["distance_from_origin"]
        assert_estimates_equal(x[4]["contact_estimates"], y[4]["contact_estimates"], "env")


def test_reset_restarts_the_estimator():
    """A reset restarts the estimator's filters and its identified friction: the same seed
    gives the same episode after a long one as in a fresh world."""
    cfg = simserpent.load_config(overrides=IN_THE_LOOP)

    def episode(world):
        world.reset(2)
        return [(world.step(wave_action(a))[0], world.contact_estimates()) for a in range(8)]

    w = simserpent.World(cfg)
    first = episode(w)
    for a in range(50):
        w.step(wave_action(a))
    again = episode(w)
    fresh = episode(simserpent.World(cfg))
    for k, (x, y, z) in enumerate(zip(first, again, fresh)):
        np.testing.assert_array_equal(x[0], y[0])
        np.testing.assert_array_equal(x[0], z[0])
        assert_estimates_equal(x[1], y[1], f"action {k}")
        assert_estimates_equal(x[1], z[1], f"action {k}")


def test_world_estimates_equal_a_rust_run_holding_the_same_commands(tmp_path):
    """World senses every physics instant once (no second noise draw or estimator update where
    one action ends and the next begins): its measured joint angles and estimates after each
    action equal, bit for bit, those a Python controller sees at the same instant of one
    ``simserpent.run`` that holds the same commands for the same control periods."""
    cfg = simserpent.load_config(overrides=IN_THE_LOOP)
    w = simserpent.World(cfg)
    n_actions, substeps = 15, int(w.substeps)
    w.reset(5)  # the run's noise is seeded with general.seed = 5; no reset noise
    from_world = []
    for a in range(n_actions):
        obs = w.step(wave_action(a))[0]
        from_world.append((w.time, obs[:4].copy(), w.contact_estimates()))

    seen = []
    k = [0]

    def controller(o):
        if k[0] > 0 and k[0] % substeps == 0:
            seen.append((o["time_secs"], o["joint_angle_rad"].copy(), o["contacts"]))
        command = wave_action(k[0] // substeps).tolist()
        k[0] += 1
        return command

    duration = n_actions * substeps * w.timestep_secs
    run_cfg = cfg.with_overrides([f"general.duration_secs={duration!r}", 'control.method="position"'])
    summary = simserpent.run(run_cfg, run_folder=tmp_path / "held", controller=controller)
    assert simserpent.open_run(summary["run_folder"]).status == "complete"
    assert len(seen) == n_actions
    for a, ((t, angles, est), (t_run, angles_run, est_run)) in enumerate(zip(from_world, seen)):
        assert t == pytest.approx(t_run, abs=1e-12), a
        np.testing.assert_array_equal(angles, angles_run, err_msg=f"measured angles after action {a}")
        assert_estimates_equal(est, est_run, f"estimates after action {a}")


@pytest.mark.parametrize("threads", [1, 2])
def test_vector_env_with_estimation_equals_single_envs(threads):
    """The Rust vector env with the estimator in the loop and noisy sensors (observation with
    the estimates) equals single envs bit for bit, through an autoreset (next step)."""
    from simserpent.envs import SimSerpentEnv, SimSerpentVectorEnv

    sets = {**IN_THE_LOOP, "env.normalize_action": True, "env.max_episode_secs": 0.1}  # 5 actions
    n, seed = 2, 8
    vec = SimSerpentVectorEnv(num_envs=n, overrides=sets, threads=threads)
    singles = [SimSerpentEnv(overrides=sets) for _ in range(n)]
    obs, _ = vec.reset(seed=seed)
    for i, s in enumerate(singles):
        np.testing.assert_array_equal(obs[i], s.reset(seed=seed + i)[0])
    done = [False] * n
    for k in range(8):
        actions = np.stack([np.clip(wave_action(k + 3 * i), -1, 1) for i in range(n)]).astype(np.float32)
        obs, rewards, term, trunc, _ = vec.step(actions)
        for i, s in enumerate(singles):
            if done[i]:
                np.testing.assert_array_equal(obs[i], s.reset()[0])
                done[i] = False
                continue
            o, r, te, tr, _ = s.step(actions[i])
            np.testing.assert_array_equal(obs[i], o, err_msg=f"env {i}, step {k}")
            assert rewards[i] == r
            done[i] = te or tr
    vec.close()
