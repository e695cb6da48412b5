"""python/examples/wave_choice_study.py: its cross-validated choice finds a wave that the
features do predict, finds nothing where they do not, and its peg features put a peg where it is."""

import importlib.util
import pathlib

import numpy as np
import pandas as pd

REPO = pathlib.Path(__file__).resolve().parents[2]


def study():
    spec = importlib.util.spec_from_file_location("wave_choice_study", REPO / "python/examples/wave_choice_study.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def synthetic_dump(rng, fields=30, windows=6):
    """Rows as `hoal_oracle --dump` writes them (window >= 1), the snake straight along +x."""
    rows = []
    for f in range(fields):
        for w in range(1, windows + 1):
            row = {"density": "medium", "seed": f, "window": w, "t_secs": 1.0 + 2.0 * w, "prev_wave": int(rng.integers(12))}
            row.update(head_x=0.1 * w, head_y=0.0, head_dx=0.1, head_dy=0.0, yaw_mean=0.0, yaw_end=0.0)
            for i in range(10):
                row.update({f"fx{i}": 0.0, f"fy{i}": 0.0, f"fa{i}": rng.normal(), f"fc{i}": 0.0})
                row.update({f"lx{i}": -0.1 * i, f"ly{i}": 0.0})
            for k in range(12):
                row[f"gain{k}"] = 0.02 * rng.normal()
            rows.append(row)
    return pd.DataFrame(rows)


def choice_gain(s, df, x):
    gains = df[[f"gain{k}" for k in range(12)]].to_numpy()
    choice = s.cross_validated(x, gains, s.folds_of(df), s.ridge_predict).argmax(1)
    return gains[np.arange(len(df)), choice].mean(), gains.max(1).mean(), gains.mean(0).max()


def test_a_predictive_feature_is_found_and_noise_is_not():
    s = study()
    rng = np.random.default_rng(1)
    df = synthetic_dump(rng)
    # Wave 3 gains 0.1 m when link 4's force magnitude is positive, wave 9 otherwise.
    df["gain3"] += np.where(df.fa4 > 0, 0.1, 0.0)
    df["gain9"] += np.where(df.fa4 > 0, 0.0, 0.1)
    chosen, oracle, fixed = choice_gain(s, df, s.sensed_features(df))
    assert oracle - chosen < 0.02, (chosen, oracle)
    assert chosen > fixed + 0.03, (chosen, fixed)
    # Gains that no feature predicts: the choice is no better than the best fixed wave.
    noise = synthetic_dump(np.random.default_rng(2))
    chosen, oracle, fixed = choice_gain(s, noise, s.sensed_features(noise))
    assert chosen < fixed + 0.01 and oracle > chosen + 0.02, (chosen, fixed, oracle)


def test_peg_features_put_pegs_ahead_or_along_the_body():
    s = study()
    df = synthetic_dump(np.random.default_rng(3), fields=2, windows=1)
    # The body runs from x = -0.9 (tail) to 0 (head), centre -0.45: field 0 has a peg 1.2 m ahead
    # of the centre, field 1 one beside link 5 (0.05 m off the axis, radius 0.02 m).
    pegs = pd.DataFrame(
        [("medium", 0, 0.75, 0.0, 0.02), ("medium", 1, -0.5, 0.05, 0.02)], columns=["density", "seed", "x", "y", "r"]
    )
    along, ahead = s.peg_features(df, pegs)
    # along: 4 x-cells × 3 y-cells, then 10 nearest distances, then cos, sin of the heading.
    assert ahead[0, :6].sum() == 1 and along[0, :12].sum() == 0
    assert ahead[1, :6].sum() == 0 and along[1, :12].sum() == 1
    assert abs(along[1, 12 + 5] - 0.03) < 1e-9
    assert np.allclose(along[:, -2:], [[1.0, 0.0], [1.0, 0.0]])
