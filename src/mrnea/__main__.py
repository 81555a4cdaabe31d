"""``python -m mrnea``: the same as the ``mrnea`` command."""

from mrnea.cli import main

main()
