"""Case files: typed frozen sections, strict validation, ``--set`` overrides."""

from .loader import CASE_FILE, load_case, parse_override
from .params import CaseError
from .schema import Case

__all__ = ["CASE_FILE", "Case", "CaseError", "load_case", "parse_override"]
