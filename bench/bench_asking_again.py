"""What asking again would cost: the shipped policy's answers about playing, right and misheard,
by score, and what its repeated questions are now.

    PYTHONPATH=. .venv/bin/python bench/bench_asking_again.py                 # the population
    PYTHONPATH=. .venv/bin/python bench/bench_asking_again.py --people default --dialogues 2000

The shipped policy talks with simulated people (`--people population`: the ones who decline
twice as often and are heard with twice the noise, `oxbot.testing.simulated_people`; or the
default ones), `--dialogues` per who-starts condition, random opponent. Every answer to an
invitation, to "Sorry, I didn't catch that" or to an acknowledged no is sorted by what the
person meant and what was understood: a yes understood where the person meant something else
(a "later" with a word dropped) can start a game nobody agreed to; a no, later or stop
understood where they meant yes can end the dialogue of someone who wanted to play. For each
threshold: how many of those the robot would catch by asking again below it, how many it
already asked again about, and how many more questions that rule would ask of answers that
were right. Then the repeated questions the policy asks now (as `oxbot learn agent` counts
them: `Request(repeat)`, or an invitation or move request said twice in a row), by what came
before. Not a test.
"""

from __future__ import annotations

import argparse
from collections import Counter

from oxbot.config import OxbotConfig
from oxbot.dialogue.agent import load_policy
from oxbot.dialogue.domain import (
    ACCEPT,
    ASK_AGAIN,
    GRANT_REFUSAL,
    INVITATION,
    REFUSALS,
    STOP,
    UNKNOWN,
)
from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.recording.agent import asks_again
from oxbot.testing.simulated_people import population

ASKING = (INVITATION, ASK_AGAIN, GRANT_REFUSAL)
"""What the robot said before an answer about playing."""
NOES = (*REFUSALS, STOP)
THRESHOLDS = (0.5, 0.6, 0.7, 0.8, 0.9)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--people", choices=("population", "default"), default="population")
    parser.add_argument("--dialogues", type=int, default=1000, help="per who-starts condition")
    parser.add_argument("--seed", type=int, default=20_000, help="first dialogue's seed")
    args = parser.parse_args()
    config = population() if args.people == "population" else OxbotConfig()
    policy = load_policy()
    # (score, asked again) of answers understood as a yes / as a no, right and misheard
    answers: dict[str, tuple[list, list]] = {"yes": ([], []), "no": ([], [])}
    repeats: Counter[str] = Counter()
    dialogues = 0
    for robot_starts in (True, False):
        env = InteractiveGameEnv(opponent="random", robot_starts=robot_starts, config=config)
        for k in range(args.dialogues):
            obs, info = env.reset(seed=args.seed + k)
            done = False
            while not done:
                action = policy.act_batch(obs[None], info["action_mask"][None])[0]
                obs, _, terminated, truncated, info = env.step(int(action))
                done = terminated or truncated
            dialogues += 1
            sort_answers(info, answers)
            count_repeats(info, repeats)
    print(f"{dialogues} dialogues with the {args.people} people")
    for kind, (right, wrong) in answers.items():
        already = sum(asked for _, asked in wrong)
        print(
            f"understood as a {kind}: {len(right)} right, {len(wrong)} misheard "
            f"(asked again about {already})"
        )
        for threshold in THRESHOLDS:
            caught = sum(score < threshold for score, _ in wrong)
            more = sum(score < threshold and not asked for score, asked in right)
            print(
                f"  ask again below {threshold}: {caught}/{len(wrong)} misheard caught, "
                f"{more} more questions about right answers ({more / dialogues:.2f} a dialogue)"
            )
    total = sum(repeats.values())
    print(f"repeated questions now: {total} ({total / dialogues:.2f} a dialogue), after:")
    for what, n in repeats.most_common():
        print(f"  {n:5d} ({n / dialogues:.2f})  {what}")


def sort_answers(info: dict, answers: dict[str, tuple[list, list]]) -> None:
    transcript, understood, scores = (
        info["transcript"],
        info["understood"],
        info["understood_scores"],
    )
    before = None
    for i, turn in enumerate(transcript):
        if turn["speaker"] == "sys":
            before = turn["act"]
            continue
        if before not in ASKING:
            continue
        after = next((t["act"] for t in transcript[i + 1 :] if t["speaker"] == "sys"), None)
        asked = after in (ASK_AGAIN, INVITATION)
        act, meant = understood[i], turn["act"]
        if act == ACCEPT:
            answers["yes"][meant != ACCEPT].append((scores[i], asked))
        elif act in NOES:
            answers["no"][meant == ACCEPT].append((scores[i], asked))


def count_repeats(info: dict, repeats: Counter[str]) -> None:
    transcript, understood, scores = (
        info["transcript"],
        info["understood"],
        info["understood_scores"],
    )
    said, heard = None, None
    for turn, act, score in zip(transcript, understood, scores, strict=True):
        if turn["speaker"] == "usr":
            heard = (act, score)
            continue
        if asks_again(turn["act"], said):
            if heard is None:
                repeats[f"{turn['act']} after silence"] += 1
            else:
                repeats[f"{turn['act']} after {heard[0]}{band(*heard)}"] += 1
        said, heard = turn["act"], None


def band(act: str, score: float) -> str:
    if act == UNKNOWN:
        return ""
    return " at " + ("<0.5" if score < 0.5 else "<0.7" if score < 0.7 else ">=0.7")


if __name__ == "__main__":
    main()
