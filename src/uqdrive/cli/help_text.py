"""What the command line's help shows beyond the flags: examples per subcommand, the candidate
effects of ``discover`` generated from the registry, and a formatter that keeps both as written."""

from __future__ import annotations

import argparse
import re

__all__ = ["HelpFormatter", "EXAMPLES", "CANDIDATES_TEXT", "DEVICE_HELP", "candidate_listing", "epilog"]

#: --device of simulate and discover, formatted with what runs where and what else the GPU implies.
DEVICE_HELP = ("where {what} integrated: cpu, {cpu} (default); gpu, JAX in float64 on a GPU (install with pip install \"uqdrive[gpu]\"; "
               "the same numbers as cpu to 1e-10 relative{gpu}); auto, the GPU when JAX sees one, else cpu{tail}")


class HelpFormatter(argparse.HelpFormatter):
    """Wraps one-paragraph descriptions to the terminal; text holding line breaks (the examples,
    the candidate list) is printed as written."""

    def _fill_text(self, text, width, indent):
        if "\n" in text:
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


#: Example command lines per subcommand (each a comment line and a command).
EXAMPLES = {
    "simulate": ("# 200 runs of the non-linear model under the slalom, with measurement noise",
                 "uqdrive simulate --model nlst --samples 200 --noise 0.05 --out runs.nc",
                 "# the model 'uqdrive discover' wrote, on another car",
                 "uqdrive simulate --model gap/model.yaml --vehicle bmw_320i --out repaired.nc"),
    "identify": ("# the distributions of mu, l_f and the mean wind of your runs, on your car",
                 "uqdrive identify runs.nc --vehicle my_car.yaml --out fit/",
                 "# the same with the effects discover found; exit 3 if the model still does not fit",
                 "uqdrive identify runs.nc --model gap/model.yaml --strict --out refit/"),
    "discover": ("# what the linear model misses in your runs, among every candidate your car's constants allow",
                 "uqdrive discover runs.nc --vehicle my_car.yaml --out gap/",
                 "# the sensors' errors and a road bank only",
                 "uqdrive discover runs.nc --candidates sensor_bias,sensor_scale,road_bank --out gap/",
                 "# only two chassis effects, no posterior sampling",
                 "uqdrive discover runs.nc --candidates longitudinal_load_transfer,compliance_steer --no-posterior --out gap/"),
    "config": ("uqdrive config --dump my.yaml      # write the default config to edit",
               "uqdrive config --check my.yaml     # validate it"),
    "vehicles": ("uqdrive vehicles                   # every packaged car",
                 "uqdrive vehicles my_car.yaml       # check a vehicle file"),
}


#: What discover searches by default and how it reports a candidate it cannot test.
CANDIDATES_TEXT = ("candidate effects (--candidates): the packaged config searches every one of them\n"
                   "(discrepancy.candidates: all). One that needs a constant your car lacks (\"needs cg_height\")\n"
                   "is not searched: the printed line and verdict.json's 'untestable' name it with the reason,\n"
                   "as they name one that acts only on channels the data lack.\n")


def _few_words(description: str, limit: int = 100) -> str:
    """The first clause of an effect's description, cut at a word within ``limit`` characters."""
    clause = re.split(r": |, | \(", description, maxsplit=1)[0]
    if len(clause) <= limit:
        return clause
    return clause[:limit].rsplit(" ", 1)[0] + " ..."


def candidate_listing() -> str:
    """Every registered candidate effect of ``discover`` with its parameters (units) and a few
    words of its physics; the sensor effects grouped by family."""
    from ..vehicle.effects import EFFECTS, FAMILIES

    family_of = {name: fam for fam, members in FAMILIES.items() for name in members}
    lines, done = [], set()
    for name, effect in EFFECTS.items():
        if name in done:
            continue
        params = ", ".join(f"{p} [{u}]" for p, u in zip(effect.parameters, effect.units))
        if name in family_of:
            fam = family_of[name]
            members = FAMILIES[fam]
            done.update(members)
            words = _few_words(effect.description.replace(name.removeprefix(fam + "_"), "channel"))
            unit = "-" if effect.units[0] == "-" else "the channel's unit"
            lines += [f"  {fam}_<channel> ({effect.parameters[0].split('_', 1)[0]} [{unit}])",
                      f"      {words}: {', '.join(members)}"]
            continue
        needs = f"; needs {', '.join(effect.requires)}" if effect.requires else ""
        lines += [f"  {name} ({params}){needs}", f"      {_few_words(effect.description)}"]
    return "\n".join(lines)


def epilog(command: str, before: str = "") -> str:
    """The text after a subcommand's flags: ``before`` (if any), then the examples."""
    examples = "\n".join(("  " + line) for line in EXAMPLES[command])
    return (before + "\n\n" if before else "") + "examples:\n" + examples + "\n"
