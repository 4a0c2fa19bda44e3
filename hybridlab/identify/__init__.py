"""Parameter identification from measured data.

Three methods, each a function returning a frozen result object with estimates,
standard errors, residuals, a text table, a JSON summary and a plot:

* :func:`fit_friction` -- Coulomb and viscous friction ``F = c sign(v) + d v`` from
  steady-state runs in both directions (:mod:`hybridlab.identify.friction`);
* :func:`fit_mass` -- the mass from the -40 dB/dec region of a position-over-force
  frequency response, and eq. (4) ``1/(s (m s + d))`` with the reasons ``d`` is
  unreliable (:mod:`hybridlab.identify.frequency`);
* :func:`fit_events` -- any model parameters from sensor edges, by matching simulated
  and measured edge sequences (:mod:`hybridlab.identify.events`);
* :func:`fit_targets` -- any model parameters from published or measured *summary
  quantities* of simulated experiments: event counts, periods, values at events, step
  overshoot and settling time (:class:`Target`, :mod:`hybridlab.identify.target_fit`).

Data come in as :class:`FrictionData`, :class:`FrequencyData` and :class:`SensorEvents`
(read from CSV by the ``read_*_csv`` functions); :mod:`hybridlab.identify.synthetic`
makes realistic data from known truths; :mod:`hybridlab.cli.identify` holds the
``identify`` subcommands.
"""

from typing import TYPE_CHECKING

from hybridlab._lazy import lazy_exports

if TYPE_CHECKING:  # the public names, loaded on first use (hybridlab._lazy)
    from hybridlab.identify.data import (
        FrequencyData,
        FrictionData,
        SensorEvents,
        read_events_csv,
        read_frequency_csv,
        read_friction_csv,
        write_csv,
    )
    from hybridlab.identify.errors import DataError, TargetError
    from hybridlab.identify.events import (
        EventFit,
        Passages,
        edges_from_result,
        fit_events,
        passages,
    )
    from hybridlab.identify.frequency import (
        Eq4Fit,
        MassFit,
        SlopeRegion,
        find_slope_region,
        fit_mass,
        local_slopes,
    )
    from hybridlab.identify.friction import FrictionFit, LineFit, fit_friction
    from hybridlab.identify.target_fit import TargetFit, fit_targets
    from hybridlab.identify.targets import Target, read_targets

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "DataError",
    "Eq4Fit",
    "EventFit",
    "FrequencyData",
    "FrictionData",
    "FrictionFit",
    "LineFit",
    "MassFit",
    "Passages",
    "SensorEvents",
    "SlopeRegion",
    "Target",
    "TargetError",
    "TargetFit",
    "edges_from_result",
    "find_slope_region",
    "fit_events",
    "fit_friction",
    "fit_mass",
    "fit_targets",
    "local_slopes",
    "passages",
    "read_events_csv",
    "read_frequency_csv",
    "read_friction_csv",
    "read_targets",
    "write_csv",
]
