"""Library code for models in closed loops: model in the loop, the adaptive protocol, operating points.

- :mod:`.model_in_loop`: an identified model as the plant of a controller
  (:func:`model_in_the_loop`), compared with the logged loop;
- :mod:`.adaptive`: models updated while a run streams in (:func:`adaptive_free_run`);
- :mod:`.operating_points`: CFF-RLS at several inclinations (:func:`identify_operating_points`);
- :mod:`.controllers`: the lab's controllers and references that recorded the soft-neck logs
  (PI, fractional, adaptive replay; the rand() dither; the controller check on the logs).

Applications (the paper's demo, the benchmark) live in :mod:`neckid.experiments` and use these.
"""
