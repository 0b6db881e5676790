"""Subcommands of the ``dexlfd`` CLI: argument parsing and file I/O only, no math."""
