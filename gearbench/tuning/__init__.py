"""Tuning a controller on a plant: the loop from an identified model back to control.

:func:`gearbench.tune` (``gearbench tune``) searches a controller's gains, and a
backlash compensator's shift, for the least objective on a set-point profile, with the
compiled simulator, subject to limits on what the run may do (voltage sign changes,
time at the voltage limit, impacts).  Robust tuning scores each candidate on plants
drawn from what the identification left uncertain.

* :mod:`.space`: the settings searched, their units and bounds, and the controller
  each point stands for;
* :mod:`.objective`: the objectives, the limits, and the robust statistic that turns
  the runs on many plants into one number;
* :mod:`.draws`: plants drawn from a fit's covariance and the datasheet tolerances;
* :mod:`.search`: where the runs are solved (here, a local pool, a Dask cluster) and
  the search itself (a scrambled Sobol sample, then Nelder-Mead from its best point);
* :mod:`.result`: :class:`~.result.TuneResult`, its tables, figures and the
  experiment file that ``gearbench run`` reproduces it from.
"""
