import threading
import time

from oxbot.robot.bus import Component, LocalBus
from oxbot.robot.messages import ArmDone, ComponentFailed, DialogueAct, Utterance
from tests.robot.helpers import wait_for


def test_subscribers_get_only_their_types_in_order():
    bus = LocalBus()
    says = bus.subscribe(Utterance)
    everything = bus.subscribe()
    for i in range(500):
        bus.publish(Utterance(text=str(i), act="Request(userGameMove)"))
        bus.publish(ArmDone(where="middle"))
    got = says.drain()
    assert [m.text for m in got] == [str(i) for i in range(500)]
    assert len(everything.drain()) == 1000


def test_a_burst_from_many_threads_keeps_each_publishers_order():
    bus = LocalBus()
    inbox = bus.subscribe(DialogueAct)

    def publisher(name):
        for i in range(300):
            bus.publish(DialogueAct(speaker="sys", act=name, text=str(i)))

    threads = [threading.Thread(target=publisher, args=(f"p{k}",)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    got = inbox.drain()
    assert len(got) == 1200
    for k in range(4):
        mine = [int(m.text) for m in got if m.act == f"p{k}"]
        assert mine == list(range(300))


class Echo(Component):
    listens_to = (Utterance,)

    def __init__(self, bus):
        super().__init__(bus)
        self.restarts = 0

    def handle(self, message):
        if message.text == "boom":
            raise ValueError("cannot say boom")
        self.bus.publish(DialogueAct(speaker="sys", act=message.act, text=message.text))

    def restart(self):
        self.restarts += 1


def test_a_failing_component_is_reported_restarted_and_carries_on():
    bus = LocalBus()
    acts, failures = bus.subscribe(DialogueAct), bus.subscribe(ComponentFailed)
    with Echo(bus) as echo:
        for text in ("hello", "boom", "bye"):
            bus.publish(Utterance(text=text, act="Salutation(greeting)"))
        assert wait_for(lambda: echo.failures == 1 and echo.restarts == 1)
        received = []
        assert wait_for(lambda: received.extend(acts.drain()) or len(received) == 2)
    assert [m.text for m in received] == ["hello", "bye"]
    failure = failures.get(timeout=1)
    assert failure.component == "Echo" and "cannot say boom" in failure.error
    assert not echo.running


class Ticker(Component):
    period = 0.02

    def __init__(self, bus):
        super().__init__(bus)
        self.ticks = 0

    def tick(self):
        self.ticks += 1


def test_periodic_components_tick_and_stop():
    with Ticker(LocalBus()) as ticker:
        assert wait_for(lambda: ticker.ticks >= 5)
    after = ticker.ticks
    time.sleep(0.1)
    assert ticker.ticks == after
