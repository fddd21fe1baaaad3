"""The dialogue domain: the acts, named once, and the parser of the domain files.

The domain lives in three plain text files under `oxbot/data/dialogue/`, in a format like
SimpleDS's. Every utterance is one line, `SPEAKER:[Act]"words"`:

    SYS:[Salutation(greeting)]"Hello!"
    USR:[Confirm(playGame=yes)]"Yes, let's go."
    SYS:[GameMove(gridloc=lowermiddle)]"I take this one [who=rob what=draw where=lowermiddle]"

- `dialogues.txt`: the 10 seed dialogues, one utterance per line, a blank line between
  dialogues. A drawing is written in square brackets like the paper's Figure 1
  (`[who=usr what=draw where=middle]`); it must name the act's `gridloc`, an empty cell, and
  the game must end with the feedback act of its real outcome.
- `templates.txt`: `SYS:[Act]"words"` lines, one or more per system act (every act must have one);
  `$loc` stands for the cell in the GameMove template.
- `user_responses.txt`: `SystemAct => USR:[UserAct]"words"` lines, the person's alternatives to
  each system act (`""` is silence).
- `user_phrases.txt` (optional): `[UserAct]` sections of the many ways people say each act,
  one a line; the language understanding learns from them and the recogniser listens for them.

Lines starting with `#` are comments. The vocabulary is every word of the templates and the user
responses (lower-cased; bracketed game-move tags are actions, not words); every word of the seed
dialogues must be in it. Every problem is a `DataError` naming the file and line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from oxbot.errors import DataError, IllegalMoveError
from oxbot.game.board import (
    CELL_NAMES,
    EMPTY_BOARD,
    N_CELLS,
    ROBOT,
    USER,
    Board,
    outcome,
    play,
)

# --- the acts, named once ---------------------------------------------------------------------
# The robot's acts other than its moves; the person greets and says goodbye with the
# same acts as the robot.
GREETING = "Salutation(greeting)"
CLOSING = "Salutation(closing)"
INTRODUCTION = "Provide(name)"
INVITATION = "Request(playGame)"
LETS_PLAY = "Reply(playGame=yes)"
MOVE_REQUEST = "Request(userGameMove)"
FEEDBACK_WIN = "Provide(feedback=win)"
FEEDBACK_DRAW = "Provide(feedback=draw)"
FEEDBACK_LOSS = "Provide(feedback=loose)"
"""The paper's spelling."""
ASK_AGAIN = "Request(repeat)"
"""oxbot: "Sorry, I didn't catch that. Shall we play?" when the answer was not understood."""
GRANT_REFUSAL = "Acknowledge(playGame=no)"
"""oxbot: "Okay, maybe another time." after the person declines, before the goodbye."""
GRANT_STOP = "Acknowledge(stop)"
"""oxbot: "Okay, let's stop here." after the person asks to stop mid-game."""

# The person's acts.
ACCEPT = "Confirm(playGame=yes)"
DECLINE = "Reject(playGame=no)"
POSTPONE = "Reject(playGame=later)"
"""A decline for now ("maybe later"): the robot takes it as a no."""
STOP = "Request(stop)"
NEW_GAME = "Request(newGame)"
"""Another game, a rematch ("again!", "one more")."""
THANKS = "Thank"
WHO_STARTS = "Request(whoStarts)"
I_START = "Request(userStarts)"
COMPLAINT = "Complain"
ACKNOWLEDGE = "Acknowledge"
SILENCE = "Silence"
"""The person said nothing (or nothing was heard)."""
UNKNOWN = "Unknown"
"""The person said something that matches no phrase of the domain."""

PROBLEM = "Inform(problem)"
"""The robot's fixed sentences about impossible drawings: said, never chosen by the policy."""
ANSWER = "Inform(answer)"
"""The robot's answer to a question asked in passing ("who starts?", "what's your name?",
"can you repeat that?": `oxbot.dialogue.asides`): said, never chosen by the policy."""
OFFER_ANOTHER = "Request(anotherGame)"
"""oxbot: "Would you like another game?" after a game, before the goodbye the policy chose:
said, never chosen by the policy. A yes to it starts the next game without a goodbye, a
greeting or an introduction."""
AFTER_ALL = "Request(playAfterAll)"
"""oxbot: "Do you want to play after all?" when "Okay, maybe another time." is answered with a bare
yes, which may agree that it is for another time or take the no back: said, never chosen by the
policy. A yes to it is the person's yes to playing."""
STOP_QUESTION = "Request(confirmStop)"
"""oxbot: "Do you want to stop?" when the person's words mid-game were heard as a stop too unsure
for the policy, which would ask for their move instead: said, never chosen by the policy. A yes
to it is the stop said again; a no, their yes to playing on."""
YES_QUESTION = "Request(confirmYes)"
"""oxbot: "Sorry, was that a yes?" when the answer to "Shall we play?" was heard as a yes too
unsurely to start a game on: said, never chosen by the policy. A yes to it is the person's yes
to playing; a no, their no."""
SAID_OUTSIDE_THE_POLICY = (PROBLEM, ANSWER, OFFER_ANOTHER, AFTER_ALL, STOP_QUESTION, YES_QUESTION)
"""The robot's acts that its interaction manager says around the policy's."""

MOVE_ACT_TYPE = "GameMove"
"""The type of every move act, whatever its cell."""
_MOVE_PREFIX = MOVE_ACT_TYPE + "(gridloc="
GAME_MOVE_TEMPLATE = _MOVE_PREFIX + "$loc)"
"""A GameMove on any cell, as the domain files write it."""


def game_move(cell: int) -> str:
    """The act of a drawing on `cell`: `GameMove(gridloc=middle)`."""
    return f"{_MOVE_PREFIX}{CELL_NAMES[cell]})"


GAME_MOVES: tuple[str, ...] = tuple(game_move(cell) for cell in range(N_CELLS))
SYSTEM_ACTS: tuple[str, ...] = (
    *GAME_MOVES,
    FEEDBACK_DRAW,
    FEEDBACK_LOSS,
    FEEDBACK_WIN,
    INTRODUCTION,
    LETS_PLAY,
    INVITATION,
    MOVE_REQUEST,
    CLOSING,
    GREETING,
    ASK_AGAIN,
    GRANT_REFUSAL,
    GRANT_STOP,
)
"""The paper's 18 actions, in its order: first a GameMove on each cell (the act's index
is its cell's), then the rest; oxbot's own acts follow. A new act goes at the end, with its
templates, its user responses and a seed dialogue that uses it (the action model never offers
an act no seed dialogue shows)."""
PAPER_ACTS = SYSTEM_ACTS[:18]
"""The paper's 18 acts."""
N_ACTIONS = len(SYSTEM_ACTS)
ACTION_INDEX: dict[str, int] = {act: i for i, act in enumerate(SYSTEM_ACTS)}

FEEDBACK_ACTS: dict[str, str] = {"win": FEEDBACK_WIN, "draw": FEEDBACK_DRAW, "loss": FEEDBACK_LOSS}
"""The feedback act that matches each outcome (from the robot's side)."""

USER_ACTS: tuple[str, ...] = (
    GREETING,
    CLOSING,
    ACCEPT,
    DECLINE,
    POSTPONE,
    STOP,
    NEW_GAME,
    THANKS,
    WHO_STARTS,
    I_START,
    COMPLAINT,
    ACKNOWLEDGE,
    GAME_MOVE_TEMPLATE,
    SILENCE,
    UNKNOWN,
)
"""The person's acts; `GameMove(gridloc=$loc)` stands for a drawing on any cell."""
REFUSALS = frozenset({DECLINE, POSTPONE})
"""The person's answers that mean no to a game."""
Turn = dict[str, str]
"""One transcript entry (`info["transcript"]`):
`{"speaker": "sys" | "usr", "act": ..., "text": ...}`."""

SURE_NO = 0.6
"""A "no thanks" or a stop understood with at least this score is clear: the robot lets it go
at once. Below it (an accept misheard as a no keeps a lower score 92-100% of the time on the
simulated recogniser at noise 0.2-0.4) the robot may check once. See docs/dialogue.md."""
ANSWERS_ABOUT_PLAYING = frozenset({ACCEPT, STOP, *REFUSALS})
"""A yes, a no or a stop: the answers whose last one says what the person wants."""
ANSWERS_TO_PLAY = frozenset({ACCEPT, STOP, CLOSING, *REFUSALS})
"""What answers a question to play; anything else (silence, chatter, a "thank you", a greeting)
it could not make out as an answer, and asking again about it does not count."""
_ACCEPT_FAMILY = ACCEPT.split("=", 1)[0]
_REFUSAL_FAMILY = DECLINE.split("=", 1)[0]


def accepts_game(act: str) -> bool:
    """Whether a person's act says yes to a game: `Confirm(playGame=yes)` or any act of its
    family (`Confirm(playGame…)`) that a domain may name, so that a measure of yes and no
    survives a domain with more acts."""
    return act.startswith(_ACCEPT_FAMILY)


def refuses_game(act: str) -> bool:
    """Whether a person's act says no to a game, now or for now: any `Reject(playGame…)`."""
    return act.startswith(_REFUSAL_FAMILY)


def game_move_cell(act: str) -> int | None:
    """The cell index of a `GameMove(gridloc=...)` act, or None for any other act."""
    if act.startswith(_MOVE_PREFIX) and act.endswith(")"):
        name = act[len(_MOVE_PREFIX) : -1]
        if name in CELL_NAMES:
            return CELL_NAMES.index(name)
    return None


def plays(act: str) -> bool:
    """True for a system act that starts or plays a game: "let's play" or a drawing."""
    return act == LETS_PLAY or is_game_move(act)


def acts_on_an_answer(act: str) -> bool:
    """True for a system act that acts on what the person answered or drew: "let's play",
    "your turn" and the robot's moves go on with a game they agreed to, the acknowledgements
    let their no or their stop go. Until the person says something new, the robot must not say
    it did not catch the answer (`ASK_AGAIN`) after one of these."""
    return act in _ACTING or is_game_move(act)


def starts_game(act: str) -> bool:
    """True for a system act after which the game is on: one that `plays`, or asking for the
    person's move (a person who starts is asked without a "let's play")."""
    return plays(act) or act == MOVE_REQUEST


def is_game_move(act: str | int) -> bool:
    """True for a drawing, given as an act (any cell, or `$loc`) or as an index of SYSTEM_ACTS."""
    if isinstance(act, str):
        return act.startswith(_MOVE_PREFIX)
    return 0 <= act < N_CELLS


def is_feedback(act: str) -> bool:
    """True for the robot's feedback on the game's outcome."""
    return act in _FEEDBACK


_FEEDBACK = frozenset(FEEDBACK_ACTS.values())
_ACTING = frozenset({LETS_PLAY, MOVE_REQUEST, GRANT_REFUSAL, GRANT_STOP})


def draw_tag(who: str, cell: int | str) -> str:
    """The paper's bracketed drawing, `[who=usr what=draw where=middle]` (`who`: usr or rob)."""
    where = cell if isinstance(cell, str) else CELL_NAMES[cell]
    return f"[who={who} what=draw where={where}]"


_UTTERANCE = re.compile(r'^(SYS|USR):\[([^\]]*)\]"([^"]*)"$')
_RESPONSE = re.compile(r"^(\S+)\s*=>\s*(.*)$")
_TAG = re.compile(r"\[who=(\w+) what=draw where=([\w$]+)\]")
_WORD = re.compile(r"[a-z]+(?:'[a-z]+)?")


def words_of(text: str) -> list[str]:
    """The spoken words of an utterance, lower-cased, without its bracketed game-move tag."""
    return _WORD.findall(_TAG.sub(" ", text.lower()))


@dataclass(frozen=True)
class DomainLine:
    """One line of a domain file: who speaks, the dialogue act, the words (and a drawing)."""

    speaker: str
    """`SYS` (the robot) or `USR` (the person)."""
    act: str
    text: str
    source: str = ""
    """`file:line` the utterance was read from, for error messages."""

    @property
    def words(self) -> list[str]:
        return words_of(self.text)

    @property
    def cell(self) -> int | None:
        """The cell this utterance draws on, or None."""
        return game_move_cell(self.act)


@dataclass(frozen=True)
class Domain:
    """Everything the action model, the simulator and the environment learn from."""

    dialogues: tuple[tuple[DomainLine, ...], ...]
    templates: dict[str, tuple[str, ...]]
    """System act (`GameMove(gridloc=$loc)` for every cell) -> its template texts."""
    responses: dict[str, tuple[DomainLine, ...]]
    """System act (`GameMove(gridloc=$loc)` for every cell) -> the person's alternatives."""
    vocabulary: tuple[str, ...]
    """The words of the templates and user responses, in order of first appearance."""
    phrasings: dict[str, tuple[str, ...]] = field(default_factory=dict)
    """User act -> how people say it (`user_phrases.txt`), normalised words."""

    def templates_for(self, act: str) -> tuple[str, ...]:
        """The template texts of a system act, with `$loc` filled for a GameMove."""
        cell = game_move_cell(act)
        if cell is None:
            return self.templates[act]
        return tuple(
            t.replace("$loc", CELL_NAMES[cell]) for t in self.templates[GAME_MOVE_TEMPLATE]
        )

    def user_utterances(self) -> list[DomainLine]:
        """Everything the person says in the domain's dialogues: the response alternatives,
        then the seed dialogues' USR lines."""
        spoken = [u for alternatives in self.responses.values() for u in alternatives]
        spoken += [u for dialogue in self.dialogues for u in dialogue if u.speaker == "USR"]
        return spoken

    def user_phrases(self) -> list[tuple[str, str]]:
        """(words, user act) of everything the person may say: the phrasings, the response
        alternatives and the seed dialogues' USR lines, each once; a drawing's act is
        `GameMove(gridloc=$loc)` whatever its cell."""
        found: dict[tuple[str, str], None] = {}
        for act, phrasings in self.phrasings.items():
            found.update(dict.fromkeys((text, act) for text in phrasings))
        for utterance in self.user_utterances():
            act = GAME_MOVE_TEMPLATE if is_game_move(utterance.act) else utterance.act
            if utterance.words and act != SILENCE:
                found[" ".join(utterance.words), act] = None
        return list(found)

    def responses_to(self, act: str) -> tuple[DomainLine, ...]:
        """The person's alternatives to a system act (empty means silence)."""
        key = GAME_MOVE_TEMPLATE if game_move_cell(act) is not None else act
        return self.responses.get(key, ())


def _lines(path: Path) -> list[tuple[int, str]]:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DataError(f"{path} does not exist; the dialogue domain needs it") from None
    except IsADirectoryError:
        raise DataError(f"{path} is a folder; the dialogue domain needs a text file") from None
    except OSError as exc:
        raise DataError(f"{path} cannot be read ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise DataError(f"{path} is not UTF-8 text: {exc}") from None
    return [(n, line.strip()) for n, line in enumerate(text.splitlines(), start=1)]


def parse_utterance(line: str, where: str, speaker: str | None = None) -> DomainLine:
    """One `SPEAKER:[Act]"words"` line, checked; `where` is `file:line` for the error message."""
    match = _UTTERANCE.match(line)
    if match is None:
        raise DataError(
            f'{where}: malformed line {line!r}; write SYS:[Act]"words" or USR:[Act]"words"'
        )
    who, act, text = match.groups()
    if speaker is not None and who != speaker:
        raise DataError(f"{where}: expected a {speaker}: line, got {who}:")
    known = (*SYSTEM_ACTS, GAME_MOVE_TEMPLATE) if who == "SYS" else USER_ACTS + GAME_MOVES
    if act not in known:
        kind = "system" if who == "SYS" else "user"
        listed = [a for a in known if a not in GAME_MOVES and a != GAME_MOVE_TEMPLATE]
        listed.append("GameMove(gridloc=<cell>)")
        raise DataError(f"{where}: unknown {kind} act {act!r}; {kind} acts are {', '.join(listed)}")
    tags = _TAG.findall(text)
    if is_game_move(act):
        expected = ("rob" if who == "SYS" else "usr", act[len(_MOVE_PREFIX) : -1])
        if tags != [expected]:
            raise DataError(
                f"{where}: {act} must draw with [who={expected[0]} what=draw where={expected[1]}]"
            )
    elif tags or "[" in text:
        raise DataError(f"{where}: only a GameMove act may carry a [who=... what=draw ...] tag")
    return DomainLine(who, act, text, where)


def parse_templates(path: Path) -> dict[str, tuple[str, ...]]:
    """The system templates file: act -> texts; every system act must have one."""
    templates: dict[str, list[str]] = {}
    for n, line in _lines(path):
        if not line or line.startswith("#"):
            continue
        utterance = parse_utterance(line, f"{path.name}:{n}", speaker="SYS")
        if utterance.cell is not None:
            raise DataError(
                f"{path.name}:{n}: write the GameMove template once, as {GAME_MOVE_TEMPLATE}"
            )
        templates.setdefault(utterance.act, []).append(utterance.text)
    needed = [a for a in SYSTEM_ACTS if a not in GAME_MOVES] + [GAME_MOVE_TEMPLATE]
    missing = [a for a in needed if a not in templates]
    if missing:
        raise DataError(f"{path.name} has no template for {', '.join(missing)}; add a line each")
    return {act: tuple(texts) for act, texts in templates.items()}


def parse_responses(path: Path) -> dict[str, tuple[DomainLine, ...]]:
    """The user responses file: system act -> the person's alternative utterances."""
    responses: dict[str, list[DomainLine]] = {}
    for n, line in _lines(path):
        if not line or line.startswith("#"):
            continue
        where = f"{path.name}:{n}"
        match = _RESPONSE.match(line)
        if match is None:
            raise DataError(
                f'{where}: malformed line {line!r}; write SystemAct => USR:[UserAct]"words"'
            )
        system_act, rest = match.groups()
        if system_act not in (*SYSTEM_ACTS, GAME_MOVE_TEMPLATE) or system_act in GAME_MOVES:
            raise DataError(
                f"{where}: unknown system act {system_act!r}; use one of the {N_ACTIONS} system "
                f"acts, with {GAME_MOVE_TEMPLATE} for the robot's moves"
            )
        utterance = parse_utterance(rest, where, speaker="USR")
        if utterance.cell is not None:
            raise DataError(f"{where}: write a person's drawing as {GAME_MOVE_TEMPLATE}")
        responses.setdefault(system_act, []).append(utterance)
    return {act: tuple(alternatives) for act, alternatives in responses.items()}


_SECTION = re.compile(r"^\[([^\]]+)\]$")


def parse_phrasings(path: Path) -> dict[str, tuple[str, ...]]:
    """The user phrases file: `[UserAct]` sections of one phrasing a line (see its header)."""
    phrasings: dict[str, list[str]] = {}
    act: str | None = None
    for n, line in _lines(path):
        if not line or line.startswith("#"):
            continue
        where = f"{path.name}:{n}"
        section = _SECTION.match(line)
        if section is not None:
            act = section.group(1)
            if act not in USER_ACTS or act == SILENCE:
                listed = ", ".join(a for a in USER_ACTS if a != SILENCE)
                raise DataError(f"{where}: unknown user act [{act}]; user acts are {listed}")
            phrasings.setdefault(act, [])
            continue
        if act is None:
            raise DataError(f"{where}: a phrasing before any [UserAct] section; start one")
        words = " ".join(words_of(line))
        if not words:
            raise DataError(f"{where}: {line!r} has no words")
        phrasings[act].append(words)
    return {act: tuple(dict.fromkeys(texts)) for act, texts in phrasings.items()}


def parse_dialogues(path: Path, vocabulary: tuple[str, ...]) -> tuple[tuple[DomainLine, ...], ...]:
    """The seed dialogues file, each dialogue replayed to check its moves and its feedback."""
    dialogues: list[list[DomainLine]] = [[]]
    known_words = set(vocabulary)
    for n, line in _lines(path):
        if line.startswith("#"):
            continue
        if not line:
            if dialogues[-1]:
                dialogues.append([])
            continue
        where = f"{path.name}:{n}"
        utterance = parse_utterance(line, where)
        if utterance.act == GAME_MOVE_TEMPLATE:
            raise DataError(
                f"{where}: a seed dialogue names the cell, e.g. GameMove(gridloc=middle)"
            )
        unknown = [w for w in utterance.words if w not in known_words]
        if unknown:
            raise DataError(
                f"{where}: {', '.join(repr(w) for w in unknown)} not in the vocabulary; use the "
                "words of templates.txt and user_responses.txt"
            )
        dialogues[-1].append(utterance)
    found = tuple(tuple(d) for d in dialogues if d)
    if not found:
        raise DataError(f"{path.name} holds no dialogue; add at least one")
    for dialogue in found:
        _check_game(dialogue)
    return found


def _check_game(dialogue: tuple[DomainLine, ...]) -> None:
    board: Board = EMPTY_BOARD
    for utterance in dialogue:
        cell = utterance.cell
        if cell is not None:
            if outcome(board) is not None:
                raise DataError(f"{utterance.source}: a move after the game is over")
            try:
                board = play(board, cell, ROBOT if utterance.speaker == "SYS" else USER)
            except IllegalMoveError as exc:
                raise DataError(f"{utterance.source}: {exc}") from None
        elif is_feedback(utterance.act):
            result = outcome(board)
            if result is None or utterance.act != FEEDBACK_ACTS[result]:
                raise DataError(
                    f"{utterance.source}: {utterance.act} does not match the game "
                    f"({result or 'not over'})"
                )


def derive_vocabulary(
    templates: dict[str, tuple[str, ...]], responses: dict[str, tuple[DomainLine, ...]]
) -> tuple[str, ...]:
    """Every word of the templates and user responses, in order of first appearance."""
    words: dict[str, None] = {}
    for texts in templates.values():
        for text in texts:
            words.update(dict.fromkeys(words_of(text)))
    for alternatives in responses.values():
        for utterance in alternatives:
            words.update(dict.fromkeys(utterance.words))
    return tuple(words)


def default_domain_dir() -> Path:
    """The shipped domain files, `oxbot/data/dialogue/`."""
    return Path(str(resources.files("oxbot") / "data" / "dialogue"))


def load_domain(directory: str | Path | None = None) -> Domain:
    """Parse and check `dialogues.txt`, `templates.txt` and `user_responses.txt` in `directory`."""
    root = Path(directory) if directory is not None else default_domain_dir()
    templates = parse_templates(root / "templates.txt")
    responses = parse_responses(root / "user_responses.txt")
    vocabulary = derive_vocabulary(templates, responses)
    if not vocabulary:
        raise DataError(
            f"the vocabulary derived from {root / 'templates.txt'} and "
            f"{root / 'user_responses.txt'} is empty; the templates need words"
        )
    dialogues = parse_dialogues(root / "dialogues.txt", vocabulary)
    shown = {u.act for dialogue in dialogues for u in dialogue if u.speaker == "SYS"}
    unseen = [a for a in SYSTEM_ACTS if not is_game_move(a) and a not in shown]
    if unseen or not any(is_game_move(a) for a in shown):
        raise DataError(
            f"no seed dialogue in {root / 'dialogues.txt'} shows the robot's "
            f"{', '.join(unseen) or 'GameMove'}; the action model never offers an act it has "
            "not seen: add a dialogue that uses it"
        )
    phrases_file = root / "user_phrases.txt"
    phrasings = parse_phrasings(phrases_file) if phrases_file.exists() else {}
    return Domain(dialogues, templates, responses, vocabulary, phrasings)
