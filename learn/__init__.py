"""Learning damage from datasets (``datagen``): the classifier lives here (issue 8).

Public API: nothing yet; modules added here declare theirs in ``__all__`` below.
"""

__all__: list[str] = []
