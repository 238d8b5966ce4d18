"""The README's library example runs as printed and lands near the config's distributions."""

import os
import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_example_runs(capsys, tmp_path, monkeypatch):
    block = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    monkeypatch.chdir(tmp_path)  # the example writes fit.png
    namespace = {}
    exec(compile(block, "README.md", "exec"), namespace)
    est = namespace["est"]
    # 200 realisations: the mu mean's standard error is 0.2 / sqrt(200) = 0.014; 4 SE
    assert abs(est.mu[0] - 1.0) < 0.06 and abs(est.l_f[0] - 1.55) < 0.06
    assert np.all(np.isfinite(est.mu + est.l_f + est.F_w_mean))
    out = capsys.readouterr().out
    assert out.splitlines()[0] == est.summary() and "mu N(" in out
    assert os.path.getsize(tmp_path / "fit.png") > 0


def test_readme_types_no_measured_time():
    """Measured times live in committed records that docs/benchmarks.md renders; a time typed
    into the README ("24 min 54 s", "5 min 56 s") drifts from them."""
    typed = re.findall(r"\b\d+ min \d+ s\b|\b\d+(?:\.\d+)? (?:minutes|min|CPU-s(?:econds)?) (?:measured|on an idle)", README.read_text())
    assert not typed, f"README.md types measured times {typed}: point to docs/benchmarks.md instead"
