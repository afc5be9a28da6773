"""Frames of a TetherNavigate episode: each maneuver played over time (`envs.drawing` draws them).

The picture is the whole table (2 m x 1 m at `SCALE` pixels per metre) under a strip of text:
its walls, the pegs (the hooked one red), the posts, the goal disc, the puck at its true size
with its orientation mark and attachment point. A reset is one frame: the puck and its velocity
(an arrow showing where it goes in `ARROW_TIME` seconds). A step is the maneuver:

- flight: the puck glides along the maneuver's path, the path unrolling behind it, on a slack
  tether (grey) from the hooked peg, sped up by a whole factor so that no flight plays longer
  than about `FLIGHT_PLAY` seconds (the factor is on screen);
- contact: the tether taut (red) for `CONTACT_FRAMES` frames (slowed down: a contact lasts
  milliseconds), the puck moving from the tautening point to the slack instant's;
- coast (with `coast`): the tether gone, the puck glides on along the path to its closest
  approach to the aim, uniformly at its final speed;
- release: the tether gone, the maneuver's outcome held for `HOLD` seconds.

What is exact and what is approximate. The path (`info["path"]`) has the flight's corners
only; the timing between them is replayed: the puck glides uniformly between wall hits, and
its velocity after each hit is the physics' wall law (`events.wall_bounce_row`, the env's
`wall_restitution`) applied to the velocity of the state the step started from, so the time of
each segment is exact, the last one (to the tautening) taking what is left of `flight_time`.
The orientation is exact in flight: the free spin (unchanged by the frictionless walls) plus
the reaction wheel's turn (`info["wheel_turn"]`) at the kernel's constant rate from the
decision to the tautening. During the contact the centre of mass is
drawn on the chord from the tautening point to the slack point and the orientation turns at a
constant rate to the outcome's (the hybrid contact's true arc and spin history are not kept).
A fast spin may alias at the render rate.

A step's scene needs the state the step started from; the renderer pairs each step with the
scene before it (every scene reaches the renderer in order). Without one, as for "rgb_array"
that draws only the latest frame, the scene is that frame alone: the released puck.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import partial

import numpy as np

from tether_gym.envs.drawing import (
    MISS,
    TARGET,
    TAUT,
    VELOCITY,
    Canvas,
    Colour,
    Scene,
    SceneRenderer,
    Still,
)
from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import (
    ARM,
    PATH_POINTS,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.spaces import OUT
from tether_gym.physics.events import time_to_wall_row, wall_bounce_row
from tether_gym.physics.geometry import fold_angle
from tether_gym.physics.state import PuckState
from tether_gym.tasks.navigate import GOAL_RADIUS

SCALE = 300
"""Pixels per metre."""
MARGIN, STRIP = 20, 80
"""Pixels: around the table, and the strip of text above it."""
SIZE = (round(TABLE_WIDTH * SCALE) + 2 * MARGIN, round(TABLE_HEIGHT * SCALE) + STRIP + MARGIN)
CENTRE = (0.5 * TABLE_WIDTH, TABLE_HEIGHT - (0.5 * SIZE[1] - STRIP) / SCALE)
"""The world point at the picture's centre: the table's top edge is `STRIP` pixels down."""
TEXT_SIZE = 28
FLIGHT_PLAY = 1.5
"""Seconds: a longer flight is sped up by the least whole factor that brings it under this."""
CONTACT_FRAMES = 8
HOLD = 0.4
"""Seconds the released puck stays on screen at the end of a maneuver."""
ARROW_TIME = 0.3
"""Seconds of motion the velocity arrow spans."""
TASK_LINES = {"reach": "reach the goal", "stop": "stop on the goal"}
Lines = list[str | tuple[str, Colour]]
"""Text lines, each with its colour or not (`Canvas.text`)."""


class Renderer(SceneRenderer):
    """TetherNavigate's scenes for `drawing.SceneRenderer`'s render modes."""

    def __init__(self, render_mode: str, fps: float, config: NavigateConfig) -> None:
        super().__init__(render_mode, fps, "TetherNavigate-v3", Canvas(SIZE, SIZE[1] / SCALE))
        self.canvas.look_at(CENTRE)
        self.config = config
        self._before: np.void | None = None
        """The state of the latest scene drawn from: the next step starts from it."""

    def render(
        self, scenes: Sequence[tuple], latest: tuple
    ) -> np.ndarray | list[np.ndarray] | None:
        """`SceneRenderer.render`, each step paired with the state it started from."""
        paired = []
        for state, outcome in scenes:
            paired.append((state, outcome, self._before))
            self._before = state
        return super().render(paired, (*latest, None))

    def scene(
        self, state: np.void | None, outcome: np.ndarray | None, before: np.void | None
    ) -> Scene:
        """Nothing before the first reset, the start after a reset, the maneuver after a step
        (only its end without the state `before` it)."""
        if state is None:
            return Still(Canvas.clear)
        if outcome is None:
            return Still(partial(_start, self.config, state))
        if before is None:
            return Still(partial(_released, self.config, state, outcome))
        return Maneuver(self.config, before, state, outcome, self.fps)


def _table(canvas: Canvas, state: np.void, hooked: np.ndarray | None = None) -> None:
    """The cleared picture: walls, goal, posts, pegs (the `hooked` one red)."""
    canvas.clear()
    corners = [(0.0, 0.0), (TABLE_WIDTH, 0.0), (TABLE_WIDTH, TABLE_HEIGHT), (0.0, TABLE_HEIGHT)]
    for k in range(4):
        canvas.wall(corners[k - 1], corners[k])
    canvas.goal((state["goal_x"], state["goal_y"]), GOAL_RADIUS)
    for post in state["posts"][: state["n_posts"]]:
        canvas.post(post, POST_RADIUS)
    for peg in state["anchors"][: state["n_anchors"]]:
        canvas.anchor(peg)
    if hooked is not None:
        canvas.anchor(hooked, TAUT)


def _attachment(centre, orientation: float) -> np.ndarray:
    """The tether's attachment point of a puck at `centre` turned by `orientation`."""
    return np.asarray(centre) + ARM * np.array([math.cos(orientation), math.sin(orientation)])


def _puck(canvas: Canvas, centre, orientation: float) -> None:
    canvas.puck(centre, PUCK_RADIUS, orientation, _attachment(centre, orientation))


def _header(canvas: Canvas, config: NavigateConfig, state: np.void, centre, lines: Lines) -> None:
    """The text strip: the task, the maneuver, the distance to the goal; `lines` on the right."""
    done = config.max_maneuvers - int(state["maneuvers_left"])
    maneuver = f"maneuver {done} of {config.max_maneuvers}" if done else "start"
    distance = math.hypot(state["goal_x"] - centre[0], state["goal_y"] - centre[1])
    left = [TASK_LINES[config.task], maneuver, f"goal {distance:.2f} m away"]
    canvas.text(left, (MARGIN, 6), TEXT_SIZE)
    canvas.text(lines, (SIZE[0] // 2, 6), TEXT_SIZE)


def _still_puck(canvas: Canvas, state: np.void) -> None:
    """The puck at rest in the picture, its velocity an arrow."""
    centre = (state["x"], state["y"])
    velocity = ARROW_TIME * np.array([state["vx"], state["vy"]])
    canvas.arrow(centre, velocity, VELOCITY, 3)
    _puck(canvas, centre, state["angle"])


def _start(config: NavigateConfig, state: np.void, canvas: Canvas) -> None:
    _table(canvas, state)
    _still_puck(canvas, state)
    speed = math.hypot(state["vx"], state["vy"])
    _header(canvas, config, state, (state["x"], state["y"]), [f"launched at {speed:.2f} m/s"])


def _released(config: NavigateConfig, state: np.void, outcome: np.ndarray, canvas: Canvas) -> None:
    """The end of a maneuver: its whole path, the released puck, the outcome."""
    _table(canvas, state, outcome[OUT.anchor : OUT.anchor + 2])
    canvas.path(_path(outcome))
    _still_puck(canvas, state)
    _header(canvas, config, state, (state["x"], state["y"]), _result(state, outcome))


def _path(outcome: np.ndarray) -> np.ndarray:
    """The maneuver's path (PATH_POINTS, 2), padded with its last point."""
    return outcome[OUT.path : OUT.path + 2 * PATH_POINTS].reshape(PATH_POINTS, 2)


def _result(state: np.void, outcome: np.ndarray) -> Lines:
    speed = math.hypot(state["vx"], state["vy"])
    lines: Lines = [
        f"released at {speed:.2f} m/s" if outcome[OUT.bounced]
        else ("the tether never went taut", MISS)
    ]  # fmt: skip
    if outcome[OUT.is_success]:
        lines.append(("success", TARGET))
    elif outcome[OUT.hit_post]:
        lines.append(("hit a post", MISS))
    elif outcome[OUT.at_rest]:
        lines.append(("at rest off the goal", MISS))
    elif outcome[OUT.truncated]:
        lines.append(("no maneuver left", MISS))
    return lines


def _index(path: np.ndarray, point: np.ndarray, start: int) -> int:
    """The first of the path's points from `start` on that is `point` (the maneuver writes
    its tautening and its release into the path as it reports them)."""
    return start + int(np.flatnonzero(np.all(path[start:] == point, axis=1))[0])


def _along(points: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The points at fractions `s` of the polyline's length."""
    lengths = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    at = s * lengths[-1]
    return np.column_stack([np.interp(at, lengths, points[:, k]) for k in (0, 1)])


def _coast_path(path: np.ndarray, release: int) -> np.ndarray:
    """The path from the slack instant (point `release`) on, its padding dropped: the release
    alone unless the puck coasted to an aim."""
    end = len(path) - 1
    while end > release and np.array_equal(path[end - 1], path[-1]):
        end -= 1
    return path[release : end + 1]


def flight_times(
    path: np.ndarray, velocity: tuple[float, float], flight_time: float, restitution: float
) -> np.ndarray:
    """The instants (s) at the points of a flight's path (start, wall hits, end), replaying
    the wall law from the start's `velocity`."""
    vx, vy = velocity
    times = np.zeros(len(path))
    for k in range(1, len(path) - 1):  # each inner point a wall hit
        t, wall = time_to_wall_row(
            PuckState(*path[k - 1], vx, vy, 0.0, 0.0), TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS
        )
        times[k] = times[k - 1] + t
        _, _, vx, vy, _, _ = wall_bounce_row(
            PuckState(*path[k], vx, vy, 0.0, 0.0), wall, restitution
        )
    times[-1] = flight_time
    return times


class Maneuver:
    """One step's maneuver as frames: flight, contact, release (see the module)."""

    def __init__(
        self,
        config: NavigateConfig,
        before: np.void,
        state: np.void,
        outcome: np.ndarray,
        fps: float,
    ) -> None:
        self.config, self.state, self.outcome = config, state, outcome
        path = _path(outcome)
        bounced = bool(outcome[OUT.bounced])
        taut = _index(path, outcome[OUT.taut_position : OUT.taut_position + 2], 1)
        flight = path[: taut + 1]
        duration = float(outcome[OUT.flight_time])
        times = flight_times(
            flight, (before["vx"], before["vy"]), duration, config.wall_restitution
        )
        self.factor = max(1, math.ceil(duration / FLIGHT_PLAY))
        """The flight's speed-up."""
        n_flight = max(1, round(duration * fps / self.factor))
        self.t = np.arange(n_flight) * (duration / n_flight)
        """Seconds since the decision at each flight frame."""
        com = np.column_stack([np.interp(self.t, times, flight[:, k]) for k in (0, 1)])
        self.passed = np.searchsorted(times, self.t, side="right")
        """The path's points behind the puck at each flight frame."""
        # the free spin and the wheel's constant rate
        wheel = outcome[OUT.wheel_turn] / duration if duration > 0.0 else 0.0
        orientation = before["angle"] + (before["spin"] + wheel) * self.t
        n_contact = CONTACT_FRAMES if bounced else 0
        if bounced:
            taut_angle = outcome[OUT.taut_angle]
            s = np.linspace(0.0, 1.0, n_contact)
            release = _index(path, outcome[OUT.release_position : OUT.release_position + 2], taut)
            com = np.vstack([com, _along(path[taut : release + 1], s)])
            spun = fold_angle(outcome[OUT.angle] - taut_angle)
            orientation = np.concatenate([orientation, taut_angle + s * spun])
        else:
            release = taut
        self.arc = path[taut : release + 1]
        "The contact's arc, from the tautening to the release."
        self.coast = _coast_path(path, release) if bounced else path[:0]
        """With `coast`: the release, the coast's wall hits and its end."""
        self.coasting = n_flight + n_contact
        """The first frame after the contact."""
        if len(self.coast) > 1:
            # glide uniformly along the coast at the puck's final speed, its free spin turning it
            lengths = np.linalg.norm(np.diff(self.coast, axis=0), axis=1)
            along = np.concatenate([[0.0], np.cumsum(lengths)])
            speed = math.hypot(*outcome[OUT.velocity : OUT.velocity + 2])
            seconds = along[-1] / max(speed, 1e-9)
            n_coast = max(1, round(seconds * fps / self.factor))
            at = np.linspace(0.0, along[-1], n_coast + 1)[1:]
            glide = np.column_stack([np.interp(at, along, self.coast[:, k]) for k in (0, 1)])
            com = np.vstack([com, glide])
            spin = outcome[OUT.spin]
            orientation = np.concatenate(
                [orientation, outcome[OUT.angle] - spin * (seconds - at / max(speed, 1e-9))]
            )
            self.coast_passed = np.searchsorted(along, at, side="right")
        self.flight, self.com, self.orientation = flight, com, orientation
        self.released = len(com)
        """The first frame after the maneuver (the release, or with `coast` its end)."""
        self.frames = self.released + max(1, round(HOLD * fps))

    def __len__(self) -> int:
        return self.frames

    def draw(self, canvas: Canvas, frame: int) -> None:
        if frame >= self.released:
            _released(self.config, self.state, self.outcome, canvas)
            return
        anchor = self.outcome[OUT.anchor : OUT.anchor + 2]
        _table(canvas, self.state, anchor)
        centre = self.com[frame]
        if frame >= self.coasting:  # the tether released, the puck on its way to the aim
            behind = self.coast[: self.coast_passed[frame - self.coasting]]
            canvas.path([*self.flight, *self.arc, *behind, centre])
            _puck(canvas, centre, self.orientation[frame])
            _header(canvas, self.config, self.state, centre, ["coasting to the aim"])
            return
        flying = frame < len(self.t)
        behind = self.flight[: self.passed[frame]] if flying else self.flight
        canvas.path([*behind, centre])
        attachment = _attachment(centre, self.orientation[frame])
        canvas.tether(anchor, attachment, taut=not flying)
        _puck(canvas, centre, self.orientation[frame])
        if flying:
            speed = f"{self.factor}x speed" if self.factor > 1 else "real time"
            phase = [f"flight, {speed}", f"t = {self.t[frame]:.2f} s"]
        else:
            phase = [("tether taut (slowed down)", TAUT)]
        _header(canvas, self.config, self.state, centre, phase)
