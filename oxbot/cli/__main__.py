"""`python -m oxbot.cli`: the `oxbot` command without its installed script."""

from __future__ import annotations

from oxbot.cli import main

if __name__ == "__main__":
    main()
