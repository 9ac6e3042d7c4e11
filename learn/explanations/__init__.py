"""The FE readings of a change: shapes, sensitivities, the classical methods, the competing explanations and their
exact refinement, the mirror ambiguity (docs/contributing.md lists the modules). Import the modules."""

__all__: list[str] = []
