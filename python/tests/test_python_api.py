"""The Python conventions of the package: Gymnasium's checker headless, saved states that pickle
and deep-copy, a render camera that frames the snake, plots and pictures of a run folder from
Python, and clear errors for bad arguments."""

from __future__ import annotations

import copy
import pickle
import shutil
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import simserpent
from simserpent.envs import SimSerpentEnv

from conftest import cli

SMALL = {"snake.n_links": 5, "terrain.kind": "none", "env.max_episode_secs": 0.2}


def wave(t: float, n: int = 4, amplitude: float = 0.6) -> np.ndarray:
    return (amplitude * np.sin(2 * np.pi * 1.0 * t - 0.8 * np.arange(n))).astype(np.float32)


# ---------------------------------------------------------------- Gymnasium's checker, headless


def test_check_env_with_its_defaults_passes_headless(monkeypatch):
    """check_env(env) renders every mode in metadata["render_modes"] (through env.spec.make);
    without a display "human" is not listed, the offscreen modes are and draw."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    env = gym.make("SimSerpent-v0", overrides=SMALL)
    assert env.unwrapped.metadata["render_modes"] == ["rgb_array", "depth_array"]
    check_env(env.unwrapped)
    # With a display, "human" is listed as Gymnasium's MuJoCo envs list it.
    monkeypatch.setenv("DISPLAY", ":99")
    assert SimSerpentEnv(overrides=SMALL).metadata["render_modes"] == ["human", "rgb_array", "depth_array"]


def test_without_the_mujoco_package_no_render_mode_is_listed(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # `import mujoco` fails, find_spec gives None
    env = SimSerpentEnv(overrides=SMALL)
    assert env.metadata["render_modes"] == []
    obs, _ = env.reset(seed=0)
    assert np.isfinite(obs).all()
    with pytest.raises(ImportError, match="pip install mujoco"):
        SimSerpentEnv(overrides=SMALL, render_mode="rgb_array")


# ---------------------------------------------------------------- saved states


def branch(world: simserpent.World, start: int, n: int = 8) -> list[tuple]:
    out = []
    for k in range(start, start + n):
        obs, r, term, trunc, info = world.step(wave(0.02 * k))
        out.append((obs, r, world.qpos, world.qvel, world.time))
    return out


def assert_same(a: list[tuple], b: list[tuple]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b):
        for u, v in zip(x, y):
            np.testing.assert_array_equal(u, v)


def test_saved_states_pickle_and_deep_copy_bit_for_bit():
    cfg = simserpent.load_config(
        overrides={**SMALL, "env.max_episode_secs": 10.0, "sensors.noise_enabled": True,
                   "sensors.joint_angle.std": 0.01}
    )
    w = simserpent.World(cfg)
    w.reset(3)
    branch(w, 0, 5)
    state = w.get_state()
    assert state.steps == 5
    pickled = pickle.loads(pickle.dumps(state))
    copied = copy.deepcopy(state)
    shallow = copy.copy(state)
    np.testing.assert_array_equal(pickled.qpos, state.qpos)
    assert pickled.time == state.time and pickled.steps == 5
    reference = branch(w, 5)
    for s in (state, pickled, copied, shallow):
        other = simserpent.World(cfg)
        other.set_state(s)
        assert_same(branch(other, 5), reference)
    # A state reached after set_state (its episode goes on from the restored one) pickles too.
    w.set_state(state)
    branch(w, 5, 3)
    later = w.get_state()
    assert later.steps == 8
    again = simserpent.World(cfg)
    again.set_state(pickle.loads(pickle.dumps(later)))
    assert_same(branch(again, 8), branch(w, 8))


def test_a_saved_state_goes_to_a_worker_process():
    """The pickled state crosses a process boundary (what a replay buffer or a worker needs)."""
    cfg = simserpent.load_config(overrides={**SMALL, "env.max_episode_secs": 10.0})
    w = simserpent.World(cfg)
    w.reset(11)
    branch(w, 0, 4)
    blob = pickle.dumps(w.get_state())
    code = (
        "import pickle, sys, numpy as np, simserpent\n"
        "s = pickle.loads(sys.stdin.buffer.read())\n"
        "sys.stdout.write(repr(float(s.time)) + ' ' + repr(np.asarray(s.qpos).tolist()))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], input=blob, capture_output=True, check=True)
    t, qpos = out.stdout.decode().split(" ", 1)
    assert float(t) == w.time and eval(qpos) == w.qpos.tolist()


def test_a_tampered_pickle_is_refused():
    cfg = simserpent.load_config(overrides={**SMALL, "env.max_episode_secs": 10.0})
    w = simserpent.World(cfg)
    w.reset(1)
    branch(w, 0, 3)
    f, args = w.get_state().__reduce__()
    toml, source, seed, actions, time, qpos = args
    with pytest.raises(simserpent.SimSerpentError, match="replaying its episode"):
        f(toml, source, seed, actions, time, [q + 1.0 for q in qpos])
    # Malformed: actions that are not whole steps of the action size, non-finite actions, an
    # infinite time: refused naming what is wrong (before any replay), never a Rust panic.
    n = w.action_size
    assert len(actions) == 3 * n
    with pytest.raises(simserpent.SimSerpentError, match=f"has {3 * n - 1} values, not a whole number of steps of this world's {n} actions"):
        f(toml, source, seed, actions[:-1], time, qpos)
    with pytest.raises(simserpent.SimSerpentError, match="action value 2 is NaN"):
        f(toml, source, seed, actions[:2] + [float("nan")] + actions[3:], time, qpos)
    with pytest.raises(simserpent.SimSerpentError, match="time or qpos is not finite"):
        f(toml, source, seed, actions, float("inf"), qpos)


def test_states_cross_machines_as_checked_bytes():
    """to_bytes/from_bytes: the same state bit for bit; every damaged or hostile blob refused as
    a SimSerpentError naming the field (a pickle of the same would run code)."""
    cfg = simserpent.load_config(overrides={**SMALL, "env.max_episode_secs": 10.0})
    w = simserpent.World(cfg)
    w.reset(5)
    branch(w, 0, 4)
    blob = w.get_state().to_bytes()
    assert blob[:16] == b"SimSerpentState\0"
    back = simserpent.WorldState.from_bytes(blob)
    assert back.steps == 4 and back.time == w.time
    np.testing.assert_array_equal(back.qpos, w.qpos)
    other = simserpent.World(cfg)
    other.set_state(back)
    assert_same(branch(other, 4), branch(w, 4))
    for damaged, message in [
        (b"", "no SimSerpentState magic"),
        (b"\x80\x04K\x01." + blob, "no SimSerpentState magic"),
        (blob[:16] + (2).to_bytes(4, "little") + blob[20:], "layout version 2"),
        (blob[:20] + (2**63).to_bytes(8, "little") + blob[28:], "config: 9223372036854775808 items, more than"),
        (blob[:-3], "qpos: cut short|qpos: .* items"),
        (blob + b"x", "1 bytes after the last field"),
    ]:
        with pytest.raises(simserpent.SimSerpentError, match=message):
            simserpent.WorldState.from_bytes(damaged)
    # A config that is not valid is refused as any config is.
    toml = w.get_state().__reduce__()[1][0]
    bad = toml.replace("[snake]", "[snake]\nn_links = 100000", 1)
    encoded = bad.encode()
    forged = blob[:20] + len(encoded).to_bytes(8, "little") + encoded + blob[28 + len(toml.encode()):]
    with pytest.raises(simserpent.SimSerpentError, match="n_links"):
        simserpent.WorldState.from_bytes(forged)


# ---------------------------------------------------------------- the render camera


def snake_extent(env: SimSerpentEnv) -> tuple[float, float, float]:
    """(largest side of the snake's pixel bounding box / picture size, centre column and row /
    picture size) in the env's current picture, from MuJoCo's segmentation rendering with the
    env's own camera."""
    import mujoco

    env.render()
    r = env._renderer
    seg = mujoco.Renderer(r.model, r.height, r.width)
    seg.enable_segmentation_rendering()
    seg.update_scene(r.data, camera=r.camera)
    ids = seg.render()
    seg.close()
    links = [i for i in range(r.model.nbody) if mujoco.mj_id2name(r.model, mujoco.mjtObj.mjOBJ_BODY, i).startswith("link_")]
    geom, kind = ids[..., 0], ids[..., 1]
    is_geom = kind == int(mujoco.mjtObj.mjOBJ_GEOM)
    body = np.where(is_geom, r.model.geom_bodyid[np.clip(geom, 0, r.model.ngeom - 1)], -1)
    mask = np.isin(body, links)
    rows, cols = np.nonzero(mask)
    assert len(rows) > 0, "the snake is not in the picture"
    size = max(r.width, r.height)
    extent = max(cols.max() - cols.min() + 1, rows.max() - rows.min() + 1) / size
    return extent, (cols.min() + cols.max()) / 2 / r.width, (rows.min() + rows.max()) / 2 / r.height


def test_the_render_camera_follows_the_snake_and_frames_it():
    """Default config (10 links, 2 m), default camera: the snake spans at least a third of the
    picture at every sampled instant of a gait episode, and stays near the middle."""
    env = SimSerpentEnv(render_mode="rgb_array", width=240, height=240, overrides={"env.max_episode_secs": 6.0})
    gait = simserpent.Gait(env.config)
    env.reset(seed=0)
    extents = []
    for k in range(250):
        env.step(gait.action(k * env.dt))
        if k % 50 == 49:
            extent, cx, cy = snake_extent(env)
            extents.append(extent)
            assert 0.3 < cx < 0.7 and 0.3 < cy < 0.7, (k, cx, cy)
    assert min(extents) >= 1 / 3, extents
    # It moved: the camera followed it.
    assert np.hypot(*np.subtract(env.world.centre_of_mass[:2], env.world.start_centre_of_mass[:2])) > 0.05
    # Configurable: four times as far, about a quarter as large.
    far = SimSerpentEnv(render_mode="rgb_array", width=240, height=240, camera_distance_m=10.0)
    far.reset(seed=0)
    near = SimSerpentEnv(render_mode="rgb_array", width=240, height=240)
    near.reset(seed=0)
    ratio = snake_extent(far)[0] / snake_extent(near)[0]
    assert 0.2 < ratio < 0.35, ratio
    with pytest.raises(ValueError, match="camera_distance_m"):
        SimSerpentEnv(render_mode="rgb_array", camera_distance_m=-1.0)


# ---------------------------------------------------------------- plots and pictures from Python


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs") / "run"
    simserpent.run(
        overrides={"snake.n_links": 5, "terrain.kind": "none", "general.duration_secs": 0.4,
                   "recording.every_n_steps": 10, "render.width_px": 96, "render.height_px": 64},
        run_folder=folder,
    )
    return folder


def test_plot_writes_the_cli_files(short_run, tmp_path):
    folder = tmp_path / "py"
    shutil.copytree(short_run, folder)
    files = simserpent.plot(folder)
    assert files and all(f.is_file() and f.parent == folder / "plots" for f in files)
    assert {f.suffix for f in files} == {".png", ".svg"}
    binary = cli()
    if binary is None:
        pytest.skip("no built simserpent CLI to compare with")
    other = tmp_path / "cli"
    shutil.copytree(short_run, other)
    subprocess.run([str(binary), "plot", str(other)], check=True, capture_output=True)
    assert sorted(p.name for p in (other / "plots").iterdir()) == sorted(f.name for f in files)


def test_render_writes_images_and_a_video(short_run, tmp_path):
    folder = tmp_path / "run"
    shutil.copytree(short_run, folder)
    images = simserpent.render(folder, video=False, images=True,
                               overrides={"render.image_times_secs": [0.0, 0.3]})
    assert [p.name for p in images] == ["follow_0.000s.png", "follow_0.300s.png"]
    assert all(p.read_bytes().startswith(b"\x89PNG") for p in images)
    video = simserpent.render(folder, overrides={"video.format": "gif"})
    assert [p.name for p in video] == ["video_follow.gif"] and video[0].read_bytes().startswith(b"GIF8")
    with pytest.raises(ValueError, match="nothing to render"):
        simserpent.render(folder, video=False, images=False)
    with pytest.raises(simserpent.ConfigError, match="render.image_times_secs"):
        simserpent.render(folder, video=False, images=True)
    with pytest.raises(simserpent.RenderError, match="not a run folder"):
        simserpent.render(tmp_path / "nothing")
    with pytest.raises(simserpent.PlotError, match="not a run folder"):
        simserpent.plot(tmp_path / "nothing")


# ---------------------------------------------------------------- clear errors


def test_bad_arguments_get_clear_errors():
    w = simserpent.World(simserpent.load_config(overrides=SMALL))
    with pytest.raises(ValueError, match=r"World.reset: seed must be a whole number from 0 to 2\*\*64 - 1.*got -1$"):
        w.reset(-1)
    with pytest.raises(ValueError, match="got 18446744073709551616"):
        w.reset(2**64)
    with pytest.raises(TypeError, match="World.reset: seed must be .*got NoneType None"):
        w.reset(None)
    with pytest.raises(TypeError, match="got float 1.5"):
        w.reset(1.5)
    with pytest.raises(TypeError, match="got the bool True"):
        w.reset(True)
    assert np.isfinite(w.reset(np.uint64(7))).all()
    with pytest.raises(TypeError, match=r"action must be .* 4 real numbers .*dtype <U1 and shape \(4,\)"):
        w.step(np.array(["a", "b", "c", "d"]))
    with pytest.raises(TypeError, match=r"dtype float64 and shape \(2, 4\)"):
        w.step(np.zeros((2, 4)))
    with pytest.raises(TypeError, match="got str 'left'"):
        w.step("left")
    with pytest.raises(ValueError, match="action has 3 values; this snake has 4 joints"):
        w.step([0.0, 0.0, 0.0])
    w.step(np.zeros(4, dtype=np.int64))  # integers are numbers


def test_bad_arguments_of_the_other_public_functions_get_clear_errors(tmp_path):
    from simserpent.envs import SimSerpentVectorEnv

    with pytest.raises(TypeError, match=r"World\(config\): config must be a simserpent.Config .*got str 'x'"):
        simserpent.World("x")
    w = simserpent.make_world(overrides=SMALL)
    with pytest.raises(TypeError, match="World.set_state: state must be a WorldState .*got int 1"):
        w.set_state(1)
    with pytest.raises(TypeError, match="load_config: source must be a path .*got int 123"):
        simserpent.load_config(123)
    with pytest.raises(TypeError, match="overrides must be a dict .*got int 5"):
        simserpent.load_config(overrides=5)
    for function in (simserpent.plot, simserpent.render, simserpent.estimate, simserpent.open_run):
        with pytest.raises(TypeError, match=r"run_(dir|folder) must be a path \(str or os.PathLike\), got NoneType None"):
            function(None)
    with pytest.raises(TypeError, match="Gait.targets: t_secs must be a number of seconds, got str 'x'"):
        simserpent.Gait(overrides=SMALL).targets("x")
    with pytest.raises(ValueError, match="num_envs must be a whole number from 1 to 4096, got -1"):
        SimSerpentVectorEnv(num_envs=-1, overrides=SMALL)
    with pytest.raises(ValueError, match="num_envs must be a whole number from 1 to 4096, got 1000000000"):
        SimSerpentVectorEnv(num_envs=10**9, overrides=SMALL)
    with pytest.raises(ValueError, match=r"threads must be a whole number from 0 to 256 \(0: one thread per core\), got -1"):
        SimSerpentVectorEnv(num_envs=2, overrides=SMALL, threads=-1)
    with pytest.raises(ValueError, match=r"threads must be a whole number from 0 to 256 .*got 100000"):
        SimSerpentVectorEnv(num_envs=2, overrides=SMALL, threads=100_000)
    with pytest.raises(ValueError, match="held-out fields = 1000000: give 1 to 10000 per family"):
        simserpent.oal_bench(held_out_fields=10**6, out=tmp_path)
    with pytest.raises(ValueError, match="tuning fields = 5000: give 0 to 1000"):
        simserpent.oal_bench(tuning_fields=5000, out=tmp_path)
    with pytest.raises(ValueError, match="threads 100000: at most 256 worker threads"):
        simserpent.oal_bench(threads=100_000, out=tmp_path)
    assert not any(tmp_path.iterdir()), "a refused benchmark writes nothing"
    vec = SimSerpentVectorEnv(num_envs=2, overrides=SMALL)
    vec.reset(seed=0)
    with pytest.raises(TypeError, match=r"actions must be real numbers.*dtype <U1 and shape \(2, 4\)"):
        vec.step(np.array([["a"] * 4] * 2))
    with pytest.raises(TypeError, match="render width and height must be whole numbers of pixels, got 'a' x 48"):
        SimSerpentEnv(overrides=SMALL, render_mode="rgb_array", width="a", height=48)
