"""The integrated robot: typed messages between concurrent components (paper §3.1)."""
