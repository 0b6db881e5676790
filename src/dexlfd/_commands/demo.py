"""``dexlfd demo``: the whole pipeline on bundled (synthetic) data, no camera."""

from __future__ import annotations

import argparse
import logging
from typing import Any

from dexlfd._commands._common import ensure_output_dir

logger = logging.getLogger(__name__)


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name, help="run the whole pipeline on bundled data and write a report"
    )
    p.add_argument(
        "-o", "--output", default="dexlfd-demo", help="output folder (default: %(default)s)"
    )
    p.add_argument("--seed", type=int, default=0)
    return p


def run(args: argparse.Namespace) -> int:
    """Run the demo pipeline."""
    from dexlfd.experiments.demo import DemoConfig, run_demo

    out = ensure_output_dir(args.output)
    result = run_demo(DemoConfig(seed=args.seed), out)
    logger.info("demo finished: %s", result.summary)
    return 0
