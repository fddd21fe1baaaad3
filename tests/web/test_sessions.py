"""20 tabs at once on a 2-core machine: every game finishes, and no game sees another's."""

from __future__ import annotations

import asyncio

import pytest

from oxbot.game.board import outcome
from tests.web.conftest import FAST, running_server

SESSIONS = 20


# twenty robots in one process, each supervised by the wall clock (a part silent for 3 s is hung):
# beside other workers' CPU-bound tests a tick can wait that long on two cores
@pytest.mark.realtime
def test_twenty_concurrent_games_finish_without_cross_talk():
    with running_server(config=FAST) as url:
        ws_url = url.replace("http://", "ws://") + "/ws"

        async def all_games():
            from oxbot.testing.player import play_game

            return await asyncio.gather(
                *(play_game(ws_url, seed=100 + i, timeout=150) for i in range(SESSIONS))
            )

        records = asyncio.run(all_games())

    assert len({r.session for r in records}) == SESSIONS
    for r in records:
        where = f"session {r.session}"
        assert r.ended, f"{where}: {r.failures}"
        assert not r.errors and not r.failures and not r.problems, where
        # every move the robot accepted is one this client drew, in order: no cross-talk
        assert r.accepted == r.drawn, where
        assert not set(r.robot_cells) & set(r.drawn), where
        assert r.outcome is not None and outcome(r.board()) == r.outcome, where
        said = [act for speaker, act, _ in r.transcript if speaker == "sys"]
        assert said[0] == "Salutation(greeting)" and said[-1] == "Salutation(closing)", where
