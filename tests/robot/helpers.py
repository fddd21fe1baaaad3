"""What several robot tests need: reading a bus subscription until a message comes, waiting
for a condition."""

import time


def collect(inbox, until, seconds=5.0):
    """Messages from `inbox` up to and including the first for which `until` is true."""
    got, deadline = [], time.monotonic() + seconds
    while time.monotonic() < deadline:
        message = inbox.get(timeout=0.05)
        if message is not None:
            got.append(message)
            if until(message):
                return got
    raise AssertionError(f"timed out after {got}")


def wait_for(predicate, seconds=3.0):
    """True as soon as `predicate()` is, False if it is not within `seconds`."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.01)
    return False
