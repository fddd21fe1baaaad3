"""Whether a model trained in this run is the very one shipped: their parameters compared."""

from __future__ import annotations

from typing import Any


def _same_weights(a: Any, b: Any) -> bool:
    """Whether two torch modules hold exactly the same parameters."""
    import torch

    sa, sb = a.state_dict(), b.state_dict()
    return list(sa) == list(sb) and all(
        sa[k].shape == sb[k].shape and torch.equal(sa[k], sb[k]) for k in sa
    )
