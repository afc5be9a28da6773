"""Animations of an agent's episodes: an animated GIF, or videos through `RecordVideo`.

    python -m tether_gym.agents.record --agent oracle --episodes 3 \\
        --out docs/figures/tether_bounce.gif
    python -m tether_gym.agents.record --env TetherNavigate-v3 --agent random --episodes 2 \\
        --out docs/figures/tether_navigate_random.gif

An env whose step lasts a physical time (TetherBounce-v0's bounce, TetherNavigate-v3's
maneuver) draws each step as many frames: its `"rgb_array_list"` render mode returns them (see
`tether_gym.envs.drawing`). The GIF is those frames, downscaled to `--size` pixels across and
played at `--fps` (the env draws at that rate too); existing files are kept unless
`--overwrite`. The agent is any that `agents.registry.make_agent` builds, by name or as the
path of a saved SB3 model zip.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import numpy as np

from tether_gym.agents.registry import make_agent
from tether_gym.arguments import ArgumentParser, add_env_arguments, chosen_env, env_from_args

GIF_COLOURS = 128
"""The GIF's one palette: the drawing's few colours and their anti-aliased blends."""


class RecordVideo(gym.wrappers.RecordVideo):
    """Gymnasium's `RecordVideo`, recording every frame of a `"*_list"` render mode.

    Gymnasium's own (1.x) records one frame per `reset` and `step`: given the list of frames a
    step drew, its `_capture_frame` keeps only the last one (the others go to the history that
    its `render()` returns), so a one-step episode makes a two-frame video. Here every frame
    of the list is recorded, and `render()` no longer returns them (they are consumed).
    """

    def _capture_frame(self) -> None:
        frames = self.env.render()
        self.recorded_frames += frames if isinstance(frames, list) else [frames]


def episode_frames(
    env_id: str, env_kwargs: dict, agent, episodes: int, seed: int = 0, fps: float | None = None
) -> list[np.ndarray]:
    """The frames of `episodes` episodes of `agent` on `env_id(**env_kwargs)`, the first reset
    with `seed`, drawn by the `"rgb_array_list"` render mode at `fps` (default the env's)."""
    if episodes < 1:
        raise ValueError(f"episodes must be an integer in [1, inf), got {episodes!r}")
    env = gym.make(env_id, render_mode="rgb_array_list", **env_kwargs)
    if fps is not None:
        env.unwrapped.metadata = {**env.unwrapped.metadata, "render_fps": fps}
    frames: list[np.ndarray] = []
    obs, _ = env.reset(seed=seed)
    for episode in range(episodes):
        if episode:
            obs, _ = env.reset()
        done = False
        while not done:
            action, _ = agent.predict(obs, deterministic=True)
            obs, _, terminated, truncated, _ = env.step(action)
            done = terminated or truncated
        frames += env.render()
    env.close()
    return frames


def write_gif(frames: list[np.ndarray], path: Path, fps: float, size: int) -> None:
    """An animated GIF of `frames` at `fps`, scaled to `size` pixels across, looping; one
    palette for all frames, taken from a sample of them, without dithering (flat colours)."""
    from PIL import Image

    images = [Image.fromarray(frame) for frame in frames]
    height = round(size * images[0].height / images[0].width)
    images = [image.resize((size, height), Image.Resampling.LANCZOS) for image in images]
    sample = images[:: max(1, len(images) // 16)]
    strip = Image.new("RGB", (size, height * len(sample)))
    for i, image in enumerate(sample):
        strip.paste(image, (0, i * height))
    palette = strip.quantize(GIF_COLOURS, method=Image.Quantize.MEDIANCUT)
    indexed = [image.quantize(palette=palette, dither=Image.Dither.NONE) for image in images]
    indexed[0].save(
        path, save_all=True, append_images=indexed[1:], duration=round(1000 / fps), loop=0
    )


def build_parser(env_id: str | None = None) -> argparse.ArgumentParser:
    parser = ArgumentParser(
        prog="python -m tether_gym.agents.record",
        description="Write an animated GIF of an agent's episodes.",
    )
    add = parser.add_argument
    add("--agent", default="oracle", help="an agent that tether_gym.agents.registry.make_agent "
        "knows (oracle and shooting: TetherBounce-v0's oracles; random) or a saved SB3 model "
        "zip (default oracle)")  # fmt: skip
    add("--episodes", type=int, default=3, help="episodes (default 3)")
    add("--seed", type=int, default=0, help="seed of the first reset (default 0)")
    add("--out", type=Path, required=True, metavar="GIF", help="the GIF to write")
    add("--size", type=int, default=640, help="pixels across (default 640)")
    add("--fps", type=int, default=20, help="frames per second, drawn and played (default 20)")
    add("--overwrite", action="store_true", help="replace an existing file")
    add_env_arguments(parser, env_id)
    return parser


def main(argv: list[str] | None = None) -> None:
    """`python -m tether_gym.agents.record`: print the GIF's path, frame count and size."""
    parser = build_parser(chosen_env(argv))
    args = parser.parse_args(argv)
    if args.out.exists() and not args.overwrite:
        parser.error(f"{args.out} exists; pass --overwrite to replace it")
    if args.size < 16 or args.fps < 1:
        parser.error(
            f"--size must be at least 16 and --fps at least 1, got {args.size}, {args.fps}"
        )
    try:
        env_id, env_kwargs = env_from_args(args)
        agent = make_agent(args.agent, env_kwargs, args.seed, env_id)
        frames = episode_frames(env_id, env_kwargs, agent, args.episodes, args.seed, args.fps)
    except (ValueError, ModuleNotFoundError) as error:
        parser.error(str(error))
    write_gif(frames, args.out, args.fps, args.size)
    print(f"{args.out}: {len(frames)} frames, {args.out.stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
