"""The study's routes on the game page's server (`oxbot study`).

For participants:
- `GET /study`: the participant's page (static/study.html): consent, the questions about them,
  each condition's games (the game page in a frame) and the questionnaires after it;
- `GET /study/setup`: the consent text, the instruments and the design, for that page;
- `POST /study/consent` `{"consent": true, "recordings": false}`: enrols a participant (their
  random id and conditions; with `"recordings": true` their games are recorded too, to learn
  from, into `recordings.sqlite3` beside the study's file); a no writes nothing and returns
  `{"kept": false}`;
- `POST /study/answer` `{participant, instrument, block, item, value}`: one answer, kept in its
  own transaction;
- `GET /study/progress/{id}`: the games kept so far in each block;
- `GET /study/game?participant=ID&block=B`: the game page set up for the block's condition
  (static/game.js hides what the condition does not allow and the manager's Q-values);
- `WS /study/ws?participant=ID&block=B`: the block's game, its robot built for its condition,
  its metrics kept when the robot says goodbye (or the tab closes first); refused (1008) for
  an unknown participant or block, or a block whose games are all played.

The two writes refuse (403) a request whose Host or Origin the game socket would refuse
(oxbot.web.admission: another site's page, DNS rebinding) and (415) a body not sent as JSON.

For the experimenter, with the token printed at start (`?token=` or an `X-Study-Token` header;
403 without it): `GET /study/experimenter` (the page), `/study/results` (JSON: participants so
far, per-condition means with 95% intervals), `/study/plot/{measure}.png` and
`/study/export.csv` (the per-block table).
"""

from __future__ import annotations

import dataclasses
import secrets
from collections.abc import Callable
from importlib import resources
from typing import Any

from fastapi import FastAPI, Request, WebSocket
from fastapi.responses import HTMLResponse, JSONResponse, Response

from oxbot.config import OxbotConfig, with_overrides
from oxbot.recording.recorder import joining as recorder
from oxbot.study.conditions import FACTORS, label
from oxbot.study.export import DICTIONARY, to_csv
from oxbot.study.instruments import AFTER_CONDITION, PRE, check_answer
from oxbot.study.metrics import GameWatcher
from oxbot.study.plots import PLOTS, plot_png
from oxbot.study.results import block_rows, summary
from oxbot.study.session import Study
from oxbot.study.withdrawal import recording_mode
from oxbot.web.server import game_socket

STATIC = {
    "study.js": "text/javascript",
    "game.js": "text/javascript",
    "experimenter.js": "text/javascript",
    "study.css": "text/css",
}


def _static(name: str) -> bytes:
    return resources.files("oxbot.study").joinpath("static", name).read_bytes()


def condition_config(config: OxbotConfig, condition: dict[str, str]) -> OxbotConfig:
    """`config` with a condition's manager and starter; the robot offers no other game (the
    study sets how many each participant plays)."""
    return with_overrides(
        config,
        {
            "game": {"robot_starts": condition["starter"] == "robot"},
            "robot": {"manager": condition["manager"], "offer_another_game": False},
        },
    )


def add_routes(app: FastAPI, study: Study, config: OxbotConfig) -> None:
    """The study's routes (see the module docstring) on the game page's FastAPI `app`."""
    _participant_routes(app, study)
    _game_routes(app, study, config)
    _experimenter_routes(app, study)


def _bad(message: str, status: int = 400) -> JSONResponse:
    return JSONResponse({"error": message}, status_code=status)


def _without_token(request: Request, study: Study) -> Response | None:
    """The 403 of an experimenter's request without the study's token, or None."""
    given = request.query_params.get("token") or request.headers.get("x-study-token") or ""
    if secrets.compare_digest(given.encode(), study.token.encode()):
        return None
    return _bad("the experimenter's page needs the token `oxbot study` printed", 403)


def _cross_site(request: Request) -> Response | None:
    """A refusal of a write that another site's page may have sent (the game socket's Host and
    Origin checks), or of a body that is not declared JSON (which a page elsewhere could post
    without the browser asking this server first); None for a write to take."""
    refusal = request.app.state.origins.refusal(request)
    if refusal is not None:
        return _bad(refusal, 403)
    if request.headers.get("content-type", "").split(";")[0].strip() != "application/json":
        return _bad("send the body as application/json", 415)
    return None


def _participant_routes(app: FastAPI, study: Study) -> None:
    """The participant's page, its setup, consent, answers and progress."""

    @app.get("/study", response_class=HTMLResponse)
    def participant_page() -> HTMLResponse:
        return HTMLResponse(_static("study.html"))

    @app.get("/study/static/{name}")
    def static(name: str) -> Response:
        if name not in STATIC:
            return _bad(f"no such file: {name}", 404)
        return Response(_static(name), media_type=STATIC[name])

    @app.get("/study/setup")
    def setup() -> dict:
        return {
            "consent": study.consent_text(),
            "pre": dataclasses.asdict(PRE),
            "after": [dataclasses.asdict(i) for i in AFTER_CONDITION],
            "games": study.design.games,
            "blocks": study.design.per_participant,
        }

    @app.post("/study/consent")
    async def consent(request: Request) -> Response:
        if (no := _cross_site(request)) is not None:
            return no
        body = await _json(request)
        if body.get("consent") is not True:
            return JSONResponse({"kept": False})  # nothing written, not even the folder
        p = study.enrol(keep_recordings=body.get("recordings") is True)
        return JSONResponse({"kept": True, "participant": p["id"], "conditions": p["conditions"]})

    @app.post("/study/answer")
    async def answer(request: Request) -> Response:
        if (no := _cross_site(request)) is not None:
            return no
        body = await _json(request)
        try:
            pid, instrument, block, item, value = (
                str(body["participant"]),
                str(body["instrument"]),
                int(body["block"]),
                str(body["item"]),
                str(body["value"]),
            )
            check_answer(instrument, item, value)
        except (KeyError, TypeError, ValueError) as exc:
            return _bad(f"an answer is {{participant, instrument, block, item, value}}: {exc}")
        conditions = _conditions(study, pid)
        if conditions is None:
            return _bad(f"no participant {pid} in this study", 404)
        if not (block == 0 if instrument == PRE.name else 1 <= block <= len(conditions)):
            return _bad(f"{instrument} is not asked in block {block}")
        study.store().answer(pid, instrument, block, item, value)
        return JSONResponse({"kept": True})

    @app.get("/study/progress/{pid}")
    def progress(pid: str) -> Response:
        conditions = _conditions(study, pid)
        if conditions is None:
            return _bad(f"no participant {pid} in this study", 404)
        games = study.store().games(pid)
        done = {b: sum(g["block"] == b for g in games) for b in range(1, len(conditions) + 1)}
        return JSONResponse({"games": done})


def _game_routes(app: FastAPI, study: Study, config: OxbotConfig) -> None:
    """The game page in the study's frame and its socket, a robot per game in its condition."""

    @app.get("/study/game", response_class=HTMLResponse)
    def game_page() -> HTMLResponse:
        page = resources.files("oxbot.web").joinpath("static", "index.html").read_text()
        page = page.replace("</body>", '<script src="/study/static/game.js"></script>\n</body>')
        return HTMLResponse(page)

    @app.websocket("/study/ws")
    async def game(websocket: WebSocket) -> None:
        pid = websocket.query_params.get("participant", "")
        conditions = _conditions(study, pid) or []
        block_text = websocket.query_params.get("block", "")
        block = int(block_text) if block_text.isdigit() else 0
        refusal = ""
        if not 1 <= block <= len(conditions):
            refusal = "no such participant and block in this study"
        elif sum(g["block"] == block for g in study.store().games(pid)) >= study.design.games:
            refusal = "this part's games are all played"
        if refusal:
            await websocket.accept()
            await websocket.close(1008, refusal)
            return
        condition = conditions[block - 1]
        made = condition_config(config, condition)
        joining: list[Callable[[Any], Any]] = [lambda bus: GameWatcher(bus, keep)]
        if study.store().participant(pid)["keep_recordings"]:  # they said yes to this too
            joining.append(recorder(study.recordings, recording_mode(pid)))

        def keep(metrics: dict[str, Any]) -> None:
            study.store().add_game(pid, block, condition, metrics)

        def make_robot() -> Any:
            from oxbot.robot.session import Robot

            return Robot(made, joining=joining)

        await game_socket(websocket, app, make_robot)


def _experimenter_routes(app: FastAPI, study: Study) -> None:
    """The experimenter's page, results, plots and CSV, behind the study's token."""

    @app.get("/study/experimenter", response_class=HTMLResponse)
    def experimenter(request: Request) -> Response:
        return _without_token(request, study) or HTMLResponse(_static("experimenter.html"))

    @app.get("/study/results")
    def results(request: Request) -> Response:
        return _without_token(request, study) or JSONResponse(study_results(study))

    @app.get("/study/plot/{measure}.png")
    def plot(measure: str, request: Request) -> Response:
        if (no := _without_token(request, study)) is not None:
            return no
        if measure not in PLOTS:
            return _bad(f"no plot of {measure}; plots: {', '.join(PLOTS)}", 404)
        rows = block_rows(study.store()) if study.exists() else []
        return Response(plot_png(measure, summary(rows)), media_type="image/png")

    @app.get("/study/export.csv")
    def export_csv(request: Request) -> Response:
        if (no := _without_token(request, study)) is not None:
            return no
        rows = block_rows(study.store()) if study.exists() else []
        return Response(
            to_csv(rows, list(DICTIONARY["blocks.csv"])),
            media_type="text/csv",
            headers={"Content-Disposition": 'attachment; filename="blocks.csv"'},
        )


def study_results(study: Study) -> dict[str, Any]:
    """The experimenter page's data: the design, the participants so far and what they did,
    the per-block rows and the per-condition summary."""
    design = {
        "conditions": [label(c) for c in study.design.conditions],
        "factors": list(FACTORS),
        **study.design.to_dict(),
    }
    if not study.exists():
        return {"design": design, "participants": [], "blocks": [], "summary": {}}
    store = study.store()
    games = store.games()
    answered = {a["participant_id"] for a in store.answers()}
    participants = [
        {
            "id": p["id"],
            "conditions": [label(c) for c in p["conditions"]],
            "games": sum(g["participant_id"] == p["id"] for g in games),
            "answered": p["id"] in answered,
        }
        for p in store.participants()
    ]
    rows = block_rows(store)
    return {
        "design": design,
        "participants": participants,
        "blocks": rows,
        "summary": summary(rows),
    }


def _conditions(study: Study, pid: str) -> list[dict[str, str]] | None:
    """A participant's conditions in order, or None when no such participant consented."""
    if not study.exists() or not pid:
        return None
    rows = study.store().query("SELECT id FROM participants WHERE id = ?", (pid,))
    return study.store().participant(pid)["conditions"] if rows else None


async def _json(request: Request) -> dict:
    """The request's JSON object body ({} when it is not one: the handlers then refuse it)."""
    try:
        body = await request.json()
    except ValueError:
        return {}
    return body if isinstance(body, dict) else {}
