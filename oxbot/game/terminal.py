"""The game in a terminal, and the conventions every oxbot terminal shares.

`oxbot game` plays noughts and crosses against one of the game strategies (random, blocker,
minimax), with no speech, vision or learned manager; `oxbot play --terminal` (oxbot.robot.
terminal) plays with the whole robot. Both look and read alike: turns printed as the paper's
Figure 1 prints them (`Rob: Your turn.`, `Usr: [who=usr what=draw where=middle]`), the board
after every move, cells typed as 1-9 or by name, `new` for a new game and `q`, `quit`, `exit`
or the end of input to leave.
"""

from __future__ import annotations

from collections.abc import Callable

from rich.console import Console
from rich.markup import escape

from oxbot.errors import IllegalMoveError
from oxbot.game.board import (
    CELL_NAMES,
    EMPTY_BOARD,
    N_CELLS,
    ROBOT,
    USER,
    Board,
    Ending,
    cell_index,
    outcome,
    play,
    render,
    symbol_of,
    to_move,
)
from oxbot.game.opponents import Opponent, checked_move

ReadLine = Callable[[str], str]
"""Like `input`: shows a prompt, returns a line, raises EOFError at the end of input."""

QUIT_WORDS = frozenset({"q", "quit", "exit"})
NEW_WORDS = frozenset({"new"})
CELL_HELP = f"a cell: 1-{N_CELLS} (row by row from the upper left) or a name such as middle"
GAME_OVER = {
    "win": "I won",
    "loss": "you won",
    "draw": "a draw",
    "declined": "no game, as you wished",
    "stopped": "stopped, as you asked",
    None: "unfinished",
}
FEEDBACK = {"win": "Yes, I won.", "loss": "Well done, you won.", "draw": "It is a draw."}


def print_turn(console: Console, speaker: str, text: str, act: str = "") -> None:
    """One turn as in the paper's Figure 1: `Rob: Hello! [Salutation(greeting)]`."""
    who = "[bold cyan]Rob:[/]" if speaker == "sys" else "[bold green]Usr:[/]"
    tag = f" [dim]{escape(f'[{act}]')}[/]" if act else ""
    console.print(f"{who} {escape(text)}{tag}")


def print_board(console: Console, board: Board, robot_starts: bool) -> None:
    """The board as text, O for circles and X for crosses, empty cells numbered."""
    console.print(escape(render(board, robot_starts)))


def print_game_over(console: Console, result: Ending | None) -> None:
    console.print(f"[bold]Game over: {GAME_OVER[result]}.[/] Type 'new' or 'quit'.")


def is_cell(text: str) -> bool:
    """True if `text` names a cell (1-9 or a paper name)."""
    try:
        cell_index(text)
    except IllegalMoveError:
        return False
    return True


class TerminalGame:
    """Games between a person at the keyboard and `robot` (a callable `f(board) -> cell`).

    `robot` sees the board from the robot's side (its marks are 1), like the environment's
    opponents see it from theirs; wrap a person-side strategy with `as_robot`.
    """

    def __init__(
        self,
        robot: Opponent,
        robot_starts: bool = True,
        read_line: ReadLine = input,
        console: Console | None = None,
    ) -> None:
        self.robot = robot
        self.robot_starts = robot_starts
        self.read_line = read_line
        self.console = console if console is not None else Console(highlight=False)

    def say(self, text: str) -> None:
        print_turn(self.console, "sys", text)

    def play_game(self) -> str | None:
        """Play one game; the outcome from the robot's side, or None if the person quit."""
        board: Board = EMPTY_BOARD
        mine = symbol_of(USER, self.robot_starts)
        self.say("Hello! I am oxbot. Let's play.")
        self.say("Let me start." if self.robot_starts else f"You start, with {mine}s.")
        while outcome(board) is None:
            if to_move(board, self.robot_starts) == ROBOT:
                cell = checked_move(self.robot, board)
                board = play(board, cell, ROBOT)
                self.say(f"I take this one [who=rob what=draw where={CELL_NAMES[cell]}]")
                print_board(self.console, board, self.robot_starts)
                continue
            self.say("Your turn.")
            cell = self._ask_cell(board)
            if cell is None:
                self.say("Good bye!")
                return None
            board = play(board, cell, USER)
            print_turn(self.console, "usr", f"[who=usr what=draw where={CELL_NAMES[cell]}]")
            print_board(self.console, board, self.robot_starts)
        result = outcome(board)
        self.say(FEEDBACK[result])
        self.say("Good bye!")
        print_game_over(self.console, result)
        return result

    def play_session(self) -> list[str]:
        """Games until the person quits; the outcomes of the finished ones."""
        self.console.print(
            f"[dim]Type {escape(CELL_HELP)} to draw, 'new' for a new game, 'quit' to leave.[/]"
        )
        results: list[str] = []
        while True:
            result = self.play_game()
            if result is None:
                return results
            results.append(result)
            while True:
                try:
                    line = self.read_line("").strip().lower()
                except EOFError:
                    return results
                if line in QUIT_WORDS:
                    return results
                if line in NEW_WORDS:
                    break
                self.console.print("[yellow]Type 'new' for a new game or 'quit' to leave.[/]")

    def _ask_cell(self, board: Board) -> int | None:
        """The person's next empty cell; None when they quit or input ends."""
        while True:
            try:
                text = self.read_line("").strip()
            except (EOFError, KeyboardInterrupt):
                self.console.print()
                return None
            if not text:
                self.console.print(f"[yellow]Type {escape(CELL_HELP)}.[/]")
                continue
            if text.lower() in QUIT_WORDS:
                return None
            try:
                cell = cell_index(text)
                play(board, cell, USER)  # raises if taken
            except IllegalMoveError as exc:
                self.console.print(escape(str(exc)), style="yellow")
                continue
            return cell
