"""Parameter sweeps: any config value swept from one file (:mod:`.spec`), one summary of the
points' metrics (:mod:`.summary`). Only the file side is imported here: the workflow reads it
while it parses its rules, and the summary needs xarray."""

from .spec import COLLECTORS, Sweep, SweepError, SweepPoint, collect_targets, expand_points, load_sweep, parse_sweep, point_name

__all__ = ["SweepError", "SweepPoint", "Sweep", "COLLECTORS", "load_sweep", "parse_sweep", "expand_points", "point_name",
           "collect_targets"]
