"""``python -m tetlap ...`` is the ``tetlap`` command."""

from .cli import main

raise SystemExit(main())
