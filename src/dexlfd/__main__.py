"""``python -m dexlfd``: the ``dexlfd`` command (:func:`dexlfd.cli.main`).

The process then ends without the interpreter's teardown when that is safe
(:func:`dexlfd._exit.exit_process`).
"""

from __future__ import annotations

from dexlfd._exit import exit_process
from dexlfd.cli import main

exit_process(main())
