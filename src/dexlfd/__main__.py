"""``python -m dexlfd``: the ``dexlfd`` command (:func:`dexlfd.cli.main`)."""

from __future__ import annotations

import sys

from dexlfd.cli import main

sys.exit(main())
