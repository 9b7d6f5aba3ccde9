"""Models against measurements: replay a record, fit effects, diagnose what is missing.

One module per step of the workflow; data flow one way, left to right::

    replay ──▶ fit (Scorer, FitResult) ──▶ candidates ──▶ ladder ──▶ explain ──▶ results
    (a record  (weights, floors, BIC;      (what can be    (immutable (every     (Diagnosis,
     driven as  least squares, secant      tried, why not; rungs, one  sentence,  to_json)
     measured)  Jacobian, covariance)      singles, pairs) step fn)    from the
                     ▲                           │            │        rungs)
                     └──── refit, search, calibration ◀───────┘
                                          policy: what pays (one frozen Policy)
                                          progress: events for a display

``diagnose`` drives it: the baseline, the calibration plan, then ``ladder.climb`` until it
stops, then ``results.diagnosis`` writes the sentences (``explain``) and the JSON.  The ladder
decides and records, ``explain`` words, ``results`` shapes; a policy change touches neither of
the last two.  ``compare`` sets one replay beside its record; ``evidence`` and ``residuals``
read residuals; ``synth`` makes records (it does not identify).
"""
