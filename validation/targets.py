"""The targets: two-sided bounds on SimSerpent's figures, against the reference's figure of the
same scene and μ, against a fixed value, against SimSerpent's own figure in another scene, or
against SimSerpent at a finer step (convergence).

Every bound has a lower and an upper end. `evaluate` checks every target for every build and μ
and returns one `Verdict` each; `report` writes them as a markdown table; `failures` names every
miss (scene, μ, figure, both engines' values and the bound) for the exit status of the suite.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Target:
    """One bound. `kind`:

    - "ratio": lo·ref ≤ ours ≤ hi·ref, ref the reference's figure; where |ref| ≤ `floor`
      (the figure's noise floor, in its units) the bound is 0 … floor instead (ours and ref both
      small), so a zero in the reference means zero here;
    - "fixed": lo ≤ ours ≤ hi;
    - "diff": ref − tol ≤ ours ≤ ref + tol, tol = max(hi·|ref|, floor) (hi a relative tolerance);
    - "angle": |ours − ref| ≤ hi degrees (around the circle);
    - "each ratio" / "each fixed": the same for every element of a per-link list; with a `floor`,
      an element within it in both figures passes (a link that carries next to nothing in both);
    - "range fixed": both ends of a (smallest, largest) pair within lo … hi.

    `against`: "drake" (the reference), "fine" (SimSerpent at the scene's finer step; the bound
    is on ours_fine / ours) or "scene:KEY" (SimSerpent's own figure in scene KEY, same μ).
    `component`: for a tuple figure, the element compared.
    """

    name: str
    scene: str
    figure: str
    kind: str
    lo: float = 0.0
    hi: float = 0.0
    floor: float = 0.0
    against: str = "drake"
    component: int | None = None


@dataclass
class Verdict:
    target: Target
    mu: float
    engine: str
    ours: object
    ref: object
    passed: bool | None  # None: a figure is missing
    bound: str


def _num(x) -> float | None:
    if x is None or isinstance(x, str):
        return None
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v


def _pick(value, component):
    if component is not None and isinstance(value, (tuple, list)):
        return value[component]
    return value


def _g(x: float) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    if x == 0:
        return "0"
    a = abs(x)
    if a >= 100:
        return f"{x:.0f}"
    if a >= 1e-3:
        return f"{x:.3g}"
    return f"{x:.2e}"


def _worst_ratio(values, bases) -> float:
    """The largest |value / base − 1| with its sign (inf where a zero base meets a non-zero value)."""
    worst = 0.0
    for v, b in zip(values, bases):
        d = (float(v) / float(b) - 1.0) if b != 0 else (0.0 if v == 0 else math.inf)
        worst = max(worst, d, key=abs)
    return worst


def _each_within(t: Target, base: float, value: float) -> bool:
    """One element of an "each" bound: lo·base … hi·base, or 0 … floor where both are within
    the floor (a link that carries next to nothing in both runs)."""
    if t.floor > 0 and abs(base) <= t.floor and abs(value) <= t.floor:
        return True
    return t.lo * base <= value <= t.hi * base


def _above_floor(t: Target, values, bases) -> tuple[list, list]:
    """The elements an "each" bound compares as ratios (not both within the floor)."""
    pairs = [(v, b) for v, b in zip(values, bases) if not (abs(b) <= t.floor and abs(v) <= t.floor and t.floor > 0)]
    return [v for v, _ in pairs], [b for _, b in pairs]


def _floor_text(t: Target) -> str:
    return f", or both ≤ {_g(t.floor)}" if t.floor > 0 else ""


def check(t: Target, ours, ref) -> tuple[bool | None, str]:
    """Whether `ours` meets the target given the reference value `ref`, and the bound as text."""
    if t.kind in ("each ratio", "each fixed"):
        if ours is None or (t.kind == "each ratio" and ref is None):
            return False, "figure missing (n/a)"
        base = list(ref) if t.kind == "each ratio" else [1.0] * len(ours)
        ok = all(_each_within(t, b, o) for o, b in zip(ours, base))
        worst = _worst_ratio(*_above_floor(t, ours, base))
        scale = "× the compared figure, each link" if t.kind == "each ratio" else "each link"
        return ok, f"{_g(t.lo)} … {_g(t.hi)} {scale}{_floor_text(t)} (worst {100 * worst:+.1f} %)"
    if t.kind == "range fixed":
        if ours is None:
            return None, "n/a"
        lo_v, hi_v = ours
        return t.lo <= lo_v and hi_v <= t.hi, f"{_g(t.lo)} … {_g(t.hi)}"
    o = _num(_pick(ours, t.component))
    r = _num(_pick(ref, t.component))
    if o is None or math.isnan(o):
        return False, "figure missing (n/a)"
    if t.kind == "fixed":
        return t.lo <= o <= t.hi, f"{_g(t.lo)} … {_g(t.hi)}"
    if r is None or math.isnan(r):
        return False, "reference missing (n/a)"
    if t.kind == "ratio":
        if abs(r) <= t.floor:
            return 0.0 <= o <= t.floor if t.floor > 0 else o == 0.0, f"0 … {_g(t.floor)} (reference ≤ {_g(t.floor)})"
        lo, hi = sorted((t.lo * r, t.hi * r))
        return lo <= o <= hi, f"{_g(lo)} … {_g(hi)} ({_g(t.lo)} … {_g(t.hi)} × {_g(r)})"
    if t.kind == "diff":
        tol = max(t.hi * abs(r), t.floor)
        return r - tol <= o <= r + tol, f"{_g(r - tol)} … {_g(r + tol)}"
    if t.kind == "angle":
        d = (o - r + 180.0) % 360.0 - 180.0
        return abs(d) <= t.hi, f"{_g(r - t.hi)} … {_g(r + t.hi)}° (off by {d:+.1f}°)"
    raise ValueError(f"unknown target kind {t.kind!r}")


def check_fine(t: Target, coarse, fine) -> tuple[bool | None, str]:
    """Convergence: SimSerpent at the finer step within lo … hi × its own figure at the default step
    (or both within the noise floor)."""
    c = _num(_pick(coarse, t.component))
    f = _num(_pick(fine, t.component))
    if t.kind in ("each ratio",):
        if coarse is None or fine is None:
            return False, "figure missing (n/a)"
        ok = all(_each_within(t, a, b) for a, b in zip(coarse, fine))
        worst = _worst_ratio(*_above_floor(t, fine, coarse))
        return ok, f"fine / default {_g(t.lo)} … {_g(t.hi)} each link{_floor_text(t)} (worst {100 * worst:+.1f} %)"
    if c is None or f is None or math.isnan(c) or math.isnan(f):
        return False, "figure missing (n/a)"
    if abs(c) <= t.floor and abs(f) <= t.floor:
        return True, f"both ≤ {_g(t.floor)}"
    lo, hi = sorted((t.lo * c, t.hi * c))
    return lo <= f <= hi, f"{_g(lo)} … {_g(hi)} ({_g(t.lo)} … {_g(t.hi)} × {_g(c)})"


R15 = (1 / 1.5, 1.5)
R2 = (0.5, 2.0)

TARGETS = [
    Target("sideways launch: no link-step airborne", "launch", "airborne link-steps (%)", "fixed", 0.0, 0.0),
    Target("sideways launch: Σ N = W within 2 % at every step from 20 ms on", "launch",
           "Σ N / W from 20 ms on, smallest … largest", "range fixed", 0.98, 1.02),
    Target("ramp start: largest lift within 1/1.5 … 1.5 × the reference's", "ramp", "largest lift, 0–1 s (mm)",
           "ratio", *R15, floor=0.5),
    Target("ramp start: largest 10-ms-window force on a link within 0.5 … 2 × the reference's", "ramp",
           "largest 10-ms-window N / m g, 0–1 s", "ratio", *R2),
    Target("ramp: steps with every link off the floor, 0.5 … 2 × the reference's (none where it has none)", "ramp",
           "steps with every link off the floor, 0–3 s", "ratio", *R2),
    Target("steady undulation: each link's mean load within 5 % of the reference's", "ramp",
           "steady undulation (1–3 s): mean N / m g per link, head → tail", "each ratio", 0.95, 1.05),
    Target("steady undulation: centre-of-mass speed within 0.8 … 1.25 × the reference's", "ramp",
           "centre of mass: mean horizontal speed, 1–3 s (mm/s)", "ratio", 0.8, 1.25),
    Target("sideways hit on the cylinders: largest lift within 1/1.5 … 1.5 × the reference's", "hit",
           "largest lift (mm)", "ratio", *R15, floor=1.0),
    Target("sideways hit: largest lift within 10 % between 1 ms and 0.1 ms", "hit", "largest lift (mm)", "ratio",
           0.9, 1.1, floor=1.0, against="fine"),
    Target("sideways hit: largest 10-ms-window obstacle force within 1/1.5 … 1.5 × the reference's", "hit",
           "largest 10-ms-window obstacle force on the snake (N)", "ratio", *R15),
    Target("upright snake tilted 1°: topples, at 0.8 … 1.2 × the reference's time", "upright",
           "topple time: top link 200 mm off (s)", "ratio", 0.8, 1.2),
    Target("upright snake tilted 1°: topples the reference's way (within 15°)", "upright",
           "topple direction (degrees from +x)", "angle", hi=15.0),
    Target("coasting: energy never rises by more than 1e-6 J in a step", "coasting",
           "largest energy rise in one recorded step (J)", "fixed", 0.0, 1e-6),
    Target("coasting: energy lost within 10 % of the reference's", "coasting", "energy change E(end) − E(0) (J)",
           "ratio", 0.9, 1.1),
    Target("peg impact: largest lift within 1/1.5 … 1.5 × the reference's (≤ 1 mm where it lifts less)", "peg",
           "largest lift (mm)", "ratio", *R15, floor=1.0),
    Target("peg impact: largest 10-ms-window obstacle force within 1/1.5 … 1.5 × the reference's", "peg",
           "largest 10-ms-window obstacle force on the snake (N)", "ratio", *R15),
    Target("mesh peg impact: largest lift within 1/1.5 … 1.5 × the reference's (≤ 1 mm where it lifts less)",
           "mesh", "largest lift (mm)", "ratio", *R15, floor=1.0),
    Target("mesh peg impact: largest 10-ms-window obstacle force within 1/1.5 … 1.5 × the reference's", "mesh",
           "largest 10-ms-window obstacle force on the snake (N)", "ratio", *R15),
    Target("flat heightfield: each link's mean load within 5 % of the reference's", "hf_flat",
           "steady undulation (1–3 s): mean N / m g per link, head → tail", "each ratio", 0.95, 1.05),
    Target("flat heightfield: centre-of-mass speed within 0.8 … 1.25 × the reference's", "hf_flat",
           "centre of mass: mean horizontal speed, 1–3 s (mm/s)", "ratio", 0.8, 1.25),
    Target("flat heightfield: largest force on a link in a step, 1–3 s, within 0.5 … 2 × the reference's",
           "hf_flat", "largest N / m g in a step, 1–3 s", "ratio", *R2),
    Target("flat heightfield equals the plane: centre-of-mass speed within 2 %", "hf_flat",
           "centre of mass: mean horizontal speed, 1–3 s (mm/s)", "ratio", 0.98, 1.02, against="scene:ramp"),
    Target("flat heightfield equals the plane: displacement x within 2 % (or 1 mm)", "hf_flat",
           "centre of mass: displacement x, y over the run (mm)", "diff", hi=0.02, floor=1.0,
           against="scene:ramp", component=0),
    Target("flat heightfield equals the plane: displacement y within 2 % (or 1 mm)", "hf_flat",
           "centre of mass: displacement x, y over the run (mm)", "diff", hi=0.02, floor=1.0,
           against="scene:ramp", component=1),
    Target("flat heightfield equals the plane: each link's mean load within 2 %", "hf_flat",
           "steady undulation (1–3 s): mean N / m g per link, head → tail", "each ratio", 0.98, 1.02,
           against="scene:ramp"),
    Target("flat heightfield equals the plane: largest force on a link in a step, 1–3 s, within 2 %", "hf_flat",
           "largest N / m g in a step, 1–3 s", "ratio", 0.98, 1.02, against="scene:ramp"),
    Target("flat heightfield: centre-of-mass speed within 2 % between 1 ms and 0.5 ms", "hf_flat",
           "centre of mass: mean horizontal speed, 1–3 s (mm/s)", "ratio", 0.98, 1.02, against="fine"),
    Target("bumpy heightfield: each link's mean load within 5 % of the reference's (or both ≤ 0.05)", "hf_bumps",
           "steady undulation (1–3 s): mean N / m g per link, head → tail", "each ratio", 0.95, 1.05, floor=0.05),
    Target("bumpy heightfield: centre-of-mass speed within 0.8 … 1.25 × the reference's", "hf_bumps",
           "centre of mass: mean horizontal speed, 1–3 s (mm/s)", "ratio", 0.8, 1.25),
    Target("bumpy heightfield: largest 10-ms-window force on a link, 1–3 s, within 0.5 … 2 × the reference's",
           "hf_bumps", "largest 10-ms-window N / m g, 1–3 s", "ratio", *R2),
    Target("bumpy heightfield: centre-of-mass speed within 5 % between 1 ms and 0.5 ms", "hf_bumps",
           "centre of mass: mean horizontal speed, 1–3 s (mm/s)", "ratio", 0.95, 1.05, against="fine"),
    Target("bumpy heightfield: each link's mean load within 5 % between 1 ms and 0.5 ms (or both ≤ 0.05)",
           "hf_bumps", "steady undulation (1–3 s): mean N / m g per link, head → tail", "each ratio", 0.95, 1.05,
           floor=0.05, against="fine"),
    Target("break-away within 1 % of μN", "breakaway", "break-away force / μN (ramp μN per 1 s)", "fixed",
           0.99, 1.01),
]


def evaluate(raw: dict, mus, engines, targets=TARGETS) -> list[Verdict]:
    """`raw[(scene, mu, engine, figure)]`: the figures; the fine-step runs are engine
    "ENGINE@fine". A target is left out where its scene, or the run it compares with, was not
    run (a subset of scenes); a figure missing from a run that was made fails."""
    ran = {(k[0], k[1], k[2]) for k in raw}
    out = []
    for t in targets:
        for mu in mus:
            for e in engines:
                if t.against == "drake":
                    other = (t.scene, mu, "drake")
                elif t.against == "fine":
                    other = (t.scene, mu, f"{e}@fine")
                elif t.against.startswith("scene:"):
                    other = (t.against[6:], mu, e)
                else:
                    raise ValueError(f"unknown comparison {t.against!r}")
                if (t.scene, mu, e) not in ran or other not in ran:
                    continue
                ours = raw.get((t.scene, mu, e, t.figure))
                ref = raw.get(other + (t.figure,))
                passed, bound = check_fine(t, ours, ref) if t.against == "fine" else check(t, ours, ref)
                out.append(Verdict(t, mu, e, ours, ref, passed, bound))
    return out


def _against_label(t: Target) -> str:
    if t.against == "drake":
        return "Drake"
    if t.against == "fine":
        return "SimSerpent, finer step"
    return f"SimSerpent, scene {t.against[6:]}"


def failures(verdicts: list[Verdict]) -> list[str]:
    """One line per miss: scene, μ, figure, both values, the bound."""
    lines = []
    for v in verdicts:
        if v.passed is False or v.passed is None:
            t = v.target
            what = "FAIL" if v.passed is False else "MISSING"
            lines.append(
                f"{what} scene {t.scene}, μ {v.mu:g}, figure \"{t.figure}\""
                + (f" [{t.component}]" if t.component is not None else "")
                + f": SimSerpent {v.engine} {show(_pick(v.ours, t.component))}, "
                f"{_against_label(t)} {show(_pick(v.ref, t.component))}; bound {v.bound} ({t.name})"
            )
    return lines


def show(value) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, tuple):
        return " … ".join(f"{v:.4g}" for v in value)
    if isinstance(value, list):
        return "(" + " / ".join(f"{v:.3f}" for v in value) + ")"
    if isinstance(value, (int, float)):
        return _g(float(value))
    return str(value)


def report(verdicts: list[Verdict], header: list[str]) -> str:
    lines = ["# Contact events: targets against the reference", "", *header, "",
             "Every bound is two-sided. \"against\": what the figure is compared with — Drake (the reference, same "
             "scene and μ, resampled to SimSerpent's step), SimSerpent at the scene's finer step (convergence), or "
             "SimSerpent's own figure in another scene.", "",
             "| target | μ | build | against | SimSerpent | compared with | bound | verdict |",
             "|---|---|---|---|---|---|---|---|"]
    for v in verdicts:
        t = v.target
        mark = "n/a" if v.passed is None else ("pass" if v.passed else "**FAIL**")
        ours = _pick(v.ours, t.component) if not t.kind.startswith("each") else v.ours
        ref = _pick(v.ref, t.component) if not t.kind.startswith("each") else v.ref
        lines.append(f"| {t.name} | {v.mu:g} | {v.engine} | {_against_label(t)} | {show(ours)} | {show(ref)} | "
                     f"{v.bound} | {mark} |")
    n_fail = sum(1 for v in verdicts if v.passed is False)
    n_na = sum(1 for v in verdicts if v.passed is None)
    lines += ["", f"{len(verdicts) - n_fail - n_na} of {len(verdicts)} checks pass, {n_fail} fail"
              + (f", {n_na} n/a" if n_na else "") + ".", ""]
    return "\n".join(lines)
