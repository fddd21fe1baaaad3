"""The terminal game: a person types cells, the robot's side answers with a chosen strategy.

It is the seed of the full robot: the same board, rules, cell names and the paper's phrasing
("I take this one [who=rob what=draw where=middle]"), with no speech or vision yet.
"""

from __future__ import annotations

from collections.abc import Callable

from rich.console import Console
from rich.markup import escape

from oxbot.errors import IllegalMoveError
from oxbot.game.board import (
    CELL_NAMES,
    EMPTY_BOARD,
    ROBOT,
    USER,
    Board,
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

QUIT_WORDS = {"q", "quit", "exit", "bye", "goodbye"}
FEEDBACK = {"win": "Yes, I won.", "loss": "Well done, you won.", "draw": "It is a draw."}


class TerminalGame:
    """One or more games between a person at the keyboard and `robot` (a SPEC §5 callable).

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
        self.console.print(f"[bold cyan]Robot:[/] {escape(text)}")

    def play_game(self) -> str | None:
        """Play one game; the outcome from the robot's side, or None if the person quit."""
        board: Board = EMPTY_BOARD
        mine = symbol_of(USER, self.robot_starts)
        self.say("Hello! I am oxbot. Would you like to play a game with me?")
        self.say("Let me start." if self.robot_starts else f"You start, with {mine}s.")
        while outcome(board) is None:
            if to_move(board, self.robot_starts) == ROBOT:
                cell = checked_move(self.robot, board)
                board = play(board, cell, ROBOT)
                self.say(f"I take this one [who=rob what=draw where={CELL_NAMES[cell]}]")
                continue
            self.console.print(render(board, self.robot_starts))
            if outcome(board) is None:
                self.say("Your turn.")
            cell = self._ask_cell(board)
            if cell is None:
                self.say("Good bye!")
                return None
            board = play(board, cell, USER)
            self.console.print(escape(f"[who=usr what=draw where={CELL_NAMES[cell]}]"), style="dim")
        self.console.print(render(board, self.robot_starts))
        result = outcome(board)
        self.say(FEEDBACK[result])
        self.say("Good bye!")
        return result

    def play_session(self) -> list[str]:
        """Games until the person declines another; the outcomes of the finished ones."""
        results: list[str] = []
        while True:
            result = self.play_game()
            if result is None:
                return results
            results.append(result)
            try:
                again = self.read_line("Play again? [y/N] ").strip().lower()
            except EOFError:
                return results
            if again not in {"y", "yes"}:
                return results

    def _ask_cell(self, board: Board) -> int | None:
        """The person's next empty cell; None when they quit or input ends."""
        while True:
            try:
                text = self.read_line("Your move (1-9 or a cell name, q to quit): ")
            except (EOFError, KeyboardInterrupt):
                self.console.print()
                return None
            text = text.strip()
            if not text:
                self.console.print("[yellow]Type a cell: 1-9 or a name such as middle.[/]")
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
