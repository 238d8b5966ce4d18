"""MATLAB ``.mat`` recordings of one run: the file's variables read as a tree (v4-v7 through
scipy, v7.3 HDF5 through hdf5storage) and the signals it holds, each with its time axis and unit.

A MAT file has no one layout for a logged run. The layouts read here, wherever they sit in the
file's variables and structs:

* **Vectors beside a time vector**: ``YawRate``, ``data.LatAcc`` (a struct's field, named by its
  dotted path), a column of a matrix ``yout(:,2)`` (or a row, ``log(2,:)``); their time is the
  vector their map entry names (``time: t_YawRate``, one per sample rate), else the file's time
  vector (the map's ``time`` entry; without one a vector named ``time``, ``t`` or Simulink's
  ``tout``), in the map's time unit.
* **A signal with its own time**: a struct holding ``time`` and ``values`` or ``data`` (any case;
  an exported timeseries), named by its path, optionally with ``unit`` or ``units``.
* **Simulink's structure with time**: ``time`` and ``signals``, each signal named by its
  ``label`` or ``blockName`` (or its path ``s.signals(2)``), the columns of a wide one ``(:,j)``.
* **dSPACE ControlDesk recorder files**: a struct with ``X`` (time axes, ``Data``) and ``Y``
  (signals with ``Name``, ``Data``, optionally ``Unit``, ``XIndex`` or ``Raster``); a signal is
  found by its whole ``Name`` (``Model Root/Sensors/"YawRate"/Out1``), the quoted part
  (``YawRate``) or the last part of the path.

A signal's own time axis is in seconds. Names are matched exactly, then ignoring case; a name
that more than one signal carries is refused, naming where each lies.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io import DataError

__all__ = ["MatSignal", "read_mat_tree", "mat_signals", "find_signal", "DEFAULT_TIME_NAMES"]

#: Names of the file's time vector when the channel map names none (Simulink logs ``tout``).
DEFAULT_TIME_NAMES = ("time", "t", "tout")
_VALUE_KEYS = ("values", "data")
_NAME_KEYS = ("name", "label", "blockname")
_UNIT_KEYS = ("unit", "units")


@dataclass(frozen=True)
class MatSignal:
    """One signal of a MAT file.

    Attributes
    ----------
    path : str
        Where it lies, in MATLAB's syntax (``run.Y(3)``, ``yout(:,2)``).
    names : tuple of str
        The names a channel map may give it: its path, then the name it carries.
    values : ndarray, shape (k,)
        Its samples (float).
    time : ndarray, shape (k,), or None
        Its own time axis (s), or None: the file's time vector times it.
    unit : str
        The unit the file states for it (``""`` where it states none).
    """

    path: str
    names: tuple
    values: np.ndarray
    time: np.ndarray | None
    unit: str


def _is_v73(path: Path) -> bool:
    with open(path, "rb") as f:
        return f.read(128).startswith(b"MATLAB 7.3")


def _plain(node):
    """hdf5storage's nested arrays as scipy's ``simplify_cells`` gives them: structs as dicts,
    struct and cell arrays as lists, character arrays as str, numbers as squeezed arrays."""
    if isinstance(node, np.ndarray):
        if node.dtype.names:
            items = [{name: _plain(rec[name]) for name in node.dtype.names} for rec in node.reshape(-1)]
            return items[0] if len(items) == 1 else items
        if node.dtype.kind in "US":
            return "".join(str(s) for s in node.reshape(-1))
        if node.dtype.kind == "O":
            items = [_plain(x) for x in node.reshape(-1)]
            return items[0] if len(items) == 1 else items
        return np.squeeze(node)
    if isinstance(node, dict):
        return {k: _plain(v) for k, v in node.items()}
    return node


def read_mat_tree(path: Path) -> dict:
    """The variables of the MAT file ``path``: name -> dict (struct), list (struct or cell
    array), ndarray (numbers) or str (characters), as ``scipy.io.loadmat(simplify_cells=True)``
    gives them; a MATLAB object (timeseries, timetable) is left as the reader's opaque value.

    Raises
    ------
    uqdrive.io.DataError
        If the file is no MAT file either reader opens.
    """
    source = str(path)
    try:
        if _is_v73(path):
            import hdf5storage  # v7.3 (HDF5): only for these files

            return {str(k): _plain(v) for k, v in hdf5storage.loadmat(str(path)).items()}
        from scipy.io import loadmat

        tree = loadmat(path, simplify_cells=True, mat_dtype=False)
    except DataError:
        raise
    except Exception as exc:  # both readers raise many kinds for a file that is not MAT
        raise DataError(f"{source}: not a readable MAT file ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
                        "save the run with MATLAB's save (v7 or v7.3), or export it as MDF4 or CSV") from None
    return {k: v for k, v in tree.items() if not k.startswith("__")}


def _keys(node: dict) -> dict:
    return {str(k).casefold(): k for k in node}


def _vector(a) -> np.ndarray | None:
    """``a`` as a float vector (k,), k >= 2, or None where it is none."""
    if isinstance(a, (list, tuple)) and a and all(isinstance(x, (int, float, np.number)) for x in a):
        a = np.asarray(a)
    if not isinstance(a, np.ndarray) or a.dtype.kind not in "fiub":
        return None
    a = np.squeeze(a)
    return a.astype(float) if a.ndim == 1 and a.size >= 2 else None


def _text(node: dict, keys: tuple) -> str:
    lower = _keys(node)
    for key in keys:
        value = node.get(lower.get(key, ""))
        if isinstance(value, str) and value.strip():
            return value.strip()
    return ""


def _aliases(name: str) -> tuple:
    """A carried name and its short forms: dSPACE's ``Root/Sub/"YawRate"/Out1`` gives the quoted
    ``YawRate``; a block path its last part (none of an empty name)."""
    if not name:
        return ()
    out = [name]
    quoted = re.findall(r'"([^"]+)"', name)
    if quoted:
        out.append(quoted[-1])
    if "/" in name:
        out.append(name.rstrip("/").rsplit("/", 1)[-1])
    return tuple(dict.fromkeys(out))


def _columns(path: str, a: np.ndarray, time, unit: str, names: tuple, out: list) -> None:
    """A numeric array's signals: a vector whole, a matrix by its columns (time down the longer axis)."""
    vector = _vector(a)
    if vector is not None:
        out.append(MatSignal(path, tuple(dict.fromkeys((path, *names))), vector, time, unit))
        return
    if not isinstance(a, np.ndarray) or a.dtype.kind not in "fiub" or np.squeeze(a).ndim != 2:
        return
    a = np.squeeze(a)
    by_column = a.shape[0] >= a.shape[1]
    for j in range(a.shape[1] if by_column else a.shape[0]):
        index = f"(:,{j + 1})" if by_column else f"({j + 1},:)"
        column = (a[:, j] if by_column else a[j]).astype(float)
        out.append(MatSignal(path + index, tuple(dict.fromkeys((path + index, *(n + index for n in names)))), column, time, unit))


def _as_list(node) -> list:
    return node if isinstance(node, list) else [node]


def _dspace(node: dict, path: str, out: list) -> None:
    lower = _keys(node)
    axes = [x for x in _as_list(node[lower["x"]]) if isinstance(x, dict)]
    for k, y in enumerate(_as_list(node[lower["y"]])):
        if not isinstance(y, dict):
            continue
        keys = _keys(y)
        data = y.get(keys.get("data", ""))
        if data is None:
            continue
        index = y.get(keys.get("xindex", ""))
        numeric = isinstance(index, (int, float, np.number, np.ndarray)) and np.asarray(index).dtype.kind in "fiub"
        index = float(np.ravel(index)[0]) if numeric and np.size(index) == 1 else 0.0
        raster = _text(y, ("raster",))
        by_raster = [x for x in axes if raster and _text(x, ("raster",)) == raster]
        if index in range(1, len(axes) + 1):
            axis = axes[int(index) - 1]
        else:
            axis = by_raster[0] if by_raster else (axes[0] if len(axes) == 1 else None)
        time = None if axis is None else _vector(axis.get(_keys(axis).get("data", "")))
        _columns(f"{path}.Y({k + 1})", data, time, _text(y, _UNIT_KEYS), _aliases(_text(y, _NAME_KEYS)), out)


def _walk(node, path: str, out: list) -> None:
    if isinstance(node, dict):
        lower = _keys(node)
        if "x" in lower and "y" in lower and any(isinstance(y, dict) for y in _as_list(node[lower["y"]])):
            _dspace(node, path, out)
            return
        time = _vector(node.get(lower.get("time", "")))
        if time is not None and "signals" in lower:  # Simulink's structure with time
            for k, signal in enumerate(_as_list(node[lower["signals"]])):
                if isinstance(signal, dict) and "values" in _keys(signal):
                    names = tuple(dict.fromkeys(_aliases(_text(signal, ("label",))) + _aliases(_text(signal, ("blockname",)))))
                    _columns(f"{path}.signals({k + 1})", signal[_keys(signal)["values"]], time, _text(signal, _UNIT_KEYS), names, out)
            return
        values = next((node[lower[k]] for k in _VALUE_KEYS if k in lower), None)
        if values is not None:  # one signal: an exported timeseries, a named record
            _columns(path, values, time, _text(node, _UNIT_KEYS), (*_aliases(_text(node, _NAME_KEYS)), path.rsplit(".", 1)[-1]), out)
            return
        for key, child in node.items():
            _walk(child, f"{path}.{key}" if path else str(key), out)
    elif isinstance(node, list):
        for k, child in enumerate(node):
            _walk(child, f"{path}({k + 1})", out)
    elif isinstance(node, np.ndarray):
        _columns(path, node, None, "", (path.rsplit(".", 1)[-1],), out)


def mat_signals(tree: dict) -> list[MatSignal]:
    """Every signal of a MAT file's variables (:func:`read_mat_tree`), in the layouts the module names."""
    out: list[MatSignal] = []
    for name, node in tree.items():
        _walk(node, str(name), out)
    return out


def find_signal(signals: list[MatSignal], channel: str, source: str, what: str) -> MatSignal:
    """The one signal a channel map's ``channel`` names: by path or carried name, exactly, else ignoring case.

    Parameters
    ----------
    signals : list of MatSignal
        The file's signals.
    channel : str
        The name in the channel map.
    source, what : str
        The file, and what the channel is mapped to, for the messages.

    Raises
    ------
    uqdrive.io.DataError
        If no signal or more than one carries the name.
    """
    for same in (lambda n: n == channel, lambda n: n.casefold() == channel.casefold()):
        by_path = [s for s in signals if same(s.path)]
        found = by_path or [s for s in signals if any(same(n) for n in s.names)]
        if len(found) == 1:
            return found[0]
        if found:
            raise DataError(f"{source}: channel '{channel}' ({what}) names {len(found)} signals ("
                            f"{', '.join(s.path for s in found[:4])}); give the one meant by its path in the channel map")
    held = ", ".join(s.path for s in signals[:8]) + (f", ... ({len(signals)} in all)" if len(signals) > 8 else "")
    raise DataError(f"{source}: channel '{channel}' ({what}) is not in the file (it holds {held or 'no numeric signal'}); "
                    "fix the name in the channel map or record that channel")
