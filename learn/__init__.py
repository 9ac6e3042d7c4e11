"""The damage classifier: pair features from datasets and measurements, the network (scikit-learn style),
classical methods, metrics, and training, evaluation and classification with a model directory.

Nothing is imported here (torch and scikit-learn load only when used); import the modules:
``learn.features`` pair features and the dataset reader, ``learn.estimator`` the network, ``learn.classical``
the classical methods, ``learn.evaluate`` metrics and figures, ``learn.model_dir`` the model directory
(:class:`~learn.model_dir.TrainedModel`), ``learn.training`` train and evaluate, ``learn.measured`` measured
data on a model's DOFs and its modes, ``learn.verdict`` the answers and the verdict, ``learn.classify`` the
classification of measured pairs.
"""

__all__: list[str] = []
