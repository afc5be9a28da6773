"""Inputs checked where they enter (issue #33, item 5): TetherNavigate's arguments and layouts
(`NavigateConfig`), its reset options (`NavigateKernel.reset_options`), the actions of every
kernel env (`Kernel.as_actions`) and the numbers of the physics API (`physics.checks`). Each bad
input raises a ValueError that names it; each valid edge case works."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import tether_gym  # noqa: F401
from tests.helpers.envs import vector_env
from tether_gym.envs.tether_navigate import TetherNavigateEnv
from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import (
    POST_RADIUS,
    PUCK_RADIUS,
)
from tether_gym.envs.tether_navigate.kernel import MAX_SPIN
from tether_gym.envs.tether_navigate.spaces import OBS
from tether_gym.physics import bounce, bounce_one
from tether_gym.physics.checks import as_finite, check_float

NO_POSTS = """
A.G
...
S..
"""
REACH = POST_RADIUS + PUCK_RADIUS
"""m: the least distance from a post's centre to the start's centre."""
CLEAR = {"start": (0.3, 0.5), "goal": (1.5, 0.5), "anchors": [(1.0, 0.8)]}
"""Options that fix everything a post given as an option could fall on."""


def navigate(**kwargs):
    return gym.make("TetherNavigate-v3", **kwargs)


def refused(env, match: str, seed: int = 0, **options):
    with pytest.raises(ValueError, match=match) as error:
        env.reset(seed=seed, options=options)
    return str(error.value)


def present_posts(obs) -> int:
    row = obs["observation"]
    return int(sum(row[getattr(OBS, f"post{j}_present")] for j in range(4)))


# ---- layouts and the counts of pegs and posts ------------------------------------------------


def test_a_layout_without_posts_works():
    env = navigate(layout=NO_POSTS)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs) and present_posts(obs) == 0
    np.testing.assert_allclose(obs["desired_goal"], [5 / 3, 5 / 6])
    _, _, _, _, info = env.step(env.action_space.sample())
    assert not info["hit_post"]
    vector = vector_env("TetherNavigate-v3", 3, layout=NO_POSTS)
    obs, _ = vector.reset(seed=0)
    assert vector.observation_space.contains(obs)


def test_a_layout_without_pegs_is_refused_a_maneuver_hooks_one():
    with pytest.raises(ValueError, match=r"layout must hold 1 to 12 pegs \(A\).*hooks a peg"):
        navigate(layout="..G\n...\nS..")


@pytest.mark.parametrize("name", ["n_anchors", "n_obstacles"])
@pytest.mark.parametrize("value", [0, 3, 6])
def test_a_layout_with_a_count_of_pegs_or_posts_is_refused(name, value):
    """Even the former defaults (6 pegs, 0 posts): a layout places them."""
    with pytest.raises(ValueError, match=rf"{name}={value} given with a layout"):
        navigate(layout=NO_POSTS, **{name: value})
    with pytest.raises(ValueError, match=rf"{name}={value} given with a layout"):
        vector_env("TetherNavigate-v3", 2, layout=NO_POSTS, **{name: value})


@pytest.mark.parametrize("name", ["n_anchors", "n_obstacles"])
def test_the_wall_rung_refuses_a_count_of_pegs_or_posts(name):
    """The Wall ids are registered with a layout: n_obstacles=2 is not silently ignored."""
    with pytest.raises(ValueError, match=rf"{name}=2 given with a layout"):
        gym.make("TetherNavigate_WallReach-v3", **{name: 2})
    gym.make("TetherNavigate_WallReach-v3").reset(seed=0)


def test_without_a_layout_the_counts_default_to_6_pegs_and_no_post():
    config = NavigateConfig()
    assert (config.n_anchors, config.n_obstacles) == (6, 0)
    assert NavigateConfig(layout=NO_POSTS).n_anchors is None  # the layout's, not given
    env = navigate()
    obs, _ = env.reset(seed=0)
    assert present_posts(obs) == 0 and env.unwrapped.state["n_anchors"] == 6
    for value in (True, 2.0, "3", -1, 5):
        with pytest.raises(ValueError, match="n_obstacles must be an integer in"):
            navigate(n_obstacles=value)


@pytest.mark.parametrize(
    ("layout", "match"),
    [
        (
            "A" + "." * 38 + "G\n" + ".S" + "." * 17 + "OO" + "." * 19,  # posts 0.05 m apart
            r"layout: the post \(O\) .* from the centre of the post \(O\) .* at least 0.1 m$",
        ),
        (
            "A.G\n" + "...\n" * 10 + "SO.",  # a post 0.042 m from the bottom wall
            r"layout: the post \(O\) at .* from the bottom wall: its centre must be at least 0.05",
        ),
        (
            "S" + "." * 30 + "G\n" + "A" + "." * 31,  # a start cell 0.031 m from the left wall
            r"layout: the start cell \(S or C\) at .* 0.03125 m from the left wall",
        ),
        (
            "A" + "." * 23 + "G\n" + "." * 25 + "\n" + "SO" + "." * 23,  # a start beside a post
            r"layout: the start cell \(S or C\) .* 0.08 m from the centre of the post \(O\) "
            r".* 0.09 m$",
        ),
        (
            "A" + "." * 29 + "\n" + ".S" + "." * 25 + "OC.",  # a C cell is a start cell too
            r"layout: the start cell \(S or C\) .* from the centre of the post \(O\)",
        ),
        (
            "A" + "." * 49 + "\n" + ".S" + "." * 38 + "OG" + "." * 8,  # a goal cell in a post
            r"layout: the goal cell \(G or C\) .* 0.04 m from the centre of the post \(O\) .* "
            r"at least 0.05 m$",
        ),
        (
            "A" + "." * 49 + "\n" + ".S" + "." * 38 + "OA" + "." * 7 + "G",  # a peg in a post
            r"layout: the peg \(A\) .* from the centre of the post \(O\)",
        ),
    ],
)
def test_a_layout_breaking_the_tables_clearances_is_refused(layout, match):
    with pytest.raises(ValueError, match=match):
        navigate(layout=layout)


def test_the_ladders_wall_layout_meets_the_clearances():
    for env_id in ("TetherNavigate_WallReach-v3", "TetherNavigate_WallStopSparse-v3"):
        env = gym.make(env_id)
        assert env.observation_space.contains(env.reset(seed=0)[0])


# ---- numeric arguments: no bool, no string ----------------------------------------------------


@pytest.mark.parametrize(
    ("name", "value"),
    [("wall_restitution", True), ("rho", "850"), ("wheel_rate", False), ("stiffness", "1e3"),
     ("rho", 850 + 0j), ("wheel_rate", np.bool_(True)), ("wall_restitution", np.array(True))],
)  # fmt: skip
def test_numeric_arguments_refuse_bools_strings_and_complex_numbers(name, value):
    with pytest.raises(ValueError, match=rf"{name} must be a real number, got"):
        navigate(**{name: value})


@pytest.mark.parametrize("value", [np.float32(0.5), np.int64(1), 1, 0.5, np.array(0.5)])
def test_numeric_arguments_take_numpy_and_python_numbers(value):
    assert navigate(wall_restitution=value).unwrapped.config.wall_restitution == float(value)


def test_tether_bounce_and_the_physics_api_refuse_bools_and_strings_too():
    with pytest.raises(ValueError, match="restitution must be a real number, got True"):
        gym.make("TetherBounce-v0", restitution=True)
    with pytest.raises(ValueError, match=r"spin_disturbance must be a real number, got '0\.1'"):
        gym.make("TetherBounce-v0", spin_disturbance="0.1")
    with pytest.raises(ValueError, match="speed must be a real number"):
        bounce_one(0.7, 0.3, speed=True)
    with pytest.raises(ValueError, match="speed must be a real number"):
        bounce(0.7, 0.3, speed=np.array([True, False]))
    with pytest.raises(ValueError, match="tether_angle must be a real number"):
        bounce("0.7", 0.3)
    with pytest.raises(ValueError, match=r"x must be a real number or array"):
        as_finite("x", (True, 0.5))
    assert check_float("x", np.float32(0.25)) == 0.25 and check_float("x", 3) == 3.0
    np.testing.assert_array_equal(as_finite("x", [1, 2.5]), [1.0, 2.5])


# ---- actions ----------------------------------------------------------------------------------


NOT_REAL = [
    np.array([1 + 1j, 0, 0, 0]),
    np.array(["0.1", "0.2", "0.3", "0.4"]),
    np.array([0.1, None, 0.3, 0.4], dtype=object),
    np.array([True, False, True, False]),
    [0.1, 0.2, 0.3, "x"],
]


@pytest.mark.parametrize("action", NOT_REAL, ids=["complex", "str", "object", "bool", "list"])
def test_actions_that_are_not_real_numbers_are_refused(action):
    env = navigate()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must be a real \(integer or float\) array of "
                                         r"shape \(4,\), got dtype"):  # fmt: skip
        env.step(action)
    bounce_env = gym.make("TetherBounce-v0")
    bounce_env.reset(seed=0)
    shape = bounce_env.action_space.shape
    with pytest.raises(ValueError, match=rf"action must be a real .* array of shape \({shape[0]},"):
        bounce_env.step(np.resize(np.asarray(action), shape))


def test_the_vector_envs_refuse_them_naming_the_batch_shape():
    envs = vector_env("TetherNavigate-v3", 2)
    envs.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must be a real .* shape \(2, 4\), got dtype"):
        envs.step(np.zeros((2, 4), dtype=complex))


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64, np.int8, np.int64])
def test_integer_and_float_actions_are_taken(dtype):
    env = navigate()
    env.reset(seed=0)
    obs, *_ = env.step(np.zeros(4, dtype=dtype))
    assert env.observation_space.contains(obs)


# ---- reset options: shape and type ------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "value", "match"),
    [
        ("start_velocity", (1.0, 2.0, 3.0), r"options\['start_velocity'\] must be a velocity "
                                            r"\(vx, vy\), m/s, got shape \(3,\)"),
        ("start_velocity", 1.0, r"options\['start_velocity'\] must be a velocity"),
        ("start", [[0.3, 0.5]], r"options\['start'\] must be a point \(x, y\), m, got shape"),
        ("goal", (1.0,), r"options\['goal'\] must be a point \(x, y\)"),
        ("posts", [(0.5, 0.5, 0.5)], r"options\['posts'\] must be points \(k, 2\), m, "
                                     r"0 <= k <= 4, got shape \(1, 3\)"),
        ("posts", [(0.5, 0.5)] * 5, r"options\['posts'\] must hold 0 to 4 points, got 5"),
        ("anchors", [], r"options\['anchors'\] must hold 1 to 12 points \(a maneuver hooks"),
        ("anchors", [(2.5, 0.5)], r"options\['anchors'\] must lie on the table"),
        ("goal", (1.0, -0.1), r"options\['goal'\] must lie on the table"),
        ("start", (True, 0.5), r"options\['start'\] must be a real number or array"),
        ("start", ("0.3", 0.5), r"options\['start'\] must be a real number or array"),
        ("goal", (1.0 + 0j, 0.5), r"options\['goal'\] must be a real number or array"),
        ("start_velocity", (True, False), r"options\['start_velocity'\] must be a real number"),
        ("anchors", [(1.0, None)], r"options\['anchors'\] must be a real number or array"),
        ("start_angle", True, r"options\['start_angle'\] must be a real number, got True"),
        ("start_angle", "0.5", r"options\['start_angle'\] must be a real number, got '0.5'"),
        ("start_spin", False, r"options\['start_spin'\] must be a real number, got False"),
        ("start_spin", 2 * MAX_SPIN, r"options\['start_spin'\] must be in \[-106\.066"),
        ("start_angle", 4.0, r"options\['start_angle'\] must be in \[-3\.14159"),
        ("start", (math.nan, 0.5), r"options\['start'\] must be finite"),
    ],
)  # fmt: skip
def test_reset_options_of_a_wrong_shape_or_type_are_refused(name, value, match):
    refused(navigate(), match, **{name: value})


@pytest.mark.parametrize("posts", [[], (), np.zeros((0, 2)), np.zeros(0)])
def test_no_post_is_a_table(posts):
    env = navigate(n_obstacles=3)
    obs, _ = env.reset(seed=0, options={"posts": posts})
    assert present_posts(obs) == 0 and env.unwrapped.state["n_posts"] == 0


# ---- reset options: the start's speed and energy ----------------------------------------------


def test_the_start_speed_is_bounded_by_its_magnitude():
    env = navigate()
    message = refused(env, r"options\['start_velocity'\] must have a speed in \[0, 3\] m/s",
                      start_velocity=(3.0, 3.0))  # fmt: skip
    assert "got 4.24264 m/s" in message
    refused(env, "start_velocity", start_velocity=(2.9, 0.8))  # each component under 3
    for velocity in [(3.0, 0.0), (0.0, -3.0), (2.1, 2.1), (0.0, 0.0)]:
        obs, _ = env.reset(seed=0, options={"start_velocity": velocity})
        assert env.observation_space.contains(obs)


def test_the_start_energy_with_the_spin_stays_within_the_observations_bound():
    env = navigate()
    refused(env, r"options\['start_velocity'\] and options\['start_spin'\] together .* got "
                 r"3.22645 m/s$", start_velocity=(2.9, 0.0), start_spin=50.0)  # fmt: skip
    message = refused(env, "start_spin", start_spin=MAX_SPIN)  # with a drawn speed >= 0.5 m/s
    assert message.endswith("(start_velocity drawn: give it too)")
    obs, _ = env.reset(seed=0, options={"start_velocity": (0.0, 0.0), "start_spin": -MAX_SPIN})
    assert env.observation_space.contains(obs)
    obs, _ = env.reset(seed=0, options={"start_velocity": (2.0, 0.0), "start_spin": 50.0})
    assert env.observation_space.contains(obs)  # sqrt(4 + 0.5 * 2^2) < 3


# ---- reset options: the table's geometry -----------------------------------------------------


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"start": (0.3, 0.5), "posts": [(0.35, 0.5)]},
         r"the start at \(0.3, 0.5\) of options\['start'\] is 0.05 m from the centre of the "
         r"post at \(0.35, 0.5\) of options\['posts'\]: it must be at least 0.09 m$"),
        ({"start": (0.01, 0.5)},
         r"the start at \(0.01, 0.5\) of options\['start'\] is 0.01 m from the left wall: its "
         r"centre must be at least 0.04 m from every wall, x in \[0.04, 1.96\], y in "
         r"\[0.04, 0.96\] m$"),
        ({"start": (1.0, 0.97)}, r"options\['start'\] .* from the top wall"),
        ({"start": (3.0, 0.5)}, r"options\['start'\] .* from the right wall"),
        ({**CLEAR, "goal": (1.0, 0.5), "posts": [(1.02, 0.5)]},
         r"the goal at \(1, 0.5\) of options\['goal'\] is 0.02 m from the centre of the post .* "
         r"of options\['posts'\]: it must be at least 0.05 m$"),
        ({**CLEAR, "anchors": [(0.5, 0.5)], "posts": [(0.52, 0.5)]},
         r"the peg at \(0.5, 0.5\) of options\['anchors'\] .* at least 0.05 m$"),
        ({**CLEAR, "posts": [(0.6, 0.5), (0.65, 0.5)]},
         r"the post at \(0.6, 0.5\) of options\['posts'\] is 0.05 m from the centre of the post "
         r"at \(0.65, 0.5\) of options\['posts'\]: it must be at least 0.1 m$"),
        ({**CLEAR, "posts": [(0.02, 0.5)]},
         r"the post at \(0.02, 0.5\) of options\['posts'\] is 0.02 m from the left wall: its "
         r"centre must be at least 0.05 m from every wall"),
    ],
)  # fmt: skip
def test_an_impossible_table_is_refused_naming_the_options(options, match):
    refused(navigate(), match, **options)


def test_options_that_clash_with_a_drawn_item_ask_for_it_too():
    """`posts` alone can cover the drawn start (and `start` alone can fall in a drawn post):
    the error names both and asks for the drawn one."""
    env = navigate(n_obstacles=2)
    env.reset(seed=0)
    state = env.unwrapped.state
    start, post = (state["x"], state["y"]), tuple(state["posts"][0])
    message = refused(env, r"the start at .* \(drawn\) is 0 m from the centre of the post at .* "
                           r"of options\['posts'\]", posts=[start])  # fmt: skip
    assert message.endswith("give options['start'] too (what is drawn fits the drawn table)")
    message = refused(env, r"the start at .* of options\['start'\] is .* post at .* \(drawn\)",
                      start=(post[0] + 0.05, post[1]))  # fmt: skip
    assert message.endswith("give options['posts'] too (what is drawn fits the drawn table)")
    goal = (state["goal_x"], state["goal_y"])
    refused(env, r"the goal at .* \(drawn\) is 0 m from .*; give options\['goal'\] too",
            start=CLEAR["start"], anchors=CLEAR["anchors"], posts=[goal])  # fmt: skip
    obs, _ = env.reset(seed=0, options={**CLEAR, "posts": [start]})  # all fixed: fine
    assert present_posts(obs) == 1


def test_every_copy_of_the_vector_env_is_checked():
    envs = vector_env("TetherNavigate-v3", 8)
    envs.reset(seed=0)
    states = envs.unwrapped.state
    start = (states["x"][5], states["y"][5])
    with pytest.raises(ValueError, match=r"\(drawn\) .*\(in copy \d of the vector env\); give "
                                         r"options\['start'\] too"):  # fmt: skip
        envs.reset(seed=0, options={"posts": [start]})
    obs, _ = envs.reset(seed=0, options={**CLEAR, "posts": [start]})
    assert envs.observation_space.contains(obs)
    assert np.all(envs.unwrapped.state["n_posts"] == 1)


def test_a_start_at_exactly_the_clearance_works():
    env = navigate()
    for start in [(PUCK_RADIUS, 0.5), (2.0 - PUCK_RADIUS, 1.0 - PUCK_RADIUS), (0.04, 0.04)]:
        obs, _ = env.reset(seed=0, options={"start": start})
        np.testing.assert_allclose(obs["achieved_goal"], start)
    table = {**CLEAR, "start": (0.59, 0.5), "posts": [(0.5, 0.5)]}  # 0.59 - 0.5 < 0.09 in floats
    obs, _ = env.reset(seed=0, options=table)
    assert env.observation_space.contains(obs)
    edges = {"start": (0.3, 0.5), "goal": (1.05, 0.5), "anchors": [(1.0, 0.75)],
             "posts": [(1.0, 0.5), (1.1, 0.5), (1.9, 0.95), (0.05, 0.05)]}  # fmt: skip
    obs, _ = env.reset(seed=0, options=edges)  # goal and peg 0.05 m, posts 0.1 m, walls 0.05 m
    assert present_posts(obs) == 4
    refused(env, "options\\['start'\\]", **{**table, "start": (0.5 + REACH - 1e-6, 0.5)})
    refused(env, "options\\['start'\\]", start=(PUCK_RADIUS - 1e-6, 0.5))


def test_a_refused_option_changes_nothing():
    env = navigate(n_obstacles=3)
    env.reset(seed=4)
    before = env.unwrapped.state.copy()
    refused(env, "start_velocity", seed=5, start_velocity=(5.0, 0.0))
    assert env.unwrapped.state.tobytes() == before.tobytes()  # the last episode's, untouched


# ---- the docstring says what the env does ----------------------------------------------------


def test_the_docstring_names_the_spaces_dtypes():
    env = navigate()
    doc = TetherNavigateEnv.__doc__
    observation = env.observation_space["observation"].dtype
    assert f"`Dict` (Gymnasium-Robotics' goal convention), {observation}:" in doc
    assert f"`Box(-1, 1, (4,), {env.action_space.dtype})`" in doc


def test_command_error_is_inf_exactly_when_no_tautening_was_found():
    """As the docstring says: then `command_met` is 0; random velocity commands often meet it."""
    assert "0 and `inf`" in TetherNavigateEnv.__doc__
    env = navigate(control="velocity", n_obstacles=2)
    rng = np.random.default_rng(0)
    errors = []
    for seed in range(6):
        env.reset(seed=seed)
        done = False
        while not done:
            action = rng.uniform(-1, 1, 4).astype(np.float32)
            _, _, terminated, truncated, info = env.step(action)
            errors.append(info["command_error"])
            assert not (math.isinf(info["command_error"]) and info["command_met"])
            done = terminated or truncated
    assert np.isinf(errors).any() and np.isfinite(errors).any()
    assert not np.isnan(errors).any()
