"""The logic moved out of the workflow's fig_* scripts into the package: the CSV writer, the
identification figure plan, and the rows of Tables 6.2/6.3, the posterior summary and the
controller table, each checked on small synthetic datasets."""

import csv
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr

from uqdrive.io import OutputError, write_csv_rows
from uqdrive.plots.identification import APPENDIX_B_PLAN, FIGURE_NAMES, identification_figures
from uqdrive.studies.bayes import posterior_table_rows
from uqdrive.studies.control import controller_table_rows
from uqdrive.studies.tables import THESIS_TABLE_6_2, thesis_table_rows

REPO = Path(__file__).resolve().parents[1]
PARAMETERS = ["mu_mean", "mu_std", "l_f_mean", "l_f_std", "F_w_mean_low", "F_w_mean_high"]
TRUTH = np.array([1.0, 0.2, 1.55, 0.2, -400.0, 400.0])
FOUR = ["LST-STD", "NLST-STD", "NLST-INP", "NLST-DST"]
TABLE_COLUMNS = ["estimate", "runs", "mu", "l_f [m]", "F_w_mean [N]", "GN error mu", "GN error l_f", "GN error wind",
                 "thesis mu", "thesis l_f", "thesis wind"]


# --- write_csv_rows ---------------------------------------------------------------------------

def test_write_csv_rows_keeps_column_order_and_values(tmp_path):
    path = tmp_path / "t.csv"
    write_csv_rows([{"b": 1, "a": "x, y"}, {"b": 2.5, "a": None}], path)
    assert path.read_bytes() == b'b,a\r\n1,"x, y"\r\n2.5,\r\n'
    with open(path, newline="") as fh:
        assert list(csv.DictReader(fh)) == [{"b": "1", "a": "x, y"}, {"b": "2.5", "a": ""}]
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]


def test_write_csv_rows_refuses_bad_tables_and_leaves_nothing(tmp_path):
    with pytest.raises(ValueError, match="at least one row"):
        write_csv_rows([], tmp_path / "empty.csv")
    with pytest.raises(ValueError):  # a later row with a column the header lacks
        write_csv_rows([{"a": 1}, {"a": 2, "b": 3}], tmp_path / "bad.csv")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(OutputError, match="does not exist"):
        write_csv_rows([{"a": 1}], tmp_path / "missing" / "t.csv")


# --- identification: tables and figure plan ---------------------------------------------------

def _identification(estimates, n_runs=3, scale=1.0, nan_run=None):
    """Every run estimates ``scale * TRUTH`` (run ``nan_run`` of the second estimate failed)."""
    theta = np.broadcast_to(scale * TRUTH, (n_runs, len(estimates), 6)).copy()
    if nan_run is not None:
        theta[nan_run, 1] = np.nan
    theta_std = np.full_like(theta, 0.01)
    theta_std[..., 4:] = 5.0
    rng = np.random.default_rng(0)
    return xr.Dataset(
        {"theta": (("run", "estimate", "parameter"), theta), "theta_std": (("run", "estimate", "parameter"), theta_std),
         "w2": (("run", "estimate", "distribution"), 0.01 + rng.random((n_runs, len(estimates), 3))),
         "w2_thesis": (("run", "estimate", "distribution"), rng.random((n_runs, len(estimates), 3))),
         "truth": ("parameter", TRUTH), "deviation": ("run", np.linspace(-0.1, 0.1, n_runs))},
        coords={"run": np.arange(1, n_runs + 1), "estimate": list(estimates), "parameter": PARAMETERS, "distribution": ["mu", "l_f", "F_w_mean"]},
        attrs={"n_spun_excluded_nlst": 2},
    )


@pytest.fixture(scope="module")
def experiments():
    return {
        "basic": _identification(FOUR, nan_run=0), "inverted": _identification(FOUR[1:], scale=1.1),
        "initial_guess": _identification(FOUR), "noise": _identification(FOUR + ["LST-STD noise-aware", "NLST-STD noise-aware"], n_runs=2),
        "robust": _identification(["NLST-STD single", "NLST-STD multi-start"]), "no_wind_moment": _identification(FOUR, scale=0.9),
        "normalised": _identification(FOUR, scale=0.8), "normalised_inverted": _identification(FOUR[1:], scale=0.7),
    }


def test_table_6_2_rows_with_both_variants(experiments):
    rows = thesis_table_rows(experiments, "6.2")
    assert len(rows) == 3 * len(FOUR)
    assert all(list(r) == TABLE_COLUMNS for r in rows)
    assert [r["estimate"] for r in rows] == FOUR + [f"{e} (M_c = 0)" for e in FOUR] + [f"{e} (unit-free residuals)" for e in FOUR]
    basic, nlst_std, no_moment = rows[0], rows[1], rows[4]
    assert (basic["runs"], nlst_std["runs"]) == (3, 2)  # the failed run is left out of the mean
    assert basic["mu"] == "N(1.000, 0.200)" and basic["F_w_mean [N]"] == "U(-400, 400)"
    assert basic["GN error mu"] == "+-(0.010, 0.010)" and basic["GN error wind"] == "+-(5, 5)"
    assert no_moment["mu"] == "N(0.900, 0.180)" and rows[8]["l_f [m]"] == "N(1.240, 0.160)"
    ref = THESIS_TABLE_6_2["NLST-STD"]
    assert rows[5]["thesis mu"] == f"N({ref[0]}, {ref[1]})" == "N(0.797, 0.192)"  # variants beside the published values


def test_table_6_3_rows_and_missing_variants(experiments):
    rows = thesis_table_rows(experiments, "6.3")
    assert [r["estimate"] for r in rows] == FOUR[1:] + [f"{e} (unit-free residuals)" for e in FOUR[1:]]
    assert rows[0]["mu"] == "N(1.100, 0.220)" and rows[0]["thesis wind"] == "U(-370, 597)"
    assert rows[3]["l_f [m]"] == "N(1.085, 0.140)"
    only_thesis = thesis_table_rows({"basic": experiments["basic"]}, "6.2")
    assert [r["estimate"] for r in only_thesis] == FOUR
    with pytest.raises(ValueError, match="no thesis table"):
        thesis_table_rows(experiments, "6.4")
    with pytest.raises(KeyError):
        thesis_table_rows({"basic": experiments["basic"]}, "6.3")


def _titles(fig):
    return fig._suptitle.get_text() if fig._suptitle is not None else ""


def test_identification_figure_plan(experiments, cfg, tmp_path):
    cfg["noise"]["levels"] = [0.0, 0.05, 0.1]  # two noisy levels, as the noise experiment's two runs
    figure_paths = [str(tmp_path / f"{n}.png") for n in reversed(FIGURE_NAMES)]  # any order
    appendix_paths = [tmp_path / f"fig_B{k}.png" for k in range(1, 14)]
    plan = []
    for fig, path in identification_figures(experiments, cfg, figure_paths, appendix_paths):
        legend = [t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()]
        plan.append((Path(path).stem, _titles(fig), legend))
        plt.close(fig)
    assert len(plan) == len(FIGURE_NAMES) + 13 == 23
    assert [p[0] for p in plan] == list(FIGURE_NAMES) + [f"fig_B{k}" for k in range(1, 14)]
    titles = dict((p[0], p[1]) for p in plan)
    assert titles["fig_6_8"].startswith("Fig 6.8: NLST-LST, basic test (2 spun runs excluded)")
    assert titles["fig_6_13"] == "Fig 6.13: LST-LST, noise (dashed: noise-aware, past the thesis)"
    assert titles["fig_B1"] == "Fig B.1: LST-STD, basic test"
    assert titles["fig_B5"] == "Fig B.5: LST-STD, initial-guess test"
    assert titles["fig_B13"] == "Fig B.13: NLST-DST, inverted test"
    assert len(APPENDIX_B_PLAN) == 13 and APPENDIX_B_PLAN[8] == ("noise", "NLST-STD")
    tyre_legend = dict((p[0], p[2]) for p in plan)["fig_6_10"]
    assert "NLST-INP: mu = 1.000" in tyre_legend and "NLST-STD: mu = 1.000" in tyre_legend  # nanmean skips the failed run


def test_identification_figure_plan_checks_paths_first(experiments, cfg, tmp_path):
    names = [str(tmp_path / f"{n}.png") for n in FIGURE_NAMES]
    appendix = [str(tmp_path / f"fig_B{k}.png") for k in range(1, 14)]
    open_before = plt.get_fignums()
    with pytest.raises(KeyError, match="fig_6_12"):
        next(identification_figures(experiments, cfg, [p for p in names if "fig_6_12" not in p], appendix))
    with pytest.raises(ValueError, match="12 appendix paths"):
        next(identification_figures(experiments, cfg, names, appendix[:-1]))
    assert plt.get_fignums() == open_before  # nothing drawn before the checks


# --- emcee summary table -------------------------------------------------------------------------

def _posterior(unit_free=True):
    """Two ensembles of 4 walkers; every finite step holds values c_j -+ d_j (half the walkers
    each); ensemble 1 ran 8 of the 10 steps (NaN padded)."""
    c, d = np.array([1.0, 0.2, 1.5, 0.2, -400.0, 400.0]), np.array([0.1, 0.01, 0.05, 0.02, 50.0, 40.0])
    chain = np.empty((2, 10, 4, 6))
    chain[:, :, :2], chain[:, :, 2:] = c - d, c + d
    chain[1, 8:] = np.nan
    attrs = {"optimiser_estimate": c + 0.5 * d, "truth": TRUTH, "seconds": 41.6}
    if unit_free:
        attrs["optimiser_estimate_unit_free"] = c - 0.5 * d
    return xr.Dataset(
        {"chain": (("ensemble", "step", "walker", "parameter"), chain), "tau": (("ensemble", "parameter"), np.full((2, 6), 2.0)),
         "burn": ("ensemble", [2, 2]), "thin": ("ensemble", [1, 2]), "r_hat": ("parameter", np.full(6, 1.0041)),
         "ess": ("parameter", np.arange(100.0, 106.0))},
        coords={"parameter": PARAMETERS}, attrs=attrs,
    )


def test_posterior_table_rows():
    titles = {"lst": "LST-LST", "nlst": "NLST-LST"}
    rows = posterior_table_rows({"lst": _posterior(), "nlst": _posterior(unit_free=False)}, titles)
    assert len(rows) == 12
    assert list(rows[0]) == ["case", "parameter", "posterior mean", "95% interval", "optimiser", "optimiser (unit-free)", "truth",
                             "tau", "N/tau", "R-hat", "ESS", "seconds"]
    assert [r["case"] for r in rows] == ["LST-LST"] * 6 + ["NLST-LST"] * 6
    mu, wind_low = rows[0], rows[4]
    assert (mu["parameter"], mu["posterior mean"], mu["95% interval"]) == ("mu_mean", "1", "[0.9, 1.1]")
    assert (mu["optimiser"], mu["optimiser (unit-free)"], mu["truth"]) == ("1.05", "0.95", "1")
    assert wind_low["95% interval"] == "[-450, -350]" and wind_low["ESS"] == "104"
    assert (mu["tau"], mu["N/tau"], mu["R-hat"], mu["seconds"]) == ("2", "4", "1.004", "42")  # N/tau: 8 finite steps / 2
    assert rows[6]["optimiser (unit-free)"] == ""


def test_posterior_table_rows_uses_given_summaries():
    fake = {"mean": np.full(6, 7.0), "low": np.full(6, 6.0), "high": np.full(6, 8.0)}
    rows = posterior_table_rows({"lst": _posterior()}, {"lst": "LST-LST"}, {"lst": fake})
    assert (rows[2]["posterior mean"], rows[2]["95% interval"]) == ("7", "[6, 8]")


# --- controller table ----------------------------------------------------------------------------

def _closed_loop(controllers, stable):
    """Two samples on t = 0, 0.5, ..., 3; after t = 1 s sample values 1 and 3 (y), -1 and -3 (beta),
    0.5 each (delta); huge values before, which the table must ignore."""
    t = np.arange(0.0, 3.01, 0.5)
    late = t > 1
    y = np.full((len(controllers), 2, t.size), 1e6)
    y[:, 0, late], y[:, 1, late] = 1.0, 3.0
    return xr.Dataset(
        {"y": (("controller", "sample", "time"), y), "beta": (("controller", "sample", "time"), -y),
         "delta": (("controller", "sample", "time"), np.where(late, 0.5, 1e6) * np.ones_like(y)),
         "stable": (("controller", "sample"), np.array(stable, np.int8))},
        coords={"controller": controllers, "sample": [0, 1], "time": t},
    )


def test_controller_table_rows():
    gains = xr.Dataset({"K": (("controller", "state"), [[-1.23456, 0.1, 0.2, 0.3], [2.0, 0.0, 0.0, -0.5]])},
                       coords={"controller": ["LQR", "SLQR"], "state": ["psi", "psi_dot", "beta", "y"]})
    lst = _closed_loop(["LQR", "SLQR"], [[1, 1], [1, 0]])
    nlst = _closed_loop(["SLQR", "LQR"], [[0, 0], [1, 1]])  # controllers are picked by name, not position
    rows = controller_table_rows(gains, lst, nlst)
    assert len(rows) == 2
    expected = ["controller", "K"] + [
        col for model in ("LST", "NLST")
        for col in [c for v in ("y", "beta", "delta") for c in (f"{model} mean |{v}| (t>1s)", f"{model} var {v} (t>1s)")] + [f"{model} unstable runs"]
    ]
    assert list(rows[0]) == expected and len(expected) == 16
    lqr, slqr = rows
    assert lqr["controller"] == "LQR" and lqr["K"] == "[-1.235  0.1    0.2    0.3  ]"
    assert lqr["LST mean |y| (t>1s)"] == "2" and lqr["LST var y (t>1s)"] == "2"  # mean of 1 and 3; ddof=1 variance
    assert lqr["NLST mean |beta| (t>1s)"] == "2" and lqr["LST var delta (t>1s)"] == "0"
    assert (lqr["LST unstable runs"], slqr["LST unstable runs"]) == (0, 1)
    assert (lqr["NLST unstable runs"], slqr["NLST unstable runs"]) == (0, 2)
