"""oxbot: a talking robot that learns to play noughts and crosses on paper.

Two learners — a CNN+SVM that perceives hand-drawn symbols (`oxbot.perception`) and a DQN
interaction manager that chooses what to say and where to draw (`oxbot.dialogue`) — joined by
a runtime of concurrent components (`oxbot.robot`). See README.md for the map.
"""

__version__ = "0.1.0"
