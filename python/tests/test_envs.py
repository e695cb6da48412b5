"""Gymnasium environments: check_env, determinism, vector = N singles, registration."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import simserpent
from simserpent.envs import SimSerpentEnv, SimSerpentVectorEnv

NOISY = {
    "snake.n_links": 5,
    "terrain.kind": "none",
    "sensors.noise_enabled": True,
    "sensors.joint_angle.std": 0.01,
    "sensors.joint_velocity.std": 0.05,
    "env.max_episode_secs": 0.2,
}


def gait(t, n, amplitude=0.5):
    return amplitude * np.sin(2 * np.pi * 1.0 * t - 0.8 * np.arange(n))


def test_check_env_passes():
    env = SimSerpentEnv(overrides=NOISY)
    check_env(env, skip_render_check=True)


def test_check_env_with_imu_force_torque_and_torque_actions():
    env = SimSerpentEnv(
        overrides={
            **NOISY,
            "env.observe_imu": True,
            "env.observe_joint_force_torque": True,
            "env.action": "torque",
            "sensors.accelerometer.std": 0.1,
        }
    )
    # Head x and y are left out by default (Swimmer's exclude_current_positions_from_observation).
    assert env.observation_space.shape == (2 * 4 + 8 + 6 * 5 + 6 * 4,)
    assert env.observation_names[-1] == "joint_04_torque_z_nm"
    assert env.observation_version == 1
    check_env(env, skip_render_check=True)


def test_registered_and_made_with_gym_make():
    env = gym.make("SimSerpent-v0", overrides=NOISY)
    obs, info = env.reset(seed=3)
    assert obs.shape == env.observation_space.shape
    vec = gym.make_vec("SimSerpent-v0", num_envs=2, vectorization_mode="vector_entry_point", overrides=NOISY)
    assert vec.num_envs == 2
    vec.close()
    env.close()


def rollout(env, seed, steps=8):
    obs, _ = env.reset(seed=seed)
    out = [obs]
    rewards = []
    for k in range(steps):
        obs, r, term, trunc, info = env.step(gait(k * 0.02, env.action_space.shape[0]))
        out.append(obs)
        rewards.append(r)
        if term or trunc:
            break
    return np.array(out), np.array(rewards)


def test_same_seed_same_episode_other_seed_other_noise():
    env = SimSerpentEnv(overrides=NOISY)
    a = rollout(env, 5)
    b = rollout(env, 5)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    c = rollout(env, 6)
    assert not np.array_equal(a[0], c[0])
    fresh = SimSerpentEnv(overrides=NOISY)
    np.testing.assert_array_equal(rollout(fresh, 5)[0], a[0])


def test_truncation_at_max_episode_secs():
    env = SimSerpentEnv(overrides=NOISY)
    env.reset(seed=0)
    for k in range(10):
        _, _, term, trunc, info = env.step(np.zeros(4))
        assert not term
        if trunc:
            break
    assert k == 9 and trunc  # 0.2 s / 0.02 s
    assert info["time_secs"] == pytest.approx(0.2)


def test_reward_terms_follow_the_weights():
    env = SimSerpentEnv(
        overrides={**NOISY, "env.reward_energy_weight": 2.0, "env.reward_contact_force_weight": 0.01}
    )
    env.reset(seed=0)
    a = np.linspace(-0.5, 0.5, 4).astype(np.float32)
    _, r, _, _, info = env.step(a)
    dt = env.unwrapped.dt
    assert dt == 0.02
    # Rates (Swimmer-v5): forward velocity, mean power; the control cost of the normalised action.
    assert info["reward_forward"] == pytest.approx(info["forward_progress_m"] / dt, abs=1e-12)
    assert info["reward_energy"] == pytest.approx(-2.0 * info["energy_j"] / dt, abs=1e-12)
    assert info["reward_contact_force"] == pytest.approx(-0.01 * info["peak_contact_force_n"], abs=1e-12)
    assert info["reward_ctrl"] == pytest.approx(-1e-4 * float(np.sum(a.astype(np.float64) ** 2)), abs=1e-15)
    total = info["reward_forward"] + info["reward_energy"] + info["reward_contact_force"] + info["reward_ctrl"]
    assert r == pytest.approx(total, abs=1e-12)
    assert info["energy_j"] > 0 and info["peak_contact_force_n"] > 0
    assert info["x_velocity"] == pytest.approx(
        (info["x_position"] - env.unwrapped.world.start_centre_of_mass[0]) / dt, abs=1e-9
    )


def test_nan_action_terminates_with_the_reason():
    env = SimSerpentEnv(overrides={**NOISY, "env.action": "torque"})
    env.reset(seed=0)
    obs, r, term, trunc, info = env.step(np.full(4, np.nan))
    assert term and not trunc
    assert "mjWARN_BADCTRL" in info["error"]
    assert np.all(np.isfinite(obs))


@pytest.mark.parametrize("threads", [1, 2])
def test_vector_env_equals_single_envs(threads):
    n, seed, steps = 3, 11, 14  # 14 steps: every env autoresets once (10 steps per episode)
    vec = SimSerpentVectorEnv(num_envs=n, overrides=NOISY, threads=threads)
    assert vec.threads == threads
    singles = [SimSerpentEnv(overrides=NOISY) for _ in range(n)]
    obs, info = vec.reset(seed=seed)
    expected = []
    for i, s in enumerate(singles):
        o, inf = s.reset(seed=seed + i)
        expected.append(o)
        assert info["seed"][i] == inf["seed"]
    np.testing.assert_array_equal(obs, np.stack(expected))
    assert info["_seed"].all()
    done = [False] * n
    episode = [0] * n
    for k in range(steps):
        actions = np.stack([gait(k * 0.02 + i, 4) for i in range(n)]).astype(np.float32)
        obs, rewards, term, trunc, infos = vec.step(actions)
        for i, s in enumerate(singles):
            if done[i]:
                episode[i] += 1
                o, _ = s.reset()  # no seed: the env's own generator, as SyncVectorEnv's autoreset
                np.testing.assert_array_equal(obs[i], o)
                assert rewards[i] == 0.0 and not term[i] and not trunc[i]
                assert not infos["_energy_j"][i]
                done[i] = False
                continue
            o, r, te, tr, inf = s.step(actions[i])
            np.testing.assert_array_equal(obs[i], o)
            assert rewards[i] == r and term[i] == te and trunc[i] == tr
            assert infos["energy_j"][i] == inf["energy_j"]
            done[i] = te or tr
    assert max(episode) == 1
    vec.close()


def test_vector_env_shape_errors():
    vec = SimSerpentVectorEnv(num_envs=2, overrides=NOISY, threads=1)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="expected"):
        vec.core.step(np.zeros((3, 4)), [0, 0])
    with pytest.raises(ValueError, match="reset_mask"):
        vec.reset(options={"reset_mask": np.array([1, 0])})


def longest_pause_of_this_thread(step) -> tuple[float, float]:
    """Runs `step` in another thread while this one spins; returns (the call's duration, the
    longest time this thread did not run during the call)."""
    import threading
    import time

    window = {}

    def worker():
        window["start"] = time.perf_counter()
        step()
        window["end"] = time.perf_counter()

    ticks = []
    t = threading.Thread(target=worker)
    t.start()
    while t.is_alive():
        ticks.append(time.perf_counter())
    t.join()
    start, end = window["start"], window["end"]
    inside = [start] + [x for x in ticks if start < x < end] + [end]
    return end - start, max(b - a for a, b in zip(inside, inside[1:]))


def test_steps_release_the_gil():
    """Python code in another thread runs while an env steps (py.detach in Rust); a call that
    held the GIL would stop this thread for all but one switch interval (5 ms)."""
    long_step = {**NOISY, "env.control_period_secs": 2.0, "env.max_episode_secs": 20.0}
    vec = SimSerpentVectorEnv(num_envs=4, overrides=long_step, threads=1)
    vec.reset(seed=0)
    duration, pause = longest_pause_of_this_thread(lambda: vec.step(np.zeros((4, 4), dtype=np.float32)))
    assert duration > 0.05, "the step was too short to tell"
    assert pause < 0.5 * duration, (pause, duration)
    # One env does a quarter of the vector's work per step: hold each action four times longer.
    single = simserpent.World(simserpent.load_config(overrides={**long_step, "env.control_period_secs": 8.0}))
    single.reset(0)
    duration, pause = longest_pause_of_this_thread(lambda: single.step(np.zeros(4)))
    assert duration > 0.05, "the step was too short to tell"
    assert pause < 0.5 * duration, (pause, duration)
    # The check itself: a call that holds the GIL (CPython's regex engine never releases it;
    # this pattern backtracks exponentially) shows up as one long pause.
    import re

    n = 18
    while True:
        text = "a" * n + "b"
        duration, pause = longest_pause_of_this_thread(lambda: re.match(r"(a+)+$", text))
        if duration > 0.1 or n > 30:
            break
        n += 2
    assert duration > 0.1, "the regex was too short to tell"
    assert pause > 0.5 * duration, (pause, duration)
