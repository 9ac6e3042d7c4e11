"""The damage classifier: pair features from datasets and measurements, the network (scikit-learn style),
classical baselines, metrics, and the train / evaluate / classify workflow with its model directory.

Imports are lazy (torch and scikit-learn load only when used): ``from learn.workflow import train``.
"""

__all__ = ["baselines", "estimator", "evaluate", "features", "models", "sensitivity", "workflow"]
