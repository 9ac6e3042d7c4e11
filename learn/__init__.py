"""The damage classifier, one sub-package per stage: ``network`` (features, the network, its training and model
directory), ``explanations`` (shapes, sensitivities, classical methods, competing explanations), ``pairs`` (measured
pairs classified) and ``monitor`` (a series of tests); ``densest_window``, where a mode sits among many tests'
poles, serves the last two. Nothing is imported here (torch and scikit-learn load only when used); import the
modules.
"""

__all__: list[str] = []
