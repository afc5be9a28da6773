"""Frames of a TetherBounce episode, drawn with pygame (imported here, only when rendering).

The view is the launch frame centred on the puck at tautening, +y up. After `reset` it shows
the incoming puck and the target (an arrow for a heading or a velocity, a ring for the
deadspin); after `step` also the anchor, the taut tether at the bounce, the outgoing path and
the puck a moment later on its slack tether.
"""

from __future__ import annotations

import math

import numpy as np

from tether_gym.envs.tether_bounce.kernel import OUT, PUCK_RADIUS, TETHER_LENGTH
from tether_gym.tasks.bounce import DEADSPIN

SIZE = 480
BACKGROUND, PATH, PUCK, MARK = (250, 250, 245), (120, 120, 120), (40, 90, 160), (250, 250, 250)
TAUT, SLACK, TARGET, ANCHOR = (200, 40, 40), (170, 170, 170), (40, 150, 60), (30, 30, 30)
SHOW_TIME = 0.3
"""Seconds of flight drawn before and after the bounce."""


class Renderer:
    """Draws frames for `TetherBounceEnv`; `render_mode` "rgb_array" or "human"."""

    def __init__(self, render_mode: str, fps: int):
        import pygame

        self._pygame = pygame
        self.render_mode, self.fps = render_mode, fps
        self.scale = SIZE / (2.6 * TETHER_LENGTH)  # pixels per metre
        self.surface = pygame.Surface((SIZE, SIZE))
        self.window = None
        self.clock = None

    def _px(self, point) -> tuple[int, int]:
        """World (launch frame, relative to the puck at tautening) to screen pixels."""
        return (round(SIZE / 2 + point[0] * self.scale), round(SIZE / 2 - point[1] * self.scale))

    def _puck(self, centre, orientation: float, attachment) -> None:
        draw, radius = self._pygame.draw, max(3, round(PUCK_RADIUS * self.scale))
        draw.circle(self.surface, PUCK, self._px(centre), radius)
        rim = centre + PUCK_RADIUS * np.array([math.cos(orientation), math.sin(orientation)])
        draw.line(self.surface, MARK, self._px(centre), self._px(rim), 2)
        if attachment is not None:
            draw.circle(self.surface, TAUT, self._px(attachment), 3)

    def _arrow(self, start, direction, length: float, colour) -> None:
        draw = self._pygame.draw
        end = start + length * direction
        draw.line(self.surface, colour, self._px(start), self._px(end), 3)
        for side in (2.6, -2.6):
            c, s = math.cos(side), math.sin(side)
            tip = end + 0.08 * np.array([c * direction[0] - s * direction[1],
                                         s * direction[0] + c * direction[1]])  # fmt: skip
            draw.line(self.surface, colour, self._px(end), self._px(tip), 3)

    def render(self, state: np.void | None, outcome: np.ndarray | None):
        """A frame of the episode `state` (None before the first reset), after the step whose
        outcome row is `outcome` (None before it)."""
        pygame = self._pygame
        self.surface.fill(BACKGROUND)
        origin = np.zeros(2)
        incoming = np.array([0.0, 1.0])
        if state is not None:
            if state["task"] == DEADSPIN:
                pygame.draw.circle(self.surface, TARGET, self._px(origin), 14, 3)
            else:
                heading = state["target_heading"]
                direction = np.array([-math.sin(heading), math.cos(heading)])
                self._arrow(origin, direction, 0.9, TARGET)
        if outcome is None:
            pygame.draw.line(self.surface, PATH, self._px(-incoming), self._px(origin), 2)
            self._puck(origin, math.pi / 2, None)
        else:
            self._bounce(outcome, origin, incoming)
        if self.render_mode == "human":
            self._show()
            return None
        return np.transpose(np.array(pygame.surfarray.pixels3d(self.surface)), axes=(1, 0, 2))

    def _bounce(self, outcome: np.ndarray, origin, incoming) -> None:
        """Anchor, taut tether, incoming and outgoing paths, and the puck after the bounce."""
        draw = self._pygame.draw
        speed = outcome[OUT.launch_speed]
        beta, alpha = outcome[OUT.tether_angle], outcome[OUT.offset_angle]
        arm = outcome[OUT.offset] * PUCK_RADIUS
        u = np.array([math.cos(beta), math.sin(beta)])
        r = -arm * np.array([math.cos(beta + alpha), math.sin(beta + alpha)])
        anchor = r - TETHER_LENGTH * u  # relative to the centre of mass at tautening
        velocity = np.array([outcome[OUT.vx], outcome[OUT.vy]])
        draw.line(self.surface, PATH, self._px(-SHOW_TIME * speed * incoming),
                  self._px(origin), 2)  # fmt: skip
        after = SHOW_TIME * velocity
        draw.line(self.surface, PATH, self._px(origin), self._px(after), 2)
        draw.circle(self.surface, ANCHOR, self._px(anchor), 5)
        if outcome[OUT.bounced]:
            draw.line(self.surface, TAUT, self._px(anchor), self._px(r), 3)
        turn = SHOW_TIME * outcome[OUT.spin]
        r_after = np.array([r[0] * math.cos(turn) - r[1] * math.sin(turn),
                            r[0] * math.sin(turn) + r[1] * math.cos(turn)])  # fmt: skip
        draw.line(self.surface, SLACK, self._px(anchor), self._px(after + r_after), 1)
        self._puck(origin, math.atan2(r[1], r[0]), r)
        self._puck(after, math.atan2(r_after[1], r_after[0]), after + r_after)

    def _show(self) -> None:
        pygame = self._pygame
        if self.window is None:
            pygame.init()
            pygame.display.init()
            self.window = pygame.display.set_mode((SIZE, SIZE))
            pygame.display.set_caption("TetherBounce-v0")
            self.clock = pygame.time.Clock()
        self.window.blit(self.surface, (0, 0))
        pygame.event.pump()
        pygame.display.flip()
        self.clock.tick(self.fps)

    def close(self) -> None:
        if self.window is not None:
            self._pygame.display.quit()
            self._pygame.quit()
            self.window = None
