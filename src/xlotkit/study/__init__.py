"""Studies: many cases at once, on a local process pool or a Dask cluster.

* :mod:`xlotkit.study.cases` -- ``--vary`` specifications, the grid and Latin-hypercube
  samples, dotted-key overrides on a scene file's mapping;
* :mod:`xlotkit.study.sweep` -- ``xlotkit sweep``: every case simulated and its synthetic
  log picked and compared with the imposed and realised stresses;
* :mod:`xlotkit.study.batch` -- ``xlotkit pick --batch``: every log of an archive
  interpreted on its own (a surface and a downhole log of one test merged);
* :mod:`xlotkit.study.executors` -- where the cases run (local pool, Dask, in-process);
* :mod:`xlotkit.study.driver`, :mod:`xlotkit.study.table` -- resuming, the study folder
  and its table (results.parquet, results.csv).

The package sits above :mod:`xlotkit.sim` and :mod:`xlotkit.interpret` (like
:mod:`xlotkit.pipeline` and :mod:`xlotkit.library`) and uses only their public entry points.
"""
