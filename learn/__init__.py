"""The damage classifier: pair features from datasets and measurements, the network (scikit-learn style),
classical methods, metrics, and the train / evaluate / classify workflow with its model directory.

Nothing is imported here (torch and scikit-learn load only when used); import the modules:
``learn.features``, ``learn.estimator``, ``learn.classical``, ``learn.evaluate``, ``learn.workflow``.
"""

__all__: list[str] = []
