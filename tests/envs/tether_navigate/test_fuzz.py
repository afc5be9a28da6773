"""TetherNavigate fuzzed through its public API (issue #33,
`benchmarks/validation/fuzz_navigate.py`): on every id, control mode and dynamics, single and vector
envs, random actions never leave the puck off the table, inside or through a post, an observation
outside its space, a NaN, an exception, or a vector copy unlike its single env; two reproducers of
the issue as physical checks. Then the instrument itself: each check fires on what it is meant to
find, reproducers replay, the command writes its JSON and keeps an existing one."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import benchmarks.validation.fuzz_navigate as fz
import tether_gym  # noqa: F401  (registers the env ids)
from benchmarks.common import random_actions
from benchmarks.validation.fuzz_navigate import (
    CLASSES,
    HOLES,
    REACH,
    arc_stray,
    audit_step,
    audit_vector_step,
    combos,
    episode_posts,
    fuzz,
    replay,
)
from tests.helpers.envs import vector_env
from tether_gym.envs.tether_navigate.config import PUCK_RADIUS, TABLE_HEIGHT, TABLE_WIDTH

COMBOS = combos()
IDS = [f"{e}-{c}{'+coast' if k else ''}-{d}" for e, c, k, d in COMBOS]
SINGLE_STEPS = 200
VECTOR_COPIES, VECTOR_STEPS = 64, 16


def _holes(result: dict) -> str:
    """The hole classes found, with a reproducer of each, as a failure message ('' if none)."""
    found = {name: result["counts"][name] for name in HOLES if result["counts"][name]}
    if not found:
        return ""
    examples = {name: result["reproducers"][name][:1] for name in found}
    return f"holes {found} in {result['steps']} transitions; {examples}; {result['exceptions']}"


@pytest.mark.parametrize("env_id, control, coast, dynamics", COMBOS, ids=IDS)
def test_single_env_fuzz_finds_no_hole(env_id, control, coast, dynamics):
    seed = COMBOS.index((env_id, control, coast, dynamics))
    result = fuzz(env_id, control, coast, dynamics, steps=SINGLE_STEPS, seed=seed)
    assert result["steps"] == SINGLE_STEPS
    assert not _holes(result), _holes(result)


@pytest.mark.parametrize("env_id, control, coast, dynamics", COMBOS, ids=IDS)
def test_vector_env_fuzz_finds_no_hole(env_id, control, coast, dynamics):
    seed = 1000 + COMBOS.index((env_id, control, coast, dynamics))
    result = fuzz(env_id, control, coast, dynamics, steps=VECTOR_COPIES * VECTOR_STEPS,
                  seed=seed, vector=True, num_envs=VECTOR_COPIES, compare=2)  # fmt: skip
    assert result["steps"] == VECTOR_COPIES * VECTOR_STEPS
    assert not _holes(result), _holes(result)


# --- the reproducers -----------------------------------------------------------------


def _on_table(points) -> bool:
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    low, high = PUCK_RADIUS - fz.TOL, np.array([TABLE_WIDTH, TABLE_HEIGHT]) - PUCK_RADIUS + fz.TOL
    return bool(np.all((points >= low) & (points <= high)))


def _check_physical(env, posts, step, label: str) -> None:
    """Every path point on the table; the post touched (`hit_post`) or none entered."""
    obs, _, _, _, info = step
    on_table = _on_table(info["path"]) and _on_table(info["position"])
    assert on_table, f"{label}: off the table, path {info['path'].tolist()}"
    assert env.observation_space.contains(obs), f"{label}: observation outside its space"
    found = audit_step(posts, obs, step[1], info, env.observation_space)
    entered = found["inside_post_point"] or found["through_post_segment"]
    assert info["hit_post"] or not entered, (
        f"{label}: a post entered without hit_post, {dict(found)}, posts {posts.tolist()}, "
        f"path {info['path'].tolist()}"
    )


def test_a_hybrid_contact_keeps_the_puck_on_the_table():
    """Seed 617: the contact used to throw the puck to (1.377, 1.407), off the table, its
    observation out of `observation_space`."""
    env = gym.make("TetherNavigate-v3")
    env.reset(seed=617)
    posts = episode_posts(env.unwrapped.state)
    step = env.step(np.array([-0.492906, -0.9373917, 0.85783046, -0.91591454], np.float32))
    _check_physical(env, posts, step, "the maneuver")


def test_a_flight_does_not_pass_through_a_post_untouched():
    """PostsReach seed 14859: the first maneuver used to end inside a post (its centre 0.0887
    m from the post's, under 0.09 m), the second to fly out through the post's centre, both
    with `hit_post` False."""
    env = gym.make("TetherNavigate_PostsReach-v3")
    env.reset(seed=14859)
    posts = episode_posts(env.unwrapped.state)
    for action in ([-0.16, 0.42, -0.43, -0.37], [-0.76, 0.01, 0.91, 0.13]):
        step = env.step(np.array(action, np.float32))
        _check_physical(env, posts, step, "the maneuver")
        if step[2] or step[3]:  # the episode ended (on a post, say): nothing left to fly
            break


# --- the instrument --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def sample():
    """A real transition (its info's keys and types) on a table of one post at (1, 0.5)."""
    env = gym.make("TetherNavigate_PostsReach-v3", dynamics="impulse")
    env.reset(seed=3, options={"posts": [[1.0, 0.5]]})
    obs, reward, _, _, info = env.step(np.zeros(4, np.float32))
    return env.observation_space, obs, reward, info


def _audit(sample, path, position=None, posts=((1.0, 0.5),), **changes):
    space, obs, reward, info = sample
    path = np.asarray(path, dtype=np.float64)
    padded = np.vstack([path, np.repeat(path[-1:], len(info["path"]) - len(path), axis=0)])
    info = {**info, "path": padded, "position": padded[-1] if position is None else position,
            **changes}  # fmt: skip
    return audit_step(np.array(posts, dtype=np.float64).reshape(-1, 2), obs, reward, info, space)


def test_audit_step_finds_each_hole(sample):
    clear = _audit(sample, [[0.3, 0.3], [0.6, 0.3]])
    assert not clear, clear
    assert _audit(sample, [[0.3, 0.3], [0.3, 0.04 - 2e-9]])["off_table_point"]
    assert not _audit(sample, [[0.3, 0.3], [0.3, 0.04 - 5e-10]])["off_table_point"]
    assert _audit(sample, [[0.3, 0.3], [0.6, 0.3]], position=[2.5, 0.5])["off_table_point"]
    inside = _audit(sample, [[0.3, 0.5], [1.0 - REACH + 1e-6, 0.5]])
    assert inside["inside_post_point"] and not inside["through_post_segment"]
    touching = _audit(sample, [[0.3, 0.5], [1.0 - REACH, 0.5]])
    assert not touching, touching
    through = _audit(sample, [[0.5, 0.5], [1.5, 0.52]])  # a flight's straight stretch
    assert through["through_post_segment"] and not through["inside_post_point"]
    grazing = _audit(sample, [[0.5, 0.5 + REACH - 5e-4], [1.5, 0.5 + REACH - 5e-4]])
    assert not grazing, grazing  # within the path's 1 mm drawing tolerance
    later = _audit(sample, [[0.5, 0.2], [0.5, 0.5], [1.5, 0.5]])  # any segment counts
    assert later["through_post_segment"]
    assert _audit(sample, [[0.3, 0.3]], posts=())["off_table_point"] == 0


def test_audit_step_finds_nan_and_notes_an_infinite_command_error(sample):
    space, obs, reward, info = sample
    assert _audit(sample, [[0.3, 0.3]], command_error=np.inf) == {"command_error_inf": 1}
    assert _audit(sample, [[0.3, 0.3]], command_error=np.nan)["nan"]
    assert _audit(sample, [[0.3, 0.3]], flight_time=np.nan)["nan"]
    terms = {**info["reward_terms"], "progress": np.inf}
    assert _audit(sample, [[0.3, 0.3]], reward_terms=terms)["nan"]
    bad = {**obs, "observation": obs["observation"].copy()}
    bad["observation"][0] = np.nan
    found = audit_step(np.zeros((0, 2)), bad, reward, info, space)
    assert found["nan"] and found["obs_outside_space"]
    assert audit_step(np.zeros((0, 2)), obs, np.nan, info, space)["nan"]


def test_audit_step_finds_a_freeze_and_a_post_report_against_the_docstring(sample):
    """A contact given up after many wall hits is a freeze (an incomplete one a note); a post
    hit must be reported at the post's reach, at rest only if it arrived at rest."""
    path = [[0.3, 0.5], [0.6, 0.5]]
    given_up = _audit(sample, path, completed=False, wall_hits=3.0)
    assert given_up == {"incomplete_contact": 1}
    frozen = _audit(sample, path, completed=False, wall_hits=50_458.0)
    assert frozen["freeze"] and frozen["incomplete_contact"]
    at_post = [1.0 - REACH, 0.5]
    reported = _audit(sample, [[0.3, 0.5], at_post], hit_post=True, velocity=[1.0, 0.0],
                      at_rest=False)  # fmt: skip
    assert not reported, reported
    assert _audit(sample, [[0.3, 0.5], [0.8, 0.5]], hit_post=True, velocity=[1.0, 0.0],
                  at_rest=False)["post_report"]  # fmt: skip
    assert _audit(sample, [[0.3, 0.5], at_post], hit_post=True, velocity=[1.0, 0.0],
                  at_rest=True)["post_report"]  # fmt: skip


def test_arc_stray_finds_a_path_that_leaves_the_arc():
    """The env's drawing of a soft contact is on its arc; the same path with its arc replaced
    by one chord (v2's drawing when its points ran out) strays from it."""
    env = gym.make("TetherNavigate-v3", rho=10)
    env.reset(seed=0, options={"start": [1.0, 0.8], "start_velocity": [1.2, 0.0],
                               "anchors": [[1.0, 0.5]], "start_angle": 0.0})  # fmt: skip
    posts = episode_posts(env.unwrapped.state)
    *_, info = env.step(np.array([0.0, -1.0, 0.0, 1.0], np.float32))
    assert info["bounced"]
    drawn = arc_stray(info, posts, env.unwrapped.config)
    assert drawn["on_arc"] and drawn["stray"] <= 1e-3
    path = np.asarray(info["path"])
    taut = np.flatnonzero((path == info["taut_position"]).all(axis=1))[0]
    release = np.flatnonzero((path == info["release_position"]).all(axis=1))[-1]
    assert release - taut >= 3  # an arc, not a chord
    chord = np.vstack([path[: taut + 1], path[release:]])
    chord = np.vstack([chord, np.repeat(chord[-1:], len(path) - len(chord), axis=0)])
    assert arc_stray({**info, "path": chord}, posts, env.unwrapped.config)["stray"] > 1e-3


def test_arc_stray_measures_a_rebound_as_drawn():
    """A contact that goes 1.3 mm out and comes back along its own way (from the sweep's run at
    rho 91): its path is on its arc, though the arc passes the path's last points twice (the
    first checker, matching path points to the arc in order, took the way out for the way
    back and reported a 1.05 mm stray)."""
    kwargs = {"control": "aim", "coast": True, "dynamics": "hybrid", "rho": 91.07590376336165,
              "wall_restitution": 0.6031809024539039, "wheel_rate": 101.41317912303306}  # fmt: skip
    env = gym.make("TetherNavigate_OpenStopSparse-v3", **kwargs)
    env.reset(seed=1095538111)
    env.reset()
    env.reset()
    actions = [[0.0, -0.4676123, -0.720761], [0.36261111, -1.0585501, 0.0],
               [-0.4088932, 0.0, 1.0], [0.30395845, 0.7517159, -0.5843743],
               [-1.0000006, -0.9906311, 0.895325]]  # fmt: skip
    for action in actions:
        posts = episode_posts(env.unwrapped.state)
        *_, info = env.step(np.array(action, np.float32))
    assert info["bounced"] and info["completed"]
    found = arc_stray(info, posts, env.unwrapped.config)
    assert found["on_arc"] and found["stray"] < 1e-5


def test_audit_vector_step_is_audit_step_row_by_row():
    """On a vector env's transitions, each row's findings are a single env's audit of it."""
    envs = vector_env("TetherNavigate_WallReach-v3", 32)
    space = envs.single_observation_space
    envs.reset(seed=5)
    rng = np.random.default_rng(5)
    for _ in range(20):
        states = envs.unwrapped.state.copy()
        obs, reward, terminated, truncated, info = envs.step(random_actions(rng, (32, 4)))
        rows = audit_vector_step(states, obs, reward, terminated | truncated, info, space)
        for i, found in enumerate(rows):
            single = {
                key: {k: v[i] for k, v in value.items()} if isinstance(value, dict) else value[i]
                for key, value in info.items()
                if key not in fz.VECTOR_SKIP
            }
            final = {key: value[i] for key, value in info["final_obs"].items()}
            expected = audit_step(episode_posts(states[i]), final, reward[i], single, space)
            if terminated[i] or truncated[i]:
                expected |= fz.audit_observation({k: v[i] for k, v in obs.items()}, space)
            assert found == expected


def test_random_actions_mix_uniform_extreme_zero_and_outside_values():
    actions = random_actions(np.random.default_rng(0), (20_000, 4))
    assert actions.dtype == np.float32
    outside = np.abs(actions) > 1.0
    assert 0.08 < np.mean(np.abs(actions) == 1.0) < 0.12
    assert 0.08 < np.mean(actions == 0.0) < 0.12
    assert 0.08 < np.mean(outside) < 0.12 and np.abs(actions).max() <= 1.1 + 1e-6
    assert np.mean(np.abs(actions) < 1.0) > 0.75


def test_reproducers_replay_their_findings():
    """Each reproducer replays, in a single env, to a transition with its finding (a vector
    copy's too: its earlier episodes skipped by resets)."""
    replayed = 0
    for vector in (False, True):
        result = fuzz("TetherNavigate_WallReach-v3", "velocity", True, "hybrid", steps=256, seed=2,
                      vector=vector, num_envs=16, compare=1, max_reproducers=3)  # fmt: skip
        for name in CLASSES:
            for reproducer in result["reproducers"][name]:
                if name == "vector_vs_single":
                    continue
                found, _ = replay(json.loads(json.dumps(reproducer)))  # as the JSON keeps it
                assert name in found, (name, reproducer, found)
                replayed += 1
    assert replayed > 0


def test_fuzz_is_deterministic_for_a_seed():
    first, second = (fuzz("TetherNavigate_PostsStop-v3", "velocity", False, "impulse",
                          steps=60, seed=4) for _ in range(2))  # fmt: skip
    for key in ("counts", "reproducers", "episodes"):
        assert first[key] == second[key]


def test_a_vector_copy_unlike_its_single_env_is_found(monkeypatch):
    """Shadowing copy i with a single env seeded otherwise than s + i is a disagreement, counted
    once per copy."""
    init = fz._Shadow.__init__

    def wrong_seed(self, env_id, kwargs, seed, row):
        init(self, env_id, kwargs, seed + 1000, row)

    monkeypatch.setattr(fz._Shadow, "__init__", wrong_seed)
    result = fuzz("TetherNavigate_OpenReach-v3", "setup", False, "impulse", steps=64, seed=0,
                  vector=True, num_envs=8, compare=3)  # fmt: skip
    assert result["counts"]["vector_vs_single"] == 3
    assert all("differs" in r for r in result["reproducers"]["vector_vs_single"])


def test_the_command_writes_its_json_and_keeps_an_existing_one(tmp_path, capsys):
    out = tmp_path / "fuzz.json"
    argv = ["--ids", "TetherNavigate_WallStop-v3", "--steps", "20", "--vector-steps", "80",
            "--num-envs", "8", "--compare", "1", "--json", str(out)]  # fmt: skip
    fz.main(argv)
    data = json.loads(out.read_text())
    assert data["command"].startswith("python -m benchmarks.validation.fuzz_navigate --ids")
    counts = data["details"]["counts"]
    assert len(data["rows"]) == 10 and counts["single"]["steps"] == 20
    assert counts["vector"]["steps"] == 10 * 8  # 8 transitions each, one step of 8
    assert set(counts["single"]["counts"]) == set(CLASSES)
    assert data["commit"] and data["seconds"] >= 0
    assert "single env: findings" in capsys.readouterr().out
    before = out.read_text()
    with pytest.raises(SystemExit):
        fz.main(argv)
    assert out.read_text() == before
    fz.main([*argv, "--overwrite"])
