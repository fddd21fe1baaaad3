"""The harness for tests and benchmarks: rendered sheet photos, a scripted WebSocket player,
browser helpers. Never imported by the robot at run time."""
