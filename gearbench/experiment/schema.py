"""The checks of plain dicts now live in :mod:`gearbench.schema`; this module keeps the old import path.

They moved out of the ``experiment`` package because the solver (``gearbench.simulate``) and the
controllers (``gearbench.control.controllers``) check their arguments with them, and importing
anything under ``gearbench.experiment`` runs its ``__init__``, which imports the file loaders,
which import the solver and the controllers: an import circle.
"""
from ..schema import (MISSING, Choice, Number, Text, check_mapping, index, is_number, join,  # noqa: F401
                      show, unknown_key)
