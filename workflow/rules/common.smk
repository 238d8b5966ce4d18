# Shared names and helpers of the rules: output folders, target lists, input selectors.
import functools

from snakemake.exceptions import WorkflowError
from uqdrive.studies.sweep import SweepError, collect_targets, load_sweep

FIG = f"{OUT}/figures"
N_LEVELS = len(NOISE_LEVELS)
#: Figs A.1-A.2L, one per model and noise level (rule fig_appendix_a); requested where both models are.
APPENDIX_A_ALL = list(range(1, 2 * N_LEVELS + 1))
APPENDIX_A = APPENDIX_A_ALL if {"lst", "nlst"} <= set(MODELS) else []
FIGURES = [f"{FIG}/fig_2_3.png", f"{FIG}/fig_5_2.png", f"{FIG}/fig_7_1.png"]
FIGURES += [f"{FIG}/fig_5_3.png", f"{FIG}/fig_5_4.png", f"{FIG}/fig_pce_convergence.png"] if "normal" in STEERS and "lst" in MODELS else []
if "normal" in STEERS:
    FIGURES += [f"{FIG}/fig_6_{i}.png" for i in (1, 2, 3, 4, 5, 6)] if APPENDIX_A else []
    FIGURES += [f"{FIG}/fig_A{n}.png" for n in APPENDIX_A]


#: Priority of the jobs that run half a minute or more (the benchmark discovers, the posteriors,
#: the wheel-slip calibration) and of those a figure job waits on (the identifications): they start before the short ones,
#: so that the DAG ends on short jobs filling both cores, not on one long job with the other core
#: idle (longest first, as list scheduling on a few cores wants it). Snakemake's schedulers
#: (ilp, greedy) take a ready job of higher priority first; its dependencies keep their own.
LONG_JOB = 1


def appendix_a_model(n):
    """Thesis numbering: A.1-A.L are the LST data sets, A.L+1-A.2L the NLST ones."""
    return "lst" if int(n) <= N_LEVELS else "nlst"

WS_FIGURES = ["paper_fig_4", "paper_fig_5", "paper_fig_6", "paper_pid_schedule", "paper_calibration", "paper_closed_loop"]
FIGURES += [f"{FIG}/{name}.png" for name in WS_FIGURES]
FIGURES += [f"{FIG}/paper_fig_poles_{n}.png" for n in config["wheelslip"]["gp"]["training_sizes"]]

ID_FIGURE_NAMES = [f"fig_6_{i}" for i in range(7, 16)] + ["fig_robust_start"] + [f"fig_B{i}" for i in range(1, 14)]
FIGURES += [f"{FIG}/{name}.png" for name in ID_FIGURE_NAMES] if {"lst", "nlst"} <= set(MODELS) and set(STEERS) == {"normal", "inverted"} else []
FIGURES += [f"{FIG}/{name}.png" for name in ("fig_6_16", "fig_6_17", "fig_6_18", "fig_gamma_sweep")] if ID_FIGURE_NAMES and {"lst", "nlst"} <= set(MODELS) else []
FIGURES += [f"{FIG}/posterior_{kind}_{case}.png" for kind in ("corner", "trace") for case in ("lst", "nlst", "lst_noise")] if {"lst", "nlst"} <= set(MODELS) else []
FIGURES += [f"{OUT}/tables/identify_coverage.csv"] if "lst" in MODELS and "coverage" in config["identification"] else []


def ws_mcmc_sets(n):
    """Sets of training size n also scored with emcee-integrated hyperparameters."""
    return dict(zip(WS_SIZES, config["wheelslip"]["calibration"]["mcmc_sets"])).get(int(n), 0)


SWEEP_DIR = f"{OUT}/sweeps"
try:  # a sweep point's workflow gets every core (points run one after another and share a cache)
    SWEEP_THREADS = workflow.cores
except WorkflowError:  # --report and --lint give no --cores
    SWEEP_THREADS = 1
#: Everything a point's run depends on besides its config: a change reruns the point's workflow,
#: which itself reruns only what the change touches.
SWEEP_CODE = sorted(str(p) for p in (REPO / "src" / "uqdrive").rglob("*.py")) + sorted(
    str(p) for p in [*(REPO / "workflow" / "rules").glob("*.smk"), *(REPO / "workflow" / "scripts").glob("*.py"), REPO / "workflow" / "Snakefile"])


def sweep_file(name):
    """config/sweeps/<name>.yaml of the working directory, else of the repository."""
    for base in (Path.cwd(), REPO):
        path = base / "config" / "sweeps" / f"{name}.yaml"
        if path.is_file():
            return path
    raise ValueError(f"no sweep file config/sweeps/{name}.yaml (in {Path.cwd()} or {REPO})")


@functools.cache
def sweep(name):
    """The parsed sweep <name> (uqdrive.studies.sweep.Sweep), every point's config validated."""
    try:
        return load_sweep(sweep_file(name), search=(Path.cwd(), REPO))
    except SweepError as err:
        raise ValueError(f"invalid sweep: {err}") from None


def sweep_base_file(name):
    """The base config file of sweep <name> as found (working directory, then repository)."""
    base = sweep(name).base_path
    return next((str(d / base) for d in (Path.cwd(), REPO) if (d / base).is_file()), base)


def point_dir(w):
    """Folder of the sweep point of the wildcards w: its config, results, metrics."""
    return f"{SWEEP_DIR}/{w.sweep}/{w.point}"


def finished_sweeps():
    """Sweeps whose summary exists (and whose file still does): the report shows them."""
    names = sorted(p.parent.name for p in Path(SWEEP_DIR).glob("*/summary.png")) if Path(SWEEP_DIR).is_dir() else []
    out = []
    for name in names:
        try:
            sweep_file(name)
        except ValueError:
            continue
        out += [f"{SWEEP_DIR}/{name}/summary.{ext}" for ext in ("csv", "png")]
    return out
