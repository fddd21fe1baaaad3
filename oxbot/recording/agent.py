"""`oxbot learn agent`: fit the simulated person to the recorded dialogues, retrain the policy.

`fit_person` reads, from what the robot recorded (the acts its answers were understood as, and
the word confidences of what was heard through the microphone), the simulated person's
answer model (`oxbot.dialogue.simulator.UserSimulator`, the `[dialogue]` section):
- `silence_probability`: share of invitations to play that got no answer;
- `nonsense_probability`: share of the answers to invitations understood as none of the acts;
- `refuse_probability` / `decline_probability`: share of dialogues whose person said no to the
  first invitation and never agreed / agreed later; `early_refusal_probability`: share of those
  who said no already to the greeting or introduction;
- `stop_probability`: share of the people who agreed and then asked to stop;
- `asr_noise`: the noise level n whose expected word confidence in the simulator
  ((n/4)·0.35 + (1-n/2)², over the 1-n/4 words not dropped) matches the recorded mean;
  typed answers (confidence 1) are left out, and without spoken ones the default stays;
- `phrasing_weights`: how often each of the domain's phrasings of an act was heard word for
  word, divided by the chance ((1 - n/2) per word) that the noisy recogniser leaves a phrasing
  of its length whole, plus one; the simulated person then says them in those proportions.

`learn_agent` then fine-tunes the policy (`init_from` the shipped one, with the shipped agent's
config, `agent.toml`) in that simulator for a short budget, in `chunks` pieces, keeping the
piece that does best against other simulated people of the same kind (or the shipped policy),
and measures both policies in the same run against the same fitted people: repeated questions
per dialogue (the robot asking again, `Request(repeat)`, or asking the same question twice in a
row), well-formed dialogues, losses and task success. A policy with more ill-formed dialogues
(all, or by its own fault), more losses or more repeated questions than before, or no piece
better than the shipped policy, is refused
(`LearningRefused`), its figures written to `learn_agent.refused.json` (the kept policy's
`learn_agent.json` stays); otherwise written with its config, seed and figures. Each file is
registered as derived from the sessions before it is written.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import tempfile
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from oxbot.atomic import write_text_atomic
from oxbot.config import DialogueConfig, OxbotConfig, load_config, with_overrides
from oxbot.dialogue.agent import DQNPolicy, load_policy, shipped_policy_path
from oxbot.dialogue.asides import ASIDE_ACTS
from oxbot.dialogue.domain import (
    ACCEPT,
    ASK_AGAIN,
    GREETING,
    INTRODUCTION,
    INVITATION,
    MOVE_REQUEST,
    REFUSALS,
    SAID_OUTSIDE_THE_POLICY,
    STOP,
    UNKNOWN,
    Turn,
)
from oxbot.dialogue.evaluation import evaluate
from oxbot.errors import DataError, LearningRefused
from oxbot.recording.derived import make_private
from oxbot.recording.store import RecordingStore

log = logging.getLogger(__name__)

ASKED_TWICE = frozenset({INVITATION, MOVE_REQUEST})
"""Questions that, said twice in a row, mean the robot asked again."""


@dataclass(frozen=True)
class LearnAgentConfig:
    """How the policy is retrained on the fitted person (oxbot; the paper has no such step)."""

    seed: int = 0
    """Seed of the fine-tuning and of the evaluation's simulated people."""
    steps: int = 30_000
    """Experiences of fine-tuning (the shipped policy had 700,000)."""
    epsilon_start: float = 0.1
    """Exploration at the start of the fine-tune (falls to the minimum over half the run)."""
    learning_rate: float = 0.0002
    """Adam step size (the shipped run started at 0.001 and annealed to 0)."""
    eval_games: int = 1_000
    """Dialogues per who-starts condition in the before/after measurement."""
    opponent: str = "random"
    """How the measured people play (`oxbot evaluate agent --opponent`)."""
    min_dialogues: int = 20
    """Fewer recorded dialogues than this are too few to fit a person to."""
    chunks: int = 5
    """The fine-tune runs in this many pieces, each measured on other simulated people
    (`select_games`); the best piece (fewest losses, then dialogues ill formed by the policy's
    own fault, then all ill-formed ones, then repeated questions) that asks again no more often
    than the shipped policy is kept, the shipped policy if none beats it."""
    select_games: int = 300
    """Dialogues per who-starts condition in each piece's measurement (other seeds than the
    before/after measurement's, so that choosing does not flatter the reported figures)."""

    def __post_init__(self) -> None:
        if min(self.steps, self.eval_games, self.chunks, self.select_games) < 1:
            raise DataError("steps, eval_games, chunks and select_games must be >= 1")


@dataclass
class PersonModel:
    """The simulated person's answer model, as fitted to recorded dialogues."""

    dialogues: int
    spoken_words: int
    """Words heard through the microphone that `asr_noise` was fitted on."""
    probabilities: dict[str, float]
    """`[dialogue]` fields: asr_noise, decline/refuse/early_refusal/stop/silence/nonsense."""
    phrasings: dict[str, dict[str, int]] = field(default_factory=dict)
    """For each act understood, the texts heard for it and how often."""
    phrasing_weights: dict[str, dict[str, float]] = field(default_factory=dict)
    """For each act, the weight of each domain phrasing heard word for word (see above)."""
    repeated_share: float = 0.0
    """Share of the recorded answers after which the robot asked again."""

    def dialogue_config(self, base: DialogueConfig) -> dict[str, Any]:
        """The overrides of `base` this fit gives (what the recordings could tell)."""
        overrides: dict[str, Any] = {
            k: round(v, 4) for k, v in self.probabilities.items() if hasattr(base, k)
        }
        if self.phrasing_weights:
            overrides["phrasing_weights"] = json.dumps(self.phrasing_weights, sort_keys=True)
        return overrides


def fit_phrasing_weights(
    heard: dict[str, dict[str, int]], known: dict[str, tuple[str, ...]], noise: float
) -> dict[str, dict[str, float]]:
    """Weights of the known phrasings of each act from how often each was heard word for word
    (`heard`: act -> text -> count), corrected for the recogniser leaving longer ones whole
    less often, plus one so that an unheard phrasing stays possible."""
    weights: dict[str, dict[str, float]] = {}
    for act, texts in heard.items():
        phrasings = set(known.get(act, ()))
        counts = {t: c for t, c in texts.items() if t in phrasings}
        if counts:
            whole = {t: (1.0 - noise / 2) ** max(len(t.split()), 1) for t in counts}
            weights[act] = {t: round(1.0 + c / whole[t], 3) for t, c in sorted(counts.items())}
    return weights


def expected_confidence(noise: float) -> float:
    """Mean confidence of a heard word in `UserSimulator.recognize` at noise level `noise`."""
    kept = 1.0 - noise / 4
    return ((noise / 4) * 0.35 + (1 - noise / 2) * (1 - noise / 2)) / kept


def noise_for(mean_confidence: float) -> float:
    """The noise level whose expected word confidence is `mean_confidence` (bisection)."""
    low, high = 0.0, 1.0
    for _ in range(40):
        mid = (low + high) / 2
        if expected_confidence(mid) > mean_confidence:
            low = mid
        else:
            high = mid
    return (low + high) / 2


_AROUND_THE_POLICY = frozenset((*SAID_OUTSIDE_THE_POLICY, *ASIDE_ACTS.values()))


def fit_person(
    dialogues: list[dict[str, Any]],
    default: DialogueConfig,
    known_phrasings: dict[str, tuple[str, ...]] | None = None,
) -> PersonModel:
    """The answer model of the people in `dialogues` (`RecordingStore.dialogues`);
    `known_phrasings` (act -> the simulator's texts, default the shipped domain's) are the
    ones whose frequencies are fitted."""
    invitations = silent = answered = nonsense = 0
    refuses = declines_once = early = agreed = stopped = 0
    words: list[float] = []
    phrasings: dict[str, Counter[str]] = {}
    repeated = answers_n = 0
    for d in dialogues:
        # the policy's dialogue: without the manager's sentences around it (a problem on the
        # sheet, an answer in passing, the offer of another game) and the questions they answer
        turns = [t for t in d["turns"] if t["act"] not in _AROUND_THE_POLICY]
        first_answer: str | None = None
        said_yes = said_no_early = asked_stop = False
        for i, turn in enumerate(turns):
            after = turns[i + 1] if i + 1 < len(turns) else None
            if turn["speaker"] == "sys" and turn["act"] == INVITATION:
                invitations += 1
                if after is None or after["speaker"] != "usr":
                    silent += 1
                else:
                    answered += 1
                    nonsense += after["act"] == UNKNOWN
                    if first_answer is None and after["act"] != UNKNOWN:
                        first_answer = after["act"]
            if turn["speaker"] != "usr":
                continue
            if turn["act"] == ACCEPT:
                said_yes = True
            if turn["act"] == STOP and said_yes:
                asked_stop = True
            before = turns[i - 1] if i else None
            if (
                turn["act"] in REFUSALS
                and before is not None
                and before["act"] in (GREETING, INTRODUCTION)
            ):
                said_no_early = True
        said_no = first_answer in REFUSALS or said_no_early
        if said_no and said_yes:
            declines_once += 1
        elif said_no:
            refuses += 1
        early += said_no and said_no_early
        agreed += said_yes
        stopped += asked_stop
        for a in d["answers"]:
            answers_n += 1
            repeated += bool(a["repeated"])
            if a["understood"] and a["nbest"]:
                texts = phrasings.setdefault(a["understood"], Counter())
                texts[a["nbest"][0][0]] += 1
            if a["source"] == "microphone":
                words += [float(c) for _, c in a["words"]]
    n = max(len(dialogues), 1)
    probabilities = {
        "silence_probability": silent / invitations if invitations else default.silence_probability,
        "nonsense_probability": nonsense / answered if answered else default.nonsense_probability,
        "refuse_probability": refuses / n,
        "decline_probability": declines_once / n,
        "early_refusal_probability": (
            early / (refuses + declines_once)
            if refuses + declines_once
            else default.early_refusal_probability
        ),
        "stop_probability": stopped / agreed if agreed else default.stop_probability,
        "asr_noise": noise_for(sum(words) / len(words)) if words else default.asr_noise,
    }
    if known_phrasings is None:
        from oxbot.dialogue.model import shipped_dialogue_model
        from oxbot.dialogue.simulator import phrasings_of

        known_phrasings = phrasings_of(shipped_dialogue_model().domain)
    heard = {act: dict(c.most_common()) for act, c in phrasings.items()}
    return PersonModel(
        dialogues=len(dialogues),
        spoken_words=len(words),
        probabilities=probabilities,
        phrasings=heard,
        phrasing_weights=fit_phrasing_weights(heard, known_phrasings, probabilities["asr_noise"]),
        repeated_share=repeated / answers_n if answers_n else 0.0,
    )


def asks_again(act: str, previous: str | None) -> bool:
    """Whether the robot's `act`, after its `previous` act, asks again: `Request(repeat)`, or
    the same question twice in a row."""
    return act == ASK_AGAIN or (act == previous and act in ASKED_TWICE)


def repeated_questions(transcript: list[Turn]) -> int:
    """How often the robot asked again in a dialogue (`asks_again`)."""
    count, previous = 0, None
    for turn in transcript:
        if turn["speaker"] != "sys":
            continue
        count += asks_again(turn["act"], previous)
        previous = turn["act"]
    return count


def measure(
    policy: DQNPolicy, config: OxbotConfig, games: int, seed: int, opponent: str = "random"
) -> dict[str, Any]:
    """A policy's dialogues with the simulated people of `config`, both who-starts conditions:
    repeated questions per dialogue, well-formed share, losses, task success."""
    results = [
        evaluate(
            policy.act_batch,
            opponent,
            starts,
            games,
            config,
            seed=seed,
            keep_transcripts=games,
        )
        for starts in (True, False)
    ]
    transcripts = [t for r in results for t in r.transcripts]
    repeats = [repeated_questions(t) for t in transcripts]
    total = sum(r.games for r in results)
    return {
        "dialogues": total,
        "repeated_questions_per_dialogue": sum(repeats) / len(repeats),
        "dialogues_with_a_repeat": sum(r > 0 for r in repeats) / len(repeats),
        "ill_formed": sum(r.ill_formed for r in results),
        "ill_formed_by_the_policy": sum(r.policy_faults for r in results),
        "losses": sum(round(r.loss_rate * r.games) for r in results),
        "task_success": sum(r.task_success * r.games for r in results) / total,
        "average_turns": sum(r.average_turns * r.games for r in results) / total,
        "problems": dict(sum((Counter(r.problems) for r in results), Counter())),
    }


@dataclass
class LearnAgentResult:
    policy: DQNPolicy
    person: PersonModel
    metrics: dict[str, Any]
    policy_path: Path | None
    metrics_path: Path | None


def shipped_agent_config() -> OxbotConfig:
    """The configuration the shipped policy was trained with (`agent.toml` beside it)."""
    return load_config(shipped_policy_path().with_suffix(".toml"))


def learn_agent(
    store: RecordingStore,
    out_dir: str | Path | None,
    config: LearnAgentConfig | None = None,
    session_ids: list[int] | None = None,
    show_progress: bool = True,
) -> LearnAgentResult:
    """Fit the person to the recorded dialogues, fine-tune the shipped policy in that
    simulator and measure both (see the module docstring). Nothing is written when `out_dir` is
    None."""
    config = config if config is not None else LearnAgentConfig()
    store.check_integrity()  # never learn from a damaged file
    dialogues = [d for d in store.dialogues(session_ids) if d["turns"]]
    if len(dialogues) < config.min_dialogues:
        raise DataError(
            f"{len(dialogues)} recorded dialogues in {store.path}; learning the agent needs at "
            f"least {config.min_dialogues} (oxbot play --record)"
        )
    sessions = [d["id"] for d in dialogues]
    base = shipped_agent_config()
    person = fit_person(dialogues, base.dialogue)
    fitted = _fitted_config(base, person, config)
    shipped = load_policy()
    before = measure(shipped, fitted, config.eval_games, config.seed, config.opponent)
    policy, best, pieces, seconds = _fine_tune(shipped, fitted, config, show_progress)
    after = measure(policy, fitted, config.eval_games, config.seed, config.opponent)
    worse = [k for k in _MUST_NOT_RISE if after[k] > before[k]]
    if policy is shipped:
        worse.append("no piece of the fine-tune beat the shipped policy")
    metrics = {
        "sessions": sessions,
        "person": dataclasses.asdict(person),
        "before": before,
        "after": after,
        "refused": worse,
        "config": dataclasses.asdict(config),
        "trained_config": dataclasses.asdict(fitted),
        "training_seconds": round(seconds, 1),
        "pieces": pieces,
        "kept": next((p["steps"] for p in pieces if p["score"] == best), 0),
    }
    policy.metadata.update(
        learned_from_sessions=sessions,
        learn_config=dataclasses.asdict(config),
        person=person.probabilities,
        before=before,
        after=after,
    )
    policy_path = metrics_path = None
    if out_dir is not None:
        out_dir = Path(out_dir)
        # a refused policy's figures go beside the kept policy's, never over them
        metrics_path = out_dir / ("learn_agent.refused.json" if worse else "learn_agent.json")
        written = [metrics_path] + ([] if worse else [out_dir / "agent.pt"])
        store.register_derived(written, sessions, "agent")  # before: nothing unregistered
        write_text_atomic(metrics_path, json.dumps(metrics, indent=2) + "\n")
        if not worse:
            policy_path = out_dir / "agent.pt"
            policy.save(policy_path)
        make_private(written)
    result = LearnAgentResult(policy, person, metrics, policy_path, metrics_path)
    if worse:
        raise LearningRefused(
            "the retrained policy is refused: "
            + ", ".join(f"{k} {before[k]} -> {after[k]}" if k in before else k for k in worse)
            + (f"; see {metrics_path}" if metrics_path else ""),
            result,
        )
    return result


_MUST_NOT_RISE = (
    "ill_formed",
    "ill_formed_by_the_policy",
    "losses",
    "repeated_questions_per_dialogue",
)
"""What a retrained policy must not do more often than the shipped one, against the fitted
people: a policy that asked again a little more often than before was once kept because it was
ill formed less often, and the person meets the repeats."""


def _fitted_config(base: OxbotConfig, person: PersonModel, config: LearnAgentConfig) -> OxbotConfig:
    """The shipped training config with the fitted person, and the fine-tune's schedule."""
    return with_overrides(
        base,
        {
            "dialogue": person.dialogue_config(base.dialogue),
            "agent": {
                "seed": config.seed,
                "total_steps": config.steps,
                "learning_starts": min(base.agent.learning_starts, config.steps // 2),
                "epsilon_start": config.epsilon_start,
                "learning_rate": config.learning_rate,
                "eval_every": 0,  # measured by `learn_agent`, before and after alike
                "anneal_learning_rate": True,
            },
        },
    )


def _fine_tune(
    shipped: DQNPolicy, fitted: OxbotConfig, config: LearnAgentConfig, show_progress: bool
) -> tuple[DQNPolicy, tuple[float, ...], list[dict[str, Any]], float]:
    """Fine-tune `shipped` in `config.chunks` pieces, each from the last; the best policy met
    (the shipped one if no piece beat it), its score, each piece's score, and the seconds."""
    from oxbot.dialogue.training import train_agent

    def score(policy: DQNPolicy) -> tuple[float, float, float, float]:
        m = measure(policy, fitted, config.select_games, config.seed + 1_000, config.opponent)
        return (
            m["losses"],
            m["ill_formed_by_the_policy"],
            m["ill_formed"],
            m["repeated_questions_per_dialogue"],
        )

    def beats(score: tuple[float, ...], other: tuple[float, ...]) -> bool:
        # better in its order, and never asking again more often than the shipped policy
        return score < other and score[-1] <= shipped_score[-1]

    shipped_score = score(shipped)
    policy, best, pieces = shipped, shipped_score, []
    current, seconds = shipped, 0.0
    piece = max(1, config.steps // config.chunks)
    for k in range(config.chunks):
        starts = min(fitted.agent.learning_starts, piece // 2)
        chunk = {"seed": config.seed + k, "total_steps": piece, "learning_starts": starts}
        chunk_config = with_overrides(fitted, {"agent": chunk})
        with tempfile.TemporaryDirectory() as work:
            trained = train_agent(
                chunk_config,
                Path(work),
                resume=False,
                show_progress=show_progress,
                init_from=current,
            )
        current, seconds = trained.policy, seconds + trained.metrics["wall_clock_s"]
        pieces.append({"steps": piece * (k + 1), "score": score(current)})
        if beats(pieces[-1]["score"], best):
            policy, best = current, pieces[-1]["score"]
    return policy, best, pieces, seconds
