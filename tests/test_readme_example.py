"""The README's library example runs as printed and lands near the config's distributions."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_example_runs(capsys):
    block = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    namespace = {}
    exec(compile(block, "README.md", "exec"), namespace)
    est = namespace["est"]
    # 200 realisations: the mu mean's standard error is 0.2 / sqrt(200) = 0.014; 4 SE
    assert abs(est.theta_[0] - 1.0) < 0.06 and abs(est.theta_[2] - 1.55) < 0.06
    assert np.all(np.isfinite(est.theta_)) and "mu_mean" in capsys.readouterr().out
