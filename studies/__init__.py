"""Studies that reproduce published results with gearbench: not part of the installed package.

Run from the repository's root, where ``data/`` and ``experiments/`` are (``make run`` does)::

    python -m studies.emps --results results
    python -m studies.hidden_effects --results results
"""
