"""TetherNavigate's kernel against the pymunk world, whole episodes (issue #33): random episodes
on each rung of the ladder (Open, Posts, Wall; setup control, hybrid dynamics) replayed in
`tether_gym.physics.pymunk_maneuver` from the kernel's control inputs, walls and posts and all,
and each maneuver's end compared with the kernel's.

    python -m benchmarks.validation.pymunk_navigate [--episodes 100] [--rho 850 10]
        [--wall-restitution 0.9] [--seed 0]
        [--json results/pymunk/agreement.json] [--overwrite]

Each rung is played at each `--rho` (the tether's stiffness as the env's `rho`: 850 is the
default; a soft tether, rho = 10, makes contacts long enough to meet the walls and the posts
often) and each `--wall-restitution` (0.9 the default; `results/pymunk/sweep.json` runs 0, 0.9
and 1 at rho 10, 850 and 1e6: at 0 a wall stops the puck's normal velocity, the puck slides
along it, and a corner stops it), `--episodes` episodes each, seeds `--seed` on, actions drawn
from the action space seeded alike. Each episode is replayed twice
in the world: whole (`replay` from the episode's start, the world carrying its own state from
maneuver to maneuver, up to the episode's end: "episode" below) and maneuver by maneuver (each
from the kernel's state before it: "maneuver").
A maneuver agrees when the world ends it within `POSITION_TOLERANCE` (2 mm) of the kernel's
position, within `VELOCITY_TOLERANCE` (1%) of its velocity, with the same `hit_post`.

A whole-episode replay that disagrees is classified (`CLASSES`): "sensitive" where the two
engines agree on that maneuver from either state (the world replaying it from the kernel's
state agrees with the kernel, and the kernel playing the same action from the replay's state
agrees with the world replaying that): the episode's replay entered it with its own error,
from earlier maneuvers, of micrometres to a tenth of a millimetre, which the maneuver amplifies
past the tolerance (a spinning puck's tautening, a wheel target at the flight's 5 s horizon, a
post touched at a glancing angle); "parted" for the later maneuvers of that episode where they
agree maneuver by maneuver (the replay has left the kernel's trajectory); "unexplained"
otherwise (none should be).

The JSON holds, per rung and rho: the maneuvers, how many had a wall touch during the contact
and how many ended on a post (the kernel's counts, and the world's maneuver by maneuver), the
median and worst position (m) and velocity (fraction) errors, episode and maneuver, and the
maneuvers outside tolerance per class, with each one's reproducer (env id, kwargs, seed,
maneuver); and the command, the git commit and the wall time.
"""

from __future__ import annotations

from benchmarks.common import one_core, output_arguments, refuse_existing

if __name__ == "__main__":  # one core (the machine's others are left free), before numba loads
    one_core()

import argparse
import itertools
import math
import sys
import time
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

import tether_gym  # noqa: F401  (registers the env ids)
from tether_gym.envs.kernels import DEFAULT_RHO, PUCK_MASS
from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import (
    FLIGHT_HORIZON,
    INERTIA_RATIO,
    OFFSET,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.evaluation import results_file
from tether_gym.physics.pymunk_maneuver import TAUT_STEPS, Maneuver, ManeuverPlan, replay
from tether_gym.physics.pymunk_world import Table
from tether_gym.physics.state import PuckState

RUNGS = ("Open", "Posts", "Wall")
WALL_RESTITUTION = NavigateConfig().wall_restitution
"""The env's default wall restitution."""
POSITION_TOLERANCE, VELOCITY_TOLERANCE = 2e-3, 0.01
"""m, and a fraction of the kernel's speed after the maneuver."""
PUCK = dict(mass=PUCK_MASS, radius=PUCK_RADIUS, inertia_ratio=INERTIA_RATIO, offset=OFFSET)
AGREE, SENSITIVE, PARTED, GIVEN_UP, UNEXPLAINED = (
    "agree",
    "sensitive",
    "parted",
    "given up",
    "unexplained",
)
CLASSES = {
    AGREE: "the episode's replay ends the maneuver within tolerance of the kernel",
    SENSITIVE: "the first maneuver of an episode's replay outside tolerance, where the two "
    "engines agree from either state: the world replaying it from the kernel's state agrees "
    "with the kernel, and the kernel playing its action from the replay's state agrees with "
    "the world replaying that (the kernel's controls there: its wheel plans from where the "
    "puck is). The replay entered it with its own earlier error, within tolerance, which the "
    "maneuver amplifies",
    PARTED: "a later maneuver of an episode whose replay left the kernel's trajectory, where "
    "the world replaying it from the kernel's state agrees with the kernel",
    GIVEN_UP: "a maneuver whose contact the kernel gave up (info['completed'] False: still taut "
    "at its time budget, or its arc needing more points than the path holds), released there, "
    "where the world, which has neither budget, plays the contact on",
    UNEXPLAINED: "any other maneuver outside tolerance",
}


def env_id(rung: str) -> str:
    return f"TetherNavigate_{rung}Reach-v3"


@dataclass(frozen=True)
class KernelEpisode:
    """One kernel episode (random actions) and what its replay needs: the table's pegs and
    posts, and per maneuver the kernel's state record before it, the action and the info."""

    env_id: str
    kwargs: dict
    seed: int
    config: NavigateConfig
    pegs: list[tuple[float, float]]
    posts: list[tuple[float, float]]
    records: list[np.void]
    actions: list[np.ndarray]
    infos: list[dict]

    def before(self, j: int) -> PuckState:
        """The puck before maneuver j, the kernel's."""
        return PuckState.from_record(self.records[j])

    @property
    def table(self) -> Table:
        """The world's table: the walls (the env's restitution) and the episode's posts."""
        return Table(0.0, TABLE_WIDTH, 0.0, TABLE_HEIGHT, elasticity=self.config.wall_restitution,
                     posts=tuple(self.posts), post_radius=POST_RADIUS)  # fmt: skip


def make_env(env_id: str, **kwargs) -> gym.Env:
    return gym.make(env_id, **kwargs).unwrapped


def play(env_id: str, seed: int, **kwargs) -> KernelEpisode:
    """The kernel's episode `seed` of `env_id` (`kwargs` to `gym.make`), actions drawn from the
    action space seeded `seed`, to its end."""
    env = make_env(env_id, **kwargs)
    env.action_space.seed(seed)
    env.reset(seed=seed)
    state = env.state
    pegs = [tuple(map(float, p)) for p in state["anchors"][: state["n_anchors"]]]
    posts = [tuple(map(float, p)) for p in state["posts"][: state["n_posts"]]]
    records, actions, infos = [], [], []
    while True:
        records.append(env.state.copy())
        actions.append(env.action_space.sample())
        *_, terminated, truncated, info = env.step(actions[-1])
        infos.append(info)
        if terminated or truncated:
            break
    return KernelEpisode(env_id, dict(kwargs), seed, env.config, pegs, posts, records, actions,
                         infos)  # fmt: skip


def contact_wall_hits(info: dict) -> int:
    """The kernel's wall bounces during the maneuver's contact: `wall_hits` (the flight's and
    the contact's) less the flight's, the path's points before the tautening."""
    if not info["bounced"]:
        return 0
    path, taut = np.asarray(info["path"]), np.asarray(info["taut_position"])
    flight = next(i for i in range(1, len(path)) if np.array_equal(path[i], taut)) - 1
    return int(info["wall_hits"]) - flight


def replay_from(episode: KernelEpisode, j: int = 0, count: int | None = None,
                start: PuckState | None = None, infos: list[dict] | None = None,
                ) -> list[Maneuver]:  # fmt: skip
    """The world's replay of `count` maneuvers (all to the end by default) from maneuver j,
    starting from `start` (the kernel's state before maneuver j by default), with the control
    inputs of `infos` (the kernel's from maneuver j on by default)."""
    infos = episode.infos[j:] if infos is None else infos
    plans = [ManeuverPlan.from_info(info) for info in infos][:count]
    config = episode.config
    return replay(
        episode.before(j) if start is None else start, episode.pegs, plans,
        stiffness=config.stiffness, table=episode.table, wheel_rate=config.wheel_rate,
        flight_horizon=FLIGHT_HORIZON, **PUCK,
    )  # fmt: skip


def kernel_from(episode: KernelEpisode, j: int, puck: PuckState) -> dict:
    """The kernel's maneuver j (its action) played from `puck` instead of its own state
    before it (the rest of the state, the table and the maneuvers left, its own): the step's
    info."""
    env = make_env(episode.env_id, **episode.kwargs)
    env.reset(seed=episode.seed)
    state, record = env.state, episode.records[j]
    for name in record.dtype.names:
        state[name] = record[name]
    for name, value in zip(PuckState._fields, puck, strict=True):
        state[name] = value
    return env.step(episode.actions[j])[-1]


def errors(info: dict, maneuver: Maneuver) -> tuple[float, float]:
    """(m, fraction of the kernel's speed): the world's position and velocity errors at the
    maneuver's end."""
    state = maneuver.state
    position = math.hypot(state.x - info["position"][0], state.y - info["position"][1])
    velocity = math.hypot(state.vx - info["velocity"][0], state.vy - info["velocity"][1])
    speed = math.hypot(*info["velocity"])
    return position, (velocity / speed if speed > 0.0 else (0.0 if velocity == 0.0 else math.inf))


def within(info: dict, maneuver: Maneuver | None) -> bool:
    """The world's maneuver agrees with the kernel's (`info`): position, velocity, hit_post."""
    if maneuver is None:
        return False
    position, velocity = errors(info, maneuver)
    return (
        position <= POSITION_TOLERANCE
        and velocity <= VELOCITY_TOLERANCE
        and maneuver.hit_post == bool(info["hit_post"])
    )


@dataclass(frozen=True)
class Row:
    """One maneuver compared: the kernel's, the episode's replay (nan where it ended before)
    and, where computed, the replay of the maneuver alone from the kernel's state."""

    seed: int
    maneuver: int
    bounced: bool
    wall_taut: bool
    """The kernel's contact bounced off a wall."""
    post: bool
    """The kernel's maneuver ended on a post."""
    post_in_contact: bool
    position: float
    velocity: float
    world_wall_taut: bool
    world_post: bool
    kind: str
    momentum: tuple[float, float] = (math.nan, math.nan)
    """The episode's replay: the angular momentum about the peg before tautening and at the
    end (`Maneuver.momentum`; nan without the replay or a bounce)."""
    alone_position: float = math.nan
    alone_velocity: float = math.nan
    alone_wall_taut: bool | None = None
    alone_post: bool | None = None
    alone_agrees: bool | None = None


def compare(episode: KernelEpisode, alone: str = "needed") -> list[Row]:
    """Each maneuver of `episode` compared with the world's whole-episode replay, and
    classified (`CLASSES`). `alone`: "all" replays every maneuver alone too, "needed" those
    the classification needs and those with a wall touch during the contact or ending on a
    post (the kernel's or the world's)."""
    chained = replay_from(episode)
    rows, parted = [], False
    for j, info in enumerate(episode.infos):
        m = chained[j] if j < len(chained) else None
        position, velocity = errors(info, m) if m is not None else (math.nan, math.nan)
        walls, post = contact_wall_hits(info) > 0, bool(info["hit_post"])
        agrees = within(info, m)
        row = dict(
            seed=episode.seed, maneuver=j, bounced=bool(info["bounced"]), wall_taut=walls,
            post=post, post_in_contact=post and bool(info["bounced"]), position=position,
            velocity=velocity, world_wall_taut=bool(m is not None and m.wall_while_taut),
            world_post=bool(m is not None and m.hit_post), kind=AGREE,
            momentum=m.momentum if m is not None else (math.nan, math.nan),
        )  # fmt: skip
        interesting = walls or post or row["world_wall_taut"] or row["world_post"]
        if alone == "all" or not agrees or parted or interesting:
            lone = m if j == 0 and m is not None else replay_from(episode, j, 1)[0]
            row.update(alone_position=errors(info, lone)[0], alone_velocity=errors(info, lone)[1],
                       alone_wall_taut=lone.wall_while_taut, alone_post=lone.hit_post,
                       alone_agrees=within(info, lone))  # fmt: skip
        if parted:
            row["kind"] = PARTED if row["alone_agrees"] else UNEXPLAINED
        elif not agrees:
            parted = True
            row["kind"] = UNEXPLAINED if info["completed"] else GIVEN_UP
            if j > 0 and row["alone_agrees"]:  # the two engines from the replay's state
                start = chained[j - 1].state
                there = kernel_from(episode, j, start)
                if within(there, replay_from(episode, j, 1, start, [there])[0]):
                    row["kind"] = SENSITIVE
        rows.append(Row(**row))
    return rows


def summary(rows: list[Row]) -> dict:
    """A population's counts and errors (see the module docstring)."""
    episode_p = np.array([r.position for r in rows if not math.isnan(r.position)])
    episode_v = np.array([r.velocity for r in rows if not math.isnan(r.velocity)])
    lone = [r for r in rows if r.alone_agrees is not None]
    alone_p = np.array([r.alone_position for r in lone])
    alone_v = np.array([r.alone_velocity for r in lone])
    outside = {}
    for r in rows:
        if r.kind != AGREE:
            outside[r.kind] = outside.get(r.kind, 0) + 1

    def stats(values: np.ndarray) -> dict:
        if values.size == 0:
            return {"median": None, "worst": None}
        return {"median": float(np.median(values)), "worst": float(values.max())}

    return {
        "episodes": len({r.seed for r in rows}),
        "maneuvers": len(rows),
        "bounced": sum(r.bounced for r in rows),
        "wall_touch_taut": sum(r.wall_taut for r in rows),
        "post_ends": sum(r.post for r in rows),
        "post_ends_in_contact": sum(r.post_in_contact for r in rows),
        "world_alone": {
            "maneuvers": len(lone),
            "wall_touch_taut": sum(bool(r.alone_wall_taut) for r in lone),
            "post_ends": sum(bool(r.alone_post) for r in lone),
        },
        "episode": {"position": stats(episode_p), "velocity": stats(episode_v)},
        "maneuver": {"position": stats(alone_p), "velocity": stats(alone_v)},
        "outside_tolerance": {
            "episode": outside,
            "maneuver": sum(not r.alone_agrees for r in lone),
        },
    }


def table(populations: dict[str, dict]) -> str:
    """The agreement table: one row per population."""
    header = ("population", "maneuvers", "wall taut", "post ends", "episode pos med/worst (m)",
              "episode vel med/worst", "maneuver pos worst (m)", "maneuver vel worst",
              "outside (episode)")  # fmt: skip
    lines = [header]
    for name, s in populations.items():
        e, m = s["episode"], s["maneuver"]
        outside = ", ".join(
            f"{k} {v}" for k, v in sorted(s["outside_tolerance"]["episode"].items())
        )
        lines.append((
            name, str(s["maneuvers"]), str(s["wall_touch_taut"]),
            f"{s['post_ends']} ({s['post_ends_in_contact']} taut)",
            f"{e['position']['median']:.1e} / {e['position']['worst']:.1e}",
            f"{e['velocity']['median']:.1e} / {e['velocity']['worst']:.1e}",
            f"{m['position']['worst']:.1e}", f"{m['velocity']['worst']:.1e}", outside or "0",
        ))  # fmt: skip
    widths = [max(len(line[k]) for line in lines) for k in range(len(header))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(line, widths, strict=True))
                     for line in lines)  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100, help="per rung, rho and restitution")
    parser.add_argument("--rho", type=float, nargs="+", default=[DEFAULT_RHO, 10.0])
    parser.add_argument("--wall-restitution", type=float, nargs="+", default=[WALL_RESTITUTION])
    parser.add_argument("--seed", type=int, default=0, help="the first episode's seed")
    parser.add_argument("--rungs", nargs="+", choices=RUNGS, default=list(RUNGS))
    output_arguments(parser)
    given = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(given)
    refuse_existing(parser, args.json, args.overwrite)
    if args.episodes < 1:
        parser.error("--episodes must be >= 1")
    begin = time.perf_counter()
    populations, reproducers = {}, []
    for rung in args.rungs:
        for rho, restitution in itertools.product(args.rho, args.wall_restitution):
            kwargs = {"rho": rho, "wall_restitution": restitution}
            name, rows = f"{rung} rho {rho:g}", []
            if args.wall_restitution != [WALL_RESTITUTION]:
                name += f" e_wall {restitution:g}"
            started = time.perf_counter()
            for seed in range(args.seed, args.seed + args.episodes):
                episode = play(env_id(rung), seed, **kwargs)
                found = compare(episode, alone="all")
                rows += found
                reproducers += [
                    {"env_id": env_id(rung), "kwargs": kwargs, "seed": seed,
                     "maneuver": r.maneuver, "class": r.kind, "position": r.position,
                     "velocity": r.velocity, "alone_position": r.alone_position,
                     "alone_velocity": r.alone_velocity}
                    for r in found if r.kind != AGREE
                ]  # fmt: skip
            populations[name] = summary(rows)
            populations[name]["seconds"] = round(time.perf_counter() - started, 1)
            print(f"{name}: {len(rows)} maneuvers, {populations[name]['seconds']} s",
                  file=sys.stderr, flush=True)  # fmt: skip
    seconds = round(time.perf_counter() - begin, 1)
    print(table(populations))
    print(f"\n{seconds} s")
    if args.json is None:
        return
    setup = {
        "episodes": args.episodes, "rho": args.rho, "wall_restitution": args.wall_restitution,
        "seed": args.seed, "taut_steps": TAUT_STEPS,
        "tolerance": {"position": POSITION_TOLERANCE, "velocity": VELOCITY_TOLERANCE},
    }  # fmt: skip
    rows = [{"population": name, **found} for name, found in populations.items()]
    details = {"classes": CLASSES, "outside_tolerance": reproducers}
    command = results_file.script_command(__file__, given)
    results_file.write(args.json, results_file.record(command, rows, setup, details, seconds))


if __name__ == "__main__":
    main()
