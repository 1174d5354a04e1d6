"""What the benchmarks that compare settings in alternating child processes share
(``fast_math.py``, ``skin.py``): the saved large-N state they start from, each child's one
result line, and the check that a setting leaves the bits alone. Imported by the scripts
beside it (``python benchmarks/NAME.py`` puts this folder on the path)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def saved_state(path: str, n: int, warm: int) -> None:
    """Write the paper shelf of ``n`` icebergs (tilt 0.05), ``warm`` steps on in the
    parallel form, to ``path`` with ``profile_stages.py --state`` unless it is there."""
    if Path(path).exists():
        return
    script = str(Path(__file__).with_name("profile_stages.py"))
    cmd = [sys.executable, script, "--n", str(n), "--warm", str(warm), "--steps", "0", "--islands", "off", "--state", path]
    subprocess.run(cmd, check=True)


def state_difference(state: dict, reference: str | Path) -> float:
    """Largest difference of ``state`` (``Model.state()``) from the state in ``reference``;
    the first child to ask writes its own there (and gets 0)."""
    import numpy as np

    ref = Path(reference)
    if not ref.exists():
        np.savez(ref, **state)
        return 0.0
    r = np.load(ref)
    return max(float(np.max(np.abs(state[k] - r[k]))) for k in state)


def report(result: dict) -> None:
    """A child's result, as the one line :func:`run_child` reads."""
    print("RESULT " + json.dumps(result), flush=True)


def run_child(cmd: list[str]) -> dict:
    """Run a child process and return what it :func:`report`-ed."""
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(next(line for line in out.splitlines() if line.startswith("RESULT "))[len("RESULT ") :])
