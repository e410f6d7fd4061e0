"""Design studies (``fsi-design``): a base case, parameters, objectives and constraints,
evaluated by the cheapest path that answers them (docs/design.md)."""

from .study import STUDY_FILE, Study, load_study

__all__ = ["STUDY_FILE", "Study", "load_study"]
