"""Learning to perceive (paper §2.1): hand-drawn symbols, their data, the CNN+SVM classifier.

from oxbot.perception import load_classifier
clf = load_classifier()          # the shipped model; load_classifier(path) for another
clf.predict(cells)               # uint8 (N, 40, 40) dark-on-light -> list of N labels

from oxbot.perception import read_board
read_board(frame)                # uint8 (H, W, 3) RGB or (H, W) gray photo -> 9 labels

Beside the contract above: clf.read(cells) and read_cells(frame) give `CellReading`s, whose
label may also be "partial" (ink that is not a whole symbol: `oxbot.perception.wholeness`), with
a calibrated confidence.
"""

from oxbot.perception.board import read_board, read_cells
from oxbot.perception.classifier import CellReading, SymbolClassifier, load_classifier
from oxbot.perception.synth import (
    LABELS,
    OUTPUTS,
    PARTIAL,
    Pen,
    draw_cell,
    draw_symbol,
    paper,
    symbol_strokes,
)

__all__ = [
    "LABELS",
    "OUTPUTS",
    "PARTIAL",
    "CellReading",
    "Pen",
    "SymbolClassifier",
    "draw_cell",
    "draw_symbol",
    "load_classifier",
    "paper",
    "read_board",
    "read_cells",
    "symbol_strokes",
]
