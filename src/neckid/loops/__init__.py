"""Library code for models in closed loops: model in the loop, the adaptive protocol, operating points.

- :mod:`.model_in_loop`: an identified model as the plant of a controller
  (:func:`model_in_the_loop`), compared with the logged loop;
- :mod:`.adaptive`: models updated while a run streams in (:func:`adaptive_free_run`);
- :mod:`.operating_points`: CFF-RLS at several inclinations (:func:`identify_operating_points`);
- :mod:`.controllers`: the lab's controllers and references that recorded the soft-neck logs
  (PI, fractional, adaptive replay and re-implemented tuner; the rand() dither; the controller
  check on the logs);
- :mod:`.lab_drive`: the bench drive identified from the logs (:func:`identify_drive`,
  :class:`LabDrive`: gains by direction and speed);
- :mod:`.lab_loop`: an identified model in the loop of a real log, with the log's controller,
  reference and the drive model (:func:`in_loop_on_log`); :mod:`.lab_loop_result` its figures,
  :mod:`.loop_measures` the tracking error, oscillation and stair measures; :mod:`.loop_checks`
  what the loop is checked against before it runs (the controller check and its tolerance, the
  sampling period, the adaptive parameter logs matched to the log).

Applications (the paper's demo, the benchmark) live in :mod:`neckid.experiments` and use these.
"""
