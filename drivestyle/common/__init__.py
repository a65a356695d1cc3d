"""Infrastructure shared by every layer: atomic result files, the process pool, CLI helpers.

Nothing here knows about vehicles: :mod:`~drivestyle.common.io` writes files and output
folders atomically (the rules of an output's path in :mod:`~drivestyle.common.output_paths`,
its one writer in :mod:`~drivestyle.common.output_lock`), :mod:`~drivestyle.common.parallel`
runs work in processes that Ctrl-C stops at once, :mod:`~drivestyle.common.cli` gives every
command one-line errors.
"""
