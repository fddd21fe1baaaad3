"""Train the learned rejector (`oxbot.perception.rejector`): P(whole circle or cross) of a cell.

    PYTHONPATH=. .venv/bin/python bench/train_rejector.py --out runs/rejector/rejector.pt
    PYTHONPATH=. .venv/bin/python bench/train_rejector.py --out oxbot/data/models/rejector.pt
    PYTHONPATH=.:bench .venv/bin/python bench/train_rejector.py --real-share 0.3 ...

Draws the training and development-validation cells (`bench/rejector_data.py`, seeds
`--seed` and `--seed + 1`: no drawing is in both), trains the network (Adam, one-cycle, each
batch in one of its 8 quarter turns and mirror images, binary cross-entropy), chooses the
threshold on the validation part so that at least `--keep` of its whole symbols pass, and writes
the model (config, seed, threshold and metrics in its metadata, checksummed), its metrics JSON
and its learning curve PNG beside it. With `--real-share`, that share of the positives are the
composed boards' development writers' UNIPEN circles and crosses (restored as
bench/data/composite_boards/SOURCES.md says); their test writers are never drawn.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time
from collections import Counter
from pathlib import Path

import numpy as np
import torch
from composite_sources import DATA
from rejector_data import draw_set, real_hands
from torch import nn

from oxbot.atomic import save_figure, write_text_atomic
from oxbot.perception.rejector import Rejector, RejectorArchitecture, rejector_input


@dataclasses.dataclass
class TrainConfig:
    train_cells: int = 60_000
    val_cells: int = 12_000
    epochs: int = 8
    batch_size: int = 128
    learning_rate: float = 0.003
    weight_decay: float = 0.0001
    width: int = 16
    keep: float = 0.997
    seed: int = 1000
    threads: int = 2
    real_share: float = 0.0
    """Share of the positives drawn from the composed boards' development writers (UNIPEN)."""


def turn_or_flip(x: torch.Tensor, k: int) -> torch.Tensor:
    x = torch.rot90(x, k % 4, dims=(2, 3)) if k % 4 else x
    return x.flip(3) if k >= 4 else x


def threshold_for(p_whole: np.ndarray, keep: float) -> float:
    """The highest threshold that keeps at least `keep` of the whole symbols' probabilities."""
    ordered = np.sort(p_whole)
    lose = math.floor((1.0 - keep) * len(ordered))
    return float(ordered[lose]) if lose < len(ordered) else 0.5


def measure(p: np.ndarray, y: np.ndarray, threshold: float) -> dict[str, float]:
    whole = y > 0.5
    return {
        "whole_kept": float((p[whole] >= threshold).mean()),
        "refused": float((p[~whole] < threshold).mean()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for field in dataclasses.fields(TrainConfig):
        parser.add_argument(
            f"--{field.name.replace('_', '-')}", type=type(field.default), default=field.default
        )
    parser.add_argument("--out", type=Path, default=Path("runs/rejector/rejector.pt"))
    parser.add_argument("--cache", type=Path, default=None, help="npz of drawn cells to reuse")
    args = parser.parse_args()
    cfg = TrainConfig(**{f.name: getattr(args, f.name) for f in dataclasses.fields(TrainConfig)})
    torch.set_num_threads(cfg.threads)

    tick = time.perf_counter()
    if args.cache is not None and args.cache.exists():
        data = np.load(args.cache, allow_pickle=False)
        xs, ys, vs, vy = data["xs"], data["ys"], data["vs"], data["vy"]
        vsrc = list(data["vsrc"])
    else:
        hands = None
        if cfg.real_share > 0:
            try:
                hands = real_hands(
                    DATA / "sources" / "handwriting", DATA / "handwriting_manifest.csv"
                )
            except FileNotFoundError as err:
                raise SystemExit(f"train_rejector: {err}") from None
        xs, ys, _ = draw_set(cfg.train_cells, cfg.seed, hands=hands, real_share=cfg.real_share)
        vs, vy, vsrc = draw_set(cfg.val_cells, cfg.seed + 1, hands=hands, real_share=cfg.real_share)
        if args.cache is not None:
            args.cache.parent.mkdir(parents=True, exist_ok=True)
            np.savez_compressed(args.cache, xs=xs, ys=ys, vs=vs, vy=vy, vsrc=np.array(vsrc))
    draw_s = time.perf_counter() - tick
    print(f"drew {len(xs)} + {len(vs)} cells in {draw_s:.0f} s; whole share {ys.mean():.2f}")
    x, y = rejector_input(xs), torch.from_numpy(ys)
    vx = rejector_input(vs)

    rejector = Rejector(RejectorArchitecture(cfg.width), seed=cfg.seed)
    net = rejector.net.train()
    optimiser = torch.optim.AdamW(
        net.parameters(), lr=cfg.learning_rate, weight_decay=cfg.weight_decay
    )
    steps = cfg.epochs * math.ceil(len(x) / cfg.batch_size)
    schedule = torch.optim.lr_scheduler.OneCycleLR(
        optimiser, max_lr=cfg.learning_rate, total_steps=steps
    )
    loss_fn = nn.BCEWithLogitsLoss()
    rng = np.random.default_rng(cfg.seed)
    torch.manual_seed(cfg.seed)
    curve = []
    tick = time.perf_counter()
    seen = 0
    for epoch in range(cfg.epochs):
        net.train()
        order = torch.from_numpy(rng.permutation(len(x)))
        total = 0.0
        for start in range(0, len(x), cfg.batch_size):
            batch = order[start : start + cfg.batch_size]
            inputs = turn_or_flip(x[batch], int(rng.integers(8)))
            optimiser.zero_grad(set_to_none=True)
            loss = loss_fn(net(inputs), y[batch])
            loss.backward()
            optimiser.step()
            schedule.step()
            total += loss.item() * len(batch)
            seen += len(batch)
        p = 1 / (1 + np.exp(-rejector.logits(vx).astype(np.float64)))
        t = threshold_for(p[vy > 0.5], cfg.keep)
        m = measure(p, vy, t)
        curve.append(
            {
                "epoch": epoch + 1,
                "cells_seen": seen,
                "train_loss": total / len(x),
                "threshold": t,
                **m,
                "seconds": time.perf_counter() - tick,
            }
        )
        print(json.dumps(curve[-1]))
    fit_s = time.perf_counter() - tick

    p = 1 / (1 + np.exp(-rejector.logits(vx).astype(np.float64)))
    rejector.threshold = threshold_for(p[vy > 0.5], cfg.keep)
    final = measure(p, vy, rejector.threshold)
    by_source: dict[str, list[int]] = {}
    for prob, label, src in zip(p, vy, vsrc, strict=True):
        kind = str(src).split("|")[0]
        ok = (prob >= rejector.threshold) if label > 0.5 else (prob < rejector.threshold)
        by_source.setdefault(kind, []).append(int(ok))
    per_kind = {k: float(np.mean(v)) for k, v in sorted(by_source.items())}
    renders = Counter(str(s).split("|")[1] for s in vsrc)
    metrics = {
        "config": dataclasses.asdict(cfg),
        "draw_seconds": round(draw_s, 1),
        "fit_seconds": round(fit_s, 1),
        "threshold": rejector.threshold,
        "validation": final,
        "validation_renders": dict(renders),
        "validation_per_source": per_kind,
        "learning_curve": curve,
    }
    print(json.dumps({k: metrics[k] for k in ("threshold", "validation", "fit_seconds")}))
    for k, v in per_kind.items():
        if v < 0.99:
            print(f"  {k:<28} {v:.3f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    rejector.save(args.out, config=dataclasses.asdict(cfg), validation=final, fit_seconds=fit_s)
    write_text_atomic(args.out.with_suffix(".metrics.json"), json.dumps(metrics, indent=2) + "\n")
    plot(curve, args.out.with_suffix(".curve.png"))
    print(f"wrote {args.out}")


def plot(curve: list[dict[str, float]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.4), dpi=110)
    epochs = [c["epoch"] for c in curve]
    ax.plot(epochs, [100 * c["refused"] for c in curve], "o-", label="no move refused")
    ax.plot(epochs, [100 * c["whole_kept"] for c in curve], "s-", label="whole symbols kept")
    ax.set_xlabel("epoch")
    ax.set_ylabel("development validation (%)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right")
    ax.set_title("Learned rejector: threshold keeping 99.7% whole")
    fig.tight_layout()
    save_figure(fig, path)


if __name__ == "__main__":
    main()
