"""The obstacle-aided locomotion benchmark with a Python controller plugged in."""

import csv
from pathlib import Path

import numpy as np
import pytest

import simserpent
from simserpent import SimSerpentError

SMALL = dict(
    quick=True,
    floors=["isotropic"],
    families=["random"],
    laws=False,
    tuning_fields=1,
    held_out_fields=1,
    duration_secs=2.0,
    passive_kp_nm_per_rad=[5.0],
    threads=2,
)


def the_base_gait(config):
    """The benchmark's base gait from Python: the same set-points as its open loop."""
    gait = simserpent.Gait(config)
    return lambda obs: np.asarray(gait.targets(obs["time_secs"])[0])


def test_a_python_controller_runs_as_a_condition_on_the_same_fields(tmp_path):
    result = simserpent.oal_bench(the_base_gait, name="mine", out=tmp_path, **SMALL)
    folder = Path(result["folder"])
    assert folder.parent == tmp_path
    assert "`mine`" in result["report"]
    assert (folder / "report.md").read_text(encoding="utf-8") == result["report"]
    with open(folder / "oal_runs.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    by = {(r["seed"], r["split"], r["condition"]): r for r in rows}
    # The passive gain's speed-matched open loop runs when the bare floor lets it be matched.
    assert {"open_loop", "passive_kp5", "mine"} <= {r["condition"] for r in rows} <= {
        "open_loop",
        "passive_kp5",
        "matched_kp5",
        "mine",
    }
    # Every held-out run has its bare-floor twin.
    assert {r["split"] for r in rows} == {"held_out", "twin"}
    # The base gait sent from Python is the open loop's command, and sensing does not move the
    # snake: the same run, bit for bit, on every field and its twin.
    for seed, split in {(r["seed"], r["split"]) for r in rows}:
        mine, open_loop = by[(seed, split, "mine")], by[(seed, split, "open_loop")]
        for column in ["end_s", "distance_bl", "speed_bl_per_cycle", "exit_heading_deg", "jammed"]:
            assert mine[column] == open_loop[column], (seed, split, column)


def test_an_exception_in_the_controller_is_raised_as_the_cause(tmp_path):
    def broken(config):
        def step(obs):
            raise RuntimeError("my controller failed")

        return step

    with pytest.raises(SimSerpentError, match="Python controller") as info:
        simserpent.oal_bench(broken, out=tmp_path, **SMALL)
    assert isinstance(info.value.__cause__, RuntimeError)


def test_bad_sizes_name_the_argument(tmp_path):
    with pytest.raises(ValueError, match="floors: unknown floor \"wet\""):
        simserpent.oal_bench(the_base_gait, out=tmp_path, **{**SMALL, "floors": ["wet"]})
    with pytest.raises(ValueError, match="duration_secs"):
        simserpent.oal_bench(the_base_gait, out=tmp_path, **{**SMALL, "duration_secs": 0.0})
    with pytest.raises(ValueError, match="law_servo_kp_nm_per_rad = -1"):
        simserpent.oal_bench(the_base_gait, out=tmp_path, law_servo_kp_nm_per_rad=-1.0, **SMALL)
    with pytest.raises(TypeError, match="controller must be callable"):
        simserpent.oal_bench(42, out=tmp_path, **SMALL)
