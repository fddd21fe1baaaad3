"""Benchmark of the perceiver: training time for 10K images and time to classify 9 cells.

    .venv/bin/python bench/bench_perception.py                 # 10K images, 3 repeats
    .venv/bin/python bench/bench_perception.py --images 2000 --repeats 1 --threads 2

Generates the training images from the shipped seeds and trains the CNN+SVM on them (the
default config: the paper's 10K images), `--repeats` times, and prints the median time of each
part; then times `predict` on one frame's 9 cells, and prints the median over repeats of the
mean time per call. Training uses `[perception] threads` torch threads (one by default: more
barely help a net this small). SPEC §1 goal: 10K images trained in ≤ 30 s on 2 CPU cores (the paper:
6 minutes); 9 cells classified in ≤ 2 ms. Not a test: timings depend on the machine and on
whatever else runs on it.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import torch
from timing import per_call_ms

from oxbot.config import PerceptionConfig
from oxbot.perception.augment import generate
from oxbot.perception.classifier import SymbolClassifier, load_classifier
from oxbot.perception.evaluation import TRAIN_STREAM, evaluate_generated
from oxbot.perception.seeds import load_seeds
from oxbot.perception.synth import LABELS, draw_cell


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", type=int, default=10_000, help="training images (10K)")
    parser.add_argument("--repeats", type=int, default=3, help="training runs (median of them)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads of predict")
    parser.add_argument("--calls", type=int, default=500, help="predict calls per timing pass")
    parser.add_argument("--model", default=None, help="classifier file (default: shipped)")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    config = PerceptionConfig()
    seeds = load_seeds()

    generating, fitting, accuracies = [], [], []
    for _ in range(args.repeats):
        started = time.perf_counter()
        rng = np.random.default_rng([config.seed, TRAIN_STREAM])
        images, labels = generate(seeds, args.images, rng, partial=config.partial_output)
        generated = time.perf_counter()
        clf = SymbolClassifier(config).fit(images, labels)
        fitting.append(time.perf_counter() - generated)
        generating.append(generated - started)
        accuracies.append(evaluate_generated(clf, seeds).accuracy)
    gen_s, fit_s = statistics.median(generating), statistics.median(fitting)
    print(
        f"training on {args.images:,} images, {config.threads} torch thread(s), "
        f"{config.epochs} epochs"
    )
    print(f"  generate images  {gen_s:6.2f} s (median of {args.repeats})")
    print(f"  fit the CNN+SVM  {fit_s:6.2f} s")
    print(f"  total            {gen_s + fit_s:6.2f} s   (goal <= 30 s; the paper: 6 minutes)")
    print(f"  accuracy on 1,000 generated test images: {statistics.median(accuracies):.2%}")

    clf = load_classifier(args.model)
    rng = np.random.default_rng(0)
    cells = np.stack([draw_cell(LABELS[i % 3], rng) for i in range(9)])
    clf.predict(cells)  # warm up
    per_call, _ = per_call_ms(clf.predict, [cells] * args.calls, 7)
    print(
        f"classify one frame's 9 cells: {per_call:.3f} ms per predict call "
        f"(median of 7 passes of {args.calls}, {args.threads} torch thread(s); goal <= 2 ms)"
    )


if __name__ == "__main__":
    main()
