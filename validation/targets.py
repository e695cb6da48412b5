"""The targets of a contact law (issue "contact events", item 3), checked against the reference.

Each target compares one SimSerpent figure with a fixed bound or with Drake's figure of the same
scene and μ; `report` writes them as a markdown table with pass/fail per build.
"""

from __future__ import annotations

import math


def _get(raw: dict, scene: str, mu: float, engine: str, figure: str):
    return raw.get((scene, mu, engine, figure))


def _targets():
    """(name, scene, figure, check(ours, reference) -> (passed, shown value))."""

    def launch_airborne(ours, ref):
        return ours == 0.0, f"{ours:.3g} %"

    def launch_load(ours, ref):
        worst = max(abs(ours[0] - 1), abs(ours[1] - 1))
        return worst <= 0.02, f"{ours[0]:.3f} … {ours[1]:.3f}"

    def within(factor):
        def check(ours, ref):
            return ours <= factor * ref, f"{ours:.3g} (≤ {factor * ref:.3g})"

        return check

    def hit_lift(ours, ref):
        bound = 5.0 if ref <= 5.0 else 1.5 * ref
        return ours <= bound, f"{ours:.3g} mm (≤ {bound:.3g})"

    def per_link(tol, absolute):
        def check(ours, ref):
            if absolute:
                worst = max(abs(o - 1.0) for o in ours)
            else:
                worst = max(abs(o / r - 1.0) for o, r in zip(ours, ref))
            return worst <= tol, f"worst {100 * worst:.1f} %"

        return check

    def upright(ours, ref):
        return ours <= 1.0, f"{ours:.3g} mm"

    def breakaway(ours, ref):
        if ours is None or isinstance(ours, str) or (isinstance(ours, float) and math.isnan(ours)):
            return None, "n/a"
        return abs(ours - 1.0) <= 0.01, f"{ours:.4f}"

    def energy(ours, ref):
        return ours <= 1e-6, f"{ours:.2e} J"

    return [
        ("sideways launch: 0 % of link-steps airborne", "launch", "airborne link-steps (%)", launch_airborne),
        ("sideways launch: Σ N = W within 2 % at every step from 20 ms on", "launch",
         "Σ N / W from 20 ms on, smallest … largest", launch_load),
        ("ramp start: largest lift ≤ 1.5 × the reference's", "ramp", "largest lift, 0–1 s (mm)", within(1.5)),
        ("ramp start: largest N / m g ≤ 2 × the reference's", "ramp", "largest N / m g, 0–1 s", within(2.0)),
        ("sideways hit: no link above 5 mm (1.5 × the reference's lift where it lifts more)", "hit",
         "largest lift (mm)", hit_lift),
        ("snake at rest: each link carries its weight within 2 %", "rest",
         "mean N / m g per link, 0.5–1 s, head → tail", per_link(0.02, True)),
        ("steady undulation: each link's mean load within 5 % of the reference's", "ramp",
         "steady undulation (1–3 s): mean N / m g per link, head → tail", per_link(0.05, False)),
        ("upright snake: top link ≤ 1 mm off after 2 s", "upright", "top link's horizontal offset at the end (mm)",
         upright),
        ("break-away within 1 % of μN", "breakaway", "break-away force / μN (ramp μN per 1 s)", breakaway),
        ("coasting: energy never rises by more than 1e-6 J in a step", "coasting",
         "largest energy rise in one recorded step (J)", energy),
    ]


def report(rows: list[dict], mus, engines, header: list[str]) -> str:
    raw = {(r["scene"], r["mu"], r["engine"], r["figure"]): r.get("raw") for r in rows}
    lines = ["# Contact events: targets against the reference", "", *header, "",
             "Each cell: SimSerpent's figure, then pass/fail; the reference's figure in its own column.", ""]
    cols = [(mu, e) for mu in mus for e in engines]
    lines.append("| target | " + " | ".join(f"μ {mu:g} Drake | μ {mu:g} {e}" if i % len(engines) == 0 else
                                           f"μ {mu:g} {e}" for i, (mu, e) in enumerate(cols)) + " |")
    n_cols = len(cols) + len(mus)
    lines.append("|---|" + "---|" * n_cols)
    for name, scene, figure, check in _targets():
        cells = []
        present = False
        for i, (mu, e) in enumerate(cols):
            ref = _get(raw, scene, mu, "drake", figure)
            if i % len(engines) == 0:
                cells.append(_show(ref))
            ours = _get(raw, scene, mu, e, figure)
            if ours is None and ref is None:
                cells.append("")
                continue
            present = True
            ok, shown = check(ours, ref) if ours is not None else (None, "n/a")
            mark = "n/a" if ok is None else ("pass" if ok else "**fail**")
            cells.append(f"{shown} {mark}" if ok is not None else shown)
        if present:
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines.append("")
    return "\n".join(lines)


def _show(ref) -> str:
    if ref is None:
        return ""
    if isinstance(ref, tuple):
        return " … ".join(f"{v:.3f}" for v in ref)
    if isinstance(ref, list):
        return "(" + " / ".join(f"{v:.2f}" for v in ref) + ")"
    if isinstance(ref, float):
        return f"{ref:.3g}"
    return str(ref)
