"""Rendering: the drawing layer, TetherBounce-v0's bounce drawn over time in every render mode,
video capture and the GIF command."""

from __future__ import annotations

import itertools
import math
import os
import subprocess
import sys
import time

import gymnasium as gym
import numpy as np
import pytest

import tether_gym  # noqa: F401
from tether_gym.agents import record
from tether_gym.envs import drawing
from tether_gym.envs.tether_bounce import kernel
from tether_gym.envs.tether_bounce.rendering import CONTACT_FRAMES, SIZE
from tether_gym.envs.tether_navigate import config as navigate_config
from tether_gym.envs.tether_navigate import rendering as navigate_rendering
from tether_gym.envs.tether_navigate.controls.setup import ACTION as SETUP_ACTION
from tether_gym.envs.tether_navigate.spaces import OUT
from tether_gym.tasks.navigate import segment_distance

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

BANK_SHOT = kernel.ACTION.normalize([2.0, math.pi / 4, 0.0, 0.0]).astype(np.float32)
"""A 45 degree tether on the centre of mass: a 90 degree turn to the left (heading +pi/2)."""
SLACK = kernel.ACTION.normalize([2.0, 0.0, 0.0, 0.0]).astype(np.float32)
"""The anchor level with the puck: the attachment never moves away, the tether stays slack."""


def bounce_frames(action, render_mode="rgb_array_list", **kwargs):
    env = gym.make("TetherBounce-v0", render_mode=render_mode, **kwargs)
    env.reset(seed=0, options={"task": "heading", "target_heading": math.pi / 2})
    env.step(action)
    frames = env.render()
    return env, frames


def has(frame: np.ndarray, colour) -> np.ndarray:
    return np.all(frame == colour, axis=-1)


def centroid(frame: np.ndarray, colour) -> np.ndarray:
    """(column, row) of the pixels of exactly `colour`."""
    rows, columns = np.nonzero(has(frame, colour))
    return np.array([columns.mean(), rows.mean()])


def test_pygame_is_imported_only_to_draw():
    code = (
        "import sys, tether_gym.envs.drawing, tether_gym.envs.tether_bounce.rendering\n"
        "import tether_gym.envs.tether_navigate.rendering\n"
        "import tether_gym.agents.record\nassert 'pygame' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_canvas_maps_metres_to_pixels_with_y_up():
    canvas = drawing.Canvas((200, 100), extent=2.0)  # 50 pixels per metre
    canvas.look_at((1.0, 1.0))
    assert canvas.px((1.0, 1.0)) == (100, 50)
    assert canvas.px((2.0, 1.5)) == (150, 25)
    canvas.clear()
    canvas.puck((1.0, 1.0), 0.2, 0.0, (1.1, 1.0))
    frame = canvas.rgb()
    assert frame.shape == (100, 200, 3) and frame.dtype == np.uint8
    np.testing.assert_allclose(centroid(frame, drawing.PUCK), (100, 50), atol=1.5)
    assert has(frame, drawing.ATTACHMENT).any()
    canvas.goal((2.5, 1.5), 0.2)  # what TetherNavigate adds
    canvas.post((0.0, 1.5), 0.1)
    canvas.wall((-1.0, 0.5), (3.0, 0.5))
    frame = canvas.rgb()
    assert has(frame, drawing.GOAL_FILL).any() and has(frame, drawing.POST)[25, 50]
    assert has(frame, drawing.POST)[75].all()  # the wall, across the picture


@pytest.mark.parametrize("dynamics", ["impulse", "hybrid"])
def test_a_step_is_drawn_over_time(dynamics):
    """The puck flies up on a slack tether, the tether goes taut for a few frames, the puck
    leaves to the left (the bank shot); `render()` then has no new frames."""
    env, frames = bounce_frames(BANK_SHOT, dynamics=dynamics)
    assert len(frames) > 40
    assert all(f.shape == (SIZE, SIZE, 3) and f.dtype == np.uint8 for f in frames)
    bounce = frames[1:]  # frames[0] is the reset's
    taut = np.array([has(f, drawing.TAUT).sum() > 50 for f in bounce])
    first, last = np.flatnonzero(taut)[[0, -1]]
    assert taut.sum() >= CONTACT_FRAMES and taut[first : last + 1].all()
    puck = np.array([centroid(f, drawing.PUCK) for f in bounce])
    assert np.all(np.diff(puck[:first, 1]) < 0)  # up the screen
    assert np.all(np.diff(puck[last + 1 :, 0]) <= 0) and puck[-1, 0] < puck[last, 0] - 50
    assert env.render() == []
    env.close()


def test_a_slack_tether_is_never_drawn_taut():
    env, frames = bounce_frames(SLACK, dynamics="impulse")
    assert len(frames) > 40 and not any(has(f, drawing.TAUT).any() for f in frames)
    env.close()


def test_rgb_array_is_the_latest_frame():
    """One frame per call: the reset's, then the end of the bounce (check_env's contract)."""
    env = gym.make("TetherBounce-v0", render_mode="rgb_array")
    env.reset(seed=0, options={"task": "heading", "target_heading": math.pi / 2})
    reset_frame = env.render()
    env.step(BANK_SHOT)
    frame = env.render()
    _, frames = bounce_frames(BANK_SHOT)
    assert np.array_equal(reset_frame, frames[0]) and np.array_equal(frame, frames[-1])
    assert np.array_equal(env.render(), frame)
    env.close()


def test_human_mode_plays_the_bounce_in_real_time():
    env = gym.make("TetherBounce-v0", render_mode="human")
    env.reset(seed=0)
    start = time.perf_counter()
    env.step(BANK_SHOT)
    elapsed = time.perf_counter() - start
    _, frames = bounce_frames(BANK_SHOT)
    assert elapsed > 0.8 * (len(frames) - 2) / env.metadata["render_fps"]
    assert env.render() is None and env.unwrapped._renderer.window.screen is not None
    env.close()


def test_record_video_keeps_every_frame_of_a_step(tmp_path):
    pytest.importorskip("moviepy")
    env = record.RecordVideo(
        gym.make("TetherBounce-v0", render_mode="rgb_array_list"),
        str(tmp_path / "videos"),
        episode_trigger=lambda _: True,
        disable_logger=True,
    )
    for episode in range(2):
        env.reset(seed=episode)
        env.step(BANK_SHOT)
        assert len(env.recorded_frames) > 40
    env.close()
    assert sorted(p.name for p in (tmp_path / "videos").iterdir()) == [
        "rl-video-episode-0.mp4",
        "rl-video-episode-1.mp4",
    ]


def test_gif_command_writes_an_animation_and_keeps_existing_files(tmp_path, capsys):
    from PIL import Image

    gif = tmp_path / "bounce.gif"
    args = ["--episodes", "2", "--out", str(gif), "--size", "96", "--fps", "10"]
    record.main([*args, "--dynamics", "impulse"])
    assert "frames" in capsys.readouterr().out
    with Image.open(gif) as image:
        assert image.size == (96, 96) and image.n_frames > 20 and image.is_animated
    written = gif.read_bytes()
    with pytest.raises(SystemExit):
        record.main(args)
    assert "--overwrite" in capsys.readouterr().err and gif.read_bytes() == written
    record.main([*args, "--overwrite", "--agent", "random"])
    assert gif.read_bytes() != written


# ---- TetherNavigate-v3 -----------------------------------------------------------------------

TABLE = {
    "start": (1.2, 0.5),
    "start_velocity": (1.2, 0.3),
    "start_angle": 0.0,
    "anchors": [(1.3, 0.3)],
    "goal": (0.3, 0.8),
}
"""One peg (the one hooked): the puck hits the right wall, then the top wall, then the tether
(0.8 m) goes taut after 1.8 s."""
LONG_TETHER = SETUP_ACTION.normalize([0.0, 0.8, 0.0, 1.0]).astype(np.float32)
POST_IN_THE_WAY = [(1.45, 0.56)]
"""A post the puck hits before its tether goes taut."""
PER_METRE = navigate_rendering.SCALE


def maneuver_frames(render_mode="rgb_array_list", **options):
    env = gym.make("TetherNavigate-v3", render_mode=render_mode)
    env.reset(seed=0, options={**TABLE, **options})
    _, _, _, _, info = env.step(LONG_TETHER)
    return env, env.render(), info


def table_point(pixel: np.ndarray) -> np.ndarray:
    """A pixel (column, row) of TetherNavigate's picture as a table point (m)."""
    column, row = pixel
    x = (column - navigate_rendering.MARGIN) / PER_METRE
    return np.array(
        [x, navigate_config.TABLE_HEIGHT - (row - navigate_rendering.STRIP) / PER_METRE]
    )


def taut_tether(frame: np.ndarray, anchor) -> int:
    """Pixels of the taut tether's colour on the table, the hooked peg's mark left out."""
    red = has(frame, drawing.TAUT)
    red[: navigate_rendering.STRIP] = False  # the text
    column = round(navigate_rendering.MARGIN + anchor[0] * PER_METRE)
    row = round(navigate_rendering.STRIP + (navigate_config.TABLE_HEIGHT - anchor[1]) * PER_METRE)
    red[row - 6 : row + 7, column - 6 : column + 7] = False
    return int(red.sum())


def test_a_maneuver_is_drawn_over_time_along_its_path():
    """The puck glides along the path (two wall hits) at the wall law's speeds, sped up by a
    whole factor, then sits at the tautening point with the tether taut, then at the release."""
    env, frames, info = maneuver_frames()
    anchor, path = info["anchor"], info["path"]
    assert all(f.shape == (*navigate_rendering.SIZE[::-1], 3) for f in frames)
    taut = np.array([taut_tether(f, anchor) > 50 for f in frames])
    first, last = np.flatnonzero(taut)[[0, -1]]
    assert taut.sum() == navigate_rendering.CONTACT_FRAMES and taut[first : last + 1].all()
    flight = frames[1:first]  # frames[0] is the reset's
    assert all(np.any(a != b) for a, b in itertools.pairwise(flight))
    # where the puck should be: uniform motion, the wall law with restitution 0.9
    x0, y0, vx, vy = 1.2, 0.5, 1.2, 0.3
    right = (navigate_config.TABLE_WIDTH - navigate_config.PUCK_RADIUS - x0) / vx
    top = right + (navigate_config.TABLE_HEIGHT - navigate_config.PUCK_RADIUS - path[1, 1]) / vy
    hits = np.array([0.0, right, top, info["flight_time"]])
    np.testing.assert_allclose(path[1], (x0 + vx * right, y0 + vy * right))
    t = np.arange(len(flight)) * info["flight_time"] / len(flight)
    expected = np.column_stack([np.interp(t, hits, path[:4, k]) for k in (0, 1)])
    drawn = np.array([table_point(centroid(f, drawing.PUCK)) for f in flight])
    np.testing.assert_allclose(drawn, expected, atol=2.0 / PER_METRE)
    assert len(flight) < 1.5 * env.metadata["render_fps"]  # sped up: a 1.8 s flight
    np.testing.assert_allclose(
        table_point(centroid(frames[first], drawing.PUCK)), path[3], atol=1.5 / PER_METRE
    )
    attachment = table_point(centroid(frames[first], drawing.ATTACHMENT))  # turned by the wheel
    reach = np.hypot(*(attachment - anchor))
    assert reach == pytest.approx(info["tether_length"], abs=1.5 / PER_METRE)
    end = table_point(centroid(frames[-1], drawing.PUCK))
    np.testing.assert_allclose(end, info["position"], atol=1.5 / PER_METRE)
    assert not any(taut_tether(f, anchor) for f in frames[last + 1 :])  # released
    assert env.render() == []
    env.close()


def test_a_tether_that_never_goes_taut_is_never_drawn_taut():
    env, frames, info = maneuver_frames(posts=POST_IN_THE_WAY)
    assert info["hit_post"] and not info["bounced"] and len(frames) > 10
    assert not any(taut_tether(f, info["anchor"]) for f in frames)
    env.close()


def test_navigate_rgb_array_is_the_latest_frame():
    env = gym.make("TetherNavigate-v3", render_mode="rgb_array")
    env.reset(seed=0, options=TABLE)
    reset_frame = env.render()
    env.step(LONG_TETHER)
    frame = env.render()
    _, frames, _ = maneuver_frames()
    assert np.array_equal(reset_frame, frames[0]) and np.array_equal(frame, frames[-1])
    assert np.array_equal(env.render(), frame)
    env.close()


def test_navigate_human_mode_plays_the_maneuver():
    env = gym.make("TetherNavigate-v3", render_mode="human")
    env.reset(seed=0, options=TABLE)
    start = time.perf_counter()
    env.step(LONG_TETHER)
    elapsed = time.perf_counter() - start
    _, frames, _ = maneuver_frames()
    assert elapsed > 0.8 * (len(frames) - 2) / env.metadata["render_fps"]
    assert env.render() is None and env.unwrapped._renderer.window.screen is not None
    env.close()


def test_navigate_passes_check_env_with_rendering():
    from gymnasium.utils.env_checker import check_env

    check_env(gym.make("TetherNavigate-v3", render_mode="rgb_array").unwrapped)
    with pytest.raises(ValueError, match="render_mode"):
        gym.make_vec("TetherNavigate-v3", 2, "vector_entry_point", render_mode="rgb_array")


@pytest.mark.parametrize("agent", ["random", "greedy"])
def test_gif_command_records_tether_navigate(tmp_path, agent):
    from PIL import Image

    gif = tmp_path / "navigate.gif"
    args = ["--env", "TetherNavigate-v3", "--agent", agent, "--episodes", "1"]
    record.main([*args, "--out", str(gif), "--size", "96", "--fps", "10"])
    with Image.open(gif) as image:
        assert image.size == (96, 60) and image.n_frames > 5


def test_a_coast_to_the_aim_is_drawn_after_the_release():
    """With `coast`, after the taut tether the puck glides, no tether drawn, along the
    maneuver's path (off a wall if it goes there) from the release to its closest approach to
    the aim, where the maneuver's last frame holds it."""
    env = gym.make("TetherNavigate_OpenReach-v3", control="aim", coast=True,
                   render_mode="rgb_array_list")  # fmt: skip
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([0.0, 0.0, 1.0], np.float32))  # the table's centre
    frames = env.render()
    anchor = info["anchor"]
    taut = np.flatnonzero([taut_tether(f, anchor) > 50 for f in frames])
    assert info["bounced"] and len(taut) == navigate_rendering.CONTACT_FRAMES
    coasting = frames[taut[-1] + 1 :]
    centres = np.array([table_point(centroid(f, drawing.PUCK)) for f in coasting])
    np.testing.assert_allclose(centres[-1], info["position"], atol=1.5 / PER_METRE)
    moves = np.hypot(*np.diff(centres, axis=0).T)
    assert (moves > 1.0 / PER_METRE).sum() > 3 and moves[-1] < 1.0 / PER_METRE  # then held
    path = info["path"]
    off = [min(segment_distance(*c, *a, *b) for a, b in itertools.pairwise(path)) for c in centres]
    assert max(off) < 1.5 / PER_METRE
    assert not any(taut_tether(f, anchor) for f in coasting)
    env.close()


def test_a_contact_is_drawn_along_its_arc_and_its_wall_bounces_are_not_the_flight_s():
    """A soft tether (rho 10) whose contacts swing the puck into a wall: the drawn flight ends
    at the tautening, the contact follows the arc the path draws, and without `coast` nothing
    is drawn after the release."""
    env = gym.make("TetherNavigate_OpenReach-v3", rho=10.0)
    kernel, rng = env.unwrapped.kernel, np.random.default_rng(0)
    checked = 0
    for seed in range(40):
        env.reset(seed=seed)
        state = env.unwrapped.state.reshape(1).copy()
        for _ in range(3):
            new_state, _, out = kernel.step(state, rng.uniform(-1, 1, (1, 4)))
            row = out[0]
            taut = row[OUT.taut_position : OUT.taut_position + 2]
            release = row[OUT.release_position : OUT.release_position + 2]
            drawn = navigate_rendering.Maneuver(
                env.unwrapped.config, state[0], new_state[0], row, 30
            )
            np.testing.assert_array_equal(drawn.flight[-1], taut)
            if row[OUT.bounced]:
                np.testing.assert_array_equal(drawn.arc[[0, -1]], [taut, release])
                contact = drawn.com[len(drawn.t) : drawn.coasting]
                gaps = [
                    min(segment_distance(*c, *a, *b) for a, b in itertools.pairwise(drawn.arc))
                    if len(drawn.arc) > 1 else np.hypot(*(c - drawn.arc[0]))
                    for c in contact
                ]  # fmt: skip
                assert max(gaps) < 1e-9
                assert len(drawn.coast) <= 1  # no coast without `coast`
                checked += len(drawn.arc) > 2 and row[OUT.wall_hits] > len(drawn.flight) - 2
            if row[OUT.terminated] or row[OUT.truncated]:
                break
            state = new_state
    assert checked >= 1  # a contact that bounced off a wall, drawn along its arc
    env.close()
