"""``python -m mrnea``: the same as the ``mrnea`` command (its entry point, mrnea_launcher)."""

from mrnea_launcher import main

main()
