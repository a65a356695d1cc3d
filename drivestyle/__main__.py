"""``python -m drivestyle <command>``: the same as the installed ``drivestyle`` command."""

from drivestyle.scripts import main

main()
