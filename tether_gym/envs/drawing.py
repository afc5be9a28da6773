"""The envs' drawing layer: a canvas in world coordinates, a window, render modes over scenes.

No physics here, and no env: an env's renderer (a `SceneRenderer` subclass) turns what it is
given, e.g. a state and the last step's outcome, into a `Scene`, a short sequence of frames
that draw themselves on a `Canvas` (metres, +y up, mapped to pixels). `SceneRenderer` then
serves Gymnasium's render modes from those scenes, the same way for every env:

- "rgb_array": the latest frame (the end of the latest scene), one (H, W, 3) uint8 array;
- "rgb_array_list": every frame of the scenes since the last `render` call, as a list;
- "human": those frames played in a window at the env's `render_fps`, in real time.

A step that lasts a physical time (a bounce, a maneuver) is thus one scene of many frames.
pygame is imported when a `Canvas` or a `Window` is made, never at module import: rendering is
optional at run time. Set SDL_VIDEODRIVER=dummy to open the "human" window headless.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Protocol

import numpy as np

Colour = tuple[int, int, int]

BACKGROUND: Colour = (250, 250, 245)
PATH: Colour = (150, 150, 150)
PUCK: Colour = (40, 90, 160)
MARK: Colour = (250, 250, 250)
ATTACHMENT: Colour = (250, 200, 0)
TAUT: Colour = (200, 40, 40)
SLACK: Colour = (170, 170, 170)
ANCHOR: Colour = (30, 30, 30)
POST: Colour = (110, 110, 110)
TARGET: Colour = (40, 150, 60)
GOAL_FILL: Colour = (205, 235, 205)
TEXT: Colour = (40, 40, 40)
MISS: Colour = (215, 95, 0)
VELOCITY: Colour = (60, 130, 230)
RENDER_MODES = ("human", "rgb_array", "rgb_array_list")
FONT_SCALE = 0.65
"""A text size in pixels is drawn in DejaVu Sans Bold at this many points per pixel: about the
height of pygame's own default font at that size."""


def font_file() -> str | None:
    """DejaVu Sans Bold, the font matplotlib ships (a dependency), or None for pygame's own.

    pygame's own font (FreeSans Bold) spaces some letter pairs apart ("maneu ver")."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.find_spec("matplotlib")
    if spec is None or spec.origin is None:
        return None
    path = Path(spec.origin).parent / "mpl-data" / "fonts" / "ttf" / "DejaVuSans-Bold.ttf"
    return str(path) if path.is_file() else None


class Canvas:
    """An off-screen picture of a square-pixel view of the plane: world points (metres, +y up)
    to pixels, and the shapes the tether envs are made of.

    `extent` metres span the smaller side of `size` (width, height) pixels; `look_at` moves the
    view's centre. Shapes take world points (any 2-sequence) and world lengths; line widths and
    text sizes are in pixels.
    """

    def __init__(self, size: tuple[int, int] = (480, 480), extent: float = 1.0) -> None:
        import pygame
        from pygame import gfxdraw

        if len(size) != 2 or min(size) < 1 or not extent > 0.0:
            raise ValueError(f"need a positive size and extent, got {size}, {extent}")
        self._pygame, self._gfx = pygame, gfxdraw
        self.size = (int(size[0]), int(size[1]))
        self.scale = min(self.size) / extent
        """Pixels per metre."""
        self.surface = pygame.Surface(self.size)
        self.centre = np.zeros(2)
        self._fonts: dict[int, object] = {}

    def look_at(self, centre) -> None:
        """Centre the view on the world point `centre`."""
        self.centre = np.asarray(centre, dtype=float).copy()

    def px(self, point) -> tuple[int, int]:
        """The pixel of a world point (+y up on screen)."""
        width, height = self.size
        return (
            round(0.5 * width + (point[0] - self.centre[0]) * self.scale),
            round(0.5 * height - (point[1] - self.centre[1]) * self.scale),
        )

    def pixels(self, length: float, least: int = 1) -> int:
        """A world length in pixels, at least `least`."""
        return max(least, round(length * self.scale))

    def clear(self, colour: Colour = BACKGROUND) -> None:
        self.surface.fill(colour)

    def line(self, start, end, colour: Colour, width: int = 1) -> None:
        if width == 1:
            self._pygame.draw.aaline(self.surface, colour, self.px(start), self.px(end))
        else:
            self._pygame.draw.line(self.surface, colour, self.px(start), self.px(end), width)

    def path(self, points: Sequence, colour: Colour = PATH, width: int = 2) -> None:
        """A polyline through world points (a path unrolled up to an instant: pass its head)."""
        pixels = [self.px(p) for p in points]
        if len(pixels) >= 2:
            self._pygame.draw.lines(self.surface, colour, False, pixels, width)

    def dashed(self, start, end, colour: Colour = PATH, dash: float = 0.05) -> None:
        """A dashed line, `dash` metres on and off: a path to come."""
        start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
        n = max(1, int(np.linalg.norm(end - start) / dash))
        for k in range(0, n, 2):
            self.line(start + (end - start) * k / n, start + (end - start) * (k + 1) / n, colour)

    def disc(self, centre, radius: float, colour: Colour, least: int = 2) -> None:
        """A filled, anti-aliased disc of world radius `radius` (at least `least` pixels)."""
        x, y = self.px(centre)
        r = self.pixels(radius, least)
        self._gfx.filled_circle(self.surface, x, y, r, colour)
        self._gfx.aacircle(self.surface, x, y, r, colour)

    def ring(self, centre, radius: float, colour: Colour, width: int = 2) -> None:
        """A circle's outline, `width` pixels thick."""
        self._pygame.draw.circle(self.surface, colour, self.px(centre), self.pixels(radius), width)

    def puck(self, centre, radius: float, orientation: float, attachment=None) -> None:
        """A puck: a disc, its orientation mark (a radius along the body angle `orientation`)
        and, if given, the tether's attachment point."""
        centre = np.asarray(centre, dtype=float)
        self.disc(centre, radius, PUCK)
        rim = centre + radius * np.array([math.cos(orientation), math.sin(orientation)])
        self.line(centre, rim, MARK, 2)
        if attachment is not None:
            self.disc(attachment, 0.18 * radius, ATTACHMENT, least=2)

    def tether(self, anchor, attachment, taut: bool) -> None:
        """The tether: red and thick when taut, grey and thin when slack."""
        self.line(anchor, attachment, TAUT if taut else SLACK, 4 if taut else 1)

    def anchor(self, point, colour: Colour = ANCHOR) -> None:
        """A tether's anchor, or a peg: a small dark disc with a light centre."""
        self.disc(point, 0.0, colour, least=5)
        self.disc(point, 0.0, BACKGROUND, least=2)

    def post(self, centre, radius: float) -> None:
        """An obstacle post of world radius `radius`."""
        self.disc(centre, radius, POST)

    def wall(self, start, end, width: int = 4) -> None:
        self.line(start, end, POST, width)

    def goal(self, centre, radius: float) -> None:
        """A goal disc: light fill, green rim."""
        self.disc(centre, radius, GOAL_FILL)
        self.ring(centre, radius, TARGET, 2)

    def arrow(self, start, vector, colour: Colour = TARGET, width: int = 3) -> None:
        """An arrow from `start` along the world vector `vector`, its head 12 pixels long."""
        start = np.asarray(start, dtype=float)
        end = start + np.asarray(vector, dtype=float)
        self.line(start, end, colour, width)
        norm = float(np.hypot(*vector))
        if norm == 0.0:
            return
        back = -np.asarray(vector, dtype=float) / norm * (12.0 / self.scale)
        for side in (0.45, -0.45):
            c, s = math.cos(side), math.sin(side)
            tip = end + np.array([c * back[0] - s * back[1], s * back[0] + c * back[1]])
            self.line(end, tip, colour, width)

    def text(
        self, lines: Iterable[str | tuple[str, Colour]], at: tuple[int, int], size: int = 20
    ) -> None:
        """Lines of text from the pixel `at` (top left) down; a line may carry its colour."""
        pygame = self._pygame
        if not pygame.font.get_init():  # also after another's pygame.quit()
            pygame.font.init()
            self._fonts.clear()
        if size not in self._fonts:
            file = font_file()
            points = size if file is None else round(FONT_SCALE * size)
            self._fonts[size] = pygame.font.Font(file, points)
        font = self._fonts[size]
        x, y = at
        for line in lines:
            words, colour = line if isinstance(line, tuple) else (line, TEXT)
            self.surface.blit(font.render(words, True, colour), (x, y))
            y += font.get_linesize()

    def rgb(self) -> np.ndarray:
        """The picture as an (H, W, 3) uint8 array (a copy)."""
        pixels = self._pygame.surfarray.pixels3d(self.surface)
        return np.transpose(np.array(pixels), axes=(1, 0, 2))


class Window:
    """A "human" window showing a canvas at `fps` frames per second, the clock keeping time."""

    def __init__(self, title: str, fps: float) -> None:
        import pygame

        self._pygame, self.title, self.fps = pygame, title, fps
        self.screen = None
        self.clock = None

    def show(self, canvas: Canvas) -> None:
        """Show the canvas, then wait out the rest of the frame's 1 / fps seconds."""
        pygame = self._pygame
        if self.screen is None:
            pygame.display.init()
            self.screen = pygame.display.set_mode(canvas.size)
            pygame.display.set_caption(self.title)
            self.clock = pygame.time.Clock()
        self.screen.blit(canvas.surface, (0, 0))
        pygame.event.pump()
        pygame.display.flip()
        self.clock.tick(self.fps)

    def close(self) -> None:
        if self.screen is not None:
            self._pygame.display.quit()
            self.screen = None


class Scene(Protocol):
    """A change of the env's picture over time: `len(scene)` frames, drawn one at a time."""

    def __len__(self) -> int: ...

    def draw(self, canvas: Canvas, frame: int) -> None:
        """Draw frame `frame` (0 <= frame < len) on the whole canvas."""


class Still:
    """A scene of one frame, drawn by `paint(canvas)`."""

    def __init__(self, paint: Callable[[Canvas], None]) -> None:
        self.paint = paint

    def __len__(self) -> int:
        return 1

    def draw(self, canvas: Canvas, frame: int) -> None:
        self.paint(canvas)


class SceneRenderer:
    """Gymnasium's render modes over an env's scenes (see the module's docstring).

    Subclasses implement `scene(*args)`; the env hands `render` the arguments of the scenes
    since its last render call and those of its latest state.
    """

    def __init__(self, render_mode: str, fps: float, title: str, canvas: Canvas) -> None:
        if render_mode not in RENDER_MODES:
            raise ValueError(f"render_mode must be one of {RENDER_MODES}, got {render_mode!r}")
        self.render_mode, self.fps, self.canvas = render_mode, fps, canvas
        self.window = Window(title, fps) if render_mode == "human" else None

    def scene(self, *args) -> Scene:
        """The scene that leads to the state described by `args` (the env's own)."""
        raise NotImplementedError

    def render(
        self, scenes: Sequence[tuple], latest: tuple
    ) -> np.ndarray | list[np.ndarray] | None:
        """ "rgb_array": the last frame of `scene(*latest)`; "rgb_array_list": every frame of
        `scenes`; "human": those frames played in the window (the latest frame if none)."""
        if self.render_mode == "rgb_array":
            return self._draw_last(latest)
        if self.render_mode == "rgb_array_list":
            return [self.canvas.rgb() for _ in self._play(scenes)]
        for _ in self._play(scenes):
            self.window.show(self.canvas)
        if not scenes:
            self._draw_last(latest)
            self.window.show(self.canvas)
        return None

    def _play(self, scenes: Sequence[tuple]) -> Iterator[None]:
        """Draw the frames of `scenes` one after the other, yielding after each."""
        for args in scenes:
            scene = self.scene(*args)
            for i in range(len(scene)):
                scene.draw(self.canvas, i)
                yield

    def _draw_last(self, args: tuple) -> np.ndarray:
        scene = self.scene(*args)
        scene.draw(self.canvas, len(scene) - 1)
        return self.canvas.rgb()

    def close(self) -> None:
        if self.window is not None:
            self.window.close()
