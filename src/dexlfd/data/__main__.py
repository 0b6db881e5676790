"""``python -m dexlfd.data [NAME]``: where the packaged samples are on disk.

Without a name, one line per sample (its path, then its licence file); with a
name, only that sample's path, for the shell: ``dexlfd teach "$(python -m
dexlfd.data lfo_place_can.webm)" -o taught/``.
"""

from __future__ import annotations

import sys

from dexlfd.data import SAMPLE_FILES, sample_path
from dexlfd.errors import InvalidInput


def main(argv: list[str] | None = None) -> int:
    """Print the sample paths (or one); 1 with a one-line error for an unknown name."""
    args = sys.argv[1:] if argv is None else argv
    try:
        if args:
            for name in args:
                sys.stdout.write(f"{sample_path(name)}\n")
        else:
            for name, licence in SAMPLE_FILES.items():
                path = sample_path(name)
                sys.stdout.write(f"{path}  (licence: {path.parent / licence})\n")
    except InvalidInput as exc:
        sys.stderr.write(f"error: {exc}\n")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
