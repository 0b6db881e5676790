"""A cached virtual environment for a tool whose dependencies clash with dexlfd's.

Simulators and consumers we test against (franky-sim, lerobot) pin packages that
cannot live beside ours (numpy 2, torch). Each gets its own environment, created
once under a cache folder and marked complete by a ``.installed`` file, so an
interrupted install is redone rather than trusted.
"""

from __future__ import annotations

import logging
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from dexlfd.errors import DexlfdError

__all__ = ["PIP_INSTALL", "ensure_venv"]

logger = logging.getLogger(__name__)

# few retries: without a package index, fail in seconds and let the tests skip
PIP_INSTALL = ("-m", "pip", "install", "-q", "--disable-pip-version-check",
               "--retries", "1", "--timeout", "30")  # fmt: skip


def ensure_venv(
    python: Path,
    installs: Sequence[Sequence[str]],
    *,
    what: str,
    error: type[DexlfdError],
    base_python: str | None = None,
    timeout_s: float = 1200.0,
) -> Path:
    """Create (once) the environment of ``python`` and run ``pip install`` steps in it.

    Parameters
    ----------
    python : Path
        The environment's interpreter, ``ENV/bin/python``.
    installs : sequence of sequences of str
        Arguments of each ``pip install`` step, in order (requirements and options).
    what : str
        Name for the log and the error message (e.g. ``"simulator"``).
    error : type of DexlfdError
        Raised when a step fails.
    base_python : str or None
        Interpreter that creates the environment; default: this one's base.
    timeout_s : float
        Limit for each step [s].

    Raises
    ------
    error
        If ``venv`` or a ``pip install`` fails (e.g. no package index reachable); the
        message ends with pip's last output lines.
    """
    env_dir = python.parent.parent
    stamp = env_dir / ".installed"
    if stamp.is_file() and python.is_file():
        return python
    base = base_python or getattr(sys, "_base_executable", None) or sys.executable
    steps = [[base, "-m", "venv", "--clear", str(env_dir)]]
    steps += [[str(python), *PIP_INSTALL, *args] for args in installs]
    logger.info("creating the %s environment %s", what, env_dir)
    t0 = time.perf_counter()
    for cmd in steps:
        try:
            out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise error(f"cannot create {env_dir}: {exc}") from exc
        if out.returncode != 0:
            tail = "\n".join((out.stdout + out.stderr).strip().splitlines()[-5:])
            raise error(
                f"cannot create the {what} environment {env_dir} "
                f"({' '.join(cmd[-2:])} exited {out.returncode}):\n{tail}"
            )
    stamp.write_text("\n".join(" ".join(a) for a in installs) + "\n")
    logger.info("%s environment ready in %.1f s", what, time.perf_counter() - t0)
    return python
