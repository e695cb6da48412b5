"""Can a causal controller choose hoal's waves the way the oracle does?

`tools/hoal_oracle.rs` (the greedy oracle with perfect foresight) reaches 2.5-4.2x the best
single open-loop wave on hoal's peg fields by picking, every 2 s, the wave of hoal's sweep that
gains most over the next window. This study asks whether what a controller *senses* predicts
that choice. Make the data (one row per oracle window: what the snake sensed over the window
before, and every wave's gain over the next window, from the same saved state):

    cargo run --release --example hoal_oracle -- --seeds 100-139 --no-sweep --dump train.csv

(`train.csv` and `train.pegs.csv`, the fields' pegs), then:

    python python/examples/wave_choice_study.py train.csv

It fits, per wave, a model of the next window's gain on one feature set, chooses the wave with
the highest predicted gain, and scores the choice by the gain the chosen wave really made (from
the oracle's state), with 5-fold cross-validation grouped by field (no field is in both the
training and the test folds). Feature sets:

- `sensed`: what the snake has: the previous wave; over the last window, per link, the mean
  estimated obstacle force (along and across the mean heading), its mean magnitude and the
  fraction of steps with a contact flag; the head's displacement and mean heading.
- `pegs along body` (privileged, not sensed): the true pegs in 0.4 m cells behind the head in the
  body's frame and each link's distance to the nearest peg: the pegs the body touches or passes,
  which a snake could map from its own contact points;
- `pegs ahead` (privileged): the true pegs in cells ahead of the head;
- `all`: all of them.

Models: ridge regression (numpy, always) and gradient-boosted trees (scikit-learn, if installed).
Gains are printed in mm/s (gain over the 2-s window / 2 s). Baselines: the oracle (the best
gain), the best fixed wave (in-sample, per density), and keeping the oracle's previous wave.
Also: how well each set predicts whether an ordinary wave (lag > 0) or a drift wave (lag < 0)
gains more, against the majority class.
"""

import sys
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

Array = npt.NDArray[Any]
#: A table (pandas.DataFrame).
Frame = Any
#: fit on (x_train, y_train), predict x_test
Predict = Callable[[Array, Array, Array], Array]

WAVES = [(a, lag) for a in (50, 65, 80) for lag in (-60, -45, -30, 30)]
DENSITIES = ["sparse", "medium", "dense"]
FOLDS = 5


def load(path: str) -> tuple[Frame, Frame]:
    df = pd.read_csv(path)
    # The first window holds the ramp-in: nothing was sensed before it.
    df = df[df.window >= 1].reset_index(drop=True)
    pegs = pd.read_csv(path[: -len(".csv")] + ".pegs.csv", names=["density", "seed", "x", "y", "r"])
    return df, pegs.drop_duplicates()


def sensed_features(df: Frame) -> Array:
    c, s = np.cos(df.yaw_mean), np.sin(df.yaw_mean)
    f = {
        "prev_amplitude": [WAVES[p][0] for p in df.prev_wave],
        "prev_lag": [WAVES[p][1] for p in df.prev_wave],
        "head_dx": df.head_dx,
        "head_dy": df.head_dy,
        "cos_yaw": c,
        "sin_yaw": s,
        "head_y": df.head_y,
    }
    for i in range(10):
        f[f"along{i}"] = df[f"fx{i}"] * c + df[f"fy{i}"] * s
        f[f"across{i}"] = -df[f"fx{i}"] * s + df[f"fy{i}"] * c
        f[f"magnitude{i}"] = df[f"fa{i}"]
        f[f"contact{i}"] = df[f"fc{i}"]
    return np.asarray(pd.DataFrame(f).to_numpy(float))


def peg_features(df: Frame, pegs: Frame) -> tuple[Array, Array]:
    """Pegs in the body's frame (centre: the links' mean, x: tail to head): counts in cells of
    0.4 m (x from -1.0 to 1.4 m, y from -0.6 to 0.6 m), split at x = 0.6 m (about the head);
    each link's distance to the nearest peg's surface; the body's heading."""
    lx = df[[f"lx{i}" for i in range(10)]].to_numpy()
    ly = df[[f"ly{i}" for i in range(10)]].to_numpy()
    cx, cy = lx.mean(1), ly.mean(1)
    heading = np.arctan2(ly[:, 0] - ly[:, 9], lx[:, 0] - lx[:, 9])
    x_edges, y_edges = np.arange(-1.0, 1.41, 0.4), np.array([-0.6, -0.2, 0.2, 0.6])
    cells = np.zeros((len(df), len(x_edges) - 1, len(y_edges) - 1))
    nearest = np.zeros((len(df), 10))
    by_field = {k: v[["x", "y", "r"]].to_numpy() for k, v in pegs.groupby(["density", "seed"])}
    for i, (d, seed) in enumerate(zip(df.density, df.seed)):
        p = by_field[(d, seed)]
        c, s = np.cos(heading[i]), np.sin(heading[i])
        dx, dy = p[:, 0] - cx[i], p[:, 1] - cy[i]
        cells[i], _, _ = np.histogram2d(c * dx + s * dy, -s * dx + c * dy, bins=[x_edges, y_edges])
        for k in range(10):
            nearest[i, k] = (np.hypot(p[:, 0] - lx[i, k], p[:, 1] - ly[i, k]) - p[:, 2]).min()
    pose = np.stack([np.cos(heading), np.sin(heading)], 1)
    along = cells[:, :4, :].reshape(len(df), -1)
    ahead = cells[:, 4:, :].reshape(len(df), -1)
    return np.hstack([along, nearest, pose]), np.hstack([ahead, pose])


def folds_of(df: Frame) -> Array:
    fields = sorted(set(zip(df.density, df.seed)))
    order = np.random.default_rng(0).permutation(len(fields))
    fold = {fields[i]: j % FOLDS for j, i in enumerate(order)}
    return np.array([fold[(d, s)] for d, s in zip(df.density, df.seed)])


def ridge_predict(x_train: Array, y_train: Array, x_test: Array, lam: float = 10.0) -> Array:
    mu, sd = x_train.mean(0), x_train.std(0) + 1e-9
    a = np.hstack([np.ones((len(x_train), 1)), (x_train - mu) / sd])
    b = np.hstack([np.ones((len(x_test), 1)), (x_test - mu) / sd])
    reg = lam * np.eye(a.shape[1])
    reg[0, 0] = 0.0
    return np.asarray(b @ np.linalg.solve(a.T @ a + reg, a.T @ y_train))


def gbm_predict(x_train: Array, y_train: Array, x_test: Array) -> Array:
    from sklearn.ensemble import HistGradientBoostingRegressor

    out = np.zeros((len(x_test), y_train.shape[1]))
    for k in range(y_train.shape[1]):
        m = HistGradientBoostingRegressor(
            max_iter=150, learning_rate=0.05, max_leaf_nodes=8, min_samples_leaf=20, random_state=0
        )
        out[:, k] = m.fit(x_train, y_train[:, k]).predict(x_test)
    return out


def cross_validated(x: Array, y: Array, fold: Array, predict: Predict) -> Array:
    pred = np.zeros(y.shape)
    for f in range(FOLDS):
        train, test = fold != f, fold == f
        pred[test] = predict(x[train], y[train], x[test])
    return pred


def per_density(df: Frame, values: Array) -> list[float]:
    out = [500.0 * float(values[(df.density == d).to_numpy()].mean()) for d in DENSITIES]
    return out + [500.0 * float(values.mean())]


def main(path: str) -> None:
    df, pegs = load(path)
    gains = df[[f"gain{k}" for k in range(len(WAVES))]].to_numpy()
    rows = np.arange(len(df))
    fold = folds_of(df)
    along, ahead = peg_features(df, pegs)
    sensed = sensed_features(df)
    sets = {
        "sensed": sensed,
        "pegs along body": along,
        "pegs ahead": ahead,
        "all": np.hstack([sensed, along, ahead]),
    }
    models: list[tuple[str, Predict]] = [("ridge", ridge_predict)]
    try:
        import sklearn  # noqa: F401

        models.append(("boosted trees", gbm_predict))
    except ImportError:
        print("(scikit-learn is not installed: ridge regression only)")
    n_fields = len(set(zip(df.density, df.seed)))
    print(f"{len(df)} decision windows on {n_fields} fields; mm/s over the next window: sparse, medium, dense, all")
    fixed = np.zeros(len(df))
    for d in DENSITIES:
        m = (df.density == d).to_numpy()
        fixed[m] = gains[m][:, gains[m].mean(0).argmax()]
    table = [
        ("oracle (foresight)", gains.max(1)),
        ("best fixed wave per density (in-sample)", fixed),
        ("keep the oracle's previous wave", gains[rows, df.prev_wave.to_numpy()]),
    ]
    for model_name, predict in models:
        for set_name, x in sets.items():
            choice = cross_validated(x, gains, fold, predict).argmax(1)
            table.append((f"{model_name}, {set_name}", gains[rows, choice]))
    for name, values in table:
        print(f"  {name:42s}" + "".join(f"{v:8.1f}" for v in per_density(df, values)))
    drift = [k for k, w in enumerate(WAVES) if w[1] < 0]
    ordinary = [k for k, w in enumerate(WAVES) if w[1] > 0]
    margin = gains[:, ordinary].max(1) - gains[:, drift].max(1)
    majority = max((margin > 0).mean(), (margin <= 0).mean())
    print(f"ordinary or drift wave next (majority class: {majority:.3f}); ridge, cross-validated:")
    for set_name, x in sets.items():
        pred = cross_validated(x, margin[:, None], fold, ridge_predict)[:, 0]
        r2 = 1.0 - ((margin - pred) ** 2).mean() / margin.var()
        print(f"  {set_name:16s} R^2 {r2:6.3f}   sign right {((pred > 0) == (margin > 0)).mean():.3f}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: wave_choice_study.py DUMP.csv   (from hoal_oracle --dump DUMP.csv)")
    main(sys.argv[1])
