"""report: what a fit tells the user, written without ever touching a file of theirs.

    FitResult, DiscoveryResult, recording
        ──force_check──▶ the barrier's load cells against the model's force (sensor recordings)
        ──comparison──▶ default versus identified parameters, run side by side
        ──plots, markdown, trajectory_csv──▶ figures, report.md, predictions.csv
        ──results──▶ result.json and the results folder, written atomically

- ``results``: the results folder, written into a temporary sibling and moved into place, and
  result.json's serialisation.
- ``markdown``: ``report.md``, the paper's Table 1 side by side.
- ``plots``: the fit's figures in the style of the paper's Figs. 4-7.
- ``comparison``: the position difference between two parameter sets over time.
- ``force_check``: the independent check of a fit against a load-cell barrier.
- ``trajectory_csv``: a simulated trajectory as CSV in the interface's columns.
"""
