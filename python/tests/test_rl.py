"""RL with the libraries people use: rendering, true state and branching, Swimmer-v5
conventions, SB3's default entry points, vector-env autoreset/seeding, pickling, Python
controllers, gaits, and a seeded cross-entropy search that improves the return."""

import copy
import math
import pickle
import sys
import time

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import simserpent
from simserpent.envs import SimSerpentEnv, SimSerpentVectorEnv, episode_seeds

#: A small snake with the default [env] (reset noise, normalised actions, velocity reward).
SMALL = {"snake.n_links": 5, "terrain.kind": "none", "env.max_episode_secs": 0.2}
NOISY = {**SMALL, "sensors.noise_enabled": True, "sensors.joint_angle.std": 0.01}


def wave(t, n=4, amplitude=0.6):
    return (amplitude * np.sin(2 * np.pi * 1.0 * t - 0.8 * np.arange(n))).astype(np.float32)


# ---------------------------------------------------------------- rendering


@pytest.mark.parametrize("mode", ["rgb_array", "depth_array"])
def test_render_modes_draw_the_true_state(mode):
    env = gym.make("SimSerpent-v0", render_mode=mode, width=64, height=48, overrides=SMALL)
    assert env.metadata["render_fps"] == 50  # 1 / env.dt
    env.reset(seed=1)
    first = env.render()
    for k in range(5):
        env.step(wave(0.02 * k, amplitude=1.0))
    second = env.render()
    if mode == "rgb_array":
        assert first.shape == (48, 64, 3) and first.dtype == np.uint8
    else:
        assert first.shape == (48, 64) and first.dtype == np.float32
        assert np.isfinite(first).all() and first.max() > first.min()
    assert first.std() > 0 and not np.array_equal(first, second)
    # The renderer's MuJoCo data holds exactly the world's true state.
    r = env.unwrapped._renderer
    np.testing.assert_array_equal(r.data.qpos, env.unwrapped.world.qpos)
    np.testing.assert_array_equal(r.data.qvel, env.unwrapped.world.qvel)
    assert r.data.time == env.unwrapped.world.time
    env.close()


#: What a user runs on a headless server in a fresh process: make, check_env, draw a frame.
HEADLESS_SCRIPT = """
import os, gymnasium as gym, simserpent
from gymnasium.utils.env_checker import check_env
check_env(gym.make("SimSerpent-v0", overrides={"env.preset": "fast"}).unwrapped)
env = gym.make("SimSerpent-v0", overrides={"env.preset": "fast"}, render_mode="rgb_array", width=64, height=48)
env.reset(seed=0)
frame = env.render()
assert frame.shape == (48, 64, 3) and frame.std() > 0, frame.shape
print("MUJOCO_GL=" + os.environ.get("MUJOCO_GL", "<unset>"))
"""


def _headless_env(**extra):
    """This process's environment without a display and without MUJOCO_GL (the test suite's
    own conftest sets MUJOCO_GL; a user's shell on a server does not), plus ``extra``."""
    import os

    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY", "WAYLAND_DISPLAY", "PYOPENGL_PLATFORM")}
    env.update(extra)
    return env


def _run_python(code, env):
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)


def test_headless_without_mujoco_gl_makes_checks_and_renders():
    """gym.make, check_env and render_mode="rgb_array" in a fresh process with no display and
    no MUJOCO_GL: the package chooses EGL before `mujoco` is imported."""
    pytest.importorskip("mujoco")
    done = _run_python(HEADLESS_SCRIPT, _headless_env())
    assert done.returncode == 0, (done.returncode, done.stdout, done.stderr[-3000:])
    assert "MUJOCO_GL=egl" in done.stdout, done.stdout


def test_headless_keeps_the_users_mujoco_gl_and_says_what_to_set():
    """A user's MUJOCO_GL is kept; a `mujoco` imported with its window back-end (GLFW) and no
    display makes rendering raise an error saying what to set, instead of MuJoCo aborting."""
    pytest.importorskip("mujoco")
    code = """
import os, simserpent
assert os.environ["MUJOCO_GL"] == "glfw", os.environ["MUJOCO_GL"]
import gymnasium as gym
try:
    gym.make("SimSerpent-v0", render_mode="rgb_array")
except RuntimeError as e:
    print("refused:", e)
"""
    done = _run_python(code, _headless_env(MUJOCO_GL="glfw"))
    assert done.returncode == 0, (done.returncode, done.stdout, done.stderr[-3000:])
    assert "refused:" in done.stdout and "MUJOCO_GL=egl" in done.stdout, done.stdout
    # `mujoco` imported first, MUJOCO_GL unset: too late to choose EGL; the same error.
    done = _run_python("import mujoco\n" + code.replace('assert os.environ["MUJOCO_GL"] == "glfw", os.environ["MUJOCO_GL"]', 'assert "MUJOCO_GL" not in os.environ'), _headless_env())
    assert done.returncode == 0, (done.returncode, done.stdout, done.stderr[-3000:])
    assert "refused:" in done.stdout, done.stdout


def test_human_mode_needs_a_display(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(ValueError, match="needs a display"):
        SimSerpentEnv(overrides=SMALL, render_mode="human")
    with pytest.raises(ValueError, match="not supported"):
        SimSerpentEnv(overrides=SMALL, render_mode="ansi")


def test_sb3_default_entry_points_work():
    """What `PPO("MlpPolicy", "SimSerpent-v0")` and `make_vec_env("SimSerpent-v0")` do with a
    string id (stable-baselines3 2.x: gym.make(id, render_mode="rgb_array"), Monitor,
    DummyVecEnv), without torch: make, wrap, reset, step through an episode end, render."""
    try:
        from stable_baselines3.common.env_util import make_vec_env
    except ImportError:
        make_vec_env = None
    if make_vec_env is not None:  # pragma: no cover - SB3 is not a test dependency
        venv = make_vec_env("SimSerpent-v0", n_envs=2, env_kwargs={"overrides": SMALL})
        venv.reset()
        venv.step(np.zeros((2, 4), dtype=np.float32))
        venv.close()
    env = gym.make("SimSerpent-v0", render_mode="rgb_array", overrides=SMALL)
    env = gym.wrappers.RecordEpisodeStatistics(env)  # what SB3's Monitor records
    assert isinstance(env.action_space, gym.spaces.Box) and env.action_space.dtype == np.float32
    assert np.all(env.action_space.low == -1) and np.all(env.action_space.high == 1)
    assert env.spec.max_episode_steps == 10
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    for _ in range(20):
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs)
        if term or trunc:
            assert "episode" in info
            obs, _ = env.reset()
    assert env.render().ndim == 3
    env.close()


# ---------------------------------------------------------------- true state, branching


def test_true_state_and_bit_exact_branching():
    cfg = simserpent.load_config(overrides={**NOISY, "env.max_episode_secs": 10.0})
    w = simserpent.World(cfg)
    w.reset(3)
    nq = len(w.qpos)
    assert nq == 7 + 4 and len(w.qvel) == 6 + 4  # the head's free joint, 4 yaw joints
    assert w.time == 0.0
    for k in range(5):
        w.step(wave(0.02 * k))
    assert w.time == pytest.approx(0.1)
    state = w.get_state()
    np.testing.assert_array_equal(state.qpos, w.qpos)
    assert state.time == w.time

    def branch(world):
        out = []
        for k in range(5, 15):
            obs, r, term, trunc, info = world.step(wave(0.02 * k))
            out.append((obs, r, info["peak_contact_force_n"], world.qpos, world.qvel))
        return out

    first = branch(w)
    w.step(np.ones(4, dtype=np.float32))  # somewhere else
    w.set_state(state)
    second = branch(w)
    other = simserpent.World(cfg)  # a second world of the same config
    other.set_state(state)
    third = branch(other)
    for a, b, c in zip(first, second, third):
        for x, y, z in zip(a, b, c):
            np.testing.assert_array_equal(x, y)
            np.testing.assert_array_equal(x, z)
    # MuJoCo's own integration state, usable with mujoco.mj_setState.
    import mujoco

    model = mujoco.MjModel.from_xml_string(w.mjcf)
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, w.integration_state(), mujoco.mjtState.mjSTATE_INTEGRATION)
    np.testing.assert_array_equal(data.qpos, w.qpos)


# ---------------------------------------------------------------- Swimmer-v5 conventions


def test_reset_noise_depends_on_the_seed():
    env = SimSerpentEnv(overrides=SMALL)
    o7, i7 = env.reset(seed=7)
    q7 = env.world.qpos
    o8, _ = env.reset(seed=8)
    assert not np.array_equal(o7, o8) and not np.array_equal(q7, env.world.qpos)
    again, _ = env.reset(seed=7)
    np.testing.assert_array_equal(o7, again)
    np.testing.assert_array_equal(q7, env.world.qpos)
    # Joint angles within +-reset_noise_scale of the straight pose, velocities nonzero.
    assert np.all(np.abs(q7[7:]) <= 0.1) and np.any(q7[7:] != 0)
    # The heading: the head's quaternion turned about z by at most 0.1 rad.
    w, x, y, z = q7[3:7]
    assert abs(x) < 1e-12 and abs(y) < 1e-12 and 0 < abs(2 * math.atan2(z, w)) <= 0.1
    quiet = SimSerpentEnv(overrides={**SMALL, "env.reset_noise_scale": 0.0, "env.reset_heading_noise_rad": 0.0})
    a, _ = quiet.reset(seed=7)
    b, _ = quiet.reset(seed=8)
    np.testing.assert_array_equal(a, b)


def test_swimmer_conventions():
    env = gym.make("SimSerpent-v0", overrides=SMALL)
    u = env.unwrapped
    assert u.dt == 0.02
    assert env.spec.max_episode_steps == 10 and u.spec.max_episode_steps == 10
    assert "head_position_x_m" not in u.observation_names and "head_position_z_m" in u.observation_names
    assert env.action_space.dtype == np.float32
    obs, info = env.reset(seed=0)
    assert {"x_position", "y_position", "distance_from_origin"} <= set(info)
    for k in range(10):
        obs, r, term, trunc, info = env.step(wave(0.02 * k))
    assert trunc and not term
    for key in ["x_position", "y_position", "x_velocity", "y_velocity", "reward_forward", "reward_ctrl",
                "reward_energy", "reward_contact_force", "peak_contact_force_n", "distance_from_origin"]:
        assert key in info and np.isfinite(info[key]), key
    assert info["peak_contact_force_n"] > 0  # computed, not a fake 0.0
    # After truncation (a time limit) the physics goes on: still truncated, never terminated.
    t = u.world.time
    obs2, r2, term2, trunc2, info2 = u.step(wave(0.2))
    assert trunc2 and not term2 and u.world.time == pytest.approx(t + 0.02)
    # Default physics: the config's own; with x/y in the observation when asked.
    full = SimSerpentEnv(overrides={**SMALL, "env.exclude_current_positions_from_observation": False,
                                    "env.normalize_action": False})
    assert "head_position_x_m" in full.observation_names
    assert full.action_space.dtype == np.float64 and full.action_space.high[0] == pytest.approx(math.pi / 2)


def test_a_diverged_step_has_no_fake_peak_force():
    env = SimSerpentEnv(overrides={**SMALL, "env.action": "torque"})
    env.reset(seed=0)
    obs, r, term, trunc, info = env.step(np.full(4, np.nan))
    assert term and "peak_contact_force_n" not in info
    assert "mjWARN_BADCTRL" in info["error"]


def test_world_step_accepts_float32_arrays_and_lists():
    w = simserpent.World(simserpent.load_config(overrides={**SMALL, "env.reset_noise_scale": 0.0,
                                                           "env.reset_heading_noise_rad": 0.0}))
    a64 = np.array([0.5, -0.25, 0.125, 1.0])
    results = []
    for a in [a64, a64.astype(np.float32), a64.tolist(), tuple(a64), a64[::1].copy()]:
        w.reset(0)
        results.append(w.step(a)[0])
    for r in results[1:]:
        np.testing.assert_array_equal(results[0], r)
    with pytest.raises(ValueError, match="4 joints"):
        w.step([0.0, 1.0])
    with pytest.raises(TypeError, match="sequence of 4 real numbers"):
        w.step("abcd")


# ---------------------------------------------------------------- vector env


def run_singles(singles, actions_per_step, seeds):
    """Singles as Gymnasium's SyncVectorEnv runs them (NEXT_STEP autoreset)."""
    obs = [s.reset(seed=seed)[0] for s, seed in zip(singles, seeds)]
    out = [np.stack(obs)]
    done = [False] * len(singles)
    for actions in actions_per_step:
        row = []
        for i, s in enumerate(singles):
            if done[i]:
                o, _ = s.reset()
                done[i] = False
            else:
                o, r, te, tr, _ = s.step(actions[i])
                done[i] = te or tr
            row.append(o)
        out.append(np.stack(row))
    return out


def test_one_seed_to_noise_mapping_in_every_vectorisation_mode():
    n, steps = 3, 14
    actions = [np.stack([wave(0.02 * k + i) for i in range(n)]) for k in range(steps)]
    results = {}
    for mode in ["vector_entry_point", "sync"]:
        vec = gym.make_vec("SimSerpent-v0", num_envs=n, vectorization_mode=mode, overrides=NOISY)
        obs, info = vec.reset(seed=21)
        rows = [obs]
        for a in actions:
            rows.append(vec.step(a)[0])
        results[mode] = rows
        vec.close()
    for a, b in zip(results["vector_entry_point"], results["sync"]):
        np.testing.assert_array_equal(a, b)
    singles = [SimSerpentEnv(overrides=NOISY) for _ in range(n)]
    for a, b in zip(results["vector_entry_point"], run_singles(singles, actions, [21, 22, 23])):
        np.testing.assert_array_equal(a, b)
    assert episode_seeds(5, 2) == episode_seeds(5, 2) != episode_seeds(6, 2)


def test_per_env_seed_lists_and_seed_mask():
    vec = SimSerpentVectorEnv(num_envs=3, overrides=NOISY, threads=1)
    obs, info = vec.reset(seed=[10, 99, 99])
    np.testing.assert_array_equal(obs[1], obs[2])
    assert not np.array_equal(obs[0], obs[1])
    single = SimSerpentEnv(overrides=NOISY)
    np.testing.assert_array_equal(obs[0], single.reset(seed=10)[0])
    np.testing.assert_array_equal(info["env_seed"], [10, 99, 99])
    assert info["_seed"].all()


def test_reset_mask_resets_only_those_envs():
    n = 3
    vec = SimSerpentVectorEnv(num_envs=n, overrides={**NOISY, "env.max_episode_secs": 10.0}, threads=1)
    singles = [SimSerpentEnv(overrides={**NOISY, "env.max_episode_secs": 10.0}) for _ in range(n)]
    vec.reset(seed=0)
    for i, s in enumerate(singles):
        s.reset(seed=i)
    for k in range(3):
        a = np.stack([wave(0.02 * k + i) for i in range(n)])
        obs, *_ = vec.step(a)
        for i, s in enumerate(singles):
            s.step(a[i])
    before = obs.copy()
    mask = np.array([True, False, True])
    obs, info = vec.reset(seed=[50, 60, 70], options={"reset_mask": mask})
    np.testing.assert_array_equal(info["_seed"], mask)
    np.testing.assert_array_equal(obs[1], before[1])
    np.testing.assert_array_equal(obs[0], singles[0].reset(seed=50)[0])
    np.testing.assert_array_equal(obs[2], singles[2].reset(seed=70)[0])
    # Env 1 goes on with its episode as a single env does.
    a = np.stack([wave(0.5 + i) for i in range(n)])
    obs, *_ = vec.step(a)
    for i, s in enumerate(singles):
        np.testing.assert_array_equal(obs[i], s.step(a[i])[0])


@pytest.mark.parametrize("threads", [1, 2])
def test_same_step_autoreset(threads):
    n, steps = 2, 12
    vec = SimSerpentVectorEnv(num_envs=n, overrides=NOISY, threads=threads, autoreset_mode="same_step")
    assert vec.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    singles = [SimSerpentEnv(overrides=NOISY) for _ in range(n)]
    obs, _ = vec.reset(seed=4)
    for i, s in enumerate(singles):
        np.testing.assert_array_equal(obs[i], s.reset(seed=4 + i)[0])
    ends = 0
    for k in range(steps):
        a = np.stack([wave(0.02 * k + i) for i in range(n)])
        obs, rewards, term, trunc, info = vec.step(a)
        for i, s in enumerate(singles):
            o, r, te, tr, inf = s.step(a[i])
            assert rewards[i] == r and trunc[i] == tr and term[i] == te
            if te or tr:
                ends += 1
                assert info["_final_obs"][i]
                np.testing.assert_array_equal(info["final_obs"][i], o)
                assert info["final_info"]["energy_j"][i] == inf["energy_j"]
                np.testing.assert_array_equal(obs[i], s.reset()[0])
            else:
                np.testing.assert_array_equal(obs[i], o)
    assert ends == n


def test_sb3_adapter_protocol():
    from simserpent.sb3 import SB3VecEnv

    venv = SB3VecEnv(num_envs=2, overrides=NOISY, threads=1)
    venv.seed(3)
    obs = venv.reset()
    assert obs.shape == (2, venv.observation_space.shape[0]) and obs.dtype == venv.observation_space.dtype
    singles = [SimSerpentEnv(overrides=NOISY) for _ in range(2)]
    for i, s in enumerate(singles):
        np.testing.assert_array_equal(obs[i], s.reset(seed=3 + i)[0])
    for k in range(10):
        a = np.stack([wave(0.02 * k + i) for i in range(2)])
        obs, rewards, dones, infos = venv.step(a)
    assert dones.all()
    for i, s in enumerate(singles):
        for k in range(10):
            last = s.step(wave(0.02 * k + i))[0]
        np.testing.assert_array_equal(infos[i]["terminal_observation"], last)
        assert infos[i]["TimeLimit.truncated"]
        np.testing.assert_array_equal(obs[i], s.reset()[0])


# ---------------------------------------------------------------- ergonomics


def test_config_pickles_and_copies():
    cfg = simserpent.load_config(overrides={"snake.n_links": 6})
    again = pickle.loads(pickle.dumps(cfg))
    assert again == cfg and again.to_toml() == cfg.to_toml() and again.source == cfg.source
    assert copy.deepcopy(cfg) == cfg and copy.copy(cfg) == cfg
    assert cfg != simserpent.load_config()


def test_async_vector_env_with_spawn_and_a_config_object():
    cfg = simserpent.load_config(overrides=NOISY)
    vec = gym.make_vec("SimSerpent-v0", num_envs=2, vectorization_mode="async",
                       vector_kwargs={"context": "spawn"}, config=cfg)
    obs, _ = vec.reset(seed=1)
    single = SimSerpentEnv(config=cfg)
    np.testing.assert_array_equal(obs[0], single.reset(seed=1)[0])
    vec.step(np.zeros((2, 4), dtype=np.float32))
    vec.close()


def test_gait_is_callable_from_python():
    g = simserpent.Gait(overrides={"snake.n_links": 5})
    a, v = g.targets(3.0)  # after the 1 s ramp: 30 deg amplitude, 0.5 Hz, 40 deg lag
    j = np.arange(4)
    np.testing.assert_allclose(a, np.radians(30) * np.sin(2 * np.pi * 0.5 * 3.0 - j * np.radians(40)), atol=1e-12)
    np.testing.assert_allclose(v, np.radians(30) * np.pi * np.cos(2 * np.pi * 0.5 * 3.0 - j * np.radians(40)),
                               atol=1e-12)
    assert np.all(g.targets(0.0)[0] == 0)  # the ramp starts at rest
    np.testing.assert_allclose(g.action(3.0), a / np.radians(90), atol=1e-6)
    assert g.action(3.0).dtype == np.float32


def test_run_with_a_python_controller_records_a_normal_run(tmp_path):
    # The built-in open-loop gait (the default job's controller is path following).
    sets = {"snake.n_links": 4, "terrain.kind": "none", "general.duration_secs": 0.3, "control.controller": "gait"}
    gait = simserpent.Gait(overrides=sets)
    calls = []

    def controller(obs):
        calls.append(obs["time_secs"])
        return gait(obs["time_secs"])

    mine = simserpent.run(overrides=sets, run_folder=tmp_path / "python", controller=controller)
    builtin = simserpent.run(overrides=sets, run_folder=tmp_path / "builtin")
    assert len(calls) == 301  # every instant 0 ..= 300 ms
    run = simserpent.open_run(mine["run_folder"])
    assert run.status == "complete"
    # The same targets as the built-in gait give the same trajectory (position servos).
    for key in ["distance_m", "forward_speed_m_per_s", "actuator_energy_j"]:
        assert mine[key] == builtin[key], key
    ref = simserpent.open_run(builtin["run_folder"])
    assert run.links.equals(ref.links)

    def broken(obs):
        if obs["time_secs"] > 0.1:
            raise ZeroDivisionError("bug in the controller")
        return [0.0] * 3

    with pytest.raises(simserpent.SimSerpentError, match="Python controller") as e:
        simserpent.run(overrides=sets, run_folder=tmp_path / "broken", controller=broken)
    assert isinstance(e.value.__cause__, ZeroDivisionError)
    assert simserpent.open_run(tmp_path / "broken").status == "failed"
    with pytest.raises(simserpent.SimSerpentError) as e:
        simserpent.run(overrides=sets, run_folder=tmp_path / "short", controller=lambda obs: [0.0])
    assert "3 joints" in str(e.value.__cause__)


def test_joint_sign_convention():
    """simserpent.JOINT_SIGN_CONVENTION, checked: hold joint 1 at a positive angle on a straight
    snake and look where the link behind it goes."""
    sets = {**SMALL, "snake.n_links": 2, "env.reset_noise_scale": 0.0, "env.reset_heading_noise_rad": 0.0,
            "env.normalize_action": False}
    w = simserpent.World(simserpent.load_config(overrides=sets))
    w.reset(0)
    head_q = w.qpos[3:7]
    for _ in range(50):
        w.step([0.5])
    assert w.qpos[7] == pytest.approx(0.5, abs=0.05)
    # The tail link's orientation relative to the head: yaw by +q about z (counter-clockwise).
    import mujoco

    model = mujoco.MjModel.from_xml_string(w.mjcf)
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, w.integration_state(), mujoco.mjtState.mjSTATE_INTEGRATION)
    mujoco.mj_forward(model, data)
    head = model.body("link_00").id
    tail = model.body("link_01").id
    hx = data.xmat[head].reshape(3, 3)[:, 0]
    tx = data.xmat[tail].reshape(3, 3)[:, 0]
    # Head frame: +x forward (the heading). The tail's centre lies behind and to the head's right.
    rel = data.xipos[tail] - data.xpos[head]
    hy = data.xmat[head].reshape(3, 3)[:, 1]
    assert np.dot(rel, hx) < 0
    assert np.dot(rel, hy) < 0, "positive angle: the link behind the joint swings to the right (-y of the head)"
    assert np.cross(hx, tx)[2] > 0  # the tail's axis is turned counter-clockwise from the head's
    assert head_q is not None
    assert "to the right" in simserpent.JOINT_SIGN_CONVENTION
    # And the gait offset: positive turns right (the head's yaw falls), negative turns left.
    turns = {}
    for off in (15.0, -15.0):
        o = {"terrain.kind": "none", "gait.sine_wave.offset_deg": off, "env.preset": "fast",
             "env.reset_noise_scale": 0.0, "env.reset_heading_noise_rad": 0.0, "env.max_episode_secs": 4.0}
        cfg = simserpent.load_config(overrides=o)
        env, gait = SimSerpentEnv(cfg), simserpent.Gait(cfg)
        env.reset(seed=0)
        for k in range(200):
            env.step(gait.action(k * 0.02))
        q = env.world.qpos[3:7]
        turns[off] = 2 * math.atan2(q[3], q[0])
    assert turns[15.0] < -0.5 and turns[-15.0] > 0.5, turns
    assert "turns right" in simserpent.JOINT_SIGN_CONVENTION


# ---------------------------------------------------------------- learning without torch


def test_cross_entropy_improves_the_return_on_the_vector_env():
    """A seeded cross-entropy search over a travelling-wave policy (amplitude, frequency, phase
    lag, in normalised units) on the Rust vector env: the elite mean return rises within a
    bounded time."""
    rng = np.random.default_rng(0)
    pop, elite, iterations, horizon = 12, 3, 4, 25
    vec = SimSerpentVectorEnv(num_envs=pop, overrides={**SMALL, "env.max_episode_secs": horizon * 0.02},
                              threads=2)
    n = vec.single_action_space.shape[0]
    mean, std = np.array([0.1, 0.5, 0.0]), np.array([0.4, 0.5, 1.0])
    start = time.perf_counter()
    means = []
    for it in range(iterations):
        params = mean + std * rng.standard_normal((pop, 3))
        vec.reset(seed=100)  # the same starts for every candidate: a fair comparison
        returns = np.zeros(pop)
        for k in range(horizon):
            t = 0.02 * k
            amp, freq, lag = np.clip(params[:, 0:1], -1, 1), np.abs(params[:, 1:2]) * 2.0, params[:, 2:3]
            a = (amp * np.sin(2 * np.pi * freq * t - lag * np.arange(n))).astype(np.float32)
            _, r, term, trunc, _ = vec.step(a)
            returns += r
        best = np.argsort(returns)[-elite:]
        means.append(returns[best].mean())
        mean, std = params[best].mean(axis=0), params[best].std(axis=0) + 0.05
    elapsed = time.perf_counter() - start
    assert means[-1] > means[0] + 0.05, means
    assert elapsed < 120, elapsed


# ---------------------------------------------------------------- progress and heading


def test_run_reports_progress_to_a_callable_a_bar_or_nobody(tmp_path, capsys, monkeypatch):
    sets = {"snake.n_links": 4, "terrain.kind": "none", "general.duration_secs": 3.0}
    seen = []
    simserpent.run(overrides=sets, run_folder=tmp_path / "callable", progress=lambda done, total: seen.append((done, total)))
    total = 3000  # 3 s of 1-ms steps
    assert seen[-1] == (total, total) and all(t == total for _, t in seen)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen) and len(seen) >= 3, seen
    capsys.readouterr()
    # Default: a bar only on a terminal (the captured stderr is none), so nothing here.
    simserpent.run(overrides=sets, run_folder=tmp_path / "quiet")
    assert capsys.readouterr().err == ""
    simserpent.run(overrides=sets, run_folder=tmp_path / "bar", progress=True)
    err = capsys.readouterr().err
    assert f"100% {total}/{total} steps" in err and err.endswith("\n"), err
    # An exception in the callable is reported (sys.unraisablehook) and does not stop the run.
    def broken(done, total):
        raise RuntimeError("progress display broke")

    reported = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: reported.append(u.exc_value))
    s = simserpent.run(overrides=sets, run_folder=tmp_path / "broken", progress=broken)
    assert simserpent.open_run(s["run_folder"]).status == "complete"
    assert reported and all("progress display broke" in str(e) for e in reported)
    with pytest.raises(TypeError, match="progress must be"):
        simserpent.run(overrides=sets, run_folder=tmp_path / "bad", progress="yes")


def test_oal_bench_reports_progress_in_runs(tmp_path):
    seen = []
    small = dict(quick=True, floors=["isotropic"], families=["random"], laws=False, tuning_fields=1,
                 held_out_fields=1, duration_secs=2.0, passive_kp_nm_per_rad=[5.0], threads=2)
    simserpent.oal_bench(out=tmp_path, progress=lambda done, total: seen.append((done, total)), **small)
    # Every run is reported once: the runs done count up to the total, which is known in full
    # once the tuning fields have chosen the held-out conditions (the last report).
    done = sorted(d for d, _ in seen)
    assert done == list(range(1, len(seen) + 1)), seen
    assert all(d <= t for d, t in seen), seen
    assert max(t for _, t in seen) == len(seen) and len(seen) >= 4, seen


def test_head_yaw_is_counter_clockwise_seen_from_above(tmp_path):
    for angle in (0.0, 0.5, -1.2, 3.0):
        q = [math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)]
        assert simserpent.head_yaw(q) == pytest.approx(angle, abs=1e-12)
    with pytest.raises(TypeError, match="quaternion"):
        simserpent.head_yaw("north")
    # A snake bent by a positive offset turns right (clockwise): its yaw falls.
    sets = {"snake.n_links": 6, "terrain.kind": "none", "general.duration_secs": 3.0, "control.controller": "gait",
            "recording.every_n_steps": 100}
    gait = simserpent.Gait(overrides=sets)
    seen = {}

    def steer(obs):
        assert obs["head_yaw_rad"] == simserpent.head_yaw(obs["head_quat"])
        seen[round(obs["time_secs"], 6)] = simserpent.head_yaw(obs)
        return gait(obs["time_secs"]) + 0.3

    simserpent.run(overrides=sets, run_folder=tmp_path / "turn", controller=steer)
    head = np.unwrap([seen[t] for t in sorted(seen)])  # every instant: no jump is missed
    assert head[-1] - head[0] < -0.2, (head[0], head[-1])


@pytest.mark.parametrize(
    "joint_axes, gait_kind, offset_rad",
    [("yaw", "sine_wave", 0.3), ("alternating", "sidewinding", 0.0)],
)
def test_link_yaws_are_the_recorded_links_yaws_at_every_step(tmp_path, joint_axes, gait_kind, offset_rad):
    """link_yaws(obs) at every step equals each link's yaw computed from its orientation in
    links.csv (recorded every step) at the same instant, while the links tilt: the 6-link snake
    bent at once by 0.3 rad rolls its head by up to 0.38 rad, where the planar sum of the joint
    angles is 0.07 rad off on the tail; sidewinding lifts links with its pitch joints."""
    n = 6
    sets = {"snake.n_links": n, "terrain.kind": "none", "general.duration_secs": 3.0, "control.controller": "gait",
            "recording.every_n_steps": 1, "snake.joint_axes": joint_axes, "gait.kind": gait_kind}
    gait = simserpent.Gait(overrides=sets)
    seen, planar = {}, {}

    def steer(obs):
        t = round(obs["time_secs"], 6)
        seen[t] = simserpent.link_yaws(obs, joint_axes)
        planar[t] = simserpent.head_yaw(obs) + np.concatenate(([0.0], np.cumsum(obs["joint_angle_rad"])))
        return gait(obs["time_secs"]) + offset_rad

    summary = simserpent.run(overrides=sets, run_folder=tmp_path / "run", controller=steer)
    links = simserpent.open_run(summary["run_folder"]).links
    times = links["time_s"].round(6).to_numpy()
    assert len(times) == 3001 and all(t in seen for t in times)
    worst, worst_planar = 0.0, 0.0
    for i in range(n):
        qw, qx, qy, qz = (links[f"link_{i:02d}_orientation_q{c}"].to_numpy() for c in "wxyz")
        truth = np.arctan2(2 * (qx * qy + qw * qz), 1 - 2 * (qy * qy + qz * qz))  # the link's +x axis
        mine = np.array([seen[t][i] for t in times])
        worst = max(worst, np.abs(np.angle(np.exp(1j * (mine - truth)))).max())
        old = np.array([planar[t][i] for t in times])
        worst_planar = max(worst_planar, np.abs(np.angle(np.exp(1j * (old - truth)))).max())
    assert worst < 1e-9, worst
    assert worst_planar > 0.03, worst_planar  # the case needs more than the planar sum
    with pytest.raises(ValueError, match="joint_axes"):
        simserpent.link_yaws({"joint_angle_rad": [0.0], "head_quat": [1, 0, 0, 0]}, "pitch")


def test_the_guide_tables_match_the_env():
    """The Gymnasium page's action and observation tables (per index) are the env's layout."""
    import re
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "guide/src/tutorials/gymnasium.md").read_text(encoding="utf-8")
    env = SimSerpentEnv()  # the default config, as the page describes it
    names = env.observation_names

    def rows(heading):
        section = page.split(heading, 1)[1].split("\n### ", 1)[0]
        found = [[c.strip() for c in line.strip().strip("|").split("|")]
                 for line in section.splitlines() if re.match(r"\| (\d|\*)", line)]
        return section, found

    section, table = rows("### Observation space")
    assert f"Box(-inf, inf, ({len(names)},), float64)" in section
    covered = []
    for cells in table:
        lo, _, hi = cells[0].partition("–")
        lo, hi = int(lo), int(hi or lo)
        listed = re.findall(r"`([^`]+)`", cells[1])
        assert (names[lo], names[hi]) == (listed[0], listed[-1]), cells
        covered.extend(range(lo, hi + 1))
    assert covered == list(range(len(names)))
    assert env.observation_space.shape == (len(names),)

    section, table = rows("### Action space")
    n = env.action_space.shape[0]
    assert f"Box(-1.0, 1.0, ({n},), float32)" in section
    numbered = {int(c[0]): re.findall(r"`(joint_\d\d)`", c[1])[0] for c in table if c[0].isdigit()}
    assert numbered == {0: "joint_01", n - 1: f"joint_{n:02d}"}
    # Action i is joint i+1's target angle (rad = action x joint_range_deg): hold one, read it back.
    env.reset(seed=0)
    action = np.zeros(n, dtype=np.float32)
    action[n - 1] = 0.5
    for _ in range(50):
        obs, *_ = env.step(action)
    assert names.index(f"joint_{n:02d}_angle_rad") == n - 1
    assert obs[n - 1] == pytest.approx(0.5 * math.pi / 2, abs=0.05), obs[:n]
    assert abs(obs[0]) < 0.05
