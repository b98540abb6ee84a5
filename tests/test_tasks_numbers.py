"""docs/tasks.md quotes what the committed results in docs/results/tasks/ hold (no rerun here).

Every measured figure of the page comes from one of four files: ``baselines.json`` (written by
``python -m perf.studies.task_baselines --json``), ``noise-floor.json`` (its
``--noise-floor-only``, which keeps each design's F per nudged scene), and
``placements-output.txt`` and ``walls-output.txt`` (``python -m perf.studies.task_placements``,
the second with ``--walls``). The results table is
rebuilt from baselines.json and compared line by line; each figure of the prose is formatted
from its file and looked for on the page, so a rerun that moves a number fails here until the
page says the new one.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "tasks.md"
RESULTS = ROOT / "docs" / "results" / "tasks"
TASKS = ("push", "hook", "obstacle", "puck")


def _page() -> str:
    # Prose is wrapped at 100 characters: compare with single spaces.
    return re.sub(r"\s+", " ", PAGE.read_text(encoding="utf-8"))


def _baselines() -> dict[str, dict[str, Any]]:
    rows = json.loads((RESULTS / "baselines.json").read_text(encoding="utf-8"))
    return {row["task"]: row for row in rows}


def _floors() -> dict[str, dict[str, Any]]:
    rows = json.loads((RESULTS / "noise-floor.json").read_text(encoding="utf-8"))
    return {row["task"]: row["noise_floor"] for row in rows}


def _placements() -> dict[str, dict[str, list[str]]]:
    """placements-output.txt's tables: {placement: {design: [cells]}}."""
    return _tables("placements-output.txt")


def _tables(name: str) -> dict[str, dict[str, list[str]]]:
    """The tables of a study's output: {heading: {design: [cells after the design]}}."""
    out: dict[str, dict[str, list[str]]] = {}
    current = ""
    for line in (RESULTS / name).read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            current = line[3:]
            out[current] = {}
        elif line.startswith("| ") and not line.startswith(("| design", "|---")):
            cells = [c.strip() for c in line.strip("|").split("|")]
            out[current][cells[0]] = cells[1:]
    return out


def _design(values: list[float]) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in values) + ")"


def _pct(share: float, digits: int = 1) -> str:
    return f"{100 * share:.{digits}f} %"


def _table(baselines: dict[str, dict[str, Any]]) -> list[str]:
    """The results table of the page, from baselines.json."""
    rows = [baselines[t] for t in TASKS]

    def line(label: str, cells: list[str]) -> str:
        return f"| {label} | " + " | ".join(cells) + " |"

    def short(value: float) -> str:  # F units: whole numbers, one decimal below 10
        return f"{value:.0f}" if abs(value) >= 10 else f"{value:.1f}"

    goal = [f"({', '.join(f'{v:g}' for v in r['goal'])})" for r in rows]
    floor = [r["noise_floor"] for r in rows]
    designs = {f["designs"] for f in floor}
    assert len(designs) == 1
    yes = {True: "yes", False: "no"}
    straight = [r["named"]["straight"] for r in rows]
    best = [r["cmaes"]["best"] for r in rows]
    evaluations = {r["cmaes"]["evaluations"] for r in rows}
    assert len(evaluations) == 1
    (n_cmaes,) = evaluations
    return [
        "| | " + " | ".join(TASKS) + " |",
        "|---|" + "---|" * len(TASKS),
        line("goal", goal),
        line("noise floor of F, median relative range",
             [_pct(f["median_relative_range"], 2) for f in floor]),
        line(f"... its largest, over the {designs.pop()} designs",
             [_pct(f["max_relative_range"], 2) for f in floor]),
        line("... median range in F units", [short(f["median_range"]) for f in floor]),
        line("F of random designs: min / quartiles / max",
             [" / ".join(f"{q:.0f}" for q in r["random"]["free_energy_quantiles"]) for r in rows]),
        line("usable random designs",
             [f"{r['random']['usable']} / {r['random']['n']}" for r in rows]),
        line("success of random designs",
             [f"{_pct(r['random']['success_rate'])} "
              f"({round(r['random']['success_rate'] * r['random']['n'])})" for r in rows]),
        line("straight tool: F, final distance, success",
             [f"{s['free_energy']:.0f}, {s['final_distance']:.3f} m, {yes[s['success']]}"
              for s in straight]),
        line(f"CMA-ES ({n_cmaes} evaluations): best F", [f"{b['free_energy']:.0f}" for b in best]),
        line("... its design (c1, c2, c3)", [_design(b["design"]) for b in best]),
        line("... its final distance, success",
             [f"{b['final_distance']:.3f} m, {yes[b['success']]}" for b in best]),
        line(f"... share of its {n_cmaes} evaluations that succeed",
             [_pct(r["cmaes"]["success_rate_of_its_evaluations"]) for r in rows]),
        line("tier", [r["tier"] for r in rows]),
    ]


def test_the_results_table_is_baselines_json():
    page = PAGE.read_text(encoding="utf-8").splitlines()
    table = _table(_baselines())
    start = page.index(table[0])
    assert page[start : start + len(table)] == table


def test_the_noise_floor_file_is_the_baselines_noise_floor():
    """The rerun that keeps each design's F measured the floor baselines.json summarizes."""
    baselines, floors = _baselines(), _floors()
    for task in TASKS:
        summary = {k: v for k, v in floors[task].items() if k != "per_design"}
        assert summary == {k: v for k, v in baselines[task]["noise_floor"].items()
                           if k != "per_design"}, task


def _largest(floor: dict[str, Any]) -> dict[str, Any]:
    row: dict[str, Any] = max(floor["per_design"], key=lambda r: r["relative_range"])
    return row


def _of(floor: dict[str, Any], design: list[float]) -> dict[str, Any]:
    (row,) = [r for r in floor["per_design"] if r["design"] == design]
    return row


def _claims() -> list[str]:
    """Each figure the prose quotes, formatted from its file, as the page words it."""
    b, floors, places = _baselines(), _floors(), _placements()
    push, hook, obstacle, puck = (b[t] for t in TASKS)
    claims = []
    # The usage example and the tasks' paragraphs.
    claims.append(f"(True, {hook['named']['hook (0.4, 1.4, 0.18)']['final_distance']:.3f})")
    claims.append(
        f"the hooks (0.4, 1.4, 0.18) and (0, 1.5, 0) end "
        f"{hook['named']['hook (0.4, 1.4, 0.18)']['final_distance']:.3f} and "
        f"{hook['named']['hook (0, 1.5, 0)']['final_distance']:.3f} m from it"
    )
    missing = [hook["named"][k]["final_distance"]
               for k in ("straight", "bow back (0, -0.6, 0)", "bow (0, 0.6, 0)")]
    claims.append(f"({min(missing):.2f} to {max(missing):.2f} m from the goal)")
    post = places["post at radius 1.75 m, 60 degrees"]
    claims.append(f"pushed up to {1000 * float(post['straight'][-1]):.0f} mm off its plan, "
                  f"against {1000 * float(post['hook (0.4, 1.4, 0.18)'][-1]):.0f} mm")
    claims.append(f"the box stays {obstacle['named']['straight']['final_distance']:.2f} m from "
                  "the goal")
    # How the post was placed.
    in_way = places["post at radius 1.6 m, 55 degrees"]["hook (0, 1.5, 0)"]
    x, y = (float(v) for v in in_way[0].strip("()").split(","))
    start = (1.169, 0.675)  # the push box's start, SceneSpec()
    claims.append(f"shot it {((x - start[0]) ** 2 + (y - start[1]) ** 2) ** 0.5:.1f} m away "
                  f"(F {int(in_way[3]):,}), to {in_way[0]}")
    at45 = places["post at radius 1.75 m, 45 degrees"]["straight"]
    claims.append(f"the straight tool, {1000 * float(at45[-1]):.0f} mm off its plan, ends "
                  f"{float(at45[1]):.2f} m from the push goal")
    at70 = places["post at radius 1.75 m, 70 degrees"]["straight"]
    claims.append(f"held up ({1000 * float(at70[-1]):.0f} mm) and still brings the box to "
                  f"{float(at70[1]):.2f} m of the push goal")
    held = [post[k] for k in ("straight", "tilt (0, 0, 0.2)", "bow back (0, -0.6, 0)")]
    off = [1000 * float(r[-1]) for r in held]
    to_goal = [float(r[2]) for r in held]
    claims.append(f"({min(off):.0f} to {max(off):.0f} mm off their plan) and leave the box "
                  f"{min(to_goal):.2f} to {max(to_goal):.2f} m from the task's goal")
    claims.append(f"the bow (0, 0.2, 0) ends {float(post['bow (0, 0.2, 0)'][2]):.3f} m")
    claims.append(f"the largest F of the {obstacle['random']['n']} random designs, "
                  f"{obstacle['random']['free_energy_quantiles'][-1]:,.0f}")
    claims.append(f"brings the box to {push['named']['straight']['final_distance']:.3f} m of the "
                  f"goal, leaves the puck {puck['named']['straight']['final_distance']:.3f} m off")
    puck_lines = (RESULTS / "placements-output.txt").read_text(encoding="utf-8")
    friction = dict(re.findall(r"puck friction ([\d.]+): .*? median ([\d.]+ %)", puck_lines))
    claims.append(f"With the box's friction 0.4 the puck's noise floor was {friction['0.4']} of F")
    claims.append(f"with 0.2 it is {friction['0.2']}")
    assert friction["0.2"] == _pct(puck["noise_floor"]["median_relative_range"], 2)
    # The walls tried in the box's way (walls-output.txt).
    walls = _tables("walls-output.txt")
    tall = walls["wall at 60 degrees from radius 1.3 to 1.7 m, 0.4 m high"]
    off = [1000 * float(r[-1]) for r in tall.values()]
    claims.append(f"all {len(tall)} designs {min(off):.0f} to {max(off):.0f} mm off their plan")
    curb = walls["wall at 60 degrees from radius 1.3 to 1.7 m, 0.04 m high"]
    tipped = [float(curb[k][1]) for k in ("straight", "bow (0, 0.2, 0)", "tilt (0, 0, 0.2)")]
    assert max(tipped) < 0.09 and float(curb["bow (0, 0.6, 0)"][1]) == 0.1
    claims.append(f"its centre {min(tipped):.3f} to {max(tipped):.3f} m high instead of 0.1 m")
    claims.append(f"carries it inside the curb to {float(curb['bow (0, 0.6, 0)'][3]):.3f} m of "
                  "this task's goal")
    text = (RESULTS / "walls-output.txt").read_text(encoding="utf-8")
    noise = re.findall(r"relative range of F over 5 nudged scenes: (.*)", text)[1]
    spreads = {k: float(v) for k, v in re.findall(r"(\S.*?) ([\d.]+) %(?:, |$)", noise)}
    assert len(spreads) == len(curb)
    ordered = sorted(spreads.values())
    middle = (ordered[3] + ordered[4]) / 2
    top = max(spreads, key=lambda k: spreads[k])
    claims.append(f"a median {middle:.2f} % over the {len(spreads)} designs (largest "
                  f"{spreads[top]:.2f} %, the tilted tool)")
    assert top == "tilt (0, 0, 0.2)"
    inner = walls["wall at 60 degrees from radius 1.2 to 1.6 m, 0.04 m high"]
    assert float(inner["bow (0, 0.6, 0)"][1]) < 0.09  # "from radius 1.2 m the curb stops it"
    # The shape decides.
    for task, row in b.items():
        best = row["cmaes"]["best"]["free_energy"]
        median = row["random"]["free_energy_quantiles"][2]
        noise = row["noise_floor"]["median_range"]
        noise_text = f"{noise:.0f}" if noise >= 10 else f"{noise:.1f}"
        if task == "push":
            claims.append(f"push {best:.0f} against a median random F of {median:.0f} "
                          f"({median - best:.0f}, about {(median - best) / noise:.0f} times the "
                          f"median noise of {noise_text})")
        else:
            claims.append(f"{task} {best:.0f} against {median:.0f} ({median - best:.0f}; noise "
                          f"{noise_text})")
    claims.append(f"({hook['named']['straight']['final_distance']:.2f} and "
                  f"{obstacle['named']['straight']['final_distance']:.2f} m from the goal)")
    claims.append(f"in puck it misses by {puck['named']['straight']['final_distance']:.2f} m "
                  f"where it brings the box to {push['named']['straight']['final_distance']:.2f} m")
    # The noise floor, per design (noise-floor.json).
    medians = [b[t]["noise_floor"]["median_relative_range"] for t in TASKS]
    claims.append(f"at most {_pct(max(medians), 2)} of F (median)")
    hook_top = _largest(floors["hook"])
    claims.append(f"its largest, {_pct(hook_top['relative_range'], 2)}, is "
                  f"{_design(hook_top['design'])}'s, a bow that moves the box")
    assert hook_top["free_energy"][0] < min(hook["random"]["free_energy_quantiles"][2:])
    top = _largest(floors["obstacle"])
    claims.append(f"Obstacle's largest, {_pct(top['relative_range'])}, is an S-shaped tool, "
                  f"{_design(top['design'])}, that never touches the post")
    assert top["free_energy_without_obstacles"] == top["free_energy"][0]
    claims.append("its F with the post removed is the same, to the bit")
    push_top = _largest(floors["push"])
    claims.append(f"(largest {_pct(push_top['relative_range'])}, the same design)")
    assert push_top["design"] == top["design"]
    straight = _of(floors["obstacle"], [0.0, 0.0, 0.0])
    assert straight["free_energy_without_obstacles"] != straight["free_energy"][0]  # caught
    claims.append(f"the straight tool, caught on the post, moves by "
                  f"{_pct(straight['relative_range'], 2)}")
    # F's lowest design is not a success.
    curl, named_hook = hook["cmaes"]["best"], hook["named"]["hook (0.4, 1.4, 0.18)"]
    claims.append(f"whose F is {named_hook['free_energy'] - curl['free_energy']:.0f} below the "
                  f"hook (0.4, 1.4, 0.18)'s while it leaves the box {curl['final_distance']:.3f} "
                  f"m from the goal instead of {named_hook['final_distance']:.3f} m")
    claims.append(f"ends {push['cmaes']['best']['final_distance']:.2f} and "
                  f"{puck['cmaes']['best']['final_distance']:.2f} m off")
    claims.append(f"which ends {push['named']['straight']['final_distance']:.2f} m off in push")
    claims.append(f"({_pct(push['cmaes']['success_rate_of_its_evaluations'], 0)} in push, "
                  f"{_pct(hook['cmaes']['success_rate_of_its_evaluations'], 0)} in hook)")
    # The tier rule and the limits.
    shares = [_pct(b[t]["random"]["success_rate"])[:-2] for t in TASKS]
    claims.append(f"With p = {', '.join(shares[:-1])} and {shares[-1]} %")
    claims.append(f"the success rates of {_pct(puck['random']['success_rate'])} and "
                  f"{_pct(push['random']['success_rate'])[:-2]} % are one and two designs")
    return claims


@pytest.mark.parametrize("index", range(len(_claims())))
def test_each_figure_of_the_prose_is_its_files(index):
    claim = _claims()[index]
    assert claim in _page(), f"docs/tasks.md does not say {claim!r}"


def _definition_claims() -> list[str]:
    """The page's figures that are definitions, formatted from the task registry."""
    import math

    from tooldesign_env.tasks import get_task

    def ranges(task: Any) -> str:
        (x0, y0, _), (x1, y1, _) = task.goal_low, task.goal_high
        return f"x in [{x0:g}, {x1:g}], y in [{y0:g}, {y1:g}] m"

    push, hook, obstacle, puck = (get_task(t) for t in TASKS)
    (post,) = obstacle.obstacles
    radius = math.hypot(*post.position)
    angle = math.degrees(math.atan2(post.position[1], post.position[0]))
    return [
        f"the goal ({', '.join(f'{v:g}' for v in push.goal)}), drawn in {ranges(push)}",
        f"The box at ({', '.join(f'{v:g}' for v in hook.scene.box_position)})",
        f"Goals {ranges(hook)}",
        f"default ({', '.join(f'{v:g}' for v in hook.goal[:2])})",
        f"a post {' x '.join(f'{v:g}' for v in post.size)} m at radius {radius:.2f} m, "
        f"{angle:.0f} degrees",
        f"Goals {ranges(obstacle)}, default ({', '.join(f'{v:g}' for v in obstacle.goal[:2])})",
        f"(diameter {puck.scene.box_size[0]:g} m, {puck.scene.box_size[2]:g} m high, "
        f"{puck.scene.box_mass:g} kg) and half its friction ({puck.scene.box_friction:g})",
        f"The success radius is {push.tolerance:g} m",
    ]


@pytest.mark.parametrize("index", range(8))
def test_each_definition_the_page_quotes_is_the_tasks(index):
    claims = _definition_claims()
    assert len(claims) == 8
    assert claims[index] in _page(), f"docs/tasks.md does not say {claims[index]!r}"
    if index == 7:
        from tooldesign_env.tasks import get_task

        assert {get_task(t).tolerance for t in TASKS} == {0.1}  # "in every task"
