"""Benchmark of reading the board: time per frame on one core, and how often all 9 are right.

    .venv/bin/python bench/bench_board.py                  # 200 held-out photos, 5 repeats
    .venv/bin/python bench/bench_board.py --photos 50 --repeats 3 --style tuning
    .venv/bin/python bench/bench_board.py --style tuning-camera     # harder tuning, seed 7000
    .venv/bin/python bench/bench_board.py --model runs/perceiver.pt
    .venv/bin/python bench/bench_board.py --set perception.wholeness=false   # network alone

Renders photos of game sheets (`oxbot.testing.render`, the held-out style by default: the
one the board reader was not tuned on; seed 2024 for the held-out styles and 7000 for the
tuning ones unless `--seed` says otherwise, as their figures are recorded), then times
`BoardReader.read` — grayscale, grid finding, rectification, grid-line removal, 9 cells, one
classifier batch — on one core (torch and OpenCV limited to one thread), and prints the median
time per frame over repeats, its stages, and the share of photos with all 9 cells right. SPEC §2
goal: ≤ 15 ms per frame, all 9 cells right in ≥ 98% of frames. Not a test.
"""

from __future__ import annotations

import argparse
import os

import numpy as np
from config_option import add_set_option
from rendered_sets import RENDER_STYLES, render_photos, usual_seed
from timing import one_core, per_call_ms

from oxbot.config import load_config
from oxbot.errors import NoGridFound
from oxbot.game.board import N_CELLS
from oxbot.perception.board import BoardReader, cut_board
from oxbot.perception.cells import CELL_SIZE
from oxbot.perception.classifier import load_classifier
from oxbot.perception.frame import as_image
from oxbot.perception.grid import find_grid


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", type=int, default=200, help="rendered photos (default 200)")
    parser.add_argument("--repeats", type=int, default=5, help="timing passes (median of them)")
    parser.add_argument("--style", choices=sorted(RENDER_STYLES), default="held-out")
    parser.add_argument(
        "--seed", type=int, default=None, help="seed of the photos (default: the style's usual)"
    )
    parser.add_argument("--model", default=None, help="classifier file (default: shipped)")
    add_set_option(parser, "perception.wholeness=false")
    args = parser.parse_args()

    one_core()
    style = RENDER_STYLES[args.style]
    seed = usual_seed(args.style) if args.seed is None else args.seed
    photos = render_photos(args.style, args.photos, seed)
    frames = [p.image for p in photos]
    config = load_config(assignments=args.set).perception
    reader = BoardReader(load_classifier(args.model), config)
    right = no_grid = 0
    cells = np.full((N_CELLS, CELL_SIZE, CELL_SIZE), 245, np.uint8)
    for photo in photos:
        try:
            reading = reader.read(photo.image)
        except NoGridFound:
            no_grid += 1
            continue
        right += reading.labels == photo.labels
        cells = reading.cells
    stages = {
        "grid finding": lambda f: find_grid(as_image(f)),
        "cells (all steps)": cut_board,
        "classify 9 cells": lambda _: reader.classifier.predict(cells),
    }

    width, height = style.size
    print(f"{args.photos} {style.name} photos, {width}x{height}, one core, seed {seed}")
    print(f"all 9 cells right: {right}/{args.photos} = {right / args.photos:.1%} (goal >= 98%)")
    print(f"no grid found:     {no_grid}")
    print(f"load average:      {' '.join(f'{x:.1f}' for x in os.getloadavg())} (other jobs)")
    for name, function in stages.items():
        wall, cpu = per_call_ms(function, frames, args.repeats, ignore=(NoGridFound,))
        print(f"{name + ':':19s}{wall:6.2f} ms wall, {cpu:6.2f} ms CPU")
    wall, cpu = per_call_ms(reader.read, frames, args.repeats, ignore=(NoGridFound,))
    print(
        f"read_board total:  {wall:6.2f} ms wall, {cpu:6.2f} ms CPU per frame, median of "
        f"{args.repeats} (goal <= 15 ms)"
    )


if __name__ == "__main__":
    main()
