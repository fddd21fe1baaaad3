"""The paper's figures the report compares with, and oxbot's own goals beside them."""

from __future__ import annotations

PAPER = "Cuayáhuitl et al. 2016, NIPS workshop on the Future of Interactive Learning Machines"
PAPER_FIGURES = {
    "accuracy": (0.999, "Experimental Results: 99.9% on 1000 randomly generated test images"),
    "train_time_10k_s": (360.0, "Experimental Results: 10K images in 6 minutes, Core i7 3.4 GHz"),
    "win_draw": (0.98, "abstract, Concluding Remarks: win/draw rate of 98%"),
    "agent_time_s": (3 * 3600.0, "Experimental Results: a reasonable policy after 3 hours"),
    "seed_images": (108, "Related Work and Limitations, Concluding Remarks"),
    "seed_dialogues": (10, "Experimental Results, Concluding Remarks"),
}
"""The paper's figures the report compares with, each with where the paper gives it."""
GOALS = {
    "accuracy": 0.999,
    "other_hand": 0.995,
    "train_time_10k_s": 30.0,
    "agent_time_s": 300.0,
    "win_random": {True: 0.9948, False: 0.9164},
}
"""oxbot's goals (the optimum against a random person minus 1 point)."""
