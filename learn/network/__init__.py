"""The network: pair features, the estimator and its forward pass, size and intervals, metrics, the model directory,
train/evaluate (docs/contributing.md lists the modules). Nothing is imported here; import the modules."""

__all__: list[str] = []
