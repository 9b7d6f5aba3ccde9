"""Models against measurements: replay a record, fit effects, diagnose what is missing.

One module per step of the workflow; data flow one way, left to right::

    replay ──▶ scoring ──▶ fit ──▶ candidates ──▶ ladder ──▶ explain ──▶ results
    (a record  (weights,   (least  (what can be   (immutable (every     (Diagnosis,
     driven as  floors,     squares, tried, why   rungs, one  sentence,  Step,
     measured:  criterion,  secant   not; singles step       from the   to_json)
     ReplayRun) evidence)   Jacobian, and pairs)  generator)  rungs)
                            covariance)   ▲           │
                                          └─ refit, search, calibration
    policy: what pays (one frozen Policy)      progress: events for a display

``diagnose`` drives it: the baseline, the calibration plan, then ``ladder.climb`` until it
stops, then ``results.diagnosis`` writes the sentences (``explain``) and the JSON.  The ladder
decides and records, ``explain`` words, ``results`` shapes: a change of policy touches neither
of the last two, and a change of criterion (a noise model of the residuals) is
``scoring.criterion``.  ``compare`` sets one replay beside its record; ``evidence`` reads the
residual as a missing torque, ``residuals`` tests its whiteness.  Records are made outside this
package (``gearbench.synth``): identification never makes its own data.
"""
