"""The learned grid finder's network: heatmaps of the grid's points from a small picture.

A fully convolutional encoder-decoder (in the manner of DocAligner's corner heatmaps and
CenterNet) sees the frame shrunk to `INPUT_SIDE` pixels on its long side, padded to a square,
and predicts at a quarter of that resolution:

- `CROSSINGS`: the 4 inner crossings of the drawn # in one channel (they look alike under
  rotation, so they are told apart by where they lie, not by channel: `grid_points.py`);
- `OUTER`: the 12 outer points of the 4x4 lattice, where each line would end one cell past its
  crossing, and the grid's 4 corners;
- `LINES`: the drawn grid lines' ink (an auxiliary target: it teaches the net what a grid line
  is, and shows in `oxbot see --debug` what it took for one);

and a "board present" logit from the deepest features. The heatmaps are logits; a peak's
sigmoid is how sure the net is that a point lies there.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional

INPUT_SIDE = 256
"""The network's picture: the frame's long side shrunk to this many pixels."""
STRIDE = 4
"""Input pixels per heatmap pixel."""
CROSSINGS, OUTER, LINES = 0, 1, 2
HEATMAPS = 3


def _conv(inputs: int, outputs: int, stride: int = 1) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(inputs, outputs, 3, stride=stride, padding=1, bias=False),
        nn.BatchNorm2d(outputs),
        nn.ReLU(inplace=True),
    )


class GridPointNet(nn.Module):
    """Heatmaps (N, HEATMAPS, H/4, W/4) and presence logits (N,) of pictures (N, 3, H, W)
    scaled to [0, 1]; H and W multiples of 32."""

    def __init__(self, width: int = 16) -> None:
        super().__init__()
        w = [width, 2 * width, 4 * width, 6 * width, 8 * width]
        self.width = width
        self.stem = _conv(3, w[0], stride=2)  # 1/2
        self.down = nn.ModuleList(
            nn.Sequential(_conv(w[k], w[k + 1], stride=2), _conv(w[k + 1], w[k + 1]))
            for k in range(4)
        )  # 1/4, 1/8, 1/16, 1/32
        # the long view: a grid spans most of the picture, its lines run far
        self.context = nn.Sequential(
            nn.Conv2d(w[4], w[4], 3, padding=2, dilation=2, bias=False),
            nn.BatchNorm2d(w[4]),
            nn.ReLU(inplace=True),
        )
        self.lateral = nn.ModuleList(nn.Conv2d(w[k], w[1], 1) for k in (1, 2, 3, 4))
        self.smooth = nn.ModuleList(_conv(w[1], w[1]) for _ in range(3))
        self.heads = nn.Sequential(_conv(w[1], w[1]), nn.Conv2d(w[1], HEATMAPS, 1))
        self.presence = nn.Linear(2 * w[4], 1)
        # heatmaps start near "nowhere" (CenterNet's prior), so the first steps are stable
        nn.init.constant_(self.heads[-1].bias, -4.0)

    def forward(self, pictures: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        features = []
        x = self.stem(pictures)
        for block in self.down:
            x = block(x)
            features.append(x)
        deepest = self.context(features[-1]) + features[-1]
        pooled = torch.cat([deepest.mean(dim=(2, 3)), deepest.amax(dim=(2, 3))], dim=1)
        presence = self.presence(pooled).squeeze(1)
        # top-down: from 1/32 back to 1/4, adding each level's own view
        top = self.lateral[3](deepest)
        for level in (2, 1, 0):
            lateral = self.lateral[level](features[level])
            top = functional.interpolate(top, size=lateral.shape[2:], mode="nearest") + lateral
            top = self.smooth[level](top)
        return self.heads(top), presence
