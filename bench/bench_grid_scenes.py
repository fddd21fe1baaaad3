"""Benchmark of the grid-scene renderer (`oxbot.perception.grid_scenes`): time per scene on one
core, and what the scenes hold.

    .venv/bin/python bench/bench_grid_scenes.py                  # 500 scenes, 256x256, seed 0
    .venv/bin/python bench/bench_grid_scenes.py --scenes 2000 --size 320x240
    .venv/bin/python bench/bench_grid_scenes.py --preview reports/grid_scenes_preview.png

Renders `--scenes` scenes one after another with OpenCV held to one thread (as in a data
loader's worker) and prints the median, 90th percentile and longest time per scene, wall clock
and the process's CPU; then the share of scenes without a grid, the paper kinds' shares, and
the share of present scenes whose grid lies partly out of the frame. `--preview` also writes
`save_preview`'s mosaic of 16 scenes. Not a test: tests/perception/test_grid_scenes.py checks
the scenes' truth on a few dozen.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import Counter

import cv2
import numpy as np

from oxbot.perception.grid_scenes import random_grid_scene, save_preview


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=500, help="scenes to render")
    parser.add_argument("--size", default="256x256", help="WIDTHxHEIGHT of each scene")
    parser.add_argument("--seed", type=int, default=0, help="the generator's seed")
    parser.add_argument("--preview", default=None, help="also write a 16-scene PNG mosaic here")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    cv2.setNumThreads(1)
    rng = np.random.default_rng(args.seed)
    random_grid_scene(rng, (width, height))  # imports and first calls out of the timing
    wall, cpu = [], []
    kinds: Counter[str] = Counter()
    absent = cut = 0
    for _ in range(args.scenes):
        started, started_cpu = time.perf_counter(), time.process_time()
        scene = random_grid_scene(rng, (width, height))
        wall.append((time.perf_counter() - started) * 1000)
        cpu.append((time.process_time() - started_cpu) * 1000)
        kinds[scene.kind] += 1
        if not scene.present:
            absent += 1
        elif (scene.lattice < 0).any() or (scene.lattice > (width - 1, height - 1)).any():
            cut += 1
    n = args.scenes
    print(f"{n} scenes of {width}x{height}, seed {args.seed}, one OpenCV thread")
    for name, times in (("wall", wall), ("cpu", cpu)):
        p90 = float(np.percentile(times, 90))
        print(
            f"  {name}: median {statistics.median(times):.1f} ms, p90 {p90:.1f} ms, "
            f"max {max(times):.1f} ms per scene"
        )
    print(f"  no grid: {absent / n:.1%}; grid partly out of the frame: {cut / (n - absent):.1%}")
    print("  paper: " + ", ".join(f"{k} {v / n:.1%}" for k, v in kinds.most_common()))
    if args.preview:
        print(f"  preview: {save_preview(args.preview, args.seed)}")


if __name__ == "__main__":
    main()
