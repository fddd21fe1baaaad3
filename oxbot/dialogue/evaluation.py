"""Evaluation of an interaction manager: outcomes, reward, length and well-formed dialogues.

Many environments run side by side so that the Q-network acts on a whole batch of states at
once; 10,000 games per condition take seconds, not minutes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from oxbot.config import OxbotConfig, with_overrides
from oxbot.dialogue.action_model import action_mask
from oxbot.dialogue.domain import (
    ACCEPT,
    ASK_AGAIN,
    GAME_MOVE_TEMPLATE,
    GREETING,
    INTRODUCTION,
    INVITATION,
    LETS_PLAY,
    MOVE_REQUEST,
    SYSTEM_ACTS,
    Turn,
    game_move_cell,
    is_game_move,
)
from oxbot.dialogue.env import InteractiveGameEnv, format_turn
from oxbot.dialogue.model import DialogueModel, build_dialogue_model
from oxbot.dialogue.simulator import UserSimulator
from oxbot.dialogue.wellformed import blame, check_dialogue
from oxbot.game.board import EMPTY_BOARD, ROBOT, USER, Board, legal_moves, play, winner
from oxbot.game.board import outcome as game_outcome
from oxbot.game.opponents import OPPONENTS

Policy = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""A batch policy: (states (N, F), masks (N, N_ACTIONS)) -> acts (N,)."""

CONDITIONS = tuple((name, robot_starts) for name in OPPONENTS for robot_starts in (True, False))
"""Every opponent in both who-starts conditions, in the order reports list them."""


OUTCOMES = ("win", "draw", "loss", "declined", "stopped", "abandoned")
"""`info["outcome"]` of a finished dialogue (`InteractiveGameEnv`)."""


def condition_key(opponent: str, robot_starts: bool) -> str:
    """`random/robot` or `random/person`: an opponent and who starts, as metrics key them."""
    return f"{opponent}/{'robot' if robot_starts else 'person'}"


@dataclass
class EvaluationResult:
    """Measured over `games` dialogues against one opponent in one who-starts condition."""

    opponent: str
    robot_starts: bool
    games: int
    win_rate: float
    draw_rate: float
    loss_rate: float
    """Share of dialogues whose game the person won."""
    declined_rate: float
    """Share of dialogues the person declined to play, and the robot let them."""
    stopped_rate: float
    """Share of dialogues whose game the person asked to stop."""
    abandoned_rate: float
    """Share of dialogues where the robot left a person who wanted to play (misheard, or a
    mistake): no game, or an unfinished one."""
    task_success: float
    """Share of dialogues that are well formed and end as the person wanted: a finished game
    with a person who wanted one (perhaps after a first no), the goodbye without a game for one
    who declines every time, the goodbye after a stop for one who asked to stop."""
    average_reward: float
    average_turns: float
    """Utterances per dialogue, robot's and person's (silences are not turns)."""
    well_formed: float
    """Share of dialogues that `check_dialogue` accepts."""
    truncated: int
    problems: dict[str, int] = field(default_factory=dict)
    policy_faults: int = 0
    """Ill-formed dialogues that are the policy's own mistakes (`wellformed.blame`); the others
    went wrong only because the robot misheard."""
    reward_std: float = 0.0
    """Standard deviation of the dialogues' rewards (for confidence intervals)."""
    asked_again: float = 0.0
    """Times per dialogue the robot asked the person to say it again (Request(repeat))."""
    transcripts: list[list[Turn]] = field(default_factory=list)
    own_faults: list[dict[str, Any]] = field(default_factory=list)
    """The first `KEPT_OWN_FAULTS` of the policy's own faults, each with its problem, the
    person's kind, the outcome, the transcript and what was understood with what score: to
    read them one by one (`bench/bench_own_faults.py`)."""

    @property
    def ill_formed(self) -> int:
        """Dialogues that `check_dialogue` refuses."""
        return round((1 - self.well_formed) * self.games)

    def summary(self) -> dict[str, Any]:
        """The figures as a plain dict (for --json), without the transcripts."""
        data = asdict(self)
        data.pop("transcripts")
        data.pop("own_faults")
        return data


WANTED = {"agrees": "game", "declines once": "game", "refuses": "declined", "stops": "stopped"}
"""How each kind of simulated person (`UserSimulator.kind`) wants the dialogue to end ("game":
a finished one, whoever won)."""


def as_wanted(person: str, outcome: str | None) -> bool:
    """True if a dialogue with this kind of person ended as they wanted."""
    ended = "game" if outcome in ("win", "draw", "loss") else outcome
    return WANTED[person] == ended


KEPT_OWN_FAULTS = 20
"""The policy's own faults an evaluation keeps whole (`EvaluationResult.own_faults`)."""


@dataclass
class _Tally:
    """What `evaluate` counts as dialogues finish."""

    keep_transcripts: int
    finished: int = 0
    outcomes: dict[str, int] = field(default_factory=lambda: dict.fromkeys(OUTCOMES, 0))
    successes: int = 0
    truncated: int = 0
    total_reward: float = 0.0
    total_squared_reward: float = 0.0
    total_asked_again: int = 0
    total_turns: int = 0
    good: int = 0
    problems: dict[str, int] = field(default_factory=dict)
    policy_faults: int = 0
    kept: list[list[Turn]] = field(default_factory=list)
    own_faults: list[dict[str, Any]] = field(default_factory=list)

    def add(self, info: dict[str, Any], terminated: bool, episode_return: float) -> None:
        self.finished += 1
        result = info["outcome"] if terminated else None
        if result is not None:
            self.outcomes[result] += 1
        else:
            self.truncated += 1
        self.total_reward += episode_return
        self.total_squared_reward += episode_return**2
        transcript = info["transcript"]
        self.total_turns += len(transcript)
        self.total_asked_again += sum(
            turn["speaker"] == "sys" and turn["act"] == ASK_AGAIN for turn in transcript
        )
        understood, scores = info.get("understood"), info.get("understood_scores")
        problem = (
            check_dialogue(transcript, result, understood, scores) if terminated else "truncated"
        )
        if problem is None:
            self.good += 1
            self.successes += as_wanted(info["person"], result)
        else:
            self.problems[problem] = self.problems.get(problem, 0) + 1
            heard = understood is not None and scores is not None and terminated
            if not heard or blame(problem, transcript, understood, scores) == "policy":
                self.policy_faults += 1
                if len(self.own_faults) < KEPT_OWN_FAULTS:
                    self.own_faults.append(
                        {
                            "problem": problem,
                            "person": info["person"],
                            "outcome": result,
                            "transcript": transcript,
                            "understood": understood,
                            "scores": scores,
                        }
                    )
        if len(self.kept) < self.keep_transcripts:
            self.kept.append(transcript)

    def result(self, opponent: str, robot_starts: bool) -> EvaluationResult:
        n = self.finished
        return EvaluationResult(
            opponent=opponent,
            robot_starts=robot_starts,
            games=n,
            win_rate=self.outcomes["win"] / n,
            draw_rate=self.outcomes["draw"] / n,
            loss_rate=self.outcomes["loss"] / n,
            declined_rate=self.outcomes["declined"] / n,
            stopped_rate=self.outcomes["stopped"] / n,
            abandoned_rate=self.outcomes["abandoned"] / n,
            task_success=self.successes / n,
            average_reward=self.total_reward / n,
            average_turns=self.total_turns / n,
            well_formed=self.good / n,
            truncated=self.truncated,
            problems=self.problems,
            policy_faults=self.policy_faults,
            transcripts=self.kept,
            own_faults=self.own_faults,
            reward_std=math.sqrt(
                max(0.0, self.total_squared_reward / n - (self.total_reward / n) ** 2)
            ),
            asked_again=self.total_asked_again / n,
        )


def evaluate(
    policy: Policy,
    opponent: str,
    robot_starts: bool,
    games: int,
    config: OxbotConfig | None = None,
    seed: int = 0,
    n_envs: int = 250,
    keep_transcripts: int = 0,
    cooperative: bool = False,
) -> EvaluationResult:
    """Play `games` dialogues with `policy` (greedy batch policy) and measure them.

    `n_envs` environments run side by side, so that the policy acts on a batch of states.
    `cooperative`: with people who always agree and play a whole game, for game play."""
    config = config if config is not None else OxbotConfig()
    n_envs = max(1, min(n_envs, games))
    envs = [
        InteractiveGameEnv(
            opponent=opponent, robot_starts=robot_starts, config=config, cooperative=cooperative
        )
        for _ in range(n_envs)
    ]
    first = [env.reset(seed=seed * 100_003 + i) for i, env in enumerate(envs)]
    states = np.stack([obs for obs, _ in first])
    masks = np.stack([info["action_mask"] for _, info in first])
    returns = np.zeros(n_envs)
    active = np.ones(n_envs, dtype=bool)
    started = n_envs
    tally = _Tally(keep_transcripts)
    while active.any():
        idx = np.flatnonzero(active)
        actions = policy(states[idx], masks[idx])
        for i, action in zip(idx, actions, strict=True):
            obs, reward, terminated, truncated, info = envs[i].step(int(action))
            returns[i] += reward
            if terminated or truncated:
                tally.add(info, terminated, returns[i])
                returns[i] = 0.0
                if started == games:
                    active[i] = False
                    continue
                obs, info = envs[i].reset()
                started += 1
            states[i] = obs
            masks[i] = info["action_mask"]
    return tally.result(opponent, robot_starts)


def format_transcript(transcript: list[Turn]) -> str:
    """A dialogue as lines like the paper's Figure 1."""
    return "\n".join(format_turn(turn) for turn in transcript)


class _DecisionStates:
    """The states a dialogue reaches at the robot's turn on a given board, in the game-tree
    check: after the person agreed and "Nice, let's play." on the empty board; else after "Your
    turn." and the person's drawing, each phrasing of a drawing heard cleanly, and
    `noisy_variants` random ones through the noisy recogniser."""

    def __init__(
        self, model: DialogueModel, robot_starts: bool, hearing: UserSimulator, noisy_variants: int
    ) -> None:
        domain = model.domain
        agreed = model.new_state(robot_starts)  # greeted, introduced, invited; the person agreed
        for act in (GREETING, INTRODUCTION, INVITATION):
            agreed.robot_says(act, domain.templates_for(act)[0])
        agreed.person_says(ACCEPT, "yes", (("yes", 1.0),), (ACCEPT, 1.0))
        self.openings = []
        for text in domain.templates_for(LETS_PLAY):
            opening = agreed.copy()
            opening.robot_says(LETS_PLAY, text)
            self.openings.append(opening)
        self.your_turn = domain.templates_for(MOVE_REQUEST)
        self.moves = hearing.phrasings(GAME_MOVE_TEMPLATE)
        self.hearing = hearing
        self.noisy_variants = noisy_variants

    def at(self, board: Board) -> np.ndarray:
        if board == EMPTY_BOARD:
            return np.stack([state.encode() for state in self.openings])
        rng = self.hearing.rng
        noisy = rng.integers(len(self.moves), size=self.noisy_variants)
        answers = [(text, False) for text in self.moves] + [(self.moves[i], True) for i in noisy]
        turns = rng.integers(len(self.your_turn), size=len(answers))
        states = []
        for (text, misheard), k in zip(answers, turns, strict=True):
            state = self.openings[0].at(
                board
            )  # "Your turn." in one of its wordings, then the drawing
            state.robot_says(MOVE_REQUEST, self.your_turn[k])
            heard, understood = self.hearing.hear(text, MOVE_REQUEST, misheard)
            state.person_says(GAME_MOVE_TEMPLATE, text, heard, understood)
            states.append(state.encode())
        return np.stack(states)


PERSON_KINDS = ("decline", "refuse", "stop", "nonsense", "silence", "out_of_turn", "rematch")
"""The simulated person's `[dialogue]` `*_probability` behaviours."""
WILLS = ("refuse", "decline", "stop")
"""The kinds of person whose will the rules are about: who says "no thanks", who says "maybe
later" and then yes, who asks to stop."""


def heard_cleanly(config: OxbotConfig, kind: str) -> OxbotConfig:
    """`config` with every simulated person of `kind` (one of PERSON_KINDS), heard without
    recognition noise."""
    only = {f"{k}_probability": float(k == kind) for k in PERSON_KINDS}
    return with_overrides(config, {"dialogue": {"asr_noise": 0.0, **only}})


def misread_wills(policy: Policy, config: OxbotConfig, games: int, seed: int = 0) -> int:
    """Dialogues, heard cleanly, that did not end as the person wanted or broke a rule: `games`
    per kind of person in WILLS (each person of that kind alone) and who starts, against the
    random person. A policy that hears right should make none."""
    missed = 0
    for kind in WILLS:
        clean = heard_cleanly(config, kind)
        for robot_starts in (True, False):
            r = evaluate(policy, "random", robot_starts, games, clean, seed=seed, n_envs=100)
            missed += games - round(r.task_success * games)
    return missed


def wins_against_random(
    policy: Policy, robot_starts: bool, config: OxbotConfig | None = None
) -> float:
    """The exact probability that the greedy policy wins against a person who draws in a
    random empty cell, each drawing heard cleanly in each of its phrasings (the game tree,
    not sampled games). Where the phrasings lead it to different cells, each counts equally;
    a board where it draws on none counts as no win. To compare with
    `oxbot.game.solver.win_probability_vs_random`, the optimum of a policy that never loses."""
    config = config if config is not None else OxbotConfig()
    model = build_dialogue_model(config)
    action_model = model.action_model
    hearing = UserSimulator(
        model.domain, rng=np.random.default_rng(0), understanding=model.understanding
    )
    decision_states = _DecisionStates(model, robot_starts, hearing, noisy_variants=0)
    values: dict[tuple[Board, bool], float] = {}

    def value(board: Board, robot_to_move: bool) -> float:
        if winner(board) == ROBOT:
            return 1.0
        if game_outcome(board) is not None:
            return 0.0
        key = (board, robot_to_move)
        if key not in values:
            if robot_to_move:
                states = decision_states.at(board)
                probs = action_model.predict_proba(states)
                masks = np.stack(
                    [action_mask(p, board, True, action_model.threshold) for p in probs]
                )
                cells = [game_move_cell(SYSTEM_ACTS[a]) for a in policy(states, masks)]
                after = [value(play(board, c, ROBOT), False) for c in cells if c is not None]
                values[key] = sum(after) / len(cells)
            else:
                cells = legal_moves(board)
                values[key] = sum(value(play(board, c, USER), True) for c in cells) / len(cells)
        return values[key]

    return value(EMPTY_BOARD, robot_starts)


def losing_positions(
    policy: Policy,
    robot_starts: bool,
    config: OxbotConfig | None = None,
    noisy_variants: int = 2,
    seed: int = 0,
) -> int:
    """Boards, reachable against *any* person, where the greedy policy can be made to lose.

    Walks the whole game tree: at every robot turn the policy sees the states a dialogue
    reaches there (`_DecisionStates`), and every cell it picks in any of these is followed;
    the person tries every empty cell. Returns how many of the robot's decision boards lead to
    a position the person wins at once, or where the policy draws on none of the hearings (on
    one, asking again for a move that was misheard wastes a turn, and is followed on the next).
    Zero means no person can beat it (up to the sampled noise).
    """
    config = config if config is not None else OxbotConfig()
    model = build_dialogue_model(config)
    action_model = model.action_model
    hearing = UserSimulator(
        model.domain,
        rng=np.random.default_rng(seed),
        asr_noise=config.dialogue.asr_noise,
        understanding=model.understanding,
    )
    decision_states = _DecisionStates(model, robot_starts, hearing, noisy_variants)
    bad: set[Board] = set()
    seen: dict[Board, set[int]] = {}
    visited: set[Board] = set()

    def choices(board: Board) -> set[int]:
        if board not in seen:
            states = decision_states.at(board)
            probs = action_model.predict_proba(states)  # one batch: the numbers of offered()
            masks = np.stack([action_mask(p, board, True, action_model.threshold) for p in probs])
            seen[board] = {int(a) for a in policy(states, masks)}
        return seen[board]

    def robot_turn(board: Board) -> None:
        picked = choices(board)
        if not any(is_game_move(a) for a in picked):
            bad.add(board)  # it never draws here (a wasted turn on one hearing is not a loss)
        for cell in (a for a in picked if is_game_move(a)):
            after = play(board, cell, ROBOT)
            if game_outcome(after) is None:
                person_turn(after, board)

    def person_turn(board: Board, decided_at: Board) -> None:
        for cell in legal_moves(board):
            after = play(board, cell, USER)
            if winner(after) == USER:
                bad.add(decided_at)
            elif game_outcome(after) is None and after not in visited:
                visited.add(after)
                robot_turn(after)

    if robot_starts:
        robot_turn(EMPTY_BOARD)
    else:
        person_turn(EMPTY_BOARD, EMPTY_BOARD)
    return len(bad)
