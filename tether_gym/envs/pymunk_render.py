"""Drawing a `TetherWorld` with pygame through pymunk's own drawing helper.

The picture is the launch frame seen from above, +x to the right and +y up (the puck launched
upwards), as the environment's frames: pymunk's `DrawOptions` draws the puck and the walls onto
an off-screen surface, this module adds the anchor, the tether (red when taut, grey when slack,
gone once released) and the attachment point. pygame is imported lazily, and the window opens
only in "human" mode; set SDL_VIDEODRIVER=dummy to draw headless.
"""

from __future__ import annotations

import numpy as np

from tether_gym.physics.pymunk_world import TetherWorld

# The colours of the environment's own frames (`tether_gym.envs.rendering`).
BACKGROUND, PUCK, WALL = (250, 250, 245), (40, 90, 160), (90, 90, 90)
TAUT, SLACK, ANCHOR, ATTACHMENT = (200, 40, 40), (170, 170, 170), (30, 30, 30), (250, 200, 0)
RENDER_MODES = ("human", "rgb_array")


def default_view(world: TetherWorld) -> tuple[float, float, float, float]:
    """(x_min, x_max, y_min, y_max) shown by default: the table with a margin of one radius,
    else the square around the anchor that the tether and the puck can reach."""
    if world.table is not None:
        t, margin = world.table, world.radius
        return t.x_min - margin, t.x_max + margin, t.y_min - margin, t.y_max + margin
    reach = world.tether_length + 2.0 * world.radius
    ax, ay = world.anchor
    return ax - reach, ax + reach, ay - reach, ay + reach


class WorldRenderer:
    """Draws a world as an (H, W, 3) uint8 array ("rgb_array") or in a window ("human")."""

    def __init__(
        self,
        render_mode: str = "rgb_array",
        *,
        size: tuple[int, int] = (480, 480),
        view: tuple[float, float, float, float] | None = None,
        fps: int = 50,
    ) -> None:
        if render_mode not in RENDER_MODES:
            raise ValueError(f"render_mode must be one of {RENDER_MODES}, got {render_mode!r}")
        if len(size) != 2 or min(size) < 1:
            raise ValueError(f"size must be two positive pixel counts (width, height), got {size}")
        self.render_mode, self.size, self.view, self.fps = render_mode, tuple(size), view, fps
        self.window = None
        self.clock = None

    def _draw(self, world: TetherWorld):
        """The world drawn on a new surface, +y up."""
        import pygame
        import pymunk
        import pymunk.pygame_util

        width, height = self.size
        x_min, x_max, y_min, y_max = self.view or default_view(world)
        scale = min(width / (x_max - x_min), height / (y_max - y_min))
        # Centre the view; draw with +y down on the surface, then flip it so that +y is up
        # (pymunk draws each circle's angle mark unflipped, so the flip must come last).
        tx = 0.5 * width - scale * 0.5 * (x_min + x_max)
        ty = 0.5 * height - scale * 0.5 * (y_min + y_max)
        surface = pygame.Surface(self.size)
        surface.fill(BACKGROUND)
        options = pymunk.pygame_util.DrawOptions(surface)
        options.transform = pymunk.Transform(a=scale, b=0.0, c=0.0, d=scale, tx=tx, ty=ty)
        options.flags = pymunk.SpaceDebugDrawOptions.DRAW_SHAPES
        world.shape.color = (*PUCK, 255)  # pymunk's drawing reads a shape's `color`
        for wall in world.walls:
            wall.color = (*WALL, 255)
        world.space.debug_draw(options)

        def pixel(x: float, y: float) -> tuple[int, int]:
            return round(scale * x + tx), round(scale * y + ty)

        anchor, attachment = pixel(*world.anchor), pixel(*world.attachment)
        dot = max(2, round(0.08 * scale * world.radius))
        if world.attached:
            color = TAUT if world.taut else SLACK
            pygame.draw.line(surface, color, anchor, attachment, max(1, dot // 2))
        pygame.draw.circle(surface, ANCHOR, anchor, dot)
        pygame.draw.circle(surface, ATTACHMENT, attachment, dot)
        return pygame.transform.flip(surface, False, True)

    def render(self, world: TetherWorld) -> np.ndarray | None:
        """The frame as an (H, W, 3) uint8 array in "rgb_array" mode; shown in "human" mode."""
        import pygame

        surface = self._draw(world)
        if self.render_mode == "rgb_array":
            return np.transpose(pygame.surfarray.array3d(surface), (1, 0, 2)).copy()
        if self.window is None:
            pygame.display.init()
            pygame.display.set_caption("tether_gym: pymunk world")
            self.window = pygame.display.set_mode(self.size)
            self.clock = pygame.time.Clock()
        pygame.event.pump()
        self.window.blit(surface, (0, 0))
        pygame.display.flip()
        self.clock.tick(self.fps)
        return None

    def close(self) -> None:
        """Close the window, if one was opened."""
        if self.window is not None:
            import pygame

            pygame.display.quit()
            self.window = None


def render_rgb(
    world: TetherWorld,
    *,
    size: tuple[int, int] = (480, 480),
    view: tuple[float, float, float, float] | None = None,
) -> np.ndarray:
    """One frame of the world as an (H, W, 3) uint8 array."""
    return WorldRenderer("rgb_array", size=size, view=view).render(world)
