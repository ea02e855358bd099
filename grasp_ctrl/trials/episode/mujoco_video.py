"""Offscreen video of MuJoCo trials (``run --backend mujoco --record-video DIR``).

Frames are rendered with ``mujoco.Renderer``, which needs an OpenGL backend:
EGL (GPU or Mesa) or OSMesa (software), chosen by the ``MUJOCO_GL`` environment
variable before mujoco is imported. Without one, recording says so once and the
trials run on without video. Written as MP4 when imageio with ffmpeg is
installed, else as an animated GIF (Pillow).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.files.storage import safe_name
from grasp_ctrl.rigs.registry import REFERENCE_WORLD
from grasp_ctrl.sim.mujoco.world import MuJoCoParams, MuJoCoWorld

FPS = 15
WIDTH, HEIGHT = 320, 240


def choose_gl_backend() -> None:
    """Headless machines: ask MuJoCo for EGL unless the user chose a backend (call before importing mujoco)."""
    if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
        os.environ["MUJOCO_GL"] = "egl"


def open_renderer(model: Any, width: int = WIDTH, height: int = HEIGHT) -> tuple[Any, str | None]:
    """(renderer, None), or (None, why not) when no GL backend works."""
    import mujoco

    try:
        return mujoco.Renderer(model, height, width), None
    except Exception as exc:  # noqa: BLE001 - every GL failure means the same to the user
        gl = os.environ.get("MUJOCO_GL", "default (GLFW, needs a display)")
        return None, (
            f"no OpenGL backend for offscreen rendering (MUJOCO_GL={gl}: {type(exc).__name__}: {exc}); "
            "install EGL (libegl1) or OSMesa (libosmesa6) and set MUJOCO_GL=egl or MUJOCO_GL=osmesa"
        )


def scene_camera(world: MuJoCoWorld) -> Any:
    """A free camera looking at the object from the front-left, above the table."""
    import mujoco

    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = (0.0, 0.0, world.grasp_height_m + 0.03)
    cam.distance = 0.6
    cam.azimuth = 120.0
    cam.elevation = -20.0
    return cam


def write_video(frames: Sequence[np.ndarray], path: Path, fps: int = FPS) -> Path:
    """MP4 with imageio-ffmpeg, else GIF; returns the file written."""
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        import imageio.v2 as imageio

        out = path.with_suffix(".mp4")
        imageio.mimsave(out, list(frames), fps=fps)
        return out
    except Exception:  # noqa: BLE001 - no imageio or no ffmpeg: fall back to GIF
        from PIL import Image

        out = path.with_suffix(".gif")
        images = [Image.fromarray(f) for f in frames]
        images[0].save(out, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
        return out


class RecordingWorld(MuJoCoWorld):
    """A MuJoCoWorld that renders a frame every 1/FPS s and writes the video on ``close``."""

    _warned = False

    def __init__(
        self, hand: HandConfig, obj: ObjectProfile, seed: int, params: MuJoCoParams | None, path: Path
    ) -> None:
        super().__init__(hand, obj, seed, params)
        self.video_path = path
        self.frames: list[np.ndarray] = []
        self._every = max(1, int(round(1.0 / (FPS * self.dt))))
        self._ticks = 0
        self.renderer, why = open_renderer(self.model)
        if why and not RecordingWorld._warned:
            RecordingWorld._warned = True
            print(f"--record-video: {why}; running without video", file=sys.stderr, flush=True)
        self._camera = scene_camera(self)

    def step(self) -> None:
        super().step()
        self._ticks += 1
        if self.renderer is not None and self._ticks % self._every == 0:
            self.renderer.update_scene(self.data, camera=self._camera)
            self.frames.append(self.renderer.render().copy())

    def close(self) -> Path | None:
        if self.renderer is None:
            return None
        self.renderer.close()
        self.renderer = None
        return write_video(self.frames, self.video_path) if self.frames else None


def video_trial_fn(
    hand: HandConfig,
    policies: Sequence[str],
    settings: PaperSettings | None,
    threads: int,
    video_dir: Path,
    variation: Any = None,
    raw_frames: bool = False,
) -> Any:
    """The mujoco trial runner with each trial recorded to VIDEO_DIR/POLICY-OBJECT-TRIAL.(mp4|gif);
    ``variation``: the world's per-trial draws (sim/variation.py; None: nominal); ``raw_frames``:
    the tick logs keep each fingertip's whole raw frame (run --raw-frames)."""
    choose_gl_backend()
    from grasp_ctrl.sim.mujoco.backends import mujoco_backends
    from grasp_ctrl.trials.episode.runner import sim_trial_fn

    current: dict[str, Path] = {}

    def make_world(hand: HandConfig, obj: ObjectProfile, seed: int, params: Any) -> RecordingWorld:
        return RecordingWorld(hand, obj, seed, params, current["path"])

    inner = sim_trial_fn(
        hand,
        policies,
        settings,
        threads,
        make_backends=mujoco_backends,
        backend=REFERENCE_WORLD,
        make_world=make_world,
        variation=variation,
        raw_frames=raw_frames,
    )

    def run(policy: str, obj: ObjectProfile, trial: int, seed: int, log_path: Path | None) -> dict[str, Any]:
        current["path"] = video_dir / f"{safe_name(policy)}-{obj.name}-{trial}"
        return inner(policy, obj, trial, seed, log_path)

    return run
