r"""Controllers designed from identified models: PI and fractional PI^λ / PD^μ, iso-damping tuning.

- :mod:`.linear_form`: a model's linear form, velocity command [rad/s] to inclination [deg]
  (:func:`linear_form`; :mod:`.linearise` for the NARX models at an operating point);
- :mod:`.operators`: the operator's realisations (Tustin integrator; :math:`s^\\alpha` by the
  lab's truncated Grünwald–Letnikov sum or by Oustaloup's filter);
- :mod:`.loop_shaping`: margins and the designs that meet a phase margin at a crossover with a
  flat phase (:func:`design_pi`, :func:`design_fractional`, :func:`ideal_iso_damping`);
- :mod:`.scheduled`: gain scheduling over the inclination from the scheduled model
  (:func:`design_scheduled`);
- :mod:`.controllers`: the controller object (:class:`DesignedController`, the controller
  contract of :class:`neckid.systems.Controller`, python-control conversion);
- :mod:`.files`: the JSON controller file (:func:`save_controller`, :func:`load_controller`);
- :mod:`.verify`: margins on models, the paper's tests 1–3 on the simulated neck, models in the
  loop, the Set Membership bands.
- :mod:`.mpc`: linear model predictive control on the same linear forms, solved by OSQP, with
  inclination limits tightened by Set Membership k-step bands (``docs/mpc.md``).

The page ``docs/design.md`` has the equations, the discretisations and the measurements.
"""

from neckid.design.controllers import DesignedController, DesignedStateMap, GainSchedule
from neckid.design.files import (
    controller_document,
    load_controller,
    model_description,
    save_controller,
)
from neckid.design.linear_form import LinearForm, linear_form
from neckid.design.linearise import NoLinearFormError, linearise
from neckid.design.loop_shaping import (
    Design,
    DesignSpec,
    LoopMargins,
    closed_loop_stable,
    design_fractional,
    design_pi,
    ideal_iso_damping,
    loop_margins,
    phase_slope,
    solve_gains,
)
from neckid.design.operators import (
    DiscreteOperator,
    gl_taps,
    grunwald_letnikov_operator,
    oustaloup_operator,
    tustin_integrator,
)
from neckid.design.scheduled import ScheduledDesign, design_scheduled
from neckid.design.verify import (
    PAPER_TESTS,
    NeckTests,
    margins_on_models,
    models_in_the_loop,
    paper_test_references,
    set_membership_check,
    simulated_neck_tests,
    tracking_rms,
)

__all__ = [
    "PAPER_TESTS",
    "Design",
    "DesignSpec",
    "DesignedController",
    "DesignedStateMap",
    "DiscreteOperator",
    "GainSchedule",
    "LinearForm",
    "LoopMargins",
    "NeckTests",
    "NoLinearFormError",
    "ScheduledDesign",
    "closed_loop_stable",
    "controller_document",
    "design_fractional",
    "design_pi",
    "design_scheduled",
    "gl_taps",
    "grunwald_letnikov_operator",
    "ideal_iso_damping",
    "linear_form",
    "linearise",
    "load_controller",
    "loop_margins",
    "margins_on_models",
    "model_description",
    "models_in_the_loop",
    "oustaloup_operator",
    "paper_test_references",
    "phase_slope",
    "save_controller",
    "set_membership_check",
    "simulated_neck_tests",
    "solve_gains",
    "tracking_rms",
    "tustin_integrator",
]
