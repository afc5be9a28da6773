"""Whole episodes of TetherNavigate-v3 on the JAX kernel against the numba one (issue #45): the
same uniforms and actions, played to each side's end, and the outcomes compared
(`results/jax/episodes.json`).

    python -m benchmarks.validation.jax_episodes [--episodes 1000] [--hybrid-episodes N]
        [--ids ...] [--dynamics impulse hybrid] [--controls setup velocity aim ...]
        [--seed 0] [--json results/jax/episodes.json] [--overwrite]

A cell is a ladder id, a dynamics and a control mode (the id's own, `setup`, by default;
`jax_navigate_agreement.CONTROLS`). Its episodes start from seeded uniforms, the numba kernel's
(`NavigateKernel.reset`) and `tether_gym.jax.tether_navigate.kernel.sample_episode` from the same
rows (the JAX side consumes them in the numba order: the starts must be equal, `start_difference`),
and each side plays the same seeded random actions, maneuver by maneuver, from its own state until
its episode ends (terminated or truncated; no autoreset). An episode's outcome is its last
maneuver's `is_success`, `hit_post`, `at_rest` and `truncated` and its count of maneuvers (`ENDS`);
the two sides' outcomes are the same or the episode is changed.

A changed episode is explained at its first maneuver where the two sides part: their flags or
counts differ, they hooked other pegs (`jax_navigate_agreement.SAME_PEG`), or a continuous
outcome differs by more than `jax_navigate_agreement.DIVERGED` (float64 only:
`first_parting`). That maneuver is played again from the
numba side's state before it through the single-maneuver comparison
(`jax_navigate_agreement.compare`): where the kernels part there too, its class is the
explanation ("same state": a peg tie, a search tie, a tautening at a right angle, or the flags
that differ). Where they agree from the numba state, the maneuver is played from the JAX side's
state too: kernels that agree from either state make the episode "sensitive" (the JAX side
entered with its rounding, `entering`, which the maneuver's branch amplifies: both kernels
branch alike on either state), otherwise the class found from the JAX state. Each explanation
carries the margin to the threshold of the first branch that parted, where the outcome rows
give it (`margins`, in the maneuver's order: two pegs' bearings, the tether's gap at the
decision, a wall's or a post's reach along the path, the rest speed, the goal's edge), and is
classed by it (`BRANCHES`); an episode is `explained` where that margin is within `MARGIN` (a
branch within a tolerance of its threshold) or, from one state, `compare`'s class names a tie
or a right angle, and counted apart as unexplained otherwise. Episodes whose trajectories
parted but whose outcome is the same are counted too (`parted_same_outcome`).

Episode i of a cell draws its uniforms and actions from its own generator (`draws`: seed, i),
so a run's episodes are the first of any larger run's and one replays alone:
`play(jax_navigate_agreement.configuration(id, dynamics, control), seed, [i])`, then
`first_parting` and `explain` (each changed episode's record names its id, dynamics, control,
seed and episode). A cell plays `BATCH` episodes at a time. Cost on this 2-core CPU (float64,
after the first compile of each dynamics' step, 20 to 35 s impulse and 30 to 80 s hybrid):
about 1 ms an episode impulse and 20 to 25 ms hybrid (a hybrid block runs one contact after
another), the numba side a few per cent of that.

Precision as `jax_navigate_agreement`: float64 (`jax_enable_x64`) and XLA's CPU code without
fused multiply-adds (`NO_FMA`, `--fma` for the default build). `--precision float32` measures
the share of changed outcomes, but its explanations are not meaningful yet: there only flags,
counts and pegs part the sides (`compare`'s float32 rule), so the first parting is found where
float32's drift has long grown, and `MARGIN` is float64's.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.common import output_arguments, refuse_existing
from benchmarks.validation import jax_navigate_agreement as agreement
from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import (
    ARM,
    POST_RADIUS,
    PUCK_RADIUS,
    STATE,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.flight import AT_ONCE
from tether_gym.envs.tether_navigate.kernel import NavigateKernel
from tether_gym.envs.tether_navigate.spaces import OUTCOME
from tether_gym.evaluation import results_file
from tether_gym.tasks import navigate as task

RESULTS = Path("results/jax/episodes.json")
ENDS = ("is_success", "hit_post", "at_rest", "truncated")
"""An episode's outcome: its last maneuver's flags, and its count of maneuvers."""
BLOCK = {"impulse": 192, "hybrid": 8}
"""Episodes per call of the JAX step (`jax_navigate_agreement.jax_side`), per dynamics: every
call has this shape (padded), so the step compiles once per dynamics and control, and the
impulse one is the shape of the agreement tests' (`tests/jax/test_navigate_agreement.py`), which
a test run then compiles once. A hybrid block runs one contact after another
(`jax_navigate_agreement.CHUNK`): a small one wastes little on padding."""
MARGIN = 1e-6
"""m, m/s or rad: a branch within this of its threshold explains a changed episode (the
tolerance `jax_navigate_agreement.DIVERGED` of a continuous outcome)."""
NAMED = ("tie", "+-pi/2")
"""Classes of `compare` that name their branch (a tie of pegs or of the search, a tautening
at a right angle): explained without a margin."""


def _column(name: str) -> slice:
    start = OUTCOME.index[name]
    return slice(start, start + OUTCOME[name].size)


def numba_step(config: NavigateConfig):
    """(states, actions) -> (states after, outcome rows) of the numba kernel."""
    kernel = NavigateKernel(config)

    def step(states, actions):
        new, _, out = kernel.step(states.copy(), actions)
        return new, out

    return step


def after(states: np.ndarray, out: np.ndarray) -> np.ndarray:
    """The states after maneuvers whose outcome rows are `out`: the puck and the maneuvers left
    from the row (`jax.tether_navigate.kernel.step_episode` sets those and nothing else)."""
    new = states.copy()
    new["x"], new["y"] = out[:, _column("position")].T
    new["vx"], new["vy"] = out[:, _column("velocity")].T
    new["angle"], new["spin"] = out[:, OUTCOME.index["angle"]], out[:, OUTCOME.index["spin"]]
    new["maneuvers_left"] = out[:, OUTCOME.index["maneuvers_left"]].astype(STATE["maneuvers_left"])
    return new


def padded(config: NavigateConfig, states: np.ndarray, actions: np.ndarray):
    """`jax_navigate_agreement.jax_side` on `BLOCK` rows at a time (the last block padded by
    repeating its last row): (observations, outcome rows) of the given rows."""
    block = BLOCK[config.dynamics]
    n = len(states)
    obs, out = [], []
    for start in range(0, n, block):
        rows = np.arange(start, min(start + block, n))
        rows = np.concatenate([rows, np.full(block - len(rows), rows[-1])])
        o, r = agreement.jax_side(config, states[rows], actions[rows])
        obs.append(o[: min(block, n - start)])
        out.append(r[: min(block, n - start)])
    return np.concatenate(obs), np.concatenate(out)


def jax_step(config: NavigateConfig):
    """(states, actions) -> (states after, outcome rows) of the JAX kernel (`padded`)."""

    def step(states, actions):
        _, out = padded(config, states, actions)
        return after(states, out), out

    return step


def starts(config: NavigateConfig, uniforms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(numba's, JAX's) first states of the episodes drawn from `uniforms` (n, `UNIFORMS`)."""
    import jax

    from tether_gym.jax.tether_navigate import kernel as jn

    kernel = NavigateKernel(config)
    numba_states, _ = kernel.reset(np.ascontiguousarray(uniforms[:, : kernel.n_uniforms]))
    if "sample" not in _SAMPLE:
        _SAMPLE["sample"] = jax.jit(jax.vmap(jn.sample_episode, in_axes=(0, None)))
    params = jn.EnvParams.from_config(config)
    return numba_states, _SAMPLE["sample"](uniforms, params).to_numba()


_SAMPLE: dict = {}


def state_difference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per row, the largest difference of two batches of `STATE` records over every field
    (relative above 1, angles folded into (-pi, pi])."""
    worst = np.zeros(len(a))
    for name in STATE.names:
        x = np.asarray(a[name], np.float64).reshape(len(a), -1)
        y = np.asarray(b[name], np.float64).reshape(len(b), -1)
        if name == "angle":
            d = np.abs(np.pi - np.mod(np.pi - (x - y), 2.0 * np.pi))
        else:
            d = np.abs(x - y) / np.maximum(1.0, np.abs(y))
        worst = np.maximum(worst, d.max(axis=1, initial=0.0))
    return worst


class Episodes:
    """One side's episodes: `states[j]` the records before maneuver j, `outcome[j]` its
    outcome rows (nan where the episode had ended), `length` the maneuvers played, `seconds`
    the time they took."""

    def __init__(self, start: np.ndarray, actions: np.ndarray, step):
        clock = time.perf_counter()
        n, horizon = actions.shape[:2]
        self.states = np.repeat(start[None], horizon, axis=0)
        self.outcome = np.full((horizon, n, OUTCOME.width), np.nan)
        self.length = np.zeros(n, np.int64)
        state, alive = start.copy(), np.ones(n, bool)
        for j in range(horizon):
            rows = np.flatnonzero(alive)
            if rows.size == 0:
                break
            self.states[j, rows] = state[rows]
            new, out = step(state[rows], np.ascontiguousarray(actions[rows, j]))
            self.outcome[j, rows] = out
            state[rows] = new
            ended = (out[:, OUTCOME.index["terminated"]] != 0.0) | (
                out[:, OUTCOME.index["truncated"]] != 0.0
            )
            self.length[rows[ended]] = j + 1
            alive[rows[ended]] = False
        if alive.any():
            raise RuntimeError(f"{int(alive.sum())} episodes not ended after {horizon} maneuvers")
        self.seconds = time.perf_counter() - clock

    def ends(self) -> dict[str, np.ndarray]:
        """Each episode's outcome (`ENDS`) and `maneuvers`."""
        last = self.outcome[self.length - 1, np.arange(len(self.length))]
        found = {name: last[:, OUTCOME.index[name]] != 0.0 for name in ENDS}
        found["maneuvers"] = self.length
        return found


def first_parting(numba: Episodes, jax_: Episodes, diverged: float) -> np.ndarray:
    """Per episode, the first maneuver where the two sides part (their flags, counts or peg
    differ, or a continuous outcome differs by more than `diverged`); -1 where they never do."""
    n = len(numba.length)
    first = np.full(n, -1)
    for j in range(numba.outcome.shape[0]):
        both = (j < numba.length) & (j < jax_.length) & (first < 0)
        rows = np.flatnonzero(both)
        if rows.size == 0:
            continue
        d = agreement.differences(OUTCOME, jax_.outcome[j, rows], numba.outcome[j, rows])
        steps = (*agreement.FLAGS, *agreement.COUNTS)
        parted = np.any([d[name] != 0.0 for name in steps], axis=0)
        parted |= d["anchor"] > agreement.SAME_PEG
        rest = [v for name, v in d.items() if name not in (*steps, "anchor")]
        parted |= np.max(rest, axis=0) > diverged
        first[rows[parted]] = j
    return first


def _path(out: np.ndarray) -> np.ndarray:
    return out[_column("path")].reshape(-1, 2)


def post_reach(path: np.ndarray, state) -> float:
    """m: the least distance along `path` (its segments) from a post's centre less the reach of
    a touch (post and puck radii): 0 or less for a path that touches a post."""
    best = math.inf
    for k in range(int(state["n_posts"])):
        px, py = state["posts"][k]
        d = task.path_distance(np.ascontiguousarray(path), px, py)
        best = min(best, d - (POST_RADIUS + PUCK_RADIUS))
    return best


def wall_reach(path: np.ndarray) -> float:
    """m: the least distance of `path`'s points after its start from a wall less the puck's
    radius (a straight stretch is nearest a wall at one of its ends; the start is where the
    last maneuver left the puck)."""
    x, y = path[1:, 0], path[1:, 1]
    gaps = np.minimum.reduce([x, TABLE_WIDTH - x, y, TABLE_HEIGHT - y]) - PUCK_RADIUS
    return float(gaps.min())


def decision_gap(state, out: np.ndarray) -> float:
    """m: the tether's gap at the decision as the search for its tautening computes it
    (`events.time_to_taut_row`, relative to the peg): the attachment point's distance from
    the peg hooked less the tether's length (both from the outcome row `out`): 0 for a tether
    raised to the peg's distance (`maneuver.maneuver`), to rounding."""
    ax, ay = out[_column("anchor")]
    x = (state["x"] - ax) + ARM * math.cos(state["angle"])
    y = (state["y"] - ay) + ARM * math.sin(state["angle"])
    return float(math.hypot(x, y) - out[OUTCOME.index["tether_length"]])


BRANCHES = {
    "anchor": "peg tie (equal bearings)",
    "flight_time": "taut at once (tether at the peg's distance)",
    "wheel_target_time": "wheel plan",
    "wall_hits": "wall touch", "hit_post": "post touch", "at_rest": "rest speed",
    "is_success": "goal edge",
}  # fmt: skip
"""The branches whose margin `margins` measures, in the order a maneuver takes them (the peg
hooked; the tether taut at the decision, `flight.AT_ONCE`, or after a flight, and the wheel's
plan kept or not; the walls met in flight and contact, a post, the end's speed, the goal), and
the name of a parting there."""


def margins(config: NavigateConfig, states, action, numba_out, jax_out) -> dict[str, float | None]:
    """The distance to its threshold of each branch of `BRANCHES` that parted the two outcome
    rows of one maneuver from `states` (the numba side's and the JAX side's before it; of the
    two sides' values the larger), where they give it, in the maneuver's order: `anchor` (rad:
    `bearing_margin`; None under the aimed controls, whose search picks the peg),
    `flight_time` (m: `decision_gap`, where one side's tether went taut within
    `flight.AT_ONCE` of the decision and the other's did not, or one side's wheel kept its
    plan and the other's did not: `flight.fly`'s tests of a tether taut at once, with the free
    spin and with the wheel's, which a tether raised to the peg's distance meets or misses by
    the sign of its rounded gap where the attachment point pulls away slowly; where that gap
    is wider than `MARGIN`, `wheel_target_time` instead, None: the wheel's plan found on one
    side only, its margin not measured),
    `wall_hits` (m: the path's least clearance of a wall, the side with fewer hits),
    `hit_post` (m: the path's least clearance of a post, the side that missed it), `at_rest`
    (m/s: the speed from `REST_SPEED`), `is_success` (m: the goal's edge along the path, or at
    the end for "stop", where the end's speed and post agree). The first is the branch the
    sides parted at; the others may follow from it."""
    rows = (numba_out, jax_out)

    def flag(out, name):
        return out[OUTCOME.index[name]] != 0.0

    def differs(name):
        return flag(numba_out, name) != flag(jax_out, name)

    found = {}
    pegs = numba_out[_column("anchor")] - jax_out[_column("anchor")]
    if np.abs(pegs).max() > agreement.SAME_PEG:
        setup = config.control == "setup"
        pair = np.stack(states)
        bearings = agreement.bearing_margin(pair, np.stack([action, action]))
        found["anchor"] = float(bearings.max()) if setup else None
    at_once = [
        (out[OUTCOME.index["flight_time"]] <= AT_ONCE, out[OUTCOME.index["wheel_target_time"]] == 0)
        for out in rows
    ]
    if at_once[0] != at_once[1]:
        gaps = [decision_gap(state, out) for state, out in zip(states, rows, strict=True)]
        gap = float(max(abs(g) for g in gaps))
        if gap <= MARGIN:
            found["flight_time"] = gap
        else:  # a tether not at the peg's distance: the wheel's plan found on one side only
            found["wheel_target_time"] = None
    hits = [out[OUTCOME.index["wall_hits"]] for out in rows]
    if hits[0] != hits[1]:
        found["wall_hits"] = abs(wall_reach(_path(rows[int(np.argmin(hits))])))
    if differs("hit_post"):
        missed = jax_out if flag(numba_out, "hit_post") else numba_out
        found["hit_post"] = abs(post_reach(_path(missed), states[0]))
    if differs("at_rest"):
        speeds = [np.hypot(*out[_column("velocity")]) for out in rows]
        found["at_rest"] = max(abs(s - task.REST_SPEED) for s in speeds)
    if differs("is_success") and not differs("at_rest") and not differs("hit_post"):
        goal = (states[0]["goal_x"], states[0]["goal_y"])
        if config.task == "reach":
            reach = [task.path_distance(np.ascontiguousarray(_path(o)), *goal) for o in rows]
        else:
            reach = [np.hypot(*(o[_column("position")] - goal)) for o in rows]
        found["is_success"] = max(abs(r - task.GOAL_RADIUS) for r in reach)
    return found


def replay(config: NavigateConfig, state, action, diverged: float) -> tuple[bool, str]:
    """(changed, class): the single-maneuver comparison of the two kernels from `state` with
    `action` (`compare` on a `BLOCK` of copies, the JAX step's one shape)."""
    block = BLOCK[config.dynamics]
    states = np.repeat(state[None], block)
    actions = np.repeat(action[None], block, axis=0)
    result = agreement.compare(config, states, actions, diverged)
    return bool(result["changed"][0]), result["case_classes"][0]


def explain(config: NavigateConfig, numba: Episodes, jax_: Episodes, actions, i: int, j: int,
            diverged: float = agreement.DIVERGED) -> dict:  # fmt: skip
    """The explanation of episode i, whose sides part at maneuver j (module docstring): where
    (`source`: "same state", "JAX state" or "sensitive"), the class `compare` gave (`compare`:
    "" where the kernels agree from either state), the `margins` and the first one's `branch`
    and `margin`, the `class` (the source and the branch's name, or `compare`'s class where no
    margin is measured), the states' difference `entering` the maneuver, and whether it is
    `explained`."""
    before = numba.states[j, i]
    entering = float(state_difference(jax_.states[j, i : i + 1], numba.states[j, i : i + 1])[0])
    action = actions[i, j]
    changed, compared = replay(config, before, action, diverged)
    source = "same state"
    if not changed:
        changed, compared = replay(config, jax_.states[j, i], action, diverged)
        source = "JAX state" if changed else "sensitive"
    pair = (before, jax_.states[j, i])
    found = margins(config, pair, action, numba.outcome[j, i], jax_.outcome[j, i])
    branch = next(iter(found), None)
    margin = found[branch] if branch is not None else None
    named = source != "sensitive" and any(word in compared for word in NAMED)
    if margin is not None:
        kind = BRANCHES[branch]
    elif source != "sensitive":
        kind = compared
    elif branch == "anchor":
        kind = "peg (search)"
    else:
        kind = BRANCHES[branch] if branch is not None else "flight"
    return {
        "maneuver": j, "source": source, "class": f"{source}: {kind}", "compare": compared,
        "branch": branch, "margin": margin, "margins": found, "entering": entering,
        "explained": bool(named or (margin is not None and margin <= MARGIN)),
    }  # fmt: skip


def draws(config: NavigateConfig, seed: int, episodes) -> tuple[np.ndarray, np.ndarray]:
    """(uniforms (n, `UNIFORMS`), actions (n, max_maneuvers, width) in [-1, 1]) of the given
    episodes, episode i's from its own generator `default_rng((seed, i))`: a cell's first n
    episodes are those of any larger run, and (seed, i) replays one."""
    from tether_gym.jax.tether_navigate import kernel as jn

    width = len(NavigateKernel(config).action)
    uniforms = np.empty((len(episodes), jn.UNIFORMS))
    actions = np.empty((len(episodes), config.max_maneuvers, width))
    for k, i in enumerate(episodes):
        rng = np.random.default_rng((seed, i))
        uniforms[k] = rng.random(jn.UNIFORMS)
        actions[k] = rng.uniform(-1.0, 1.0, actions.shape[1:])
    return uniforms, actions


def play(config: NavigateConfig, seed: int, episodes) -> tuple[Episodes, Episodes, np.ndarray]:
    """(numba's episodes, JAX's, their actions) of the given episodes (`draws`)."""
    uniforms, actions = draws(config, seed, episodes)
    numba_start, jax_start = starts(config, uniforms)
    numba = Episodes(numba_start, actions, numba_step(config))
    jax_ = Episodes(jax_start, actions, jax_step(config))
    return numba, jax_, actions


BATCH = 4096
"""Episodes of a cell played at once: both sides' records take about 35 kB an episode."""


def cell(env_id: str, dynamics: str, control: str, n: int, seed: int,
         precision: str = "float64") -> tuple[dict, list[dict]]:  # fmt: skip
    """One row of the table and the changed episodes' records (each with its reproducer: the
    id, dynamics, control, seed and episode, `draws`). The episodes whose sides parted but
    ended alike are explained too (their classes in `parted_classes`)."""
    config = agreement.configuration(env_id, dynamics, control)
    diverged = agreement.DIVERGED if precision == "float64" else np.inf
    began = time.perf_counter()
    counts = dict.fromkeys(("maneuvers", "same", "parted", "numba_seconds", "jax_seconds"), 0)
    outcomes = dict.fromkeys(ENDS, 0)
    start_difference, classes, parted_classes, changed = 0.0, {}, {}, []
    for first_episode in range(0, n, BATCH):
        episodes = range(first_episode, min(first_episode + BATCH, n))
        numba, jax_, actions = play(config, seed, episodes)
        start = state_difference(jax_.states[0], numba.states[0]).max(initial=0.0)
        start_difference = max(start_difference, float(start))
        ends, got = numba.ends(), jax_.ends()
        same = np.all([ends[k] == got[k] for k in (*ENDS, "maneuvers")], axis=0)
        first = first_parting(numba, jax_, diverged)
        for k in np.flatnonzero(first >= 0):
            why = explain(config, numba, jax_, actions, int(k), int(first[k]), diverged)
            if same[k]:
                parted_classes[why["class"]] = parted_classes.get(why["class"], 0) + 1
                continue
            classes[why["class"]] = classes.get(why["class"], 0) + 1
            changed.append({
                "id": env_id, "dynamics": dynamics, "control": control, "seed": seed,
                "episode": episodes[k], **why,
                "numba": {name: int(ends[name][k]) for name in (*ENDS, "maneuvers")},
                "jax": {name: int(got[name][k]) for name in (*ENDS, "maneuvers")},
            })  # fmt: skip
        counts["maneuvers"] += int(numba.length.sum())
        counts["same"] += int(same.sum())
        counts["parted"] += int((same & (first >= 0)).sum())
        counts["numba_seconds"] += numba.seconds
        counts["jax_seconds"] += jax_.seconds
        for name in ENDS:
            outcomes[name] += int(ends[name].sum())
    explained = sum(c["explained"] for c in changed)
    row = {
        "id": env_id, "dynamics": dynamics, "control": control, "precision": precision,
        "episodes": n, "maneuvers": counts["maneuvers"], "start_difference": start_difference,
        "same": counts["same"], "same_share": counts["same"] / n,
        "changed": n - counts["same"], "explained": int(explained),
        "unexplained": n - counts["same"] - int(explained), "classes": classes,
        "parted_same_outcome": counts["parted"], "parted_classes": parted_classes,
        "outcomes": outcomes, "numba_seconds": round(counts["numba_seconds"], 2),
        "jax_seconds": round(counts["jax_seconds"], 2),
        "seconds": round(time.perf_counter() - began, 1),
    }  # fmt: skip
    return row, changed


def table(rows: list[dict]) -> str:
    """The table: one line per cell."""
    header = ("id", "dynamics", "control", "episodes", "maneuvers", "same", "changed",
              "unexplained", "parted, same end", "classes")  # fmt: skip
    lines = [header]
    for r in rows:
        classes = ", ".join(f"{k} {v}" for k, v in sorted(r["classes"].items())) or "-"
        lines.append((
            r["id"], r["dynamics"], r["control"], str(r["episodes"]), str(r["maneuvers"]),
            f"{100 * r['same_share']:.2f}%", str(r["changed"]), str(r["unexplained"]),
            str(r["parted_same_outcome"]), classes,
        ))  # fmt: skip
    widths = [max(len(line[k]) for line in lines) for k in range(len(header))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(line, widths, strict=True)).rstrip()
                     for line in lines)  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000, help="per impulse cell")
    parser.add_argument("--hybrid-episodes", type=int, default=None,
                        help="per hybrid cell (default: --episodes)")  # fmt: skip
    parser.add_argument("--ids", nargs="+", default=list(agreement.ladder_ids()),
                        choices=list(agreement.ladder_ids()), metavar="ID")  # fmt: skip
    parser.add_argument("--dynamics", nargs="+", default=["impulse", "hybrid"],
                        choices=("impulse", "hybrid"))  # fmt: skip
    parser.add_argument("--controls", nargs="+", default=["setup"], choices=agreement.CONTROLS)
    parser.add_argument("--seed", type=int, default=0, help="the first cell's seed")
    parser.add_argument("--precision", choices=("float64", "float32"), default="float64")
    parser.add_argument("--fma", action="store_true", help="XLA's default build (`NO_FMA`)")
    output_arguments(parser)
    given = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(given)
    if args.json is None:
        args.json = RESULTS
    refuse_existing(parser, args.json, args.overwrite)
    if args.episodes < 1 or (args.hybrid_episodes is not None and args.hybrid_episodes < 1):
        parser.error("--episodes and --hybrid-episodes must be >= 1")
    if not args.fma:
        os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {agreement.NO_FMA}".strip()
    import jax

    jax.config.update("jax_enable_x64", args.precision == "float64")
    print(f"jax {jax.__version__} on {jax.devices()[0]}, {args.precision}", flush=True)
    began = time.perf_counter()
    rows, changed = [], []
    cells = [(d, c, k, i) for d in args.dynamics for c in args.controls
             for k, i in enumerate(args.ids)]  # fmt: skip
    for dynamics, control, k, env_id in cells:
        n = (args.hybrid_episodes or args.episodes) if dynamics == "hybrid" else args.episodes
        row, found = cell(env_id, dynamics, control, n, args.seed + k, args.precision)
        row["fma"] = bool(args.fma)
        rows.append(row)
        changed += found
        print(f"{env_id:36} {dynamics:8} {control:14} {row['episodes']} episodes "
              f"{row['maneuvers']} maneuvers, same {100 * row['same_share']:.2f}%, changed "
              f"{row['changed']} (unexplained {row['unexplained']}) {row['classes']}, start "
              f"{row['start_difference']:.1e}, numba {row['numba_seconds']} s, JAX "
              f"{row['jax_seconds']} s, {row['seconds']} s", flush=True)  # fmt: skip
    seconds = round(time.perf_counter() - began, 1)
    print(table(rows))
    print(f"\n{seconds} s")
    command = results_file.script_command(__file__, given)
    setup = {
        "episodes": args.episodes, "hybrid_episodes": args.hybrid_episodes or args.episodes,
        "ids": args.ids, "dynamics": args.dynamics, "controls": args.controls,
        "seed": args.seed, "precision": args.precision, "ends": list(ENDS),
        "diverged": agreement.DIVERGED, "margin": MARGIN, "block": BLOCK,
    }  # fmt: skip
    details = {"jax": jax.__version__, "device": str(jax.devices()[0]),
               "xla_flags": os.environ.get("XLA_FLAGS", ""), "changed": changed}  # fmt: skip
    results_file.write(args.json, results_file.record(command, rows, setup, details, seconds))
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
