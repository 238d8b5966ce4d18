"""One validation layer at the edge (issue 18): an independent battery of bad files, configs and
flags, each refused with exit code 2, exactly one line on stderr naming the field, no traceback
and nothing written; outputs only once the input is accepted; --force; clean exits on signals."""

import ctypes
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from uqdrive.cli.identify import fit_warnings
from uqdrive.cli.main import Interrupted, _signals_exit_cleanly, main
from uqdrive import interrupts
from uqdrive.interrupts import package_roots, shielded
from uqdrive.io import OutputError, atomic_path, write_dataset

from conftest import REPO, tiny_config, tiny_files


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """(config file, valid NLST ensemble file) of 12 samples x 41 time points."""
    return tiny_files(tmp_path_factory.mktemp("tiny"))


def files_under(folder: Path) -> set:
    return {p.relative_to(folder) for p in folder.rglob("*")}


def refused(capsys, rc, *needles):
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert "Traceback" not in err and err.startswith("uqdrive"), err
    for needle in needles:
        assert needle in err, err
    return err


# -- bad ensembles ------------------------------------------------------------------------------------
def _set(ds, name, index, value):
    ds[name].values[index] = value
    return ds


def _attr(ds, **attrs):
    ds.attrs.update(attrs)
    return ds


def _drop_attr(ds, name):
    ds.attrs.pop(name)
    return ds


def _scaled(ds, factor):
    for s in ("psi", "psi_dot", "beta", "y"):
        ds[s] = ds[s] * factor
    return ds


BAD_FILES = {
    "inf": (lambda d: _set(d, "y", (3, 7), np.inf), "'y' holds 1 infinite"),
    "minus_inf": (lambda d: _set(d, "psi", (0, 1), -np.inf), "'psi' holds 1 infinite"),
    "huge": (lambda d: _set(d, "beta", (2, 9), 1e300), "'beta' reaches"),
    "scaled_1e6": (lambda d: _scaled(d, 1e6), "beyond the physical"),
    "int_dtype": (lambda d: d.assign(psi=d["psi"].astype("int64")), "'psi' has dtype int64"),
    "str_dtype": (lambda d: d.assign(y=d["y"].astype(str)), "'y' has dtype"),
    "delta_in_degrees": (lambda d: d.assign(delta=np.rad2deg(d["delta"]) * 20), "'delta' reaches"),
    "v_c_negative": (lambda d: _attr(d, v_c=-19.4), "'v_c' = -19.4"),
    "v_c_zero": (lambda d: _attr(d, v_c=0.0), "'v_c' = 0 m/s"),
    "v_c_nan": (lambda d: _attr(d, v_c=np.nan), "'v_c' = nan"),
    "v_c_huge": (lambda d: _attr(d, v_c=1e6), "'v_c' = 1e+06 m/s"),
    "v_c_string": (lambda d: _attr(d, v_c="fast"), "'v_c' is 'fast'"),
    "v_c_array": (lambda d: _attr(d, v_c=np.array([19.4, 20.0])), "'v_c' is array"),
    "v_c_missing": (lambda d: _drop_attr(d, "v_c"), "missing global attribute 'v_c'"),
    "two_time_points": (lambda d: d.isel(time=[0, 1]), "at least 3"),
    "one_sample": (lambda d: d.isel(sample=[0]), "at least 2 realisations"),
    "all_zero": (lambda d: _scaled(d, 0.0), "zero everywhere"),
    "identical_samples": (lambda d: d.isel(sample=[0] * 6).assign_coords(sample=np.arange(6)), "identical in every realisation"),
    "late_start": (lambda d: d.assign_coords(time=d["time"] + 1.0), "starts at 1 s"),
    "time_ms": (lambda d: d.assign_coords(time=d["time"].assign_attrs(units="ms")), "units 'ms'"),
    "time_seconds": (lambda d: d.assign_coords(time=d["time"].assign_attrs(units="seconds")), "units 'seconds'"),
    "non_uniform": (lambda d: d.assign_coords(time=d["time"].values ** 1.05), "uniform"),
    "all_spun": (lambda d: d.assign(beta=d["beta"] + 0.5), "only 0 of 12 realisations kept control"),
    "spun_garbage": (lambda d: d.assign(spun=("sample", np.full(d.sizes["sample"], 7, np.int8))), "'spun' must be"),
    "missing_delta": (lambda d: d.drop_vars("delta"), "missing variable 'delta'"),
    "transposed": (lambda d: d.assign(y=d["y"].T), "'y' has dims ('time', 'sample')"),
    "beta_in_deg": (lambda d: d.assign(beta=d["beta"].assign_attrs(units="deg")), "units 'deg'"),
    "no_sample_dim": (lambda d: d.rename({"sample": "run"}), "missing dimension 'sample'"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_ensemble_is_refused_in_one_line(tiny, tmp_path, capsys, case):
    config, data = tiny
    corrupt, needle = BAD_FILES[case]
    bad = tmp_path / "bad.nc"
    corrupt(xr.load_dataset(data)).to_netcdf(bad)
    before = files_under(tmp_path)
    rc = main(["identify", str(bad), "--config", str(config), "--out", str(tmp_path / "out" / "est")])
    refused(capsys, rc, needle)
    assert files_under(tmp_path) == before


@pytest.mark.parametrize("how, needle", [("missing", "does not exist"), ("folder", "not a file"), ("text", "not a readable netCDF"),
                                         ("empty", "not a readable netCDF")])
def test_unreadable_input_is_refused(tiny, tmp_path, capsys, how, needle):
    path = tmp_path / "in.nc"
    if how == "folder":
        path.mkdir()
    elif how == "text":
        path.write_text("psi,beta\n1,2\n")
    elif how == "empty":
        path.write_bytes(b"")
    before = files_under(tmp_path)
    refused(capsys, main(["identify", str(path), "--config", str(tiny[0]), "--out", str(tmp_path / "out")]), needle)
    assert files_under(tmp_path) == before


# -- bad configs --------------------------------------------------------------------------------------
def _cfg(mutate):
    def make(path):
        cfg = tiny_config()
        mutate(cfg)
        path.write_text(yaml.safe_dump(cfg))
    return make


def _raw(text: bytes):
    return lambda path: path.write_bytes(text)


def _replace(old, new):
    return lambda path: path.write_text(yaml.safe_dump(tiny_config()).replace(old, new))


BAD_CONFIGS = {
    "latin1": (_raw("seed: 1\n# Gr\xfc\xdfe\n".encode("latin-1")), "not UTF-8"),
    "dt_nan": (_replace("dt: 0.02", "dt: .nan"), "'time.dt' is nan"),
    "mu_mean_inf": (_replace("mean: 1.0", "mean: .inf"), "'uncertainty.mu.mean' is inf"),
    "mu_std_nan": (_cfg(lambda c: c["uncertainty"]["mu"].update(std=float("nan"))), "uncertainty.mu.std"),
    "m_load_negative": (_cfg(lambda c: c["uncertainty"]["m_load"].update(mean=-1784.0)), "uncertainty.m_load.mean"),
    "l_f_std_negative": (_cfg(lambda c: c["uncertainty"]["l_f"].update(std=-0.1)), "uncertainty.l_f.std"),  # 0 declares l_f known
    "m_base_huge": (_cfg(lambda c: c["vehicle"].update(m_base=1e300)), "vehicle.m_base"),
    "speed_zero": (_cfg(lambda c: c["vehicle"].update(speed_kmh=0.0)), "vehicle.speed_kmh"),
    "t_end_equals_dt": (_cfg(lambda c: c["time"].update(t_end=0.02)), "time.t_end"),
    "step_negative": (_cfg(lambda c: c["time"].update(step=-0.01)), "time.step"),
    "seed_too_big": (_cfg(lambda c: c.update(seed=2**64)), "'seed'"),
    "samples_float_huge": (_cfg(lambda c: c["montecarlo"].update(samples=1e300)), "montecarlo.samples"),
    "a_list": (_raw(b"- 1\n- 2\n"), "mapping of keys"),
    "empty": (_raw(b""), "mapping of keys"),
    "not_yaml": (_raw(b"vehicle: [1,\n  2\n"), "not valid YAML"),
    "typo": (_cfg(lambda c: c["vehicle"].update(m_bse=1.0)), "'vehicle.m_bse' is not known"),
    "missing_key": (_cfg(lambda c: c["time"].pop("dt")), "'time.dt' is missing"),
    "wind_sigma_string": (_cfg(lambda c: c["wind"].update(sigma="100 N")), "wind.sigma"),
}


@pytest.mark.parametrize("command", ["simulate", "identify"])
@pytest.mark.parametrize("case", sorted(BAD_CONFIGS))
def test_bad_config_is_refused_in_one_line(tiny, tmp_path, capsys, case, command):
    make, needle = BAD_CONFIGS[case]
    config = tmp_path / "c.yaml"
    make(config)
    before = files_under(tmp_path)
    if command == "simulate":
        argv = ["simulate", "--model", "lst", "--samples", "4", "--config", str(config), "--out", str(tmp_path / "x.nc")]
    else:
        argv = ["identify", str(tiny[1]), "--config", str(config), "--out", str(tmp_path / "out")]
    refused(capsys, main(argv), needle)
    assert files_under(tmp_path) == before


def test_config_check_names_the_key(tmp_path, capsys):
    make, _ = BAD_CONFIGS["m_load_negative"]
    make(tmp_path / "c.yaml")
    refused(capsys, main(["config", "--check", str(tmp_path / "c.yaml")]), "uncertainty.m_load.mean", "[0, 100000] kg")
    assert main(["config", "--check", str(REPO / "config" / "config.yaml")]) == 0


# -- bad flags ----------------------------------------------------------------------------------------
BAD_FLAGS = {
    "m_load_nan": (["identify", "DATA", "--m-load", "nan"], "--m-load nan"),
    "m_load_inf": (["identify", "DATA", "--m-load", "inf"], "--m-load inf"),
    "m_load_negative": (["identify", "DATA", "--m-load", "-1784"], "--m-load -1784"),
    "m_load_text": (["identify", "DATA", "--m-load", "heavy"], "not a number"),
    "starts_negative": (["identify", "DATA", "--starts", "-1"], "--starts -1"),
    "state_scale": (["identify", "DATA", "--state-scale", "si"], "--state-scale 'si' is unknown; choose one of none, rms_mean, rms_std"),
    "seed_2_64": (["simulate", "--model", "lst", "--seed", str(2**64)], "--seed 18446744073709551616"),
    "seed_negative": (["simulate", "--model", "lst", "--seed", "-1"], "--seed -1"),
    "seed_float": (["simulate", "--model", "lst", "--seed", "1.5"], "not an integer"),
    "samples_one": (["simulate", "--model", "lst", "--samples", "1"], "--samples 1"),
    "noise_nan": (["simulate", "--model", "lst", "--noise", "nan"], "--noise nan"),
    "noise_negative": (["simulate", "--model", "lst", "--noise", "-0.1"], "--noise -0.1"),
    "no_out": (["simulate", "--model", "lst", "NO_OUT"], "required: --out"),
}


@pytest.mark.parametrize("case", sorted(BAD_FLAGS))
def test_bad_flag_is_refused_in_one_line(tiny, tmp_path, capsys, case):
    argv, needle = BAD_FLAGS[case]
    argv = [str(tiny[1]) if a == "DATA" else a for a in argv if a != "NO_OUT"]
    if case != "no_out":
        argv += ["--out", str(tmp_path / ("x.nc" if argv[0] == "simulate" else "out"))]
    argv += ["--config", str(tiny[0])]
    err = refused(capsys, main(argv), needle)
    assert "usage:" not in err
    assert files_under(tmp_path) == set()


@pytest.mark.parametrize("command", ["simulate", "identify"])
def test_out_under_a_regular_file(tiny, tmp_path, capsys, command):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    out = blocker / "sub" / ("x.nc" if command == "simulate" else "est")
    argv = (["simulate", "--model", "lst", "--samples", "3"] if command == "simulate" else ["identify", str(tiny[1])])
    refused(capsys, main(argv + ["--config", str(tiny[0]), "--out", str(out)]), "regular file")
    assert files_under(tmp_path) == {Path("file")}


@pytest.mark.parametrize("command", ["simulate", "identify"])
def test_out_in_a_read_only_folder(tiny, tmp_path, capsys, monkeypatch, command):
    """Refused before any work. As root a chmod does not bind, so os.access reports it instead."""
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    if os.geteuid() == 0:
        real = os.access
        monkeypatch.setattr("uqdrive.outputs.os.access", lambda p, mode: False if Path(p) == folder else real(p, mode))
    out = folder / ("x.nc" if command == "simulate" else "est")
    argv = (["simulate", "--model", "lst", "--samples", "3"] if command == "simulate" else ["identify", str(tiny[1])])
    try:
        refused(capsys, main(argv + ["--config", str(tiny[0]), "--out", str(out)]), "not writable")
        assert list(folder.iterdir()) == []
    finally:
        folder.chmod(0o755)


# -- outputs only after acceptance, --force -----------------------------------------------------------
def test_failed_identify_creates_no_folder(tiny, tmp_path, capsys):
    bad = tmp_path / "bad.nc"
    xr.load_dataset(tiny[1]).assign(y=lambda d: d["y"] * np.inf).to_netcdf(bad)
    rc = main(["identify", str(bad), "--config", str(tiny[0]), "--out", str(tmp_path / "a" / "b" / "est")])
    refused(capsys, rc, "'y'")
    assert not (tmp_path / "a").exists()


def test_identify_refuses_existing_output_unless_forced(tiny, tmp_path, capsys):
    out = tmp_path / "est"
    argv = ["identify", str(tiny[1]), "--config", str(tiny[0]), "--out", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    first = (out / "estimate.json").read_bytes()
    (out / "estimate.json").write_text("{}")
    refused(capsys, main(argv), "exists; pass --force")
    assert (out / "estimate.json").read_text() == "{}"
    assert main(argv + ["--force"]) == 0
    assert (out / "estimate.json").read_bytes() == first
    assert sorted(p.name for p in out.iterdir()) == ["estimate.json", "fit.png"]


def test_simulate_refuses_existing_output_unless_forced(tiny, tmp_path, capsys):
    out = tmp_path / "x.nc"
    out.write_text("old")
    argv = ["simulate", "--model", "lst", "--samples", "3", "--config", str(tiny[0]), "--out", str(out)]
    refused(capsys, main(argv), "exists; pass --force")
    assert out.read_text() == "old"
    assert main(argv + ["--force"]) == 0
    assert xr.load_dataset(out).sizes["sample"] == 3 and [p.name for p in tmp_path.iterdir()] == ["x.nc"]


def test_second_writer_cannot_silently_win(tmp_path):
    path = tmp_path / "out.txt"
    with pytest.raises(OutputError, match="created by another run"):
        with atomic_path(path, overwrite=False) as tmp:
            tmp.write_text("mine")
            path.write_text("theirs")  # another run finished first
    assert path.read_text() == "theirs" and [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_stale_temporary_of_a_dead_writer_is_removed(tmp_path):
    from uqdrive.outputs import _HOST

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".x.nc.{_HOST}.{dead.pid}.abcd.tmp"
    live = tmp_path / f".x.nc.{_HOST}.{os.getpid()}.efgh.tmp"
    stale.write_text("half")
    live.write_text("being written")
    write_dataset(xr.Dataset({"a": ("t", np.arange(3.0))}), tmp_path / "x.nc")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([live.name, "x.nc"])


# -- fit diagnostics ----------------------------------------------------------------------------------
def test_fit_warnings_flag_bounds_and_unchanged_start():
    names, bounds = ("a", "b"), [(0.0, 1.0), (-5.0, 5.0)]
    assert fit_warnings([0.5, 1.0], [0.4, 2.0], bounds, names, True, "") == []
    at_bound = fit_warnings([1.0, 1.0], [0.4, 2.0], bounds, names, True, "")
    assert len(at_bound) == 1 and "a = 1 ended at the bound 1" in at_bound[0]
    assert "starting point unchanged" in fit_warnings([0.4, 2.0], [0.4, 2.0], bounds, names, True, "")[0]
    assert "without converging: ABNORMAL" in fit_warnings([0.5, 1.0], [0.4, 2.0], bounds, names, False, "ABNORMAL")[0]


def test_fit_at_a_bound_is_reported_not_converged(tiny, tmp_path, capsys):
    """States scaled down 1000-fold (millimetres read as metres): mu's spread pinned at zero and
    a misfit far beyond the sampling noise, which is the warning (with the units to check)."""
    small = tmp_path / "small.nc"
    _scaled(xr.load_dataset(tiny[1]), 1e-3).to_netcdf(small)
    assert main(["identify", str(small), "--config", str(tiny[0]), "--out", str(tmp_path / "est")]) == 0
    est = json.loads((tmp_path / "est" / "estimate.json").read_text())
    assert est["converged"] is False and any("times the noise" in w and "units of the states" in w for w in est["warnings"])
    assert "NOT CONVERGED" in capsys.readouterr().out and est["model_fits"] is False


# -- signals ------------------------------------------------------------------------------------------
def test_signal_exception_removes_the_temporary(tmp_path):
    with pytest.raises(Interrupted):
        with _signals_exit_cleanly():
            with atomic_path(tmp_path / "x.nc") as tmp:
                tmp.write_text("half")
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(5)
    assert list(tmp_path.iterdir()) == []
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL


def test_a_signal_whose_exception_code_called_from_c_swallowed_still_stops_the_output(tmp_path, monkeypatch):
    """The handler's exception raised inside a ctypes callback (numba writing its cache is one) is
    ignored there and the run goes on: the output is still not written, and no traceback is printed."""
    def callback():
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)  # the handler runs here and its exception ends the callback, not the run

    reported = []  # what would be printed as "Exception ignored ..."
    monkeypatch.setattr(sys, "unraisablehook", reported.append)
    with pytest.raises(Interrupted) as stopped:
        with _signals_exit_cleanly():
            with atomic_path(tmp_path / "x.nc") as tmp:
                tmp.write_text("whole")
                ctypes.CFUNCTYPE(None)(callback)()
    assert stopped.value.signum == signal.SIGTERM
    assert list(tmp_path.iterdir()) == [] and reported == []
    with _signals_exit_cleanly(), atomic_path(tmp_path / "y.nc") as tmp:  # the next run is not interrupted
        tmp.write_text("whole")
    assert (tmp_path / "y.nc").read_text() == "whole"


def test_a_signal_during_an_import_is_raised_once_the_import_has_ended(tmp_path, monkeypatch):
    """An extension module interrupted in its initialisation prints the traceback itself and
    reports ImportError (numba's does), so a signal that arrives during an import is raised
    when the import has ended: the module is whole, and the run still stops."""
    (tmp_path / "slow_module.py").write_text(
        "import os, signal, time\n"
        "os.kill(os.getpid(), signal.SIGTERM)\n"
        "end = time.monotonic() + 0.2\n"
        "while time.monotonic() < end:\n"
        "    pass\n"
        "WHOLE = True\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "slow_module", raising=False)
    with pytest.raises(Interrupted) as stopped:
        with _signals_exit_cleanly():
            import slow_module  # noqa: F401
            time.sleep(5)  # the recheck raises here
    assert stopped.value.signum == signal.SIGTERM
    assert sys.modules["slow_module"].WHOLE
    assert signal.getsignal(signal.SIGALRM) == signal.SIG_DFL and signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)


def _compile_step(path):
    """A function, its code in the file ``path``, that receives SIGTERM and then works for 0.2 s
    before it records that it ended."""
    source = ("import os, signal, time\n"
              "def compile_step(done):\n"
              "    os.kill(os.getpid(), signal.SIGTERM)\n"
              "    end = time.monotonic() + 0.2\n"
              "    while time.monotonic() < end:\n"
              "        pass\n"
              "    done.append(True)\n")
    space = {}
    exec(compile(source, str(path), "exec"), space)
    return space["compile_step"]


def test_a_signal_during_numbas_compiler_is_raised_once_it_has_returned(tmp_path, monkeypatch):
    """An exception raised inside numba's or llvmlite's code (a compilation, a load from numba's
    cache) leaves LLVM's state half-changed and the interpreter may crash at exit: a signal that
    lands there is raised once that code has returned. A function whose code sits in a file of a
    package folder taken for numba's stands in for the compiler; one in a folder that is only
    named numba (a project's own) is interrupted at once."""
    installed, own = tmp_path / "site-packages" / "numba", tmp_path / "project" / "numba"
    monkeypatch.setitem(interrupts._DEFERRING, "roots", (os.path.join(installed, ""),))
    done = []
    with pytest.raises(Interrupted) as stopped:
        with _signals_exit_cleanly():
            _compile_step(installed / "core" / "compiler.py")(done)
            time.sleep(5)  # the recheck raises here
    assert stopped.value.signum == signal.SIGTERM and done == [True]
    done = []
    with pytest.raises(Interrupted), _signals_exit_cleanly():
        _compile_step(own / "core" / "compiler.py")(done)
    assert done == []


def test_the_deferring_packages_are_found_by_their_installed_folders():
    """numba's and llvmlite's code is recognised by the folders they are installed in (without
    importing them), a package that is not installed has none."""
    numba_root, llvmlite_root = package_roots("numba"), package_roots("llvmlite")
    assert numba_root and llvmlite_root and set(numba_root + llvmlite_root) <= set(interrupts._DEFERRING["roots"])
    import numba.core.compiler

    assert numba.core.compiler.__file__.startswith(numba_root)
    assert package_roots("uqdrive_no_such_package") == ()


def test_a_signal_in_a_shielded_block_is_raised_when_the_block_ends(tmp_path, monkeypatch):
    """netCDF4's writer and reader hold locks that an exception raised between taking one and its
    ``try`` would leave taken (the close then waits forever): a signal there is raised when the
    read or write has ended, and the output is still not written."""
    done = []
    with pytest.raises(Interrupted) as stopped:
        with _signals_exit_cleanly(), atomic_path(tmp_path / "x.nc") as tmp, shielded():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.05)
            done.append(tmp.write_text("whole"))
    assert stopped.value.signum == signal.SIGTERM and done == [5]
    assert list(tmp_path.iterdir()) == []
    real = xr.Dataset.to_netcdf

    def interrupted_write(self, *args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.05)
        done.append("written")
        return real(self, *args, **kwargs)

    monkeypatch.setattr(xr.Dataset, "to_netcdf", interrupted_write)
    with pytest.raises(Interrupted), _signals_exit_cleanly():
        write_dataset(xr.Dataset({"a": ("x", np.arange(3.0))}), tmp_path / "y.nc")
    assert done[-1] == "written" and list(tmp_path.iterdir()) == []


def test_a_signal_that_surfaces_as_another_exception_still_exits_as_interrupted(monkeypatch, capsys):
    """A signal arriving while an extension module is imported comes out as that import's
    ImportError (numba's, imported at first use, does this): the run still ends as interrupted,
    128 + N and one line, while the same error without a signal is not hidden."""
    cli = sys.modules["uqdrive.cli.main"]  # the package's `main` attribute is the function

    def run(args, signalled=True):
        try:
            if signalled:
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(5)  # the handler's exception ends the sleep
        except Interrupted as exc:
            raise ImportError("numba._devicearray failed to import") from exc
        raise ImportError("numba._devicearray failed to import")

    parser = cli.build_parser()
    monkeypatch.setattr(parser, "parse_args", lambda argv: type("Args", (), {"run": staticmethod(run)})())
    monkeypatch.setattr(cli, "build_parser", lambda: parser)
    assert main(["config"]) == 128 + signal.SIGTERM
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "interrupted by SIGTERM" in err
    monkeypatch.setattr(parser, "parse_args", lambda argv: type("Args", (), {"run": staticmethod(lambda a: run(a, False))})())
    with pytest.raises(ImportError):
        main(["config"])


def _catches(pid: int, signum: int) -> bool:
    status = Path(f"/proc/{pid}/status").read_text()
    mask = int(next(line.split()[1] for line in status.splitlines() if line.startswith("SigCgt:")), 16)
    return bool(mask >> (signum - 1) & 1)


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc to see when the handler is installed")
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_signal_during_a_run_exits_cleanly(tiny, tmp_path, signum):
    """A run killed by SIGTERM (or Ctrl-C) exits with 128 + N and one line, and leaves nothing."""
    out = tmp_path / "run"
    out.mkdir()
    argv = ["simulate", "--model", "nlst", "--samples", "4000", "--config", str(REPO / "config" / "test.yaml"), "--out", str(out / "x.nc")]
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from uqdrive.cli import main; sys.exit(main(sys.argv[1:]))", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 30
    while not _catches(proc.pid, signal.SIGTERM):
        assert proc.poll() is None and time.monotonic() < deadline, "the CLI never installed its handler"
        time.sleep(0.01)
    time.sleep(0.3)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum, err
    assert err.count("\n") == 1 and f"interrupted by {signal.Signals(signum).name}" in err
    assert list(out.iterdir()) == []


def test_cost_flag_reads_the_registry(monkeypatch):
    """--cost accepts what uqdrive.inference.identify.COSTS holds, a registry entry added later
    included (docs/maintainer.md "Extending uqdrive"), and refuses anything else with the known names."""
    import argparse

    from uqdrive.cli.validation import registry_choice
    from uqdrive.inference import identify

    parse = registry_choice("--cost", "uqdrive.inference.identify", "COSTS")
    assert parse("INP") == "inp"
    with pytest.raises(argparse.ArgumentTypeError, match="choose one of std, inp, dst"):
        parse("flat")
    monkeypatch.setitem(identify.COSTS, "flat", identify.COSTS["std"])
    assert parse("flat") == "flat"
