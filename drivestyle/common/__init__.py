"""Infrastructure shared by every layer: atomic result files, the process pool, CLI helpers.

Nothing here knows about vehicles: :mod:`~drivestyle.common.io` writes files and output
folders atomically, :mod:`~drivestyle.common.parallel` runs work in processes that Ctrl-C
stops at once, :mod:`~drivestyle.common.cli` gives every command one-line errors.
"""
