"""kill -9 of the study's server mid-study loses no answer already given."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time

import httpx

from oxbot.study.store import DB_NAME, StudyStore, integrity

SERVER = """
import sys
import uvicorn
from oxbot.config import OxbotConfig
from oxbot.study.page import add_routes
from oxbot.study.session import Study
from oxbot.web.server import create_app

config = OxbotConfig()
app = create_app(config)
add_routes(app, Study(sys.argv[1]), config)
# no lifespan: the robot's models are not needed to answer questions
uvicorn.run(app, host="127.0.0.1", port=int(sys.argv[2]), lifespan="off", log_level="warning")
"""


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_kill_9_of_the_server_keeps_every_answer_given(tmp_path):
    port = free_port()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    server = subprocess.Popen(
        [sys.executable, "-c", SERVER, str(tmp_path), str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    url = f"http://127.0.0.1:{port}"
    answered = []
    try:
        with httpx.Client(base_url=url, timeout=10) as client:
            deadline = time.monotonic() + 60
            while True:
                try:
                    client.get("/study/setup")
                    break
                except httpx.TransportError:
                    assert time.monotonic() < deadline, "the study's server did not start"
                    assert server.poll() is None, "the study's server died"
                    time.sleep(0.1)
            pid = client.post("/study/consent", json={"consent": True}).json()["participant"]
            for i, value in enumerate("4241524251", start=1):
                reply = client.post(
                    "/study/answer",
                    json={
                        "participant": pid,
                        "instrument": "sus",
                        "block": 1,
                        "item": f"sus{i}",
                        "value": value,
                    },
                )
                assert reply.status_code == 200, reply.text
                answered.append((f"sus{i}", value))
                if i == 7:
                    break
        server.send_signal(signal.SIGKILL)  # mid-questionnaire, with no goodbye to the file
        server.wait(10)
    finally:
        if server.poll() is None:
            server.kill()
            server.wait(10)
    assert server.returncode == -signal.SIGKILL
    assert integrity(tmp_path / DB_NAME) == "ok"
    with StudyStore(tmp_path) as store:
        kept = [(a["item"], a["value"]) for a in store.answers(pid)]
    assert sorted(kept) == sorted(answered)
