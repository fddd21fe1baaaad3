"""A running study: its folder, design, consent wording and the experimenter's token, and the
database opened only once a participant says yes.

Nothing is written before the first consent: the folder and `study.sqlite3` are made by the
first `enrol`, and until then the experimenter's page reads an empty study.
"""

from __future__ import annotations

import secrets
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from oxbot.errors import ConfigError
from oxbot.recording.store import RecordingStore
from oxbot.study.conditions import Design
from oxbot.study.store import DB_NAME, StudyStore
from oxbot.study.withdrawal import open_recordings

DEFAULT_RETENTION = "until the study's results are written up, and at most 12 months"
CONSENT = """\
Thank you for coming. In this study you play noughts and crosses with a robot on this screen and \
talk with it, by typing or by speaking, and answer a few short questions about it.

What is kept: your answers to the questions, and notes on each game: who won, how many turns, \
how long it took, the words the robot understood from you as text and how sure it was, and how \
often it had to ask again. Your name is never asked. You get a random code instead. No \
recording of your voice and no picture of you is kept; nothing you draw is kept unless you tick \
the box below.

Where and how long: on this computer only, readable by the experimenter, {retention}. Then it is \
deleted. Results are reported only as averages over everyone.

Stopping and withdrawing: you may stop at any time without saying why. To withdraw your data, \
now or later, give the experimenter your code (shown on the next page and at the end); \
everything kept under it is deleted.

If you also tick "Keep what the robot saw and read", the pictures of each square of the sheet \
the robot read and your answers as text are kept too, so that the robot can learn from them. \
This is up to you and changes nothing else; withdrawing deletes them as well.

Nothing at all is kept unless you press "Yes, I agree" below."""
"""The consent text shown before anything else (`--consent FILE` replaces it; `{retention}` is
filled in with `--retention`)."""


@dataclass
class Study:
    """A study's settings and its database (opened, and made, at the first consent)."""

    folder: Path
    design: Design = field(default_factory=Design)
    retention: str = DEFAULT_RETENTION
    consent: str = CONSENT
    token: str = field(default_factory=lambda: secrets.token_urlsafe(16))
    """The experimenter's page's token, printed at start."""
    _store: StudyStore | None = field(default=None, repr=False)
    _recordings: RecordingStore | None = field(default=None, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def __post_init__(self) -> None:
        self.folder = Path(self.folder).expanduser()
        if self.exists():  # a study carried on must keep its counterbalancing
            saved = self.store().design()
            if saved is not None and saved != self.design.to_dict():
                raise ConfigError(
                    f"the study in {self.folder} was started with {saved}, not "
                    f"{self.design.to_dict()}: start it with the same --vary, --games and "
                    "--blocks, or use another --data-dir"
                )

    def exists(self) -> bool:
        """Whether any participant has consented yet (the database file exists)."""
        return (self.folder / DB_NAME).exists()

    def store(self) -> StudyStore:
        """The database, opened (and made) at the first call."""
        with self._lock:
            if self._store is None:
                self._store = StudyStore(self.folder)
            return self._store

    def consent_text(self) -> str:
        """The consent text as the participant reads it, the retention filled in."""
        return self.consent.replace("{retention}", self.retention)

    def enrol(self, keep_recordings: bool = False) -> dict[str, Any]:
        """A participant who has said yes (and, with `keep_recordings`, yes to keeping what the
        robot saw and heard in their games): their id and conditions in order."""
        store = self.store()
        if store.design() is None:
            store.save_design(self.design.to_dict())
        return store.enrol(self.design.order, keep_recordings)

    def recordings(self) -> RecordingStore:
        """The recordings of the participants who agreed to keep them, opened at the first call."""
        with self._lock:
            if self._recordings is None:
                self._recordings = open_recordings(self.folder)
            return self._recordings

    def close(self) -> None:
        """Close the databases, if they were opened."""
        with self._lock:
            if self._store is not None:
                self._store.close()
                self._store = None
            if self._recordings is not None:
                self._recordings.close()
                self._recordings = None
