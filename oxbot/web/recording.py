"""The web page's side of recording: the record toggle's settings and the "what I learned" page.

Routes (added by `add_routes`, beside the game's):
- `GET /learned`: the page (static/learned.html), which reads
- `GET /recording/learned`: JSON of the recorded sessions, the crops the robot read wrong when
  it saw them and what the learnt model (`DATA_DIR/learned/perceiver.pt`, else the shipped one)
  reads now, and the answers it had to ask again about;
- `GET /recording/status`: whether games can be recorded here, whether new ones are by default,
  and the notice to show;
- `GET /recording/{name}`: the two scripts (record.js for the toggle, learned.js).

The database is opened at the first use (a game recorded or the page asked for), never before.
"""

from __future__ import annotations

import base64
import functools
import logging
import threading
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from oxbot.errors import DataError, OxbotError
from oxbot.recording.rows import MAX_CROP_BYTES
from oxbot.recording.store import DB_NAME, RecordingStore, default_data_dir

log = logging.getLogger(__name__)

SCRIPTS = {"record.js": "text/javascript", "learned.js": "text/javascript"}
MAX_SESSIONS = 500
"""The page lists at most this many sessions (the latest), so its data stays small."""
MAX_CROPS = 60
"""The page shows at most this many drawings read wrong (the latest sessions')."""
NOTICE = (
    "Keeps this game's cell images, your answers as text, the transcript, outcome and "
    "timings on this computer ({path}); `oxbot data forget` deletes a game."
)


@dataclass
class RecordingSetup:
    """Where a server's games are recorded, and whether a new tab records without asking."""

    data_dir: Path | None = None
    """The recordings' folder (default: the user's data folder)."""
    on_by_default: bool = False
    """`oxbot play --record`: the page's toggle starts on."""
    keep_audio: bool = False
    """`--record-audio`: keep the recordings of spoken answers too."""
    unavailable: str = ""
    """Why games cannot be recorded here (the toggle is refused with it), or "" when they can."""
    _store: RecordingStore | None = field(default=None, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    @property
    def folder(self) -> Path:
        return self.data_dir if self.data_dir is not None else default_data_dir()

    def store(self) -> RecordingStore:
        """The database, opened (and created) at the first call."""
        with self._lock:
            if self._store is None:
                self._store = RecordingStore(self.folder)
            return self._store

    def notice(self) -> str:
        return NOTICE.format(path=self.folder / DB_NAME)


def add_routes(app: Any, setup: RecordingSetup) -> None:
    """The "what I learned" page, its data and the recording scripts, on a FastAPI `app`."""
    from fastapi.responses import HTMLResponse, JSONResponse, Response

    @app.get("/learned", response_class=HTMLResponse)
    def learned_page() -> HTMLResponse:
        return HTMLResponse(_static("learned.html"))

    @app.get("/recording/status")
    def recording_status() -> dict:
        if setup.unavailable:  # the truth: nothing would be kept
            return {"available": False, "on_by_default": False, "notice": setup.unavailable}
        return {"available": True, "on_by_default": setup.on_by_default, "notice": setup.notice()}

    @app.get("/recording/learned")
    def learned_data() -> Any:
        if not (setup.folder / DB_NAME).exists():  # nothing recorded: no file made for it
            return {"sessions": [], "crops": [], "answers": [], "model": "", "notice": ""}
        try:
            return what_i_learned(setup.store())
        except OxbotError as exc:  # a damaged database: say so, no traceback
            log.warning("the learned page: %s", exc)
            return JSONResponse({"error": str(exc)}, status_code=500)

    @app.get("/recording/{name}")
    def recording_script(name: str) -> Response:
        if name not in SCRIPTS:
            return JSONResponse({"error": f"no such file: {name}"}, status_code=404)
        return Response(_static(name), media_type=SCRIPTS[name])


def _static(name: str) -> bytes:
    return resources.files("oxbot.web").joinpath("static", name).read_bytes()


def learned_model(store: RecordingStore) -> Path | None:
    """The model `oxbot learn perceiver` wrote into the data folder, if any."""
    path = store.data_dir / "learned" / "perceiver.pt"
    return path if path.exists() else None


@functools.lru_cache(maxsize=2)
def _classifier(path: str, stamp: float) -> Any:
    from oxbot.perception.classifier import load_classifier

    return load_classifier(path or None)


def what_i_learned(store: RecordingStore) -> dict[str, Any]:
    """The data of the "what I learned" page (see the module docstring)."""
    from oxbot.recording.perceiver import decode_crops

    sessions = [
        {
            "id": s.id,
            "started_at": s.started_at,
            "mode": s.mode,
            "status": s.status,
            "outcome": s.outcome,
            "turns": s.turns,
            "answers": s.answers,
            "repeated": s.repeated,
            "crops": s.crops,
            "labelled": s.labelled,
        }
        for s in store.sessions()[-MAX_SESSIONS:]
    ]
    # a crop bigger than any real one is left in the file, unread (a damaged or crafted row)
    rows = store.query(
        "SELECT session_id, reading, cell, image, read_as, confidence, label FROM crops "
        "WHERE label IS NOT NULL AND read_as != label AND length(image) <= ? "
        "ORDER BY session_id DESC, reading",
        (MAX_CROP_BYTES,),
    )
    wrong, images, drawings = [], [], set()
    for row in rows:  # a drawing is read many times: its first wrong reading stands for it
        if (row["session_id"], row["cell"]) not in drawings and len(wrong) < MAX_CROPS:
            try:
                images.append(decode_crops([row])[0])  # its header checked before decoding
            except DataError as exc:
                log.warning("the learned page skips a crop: %s", exc)
                continue
            drawings.add((row["session_id"], row["cell"]))
            wrong.append(row)
    model = learned_model(store)
    crops = []
    if wrong:
        clf = _classifier(str(model or ""), model.stat().st_mtime if model else 0.0)
        now = clf.predict(np.stack(images))
        for row, reads_now in zip(wrong, now, strict=True):
            crops.append(
                {
                    "session": row["session_id"],
                    "cell": row["cell"],
                    "png": base64.b64encode(row["image"]).decode("ascii"),
                    "label": row["label"],
                    "read_then": row["read_as"],
                    "confidence_then": row["confidence"],
                    "reads_now": reads_now,
                }
            )
    answers = store.query(
        "SELECT session_id, nbest, understood, after_act FROM answers WHERE repeated = 1 "
        "ORDER BY session_id DESC, seq DESC LIMIT 100"
    )
    return {
        "sessions": sessions,
        "crops": crops,
        "answers": answers,
        "model": str(model) if model else "the shipped model (run `oxbot learn perceiver`)",
        "notice": NOTICE.format(path=store.path),
    }
