"""``python -m armtree.cli``: the ``armtree`` command, Ctrl-C held from the first import."""

import sys

from armtree.cli.console import armtree

sys.exit(armtree())
