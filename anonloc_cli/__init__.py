"""anonloc_cli: the ``anonloc`` command line, on top of :mod:`anonloc_env` and :mod:`baselines`.

Commands (``anonloc COMMAND --help`` for each):

* ``reproduce``: the paper's table, re-run on the simulator, next to the paper's figures;
* ``bench``: any policies x scenarios x seeds, to CSV or Parquet with a summary table;
* ``study``: sweeps answering the paper's future-work questions, as plots and CSV;
* ``render``: a GIF (or MP4) of a scenario played by a policy;
* ``frame``: one rendered frame of a short random rollout (the former ``python -m anonloc_env``).

Long commands run their work units on a local process pool (or Ray tasks) and append each
finished unit to a JSON-lines store, so that re-running the same command resumes where it stopped.

Nothing in :mod:`anonloc_env` or :mod:`baselines` imports this package.
"""

from __future__ import annotations

__all__: list[str] = []
