"""Sweeps: many headless runs (or simulated study participants) from one spec, as tasks on Dask.

``pedvr sweep SPEC.toml`` → :func:`pedvr.sweep.spec.load_spec` (validate, expand
into tasks with stable keys) → :func:`pedvr.sweep.runner.run_sweep` (a
LocalCluster, an existing scheduler, or serially; each task is
:func:`pedvr.sweep.task.execute`) → ``DIR/runs.parquet`` (:mod:`pedvr.sweep.table`),
recordings, a merged study store (:mod:`pedvr.sweep.participants`) →
``pedvr sweep report DIR`` (:mod:`pedvr.sweep.report`). SteerSuite cases get
SteerBench scores (:mod:`pedvr.sweep.steerbench`).

Needs the ``sweep`` extra (``pip install -e '.[sweep]'``: dask.distributed and
pyarrow); nothing here is imported by ``pedvr run``.
"""
