"""docs/tasks.md quotes what the committed results in docs/results/tasks/ hold (no rerun here).

Every measured figure of the page comes from one of five files: ``baselines.json`` (written by
``python -m perf.studies.task_baselines --json``), ``noise-floor.json`` (its
``--noise-floor-only``, which keeps each design's F per nudged scene),
``placements-output.txt`` and ``walls-output.txt`` (``python -m perf.studies.task_placements``,
the second with ``--walls``) and ``success-standing-output.txt`` (``python -m
perf.studies.task_success_standing``); the figures that are definitions come from the task
registry. The results table is rebuilt from baselines.json and compared line by line; each
figure of the prose is formatted from its file and looked for on the page, so a rerun that
moves a number fails here until the page says the new one.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
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
        elif line.startswith("| ") and not line.startswith(("| design", "|---", "| y ")):
            cells = [c.strip() for c in line.strip("|").split("|")]
            if re.fullmatch(r"-?[\d.]+", cells[0]):  # a row of the goal grid, not a design
                continue
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
    moved = {
        r["task"]: r
        for r in json.loads((RESULTS / "floor-moving.json").read_text(encoding="utf-8"))
    }
    moving = [moved[t] for t in TASKS]
    assert {m["moved_threshold"] for m in moving} == {0.01}  # the row's "> 1 cm"
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
        line(
            "noise floor of F over the old set (the straight tool and the first 8 usable random "
            "designs), median relative range",
            [_pct(f["median_relative_range"], 2) for f in floor],
        ),
        line(
            f"... its largest, over the {designs.pop()} designs",
            [_pct(f["max_relative_range"], 2) for f in floor],
        ),
        line("... median range in F units", [short(f["median_range"]) for f in floor]),
        # The box-moving floor (floor-moving.json, tests/test_task_floor.py): which of the old
        # set's designs move the box, and the floor over the designs that do.
        line(
            "... old-set designs that move the box (> 1 cm)",
            [f"{m['old_set']['moved_box']} of {m['old_set']['designs']}" for m in moving],
        ),
        line(
            "noise floor on the box-moving designs (below): median of \\|F\\| / of the F span",
            [
                f"{_pct(m['moving']['median_relative_range'], 2)} / "
                f"{_pct(m['moving']['median_span_relative'], 2)}"
                for m in moving
            ],
        ),
        line(
            "F of random designs: min / quartiles / max",
            [" / ".join(f"{q:.0f}" for q in r["random"]["free_energy_quantiles"]) for r in rows],
        ),
        line(
            "usable random designs", [f"{r['random']['usable']} / {r['random']['n']}" for r in rows]
        ),
        line(
            "success of random designs",
            [
                f"{_pct(r['random']['success_rate'])} "
                f"({round(r['random']['success_rate'] * r['random']['n'])})"
                for r in rows
            ],
        ),
        line(
            "straight tool: F, final distance, success",
            [
                f"{s['free_energy']:.0f}, {s['final_distance']:.3f} m, {yes[s['success']]}"
                for s in straight
            ],
        ),
        line(f"CMA-ES ({n_cmaes} evaluations): best F", [f"{b['free_energy']:.0f}" for b in best]),
        line("... its design (c1, c2, c3)", [_design(b["design"]) for b in best]),
        line(
            "... its final distance, success",
            [f"{b['final_distance']:.3f} m, {yes[b['success']]}" for b in best],
        ),
        line(
            f"... share of its {n_cmaes} evaluations that succeed",
            [_pct(r["cmaes"]["success_rate_of_its_evaluations"]) for r in rows],
        ),
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
        assert summary == {
            k: v for k, v in baselines[task]["noise_floor"].items() if k != "per_design"
        }, task


def _largest(floor: dict[str, Any]) -> dict[str, Any]:
    row: dict[str, Any] = max(floor["per_design"], key=lambda r: r["relative_range"])
    return row


def _of(floor: dict[str, Any], design: list[float]) -> dict[str, Any]:
    (row,) = [r for r in floor["per_design"] if r["design"] == design]
    return row


def _wall_claims() -> list[str]:
    """The figures of *How the curb was chosen*, from walls-output.txt."""
    from tooldesign_env.tasks import get_task

    walls = _tables("walls-output.txt")
    text = (RESULTS / "walls-output.txt").read_text(encoding="utf-8")
    sections = dict(re.findall(r"## (.*)\n((?:.|\n)*?)(?=\n## |\Z)", text))

    def floor(heading: str) -> tuple[str, str]:
        median, largest = re.search(
            r"noise floor of task_baselines' set .*: median ([\d.]+ %), largest ([\d.]+ %)",
            sections[heading],
        ).groups()
        return median, largest

    claims = []
    way = re.search(r"carried at ([\d.]+) to ([\d.]+) m \(.*?([\d.]+) m at 60 degrees", text)
    claims.append(
        f"the straight tool carries the box at radius {way[1]} to {way[2]} m, "
        f"{way[3]} m at 60 degrees"
    )
    tall = walls["wall at 60 degrees from radius 1.3 to 1.7 m, 0.4 m high, friction 0.5"]
    off = [1000 * float(r[-1]) for r in tall.values()]
    assert min(off) > 20  # every tool held up
    claims.append(f"all {len(tall)} designs {min(off):.0f} to {max(off):.0f} mm off their plan")
    chosen = "wall at 60 degrees from radius 1.3 to 1.7 m, 0.04 m high, friction 1"
    curb = walls[chosen]
    claims.append(f"to {float(curb['bow (0, 0.6, 0)'][3]):.3f} m of the goal")
    assert float(curb["bow (0, 0.6, 0)"][1]) == 0.1
    inner = "wall at 60 degrees from radius 1.2 to 1.6 m, 0.04 m high, friction 0.5"
    assert float(walls[inner]["bow (0, 0.6, 0)"][1]) < 0.09  # "from 1.2 m the curb stops it"
    assert "not standing but within 0.1 m of a goal of the range: 1" in sections[inner]
    mild = "wall at 60 degrees from radius 1.3 to 1.7 m, 0.04 m high, friction 0.5"
    slippery = "wall at 60 degrees from radius 1.3 to 1.7 m, 0.04 m high, friction 0.2"

    def named_ranges(heading: str) -> dict[str, str]:
        line = re.search(r"relative range of F over 5 nudged scenes: (.*)", sections[heading])
        return dict(re.findall(r"(\S.*?) ([\d.]+ %)(?:, |$)", line[1]))

    r05, r10 = named_ranges(mild), named_ranges(chosen)
    f05, f02, f10 = floor(mild), floor(slippery), floor(chosen)
    claims.append(
        f"F's relative range {r05['straight']} for the straight tool and "
        f"{r05['tilt (0, 0, 0.2)']} for the tilted one; over the noise-floor set of "
        f"the baselines a median of {f05[0]}, largest {f05[1]}"
    )
    outcome = re.search(r"tipped (\d+) .*?lying (\d+)", sections[slippery])
    assert int(outcome[2]) > int(outcome[1])  # "most slid off and fell"
    claims.append(f"with 0.2 most slid off and fell (median {f02[0]}, largest {f02[1]})")
    claims.append(
        f"they stay ({r10['straight']} and {r10['tilt (0, 0, 0.2)']}; median "
        f"{f10[0]}, largest {f10[1]}, the S-shaped tool"
    )
    f03 = floor("wall at 60 degrees from radius 1.3 to 1.7 m, 0.03 m high, friction 1")
    f05h = floor("wall at 60 degrees from radius 1.3 to 1.7 m, 0.05 m high, friction 1")
    at70 = "wall at 70 degrees from radius 1.25 to 1.8 m, 0.04 m high, friction 1"
    f70 = floor(at70)
    claims.append(
        f"Heights 0.03 and 0.05 m (medians {f03[0]} and {f05h[0]}) and the curb at 70 "
        f"degrees ({f70[0]})"
    )
    highest = float(re.search(r"its centre [\d.]+ to ([\d.]+) m high", sections[at70])[1])
    assert abs(highest - 0.1) <= get_task("obstacle").height_tolerance  # caught by its tilt
    claims.append(f"ended lying across the curb, its centre {highest:.3f} m high")
    tipped = [float(curb[k][1]) for k in ("straight", "tilt (0, 0, 0.2)")]
    lying = [float(curb[k][1]) for k in ("bow (0, 0.2, 0)", "bow back (0, -0.6, 0)")]
    assert max(tipped) < 0.09 and min(tipped) > 0.06 and lying == [0.05, 0.05]
    claims.append(f"(its centre {min(tipped):.3f} to {max(tipped):.3f} m high instead of 0.1 m)")
    counts = re.search(
        r"64 random designs \(seed 0\): (\d+) usable; the box ends standing (\d+), tipped (\d+) "
        r"\(its centre [\d.]+ to [\d.]+ m high, its up axis (\d+) to (\d+) degrees from the "
        r"vertical\), lying (\d+); shot away \(> 2 m from the base\) 0",
        sections[chosen],
    )
    assert counts is not None
    _, stand, tip, low, high, lie = counts.groups()
    claims.append(
        f"{stand} end with the box standing, {tip} tipped (up axis {low} to {high} "
        f"degrees from the vertical), {lie} lying, none shot away"
    )
    task = get_task("obstacle")
    (x0, y0, _), (x1, y1, _) = task.goal_low, task.goal_high
    in_range = [int(v) for v in re.findall(r"(\d+)\*", sections[chosen])]
    assert len(in_range) == round((x1 - x0) / 0.05 + 1) * round((y1 - y0) / 0.05 + 1)
    claims.append(f"at every goal of the range {min(in_range)} to {max(in_range)} of them succeed")
    assert min(in_range) >= 1
    assert "between the start and every goal" in sections[chosen]
    angles = re.search(r"corners are at ([\d.]+) to ([\d.]+) degrees", sections[chosen])
    claims.append(f"lie beyond it along that way ({angles[1]} to {angles[2]} degrees)")
    return claims


def test_the_standing_test_changed_no_success_of_the_baselines():
    """success-standing-output.txt: every task's 191 baseline evaluations, both rules."""
    text = (RESULTS / "success-standing-output.txt").read_text(encoding="utf-8")
    lines = dict(re.findall(r"^(\w+): (.*)$", text, flags=re.MULTILINE))
    assert sorted(lines) == sorted(TASKS)
    tilts = {}
    for task, line in lines.items():
        assert "191 evaluations" in line and "differing 0;" in line, task
        tilts[task] = float(re.search(r"largest final tilt ([\d.]+) degrees", line)[1])
    upright = max(tilts[t] for t in ("push", "hook", "puck"))
    assert upright < 1.0
    assert f"(largest tilt {upright:.3f} degrees)" in _page()
    baselines = _baselines()
    successes = int(re.search(r"standing too (\d+)", lines["obstacle"])[1])
    row = baselines["obstacle"]
    from_json = (
        sum(r["success"] for r in row["named"].values())
        + round(row["random"]["success_rate"] * row["random"]["n"])
        + round(row["cmaes"]["success_rate_of_its_evaluations"] * row["cmaes"]["evaluations"])
    )
    assert successes == from_json  # the same evaluations as baselines.json's


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
    missing = [
        hook["named"][k]["final_distance"]
        for k in ("straight", "bow back (0, -0.6, 0)", "bow (0, 0.6, 0)")
    ]
    claims.append(f"({min(missing):.2f} to {max(missing):.2f} m from the goal)")
    obstacle_named = obstacle["named"]
    claims.append(
        f"The straight tool leaves the box tipped onto the curb, "
        f"{obstacle_named['straight']['final_distance']:.3f} m from the goal"
    )
    claims.append(
        f"the hooks (0.4, 1.4, 0.18) and (0, 1.5, 0) carry it around and end "
        f"{obstacle_named['hook (0.4, 1.4, 0.18)']['final_distance']:.3f} and "
        f"{obstacle_named['hook (0, 1.5, 0)']['final_distance']:.3f} m from it"
    )
    assert not obstacle_named["straight"]["success"]
    assert obstacle_named["hook (0.4, 1.4, 0.18)"]["success"]
    assert obstacle_named["hook (0, 1.5, 0)"]["success"]
    # The first design, the post (placements-output.txt).
    post = places["post at radius 1.75 m, 60 degrees"]
    in_way = places["post at radius 1.6 m, 55 degrees"]["hook (0, 1.5, 0)"]
    x, y = (float(v) for v in in_way[0].strip("()").split(","))
    start = (1.169, 0.675)  # the push box's start, SceneSpec()
    claims.append(
        f"shot it {((x - start[0]) ** 2 + (y - start[1]) ** 2) ** 0.5:.1f} m away "
        f"(F {int(in_way[3]):,}), to {in_way[0]}"
    )
    held = [post[k] for k in ("straight", "tilt (0, 0, 0.2)", "bow back (0, -0.6, 0)")]
    off = [1000 * float(r[-1]) for r in held]
    to_goal = [float(r[2]) for r in held]
    claims.append(
        f"({min(off):.0f} to {max(off):.0f} mm off their plan) and left the box "
        f"{min(to_goal):.2f} to {max(to_goal):.2f} m from that design's goal"
    )
    claims.append(
        f"brings the box to {push['named']['straight']['final_distance']:.3f} m of the "
        f"goal, leaves the puck {puck['named']['straight']['final_distance']:.3f} m off"
    )
    puck_lines = (RESULTS / "placements-output.txt").read_text(encoding="utf-8")
    friction = dict(re.findall(r"puck friction ([\d.]+): .*? median ([\d.]+ %)", puck_lines))
    claims.append(f"With the box's friction 0.4 the puck's noise floor was {friction['0.4']} of F")
    claims.append(f"with 0.2 it is {friction['0.2']}")
    assert friction["0.2"] == _pct(puck["noise_floor"]["median_relative_range"], 2)
    # The walls and curbs tried in the box's way (walls-output.txt).
    claims.extend(_wall_claims())
    # The shape decides.
    for task, row in b.items():
        best = row["cmaes"]["best"]["free_energy"]
        median = row["random"]["free_energy_quantiles"][2]
        noise = row["noise_floor"]["median_range"]
        noise_text = f"{noise:.0f}" if noise >= 10 else f"{noise:.1f}"
        if task == "push":
            claims.append(
                f"push {best:.0f} against a median random F of {median:.0f} "
                f"({median - best:.0f}, about {(median - best) / noise:.0f} times the "
                f"median noise of {noise_text})"
            )
        else:
            claims.append(
                f"{task} {best:.0f} against {median:.0f} ({median - best:.0f}; noise {noise_text})"
            )
    claims.append(
        f"({hook['named']['straight']['final_distance']:.2f} and "
        f"{obstacle['named']['straight']['final_distance']:.2f} m from the goal)"
    )
    claims.append(
        f"in puck it misses by {puck['named']['straight']['final_distance']:.2f} m "
        f"where it brings the box to {push['named']['straight']['final_distance']:.2f} m"
    )
    # The noise floor, per design (noise-floor.json).
    medians = [b[t]["noise_floor"]["median_relative_range"] for t in TASKS]
    claims.append(f"at most {_pct(max(medians), 2)} of F (median)")
    hook_top = _largest(floors["hook"])
    claims.append(
        f"its largest, {_pct(hook_top['relative_range'], 2)}, is "
        f"{_design(hook_top['design'])}'s, a bow that moves the box"
    )
    assert hook_top["free_energy"][0] < min(hook["random"]["free_energy_quantiles"][2:])
    top = _largest(floors["obstacle"])
    claims.append(
        f"Obstacle's largest, {_pct(top['relative_range'], 2)}, is an S-shaped tool, "
        f"{_design(top['design'])}, whose box reaches the curb"
    )
    assert top["free_energy_without_obstacles"] != top["free_energy"][0]  # it touches the curb
    push_top = _largest(floors["push"])
    claims.append(f"(largest {_pct(push_top['relative_range'])}, the same design)")
    assert push_top["design"] == top["design"]
    straight = _of(floors["obstacle"], [0.0, 0.0, 0.0])
    assert straight["free_energy_without_obstacles"] != straight["free_energy"][0]  # stopped
    claims.append(
        f"the straight tool, whose box tips onto the curb, moves by "
        f"{_pct(straight['relative_range'], 2)}"
    )
    untouched = [
        r
        for r in floors["obstacle"]["per_design"]
        if r["free_energy_without_obstacles"] == r["free_energy"][0]
    ]
    claims.append(
        f"{len(untouched)} of the {len(floors['obstacle']['per_design'])} designs "
        "never touch the curb (their F with it removed is the same, to the bit)"
    )
    # F's lowest design is not a success.
    curl, named_hook = hook["cmaes"]["best"], hook["named"]["hook (0.4, 1.4, 0.18)"]
    claims.append(
        f"whose F is {named_hook['free_energy'] - curl['free_energy']:.0f} below the "
        f"hook (0.4, 1.4, 0.18)'s while it leaves the box {curl['final_distance']:.3f} "
        f"m from the goal instead of {named_hook['final_distance']:.3f} m"
    )
    claims.append(
        f"ends {push['cmaes']['best']['final_distance']:.2f} and "
        f"{puck['cmaes']['best']['final_distance']:.2f} m off"
    )
    claims.append(f"which ends {push['named']['straight']['final_distance']:.2f} m off in push")
    claims.append(
        f"({_pct(push['cmaes']['success_rate_of_its_evaluations'], 0)} in push, "
        f"{_pct(hook['cmaes']['success_rate_of_its_evaluations'], 0)} in hook, "
        f"{_pct(obstacle['cmaes']['success_rate_of_its_evaluations'], 0)} in obstacle)"
    )
    cma, hooked = obstacle["cmaes"]["best"], obstacle["named"]["hook (0.4, 1.4, 0.18)"]
    claims.append(
        f"in obstacle it is a hook, {_design(cma['design'])}, that carries the box "
        f"around the curb and ends {cma['final_distance']:.3f} m off, its F "
        f"{hooked['free_energy'] - cma['free_energy']:.0f} below that of the hook "
        f"(0.4, 1.4, 0.18), which ends {hooked['final_distance']:.3f} m off"
    )
    assert not cma["success"] and hooked["success"]
    # The tier rule and the limits.
    shares = [_pct(b[t]["random"]["success_rate"])[:-2] for t in TASKS]
    claims.append(f"With p = {', '.join(shares[:-1])} and {shares[-1]} %")
    claims.append(
        f"the success rates of {_pct(puck['random']['success_rate'])} and "
        f"{_pct(push['random']['success_rate'])[:-2]} % are one and two designs"
    )
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
    (curb,) = obstacle.obstacles
    middle = math.hypot(*curb.position)
    angle = math.degrees(math.atan2(curb.position[1], curb.position[0]))
    assert math.isclose(math.degrees(curb.yaw), angle)  # radial
    # Where the straight line from the box's start to each goal of the range crosses the
    # curb's angle: inside its inner end.
    start = obstacle.box_start()[:2]
    along = np.array([math.cos(curb.yaw), math.sin(curb.yaw)])
    crossings = []
    for x in np.linspace(obstacle.goal_low[0], obstacle.goal_high[0], 11):
        for y in np.linspace(obstacle.goal_low[1], obstacle.goal_high[1], 11):
            d = np.array([x, y]) - start
            t = (along[0] * start[1] - along[1] * start[0]) / (along[1] * d[0] - along[0] * d[1])
            crossings.append(float(np.hypot(*(start + t * d))))
    assert max(crossings) < middle - curb.size[0] / 2
    return [
        f"The straight line from the start to a goal crosses {angle:.0f} degrees "
        f"{min(crossings):.2f} to {max(crossings):.2f} m from the base, inside the curb's inner "
        "end",
        f"the goal ({', '.join(f'{v:g}' for v in push.goal)}), drawn in {ranges(push)}",
        f"The box at ({', '.join(f'{v:g}' for v in hook.scene.box_position)})",
        f"Goals {ranges(hook)}",
        f"default ({', '.join(f'{v:g}' for v in hook.goal[:2])})",
        f"a curb {' x '.join(f'{v:g}' for v in curb.size)} m standing radially at "
        f"{angle:.0f} degrees, from radius {middle - curb.size[0] / 2:g} to "
        f"{middle + curb.size[0] / 2:g} m, with the floor's friction ({curb.friction:.1f})",
        f"Goals {ranges(obstacle)}, default ({', '.join(f'{v:g}' for v in obstacle.goal[:2])})",
        f"(diameter {puck.scene.box_size[0]:g} m, {puck.scene.box_size[2]:g} m high, "
        f"{puck.scene.box_mass:g} kg) and half its friction ({puck.scene.box_friction:g})",
        f"The success radius is {push.tolerance:g} m",
    ]


@pytest.mark.parametrize("index", range(9))
def test_each_definition_the_page_quotes_is_the_tasks(index):
    claims = _definition_claims()
    assert len(claims) == 9
    assert claims[index] in _page(), f"docs/tasks.md does not say {claims[index]!r}"
    if index == 8:
        from tooldesign_env.tasks import get_task

        assert {get_task(t).tolerance for t in TASKS} == {0.1}  # "in every task"


# --- tiers per (task, d): docs/results/tasks/tiers.json (python -m perf.studies.task_tiers) ---


def _tiers() -> dict[tuple[str, int], dict[str, Any]]:
    record = json.loads((RESULTS / "tiers.json").read_text(encoding="utf-8"))
    return {(c["task"], c["degree"]): c for c in record["cells"]}


@pytest.mark.slow  # imports the studies' modules (the simulation, the optimizers): seconds
def test_the_tiers_follow_the_rule_and_their_d3_cells_are_the_baselines():
    from benchmarks.reports.success import wilson_interval
    from perf.studies.task_baselines import tier

    tiers, baselines = _tiers(), _baselines()
    assert set(tiers) == {(t, d) for t in TASKS for d in (3, 5, 8)}
    for (task, degree), cell in tiers.items():
        assert cell["success_rate"] == cell["successes"] / cell["n"]
        # The random share's tier; labelled with CMA-ES's regret (task_tiers --protocol), the
        # cell keeps it as random_tier and its tier is the harder (tests/test_task_tiers.py).
        random_tier = cell.get("random_tier", cell["tier"])
        assert random_tier == tier(cell["success_rate"]), (task, degree)
        assert cell["success_95"] == list(wilson_interval(cell["successes"], cell["n"]))
        if degree == 3:  # the same draw as the baselines' (same seed sequence and bounds)
            random = baselines[task]["random"]
            assert (cell["n"], cell["usable"]) == (random["n"], random["usable"]), task
            assert cell["success_rate"] == random["success_rate"], task
            assert random_tier == baselines[task]["tier"], task


def _share_tier(share: float) -> str:
    """The random share's tier by the thresholds the page states (10 % and 1 %)."""
    return "easy" if share >= 0.10 else "medium" if share >= 0.01 else "hard"


def test_the_tier_table_of_the_page_is_tiers_json():
    rows = []
    for task in TASKS:
        cells = []
        for degree in (3, 5, 8):
            c = _tiers()[(task, degree)]
            low, high = c["success_95"]
            # "?" where the Wilson interval reaches another tier than the share's.
            spans = {_share_tier(v) for v in (low, c["success_rate"], high)}
            cells.append(
                f"{c['successes']}/{c['n']} ({100 * c['success_rate']:.1f} %, "
                f"[{100 * low:.1f}, {100 * high:.1f}] %): **{c.get('random_tier', c['tier'])}"
                f"{'?' if len(spans) > 1 else ''}**"
            )
        rows.append(f"| {task} | " + " | ".join(cells) + " |")
    text = PAGE.read_text(encoding="utf-8")
    for row in rows:
        assert row in text, row


def test_the_tier_study_refuses_bad_options():
    from perf.studies.task_tiers import parse_args

    for argv in (["--degrees", "4"], ["--random", "0"], ["--workers", "0"], ["--task", "pushh"]):
        with pytest.raises(SystemExit):
            parse_args(argv)


def test_a_tier_cell_without_a_usable_design_prints():
    from perf.studies.task_tiers import _line

    cell = {
        "task": "push",
        "degree": 8,
        "n": 2,
        "usable": 0,
        "successes": 0,
        "success_rate": 0.0,
        "success_95": [0.0, 0.66],
        "free_energy_median": None,
        "tier": "hard",
    }
    assert "0/2 usable, median F n/a: hard" in _line(cell)


def test_the_baselines_study_refuses_merge_without_a_file(capsys):
    from perf.studies.task_baselines import parse_args as baselines_args

    with pytest.raises(SystemExit):
        baselines_args(["--merge"])
    assert "--merge needs --json FILE" in capsys.readouterr().err
