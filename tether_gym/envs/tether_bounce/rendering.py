"""Frames of a TetherBounce episode: the bounce played over time (`envs.drawing` draws them).

The view is the launch frame centred on the puck's centre of mass at tautening, +y up, with
the target drawn there: an arrow along the target heading (heading task), an arrow whose tip is
where the puck should be `AFTER` seconds past the bounce (velocity task), a ring the puck
should stay in (deadspin). A reset is one frame: the target and the puck to come. A step is
the bounce, sampled in time with `physics.trajectory` from the episode's set-up: the puck
flying in along +y on its slack tether (grey), the contact with the taut tether (red, at
least `CONTACT_FRAMES` frames however short it is; the impulse model's instant is held that
long), the puck leaving with its path unrolled behind it, then the outcome held for `HOLD`.
Flight plays in real time at the env's `render_fps`; only the contact is slowed down.

The drawn motion is the impulse model's for `dynamics="impulse"`, else the hybrid model's
(scipy's reference integration, for "pymunk" too): it agrees with the outcome the env reports
to the drawing's precision. The puck is drawn `PUCK_DRAWN` times its size (4 cm on a 1 m tether)
so that its orientation mark and attachment point read.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np

from tether_gym.envs.drawing import (
    MISS,
    PATH,
    PUCK,
    TARGET,
    Canvas,
    Colour,
    Scene,
    SceneRenderer,
    Still,
)
from tether_gym.envs.tether_bounce.kernel import OUT, PUCK_MASS, PUCK_RADIUS, ST, TETHER_LENGTH
from tether_gym.physics.trajectory import trajectory
from tether_gym.tasks.bounce import DEADSPIN, VELOCITY

SIZE = 640
TEXT_SIZE = 26
"""Pixels: the picture's side, and the height of its text."""
VIEW = 2.6 * TETHER_LENGTH
"""Metres across the picture: the anchor, a tether length from the puck, is always in view."""
PUCK_DRAWN = 2.5
BEFORE = AFTER = 0.6
"""Seconds of flight drawn before tautening and after the contact."""
CONTACT_FRAMES = 8
HOLD = 0.4
"""Seconds the outcome stays on screen at the end of a step."""
HEADING_ARROW = 0.9
DEADSPIN_RING = 0.15
"""Metres: the heading target's arrow, the deadspin target's ring."""


class Renderer(SceneRenderer):
    """TetherBounce's scenes for `drawing.SceneRenderer`'s render modes."""

    def __init__(self, render_mode: str, fps: float, dynamics: str) -> None:
        super().__init__(render_mode, fps, "TetherBounce-v0", Canvas((SIZE, SIZE), VIEW))
        self.model = "impulse" if dynamics == "impulse" else "hybrid"

    def scene(self, state: np.ndarray | None, outcome: np.ndarray | None) -> Scene:
        """Nothing before the first reset, the set-up after a reset, the bounce after a step."""
        if state is None:
            return Still(Canvas.clear)
        if outcome is None:
            return Still(partial(_set_up, state))
        return Bounce(state, outcome, self.model, self.fps)


def _set_up(state: np.ndarray, canvas: Canvas) -> None:
    """The target and the puck to come, up +y to where its tether will go taut."""
    origin = np.zeros(2)
    canvas.look_at(origin)
    canvas.clear()
    _target(canvas, state, origin)
    canvas.dashed((0.0, -0.6 * VIEW / 2), origin)
    canvas.disc(origin, PUCK_DRAWN * PUCK_RADIUS, PUCK)
    canvas.text([_task_line(state), "set-up to choose"], (10, 8), TEXT_SIZE)


def _target(canvas: Canvas, state: np.ndarray, at: np.ndarray) -> None:
    if state[ST.task] == DEADSPIN:
        canvas.ring(at, DEADSPIN_RING, TARGET, 3)
        return
    heading = state[ST.target_heading]
    direction = np.array([-math.sin(heading), math.cos(heading)])
    length = AFTER * state[ST.target_speed] if state[ST.task] == VELOCITY else HEADING_ARROW
    canvas.arrow(at, length * direction, TARGET)


def _task_line(state: np.ndarray) -> str:
    if state[ST.task] == DEADSPIN:
        return "target: deadspin"
    heading = f"{math.degrees(state[ST.target_heading]):+.0f} deg"
    if state[ST.task] == VELOCITY:
        return f"target: {state[ST.target_speed]:.2f} m/s at {heading}"
    return f"target: heading {heading}"


class Bounce:
    """One step's bounce as frames: in flight, contact, out, hold (see the module)."""

    def __init__(self, state: np.ndarray, outcome: np.ndarray, model: str, fps: float) -> None:
        self.state = state
        arm = outcome[OUT.offset] * PUCK_RADIUS
        path = trajectory(
            outcome[OUT.tether_angle], outcome[OUT.offset_angle], offset=outcome[OUT.offset],
            inertia_ratio=state[ST.inertia_ratio], speed=outcome[OUT.launch_speed],
            spin=state[ST.spin], restitution=state[ST.restitution], model=model,
            mass=PUCK_MASS, radius=PUCK_RADIUS, tether_length=TETHER_LENGTH,
            stiffness=state[ST.stiffness], before=BEFORE, after=AFTER, frames=2,
        )  # fmt: skip
        step = 1.0 / fps  # physical seconds per frame
        bounced = bool(path.taut.any())
        end = float(path.t[path.taut][-1]) if bounced else 0.0
        n_in = max(1, round(BEFORE / step))
        n_contact = max(CONTACT_FRAMES, math.ceil(end / step) + 1) if bounced else 1
        n_out = max(1, round(AFTER / step))
        self.t = np.concatenate([
            np.linspace(-BEFORE, 0.0, n_in, endpoint=False),
            np.linspace(0.0, end, n_contact),
            np.linspace(end, end + AFTER, n_out + 1)[1:],
            np.full(round(HOLD * fps), end + AFTER),
        ])  # fmt: skip
        self.taut = np.zeros(self.t.size, dtype=bool)
        self.taut[n_in : n_in + n_contact] = bounced
        self.leaving = n_in + n_contact
        """The first frame after the contact."""
        self.slowed = n_contact > math.ceil(end / step) + 1
        """Whether the contact is drawn slower than real time (a short one)."""
        self.com = np.column_stack([np.interp(self.t, path.t, path.com[:, k]) for k in (0, 1)])
        self.orientation = np.interp(self.t, path.t, path.orientation)
        self.attachment = self.com + PUCK_DRAWN * arm * np.column_stack(
            [np.cos(self.orientation), np.sin(self.orientation)]
        )
        self.origin = self.com[n_in]
        """The centre of mass at tautening; the anchor is at (0, 0)."""
        beta, alpha = (math.degrees(outcome[i]) for i in (OUT.tether_angle, OUT.offset_angle))
        self.lines = [
            _task_line(state),
            f"launch {outcome[OUT.launch_speed]:.2f} m/s, tether {beta:.0f} deg, "
            f"offset {outcome[OUT.offset]:.2f} R at {alpha:+.0f} deg",
        ]
        self.result = _result_lines(outcome)
        """Text lines: the task and the set-up, then the outcome from `leaving` on."""

    def __len__(self) -> int:
        return self.t.size

    def draw(self, canvas: Canvas, frame: int) -> None:
        canvas.look_at(self.origin)
        canvas.clear()
        canvas.path(self.com[: frame + 1], PATH)
        _target(canvas, self.state, self.origin)
        canvas.tether((0.0, 0.0), self.attachment[frame], bool(self.taut[frame]))
        canvas.anchor((0.0, 0.0))
        canvas.puck(
            self.com[frame], PUCK_DRAWN * PUCK_RADIUS, self.orientation[frame],
            self.attachment[frame],
        )  # fmt: skip
        lines = self.lines + (self.result if frame >= self.leaving else [])
        canvas.text(lines, (10, 8), TEXT_SIZE)
        phase = "slack"
        if self.taut[frame]:
            phase = "taut (slowed down)" if self.slowed else "taut"
        canvas.text(
            [f"t = {self.t[frame]:+.3f} s, tether {phase}"], (10, canvas.size[1] - 32), TEXT_SIZE
        )


def _result_lines(out: np.ndarray) -> list[str | tuple[str, Colour]]:
    if not out[OUT.bounced]:
        return [("the tether never went taut", MISS)]
    speed = out[OUT.speed_ratio] * out[OUT.launch_speed]
    return [
        f"out: {math.degrees(out[OUT.deflection]):+.1f} deg, {speed:.2f} m/s, "
        f"spin {out[OUT.spin]:+.1f} rad/s",
        ("success", TARGET) if out[OUT.is_success] else ("miss", MISS),
    ]
