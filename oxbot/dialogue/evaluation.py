"""Evaluation of an interaction manager: outcomes, reward, length and well-formed dialogues.

Many environments run side by side so that the Q-network acts on a whole batch of states at
once; 10,000 games per condition take seconds, not minutes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from oxbot.config import OxbotConfig
from oxbot.dialogue.domain import FEEDBACK_ACTS, game_move_cell, words_of
from oxbot.dialogue.env import InteractiveGameEnv, format_turn
from oxbot.game.board import EMPTY_BOARD, ROBOT, USER, Board, play
from oxbot.game.board import outcome as game_outcome

Policy = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""A batch policy: (states (N, F), masks (N, 18)) -> acts (N,)."""


def check_dialogue(transcript: list[dict[str, str]], outcome: str | None) -> str | None:
    """Why a finished dialogue is not well formed, or None if it is.

    Well formed: it greets first, introduces itself and invites before the first move, asks for
    the person's move after each robot move unless the game is then over, gives exactly one
    feedback act, the one matching the real outcome, after the game, and closes last.
    """
    acts = [t["act"] for t in transcript if t["speaker"] == "sys"]
    if not acts or acts[0] != "Salutation(greeting)":
        return "does not greet first"
    first_move = next(
        (i for i, t in enumerate(transcript) if game_move_cell(t["act"]) is not None), None
    )
    if first_move is None:
        return "no game was played"
    before = {t["act"] for t in transcript[:first_move] if t["speaker"] == "sys"}
    if "Provide(name)" not in before:
        return "does not introduce itself before the first move"
    if "Request(playGame)" not in before:
        return "does not invite the person before the first move"
    feedback_at = [i for i, a in enumerate(acts) if a.startswith("Provide(feedback=")]
    board: Board = EMPTY_BOARD
    sys_index = -1
    for turn in transcript:
        if turn["speaker"] == "sys":
            sys_index += 1
        cell = game_move_cell(turn["act"])
        if cell is None:
            continue
        board = play(board, cell, ROBOT if turn["speaker"] == "sys" else USER)
        if turn["speaker"] == "sys" and game_outcome(board) is None:
            following = acts[sys_index + 1] if sys_index + 1 < len(acts) else None
            if following != "Request(userGameMove)":
                return f"does not ask for the person's move after its move {turn['act']}"
    if outcome is None:
        return "the game did not finish"
    if len(feedback_at) != 1:
        return f"gives {len(feedback_at)} feedback acts instead of one"
    if acts[feedback_at[0]] != FEEDBACK_ACTS[outcome]:
        return f"says {acts[feedback_at[0]]} but the outcome is a {outcome}"
    if acts[-1] != "Salutation(closing)" or acts.count("Salutation(closing)") != 1:
        return "does not close with a goodbye"
    return None


@dataclass
class EvaluationResult:
    """Measured over `games` dialogues against one opponent in one who-starts condition."""

    opponent: str
    robot_starts: bool
    games: int
    win_rate: float
    draw_rate: float
    loss_rate: float
    average_reward: float
    average_turns: float
    """Utterances per dialogue, robot's and person's (silences are not turns)."""
    well_formed: float
    """Share of dialogues that `check_dialogue` accepts."""
    truncated: int
    problems: dict[str, int] = field(default_factory=dict)
    transcripts: list[list[dict[str, str]]] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """The figures as a plain dict (for --json), without the transcripts."""
        data = asdict(self)
        data.pop("transcripts")
        return data


def evaluate(
    policy: Policy,
    opponent: str,
    robot_starts: bool,
    games: int,
    config: OxbotConfig | None = None,
    seed: int = 0,
    n_envs: int = 250,
    keep_transcripts: int = 0,
) -> EvaluationResult:
    """Play `games` dialogues with `policy` (greedy batch policy) and measure them."""
    config = config if config is not None else OxbotConfig()
    n_envs = max(1, min(n_envs, games))
    envs = [
        InteractiveGameEnv(opponent=opponent, robot_starts=robot_starts, config=config)
        for _ in range(n_envs)
    ]
    states, masks = [], []
    for i, env in enumerate(envs):
        obs, info = env.reset(seed=seed * 100_003 + i)
        states.append(obs)
        masks.append(info["action_mask"])
    states_arr = np.stack(states)
    masks_arr = np.stack(masks)
    returns = np.zeros(n_envs)
    active = np.ones(n_envs, dtype=bool)
    started = n_envs
    counts = {"win": 0, "draw": 0, "loss": 0}
    total_reward = 0.0
    total_turns = 0
    finished = 0
    good = 0
    truncated_games = 0
    problems: dict[str, int] = {}
    kept: list[list[dict[str, str]]] = []
    while active.any():
        idx = np.flatnonzero(active)
        actions = policy(states_arr[idx], masks_arr[idx])
        for i, action in zip(idx, actions, strict=True):
            env = envs[i]
            obs, reward, terminated, truncated, info = env.step(int(action))
            returns[i] += reward
            if terminated or truncated:
                finished += 1
                result = info["outcome"] if terminated else None
                if result is not None:
                    counts[result] += 1
                else:
                    truncated_games += 1
                total_reward += returns[i]
                transcript = info["transcript"]
                total_turns += len(transcript)
                problem = check_dialogue(transcript, result) if terminated else "truncated"
                if problem is None:
                    good += 1
                else:
                    problems[problem] = problems.get(problem, 0) + 1
                if len(kept) < keep_transcripts:
                    kept.append(transcript)
                returns[i] = 0.0
                if started < games:
                    obs, info = env.reset()
                    started += 1
                else:
                    active[i] = False
                    continue
            states_arr[i] = obs
            masks_arr[i] = info["action_mask"]
    return EvaluationResult(
        opponent=opponent,
        robot_starts=robot_starts,
        games=finished,
        win_rate=counts["win"] / finished,
        draw_rate=counts["draw"] / finished,
        loss_rate=counts["loss"] / finished,
        average_reward=total_reward / finished,
        average_turns=total_turns / finished,
        well_formed=good / finished,
        truncated=truncated_games,
        problems=problems,
        transcripts=kept,
    )


def format_transcript(transcript: list[dict[str, str]]) -> str:
    """A dialogue as lines like the paper's Figure 1."""
    return "\n".join(format_turn(turn) for turn in transcript)


def losing_positions(
    policy: Policy,
    robot_starts: bool,
    config: OxbotConfig | None = None,
    noisy_variants: int = 2,
    seed: int = 0,
) -> int:
    """Boards, reachable against *any* person, where the greedy policy can be made to lose.

    Walks the whole game tree: at every robot turn the policy sees the state the environment
    would build (after "Your turn." and the person's drawing, each of its utterances heard
    cleanly and `noisy_variants` times through the noisy recogniser), and every cell it picks
    in any of these is followed; the person tries every empty cell. Returns how many of the
    robot's decision boards lead to a position the person wins at once, or where the policy
    does not draw at all. Zero means no person can beat it (up to the sampled noise).
    """
    from oxbot.dialogue.action_model import action_mask
    from oxbot.dialogue.simulator import UserSimulator
    from oxbot.game.board import winner

    config = config if config is not None else OxbotConfig()
    env = InteractiveGameEnv(config=config)
    layout, model, domain = env.layout, env.action_model, env.domain
    hearing = UserSimulator(
        domain, rng=np.random.default_rng(seed), asr_noise=config.dialogue.asr_noise
    )
    said = ("Salutation(greeting)", "Provide(name)", "Request(playGame)", "Reply(playGame=yes)")
    moves = [u.words for u in domain.responses_to("Request(userGameMove)")]
    openers = [w for t in domain.templates_for("Reply(playGame=yes)") for w in [words_of(t)]]
    your_turn = [words_of(t) for t in domain.templates_for("Request(userGameMove)")]
    bad: set[Board] = set()
    seen: dict[Board, set[int]] = {}

    def choices(board: Board) -> set[int]:
        if board in seen:
            return seen[board]
        states = []
        if board == EMPTY_BOARD:
            contexts = [(words, ()) for words in openers]
        else:
            contexts = [
                (sys_words, heard)
                for sys_words in your_turn
                for words in moves
                for heard in [tuple((w, 1.0) for w in words)]
                + [hearing.recognise(words) for _ in range(noisy_variants)]
            ]
        for sys_words, heard in contexts:
            states.append(layout.encode(sys_words, heard, board, robot_starts, said))
        states_arr = np.stack(states)
        probs = model.predict_proba(states_arr)
        masks = np.stack([action_mask(p, board, True, config.reward.mask_threshold) for p in probs])
        picked = {int(a) for a in policy(states_arr, masks)}
        seen[board] = picked
        return picked

    def robot_turn(board: Board) -> None:
        picked = choices(board)
        if any(a >= 9 for a in picked):
            bad.add(board)
        for cell in (a for a in picked if a < 9):
            after = play(board, cell, ROBOT)
            if game_outcome(after) is None:
                person_turn(after, board)

    def person_turn(board: Board, decided_at: Board) -> None:
        for cell in (c for c, v in enumerate(board) if v == 0):
            after = play(board, cell, USER)
            if winner(after) == USER:
                bad.add(decided_at)
            elif game_outcome(after) is None and after not in visited:
                visited.add(after)
                robot_turn(after)

    visited: set[Board] = set()
    if robot_starts:
        robot_turn(EMPTY_BOARD)
    else:
        person_turn(EMPTY_BOARD, EMPTY_BOARD)
    return len(bad)
