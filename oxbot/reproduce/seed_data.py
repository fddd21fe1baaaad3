"""The seed data everything is learned from: the seed images drawn afresh and compared with the
shipped ones, the seed dialogues counted, and their rows of the paper's figures table."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from oxbot.config import OxbotConfig
from oxbot.reproduce.cells import _row
from oxbot.reproduce.paper import PAPER_FIGURES


def _make_seed_data(work_dir: Path, config: OxbotConfig) -> dict[str, Any]:
    from oxbot.dialogue.domain import load_domain
    from oxbot.perception.seeds import load_seeds, make_seeds

    p = config.perception
    written = make_seeds(work_dir / "seeds", p.seeds_per_class, p.seed, p.image_size)
    made, shipped = load_seeds(work_dir / "seeds", p.image_size), load_seeds(size=p.image_size)
    same = all(
        len(made.images[k]) == len(shipped.images[k])
        and all(
            np.array_equal(a, b) for a, b in zip(made.images[k], shipped.images[k], strict=True)
        )
        for k in made.images
    )
    domain = load_domain()
    return {
        "seed_images": len(written),
        "seed_images_per_label": {k: len(v) for k, v in made.images.items()},
        "seed_images_same_as_shipped": same,
        "seed_dialogues": len(domain.dialogues),
        "vocabulary": len(domain.vocabulary),
    }


def _seed_data_rows(f: dict[str, Any]) -> list[str]:
    """The seed images and seed dialogues everything is learned from."""
    data = f["data"]
    seeds_cell = (
        f"{data['seed_images']} ("
        + ", ".join(f"{v} {k}" for k, v in data["seed_images_per_label"].items())
        + "; drawn by oxbot's synthesiser)"
    )
    return [
        _row(
            "data: seed images",
            f"108 ({PAPER_FIGURES['seed_images'][1]})",
            seeds_cell,
            "the same 108 (`oxbot/data/seeds/`)"
            if data["seed_images_same_as_shipped"]
            else "108 others (`oxbot/data/seeds/`)",
            "—",
            "—",
        ),
        _row(
            "data: seed dialogues",
            f"10 ({PAPER_FIGURES['seed_dialogues'][1]})",
            f"{data['seed_dialogues']} (`oxbot/data/dialogue/dialogues.txt`)",
            f"the same {data['seed_dialogues']}",
            "—",
            "—",
        ),
    ]
