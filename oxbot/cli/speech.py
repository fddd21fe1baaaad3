"""The speech command: training the yes / no / other keyword model (`oxbot train keywords`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer


def train_keywords_command(
    repo: Annotated[
        Path,
        typer.Option(
            help="Git directory of the fetched MahmoudEhab3/Yes-No-Speech-Classifier "
            "(oxbot/data/models/keywords.SOURCES.md); read, never written."
        ),
    ],
    out: Annotated[
        Path, typer.Option(help="Model file to write (the shipped one: oxbot/data/models/).")
    ] = Path("runs/keywords/keywords.pt"),
    seed: Annotated[int, typer.Option(help="Seed of the weights and augmentation.")] = 0,
    epochs: Annotated[int | None, typer.Option(help="Passes (default: KeywordConfig).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
) -> None:
    """Train the yes / no / other keyword model that double-checks short spoken answers."""
    import dataclasses

    from oxbot.speech.keywords import KeywordConfig, load_training_data, train_keywords

    config = KeywordConfig(seed=seed)
    if epochs is not None:
        config = dataclasses.replace(config, epochs=epochs)
    from oxbot.dialogue.domain import load_domain
    from oxbot.speech.keywords import spoken_clips

    data = load_training_data(repo) + spoken_clips(load_domain())
    spotter = train_keywords(data, config, out, show_progress=not quiet)
    m = spotter.metadata
    typer.echo(
        f"trained on {sum(m['clips'].values()):,} clips ({m['clips']}) in "
        f"{m['train_cpu_seconds']:.0f} s of CPU; last loss {m['loss_per_epoch'][-1]:.3f}; "
        f"wrote {out}"
    )
