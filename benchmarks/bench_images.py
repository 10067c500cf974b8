"""The image path's quality and speed: detection errors, miss rate, paper success, time.

Run from the repository root (needs the ``images`` extra)::

    python benchmarks/bench_images.py                 # everything, paper runs at the paper's counts
    python benchmarks/bench_images.py --runs 30       # fewer paper runs per experiment
    python benchmarks/bench_images.py --only errors   # one section: errors, refinement, misses,
                                                      # speed, calibration, paper

Sections (Markdown tables on stdout):

* ``errors``: detection error against the truth (position in pixels, heading in degrees: mean,
  sd, 95th percentile) on ``paper-angular`` with 20 robots at random poses, at the default
  resolution (5 pixels per marker cell) and at twice it, untilted and with 10 degrees of tilt,
  on clean images and on images with sensor noise (sd 4 grey levels) and blur (sd 0.7 pixel).
* ``refinement``: the same error with each ArUco corner refinement (noisy images), which is why
  the detector uses ``CORNER_REFINE_SUBPIX`` with a window of half a marker cell.
* ``misses``: miss rate against the marker's side in pixels (noisy images).
* ``calibration``: homography fitted from 3 robots driving across the arena, against the truth.
* ``speed``: time per picture of render plus detection for N in {2, 10, 100} (the geometric
  camera's ``take`` as the peer), and the env's steps/s with the image source against the
  geometric one (ratios in the same process; medians of repeated blocks).
* ``paper``: success of the corrected baselines and of ``bayes`` on the three paper presets, image
  path beside the geometric path, with 95 % Wilson intervals (``baselines.paper.run``).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import anonloc_env
from anonloc_env.camera import Camera
from anonloc_env.images import ImageCamera, MarkerDetector, calibrate, sample_errors
from anonloc_env.images.frame import AUTO_CELL_PIXELS
from anonloc_env.images.marker import MARKER_CELLS, cell_size
from anonloc_env.world import random_poses

NOISY = {"image_noise": 4.0, "image_blur": 0.7}


def _table(headers: list[str], rows: list[list[str]]) -> None:
    print("| " + " | ".join(headers) + " |")
    print("|" + "---|" * len(headers))
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print()


def _stats(x: np.ndarray) -> str:
    return f"{x.mean():.3f} / {x.std():.3f} / {np.percentile(x, 95):.3f}"


def _config(cell_pixels: float, tilt: float, **camera: Any) -> anonloc_env.EnvConfig:
    base = anonloc_env.make_config("paper-angular", n_robots=20)
    ppu = cell_pixels / (cell_size(base.robot) * base.camera.scale)
    return anonloc_env.make_config(
        "paper-angular",
        n_robots=20,
        camera={"source": "image", "tilt_deg": tilt, "image_pixels_per_unit": ppu, **camera},
    )


def errors(pictures: int) -> None:
    print("## Detection error (paper-angular, 20 robots, random poses)\n")
    rows = []
    for noise in ({}, NOISY):
        for cell in (AUTO_CELL_PIXELS, 2 * AUTO_CELL_PIXELS):
            for tilt in (0.0, 10.0):
                config = _config(cell, tilt, **noise)
                ppu = config.camera.image_pixels_per_unit
                assert ppu is not None
                s = sample_errors(config, pictures, seed=1)
                rows.append(
                    [
                        "noisy" if noise else "clean",
                        f"{MARKER_CELLS * cell:.0f}",
                        f"{tilt:g}",
                        _stats(s.position * ppu),
                        _stats(np.degrees(np.abs(s.dtheta))),
                        f"{100 * s.miss_rate:.2f}",
                        str(len(s.du)),
                    ]
                )
    _table(
        [
            "image",
            "marker (px)",
            "tilt (deg)",
            "position error (px): mean / sd / p95",
            "heading error (deg): mean / sd / p95",
            "miss %",
            "detections",
        ],
        rows,
    )
    print("The paper's ARToolKit heading error: 1.6 / 1.1 deg (mean / sd).\n")


def refinement(pictures: int) -> None:
    print("## Corner refinement (noisy images, 30-pixel markers, tilt 4.24 deg)\n")
    config = _config(AUTO_CELL_PIXELS, 4.24, **NOISY)
    ppu = config.camera.image_pixels_per_unit
    assert ppu is not None
    rows = []
    choices: list[tuple[str, int | None]] = [
        ("none", None),
        ("subpix", 1),
        ("subpix", 2),
        ("subpix", 3),
        ("subpix", 5),
        ("contour", None),
        ("apriltag", None),
    ]
    for method, window in choices:
        original = MarkerDetector.__init__

        def patched(self: Any, frame: Any, cell: float, *_: Any, **__: Any) -> None:
            original(self, frame, cell, method, window)  # noqa: B023 - used inside the loop

        MarkerDetector.__init__ = patched  # type: ignore[method-assign]  # benchmark-only swap
        try:
            start = time.perf_counter()
            s = sample_errors(config, pictures, seed=1)
            seconds = (time.perf_counter() - start) / pictures
        finally:
            MarkerDetector.__init__ = original  # type: ignore[method-assign]
        label = method if window is None else f"{method}, window {window}"
        rows.append(
            [
                label,
                _stats(s.position * ppu),
                _stats(np.degrees(np.abs(s.dtheta))),
                f"{100 * s.miss_rate:.2f}",
                f"{1000 * seconds:.1f}",
            ]
        )
    _table(
        ["refinement", "position (px)", "heading (deg)", "miss %", "ms per picture (20 robots)"],
        rows,
    )


def misses(pictures: int) -> None:
    print("## Miss rate against marker size (noisy images, tilt 4.24 deg, 20 robots)\n")
    rows = []
    for cell in (1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 8.0):
        s = sample_errors(_config(cell, 4.24, **NOISY), pictures, seed=2)
        ppu = _config(cell, 4.24).camera.image_pixels_per_unit
        assert ppu is not None
        pos = _stats(s.position * ppu) if len(s.du) else "n/a"
        rows.append([f"{MARKER_CELLS * cell:.0f}", f"{100 * s.miss_rate:.1f}", pos])
    _table(["marker side (px)", "miss %", "position error (px): mean / sd / p95"], rows)


def calibration() -> None:
    print("## Calibration: 3 robots driving across the arena, 20 pictures\n")
    rows = []
    for tilt in (4.24, 10.0):
        config = anonloc_env.make_config("paper-angular", camera={"tilt_deg": tilt})
        r = calibrate(config, robots=3, pictures=20)
        (lo, hi), (tlo, thi) = r.scale_u_range
        rows.append(
            [
                f"{tilt:g}",
                str(r.points),
                f"{r.scale[0]:.3f} ({r.scale[1]:.3f})",
                f"{lo:.2f} to {hi:.2f} ({tlo:.2f} to {thi:.2f})",
                f"{r.perspective[0]:.5f} ({r.perspective[1]:.5f})",
                f"{r.tilt_deg[0]:.2f} ({r.tilt_deg[1]:.2f})",
                f"{r.fit_rms:.4f}",
                f"{r.grid_error:.4f}",
            ]
        )
    _table(
        [
            "tilt (deg)",
            "points",
            "scale at centre (true)",
            "scale along u (true)",
            "sin(tilt)/height (true)",
            "tilt from scales (true)",
            "fit rms (units)",
            "max grid error (units)",
        ],
        rows,
    )


def _median_time(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def speed(repeats: int) -> None:
    print("## Time per picture (default preset's camera and robots, N robots)\n")
    rows = []
    for n in (2, 10, 100):
        config = anonloc_env.make_config("default", n_robots=n, camera={"source": "image"})
        camera = Camera(config)
        source = ImageCamera(config, camera)
        rng = np.random.default_rng(0)
        poses = random_poses(config, rng)
        image = source.renderer.render(poses, rng)
        render = _median_time(lambda: source.renderer.render(poses, rng), repeats)  # noqa: B023
        detect = _median_time(lambda: source.detector.detect(image), repeats)  # noqa: B023
        geometric = _median_time(lambda: camera.take(poses, rng, 0.0, 0), repeats)  # noqa: B023
        rows.append(
            [
                str(n),
                f"{source.frame.width} x {source.frame.height}",
                f"{1000 * render:.2f}",
                f"{1000 * detect:.2f}",
                f"{1000 * (render + detect):.2f}",
                f"{(render + detect) / geometric:.0f}x",
            ]
        )
    _table(
        ["N", "image (px)", "render (ms)", "detect (ms)", "total (ms)", "vs geometric take"],
        rows,
    )
    print("## Env steps/s, image source against geometric (random actions)\n")
    rows = []
    for preset, steps in (("default", 400), ("paper-angular", 4000)):
        rates = {}
        for source_name in ("geometric", "image"):
            env = anonloc_env.parallel_env(
                preset, camera={"source": source_name}, reward_fn=anonloc_env.EnergyCost()
            )
            env.reset(seed=0)
            rng = np.random.default_rng(0)
            actions = rng.uniform(-1, 1, (steps, env.config.n_robots, 2)).astype(np.float32)
            blocks = []
            for _ in range(3):
                env.reset(seed=0)
                start = time.perf_counter()
                for k in range(min(steps, env.config.max_cycles)):
                    env.step(dict(zip(env.agents, actions[k], strict=True)))
                blocks.append(min(steps, env.config.max_cycles) / (time.perf_counter() - start))
            rates[source_name] = statistics.median(blocks)
        env = anonloc_env.parallel_env(preset)
        rows.append(
            [
                preset,
                f"{env.config.steps_per_picture:g}",
                f"{rates['geometric']:.0f}",
                f"{rates['image']:.0f}",
                f"{rates['image'] / rates['geometric']:.2f}",
            ]
        )
    _table(
        ["preset", "steps per picture", "geometric steps/s", "image steps/s", "image / geometric"],
        rows,
    )


def paper(runs: int | None) -> None:
    from baselines.paper import EXPERIMENTS, Rate, run

    print("## Paper presets: success per robot at its first decision (95 % Wilson intervals)\n")
    rows = []
    for method, experiment in EXPERIMENTS.items():
        count = experiment.runs if runs is None else runs
        for label, overrides in (("geometric", None), ("image", {"camera": {"source": "image"}})):
            outcomes = [run(method, seed, overrides) for seed in range(count)]

            def rate(field: str, outcomes: list[Any] = outcomes) -> Rate:
                flat = [x for o in outcomes for x in getattr(o, field)]
                return Rate(sum(flat), len(flat))

            rows.append(
                [
                    method,
                    label,
                    str(count),
                    str(rate("corrected")),
                    str(rate("bayes_first")),
                    str(rate("bayes_at_4th")),
                ]
            )
    _table(
        ["experiment", "camera", "runs", "corrected", "bayes (first decision)", "bayes at 4th"],
        rows,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default=None, help="one section")
    parser.add_argument("--runs", type=int, default=None, help="paper runs per experiment")
    parser.add_argument("--pictures", type=int, default=20, help="pictures per error figure")
    args = parser.parse_args()
    sections: dict[str, Callable[[], None]] = {
        "errors": lambda: errors(args.pictures),
        "refinement": lambda: refinement(args.pictures),
        "misses": lambda: misses(args.pictures),
        "calibration": calibration,
        "speed": lambda: speed(15),
        "paper": lambda: paper(args.runs),
    }
    for name, section in sections.items():
        if args.only in (None, name):
            start = time.perf_counter()
            section()
            print(f"_{name}: {time.perf_counter() - start:.0f} s_\n")


if __name__ == "__main__":
    main()
