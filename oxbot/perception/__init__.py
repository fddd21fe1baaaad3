"""Learning to perceive (paper §2.1): hand-drawn symbols, their data, the CNN+SVM classifier.

from oxbot.perception import load_classifier
clf = load_classifier()          # the shipped model; load_classifier(path) for another
clf.predict(cells)               # uint8 (N, 40, 40) dark-on-light -> list of N labels

from oxbot.perception import read_board
read_board(frame)                # uint8 (H, W, 3) RGB or (H, W) gray photo -> 9 labels
"""

from oxbot.perception.board import read_board
from oxbot.perception.classifier import SymbolClassifier, load_classifier
from oxbot.perception.synth import LABELS, Pen, draw_cell, draw_symbol, paper, symbol_strokes

__all__ = [
    "LABELS",
    "Pen",
    "SymbolClassifier",
    "draw_cell",
    "draw_symbol",
    "load_classifier",
    "paper",
    "read_board",
    "symbol_strokes",
]
