"""Prints the BENCHMARKS.md section of the latest results (results/targets.md, tables.md and the
reference's cross-checks in results/checks/), with the commands that reproduce them."""

from __future__ import annotations

import csv
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"

CHECKS = [
    ("TAMSI, 0.1 ms, d per scene (the reference)", RESULTS / "figures.csv"),
    ("TAMSI, 0.05 ms", RESULTS / "checks" / "step-5e-5" / "figures.csv"),
    ("continuous plant, Runge–Kutta 3, accuracy 1e-4", RESULTS / "checks" / "continuous" / "figures.csv"),
    ("TAMSI, 0.1 ms, d = 10 s/m", RESULTS / "checks" / "dissipation-10" / "figures.csv"),
    ("TAMSI, 0.1 ms, d = 200 s/m", RESULTS / "checks" / "dissipation-200" / "figures.csv"),
]
FIGS = ["airborne link-steps, ramp 0–1 s (%)", "largest lift, 0–1 s (mm)", "largest N / m g, 0–1 s"]


def demote(text: str) -> list[str]:
    out = []
    for line in text.splitlines():
        if line.startswith("# "):
            continue
        out.append("#" + line if line.startswith("##") else line)
    return out


def main() -> None:
    lines = [
        "## Contact events against a reference engine (Drake)",
        "",
        "`validation/` builds each contact-event scene — a gait's ramp start, a sideways launch, a sideways",
        "hit on cylinders, an upright snake, coasting, a peg impact, break-away under a ramped push, a",
        "snake at rest — in Drake 1.51.1 (PyPI) from the MJCF SimSerpent generates for it (same capsules,",
        "masses, inertias, joints, servos, gait; the floor's MuJoCo stiffness as compliant point contact;",
        "Coulomb friction by TAMSI, Drake's non-convex solver) and computes the same figures from both",
        "engines' every-step tables (validation/README.md says how, and what \"the same stiffness\" means).",
        "",
        "```sh",
        "cargo build --release",
        "validation/run                                   # Drake and target/release/simserpent, μ 0.5 and 1.0",
        "validation/run --binary main=PATH1 --binary contact=PATH2   # two builds side by side",
        "```",
        "",
    ]
    for name in ("targets.md", "tables.md"):
        lines += demote((RESULTS / name).read_text())
        lines.append("")
    lines += [
        "### How firm the reference is: the ramp start under other Drake settings",
        "",
        "```sh",
        "validation/run --reference-only --drake-step 5e-5 --out validation/results/checks/step-5e-5",
        "validation/run --reference-only --scenes ramp --continuous --out validation/results/checks/continuous",
        "validation/run --reference-only --scenes ramp --dissipation 10 --out validation/results/checks/dissipation-10",
        "validation/run --reference-only --scenes ramp --dissipation 200 --out validation/results/checks/dissipation-200",
        "```",
        "",
        "| Drake | " + " | ".join(f"μ {m} {f}" for m in ("0.5", "1") for f in
                                   ("airborne 0–1 s (%)", "largest lift (mm)", "largest N / m g")) + " |",
        "|---|" + "---|" * 6,
    ]
    for name, path in CHECKS:
        if not path.exists():
            continue
        v = {(r["mu"], r["figure"]): r["value"] for r in csv.DictReader(path.open())
             if r["scene"] == "ramp" and r["engine"] == "drake"}
        lines.append(f"| {name} | " + " | ".join(v.get((m, f), "–") for m in ("0.5", "1.0") for f in FIGS) + " |")
    lines.append("")
    impacts = RESULTS / "checks" / "continuous-impacts" / "figures.csv"
    if impacts.exists():
        lines += [
            "The impacts with Drake's continuous plant (`validation/run --reference-only --scenes hit,peg,upright "
            "--continuous --out validation/results/checks/continuous-impacts`):",
            "",
            "| scene, figure | μ 0.5 TAMSI | μ 0.5 continuous | μ 1 TAMSI | μ 1 continuous |",
            "|---|---|---|---|---|",
        ]
        ref = _drake(RESULTS / "figures.csv")
        cont = _drake(impacts)
        for scene, figure in [("hit", "largest lift (mm)"), ("hit", "largest N / m g"),
                              ("hit", "largest obstacle force on the snake (N)"), ("peg", "largest lift (mm)"),
                              ("peg", "largest N / m g"), ("peg", "largest obstacle force on the snake (N)"),
                              ("upright", "top link's horizontal offset at the end (mm)")]:
            cells = [d.get((scene, m, figure), "–") for m in ("0.5", "1.0") for d in (ref, cont)]
            lines.append(f"| {scene}: {figure} | " + " | ".join(cells) + " |")
        lines.append("")
    print("\n".join(lines))


def _drake(path: Path) -> dict:
    return {(r["scene"], r["mu"], r["figure"]): r["value"] for r in csv.DictReader(path.open()) if r["engine"] == "drake"}


if __name__ == "__main__":
    main()
