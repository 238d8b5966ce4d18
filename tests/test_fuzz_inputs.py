"""Property-based fuzzing of the CLI's edge (issue 18): a tiny valid ensemble, config and flag set
corrupted in random ways (NaN/inf/huge values, dtype changes, dropped variables and attributes,
wrong dims and units, non-uniform or shifted time, bad v_c, spin flags, damaged files, bad
flags and output paths). Every run either is refused (exit code 2, exactly one line on stderr,
also at the file-descriptor level, and nothing left behind) or gives a valid result (exit 0,
a readable ensemble or an estimate.json with finite numbers or null). The counts of cases tried,
refused and accepted are printed (docs/workflow.md quotes them); UQDRIVE_FUZZ_LOG=FILE appends each
case's flags, exit code and stderr line to FILE.
"""

import contextlib
import io
import json
import math
import os
import sys
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
import xarray as xr
import yaml
from hypothesis import HealthCheck, Phase, given, seed, settings
from hypothesis import strategies as st

from uqdrive.cli.main import main
from uqdrive.io import read_ensemble

from conftest import tiny_config

STATES = ("psi", "psi_dot", "beta", "y")
VARIABLES = STATES + ("delta",)
BAD_NUMBERS = (math.nan, math.inf, -math.inf, 1e300, -1e300, 1e6, -1.0, 0.0)
CONFIG_LEAVES = (
    "seed", "vehicle.m_base", "vehicle.J0", "vehicle.wheelbase", "vehicle.c_Sf", "vehicle.c_Sr", "vehicle.speed_kmh",
    "vehicle.M_c", "vehicle.g", "tyre.C", "tyre.E", "uncertainty.mu.mean", "uncertainty.mu.std", "uncertainty.m_load.mean",
    "uncertainty.m_load.std", "uncertainty.l_f.mean", "uncertainty.l_f.std", "uncertainty.F_w_mean.low",
    "uncertainty.F_w_mean.high", "wind.sigma", "wind.Tc", "wind.kle_quadrature", "wind.kle_truncation",
    "steering.delta_max_deg", "steering.period", "time.t_end", "time.dt", "time.step", "montecarlo.samples",
    "montecarlo.spin_threshold", "montecarlo.spin_policy", "identification.order", "identification.quadrature_points",
    "identification.max_iter", "identification.state_scale",
)
CONFIG_VALUES = BAD_NUMBERS + ("x", None, True, [1, 2], 2.5, 3, "x1.1", "x0.9")  # "xF": F times the valid value
COUNTS = {"tried": 0, "refused": 0, "accepted": 0}


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """A valid NLST ensemble of 20 samples x 50 time points (in memory) and its config."""
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "c.yaml").write_text(yaml.safe_dump(tiny_config(t_end=0.98, samples=20)))  # 50 time points
    assert main(["simulate", "--model", "nlst", "--config", str(folder / "c.yaml"), "--out", str(folder / "e.nc")]) == 0
    ds = xr.load_dataset(folder / "e.nc")
    for name in ds.variables:
        ds[name].encoding = {}  # chunk sizes of the file would not fit a cut ensemble
    return ds


# -- corruptions ----------------------------------------------------------------------------------
def corrupt_ensemble(ds: xr.Dataset, data) -> xr.Dataset:
    kind = data.draw(st.sampled_from(["value", "scale", "dtype", "drop", "v_c", "units", "time", "dims", "size", "spread",
                                      "spun", "spin"]), label="ensemble corruption")
    var = data.draw(st.sampled_from(VARIABLES), label="variable")
    if var not in ds.variables or "sample" not in ds.dims or "time" not in ds.variables or ds.sizes["time"] < 4:
        return ds  # an earlier corruption removed what this one acts on
    if kind == "value":
        flat = ds[var].values.reshape(-1)
        flat[data.draw(st.integers(0, flat.size - 1), label="index")] = data.draw(st.sampled_from(BAD_NUMBERS), label="number")
    elif kind == "scale":
        ds[var] = ds[var] * data.draw(st.sampled_from([1e6, 1e3, 1.1, -1.0, 1e-6, 0.0]), label="factor")
    elif kind == "dtype":
        ds[var] = ds[var].astype(data.draw(st.sampled_from(["int8", "int64", "float32", "str"]), label="dtype"))
    elif kind == "drop":
        name = data.draw(st.sampled_from(VARIABLES + ("time", "spun")), label="dropped")
        ds = ds.drop_vars(name) if name in ds.variables else ds
    elif kind == "v_c":
        value = data.draw(st.sampled_from(BAD_NUMBERS + (0.4, 0.5, 100.0, 100.1, "fast", "dropped", 19.4, 1)), label="v_c")
        if value == "dropped":
            ds.attrs.pop("v_c")
        else:
            ds.attrs["v_c"] = np.array([value, value]) if data.draw(st.booleans(), label="as array") and value != "fast" else value
    elif kind == "units":
        name = data.draw(st.sampled_from(VARIABLES + ("time",)), label="of")
        ds[name].attrs["units"] = data.draw(st.sampled_from(["deg", "km", "", "seconds", "ms", "rad", "m", "s"]), label="unit")
    elif kind == "time":
        t = ds["time"].values.copy()
        how = data.draw(st.sampled_from(["jitter", "reverse", "shift", "stretch", "repeat"]), label="time")
        if how == "jitter":
            t[data.draw(st.integers(1, t.size - 2), label="at")] += 0.003
        elif how == "reverse":
            t = t[::-1].copy()
        elif how == "shift":
            t = t + 0.5
        elif how == "stretch":
            t = t * 1000.0
        else:
            t[2] = t[1]
        ds = ds.assign_coords(time=("time", t, ds["time"].attrs))
    elif kind == "dims":
        how = data.draw(st.sampled_from(["transpose", "rename", "delta2d"]), label="dims")
        if how == "transpose" and var != "delta":
            ds[var] = ds[var].transpose()
        elif how == "rename":
            ds = ds.rename({"sample": "run"})
        else:
            ds["delta"] = ds["delta"].expand_dims(sample=ds["sample"]).transpose("sample", "time")
    elif kind == "size":
        ds = ds.isel(time=slice(0, data.draw(st.sampled_from([0, 1, 2, 3]), label="time points")))
    elif kind == "spread":
        name = data.draw(st.sampled_from(STATES), label="state")
        ds[name] = ds[name] * 0.0 if data.draw(st.booleans(), label="zero") else ds[name].isel(sample=0).broadcast_like(ds[name]).copy()
    elif kind == "spun":
        ds["spun"] = ("sample", data.draw(st.sampled_from([np.ones, np.zeros, lambda n: np.full(n, 7), lambda n: np.full(n, np.nan)]),
                                          label="spun flags")(ds.sizes["sample"]))
    else:
        k = data.draw(st.integers(1, ds.sizes["sample"]), label="spun samples")
        ds["beta"].values[:k] += 0.5
    return ds


def _parent(cfg: dict, key: str):
    """(mapping holding the leaf of the dotted key, leaf name), or (None, leaf) if an earlier corruption removed it."""
    *parents, leaf = key.split(".")
    node = cfg
    for part in parents:
        node = node.get(part) if isinstance(node, dict) else None
    return (node if isinstance(node, dict) else None), leaf


def corrupt_config(cfg: dict, data) -> bytes:
    kind = data.draw(st.sampled_from(["leaf", "leaf", "leaf", "drop", "unknown", "bytes"]), label="config corruption")
    key = data.draw(st.sampled_from(CONFIG_LEAVES), label="key")
    node, leaf = _parent(cfg, key)
    if kind == "leaf" and node is not None and leaf in node:
        value = data.draw(st.sampled_from(CONFIG_VALUES), label="value")
        node[leaf] = node[leaf] * float(value[1:]) if isinstance(value, str) and value.startswith("x") and len(value) > 1 else value
    elif kind == "drop" and node is not None:
        node.pop(leaf, None)
    elif kind == "unknown":
        cfg.setdefault("vehicle", {})["m_bse"] = 1.0
    text = yaml.safe_dump(cfg).encode()
    if kind == "bytes":
        how = data.draw(st.sampled_from(["latin1", "truncate", "list", "tab"]), label="bytes")
        text = {"latin1": text + "# Gr\xfc\xdfe\n".encode("latin-1"), "truncate": text[: len(text) // 3] + b"[",
                "list": b"- 1\n- 2\n", "tab": b"vehicle:\n\t m_base: 1\n"}[how]
    return text


FLAGS = {
    "identify": {"--m-load": ["nan", "inf", "-1", "1e300", "abc", "150", "0"], "--starts": ["-1", "0", "1", "x"],
                 "--state-scale": ["none", "rms_std", "bogus"], "--cost": ["std", "inp", "xyz"]},
    "simulate": {"--seed": ["-1", str(2**64), str(2**63 - 1), "0", "1.5"], "--samples": ["1", "0", "3", "-5"],
                 "--noise": ["nan", "-0.1", "0.05", "2"], "--model": ["lst", "nlst", "bicycle"]},
}


# -- one run --------------------------------------------------------------------------------------
@contextlib.contextmanager
def captured():
    """stdout and stderr of an in-process run, stderr also at the file-descriptor level (C libraries)."""
    out, err = io.StringIO(), io.StringIO()
    with tempfile.TemporaryFile() as fd_file:
        sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(fd_file.fileno(), 2)
        result = {}
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                yield result
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            fd_file.seek(0)
            result["stderr"] = err.getvalue() + fd_file.read().decode(errors="replace")
            result["stdout"] = out.getvalue()


def files_under(folder: Path) -> dict:
    return {p.relative_to(folder): (p.stat().st_size if p.is_file() else None) for p in folder.rglob("*")}


def _stub_figure(stats, moments, path, title=""):
    Path(path).write_bytes(b"\x89PNG\r\n\x1a\n")  # the fuzz checks the edge, not matplotlib


def check_valid_result(command: str, out: Path) -> None:
    if command == "simulate":
        ds = read_ensemble(out)
        assert ds.sizes["sample"] >= 2
        return
    est = json.loads((out / "estimate.json").read_text())
    assert isinstance(est["converged"], bool) and isinstance(est["warnings"], list)
    for key in ("mu", "l_f", "F_w_mean"):
        assert all(v is None or math.isfinite(v) for v in est[key])
    assert est["n_spun"] == len(est["spun_indices"]) and est["samples_used"] >= 2
    assert (out / "fit.png").is_file()


@pytest.mark.long(10)
def test_fuzzed_inputs_are_refused_in_one_line_or_give_a_valid_result(base, capsys):
    @seed(20230601)  # reproducible cases, so that the counts docs/workflow.md quotes stay put
    @settings(max_examples=60, deadline=None, database=None, suppress_health_check=list(HealthCheck),
              phases=(Phase.explicit, Phase.generate))  # no shrinking: the draws of a failure are printed as they are
    @given(data=st.data())
    def run(data):
        command = data.draw(st.sampled_from(["identify", "identify", "identify", "simulate"]), label="command")
        kinds = ["ensemble", "ensemble", "config", "flag", "out"] if command == "identify" else ["config", "flag", "out"]
        targets = data.draw(st.lists(st.sampled_from(kinds), min_size=1, max_size=2), label="targets")
        ds = base.isel(sample=slice(0, data.draw(st.integers(5, 20), label="samples")),
                       time=slice(0, data.draw(st.integers(20, 50), label="time points"))).copy(deep=True)
        cfg = tiny_config(t_end=0.98, samples=20)  # 50 time points
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            config_bytes = yaml.safe_dump(cfg).encode()
            for target in targets:
                if target == "ensemble":
                    ds = corrupt_ensemble(ds, data)
                elif target == "config":
                    config_bytes = corrupt_config(cfg, data)
            (tmp / "c.yaml").write_bytes(config_bytes)
            measured = tmp / "m.nc"
            ds.to_netcdf(measured)
            if "ensemble" in targets and data.draw(st.integers(0, 9), label="damage file") == 0:
                raw = measured.read_bytes()
                measured.write_bytes(raw[: len(raw) // 2] if data.draw(st.booleans(), label="truncate") else b"\x00" * 64 + raw[64:])
            out = tmp / "out" / ("x.nc" if command == "simulate" else "est")
            argv = [command] + ([str(measured)] if command == "identify" else ["--model", "lst", "--samples", "6"])
            argv += ["--config", str(tmp / "c.yaml")]
            if "flag" in targets:
                flag = data.draw(st.sampled_from(sorted(FLAGS[command])), label="flag")
                argv += [f"{flag}={data.draw(st.sampled_from(FLAGS[command][flag]), label='flag value')}"]
            if "out" in targets:
                how = data.draw(st.sampled_from(["under_file", "exists", "exists_force", "exists_force"]), label="out")
                if how == "under_file":
                    (tmp / "out").write_text("a file")
                else:
                    target = out if command == "simulate" else out / "estimate.json"
                    target.parent.mkdir(parents=True)
                    target.write_text("previous run")
                    argv += ["--force"] if how == "exists_force" else []
            else:
                (tmp / "out").mkdir()
            before = files_under(tmp)
            with mock.patch("uqdrive.cli.identify._figure", _stub_figure), captured() as io_:
                rc = main(argv + ["--out", str(out)])
            COUNTS["tried"] += 1
            if os.environ.get("UQDRIVE_FUZZ_LOG"):
                with open(os.environ["UQDRIVE_FUZZ_LOG"], "a") as log:
                    log.write(f"{rc} {argv[1:]} {io_['stderr'].strip()!r}\n")
            if rc == 2:
                COUNTS["refused"] += 1
                err = io_["stderr"]
                assert err.count("\n") == 1 and err.endswith("\n") and "Traceback" not in err, (argv, err)
                assert files_under(tmp) == before, (argv, err)
            else:
                assert rc == 0, (argv, rc, io_["stderr"])
                COUNTS["accepted"] += 1
                check_valid_result(command, out)

    run()
    assert COUNTS["tried"] == COUNTS["refused"] + COUNTS["accepted"] >= 60
    assert COUNTS["refused"] > 0 and COUNTS["accepted"] > 0
    with capsys.disabled():
        print(f"\nfuzz: {COUNTS['tried']} cases tried, {COUNTS['refused']} refused (exit 2, one line, nothing left), "
              f"{COUNTS['accepted']} accepted (valid result)")
