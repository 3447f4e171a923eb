"""Benchmark the identification methods on real data, next to published figures of merit.

:func:`run_benchmark` runs the methods of the registry (:func:`neckid.methods`: ``arx``, the
state models ``ss`` and ``pnlss``, ``sm``, ``sm-linear``, ``sm-parallel``, ``nn``, on the public
benchmarks ``poly`` and ``sm-parallel-poly``, on the soft-neck logs ``scheduled`` and
``greybox-neck``) and, when named and installed, the peer ``sysidentpy-frols`` on

- the four public benchmarks of :mod:`neckid.datasets.benchmarks`, with the official protocol of
  each (train on the training record, free-run simulation of every test record, the number of
  initial samples the protocol gives, RMSE in the unit the literature uses);
- the UC3M soft-neck logs, with the protocol of ``docs/benchmarks/methods.md`` (identify on
  ``stair/ada000response.csv``, validate by free run on every other log that has the raw
  inclination; see :func:`softneck_protocol`);
- two cross-run protocols on the soft-neck staircases (:data:`SOFTNECK_CROSS_RUN`): identify on
  several runs at once with the payload as a condition input, free-run the others
  (``softneck-payload``: train 0 g and 600 g, test 200 g and 400 g; ``softneck-controller``:
  train the two fractional controllers, test the integer PI).

Hyper-parameters (lags, noise bounds, ...) are chosen per method on the training data only: on one
training record every candidate is fitted on its first 75 % and ranked by free-run RMSE on the
last 25 %; on several training runs, by leave-one-run-out free-run RMSE. The best one is then
refitted on all the training data. Test records are never looked at before the final simulation.
The candidates, final fits and test runs of all data sets and methods share the local cores (or a
Dask cluster), and a fit that several grids need is done once (:mod:`.shared`).

The package reads as the benchmark is built:

- :mod:`~neckid.experiments.benchmark.datasets`: the data sets and their protocols (loaders,
  :func:`softneck_protocol`, quick subsets);
- :mod:`~neckid.experiments.benchmark.settings`: per-data-set lag grids and per-method candidate
  grids, as tables; every candidate is made by the method registry;
- :mod:`~neckid.experiments.benchmark.runner`: :func:`run_benchmark`: selection, fit, free run;
- :mod:`~neckid.experiments.benchmark.plans`: one method on one data set through its stages, and
  the stage loop over all of them; :mod:`~neckid.experiments.benchmark.stages`: the work units;
  :mod:`~neckid.experiments.benchmark.shared`: the fits a run shares;
- :mod:`~neckid.experiments.benchmark.report`: :class:`BenchmarkReport`, its files and tables;
- :mod:`~neckid.experiments.benchmark.published`: the published figures, read from
  ``published.json`` (package data) with their sources;
- :mod:`~neckid.experiments.benchmark.peers`: another toolkit's model on the same split and
  selection rule (SysIdentPy's FROLS, ``pip install "neckid[peers]"``; without it, a row that
  says it was skipped).

Examples
--------
>>> from neckid.experiments.benchmark import BENCHMARK_METHODS, BENCHMARKS
>>> BENCHMARK_METHODS
('arx', 'ss', 'pnlss', 'sm', 'sm-linear', 'sm-parallel', 'sm-parallel-poly', 'poly', 'lpv', 'nn',
 'scheduled', 'greybox-neck', 'sindy', 'sm-parallel-sindy', 'koopman', 'sm-parallel-koopman')
>>> BENCHMARKS
('softneck', 'softneck-payload', 'softneck-controller', 'cascaded_tanks', 'silverbox', 'bouc_wen', 'robot_arm')
"""

from neckid.experiments.benchmark.datasets import (
    BENCHMARKS,
    PROTOCOLS,
    SOFTNECK_CROSS_RUN,
    SOFTNECK_STAIR_EDGES,
    SOFTNECK_TRAINING_LOG,
    Protocol,
    load_benchmark,
    load_softneck_benchmark,
    quick_subset,
    softneck_protocol,
)
from neckid.experiments.benchmark.published import (
    published_frame,
    published_table,
    published_units,
)
from neckid.experiments.benchmark.report import BenchmarkReport
from neckid.experiments.benchmark.runner import run_benchmark
from neckid.experiments.benchmark.settings import (
    BENCHMARK_METHODS,
    CROSS_RUN_BENCHMARKS,
    DEFAULT_METHODS,
    LAG_GRIDS,
    PEER_METHODS,
    SELECTION_FRACTION,
    candidates,
)

__all__ = [
    "BENCHMARKS",
    "BENCHMARK_METHODS",
    "CROSS_RUN_BENCHMARKS",
    "DEFAULT_METHODS",
    "LAG_GRIDS",
    "PEER_METHODS",
    "PROTOCOLS",
    "SELECTION_FRACTION",
    "SOFTNECK_CROSS_RUN",
    "SOFTNECK_STAIR_EDGES",
    "SOFTNECK_TRAINING_LOG",
    "BenchmarkReport",
    "Protocol",
    "candidates",
    "load_benchmark",
    "load_softneck_benchmark",
    "published_frame",
    "published_table",
    "published_units",
    "quick_subset",
    "run_benchmark",
    "softneck_protocol",
]
