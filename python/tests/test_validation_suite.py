"""validation/ (the Drake reference suite): its bounds and figures on synthetic series, without
Drake. The suite itself (`validation/run`) is heavy and runs outside CI; these check that its
logic can fail: a two-sided bound rejects a figure too far below the reference as well as above,
forces are compared at equal sampling, and a miss names the scene, the figure, both values and
the bound."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "validation"))

import figures as fg  # noqa: E402
import restitution as rs  # noqa: E402
import targets as tg  # noqa: E402
from mjcf_model import Link, Model  # noqa: E402


def model(n_links=2, mass=0.3):
    links = [Link(f"link_{i:02d}", mass, 0.04, np.array([-0.16, 0, 0]), np.array([-0.04, 0, 0]), np.zeros(3))
             for i in range(n_links)]
    return Model(1e-3, np.array([0, 0, -9.81]), links, [], [], [], [], 0.002, 0.5, 0.5, 0.5, 0.5,
                 np.zeros(7 + n_links - 1), np.zeros(6 + n_links - 1))


def run_of(t, floor_z, velocity=None, obstacle=None, position=None):
    rows, n = floor_z.shape
    floor = np.zeros((rows, n, 3))
    floor[:, :, 2] = floor_z
    return {
        "time_s": t,
        "floor_force": floor,
        "obstacle_force": np.zeros((rows, n, 3)) if obstacle is None else obstacle,
        "velocity": np.zeros((rows, n, 3)) if velocity is None else velocity,
        "position": np.zeros((rows, n, 3)) if position is None else position,
    }


RAMP_PEAK = tg.Target("ramp peak", "ramp", "peak", "ratio", 0.5, 2.0)


@pytest.mark.parametrize("ours, passed", [(80.0, True), (40.0, True), (160.0, True), (33.0, False), (170.0, False)])
def test_a_ratio_bound_is_two_sided(ours, passed):
    # Against the reference's 80 × m g, a peak 2.4 × below it fails, as one 2.1 × above it.
    ok, bound = tg.check(RAMP_PEAK, ours, 80.0)
    assert ok is passed, bound


def test_where_the_reference_has_none_a_ratio_bound_allows_none():
    t = tg.Target("no step with every link off", "ramp", "off", "ratio", 0.5, 2.0)
    assert tg.check(t, 0, 0)[0] is True
    assert tg.check(t, 3, 0)[0] is False
    assert tg.check(t, 3, 4)[0] is True and tg.check(t, 1, 4)[0] is False


def test_per_link_bounds_topple_and_angles():
    t = tg.Target("loads", "ramp", "loads", "each ratio", 0.95, 1.05)
    assert tg.check(t, [1.0, 1.04], [1.0, 1.0])[0] is True
    assert tg.check(t, [1.0, 0.94], [1.0, 1.0])[0] is False
    angle = tg.Target("direction", "upright", "dir", "angle", hi=15.0)
    assert tg.check(angle, 179.0, -175.0)[0] is True
    assert tg.check(angle, 0.0, 180.0)[0] is False
    # A snake that does not topple (nan) fails the topple-time target; so does a reference that does not.
    when = tg.Target("topple", "upright", "t", "ratio", 0.8, 1.2)
    assert tg.check(when, math.nan, 1.5)[0] is False
    assert tg.check(when, 1.5, math.nan)[0] is False
    assert tg.check(when, 1.75, 1.5)[0] is True and tg.check(when, 1.9, 1.5)[0] is False


def test_a_miss_names_scene_figure_both_values_and_the_bound():
    raw = {("ramp", 0.5, "drake", "peak"): 79.6, ("ramp", 0.5, "main", "peak"): 32.8,
           ("ramp", 1.0, "drake", "peak"): 122.0, ("ramp", 1.0, "main", "peak"): 120.0}
    verdicts = tg.evaluate(raw, [0.5, 1.0], ["main"], [RAMP_PEAK])
    assert [v.passed for v in verdicts] == [False, True]
    (line,) = tg.failures(verdicts)
    assert "scene ramp" in line and "μ 0.5" in line and '"peak"' in line
    assert "32.8" in line and "79.6" in line and "39.8 … 159" in line, line
    report = tg.report(verdicts, [])
    assert "**FAIL**" in report and "1 of 2 checks pass, 1 fail" in report


def test_convergence_and_same_engine_comparisons():
    fine = tg.Target("lift converges", "hit", "lift", "ratio", 0.9, 1.1, floor=1.0, against="fine")
    plane = tg.Target("flat = plane", "hf_flat", "speed", "ratio", 0.98, 1.02, against="scene:ramp")
    raw = {("hit", 1.0, "main", "lift"): 96.0, ("hit", 1.0, "main@fine", "lift"): 75.0,
           ("hf_flat", 1.0, "main", "speed"): 80.0, ("ramp", 1.0, "main", "speed"): 16.0}
    verdicts = tg.evaluate(raw, [1.0], ["main"], [fine, plane])
    assert [v.passed for v in verdicts] == [False, False]
    raw[("hit", 1.0, "main@fine", "lift")] = 100.0
    raw[("hf_flat", 1.0, "main", "speed")] = 16.2
    assert all(v.passed for v in tg.evaluate(raw, [1.0], ["main"], [fine, plane]))
    # A scene that was not run is left out, not failed.
    assert tg.evaluate({("hf_flat", 1.0, "main", "speed"): 1.0}, [1.0], ["main"], [plane]) == []


def test_every_listed_target_has_two_finite_ends():
    for t in tg.TARGETS:
        if t.kind in ("ratio", "fixed", "each ratio", "each fixed", "range fixed"):
            assert math.isfinite(t.lo) and math.isfinite(t.hi) and t.lo <= t.hi, t
            assert t.kind == "fixed" or t.lo > 0 or t.floor > 0 or t.against != "drake", t
        else:
            assert t.hi > 0, t


def test_resampling_gives_the_mean_force_of_each_coarse_step():
    # 0.1-ms rows: a 1-row spike of 100 × m g lands in one 1-ms step as a mean of 10 × m g.
    m = model(1)
    w = m.link_weight_n(0)
    t = np.arange(0, 0.0501, 1e-4)
    n = np.full((len(t), 1), w)
    n[125] = 100 * w
    fine = run_of(t, n)
    coarse = fg.resample(fine, 1e-3)
    assert len(coarse["time_s"]) == 51 and coarse["time_s"][-1] == pytest.approx(0.05)
    assert fg.peak_load_per_weight(fine, m) == pytest.approx(100.0)
    assert fg.peak_load_per_weight(coarse, m) == pytest.approx(10.9)
    # The 10-ms window mean is the same at both samplings: (100 + 99·1)/100 rows.
    assert fg.largest_window_load(fine, m) == pytest.approx(1.99)
    assert fg.largest_window_load(coarse, m) == pytest.approx(1.99, rel=0.06)
    with pytest.raises(ValueError, match="whole multiple"):
        fg.resample(fine, 2.5e-4 + 1e-5)


def test_steps_with_every_link_off_and_topple():
    m = model(2)
    w = m.link_weight_n(0)
    t = np.arange(0, 0.0101, 1e-3)
    n = np.full((len(t), 2), w)
    n[3:6, 0] = 0.0
    n[4:7, 1] = 0.0
    assert fg.all_links_off_steps(run_of(t, n), m) == 2
    pos = np.zeros((len(t), 2, 3))
    pos[:, 1, 1] = -np.linspace(0, 0.5, len(t))
    when, direction = fg.topple(run_of(t, n, position=pos), 0.2)
    assert when == pytest.approx(0.004) and direction == pytest.approx(-90.0)


def test_the_roll_after_a_hit_and_the_rise_of_the_centre_of_mass():
    # Two links spinning about their axes (world x, then turned 90° about z: the head's axis is
    # world y from row 3 on); an obstacle force first at row 2 (t = 2 ms), read 10 ms later.
    m = model(2, mass=0.3)
    t = np.arange(0, 0.0201, 1e-3)
    rows = len(t)
    obstacle = np.zeros((rows, 2, 3))
    obstacle[2:5, 1, 1] = -100.0
    pos = np.zeros((rows, 2, 3))
    pos[:, 0, 2] = 0.04 + 0.001 * np.sin(np.pi * t / 0.02)  # the head rises 1 mm and comes back
    pos[:, 1, 2] = 0.04
    run = run_of(t, np.zeros((rows, 2)), obstacle=obstacle, position=pos)
    run["rotation"] = np.tile(np.eye(3), (rows, 2, 1, 1))
    run["rotation"][3:, 0] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    run["angular_velocity"] = np.zeros((rows, 2, 3))
    run["angular_velocity"][:, 0] = [-30.0, -4.0, 0.0]
    assert fg.roll_rate_after_hit(run) == pytest.approx(-4.0)  # about world y at t = 12 ms
    run["angular_velocity"][12, 0] = [-30.0, 5.0, 0.0]
    assert fg.roll_rate_after_hit(run) == pytest.approx(5.0)
    assert fg.largest_com_rise_mm(run, m) == pytest.approx(0.5, rel=1e-3)  # equal masses: half the head's
    assert math.isnan(fg.roll_rate_after_hit(run_of(t, np.zeros((rows, 2)))))


def test_restitution_of_a_synthetic_bounce():
    m = model(1)
    w = m.link_weight_n(0)
    t = np.arange(0, 0.0101, 1e-3)
    n = np.zeros((len(t), 1))
    n[4:7] = 50 * w
    v = np.zeros((len(t), 1, 3))
    v[:4, 0, 2] = -1.0
    v[4:7, 0, 2] = [-0.5, 0.0, 0.3]
    v[7:, 0, 2] = 0.4
    assert rs.measure(run_of(t, n, velocity=v), m, "floor") == pytest.approx(0.4)
    n[7:] = 50 * w  # never opens again: no rebound
    assert rs.measure(run_of(t, n, velocity=v), m, "floor") == 0.0


def test_calibration_finds_the_damping_of_a_target_restitution():
    # A restitution falling with d like exp(-d/3): d for 0.3 is 3.61.
    d, e = rs.calibrate(lambda d: math.exp(-d / 3.0), 0.3, 1.0, iterations=20)
    assert e == pytest.approx(0.3, abs=1e-3) and d == pytest.approx(-3.0 * math.log(0.3), rel=1e-2)


def test_a_chaotic_scenes_figures_are_the_means_over_its_starts():
    starts = [[("speed", 180.0), ("loads", [0.0, 2.0]), ("range", (0.9, 1.1)), ("name", "x")],
              [("speed", 220.0), ("loads", [1.0, 1.0]), ("range", (0.7, 1.3)), ("name", "x")]]
    figures = dict(fg.ensemble_mean(starts))
    assert figures["speed"] == pytest.approx(200.0)
    assert figures["loads"] == pytest.approx([0.5, 1.5])
    assert figures["range"] == pytest.approx((0.8, 1.2)) and isinstance(figures["range"], tuple)
    assert figures["name"] == "x"
    assert figures["speed, smallest … largest of 2 starts"] == (180.0, 220.0)
    with pytest.raises(ValueError):
        fg.ensemble_mean([[("speed", 1.0)], [("lift", 1.0)]])


def test_a_start_of_an_ensemble_moves_only_the_head_sideways():
    sets = {"snake.head_position_m": [0.0, 0.0, 0.02], "general.duration_secs": 3.0}
    assert fg.perturbed(sets, 0) is sets
    moved = fg.perturbed(sets, 3)
    assert moved["snake.head_position_m"] == [0.0, 3 * fg.ENSEMBLE_OFFSET_M, 0.02]
    assert sets["snake.head_position_m"] == [0.0, 0.0, 0.02] and moved["general.duration_secs"] == 3.0


def test_a_per_link_floor_passes_only_links_that_carry_next_to_nothing_in_both():
    t = tg.Target("loads", "hf_bumps", "loads", "each ratio", 0.95, 1.05, floor=0.05)
    assert tg.check(t, [0.009, 1.0], [0.02, 1.02])[0] is True
    assert tg.check(t, [0.0, 1.0], [0.227, 1.0])[0] is False
    assert tg.check(t, [0.04, 1.2], [0.01, 1.0])[0] is False
    assert tg.check_fine(t, [0.009, 1.0], [0.03, 1.04])[0] is True
    assert tg.check_fine(t, [0.009, 1.0], [0.06, 1.0])[0] is False
    assert "worst +20.0 %" in tg.check(t, [0.04, 1.2], [0.01, 1.0])[1]
